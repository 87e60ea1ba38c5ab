//! Exact least squares of the rigid model plus extra columns, assembled from per-run
//! moments on the reduction of [`super::reduced`].
//!
//! For columns X (an effect's, the accepted effects' and the data y), each run g
//! contributes its moments Z_g = Q_gᵀ X_g and G_g = X_gᵀ X_g (columns centred per run and
//! reading direction: Q_g's columns are centred, so Q_gᵀ X_g needs no centring, and
//! X_gᵀX_g is corrected by the per-direction sums). For a set S of runs and W_S an
//! orthonormal basis of the reduced rigid block Ã_S:
//!
//!   C_S = Σ_S G_g − (W_Sᵀ Z_S)ᵀ (W_Sᵀ Z_S) = Xᵀ (I − P_A) X on the rows of S,
//!
//! so the joint fit of [A | X'] to y on S (Frisch–Waugh) is the small system
//! C_X'X' x = C_X'y, with SSR = C_yy − C_yX' x and the rigid coefficients
//! a = Ã_S⁺ (z_y − Z_X' x). A run h held out of the fit has the residual
//! e_h = X_h w − Q_h Ã_h a, w = (−x, 1), whose squared norm is
//! wᵀ G_h w − 2 (Z_h w)·(Ã_h a) + ‖Ã_h a‖² (Q_h orthonormal).
//!
//! One pass over the rows per set of columns (O(n·(r_g + m))) is all that touches the
//! samples; every fit, on all runs and on each fold of held-out runs, is then of the size
//! of the reduced problem. Within a run the rows of each reading direction are gathered
//! by column (X, Q_g's values, U; Q_g's are read where the run stores them, by direction
//! and column, when every row of the direction is visited), and each moment is a dot
//! product of two such columns
//! (Z_g[j, t] = Σ_i X_ij Q_it, (X_gᵀX_g)_jl = Σ_i X_ij X_il, (X_gᵀU_g)_jc = Σ_i X_ij U_ic,
//! summed per direction and added), over the columns nonzero on some row of it. The
//! small system is solved by an eigen-decomposition of the equilibrated (unit-diagonal)
//! C_X'X', eigenvalues below 10⁻¹² of the largest dropped; a column with less than
//! 10⁻¹⁰ of its sum of squares outside the model is dropped.

use super::design::Design;
use super::linalg::{Projector, dot, dot_lanes, wide};
use super::reduced::{Reduction, RunSpace};
use column_stats::column_stats;
use gather::{Gathered, Pass};
use nalgebra::{DMatrix, SymmetricEigen};

mod column_stats;
mod gather;
#[cfg(test)]
mod same_bits;
#[cfg(test)]
pub(crate) use same_bits::assert_same_bits;

/// Moments of m columns on one run.
#[derive(Clone)]
pub struct RunMoments {
    /// Q_gᵀ X, by column: z[j·r + c].
    pub z: Vec<f64>,
    /// Centred X_gᵀ X_g (m × m, row-major).
    pub xx: Vec<f64>,
    /// X_gᵀ U_g with the extra columns U (m × u, row-major).
    pub xu: Vec<f64>,
}

/// The base columns U of the joint fits (full-length, centred), with where each is
/// nonzero: per run and reading direction (row parity), bit c set when column c has a
/// nonzero value there (`None`: every column may). A pass over the rows gathers and
/// multiplies only the columns nonzero on a direction's rows (the others' moments are 0).
pub struct Extra<'c> {
    pub cols: Vec<&'c [f64]>,
    pub support: Option<&'c [[u64; 2]]>,
}

