//! Diagnosis of a grid-encoder session: locate the misfit of the rigid (21-term) model,
//! explain it with the catalogue of effects fitted jointly with the model, and prove the
//! gain on whole runs held out of the fit.
//!
//! The loop is the diagnosis engine's ([`super::engine::run`]); a session is its
//! [`super::engine::Greedy`] problem on per-run moments:
//! 1. the state is the current model (rigid terms, plate rotations, run offsets
//!    eliminated, plus the effects accepted so far) fitted on all runs: its residual r,
//!    SSR and K-fold held-out SSR (folds of whole runs: run index within its file mod K);
//! 2. every candidate of the catalogue has its nonlinear parameter searched and is fitted
//!    jointly ([`try_candidate`]), giving ΔBIC = n·ln(SSR₁/SSR₀) + (m + n_nonlinear)·ln n
//!    and the held-out RMS;
//! 3. of those with ΔBIC ≤ −10 and a held-out RMS gain ≥ 0.5 %, the engine's parsimonious
//!    choice is admitted when plausible and determined, otherwise set aside (rejected or
//!    possible) and never tried again; the loop repeats until none qualifies (reaching
//!    the noise floor does not stop the search: a small effect near the floor is still
//!    found on its evidence).

use super::catalogue::{self, Candidate, Columns, Search};
use super::design::{self, Design};
use super::effects;
use super::engine::{self, Admission, Rules, Score};
use super::linalg::{Cols, dot};
use super::moments::{self, Moments, Sets};
use super::periodic_scan;
use super::reduced::Reduction;
use super::thermal_search::ThermalBasis;
use super::{
    Baseline, BeforeAfter, DiagnosisResult, Finding, Mismatch, Monotone, NoProgress, PlotData,
    PlotKind, PlotSeries, Progress,
};
use crate::axis::Topology;
use crate::error::SolverError;
use crate::session::{Session, TestKind};
use crate::terms::{Component, Term};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Options of a session diagnosis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct DiagnoseOptions {
    /// Polynomial order of the rigid model's error functions (default 3).
    pub order: usize,
    /// Number of held-out folds of whole runs (default 3).
    pub folds: usize,
    /// At most this many findings (default 4).
    pub max_findings: usize,
    /// Minimum BIC decrease to accept an effect (default 10: "very strong" evidence).
    pub min_bic_gain: f64,
    /// Minimum relative decrease of the held-out RMS (default 0.005).
    pub min_heldout_gain: f64,
    /// Held-out RMS within this factor of the noise floor counts as noise level (1.2).
    pub noise_level_ratio: f64,
    /// Topology when the session declares none.
    pub topology: Option<Topology>,
}

impl Default for DiagnoseOptions {
    fn default() -> Self {
        DiagnoseOptions {
            order: 3,
            folds: 3,
            max_findings: 4,
            min_bic_gain: 10.0,
            min_heldout_gain: 0.005,
            noise_level_ratio: 1.2,
            topology: None,
        }
    }
}

/// The current model (rigid terms and the accepted effects) fitted on all runs and on
/// each fold's training runs.
struct Fit {
    /// Accepted effect columns (centred, unit norm).
    cols: Cols,
    /// Moments of [accepted effects | y] (the base of every joint fit).
    base: moments::Base,
    /// Coefficients of the rigid columns (scaled) on all runs.
    a: Vec<f64>,
    resid: Vec<f64>,
    ssr: f64,
    heldout_ssr: f64,
    /// Numerical rank of [rigid | effects] on all runs.
    rank: usize,
}

/// Fits the rigid model plus the effect columns `cols` on all runs and on the training
/// runs of each fold, and forms the residual on all rows.
fn fit(d: &Design, red: &Reduction, sets: &Sets, cols: Cols) -> Fit {
    let base = moments::Base::new(red, sets, Moments::of_columns(red, &base_columns(d, &cols)));
    let jf = moments::joint_fit(red, sets, None, &base, true);
    let mut resid = d.y.clone();
    for (col, e) in cols.iter().zip(&jf.all.x) {
        resid.iter_mut().zip(col).for_each(|(r, v)| *r -= e * v);
    }
    for (g, rs) in red.runs.iter().enumerate() {
        let pa = red.predict_reduced(g, &jf.all.a);
        for i in 0..rs.rows {
            let (off, q) = rs.row(i);
            resid[rs.row0 + i] -= dot(&pa[off..off + q.len()], q);
        }
    }
    Fit {
        rank: sets.all.rank() + jf.all.rank,
        cols,
        base,
        a: jf.all.a,
        resid,
        ssr: jf.all.ssr,
        heldout_ssr: jf.heldout_ssr,
    }
}

/// The base columns U = [accepted effects `cols` | y] of every joint fit.
fn base_columns<'a>(d: &'a Design, cols: &'a Cols) -> Vec<&'a [f64]> {
    cols.iter()
        .map(Vec::as_slice)
        .chain([d.y.as_slice()])
        .collect()
}

