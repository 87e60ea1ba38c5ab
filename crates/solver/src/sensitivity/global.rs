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
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
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
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
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
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct SobolEntry {
    pub error: String,
    pub first_order: f64,
    pub first_order_se: f64,
    pub total: f64,
    pub total_se: f64,
}

/// Indices of every error for one output, by decreasing total index.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
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
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
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
    if !(16..=10_000_000).contains(&n) {
        return Err(SolverError::InvalidInput(
            "global analysis needs 16 to 10^7 samples".into(),
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
    // g_i(q) = J_i(q) m_i(q) for every pose: the linear model E(q) = Σ_i g_i(q) X_i.
    let mut ws = Workspace::default();
    let mut jac: Vec<Vector3<f64>> = Vec::new();
    let mut m = Vec::new();
    let mut g: Vec<Vector3<f64>> = Vec::with_capacity(poses.len() * k);
    for q in poses {
        chain.jacobian_zero_into(q, &mut ws, &mut jac);
        mags.at_pose(q, &mut m);
        g.extend(jac.iter().zip(&m).map(|(j, mi)| j * *mi));
    }
    // Rows of A and B are drawn one sample at a time (memory O(k), not O(N k)). Per sample
    // j the first-order and total terms are summed over the poses, then accumulated
    // (Welford) per output c and error i for their mean and standard error.
    let mut t1 = vec![Welford::default(); 4 * k];
    let mut tt = vec![Welford::default(); 4 * k];
    let mut loc1 = vec![0.0; 4 * k];
    let mut loct = vec![0.0; 4 * k];
    // Per pose and component: Σ f and Σ f² over the 2N values f(A), f(B).
    let mut sums = vec![[0.0f64; 6]; poses.len()];
    for _ in 0..n {
        let ra = draw(k);
        let rb = draw(k);
        loc1.iter_mut().for_each(|v| *v = 0.0);
        loct.iter_mut().for_each(|v| *v = 0.0);
        for (p, gp) in g.chunks_exact(k).enumerate() {
            let fa: Vector3<f64> = gp.iter().zip(&ra).map(|(gi, x)| gi * *x).sum();
            let fb: Vector3<f64> = gp.iter().zip(&rb).map(|(gi, x)| gi * *x).sum();
            for c in 0..3 {
                sums[p][c] += fa[c] + fb[c];
                sums[p][3 + c] += fa[c] * fa[c] + fb[c] * fb[c];
            }
            for i in 0..k {
                // f(A_B⁽ⁱ⁾) − f(A) of the linear model.
                let d = gp[i] * (rb[i] - ra[i]);
                for c in 0..3 {
                    loc1[c * k + i] += fb[c] * d[c];
                    loct[c * k + i] += 0.5 * d[c] * d[c];
                }
            }
        }
        for i in 0..k {
            let (s1, st) = (
                loc1[i] + loc1[k + i] + loc1[2 * k + i],
                loct[i] + loct[k + i] + loct[2 * k + i],
            );
            loc1[3 * k + i] = s1;
            loct[3 * k + i] = st;
        }
        for (w, v) in t1.iter_mut().zip(&loc1) {
            w.push(*v);
        }
        for (w, v) in tt.iter_mut().zip(&loct) {
            w.push(*v);
        }
    }
    let mut var_total = [0.0; 4];
    let mut mean_sq = [0.0; 4];
    let cnt = 2.0 * n as f64;
    for s in &sums {
        for c in 0..3 {
            let mean = s[c] / cnt;
            let var = (s[3 + c] / cnt - mean * mean) * cnt / (cnt - 1.0);
            var_total[c] += var;
            var_total[3] += var;
            mean_sq[c] += s[3 + c] / cnt;
            mean_sq[3] += s[3 + c] / cnt;
        }
    }
    let mut outputs = std::collections::BTreeMap::new();
    for (c, name) in super::local::COMPONENTS.iter().enumerate() {
        let v = var_total[c];
        let mut indices: Vec<SobolEntry> = (0..k)
            .map(|i| {
                let (m1, s1) = t1[c * k + i].mean_se();
                let (mt, st) = tt[c * k + i].mean_se();
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

/// Running mean and sum of squared deviations (Welford 1962).
#[derive(Debug, Clone, Copy, Default)]
struct Welford {
    n: f64,
    mean: f64,
    m2: f64,
}

impl Welford {
    fn push(&mut self, x: f64) {
        self.n += 1.0;
        let d = x - self.mean;
        self.mean += d / self.n;
        self.m2 += d * (x - self.mean);
    }

    /// Mean and standard error of the mean.
    fn mean_se(&self) -> (f64, f64) {
        (self.mean, (self.m2 / (self.n - 1.0) / self.n).sqrt())
    }
}