impl<'c> Extra<'c> {
    /// Columns that may be nonzero anywhere.
    pub fn plain(cols: &[&'c [f64]]) -> Extra<'c> {
        Extra {
            cols: cols.to_vec(),
            support: None,
        }
    }

    /// Per run and reading direction of `red`, the columns `cols` nonzero there (bit c;
    /// at most 64 columns, `None` beyond).
    pub fn support_of(red: &Reduction, cols: &[&[f64]]) -> Option<Vec<[u64; 2]>> {
        (cols.len() <= 64).then(|| {
            red.runs
                .iter()
                .map(|rs| {
                    let mut bits = [0u64; 2];
                    for (c, col) in cols.iter().enumerate() {
                        for (i, v) in col[rs.row0..rs.row0 + rs.rows].iter().enumerate() {
                            if *v != 0.0 {
                                bits[i & 1] |= 1 << c;
                            }
                        }
                    }
                    bits
                })
                .collect()
        })
    }

    /// The columns nonzero on run g's rows of each reading direction.
    fn live(&self, g: usize) -> [Vec<usize>; 2] {
        let bits = self.support.map_or([u64::MAX; 2], |s| s[g]);
        bits.map(|b| (0..self.cols.len()).filter(|&c| b >> c & 1 == 1).collect())
    }
}

/// Moments of m columns on every run.
#[derive(Clone)]
pub struct Moments {
    pub m: usize,
    /// Number of extra columns U.
    pub u: usize,
    pub runs: Vec<RunMoments>,
    /// Per column: largest |value| over the (run, direction) groups where it varies (its
    /// size as a machine error per unit coefficient; the run offsets absorb a constant).
    pub peaks: Vec<f64>,
    /// Per column: whether it varies in some group (is not absorbed by the run offsets).
    pub varies: Vec<bool>,
    /// Per column: whether it is local, i.e. describes a one-off event of the runs where
    /// it is nonzero (a step): a held-out run refits it on its own rows, like its zero
    /// offsets, in the held-out residual of [`joint_fit`].
    pub local: Vec<bool>,
}

impl Moments {
    /// One pass over the rows: `fill(row, out)` writes the m column values at `row`;
    /// `extra` are full-length centred columns U.
    pub fn new(
        red: &Reduction,
        m: usize,
        extra: &Extra,
        fill: impl FnMut(usize, &mut [f64]),
    ) -> Moments {
        Moments::new_on(red, m, extra, |_| true, fill)
    }

    /// [`Moments::new`] over the live reading directions only: `live(row)` is asked of
    /// each run's first two rows (one per reading direction, which is the same for every
    /// row of the run); a direction that is not live has every column 0 on all its rows,
    /// which are then not visited (the moments are those of zero rows: nothing to add).
    pub fn new_on(
        red: &Reduction,
        m: usize,
        extra: &Extra,
        live: impl Fn(usize) -> bool,
        fill: impl FnMut(usize, &mut [f64]),
    ) -> Moments {
        Moments::over_rows(red, m, extra, live_directions(live), fill)
    }

    /// [`Moments::new`] over chosen rows: `rows(g, run, out)` pushes the indices (counted
    /// from the run's first row, ascending) of run g's rows where some column may be
    /// nonzero; every other row has all columns 0 and is not visited.
    pub fn over_rows(
        red: &Reduction,
        m: usize,
        extra: &Extra,
        mut rows: impl FnMut(usize, &RunSpace, &mut Vec<usize>),
        mut fill: impl FnMut(usize, &mut [f64]),
    ) -> Moments {
        let u = extra.cols.len();
        let mut peaks = vec![0.0f64; m];
        let mut varies = vec![false; m];
        let mut runs = Vec::with_capacity(red.runs.len());
        let mut pass = Pass::new(m);
        // Per column and direction, set anew for each run: the sum, the least and
        // largest value, and the rows where the column is nonzero (where they are fewer
        // than the direction's rows, 0 is one of the column's values, for lo/hi;
        // `column_stats` counts the visited zeros in already).
        let (mut sums, mut lo, mut hi) = (vec![[0.0; 2]; m], vec![[0.0; 2]; m], vec![[0.0; 2]; m]);
        let mut count = vec![[0usize; 2]; m];
        for (g, rs) in red.runs.iter().enumerate() {
            let r = rs.r;
            let mut rm = RunMoments {
                z: vec![0.0; m * r],
                xx: vec![0.0; m * m],
                xu: vec![0.0; m * u],
            };
            sums.fill([0.0; 2]);
            lo.fill([f64::INFINITY; 2]);
            hi.fill([f64::NEG_INFINITY; 2]);
            count.fill([0; 2]);
            let w = rs.width();
            let live = pass.gather((g, rs), extra, true, &mut rows, &mut fill);
            for (comp, d) in pass.dirs.iter().enumerate() {
                let Some(off) = d.off else { continue };
                let q = pass.basis(rs, comp);
                let stats = wide(DirectionMoments {
                    d,
                    q,
                    off,
                    live: &live[comp],
                    dims: (m, w, u, r),
                    rm: &mut rm,
                });
                for (j, (n, sum, l, h)) in stats.into_iter().enumerate() {
                    (count[j][comp], sums[j][comp], lo[j][comp], hi[j][comp]) = (n, sum, l, h);
                }
            }
            for j in 0..m {
                for l in 0..j {
                    rm.xx[j * m + l] = rm.xx[l * m + j];
                }
            }
            let half = (rs.rows / 2) as f64;
            for j in 0..m {
                for l in 0..m {
                    rm.xx[j * m + l] -= (0..2).map(|c| sums[j][c] * sums[l][c]).sum::<f64>() / half;
                }
                for c in 0..2 {
                    if count[j][c] < (rs.rows + 1 - c) / 2 {
                        lo[j][c] = lo[j][c].min(0.0);
                        hi[j][c] = hi[j][c].max(0.0);
                    }
                    let raw = lo[j][c].abs().max(hi[j][c].abs());
                    let dev = hi[j][c] - lo[j][c];
                    if dev > 1e-9 * raw.max(1e-300) {
                        peaks[j] = peaks[j].max(raw);
                    }
                    varies[j] |= dev > 1e-12;
                }
            }
            runs.push(rm);
        }
        Moments {
            m,
            u,
            runs,
            peaks,
            varies,
            local: vec![false; m],
        }
    }

    /// X_gᵀU_g of m columns with the base columns `extra` alone, per run (m × u,
    /// row-major; 0 where a base column is 0 on a direction's rows), over the rows
    /// `rows` pushes: the same sums [`Moments::over_rows`] forms for them, without Z_g
    /// and X_gᵀX_g. Only the rows of the (run, reading direction) groups where some
    /// base column is nonzero are visited: elsewhere every product is 0, and in the
    /// others the same rows are taken in the same order.
    pub fn cross(
        red: &Reduction,
        m: usize,
        extra: &Extra,
        mut rows: impl FnMut(usize, &RunSpace, &mut Vec<usize>),
        mut fill: impl FnMut(usize, &mut [f64]),
    ) -> Vec<Vec<f64>> {
        let u = extra.cols.len();
        let mut pass = Pass::new(m);
        let mut out = Vec::with_capacity(red.runs.len());
        for (g, rs) in red.runs.iter().enumerate() {
            let mut xu = vec![0.0; m * u];
            let on = extra.live(g).map(|c| !c.is_empty());
            if on == [false; 2] {
                out.push(xu);
                continue;
            }
            let mut rows_on = |g: usize, rs: &RunSpace, to: &mut Vec<usize>| {
                rows(g, rs, to);
                if on != [true; 2] {
                    to.retain(|&i| on[i & 1]);
                }
            };
            let live = pass.gather((g, rs), extra, false, &mut rows_on, &mut fill);
            for (d, live) in pass.dirs.iter().zip(&live) {
                if d.off.is_some() {
                    wide(CrossMoments {
                        d,
                        live,
                        m,
                        u,
                        xu: &mut xu,
                    });
                }
            }
            out.push(xu);
        }
        out
    }

    /// These moments, formed with a base of `u_prev` columns (the first `u_prev − 1`
    /// columns of `all` and y, its last), carried to the base `all`: the products with
    /// the rigid basis, among the m columns, with the earlier base columns and with y are
    /// the same sums; only the products with the columns added since are new, which
    /// `cross(added)` forms per run (m × added, row-major; [`Moments::cross`] over the same
    /// rows) with `added` those columns and where they are nonzero.
    pub fn carried(
        &self,
        all: &Extra,
        u_prev: usize,
        cross: impl FnOnce(&Extra) -> Vec<Vec<f64>>,
    ) -> Moments {
        let (m, u, old) = (self.m, all.cols.len(), u_prev - 1);
        let added = u - u_prev;
        let mask = (1u64 << added) - 1;
        let support: Option<Vec<[u64; 2]>> = all
            .support
            .map(|s| s.iter().map(|b| b.map(|b| (b >> old) & mask)).collect());
        let new = Extra {
            cols: all.cols[old..old + added].to_vec(),
            support: support.as_deref(),
        };
        let runs = self
            .runs
            .iter()
            .zip(cross(&new))
            .map(|(rm, xc)| {
                let mut xu = vec![0.0; m * u];
                for j in 0..m {
                    let (to, from) = (
                        &mut xu[j * u..(j + 1) * u],
                        &rm.xu[j * u_prev..(j + 1) * u_prev],
                    );
                    to[..old].copy_from_slice(&from[..old]);
                    to[old..old + added].copy_from_slice(&xc[j * added..(j + 1) * added]);
                    to[u - 1] = from[u_prev - 1];
                }
                RunMoments {
                    z: rm.z.clone(),
                    xx: rm.xx.clone(),
                    xu,
                }
            })
            .collect();
        Moments {
            m,
            u,
            runs,
            peaks: self.peaks.clone(),
            varies: self.varies.clone(),
            local: self.local.clone(),
        }
    }

    /// Moments of full-length columns (already centred).
    pub fn of_columns(red: &Reduction, cols: &[&[f64]]) -> Moments {
        Moments::new(red, cols.len(), &Extra::plain(&[]), |row, out| {
            for (o, c) in out.iter_mut().zip(cols) {
                *o = c[row];
            }
        })
    }

    /// The moments of the columns `keep` only.
    pub fn select(&self, keep: &[usize]) -> Moments {
        let (m, u) = (keep.len(), self.u);
        let runs = self
            .runs
            .iter()
            .map(|rm| {
                let r = rm.z.len() / self.m.max(1);
                RunMoments {
                    z: keep
                        .iter()
                        .flat_map(|&j| rm.z[j * r..(j + 1) * r].iter().copied())
                        .collect(),
                    xx: keep
                        .iter()
                        .flat_map(|&j| keep.iter().map(move |&l| rm.xx[j * self.m + l]))
                        .collect(),
                    xu: keep
                        .iter()
                        .flat_map(|&j| rm.xu[j * u..(j + 1) * u].iter().copied())
                        .collect(),
                }
            })
            .collect();
        Moments {
            m,
            u,
            runs,
            peaks: keep.iter().map(|&j| self.peaks[j]).collect(),
            varies: keep.iter().map(|&j| self.varies[j]).collect(),
            local: keep.iter().map(|&j| self.local[j]).collect(),
        }
    }

    /// The moments of m combinations of these columns, run by run: column c on run g is
    /// Σ w·X_b over the (b, w) of `weights(g)[c]` (X_b this set's column b). Each sum is
    /// taken in the order of its terms.
    pub fn combine(&self, m: usize, weights: impl Fn(usize) -> Vec<Vec<(usize, f64)>>) -> Moments {
        let (mb, u) = (self.m, self.u);
        let runs = self
            .runs
            .iter()
            .enumerate()
            .map(|(g, rm)| {
                let wg = weights(g);
                let r = rm.z.len() / mb.max(1);
                let mut z = vec![0.0; m * r];
                let mut xu = vec![0.0; m * u];
                for (c, wc) in wg.iter().enumerate() {
                    for &(b, w) in wc {
                        for (o, v) in z[c * r..(c + 1) * r].iter_mut().zip(&rm.z[b * r..]) {
                            *o += w * v;
                        }
                        for (o, v) in xu[c * u..(c + 1) * u].iter_mut().zip(&rm.xu[b * u..]) {
                            *o += w * v;
                        }
                    }
                }
                let mut xx = vec![0.0; m * m];
                for (c, wc) in wg.iter().enumerate() {
                    for (e, we) in wg.iter().enumerate() {
                        let mut acc = 0.0;
                        for &(b, w) in wc {
                            acc += w * we.iter().map(|&(l, v)| rm.xx[b * mb + l] * v).sum::<f64>();
                        }
                        xx[c * m + e] = acc;
                    }
                }
                RunMoments { z, xx, xu }
            })
            .collect();
        Moments {
            m,
            u,
            runs,
            peaks: vec![0.0; m],
            varies: vec![true; m],
            local: vec![false; m],
        }
    }

    /// Σ over all runs of the centred X_gᵀX_g (m × m).
    pub fn gram(&self) -> DMatrix<f64> {
        let mut g = DMatrix::zeros(self.m, self.m);
        for rm in &self.runs {
            for j in 0..self.m {
                for l in 0..self.m {
                    g[(j, l)] += rm.xx[j * self.m + l];
                }
            }
        }
        g
    }
}

/// The rows of a run's live reading directions ([`Moments::new_on`]).
pub fn live_directions(
    live: impl Fn(usize) -> bool,
) -> impl FnMut(usize, &RunSpace, &mut Vec<usize>) {
    move |_, rs, out| {
        let on = [0, 1].map(|c| c < rs.rows && live(rs.row0 + c));
        let (first, step) = match on {
            [true, true] => (0, 1),
            [true, false] => (0, 2),
            [false, true] => (1, 2),
            [false, false] => (rs.rows, 1),
        };
        out.extend((first..rs.rows).step_by(step));
    }
}

/// The moments of one reading direction of a run from its gathered rows, added to the
/// run's (Z_g at the direction's offset `off`, the upper triangle of X_gᵀX_g, X_gᵀU_g)
/// over the columns nonzero on some row of it; [`wide`] runs it, and it returns each
/// column's [`column_stats`].
struct DirectionMoments<'a> {
    d: &'a Gathered,
    /// The w basis columns of the gathered rows (k values each, column after column).
    q: &'a [f64],
    off: usize,
    /// The base columns gathered (nonzero on this direction's rows), in order.
    live: &'a [usize],
    /// m columns, w basis values per row, u base columns, r reduced coordinates.
    dims: (usize, usize, usize, usize),
    rm: &'a mut RunMoments,
}

impl pulp::WithSimd for DirectionMoments<'_> {
    type Output = Vec<(usize, f64, f64, f64)>;

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _: S) -> Self::Output {
        let DirectionMoments {
            d,
            q,
            off,
            live,
            rm,
            ..
        } = self;
        let (m, w, u, r) = self.dims;
        let k = d.k;
        let stats = column_stats(&d.x, k, m);
        // The columns nonzero on some row of this direction.
        let nz: Vec<usize> = (0..m).filter(|&j| stats[j].0 > 0).collect();
        for (a, &j) in nz.iter().enumerate() {
            let xj = Gathered::col(&d.x, k, j);
            for t in 0..w {
                rm.z[j * r + off + t] += dot_lanes(xj, Gathered::col(q, k, t));
            }
            // The upper triangle only (the lower is its mirror).
            for &l in &nz[a..] {
                rm.xx[j * m + l] += dot_lanes(xj, Gathered::col(&d.x, k, l));
            }
            for (i, &c) in live.iter().enumerate() {
                rm.xu[j * u + c] += dot_lanes(xj, Gathered::col(&d.u, k, i));
            }
        }
        stats
    }
}

