//! A candidate of the catalogue fitted jointly with the current model: its nonlinear
//! parameter searched (a grid refined by golden section, or a frequency scan), its joint
//! fit on all runs and on the folds, its ΔBIC, and its parameters in physical units.

use super::super::band_search;
use super::super::catalogue::{self, Candidate, Search};
use super::super::design::{Design, RunInfo};
use super::super::local_scan;
use super::super::lost_motion::Profile;
use super::super::moments::{self, Moments};
use super::super::periodic_scan;
use super::super::search::golden_section;
use super::super::temperature;
use super::anomalies::{self, step_time};
use super::context::{Ctx, ScanMoments, State, Visit};
use crate::axis::Axis;
use std::collections::BTreeMap;
use std::sync::Arc;

/// A candidate fitted jointly with the current model.
#[derive(Clone)]
pub(crate) struct Trial {
    pub cand: Candidate,
    pub theta: Option<(&'static str, f64)>,
    /// Number of columns.
    pub ncols: usize,
    pub names: Vec<String>,
    /// Largest |value| of each column before centring (its size as a machine error per
    /// unit coefficient).
    pub peaks: Vec<f64>,
    pub coef: Vec<f64>,
    pub coef_sd: Vec<f64>,
    /// Σ over the rows of the centred columns' cross-products (for the fitted RMS).
    pub gram: nalgebra::DMatrix<f64>,
    pub ssr: f64,
    pub heldout_ssr: f64,
    pub dbic: f64,
    pub extra_params: usize,
    /// A logged temperature's growth: the other forms, evaluated with this one
    /// ([`Ctx::form_variance`]).
    pub forms: Vec<Trial>,
}

/// Most frequencies in one scan, and the most (row, frequency) pairs a scan evaluates.
const MAX_SCAN_FREQS: usize = 2000;
const MAX_SCAN_WORK: usize = 20_000_000;

/// A frequency scan's variable: the rows read along `axis`, the variable per sample
/// (time, or an axis's position), with each run's own phase (`per_run`: an incoherent
/// sum, for a coarse scan in time) or one phase for the session.
struct ScanVar<'v> {
    axis: Axis,
    var: &'v [f64],
    per_run: bool,
}

/// Frequency (in `freqs`, evenly spaced) whose sine/cosine pair of the scan's variable
/// explains most of the residual `r`, with the columns centred per (run, component) like
/// the model.
///
/// This is a scan heuristic only: the 2×2 moment system of each candidate frequency is
/// solved in closed form; the chosen frequency is then fitted jointly. The work is bounded:
/// whole runs, every `stride`-th, so that at most [`MAX_SCAN_WORK`] (row, frequency) pairs
/// are evaluated (the runs chosen still span the session). Each run's moments at every
/// frequency come from [`periodic_scan::run_moments`]; those that do not depend on the
/// residual from `kept` when the session has made the same scan before ([`ScanMoments`]),
/// and kept there otherwise.
fn periodic_best(
    d: &Design,
    r: &[f64],
    v: &ScanVar,
    freqs: &[f64],
    kept: &ScanMoments,
) -> Option<f64> {
    let score = scan_scores(d, r, v, freqs, kept)?;
    let kbest = (0..freqs.len()).max_by(|&a, &b| score[a].total_cmp(&score[b]))?;
    Some(freqs[kbest])
}

/// [`periodic_best`]'s score of every frequency: the residual's sum of squares its pair
/// explains (`None`: no run reads the axis).
fn scan_scores(
    d: &Design,
    r: &[f64],
    v: &ScanVar,
    freqs: &[f64],
    kept: &ScanMoments,
) -> Option<Vec<f64>> {
    let ScanVar { axis, var, per_run } = *v;
    let nf = freqs.len();
    let f0 = *freqs.first()?;
    let reads = |run: &RunInfo| {
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
    let key = (
        axis.index(),
        var.as_ptr() as usize,
        f0.to_bits(),
        df.to_bits(),
        nf,
        per_run,
    );
    let known = kept.get(&key);
    // The moments that do not depend on the residual: taken from `known` (from its
    // first entry, run by run when per run), or gathered into `fresh` to keep.
    let (from, mut fresh) = (if known.is_some() { 3 } else { 0 }, Vec::new());
    let mut scanned = 0;
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
        match known {
            Some(_) => periodic_scan::run_moments::<false>(&rv, &xs, f0, df, &mut sums, &mut mom),
            None => periodic_scan::run_moments::<true>(&rv, &xs, f0, df, &mut sums, &mut mom),
        }
        for (k, m) in mom.iter_mut().enumerate() {
            if per_run {
                match &known {
                    Some(kn) => m[..3].copy_from_slice(&kn[scanned * nf + k]),
                    None => fresh.push([m[0], m[1], m[2]]),
                }
                score[k] += solve(m);
            } else {
                for j in from..5 {
                    total[k][j] += m[j];
                }
            }
        }
        scanned += 1;
    }
    if !any {
        return None;
    }
    if !per_run {
        for k in 0..nf {
            match &known {
                Some(kn) => total[k][..3].copy_from_slice(&kn[k]),
                None => fresh.push([total[k][0], total[k][1], total[k][2]]),
            }
            score[k] = solve(&total[k]);
        }
    }
    if known.is_none() {
        kept.insert(key, fresh);
    }
    Some(score)
}

/// A frequency band of a refinement: the scanned frequency, the half-width of the band
/// searched, the lowest frequency of the scan and the golden-section steps.
struct Band {
    f0: f64,
    step: f64,
    f_lo: f64,
    iters: usize,
    /// A frequency in time (a vibration's): refined on the band's own basis
    /// ([`band_search`]) where it holds.
    in_time: bool,
}

