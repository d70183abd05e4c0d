//! Where the strings' force goes: the bridge, and what it drives.
//!
//! Today the bridge is rigid and resistive: a key's bridge force is the sound,
//! placed in the stereo field by the key's pan. This is the seam the
//! instrument's body joins at: a key hands its force to a [`Bridge`] rather than
//! to the mix.
