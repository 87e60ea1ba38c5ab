//! Global, variance-based sensitivity: Sobol first-order and total indices over the
//! workspace (beyond Cheng et al. 2012).
//!
//! # Model
//!
//! The machine has one error state X = (X_1 … X_k), independent, each X_i uniform on
//! [−1, 1] or normal with σ = 1/3 (the tolerance read as a 3σ bound); the error value at
//! pose q is g_i(q) = X_i · m_i(q) (m_i: the tolerance, or the identified function). The
//! volumetric error is taken to first order, E(q) = Σ_i J_i(q) m_i(q) X_i, with J the
//! analytic Jacobian of the exact chain at zero error (the second-order remainder is below
//! 10⁻⁴ of E for errors of tens of µrad). Outputs: E_x, E_y, E_z at every pose, and the
//! volumetric error vector E, whose variance is the trace of its covariance,
//! V = Var E_x + Var E_y + Var E_z (the mean-square volumetric error about its mean), so
//! that its indices are shares of the mean-square volumetric error and add up like those
//! of the components.
//!
//! Indices are pooled over the poses (the workspace): with V(q) the variance of the output
//! at q, S_i = Σ_q V_i(q) / Σ_q V(q) and S_Ti = Σ_q V_Ti(q) / Σ_q V(q), i.e. the share of the
//! output's variance over the workspace.
//!
//! # Estimators (Saltelli et al. 2010, Comput. Phys. Commun. 181, 259-270)
//!
//! Two independent sample matrices A, B (N × k); A_B⁽ⁱ⁾ is A with column i from B.
//!
//! * first order (Saltelli 2010): V_i = (1/N) Σ_j f(B)_j · (f(A_B⁽ⁱ⁾)_j − f(A)_j);
//! * total (Jansen 1999): V_Ti = (1/2N) Σ_j (f(A)_j − f(A_B⁽ⁱ⁾)_j)²;
//! * V from the 2N values f(A), f(B).
//!
//! The standard error of each index is the standard deviation of its N per-sample terms
//! (summed over the poses) over √N, divided by Σ_q V(q). For the linear outputs,
//! f(A_B⁽ⁱ⁾) = f(A) + J_i m_i (B_i − A_i), so each index costs O(N) per pose.

use super::chain::{Chain, Workspace};
use super::magnitudes::Magnitudes;
use crate::error::SolverError;
use nalgebra::Vector3;
use rand::SeedableRng;
use rand::rngs::StdRng;
use rand_distr::{Distribution, Normal, Uniform};
use serde::{Deserialize, Serialize};

/// Distribution of the errors within their tolerances.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ErrorDistribution {
    /// Uniform on ±tolerance.
    #[default]
    Uniform,
    /// Normal with σ = tolerance / 3.
    Normal,
}

/// Options of the global analysis.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GlobalOptions {
    /// Base sample size N (cost N·(k + 2) model evaluations per pose).
    pub samples: usize,
    #[serde(default)]
    pub distribution: ErrorDistribution,
    #[serde(default = "default_seed")]
    pub seed: u64,
    /// At most this many poses of the evaluation set (evenly subsampled).
    #[serde(default = "default_max_poses")]
    pub max_poses: usize,
}

fn default_seed() -> u64 {
    4
}

fn default_max_poses() -> usize {
    256
}

impl Default for GlobalOptions {
    fn default() -> Self {
        GlobalOptions {
            samples: 1024,
            distribution: ErrorDistribution::Uniform,
            seed: default_seed(),
            max_poses: default_max_poses(),
        }
    }
}

/// Sobol indices of one error for one output.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SobolEntry {
    pub error: String,
    pub first_order: f64,
    pub first_order_se: f64,
    pub total: f64,
    pub total_se: f64,
}

/// Indices of every error for one output, by decreasing total index.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SobolOutput {
    pub indices: Vec<SobolEntry>,
    /// Σ S_i: 1 up to Monte-Carlo error for the first-order (additive) model.
    pub sum_first_order: f64,
    /// RMS of the output over the workspace and the error distribution, µm (for E: the
    /// RMS of |E|).
    pub rms_um: f64,
}

/// The global analysis, per output (order as `local::COMPONENTS`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GlobalResult {
    pub samples: usize,
    pub distribution: ErrorDistribution,
    pub seed: u64,
    pub poses: usize,
    pub outputs: std::collections::BTreeMap<String, SobolOutput>,
}

