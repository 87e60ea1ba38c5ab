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
//!    jointly (`Ctx::try_candidate`), giving ΔBIC = n·ln(SSR₁/SSR₀) + (m + n_nonlinear)·ln n
//!    and the held-out RMS;
//! 3. of those with ΔBIC ≤ −10 and a held-out RMS gain ≥ 0.5 %, the engine's parsimonious
//!    choice is admitted when plausible and determined, otherwise set aside (rejected or
//!    possible) and never tried again; the loop repeats until none qualifies (reaching
//!    the noise floor does not stop the search: a small effect near the floor is still
//!    found on its evidence).

use super::catalogue::{self, Candidate};
use super::design::{self, Design};
use super::effects;
use super::engine::{self, Admission, Rules, Score};
use super::linalg::dot;
use super::locate::locate;
use super::moments::Sets;
use super::reduced::Reduction;
use super::{
    Baseline, BeforeAfter, DiagnosisResult, Finding, Mismatch, Monotone, NoProgress, Progress,
};
use crate::axis::Topology;
use crate::error::SolverError;
use crate::session::Session;
use again::{Diagnosed, velocity_axes};
use context::{Ctx, Fit, State};
use seen::Seen;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use trial::{Trial, report_parameters};

mod again;
mod anomalies;
mod confounded;
mod context;
mod plates;
mod plots;
mod rivals;
mod seen;
mod trial;

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
            noise_level_ratio: crate::misfit::AT_NOISE_LEVEL,
            topology: None,
        }
    }
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
/// by `Ctx::try_candidate`; a choice is admitted when its parameters are plausible
/// ([`effects::implausible`]) and determined ([`effects::classify`]), and set aside (never
/// tried again) otherwise.
struct SessionProblem<'a> {
    ctx: Ctx<'a>,
    cands: Vec<Candidate>,
    floor: f64,
    /// Residual degrees of freedom of the rigid model.
    dof: usize,
    folds: usize,
    /// The head offsets of the setup-offset candidates, whose columns need the
    /// per-sample rotation errors on the runs of those groups (none: not needed).
    eps_groups: Vec<[f64; 3]>,
    /// The error axes of findings left undetermined for a rival (`rivals`): `None`, an
    /// effect without an axis. Their misfit stays the undecided pair's.
    undecided: std::sync::Mutex<Vec<Option<crate::axis::Axis>>>,
    /// Where this diagnosis records each candidate's gain (a first diagnosis), and the
    /// record of the first that spares candidates far from qualifying (a second):
    /// [`seen`].
    seen: (Option<&'a Seen>, Option<&'a Seen>),
}

/// What the session says of a candidate the loop chose.
enum Note {
    Finding(Finding),
    Possible(Finding),
    Rejected(String),
}

