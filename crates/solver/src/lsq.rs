//! Large linear least squares without normal equations.
//!
//! [`QrAccumulator`] reduces a tall system [A | b] (millions of rows, tens of columns)
//! block by block with Householder QR (faer): after each block, the stack
//! [R; A_block] is factorised again and only its triangular factor kept (TSQR). At the
//! end R (k × k), Qᵀb and the residual norm ‖b − A x̂‖ are exactly those of one QR of
//! the whole system, with O(block × k) memory and 2·n·k² flops.
//!
//! [`solve`] then scales the columns of R to unit norm (column norms of A equal those of
//! R), takes its SVD, decides the numerical rank, and returns the minimum-norm solution
//! in the scaled coordinates, the covariance σ̂²·V Σ⁻² Vᵀ, and the null space — from
//! which the observability module reads which parameters the data determine.

use faer::Mat;

/// Streaming QR reduction of [A | b].
pub struct QrAccumulator {
    k: usize,
    /// Current triangular factor of [A | b] so far ((k+1) × (k+1) once full).
    r: Mat<f64>,
    r_rows: usize,
    block: Mat<f64>,
    block_rows: usize,
    rows: usize,
}

/// The reduced problem: min ‖R x − qtb‖ plus a constant residual.
#[derive(Debug, Clone)]
pub struct Reduced {
    /// Upper-triangular k × k factor (rows beyond the data count are zero).
    pub r: Mat<f64>,
    /// First k entries of Qᵀb.
    pub qtb: Vec<f64>,
    /// ‖b‖² outside the column space of A: the residual sum of squares of the LS fit.
    pub rss: f64,
    /// Number of rows pushed.
    pub rows: usize,
}

const BLOCK_ROWS: usize = 4096;

impl QrAccumulator {
    /// A reduction for `k` unknowns.
    pub fn new(k: usize) -> QrAccumulator {
        QrAccumulator {
            k,
            r: Mat::zeros(0, k + 1),
            r_rows: 0,
            block: Mat::zeros(BLOCK_ROWS, k + 1),
            block_rows: 0,
            rows: 0,
        }
    }

    pub fn unknowns(&self) -> usize {
        self.k
    }

    /// Appends one row a (length k) with right-hand side b.
    pub fn push(&mut self, a: &[f64], b: f64) {
        debug_assert_eq!(a.len(), self.k);
        let i = self.block_rows;
        for (j, &v) in a.iter().enumerate() {
            self.block[(i, j)] = v;
        }
        self.block[(i, self.k)] = b;
        self.block_rows += 1;
        self.rows += 1;
        if self.block_rows == BLOCK_ROWS {
            self.flush();
        }
    }

    /// Appends a row that already summarises several observations (an exact reduction
    /// of a block); it does not count as an observation.
    pub fn push_reduced(&mut self, a: &[f64], b: f64) {
        self.push(a, b);
        self.rows -= 1;
    }

    /// Counts `n` observations represented by rows given to [`Self::push_reduced`].
    pub fn count_observations(&mut self, n: usize) {
        self.rows += n;
    }

    fn flush(&mut self) {
        if self.block_rows == 0 {
            return;
        }
        let n = self.r_rows + self.block_rows;
        let mut stack = Mat::<f64>::zeros(n, self.k + 1);
        for j in 0..=self.k {
            for i in 0..self.r_rows {
                stack[(i, j)] = self.r[(i, j)];
            }
            for i in 0..self.block_rows {
                stack[(self.r_rows + i, j)] = self.block[(i, j)];
            }
        }
        let qr = stack.qr();
        crate::upper_state::clear();
        let r = qr.thin_R();
        self.r_rows = r.nrows();
        self.r = r.to_owned();
        self.block_rows = 0;
    }

    /// The reduction of the rows pushed so far, leaving the accumulator open for more
    /// (prefix problems, e.g. rolling-origin cross-validation, in one pass).
    pub fn snapshot(&mut self) -> Reduced {
        self.flush();
        self.reduced()
    }

    /// Finishes the reduction.
    pub fn finish(mut self) -> Reduced {
        self.flush();
        self.reduced()
    }

