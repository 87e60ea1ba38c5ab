//! 21-term identification from planar grid-encoder sessions (patent CN101982726), as one
//! joint least-squares problem over every run and mounting (module docs are completed
//! with the implementation).

use crate::basis::BasisKind;
use crate::error::SolverError;
use crate::session::Session;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// The convention line every result document carries (see docs/conventions.md).
pub const CONVENTION: &str =
    "mtcal kinematics v1: tool-relative-to-workpiece, X primary, Y secondary";

/// Which estimator to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
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
    /// Monomial coefficients, element i ↔ q^(i+1) (µm/mm^k or µrad/mm^k), as reported
    /// (straightness: after removing its least-squares line). Empty when not identifiable.
    #[serde(default)]
    pub coefficients: Vec<f64>,
}

/// One squareness value (results contract).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SquarenessReport {
    pub value_urad: Option<f64>,
    pub std_urad: Option<f64>,
    pub identifiable: bool,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub confounded_with: Vec<String>,
}

/// A group of terms the data cannot separate, and how it is seen.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Confounded {
    pub terms: Vec<String>,
    pub seen_as: String,
}

/// Identifiability of the error model for the session's plan.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
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
pub struct FitSummary {
    pub samples: usize,
    pub residual_rms_um: f64,
    /// Noise estimated independently of the model, from repeated passes.
    pub noise_estimate_um: Option<f64>,
}

/// Nuisance parameters estimated with the errors.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MountingReport {
    pub rotation_urad: f64,
    pub std_urad: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Nuisance {
    pub mountings: BTreeMap<String, MountingReport>,
    /// Number of runs (each with two zero offsets).
    pub runs: usize,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelInfo {
    pub basis: BasisKind,
    pub order: usize,
}

/// The identification result document (shared/spec/results.md, "Identification result").
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
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
}

impl IdentificationResult {
    /// Value of an identified term at `q_mm` from its coefficients (µm or µrad);
    /// `None` when the term is unknown or not identifiable.
    pub fn term_value_at(&self, name: &str, q_mm: f64) -> Option<f64> {
        let t = self.terms.get(name)?;
        if !t.identifiable || t.coefficients.is_empty() {
            return None;
        }
        let mut acc = 0.0;
        for &c in t.coefficients.iter().rev() {
            acc = acc * q_mm + c;
        }
        Some(acc * q_mm)
    }
}

/// Identifies the 21 terms of the machine measured in `session`.
pub fn identify(
    session: &Session,
    opts: &IdentifyOptions,
) -> Result<IdentificationResult, SolverError> {
    let _ = (session, opts);
    Err(SolverError::InvalidInput(
        "identification is being implemented".into(),
    ))
}
