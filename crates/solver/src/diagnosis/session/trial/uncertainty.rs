//! Standard uncertainties of a trial's nonlinear parameter (the curvature or the 2σ
//! interval of its profiled sum of squares), the variance the choice of a temperature
//! form adds, and the slopes of the coefficients along the nonlinear parameter.

use crate::diagnosis::catalogue::{self, Candidate, Search};
use crate::diagnosis::session::anomalies::step_time;
use crate::diagnosis::session::context::{Ctx, State};
use crate::diagnosis::session::trial::Trial;
use crate::diagnosis::session::trial::profile_likelihood::{
    LN_REACH, TimeConstantInterval, confirmed, profile_bound, profile_bound_confirmed,
};

impl Ctx<'_> {
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
            let specs = catalogue::specs(self.d, &lag.cand, up, self.eps(s));
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
        if catalogue::is_own_value(name) {
            // Not a free parameter: the first coefficient itself (a play's width, a lag).
            return None;
        }
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
        if catalogue::is_own_value(name) {
            // Not a free parameter: the first coefficient itself (a play's width, a lag).
            return None;
        }
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
        if t.cand.effect == "step" && t.cand.width_s > 0.0 {
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
