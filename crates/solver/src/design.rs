//! The observation model of a grid-encoder session: which parameters exist, and the
//! design row of every reading (kinematics contract, "Planar grid encoder").
//!
//! A sample of a run in plane (u, v) with head offset t at commanded position q gives two
//! observations, for the in-plane directions d ∈ {u, v}:
//!
//! ```text
//! du = e_u(q, t) + φ_m · v_h · 10⁻³ + o_run,u + noise
//! dv = e_v(q, t) − φ_m · u_h · 10⁻³ + o_run,v + noise
//! ```
//!
//! with e the linearised volumetric error (µm) of [`crate::kinematics::linear_error_um`]
//! — a linear function of the error parameters (basis coefficients of the 18 functions
//! and the three squareness constants) — φ_m the in-plane rotation of the plate mounting
//! m (µrad; +φ turns the plate from u toward v), (u_h, v_h) the head's in-plane position
//! q + t (mm) and o the run's two zero offsets (µm).
//!
//! The zero offsets are eliminated exactly by centring every column and the readings
//! within each (run, direction) group (Frisch–Waugh–Lovell); the remaining columns are
//! ordered [mounting rotations | error parameters | extra columns] and reduced with
//! [`crate::lsq::QrAccumulator`]. Extra columns (the diagnosis' candidate effects) are
//! supplied through [`ExtraColumns`].

mod run_interpolant;

pub(crate) use run_interpolant::RunInterpolant;
use run_interpolant::compress_run;

use crate::axis::{Axis, Topology};
use crate::basis::{Basis, BasisKind};
use crate::kinematics::{abbe_arm_mm, squareness_gradient, term_gradient};
use crate::lsq::{LsSolution, QrAccumulator, Reduced};
use crate::session::{PlaneRecord, Run, Session};
use crate::terms::Component;
use crate::terms::{SquarenessTerm, Term};
use nalgebra::Vector3;

/// One error-model parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Param {
    /// Coefficient of the basis function of power `power` of `term`.
    Coef {
        term: Term,
        power: usize,
    },
    Squareness(SquarenessTerm),
}

impl Param {
    /// The ISO name of the term the parameter belongs to.
    pub fn term_name(&self) -> String {
        match self {
            Param::Coef { term, .. } => term.name(),
            Param::Squareness(s) => s.name().to_string(),
        }
    }
}

/// The error model: a basis per term over the measured travel of its axis.
#[derive(Debug, Clone)]
pub struct ErrorModel {
    pub topology: Topology,
    pub kind: BasisKind,
    pub order: usize,
    /// Measured travel (lo, hi) per axis, `None` for an axis that never moved.
    pub travel: [Option<(f64, f64)>; 3],
    /// Basis of each of the 18 terms (in [`Term::all`] order); `None` without travel.
    pub bases: Vec<Option<Basis>>,
    /// All error parameters, terms in [`Term::all`] order, then the squareness constants
    /// (when [`ErrorModel::squareness`]).
    pub params: Vec<Param>,
    /// Start index in `params` of each term's coefficients.
    pub term_start: Vec<usize>,
    /// Whether the three squareness constants are parameters (the last three).
    pub squareness: bool,
}

impl ErrorModel {
    /// The model of `order` in the `kind` basis over the given measured travels.
    pub fn new(
        topology: Topology,
        kind: BasisKind,
        order: usize,
        travel: [Option<(f64, f64)>; 3],
    ) -> ErrorModel {
        let mut bases = Vec::new();
        let mut params = Vec::new();
        let mut term_start = Vec::new();
        for term in Term::all() {
            term_start.push(params.len());
            let b = travel[term.axis.index()]
                .map(|(lo, hi)| Basis::for_term(kind, order, term, lo, hi));
            if let Some(b) = &b {
                for k in 0..b.len() {
                    params.push(Param::Coef {
                        term,
                        power: b.first_power() + k,
                    });
                }
            }
            bases.push(b);
        }
        for s in SquarenessTerm::ALL {
            params.push(Param::Squareness(s));
        }
        ErrorModel {
            topology,
            kind,
            order,
            travel,
            bases,
            params,
            term_start,
            squareness: true,
        }
    }

