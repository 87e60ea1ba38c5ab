//! Catalogue of candidate effects for sessions: each is a parametric extension of the
//! rigid model — extra columns of the design (linear parameters, physical units) that
//! depend on at most one nonlinear parameter, searched in 1-D.
//!
//! | effect | columns (along the named axis) | nonlinear |
//! |---|---|---|
//! | backlash | −d/2 (d: sign of the axis's last travel), taken up over the first b of travel after a reversal (from +d/2) → lost motion b, µm | take-up θ = b (fixed point) |
//! | servo_lag_growth, cyclic_growth, reversal_spike_growth, direction_coupling_growth | the finding's own column per unit of its principal value (at its nonlinear value and phase) × (t − t̄)/3600 on the runs that move its axis, once the finding is in the model → growth, per hour (`growth`) | — |
//! | backlash_growth | −d/2·(t − t̄)/3600 on the runs that move the axis, t the session time (s), once the axis's backlash is in the model → growth g, µm/h (`lost_motion_growth`) | — |
//! | lost_motion_profile | −d·P_k(s)/2, k = 0..K, s the position on the measured travel, taken up as a backlash's over θ → lost motion b(q), µm; k = 1..K alone (its varying part, θ the backlash's b̄) once the axis's backlash is in the model; the order K chosen by the data (2 … 9) | take-up θ = b₀ (fixed point) |
//! | servo_lag | (−v + a·θ/2)·10³, a the set-points' acceleration → lag τ, s | second order θ = τ (fixed point) |
//! | reversal_spike | −d·exp(−s/λ) → height h, µm | decay λ, mm |
//! | cyclic | sin, cos(2π q/P) → amplitude, phase | period P, mm |
//! | thermal_drift | g(t)·q_j·10⁻³ and g(t) per direction j, g = 1 − e^(−t/T) → scale ppm, offset µm | T, s |
//! | thermal_drift (temperature) | ΔT·q_j·10⁻³ and ΔT per direction j, ΔT the logged temperature's change → ppm/K, µm/K | — |
//! | thermal_drift (temperature, lagged) | the same with ΔT through a first-order lag → ppm/K, µm/K | lag τ, s |
//! | thermal_drift (temperature, quadratic) | the same and ΔT²·q_j·10⁻³, ΔT² → ppm/K, µm/K, ppm/K², µm/K² | — |
//! | setup_offset | (Σ_k ε_k(q_k)) × e_j ·10⁻³ on one head-offset group → Δt_j, mm | — |
//! | plate_scale | (u, v)·10⁻³ on both readings of one plate mounting's runs, (u, v) the in-plane position plus head offset → scale s, ppm (`plate_scale`) | — |
//! | model_order | Legendre P_4..P_10 of the axis position, along one direction | — |
//! | vibration | sin, cos(2π f t) → amplitude, phase | frequency f, Hz |
//! | waviness (signature) | sin, cos(2π q_a/P) along a direction j ≠ a → amplitude, phase | period P, mm |
//! | velocity_coupling (signature) | v_a along a direction j ≠ a → coefficient, µm per mm/s | — |
//! | direction_coupling (signature) | d_a/2 along a direction j ≠ a, taken up over the first θ of a's travel after its reversal → shift, µm | take-up θ, mm |
//! | step (signature) | 1 from time t₀ on along direction j, or a ramp from 0 to 1 over a width w centred on t₀ → size, µm (local to the run holding t₀) | t₀, s; w, s |
//! | transient (signature) | e^(−(t − t₀)/τ) from time t₀ on along direction j, 0 before → amplitude, µm (local to the run holding t₀; `transient`) | t₀, s; τ, s |
//!
//! The signature space: for each moving axis a, its direction of travel d_a, position
//! (smooth and periodic), velocity v_a and travel since its last reversal, and the session
//! time and logged temperature, each acting along X, Y or Z. Along a itself these are the
//! named mechanisms (backlash, model order, cyclic error, servo lag, reversal spike);
//! across it they are model order, waviness, velocity coupling and direction coupling; in
//! time, vibration and thermal drift (docs/diagnosis-catalogue.md, "Beyond the catalogue: signatures").

use super::design::Design;
use super::linalg::Cols;
use super::lost_motion::Profile;
use super::phase_walk::PhaseWalk;
use crate::axis::Axis;
use std::f64::consts::PI;

pub use columns::Columns;

mod columns;
pub mod growth;
pub mod lost_motion_growth;
pub mod plate_scale;