/// X_gᵀU_g of one reading direction of a run from its gathered rows, added to `xu`
/// ([`Moments::cross`]; the products [`DirectionMoments`] forms for them).
struct CrossMoments<'a> {
    d: &'a Gathered,
    live: &'a [usize],
    m: usize,
    u: usize,
    xu: &'a mut [f64],
}

impl pulp::WithSimd for CrossMoments<'_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _: S) {
        let CrossMoments { d, live, m, u, xu } = self;
        for j in 0..m {
            let xj = Gathered::col(&d.x, d.k, j);
            for (i, &c) in live.iter().enumerate() {
                xu[j * u + c] += dot_lanes(xj, Gathered::col(&d.u, d.k, i));
            }
        }
    }
}

/// The rigid model's projector on a set of runs.
pub struct RunSet {
    pub runs: Vec<usize>,
    proj: Projector,
}

impl RunSet {
    fn new(red: &Reduction, runs: Vec<usize>) -> RunSet {
        let rows: Vec<usize> = runs
            .iter()
            .flat_map(|&g| red.runs[g].red0..red.runs[g].red0 + red.runs[g].r)
            .collect();
        RunSet {
            proj: Projector::new(&red.a, Some(&rows)),
            runs,
        }
    }

    /// Rank of the rigid model on these runs.
    pub fn rank(&self) -> usize {
        self.proj.rank
    }
}

