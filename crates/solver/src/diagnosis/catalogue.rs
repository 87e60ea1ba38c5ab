//! Catalogue of candidate effects for sessions: each is a parametric extension of the
//! rigid model — extra columns of the design (linear parameters, physical units) that
//! depend on at most one nonlinear parameter, searched in 1-D.
//!
//! | effect | columns (along the named axis) | nonlinear |
//! |---|---|---|
//! | backlash | −d/2 (d: sign of the axis's last travel) → lost motion b, µm | — |
//! | servo_lag | −v·10³ → lag τ, s | — |
//! | reversal_spike | −d·exp(−s/λ) → height h, µm | decay λ, mm |
//! | cyclic | sin, cos(2π q/P) → amplitude, phase | period P, mm |
//! | thermal_drift | g(t)·q_j·10⁻³ and g(t) per direction j, g = 1 − e^(−t/T) → scale ppm, offset µm | T, s |
//! | thermal_drift (temperature) | ΔT·q_j·10⁻³ and ΔT per direction j, ΔT the logged temperature's change → ppm/K, µm/K | — |
//! | setup_offset | (Σ_k ε_k(q_k)) × e_j ·10⁻³ on one head-offset group → Δt_j, mm | — |
//! | model_order | Legendre P_4..P_10 of the axis position, along one direction | — |
//! | vibration | sin, cos(2π f t) → amplitude, phase | frequency f, Hz |
//! | waviness (signature) | sin, cos(2π q_a/P) along a direction j ≠ a → amplitude, phase | period P, mm |
//! | velocity_coupling (signature) | v_a along a direction j ≠ a → coefficient, µm per mm/s | — |

use super::design::{Design, SampleMeta};
use super::linalg::Cols;
use crate::axis::Axis;
use crate::basis::legendre;
use std::f64::consts::PI;

/// One candidate: an effect on an axis/direction (or a head-offset group).
#[derive(Debug, Clone, PartialEq)]
pub struct Candidate {
    pub effect: &'static str,
    pub axis: Option<Axis>,
    /// For model_order: the direction of the error; for setup_offset: unused.
    pub direction: Option<Axis>,
    /// For setup_offset: the declared head offset of the group.
    pub group: Option<[f64; 3]>,
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
        _ => None,
    }
}