impl SessionProblem<'_> {
    /// The catalogue's candidates on the model `s`, before the first diagnosis's record
    /// spares or defers any ([`seen`]).
    fn candidates_all(&self, s: &State) -> Vec<Candidate> {
        // A lost motion that varies along the travel: whole (constant part included)
        // while the axis has no backlash in the model, its varying part refining the
        // axis's backlash once it has; neither, nor a backlash, after a whole profile.
        self.cands
            .iter()
            .filter(|c| {
                // A plate's scale, while its group's common scale stays with the axes.
                if let Some(m) = &c.mounting {
                    return catalogue::plate_scale::open(self.ctx.d, &s.plates, m);
                }
                let Some(a) = c.axis.map(|a| a.index()) else {
                    return true;
                };
                match c.effect {
                    "lost_motion_profile" => s.backlash[a].is_none() && !s.profiled[a],
                    "lost_motion_variation" => s.backlash[a].is_some() && !s.profiled[a],
                    "backlash" => !s.profiled[a],
                    // A growth in time of the axis's constant lost motion, once.
                    "backlash_growth" => s.backlash[a].is_some() && !s.grown[a],
                    _ => true,
                }
            })
            .map(|c| match (c.effect, c.axis) {
                // The growth widens the play of the axis's backlash in the model; the
                // varying part of its lost motion is taken up over it.
                ("backlash_growth" | "lost_motion_variation", Some(a)) => Candidate {
                    lost_motion_um: s.backlash[a.index()].map_or(0.0, |b| b.0),
                    ..c.clone()
                },
                _ => c.clone(),
            })
            // A change in time of a finding in the model, once (`catalogue::growth`).
            .chain(s.growths.iter().cloned())
            .collect()
    }
    fn state(
        &self,
        fit: Fit,
        k: usize,
        backlash: [Option<(f64, f64)>; 3],
        profiled: [bool; 3],
        prior: Option<(context::Kept, usize)>,
        thermal_prior: Option<(std::sync::Arc<super::thermal_search::ThermalBasis>, usize)>,
    ) -> State {
        State {
            backlash,
            profiled,
            grown: [false; 3],
            plates: Vec::new(),
            plate_cols: Vec::new(),
            growths: Vec::new(),
            kept: Default::default(),
            steps: Default::default(),
            prior: std::sync::Mutex::new(prior),
            thermal: Default::default(),
            thermal_prior: std::sync::Mutex::new(thermal_prior),
            path: Vec::new(),
            eps: Default::default(),
            eps_groups: self.eps_groups.clone(),
            fit,
            k,
        }
    }

    /// A step's signature in words with its place: direction, time, file, run, test and
    /// commanded position.
    fn step_place(&self, t0: f64, dir: crate::axis::Axis) -> String {
        let what = format!("a lasting offset of the {dir} reading from t = {t0:.2} s on");
        self.event_place(&what, t0)
    }

    /// A transient's signature in words with its place, as [`Self::step_place`].
    fn transient_place(&self, t0: f64, dir: crate::axis::Axis) -> String {
        let what = format!(
            "an offset of the {dir} reading from t = {t0:.2} s on that recovered (a knock, a collision, a chip under the plate)"
        );
        self.event_place(&what, t0)
    }

    /// `what` with the place of time `t0`: file, run, test and commanded position.
    fn event_place(&self, what: &str, t0: f64) -> String {
        let d = self.ctx.d;
        let s = d.fields.t_s.partition_point(|&t| t < t0);
        let s = s.min(d.fields.len() - 1);
        format!(
            "{what}: {}, at {}",
            anomalies::run_name(d, d.fields.run(s)),
            anomalies::position(d, s)
        )
    }

    fn heldout_rms(&self, f: &Fit) -> f64 {
        rms(f.heldout_ssr, self.ctx.sets.heldout_n)
    }

    /// The finding of a trial: before/after figures from the current fit `f` and, once
    /// the effect is added, the new fit `nf` (without it, the trial's own figures).
    fn finding_of(
        &self,
        t: &Trial,
        parameters: BTreeMap<String, f64>,
        f: &Fit,
        nf: Option<&Fit>,
        plates: &[String],
    ) -> Finding {
        let (n, heldout_n) = (self.ctx.d.rows(), self.ctx.sets.heldout_n);
        let h_before = self.heldout_rms(f);
        // A position-dependent lost motion says how its constant and varying parts share
        // the reversal error.
        let shares = matches!(
            t.cand.effect,
            "lost_motion_profile" | "lost_motion_variation"
        )
        .then(|| {
            let get = |k: &str| parameters.get(k).copied();
            Some(format!(
                "; {}",
                super::lost_motion::shares(get("mean_lost_motion_um")?, get("variation_um")?)
            ))
        })
        .flatten()
        .unwrap_or_default();
        let (after, h_after) = match nf {
            Some(nf) => (rms(nf.ssr, n), rms(nf.heldout_ssr, heldout_n)),
            None => (rms(t.ssr, n), rms(t.heldout_ssr, heldout_n)),
        };
        let signature = match (t.cand.effect, t.theta, t.cand.direction) {
            ("step", Some((_, th)), Some(dir)) => Some(self.step_place(th, dir)),
            ("transient", Some((_, th)), Some(dir)) => Some(self.transient_place(th, dir)),
            _ => match &t.cand.mounting {
                // A plate's scale: its mounting, the reference and what it means.
                Some(m) => Some(catalogue::plate_scale::signature(
                    self.ctx.d,
                    plates,
                    m,
                    parameters.get("scale_ppm").copied(),
                )),
                None => catalogue::signature(&t.cand, t.theta.map(|x| x.1)),
            },
        };
        Finding {
            effect: catalogue::reported_name(t.cand.effect).into(),
            axis: match (t.cand.effect, t.cand.direction) {
                // An error across the moving axis is the error of its direction.
                (
                    "direction_coupling" | "direction_coupling_growth" | "velocity_coupling",
                    Some(dir),
                ) => Some(dir.to_string()),
                _ => t
                    .cand
                    .axis
                    .map(|a| a.to_string())
                    .or(t.cand.direction.map(|a| a.to_string())),
            },
            depends_on: match t.cand.effect {
                "direction_coupling" | "direction_coupling_growth" | "velocity_coupling" => {
                    t.cand.axis.map(|a| a.to_string())
                }
                _ => None,
            },
            parameters,
            physics: effects::physics(catalogue::reported_name(t.cand.effect)).into(),
            signature,
            undetermined: vec![],
            rivals: Vec::new(),
            residual_rms_um: BeforeAfter {
                before: rms(f.ssr, n),
                after,
            },
            heldout_rms_um: BeforeAfter {
                before: h_before,
                after: h_after,
            },
            evidence: format!(
                "{}: BIC {:+.1} with {} extra parameter(s); held-out RMS {:.3} -> {:.3} um over {} folds of whole runs; noise floor {:.3} um{shares}",
                t.cand.label(),
                t.dbic,
                t.ncols + t.extra_params,
                h_before,
                h_after,
                self.folds,
                self.floor
            ),
        }
    }

    /// The reported parameters of trial `t` of candidate `c` on the model `s` at the
    /// residual σ `sigma`, with what its effect adds (a profile's, a growth's, a plate's
    /// temperature) before the σ of its nonlinear parameter are carried in.
    fn effect_parameters(
        &self,
        s: &State,
        c: &Candidate,
        t: &Trial,
        sigma: f64,
    ) -> std::collections::BTreeMap<String, f64> {
        let d = self.ctx.d;
        let mut params = report_parameters(t, sigma, d);
        if let ("lost_motion_profile" | "lost_motion_variation", Some(a)) = (c.effect, c.axis) {
            let constant = (c.effect == "lost_motion_variation")
                .then(|| s.backlash[a.index()])
                .flatten();
            params = trial::profile_parameters(t, sigma, d, a, constant);
        }
        if let ("backlash_growth", Some(a)) = (c.effect, c.axis) {
            catalogue::lost_motion_growth::parameters(&mut params, d, a, s.backlash[a.index()]);
        }
        if c.effect == catalogue::plate_scale::NAME {
            catalogue::plate_scale::parameters(&mut params, d);
        }
        catalogue::growth::parameters(&mut params, d, c);
        params
    }
}