impl Ctx<'_> {
    /// The scan fits each frequency to the current model's residual alone; fitted jointly
    /// with the rigid terms, whose polynomials absorb part of a long period, the best
    /// frequency can lie elsewhere within a coarse step (a 35 mm waviness over 100 mm of
    /// travel scans at 33 mm). A position-periodic candidate with evidence at the scanned
    /// frequency f0 (ΔBIC = n·ln(SSR₁/SSR₀) + 3·ln n < 0) has its frequency refined by
    /// golden section on the exact joint SSR within f0 ± step (at least f_lo/2); the
    /// scanned one is kept unless the refined one fits better. Candidates without
    /// evidence (nearly all, on a clean session) cost nothing more. A frequency in time
    /// is refined the same way within one fine step: its scan's grid (a tenth of the
    /// session's inverse length) is about a hundred times its standard uncertainty, so
    /// the scanned value alone lay several σ from the least-squares one.
    ///
    /// Returns the frequency and, when it is the scanned one, the candidate's moments
    /// there (formed for the evidence; the trial's joint fit takes them instead of a pass
    /// of its own).
    fn refine_on_joint_fit(
        &self,
        s: &State,
        cand: &Candidate,
        b: Band,
    ) -> (f64, Option<Arc<Moments>>) {
        let Band {
            f0,
            step,
            f_lo,
            iters,
            in_time,
        } = b;
        let ssr = |v: f64| self.ssr_at(s, cand, v);
        let m0 = self.moments_at(s, cand, f0);
        let s0 = self
            .fit_moments(&s.fit, m0.clone(), false)
            .map_or(f64::INFINITY, |(_, _, jf)| jf.all.ssr);
        let n = self.d.rows() as f64;
        if !s0.is_finite() || n * (s0 / s.fit.ssr).ln() + 3.0 * n.ln() >= 0.0 {
            return (f0, Some(m0));
        }
        let (lo, hi) = ((f0 - step).max(0.5 * f_lo), f0 + step);
        let spans = band_search::spans(self.d);
        if let (true, Some(dir)) = (in_time, cand.direction)
            && band_search::holds(&spans, (hi - f0).max(f0 - lo))
        {
            // The profile from the band's basis: one pass over the rows.
            let (d, w0) = (self.d, 2.0 * std::f64::consts::PI * f0);
            let spans = &spans;
            let specs = catalogue::Columns::new(
                (0..2 * band_search::N).map(|k| format!("b{k}")).collect(),
                vec![Some(dir); 2 * band_search::N],
                move |smp, _, o| band_search::fill(d, spans, w0, smp, o),
            );
            let rows = self.live_rows(&specs);
            let basis = self.moments_kept(s, (cand, Visit::Band, f0), &specs, |g, rs, out| {
                rows.push(g, rs, out)
            });
            let at = |v: f64| {
                self.fit_moments(&s.fit, band_search::at(&basis, spans, v - f0), false)
                    .map_or(f64::INFINITY, |(_, _, jf)| jf.all.ssr)
            };
            let (v, sv) = golden_section(lo, hi, iters, at).best();
            return if sv < at(f0) {
                (v, None)
            } else {
                (f0, Some(m0))
            };
        }
        let (v, sv) = golden_section(lo, hi, iters, ssr).best();
        if sv < s0 { (v, None) } else { (f0, Some(m0)) }
    }

    /// The candidate's nonlinear parameter searched on the state `s`, with the number of
    /// parameters the search adds and the candidate's moments at it when the search
    /// formed them (`None`: it cannot be searched).
    #[allow(clippy::type_complexity)]
    fn search_theta(
        &self,
        s: &State,
        cand: &Candidate,
    ) -> Option<(Option<(&'static str, f64)>, usize, Option<Arc<Moments>>)> {
        let (d, f) = (self.d, &s.fit);
        Some(match catalogue::search(d, cand) {
            Search::None => (None, 0, None),
            Search::Grid(name, values) => {
                // The thermal time constant and the lag of a logged temperature are
                // searched on the reduced problem ([`ThermalBasis`]); other parameters
                // from their columns.
                let lag = cand.effect == "thermal_temperature_lag" && d.temperature.is_some();
                let on_basis = cand.effect == "thermal_drift" || lag;
                // A candidate that vanishes away from its axis's reversals (the spike) is
                // evaluated on the rows within its reach at the largest value searched
                // (the golden section stays within a grid ratio of the grid; 1 % margin).
                let ratio = values.get(1).map_or(2.0, |v1| v1 / values[0]);
                let top = values.iter().copied().fold(0.0, f64::max) * ratio * 1.01;
                let near = catalogue::reach(cand, top).map(|(a, x)| self.near_rows(a, x));
                let ssr_at = |v: f64| match (on_basis, &near) {
                    (true, _) => self.basis_ssr(s, lag, v),
                    (false, Some(near)) => {
                        let reach = catalogue::reach(cand, v).map_or(f64::INFINITY, |r| r.1);
                        let specs = catalogue::specs(d, cand, v, s.eps());
                        let mom =
                            self.moments_kept(s, (cand, Visit::Near, v), &specs, |g, _, out| {
                                out.extend(near[g].iter().filter(|p| p.1 < reach).map(|p| p.0))
                            });
                        self.fit_moments(f, mom, false)
                            .map_or(f64::INFINITY, |(_, _, jf)| jf.all.ssr)
                    }
                    (false, None) => self.ssr_at(s, cand, v),
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
                let bracket = golden_section((v0 / ratio).ln(), (v0 * ratio).ln(), 10, eval);
                (Some((name, bracket.centre().exp())), 1, None)
            }
            Search::Step => {
                let (g, k) = self.most_significant_step(&f.resid, cand.direction?)?;
                // The exact joint fit at the scanned place and three samples either side.
                let start = d.runs[g].start;
                let n = d.runs[g].end - start;
                let (_, k) = (k.saturating_sub(3).max(1)..(k + 4).min(n))
                    .map(|k| (self.ssr_at(s, cand, step_time(d, start + k)), k))
                    .min_by(|a, b| a.0.total_cmp(&b.0))?;
                (Some(("time_s", step_time(d, start + k))), 1, None)
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
                let (axis, var) = if in_time {
                    (cand.direction?, &d.fields.t_s)
                } else {
                    // Rows read along the effect's direction (its own axis for `cyclic`).
                    let a = cand.axis?;
                    (cand.direction.unwrap_or(a), &d.fields.q_mm[a.index()])
                };
                // Scan sizes are bounded (a heuristic: the exact joint fit follows): at
                // most MAX_SCAN_FREQS coarse and fine frequencies.
                let coarse_step = coarse_step.max((f_hi - f_lo) / MAX_SCAN_FREQS as f64);
                let fine_step = fine_step.max(2.0 * coarse_step / MAX_SCAN_FREQS as f64);
                let coarse: Vec<f64> = (0..)
                    .map(|i| f_lo + i as f64 * coarse_step)
                    .take_while(|&x| x <= f_hi)
                    .collect();
                let scan = |per_run| ScanVar { axis, var, per_run };
                let c0 = periodic_best(d, &f.resid, &scan(in_time), &coarse, self.scans)?;
                let fine: Vec<f64> = (0..)
                    .map(|i| (c0 - coarse_step).max(0.5 * f_lo) + i as f64 * fine_step)
                    .take_while(|&x| x <= c0 + coarse_step)
                    .collect();
                let best = periodic_best(d, &f.resid, &scan(false), &fine, self.scans)?;
                // Position: within a coarse step (12 golden steps); time: within a fine
                // step, to 10⁻⁵ of it (24 steps).
                let band = if in_time {
                    Band {
                        f0: best,
                        step: fine_step,
                        f_lo,
                        iters: 24,
                        in_time,
                    }
                } else {
                    Band {
                        f0: best,
                        step: coarse_step,
                        f_lo,
                        iters: 12,
                        in_time,
                    }
                };
                let (best, mom) = self.refine_on_joint_fit(s, cand, band);
                // Columns take a frequency; `report_parameters` turns it into a period.
                let _ = as_period;
                (Some((name, best)), 1, mom)
            }
        })
    }

    /// The most significant step of the residual `r` along direction `dir` over every
    /// run, as (run, index of the first sample after it within the run), when it is an
    /// anomaly by the local scan's rule ([`local_scan`]: its p-value below the
    /// family-wise threshold of a scan of the whole session).
    fn most_significant_step(&self, r: &[f64], dir: Axis) -> Option<(usize, usize)> {
        let thr = anomalies::thresholds(self.d)[0];
        // The first of the least ln p, as `Iterator::min_by` takes it.
        let mut best: Option<(usize, local_scan::Anomaly)> = None;
        anomalies::each_sequence_along(self.d, r, dir, |g, seq| {
            let Some(a) = local_scan::best_step(seq, self.floor) else {
                return;
            };
            let less = best
                .as_ref()
                .is_none_or(|b| a.ln_p.total_cmp(&b.1.ln_p).is_lt());
            if a.ln_p < thr && less {
                best = Some((g, a));
            }
        });
        best.map(|(g, a)| (g, a.at))
    }

    /// The candidate evaluated jointly with the current model `s`: its nonlinear
    /// parameter searched, its joint fit on all runs and the folds, its ΔBIC.
    pub fn try_candidate(&self, s: &State, cand: &Candidate) -> Option<Trial> {
        match cand.effect {
            "thermal_temperature" => self.try_temperature_forms(s, cand),
            "lost_motion_profile" | "lost_motion_variation" => self.try_profile_orders(s, cand),
            "step" => self.try_step(s, cand),
            _ => self.try_one(s, cand),
        }
    }

    /// A step with the width of its ramp searched: a slip that takes several samples
    /// (a ramp from 0 to its size over a width w centred on its time t₀) fitted as a
    /// sharp step leaves the ramp's odd misfit and reads its size low (z −4 at 20
    /// floors over 1 s). The sharp step's time is the start ([`Search::Step`]); w = 0
    /// (sharp) and a geometric grid from 2 sample intervals (a ramp within one interval
    /// reads as sharp) by ratio 1.5, up to 32 intervals and within the run, are fitted at
    /// that time; the best ramp, if it fits better than the sharp step, is refined by
    /// golden section in ln w, then t₀ within one interval, then ln w again. The width is
    /// kept only when the BIC says so (below).
    fn try_step(&self, s: &State, cand: &Candidate) -> Option<Trial> {
        let d = self.d;
        let (theta, _, _) = self.search_theta(s, cand)?;
        let (name, t0) = theta?;
        let run = &d.runs[d.run_at_time(t0)?];
        let ts = &d.fields.t_s[run.start..run.end];
        let (first, last) = (*ts.first()?, *ts.last()?);
        let dt = (last - first) / (ts.len() - 1).max(1) as f64;
        let top = (32.0 * dt).min(2.0 * (t0 - first).min(last - t0));
        let with = |w: f64| Candidate {
            width_s: w,
            ..cand.clone()
        };
        let ssr = |w: f64, t: f64| self.ssr_at(s, &with(w), t);
        let sharp = ssr(0.0, t0);
        let (mut grid_w, mut best) = (0.0, sharp);
        for v in (0..)
            .map(|i| 2.0 * dt * 1.5f64.powi(i))
            .take_while(|&v| v <= top)
        {
            let x = ssr(v, t0);
            if x < best {
                (grid_w, best) = (v, x);
            }
        }
        let (mut w, mut t) = (grid_w, t0);
        if w > 0.0 {
            let in_w = |w: f64, t: f64| {
                let lo = (w / 1.5).max(1.01 * dt).ln();
                golden_section(lo, (w * 1.5).min(top).ln(), 10, |lv| ssr(lv.exp(), t))
                    .centre()
                    .exp()
            };
            w = in_w(w, t);
            t = golden_section(t - dt, t + dt, 12, |x| ssr(w, x)).centre();
            w = in_w(w, t);
            if ssr(w, t) >= best {
                (w, t) = (grid_w, t0);
            }
        }
        // The ramp replaces the sharp step only when its width lowers the BIC, n·ln
        // SSR + k·ln n, by its one parameter more (a ramp fitted to noise is sharp).
        let n = d.rows() as f64;
        if w > 0.0 && n * (ssr(w, t) / sharp).ln() + n.ln() >= 0.0 {
            (w, t) = (0.0, t0);
        }
        let c = with(w);
        let specs = catalogue::specs(d, &c, t, s.eps());
        let k = 1 + usize::from(w > 0.0);
        let fitted = self.fit_candidate(s, self.moments_at(s, &c, t), k)?;
        Some(self.trial_of(s, &c, (Some((name, t)), k), &specs.names, fitted))
    }

    /// A lost motion varying along the travel, of the order K the data choose
    /// ([`catalogue::PROFILE_ORDERS`]): the columns' moments are formed once at the
    /// candidate's largest order and each order fitted on its first columns. From the
    /// least order up, a higher order replaces the one chosen when it lowers both the
    /// BIC (n·ln SSR + k·ln n: each added coefficient must lower the SSR by ln n ≈ 12
    /// noise variances) and the held-out sum of squares (folds of whole runs), the
    /// discipline the loop holds every candidate to. A profile of too low an order is
    /// biased by tens of its σ where the lost motion changes sign along the travel. The
    /// columns do not depend on the model: their moments are kept for the next round
    /// ([`Ctx::moments_kept`]).
    fn try_profile_orders(&self, s: &State, cand: &Candidate) -> Option<Trial> {
        let specs = catalogue::specs(self.d, cand, 0.0, s.eps());
        let mom = self.moments_at(s, cand, 0.0);
        let from = usize::from(cand.effect == "lost_motion_variation");
        // Every order fitted on all runs; on the folds too when one of them may qualify
        // ([`Ctx::may_qualify`]; none may: the candidate is not chosen whatever its order).
        let mut fits = Vec::new();
        for order in catalogue::PROFILE_ORDERS.filter(|&k| k <= cand.order) {
            let cols: Vec<usize> = (0..order + 1 - from).collect();
            if let Some(fit) = self.fit_moments(&s.fit, mom.select(&cols), false) {
                fits.push((order, fit));
            }
        }
        if fits
            .iter()
            .any(|(_, (_, keep, jf))| self.may_qualify(s, jf.all.ssr, keep.len()))
        {
            for (_, (sub, _, jf)) in &mut fits {
                jf.heldout_ssr = self.heldout_ssr(s, sub);
            }
        }
        let mut best: Option<usize> = None;
        let mut tried: Vec<Trial> = Vec::new();
        for (order, fit) in fits {
            let c = Candidate {
                order,
                ..cand.clone()
            };
            let t = self.trial_of(s, &c, (None, 0), &specs.names, fit);
            if best
                .map(|b| &tried[b])
                .is_none_or(|b| t.dbic < b.dbic && t.heldout_ssr < b.heldout_ssr)
            {
                best = Some(tried.len());
            }
            tried.push(t);
        }
        // The two next orders (one odd, one even) ride along as the orders the data did
        // not choose but do not exclude ([`profile_parameters`]).
        let b = best?;
        let richer: Vec<Trial> = tried.drain(b + 1..).take(2).collect();
        let mut t = tried.swap_remove(b);
        t.forms = richer;
        Some(t)
    }

    /// A growth that follows a logged temperature, in the form of least BIC: linear in
    /// the smoothed temperature change ΔT̂, linear in ΔT̂ through a first-order lag (a
    /// structure slower than its sensor; its time constant searched), or quadratic in
    /// ΔT̂. A form outside the one fitted biases the coefficients (the lag shifts the
    /// temperature the scale sees, the curvature the slope), so the richer form is taken
    /// wherever the data show it, by the criterion the loop uses between effects.
    fn try_temperature_forms(&self, s: &State, cand: &Candidate) -> Option<Trial> {
        let linear = self.try_one(s, cand)?;
        // No evidence of a growth that follows the temperature at all: the richer forms
        // are not searched (a lag or a curvature is a refinement of that growth; each
        // costs passes over the rows: the lag's basis and exact fit, the quadratic's fit).
        if linear.dbic >= 0.0 {
            return Some(linear);
        }
        let mut forms: Vec<Trial> = ["thermal_temperature_lag", "thermal_temperature_quadratic"]
            .into_iter()
            .filter_map(|effect| {
                self.try_one(
                    s,
                    &Candidate {
                        effect,
                        ..cand.clone()
                    },
                )
            })
            .collect();
        forms.insert(0, linear);
        let best = (0..forms.len()).min_by(|&a, &b| forms[a].dbic.total_cmp(&forms[b].dbic))?;
        let mut t = forms.swap_remove(best);
        t.forms = forms;
        Some(t)
    }

    /// The variance the choice of form adds to each coefficient of a logged
    /// temperature's growth `t` (its per-kelvin coefficients by name; 0 elsewhere), σ
    /// the residual standard deviation of its joint fit. A richer form the BIC did not
    /// choose can still be the physics: the forms are told apart only by how the
    /// temperature turns. A heating or a cooling that settles exponentially makes a
    /// lagged temperature nearly an affine function of the sensor's (a lag is then nearly
    /// a change of the coefficients), and its small within-run changes where the
    /// temperature is high say little of a curvature; a temperature that rises and falls
    /// tells them apart. So the coefficients carry the forms as nuisance, the larger of
    /// per coefficient:
    ///
    /// - every richer form: the squared difference of its coefficients from `t`'s (in
    ///   expectation the richer form's own variance beyond `t`'s where both describe the
    ///   data, the bias of `t` where only the richer one does);
    /// - the linear form chosen: the lags the data do not exclude, τ from 0 up to the
    ///   largest with SSR(τ) within 4σ² of the least of the linear and lagged fits
    ///   (the 2σ profile interval, τ = 0 being the linear form), the coefficients
    ///   ranging from the linear ones to those at the interval's end: the square of half
    ///   that range (the linear estimate lies at one end of it).
    pub fn form_variance(&self, s: &State, t: &Trial, sigma: f64) -> Vec<f64> {
        let mut var = vec![0.0; t.ncols];
        let widen = |var: &mut [f64], names: &[String], coef: &[f64], half: bool| {
            for (i, name) in t.names.iter().enumerate() {
                if let Some(j) = names.iter().position(|x| x == name) {
                    let d = coef[j] - t.coef[i];
                    let d2 = if half { d * d / 4.0 } else { d * d };
                    var[i] = var[i].max(d2);
                }
            }
        };
        let k = |x: &Trial| x.ncols + x.extra_params;
        for a in t.forms.iter().filter(|a| k(a) > k(t)) {
            widen(&mut var, &a.names, &a.coef, false);
        }
        let lag = t
            .forms
            .iter()
            .find(|a| a.cand.effect == "thermal_temperature_lag");
        if let (true, Some(lag), Some((_, tau_hat))) = (
            t.cand.effect == "thermal_temperature",
            lag,
            lag.and_then(|l| l.theta),
        ) {
            let limit = t.ssr.min(lag.ssr) + 4.0 * sigma * sigma;
            let top = match catalogue::search(self.d, &lag.cand) {
                Search::Grid(_, v) => v.iter().copied().fold(tau_hat, f64::max),
                _ => tau_hat,
            };
            // Outward from τ̂ in steps of 25 % while within, located on the round's
            // thermal basis (the profile the lag's search used) and confirmed by exact
            // passes at the last τ within and the first beyond ([`confirmed`]).
            let walk = |within: &dyn Fn(f64) -> bool| {
                let mut up = tau_hat;
                while up < top && within((up * 1.25).min(top)) {
                    up = (up * 1.25).min(top);
                }
                let next = (up < top).then(|| (up * 1.25).min(top));
                (up, (up != tau_hat).then_some(up), next)
            };
            let near = |tau: f64| self.basis_ssr(s, true, tau) <= limit;
            let within = |tau: f64| self.ssr_at(s, &lag.cand, tau) <= limit;
            let up = confirmed(walk, &near, &within);
            let specs = catalogue::specs(self.d, &lag.cand, up, s.eps());
            if let Some((_, keep, jf)) =
                self.fit_moments(&s.fit, self.moments_at(s, &lag.cand, up), false)
            {
                let names: Vec<String> = keep.iter().map(|&j| specs.names[j].clone()).collect();
                widen(&mut var, &names, &jf.all.x[..keep.len()], true);
            }
            widen(&mut var, &lag.names, &lag.coef, true);
        }
        var
    }

    /// The slope dβ/dθ of a trial's coefficients along the profile of its nonlinear
    /// parameter θ (the coefficients refitted at θ·e^(±0.05), or θ ± one fine step of a
    /// frequency's scan; central difference), in the trial's column order; `None` when a
    /// refit loses a column or θ is a step's time (a place between two samples).
    pub fn coef_slope(&self, s: &State, t: &Trial) -> Option<Vec<f64>> {
        let (name, th) = t.theta?;
        if name == "time_s" {
            return None;
        }
        let (lo, hi) = match catalogue::search(self.d, &t.cand) {
            Search::Periodic { fine_step, .. } => (th - fine_step, th + fine_step),
            _ => (th * (-0.05f64).exp(), th * 0.05f64.exp()),
        };
        self.slope(s, t, (&t.cand, lo), (&t.cand, hi), hi - lo)
    }

    /// The slope dβ/dw of a ramped step's coefficients along its width w (refitted at
    /// w·e^(±0.05), t₀ kept), as [`Ctx::coef_slope`] along θ.
    pub fn width_slope(&self, s: &State, t: &Trial) -> Option<Vec<f64>> {
        let (_, th) = t.theta?;
        let w = t.cand.width_s;
        let at = |f: f64| Candidate {
            width_s: w * f,
            ..t.cand.clone()
        };
        let (lo, hi) = (at((-0.05f64).exp()), at(0.05f64.exp()));
        self.slope(s, t, (&lo, th), (&hi, th), hi.width_s - lo.width_s)
    }

    /// The central difference of a trial's coefficients between two refits, each a
    /// candidate at a nonlinear value, `h` apart; `None` when a refit loses a column.
    fn slope(
        &self,
        s: &State,
        t: &Trial,
        lo: (&Candidate, f64),
        hi: (&Candidate, f64),
        h: f64,
    ) -> Option<Vec<f64>> {
        let (a, b) = (self.coef_at(s, t, hi)?, self.coef_at(s, t, lo)?);
        Some(a.iter().zip(&b).map(|(a, b)| (a - b) / h).collect())
    }

    /// A trial's coefficients refitted with its candidate `c` at the nonlinear value `v`,
    /// in the trial's column order; `None` when the refit loses a column.
    /// The moments are those kept on the state ([`Ctx::moments_at`]): a thermal drift's
    /// interval refits at the bounds its confirmation has just evaluated.
    fn coef_at(&self, s: &State, t: &Trial, (c, v): (&Candidate, f64)) -> Option<Vec<f64>> {
        let (_, keep, jf) = self.fit_moments(&s.fit, self.moments_at(s, c, v), false)?;
        (keep.len() == t.ncols).then(|| jf.all.x[..t.ncols].to_vec())
    }

    /// The 2σ likelihood-ratio interval of a thermal drift's time constant T: the T
    /// whose profiled sum of squares exceeds the trial's by at most 4σ² (χ²₁ at 2σ),
    /// searched outward in ln T in steps that double from 0.05 up to a factor e^3.2 ≈ 25
    /// either side, each crossing then halved six times; at least T̂ ± 2`sd` (the
    /// curvature's σ). Over a session not much longer than T the profile is flat toward
    /// long T (the growth becomes a straight line in time, its scale and T trading off),
    /// and the curvature at T̂ read the longer time constants 2–4σ off; the interval is
    /// asymmetric. Returns (T₋, T₊, β(T₋), β(T₊)): T₊ is infinite when the profile stays
    /// within 4σ² up to 25·T̂, the coefficients then those at 25·T̂; `None` when a refit
    /// at a bound loses a column.
    pub fn time_constant_interval(
        &self,
        s: &State,
        t: &Trial,
        sigma: f64,
        sd: f64,
    ) -> Option<TimeConstantInterval> {
        let (_, th) = t.theta.filter(|_| t.cand.effect == "thermal_drift")?;
        let thr = t.ssr + 4.0 * sigma * sigma;
        let within = |x: f64| self.ssr_at(s, &t.cand, th * x.exp()) <= thr;
        // The bracket located on the round's thermal basis (the profile its search used),
        // then confirmed by the exact passes at its ends ([`profile_bound_confirmed`]).
        let near = |x: f64| self.basis_ssr(s, false, th * x.exp()) <= thr;
        let (lo, lo_open) = profile_bound_confirmed(near, within, -1.0, 0.05, LN_REACH);
        let (hi, hi_open) = profile_bound_confirmed(near, within, 1.0, 0.05, LN_REACH);
        let low = (th * lo.exp())
            .min(th - 2.0 * sd)
            .max(th * (-LN_REACH).exp());
        let high = (th * hi.exp()).max(th + 2.0 * sd);
        let cand = &t.cand;
        let fit_high = high.min(th * LN_REACH.exp());
        Some(TimeConstantInterval {
            low: if lo_open { 0.0 } else { low },
            high: if hi_open { f64::INFINITY } else { high },
            fitted_at: [low, fit_high],
            coef_low: self.coef_at(s, t, (cand, low))?,
            coef_high: self.coef_at(s, t, (cand, fit_high))?,
        })
    }

    /// A step's width with its standard uncertainty and the slope of its coefficients
    /// along it (`None`: not a step). The 2σ interval of the profiled sum of squares in
    /// w at the step's time (the widths whose SSR exceeds the trial's by at most 4σ²,
    /// χ²₁ at 2σ, searched outward in ln w by [`profile_bound`] from a first step of 2 %,
    /// between one sample interval, as a ramp within one interval reads as sharp, and
    /// twice the step's distance to its run's nearer end) is ±2 standard
    /// uncertainties: the curvature of S read a 0.45 µm ramp's width 3–6σ high, its
    /// profile being flat toward long ramps. A ramp: the interval reaches 0 when the
    /// sharp step is within it; the slope is dβ/dw at ŵ. A sharp step (w = 0): the
    /// interval is [0, w₊], w₊ the widest ramp within it, the width 0 ± w₊/2 (at least
    /// the mean sample interval: undetermined), and the slope (β(w₊) − β(0))/w₊, so the
    /// size carries half its change over the ramps the data do not exclude.
    pub fn step_width(
        &self,
        s: &State,
        t: &Trial,
        sigma: f64,
    ) -> Option<(f64, f64, Option<Vec<f64>>)> {
        let (_, th) = t.theta.filter(|_| t.cand.effect == "step")?;
        let d = self.d;
        let run = &d.runs[d.run_at_time(th)?];
        let ts = &d.fields.t_s;
        let dt = (ts[run.end - 1] - ts[run.start]) / (run.end - run.start - 1).max(1) as f64;
        let top = 2.0 * (th - ts[run.start]).min(ts[run.end - 1] - th);
        let w = t.cand.width_s;
        let with = |w: f64| Candidate {
            width_s: w,
            ..t.cand.clone()
        };
        let thr = t.ssr + 4.0 * sigma * sigma;
        // Within [one interval, the run]: beyond, a ramp reads as sharp or leaves the run.
        let (least, most) = (dt.ln(), top.ln());
        let within = |x0: f64| move |x: f64| self.ssr_at(s, &with((x0 + x).exp()), th) <= thr;
        if w <= 0.0 {
            let x0 = (1.03 * dt).min(top).ln();
            let (hi, _) = profile_bound(within(x0), 1.0, 0.02, (most - x0).max(0.0));
            let wide = (x0 + hi).exp();
            let slope = self.slope(s, t, (&with(0.0), th), (&with(wide), th), wide);
            return Some((0.0, (0.5 * wide).max(dt), slope));
        }
        let x0 = w.ln();
        let (lo, _) = profile_bound(within(x0), -1.0, 0.02, (x0 - least).max(0.0));
        let (hi, _) = profile_bound(within(x0), 1.0, 0.02, (most - x0).max(0.0));
        let (lo, hi) = ((x0 + lo).exp(), (x0 + hi).exp());
        let sharp = lo <= 1.03 * dt && self.ssr_at(s, &with(0.0), th) <= thr;
        let lo = if sharp { 0.0 } else { lo };
        Some((w, 0.25 * (hi - lo), self.width_slope(s, t)))
    }

    fn try_one(&self, s: &State, cand: &Candidate) -> Option<Trial> {
        let (theta, extra, mom) = self.search_theta(s, cand)?;
        let th = theta.map_or(0.0, |t| t.1);
        let specs = catalogue::specs(self.d, cand, th, s.eps());
        let mom = match mom {
            Some(mom) => mom,
            None => self.moments_at(s, cand, th),
        };
        let fitted = self.fit_candidate(s, mom, extra)?;
        Some(self.trial_of(s, cand, (theta, extra), &specs.names, fitted))
    }

    /// The trial of a candidate fitted jointly with the current model `s`: its
    /// nonlinear parameter and the number of parameters its search adds, its columns'
    /// names and the joint fit ([`Ctx::evaluate`]'s moments, kept columns and fit).
    fn trial_of(
        &self,
        s: &State,
        cand: &Candidate,
        (theta, extra): (Option<(&'static str, f64)>, usize),
        names: &[String],
        (mom, keep, jf): (Arc<Moments>, Vec<usize>, moments::JointFit),
    ) -> Trial {
        let n = self.d.rows() as f64;
        let f = &s.fit;
        let m = keep.len();
        let ssr = jf.all.ssr;
        let k = m + extra;
        let dbic = n * (ssr / f.ssr).ln() + k as f64 * n.ln();
        Trial {
            cand: cand.clone(),
            theta,
            ncols: m,
            names: keep.iter().map(|&j| names[j].clone()).collect(),
            peaks: mom.peaks.clone(),
            coef: jf.all.x[..m].to_vec(),
            coef_sd: jf.all.sd[..m].to_vec(),
            gram: mom.gram(),
            ssr,
            heldout_ssr: jf.heldout_ssr,
            dbic,
            extra_params: extra,
            forms: Vec::new(),
        }
    }

    /// Standard uncertainty of a trial's nonlinear parameter from the curvature of the
    /// profiled sum of squares S(θ) (the linear parameters re-fitted at every θ):
    /// var(θ̂) = 2σ²/S''(θ̂), by central differences (in ln θ for time constants and decay
    /// lengths, in frequency for periods and frequencies). Returns the reported name and
    /// σ; infinite when S is not convex there (θ not determined). A step's time takes
    /// the standard uncertainty of its width, `width_sd` ([`Ctx::step_width`]).
    pub fn theta_std(
        &self,
        s: &State,
        t: &Trial,
        sigma: f64,
        width_sd: Option<f64>,
    ) -> Option<(&'static str, f64)> {
        let (name, th) = t.theta?;
        if name == "time_s" {
            return Some((name, self.step_time_std(s, t, sigma, width_sd)));
        }
        let ssr_at = |v: f64| {
            let x = self.ssr_at(s, &t.cand, v);
            if x.is_finite() { x } else { f64::NAN }
        };
        let (log, h) = match catalogue::search(self.d, &t.cand) {
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
}

impl Ctx<'_> {
    /// Standard uncertainty of a step's time t̂ (between two samples): the 2σ interval
    /// of the profiled sum of squares, the step times whose SSR exceeds the least by at
    /// most 4σ² (χ²₁ at 2σ), over ±10 samples, is ±2 standard uncertainties; at least the
    /// uncertainty of a time known to one sample interval Δt, Δt/√12. `width_sd`: the
    /// step's width's standard uncertainty, from [`Ctx::step_width`].
    fn step_time_std(&self, s: &State, t: &Trial, sigma: f64, width_sd: Option<f64>) -> f64 {
        let d = self.d;
        let Some((_, th)) = t.theta else {
            return f64::INFINITY;
        };
        let Some(g) = d.run_at_time(th) else {
            return f64::INFINITY;
        };
        let (start, end) = (d.runs[g].start, d.runs[g].end);
        let ts = &d.fields.t_s;
        let k = start + ts[start..end].partition_point(|&x| x < th);
        let dt = ts[k.min(end - 1)] - ts[k.saturating_sub(1).max(start)];
        if t.cand.width_s > 0.0 {
            // A ramp's time is continuous: its 2σ interval searched from a fiftieth of an
            // interval up to 20 intervals either side.
            let thr = t.ssr + 4.0 * sigma * sigma;
            let within = |x: f64| self.ssr_at(s, &t.cand, th + x) <= thr;
            let (lo, _) = profile_bound(within, -1.0, 0.02 * dt, 20.0 * dt);
            let (hi, _) = profile_bound(within, 1.0, 0.02 * dt, 20.0 * dt);
            return (0.25 * (hi - lo)).max(0.02 * dt / 12f64.sqrt());
        }
        let (mut lo, mut hi) = (th, th);
        for j in k.saturating_sub(10).max(start + 1)..(k + 11).min(end) {
            let tj = step_time(d, j);
            if self.ssr_at(s, &t.cand, tj) - t.ssr <= 4.0 * sigma * sigma {
                lo = lo.min(tj);
                hi = hi.max(tj);
            }
        }
        // A sharp step is a ramp of any width the data do not exclude ([`Ctx::step_width`]:
        // [0, w₊], σ = w₊/2 once w₊ exceeds two intervals) centred within w₊/2 of its
        // time: ±w₊/2 is at least its 2σ interval.
        let wide = width_sd.map_or(0.0, |sw| if sw > dt { 2.0 * sw } else { 0.0 });
        (0.25 * (hi - lo)).max(dt / 12f64.sqrt()).max(0.25 * wide)
    }
}

/// The lack-of-fit test of a one-column effect's form on its own support
/// ([`Ctx::form_test`]).
pub(crate) struct FormTest {
    /// χ² = (SSR of the effect − SSR with a coefficient per place)/σ².
    pub chi2: f64,
    /// Its degrees of freedom: the places where the column varies, less one.
    pub dof: usize,
    /// Its p-value (upper tail of χ² with `dof` degrees of freedom).
    pub p: f64,
    /// Per place: its name, the coefficient there and its σ.
    pub places: Vec<(String, f64, f64)>,
}

impl FormTest {
    /// The spread between the places beyond their own σ: the DerSimonian–Laird estimate
    /// of a random-effects model (DerSimonian & Laird 1986; the "dark uncertainty" of an
    /// interlaboratory comparison). With weights wᵢ = 1/σᵢ², the weighted mean x̄ and
    /// Q = Σ wᵢ(xᵢ − x̄)², τ² = max(0, (Q − (k − 1)) / (Σwᵢ − Σwᵢ²/Σwᵢ)), in the
    /// coefficient's units squared. Where the places read the effect differently (a
    /// delay whose circles read it lower than its lines), τ² is how much one figure for
    /// all places is uncertain by that disagreement. Where the form holds, Q is about
    /// χ²(k − 1) and τ² is 0 in about half the checks; in the others it is of the order of
    /// the less precise places' σ², which makes the one figure's σ conservative (the
    /// coverage table's sharp direction couplings: z spread 0.7).
    pub fn between_places_variance(&self) -> f64 {
        let w: Vec<f64> = self.places.iter().map(|p| 1.0 / (p.2 * p.2)).collect();
        let sw: f64 = w.iter().sum();
        if self.places.len() < 2 || !(sw.is_finite() && sw > 0.0) {
            return 0.0;
        }
        let mean = self
            .places
            .iter()
            .zip(&w)
            .map(|(p, w)| w * p.1)
            .sum::<f64>()
            / sw;
        let q: f64 = self
            .places
            .iter()
            .zip(&w)
            .map(|(p, w)| w * (p.1 - mean).powi(2))
            .sum();
        let c = sw - w.iter().map(|w| w * w).sum::<f64>() / sw;
        ((q - (self.places.len() - 1) as f64) / c).max(0.0)
    }
}

impl Ctx<'_> {
    /// The trial's one column fitted with a coefficient per place instead
    /// ([`catalogue::split`]: lines or circles, near or beyond the axis's reversals), on
    /// all runs: where the effect's form holds, the drop of the sum of squares is σ²
    /// times a χ² with (places − 1) degrees of freedom. `None` for an effect of more
    /// than one column, or whose column varies in one place only.
    pub fn form_test(&self, s: &State, t: &Trial, sigma: f64) -> Option<FormTest> {
        let th = t.theta.map_or(0.0, |x| x.1);
        let specs = catalogue::split(self.d, &t.cand, th, s.eps())?;
        let (_, keep, jf) = self.evaluate(&s.fit, &specs, false)?;
        // The places' columns, not the nuisance ones that follow them.
        let n_places = catalogue::SPLIT_PLACES.len();
        let at_places = keep.iter().filter(|&&j| j < n_places).count();
        let dof = at_places.checked_sub(1).filter(|&k| k > 0)?;
        let chi2 = ((t.ssr - jf.all.ssr) / (sigma * sigma)).max(0.0);
        let p = statrs::distribution::ChiSquared::new(dof as f64)
            .map(|c| 1.0 - statrs::distribution::ContinuousCDF::cdf(&c, chi2))
            .ok()?;
        let places = keep
            .iter()
            .enumerate()
            .filter(|&(_, &j)| j < n_places)
            .map(|(i, &j)| {
                let name = catalogue::SPLIT_PLACES[j].to_string();
                (name, jf.all.x[i], jf.all.sd[i] * sigma)
            })
            .collect();
        Some(FormTest {
            chi2,
            dof,
            p,
            places,
        })
    }
}

/// How far in ln T [`Ctx::time_constant_interval`] searches either side of T̂.
const LN_REACH: f64 = 3.2;

/// A thermal drift's time constant's 2σ likelihood-ratio interval [T₋, T₊] and the
/// trial's coefficients refitted at each bound ([`Ctx::time_constant_interval`]).
pub(crate) struct TimeConstantInterval {
    pub low: f64,
    pub high: f64,
    /// The T at which the coefficients were refitted: the bounds, within the reach.
    pub fitted_at: [f64; 2],
    pub coef_low: Vec<f64>,
    pub coef_high: Vec<f64>,
}

/// One side of a profile interval: the last offset x (of sign `dir`) from 0 with
/// `within(x)` (0 itself within), searched in steps that double from `first` up to
/// `reach` (the last step cut to it), the crossing then halved six times, i.e. found
/// to 1/64 of its bracket; `true` when still within at the reach (the interval open on
/// that side). Every likelihood-ratio interval of the session's parameters is this
/// search: a thermal drift's time constant (in ln T), a step's width (in ln w) and a
/// ramp's time.
fn profile_bound(within: impl Fn(f64) -> bool, dir: f64, first: f64, reach: f64) -> (f64, bool) {
    let (a, b) = bracket(&within, dir, first, reach);
    (dir * a, b.is_none())
}

/// [`profile_bound`]'s last bracket on one side: the last offset found within and the
/// first found outside (both ≥ 0, along `dir`); `None` outside when still within at the
/// reach.
fn bracket(within: &dyn Fn(f64) -> bool, dir: f64, first: f64, reach: f64) -> (f64, Option<f64>) {
    let (mut inside, mut step) = (0.0, first.min(reach));
    let outside = loop {
        if !within(dir * step) {
            break step;
        }
        inside = step;
        if step >= reach {
            return (reach, None);
        }
        step = (2.0 * step).min(reach);
    };
    let (mut a, mut b) = (inside, outside);
    for _ in 0..6 {
        let m = 0.5 * (a + b);
        if within(dir * m) {
            a = m;
        } else {
            b = m;
        }
    }
    (a, Some(b))
}

/// [`profile_bound`] of `within` (exact, one pass over the rows a call) searched on a
/// cheap profile `near` of the same quantity, its last bracket confirmed by `within`
/// ([`confirmed`]).
fn profile_bound_confirmed(
    near: impl Fn(f64) -> bool,
    within: impl Fn(f64) -> bool,
    dir: f64,
    first: f64,
    reach: f64,
) -> (f64, bool) {
    let search = |w: &dyn Fn(f64) -> bool| {
        let (a, b) = bracket(w, dir, first, reach);
        (
            (dir * a, b.is_none()),
            (a != 0.0).then_some(dir * a),
            b.map(|b| dir * b),
        )
    };
    confirmed(search, &near, &within)
}

/// The result of an outward search on the exact predicate `within` (one pass over the
/// rows a call), made on a cheap one `near` of the same quantity and confirmed by
/// `within` at the two places that decide it: `search(p)` returns its result on the
/// predicate p, the last place p held (none: only its start, which is not asked) and the
/// first where it failed (none: the search reached its end within). Within at the one and
/// not at the other: on a profile that crosses its threshold once, every place the
/// search visits lies at or before the first (within) or at or beyond the second (not
/// within), so the search on `within` would make the same decisions, the same result,
/// for at most two exact calls. Otherwise (the cheap profile off near the threshold) the
/// search is made again on `within`.
fn confirmed<R>(
    search: impl Fn(&dyn Fn(f64) -> bool) -> (R, Option<f64>, Option<f64>),
    near: &dyn Fn(f64) -> bool,
    within: &dyn Fn(f64) -> bool,
) -> R {
    let (r, inside, outside) = search(near);
    if inside.is_none_or(within) && outside.is_none_or(|x| !within(x)) {
        r
    } else {
        search(within).0
    }
}

/// Carries the uncertainty `sd` of a nonlinear parameter into the other reported
/// parameters of trial `t` (σ² + (dβ/dθ·σ_θ)²): its coefficients moved by ±σ_θ along
/// their slope `slope` (so a parameter made of several coefficients, an amplitude of its
/// sine and cosine, moves as reported), half the difference of the reported figures added
/// in quadrature to each σ in `params`; `skip` is the nonlinear parameter's own name.
pub(crate) fn carry(
    params: &mut BTreeMap<String, f64>,
    (t, sigma, d): (&Trial, f64, &Design),
    slope: &[f64],
    sd: f64,
    skip: &str,
) {
    let moved = |sign: f64| {
        let mut m = t.clone();
        for (c, b) in m.coef.iter_mut().zip(slope) {
            *c += sign * b * sd;
        }
        report_parameters(&m, sigma, d)
    };
    let (up, down) = (moved(1.0), moved(-1.0));
    for (n, v) in &up {
        if n.starts_with("std_") || n.starts_with("phase") || n == skip {
            continue;
        }
        let shift = 0.5 * (v - down.get(n).copied().unwrap_or(*v));
        if let Some(sd) = params.get_mut(&format!("std_{n}")) {
            *sd = sd.hypot(shift);
        }
    }
}

/// Carries a thermal drift's time constant's interval into the other reported
/// parameters of trial `t`: each refigured from the coefficients at T₋ and at T₊
/// ([`Ctx::time_constant_interval`], the 2σ bounds), half the larger change from the
/// reported figure (one σ's worth of the wider side) added in quadrature to its σ.
pub(crate) fn carry_interval(
    params: &mut BTreeMap<String, f64>,
    (t, sigma, d): (&Trial, f64, &Design),
    iv: &TimeConstantInterval,
    skip: &str,
) {
    let at = |coef: &[f64]| {
        let mut m = t.clone();
        m.coef = coef.to_vec();
        report_parameters(&m, sigma, d)
    };
    let (low, high) = (at(&iv.coef_low), at(&iv.coef_high));
    let here = report_parameters(t, sigma, d);
    for (n, v) in &here {
        if n.starts_with("std_") || n.starts_with("phase") || n == skip {
            continue;
        }
        let side = |m: &BTreeMap<String, f64>| (m.get(n).copied().unwrap_or(*v) - v).abs();
        let shift = 0.5 * side(&low).max(side(&high));
        if let Some(sd) = params.get_mut(&format!("std_{n}")) {
            *sd = sd.hypot(shift);
        }
    }
}

/// A thermal drift's growth over the recorded span: each offset and scale times
/// g(t_end) = 1 − e^(−t_end/T), t_end the last sample's time, reported as
/// `span_{name}` with its σ (conditional on T, times g) and half the larger change of
/// the product at T's bounds ([`Ctx::time_constant_interval`]) added in quadrature. What
/// the recording saw, determined where T and the final growth are not (a session not
/// much longer than T: the growth nearly a straight line in time); nothing evaluated
/// beyond the last sample.
pub(crate) fn span_growth(
    params: &mut BTreeMap<String, f64>,
    (t, sigma): (&Trial, f64),
    iv: &TimeConstantInterval,
    t_end: f64,
) {
    let Some((_, th)) = t.theta else {
        return;
    };
    let g = |tc: f64| -(-t_end / tc).exp_m1();
    for (i, name) in t.names.iter().enumerate() {
        if catalogue::is_nuisance(name) {
            continue;
        }
        let v = t.coef[i] * g(th);
        let low = iv.coef_low[i] * g(iv.fitted_at[0]);
        let high = iv.coef_high[i] * g(iv.fitted_at[1]);
        let shift = 0.5 * (low - v).abs().max((high - v).abs());
        params.insert(format!("span_{name}"), v);
        params.insert(
            format!("std_span_{name}"),
            (t.coef_sd[i] * sigma * g(th)).hypot(shift),
        );
    }
}

/// Physical parameters of an accepted trial (with `std_*` uncertainties), scaled by the
/// residual standard deviation `sigma` of the joint fit.
pub(crate) fn report_parameters(t: &Trial, sigma: f64, d: &Design) -> BTreeMap<String, f64> {
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
    let smoother = t
        .cand
        .effect
        .starts_with("thermal_temperature")
        .then(|| smoother_variance(t, d))
        .flatten();
    for (i, name) in t.names.iter().enumerate() {
        if catalogue::is_nuisance(name) {
            continue;
        }
        p.insert(name.clone(), t.coef[i]);
        let sd = match &smoother {
            Some(v) => (sd(i).powi(2) + v[i]).sqrt(),
            None => sd(i),
        };
        p.insert(format!("std_{name}"), sd);
    }
    p
}

/// Number of points along the measured travel at which a session's position-dependent
/// lost motion is reported (evenly spaced, ends included).
const PROFILE_POINTS: usize = 5;

/// The parameters of a position-dependent lost motion of axis `a` (`lost_motion_profile`,
/// the effects table's): b(q) = Σ_k b_k·P_k(s) at [`PROFILE_POINTS`] points of the
/// measured travel, its mean and its variation along the travel, each with its σ. The b_k
/// are the trial's (their covariance: their σ with the correlation of their Gram
/// matrix), b₀ ± σ₀ the `constant` lost motion of the axis's `backlash` in the model when
/// the trial is its varying part alone (taken independent of the b_k).
pub(crate) fn profile_parameters(
    t: &Trial,
    sigma: f64,
    d: &Design,
    a: Axis,
    constant: Option<(f64, f64)>,
) -> BTreeMap<String, f64> {
    let mut p = BTreeMap::new();
    let Some((prof, coef, cov)) = profile_of(t, sigma, d, a, constant) else {
        return p;
    };
    let points: Vec<f64> = (0..PROFILE_POINTS)
        .map(|i| prof.lo + (prof.hi - prof.lo) * i as f64 / (PROFILE_POINTS - 1) as f64)
        .collect();
    let report = |prof: &Profile, coef: &[f64], cov: &nalgebra::DMatrix<f64>| {
        let mut v: Vec<(f64, f64)> = prof.at(coef, cov, &points);
        v.push(prof.mean(coef, cov, &points));
        v.push(prof.variation(coef, cov, &points));
        v
    };
    let mut at = report(&prof, &coef, &cov);
    // The orders the data did not choose are nuisance: each figure's variance takes the
    // largest squared difference from the figure of the next two orders (the richer
    // order's own extra variance where the chosen one describes the lost motion, the
    // chosen one's truncation where it does not: a coefficient just below the BIC's
    // threshold left out of a profile of order 7 biased its ends by 1.5 σ).
    let richer: Vec<Vec<(f64, f64)>> = t
        .forms
        .iter()
        .filter_map(|r| profile_of(r, sigma, d, a, constant))
        .map(|(p, c, v)| report(&p, &c, &v))
        .collect();
    for (i, (x, sx)) in at.iter_mut().enumerate() {
        let wide = richer
            .iter()
            .map(|r| (r[i].0 - *x).powi(2))
            .fold(0.0, f64::max);
        *sx = sx.hypot(wide.sqrt());
    }
    let (v, sv) = at.pop().unwrap_or_default();
    let (mean, sm) = at.pop().unwrap_or_default();
    for (n, ((b, sb), q)) in at.iter().zip(&points).enumerate() {
        p.insert(format!("lost_motion_um_{}", n + 1), *b);
        p.insert(format!("std_lost_motion_um_{}", n + 1), *sb);
        p.insert(format!("target_mm_{}", n + 1), *q);
    }
    p.insert("mean_lost_motion_um".into(), mean);
    p.insert("std_mean_lost_motion_um".into(), sm);
    p.insert("variation_um".into(), v);
    p.insert("std_variation_um".into(), sv);
    p.insert("order".into(), prof.order as f64);
    p
}

/// The profile of a lost-motion trial `t` with its coefficients and their covariance
/// ([`profile_parameters`]).
fn profile_of(
    t: &Trial,
    sigma: f64,
    d: &Design,
    a: Axis,
    constant: Option<(f64, f64)>,
) -> Option<(Profile, Vec<f64>, nalgebra::DMatrix<f64>)> {
    let prof = catalogue::profile(d, a, t.cand.order)?;
    let k = prof.order + 1;
    let mut coef = Vec::with_capacity(k);
    let mut cov = nalgebra::DMatrix::zeros(k, k);
    let off = usize::from(constant.is_some());
    if let Some((b0, sb0)) = constant {
        coef.push(b0);
        cov[(0, 0)] = sb0 * sb0;
    }
    let m = t.coef.len().min(k - off);
    coef.extend(&t.coef[..m]);
    coef.resize(k, 0.0);
    let ginv = t.gram.clone().pseudo_inverse(1e-12).ok();
    for i in 0..m {
        for j in 0..m {
            let corr = match &ginv {
                Some(g) if g[(i, i)] > 0.0 && g[(j, j)] > 0.0 => {
                    g[(i, j)] / (g[(i, i)] * g[(j, j)]).sqrt()
                }
                _ => f64::from(u8::from(i == j)),
            };
            cov[(i + off, j + off)] = corr * t.coef_sd[i] * t.coef_sd[j] * sigma * sigma;
        }
    }
    Some((prof, coef, cov))
}

/// The variance the smoother of the logged temperature adds to each coefficient of a
/// temperature-driven form ([`temperature::Smoother::coefficient_cov`]); infinite where
/// the smoother does not follow the temperature (the coefficients are then
/// undetermined), none without a smoother. The lagged form's columns follow the lagged
/// smoothed temperature, whose error is the smoother's error lagged; the smoother's
/// error is a polynomial of the session time, slow against the lags the data can tell
/// from none, and is taken unlagged.
fn smoother_variance(t: &Trial, d: &Design) -> Option<Vec<f64>> {
    let sm = d.temperature.as_ref()?;
    let kc = t.names.len();
    if !sm.follows {
        return Some(vec![f64::INFINITY; kc]);
    }
    // The columns by name: scale_ppm_per_k_{j} weighs q_j/1000, offset_um_per_k_{j} 1;
    // the `_k2_` ones the same times ΔT̂ once more.
    let col = |name: &str| -> Option<(bool, bool, Axis)> {
        let (scale, quad, a) = [
            ("scale_ppm_per_k_", true, false),
            ("offset_um_per_k_", false, false),
            ("scale_ppm_per_k2_", true, true),
            ("offset_um_per_k2_", false, true),
        ]
        .into_iter()
        .find_map(|(p, scale, quad)| Some((scale, quad, name.strip_prefix(p)?)))?;
        Some((
            scale,
            quad,
            Axis::ALL.into_iter().find(|x| x.to_string() == a)?,
        ))
    };
    let cols: Vec<(bool, bool, Axis)> = t.names.iter().map(|n| col(n)).collect::<Option<_>>()?;
    let temp: Vec<f64> = match (t.cand.effect, t.theta) {
        ("thermal_temperature_lag", Some((_, tau))) => d.lagged_temperature(tau)?,
        _ => d.fields.temp_k.clone()?,
    };
    let groups = d.runs.iter().flat_map(|run| {
        let (u, v) = d.plane_axes[run.plane_idx];
        let (cols, temp) = (&cols, &temp);
        [u, v].into_iter().map(move |read| {
            let mut z = Vec::with_capacity((run.end - run.start) * kc);
            let mut growth = Vec::with_capacity(run.end - run.start);
            for s in run.start..run.end {
                let dt = temp[s];
                let mut g = 0.0;
                for (&(scale, quad, a), b) in cols.iter().zip(&t.coef) {
                    let w = match (a == read, scale) {
                        (false, _) => 0.0,
                        (true, true) => d.fields.q_mm[a.index()][s] * 1e-3,
                        (true, false) => 1.0,
                    };
                    // Column ΔT̂·w (derivative w) or ΔT̂²·w (derivative 2ΔT̂·w).
                    let (zv, dz) = if quad {
                        (dt * dt * w, 2.0 * dt * w)
                    } else {
                        (dt * w, w)
                    };
                    z.push(zv);
                    g += b * dz;
                }
                growth.push(g);
            }
            temperature::Group {
                t_s: d.fields.t_s[run.start..run.end].to_vec(),
                z,
                growth,
            }
        })
    });
    let cov = sm.coefficient_cov(groups, &t.gram)?;
    Some((0..kc).map(|i| cov[(i, i)]).collect())
}

#[cfg(test)]
mod tests {
    use super::super::super::design;
    use super::{FormTest, LN_REACH, ScanMoments, ScanVar, profile_bound, profile_bound_confirmed};
    use crate::axis::Axis;
    use crate::simulate::seed_session;
    use std::cell::Cell;

    /// The bounds of a known profile: within where (x − 0.3)² ≤ 0.9, i.e.
    /// 0.3 ± √0.9, found from inside to within one 64th of the bracket ([0.8, 1.6] on the
    /// upper side, [−0.8, −0.4] on the lower); a side that never crosses is open at the
    /// reach.
    #[test]
    fn profile_bound_finds_the_crossings_of_a_known_profile() {
        let r = 0.9f64.sqrt();
        let within = |x: f64| (x - 0.3f64).powi(2) <= 0.9;
        let (hi, open) = profile_bound(within, 1.0, 0.05, LN_REACH);
        assert!(!open && hi <= 0.3 + r && hi > 0.3 + r - 0.8 / 64.0, "{hi}");
        let (lo, open) = profile_bound(within, -1.0, 0.05, LN_REACH);
        assert!(!open && lo >= 0.3 - r && lo < 0.3 - r + 0.4 / 64.0, "{lo}");
        let flat_above = |x: f64| x > -0.5;
        assert_eq!(
            profile_bound(flat_above, 1.0, 0.05, LN_REACH),
            (LN_REACH, true)
        );
        // A reach that is not a doubling of the first step: the last step is cut to it,
        // so a crossing between the last doubling and the reach is still found.
        let (hi, open) = profile_bound(|x: f64| x <= 2.5, 1.0, 0.05, 3.0);
        assert!(!open && hi <= 2.5 && hi > 2.5 - 1.4 / 64.0, "{hi}");
        assert_eq!(
            profile_bound(|x: f64| x <= 3.5, 1.0, 0.05, 3.0),
            (3.0, true)
        );
    }

    /// The bound located on a cheap profile and confirmed by the exact one is the exact
    /// search's, bit for bit, whenever the cheap profile crosses within the exact one's
    /// last bracket (offset by 10⁻⁶ here, or far off on the open side), for two exact
    /// calls a side (one on an open side); where the cheap profile crosses elsewhere
    /// (off by 0.1), the confirmation fails and the exact search is made again: the same
    /// bound still.
    #[test]
    fn a_confirmed_bound_is_the_exact_search_s() {
        let calls = Cell::new(0);
        let exact = |x: f64| {
            calls.set(calls.get() + 1);
            (x - 0.3f64).powi(2) <= 0.9
        };
        for off in [1e-6, -1e-6, 0.1, -0.1] {
            let near = |x: f64| (x - 0.3f64).powi(2) <= 0.9 + off;
            for dir in [1.0, -1.0] {
                calls.set(0);
                let want = profile_bound(exact, dir, 0.05, LN_REACH);
                let exact_calls = calls.get();
                calls.set(0);
                let got = profile_bound_confirmed(near, exact, dir, 0.05, LN_REACH);
                assert_eq!(got, want, "offset {off}, side {dir}");
                if off.abs() < 1e-3 {
                    assert_eq!(calls.get(), 2, "offset {off}, side {dir}");
                } else {
                    // One or two calls to find it unconfirmed, then the exact search.
                    let extra = calls.get() - exact_calls;
                    assert!((1..=2).contains(&extra), "offset {off}, side {dir}");
                }
            }
        }
        // Open above on both: one exact call, at the reach.
        calls.set(0);
        let flat = |x: f64| {
            calls.set(calls.get() + 1);
            x > -0.5
        };
        assert_eq!(
            profile_bound_confirmed(|x: f64| x > -0.6, flat, 1.0, 0.05, LN_REACH),
            (LN_REACH, true)
        );
        assert_eq!(calls.get(), 1);
        // Open on the cheap profile, closed on the exact one: found by the exact search.
        assert_eq!(
            profile_bound_confirmed(|_: f64| true, |x: f64| x <= 2.5, 1.0, 0.05, 3.0),
            profile_bound(|x: f64| x <= 2.5, 1.0, 0.05, 3.0)
        );
    }

    /// A frequency scan of a second residual on the moments kept from the first (the
    /// same rows and grid) scores every frequency bit for bit as the scan made afresh:
    /// in position over the whole session and in time run by run.
    #[test]
    fn a_scan_on_kept_moments_is_the_fresh_scan() {
        let session = seed_session(3);
        let d = design::build(&session, &Default::default(), 3).unwrap();
        let resid = |a: f64| -> Vec<f64> {
            (0..d.rows())
                .map(|i| (a * i as f64).sin() + 0.01 * ((i * 7919) % 13) as f64)
                .collect()
        };
        let (r1, r2) = (resid(0.37), resid(0.011));
        let scans = [
            (Axis::X, &d.fields.q_mm[0], false, 1.0 / 30.0, 0.0025),
            (Axis::Y, &d.fields.t_s, true, 0.01, 0.013),
        ];
        for (axis, var, per_run, f0, df) in scans {
            let v = ScanVar { axis, var, per_run };
            let freqs: Vec<f64> = (0..300).map(|k| f0 + k as f64 * df).collect();
            let kept = ScanMoments::default();
            let first = super::scan_scores(&d, &r1, &v, &freqs, &kept).unwrap();
            let again = super::scan_scores(&d, &r2, &v, &freqs, &kept).unwrap();
            let fresh = super::scan_scores(&d, &r2, &v, &freqs, &Default::default()).unwrap();
            assert!(
                again
                    .iter()
                    .zip(&fresh)
                    .all(|(a, b)| a.to_bits() == b.to_bits())
            );
            // Not the first residual's scores: the residual's sums were formed anew.
            assert!(again.iter().zip(&first).any(|(a, b)| a != b));
            assert!(fresh.iter().any(|&x| x > 0.0));
        }
    }

    fn places(v: &[(f64, f64)]) -> FormTest {
        FormTest {
            chi2: 0.0,
            dof: v.len() - 1,
            p: 1.0,
            places: v.iter().map(|&(x, s)| ("place".into(), x, s)).collect(),
        }
    }

    /// DerSimonian–Laird by hand: four places 1, 2, 3, 4 with σ = 0.5 (w = 4): x̄ = 2.5,
    /// Q = 4·(2.25 + 0.25 + 0.25 + 2.25) = 20, C = 16 − 64/16 = 12, τ² = (20 − 3)/12.
    /// Places that agree within their σ (Q below its degrees of freedom) add nothing.
    #[test]
    fn the_spread_between_places_is_the_dersimonian_laird_variance() {
        let t = places(&[(1.0, 0.5), (2.0, 0.5), (3.0, 0.5), (4.0, 0.5)]);
        assert!((t.between_places_variance() - 17.0 / 12.0).abs() < 1e-12);
        let agree = places(&[(1.0, 0.5), (1.2, 0.5), (0.9, 0.4), (1.1, 0.6)]);
        assert_eq!(agree.between_places_variance(), 0.0);
        // Unequal weights: the precise places pull the mean, the spread is still found.
        let t = places(&[(3.0, 0.002), (2.99, 0.001), (2.97, 0.001), (2.99, 0.004)]);
        let tau = t.between_places_variance().sqrt();
        assert!(tau > 0.005 && tau < 0.02, "{tau}");
    }
}