    fn reduced(&self) -> Reduced {
        let k = self.k;
        let mut r = Mat::<f64>::zeros(k, k);
        let mut qtb = vec![0.0; k];
        for i in 0..self.r_rows.min(k) {
            for j in i..k {
                r[(i, j)] = self.r[(i, j)];
            }
            qtb[i] = self.r[(i, k)];
        }
        let rss = if self.r_rows > k {
            self.r[(k, k)].powi(2)
        } else {
            0.0
        };
        Reduced {
            r,
            qtb,
            rss,
            rows: self.rows,
        }
    }
}

/// Solution of a reduced least-squares problem.
#[derive(Debug, Clone)]
pub struct LsSolution {
    /// Minimum-norm solution (in the scaled coordinates), mapped back to the original
    /// parameters.
    pub x: Vec<f64>,
    /// Covariance of x (original parameters), σ̂² · D⁻¹ V_r Σ_r⁻² V_rᵀ D⁻¹.
    pub cov: Mat<f64>,
    /// Singular values of the column-scaled R, descending.
    pub singular_values: Vec<f64>,
    pub rank: usize,
    /// Basis of the null space in the scaled coordinates (k × (k − rank)); a
    /// parameter j is determined by the data iff row j of it is zero.
    pub null_space: Mat<f64>,
    /// Column norms of A (the scaling D).
    pub column_norms: Vec<f64>,
    /// Residual variance σ̂² = RSS / (rows − rank − extra_dof).
    pub sigma2: f64,
    pub rss: f64,
    pub dof: f64,
}

/// Relative singular-value threshold for the numerical rank of a column-scaled system.
pub const RANK_RTOL: f64 = 1e-9;

/// Solves the reduced problem. `extra_dof` counts parameters eliminated before the
/// reduction (e.g. per-run offsets removed by centring), for σ̂².
pub fn solve(red: &Reduced, extra_dof: usize) -> LsSolution {
    let k = red.r.ncols();
    let (rs, norms) = scaled_columns(red, 0..k);
    let svd = rs.svd().expect("SVD of a small dense matrix converges");
    crate::upper_state::clear();
    let s: Vec<f64> = (0..k).map(|i| svd.S().column_vector()[i]).collect();
    let smax = s.first().copied().unwrap_or(0.0);
    let rank = s
        .iter()
        .filter(|&&v| v > smax * RANK_RTOL && v > 0.0)
        .count();
    let u = svd.U();
    let v = svd.V();
    // y = V_r Σ_r⁻¹ U_rᵀ qtb in scaled coordinates.
    let mut y = vec![0.0; k];
    for c in 0..rank {
        let coef = (0..k).map(|i| u[(i, c)] * red.qtb[i]).sum::<f64>() / s[c];
        for (j, yj) in y.iter_mut().enumerate() {
            *yj += v[(j, c)] * coef;
        }
    }
    // RSS: outside-column-space part plus the part of qtb not reached by the rank-r fit.
    let mut rss = red.rss;
    for c in rank..k {
        let p = (0..k).map(|i| u[(i, c)] * red.qtb[i]).sum::<f64>();
        rss += p * p;
    }
    let dof = (red.rows as f64 - rank as f64 - extra_dof as f64).max(1.0);
    let sigma2 = rss / dof;
    let cov = Mat::<f64>::from_fn(k, k, |a, b| {
        let mut acc = 0.0;
        for c in 0..rank {
            acc += v[(a, c)] * v[(b, c)] / (s[c] * s[c]);
        }
        sigma2 * acc / (norms[a] * norms[b])
    });
    let null_space = Mat::<f64>::from_fn(k, k - rank, |i, c| v[(i, rank + c)]);
    LsSolution {
        x: (0..k).map(|j| y[j] / norms[j]).collect(),
        cov,
        singular_values: s,
        rank,
        null_space,
        column_norms: norms,
        sigma2,
        rss,
        dof,
    }
}