impl super::engine::Greedy for SessionProblem<'_> {
    type State = State;
    type Candidate = Candidate;
    type Trial = Trial;
    type Note = Note;
    /// Nothing: the report reads the findings' notes and the final state only, so a
    /// state the loop has moved past is freed.
    type Before = ();

    fn noise_floor(&self) -> f64 {
        self.floor
    }
    fn n_fit(&self) -> usize {
        self.ctx.d.rows()
    }
    fn n_heldout(&self) -> usize {
        self.ctx.sets.heldout_n
    }
    fn score(&self, s: &State) -> Score {
        Score {
            sse: s.fit.ssr,
            heldout_sse: s.fit.heldout_ssr,
            k: s.k as f64,
        }
    }
    fn candidates(&self, s: &State) -> Vec<Candidate> {
        let first = self.seen.1;
        self.candidates_all(s)
            .into_iter()
            .filter(|c| first.is_none_or(|f| !f.spares(&s.path, c) && !f.defers(&s.path, c)))
            .collect()
    }
    fn deferred(&self, s: &State) -> Vec<Candidate> {
        let Some(first) = self.seen.1 else {
            return Vec::new();
        };
        self.candidates_all(s)
            .into_iter()
            .filter(|c| !first.spares(&s.path, c) && first.defers(&s.path, c))
            .collect()
    }
    fn label(&self, c: &Candidate) -> String {
        c.label()
    }
    fn evaluate(&self, s: &State, c: &Candidate) -> Option<(Score, Trial)> {
        let t = self.ctx.try_candidate(s, c)?;
        if let Some(record) = self.seen.0 {
            let n = self.ctx.d.rows() as f64;
            let gain = t.dbic - (t.ncols + t.extra_params) as f64 * n.ln();
            record.record(&s.path, c, gain, t.heldout_ssr);
        }
        let score = Score {
            sse: t.ssr,
            heldout_sse: t.heldout_ssr,
            k: (s.k + t.ncols + t.extra_params) as f64,
        };
        Some((score, t))
    }
    fn admit(&self, s: &State, c: &Candidate, t: &Trial) -> Admission<Note> {
        // A plate scale whose form does not hold: one axis's change of scale (`plates`).
        if let Some(why) = self.plate_form_broken(s, c, t) {
            return Admission::SetAside(Note::Rejected(why));
        }
        let (d, f) = (self.ctx.d, &s.fit);
        let n = d.rows();
        let sigma = (t.ssr
            / (self.dof.saturating_sub(s.k + t.ncols + t.extra_params)).max(1) as f64)
            .sqrt();
        let mut params = self.effect_parameters(s, c, t, sigma);
        // A step's ramp: its width with σ (also the step time's, below).
        let width = self.ctx.step_width(s, t, sigma);
        if let Some((name, sd)) = self.ctx.theta_std(s, t, sigma, width.as_ref().map(|w| w.1)) {
            params.insert(format!("std_{name}"), sd);
            // The linear parameters are fitted jointly with the nonlinear one: their σ,
            // conditional on it, take its uncertainty along the profile,
            // σ² + (dβ/dθ·σ_θ)² (a reversal spike's height with its decay length, a
            // thermal offset or scale with its time constant, a temperature's per-kelvin
            // coefficients with its lag).
            if t.cand.effect == "thermal_temperature_lag" {
                let slope = self.ctx.coef_slope(s, t);
                for (i, n) in t.names.iter().enumerate() {
                    let b = slope.as_ref().map_or(f64::INFINITY, |v| v[i]);
                    if let Some(v) = params.get_mut(&format!("std_{n}")) {
                        *v = v.hypot(b * sd);
                    }
                }
            } else if let Some(iv) = self.ctx.time_constant_interval(s, t, sigma, sd) {
                // A thermal drift's time constant: its likelihood-ratio interval, often
                // asymmetric, reported as such, σ a quarter of its width; the offsets and
                // scales refitted at its bounds.
                params.insert(format!("{name}_low"), iv.low);
                if iv.high.is_finite() {
                    params.insert(format!("{name}_high"), iv.high);
                }
                params.insert(format!("std_{name}"), 0.25 * (iv.high - iv.low));
                trial::carry_interval(&mut params, (t, sigma, d), &iv, name);
                let t_end = d.fields.t_s.iter().copied().fold(0.0, f64::max);
                trial::span_growth(&mut params, (t, sigma), &iv, t_end);
            } else if let Some(slope) = self.ctx.coef_slope(s, t) {
                // Reported parameters (an amplitude from its sine and cosine) moved by
                // ±σ_θ along the profile; σ_θ of a frequency from its period's.
                let sd_theta = match t.theta {
                    Some(("period_mm", f)) => sd * f * f,
                    _ => sd,
                };
                trial::carry(&mut params, (t, sigma, d), &slope, sd_theta, name);
            }
        }
        // The ramp's width carried into the step's size along the same path.
        if let Some((w, sw, slope)) = width {
            params.insert("width_s".into(), w);
            params.insert("std_width_s".into(), sw);
            if let Some(slope) = slope {
                trial::carry(&mut params, (t, sigma, d), &slope, sw, "width_s");
            }
        }
        // A transient's decay and its onset within the run, carried into its amplitude.
        self.ctx.transient_parameters(s, t, sigma, &mut params);
        if t.cand.effect.starts_with("thermal_temperature") {
            let forms = self.ctx.form_variance(s, t, sigma);
            for (name, v) in t.names.iter().zip(forms) {
                if let Some(sd) = params.get_mut(&format!("std_{name}")) {
                    *sd = sd.hypot(v.sqrt());
                }
            }
        }
        let explained = ((f.ssr - t.ssr).max(0.0) / n as f64).sqrt();
        let size: f64 = t
            .coef
            .iter()
            .zip(&t.peaks)
            .map(|(c, p)| (c * p).abs())
            .sum();
        // A logged temperature is a measured regressor, not a shape fitted to the misfit:
        // a large growth of which the run offsets absorb the bulk is physics, judged by
        // its σ (the smoother's included), not by its size against the misfit.
        let measured = t.cand.effect.starts_with("thermal_temperature");
        // The size's standard uncertainty: Σ peak·σ over the coefficients, an upper bound
        // of the linear combination's (their covariance is not at hand), with σ
        // conditional on the nonlinear parameter (a thermal drift's time constant). With
        // that parameter's uncertainty carried in, as the reported σ carry it, the 40 ppm
        // thermal drifts of the coverage test keep z = 12.8–22, above the bound too.
        let size_sd: f64 = t
            .coef_sd
            .iter()
            .zip(&t.peaks)
            .map(|(s, p)| s * sigma * p)
            .sum();
        if let Some(why) = effects::implausible(&c.label(), size, size_sd, explained, self.floor)
            .filter(|_| !measured)
            .or_else(|| self.confounded(s, c, t, sigma))
        {
            return Admission::SetAside(Note::Rejected(why));
        }
        // The model's form on its own support: a lag or a shift that differs between
        // lines and circles, near and beyond the axis's reversals, beyond what the noise
        // allows is not the model's (`FORM_ALPHA`). Below that, the places' spread
        // beyond their σ (`FormTest::between_places_variance`, τ²) is carried into the
        // one coefficient's σ, σ² + τ², and so into every figure made of it.
        let form = matches!(c.effect, "servo_lag" | "direction_coupling")
            .then(|| self.ctx.form_test(s, t, sigma))
            .flatten();
        if let Some(ft) = &form {
            let sd = t.coef_sd[0] * sigma;
            let widen = (1.0 + ft.between_places_variance() / (sd * sd)).sqrt();
            if widen.is_finite() {
                params
                    .iter_mut()
                    .filter(|(n, _)| n.starts_with("std_"))
                    .for_each(|(_, v)| *v *= widen);
            }
        }
        // A servo lag whose places agree within `LAG_FORM_SPREAD` is a lag whatever the
        // test's p: its second order (the ramps between samples, the acceleration at the
        // reversals) moves the places by a few per cent, which the σ now carries, while
        // a lost motion read as a lag differs between them by the feeds' ratio.
        let form = form.filter(|ft| {
            ft.p < FORM_ALPHA
                && !(c.effect == "servo_lag" && ft.relative_spread() <= LAG_FORM_SPREAD)
        });
        let finding = self.finding_of(t, params, f, None, &s.plates);
        // A size far beyond what the held-out runs gain from it is not credible, whatever
        // its σ (`credible::MAX_SIZE_PER_GAIN`); a logged temperature's growth is judged
        // by its σ alone, as above; a local effect (a step, on its run) is not judged by a
        // gain diluted over the session.
        let th = t.theta.map_or(0.0, |x| x.1);
        let local = catalogue::specs(d, &t.cand, th, self.ctx.eps(s))
            .run()
            .is_some();
        let beyond = super::credible::beyond_heldout_gain(size, &finding.heldout_rms_um)
            .filter(|_| !measured && !local);
        let sorted = match (form, beyond) {
            (Some(ft), _) => effects::form_rejected(finding, &form_sentence(c.effect, &ft)),
            (None, Some(why)) => super::credible::not_credible(finding, &t.names, &why),
            (None, None) => effects::classify(finding),
        };
        match sorted {
            effects::Sorted::Determined(f) => self.against_rivals(s, c, t, f),
            effects::Sorted::Possible(f) => Admission::SetAside(Note::Possible(f)),
        }
    }
    /// The model refitted with the trial's columns (centred, unit norm); its finding with
    /// the refitted figures. The state before is the loop's no longer: its columns move
    /// into the new model, its kept moments and thermal basis into the new state (for the
    /// next round's), and its residual and rotation errors are freed before the new
    /// model's are formed.
    fn add(&self, mut s: State, c: &Candidate, t: Trial, note: Note) -> (State, (), Note) {
        let d = self.ctx.d;
        // Base columns [accepted effects | y] of the model before.
        let u_prev = s.fit.cols.len() + 1;
        let th = t.theta.map_or(0.0, |x| x.1);
        // The trial's own form (a logged temperature's lagged or quadratic form).
        let form = &t.cand;
        let (new_cols, _, _) = catalogue::columns(d, form, th, self.ctx.eps(&s));
        let is_local = catalogue::specs(d, form, th, self.ctx.eps(&s))
            .run()
            .is_some();
        let mut cols = std::mem::take(&mut s.fit.cols);
        let mut local = std::mem::take(&mut s.fit.local);
        for mut col in new_cols {
            let nrm = dot(&col, &col).sqrt().max(1e-300);
            col.iter_mut().for_each(|v| *v /= nrm);
            cols.push(col);
            local.push(is_local);
        }
        s.eps.take();
        s.fit.resid = Vec::new();
        // The model before this one is not searched again: its kept moments go.
        s.prior.get_mut().expect("prior moments").take();
        let nf = self.ctx.fit(cols, local);
        let note = match note {
            Note::Finding(finding) => Note::Finding(Finding {
                undetermined: finding.undetermined,
                rivals: finding.rivals,
                ..self.finding_of(&t, finding.parameters, &s.fit, Some(&nf), &s.plates)
            }),
            other => other,
        };
        let (mut backlash, mut profiled, mut grown) = (s.backlash, s.profiled, s.grown);
        match (&note, c.effect, c.axis) {
            (Note::Finding(f), "backlash", Some(a)) => {
                backlash[a.index()] = f.parameters.get("lost_motion_um").map(|&b| {
                    (
                        b,
                        f.parameters
                            .get("std_lost_motion_um")
                            .copied()
                            .unwrap_or(0.0),
                    )
                });
            }
            (Note::Finding(_), "lost_motion_profile", Some(a)) => profiled[a.index()] = true,
            (Note::Finding(_), "backlash_growth", Some(a)) => grown[a.index()] = true,
            _ => {}
        }
        let mut plates = std::mem::take(&mut s.plates);
        let mut plate_cols = std::mem::take(&mut s.plate_cols);
        if let (Note::Finding(_), Some(m)) = (&note, &c.mounting) {
            plates.push(m.clone());
            plate_cols.push(u_prev - 1);
        }
        let mut growths = std::mem::take(&mut s.growths);
        if let Note::Finding(f) = &note {
            // A finding tested for a change offers its growth; a growth in the model is
            // not offered again.
            growths
                .retain(|g| g.effect != c.effect || g.axis != c.axis || g.direction != c.direction);
            let parent = catalogue::growth::Parent::of(c.effect, &f.parameters, th);
            growths.extend(parent.and_then(|p| catalogue::growth::candidate(c, p)));
        }
        let k = s.k + t.ncols + t.extra_params;
        // The candidates' moments on this model serve the next round's.
        let kept = std::mem::take(s.kept.get_mut().expect("kept moments"));
        // So does the thermal searches' basis.
        let thermal = s.thermal.take().map(|b| (b, u_prev));
        let mut path = std::mem::take(&mut s.path);
        if let Some(record) = self.seen.0 {
            record.admitted(&path, c);
        }
        path.push(c.clone());
        drop(s);
        let mut next = self.state(nf, k, backlash, profiled, Some((kept, u_prev)), thermal);
        next.path = path;
        next.grown = grown;
        next.plates = plates;
        next.plate_cols = plate_cols;
        next.growths = growths;
        (next, (), note)
    }
}

