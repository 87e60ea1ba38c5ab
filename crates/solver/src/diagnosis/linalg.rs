//! Least squares for the diagnosis of sessions: an orthonormal basis of the rigid model's
//! column space (faer thin QR, then an SVD of the small R factor for the rank), and
//! projections of candidate effect columns onto its complement.
//!
//! With A = Q·R and R = U·Σ·Vᵀ (rank r after truncation at 1e-9·σ₁), W = Q·U_r is an
//! orthonormal basis of col(A) and A⁺ = V_r·Σ_r⁻¹·Wᵀ. A candidate's extra columns B are
//! fitted jointly with the rigid model by Frisch–Waugh: c = argmin ‖(I − WWᵀ)(y − B c)‖,
//! x_A = A⁺(y − B c). Normal matrices are never formed.

use nalgebra::{DMatrix, DVector};

/// Column-major dense matrix as a list of columns.
pub type Cols = Vec<Vec<f64>>;

pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Orthonormal basis of a column space and the pseudo-inverse factors.
pub struct Projector {
    /// W (n × r), columns.
    pub w: Cols,
    /// V_r·Σ_r⁻¹ (k × r).
    pub v_sinv: DMatrix<f64>,
    pub rank: usize,
    /// σ₁/σ_r of the (column-scaled) matrix.
    pub condition: f64,
}

impl Projector {
    /// Basis of the columns `a` restricted to the rows `rows` (all rows when `None`).
    pub fn new(a: &Cols, rows: Option<&[usize]>) -> Projector {
        let k = a.len();
        let n = rows.map_or_else(|| a.first().map_or(0, Vec::len), <[usize]>::len);
        let get = |i: usize, j: usize| match rows {
            Some(r) => a[j][r[i]],
            None => a[j][i],
        };
        if k == 0 || n == 0 {
            return Projector {
                w: Vec::new(),
                v_sinv: DMatrix::zeros(k, 0),
                rank: 0,
                condition: 1.0,
            };
        }
        let m = faer::Mat::<f64>::from_fn(n, k, get);
        let qr = m.qr();
        let q = qr.compute_thin_Q();
        let kk = k.min(n);
        let r = qr.thin_R();
        let rn = DMatrix::from_fn(kk, k, |i, j| if j >= i { r[(i, j)] } else { 0.0 });
        let svd = rn.svd(true, true);
        let u = svd.u.expect("u requested");
        let vt = svd.v_t.expect("v requested");
        let s = &svd.singular_values;
        let mut order: Vec<usize> = (0..s.len()).collect();
        order.sort_by(|&i, &j| s[j].total_cmp(&s[i]));
        let s1 = s[order[0]];
        let keep: Vec<usize> = order
            .into_iter()
            .filter(|&i| s[i] > 1e-9 * s1 && s[i] > 0.0)
            .collect();
        let rank = keep.len();
        let uf = faer::Mat::<f64>::from_fn(kk, rank, |i, j| u[(i, keep[j])]);
        let wm = &q * &uf;
        let w = (0..rank)
            .map(|j| (0..n).map(|i| wm[(i, j)]).collect())
            .collect();
        let v_sinv = DMatrix::from_fn(k, rank, |i, j| vt[(keep[j], i)] / s[keep[j]]);
        let condition = if rank > 0 {
            s1 / s[keep[rank - 1]]
        } else {
            1.0
        };
        Projector {
            w,
            v_sinv,
            rank,
            condition,
        }
    }

    /// Wᵀ·b.
    pub fn coords(&self, b: &[f64]) -> DVector<f64> {
        DVector::from_iterator(self.w.len(), self.w.iter().map(|wj| dot(wj, b)))
    }

    /// (I − WWᵀ)·b.
    pub fn residual(&self, b: &[f64]) -> Vec<f64> {
        let c = self.coords(b);
        let mut out = b.to_vec();
        for (wj, cj) in self.w.iter().zip(c.iter()) {
            for (o, w) in out.iter_mut().zip(wj) {
                *o -= cj * w;
            }
        }
        out
    }

    /// A⁺·b (coefficients of the scaled columns).
    pub fn solve(&self, b: &[f64]) -> DVector<f64> {
        &self.v_sinv * self.coords(b)
    }
}

/// Small dense least squares min ‖B c − y‖ (B has few columns, many rows): a thin
/// Householder QR of [B | y] (faer) reduces it to the (m + 1)-square triangle, whose
/// leading m × m block R is solved by SVD. Returns the coefficients and their
/// unit-variance standard deviations √diag((BᵀB)⁺) = row norms of V Σ⁻¹ (from R's SVD:
/// BᵀB = RᵀR), or `None` when B has no usable column.
pub fn small_lstsq(b: &Cols, y: &[f64]) -> Option<(DVector<f64>, DVector<f64>)> {
    let m = b.len();
    let n = y.len();
    if m == 0 || n < m {
        return None;
    }
    let bm = faer::Mat::<f64>::from_fn(n, m + 1, |i, j| if j < m { b[j][i] } else { y[i] });
    let qr = bm.qr();
    let r = qr.thin_R();
    let k = r.nrows().min(m);
    let rm = DMatrix::from_fn(m, m, |i, j| if i < k && j >= i { r[(i, j)] } else { 0.0 });
    let qty = DVector::from_fn(m, |i, _| if i < k { r[(i, m)] } else { 0.0 });
    let svd = rm.svd(true, true);
    let s = &svd.singular_values;
    let smax = s.iter().cloned().fold(0.0, f64::max);
    if smax <= 0.0 {
        return None;
    }
    let tol = 1e-9 * smax;
    let c = svd.solve(&qty, tol).ok()?;
    let vt = svd.v_t.as_ref()?;
    let sd = DVector::from_fn(m, |i, _| {
        (0..s.len())
            .filter(|&k| s[k] > tol)
            .map(|k| (vt[(k, i)] / s[k]).powi(2))
            .sum::<f64>()
            .sqrt()
    });
    Some((c, sd))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against a fit worked by hand: y = 2 + 3x at x = 0, 1, 2, 3 plus residuals
    /// (+1, −1, −1, +1) orthogonal to both columns; (BᵀB)⁻¹ = [[7, −3], [−3, 2]]/10.
    #[test]
    fn small_lstsq_by_hand() {
        let b = vec![vec![1.0; 4], vec![0.0, 1.0, 2.0, 3.0]];
        let y = [3.0, 4.0, 7.0, 12.0];
        let (c, sd) = small_lstsq(&b, &y).unwrap();
        assert!(
            (c[0] - 2.0).abs() < 1e-12 && (c[1] - 3.0).abs() < 1e-12,
            "{c}"
        );
        assert!((sd[0] - 0.7f64.sqrt()).abs() < 1e-12, "{sd}");
        assert!((sd[1] - 0.2f64.sqrt()).abs() < 1e-12, "{sd}");
    }
}