    /// The same model restricted to the terms for which `keep` is true, with or without
    /// the squareness constants (a term left out has no basis and no parameters: its
    /// effect is not modelled). Used by the stepwise method's two sub-problems.
    pub fn restricted(&self, keep: impl Fn(Term) -> bool, squareness: bool) -> ErrorModel {
        let mut out = ErrorModel::new(self.topology.clone(), self.kind, self.order, self.travel);
        for (i, term) in Term::all().into_iter().enumerate() {
            if !keep(term) {
                out.bases[i] = None;
            }
        }
        out.params.clear();
        out.term_start.clear();
        for (i, b) in out.bases.iter().enumerate() {
            out.term_start.push(out.params.len());
            if let Some(b) = b {
                for k in 0..b.len() {
                    out.params.push(Param::Coef {
                        term: Term::all()[i],
                        power: b.first_power() + k,
                    });
                }
            }
        }
        if squareness {
            out.params
                .extend(SquarenessTerm::ALL.map(Param::Squareness));
        }
        out.squareness = squareness;
        out
    }

    /// Index range in `params` of term number `i` (in [`Term::all`] order).
    pub fn term_range(&self, i: usize) -> std::ops::Range<usize> {
        let len = self.bases[i].map_or(0, |b| b.len());
        self.term_start[i]..self.term_start[i] + len
    }

    /// Index in `params` of a squareness constant (the model must have them).
    pub fn squareness_index(&self, s: SquarenessTerm) -> usize {
        debug_assert!(self.squareness);
        self.params.len() - 3 + SquarenessTerm::ALL.iter().position(|&x| x == s).unwrap()
    }

    pub fn len(&self) -> usize {
        self.params.len()
    }

    pub fn is_empty(&self) -> bool {
        self.params.is_empty()
    }

    /// Design row of the error parameters: the sensitivity of volumetric error
    /// component `dir` at (q, t) to every parameter (µm per unit).
    pub fn error_row(&self, q: [f64; 3], t: [f64; 3], dir: Axis, out: &mut [f64]) {
        let mut vals = Vec::with_capacity(self.order + 1);
        for (i, term) in Term::all().into_iter().enumerate() {
            let Some(b) = &self.bases[i] else { continue };
            let g = term_gradient(&self.topology, term.axis, term.component, q, t)[dir.index()];
            vals.clear();
            b.eval_into(q[term.axis.index()], &mut vals);
            let s = self.term_start[i];
            for (k, v) in vals.iter().enumerate() {
                out[s + k] = g * v;
            }
        }
        if !self.squareness {
            return;
        }
        let sg = squareness_gradient(q);
        let n = self.params.len();
        for j in 0..3 {
            out[n - 3 + j] = sg[j][dir.index()];
        }
    }

    /// Volumetric error (µm) of the model at (q, t) for the error parameters `x` (error
    /// block only): e = Σ_k [δ_k + ε_k × a_k] + squareness, i.e. the vector whose
    /// component `dir` is `error_row(q, t, dir) · x`, with one Abbe arm per axis instead of
    /// one gradient per term and direction (the per-sample residuals of a report use it).
    pub fn error_vector(
        &self,
        q: [f64; 3],
        t: [f64; 3],
        x: &[f64],
        vals: &mut Vec<f64>,
    ) -> Vector3<f64> {
        let mut e = Vector3::zeros();
        for axis in Axis::ALL {
            let mut delta = Vector3::zeros();
            let mut eps = Vector3::zeros();
            for term in Term::all().into_iter().filter(|t| t.axis == axis) {
                let i = term.index();
                let Some(b) = &self.bases[i] else { continue };
                vals.clear();
                b.eval_into(q[axis.index()], vals);
                let s = self.term_start[i];
                let v: f64 = vals
                    .iter()
                    .zip(&x[s..s + vals.len()])
                    .map(|(a, c)| a * c)
                    .sum();
                match term.component {
                    Component::Translation(d) => delta[d.index()] += v,
                    Component::Rotation(d) => eps[d.index()] += v,
                }
            }
            e += delta;
            if eps != Vector3::zeros() {
                e += eps.cross(&abbe_arm_mm(&self.topology, axis, q, t)) * 1e-3;
            }
        }
        if self.squareness {
            let n = self.params.len();
            for (j, g) in squareness_gradient(q).iter().enumerate() {
                e += g * x[n - 3 + j];
            }
        }
        e
    }