/// False-alarm rate of the lack-of-fit test of an effect's form (`trial::FormTest`): a
/// servo lag or a direction coupling whose form holds is set aside with this
/// probability.
const FORM_ALPHA: f64 = 1e-3;

/// Largest spread of a servo lag's places relative to the lag
/// ([`trial::FormTest::relative_spread`]) within which its form holds whatever the
/// lack-of-fit test says. A lag is read alike on lines and circles (within a few per
/// cent: the ramps between samples, the acceleration at the reversals); a lost motion
/// read as a lag differs between them by the feeds' ratio, and by 2–5× near the
/// reversals at one feed, where the axis slows but the play does not shrink.
const LAG_FORM_SPREAD: f64 = 0.25;

/// The sentence of an effect whose form does not hold: the coefficient per place, the
/// test, and what would decide it.
fn form_sentence(effect: &str, ft: &trial::FormTest) -> String {
    let unit = if effect == "servo_lag" { "ms" } else { "um" };
    let k = if effect == "servo_lag" { 1e3 } else { 1.0 };
    let places: Vec<String> = ft
        .places
        .iter()
        .map(|(name, v, sd)| format!("{:+.3} ± {:.3} {unit} on {name}", k * v, k * sd))
        .collect();
    let data = match effect {
        "servo_lag" => {
            "the controller's commanded velocity, or a sample rate well above the acceleration ramps,"
        }
        _ => "a model of the transient across the axis after its reversals",
    };
    format!(
        "the model's form does not hold on its own support: fitted per place it reads {} (chi2 = {:.1} on {} degrees of freedom, p = {:.1e}); {data} would decide it",
        places.join(", "),
        ft.chi2,
        ft.dof,
        ft.p
    )
}

