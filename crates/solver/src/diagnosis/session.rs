//! Diagnosis of a grid-encoder session: locate the misfit of the rigid (21-term) model,
//! explain it with the catalogue of effects fitted jointly with the model, and prove the
//! gain on whole runs held out of the fit.
//!
//! Loop (greedy forward selection):
//! 1. fit the current model (rigid terms, plate rotations, run offsets eliminated, plus
//!    the effects accepted so far); its residual r, SSR and K-fold held-out SSR (folds of
//!    whole runs: run index within its file mod K);
//! 2. for every candidate, search its nonlinear parameter, fit it jointly, compute
//!    ΔBIC = n·ln(SSR₁/SSR₀) + (m + n_nonlinear)·ln n and the held-out RMS;
//! 3. accept the candidate with the lowest held-out RMS among those with ΔBIC < −10 and a
//!    held-out gain ≥ 0.5 %; repeat until none qualifies (reaching the noise floor does
//!    not stop the search: a small effect near the floor is still found on its evidence).

use super::catalogue::{self, Candidate, Search};
use super::design::{self, Design};
use super::effects;
use super::linalg::{Cols, dot, small_lstsq};
use super::reduced::{ModelProj, Reduction, predict_run};
use super::{Baseline, BeforeAfter, DiagnosisResult, Finding, Mismatch, PlotData, PlotSeries};
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

/// The current model fitted on all rows and on each fold's training runs.
struct Fit {
    /// Accepted effect columns (unit norm).
    cols: Cols,
    full: ModelProj,
    resid: Vec<f64>,
    ssr: f64,
    folds: Vec<Fold>,
    heldout_ssr: f64,
    heldout_n: usize,
}

struct Fold {
    held: Vec<usize>,
    proj: ModelProj,
    /// Residual of the data on the training runs (zero elsewhere).
    r_train: Vec<f64>,
}

/// Fits the rigid model plus the effect columns `cols` on all runs and on the training
/// runs of each of the `k` folds (run index within its file mod k).
fn fit(d: &Design, red: &Reduction, cols: Cols, k: usize) -> Fit {
    let all: Vec<usize> = (0..d.runs.len()).collect();
    let full = ModelProj::new(red, all, &cols);
    let resid = full.residual(red, &d.y);
    let ssr = dot(&resid, &resid);
    let mut folds = Vec::new();
    let mut heldout_ssr = 0.0;
    let mut heldout_n = 0;
    let mut first_run = vec![usize::MAX; d.files.len()];
    for (i, r) in d.runs.iter().enumerate() {
        first_run[r.plane_idx] = first_run[r.plane_idx].min(i);
    }
    for f in 0..k {
        let (held, train): (Vec<usize>, Vec<usize>) =
            (0..d.runs.len()).partition(|&ri| (ri - first_run[d.runs[ri].plane_idx]) % k == f);
        if held.is_empty() || train.is_empty() {
            continue;
        }
        let proj = ModelProj::new(red, train, &cols);
        let r_train = proj.residual(red, &d.y);
        let coef = proj.fit(red, &d.y);
        for &g in &held {
            let pred = predict_run(red, &cols, &coef, g);
            let rs = &red.runs[g];
            for (i, p) in pred.iter().enumerate() {
                let e = d.y[rs.row0 + i] - p;
                heldout_ssr += e * e;
            }
            heldout_n += rs.rows;
        }
        folds.push(Fold {
            held,
            proj,
            r_train,
        });
    }
    Fit {
        cols,
        full,
        resid,
        ssr,
        folds,
        heldout_ssr,
        heldout_n,
    }
}

