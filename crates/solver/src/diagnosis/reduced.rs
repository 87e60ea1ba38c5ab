//! Exact per-run reduction of the rigid model for the session diagnosis.
//!
//! A run's rigid columns A_g (its rows of the 21-term model and plate rotations, centred
//! per run and reading direction) lie in a space of small dimension: along a line every
//! column is a polynomial of degree ≤ N + 1 in the moving coordinate, around a circle a
//! trigonometric polynomial of degree ≤ N + 1 in the angle. Identification's
//! [`RunInterpolant`] gives A_g = Φ_g P_g exactly (Φ_g the run's basis functions at its
//! samples, P_g from interpolation at m nodes, one per reading direction). With the
//! centred basis Φ_c = Q_Φ R (thin QR, the constant column dropped: centring removes
//! it), each direction's block is A_c = Q_Φ (R P), so Q_g = diag(Q_Φ, Q_Φ) is an
//! orthonormal basis of a space V_g ⊇ col(A_g) and Ã_g = Q_gᵀ A_g = [R P_u; R P_v] —
//! the exact reduced block, found at O(n_g m²) without forming A_g. Runs that are not a
//! line or a circle path (or too short for the interpolant) are reduced from their dense
//! rows: a thin QR of A_g, an SVD of its R factor, singular values below 10⁻¹² of the
//! largest dropped (exact structure, not a truncation).
//!
//! Since col(A) ⊂ V = ⊕ V_g, the projection of any column b onto the rigid model is
//! P_A b = Q P_Ã (Qᵀ b): the large problem (2 rows per sample, ≈ 55 columns) becomes one
//! of Σ r_g reduced rows, and every fit of the diagnosis is assembled from per-run
//! moments (`diagnosis::moments`).

use super::design::Design;
use super::linalg::Cols;
use super::lsq::{Basis, basis};
use crate::design::{Layout, RunInterpolant};
use crate::session::Session;
use nalgebra::DMatrix;

/// One run's orthonormal basis Q_g of a space holding its rigid columns.
pub struct RunSpace {
    /// First row (2 × first sample) and number of rows of the run.
    pub row0: usize,
    pub rows: usize,
    /// Basis values by reading direction and column: direction c's block holds, column
    /// after column, the w values of its rows (rows c, c + 2, …, one per sample). One
    /// block shared by both directions (`shared`: Q_g = diag(Q_Φ, Q_Φ), direction c at
    /// offset c·w of the reduced coordinates), or one block per direction (offset 0).
    q: Vec<f64>,
    /// Width of one basis row.
    w: usize,
    shared: bool,
    /// Dimension r_g of the run's reduced block.
    pub r: usize,
    /// Offset of the run's block in the reduced coordinates.
    pub red0: usize,
}

impl RunSpace {
    /// Width w of a row's basis values.
    #[inline]
    pub fn width(&self) -> usize {
        self.w
    }

    /// Reading direction `c`'s basis block (w columns of rows/2 values, its rows in
    /// order) and its offset in the run's reduced coordinates.
    #[inline]
    pub fn direction(&self, c: usize) -> (usize, &[f64]) {
        let len = self.w * (self.rows / 2);
        if self.shared {
            (c * self.w, &self.q[..len])
        } else {
            (0, &self.q[c * len..(c + 1) * len])
        }
    }

    /// Offset in the run's reduced coordinates of row `i` (counted from the run's first
    /// row), with its basis values written to `out` (w values): Q_g[i, off..off + w] =
    /// `out`, 0 elsewhere.
    #[inline]
    pub fn row_into(&self, i: usize, out: &mut [f64]) -> usize {
        let (off, block) = self.direction(i & 1);
        let (k, s) = (self.rows / 2, i / 2);
        for (t, o) in out[..self.w].iter_mut().enumerate() {
            *o = block[t * k + s];
        }
        off
    }
}

/// The reduction of every run (module documentation).
pub struct Reduction {
    pub runs: Vec<RunSpace>,
    /// Ã: the k rigid columns in reduced coordinates (length Σ r_g each), each divided by
    /// its norm over the centred rows (`scale`).
    pub a: Cols,
    /// Norm of each rigid column (centred per run and direction) over all rows.
    pub scale: Vec<f64>,
    /// Σ r_g.
    pub dim: usize,
    /// Rows of the full problem (2 per sample).
    pub n: usize,
}

impl Reduction {
    /// Reduces the rigid model of `d` (built from `session`) run by run. The columns are
    /// the error parameters of `d.model`, then one plate rotation per mounting (sorted by
    /// name): du = +v·10⁻³, dv = −u·10⁻³ per µrad, the point being position plus head
    /// offset.
    pub fn new(session: &Session, d: &Design) -> Reduction {
        let n_err = d.model.len();
        let layout = Layout::new(session, n_err, 0);
        let mut sorted = layout.mountings.clone();
        sorted.sort();
        // Column of the diagnosis for each column of identification's layout
        // (rotations of the mountings in order of appearance, then the errors).
        let col_of: Vec<usize> = layout
            .mountings
            .iter()
            .map(|m| n_err + sorted.iter().position(|x| x == m).unwrap_or(0))
            .chain(0..n_err)
            .collect();
        let k = n_err + sorted.len();
        let mut runs = Vec::with_capacity(d.runs.len());
        let mut blocks: Vec<DMatrix<f64>> = Vec::with_capacity(d.runs.len());
        let mut red0 = 0;
        let mut g = 0;
        for (p, plane) in session.planes.iter().enumerate() {
            let rot = col_of[layout.plane_mounting[p]];
            for r in 0..plane.runs.len() {
                let info = &d.runs[g];
                g += 1;
                let (mut space, block) = match RunInterpolant::new(session, &d.model, &layout, p, r)
                {
                    Some(it) => interpolated(d, info.start, info.end, &it, &col_of, k),
                    None => dense(d, info.start, info.end, rot, k),
                };
                space.red0 = red0;
                red0 += space.r;
                runs.push(space);
                blocks.push(block);
            }
        }
        let dim = red0;
        let mut scale = vec![0.0; k];
        for b in &blocks {
            for (j, s) in scale.iter_mut().enumerate() {
                *s += b.column(j).norm_squared();
            }
        }
        for s in scale.iter_mut() {
            *s = if *s > 0.0 { s.sqrt() } else { 1.0 };
        }
        let mut a = vec![vec![0.0; dim]; k];
        for (rs, b) in runs.iter().zip(&blocks) {
            for (j, col) in a.iter_mut().enumerate() {
                for c in 0..rs.r {
                    col[rs.red0 + c] = b[(c, j)] / scale[j];
                }
            }
        }
        Reduction {
            runs,
            a,
            scale,
            dim,
            n: d.rows(),
        }
    }

