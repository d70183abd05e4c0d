//! The exciters: what sets a string in motion.
//!
//! - [`hammer`]: a piano hammer or a dulcimer's, santoor's or cimbalom's mallet,
//!   a point mass meeting the string through felt (F = K C^alpha) or a spring
//!   (alpha = 1): one physics for both, so a mallet is a light hammer. Its
//!   contact law and implicit solve ([`hammer::contact`]) and how finely a strike
//!   is sub-stepped ([`hammer::substeps`]) sit beside it.
//! - [`tangent`]: the clavichord's brass blade, which strikes and stays, an
//!   imposed motion of the string's end.
//! - [`pluck`]: the harpsichord's plectrum, a released triangle.

pub mod hammer;
pub mod pluck;
pub mod tangent;