/// One candidate: an effect on an axis/direction (or a head-offset group).
#[derive(Debug, Clone, PartialEq)]
pub struct Candidate {
    pub effect: &'static str,
    pub axis: Option<Axis>,
    /// For model_order: the direction of the error; for setup_offset: unused.
    pub direction: Option<Axis>,
    /// For setup_offset: the declared head offset of the group.
    pub group: Option<[f64; 3]>,
    /// For lost_motion_profile and lost_motion_variation: the Legendre order K of the
    /// profile (the catalogue's candidate holds the largest, [`PROFILE_ORDERS`]; a
    /// trial's, the order the data chose); 0 for every other effect.
    pub order: usize,
    /// For step: the width w of its ramp, s (0: sharp, between two samples; a trial's,
    /// the width the data chose); for transient: its decay time τ, s; 0 for every other
    /// effect.
    pub width_s: f64,
    /// For backlash_growth: the axis's constant lost motion b̄ in the model (µm), the
    /// play whose take-up the growth widens (`lost_motion_growth`); for
    /// lost_motion_variation, the same b̄, over which its columns are taken up; 0 for
    /// every other effect.
    pub lost_motion_um: f64,
    /// For plate_scale: the plate's mounting (the session's name of it,
    /// `plate_scale`); `None` for every other effect.
    pub mounting: Option<String>,
    /// For a growth (`growth`): the finding it refines, as it is in the model; `None`
    /// for every other effect.
    pub parent: Option<growth::Parent>,
}

impl Candidate {
    pub fn label(&self) -> String {
        let mut s = self.effect.to_string();
        if let Some(a) = self.axis {
            s += &format!(" {a}");
        }
        if let Some(d) = self.direction {
            s += &format!(" along {d}");
        }
        if let Some(g) = self.group {
            s += &format!(" at t = {g:?}");
        }
        if let Some(m) = &self.mounting {
            s += &format!(" of mounting `{m}`");
        }
        if self.order > 0 {
            s += &format!(" of order {}", self.order);
        }
        if self.width_s > 0.0 && self.effect == "transient" {
            s += &format!(" decaying over {:.3} s", self.width_s);
        } else if self.width_s > 0.0 {
            s += &format!(" ramped over {:.2} s", self.width_s);
        }
        s
    }
}

/// For an effect found by its signature (outside the named catalogue): the signature in
/// words, e.g. "a Y error periodic in the X position (period 16.0 mm)".
pub fn signature(c: &Candidate, theta: Option<f64>) -> Option<String> {
    let (a, j) = (c.axis?, c.direction?);
    match c.effect {
        "waviness" => Some(format!(
            "a {j} error periodic in the {a} position (period {:.1} mm)",
            theta.map_or(f64::NAN, |f| 1.0 / f)
        )),
        "velocity_coupling" => Some(format!("a {j} error that follows the {a} velocity")),
        "direction_coupling" => Some(format!(
            "a {j} error that flips with the {a} direction of travel"
        )),
        _ => None,
    }
}