/// All runs, and the K folds of whole runs held out (run index within its file mod K).
pub struct Sets {
    pub all: RunSet,
    /// (training runs, held-out runs) per fold.
    pub folds: Vec<(RunSet, Vec<usize>)>,
    /// Rows held out over all folds.
    pub heldout_n: usize,
}

impl Sets {
    pub fn new(d: &Design, red: &Reduction, k: usize) -> Sets {
        let mut first_run = vec![usize::MAX; d.files.len()];
        for (i, r) in d.runs.iter().enumerate() {
            first_run[r.plane_idx] = first_run[r.plane_idx].min(i);
        }
        let mut folds = Vec::new();
        let mut heldout_n = 0;
        for f in 0..k {
            let (held, train): (Vec<usize>, Vec<usize>) =
                (0..d.runs.len()).partition(|&ri| (ri - first_run[d.runs[ri].plane_idx]) % k == f);
            if held.is_empty() || train.is_empty() {
                continue;
            }
            heldout_n += held.iter().map(|&g| red.runs[g].rows).sum::<usize>();
            folds.push((RunSet::new(red, train), held));
        }
        Sets {
            all: RunSet::new(red, (0..d.runs.len()).collect()),
            folds,
            heldout_n,
        }
    }
}

/// The base columns U = [E | y] of the joint fits (the accepted effects and the data),
/// with their products with the rigid basis on each set of runs, formed once per base
/// for every joint fit that extends it: V_S,U = W_Sᵀ Z_S,U = Σ_{g∈S} W_S,gᵀ Z_g,U (the
/// columns of V in the joint fits' `solve` that do not depend on the candidate).
pub struct Base {
    pub mom: Moments,
    /// V_S,U (rank × u) on all runs.
    v_all: DMatrix<f64>,
    /// V_S,U on each fold's training runs, in the order of [`Sets::folds`].
    v_folds: Vec<DMatrix<f64>>,
}