/// A candidate fitted jointly with the current model.
#[derive(Clone)]
struct Trial {
    cand: Candidate,
    theta: Option<(&'static str, f64)>,
    /// Number of columns.
    ncols: usize,
    names: Vec<String>,
    /// Largest |value| of each column before centring (its size as a machine error per
    /// unit coefficient).
    peaks: Vec<f64>,
    coef: Vec<f64>,
    coef_sd: Vec<f64>,
    /// Σ over the rows of the centred columns' cross-products (for the fitted RMS).
    gram: nalgebra::DMatrix<f64>,
    ssr: f64,
    heldout_ssr: f64,
    dbic: f64,
    extra_params: usize,
}

/// The joint fit of the current model plus a candidate's columns: its moments (one pass
/// over the rows), the columns that vary, and the fit on all runs (and the folds, with
/// `heldout`).
fn evaluate(
    d: &Design,
    red: &Reduction,
    sets: &Sets,
    f: &Fit,
    specs: &Columns,
    heldout: bool,
) -> Option<(Moments, Vec<usize>, moments::JointFit)> {
    // Columns that follow one axis are constant on the runs that do not move it: the
    // centring per run removes them there (their moments are 0).
    let parked = specs.follows().map(|a| parked_runs(d, a));
    let mom = Moments::new_on(
        red,
        specs.len(),
        &base_columns(d, &f.cols),
        |row| {
            specs.live(d, row)
                && parked
                    .as_ref()
                    .is_none_or(|p| !p[d.samples[row / 2].run_idx])
        },
        |row, out| specs.at(d, row, out),
    );
    fit_moments(red, sets, f, mom, heldout)
}

/// Per run: whether axis `a` keeps one position over the whole run.
fn parked_runs(d: &Design, a: crate::axis::Axis) -> Vec<bool> {
    d.runs.iter().map(|r| r.parked[a.index()]).collect()
}

/// The joint fit of the current model plus the columns of `mom` that vary (none vary:
/// `None`), with those columns' indices.
fn fit_moments(
    red: &Reduction,
    sets: &Sets,
    f: &Fit,
    mom: Moments,
    heldout: bool,
) -> Option<(Moments, Vec<usize>, moments::JointFit)> {
    let keep: Vec<usize> = (0..mom.m).filter(|&j| mom.varies[j]).collect();
    if keep.is_empty() {
        return None;
    }
    let mom = if keep.len() == mom.m {
        mom
    } else {
        mom.select(&keep)
    };
    let jf = moments::joint_fit(red, sets, Some(&mom), &f.base, heldout);
    Some((mom, keep, jf))
}

/// SSR of the current model plus the candidate's columns at θ (∞ when it has none).
fn ssr_at(
    d: &Design,
    red: &Reduction,
    sets: &Sets,
    f: &Fit,
    cand: &Candidate,
    theta: f64,
    eps: Option<&[[f64; 3]]>,
) -> f64 {
    let specs = catalogue::specs(d, cand, theta, eps);
    evaluate(d, red, sets, f, &specs, false).map_or(f64::INFINITY, |(_, _, jf)| jf.all.ssr)
}

/// Per run that moves `axis`: the rows read along it less than `reach` mm of travel after
/// the axis's last reversal, as (index counted from the run's first row, travel since
/// reversal). A run that does not move the axis has a constant column (none).
fn near_rows(
    d: &Design,
    red: &Reduction,
    axis: crate::axis::Axis,
    reach: f64,
) -> Vec<Vec<(usize, f64)>> {
    let parked = parked_runs(d, axis);
    red.runs
        .iter()
        .zip(parked)
        .map(|(rs, parked)| {
            (0..if parked { 0 } else { rs.rows })
                .filter_map(|i| {
                    let row = rs.row0 + i;
                    let x = d.fields.since_reversal_mm[axis.index()][row / 2];
                    (d.row_axis(row) == axis && x < reach).then_some((i, x))
                })
                .collect()
        })
        .collect()
}

/// Most frequencies in one scan, and the most (row, frequency) pairs a scan evaluates.
const MAX_SCAN_FREQS: usize = 2000;
const MAX_SCAN_WORK: usize = 20_000_000;

/// Frequency (in `freqs`, evenly spaced) whose sine/cosine pair of `var` along `axis`
/// explains most of the residual `r`, with the columns centred per (run, component) like
/// the model. With `per_run` each run gets its own phase (incoherent sum, for a coarse
/// scan in time).
///
/// This is a scan heuristic only: the 2×2 moment system of each candidate frequency is
/// solved in closed form; the chosen frequency is then fitted jointly. The work is bounded:
/// whole runs, every `stride`-th, so that at most [`MAX_SCAN_WORK`] (row, frequency) pairs
/// are evaluated (the runs chosen still span the session). Each run's moments at every
/// frequency come from [`periodic_scan::run_moments`].
fn periodic_best(
    d: &Design,
    r: &[f64],
    axis: crate::axis::Axis,
    var: &[f64],
    freqs: &[f64],
    per_run: bool,
) -> Option<f64> {
    let nf = freqs.len();
    let f0 = *freqs.first()?;
    let reads = |run: &design::RunInfo| {
        let (u, v) = d.plane_axes[run.plane_idx];
        u == axis || v == axis
    };
    let axis_rows: usize = d
        .runs
        .iter()
        .filter(|r| reads(r))
        .map(|r| r.end - r.start)
        .sum();
    let stride = (axis_rows * nf).div_ceil(MAX_SCAN_WORK).max(1);
    let df = if nf > 1 { freqs[1] - f0 } else { 0.0 };
    // Explained sum of squares of the centred 2-column fit from its moments
    // (ss, cc, sc, rs, rc).
    let solve = |m: &[f64; 5]| {
        let [ss, cc, sc, rs, rc] = *m;
        let det = ss * cc - sc * sc;
        if det <= 1e-12 * (ss * cc).max(1e-300) {
            return 0.0;
        }
        let a = (cc * rs - sc * rc) / det;
        let b = (ss * rc - sc * rs) / det;
        a * rs + b * rc
    };
    let mut score = vec![0.0; nf];
    let mut total = vec![[0.0; 5]; nf];
    let mut mom = vec![[0.0; 5]; nf];
    let mut sums = vec![[0.0; 7]; nf];
    let mut any = false;
    // Per row of a run: its residual and variable.
    let mut rv = Vec::new();
    let mut xs = Vec::new();
    for (ri, run) in d.runs.iter().enumerate() {
        if ri % stride != 0 || !reads(run) {
            continue;
        }
        rv.clear();
        xs.clear();
        // The run's rows read along `axis` (one component of each sample).
        for row in 2 * run.start..2 * run.end {
            if d.row_axis(row) != axis {
                continue;
            }
            rv.push(r[row]);
            xs.push(var[row / 2]);
        }
        if rv.is_empty() {
            continue;
        }
        any = true;
        // A variable constant over the run gives constant columns, which its centring
        // removes: the run adds nothing to any frequency's moments.
        if xs.iter().all(|&x| x == xs[0]) {
            continue;
        }
        // The run's moments [ss, cc, sc, rs, rc] at every frequency: in closed form on
        // its evenly spaced stretches, by rotating phasors elsewhere ([`periodic_scan`]).
        periodic_scan::run_moments(&rv, &xs, f0, df, &mut sums, &mut mom);
        for (k, m) in mom.iter().enumerate() {
            if per_run {
                score[k] += solve(m);
            } else {
                for j in 0..5 {
                    total[k][j] += m[j];
                }
            }
        }
    }
    if !any {
        return None;
    }
    if !per_run {
        for k in 0..nf {
            score[k] = solve(&total[k]);
        }
    }
    let kbest = (0..nf).max_by(|&a, &b| score[a].total_cmp(&score[b]))?;
    Some(freqs[kbest])
}

/// Σ_k ε_k(q_k) (µrad) at every sample of the runs whose head offset is one of `groups`,
/// from the current fit's error parameters; 0 on the other runs (the setup-offset
/// columns, which alone read it, are 0 there).
fn eps_per_sample(d: &Design, red: &Reduction, f: &Fit, groups: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let x: Vec<f64> = (0..d.model.len()).map(|j| f.a[j] / red.scale[j]).collect();
    // The rotation terms: (its value as a function of q, its axis, the rotation's
    // direction).
    let rot: Vec<_> = Term::all()
        .into_iter()
        .enumerate()
        .filter_map(|(i, term)| match term.component {
            Component::Rotation(dir) => {
                Some((d.model.term_fn(i, &x), term.axis.index(), dir.index()))
            }
            _ => None,
        })
        .collect();
    // Consecutive samples often share an axis position (a parked axis): a term's value
    // is evaluated again only when its axis's position changes. One pass over the
    // samples, each sample's terms added in term order.
    let mut last = vec![(f64::NAN, 0.0); rot.len()];
    let mut out = vec![[0.0; 3]; d.samples.len()];
    let runs = d
        .runs
        .iter()
        .filter(|r| groups.contains(&d.samples[r.start].head_mm));
    for s in runs.flat_map(|r| r.start..r.end) {
        let o = &mut out[s];
        for ((value, a, dir), last) in rot.iter().zip(last.iter_mut()) {
            let (a, dir) = (*a, *dir);
            let q = d.fields.q_mm[a][s];
            if q != last.0 {
                *last = (q, value(q));
            }
            o[dir] += last.1;
        }
    }
    out
}

/// The scan fits each frequency to the current model's residual alone; fitted jointly with
/// the rigid terms, whose polynomials absorb part of a long period, the best frequency can
/// lie elsewhere within a coarse step (a 35 mm waviness over 100 mm of travel scans at
/// 33 mm). A position-periodic candidate with evidence at the scanned frequency `f0`
/// (ΔBIC = n·ln(SSR₁/SSR₀) + 3·ln n < 0) has its frequency refined by golden section on
/// the exact joint SSR within `f0 ± step` (at least `f_lo`/2); the scanned one is kept
/// unless the refined one fits better. Candidates without evidence (nearly all, on a
/// clean session) cost nothing more.
#[allow(clippy::too_many_arguments)]
fn refine_on_joint_fit(
    d: &Design,
    red: &Reduction,
    sets: &Sets,
    f: &Fit,
    cand: &Candidate,
    eps: Option<&[[f64; 3]]>,
    f0: f64,
    step: f64,
    f_lo: f64,
) -> f64 {
    let ssr = |v: f64| ssr_at(d, red, sets, f, cand, v, eps);
    let s0 = ssr(f0);
    let n = d.rows() as f64;
    if !s0.is_finite() || n * (s0 / f.ssr).ln() + 3.0 * n.ln() >= 0.0 {
        return f0;
    }
    let br = super::search::golden_section((f0 - step).max(0.5 * f_lo), f0 + step, 12, ssr);
    let (v, s) = br.best();
    if s < s0 { v } else { f0 }
}

#[allow(clippy::too_many_arguments)]
fn try_candidate(
    d: &Design,
    red: &Reduction,
    sets: &Sets,
    f: &Fit,
    cand: &Candidate,
    eps: Option<&[[f64; 3]]>,
) -> Option<Trial> {
    let n = d.rows() as f64;
    let (theta, extra) = match catalogue::search(d, cand) {
        Search::None => (None, 0),
        Search::Grid(name, values) => {
            // The thermal time constant is searched on the reduced problem
            // ([`ThermalBasis`]); other parameters from their columns.
            let basis = (cand.effect == "thermal_drift")
                .then(|| ThermalBasis::new(d, red, &base_columns(d, &f.cols)));
            // A candidate that vanishes away from its axis's reversals (the spike) is
            // evaluated on the rows within its reach at the largest value searched (the
            // golden section stays within a grid ratio of the grid; 1 % margin).
            let ratio = values.get(1).map_or(2.0, |v1| v1 / values[0]);
            let top = values.iter().copied().fold(0.0, f64::max) * ratio * 1.01;
            let near = catalogue::reach(cand, top).map(|(a, x)| near_rows(d, red, a, x));
            let ssr_at = |v: f64| match (&basis, &near) {
                (Some(b), _) => {
                    moments::joint_fit(red, sets, Some(&b.at(v)), &f.base, false)
                        .all
                        .ssr
                }
                (None, Some(near)) => {
                    let reach = catalogue::reach(cand, v).map_or(f64::INFINITY, |r| r.1);
                    let specs = catalogue::specs(d, cand, v, eps);
                    let mom = Moments::over_rows(
                        red,
                        specs.len(),
                        &base_columns(d, &f.cols),
                        |g, _, out| out.extend(near[g].iter().filter(|p| p.1 < reach).map(|p| p.0)),
                        |row, out| specs.at(d, row, out),
                    );
                    fit_moments(red, sets, f, mom, false)
                        .map_or(f64::INFINITY, |(_, _, jf)| jf.all.ssr)
                }
                (None, None) => ssr_at(d, red, sets, f, cand, v, eps),
            };
            let mut best: Option<(f64, f64)> = None;
            for &v in &values {
                let ssr = ssr_at(v);
                if !ssr.is_finite() {
                    return None;
                }
                if best.is_none_or(|(s, _)| ssr < s) {
                    best = Some((ssr, v));
                }
            }
            // Golden-section refinement in log θ around the best grid value.
            let (_, v0) = best?;
            let eval = |lv: f64| ssr_at(lv.exp());
            let bracket =
                super::search::golden_section((v0 / ratio).ln(), (v0 * ratio).ln(), 10, eval);
            (Some((name, bracket.centre().exp())), 1)
        }
        Search::Periodic {
            name,
            f_lo,
            f_hi,
            coarse_step,
            fine_step,
            in_time,
            as_period,
        } => {
            if f_hi <= f_lo {
                return None;
            }
            // The variable per sample: time, or the axis's position.
            let (axis, in_var) = if in_time {
                (cand.direction?, &d.fields.t_s)
            } else {
                // Rows read along the effect's direction (its own axis for `cyclic`).
                let a = cand.axis?;
                (cand.direction.unwrap_or(a), &d.fields.q_mm[a.index()])
            };
            // Scan sizes are bounded (a heuristic: the exact joint fit follows): at most
            // MAX_SCAN_FREQS coarse and fine frequencies.
            let coarse_step = coarse_step.max((f_hi - f_lo) / MAX_SCAN_FREQS as f64);
            let fine_step = fine_step.max(2.0 * coarse_step / MAX_SCAN_FREQS as f64);
            let coarse: Vec<f64> = (0..)
                .map(|i| f_lo + i as f64 * coarse_step)
                .take_while(|&x| x <= f_hi)
                .collect();
            let c0 = periodic_best(d, &f.resid, axis, in_var, &coarse, in_time)?;
            let fine: Vec<f64> = (0..)
                .map(|i| (c0 - coarse_step).max(0.5 * f_lo) + i as f64 * fine_step)
                .take_while(|&x| x <= c0 + coarse_step)
                .collect();
            let best = periodic_best(d, &f.resid, axis, in_var, &fine, false)?;
            let best = if in_time {
                best
            } else {
                refine_on_joint_fit(d, red, sets, f, cand, eps, best, coarse_step, f_lo)
            };
            // Columns take a frequency; `report_parameters` turns it into a period.
            let _ = as_period;
            (Some((name, best)), 1)
        }
    };
    let th = theta.map_or(0.0, |t| t.1);
    let specs = catalogue::specs(d, cand, th, eps);
    let (mom, keep, jf) = evaluate(d, red, sets, f, &specs, true)?;
    let m = keep.len();
    let ssr = jf.all.ssr;
    let k = m + extra;
    let dbic = n * (ssr / f.ssr).ln() + k as f64 * n.ln();
    Some(Trial {
        cand: cand.clone(),
        theta,
        ncols: m,
        names: keep.iter().map(|&j| specs.names[j].clone()).collect(),
        peaks: mom.peaks.clone(),
        coef: jf.all.x[..m].to_vec(),
        coef_sd: jf.all.sd[..m].to_vec(),
        gram: mom.gram(),
        ssr,
        heldout_ssr: jf.heldout_ssr,
        dbic,
        extra_params: extra,
    })
}

/// Physical parameters of an accepted trial (with `std_*` uncertainties), scaled by the
/// residual standard deviation `sigma` of the joint fit.
fn report_parameters(t: &Trial, sigma: f64, d: &Design) -> BTreeMap<String, f64> {
    let mut p = BTreeMap::new();
    let sd = |i: usize| t.coef_sd[i] * sigma;
    if let Some((name, v)) = t.theta {
        if name == "period_mm" {
            p.insert("period_mm".into(), 1.0 / v);
        } else {
            p.insert(name.into(), v);
        }
    }
    let idx = |n: &str| t.names.iter().position(|x| x == n);
    if let (Some(i), Some(j)) = (idx("sin"), idx("cos")) {
        let (a, b) = (t.coef[i], t.coef[j]);
        p.insert("amplitude_um".into(), a.hypot(b));
        p.insert("std_amplitude_um".into(), sd(i).max(sd(j)));
        p.insert("phase_rad".into(), b.atan2(a));
        return p;
    }
    if t.cand.effect == "model_order" {
        // Size of the extra (higher-order) function as seen in the data: RMS of its fit.
        let n = d.rows() as f64;
        let c = nalgebra::DVector::from_column_slice(&t.coef);
        let rms = ((c.transpose() * &t.gram * &c)[(0, 0)].max(0.0) / n).sqrt();
        p.insert("rms_um".into(), rms);
        p.insert("extra_order".into(), 10.0);
        return p;
    }
    for (i, name) in t.names.iter().enumerate() {
        p.insert(name.clone(), t.coef[i]);
        p.insert(format!("std_{name}"), sd(i));
    }
    p
}

fn run_id(d: &Design, ri: usize) -> String {
    let r = &d.runs[ri];
    format!("{}#run {}", d.files[r.plane_idx], r.number)
}

/// Splits the squared residual above the noise floor by place and signature.
fn locate(d: &Design, r: &[f64], sigma: f64) -> Vec<Mismatch> {
    let excess = |rows: &mut dyn Iterator<Item = usize>| -> f64 {
        rows.map(|i| r[i] * r[i] - sigma * sigma).sum::<f64>()
    };
    let total = excess(&mut (0..r.len())).max(1e-300);
    let mut out: Vec<Mismatch> = Vec::new();
    let mut add = |where_: String, runs: Vec<usize>, e: f64| {
        if e / total >= 0.1 {
            out.push(Mismatch {
                where_,
                tests: runs.iter().take(6).map(|&ri| run_id(d, ri)).collect(),
                share_of_misfit: (e / total).min(1.0),
            });
        }
    };
    // By file and test kind.
    for (pi, file) in d.files.iter().enumerate() {
        for kind in [
            TestKind::LineX,
            TestKind::LineY,
            TestKind::LineZ,
            TestKind::CircleCcw,
            TestKind::CircleCw,
            TestKind::Free,
        ] {
            let runs: Vec<usize> = (0..d.runs.len())
                .filter(|&i| d.runs[i].plane_idx == pi && d.runs[i].test == kind)
                .collect();
            if runs.is_empty() {
                continue;
            }
            let e = excess(
                &mut runs
                    .iter()
                    .flat_map(|&i| 2 * d.runs[i].start..2 * d.runs[i].end),
            );
            add(format!("{file}: {} runs", kind.name()), runs, e);
        }
    }
    // Circles by angle sector (all circles together).
    for sector in 0..12 {
        let lo = sector as f64 * 30.0;
        let mut runs = Vec::new();
        let mut rows = Vec::new();
        for (ri, run) in d.runs.iter().enumerate() {
            if !matches!(run.test, TestKind::CircleCcw | TestKind::CircleCw) {
                continue;
            }
            let (u, v) = d.plane_axes[run.plane_idx];
            for s in run.start..run.end {
                let q = d.samples[s].q_mm;
                let ang = q[v.index()]
                    .atan2(q[u.index()])
                    .to_degrees()
                    .rem_euclid(360.0);
                if ang >= lo && ang < lo + 30.0 {
                    rows.push(2 * s);
                    rows.push(2 * s + 1);
                    if runs.last() != Some(&ri) {
                        runs.push(ri);
                    }
                }
            }
        }
        let e = excess(&mut rows.into_iter());
        add(
            format!("circle runs, angle {lo:.0}..{:.0} deg", lo + 30.0),
            runs,
            e,
        );
    }
    // Line passes near their reversal (first 10 % of travel) versus the rest.
    let mut near = Vec::new();
    let mut near_runs = Vec::new();
    for (ri, run) in d.runs.iter().enumerate() {
        let i = match run.test {
            TestKind::LineX => 0,
            TestKind::LineY => 1,
            TestKind::LineZ => 2,
            _ => continue,
        };
        let Some([lo, hi]) = d.travel[i] else {
            continue;
        };
        for s in run.start..run.end {
            if d.samples[s].since_reversal_mm[i] < 0.1 * (hi - lo) {
                near.push(2 * s);
                near.push(2 * s + 1);
                if near_runs.last() != Some(&ri) {
                    near_runs.push(ri);
                }
            }
        }
    }
    let e = excess(&mut near.into_iter());
    add(
        "line passes, first 10 % of travel after each reversal".into(),
        near_runs,
        e,
    );
    // By time, in fifths of the session.
    let (t0, t1) = (d.samples[0].t_s, d.samples[d.samples.len() - 1].t_s);
    for k in 0..5 {
        let (a, b) = (
            t0 + (t1 - t0) * k as f64 / 5.0,
            t0 + (t1 - t0) * (k + 1) as f64 / 5.0,
        );
        let runs: Vec<usize> = (0..d.runs.len())
            .filter(|&i| {
                let t = d.samples[d.runs[i].start].t_s;
                t >= a && (t < b || k == 4)
            })
            .collect();
        let e = excess(
            &mut runs
                .iter()
                .flat_map(|&i| 2 * d.runs[i].start..2 * d.runs[i].end),
        );
        add(format!("session time {a:.0}..{b:.0} s"), runs, e);
    }
    out.sort_by(|a, b| b.share_of_misfit.total_cmp(&a.share_of_misfit));
    out.truncate(6);
    out
}

fn rms(ssr: f64, n: usize) -> f64 {
    (ssr / n.max(1) as f64).sqrt()
}

/// Polar plot of the first circle's radial residual and per-run RMS against time, before
/// and after the findings.
fn plots(d: &Design, before: &[f64], after: &[f64]) -> Vec<PlotData> {
    let mut out = Vec::new();
    if let Some(run) = d
        .runs
        .iter()
        .find(|r| matches!(r.test, TestKind::CircleCcw | TestKind::CircleCw))
    {
        let (u, v) = d.plane_axes[run.plane_idx];
        let series = |r: &[f64], name: &str| {
            let mut x = Vec::new();
            let mut y = Vec::new();
            for s in run.start..run.end {
                let q = d.samples[s].q_mm;
                let th = q[v.index()].atan2(q[u.index()]);
                x.push(th.to_degrees().rem_euclid(360.0));
                y.push(r[2 * s] * th.cos() + r[2 * s + 1] * th.sin());
            }
            PlotSeries {
                name: name.into(),
                x,
                y,
            }
        };
        out.push(PlotData {
            id: "circle_polar".into(),
            title: format!(
                "{} run {}: radial residual",
                d.files[run.plane_idx], run.number
            ),
            x_label: "angle (deg)".into(),
            y_label: "radial residual (um)".into(),
            kind: PlotKind::Polar,
            series: vec![series(before, "before"), series(after, "after")],
        });
    }
    let per_run = |r: &[f64], name: &str| {
        let mut x = Vec::new();
        let mut y = Vec::new();
        for run in &d.runs {
            let rows = 2 * run.start..2 * run.end;
            let n = rows.len();
            x.push(0.5 * (d.samples[run.start].t_s + d.samples[run.end - 1].t_s));
            y.push((rows.map(|i| r[i] * r[i]).sum::<f64>() / n as f64).sqrt());
        }
        PlotSeries {
            name: name.into(),
            x,
            y,
        }
    };
    out.push(PlotData {
        id: "rms_vs_time".into(),
        title: "residual RMS of each run against session time".into(),
        x_label: "time (s)".into(),
        y_label: "RMS (um)".into(),
        kind: PlotKind::Cartesian,
        series: vec![per_run(before, "before"), per_run(after, "after")],
    });
    out
}

/// The finding of a trial: before/after figures from the current fit `f` and, once the
/// effect is added, the new fit `nf` (without it, the trial's own figures).
fn finding_of(
    t: &Trial,
    parameters: BTreeMap<String, f64>,
    f: &Fit,
    nf: Option<&Fit>,
    h_before: f64,
    (n, heldout_n): (usize, usize),
    folds: usize,
    floor: f64,
) -> Finding {
    let (after, h_after) = match nf {
        Some(nf) => (rms(nf.ssr, n), rms(nf.heldout_ssr, heldout_n)),
        None => (rms(t.ssr, n), rms(t.heldout_ssr, heldout_n)),
    };
    Finding {
        effect: catalogue::reported_name(t.cand.effect).into(),
        axis: t
            .cand
            .axis
            .map(|a| a.to_string())
            .or(t.cand.direction.map(|a| a.to_string())),
        parameters,
        physics: effects::physics(catalogue::reported_name(t.cand.effect)).into(),
        signature: catalogue::signature(&t.cand, t.theta.map(|x| x.1)),
        undetermined: vec![],
        residual_rms_um: BeforeAfter {
            before: rms(f.ssr, n),
            after,
        },
        heldout_rms_um: BeforeAfter {
            before: h_before,
            after: h_after,
        },
        evidence: format!(
            "{}: BIC {:+.1} with {} extra parameter(s); held-out RMS {:.3} -> {:.3} um over {} folds of whole runs; noise floor {:.3} um",
            t.cand.label(),
            t.dbic,
            t.ncols + t.extra_params,
            h_before,
            h_after,
            folds,
            floor
        ),
    }
}

/// Standard uncertainty of a trial's nonlinear parameter from the curvature of the
/// profiled sum of squares S(θ) (the linear parameters re-fitted at every θ):
/// var(θ̂) = 2σ²/S''(θ̂), by central differences (in ln θ for time constants and decay
/// lengths, in frequency for periods and frequencies). Returns the reported name and σ;
/// infinite when S is not convex there (θ not determined).
fn theta_std(
    d: &Design,
    red: &Reduction,
    sets: &Sets,
    f: &Fit,
    t: &Trial,
    eps: Option<&[[f64; 3]]>,
    sigma: f64,
) -> Option<(&'static str, f64)> {
    let (name, th) = t.theta?;
    let ssr_at = |v: f64| {
        let s = ssr_at(d, red, sets, f, &t.cand, v, eps);
        if s.is_finite() { s } else { f64::NAN }
    };
    let (log, h) = match catalogue::search(d, &t.cand) {
        Search::Periodic { fine_step, .. } => (false, fine_step),
        _ => (true, 0.02),
    };
    let (lo, hi) = if log {
        (th * (-h).exp(), th * h.exp())
    } else {
        (th - h, th + h)
    };
    let curv = (ssr_at(lo) + ssr_at(hi) - 2.0 * t.ssr) / (h * h);
    let sd_lin = if curv > 0.0 {
        (2.0 * sigma * sigma / curv).sqrt()
    } else {
        f64::INFINITY
    };
    Some(match (name, log) {
        (_, true) => (name, th * sd_lin),
        ("period_mm", false) => ("period_mm", sd_lin / (th * th)),
        _ => (name, sd_lin),
    })
}

/// Diagnoses a grid-encoder session: see the module documentation.
pub fn diagnose_session(
    session: &Session,
    opts: &DiagnoseOptions,
) -> Result<DiagnosisResult, SolverError> {
    diagnose_session_with_progress(session, opts, &mut NoProgress)
}

/// A session as a problem of the diagnosis engine ([`super::engine`]): its state is the
/// current model fitted on per-run moments, its candidates the catalogue's, each evaluated
/// by [`try_candidate`]; a choice is admitted when its parameters are plausible
/// ([`effects::implausible`]) and determined ([`effects::classify`]), and set aside (never
/// tried again) otherwise.
struct SessionProblem<'a> {
    d: &'a Design,
    red: &'a Reduction,
    sets: &'a Sets,
    cands: Vec<Candidate>,
    floor: f64,
    /// Residual degrees of freedom of the rigid model.
    dof: usize,
    folds: usize,
    /// The head offsets of the setup-offset candidates, whose columns need the
    /// per-sample rotation errors on the runs of those groups (none: not needed).
    eps_groups: Vec<[f64; 3]>,
}

