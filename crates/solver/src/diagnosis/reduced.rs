//! Exact per-run reduction of the rigid model for the session diagnosis, and the
//! projections of the greedy loop built on it.
//!
//! A run's rigid columns A_g (its rows of the 21-term model and plate rotations, centred
//! per run and direction) span a space of small dimension r_g: along a line every column
//! is a polynomial of degree ≤ N + 1 in the moving coordinate, around a circle a
//! trigonometric polynomial of degree ≤ N + 1 in the angle (the structure identification's
//! per-run compression uses). One thin QR of A_g and an SVD of its R factor give an
//! orthonormal basis Q_g (n_g × r_g, singular values below 10⁻¹² of the run's largest
//! dropped: exact structure, not a truncation) and the reduced block Ã_g = Q_gᵀ A_g, with
//! A_g = Q_g Ã_g. Since col(A) ⊂ V = ⊕ col(Q_g), the projection onto the rigid model of
//! any column b is P_A b = Q P_Ã (Qᵀ b): the large problem (2 rows per sample, ≈ 55
//! columns) is replaced by one of Σ r_g rows, and a candidate column costs O(n·r_g)
//! instead of O(n·k). No normal matrix is formed: P_Ã comes from the SVD of Ã
//! ([`Projector`]).
//!
//! Accepted effects E enter by Frisch–Waugh: with E_⊥ = (I − P_A)E orthonormalised (Gram–
//! Schmidt, twice), P_[A E] b = P_A b + E_⊥ E_⊥ᵀ b. The held-out folds are sets of whole
//! runs, so a fold's rigid projection is the same reduction on its runs' blocks.

use super::design::Design;
use super::linalg::{Cols, Projector, dot, small_lstsq};
use nalgebra::DVector;

/// One run's orthonormal basis of its rigid columns.
pub struct RunSpace {
    /// First row (2 × first sample) and number of rows of the run.
    pub row0: usize,
    pub rows: usize,
    /// Q_g, column-major (rows × r).
    q: Vec<f64>,
    pub r: usize,
    /// Offset of the run's block in the reduced coordinates.
    pub red0: usize,
}

impl RunSpace {
    fn col(&self, j: usize) -> &[f64] {
        &self.q[j * self.rows..(j + 1) * self.rows]
    }

    /// Q_gᵀ b (b: the full-length column).
    fn coords(&self, b: &[f64]) -> Vec<f64> {
        let bg = &b[self.row0..self.row0 + self.rows];
        (0..self.r).map(|j| dot(self.col(j), bg)).collect()
    }

    /// out[rows of g] −= Q_g c.
    fn sub(&self, c: &[f64], out: &mut [f64]) {
        let o = &mut out[self.row0..self.row0 + self.rows];
        for (j, cj) in c.iter().enumerate() {
            for (v, q) in o.iter_mut().zip(self.col(j)) {
                *v -= cj * q;
            }
        }
    }
}

/// The reduction of every run (module documentation).
pub struct Reduction {
    pub runs: Vec<RunSpace>,
    /// Ã: the k rigid columns in reduced coordinates (length Σ r_g each).
    pub a: Cols,
    /// Σ r_g.
    pub dim: usize,
    /// Rows of the full problem (2 per sample).
    pub n: usize,
}

impl Reduction {
    /// Reduces the rigid columns `d.a` run by run.
    pub fn new(d: &Design) -> Reduction {
        let k = d.a.len();
        let mut runs = Vec::with_capacity(d.runs.len());
        let mut blocks: Vec<nalgebra::DMatrix<f64>> = Vec::with_capacity(d.runs.len());
        let mut red0 = 0;
        for run in &d.runs {
            let (row0, rows) = (2 * run.start, 2 * (run.end - run.start));
            let m = faer::Mat::<f64>::from_fn(rows, k, |i, j| d.a[j][row0 + i]);
            let qr = m.qr();
            let q = qr.compute_thin_Q();
            let kk = rows.min(k);
            let rf = qr.thin_R();
            let rn =
                nalgebra::DMatrix::from_fn(kk, k, |i, j| if j >= i { rf[(i, j)] } else { 0.0 });
            let svd = rn.svd(true, true);
            let (u, vt) = (svd.u.expect("u"), svd.v_t.expect("v_t"));
            let s = &svd.singular_values;
            let smax = s.iter().copied().fold(0.0, f64::max);
            let keep: Vec<usize> = (0..s.len()).filter(|&i| s[i] > 1e-12 * smax).collect();
            let r = keep.len();
            let mut qg = vec![0.0; rows * r];
            for (c, &ki) in keep.iter().enumerate() {
                for l in 0..kk {
                    let ul = u[(l, ki)];
                    if ul == 0.0 {
                        continue;
                    }
                    for i in 0..rows {
                        qg[c * rows + i] += q[(i, l)] * ul;
                    }
                }
            }
            // Ã_g = Σ_keep Vᵀ (r × k).
            blocks.push(nalgebra::DMatrix::from_fn(r, k, |c, j| {
                s[keep[c]] * vt[(keep[c], j)]
            }));
            runs.push(RunSpace {
                row0,
                rows,
                q: qg,
                r,
                red0,
            });
            red0 += r;
        }
        let dim = red0;
        let mut a = vec![vec![0.0; dim]; k];
        for (g, b) in runs.iter().zip(&blocks) {
            for j in 0..k {
                for c in 0..g.r {
                    a[j][g.red0 + c] = b[(c, j)];
                }
            }
        }
        Reduction {
            runs,
            a,
            dim,
            n: d.rows(),
        }
    }
}