/// The nonlinear parameter of a candidate, if any: name and the search.
pub enum Search {
    None,
    /// Evaluate the joint fit on each value (few values).
    Grid(&'static str, Vec<f64>),
    /// θ the candidate's own first coefficient, no free parameter ([`is_own_value`]): a
    /// play's take-up travel, its width b ([`TAKE_UP`]); a lag's second order, τ
    /// ([`LAG_SECOND_ORDER`]). By fixed point from θ = 0, kept when it fits better.
    TakeUp(&'static str),
    /// A step's time: the most significant step of the current residual along the
    /// candidate's direction (the local scan's rule, `diagnosis::local_scan`), refined on
    /// the exact joint fit.
    Step,
    /// Periodic: scan a coarse frequency grid on the residual, refine finely around the
    /// best; the value reported is 1/frequency for periods.
    Periodic {
        name: &'static str,
        f_lo: f64,
        f_hi: f64,
        coarse_step: f64,
        fine_step: f64,
        /// The variable is time (true) or the axis position (false).
        in_time: bool,
        /// Report the period (1/f) instead of the frequency.
        as_period: bool,
    },
}

/// The names of a play's take-up travel θ (µm), its own width, and of the lag θ (s) in a
/// servo lag's second-order term ([`Search::TakeUp`]).
pub const TAKE_UP: &str = "take_up_um";
pub const LAG_SECOND_ORDER: &str = "lag_second_order_s";

/// Whether the nonlinear parameter `name` is the candidate's own first coefficient
/// ([`Search::TakeUp`]): not reported, with no σ of its own.
pub fn is_own_value(name: &str) -> bool {
    matches!(name, TAKE_UP | LAG_SECOND_ORDER)
}

/// Axes that moved (have travel) and are read by some plane.
fn observed_axes(d: &Design) -> Vec<Axis> {
    Axis::ALL
        .into_iter()
        .filter(|a| d.travel[a.index()].is_some())
        .collect()
}

/// Legendre orders K of a session's position-dependent lost motion
/// (`lost_motion_profile`) the data choose from: at least a linear and a symmetric (ends
/// against middle) variation along the travel, at most the positioning runs' largest
/// order (a lost motion that changes sign along the travel, a pitch error of the screw,
/// needs more than the lowest orders).
pub const PROFILE_ORDERS: std::ops::RangeInclusive<usize> = 2..=9;

/// The lost-motion profile of order `order` on axis `a`'s measured travel.
pub fn profile(d: &Design, a: Axis, order: usize) -> Option<Profile> {
    let [lo, hi] = d.travel[a.index()]?;
    (hi > lo).then_some(Profile { lo, hi, order })
}

/// All candidates for a session.
pub fn candidates(d: &Design) -> Vec<Candidate> {
    let axes = observed_axes(d);
    let c = |effect, axis, direction, group| Candidate {
        effect,
        axis,
        direction,
        group,
        order: match effect {
            "lost_motion_profile" | "lost_motion_variation" => *PROFILE_ORDERS.end(),
            _ => 0,
        },
        width_s: 0.0,
        lost_motion_um: 0.0,
        mounting: None,
        parent: None,
    };
    let mut out = Vec::new();
    for &a in &axes {
        for e in [
            "backlash",
            lost_motion_growth::NAME,
            "lost_motion_profile",
            "lost_motion_variation",
            "servo_lag",
            "reversal_spike",
            "cyclic",
        ] {
            out.push(c(e, Some(a), None, None));
        }
        for dir in Axis::ALL {
            out.push(c("model_order", Some(a), Some(dir), None));
        }
        // Signatures beyond the named catalogue: an error across the axis periodic in
        // its position, or following its velocity.
        for dir in Axis::ALL.into_iter().filter(|&j| j != a) {
            out.push(c("waviness", Some(a), Some(dir), None));
            out.push(c("velocity_coupling", Some(a), Some(dir), None));
            out.push(c("direction_coupling", Some(a), Some(dir), None));
        }
    }
    // A lasting offset of one direction's readings from a time on (a slip): one-off, in
    // the run where it happens (later runs carry it as a constant their zero offsets
    // take).
    for dir in Axis::ALL
        .into_iter()
        .filter(|j| d.plane_axes.iter().any(|(u, v)| u == j || v == j))
    {
        out.push(c("step", None, Some(dir), None));
        // An offset that appears at once and recovers (a knock): one-off, in its run.
        out.push(c("transient", None, Some(dir), None));
    }
    out.push(c("thermal_drift", None, None, None));
    // Logged temperatures: growth that follows the temperature, whatever its course.
    if d.fields.temp_k.is_some() {
        out.push(c("thermal_temperature", None, None, None));
    }
    for dir in Axis::ALL {
        out.push(c("vibration", None, Some(dir), None));
    }
    let mut groups: Vec<[f64; 3]> = d.runs.iter().map(|r| r.head_mm).collect();
    groups.dedup();
    let mut uniq: Vec<[f64; 3]> = Vec::new();
    for g in groups {
        if !uniq.contains(&g) {
            uniq.push(g);
        }
    }
    // A uniform error of every declared offset is a re-parameterisation of the terms:
    // only a group differing from the others can show it.
    if uniq.len() >= 2 {
        for g in uniq.into_iter().skip(1) {
            out.push(c("setup_offset", None, None, Some(g)));
        }
    }
    out.extend(plate_scale::candidates(d));
    out
}

/// Session duration, the Nyquist frequency of its shortest sample interval (Hz) and the
/// longest run's duration; computed once per design (a pass over the samples).
fn time_band(d: &Design) -> (f64, f64, f64) {
    *d.time_band.get_or_init(|| time_band_of(d))
}

fn time_band_of(d: &Design) -> (f64, f64, f64) {
    let t = &d.fields.t_s;
    let t0 = t.first().copied().unwrap_or(0.0);
    let t1 = t.last().copied().unwrap_or(1.0);
    let mut dt = f64::INFINITY;
    for r in &d.runs {
        for w in t[r.start..r.end].windows(2) {
            dt = dt.min(w[1] - w[0]);
        }
    }
    let nyq = 0.5 / dt;
    let run_len = d
        .runs
        .iter()
        .map(|r| t[r.end - 1] - t[r.start])
        .fold(0.0, f64::max);
    (t1 - t0, nyq, run_len.max(1.0))
}

/// The fewest cycles of a vibration within the session's longest run.
pub const VIBRATION_MIN_CYCLES: f64 = 2.0;

pub fn search(d: &Design, c: &Candidate) -> Search {
    match c.effect {
        "reversal_spike" => {
            Search::Grid("decay_mm", (0..12).map(|i| 0.1 * 1.4f64.powi(i)).collect())
        }
        "thermal_drift" => {
            let (span, _, _) = time_band(d);
            Search::Grid(
                "time_constant_s",
                (0..14).map(|i| span * 0.05 * 1.45f64.powi(i)).collect(),
            )
        }
        "cyclic" | "waviness" => {
            let travel = c
                .axis
                .and_then(|a| d.travel[a.index()])
                .map_or(100.0, |[lo, hi]| hi - lo);
            // A screw's cyclic error has a short period (≤ 30 mm); a guideway's waviness
            // any period from 1.5 cycles over the travel.
            let f_lo = if c.effect == "cyclic" {
                1.0 / 30.0
            } else {
                1.5 / travel
            };
            Search::Periodic {
                name: "period_mm",
                f_lo,
                f_hi: 1.0 / 2.0,
                coarse_step: 0.25 / travel,
                fine_step: 0.02 / travel,
                in_time: false,
                as_period: true,
            }
        }
        "thermal_temperature_lag" => {
            // A structure slower than its sensor: 1 s to a quarter of the session.
            let (span, _, _) = time_band(d);
            let n = ((0.25 * span).max(2.0).ln() / 1.5f64.ln()).ceil() as i32;
            Search::Grid("lag_s", (0..=n).map(|i| 1.5f64.powi(i)).collect())
        }
        "step" | "transient" => Search::Step,
        // A clearance across the axis taken up over its travel: 2 µm to 1 mm.
        "direction_coupling" => Search::Grid(
            "take_up_mm",
            (0..10).map(|i| 0.002 * 2f64.powi(i)).collect(),
        ),
        // A growth's take-up: θ = the fitted growth, the same fixed point.
        "backlash" | "backlash_growth" => Search::TakeUp(TAKE_UP),
        // A lag's second order: θ = the fitted lag.
        "servo_lag" => Search::TakeUp(LAG_SECOND_ORDER),
        "vibration" => {
            let (span, nyq, run_len) = time_band(d);
            // At least two cycles within the longest run: a slower sine is, within each
            // run, a slow change (a warm-up, a play that widens) the run offsets and
            // the effects that change in time read as well (docs/diagnosis.md).
            Search::Periodic {
                name: "frequency_hz",
                f_lo: VIBRATION_MIN_CYCLES / run_len,
                f_hi: 0.98 * nyq,
                coarse_step: 0.25 / run_len,
                fine_step: 0.1 / span,
                in_time: true,
                as_period: false,
            }
        }
        _ => Search::None,
    }
}

/// The reversal spike's column is 0 past this many decay lengths λ from the last
/// reversal: exp(−x/λ) is below 5·10⁻¹⁸ there (beyond double precision next to the
/// transient's height).
const SPIKE_REACH: f64 = 40.0;

/// The travel (mm) a reversal spike has decayed over at the signed travel `travel` since
/// its axis turned ([`super::design::SampleFields::play_travel_mm`]); infinite for an axis
/// that has not moved (no spike).
pub fn spike_travel(travel: f64) -> f64 {
    if travel == 0.0 {
        f64::INFINITY
    } else {
        travel.abs()
    }
}

/// For a candidate whose columns vanish away from its axis's reversals (the reversal
/// spike): the axis and the travel since the last reversal from which its columns are 0
/// at nonlinear value `theta` (they are 0 on the rows read along other axes too).
pub fn reach(c: &Candidate, theta: f64) -> Option<(Axis, f64)> {
    match c.effect {
        "reversal_spike" => Some((c.axis?, SPIKE_REACH * theta)),
        _ => None,
    }
}

/// The columns of a candidate at nonlinear value `theta` (ignored when it has none).
/// `eps` is Σ_k ε_k(q_k) (µrad) per sample, for setup_offset.
pub fn specs<'a>(
    d: &'a Design,
    c: &Candidate,
    theta: f64,
    eps: Option<&'a [[f64; 3]]>,
) -> Columns<'a> {
    match c.effect {
        "backlash"
        | "lost_motion_profile"
        | "lost_motion_variation"
        | "servo_lag"
        | "reversal_spike" => motion_columns(d, c, theta),
        "backlash_growth" => lost_motion_growth::columns(d, c, theta),
        e if growth::named(e).is_some() => growth::columns(d, c),
        "cyclic" | "waviness" | "velocity_coupling" | "direction_coupling" | "step"
        | "vibration" => path_columns(d, c, theta),
        "transient" => transient_columns(d, c, theta),
        "thermal_drift"
        | "thermal_temperature"
        | "thermal_temperature_lag"
        | "thermal_temperature_quadratic" => thermal_columns(d, c, theta),
        "model_order" | "setup_offset" => setup_columns(d, c, eps),
        plate_scale::NAME => plate_scale::columns(d, c),
        _ => Columns::none(),
    }
}