/// Sobol indices of every error over `poses`.
pub fn sobol(
    chain: &Chain,
    mags: &Magnitudes,
    poses: &[Vec<f64>],
    opts: &GlobalOptions,
) -> Result<GlobalResult, SolverError> {
    let k = chain.params().len();
    let n = opts.samples;
    if n < 16 {
        return Err(SolverError::InvalidInput(
            "global analysis needs at least 16 samples".into(),
        ));
    }
    if poses.is_empty() {
        return Err(SolverError::InvalidInput(
            "no poses for the global analysis".into(),
        ));
    }
    let mut rng = StdRng::seed_from_u64(opts.seed);
    let mut draw = |len: usize| -> Vec<f64> {
        match opts.distribution {
            ErrorDistribution::Uniform => {
                let u = Uniform::new_inclusive(-1.0, 1.0).expect("valid range");
                (0..len).map(|_| u.sample(&mut rng)).collect()
            }
            ErrorDistribution::Normal => {
                let d = Normal::new(0.0, 1.0 / 3.0).expect("valid sigma");
                (0..len).map(|_| d.sample(&mut rng)).collect()
            }
        }
    };
    // Row-major N × k.
    let a = draw(n * k);
    let b = draw(n * k);
    // Per output c, per sample j, per error i: first-order and total terms (summed over poses).
    let mut t1 = vec![0.0; 4 * n * k];
    let mut tt = vec![0.0; 4 * n * k];
    let mut var_total = [0.0; 4];
    let mut mean_sq = [0.0; 4];
    let mut ws = Workspace::default();
    let mut jac: Vec<Vector3<f64>> = Vec::new();
    let mut m = Vec::new();
    let mut fa = vec![Vector3::zeros(); n];
    let mut fb = vec![Vector3::zeros(); n];
    for q in poses {
        chain.jacobian_zero_into(q, &mut ws, &mut jac);
        mags.at_pose(q, &mut m);
        let g: Vec<Vector3<f64>> = jac.iter().zip(&m).map(|(j, mi)| j * *mi).collect();
        for j in 0..n {
            let (ra, rb) = (&a[j * k..(j + 1) * k], &b[j * k..(j + 1) * k]);
            fa[j] = g.iter().zip(ra).map(|(gi, x)| gi * *x).sum();
            fb[j] = g.iter().zip(rb).map(|(gi, x)| gi * *x).sum();
        }
        // Variance of each output at this pose from the 2N values.
        for c in 0..3 {
            let (mut s, mut s2) = (0.0, 0.0);
            for v in fa.iter().chain(fb.iter()) {
                s += v[c];
                s2 += v[c] * v[c];
            }
            let cnt = 2.0 * n as f64;
            let mean = s / cnt;
            let var = (s2 / cnt - mean * mean) * cnt / (cnt - 1.0);
            var_total[c] += var;
            var_total[3] += var;
            mean_sq[c] += s2 / cnt;
            mean_sq[3] += s2 / cnt;
        }
        for j in 0..n {
            let (ra, rb) = (&a[j * k..(j + 1) * k], &b[j * k..(j + 1) * k]);
            let vb = fb[j];
            for i in 0..k {
                // f(A_B⁽ⁱ⁾) − f(A) of the linear model.
                let d = g[i] * (rb[i] - ra[i]);
                let (mut s1, mut st) = (0.0, 0.0);
                for c in 0..3 {
                    let idx = (c * n + j) * k + i;
                    t1[idx] += vb[c] * d[c];
                    tt[idx] += 0.5 * d[c] * d[c];
                    s1 += vb[c] * d[c];
                    st += 0.5 * d[c] * d[c];
                }
                let idx = (3 * n + j) * k + i;
                t1[idx] += s1;
                tt[idx] += st;
            }
        }
    }
    let mut outputs = std::collections::BTreeMap::new();
    for (c, name) in super::local::COMPONENTS.iter().enumerate() {
        let v = var_total[c];
        let mut indices: Vec<SobolEntry> = (0..k)
            .map(|i| {
                let (m1, s1) = mean_se((0..n).map(|j| t1[(c * n + j) * k + i]), n);
                let (mt, st) = mean_se((0..n).map(|j| tt[(c * n + j) * k + i]), n);
                let scale = if v > 0.0 { 1.0 / v } else { 0.0 };
                SobolEntry {
                    error: chain.params()[i].name.clone(),
                    first_order: m1 * scale,
                    first_order_se: s1 * scale,
                    total: mt * scale,
                    total_se: st * scale,
                }
            })
            .collect();
        let sum_first_order = indices.iter().map(|e| e.first_order).sum();
        indices.sort_by(|x, y| y.total.total_cmp(&x.total));
        outputs.insert(
            (*name).to_string(),
            SobolOutput {
                indices,
                sum_first_order,
                rms_um: (mean_sq[c] / poses.len() as f64).sqrt(),
            },
        );
    }
    Ok(GlobalResult {
        samples: n,
        distribution: opts.distribution,
        seed: opts.seed,
        poses: poses.len(),
        outputs,
    })
}

/// Mean and standard error of the mean of `n` values.
fn mean_se(it: impl Iterator<Item = f64> + Clone, n: usize) -> (f64, f64) {
    let nf = n as f64;
    let mean = it.clone().sum::<f64>() / nf;
    let var = it.map(|x| (x - mean) * (x - mean)).sum::<f64>() / (nf - 1.0);
    (mean, (var / nf).sqrt())
}
