//! The one dense least-squares kernel of the diagnosis (positioning runs, drift logs, the
//! engine's fits, and the orthonormal bases of sessions: `linalg::Projector` and the
//! dense per-run reduction of `diagnosis::reduced`, both by [`basis`]):
//! min ‖y − X b‖₂ for a tall X with few columns, never through the normal matrix.
//!
//! Columns are scaled to unit norm (D = diag of the column norms); a thin Householder QR
//! (faer) of [X D⁻¹ | y] gives the triangle [[R, Qᵀy], [0, ρ]]; the SVD R = U Σ Vᵀ
//! ([`RSvd`]) keeps the singular values above `RANK_TOL`·σ₁ (rank r). Then
//! b = D⁻¹ V_r Σ_r⁻¹ U_rᵀ Qᵀy (the minimum-norm solution),
//! cov(b) = s² D⁻¹ V_r Σ_r⁻² V_rᵀ D⁻¹ with s² = SSE/(n − r), and cond = σ₁/σ_r of X D⁻¹
//! (∞ when r < number of columns). Golub & Van Loan, Matrix Computations, §5.5.

use nalgebra::{DMatrix, DVector};

/// Relative threshold of the numerical rank: singular values ≤ `RANK_TOL`·σ₁ are dropped.
pub const RANK_TOL: f64 = 1e-9;

/// A design matrix built column by column (each column has one value per observation).
#[derive(Debug, Clone, Default)]
pub struct Design {
    pub names: Vec<String>,
    pub cols: Vec<Vec<f64>>,
}

impl Design {
    pub fn new() -> Design {
        Design::default()
    }
    pub fn push(&mut self, name: impl Into<String>, col: Vec<f64>) {
        self.names.push(name.into());
        self.cols.push(col);
    }
    pub fn len(&self) -> usize {
        self.cols.len()
    }
    pub fn is_empty(&self) -> bool {
        self.cols.is_empty()
    }
    /// The design restricted to the rows `rows`.
    pub fn rows(&self, rows: &[usize]) -> Design {
        Design {
            names: self.names.clone(),
            cols: self
                .cols
                .iter()
                .map(|c| rows.iter().map(|&i| c[i]).collect())
                .collect(),
        }
    }
    /// Prediction X b at every row.
    pub fn predict(&self, b: &[f64]) -> Vec<f64> {
        let n = self.cols.first().map_or(0, Vec::len);
        let mut out = vec![0.0; n];
        for (c, &bj) in self.cols.iter().zip(b) {
            for (o, &v) in out.iter_mut().zip(c) {
                *o += bj * v;
            }
        }
        out
    }
}

/// The SVD R = U Σ Vᵀ of a small factor (the R of a thin QR) and its numerical rank.
pub struct RSvd {
    pub u: DMatrix<f64>,
    pub s: DVector<f64>,
    pub vt: DMatrix<f64>,
    /// Indices of the singular values above `RANK_TOL`·σ₁, largest first.
    pub keep: Vec<usize>,
}

impl RSvd {
    /// The SVD of `r` with the rank at `RANK_TOL`.
    pub fn new(r: DMatrix<f64>) -> RSvd {
        RSvd::with_tol(r, RANK_TOL)
    }

    /// The SVD of `r`, keeping the singular values above `tol`·σ₁.
    pub fn with_tol(r: DMatrix<f64>, tol: f64) -> RSvd {
        let svd = r.svd(true, true);
        let (u, vt) = (svd.u.expect("u requested"), svd.v_t.expect("v requested"));
        let s = svd.singular_values;
        let mut order: Vec<usize> = (0..s.len()).collect();
        order.sort_by(|&i, &j| s[j].total_cmp(&s[i]));
        let s1 = order.first().map_or(0.0, |&i| s[i]);
        let keep = order
            .into_iter()
            .filter(|&i| s[i] > tol * s1 && s[i] > 0.0)
            .collect();
        RSvd { u, s, vt, keep }
    }

    pub fn rank(&self) -> usize {
        self.keep.len()
    }

    /// σ₁/σ_r over the kept singular values (1 without any).
    pub fn condition(&self) -> f64 {
        match (self.keep.first(), self.keep.last()) {
            (Some(&a), Some(&b)) => self.s[a] / self.s[b],
            _ => 1.0,
        }
    }
}

/// An orthonormal basis of the column space of A (n × k): A = Q R (thin QR, faer),
/// R = U Σ Vᵀ ([`RSvd`], rank r at `tol`), W = Q U_r (n × r), so that A = W Σ_r V_rᵀ.
pub struct Basis {
    pub w: faer::Mat<f64>,
    pub r: RSvd,
}

/// The [`Basis`] of `a`, singular values above `tol`·σ₁ kept.
pub fn basis(a: &faer::Mat<f64>, tol: f64) -> Basis {
    let (n, k) = (a.nrows(), a.ncols());
    let qr = a.qr();
    let q = qr.compute_thin_Q();
    let kk = k.min(n);
    let rf = qr.thin_R();
    let r = RSvd::with_tol(
        DMatrix::from_fn(kk, k, |i, j| if j >= i { rf[(i, j)] } else { 0.0 }),
        tol,
    );
    let uf = faer::Mat::<f64>::from_fn(kk, r.rank(), |i, j| r.u[(i, r.keep[j])]);
    let w = &q * &uf;
    crate::upper_state::clear();
    Basis { w, r }
}

