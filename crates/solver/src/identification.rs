//! 21-term identification from planar grid-encoder sessions (patent CN101982726).
//!
//! The joint method solves one least-squares problem over every run and mounting: the
//! observation model of [`crate::design`] (the contract's linearised kinematics with the
//! Abbe arms, plus a plate rotation per mounting and two zero offsets per run), reduced
//! by streaming Householder QR and solved by SVD of the column-scaled triangular factor
//! ([`crate::lsq`]) — never by normal equations. The rank analysis of
//! [`crate::observability`] says which terms the plan determines; a term it cannot
//! determine is reported without numbers (`identifiable: false`) with the terms it is
//! confounded with, and [`advice`] recomputes the rank with candidate extra tests to say
//! which one resolves them.
//!
//! Layout: [`joint`] and [`stepwise`] are the two estimation methods; each returns an
//! [`Estimate`] (the fit over the full model's columns, its identifiability, advice and
//! its own wording), and [`report`] builds the one result document from it for both.
//!
//! Reported values follow the contract's reporting conventions: values on a grid over
//! the measured travel (every 5 mm, always including 0); straightness as deviation from
//! its least-squares line over the travel (continuous, uniform weight: Gauss–Legendre
//! quadrature of the polynomial); squareness as the angle between the least-squares axis
//! lines (EC0Y = γ − s_XY − s_YX, EB0Z = β + s_XZ + s_ZX, EA0Z = α − s_YZ − s_ZY). Each
//! value's standard uncertainty is √(wᵀ Σ w) for its functional w and the parameter
//! covariance Σ = σ̂² (RᵀR)⁺ taken from the SVD.

use crate::basis::BasisKind;
use crate::design::{ErrorModel, Fit, measured_travel};
use crate::error::SolverError;
use crate::misfit::ModelCheck;
use crate::noise::session_floor;
use crate::observability::Identifiability;
use crate::session::Session;
use crate::uncertainty::Conditions;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

pub mod joint;
pub mod report;
pub mod stepwise;

pub use joint::thin_session;
pub use report::{grid, ls_line_functionals, ls_line_weights};

/// The convention line every result document carries (see docs/conventions.md).
pub const CONVENTION: &str =
    "mtcal kinematics v1: tool-relative-to-workpiece, X primary, Y secondary";

/// Which estimator to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// One least-squares problem over all runs, nuisance parameters estimated jointly.
    #[default]
    Joint,
    /// The seed patent's two steps: lines → 12 translational terms, circles → 9 angular.
    Stepwise,
}

/// Options of an identification.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct IdentifyOptions {
    pub method: Method,
    pub basis: BasisKind,
    /// Polynomial order N (default 3).
    pub order: usize,
    /// Spacing of the reported value grid, mm (default 5; the grid always includes 0).
    pub grid_step_mm: f64,
    /// Topology to use when the session does not declare one.
    pub topology: Option<crate::axis::Topology>,
}

impl Default for IdentifyOptions {
    fn default() -> Self {
        IdentifyOptions {
            method: Method::Joint,
            basis: BasisKind::Polynomial,
            order: 3,
            grid_step_mm: 5.0,
            topology: None,
        }
    }
}

/// Values of one of the 18 error functions on the reporting grid (results contract).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct TermReport {
    /// `um` or `urad`.
    pub unit: String,
    pub positions_mm: Vec<f64>,
    pub values: Vec<f64>,
    /// Standard uncertainty of each value.
    pub std: Vec<f64>,
    pub identifiable: bool,
    /// Terms this one cannot be separated from (when not identifiable).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub confounded_with: Vec<String>,
    /// Monomial coefficients c of the **model function** f(q) = Σ_{k≥1} c_k q^k (element
    /// k−1 ↔ q^k; µm/mm^k or µrad/mm^k), q the position on the term's axis in mm. f has
    /// no constant term (0 at q = 0). These are not the reported `values` for a
    /// straightness: those are f minus its least-squares line over the measured travel
    /// of its axis (the line belongs to the squareness). The one evaluation of the
    /// reported value from c, with its uncertainty from `coefficient_covariance`, is the
    /// comparison module's `term_value`, used by every consumer of a stored result.
    /// Empty when not identifiable.
    #[serde(default)]
    pub coefficients: Vec<f64>,
    /// Covariance Σ of `coefficients` (row-major, n × n, units² of the coefficients). A
    /// reported value is linear in c, v(q) = gᵀc with g_k = q^k, less the least-squares
    /// line of q^k over the measured travel for a straightness; its standard uncertainty
    /// is √(gᵀ Σ g). Empty when not identifiable.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub coefficient_covariance: Vec<Vec<f64>>,
}