impl Base {
    pub fn new(red: &Reduction, sets: &Sets, mom: Moments) -> Base {
        let z = |g: usize, c: usize| mom.z_col(g, c);
        Base {
            v_all: rigid_products(red, &sets.all, mom.m, z),
            v_folds: sets
                .folds
                .iter()
                .map(|(train, _)| rigid_products(red, train, mom.m, z))
                .collect(),
            mom,
        }
    }
}

impl Moments {
    /// Column c of Z_g = Q_gᵀ X on run g.
    fn z_col(&self, g: usize, c: usize) -> &[f64] {
        let rm = &self.runs[g];
        let r = rm.z.len() / self.m.max(1);
        &rm.z[c * r..(c + 1) * r]
    }
}

/// V = W_Sᵀ Z_S (rank × n) of n columns whose run-g blocks are `z(g, c)`: the runs' terms
/// added in the set's order ([`add_products`]), but a block of zeros, whose terms are 0
/// (a sum that starts at +0 and adds signed zeros stays +0: the same V).
fn rigid_products<'a, Z: Fn(usize, usize) -> &'a [f64]>(
    red: &Reduction,
    set: &RunSet,
    n: usize,
    z: Z,
) -> DMatrix<f64> {
    wide(RigidProducts { red, set, n, z })
}