/// Result of one least-squares solve.
#[derive(Debug, Clone)]
pub struct LsqFit {
    pub coef: Vec<f64>,
    /// Standard uncertainties of the coefficients (s √diag of the unscaled covariance).
    pub std: Vec<f64>,
    pub sse: f64,
    pub n: usize,
    pub rank: usize,
    /// 2-norm condition number of the equilibrated design.
    pub cond: f64,
    /// Covariance of the coefficients, s² D⁻¹ V_r Σ_r⁻² V_rᵀ D⁻¹ (p × p).
    pub cov: DMatrix<f64>,
}

impl LsqFit {
    /// Residual variance s² = SSE/(n − rank).
    pub fn s2(&self) -> f64 {
        self.sse / (self.n.saturating_sub(self.rank)).max(1) as f64
    }
}

/// Solves min ‖y − X b‖ (see the module docs). A design with no columns fits nothing.
pub fn solve(x: &Design, y: &[f64]) -> LsqFit {
    let n = y.len();
    let p = x.len();
    if p == 0 || n == 0 {
        return LsqFit {
            coef: vec![0.0; p],
            std: vec![f64::INFINITY; p],
            sse: y.iter().map(|v| v * v).sum(),
            n,
            rank: 0,
            cond: if p == 0 { 1.0 } else { f64::INFINITY },
            cov: DMatrix::from_element(p, p, f64::INFINITY),
        };
    }
    let norms: Vec<f64> = x
        .cols
        .iter()
        .map(|c| {
            let s = c.iter().map(|v| v * v).sum::<f64>().sqrt();
            if s > 0.0 { s } else { 1.0 }
        })
        .collect();
    let m = faer::Mat::<f64>::from_fn(
        n,
        p + 1,
        |i, j| {
            if j < p { x.cols[j][i] / norms[j] } else { y[i] }
        },
    );
    let qr = m.qr();
    crate::upper_state::clear();
    let r = qr.thin_R();
    let kk = r.nrows().min(p);
    let f = RSvd::new(DMatrix::from_fn(p, p, |i, j| {
        if i < kk && j >= i { r[(i, j)] } else { 0.0 }
    }));
    let qty = DVector::from_fn(p, |i, _| if i < kk { r[(i, p)] } else { 0.0 });
    let uty = f.u.transpose() * qty;
    let mut bs = DVector::zeros(p);
    for &k in &f.keep {
        bs += f.vt.row(k).transpose() * (uty[k] / f.s[k]);
    }
    let coef: Vec<f64> = (0..p).map(|j| bs[j] / norms[j]).collect();
    let sse: f64 = y
        .iter()
        .zip(x.predict(&coef))
        .map(|(a, b)| (a - b) * (a - b))
        .sum();
    let rank = f.rank();
    let s2 = sse / (n.saturating_sub(rank)).max(1) as f64;
    let cov = DMatrix::from_fn(p, p, |i, j| {
        let v: f64 = f
            .keep
            .iter()
            .map(|&k| f.vt[(k, i)] * f.vt[(k, j)] / (f.s[k] * f.s[k]))
            .sum();
        s2 * v / (norms[i] * norms[j])
    });
    let std = (0..p).map(|j| cov[(j, j)].sqrt()).collect();
    LsqFit {
        coef,
        std,
        sse,
        n,
        rank,
        cond: if rank < p {
            f64::INFINITY
        } else {
            f.condition()
        },
        cov,
    }
}

/// Sum of squared residuals only (same solve; convenience for searches).
pub fn sse(x: &Design, y: &[f64]) -> f64 {
    solve(x, y).sse
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against a fit worked by hand: y = 2 + 3x at x = 0, 1, 2, 3 plus residuals
    /// (+1, −1, −1, +1) orthogonal to both columns: SSE = 4, s² = 4/(4 − 2) = 2 and
    /// (XᵀX)⁻¹ = [[7, −3], [−3, 2]]/10, so std = √(2·0.7), √(2·0.2).
    #[test]
    fn solve_by_hand() {
        let mut d = Design::new();
        d.push("1", vec![1.0; 4]);
        d.push("x", vec![0.0, 1.0, 2.0, 3.0]);
        let f = solve(&d, &[3.0, 4.0, 7.0, 12.0]);
        assert!((f.coef[0] - 2.0).abs() < 1e-12, "{:?}", f.coef);
        assert!((f.coef[1] - 3.0).abs() < 1e-12, "{:?}", f.coef);
        assert!((f.sse - 4.0).abs() < 1e-12, "{}", f.sse);
        assert!((f.std[0] - 1.4f64.sqrt()).abs() < 1e-12, "{:?}", f.std);
        assert!((f.std[1] - 0.4f64.sqrt()).abs() < 1e-12, "{:?}", f.std);
    }
}
