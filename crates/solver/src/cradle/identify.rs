//! Identification of the cradle model (location errors, ball, optional compliance) from
//! all measured points at once, and its leave-one-pose-out validation.
//!
//! Nonlinear least squares: minimise Σ |p(Aᵢ, Cᵢ; q) − pᵢ|² over q (the parameters of
//! [`model_from_params`] for a [`ModelSpec`]) by Gauss–Newton with step halving
//! ([`gauss_newton`], also used to register the instrument frame); the Jacobian by
//! central differences; each step and the covariance σ²·V·S⁻²·Vᵀ from the SVD of the
//! column-equilibrated Jacobian, σ² = SSR / (3N − P).
//! Start: zero errors, the ball from the nominal inverse kinematics averaged over all
//! points, w = Rz(C)ᵀ·Rx(A)ᵀ·(p − P).

use super::model::{CradleModel, ModelSpec, model_from_params};
use crate::error::SolverError;
use crate::fits::{covariance, equilibrated_condition, halving_step};
use nalgebra::{DMatrix, DVector, Isometry3, Rotation3, Vector3};

/// One measured point: commanded A, C (rad), measured position (mm), pose index.
#[derive(Debug, Clone, Copy)]
pub struct Obs {
    pub a: f64,
    pub c: f64,
    pub p: Vector3<f64>,
    pub pose: usize,
}

/// A fitted model.
#[derive(Debug, Clone)]
pub struct KinematicFit {
    pub spec: ModelSpec,
    pub q: Vec<f64>,
    pub model: CradleModel,
    /// Covariance of q (mm, rad).
    pub cov: DMatrix<f64>,
    /// σ per coordinate, mm.
    pub sigma: f64,
    /// RMS 3-D residual, mm.
    pub rms: f64,
    pub condition: f64,
    /// Numerical rank of the Jacobian (relative threshold 1e-10 after equilibration).
    pub rank: usize,
    pub iterations: usize,
    pub converged: bool,
}

const MAX_ITER: usize = 50;

pub(crate) fn residuals(obs: &[Obs], pivot: [f64; 3], spec: &ModelSpec, q: &[f64]) -> DVector<f64> {
    let m = model_from_params(pivot, spec, q);
    let b = m.ball_in_table();
    let mut r = DVector::zeros(3 * obs.len());
    // Points come grouped by pose: T_A once per A.
    let mut a_part: Option<(f64, Isometry3<f64>)> = None;
    for (i, o) in obs.iter().enumerate() {
        let ap = match a_part {
            Some((a, p)) if a == o.a => p,
            _ => {
                let p = m.a_part(o.a);
                a_part = Some((o.a, p));
                p
            }
        };
        let e = (ap * (m.c_part(o.c) * b)).coords - o.p;
        r.fixed_rows_mut::<3>(3 * i).copy_from(&e);
    }
    r
}

/// Central-difference Jacobian of `f` at `q`, parameter k stepped by `steps[k]` (in its
/// own unit: [`ModelSpec::steps`]).
pub fn jacobian(
    f: &impl Fn(&[f64]) -> DVector<f64>,
    q: &[f64],
    rows: usize,
    steps: &[f64],
) -> DMatrix<f64> {
    let mut j = DMatrix::zeros(rows, q.len());
    let mut qq = q.to_vec();
    for k in 0..q.len() {
        let h = steps[k];
        qq[k] = q[k] + h;
        let rp = f(&qq);
        qq[k] = q[k] - h;
        let rm = f(&qq);
        qq[k] = q[k];
        j.set_column(k, &((rp - rm) / (2.0 * h)));
    }
    j
}

/// A Gauss–Newton solution of min ‖f(q)‖².
#[derive(Debug, Clone)]
pub struct GnSolution {
    pub q: Vec<f64>,
    pub residual: DVector<f64>,
    pub iterations: usize,
    pub converged: bool,
}

/// Gauss–Newton with step halving from `q0` (module docs); `what` names the problem in
/// errors.
pub fn gauss_newton(
    f: impl Fn(&[f64]) -> DVector<f64>,
    q0: &[f64],
    steps: &[f64],
    what: &str,
) -> Result<GnSolution, SolverError> {
    let np = q0.len();
    let mut q = q0.to_vec();
    let mut res = f(&q);
    let rows = res.len();
    if rows <= np {
        return Err(SolverError::Degenerate(format!(
            "{what}: {rows} coordinates for {np} parameters"
        )));
    }
    let mut ss = res.norm_squared();
    let mut iterations = 0;
    let mut converged = false;
    while iterations < MAX_ITER {
        iterations += 1;
        let j = jacobian(&f, &q, rows, steps);
        // A column of no effect (z_M while nothing tilts) keeps scale 1: its step stays at
        // rounding level instead of being divided by nothing.
        let scale: Vec<f64> = j
            .column_iter()
            .map(|c| {
                let n = c.norm();
                if n > 0.0 { n } else { 1.0 }
            })
            .collect();
        let mut js = j.clone();
        for (k, mut col) in js.column_iter_mut().enumerate() {
            col /= scale[k];
        }
        let z = js
            .svd(true, true)
            .solve(&(-&res), 1e-12)
            .map_err(|e| SolverError::Degenerate(format!("{what}: {e}")))?;
        let step: Vec<f64> = (0..np).map(|k| z[k] / scale[k]).collect();
        let (next, lambda) = halving_step(ss, 1e-14, |lambda| {
            let q2: Vec<f64> = q.iter().zip(&step).map(|(a, d)| a + lambda * d).collect();
            let r2 = f(&q2);
            let s2 = r2.norm_squared();
            ((q2, r2), s2)
        });
        let accepted = next.is_some();
        if let Some(((q2, r2), s2)) = next {
            q = q2;
            res = r2;
            ss = s2;
        }
        // Size of the step in the equilibrated coordinates relative to the residual norm.
        // (z is in residual units, mm; the floor is 1e-12 mm.)
        let size = z.norm() * lambda;
        let tol = 1e-9 * res.norm() + 1e-12;
        if !accepted || size < tol {
            converged = accepted || size < 1e3 * tol;
            break;
        }
    }
    Ok(GnSolution {
        q,
        residual: res,
        iterations,
        converged,
    })
}