/// [`rigid_products`]' arguments, as the kernel [`wide`] runs.
struct RigidProducts<'a, Z> {
    red: &'a Reduction,
    set: &'a RunSet,
    n: usize,
    z: Z,
}

impl<'a, Z: Fn(usize, usize) -> &'a [f64]> pulp::WithSimd for RigidProducts<'_, Z> {
    type Output = DMatrix<f64>;

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _: S) -> DMatrix<f64> {
        let w = &self.set.proj.w;
        let mut v = DMatrix::<f64>::zeros(w.len(), self.n);
        let mut off = 0;
        for &run in &self.set.runs {
            for c in 0..self.n {
                // A column 0 on the run (not visited there: another mounting's, a step
                // on another run) adds 0 to every product.
                let z = (self.z)(run, c);
                if z.iter().any(|&x| x != 0.0) {
                    add_products(&mut v, c, w, off, z);
                }
            }
            off += self.red.runs[run].r;
        }
        v
    }
}

/// The columns of a joint fit: an effect's B (optional) before the base U = [E | y].
struct Joint<'a> {
    b: Option<&'a Moments>,
    base: &'a Moments,
}

impl Joint<'_> {
    fn mb(&self) -> usize {
        self.b.map_or(0, |b| b.m)
    }
    fn q(&self) -> usize {
        self.mb() + self.base.m
    }
    /// Column j of Z_g.
    fn z(&self, g: usize, j: usize) -> &[f64] {
        let mb = self.mb();
        match self.b {
            Some(b) if j < mb => b.z_col(g, j),
            _ => self.base.z_col(g, j - mb),
        }
    }
    /// Whether column j is local ([`Moments::local`]).
    fn local(&self, j: usize) -> bool {
        let mb = self.mb();
        match self.b {
            Some(b) if j < mb => b.local[j],
            _ => self.base.local[j - mb],
        }
    }
    /// Element (i, j) of G_g.
    fn g_at(&self, g: usize, i: usize, j: usize) -> f64 {
        let mb = self.mb();
        match (i < mb, j < mb) {
            (true, true) => self.b.map_or(0.0, |b| b.runs[g].xx[i * mb + j]),
            (true, false) => self.b.map_or(0.0, |b| b.runs[g].xu[i * b.u + (j - mb)]),
            (false, true) => self.b.map_or(0.0, |b| b.runs[g].xu[j * b.u + (i - mb)]),
            (false, false) => self.base.runs[g].xx[(i - mb) * self.base.m + (j - mb)],
        }
    }
    /// G_g (q × q).
    fn g(&self, g: usize) -> DMatrix<f64> {
        let q = self.q();
        DMatrix::from_fn(q, q, |i, j| self.g_at(g, i, j))
    }
}

