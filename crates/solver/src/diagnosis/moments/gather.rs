//! The rows a pass over a run visits, gathered by reading direction and column for the
//! moments' dot products ([`super::Moments::over_rows`], [`super::Moments::cross`]).

use super::Extra;
use crate::diagnosis::reduced::RunSpace;

/// The visited rows of one reading direction of a run, gathered by column (flat,
/// column after column of k values), so that every moment is a dot product of two
/// contiguous vectors ([`dot_lanes`](crate::diagnosis::linalg::dot_lanes)).
#[derive(Default)]
pub(super) struct Gathered {
    /// Offset of the direction's basis values in the run's reduced coordinates (the
    /// same for all its rows); `None` when no row of it is visited.
    pub(super) off: Option<usize>,
    /// Rows gathered, and rows to gather.
    pub(super) n: usize,
    pub(super) k: usize,
    /// The m columns X, the w basis values Q_g[·, off..off + w] and the base columns U
    /// nonzero on the direction's rows.
    pub(super) x: Vec<f64>,
    pub(super) q: Vec<f64>,
    pub(super) u: Vec<f64>,
}

/// Scratch of one pass over the runs: the rows a run visits, one row's column and basis
/// values, and the visited rows gathered per reading direction (even rows, odd rows),
/// with whether every row of a direction is visited (its basis values are then read
/// from the run's block, [`RunSpace::direction`], not gathered).
pub(super) struct Pass {
    pub(super) visit: Vec<usize>,
    pub(super) vals: Vec<f64>,
    pub(super) qrow: Vec<f64>,
    pub(super) dirs: [Gathered; 2],
    full: [bool; 2],
}

impl Pass {
    pub(super) fn new(m: usize) -> Pass {
        Pass {
            visit: Vec::new(),
            vals: vec![0.0; m],
            qrow: Vec::new(),
            dirs: [Gathered::default(), Gathered::default()],
            full: [false; 2],
        }
    }

    /// Gathers run g's rows that `rows` visits into `dirs`, by column: the m columns'
    /// values from `fill`, the basis row Q_g's values (and the row's offset) when
    /// `with_basis` and some row of the direction is not visited (`full`), and the base
    /// columns of `extra` live on the row's direction. Returns those live base columns
    /// per direction.
    pub(super) fn gather(
        &mut self,
        (g, rs): (usize, &RunSpace),
        extra: &Extra,
        with_basis: bool,
        rows: &mut impl FnMut(usize, &RunSpace, &mut Vec<usize>),
        fill: &mut impl FnMut(usize, &mut [f64]),
    ) -> [Vec<usize>; 2] {
        let m = self.vals.len();
        self.visit.clear();
        rows(g, rs, &mut self.visit);
        let w = if with_basis { rs.width() } else { 0 };
        let odd = self.visit.iter().filter(|&&i| i & 1 == 1).count();
        let live = extra.live(g);
        let counts = [self.visit.len() - odd, odd];
        self.full = counts.map(|k| with_basis && k == rs.rows / 2);
        let offs = [0, 1].map(|c| if with_basis { rs.direction(c).0 } else { 0 });
        for (c, (d, live)) in self.dirs.iter_mut().zip(&live).enumerate() {
            let wc = if self.full[c] { 0 } else { w };
            d.start(counts[c], m, wc, live.len());
        }
        self.qrow.resize(w, 0.0);
        let Pass {
            visit,
            vals,
            qrow,
            dirs,
            full,
        } = self;
        for &i in visit.iter() {
            let (row, c) = (rs.row0 + i, i & 1);
            let copy = with_basis && !full[c];
            if copy {
                rs.row_into(i, qrow);
            }
            fill(row, vals);
            let cols = live[c].iter().map(|&col| extra.cols[col][row]);
            let q = if copy { &qrow[..] } else { &[][..] };
            dirs[c].push(offs[c], vals, q, cols);
        }
        live
    }

    /// The basis columns of reading direction `c`'s gathered rows (k values each, column
    /// after column): the run's block where every row of it is visited, else the values
    /// gathered.
    pub(super) fn basis<'p>(&'p self, rs: &'p RunSpace, c: usize) -> &'p [f64] {
        if self.full[c] {
            rs.direction(c).1
        } else {
            &self.dirs[c].q
        }
    }
}

impl Gathered {
    /// Makes room for `k` rows of m columns, w basis values and u base columns (not
    /// cleared: the k rows pushed then write every value).
    fn start(&mut self, k: usize, m: usize, w: usize, u: usize) {
        (self.off, self.n, self.k) = (None, 0, k);
        for (buf, c) in [(&mut self.x, m), (&mut self.q, w), (&mut self.u, u)] {
            buf.resize(c * k, 0.0);
        }
    }

    fn push(&mut self, off: usize, x: &[f64], q: &[f64], u: impl Iterator<Item = f64>) {
        self.off = Some(off);
        let (i, k) = (self.n, self.k);
        for (j, &v) in x.iter().enumerate() {
            self.x[j * k + i] = v;
        }
        for (t, &v) in q.iter().enumerate() {
            self.q[t * k + i] = v;
        }
        for (c, v) in u.enumerate() {
            self.u[c * k + i] = v;
        }
        self.n += 1;
    }

    /// Column `j` of a gathered block.
    pub(super) fn col(buf: &[f64], k: usize, j: usize) -> &[f64] {
        &buf[j * k..(j + 1) * k]
    }
}