/// One squareness value (results contract).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct SquarenessReport {
    pub value_urad: Option<f64>,
    pub std_urad: Option<f64>,
    pub identifiable: bool,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub confounded_with: Vec<String>,
    /// `ls_axis_lines` (the contract's reporting convention: the angle between the
    /// least-squares axis lines) or `model_constant` (the constant of u_Y / u_Z, when
    /// the straightness slopes that convention needs are not determined by the data).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reported_as: Option<String>,
}

/// A group of terms the data cannot separate, and how it is seen.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Confounded {
    pub terms: Vec<String>,
    pub seen_as: String,
}

/// Identifiability of the error model for the session's plan.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Observability {
    /// Number of error-model parameters (51 for the cubic model).
    pub parameters: usize,
    /// Rank of the error-parameter block after eliminating the nuisance parameters.
    pub rank: usize,
    /// Condition number of the (column-scaled) identifiable part.
    pub condition_number: f64,
    pub identifiable: Vec<String>,
    pub not_identifiable: Vec<String>,
    pub confounded: Vec<Confounded>,
    pub advice: Vec<String>,
}

/// Goodness of fit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct FitSummary {
    pub samples: usize,
    pub residual_rms_um: f64,
    /// The noise floor, estimated independently of the model from the flat
    /// high-frequency part of the reading spectrum ([`crate::noise`]).
    pub noise_estimate_um: Option<f64>,
    /// The check of the floor: noise from differences of repeated passes (larger when
    /// something does not repeat from pass to pass: vibration, drift).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise_pass_differences_um: Option<f64>,
}

