//! Tolerances and the decision rule of conformity (ISO 14253-1), with the uncertainty of
//! an ISO/TR 230-9 budget, on the quantities ISO 230-1 and ISO 230-2 state limits for.
//!
//! **What is judged** ([`figures`]): an error function by its **range** (max − min) over
//! the travel the check measured (ISO 230-1: positioning and straightness deviations are
//! ranges, a straightness about its least-squares reference line, so no verdict depends
//! on the arbitrary zero of a function); a squareness by its magnitude; a figure of ISO
//! 230-2 (E, M, A, B, R, …) or ISO 230-4 (G, H, F, …) by its magnitude against its own
//! limit. A limit on an error function may be stated per length ([`TermLimit`]).
//!
//! **The rule**: a measured quantity y (a range, or |value|) with combined standard
//! uncertainty u_c (the budget of [`crate::uncertainty`]: instrument, thermal, setup and
//! the fit) against a limit L, with U = k·u_c, k = [`COVERAGE_K`] = 2:
//!
//! * **pass** when y + U ≤ L (conformance proven);
//! * **fail** when y − U > L (non-conformance proven);
//! * **undecided** otherwise (the interval straddles the limit);
//! * **not decided: model misfit** ([`Decision::Misfit`]) for a quantity of a fitted
//!   model that does not explain its recording ([`crate::misfit`]): no value of such a
//!   model is judged. The figures of the standards, taken from the readings directly,
//!   are still judged.
//!
//! The result's decision combines its items: fail when any fails, else not decided
//! (misfit) when any is, else undecided when any is, else pass. An item covering only
//! part of the machine's registered travel says which part ([`Assessment`]).
//!
//! [`Limits`] is a tolerance profile's content. Drift thresholds judge changes since a
//! baseline, pointwise ([`Figure`], [`drift_alerts`]).
//!
//! One concept a module: [`decision`] (the rule of ISO 14253-1 on one value or one
//! function), [`limits`] (a tolerance profile's content and the items' names),
//! [`verdict`] (a result's items judged against a profile) and [`drift`] (changes since
//! a baseline judged against the drift thresholds).

pub mod figures;

pub use figures::{Figures, Measure, Quantity, identification_figures};

mod decision;
mod drift;
mod limits;
mod verdict;

pub use decision::{COVERAGE_K, Decision, Figure, Point, RULE, combine, decide};
pub use drift::{changes, drift_alerts};
#[cfg(feature = "openapi")]
pub use limits::TermLimitSchema;
pub use limits::{Limits, MIN_PROPORTIONAL_UM, TermLimit, display_name, is_standard_figure};
pub use verdict::{Assessment, NotEvaluated, Verdict, VerdictItem, evaluate};