/// A candidate fitted jointly with the current model.
struct Trial {
    cand: Candidate,
    theta: Option<(&'static str, f64)>,
    cols: Cols,
    names: Vec<String>,
    /// Largest |value| of each column before centring (its size as a machine error per
    /// unit coefficient).
    peaks: Vec<f64>,
    coef: Vec<f64>,
    coef_sd: Vec<f64>,
    ssr: f64,
    heldout_ssr: f64,
    dbic: f64,
    extra_params: usize,
}

/// SSR of the current model plus `b`, fitted jointly (Frisch–Waugh on the full rows).
fn joint_ssr(red: &Reduction, f: &Fit, b: &Cols) -> Option<(f64, Vec<f64>, Vec<f64>)> {
    let bp: Cols = b.iter().map(|c| f.full.residual(red, c)).collect();
    let (c, sd) = small_lstsq(&bp, &f.resid)?;
    let mut r = f.resid.clone();
    for (col, cj) in bp.iter().zip(c.iter()) {
        for (ri, v) in r.iter_mut().zip(col) {
            *ri -= cj * v;
        }
    }
    Some((
        dot(&r, &r),
        c.iter().copied().collect(),
        sd.iter().copied().collect(),
    ))
}

/// Most frequencies in one scan, and about the most rows a scan reads (per direction).
const MAX_SCAN_FREQS: usize = 2000;
const MAX_SCAN_ROWS: usize = 20_000;

/// Frequency (in `freqs`) whose sine/cosine pair of `var` along `axis` explains most of
/// the residual `r`, with the columns centred per (run, component) like the model. With
/// `per_run` each run gets its own phase (incoherent sum, for a coarse scan in time).
///
/// This is a scan heuristic only: the 2×2 moment system of each candidate frequency is
/// solved in closed form; the chosen frequency is then fitted jointly by SVD.
fn periodic_best(
    d: &Design,
    r: &[f64],
    axis: crate::axis::Axis,
    var: &dyn Fn(&design::SampleMeta) -> f64,
    freqs: &[f64],
    per_run: bool,
) -> Option<f64> {
    // Whole runs, every `stride`-th, so that at most about MAX_SCAN_ROWS rows are scanned
    // (the runs chosen still span the session).
    let stride = (d.rows() / 3).div_ceil(MAX_SCAN_ROWS).max(1);
    let rows: Vec<(usize, usize)> = d
        .runs
        .iter()
        .enumerate()
        .filter(|(ri, _)| ri % stride == 0)
        .flat_map(|(ri, run)| (2 * run.start..2 * run.end).map(move |row| (ri, row)))
        .filter(|&(_, row)| d.row_axis(row) == axis)
        .collect();
    if rows.is_empty() {
        return None;
    }
    let x: Vec<f64> = rows
        .iter()
        .map(|&(_, row)| var(&d.samples[row / 2]))
        .collect();
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
    // Frequencies are evenly spaced: sin/cos of w_k·x by rotation from w_0·x by Δw·x.
    let nf = freqs.len();
    let f0 = *freqs.first()?;
    let df = if nf > 1 { freqs[1] - f0 } else { 0.0 };
    let two_pi = 2.0 * std::f64::consts::PI;
    let mut score = vec![0.0; nf];
    let mut total = vec![[0.0; 5]; nf];
    // Per group: n, Σsin, Σcos, Σsin², Σcos², Σsin·cos, Σr·sin, Σr·cos.
    let mut acc = vec![[0.0; 8]; nf];
    let mut i = 0;
    while i < rows.len() {
        let ri = rows[i].0;
        acc.iter_mut().for_each(|a| *a = [0.0; 8]);
        // One (run, component) group: the rows of a run read along `axis`.
        while i < rows.len() && rows[i].0 == ri {
            let rv = r[rows[i].1];
            let (mut sn, mut cs) = (two_pi * f0 * x[i]).sin_cos();
            let (ds, dc) = (two_pi * df * x[i]).sin_cos();
            for a in acc.iter_mut() {
                a[0] += 1.0;
                a[1] += sn;
                a[2] += cs;
                a[3] += sn * sn;
                a[4] += cs * cs;
                a[5] += sn * cs;
                a[6] += rv * sn;
                a[7] += rv * cs;
                let ns = sn * dc + cs * ds;
                cs = cs * dc - sn * ds;
                sn = ns;
            }
            i += 1;
        }
        for k in 0..nf {
            let a = &acc[k];
            let n = a[0];
            let m = [
                a[3] - a[1] * a[1] / n,
                a[4] - a[2] * a[2] / n,
                a[5] - a[1] * a[2] / n,
                a[6],
                a[7],
            ];
            if per_run {
                score[k] += solve(&m);
            } else {
                for j in 0..5 {
                    total[k][j] += m[j];
                }
            }
        }
    }
    if !per_run {
        for k in 0..nf {
            score[k] = solve(&total[k]);
        }
    }
    let kbest = (0..nf).max_by(|&a, &b| score[a].total_cmp(&score[b]))?;
    Some(freqs[kbest])
}

/// Σ_k ε_k(q_k) (µrad) at every sample, from the current fit's error parameters.
fn eps_per_sample(d: &Design, red: &Reduction, f: &Fit) -> Vec<[f64; 3]> {
    let xs = f.full.fit(red, &d.y).a;
    let x: Vec<f64> = (0..d.model.len()).map(|j| xs[j] / d.a_scale[j]).collect();
    let mut out = vec![[0.0; 3]; d.samples.len()];
    for (i, term) in Term::all().into_iter().enumerate() {
        let Component::Rotation(dir) = term.component else {
            continue;
        };
        for (s, m) in d.samples.iter().enumerate() {
            out[s][dir.index()] += d.model.term_value(i, &x, m.q_mm[term.axis.index()]);
        }
    }
    out
}

fn try_candidate(
    d: &Design,
    red: &Reduction,
    f: &Fit,
    cand: &Candidate,
    eps: &[[f64; 3]],
) -> Option<Trial> {
    let n = d.rows() as f64;
    let (theta, extra) = match catalogue::search(d, cand) {
        Search::None => (None, 0),
        Search::Grid(name, values) => {
            let mut best: Option<(f64, f64)> = None;
            for &v in &values {
                let (b, _, _) = catalogue::columns(d, cand, v, Some(eps));
                if b.is_empty() {
                    return None;
                }
                let (ssr, _, _) = joint_ssr(red, f, &b)?;
                if best.is_none_or(|(s, _)| ssr < s) {
                    best = Some((ssr, v));
                }
            }
            // Golden-section refinement in log θ around the best grid value.
            let (_, v0) = best?;
            let ratio = values.get(1).map_or(2.0, |v1| v1 / values[0]);
            let eval = |lv: f64| {
                let (b, _, _) = catalogue::columns(d, cand, lv.exp(), Some(eps));
                joint_ssr(red, f, &b).map_or(f64::INFINITY, |t| t.0)
            };
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
            type Var = Box<dyn Fn(&design::SampleMeta) -> f64>;
            let (axis, in_var): (crate::axis::Axis, Var) = if in_time {
                (cand.direction?, Box::new(|m| m.t_s))
            } else {
                // Rows read along the effect's direction (its own axis for `cyclic`).
                let a = cand.axis?;
                (
                    cand.direction.unwrap_or(a),
                    Box::new(move |m| m.q_mm[a.index()]),
                )
            };
            // Scan sizes are bounded (a heuristic: the exact joint fit follows): at most
            // MAX_SCAN_FREQS coarse and fine frequencies.
            let coarse_step = coarse_step.max((f_hi - f_lo) / MAX_SCAN_FREQS as f64);
            let fine_step = fine_step.max(2.0 * coarse_step / MAX_SCAN_FREQS as f64);
            let coarse: Vec<f64> = (0..)
                .map(|i| f_lo + i as f64 * coarse_step)
                .take_while(|&x| x <= f_hi)
                .collect();
            let c0 = periodic_best(d, &f.resid, axis, &*in_var, &coarse, in_time)?;
            let fine: Vec<f64> = (0..)
                .map(|i| (c0 - coarse_step).max(0.5 * f_lo) + i as f64 * fine_step)
                .take_while(|&x| x <= c0 + coarse_step)
                .collect();
            let best = periodic_best(d, &f.resid, axis, &*in_var, &fine, false)?;
            // Columns take a frequency; `report_parameters` turns it into a period.
            let _ = as_period;
            (Some((name, best)), 1)
        }
    };
    let th = theta.map_or(0.0, |t| t.1);
    let (cols, names, peaks) = catalogue::columns(d, cand, th, Some(eps));
    if cols.is_empty() {
        return None;
    }
    let (ssr, coef, sd) = joint_ssr(red, f, &cols)?;
    let hssr = heldout_ssr_with(d, red, f, &cols);
    let k = cols.len() + extra;
    let dbic = n * (ssr / f.ssr).ln() + k as f64 * n.ln();
    Some(Trial {
        cand: cand.clone(),
        theta,
        cols,
        names,
        peaks,
        coef,
        coef_sd: sd,
        ssr,
        heldout_ssr: hssr,
        dbic,
        extra_params: extra,
    })
}

/// Held-out SSR of the current model plus `b` (whole runs held out, K folds).
fn heldout_ssr_with(d: &Design, red: &Reduction, f: &Fit, b: &Cols) -> f64 {
    let mut total = 0.0;
    for fold in &f.folds {
        let bp: Cols = b.iter().map(|c| fold.proj.residual(red, c)).collect();
        let Some((c, _)) = small_lstsq(&bp, &fold.r_train) else {
            return f64::INFINITY;
        };
        let mut yt = d.y.clone();
        for (col, cj) in b.iter().zip(c.iter()) {
            for (y, v) in yt.iter_mut().zip(col) {
                *y -= cj * v;
            }
        }
        let coef = fold.proj.fit(red, &yt);
        for &g in &fold.held {
            let pred = predict_run(red, &f.cols, &coef, g);
            let rs = &red.runs[g];
            for (i, p) in pred.iter().enumerate() {
                let row = rs.row0 + i;
                let e = yt[row] - p;
                total += e * e;
            }
        }
    }
    total
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
        let mut fitted = vec![0.0; d.rows()];
        for (c, k) in t.cols.iter().zip(&t.coef) {
            fitted.iter_mut().zip(c).for_each(|(f, v)| *f += k * v);
        }
        let rms = (dot(&fitted, &fitted) / n).sqrt();
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
            kind: "polar".into(),
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
        kind: "cartesian".into(),
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
    n: usize,
    folds: usize,
    floor: f64,
) -> Finding {
    let (after, h_after) = match nf {
        Some(nf) => (rms(nf.ssr, n), rms(nf.heldout_ssr, nf.heldout_n)),
        None => (rms(t.ssr, n), rms(t.heldout_ssr, f.heldout_n)),
    };
    Finding {
        effect: catalogue::reported_name(t.cand.effect).into(),
        axis: t
            .cand
            .axis
            .map(|a| a.to_string())
            .or(t.cand.direction.map(|a| a.to_string())),
        parameters,
        physics: catalogue::physics(catalogue::reported_name(t.cand.effect)).into(),
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
            t.cols.len() + t.extra_params,
            h_before,
            h_after,
            folds,
            floor
        ),
        decide: None,
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
    f: &Fit,
    t: &Trial,
    eps: &[[f64; 3]],
    sigma: f64,
) -> Option<(&'static str, f64)> {
    let (name, th) = t.theta?;
    let ssr_at = |v: f64| {
        let (b, _, _) = catalogue::columns(d, &t.cand, v, Some(eps));
        joint_ssr(red, f, &b).map_or(f64::NAN, |r| r.0)
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
    let topology = session
        .topology
        .clone()
        .or_else(|| opts.topology.clone())
        .unwrap_or_default();
    let mut d = design::build(session, &topology, opts.order)?;
    let n = d.rows();
    let folds = opts.folds.max(2);
    let red = Reduction::new(&d);
    // The dense rigid columns are no longer needed: the reduction holds them exactly.
    d.a = Vec::new();
    let mut f = fit(&d, &red, Vec::new(), folds);
    let dof = n
        .saturating_sub(2 * 2 * d.runs.len() / 2 + f.full.rank())
        .max(1);
    let base_rms = (f.ssr / dof as f64).sqrt();
    let base_heldout = rms(f.heldout_ssr, f.heldout_n);
    let (floor, floor_note) = match crate::noise::session_floor(session) {
        Some(nf) => (nf.sigma_um, nf.note()),
        None => (
            base_rms,
            "no run long enough for the spectrum and no repeated passes: the rigid model's residual stands in for the noise floor".into(),
        ),
    };
    let before_resid = f.resid.clone();
    let mismatch = if base_heldout > opts.noise_level_ratio * floor {
        locate(&d, &f.resid, floor)
    } else {
        Vec::new()
    };
    let cands = catalogue::candidates(&d);
    let mut findings = Vec::new();
    let mut possible = Vec::new();
    let mut rejected = Vec::new();
    // Candidates set aside (undetermined or implausible) are not tried again.
    let mut set_aside: Vec<String> = Vec::new();
    let mut dof_used = 0usize;
    while findings.len() < opts.max_findings {
        // No stop at the floor: an effect is accepted on its evidence (BIC and held-out
        // gain), so a small misfit near the floor is still looked for.
        let cur_heldout = rms(f.heldout_ssr, f.heldout_n);
        let eps = eps_per_sample(&d, &red, &f);
        let mut qualifying: Vec<Trial> = cands
            .iter()
            .filter(|c| !set_aside.contains(&c.label()))
            .filter_map(|c| try_candidate(&d, &red, &f, c, &eps))
            .filter(|t| {
                t.dbic < -opts.min_bic_gain
                    && rms(t.heldout_ssr, f.heldout_n) < cur_heldout * (1.0 - opts.min_heldout_gain)
            })
            .collect();
        qualifying.sort_by(|a, b| a.heldout_ssr.total_cmp(&b.heldout_ssr));
        let mut accepted = None;
        for t in qualifying {
            let sigma = (t.ssr
                / (dof.saturating_sub(dof_used + t.cols.len() + t.extra_params)).max(1) as f64)
                .sqrt();
            let mut params = report_parameters(&t, sigma, &d);
            if let Some((name, sd)) = theta_std(&d, &red, &f, &t, &eps, sigma) {
                params.insert(format!("std_{name}"), sd);
            }
            let explained = ((f.ssr - t.ssr).max(0.0) / n as f64).sqrt();
            let size: f64 = t
                .coef
                .iter()
                .zip(&t.peaks)
                .map(|(c, p)| (c * p).abs())
                .sum();
            if let Some(why) = effects::implausible(&t.cand.label(), size, explained, floor) {
                rejected.push(why);
                set_aside.push(t.cand.label());
                continue;
            }
            let finding = finding_of(&t, params, &f, None, cur_heldout, n, folds, floor);
            if let Some(why) = effects::undetermined(&finding) {
                possible.push(Finding {
                    decide: Some(why),
                    ..finding
                });
                set_aside.push(t.cand.label());
                continue;
            }
            accepted = Some((t, finding));
            break;
        }
        let Some((t, finding)) = accepted else { break };
        dof_used += t.cols.len() + t.extra_params;
        let mut cols = f.cols.clone();
        for c in &t.cols {
            let nrm = dot(c, c).sqrt().max(1e-300);
            cols.push(c.iter().map(|v| v / nrm).collect());
        }
        let nf = fit(&d, &red, cols, folds);
        findings.push(finding_of(
            &t,
            finding.parameters,
            &f,
            Some(&nf),
            cur_heldout,
            n,
            folds,
            floor,
        ));
        f = nf;
    }
    let final_heldout = rms(f.heldout_ssr, f.heldout_n);
    let at_noise = final_heldout <= opts.noise_level_ratio * floor;
    let verdict = effects::verdict(
        base_heldout <= opts.noise_level_ratio * floor,
        at_noise,
        findings.len(),
    );
    let mut unexplained = Vec::new();
    if !at_noise {
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