/// One column `name` read along `axis`.
fn one(name: &str, axis: Axis) -> (Vec<String>, Vec<Option<Axis>>) {
    (vec![name.to_string()], vec![Some(axis)])
}

/// The columns of the effects of an axis's drive: play, lost motion, lag, reversal spike.
fn motion_columns<'a>(d: &'a Design, c: &Candidate, theta: f64) -> Columns<'a> {
    match c.effect {
        "backlash" => {
            // A play of width b: −d·b/2 once taken up; over the first θ of travel after
            // a reversal it is taken up, +d·b/2 − d·s (θ = b, µm: [`Search::TakeUp`]).
            let a = c.axis.expect("axis");
            let (n, ax) = one("lost_motion_um", a);
            let i = a.index();
            let (dir, travel) = (&d.fields.dir[i], &d.fields.play_travel_mm[i]);
            let w = theta * 1e-3;
            Columns::new(n, ax, move |s, _, o| {
                o[0] = if w > 0.0 {
                    play(travel[s], w)
                } else {
                    -0.5 * dir[s]
                }
            })
            .following(a)
        }
        "lost_motion_profile" | "lost_motion_variation" => {
            // Lost motion varying along the travel: −d·P_k(s)/2 on the measured travel
            // (`lost_motion::Profile`), k = 0..=K (the candidate's order); k from 1 for
            // its varying part alone (the constant part, k = 0, is then the axis's
            // `backlash`). As the backlash's, taken up over θ > 0 (µm: the mean lost
            // motion by fixed point, or the axis's backlash b̄ for the varying part) along
            // the play's travel from the turn ([`play`]); at θ = 0, −d/2 at once.
            let a = c.axis.expect("axis");
            let Some(prof) = profile(d, a, c.order) else {
                return Columns::none();
            };
            let from = usize::from(c.effect == "lost_motion_variation");
            let i = a.index();
            let (q, dir) = (&d.fields.q_mm[i], &d.fields.dir[i]);
            let (travel, w) = (&d.fields.play_travel_mm[i], theta * 1e-3);
            Columns::new(
                (from..=c.order).map(|k| format!("b{k}")).collect(),
                vec![Some(a); c.order + 1 - from],
                move |s, _, o| {
                    let p = crate::basis::Legendre::new(prof.s(q[s]).clamp(-1.0, 1.0));
                    let side = if w > 0.0 {
                        play(travel[s], w)
                    } else {
                        -0.5 * dir[s]
                    };
                    for (o, (pk, _)) in o.iter_mut().zip(p.skip(from)) {
                        *o = side * pk;
                    }
                },
            )
            .following(a)
        }
        "servo_lag" => {
            // The lag, q(t − τ) − q(t) = −v·τ + a·τ²/2 − …: τ·(−v + a·θ/2) at θ = τ
            // ([`Search::TakeUp`]; on a fast circle a·τ²/2 scales the readings 0.2 µm at
            // 4 ms). And a nuisance at the starts and stops of the motion, where the
            // set-points do not tell the velocity ([`super::design::velocity_at_ends`]),
            // one on lines and one on circles: its coefficient takes what the lag does
            // there (−τ for a smooth path, about the central difference; 0 for an axis
            // that moves at the feed until it stops): the lag is read where the velocity
            // is known.
            let a = c.axis.expect("axis");
            let i = a.index();
            let (vel, ends) = (&d.fields.vel_mm_s[i], &d.fields.vel_ends_mm_s[i]);
            let acc = &d.fields.acc_mm_s2[i];
            Columns::new(
                vec![
                    "lag_s".into(),
                    NUISANCE_LAG_ENDS[0].into(),
                    NUISANCE_LAG_ENDS[1].into(),
                ],
                vec![Some(a); 3],
                move |s, _, o| {
                    o[0] = (0.5 * theta * acc[s] - vel[s]) * 1e3;
                    let circle = is_circle(d, s);
                    o[1] = if circle { 0.0 } else { ends[s] * 1e3 };
                    o[2] = if circle { ends[s] * 1e3 } else { 0.0 };
                },
            )
        }
        "reversal_spike" => {
            // −d·e^(−s/λ), s the travel since the axis turned and d its direction: from
            // the turn itself, as the play's (between two samples of a circle, at the
            // vertex; a sample already past it travels the new way), not from the last
            // sample before it.
            let a = c.axis.expect("axis");
            let (n, ax) = one("height_um", a);
            let travel = &d.fields.play_travel_mm[a.index()];
            Columns::new(n, ax, move |s, _, o| {
                let x = spike_travel(travel[s]);
                o[0] = if x < SPIKE_REACH * theta {
                    -travel[s].signum() * (-x / theta).exp()
                } else {
                    0.0
                };
            })
            .following(a)
        }
        _ => Columns::none(),
    }
}