/// The nonlinear parameter of a candidate, if any: name and the search.
pub enum Search {
    None,
    /// Evaluate the joint fit on each value (few values).
    Grid(&'static str, Vec<f64>),
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

/// Axes that moved (have travel) and are read by some plane.
fn observed_axes(d: &Design) -> Vec<Axis> {
    Axis::ALL
        .into_iter()
        .filter(|a| d.travel[a.index()].is_some())
        .collect()
}

/// All candidates for a session.
pub fn candidates(d: &Design) -> Vec<Candidate> {
    let axes = observed_axes(d);
    let c = |effect, axis, direction, group| Candidate {
        effect,
        axis,
        direction,
        group,
    };
    let mut out = Vec::new();
    for &a in &axes {
        for e in ["backlash", "servo_lag", "reversal_spike", "cyclic"] {
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
        }
    }
    out.push(c("thermal_drift", None, None, None));
    // Logged temperatures: growth that follows the temperature, whatever its course.
    if d.samples.iter().all(|s| s.temp_k.is_some()) {
        out.push(c("thermal_temperature", None, None, None));
    }
    for dir in Axis::ALL {
        out.push(c("vibration", None, Some(dir), None));
    }
    let mut groups: Vec<[f64; 3]> = d.samples.iter().map(|s| s.head_mm).collect();
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
    out
}

/// Session duration and the rate-limited frequency band (Hz).
fn time_band(d: &Design) -> (f64, f64, f64) {
    let t0 = d.samples.first().map_or(0.0, |s| s.t_s);
    let t1 = d.samples.last().map_or(1.0, |s| s.t_s);
    let mut dt = f64::INFINITY;
    for w in d.samples.windows(2) {
        if w[0].run_idx == w[1].run_idx {
            dt = dt.min(w[1].t_s - w[0].t_s);
        }
    }
    let nyq = 0.5 / dt;
    let run_len = d
        .runs
        .iter()
        .map(|r| d.samples[r.end - 1].t_s - d.samples[r.start].t_s)
        .fold(0.0, f64::max);
    (t1 - t0, nyq, run_len.max(1.0))
}

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
        "vibration" => {
            let (span, nyq, run_len) = time_band(d);
            Search::Periodic {
                name: "frequency_hz",
                f_lo: 0.5 / run_len,
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

/// Columns of a candidate at nonlinear value `theta` (ignored when it has none), with the
/// names (and units) of their coefficients and each column's largest |value| before
/// centring. `eps` is Σ_k ε_k(q_k) (µrad) per sample, for setup_offset.
pub fn columns(
    d: &Design,
    c: &Candidate,
    theta: f64,
    eps: Option<&[[f64; 3]]>,
) -> (Cols, Vec<String>, Vec<f64>) {
    let mut cols = Vec::new();
    let mut names = Vec::new();
    let mut peaks = Vec::new();
    let mut push = |axis: Axis, name: String, f: &dyn Fn(&SampleMeta) -> f64| {
        let (col, peak) = d.effect_column_peak(axis, f);
        if col.iter().any(|v| v.abs() > 1e-12) {
            cols.push(col);
            names.push(name);
            peaks.push(peak);
        }
    };
    match c.effect {
        "backlash" => {
            let a = c.axis.expect("axis");
            push(a, "lost_motion_um".into(), &|s| -0.5 * s.dir[a.index()]);
        }
        "servo_lag" => {
            let a = c.axis.expect("axis");
            push(a, "lag_s".into(), &|s| -s.vel_mm_s[a.index()] * 1e3);
        }
        "reversal_spike" => {
            let a = c.axis.expect("axis");
            let i = a.index();
            push(a, "height_um".into(), &|s| {
                let x = s.since_reversal_mm[i];
                if x.is_finite() {
                    -s.dir[i] * (-x / theta).exp()
                } else {
                    0.0
                }
            });
        }
        "cyclic" | "waviness" => {
            // Along the axis itself (cyclic) or across it (waviness).
            let a = c.axis.expect("axis");
            let dir = c.direction.unwrap_or(a);
            let i = a.index();
            let w = 2.0 * PI * theta;
            push(dir, "sin".into(), &|s| (w * s.q_mm[i]).sin());
            push(dir, "cos".into(), &|s| (w * s.q_mm[i]).cos());
        }
        "velocity_coupling" => {
            let (a, dir) = (c.axis.expect("axis"), c.direction.expect("direction"));
            push(dir, "coefficient_um_per_mm_s".into(), &|s| {
                s.vel_mm_s[a.index()]
            });
        }
        "vibration" => {
            let dir = c.direction.expect("direction");
            let w = 2.0 * PI * theta;
            push(dir, "sin".into(), &|s| (w * s.t_s).sin());
            push(dir, "cos".into(), &|s| (w * s.t_s).cos());
        }
        "thermal_drift" => {
            for j in Axis::ALL {
                let i = j.index();
                push(j, format!("scale_ppm_{j}"), &|s| {
                    (1.0 - (-s.t_s / theta).exp()) * s.q_mm[i] * 1e-3
                });
            }
            for j in Axis::ALL {
                push(j, format!("offset_um_{j}"), &|s| {
                    1.0 - (-s.t_s / theta).exp()
                });
            }
        }
        "thermal_temperature" => {
            for j in Axis::ALL {
                let i = j.index();
                push(j, format!("scale_ppm_per_k_{j}"), &|s| {
                    s.temp_k.unwrap_or(0.0) * s.q_mm[i] * 1e-3
                });
            }
            for j in Axis::ALL {
                push(j, format!("offset_um_per_k_{j}"), &|s| {
                    s.temp_k.unwrap_or(0.0)
                });
            }
        }
        "model_order" => {
            let a = c.axis.expect("axis");
            let dir = c.direction.expect("direction");
            let Some([lo, hi]) = d.travel[a.index()] else {
                return (cols, names, peaks);
            };
            let (cen, h) = (0.5 * (lo + hi), (0.5 * (hi - lo)).max(1.0));
            for k in 4..=10 {
                push(dir, format!("P{k}"), &|s| {
                    legendre(k, (s.q_mm[a.index()] - cen) / h).0
                });
            }
        }
        "setup_offset" => {
            let (Some(g), Some(eps)) = (c.group, eps) else {
                return (cols, names, peaks);
            };
            for j in Axis::ALL {
                // (ε × e_j)[read axis] · 10⁻³ on the group's samples.
                let mut col = vec![0.0; d.rows()];
                for (r, slot) in col.iter_mut().enumerate() {
                    let s = &d.samples[r / 2];
                    if s.head_mm != g {
                        continue;
                    }
                    let e = nalgebra::Vector3::from(eps[r / 2]);
                    let mut ej = nalgebra::Vector3::zeros();
                    ej[j.index()] = 1.0;
                    *slot = e.cross(&ej)[d.row_axis(r).index()] * 1e-3;
                }
                let peak = d.centre_with_peak(&mut col);
                if col.iter().any(|v| v.abs() > 1e-12) {
                    cols.push(col);
                    names.push(format!("delta_mm_{j}"));
                    peaks.push(peak);
                }
            }
        }
        _ => {}
    }
    (cols, names, peaks)
}

/// The effect name a candidate is reported under (the temperature-driven thermal model
/// is a form of `thermal_drift`).
pub fn reported_name(effect: &'static str) -> &'static str {
    match effect {
        "thermal_temperature" => "thermal_drift",
        e => e,
    }
}

/// The physics sentence of an effect (the shared table of [`super::effects`]).
pub fn physics(effect: &str) -> &'static str {
    super::effects::spec(effect).map_or("unmodelled effect", |e| e.physics)
}
