//! A transient's trial (`diagnosis::transient`): its onset t₀ and decay time τ searched
//! on the exact joint fit with the current model, its amplitude linear; and its decay's
//! and onset's standard uncertainties carried into the amplitude.

use super::Trial;
use super::profile_likelihood::profile_bound;
use crate::diagnosis::catalogue::{self, Candidate};
use crate::diagnosis::local_scan;
use crate::diagnosis::search::golden_section;
use crate::diagnosis::session::anomalies::step_time;
use crate::diagnosis::session::context::{Ctx, State};
use crate::diagnosis::transient::{DECAY_LEAST_INTERVALS, DECAY_RATIO, decay_grid, run_times};
use std::collections::BTreeMap;

/// Onsets tried either side of the scanned step's place, in samples.
const ONSET_REACH: usize = 3;

impl Ctx<'_> {
    /// A transient: t₀ at the residual's most significant step along the candidate's
    /// direction (by the local scan's rule: none, no transient) and [`ONSET_REACH`]
    /// samples either side (at least [`local_scan::MIN_SIDE`] samples into the run), τ on the decay grid ([`decay_grid`]) at the scanned place,
    /// then t₀ again at the best τ, then τ by golden section in ln τ within one grid
    /// ratio. A τ at the grid's top is a decay the run does not see end (a step's), one
    /// under [`DECAY_LEAST_INTERVALS`] sample intervals one or two readings off (an
    /// excursion's): no transient. Its parameters are the amplitude (linear), t₀ and τ (two searched).
    pub(super) fn try_transient(&self, s: &State, cand: &Candidate) -> Option<Trial> {
        let d = self.d;
        let (g, k) = self.step_of(s, cand.direction?)?;
        let (start, n) = (d.runs[g].start, d.runs[g].end - d.runs[g].start);
        let with = |tau: f64| Candidate {
            width_s: tau,
            ..cand.clone()
        };
        let ssr = |tau: f64, t0: f64| {
            let x = self.ssr_at(s, &with(tau), t0);
            if x.is_finite() { x } else { f64::INFINITY }
        };
        // At least the local scan's fewest samples before the onset: an event is seen
        // to appear against the readings before it (at a run's first samples, a play's
        // take-up or the approach would read as one).
        let first = local_scan::MIN_SIDE.max(k.saturating_sub(ONSET_REACH));
        let onsets: Vec<f64> = (first..(k + ONSET_REACH + 1).min(n))
            .map(|j| step_time(d, start + j))
            .collect();
        let grid = decay_grid(d, g, step_time(d, start + k));
        let top = *grid.last()?;
        let best_tau = |t0: f64| {
            grid.iter()
                .map(|&v| (ssr(v, t0), v))
                .min_by(|a, b| a.0.total_cmp(&b.0))
        };
        let (_, tau) = best_tau(step_time(d, start + k))?;
        let (_, t0) = onsets
            .iter()
            .map(|&t| (ssr(tau, t), t))
            .min_by(|a, b| a.0.total_cmp(&b.0))?;
        let (_, tau) = best_tau(t0)?;
        if tau >= top || grid.len() < 3 {
            return None;
        }
        let lo = (tau / DECAY_RATIO).max(grid[0]).ln();
        let hi = (tau * DECAY_RATIO).min(top).ln();
        let tau = golden_section(lo, hi, 10, |lv| ssr(lv.exp(), t0))
            .centre()
            .exp();
        let (dt, _) = run_times(d, g, t0);
        if tau < DECAY_LEAST_INTERVALS * dt {
            return None;
        }
        let c = with(tau);
        let specs = catalogue::specs(d, &c, t0, self.eps(s));
        let fitted = self.fit_candidate(s, self.moments_at(s, &c, t0), 2)?;
        Some(self.trial_of(s, &c, (Some(("time_s", t0)), 2), &specs.names, fitted))
    }

    /// A transient's decay time and its onset within its run, with standard
    /// uncertainties, into `params` (which hold its amplitude, onset and their σ); `None`
    /// for another effect. τ's 2σ interval is the τ whose profiled sum of squares
    /// (amplitude refitted, t₀ kept) exceeds the trial's by at most 4σ² (χ²₁ at 2σ),
    /// searched outward in ln τ by [`profile_bound`] between a tenth of a sample interval
    /// and the run's end; its quarter is σ_τ (infinite when the profile stays within it
    /// to the run's end: a decay the data do not bound). The amplitude's σ takes τ's
    /// along the profile (dβ/dτ·σ_τ) and the onset's: the amplitude is read at t₀, which
    /// is known to its σ_t₀ only, and a·e^(−Δ/τ) moves by a·σ_t₀/τ over Δ = σ_t₀.
    pub(crate) fn transient_parameters(
        &self,
        s: &State,
        t: &Trial,
        sigma: f64,
        params: &mut BTreeMap<String, f64>,
    ) -> Option<()> {
        let (_, t0) = t.theta.filter(|_| t.cand.effect == "transient")?;
        let d = self.d;
        let g = d.run_at_time(t0)?;
        let (dt, rest) = run_times(d, g, t0);
        let tau = t.cand.width_s;
        let with = |tau: f64| Candidate {
            width_s: tau,
            ..t.cand.clone()
        };
        let thr = t.ssr + 4.0 * sigma * sigma;
        let x0 = tau.ln();
        let within = |x: f64| self.ssr_at(s, &with((x0 + x).exp()), t0) <= thr;
        let (lo, _) = profile_bound(within, -1.0, 0.02, (x0 - (0.1 * dt).ln()).max(0.0));
        let (hi, open) = profile_bound(within, 1.0, 0.02, (rest.ln() - x0).max(0.0));
        let sd_tau = if open {
            f64::INFINITY
        } else {
            0.25 * ((x0 + hi).exp() - (x0 + lo).exp())
        };
        params.insert("decay_s".into(), tau);
        params.insert("std_decay_s".into(), sd_tau);
        params.insert("run_time_s".into(), t0 - d.fields.t_s[d.runs[g].start]);
        let sd_t0 = params.get("std_time_s").copied().unwrap_or(f64::INFINITY);
        params.insert("std_run_time_s".into(), sd_t0);
        if let Some(slope) = sd_tau.is_finite().then(|| self.width_slope(s, t)).flatten() {
            super::carry(params, (t, sigma, d), &slope, sd_tau, "decay_s");
        }
        let a = params.get("amplitude_um").copied()?;
        if let Some(sd) = params.get_mut("std_amplitude_um") {
            *sd = sd.hypot(a * sd_t0 / tau);
        }
        Some(())
    }
}
