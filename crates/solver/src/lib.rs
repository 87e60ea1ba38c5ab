//! # mtcal-solver
//!
//! The pure numerical core of mtcal: no IO, no async, no database. Every function
//! takes plain data (the types of [`session`] and [`datasets`]) and returns plain data
//! (serialisable result documents). Formats, storage, the job queue, HTTP and the CLI
//! are thin layers around this crate.
//!
//! Conventions follow `docs/conventions.md` (the kinematics contract): positions in mm,
//! translational errors in µm, angular errors in µrad, ISO 230-1 names, errors in the
//! tool-relative-to-workpiece sense.

pub mod axis;
pub mod datasets;
pub mod error;
pub mod kinematics;
pub mod names;
pub mod session;
pub mod terms;
pub mod text;
// The inputs and the contributions of an uncertainty budget (ISO/TR 230-9).
pub mod uncertainty;

// identification core.
pub mod basis;
pub mod design;
pub mod identification;
pub mod lsq;
pub mod misfit;
pub mod noise;
pub mod observability;
pub mod simulate;

// sensitivity (Cheng et al. 2012).
pub mod sensitivity;

// 5-axis cradle and geometric fits.
pub mod cradle;
pub mod fits;

// mismatch diagnosis.
pub mod diagnosis;
pub mod explained;

// Figures of the machine-tool test standards (ISO 230-2, ISO 230-4) and the residuals
// of a fit by file and test.
pub mod residuals;
pub mod standards;
// The check of a positioning-run file: its diagnosis and its ISO 230-2 figures together.
pub mod positioning_check;

// Tolerances and the decision rule of conformity.
pub mod tolerance;

// Result arithmetic: term values, differences and drift between checks.
pub mod comparison;

// Thermal drift model of drift logs (spindle history and structure temperatures).
pub mod thermal;

// The vector registers after faer's kernels (a speed matter only).
pub mod upper_state;

pub use axis::{Axis, Plane, Topology};
pub use error::SolverError;