/// A joint fit on a set of runs.
pub struct SetFit {
    /// Coefficients of the columns before y (B, then E); 0 for a dropped column.
    pub x: Vec<f64>,
    /// Unit-variance standard deviations √diag(C⁺) of `x` (∞ for a dropped column).
    pub sd: Vec<f64>,
    /// Coefficients of the (scaled) rigid columns.
    pub a: Vec<f64>,
    pub ssr: f64,
    /// Rank of the extra columns after the rigid model.
    pub rank: usize,
}

/// The joint fit on the runs of `set`; `v_base` is the base's V_S,U on them ([`Base`]).
fn solve(red: &Reduction, set: &RunSet, j: &Joint, v_base: &DMatrix<f64>) -> SetFit {
    let (q, mb) = (j.q(), j.mb());
    let p = q - 1;
    let rank = set.proj.w.len();
    let mut g = DMatrix::<f64>::zeros(q, q);
    for &run in &set.runs {
        for b in 0..q {
            for a in 0..q {
                g[(a, b)] += j.g_at(run, a, b);
            }
        }
    }
    // V = W_Sᵀ [Z_B | Z_U]: the candidate's columns here, the base's formed once.
    let vb = rigid_products(red, set, mb, |g, c| j.z(g, c));
    let v = DMatrix::from_fn(rank, q, |l, c| {
        if c < mb {
            vb[(l, c)]
        } else {
            v_base[(l, c - mb)]
        }
    });
    // C = G − VᵀV, the moments of the columns after the rigid model.
    let c = &g - v.transpose() * &v;
    let diag: Vec<f64> = (0..p)
        .map(|i| {
            if c[(i, i)] > 1e-10 * g[(i, i)].max(1e-300) {
                c[(i, i)].sqrt()
            } else {
                0.0
            }
        })
        .collect();
    let keep: Vec<usize> = (0..p).filter(|&i| diag[i] > 0.0).collect();
    let mut x = vec![0.0; p];
    let mut sd = vec![f64::INFINITY; p];
    let mut rank_x = 0;
    if !keep.is_empty() {
        let cs = DMatrix::from_fn(keep.len(), keep.len(), |a, b| {
            c[(keep[a], keep[b])] / (diag[keep[a]] * diag[keep[b]])
        });
        let eig = SymmetricEigen::new(cs);
        let lmax = eig.eigenvalues.iter().copied().fold(0.0, f64::max);
        let mut pinv = DMatrix::<f64>::zeros(keep.len(), keep.len());
        for (e, &l) in eig.eigenvalues.iter().enumerate() {
            if l > 1e-12 * lmax && l > 0.0 {
                let ve = eig.eigenvectors.column(e);
                pinv += ve * ve.transpose() / l;
                rank_x += 1;
            }
        }
        let rhs: Vec<f64> = keep.iter().map(|&i| c[(i, p)] / diag[i]).collect();
        for (a, &i) in keep.iter().enumerate() {
            let xs: f64 = (0..keep.len()).map(|b| pinv[(a, b)] * rhs[b]).sum();
            x[i] = xs / diag[i];
            sd[i] = pinv[(a, a)].max(0.0).sqrt() / diag[i];
        }
    }
    let ssr = (c[(p, p)] - (0..p).map(|i| c[(i, p)] * x[i]).sum::<f64>()).max(0.0);
    // a = Ã⁺ (z_y − Z_X x) = V_r Σ⁻¹ W ᵀ(…).
    let mut wz = vec![0.0; rank];
    for (l, slot) in wz.iter_mut().enumerate() {
        *slot = v[(l, p)] - (0..p).map(|i| v[(l, i)] * x[i]).sum::<f64>();
    }
    let a = (0..set.proj.v_sinv.nrows())
        .map(|i| (0..rank).map(|l| set.proj.v_sinv[(i, l)] * wz[l]).sum())
        .collect();
    SetFit {
        x,
        sd,
        a,
        ssr,
        rank: rank_x,
    }
}

