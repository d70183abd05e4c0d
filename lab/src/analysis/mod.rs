//! Measuring what the engine produces: the contract's low-pass, spectra,
//! partial levels and partial tracking. Shared by the lab, the tests and the charts.

pub mod filter;
pub mod spectrum;
