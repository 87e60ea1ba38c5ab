//! Linear least squares for the series diagnoses: min ‖y − X b‖₂ by the SVD of the
//! column-equilibrated design X D⁻¹ (D = diag of column norms), never the normal matrix.
//!
//! b = D⁻¹ V Σ⁺ Uᵀ y; singular values below `1e-10·σ_max` count as rank loss;
//! cov(b) = s² D⁻¹ V Σ⁻² Vᵀ D⁻¹ with s² = SSE/(n − rank); cond = σ_max/σ_min of X D⁻¹.

use nalgebra::{DMatrix, DVector};

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
    if p == 0 {
        return LsqFit {
            coef: vec![],
            std: vec![],
            sse: y.iter().map(|v| v * v).sum(),
            n,
            rank: 0,
            cond: 1.0,
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
    let a = DMatrix::from_fn(n, p, |i, j| x.cols[j][i] / norms[j]);
    let svd = a.svd(true, true);
    let (u, vt) = (svd.u.expect("u"), svd.v_t.expect("v_t"));
    let smax = svd.singular_values.max();
    let tol = 1e-10 * smax.max(1e-300);
    let yv = DVector::from_column_slice(y);
    let uty = u.transpose() * &yv;
    let mut z = DVector::zeros(p);
    let mut rank = 0;
    let mut smin = f64::INFINITY;
    for k in 0..p {
        let s = svd.singular_values[k];
        if s > tol {
            z[k] = uty[k] / s;
            rank += 1;
            smin = smin.min(s);
        }
    }
    let bs = vt.transpose() * z;
    let coef: Vec<f64> = (0..p).map(|j| bs[j] / norms[j]).collect();
    let pred = x.predict(&coef);
    let sse: f64 = y.iter().zip(&pred).map(|(a, b)| (a - b) * (a - b)).sum();
    let s2 = sse / (n.saturating_sub(rank)).max(1) as f64;
    let std = (0..p)
        .map(|j| {
            let mut v = 0.0;
            for k in 0..p {
                let s = svd.singular_values[k];
                if s > tol {
                    v += (vt[(k, j)] / s).powi(2);
                }
            }
            (s2 * v).sqrt() / norms[j]
        })
        .collect();
    let cond = if rank < p { f64::INFINITY } else { smax / smin };
    LsqFit {
        coef,
        std,
        sse,
        n,
        rank,
        cond,
    }
}

/// Sum of squared residuals only (same solve; convenience for searches).
pub fn sse(x: &Design, y: &[f64]) -> f64 {
    solve(x, y).sse
}