/// The columns of effects along the path or in time: periodic errors, couplings, a step,
/// a vibration.
fn path_columns<'a>(d: &'a Design, c: &Candidate, theta: f64) -> Columns<'a> {
    match c.effect {
        "cyclic" | "waviness" => {
            // Along the axis itself (cyclic) or across it (waviness). The sines and
            // cosines by a [`PhaseWalk`] along each run (a `sincos` call at every 32nd
            // sample and after a step of more than a quarter radian, rotations between).
            let a = c.axis.expect("axis");
            let dir = c.direction.unwrap_or(a);
            let i = a.index();
            let walk = PhaseWalk::new(2.0 * PI * theta);
            let q = &d.fields.q_mm[i];
            Columns::new(
                vec!["sin".into(), "cos".into()],
                vec![Some(dir); 2],
                move |s, _, o| sin_cos_into(o, walk.at(s, q[s])),
            )
            .following(a)
        }
        "velocity_coupling" => {
            let (a, dir) = (c.axis.expect("axis"), c.direction.expect("direction"));
            let (n, ax) = one("coefficient_um_per_mm_s", dir);
            let vel = &d.fields.vel_mm_s[a.index()];
            Columns::new(n, ax, move |s, _, o| o[0] = vel[s])
        }
        "direction_coupling" => {
            // Across a, +s/2 while a last travelled toward + and −s/2 toward −, the
            // clearance taken up over the first θ mm of a's travel after its reversal.
            let (a, dir) = (c.axis.expect("axis"), c.direction.expect("direction"));
            let (n, ax) = one("shift_um", dir);
            let travel = &d.fields.play_travel_mm[a.index()];
            Columns::new(n, ax, move |s, _, o| o[0] = -play(travel[s], theta)).following(a)
        }
        "step" => {
            // +1 from time θ on along the direction: the reading's offset after − before;
            // with a width w, a ramp from 0 to 1 over [θ − w/2, θ + w/2].
            let dir = c.direction.expect("direction");
            let (n, ax) = one("size_um", dir);
            let (t, w) = (&d.fields.t_s, c.width_s);
            Columns::new(n, ax, move |s, _, o| {
                o[0] = if w > 0.0 {
                    ((t[s] - theta) / w + 0.5).clamp(0.0, 1.0)
                } else {
                    f64::from(u8::from(t[s] >= theta))
                }
            })
            .on_run(d.run_at_time(theta))
        }
        "vibration" => {
            let dir = c.direction.expect("direction");
            // Directly at every sample, not by a [`PhaseWalk`]: a phase in time reaches
            // 10⁴–10⁶ rad, where the direct argument's own rounding, and so the walk's
            // difference from it, is up to 10⁻¹⁰ rad; with a walk, the frequency's 24
            // golden-section steps (to 10⁻⁵ of a fine step) ended elsewhere in a test
            // session (10⁻⁵ σ of the frequency, 10⁻⁶ rad of the reported phase).
            let w = 2.0 * PI * theta;
            Columns::new(
                vec!["sin".into(), "cos".into()],
                vec![Some(dir); 2],
                move |s, _, o| sin_cos_into(o, (w * d.fields.t_s[s]).sin_cos()),
            )
        }
        _ => Columns::none(),
    }
}