/// The current model: its fit, the parameters added to the rigid model, and the rigid
/// model's rotation errors at every sample when a candidate needs them.
struct State {
    fit: Fit,
    k: usize,
    eps: Option<Vec<[f64; 3]>>,
}

/// What the session says of a candidate the loop chose.
enum Note {
    Finding(Finding),
    Possible(Finding),
    Rejected(String),
}

impl SessionProblem<'_> {
    fn state(&self, fit: Fit, k: usize) -> State {
        State {
            eps: (!self.eps_groups.is_empty())
                .then(|| eps_per_sample(self.d, self.red, &fit, &self.eps_groups)),
            fit,
            k,
        }
    }

    fn heldout_rms(&self, f: &Fit) -> f64 {
        rms(f.heldout_ssr, self.sets.heldout_n)
    }
}

impl super::engine::Greedy for SessionProblem<'_> {
    type State = State;
    type Candidate = Candidate;
    type Trial = Trial;
    type Note = Note;

    fn noise_floor(&self) -> f64 {
        self.floor
    }
    fn n_fit(&self) -> usize {
        self.d.rows()
    }
    fn n_heldout(&self) -> usize {
        self.sets.heldout_n
    }
    fn score(&self, s: &State) -> Score {
        Score {
            sse: s.fit.ssr,
            heldout_sse: s.fit.heldout_ssr,
            k: s.k as f64,
        }
    }
    fn candidates(&self, _: &State) -> Vec<Candidate> {
        self.cands.clone()
    }
    fn label(&self, c: &Candidate) -> String {
        c.label()
    }
    fn evaluate(&self, s: &State, c: &Candidate) -> Option<(Score, Trial)> {
        let t = try_candidate(self.d, self.red, self.sets, &s.fit, c, s.eps.as_deref())?;
        let score = Score {
            sse: t.ssr,
            heldout_sse: t.heldout_ssr,
            k: (s.k + t.ncols + t.extra_params) as f64,
        };
        Some((score, t))
    }
    fn admit(&self, s: &State, c: &Candidate, t: &Trial) -> Admission<Note> {
        let (d, f) = (self.d, &s.fit);
        let n = d.rows();
        let sigma = (t.ssr
            / (self.dof.saturating_sub(s.k + t.ncols + t.extra_params)).max(1) as f64)
            .sqrt();
        let mut params = report_parameters(t, sigma, d);
        if let Some((name, sd)) = theta_std(d, self.red, self.sets, f, t, s.eps.as_deref(), sigma) {
            params.insert(format!("std_{name}"), sd);
        }
        let explained = ((f.ssr - t.ssr).max(0.0) / n as f64).sqrt();
        let size: f64 = t
            .coef
            .iter()
            .zip(&t.peaks)
            .map(|(c, p)| (c * p).abs())
            .sum();
        if let Some(why) = effects::implausible(&c.label(), size, explained, self.floor) {
            return Admission::SetAside(Note::Rejected(why));
        }
        let finding = finding_of(
            t,
            params,
            f,
            None,
            self.heldout_rms(f),
            (n, self.sets.heldout_n),
            self.folds,
            self.floor,
        );
        match effects::classify(finding) {
            effects::Sorted::Determined(f) => Admission::Add(Note::Finding(f)),
            effects::Sorted::Possible(f) => Admission::SetAside(Note::Possible(f)),
        }
    }
    /// The model refitted with the trial's columns (centred, unit norm); its finding with
    /// the refitted figures.
    fn add(&self, s: &State, c: &Candidate, t: Trial, note: Note) -> (State, Note) {
        let d = self.d;
        let mut cols = s.fit.cols.clone();
        let th = t.theta.map_or(0.0, |x| x.1);
        let (new_cols, _, _) = catalogue::columns(d, c, th, s.eps.as_deref());
        for c in &new_cols {
            let nrm = dot(c, c).sqrt().max(1e-300);
            cols.push(c.iter().map(|v| v / nrm).collect());
        }
        let nf = fit(d, self.red, self.sets, cols);
        let note = match note {
            Note::Finding(finding) => Note::Finding(Finding {
                undetermined: finding.undetermined,
                ..finding_of(
                    &t,
                    finding.parameters,
                    &s.fit,
                    Some(&nf),
                    self.heldout_rms(&s.fit),
                    (d.rows(), self.sets.heldout_n),
                    self.folds,
                    self.floor,
                )
            }),
            other => other,
        };
        (self.state(nf, s.k + t.ncols + t.extra_params), note)
    }
}

