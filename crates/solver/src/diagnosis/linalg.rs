//! Least squares for the diagnosis of sessions: an orthonormal basis of the rigid model's
//! column space (faer thin QR, then the SVD of the small R factor for the rank, the one
//! dense kernel's [`basis`]), and projections of candidate effect columns onto its
//! complement.
//!
//! With A = Q·R and R = U·Σ·Vᵀ (rank r after truncation at `RANK_TOL`·σ₁), W = Q·U_r is an
//! orthonormal basis of col(A) and A⁺ = V_r·Σ_r⁻¹·Wᵀ. A candidate's extra columns B are
//! fitted jointly with the rigid model by Frisch–Waugh: c = argmin ‖(I − WWᵀ)(y − B c)‖,
//! x_A = A⁺(y − B c). Normal matrices are never formed.

use super::lsq::{Basis, RANK_TOL, basis};
use nalgebra::{DMatrix, DVector};

/// Column-major dense matrix as a list of columns.
pub type Cols = Vec<Vec<f64>>;

/// Runs the kernel `op` compiled for the widest vector instructions the CPU has (AVX2 on
/// x86-64, chosen at run time by pulp's dispatch, without unsafe code; the plain build
/// elsewhere). A kernel is built wide where it is inlined: `op.with_simd` and what it
/// calls are `#[inline(always)]` (a closure, pulp's `NullaryFnOnce`, may stay a call of
/// its own when large). The kernels run this way do the same operations in the same
/// order on each lane whatever the vector width (Rust never fuses a multiply and an
/// add), so their values do not depend on the machine.
#[inline(always)]
pub fn wide<Op: pulp::WithSimd>(op: Op) -> Op::Output {
    pulp::Arch::new().dispatch(op)
}

#[inline]
pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// a·b summed in eight interleaved lanes (element i into lane i mod 8), the lanes then
/// added pairwise: the same value as [`dot`] to rounding, without its chain of
/// dependent additions (the lanes vectorise).
#[inline(always)]
pub fn dot_lanes(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut acc = [0.0; 8];
    let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for k in 0..8 {
            acc[k] += x[k] * y[k];
        }
    }
    for (k, (x, y)) in ra.iter().zip(rb).enumerate() {
        acc[k] += x * y;
    }
    let [a0, a1, a2, a3, a4, a5, a6, a7] = acc;
    ((a0 + a4) + (a2 + a6)) + ((a1 + a5) + (a3 + a7))
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
        let Basis { w: wm, r: f } = basis(&faer::Mat::<f64>::from_fn(n, k, get), RANK_TOL);
        let (keep, rank) = (&f.keep, f.rank());
        let w = (0..rank)
            .map(|j| (0..n).map(|i| wm[(i, j)]).collect())
            .collect();
        let v_sinv = DMatrix::from_fn(k, rank, |i, j| f.vt[(keep[j], i)] / f.s[keep[j]]);
        let condition = f.condition();
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Hand-worked sums over 19 elements (two full groups of eight and a remainder of
    /// three): Σ i = 190, Σ i² = 19·20·39/6 = 2470; a shorter second vector bounds the sum.
    #[test]
    fn dot_lanes_by_hand() {
        let a: Vec<f64> = (1..=19).map(f64::from).collect();
        assert_eq!(dot_lanes(&a, &[1.0; 19]), 190.0);
        assert_eq!(dot_lanes(&a, &a), 2470.0);
        assert_eq!(dot_lanes(&a, &[1.0; 5]), 15.0);
        assert_eq!(dot_lanes(&[], &a), 0.0);
    }
}
