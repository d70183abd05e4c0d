//! Helpers for Struck's whole-program tests: finding and running the `struck`
//! binary, reading its outputs, and the reference cases shipped as test data.
