//! Local sensitivities (Cheng et al. 2012) at a point, along a path, over a grid.
//!
//! For error g_i and component c ∈ {E_x, E_y, E_z}: S_ci(q) = |∂E_c/∂g_i| at pose q; for
//! the volumetric error E: S_i(q) = ‖∂E/∂g_i‖ (the length of the column: the magnitude
//! |E| itself has no derivative at E = 0). Two scales:
//!
//! * `paper`: in mm/mm for translational errors and mm/rad for angular errors, as the
//!   paper does: an angular error's sensitivity is then its Abbe arm in mm;
//! * `weighted`: S_ci(q) · |m_i(q)| in µm, the share of the error component that error
//!   i produces at its tolerance or identified value: comparable across units.
//!
//! Over a path or a grid: mean and max over the poses. Normalised coefficients
//! C_i = S̄_i / Σ_j S̄_j (means), key errors = the fewest errors, by decreasing C_i, whose
//! coefficients sum to at least the chosen share.

use super::chain::{Chain, Workspace};
use super::magnitudes::Magnitudes;
use crate::error::SolverError;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// One axis of an evaluation grid: `n` evenly spaced positions from `min` to `max`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(deny_unknown_fields)]
pub struct GridAxis {
    pub min: f64,
    pub max: f64,
    pub n: usize,
}

impl GridAxis {
    fn at(&self, i: usize) -> f64 {
        if self.n <= 1 {
            self.min
        } else {
            self.min + (self.max - self.min) * i as f64 / (self.n - 1) as f64
        }
    }
}

/// Where the sensitivities are evaluated (poses in the chain's axis order).
#[derive(Debug, Clone, PartialEq)]
pub enum Poses {
    /// One point, or a tool path (list of points).
    Points(Vec<Vec<f64>>),
    /// A full grid, one [`GridAxis`] per axis.
    Grid(Vec<GridAxis>),
}