/// Columns `cols` of R scaled to unit norm (a zero column is left as it is), and the
/// norms: the column norms of A, since QR preserves them.
fn scaled_columns(red: &Reduced, cols: std::ops::Range<usize>) -> (Mat<f64>, Vec<f64>) {
    let k = red.r.nrows();
    let norms: Vec<f64> = cols
        .clone()
        .map(|j| {
            let n = (0..k).map(|i| red.r[(i, j)].powi(2)).sum::<f64>().sqrt();
            if n > 0.0 { n } else { 1.0 }
        })
        .collect();
    let m = Mat::<f64>::from_fn(k, cols.len(), |i, j| red.r[(i, cols.start + j)] / norms[j]);
    (m, norms)
}

/// Rank of the columns `cols` of the reduced problem (column-scaled), with the same
/// threshold as [`solve`].
pub fn block_rank(red: &Reduced, cols: std::ops::Range<usize>) -> usize {
    let k = red.r.nrows();
    let n = cols.len();
    if n == 0 {
        return 0;
    }
    let (m, _) = scaled_columns(red, cols);
    let svd = m.thin_svd().expect("SVD converges");
    crate::upper_state::clear();
    let s: Vec<f64> = (0..n.min(k)).map(|i| svd.S().column_vector()[i]).collect();
    let smax = s.first().copied().unwrap_or(0.0);
    s.iter()
        .filter(|&&v| v > smax * RANK_RTOL && v > 0.0)
        .count()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// The streamed reduction gives the same solution as a dense solve of a textbook
    /// problem (straight line fit with known closed form), across block boundaries.
    #[test]
    fn streamed_qr_matches_closed_form_line_fit() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(7);
        let n = 3 * BLOCK_ROWS + 17;
        let mut acc = QrAccumulator::new(2);
        let (mut sx, mut sy, mut sxx, mut sxy) = (0.0, 0.0, 0.0, 0.0);
        let mut ys = Vec::new();
        let mut xs = Vec::new();
        for i in 0..n {
            let x = i as f64 / n as f64 * 10.0 - 3.0;
            let y = 2.5 - 0.7 * x + rng.random_range(-0.1..0.1);
            acc.push(&[1.0, x], y);
            sx += x;
            sy += y;
            sxx += x * x;
            sxy += x * y;
            xs.push(x);
            ys.push(y);
        }
        let nf = n as f64;
        let slope = (nf * sxy - sx * sy) / (nf * sxx - sx * sx);
        let icpt = (sy - slope * sx) / nf;
        let sol = solve(&acc.finish(), 0);
        assert_eq!(sol.rank, 2);
        assert!((sol.x[0] - icpt).abs() < 1e-10, "{} vs {}", sol.x[0], icpt);
        assert!((sol.x[1] - slope).abs() < 1e-10);
        let rss: f64 = xs
            .iter()
            .zip(&ys)
            .map(|(x, y)| (y - icpt - slope * x).powi(2))
            .sum();
        assert!((sol.rss - rss).abs() < 1e-8 * rss.max(1.0));
        // Textbook slope variance: σ² / Σ(x − x̄)².
        let sxx_c = sxx - sx * sx / nf;
        let want = sol.sigma2 / sxx_c;
        assert!((sol.cov[(1, 1)] - want).abs() < 1e-9 * want);
    }

    /// A duplicated column is rank deficient: the null space points along the difference.
    #[test]
    fn rank_deficiency_is_reported_with_its_null_space() {
        let mut acc = QrAccumulator::new(3);
        for i in 0..100 {
            let x = i as f64 * 0.1;
            acc.push(&[1.0, x, 2.0 * x], 1.0 + x);
        }
        let red = acc.finish();
        let sol = solve(&red, 0);
        assert_eq!(sol.rank, 2);
        assert!(sol.null_space[(0, 0)].abs() < 1e-9);
        assert!(sol.null_space[(1, 0)].abs() > 0.5);
        assert_eq!(block_rank(&red, 1..3), 1);
        assert_eq!(block_rank(&red, 0..2), 2);
        // Minimum-norm: x1 + 2 x2 = 1 with x1 = x2/… split by the scaled norm.
        assert!((sol.x[1] + 2.0 * sol.x[2] - 1.0).abs() < 1e-9);
    }
}