/// Starting parameters: zero errors and compliance, the ball from nominal inverse
/// kinematics, the mount (if any) at the pivot.
pub fn start(obs: &[Obs], pivot: [f64; 3], spec: &ModelSpec) -> Vec<f64> {
    let p = Vector3::from(pivot);
    let mut w = Vector3::zeros();
    for o in obs {
        let r = Rotation3::from_axis_angle(&Vector3::x_axis(), o.a)
            * Rotation3::from_axis_angle(&Vector3::z_axis(), o.c);
        w += r.inverse() * (o.p - p);
    }
    w /= obs.len() as f64;
    let mut q = vec![0.0; spec.n_params()];
    q[8] = w.x.hypot(w.y);
    q[9] = w.y.atan2(w.x);
    q[10] = w.z;
    q
}

/// Fits the model `spec` to `obs` from `q0`.
pub fn fit_kinematics(
    obs: &[Obs],
    pivot: [f64; 3],
    spec: &ModelSpec,
    q0: &[f64],
) -> Result<KinematicFit, SolverError> {
    let np = q0.len();
    let f = |q: &[f64]| residuals(obs, pivot, spec, q);
    let steps = spec.steps();
    let sol = gauss_newton(f, q0, &steps, "cradle model")?;
    let ss = sol.residual.norm_squared();
    let j = &jacobian(&f, &sol.q, sol.residual.len(), &steps);
    let dof = 3 * obs.len() - np;
    let sigma = (ss / dof as f64).sqrt();
    let cov = covariance(j, sigma);
    let condition = equilibrated_condition(j);
    let mut js = j.clone();
    for mut col in js.column_iter_mut() {
        let n = col.norm();
        if n > 0.0 {
            col /= n;
        }
    }
    let sv = js.singular_values();
    let rank = sv.iter().filter(|s| **s > 1e-10 * sv.max()).count();
    Ok(KinematicFit {
        model: model_from_params(pivot, spec, &sol.q),
        spec: *spec,
        q: sol.q,
        cov,
        sigma,
        rms: (ss / obs.len() as f64).sqrt(),
        condition,
        rank,
        iterations: sol.iterations,
        converged: sol.converged,
    })
}

/// The model of one leave-one-pose-out fold (no covariance needed).
struct FoldFit {
    model: CradleModel,
}

/// Held-out figures of one left-out pose: RMS 3-D distance of its measured points from
/// the nominal kinematics (before compensation) and from the fold's model (after), mm.
#[derive(Debug, Clone, Copy)]
pub struct HeldOut {
    pub pose: usize,
    pub before_rms: f64,
    pub after_rms: f64,
    pub after_max: f64,
}

/// Leave-one-pose-out: for each pose, fit the model on the others (starting from `q`)
/// and predict the left-out pose.
pub fn leave_one_pose_out(
    obs: &[Obs],
    pivot: [f64; 3],
    spec: &ModelSpec,
    q: &[f64],
    n_poses: usize,
) -> Result<Vec<HeldOut>, SolverError> {
    let mut out = Vec::with_capacity(n_poses);
    for k in 0..n_poses {
        let train: Vec<Obs> = obs.iter().filter(|o| o.pose != k).copied().collect();
        let sol = gauss_newton(
            |q: &[f64]| residuals(&train, pivot, spec, q),
            q,
            &spec.steps(),
            "cradle model",
        )?;
        let fit = FoldFit {
            model: model_from_params(pivot, spec, &sol.q),
        };
        let (mut sb, mut sa, mut ma, mut n) = (0.0, 0.0, 0.0f64, 0usize);
        for o in obs.iter().filter(|o| o.pose == k) {
            let before = (o.p - fit.model.nominal_ball(o.a, o.c)).norm();
            let after = (o.p - fit.model.ball(o.a, o.c)).norm();
            sb += before * before;
            sa += after * after;
            ma = ma.max(after);
            n += 1;
        }
        let n = n.max(1) as f64;
        out.push(HeldOut {
            pose: k,
            before_rms: (sb / n).sqrt(),
            after_rms: (sa / n).sqrt(),
            after_max: ma,
        });
    }
    Ok(out)
}