impl Poses {
    pub fn len(&self) -> usize {
        match self {
            Poses::Points(p) => p.len(),
            Poses::Grid(g) => g.iter().map(|a| a.n).product(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// `point`, `path` or `grid`.
    pub fn kind(&self) -> &'static str {
        match self {
            Poses::Points(p) if p.len() == 1 => "point",
            Poses::Points(_) => "path",
            Poses::Grid(_) => "grid",
        }
    }

    /// Checks dimensions and finiteness against `n_axes`.
    pub fn validate(&self, n_axes: usize) -> Result<(), SolverError> {
        let bad = |m: String| Err(SolverError::InvalidInput(m));
        match self {
            Poses::Points(p) => {
                if p.is_empty() {
                    return bad("no evaluation point".into());
                }
                for (i, q) in p.iter().enumerate() {
                    if q.len() != n_axes {
                        return bad(format!(
                            "point {} has {} coordinates, the machine has {n_axes} axes",
                            i + 1,
                            q.len()
                        ));
                    }
                    if !q.iter().all(|v| v.is_finite()) {
                        return bad(format!("point {} is not finite", i + 1));
                    }
                }
            }
            Poses::Grid(g) => {
                if g.len() != n_axes {
                    return bad(format!(
                        "grid has {} axes, the machine has {n_axes}",
                        g.len()
                    ));
                }
                for (i, a) in g.iter().enumerate() {
                    if a.n == 0 || !a.min.is_finite() || !a.max.is_finite() {
                        return bad(format!("grid axis {}: n >= 1 and finite bounds", i + 1));
                    }
                }
            }
        }
        Ok(())
    }

    /// The pose of index `k` (grid: first axis slowest).
    pub fn pose(&self, k: usize, out: &mut Vec<f64>) {
        out.clear();
        match self {
            Poses::Points(p) => out.extend_from_slice(&p[k]),
            Poses::Grid(g) => {
                let mut rem = k;
                out.resize(g.len(), 0.0);
                for (i, a) in g.iter().enumerate().rev() {
                    out[i] = a.at(rem % a.n);
                    rem /= a.n;
                }
            }
        }
    }

    /// At most `max` poses spread evenly over the set (every ⌈len/max⌉-th pose, offset to
    /// the middle of each stride).
    pub fn subsample(&self, max: usize) -> Vec<Vec<f64>> {
        let n = self.len();
        let stride = n.div_ceil(max.max(1)).max(1);
        let mut out = Vec::new();
        let mut q = Vec::new();
        let mut k = stride / 2;
        while k < n {
            self.pose(k, &mut q);
            out.push(q.clone());
            k += stride;
        }
        out
    }
}

/// The four outputs: E_x, E_y, E_z and the volumetric error E.
pub const COMPONENTS: [&str; 4] = ["Ex", "Ey", "Ez", "E"];

/// Mean and max over the poses of the sensitivities, per component (index as
/// [`COMPONENTS`]) and parameter.
#[derive(Debug, Clone, PartialEq)]
pub struct LocalStats {
    pub poses: usize,
    /// Paper scale (mm/mm or mm/rad).
    pub mean: [Vec<f64>; 4],
    pub max: [Vec<f64>; 4],
    /// Weighted by the magnitudes, µm.
    pub mean_weighted: [Vec<f64>; 4],
    pub max_weighted: [Vec<f64>; 4],
}

/// Sensitivities of every error over `poses`: the analytic Jacobian at zero error
/// ([`Chain::jacobian_zero_into`], the paper's definition), or, with `at_error_state`, at
/// the machine's own error state g_i = m_i(q) (tolerances count as 0: they are bounds, not
/// values), where the arms reach the actual tool point ([`Chain::jacobian_into`]).
pub fn local_stats(
    chain: &Chain,
    mags: &Magnitudes,
    poses: &Poses,
    at_error_state: bool,
) -> LocalStats {
    let k = chain.params().len();
    let paper: Vec<f64> = chain
        .params()
        .iter()
        .map(|p| if p.angular { 1e3 } else { 1.0 })
        .collect();
    // Per parameter: [sum over poses of |J_x|, |J_y|, |J_z|, ‖J‖; their max; the same
    // weighted by |m_i(q)|], contiguous for the inner loop.
    let mut acc = vec![[0.0f64; 16]; k];
    let mut ws = Workspace::default();
    let mut jac: Vec<Vector3<f64>> = Vec::new();
    let mut q = Vec::new();
    let mut m = Vec::new();
    let mut state = Vec::new();
    let varying = mags.varies_with_position() || at_error_state;
    let n = poses.len();
    for idx in 0..n {
        poses.pose(idx, &mut q);
        if varying || idx == 0 {
            mags.at_pose(&q, &mut m);
        }
        if at_error_state {
            mags.state_at_pose(&q, &mut state);
            chain.jacobian_into(&q, &state, &mut ws, &mut jac);
        } else {
            chain.jacobian_zero_into(&q, &mut ws, &mut jac);
        }
        if varying {
            for i in 0..k {
                let col = jac[i];
                let vals = [col.x.abs(), col.y.abs(), col.z.abs(), col.norm()];
                let (p, w) = (paper[i], m[i].abs());
                let a = &mut acc[i];
                for c in 0..4 {
                    let s = vals[c] * p;
                    let sw = vals[c] * w;
                    a[c] += s;
                    a[4 + c] = a[4 + c].max(s);
                    a[8 + c] += sw;
                    a[12 + c] = a[12 + c].max(sw);
                }
            }
        } else {
            // Constant magnitudes: accumulate |J| only; scales are applied once below.
            for (a, col) in acc.iter_mut().zip(&jac) {
                let vals = [col.x.abs(), col.y.abs(), col.z.abs(), col.norm()];
                for c in 0..4 {
                    a[c] += vals[c];
                    a[4 + c] = a[4 + c].max(vals[c]);
                }
            }
        }
    }
    if !varying {
        for (i, a) in acc.iter_mut().enumerate() {
            let (p, w) = (paper[i], m.get(i).map_or(0.0, |v: &f64| v.abs()));
            for c in 0..8 {
                a[8 + c] = a[c] * w;
                a[c] *= p;
            }
        }
    }
    let inv = 1.0 / n.max(1) as f64;
    let pick = |off: usize, scale: f64| -> [Vec<f64>; 4] {
        std::array::from_fn(|c| acc.iter().map(|a| a[off + c] * scale).collect())
    };
    let (mean, max, mean_w, max_w) = (pick(0, inv), pick(4, 1.0), pick(8, inv), pick(12, 1.0));
    LocalStats {
        poses: n,
        mean,
        max,
        mean_weighted: mean_w,
        max_weighted: max_w,
    }
}

/// RMS and max of |E_x|, |E_y|, |E_z|, |E| over the poses, µm.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ErrorSummary {
    pub rms_um: f64,
    pub max_um: f64,
}

/// The volumetric error of the machine's own error state (errors given as values or
/// functions; tolerances count as 0) over the poses, by the exact chain; `None` when every
/// error is a tolerance.
pub fn volumetric_error(
    chain: &Chain,
    mags: &Magnitudes,
    poses: &Poses,
) -> Option<std::collections::BTreeMap<String, ErrorSummary>> {
    if !mags.has_values() {
        return None;
    }
    let (mut sq, mut mx) = ([0.0; 4], [0.0f64; 4]);
    let (mut q, mut state) = (Vec::new(), Vec::new());
    for idx in 0..poses.len() {
        poses.pose(idx, &mut q);
        mags.state_at_pose(&q, &mut state);
        let e = chain.error_um(&q, &state);
        let v = [e.x.abs(), e.y.abs(), e.z.abs(), e.norm()];
        for c in 0..4 {
            sq[c] += v[c] * v[c];
            mx[c] = mx[c].max(v[c]);
        }
    }
    let n = poses.len().max(1) as f64;
    Some(
        COMPONENTS
            .iter()
            .enumerate()
            .map(|(c, name)| {
                (
                    (*name).to_string(),
                    ErrorSummary {
                        rms_um: (sq[c] / n).sqrt(),
                        max_um: mx[c],
                    },
                )
            })
            .collect(),
    )
}

/// Which sensitivities the normalised coefficients are built from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(rename_all = "snake_case")]
pub enum Weighting {
    /// Sensitivity × magnitude (µm): the default; comparable across units.
    #[default]
    Weighted,
    /// The paper's raw sensitivities (mm/mm and mm/rad).
    Paper,
}

/// One row of a ranking table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct RankEntry {
    pub error: String,
    /// Unit of the error (`um` or `urad`).
    pub unit: String,
    /// Mean sensitivity on the paper's scale: `mm/mm` for translations, `mm/rad` for
    /// angles (the Abbe arm).
    pub sensitivity_mean: f64,
    pub sensitivity_max: f64,
    /// Mean and max of sensitivity × magnitude, µm.
    pub contribution_mean_um: f64,
    pub contribution_max_um: f64,
    /// Normalised coefficient S_i / Σ S_j (of the chosen weighting).
    pub coefficient: f64,
}

