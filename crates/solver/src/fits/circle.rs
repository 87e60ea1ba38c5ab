//! 3-D circle by orthogonal distance: plane + Kåsa start, then Gauss–Newton on the
//! geometric distance (see the [module docs](super) for the maths).

use super::{halving_step, perpendicular, plane::fit_plane};
use crate::error::SolverError;
use nalgebra::{DMatrix, DVector, Vector3};
use serde::{Deserialize, Serialize};

/// Iteration limit of the Gauss–Newton refinement.
const MAX_ITER: usize = 100;

/// A fitted 3-D circle.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CircleFit {
    /// Centre, mm.
    pub centre: Vector3<f64>,
    /// Unit normal (sign: that of the plane fit; the caller orients it).
    pub normal: Vector3<f64>,
    /// Radius, mm.
    pub radius: f64,
    /// Per point, in input order: radial residual ρᵢ − r, mm.
    pub radial: Vec<f64>,
    /// Per point: axial residual hᵢ = (pᵢ − c)·n, mm.
    pub axial: Vec<f64>,
    /// RMS orthogonal distance √(Σdᵢ²/N), mm.
    pub rms: f64,
    /// σ per residual component, √(Σdᵢ² / (2N − 6)), mm (NaN for N = 3).
    pub sigma: f64,
    /// Standard uncertainty of the centre coordinates, mm.
    pub centre_std: [f64; 3],
    /// Standard uncertainty of the normal's tilt towards the two in-plane directions
    /// `tilt_axes`, rad.
    pub normal_std_rad: [f64; 2],
    /// The in-plane directions the normal's tilts are expressed along.
    pub tilt_axes: [Vector3<f64>; 2],
    /// Standard uncertainty of the radius, mm.
    pub radius_std: f64,
    /// Covariance of (cx, cy, cz, tilt₁, tilt₂, r), mm and rad.
    pub covariance: [[f64; 6]; 6],
    /// Condition number of the column-equilibrated Jacobian at the solution.
    pub condition: f64,
    /// Gauss–Newton iterations taken, and whether the step fell below tolerance.
    pub iterations: usize,
    pub converged: bool,
}

impl CircleFit {
    /// The same circle with its normal pointing into the half-space of `towards`.
    pub fn oriented(mut self, towards: &Vector3<f64>) -> Self {
        if self.normal.dot(towards) < 0.0 {
            self.normal = -self.normal;
            self.axial.iter_mut().for_each(|h| *h = -*h);
        }
        self
    }
}

/// Residuals (hᵢ, ρᵢ − r) stacked [h₁..h_N, ρ₁−r..ρ_N−r] and their sum of squares.
fn residuals(points: &[Vector3<f64>], c: &Vector3<f64>, n: &Vector3<f64>, r: f64) -> DVector<f64> {
    let m = points.len();
    let mut out = DVector::zeros(2 * m);
    for (i, p) in points.iter().enumerate() {
        let d = p - c;
        let h = d.dot(n);
        out[i] = h;
        out[m + i] = (d - n * h).norm() - r;
    }
    out
}

/// Jacobian of [`residuals`] in (c, α, β, r) with n(α, β) = normalize(n + αu + βv).
fn jacobian(
    points: &[Vector3<f64>],
    c: &Vector3<f64>,
    n: &Vector3<f64>,
    u: &Vector3<f64>,
    v: &Vector3<f64>,
) -> DMatrix<f64> {
    let m = points.len();
    let mut j = DMatrix::zeros(2 * m, 6);
    for (i, p) in points.iter().enumerate() {
        let d = p - c;
        let h = d.dot(n);
        let w = d - n * h;
        let rho = w.norm();
        let wh = if rho > 0.0 { w / rho } else { *u };
        // ∂h/∂c = −n, ∂h/∂α = d·u, ∂h/∂β = d·v.
        for k in 0..3 {
            j[(i, k)] = -n[k];
            // ∂ρ/∂c = −ŵ (ŵ ⊥ n).
            j[(m + i, k)] = -wh[k];
        }
        j[(i, 3)] = d.dot(u);
        j[(i, 4)] = d.dot(v);
        // ∂ρ/∂n·dn = −h (ŵ·dn).
        j[(m + i, 3)] = -h * wh.dot(u);
        j[(m + i, 4)] = -h * wh.dot(v);
        j[(m + i, 5)] = -1.0;
    }
    j
}

