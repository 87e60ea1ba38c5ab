//! Least-squares plane by orthogonal distance (see the [module docs](super) for the maths).

use super::principal;
use crate::error::SolverError;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// A fitted plane.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlaneFit {
    /// A point of the plane (the centroid), mm.
    pub point: Vector3<f64>,
    /// Unit normal (sign: arbitrary, the caller orients it).
    pub normal: Vector3<f64>,
    /// In-plane principal directions u₁, u₂ (largest spread first).
    pub in_plane: [Vector3<f64>; 2],
    /// Signed distances hᵢ = (pᵢ − p̄)·n, mm, in input order.
    pub residuals: Vec<f64>,
    /// RMS of the residuals, mm.
    pub rms: f64,
    /// σ = √(Σhᵢ² / (N − 3)), mm (NaN for N = 3).
    pub sigma: f64,
    /// Standard uncertainty of the normal's tilt towards u₁ and u₂, rad.
    pub normal_std_rad: [f64; 2],
    /// Singular values s₁ ≥ s₂ ≥ s₃ of the centred cloud, mm.
    pub singular_values: [f64; 3],
    /// s₁ / s₂: large means nearly collinear points (normal poorly determined).
    pub conditioning: f64,
}

/// Fits a plane to `points` (at least 3, not all on one line).
pub fn fit_plane(points: &[Vector3<f64>]) -> Result<PlaneFit, SolverError> {
    let pr = principal(points, 3, "plane")?;
    if pr.sv[1] <= 1e-12 * pr.sv[0].max(1e-300) {
        return Err(SolverError::Degenerate(
            "plane fit: the points lie on one line".into(),
        ));
    }
    let normal = pr.dirs[2];
    let residuals: Vec<f64> = points
        .iter()
        .map(|p| (p - pr.centroid).dot(&normal))
        .collect();
    let ss: f64 = residuals.iter().map(|h| h * h).sum();
    let n = points.len();
    let sigma = if n > 3 {
        (ss / (n - 3) as f64).sqrt()
    } else {
        f64::NAN
    };
    Ok(PlaneFit {
        point: pr.centroid,
        normal,
        in_plane: [pr.dirs[0], pr.dirs[1]],
        rms: (ss / n as f64).sqrt(),
        residuals,
        sigma,
        normal_std_rad: [sigma / pr.sv[0], sigma / pr.sv[1]],
        singular_values: pr.sv,
        conditioning: pr.sv[0] / pr.sv[1],
    })
}
