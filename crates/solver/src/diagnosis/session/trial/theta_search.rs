//! The search of a candidate's nonlinear parameter (a grid refined by golden section, a
//! frequency scan refined on the joint fit, a step's time at the residual's most
//! significant step).

use crate::axis::Axis;
use crate::diagnosis::band_search;
use crate::diagnosis::catalogue::{self, Candidate, Search};
use crate::diagnosis::local_scan;
use crate::diagnosis::moments::Moments;
use crate::diagnosis::search::golden_section;
use crate::diagnosis::session::anomalies::{self, step_time};
use crate::diagnosis::session::context::{Ctx, State, Visit};
use crate::diagnosis::session::trial::frequency_scan::{MAX_SCAN_FREQS, ScanVar, periodic_best};
use std::sync::Arc;

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

/// Passes of a play's take-up fixed point ([`take_up_fixed_point`]) beyond the sharp
/// switch's.
const TAKE_UP_ROUNDS: usize = 4;

/// A take-up's fixed point from `b0`, the first coefficient fitted with the play taken
/// up at once: θ set to the first coefficient `fit(θ)` gives and the fit repeated until
/// they agree within 1 % or it is ≤ 0 (at most [`TAKE_UP_ROUNDS`] passes). The pass of
/// least sum of squares, as (SSR, θ, what `fit` gave with them); `None` when no pass fits.
/// `fit(θ)`: (SSR, first coefficient, payload).
pub(super) fn take_up_fixed_point<T>(
    b0: f64,
    fit: impl Fn(f64) -> Option<(f64, f64, T)>,
) -> Option<(f64, f64, T)> {
    let (mut v, mut best) = (b0, None::<(f64, f64, T)>);
    for _ in 0..TAKE_UP_ROUNDS {
        let Some((sv, b, m)) = fit(v) else { break };
        if best.as_ref().is_none_or(|x| sv < x.0) {
            best = Some((sv, v, m));
        }
        if b <= 0.0 || (b - v).abs() <= 0.01 * v {
            break;
        }
        v = b;
    }
    best
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
        if !s0.is_finite() || self.lacks_evidence(s, s0, 3) {
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
    pub(super) fn search_theta(
        &self,
        s: &State,
        cand: &Candidate,
    ) -> Option<(Option<(&'static str, f64)>, usize, Option<Arc<Moments>>)> {
        let (d, f) = (self.d, &s.fit);
        Some(match catalogue::search(d, cand) {
            Search::None => (None, 0, None),
            Search::Grid(name, values) => self.search_grid(s, cand, name, &values)?,
            Search::TakeUp(name) => {
                let (theta, mom) = self.take_up(s, cand)?;
                (theta.map(|v| (name, v)), 0, Some(mom))
            }
            Search::Step => {
                let (g, k) = self.step_of(s, cand.direction?)?;
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

    /// [`Ctx::search_theta`] of a candidate whose θ is searched on the grid `values`: the
    /// grid value of least SSR, refined by golden section where it shows evidence.
    #[allow(clippy::type_complexity)]
    fn search_grid(
        &self,
        s: &State,
        cand: &Candidate,
        name: &'static str,
        values: &[f64],
    ) -> Option<(Option<(&'static str, f64)>, usize, Option<Arc<Moments>>)> {
        let (d, f) = (self.d, &s.fit);
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
        let basis_cols = on_basis.then(|| self.thermal_basis(s).varying());
        // The sum of squares at `v` and the number of the candidate's columns that
        // vary there (on the thermal basis, those of the basis that vary).
        let fit_at = |v: f64| -> Option<(f64, usize)> {
            let mom = match (basis_cols, &near) {
                (Some(m), _) => return Some((self.basis_ssr(s, lag, v), m)),
                (None, Some(near)) => {
                    let reach = catalogue::reach(cand, v).map_or(f64::INFINITY, |r| r.1);
                    let specs = catalogue::specs(d, cand, v, self.eps(s));
                    self.moments_kept(s, (cand, Visit::Near, v), &specs, |g, _, out| {
                        out.extend(near[g].iter().filter(|p| p.1 < reach).map(|p| p.0))
                    })
                }
                (None, None) => self.moments_at(s, cand, v),
            };
            self.fit_moments(f, mom, false)
                .map(|(_, keep, jf)| (jf.all.ssr, keep.len()))
        };
        let ssr_at = |v: f64| fit_at(v).map_or(f64::INFINITY, |(ssr, _)| ssr);
        // A clearance's take-up is searched only where the sharp switch shows
        // evidence (ΔBIC < 0 with the take-up counted): elsewhere it cannot
        // qualify, and each value costs a pass over the rows.
        if cand.effect == "direction_coupling" {
            let s0 = ssr_at(values[0]);
            if !s0.is_finite() || self.lacks_evidence(s, s0, 2) {
                return Some((Some((name, values[0])), 1, None));
            }
        }
        let mut best: Option<(f64, f64, usize)> = None;
        for &v in values {
            let (ssr, m) = fit_at(v).unwrap_or((f64::INFINITY, 0));
            if !ssr.is_finite() {
                return None;
            }
            if best.is_none_or(|(s, _, _)| ssr < s) {
                best = Some((ssr, v, m));
            }
        }
        // Golden-section refinement in log θ around the best grid value, where that
        // value shows evidence (ΔBIC < 0 with its varying columns and the search
        // counted). Elsewhere the grid value gains at most (k + 1)·ln n in n·ln SSR,
        // a few tens, and a value within one grid ratio (1.4 for the spike's decay,
        // 1.45 for a drift's time constant, 2 for a take-up) a few % more: never the
        // gate's 10. Each of the refinement's 12 values costs a pass over the rows
        // or, for the drift, a fit on the thermal basis. A lagged temperature's lag
        // is always refined: its trial then chooses among forms of other columns.
        let (s_best, v0, m) = best?;
        if !lag && self.lacks_evidence(s, s_best, m + 1) {
            return Some((Some((name, v0)), 1, None));
        }
        let eval = |lv: f64| ssr_at(lv.exp());
        let bracket = golden_section((v0 / ratio).ln(), (v0 * ratio).ln(), 10, eval);
        Some((Some((name, bracket.centre().exp())), 1, None))
    }

    /// A play's take-up travel θ (µm), which is its width b: from the sharp switch
    /// (θ = 0), θ set to the fitted b and the fit repeated until they agree within 1 %
    /// (at most [`TAKE_UP_ROUNDS`] passes), then kept only when it fits better than the
    /// sharp switch. Not searched without evidence (ΔBIC ≥ 0 at θ = 0) or for a b of
    /// the wrong sign. Returns θ (`None`: sharp) and the candidate's moments there. θ is
    /// no free parameter: it is b.
    fn take_up(&self, s: &State, cand: &Candidate) -> Option<(Option<f64>, Arc<Moments>)> {
        let fit = |v: f64| {
            let mom = self.moments_at(s, cand, v);
            let (_, _, jf) = self.fit_moments(&s.fit, mom.clone(), false)?;
            Some((jf.all.ssr, jf.all.x[0], mom))
        };
        let (s0, b0, m0) = fit(0.0)?;
        if self.lacks_evidence(s, s0, 1) || b0 <= 0.0 {
            return Some((None, m0));
        }
        Some(match take_up_fixed_point(b0, fit) {
            Some((sv, v, m)) if sv < s0 => (Some(v), m),
            _ => (None, m0),
        })
    }

    /// [`Ctx::most_significant_step`] of the residual of the model `s` along `dir`, scanned
    /// on the first call and kept on the state for the other candidates that start from
    /// it (a step's and a transient's of that direction: the same scan of the same
    /// residual).
    pub(super) fn step_of(&self, s: &State, dir: Axis) -> Option<(usize, usize)> {
        *s.steps[dir.index()].get_or_init(|| self.most_significant_step(&s.fit.resid, dir))
    }

    /// The most significant step of the residual `r` along direction `dir` over every
    /// run, as (run, index of the first sample after it within the run), when it is an
    /// anomaly by the local scan's rule ([`local_scan`]: its p-value below the
    /// family-wise threshold of a scan of the whole session).
    pub(super) fn most_significant_step(&self, r: &[f64], dir: Axis) -> Option<(usize, usize)> {
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
}
