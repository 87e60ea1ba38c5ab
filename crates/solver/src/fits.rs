//! Geometric fits of measured 3-D points: plane, line and circle, each by orthogonal
//! distance, each with per-point residuals, standard uncertainties and a conditioning
//! figure.
//!
//! # Maths
//!
//! All three start from the centred point cloud M = [p₁ − p̄, …, p_N − p̄] (3 × N) and its
//! singular value decomposition M = U·S·Vᵀ, s₁ ≥ s₂ ≥ s₃, u₁, u₂, u₃ the columns of U
//! (never the scatter matrix M·Mᵀ: that would square the condition).
//!
//! * **Plane** ([`plane::fit_plane`]): point p̄, normal u₃; residual hᵢ = (pᵢ − p̄)·u₃;
//!   σ² = Σhᵢ² / (N − 3); the normal's tilt towards u₁ (u₂) has standard uncertainty
//!   σ / s₁ (σ / s₂). Conditioning: s₁ / s₂ (large: the points are nearly collinear and
//!   the tilt about u₁ is poorly determined).
//! * **Line** ([`line::fit_line`]): point p̄, direction u₁; residual = the component of
//!   pᵢ − p̄ perpendicular to u₁; σ² = Σ|rᵢ|² / (2N − 4); the direction's tilt towards u₂
//!   and u₃ each has standard uncertainty σ / s₁ (s₁² = Σtᵢ², tᵢ the abscissae).
//!   Conditioning: s₂ / s₁ (0 for a perfect line; near 1 the direction is undetermined).
//! * **Circle** ([`circle::fit_circle`]): centre c, unit normal n, radius r minimising
//!   Σ dᵢ², dᵢ² = hᵢ² + (ρᵢ − r)², hᵢ = (pᵢ − c)·n, ρᵢ = |(pᵢ − c) − hᵢ n| (the exact
//!   orthogonal distance from pᵢ to the circle). Algebraic start: the plane above, then
//!   the Kåsa circle in the plane (linear least squares in (a, b, k) of
//!   x² + y² = 2ax + 2by + k, solved by SVD). Then Gauss–Newton with step control on the
//!   2N residuals (hᵢ, ρᵢ − r) in the six parameters (c, two tilts of n about the current
//!   in-plane basis, r), each step solved by SVD of the Jacobian J. Covariance
//!   σ²·V·S⁻²·Vᵀ from the SVD of J at the solution, σ² = Σdᵢ² / (2N − 6). Conditioning:
//!   the condition number of J with unit-norm columns.
//!
//! Numerical outcomes (iterations, convergence) are data in the results; an error is
//! returned only when the input cannot be fitted at all (too few points, non-finite
//! coordinates, all points on a line for a plane or circle).

pub mod circle;
pub mod line;
pub mod plane;

pub use circle::{CircleFit, fit_circle};
pub use line::{LineFit, fit_line};
pub use plane::{PlaneFit, fit_plane};

use crate::error::SolverError;
use nalgebra::{DMatrix, Matrix3xX, Vector3};

/// Centroid, principal directions (columns of U, by decreasing singular value) and the
/// singular values of the centred point cloud.
pub(crate) struct Principal {
    pub centroid: Vector3<f64>,
    pub dirs: [Vector3<f64>; 3],
    pub sv: [f64; 3],
}

/// Checks the points (count, finiteness) and computes their principal axes.
pub(crate) fn principal(
    points: &[Vector3<f64>],
    min: usize,
    what: &str,
) -> Result<Principal, SolverError> {
    if points.len() < min {
        return Err(SolverError::InvalidInput(format!(
            "{what} fit needs at least {min} points, got {}",
            points.len()
        )));
    }
    if let Some(i) = points.iter().position(|p| !p.iter().all(|v| v.is_finite())) {
        return Err(SolverError::InvalidInput(format!(
            "{what} fit: point {i} has a non-finite coordinate"
        )));
    }
    let n = points.len() as f64;
    let centroid = points.iter().sum::<Vector3<f64>>() / n;
    let m = Matrix3xX::from_fn(points.len(), |r, c| points[c][r] - centroid[r]);
    let svd = m.svd(true, false);
    let u = svd.u.expect("U requested");
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| svd.singular_values[b].total_cmp(&svd.singular_values[a]));
    let dirs = order.map(|k| u.column(k).into_owned());
    let sv = order.map(|k| svd.singular_values[k]);
    Ok(Principal { centroid, dirs, sv })
}

/// A unit vector perpendicular to `n` (any; deterministic).
pub(crate) fn perpendicular(n: &Vector3<f64>) -> Vector3<f64> {
    let a = if n.x.abs() < 0.6 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    (a - n * n.dot(&a)).normalize()
}

/// σ²·(JᵀJ)⁻¹ computed as σ²·V·S⁻²·Vᵀ from the SVD of J (never forming JᵀJ). Directions
/// with a singular value below 1e-14·s_max get infinite variance.
pub(crate) fn covariance(j: &DMatrix<f64>, sigma: f64) -> DMatrix<f64> {
    let p = j.ncols();
    let svd = j.clone().svd(false, true);
    let vt = svd.v_t.expect("V requested");
    let smax = svd.singular_values.max();
    DMatrix::from_fn(p, p, |a, b| {
        let mut s = 0.0;
        for k in 0..svd.singular_values.len() {
            let sk = svd.singular_values[k];
            if sk > 1e-14 * smax {
                s += vt[(k, a)] * vt[(k, b)] / (sk * sk);
            } else if a == b && vt[(k, a)].abs() > 1e-8 {
                s = f64::INFINITY;
            }
        }
        sigma * sigma * s
    })
}

/// Step control of the Gauss–Newton fits (circle, cradle): the full step λ = 1 is tried,
/// then λ/2, λ/4, … (at most 30 halvings), and the first trial whose sum of squares does
/// not exceed the current `ss` (up to a relative rounding allowance `rel`) is accepted.
/// `trial(λ)` returns the state at λ·step and its sum of squares. Returns the accepted
/// state with its sum of squares (None when no λ reduced it), and the last λ tried.
pub(crate) fn halving_step<S>(
    ss: f64,
    rel: f64,
    mut trial: impl FnMut(f64) -> (S, f64),
) -> (Option<(S, f64)>, f64) {
    let mut lambda = 1.0;
    for _ in 0..30 {
        let (state, s2) = trial(lambda);
        if s2 <= ss * (1.0 + rel) + 1e-30 {
            return (Some((state, s2)), lambda);
        }
        lambda *= 0.5;
    }
    (None, lambda)
}

/// Condition number of `j` after scaling every column to unit norm (∞ if rank-deficient).
pub(crate) fn equilibrated_condition(j: &DMatrix<f64>) -> f64 {
    let mut js = j.clone();
    for mut col in js.column_iter_mut() {
        let nrm = col.norm();
        if nrm > 0.0 {
            col /= nrm;
        }
    }
    let sv = js.singular_values();
    let (mx, mn) = (sv.max(), sv.min());
    if mn > 0.0 { mx / mn } else { f64::INFINITY }
}
