//! A candidate of the catalogue fitted jointly with the current model: its nonlinear
//! parameter searched (a grid refined by golden section, or a frequency scan), its joint
//! fit on all runs and on the folds, its ΔBIC, and its parameters in physical units.
//!
//! The trial is built in steps, one module each:
//! - [`frequency_scan`]: the coarse scan of a periodic candidate's frequency;
//! - [`theta_search`]: the nonlinear parameter searched and refined on the joint fit;
//! - this module: the joint fit of the candidate with the current model (its ΔBIC);
//! - [`uncertainty`]: the standard uncertainties of the nonlinear parameter and the
//!   slopes of the coefficients along it;
//! - [`profile_likelihood`]: the 2σ likelihood-ratio intervals of a profile;
//! - [`form_test`]: the lack-of-fit test of an effect's form on its own support;
//! - [`stationarity`]: a vibration's one amplitude and phase over the session;
//! - [`parameters`]: the trial's parameters in physical units with their σ.

mod form_test;
mod frequency_scan;
mod parameters;
mod profile_likelihood;
mod stationarity;
mod theta_search;
mod transient;
mod uncertainty;

pub(crate) use form_test::FormTest;
pub(crate) use parameters::{
    carry, carry_interval, profile_parameters, report_parameters, span_growth,
};

use crate::diagnosis::catalogue::{self, Candidate};
use crate::diagnosis::moments::{self, Moments};
use crate::diagnosis::search::golden_section;
use crate::diagnosis::session::context::{Ctx, State};
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

impl Ctx<'_> {
    /// The candidate evaluated jointly with the current model `s`: its nonlinear
    /// parameter searched, its joint fit on all runs and the folds, its ΔBIC.
    pub fn try_candidate(&self, s: &State, cand: &Candidate) -> Option<Trial> {
        match cand.effect {
            "thermal_temperature" => self.try_temperature_forms(s, cand),
            "lost_motion_profile" | "lost_motion_variation" => self.try_profile_orders(s, cand),
            "step" => self.try_step(s, cand),
            "transient" => self.try_transient(s, cand),
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
        let specs = catalogue::specs(d, &c, t, self.eps(s));
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
    /// biased by tens of its σ where the lost motion changes sign along the travel.
    ///
    /// The play is taken up after each turn as a backlash's ([`catalogue::play`]): the
    /// varying part over the axis's backlash b̄ in the model; the whole profile over its
    /// own mean lost motion (its constant coefficient), by the backlash's fixed point from
    /// the sharp switch on the order chosen there ([`Ctx::profile_take_up`]), the orders
    /// chosen again at it. Taken up at once, a sample of a circle just
    /// past an axis's turn (a few µm of its travel) read the whole lost motion. The
    /// columns at one θ do not depend on the model: their moments are kept for the next
    /// round ([`Ctx::moments_kept`]).
    fn try_profile_orders(&self, s: &State, cand: &Candidate) -> Option<Trial> {
        if cand.effect == "lost_motion_variation" {
            return self.profile_orders_at(s, cand, cand.lost_motion_um.max(0.0));
        }
        let sharp = self.profile_orders_at(s, cand, 0.0)?;
        let Some(theta) = self.profile_take_up(s, cand, &sharp) else {
            return Some(sharp);
        };
        self.profile_orders_at(s, cand, theta).or(Some(sharp))
    }

    /// The whole profile's take-up θ (µm) on the order of `sharp` (its trial taken up at
    /// once): the backlash's fixed point ([`theta_search::take_up_fixed_point`]) on the
    /// constant coefficient, its pass of least SSR taken even where `sharp` fits better
    /// (the play's width is its physics, not a choice of the fit). Not searched for a
    /// profile that cannot qualify or of a mean lost motion ≤ 0. The moments are the
    /// candidate's `cand` (of the largest order), kept for the orders' fits at the θ found.
    fn profile_take_up(&self, s: &State, cand: &Candidate, sharp: &Trial) -> Option<f64> {
        let b0 = match sharp.names.first() {
            Some(n) if n == "b0" => sharp.coef[0],
            _ => return None,
        };
        if b0 <= 0.0 || !self.may_qualify(s, sharp.ssr, sharp.ncols) {
            return None;
        }
        let cols: Vec<usize> = (0..=sharp.cand.order).collect();
        let fit = |v: f64| {
            let mom = self.moments_at(s, cand, v);
            let (_, keep, jf) = self.fit_moments(&s.fit, mom.select(&cols), false)?;
            (keep.first() == Some(&0)).then(|| (jf.all.ssr, jf.all.x[0], ()))
        };
        theta_search::take_up_fixed_point(b0, fit).map(|x| x.1)
    }

    /// [`Ctx::try_profile_orders`] with the play taken up over θ (µm; 0: at once).
    fn profile_orders_at(&self, s: &State, cand: &Candidate, theta: f64) -> Option<Trial> {
        let specs = catalogue::specs(self.d, cand, theta, self.eps(s));
        let mom = self.moments_at(s, cand, theta);
        let from = usize::from(cand.effect == "lost_motion_variation");
        let theta = (theta > 0.0).then_some((catalogue::TAKE_UP, theta));
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
            let t = self.trial_of(s, &c, (theta, 0), &specs.names, fit);
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

    fn try_one(&self, s: &State, cand: &Candidate) -> Option<Trial> {
        let (theta, extra, mom) = self.search_theta(s, cand)?;
        let th = theta.map_or(0.0, |t| t.1);
        let specs = catalogue::specs(self.d, cand, th, self.eps(s));
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
}