    /// Value of term number `i` at `q` for parameter vector `x` (error block only).
    pub fn term_value(&self, i: usize, x: &[f64], q: f64) -> f64 {
        match &self.bases[i] {
            None => 0.0,
            Some(b) => combine(b.eval(q).into_iter(), &x[self.term_range(i)]),
        }
    }

    /// [`ErrorModel::term_value`] of term `i` as a function of q, for evaluating at many
    /// positions: its basis's terms at the reference position formed once
    /// ([`crate::basis::Basis::at_reference`]).
    pub fn term_fn<'a>(&'a self, i: usize, x: &'a [f64]) -> impl Fn(f64) -> f64 + 'a {
        let b = self.bases[i].as_ref();
        let reference = b.map(|b| b.at_reference()).unwrap_or_default();
        let c = &x[self.term_range(i)];
        move |q| b.map_or(0.0, |b| combine(b.values_from(q, &reference), c))
    }

    /// Gradient of term `i`'s value at `q` with respect to the error parameters.
    pub fn term_value_gradient(&self, i: usize, q: f64) -> Vec<f64> {
        let mut g = vec![0.0; self.params.len()];
        if let Some(b) = &self.bases[i] {
            let r = self.term_range(i);
            for (k, v) in b.eval(q).into_iter().enumerate() {
                g[r.start + k] = v;
            }
        }
        g
    }
}

/// Σ_k v_k c_k of basis values and their coefficients, in order.
pub(crate) fn combine(values: impl Iterator<Item = f64>, c: &[f64]) -> f64 {
    values.zip(c).map(|(v, c)| v * c).sum()
}

/// Measured travel of each axis: the range of commanded positions over the runs in which
/// it moved (an axis parked during a run contributes nothing there).
pub fn measured_travel(session: &Session) -> [Option<(f64, f64)>; 3] {
    let mut out: [Option<(f64, f64)>; 3] = [None; 3];
    for run in session.planes.iter().flat_map(|p| p.runs.iter()) {
        for a in 0..3 {
            let (lo, hi) = run
                .pos_mm
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), q| {
                    (lo.min(q[a]), hi.max(q[a]))
                });
            if hi - lo > MOVING_MM {
                out[a] = Some(match out[a] {
                    None => (lo, hi),
                    Some((l, h)) => (l.min(lo), h.max(hi)),
                });
            }
        }
    }
    out
}

/// An axis whose commanded position spans less than this in a run is parked there (the
/// same threshold as the test-kind inference).
pub const MOVING_MM: f64 = crate::session::PARKED_RANGE_MM;

/// Everything known about one observation row (for extra columns and residual analysis).
#[derive(Debug, Clone, Copy)]
pub struct RowMeta<'a> {
    pub plane: usize,
    pub run: usize,
    pub sample: usize,
    /// 0 for u, 1 for v.
    pub comp: usize,
    /// The machine direction of this reading.
    pub dir: Axis,
    pub t_s: f64,
    pub q: [f64; 3],
    pub head_offset: [f64; 3],
    pub record: &'a PlaneRecord,
    pub run_data: &'a Run,
}

/// Additional model columns (candidate effects of the diagnosis).
pub trait ExtraColumns {
    fn count(&self) -> usize;
    /// Writes the `count()` column values of the row.
    fn fill(&self, row: &RowMeta, out: &mut [f64]);
}

/// Column layout of a session's problem.
#[derive(Debug, Clone)]
pub struct Layout {
    /// Mounting names, in order of first appearance.
    pub mountings: Vec<String>,
    /// Mounting index of each plane record.
    pub plane_mounting: Vec<usize>,
    pub n_err: usize,
    pub n_extra: usize,
}

impl Layout {
    pub fn new(session: &Session, n_err: usize, n_extra: usize) -> Layout {
        let mut mountings: Vec<String> = Vec::new();
        let mut plane_mounting = Vec::new();
        for p in &session.planes {
            let i = match mountings.iter().position(|m| *m == p.mounting) {
                Some(i) => i,
                None => {
                    mountings.push(p.mounting.clone());
                    mountings.len() - 1
                }
            };
            plane_mounting.push(i);
        }
        Layout {
            mountings,
            plane_mounting,
            n_err,
            n_extra,
        }
    }
    pub fn n_rot(&self) -> usize {
        self.mountings.len()
    }
    pub fn err_range(&self) -> std::ops::Range<usize> {
        self.n_rot()..self.n_rot() + self.n_err
    }
    pub fn extra_range(&self) -> std::ops::Range<usize> {
        self.n_rot() + self.n_err..self.total()
    }
    pub fn total(&self) -> usize {
        self.n_rot() + self.n_err + self.n_extra
    }
}