/// The current model (rigid columns and accepted effects) fitted on a set of runs.
pub struct ModelProj {
    runs: Vec<usize>,
    /// Reduced rows of those runs.
    red_rows: Vec<usize>,
    pa: Projector,
    /// Accepted effect columns (full length) and (I − P_A)E on the runs' rows.
    e: Cols,
    e_perp: Cols,
    /// Orthonormal basis of `e_perp`.
    e_orth: Cols,
}

/// Coefficients of a fitted model: the rigid columns (scaled) and the effects.
pub struct Coef {
    pub a: DVector<f64>,
    pub c: Vec<f64>,
}

impl ModelProj {
    /// The model [A | effects] on the rows of `runs`.
    pub fn new(red: &Reduction, runs: Vec<usize>, effects: &Cols) -> ModelProj {
        let red_rows: Vec<usize> = runs
            .iter()
            .flat_map(|&g| red.runs[g].red0..red.runs[g].red0 + red.runs[g].r)
            .collect();
        let pa = Projector::new(&red.a, Some(&red_rows));
        let mut p = ModelProj {
            runs,
            red_rows,
            pa,
            e: effects.clone(),
            e_perp: Vec::new(),
            e_orth: Vec::new(),
        };
        for e in effects {
            let ep = p.rigid_residual(red, e);
            let mut o = ep.clone();
            let n0 = dot(&o, &o).sqrt();
            for _ in 0..2 {
                for b in &p.e_orth {
                    let c = dot(b, &o);
                    o.iter_mut().zip(b).for_each(|(v, bv)| *v -= c * bv);
                }
            }
            let nrm = dot(&o, &o).sqrt();
            if nrm > 1e-9 * n0.max(1e-300) {
                o.iter_mut().for_each(|v| *v /= nrm);
                p.e_orth.push(o);
            }
            p.e_perp.push(ep);
        }
        p
    }

    /// Numerical rank of [A | effects] on the runs.
    pub fn rank(&self) -> usize {
        self.pa.rank + self.e_orth.len()
    }

    /// Rows of the runs (full-length indices).
    pub fn rows<'a>(&'a self, red: &'a Reduction) -> impl Iterator<Item = usize> + 'a {
        self.runs
            .iter()
            .flat_map(|&g| red.runs[g].row0..red.runs[g].row0 + red.runs[g].rows)
    }

    /// (I − P_A) b on the runs' rows (zero elsewhere).
    fn rigid_residual(&self, red: &Reduction, b: &[f64]) -> Vec<f64> {
        let mut z = Vec::with_capacity(self.red_rows.len());
        for &g in &self.runs {
            z.extend(red.runs[g].coords(b));
        }
        let w = self.pa.residual(&z);
        let mut out = vec![0.0; red.n];
        let mut off = 0;
        for &g in &self.runs {
            let rs = &red.runs[g];
            out[rs.row0..rs.row0 + rs.rows].copy_from_slice(&b[rs.row0..rs.row0 + rs.rows]);
            let pz: Vec<f64> = (0..rs.r).map(|c| z[off + c] - w[off + c]).collect();
            rs.sub(&pz, &mut out);
            off += rs.r;
        }
        out
    }

    /// (I − P_[A E]) b on the runs' rows (zero elsewhere).
    pub fn residual(&self, red: &Reduction, b: &[f64]) -> Vec<f64> {
        let mut out = self.rigid_residual(red, b);
        for e in &self.e_orth {
            let c = dot(e, &out);
            out.iter_mut().zip(e).for_each(|(v, ev)| *v -= c * ev);
        }
        out
    }

    /// Least-squares coefficients of the model for the data `y` on the runs (Frisch–Waugh:
    /// effects from (I − P_A)y on (I − P_A)E, then the rigid part from what remains).
    pub fn fit(&self, red: &Reduction, y: &[f64]) -> Coef {
        let c: Vec<f64> = if self.e.is_empty() {
            Vec::new()
        } else {
            let ra = self.rigid_residual(red, y);
            small_lstsq(&self.e_perp, &ra)
                .map(|(c, _)| c.iter().copied().collect())
                .unwrap_or_else(|| vec![0.0; self.e.len()])
        };
        let mut y2 = y.to_vec();
        for (e, cj) in self.e.iter().zip(&c) {
            y2.iter_mut().zip(e).for_each(|(v, ev)| *v -= cj * ev);
        }
        let mut z = Vec::with_capacity(self.red_rows.len());
        for &g in &self.runs {
            z.extend(red.runs[g].coords(&y2));
        }
        Coef {
            a: self.pa.solve(&z),
            c,
        }
    }
}

/// The model's prediction on run `g`'s rows: Q_g Ã_g a + E_g c.
pub fn predict_run(red: &Reduction, effects: &Cols, coef: &Coef, g: usize) -> Vec<f64> {
    let rs = &red.runs[g];
    let ac: Vec<f64> = (0..rs.r)
        .map(|c| {
            red.a
                .iter()
                .zip(coef.a.iter())
                .map(|(col, x)| col[rs.red0 + c] * x)
                .sum::<f64>()
        })
        .collect();
    let mut out = vec![0.0; rs.rows];
    for (c, v) in ac.iter().enumerate() {
        for (o, q) in out.iter_mut().zip(rs.col(c)) {
            *o += v * q;
        }
    }
    for (e, cj) in effects.iter().zip(&coef.c) {
        for (i, o) in out.iter_mut().enumerate() {
            *o += cj * e[rs.row0 + i];
        }
    }
    out
}
