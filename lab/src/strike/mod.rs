//! Strike cases: `struck strike` as a library. A strike case (one string excited
//! once) is parsed and checked ([`case`]), simulated on the same
//! [`struck_engine::struck_string::StruckString`] the instrument plays, and measured
//! ([`mod@run`]): contacts at sub-step resolution, bridge-force level and partials.
//! [`sweep`] runs many hammer strikes of one string for the hammer design charts,
//! [`seed`] holds the seed's own experiments as cases, and [`film`] records a
//! strike's string shape for the animations.

pub mod case;
pub mod film;
pub mod run;
pub mod seed;
pub mod sweep;

pub use case::{CaseError, ExciterSpec, StrikeCase, parse_case};
pub use run::{LabRun, Metrics, Trace, run};
pub use sweep::{GridResult, HammerGrid, StrikeSummary, SweepError, UniversalScale, run_grid, strike_summary};