/// Fills the design row (rotation | error) of a reading in direction `comp` (0: u, 1: v)
/// of plane record `plane` at commanded position `q`; extra columns are left untouched.
pub(super) fn geometric_row(
    model: &ErrorModel,
    layout: &Layout,
    plane: usize,
    record: &PlaneRecord,
    q: [f64; 3],
    comp: usize,
    out: &mut [f64],
) {
    out[..layout.n_rot() + layout.n_err]
        .iter_mut()
        .for_each(|v| *v = 0.0);
    let (u_ax, v_ax) = record.plane.axes();
    let t = record.head_offset_mm;
    let hu = q[u_ax.index()] + t[u_ax.index()];
    let hv = q[v_ax.index()] + t[v_ax.index()];
    let m = layout.plane_mounting[plane];
    out[m] = if comp == 0 { hv * 1e-3 } else { -hu * 1e-3 };
    let dir = if comp == 0 { u_ax } else { v_ax };
    model.error_row(q, t, dir, &mut out[layout.err_range()]);
}

/// Fills the full design row (rotation | error | extra) of one observation; returns the
/// reading.
fn full_row(
    model: &ErrorModel,
    layout: &Layout,
    extra: Option<&dyn ExtraColumns>,
    meta: &RowMeta,
    out: &mut [f64],
) -> f64 {
    geometric_row(
        model,
        layout,
        meta.plane,
        meta.record,
        meta.q,
        meta.comp,
        out,
    );
    if let Some(x) = extra {
        let r = layout.extra_range();
        out[r.clone()].iter_mut().for_each(|v| *v = 0.0);
        x.fill(meta, &mut out[r]);
    }
    let run = meta.run_data;
    if meta.comp == 0 {
        run.du_um[meta.sample]
    } else {
        run.dv_um[meta.sample]
    }
}

/// Visits every observation of one run, in order (sample, then u before v).
pub fn for_each_row<'a>(
    session: &'a Session,
    plane: usize,
    run: usize,
    mut f: impl FnMut(RowMeta<'a>),
) {
    let record = &session.planes[plane];
    let run_data = &record.runs[run];
    let (u_ax, v_ax) = record.plane.axes();
    for sample in 0..run_data.len() {
        for (comp, dir) in [(0, u_ax), (1, v_ax)] {
            f(RowMeta {
                plane,
                run,
                sample,
                comp,
                dir,
                t_s: run_data.t_s[sample],
                q: run_data.pos_mm[sample],
                head_offset: record.head_offset_mm,
                record,
                run_data,
            });
        }
    }
}

/// A fitted session model.
#[derive(Debug, Clone)]
pub struct Fit {
    pub layout: Layout,
    pub reduced: Reduced,
    pub solution: LsSolution,
    /// Number of (run, direction) groups centred out (two zero offsets per run).
    pub offsets_eliminated: usize,
    /// Runs reduced exactly by [`compress_run`] (the others row by row).
    pub compressed_runs: usize,
}

impl Fit {
    /// Error-parameter block of the solution.
    pub fn error_params(&self) -> &[f64] {
        &self.solution.x[self.layout.err_range()]
    }
}