/// [`diagnose_session`], reporting its phases and the fraction of the work done to
/// `progress` (fractions in [0, 1], never decreasing, ending at 1).
///
/// A servo lag or a velocity coupling found (or possible) reads the axis's velocity at
/// every sample, which the set-points do not tell inside the starts and stops of the
/// motion ([`design::velocity_known`]): the session is then diagnosed again with those
/// samples of the axes concerned left out, and that diagnosis is the result.
pub fn diagnose_session_with_progress(
    session: &Session,
    opts: &DiagnoseOptions,
    progress: &mut dyn Progress,
) -> Result<DiagnosisResult, SolverError> {
    let mut progress = Monotone::new(progress);
    let topology = session
        .topology
        .clone()
        .or_else(|| opts.topology.clone())
        .unwrap_or_default();
    progress.report("reducing the rigid model", 0.0);
    let d = design::build(session, &topology, opts.order)?;
    // The session's spectral noise floor, the same for both diagnoses: formed once.
    let spectral = crate::noise::session_spectral_floor(session);
    let seen = Seen::default();
    let first = diagnose_design(
        session,
        opts,
        &d,
        &mut progress,
        (0.0, 0.6),
        (Some(&seen), None),
        spectral,
    )?;
    drop(d);
    let axes = match first {
        Diagnosed::Done(first) => {
            progress.report("done", 1.0);
            return Ok(first);
        }
        Diagnosed::Again(axes) => axes,
    };
    let d = design::build_leaving_out(session, &topology, opts.order, axes)?;
    if d.left_out == 0 {
        // No sample to leave out: the first diagnosis is the result, with its report
        // (not formed above), diagnosed again as it was.
        drop(d);
        let d = design::build(session, &topology, opts.order)?;
        let first = diagnose_design(
            session,
            opts,
            &d,
            &mut progress,
            (0.6, 1.0),
            (None, None),
            spectral,
        )?;
        progress.report("done", 1.0);
        return Ok(first.done());
    }
    progress.report("reducing the rigid model without the ramps' samples", 0.6);
    let mut r = diagnose_design(
        session,
        opts,
        &d,
        &mut progress,
        (0.6, 1.0),
        (None, Some(&seen)),
        spectral,
    )?
    .done();
    let note = format!(
        "; {} samples inside the starts and stops of the motion, where the set-points do not tell the velocity, left out",
        d.left_out
    );
    for f in r.findings.iter_mut().chain(r.possible.iter_mut()) {
        if matches!(f.effect.as_str(), "servo_lag" | "velocity_coupling") {
            f.evidence.push_str(&note);
        }
    }
    progress.report("done", 1.0);
    Ok(r)
}