/// The column of a transient at onset `t0` (session time, s; `super::transient`): along
/// the candidate's direction, e^(−(t − t₀)/τ) from t₀ on (τ the candidate's `width_s`),
/// 0 before and on every other run (exactly 0, not its tail: a held-out fold without the
/// run would otherwise fit its amplitude to the tail's 10⁻⁴ on the next run); local to
/// the run holding t₀.
fn transient_columns<'a>(d: &'a Design, c: &Candidate, t0: f64) -> Columns<'a> {
    let dir = c.direction.expect("direction");
    let tau = c.width_s.max(1e-6);
    let t = &d.fields.t_s;
    let g = d.run_at_time(t0);
    let rows = g.map_or(0..0, |g| d.runs[g].start..d.runs[g].end);
    Columns::new(
        vec!["amplitude_um".into()],
        vec![Some(dir)],
        move |s, _, o| {
            o[0] = if rows.contains(&s) && t[s] >= t0 {
                (-(t[s] - t0) / tau).exp()
            } else {
                0.0
            }
        },
    )
    .on_run(g)
}

/// The columns of thermal growth: in time, with the temperature, or through a lag of it.
fn thermal_columns<'a>(d: &'a Design, c: &Candidate, theta: f64) -> Columns<'a> {
    match c.effect {
        "thermal_drift" | "thermal_temperature" | "thermal_temperature_lag" => {
            // Scale (per axis) then offset (per axis), times g = 1 − e^(−t/T), ΔT, or ΔT
            // through a first-order lag of time constant θ.
            let temp = c.effect != "thermal_drift";
            let (scale, offset) = if temp {
                ("scale_ppm_per_k", "offset_um_per_k")
            } else {
                ("scale_ppm", "offset_um")
            };
            let names = Axis::ALL
                .map(|j| format!("{scale}_{j}"))
                .into_iter()
                .chain(Axis::ALL.map(|j| format!("{offset}_{j}")))
                .collect();
            let axes = Axis::ALL.into_iter().chain(Axis::ALL).map(Some).collect();
            let lagged = (c.effect == "thermal_temperature_lag")
                .then(|| d.lagged_temperature(theta))
                .flatten();
            let temp_k: Option<std::borrow::Cow<[f64]>> = match lagged {
                Some(l) => Some(l.into()),
                None => d.fields.temp_k.as_deref().map(Into::into),
            };
            // A pass visits a sample's two readings one after the other: the time
            // form's exponential is taken once a sample (the same value for both).
            let last = std::cell::Cell::new((usize::MAX, 0.0));
            Columns::new(names, axes, move |s, read, o| {
                let g = if temp {
                    temp_k.as_ref().map_or(0.0, |t| t[s])
                } else if last.get().0 == s {
                    last.get().1
                } else {
                    let g = 1.0 - (-d.fields.t_s[s] / theta).exp();
                    last.set((s, g));
                    g
                };
                let i = read.index();
                o[i] = g * d.fields.q_mm[i][s] * 1e-3;
                o[3 + i] = g;
            })
        }
        "thermal_temperature_quadratic" => {
            // The per-kelvin columns, then the same times ΔT again (a growth quadratic in
            // the temperature: the per-kelvin coefficients are its slope at ΔT = 0).
            let names = [
                "scale_ppm_per_k",
                "offset_um_per_k",
                "scale_ppm_per_k2",
                "offset_um_per_k2",
            ]
            .into_iter()
            .flat_map(|n| Axis::ALL.map(|j| format!("{n}_{j}")))
            .collect();
            let axes = (0..4).flat_map(|_| Axis::ALL.map(Some)).collect();
            let temp_k = d.fields.temp_k.as_deref();
            Columns::new(names, axes, move |s, read, o| {
                let g = temp_k.map_or(0.0, |t| t[s]);
                let i = read.index();
                let q = d.fields.q_mm[i][s] * 1e-3;
                (o[i], o[3 + i], o[6 + i], o[9 + i]) = (g * q, g, g * g * q, g * g);
            })
        }
        _ => Columns::none(),
    }
}