/// Kåsa circle in the plane's (u₁, u₂) coordinates: returns (centre, radius).
fn kasa(
    points: &[Vector3<f64>],
    o: &Vector3<f64>,
    e1: &Vector3<f64>,
    e2: &Vector3<f64>,
) -> Result<(Vector3<f64>, f64), SolverError> {
    let m = points.len();
    let mut a = DMatrix::zeros(m, 3);
    let mut b = DVector::zeros(m);
    for (i, p) in points.iter().enumerate() {
        let x = (p - o).dot(e1);
        let y = (p - o).dot(e2);
        a[(i, 0)] = 2.0 * x;
        a[(i, 1)] = 2.0 * y;
        a[(i, 2)] = 1.0;
        b[i] = x * x + y * y;
    }
    let sol = a
        .svd(true, true)
        .solve(&b, 1e-12)
        .map_err(|e| SolverError::Degenerate(format!("circle fit: Kåsa start failed: {e}")))?;
    let r2 = sol[2] + sol[0] * sol[0] + sol[1] * sol[1];
    if r2.is_nan() || r2 <= 0.0 {
        return Err(SolverError::Degenerate(
            "circle fit: Kåsa start gave no circle".into(),
        ));
    }
    Ok((o + e1 * sol[0] + e2 * sol[1], r2.sqrt()))
}

/// Fits a circle to `points` (at least 3, not collinear) by orthogonal distance.
pub fn fit_circle(points: &[Vector3<f64>]) -> Result<CircleFit, SolverError> {
    let pl = fit_plane(points)?;
    let (mut c, mut r) = kasa(points, &pl.point, &pl.in_plane[0], &pl.in_plane[1])?;
    let mut n = pl.normal;
    let mut res = residuals(points, &c, &n, r);
    let mut ss = res.norm_squared();
    let mut iterations = 0;
    let mut converged = false;
    let scale = r.max(1e-300);
    while iterations < MAX_ITER {
        iterations += 1;
        let u = perpendicular(&n);
        let v = n.cross(&u);
        let j = jacobian(points, &c, &n, &u, &v);
        let step = j
            .svd(true, true)
            .solve(&(-&res), 1e-14)
            .map_err(|e| SolverError::Degenerate(format!("circle fit: {e}")))?;
        // Step halving keeps the sum of squares from increasing.
        let (next, lambda) = halving_step(ss, 1e-15, |lambda| {
            let c2 = c + Vector3::new(step[0], step[1], step[2]) * lambda;
            let n2 = (n + u * (step[3] * lambda) + v * (step[4] * lambda)).normalize();
            let r2 = r + step[5] * lambda;
            let res2 = residuals(points, &c2, &n2, r2);
            let ss2 = res2.norm_squared();
            ((c2, n2, r2, res2), ss2)
        });
        let accepted = next.is_some();
        if let Some(((c2, n2, r2, res2), ss2)) = next {
            c = c2;
            n = n2;
            r = r2;
            res = res2;
            ss = ss2;
        }
        let size = (step.fixed_rows::<3>(0).norm() + step[5].abs()) / scale
            + step[3].abs()
            + step[4].abs();
        if !accepted || size * lambda < 1e-13 {
            converged = accepted || size < 1e-10;
            break;
        }
    }
    let m = points.len();
    let u = perpendicular(&n);
    let v = n.cross(&u);
    let j = jacobian(points, &c, &n, &u, &v);
    let sigma = if m > 3 {
        (ss / (2 * m - 6) as f64).sqrt()
    } else {
        f64::NAN
    };
    let (c6, condition) = (
        super::covariance(&j, sigma),
        super::equilibrated_condition(&j),
    );
    let mut cov = [[0.0; 6]; 6];
    for a in 0..6 {
        for b in 0..6 {
            cov[a][b] = c6[(a, b)];
        }
    }
    let radial = res.rows(m, m).iter().copied().collect();
    let axial = res.rows(0, m).iter().copied().collect();
    Ok(CircleFit {
        centre: c,
        normal: n,
        radius: r,
        radial,
        axial,
        rms: (ss / m as f64).sqrt(),
        sigma,
        centre_std: [cov[0][0].sqrt(), cov[1][1].sqrt(), cov[2][2].sqrt()],
        normal_std_rad: [cov[3][3].sqrt(), cov[4][4].sqrt()],
        tilt_axes: [u, v],
        radius_std: cov[5][5].sqrt(),
        covariance: cov,
        condition,
        iterations,
        converged,
    })
}