/// What the rigid model alone gives the report.
struct RigidFigures {
    dof: usize,
    base_heldout: f64,
    residual_rms: f64,
    before: plots::Series,
    anomalies: Vec<anomalies::Located>,
    mismatch: Vec<Mismatch>,
}

/// The rigid model's figures on its fit `f`: its residual, the places of its misfit and
/// its local anomalies (listed as places when one-off events, in a few runs; anomalies
/// in many runs are the recurring misfit the other places describe).
fn rigid_figures(d: &Design, f: &Fit, floor: f64, heldout_n: usize, ratio: f64) -> RigidFigures {
    let n = d.rows();
    let dof = n.saturating_sub(2 * d.runs.len() + f.rank).max(1);
    let base_heldout = rms(f.heldout_ssr, heldout_n);
    // Local anomalies of the rigid model's residual: a session with one is never
    // consistent, whatever its global ratio.
    let rigid_anomalies = anomalies::scan(d, &f.resid, floor);
    let mut mismatch = if base_heldout > ratio * floor {
        locate(d, &f.resid, floor)
    } else {
        Vec::new()
    };
    let total_excess: f64 = f.resid.iter().map(|r| r * r - floor * floor).sum();
    let one_off = anomalies::events(&rigid_anomalies) <= anomalies::MAX_ONE_OFF;
    mismatch.extend(
        rigid_anomalies
            .iter()
            .filter(|_| one_off)
            .take(6)
            .map(|a| Mismatch {
                where_: a.describe(d),
                tests: vec![a.test_id(d)],
                share_of_misfit: (a.excess / total_excess.max(1e-300)).clamp(0.0, 1.0),
            }),
    );
    mismatch.sort_by(|a, b| b.share_of_misfit.total_cmp(&a.share_of_misfit));
    RigidFigures {
        dof,
        base_heldout,
        residual_rms: rms(f.resid.iter().map(|v| v * v).sum(), n),
        before: plots::Series::of(d, &f.resid, "before"),
        anomalies: rigid_anomalies,
        mismatch,
    }
}

