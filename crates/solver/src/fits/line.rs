//! Least-squares 3-D line by orthogonal distance (see the [module docs](super)).

use super::principal;
use crate::error::SolverError;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// A fitted line.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LineFit {
    /// A point of the line (the centroid), mm.
    pub point: Vector3<f64>,
    /// Unit direction (sign: arbitrary, the caller orients it).
    pub direction: Vector3<f64>,
    /// Perpendicular residual vectors, mm, in input order.
    pub residuals: Vec<Vector3<f64>>,
    /// Abscissae tᵢ = (pᵢ − p̄)·direction, mm.
    pub abscissae: Vec<f64>,
    /// RMS perpendicular distance, mm.
    pub rms: f64,
    /// σ per perpendicular coordinate, √(Σ|rᵢ|² / (2N − 4)), mm (NaN for N = 2).
    pub sigma: f64,
    /// Standard uncertainty of the direction's tilt towards the two perpendicular
    /// principal directions, rad.
    pub direction_std_rad: [f64; 2],
    /// Singular values s₁ ≥ s₂ ≥ s₃ of the centred cloud, mm.
    pub singular_values: [f64; 3],
    /// s₂ / s₁: 0 for a perfect line, near 1 when the direction is undetermined.
    pub conditioning: f64,
}

/// Fits a line to `points` (at least 2, not all equal).
pub fn fit_line(points: &[Vector3<f64>]) -> Result<LineFit, SolverError> {
    let pr = principal(points, 2, "line")?;
    if pr.sv[0] <= 0.0 {
        return Err(SolverError::Degenerate(
            "line fit: all points coincide".into(),
        ));
    }
    let d = pr.dirs[0];
    let abscissae: Vec<f64> = points.iter().map(|p| (p - pr.centroid).dot(&d)).collect();
    let residuals: Vec<Vector3<f64>> = points
        .iter()
        .zip(&abscissae)
        .map(|(p, t)| p - pr.centroid - d * *t)
        .collect();
    let ss: f64 = residuals.iter().map(|r| r.norm_squared()).sum();
    let n = points.len();
    let sigma = if n > 2 {
        (ss / (2 * n - 4) as f64).sqrt()
    } else {
        f64::NAN
    };
    Ok(LineFit {
        point: pr.centroid,
        direction: d,
        residuals,
        abscissae,
        rms: (ss / n as f64).sqrt(),
        sigma,
        direction_std_rad: [sigma / pr.sv[0]; 2],
        singular_values: pr.sv,
        conditioning: pr.sv[1] / pr.sv[0],
    })
}