/// The columns of the model's order along an axis and of a setup's head offset.
fn setup_columns<'a>(d: &'a Design, c: &Candidate, eps: Option<&'a [[f64; 3]]>) -> Columns<'a> {
    match c.effect {
        "model_order" => {
            let a = c.axis.expect("axis");
            let dir = c.direction.expect("direction");
            let Some([lo, hi]) = d.travel[a.index()] else {
                return Columns::none();
            };
            let (cen, h) = (0.5 * (lo + hi), (0.5 * (hi - lo)).max(1.0));
            let q = &d.fields.q_mm[a.index()];
            Columns::new(
                (4..=10).map(|k| format!("P{k}")).collect(),
                vec![Some(dir); 7],
                move |s, _, o| {
                    // Bonnet's recurrence: (k+1) P_{k+1} = (2k+1) x P_k − k P_{k−1}.
                    let x = (q[s] - cen) / h;
                    let (mut p0, mut p1) = (1.0, x);
                    for k in 1..10 {
                        let p2 = ((2 * k + 1) as f64 * x * p1 - k as f64 * p0) / (k + 1) as f64;
                        p0 = p1;
                        p1 = p2;
                        if k + 1 >= 4 {
                            o[k + 1 - 4] = p1;
                        }
                    }
                },
            )
            .following(a)
        }
        "setup_offset" => {
            let (Some(g), Some(eps)) = (c.group, eps) else {
                return Columns::none();
            };
            // Per run: whether it is of the group.
            let on: Vec<bool> = d.runs.iter().map(|r| r.head_mm == g).collect();
            let in_group = on.clone();
            Columns::new(
                Axis::ALL.map(|j| format!("delta_mm_{j}")).to_vec(),
                vec![None; 3],
                move |si, read, o| {
                    // (ε × e_j)[read axis] · 10⁻³ on the group's samples.
                    let e = nalgebra::Vector3::from(eps[si]);
                    for (j, slot) in o.iter_mut().enumerate() {
                        *slot = if in_group[d.fields.run(si)] {
                            let mut ej = nalgebra::Vector3::zeros();
                            ej[j] = 1.0;
                            e.cross(&ej)[read.index()] * 1e-3
                        } else {
                            0.0
                        };
                    }
                },
            )
            .only_on(on)
        }
        _ => Columns::none(),
    }
}

/// The servo lag's nuisance columns at the starts and stops of the motion on lines and
/// on circles: their coefficients are fitted, not reported (names starting `nuisance_`).
pub const NUISANCE_LAG_ENDS: [&str; 2] =
    ["nuisance_lag_at_line_ends", "nuisance_lag_at_circle_ends"];

/// Writes a periodic candidate's sine and cosine into the first two of `o`.
#[inline(always)]
fn sin_cos_into(o: &mut [f64], (sin, cos): (f64, f64)) {
    let pair: &mut [f64; 2] = (&mut o[..2]).try_into().expect("two columns");
    *pair = [sin, cos];
}

/// Whether sample `s` is of a circle test.
fn is_circle(d: &Design, s: usize) -> bool {
    d.runs[d.fields.run(s)].test.is_circle()
}

/// Whether a column's coefficient is a nuisance: fitted with the effect, not reported.
pub fn is_nuisance(name: &str) -> bool {
    name.starts_with("nuisance_")
}

/// Travel since the axis's last reversal (mm) within which a sample is "near" the
/// reversal for [`split`].
pub const SPLIT_NEAR_MM: f64 = 2.0;

/// The most columns (one and its nuisance) of a candidate [`split`] takes.
pub const SPLIT_MAX_COLUMNS: usize = 4;