/// The diagnosis of the session `session` on its design `d`, reporting within `span`
/// of the whole work.
fn diagnose_design(
    session: &Session,
    opts: &DiagnoseOptions,
    d: &Design,
    progress: &mut Monotone,
    span: (f64, f64),
    seen: (Option<&Seen>, Option<&Seen>),
    spectral: Option<(f64, usize)>,
) -> Result<Diagnosed, SolverError> {
    let folds = opts.folds.max(2);
    let red = Reduction::new(session, d);
    let sets = Sets::new(d, &red, folds);
    let heldout_n = sets.heldout_n;
    let scans = Default::default();
    let ctx = Ctx {
        d,
        red: &red,
        sets: &sets,
        floor: f64::NAN,
        bic_threshold: opts.min_bic_gain,
        scans: &scans,
    };
    progress.report_in(span, "fitting the rigid model", 0.05);
    let f = ctx.fit(Vec::new(), Vec::new());
    progress.report_in(span, "noise floor", 0.08);
    // The floor is the spectral one when a run is long enough for the spectrum; the
    // differences of repeated passes (`noise::session_floor`'s check) otherwise, and for
    // the note, which only a misfit left above the floor needs: computed then.
    let checked = std::cell::OnceCell::new();
    let noise_floor = || {
        *checked.get_or_init(|| {
            crate::noise::NoiseFloor::of(spectral, crate::noise::pass_differences(session))
        })
    };
    let floor = match spectral {
        Some((s, _)) => s,
        None => noise_floor().map_or(
            (f.ssr / d.rows().saturating_sub(2 * d.runs.len() + f.rank).max(1) as f64).sqrt(),
            |nf| nf.sigma_um,
        ),
    };
    let ctx = Ctx { floor, ..ctx };
    // What the report says of the rigid model's residual, formed now: the residual
    // itself is not kept.
    let rigid = rigid_figures(d, &f, floor, heldout_n, opts.noise_level_ratio);
    let cands = catalogue::candidates(d);
    let problem = SessionProblem {
        ctx,
        eps_groups: cands
            .iter()
            .filter(|c| c.effect == "setup_offset")
            .filter_map(|c| c.group)
            .collect(),
        cands,
        floor,
        dof: rigid.dof,
        folds,
        undecided: Default::default(),
        seen,
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
    let base = problem.state(f, 0, [None; 3], [false; 3], None, None);
    let o = engine::run(&problem, base, &rules, "", progress, span);
    let mut findings: Vec<Finding> = o
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
    problem.restate_plates(&o.state, &mut findings);
    let axes = velocity_axes(findings.iter().chain(&possible));
    if seen.0.is_some() && axes.contains(&true) {
        return Ok(Diagnosed::Again(axes));
    }
    // All the report reads of the final model: the rest of its state (accepted columns,
    // kept moments, rotation errors, thermal basis) is freed before the report's scans.
    let (resid, heldout_ssr) = o.state.into_residual();
    progress.report_in(span, "report", 0.95);
    let final_heldout = rms(heldout_ssr, heldout_n);
    let at_noise = final_heldout <= opts.noise_level_ratio * floor;
    let final_anomalies = anomalies::scan(d, &resid, floor);
    let verdict = effects::verdict(
        rigid.base_heldout <= opts.noise_level_ratio * floor && rigid.anomalies.is_empty(),
        at_noise && final_anomalies.is_empty(),
        findings.len(),
    );
    let mut unexplained = unexplained_anomalies(d, &final_anomalies);
    if !at_noise {
        let floor_note = match noise_floor() {
            Some(nf) => nf.note(),
            None => "no run long enough for the spectrum and no repeated passes: the rigid model's residual stands in for the noise floor".into(),
        };
        let rest = locate(d, &resid, floor);
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
    let plots = plots::plots(d, rigid.before, plots::Series::of(d, &resid, "after"));
    Ok(Diagnosed::Done(DiagnosisResult {
        kind: "diagnosis".into(),
        machine_id: session.machine_id.clone(),
        source: "session".into(),
        baseline: Baseline {
            residual_rms_um: rigid.residual_rms,
            heldout_rms_um: rigid.base_heldout,
            noise_estimate_um: floor,
        },
        mismatch: rigid.mismatch,
        findings,
        possible,
        rejected,
        verdict,
        unexplained,
        plots,
    }))
}

/// The final model's local anomalies in words (at most 6), each saying whether they
/// recur (in more runs than one-off events are).
fn unexplained_anomalies(d: &Design, found: &[anomalies::Located]) -> Vec<String> {
    let (n, events) = (found.len(), anomalies::events(found));
    found
        .iter()
        .take(6)
        .map(|a| {
            let how = if events > anomalies::MAX_ONE_OFF {
                format!("; {n} such anomalies in {events} runs: a misfit that recurs")
            } else {
                String::new()
            };
            format!("{} (not explained by the findings{how})", a.describe(d))
        })
        .collect()
}

fn rms(ssr: f64, n: usize) -> f64 {
    (ssr / n.max(1) as f64).sqrt()
}