/// v[(l, c)] += w_l[off..off + len]·z for every basis column w_l, four at a time: four
/// independent sums over z (each one's terms added in the order of [`dot`]).
#[inline(always)]
fn add_products(v: &mut DMatrix<f64>, c: usize, w: &[Vec<f64>], off: usize, z: &[f64]) {
    let r = z.len();
    let mut groups = w.chunks_exact(4);
    for (g, ws) in groups.by_ref().enumerate() {
        let ws: [&[f64]; 4] = std::array::from_fn(|k| &ws[k][off..off + r]);
        let mut acc = [0.0; 4];
        for (i, zi) in z.iter().enumerate() {
            for k in 0..4 {
                acc[k] += ws[k][i] * zi;
            }
        }
        for (k, a) in acc.into_iter().enumerate() {
            v[(4 * g + k, c)] += a;
        }
    }
    let done = w.len() - groups.remainder().len();
    for (l, wl) in groups.remainder().iter().enumerate() {
        v[(done + l, c)] += dot(&wl[off..off + r], z);
    }
}

/// The part of a held-out run h's squared residual e_h that its local columns S (a step
/// in it: [`Moments::local`]) take when refitted on its own rows: with
/// Sᵀe_h = G_h[S, ·]·w − Z_h[S]·(Ã_h a) and M = G_h[S, S] (centred per run, like every
/// column), ‖e_h‖² − min_c ‖e_h − S c‖² = (Sᵀe_h)ᵀ M⁺ (Sᵀe_h). 0 without local columns.
fn local_refit(j: &Joint, h: usize, gh: &DMatrix<f64>, wv: &DMatrix<f64>, pa: &[f64]) -> f64 {
    let q = j.q();
    let loc: Vec<usize> = (0..q - 1)
        .filter(|&c| j.local(c) && gh[(c, c)] > 0.0)
        .collect();
    if loc.is_empty() {
        return 0.0;
    }
    let gw = gh * wv;
    let s = nalgebra::DVector::from_iterator(
        loc.len(),
        loc.iter().map(|&c| gw[c] - dot(j.z(h, c), pa)),
    );
    let m = DMatrix::from_fn(loc.len(), loc.len(), |a, b| gh[(loc[a], loc[b])]);
    let eig = SymmetricEigen::new(m);
    let lmax = eig.eigenvalues.iter().copied().fold(0.0, f64::max);
    let mut taken = 0.0;
    for (e, &l) in eig.eigenvalues.iter().enumerate() {
        if l > 1e-12 * lmax && l > 0.0 {
            let c = eig.eigenvectors.column(e).dot(&s);
            taken += c * c / l;
        }
    }
    taken
}

/// The fit on all runs and the held-out sum of squares over the folds.
pub struct JointFit {
    pub all: SetFit,
    pub heldout_ssr: f64,
}

/// Fits the rigid model plus `b` (optional) plus the base columns (accepted effects),
/// with y the base's last column, on all runs and on each fold; `heldout` false skips
/// the folds (`heldout_ssr` is then NaN).
pub fn joint_fit(
    red: &Reduction,
    sets: &Sets,
    b: Option<&Moments>,
    base: &Base,
    heldout: bool,
) -> JointFit {
    let all = solve(red, &sets.all, &Joint { b, base: &base.mom }, &base.v_all);
    JointFit {
        all,
        heldout_ssr: if heldout {
            heldout_ssr(red, sets, b, base)
        } else {
            f64::NAN
        },
    }
}

/// The held-out sum of squares of [`joint_fit`] alone: the fit on each fold's training
/// runs, scored on its held-out runs.
pub fn heldout_ssr(red: &Reduction, sets: &Sets, b: Option<&Moments>, base: &Base) -> f64 {
    let j = Joint { b, base: &base.mom };
    let mut total = 0.0;
    for ((train, held), v_base) in sets.folds.iter().zip(&base.v_folds) {
        let f = solve(red, train, &j, v_base);
        let q = j.q();
        let mut wv = DMatrix::<f64>::zeros(q, 1);
        for (i, x) in f.x.iter().enumerate() {
            wv[i] = -x;
        }
        wv[q - 1] = 1.0;
        for &h in held {
            let gh = j.g(h);
            let quad = (wv.transpose() * &gh * &wv)[(0, 0)];
            let pa = red.predict_reduced(h, &f.a);
            let r = red.runs[h].r;
            let mut zw = vec![0.0; r];
            for (c, &wc) in wv.iter().enumerate() {
                if wc != 0.0 {
                    for (o, z) in zw.iter_mut().zip(j.z(h, c)) {
                        *o += wc * z;
                    }
                }
            }
            let ee = quad - 2.0 * dot(&zw, &pa) + dot(&pa, &pa);
            total += (ee - local_refit(&j, h, &gh, &wv, &pa)).max(0.0);
        }
    }
    total
}