/// Fits the session model to the runs for which `include(plane, run)` is true.
pub fn fit(
    session: &Session,
    model: &ErrorModel,
    include: &dyn Fn(usize, usize) -> bool,
    extra: Option<&dyn ExtraColumns>,
) -> Fit {
    let layout = Layout::new(session, model.len(), extra.map_or(0, |e| e.count()));
    let k = layout.total();
    let mut acc = QrAccumulator::new(k);
    let mut row = vec![0.0; k];
    let mut groups = 0;
    let mut compressed = 0;
    for (p, rec) in session.planes.iter().enumerate() {
        for r in 0..rec.runs.len() {
            if !include(p, r) || rec.runs[r].is_empty() {
                continue;
            }
            if let Some(rows) = extra
                .is_none()
                .then(|| compress_run(session, model, &layout, p, r))
                .flatten()
            {
                for (a, b) in &rows {
                    acc.push_reduced(a, *b);
                }
                acc.count_observations(2 * rec.runs[r].len());
                groups += 2;
                compressed += 1;
                continue;
            }
            // Pass 1: means of every column and of the readings, per direction.
            let mut sums = [vec![0.0; k + 1], vec![0.0; k + 1]];
            let mut counts = [0usize; 2];
            for_each_row(session, p, r, |m| {
                let b = full_row(model, &layout, extra, &m, &mut row);
                let s = &mut sums[m.comp];
                for j in 0..k {
                    s[j] += row[j];
                }
                s[k] += b;
                counts[m.comp] += 1;
            });
            for c in 0..2 {
                let n = counts[c].max(1) as f64;
                sums[c].iter_mut().for_each(|v| *v /= n);
            }
            groups += 2;
            // Pass 2: centred rows into the reduction.
            for_each_row(session, p, r, |m| {
                let b = full_row(model, &layout, extra, &m, &mut row);
                let mean = &sums[m.comp];
                for j in 0..k {
                    row[j] -= mean[j];
                }
                acc.push(&row, b - mean[k]);
            });
        }
    }
    let reduced = acc.finish();
    let solution = crate::lsq::solve(&reduced, groups);
    Fit {
        layout,
        reduced,
        solution,
        offsets_eliminated: groups,
        compressed_runs: compressed,
    }
}