    /// Ã_g a: the rigid model's prediction on run `g` in its reduced coordinates.
    pub fn predict_reduced(&self, g: usize, a: &[f64]) -> Vec<f64> {
        let rs = &self.runs[g];
        (0..rs.r)
            .map(|c| {
                self.a
                    .iter()
                    .zip(a)
                    .map(|(col, x)| col[rs.red0 + c] * x)
                    .sum()
            })
            .collect()
    }
}

/// The reduction of a line or circle run from its interpolant (module documentation).
fn interpolated(
    d: &Design,
    start: usize,
    end: usize,
    it: &RunInterpolant,
    col_of: &[usize],
    k: usize,
) -> (RunSpace, DMatrix<f64>) {
    let n = end - start;
    let m = it.m;
    let w = m - 1;
    let mut phi = vec![0.0; m];
    let mut fm = faer::Mat::<f64>::zeros(n, w);
    let mut mean = vec![0.0; w];
    for i in 0..n {
        it.basis_at_q(&d.fields.q(start + i), &mut phi);
        for j in 0..w {
            fm[(i, j)] = phi[j + 1];
            mean[j] += phi[j + 1];
        }
    }
    for (j, mu) in mean.iter().enumerate() {
        let mu = mu / n as f64;
        for v in fm.col_mut(j).iter_mut() {
            *v -= mu;
        }
    }
    let qr = fm.qr();
    let qm = qr.compute_thin_Q();
    crate::upper_state::clear();
    let rr = qr.thin_R();
    let mut q = vec![0.0; n * w];
    for j in 0..w {
        for i in 0..n {
            q[j * n + i] = qm[(i, j)];
        }
    }
    let mut block = DMatrix::zeros(2 * w, k);
    for (comp, pm) in it.pms.iter().enumerate() {
        for i in 0..w {
            for (idc, &dc) in col_of.iter().enumerate() {
                let v: f64 = (i..w).map(|j| rr[(i, j)] * pm[(j + 1, idc)]).sum();
                block[(comp * w + i, dc)] += v;
            }
        }
    }
    (
        RunSpace {
            row0: 2 * start,
            rows: 2 * n,
            q,
            w,
            shared: true,
            r: 2 * w,
            red0: 0,
        },
        block,
    )
}

/// The reduction of any run from its dense, centred rigid rows (module documentation).
fn dense(d: &Design, start: usize, end: usize, rot: usize, k: usize) -> (RunSpace, DMatrix<f64>) {
    let n_err = d.model.len();
    let rows = 2 * (end - start);
    let mut m = faer::Mat::<f64>::zeros(rows, k);
    let mut buf = vec![0.0; n_err];
    let run = &d.runs[d.fields.run(start)];
    let (u, v) = d.plane_axes[run.plane_idx];
    let head = run.head_mm;
    for s in start..end {
        let q = d.fields.q(s);
        let pu = q[u.index()] + head[u.index()];
        let pv = q[v.index()] + head[v.index()];
        for (comp, (dir, rv)) in [(u, pv * 1e-3), (v, -pu * 1e-3)].into_iter().enumerate() {
            let i = 2 * (s - start) + comp;
            d.model.error_row(q, head, dir, &mut buf);
            for (j, b) in buf.iter().enumerate() {
                m[(i, j)] = *b;
            }
            m[(i, rot)] = rv;
        }
    }
    for j in 0..k {
        for comp in 0..2 {
            let mean = (comp..rows).step_by(2).map(|i| m[(i, j)]).sum::<f64>() / (rows / 2) as f64;
            for i in (comp..rows).step_by(2) {
                m[(i, j)] -= mean;
            }
        }
    }
    let Basis { w: wm, r: f } = basis(&m, 1e-12);
    let r = f.rank();
    // By reading direction, then column (the direction's rows comp, comp + 2, …).
    let half = rows / 2;
    let mut q = vec![0.0; rows * r];
    for comp in 0..2 {
        for c in 0..r {
            for s in 0..half {
                q[(comp * r + c) * half + s] = wm[(2 * s + comp, c)];
            }
        }
    }
    // Ã_g = Σ_keep Vᵀ (r × k).
    let block = DMatrix::from_fn(r, k, |c, j| f.s[f.keep[c]] * f.vt[(f.keep[c], j)]);
    (
        RunSpace {
            row0: 2 * start,
            rows,
            q,
            w: r,
            shared: false,
            r,
            red0: 0,
        },
        block,
    )
}