/// The ranking of one component.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ComponentRanking {
    /// Rows by decreasing coefficient.
    pub ranking: Vec<RankEntry>,
    /// The fewest errors whose coefficients reach the share.
    pub key_errors: Vec<String>,
    /// Sum of the key errors' coefficients.
    pub covered: f64,
}

/// Ranks the errors for component `c` (index into [`COMPONENTS`]).
pub fn rank(
    chain: &Chain,
    stats: &LocalStats,
    c: usize,
    weighting: Weighting,
    share: f64,
) -> ComponentRanking {
    let basis = match weighting {
        Weighting::Weighted => &stats.mean_weighted[c],
        Weighting::Paper => &stats.mean[c],
    };
    let coefficients = normalise(basis);
    let mut ranking: Vec<RankEntry> = chain
        .params()
        .iter()
        .enumerate()
        .map(|(i, p)| RankEntry {
            error: p.name.clone(),
            unit: p.unit().into(),
            sensitivity_mean: stats.mean[c][i],
            sensitivity_max: stats.max[c][i],
            contribution_mean_um: stats.mean_weighted[c][i],
            contribution_max_um: stats.max_weighted[c][i],
            coefficient: coefficients[i],
        })
        .collect();
    ranking.sort_by(|a, b| b.coefficient.total_cmp(&a.coefficient));
    let sorted: Vec<f64> = ranking.iter().map(|r| r.coefficient).collect();
    let n_key = key_count(&sorted, share);
    ComponentRanking {
        key_errors: ranking[..n_key].iter().map(|r| r.error.clone()).collect(),
        covered: sorted[..n_key].iter().sum(),
        ranking,
    }
}

/// C_i = S_i / Σ S_j; all zero when every S_i is zero.
pub fn normalise(s: &[f64]) -> Vec<f64> {
    let total: f64 = s.iter().sum();
    if total > 0.0 {
        s.iter().map(|v| v / total).collect()
    } else {
        vec![0.0; s.len()]
    }
}

/// The number of leading coefficients (sorted decreasing) whose sum reaches `share`;
/// zero when all are zero. A tolerance of 1e-12 absorbs rounding in the running sum.
pub fn key_count(sorted: &[f64], share: f64) -> usize {
    if sorted.iter().all(|&v| v == 0.0) {
        return 0;
    }
    let mut acc = 0.0;
    for (i, v) in sorted.iter().enumerate() {
        acc += v;
        if acc >= share - 1e-12 {
            return i + 1;
        }
    }
    sorted.len()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn key_count_takes_the_fewest_reaching_the_share() {
        assert_eq!(key_count(&[0.5, 0.3, 0.15, 0.05], 0.9), 3);
        assert_eq!(key_count(&[0.5, 0.4, 0.1], 0.9), 2);
        assert_eq!(key_count(&[0.0, 0.0], 0.9), 0);
        assert_eq!(key_count(&[1.0], 1.0), 1);
    }

    #[test]
    fn grid_poses_enumerate_first_axis_slowest() {
        let p = Poses::Grid(vec![
            GridAxis {
                min: 0.0,
                max: 10.0,
                n: 2,
            },
            GridAxis {
                min: 1.0,
                max: 3.0,
                n: 3,
            },
        ]);
        assert_eq!(p.len(), 6);
        let mut q = Vec::new();
        p.pose(4, &mut q);
        assert_eq!(q, vec![10.0, 2.0]);
        assert_eq!(p.subsample(3).len(), 3);
        assert_eq!(p.subsample(100).len(), 6);
    }
}