/// Nuisance parameters estimated with the errors.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct MountingReport {
    /// In-plane rotation φ of the plate (+φ turns it from u toward v), `None` when the
    /// data cannot determine it.
    pub rotation_urad: Option<f64>,
    pub std_urad: Option<f64>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Nuisance {
    pub mountings: BTreeMap<String, MountingReport>,
    /// Number of runs (each with two zero offsets).
    pub runs: usize,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ModelInfo {
    pub basis: BasisKind,
    pub order: usize,
    /// Travel each axis covered in the session's line and circle runs, [min, max] mm, by
    /// axis letter: the terms are determined there and nowhere else (no figure of this
    /// result is evaluated outside it). Axes that did not move are absent.
    #[serde(default)]
    pub measured_travel_mm: BTreeMap<String, [f64; 2]>,
}

/// The identification result document (docs/results.md, "Identification result").
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct IdentificationResult {
    /// Always `identification`.
    pub kind: String,
    pub machine_id: String,
    pub measured_at: String,
    pub convention: String,
    pub method: Method,
    pub model: ModelInfo,
    /// The 18 functions, keyed by ISO 230-1 name.
    pub terms: BTreeMap<String, TermReport>,
    /// EC0Y, EB0Z, EA0Z.
    pub squareness: BTreeMap<String, SquarenessReport>,
    pub observability: Observability,
    pub fit: FitSummary,
    pub nuisance: Nuisance,
    /// Sentences stating the reporting conventions used (straightness, squareness,
    /// circle direction).
    pub reporting: Vec<String>,
    /// ISO 230-2 figures from the line passes and ISO 230-4 figures from the circle runs
    /// of the session (`crate::standards`).
    #[serde(default)]
    pub standards: crate::standards::Standards,
    /// Polar-plot data of every circle run: radial deviation measured and from the fitted
    /// model.
    #[serde(default)]
    pub circles: Vec<crate::standards::iso230_4::CirclePlot>,
    /// Residual RMS of the fit by file and test.
    #[serde(default)]
    pub residuals: Vec<crate::residuals::ResidualSummary>,
    /// The misfit gate ([`crate::misfit`]): whether the model explains this recording to
    /// noise level. A document of an earlier version has none; read it with
    /// [`IdentificationResult::model_check`], which works it out from `fit`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model_check: Option<ModelCheck>,
    /// What the session states about how the test was made (operator, instrument,
    /// temperature, …): the report's facts and the uncertainty budget's inputs.
    #[serde(default)]
    pub conditions: Conditions,
    /// The explained model ([`crate::explained::doc`]): present when this document's
    /// terms are those of the 21 terms fitted jointly with the physics a diagnosis found.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub explained: Option<crate::explained::doc::ExplainedModel>,
}

impl IdentificationResult {
    /// The misfit gate of this result, from its fit (the same as the stored
    /// `model_check` of a document of this version; an earlier one is gated too).
    pub fn model_check(&self) -> ModelCheck {
        // An explained model's gate is its own (decided on it, or what remains).
        match (&self.explained, &self.model_check) {
            (Some(_), Some(c)) => c.clone(),
            _ => ModelCheck::of(self.fit.residual_rms_um, self.fit.noise_estimate_um),
        }
    }
}

/// Identifies the 21 terms of the machine measured in `session`.
///
/// Topology: the session's, else `opts.topology`, else the default (workpiece [X, Y],
/// tool [Z]).
pub fn identify(
    session: &Session,
    opts: &IdentifyOptions,
) -> Result<IdentificationResult, SolverError> {
    let model = prepare(session, opts)?;
    // The noise floor is independent of the model: the joint method estimates it on a
    // second core while it fits (the stepwise method needs it first).
    let (floor, mut estimate) = match opts.method {
        Method::Joint => std::thread::scope(|s| {
            let floor = s.spawn(|| session_floor(session));
            let estimate = joint::estimate(session, &model);
            let floor = floor
                .join()
                .unwrap_or_else(|p| std::panic::resume_unwind(p));
            (floor, estimate)
        }),
        Method::Stepwise => {
            let floor = session_floor(session);
            let noise = floor.map(|f| report::round(f.sigma_um));
            (floor, stepwise::estimate(session, &model, noise)?)
        }
    };
    let noise = floor.map(|f| report::round(f.sigma_um));
    if let Some(f) = &floor {
        estimate.reporting.push(f.note());
    }
    let mut result = report::report(session, &model, opts, opts.method, noise, &estimate);
    result.fit.noise_pass_differences_um =
        floor.and_then(|f| f.pass_differences_um.map(report::round));
    result.model_check = Some(result.model_check());
    Ok(result)
}

/// What an estimation method hands to [`report::report`].
pub struct Estimate {
    /// The fit over the full model's columns [plate rotations | error parameters].
    pub fit: Fit,
    pub ident: Identifiability,
    pub advice: Vec<String>,
    /// The method's wording of how a confounded group is seen (`None`: the joint
    /// wording, one fit over every run).
    pub seen_as: Option<fn(&[String]) -> String>,
    /// Sentences appended to the document's `reporting`.
    pub reporting: Vec<String>,
}

/// Checks the session and builds the error model over its measured travel.
pub fn prepare(session: &Session, opts: &IdentifyOptions) -> Result<ErrorModel, SolverError> {
    if session.planes.is_empty() || session.sample_count() == 0 {
        return Err(SolverError::InvalidInput(
            "the session has no samples".into(),
        ));
    }
    if opts.order == 0 || opts.order > MAX_ORDER {
        return Err(SolverError::InvalidInput(format!(
            "polynomial order must be 1..={MAX_ORDER}, got {}",
            opts.order
        )));
    }
    if opts.grid_step_mm.is_nan() || opts.grid_step_mm <= 0.0 {
        return Err(SolverError::InvalidInput(
            "grid step must be positive".into(),
        ));
    }
    let topology = session
        .topology
        .clone()
        .or_else(|| opts.topology.clone())
        .unwrap_or_default();
    topology.validate().map_err(SolverError::InvalidInput)?;
    let travel = measured_travel(session);
    if travel.iter().all(Option::is_none) {
        return Err(SolverError::Degenerate(
            "no axis moved in the session".into(),
        ));
    }
    Ok(ErrorModel::new(topology, opts.basis, opts.order, travel))
}

/// Highest polynomial order accepted.
pub const MAX_ORDER: usize = 9;