/// The four places [`split`] cuts a candidate's support into, in its column order.
pub const SPLIT_PLACES: [&str; 4] = [
    "lines, beyond 2 mm of the reversals",
    "lines, within 2 mm of the reversals",
    "circles, beyond 2 mm of the reversals",
    "circles, within 2 mm of the reversals",
];

/// A one-column candidate of axis `a` (its columns at `theta`) split by place: its column
/// times the indicator of each of [`SPLIT_PLACES`] (the run's test, a line or a circle,
/// and the travel of the candidate's axis since its last reversal, below or from
/// [`SPLIT_NEAR_MM`]): the same model with a coefficient per place. Where the model's
/// form holds the places share one coefficient; a second-order term of a delay (its
/// acceleration, largest at the reversals), a shift that settles after each reversal,
/// a velocity the set-points do not tell at a start or a stop, make them differ.
/// The candidate's nuisance columns ([`is_nuisance`]) follow unsplit. `None` for a
/// candidate without an axis, with more than one column besides its nuisance, or with
/// more than [`SPLIT_MAX_COLUMNS`] in all.
pub fn split<'a>(
    d: &'a Design,
    c: &Candidate,
    theta: f64,
    eps: Option<&'a [[f64; 3]]>,
) -> Option<Columns<'a>> {
    let a = c.axis?;
    let inner = specs(d, c, theta, eps);
    let m = inner.len();
    if m == 0 || m > SPLIT_MAX_COLUMNS || inner.names[1..].iter().any(|n| !is_nuisance(n)) {
        return None;
    }
    let since = &d.fields.since_reversal_mm[a.index()];
    let k = SPLIT_PLACES.len();
    let mut names: Vec<String> = SPLIT_PLACES
        .iter()
        .map(|p| format!("{} ({p})", inner.names[0]))
        .collect();
    names.extend(inner.names[1..].iter().cloned());
    let mut axes = vec![inner.axes[0]; k];
    axes.extend(inner.axes[1..].iter().copied());
    let follows = inner.follows;
    let fill = inner.fill;
    let mut cols = Columns::new(names, axes, move |s, read, o| {
        let mut v = [0.0; SPLIT_MAX_COLUMNS];
        fill(s, read, &mut v[..m]);
        let place = 2 * usize::from(is_circle(d, s)) + usize::from(since[s] < SPLIT_NEAR_MM);
        o[..k].iter_mut().for_each(|x| *x = 0.0);
        o[place] = v[0];
        o[k..].copy_from_slice(&v[1..m]);
    });
    cols.follows = follows;
    Some(cols)
}

/// The shape of a play's error per unit width along the last travel's sign d, at travel
/// `s` since the reversal when it is taken up over `w` (mm, 0: at once): −1/2 once taken
/// up, from +1/2 at the reversal linearly to it over w.
pub fn take_up(s: f64, w: f64) -> f64 {
    if w > 0.0 && s < w { 0.5 - s / w } else { -0.5 }
}

/// A play's error per unit width at the signed travel `travel` since the axis turned
/// ([`super::design::SampleFields::play_travel_mm`]), taken up over `w` mm: d·[`take_up`];
/// 0 for an axis that has not moved.
pub fn play(travel: f64, w: f64) -> f64 {
    if travel == 0.0 {
        0.0
    } else {
        travel.signum() * take_up(travel.abs(), w)
    }
}

/// Columns of a candidate at nonlinear value `theta` as full-length vectors, centred per
/// (run, direction) ([`specs`]), with the names (and units) of their coefficients and
/// each column's largest |value| before centring; columns the run offsets absorb whole
/// are left out.
pub fn columns(
    d: &Design,
    c: &Candidate,
    theta: f64,
    eps: Option<&[[f64; 3]]>,
) -> (Cols, Vec<String>, Vec<f64>) {
    let spec = specs(d, c, theta, eps);
    let m = spec.len();
    let mut all = vec![vec![0.0; d.rows()]; m];
    let mut buf = vec![0.0; m];
    for r in 0..d.rows() {
        spec.at(d, r, &mut buf);
        for (col, v) in all.iter_mut().zip(&buf) {
            col[r] = *v;
        }
    }
    let mut cols = Vec::new();
    let mut names = Vec::new();
    let mut peaks = Vec::new();
    for (mut col, name) in all.into_iter().zip(spec.names) {
        let peak = d.centre_with_peak(&mut col);
        if col.iter().any(|v| v.abs() > 1e-12) {
            cols.push(col);
            names.push(name);
            peaks.push(peak);
        }
    }
    (cols, names, peaks)
}

/// The effect name a candidate is reported under (the temperature-driven thermal model
/// is a form of `thermal_drift`).
pub fn reported_name(effect: &'static str) -> &'static str {
    match effect {
        "thermal_temperature" | "thermal_temperature_lag" | "thermal_temperature_quadratic" => {
            "thermal_drift"
        }
        "lost_motion_variation" => "lost_motion_profile",
        e => e,
    }
}