/// [`diagnose_session`], reporting its phases and the fraction of the work done to
/// `progress` (fractions in [0, 1], never decreasing, ending at 1).
pub fn diagnose_session_with_progress(
    session: &Session,
    opts: &DiagnoseOptions,
    progress: &mut dyn Progress,
) -> Result<DiagnosisResult, SolverError> {
    let mut progress = Monotone::new(progress);
    progress.report("reducing the rigid model", 0.0);
    let topology = session
        .topology
        .clone()
        .or_else(|| opts.topology.clone())
        .unwrap_or_default();
    let d = design::build(session, &topology, opts.order)?;
    let n = d.rows();
    let folds = opts.folds.max(2);
    let red = Reduction::new(session, &d);
    let sets = Sets::new(&d, &red, folds);
    let heldout_n = sets.heldout_n;
    progress.report("fitting the rigid model", 0.05);
    let f = fit(&d, &red, &sets, Vec::new());
    let dof = n.saturating_sub(2 * d.runs.len() + f.rank).max(1);
    let base_rms = (f.ssr / dof as f64).sqrt();
    let base_heldout = rms(f.heldout_ssr, heldout_n);
    progress.report("noise floor", 0.08);
    // The floor is the spectral one when a run is long enough for the spectrum; the
    // differences of repeated passes (`noise::session_floor`'s check) otherwise, and for
    // the note, which only a misfit left above the floor needs: computed then.
    let spectral = crate::noise::session_spectral_floor(session);
    let checked = std::cell::OnceCell::new();
    let noise_floor = || {
        *checked.get_or_init(|| {
            crate::noise::NoiseFloor::of(spectral, crate::noise::pass_differences(session))
        })
    };
    let floor = match spectral {
        Some((s, _)) => s,
        None => noise_floor().map_or(base_rms, |nf| nf.sigma_um),
    };
    let before_resid = f.resid.clone();
    let mismatch = if base_heldout > opts.noise_level_ratio * floor {
        locate(&d, &f.resid, floor)
    } else {
        Vec::new()
    };
    let cands = catalogue::candidates(&d);
    let problem = SessionProblem {
        d: &d,
        red: &red,
        sets: &sets,
        eps_groups: cands
            .iter()
            .filter(|c| c.effect == "setup_offset")
            .filter_map(|c| c.group)
            .collect(),
        cands,
        floor,
        dof,
        folds,
    };
    // No stop at the floor: an effect is accepted on its evidence (BIC and held-out gain),
    // so a small misfit near the floor is still looked for. The options' held-out gain is
    // on the RMS; the engine's on the sum of squares.
    let rules = Rules {
        bic_threshold: opts.min_bic_gain,
        min_heldout_gain: 1.0 - (1.0 - opts.min_heldout_gain).powi(2),
        stop_ratio: 0.0,
        max_findings: opts.max_findings,
    };
    let base = problem.state(f, 0);
    let o = engine::run(&problem, base, &rules, "", &mut progress, (0.0, 1.0));
    let findings: Vec<Finding> = o
        .added
        .into_iter()
        .filter_map(|a| match a.note {
            Note::Finding(f) => Some(f),
            _ => None,
        })
        .collect();
    let mut possible = Vec::new();
    let mut rejected = Vec::new();
    for (_, note) in o.set_aside {
        match note {
            Note::Possible(f) => possible.push(f),
            Note::Rejected(why) => rejected.push(why),
            Note::Finding(_) => {}
        }
    }
    let f = o.state.fit;
    progress.report("report", 0.95);
    let final_heldout = rms(f.heldout_ssr, heldout_n);
    let at_noise = final_heldout <= opts.noise_level_ratio * floor;
    let verdict = effects::verdict(
        base_heldout <= opts.noise_level_ratio * floor,
        at_noise,
        findings.len(),
    );
    let mut unexplained = Vec::new();
    if !at_noise {
        let floor_note = match noise_floor() {
            Some(nf) => nf.note(),
            None => "no run long enough for the spectrum and no repeated passes: the rigid model's residual stands in for the noise floor".into(),
        };
        let rest = locate(&d, &f.resid, floor);
        let places: Vec<String> = rest
            .iter()
            .map(|m| format!("{} ({:.0} %)", m.where_, 100.0 * m.share_of_misfit))
            .collect();
        unexplained.push(format!(
            "held-out RMS {:.3} um remains above {:.1} x the noise floor {:.3} um ({floor_note}); misfit concentrates in: {}",
            final_heldout,
            opts.noise_level_ratio,
            floor,
            if places.is_empty() {
                "no single place (spread over the session)".to_string()
            } else {
                places.join("; ")
            }
        ));
    }
    let plots = plots(&d, &before_resid, &f.resid);
    progress.report("done", 1.0);
    Ok(DiagnosisResult {
        kind: "diagnosis".into(),
        machine_id: session.machine_id.clone(),
        source: "session".into(),
        baseline: Baseline {
            residual_rms_um: rms(before_resid.iter().map(|v| v * v).sum(), n),
            heldout_rms_um: base_heldout,
            noise_estimate_um: floor,
        },
        mismatch,
        findings,
        possible,
        rejected,
        verdict,
        unexplained,
        plots,
    })
}
