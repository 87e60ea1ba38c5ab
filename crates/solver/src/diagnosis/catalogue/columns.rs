//! The columns of a candidate effect: names, reading axes, the values at a row, and
//! where they can be nonzero (the rows and runs a pass over the moments visits).

use super::SPLIT_MAX_COLUMNS;
use crate::axis::Axis;
use crate::diagnosis::design::Design;

/// The columns of a candidate: their coefficients' names (with units), the reading axis
/// of each (its values are nonzero only on rows read along it; `None`: every row), and
/// `fill(sample, reading axis, out)` writing every column's value at a row from the
/// design's per-sample fields (entries of columns along another axis are then set to 0). The design centres them per (run,
/// direction) like the rigid columns.
pub struct Columns<'a> {
    pub names: Vec<String>,
    pub axes: Vec<Option<Axis>>,
    #[allow(clippy::type_complexity)]
    pub(super) fill: Box<dyn Fn(usize, Axis, &mut [f64]) + 'a>,
    /// Per reading axis: whether some column can be nonzero on its rows, and whether
    /// some column is read along another axis (0 on its rows: [`Columns::at`]).
    active: [bool; 3],
    other: [bool; 3],
    /// An axis whose position and travel alone the columns follow: they are constant
    /// over a run that does not move it.
    pub(super) follows: Option<Axis>,
    /// The one run where the columns vary (a step inside it: constant on every other
    /// run, which its zero offsets take); the columns are then local
    /// ([`crate::diagnosis::moments::Moments::local`]).
    run: Option<usize>,
    /// The runs where some column can be nonzero (a mounting's, a head-offset group's),
    /// per run of the design; `None`: any run.
    on: Option<Vec<bool>>,
}

impl<'a> Columns<'a> {
    pub(crate) fn new(
        names: Vec<String>,
        axes: Vec<Option<Axis>>,
        fill: impl Fn(usize, Axis, &mut [f64]) + 'a,
    ) -> Self {
        let active = [0, 1, 2].map(|i| axes.iter().any(|a| a.is_none_or(|a| a.index() == i)));
        let other = [0, 1, 2].map(|i| axes.iter().any(|a| a.is_some_and(|a| a.index() != i)));
        Columns {
            names,
            axes,
            fill: Box::new(fill),
            active,
            other,
            follows: None,
            run: None,
            on: None,
        }
    }

    /// The columns vary on run `g` alone ([`Columns::run`]).
    pub(super) fn on_run(self, g: Option<usize>) -> Self {
        Columns { run: g, ..self }
    }

    /// The one run where the columns vary, for a local effect.
    pub fn run(&self) -> Option<usize> {
        self.run
    }

    /// The columns are 0 on every run `on` does not hold (per run of the design): a
    /// pass over the rows skips those runs ([`Columns::on_run_of`]).
    pub(crate) fn only_on(self, on: Vec<bool>) -> Self {
        Columns {
            on: Some(on),
            ..self
        }
    }

    /// Whether some column can be nonzero on run `g` (every row of a run it does not
    /// hold is 0: the moments of its rows are 0, and not visiting them adds the same
    /// nothing).
    pub fn on_run_of(&self, g: usize) -> bool {
        self.on.as_ref().is_none_or(|on| on[g])
    }

    /// The columns follow axis `a`'s position and travel alone ([`Columns::follows`]).
    pub(crate) fn following(self, a: Axis) -> Self {
        Columns {
            follows: Some(a),
            ..self
        }
    }

    /// The axis whose position and travel alone the columns follow, if any: on a run
    /// that does not move it they are constant, and the centring per run removes them.
    pub fn follows(&self) -> Option<Axis> {
        self.follows
    }

    pub(super) fn none() -> Self {
        Columns::new(Vec::new(), Vec::new(), |_, _, _| {})
    }

    /// The columns (at most [`SPLIT_MAX_COLUMNS`]) in `k` copies, one per equal part of the
    /// time span `t0..t1` (s): a sample's value in its time's part (clamped), 0 in the others.
    pub(crate) fn per_segment(self, k: usize, times: &'a [f64], (t0, t1): (f64, f64)) -> Self {
        let span = (t1 - t0).max(f64::MIN_POSITIVE);
        let m = self.len();
        let names = (1..=k)
            .flat_map(|g| self.names.iter().map(move |n| format!("{n} (segment {g})")))
            .collect();
        let axes = (0..k).flat_map(|_| self.axes.iter().copied()).collect();
        assert!(
            m <= SPLIT_MAX_COLUMNS,
            "at most {SPLIT_MAX_COLUMNS} columns per segment"
        );
        let (fill, on) = (self.fill, self.on);
        let split = Columns::new(names, axes, move |s, read, o| {
            let mut v = [0.0; SPLIT_MAX_COLUMNS];
            fill(s, read, &mut v[..m]);
            o.iter_mut().for_each(|x| *x = 0.0);
            let g = (((times[s] - t0) / span * k as f64) as usize).min(k - 1);
            o[g * m..(g + 1) * m].copy_from_slice(&v[..m]);
        });
        Columns { on, ..split }
    }

    pub fn len(&self) -> usize {
        self.names.len()
    }

    pub fn is_empty(&self) -> bool {
        self.names.is_empty()
    }

    /// Whether some column can be nonzero at row `row` (its reading axis is one of the
    /// columns'); the same for every row of a run's reading direction.
    #[inline]
    pub fn live(&self, d: &Design, row: usize) -> bool {
        self.active[d.row_axis(row).index()]
    }

    /// The values of every column at row `row` of the design.
    #[inline]
    pub fn at(&self, d: &Design, row: usize, out: &mut [f64]) {
        let read = d.row_axis(row);
        if !self.active[read.index()] {
            out.iter_mut().for_each(|v| *v = 0.0);
            return;
        }
        (self.fill)(row / 2, read, out);
        if self.other[read.index()] {
            for (o, a) in out.iter_mut().zip(&self.axes) {
                if a.is_some_and(|a| a != read) {
                    *o = 0.0;
                }
            }
        }
    }
}