/// Residuals (reading − model) of every run, with each run's zero offsets taken as the
/// mean of its own residuals (so runs left out of the fit are judged fairly: their
/// offsets are nuisance, not prediction). Indexed [plane][run][sample] = (ru, rv), µm.
pub fn residuals(
    session: &Session,
    model: &ErrorModel,
    fit: &Fit,
    extra: Option<&dyn ExtraColumns>,
) -> Vec<Vec<Vec<[f64; 2]>>> {
    let layout = &fit.layout;
    let x = &fit.solution.x;
    let mut row = vec![0.0; layout.total()];
    let mut vals = Vec::new();
    let mut out = Vec::new();
    for (p, rec) in session.planes.iter().enumerate() {
        let mut runs = Vec::new();
        for r in 0..rec.runs.len() {
            let run = &rec.runs[r];
            let mut res = vec![[0.0; 2]; run.len()];
            if extra.is_some() {
                for_each_row(session, p, r, |m| {
                    let b = full_row(model, layout, extra, &m, &mut row);
                    let pred: f64 = row.iter().zip(x).map(|(a, c)| a * c).sum();
                    res[m.sample][m.comp] = b - pred;
                });
            } else if let Some(interp) = RunInterpolant::new(session, model, layout, p, r) {
                // A line or circle: the prediction is Φ(s) P x, exactly (O(m) per sample).
                let k = layout.n_rot() + layout.n_err;
                let coef = interp
                    .pms
                    .each_ref()
                    .map(|pm| pm * nalgebra::DVector::from_column_slice(&x[..k]));
                let mut phi = vec![0.0; interp.m];
                for (i, q) in run.pos_mm.iter().enumerate() {
                    interp.basis_at_q(q, &mut phi);
                    let pred = coef
                        .each_ref()
                        .map(|c| c.iter().zip(&phi).map(|(a, b)| a * b).sum::<f64>());
                    res[i][0] = run.du_um[i] - pred[0];
                    res[i][1] = run.dv_um[i] - pred[1];
                }
            } else {
                // The same prediction as the design row times x (geometric_row), computed
                // once per sample for both reading directions.
                let (u_ax, v_ax) = rec.plane.axes();
                let t = rec.head_offset_mm;
                let rot = x[layout.plane_mounting[p]];
                let x_err = &x[layout.err_range()];
                for (i, q) in run.pos_mm.iter().enumerate() {
                    let e = model.error_vector(*q, t, x_err, &mut vals);
                    let hu = q[u_ax.index()] + t[u_ax.index()];
                    let hv = q[v_ax.index()] + t[v_ax.index()];
                    res[i][0] = run.du_um[i] - (rot * hv * 1e-3 + e[u_ax.index()]);
                    res[i][1] = run.dv_um[i] - (-rot * hu * 1e-3 + e[v_ax.index()]);
                }
            }
            for c in 0..2 {
                let n = res.len().max(1) as f64;
                let mean = res.iter().map(|v| v[c]).sum::<f64>() / n;
                res.iter_mut().for_each(|v| v[c] -= mean);
            }
            runs.push(res);
        }
        out.push(runs);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simulate::{Plan, SimOptions, random_truth, simulate};

    /// Forces the dense path (an empty set of extra columns).
    struct NoExtra;
    impl ExtraColumns for NoExtra {
        fn count(&self) -> usize {
            0
        }
        fn fill(&self, _row: &RowMeta, _out: &mut [f64]) {}
    }

    /// The exact per-run compression gives the same triangular factor as the dense rows:
    /// same solution, residual sum of squares, covariance and observation count.
    #[test]
    fn per_sample_residuals_equal_design_row_times_solution() {
        // The residuals' fast path (one error vector per sample) against the design row
        // times the solution (the dense path, forced by an empty set of extra columns),
        // on a simulated machine with every term non-zero and two head offsets.
        let out = simulate(
            &random_truth(11),
            &SimOptions {
                plan: Plan::Full,
                sample_rate_hz: 2.0,
                ..Default::default()
            },
        )
        .unwrap();
        let s = &out.session;
        let model = ErrorModel::new(
            Topology::default(),
            BasisKind::Legendre,
            3,
            measured_travel(s),
        );
        let f = fit(s, &model, &|_, _| true, None);
        let runs: usize = s.planes.iter().map(|p| p.runs.len()).sum();
        assert!(
            f.compressed_runs > 0 && f.compressed_runs < runs,
            "both paths are exercised: {} of {runs} runs interpolated",
            f.compressed_runs
        );
        let fast = residuals(s, &model, &f, None);
        let dense = residuals(s, &model, &f, Some(&NoExtra));
        let mut compared = 0;
        for (a, b) in fast
            .iter()
            .flatten()
            .flatten()
            .zip(dense.iter().flatten().flatten())
        {
            for c in 0..2 {
                assert!((a[c] - b[c]).abs() < 1e-9, "{a:?} vs {b:?}");
                compared += 1;
            }
        }
        assert_eq!(compared, 2 * s.sample_count());
        let rms = (fast
            .iter()
            .flatten()
            .flatten()
            .map(|r| r[0] * r[0] + r[1] * r[1])
            .sum::<f64>()
            / (2 * s.sample_count()) as f64)
            .sqrt();
        assert!(
            rms > 0.05 && rms < 0.5,
            "residual RMS {rms} µm (noise 0.15 µm)"
        );
    }

    #[test]
    fn compressed_runs_equal_the_dense_problem() {
        let out = simulate(
            &random_truth(5),
            &SimOptions {
                plan: Plan::Full,
                sample_rate_hz: 5.0,
                ..Default::default()
            },
        )
        .unwrap();
        let s = &out.session;
        let model = ErrorModel::new(
            Topology::default(),
            BasisKind::Polynomial,
            3,
            measured_travel(s),
        );
        let fast = fit(s, &model, &|_, _| true, None);
        let dense = fit(s, &model, &|_, _| true, Some(&NoExtra));
        let runs: usize = s.planes.iter().map(|p| p.runs.len()).sum();
        assert_eq!(
            fast.compressed_runs, runs,
            "every line and circle run compresses"
        );
        assert_eq!(dense.compressed_runs, 0);
        assert_eq!(fast.reduced.rows, dense.reduced.rows);
        assert_eq!(fast.solution.rank, dense.solution.rank);
        let rel = (fast.solution.rss - dense.solution.rss).abs() / dense.solution.rss;
        assert!(
            rel < 1e-8,
            "rss {} vs {}",
            fast.solution.rss,
            dense.solution.rss
        );
        for j in 0..fast.solution.x.len() {
            let (a, b) = (fast.solution.x[j], dense.solution.x[j]);
            let sd = dense.solution.cov[(j, j)].sqrt();
            assert!(
                (a - b).abs() < 1e-6 * sd.max(1e-9) + 1e-9 * b.abs(),
                "param {j}: {a} vs {b}"
            );
            let (ca, cb) = (fast.solution.cov[(j, j)], dense.solution.cov[(j, j)]);
            assert!((ca - cb).abs() < 1e-6 * cb, "var {j}: {ca} vs {cb}");
        }
    }
}
