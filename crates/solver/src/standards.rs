//! The figures of the machine-tool test standards, computed from measured data.
//!
//! * [`iso230_2`]: ISO 230-2 (positioning accuracy and repeatability of numerically
//!   controlled axes), from positioning runs.
//!
//! Every figure is in µm; formulas and readings are in `docs/standards.md`.

pub mod iso230_2;

pub use iso230_2::{Iso2302, iso230_2};
