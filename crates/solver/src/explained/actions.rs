//! One action per finding of the explained model, in words a technician acts on: what to
//! do, the number to set and where it comes from, and the residual predicted once it is
//! done ([`super::predict`]).
//!
//! | effect | action | number |
//! |---|---|---|
//! | `backlash` | set the axis's backlash compensation | the lost motion (reversal value), µm |
//! | `lost_motion_profile` | set forward and reverse compensation per position | the lost motion at each target, µm |
//! | `servo_lag` | check velocity feed-forward and Kv | the lag, ms |
//! | `reversal_spike` | check the reversal-peak (friction) compensation | the spike's height, µm |
//! | `cyclic` | ball screw or encoder | the period, mm, and amplitude, µm |
//! | `thermal_drift` | warm up before checks, or thermal compensation with the coefficients | the per-kelvin (or span) coefficients |
//! | `vibration` | find and isolate the source | the frequency, Hz |
//! | `step` | check the plate's and the head's fixing, repeat the check | the step, µm |
//! | `waviness`, couplings | check the guideways (gibs, preload) | the amplitude or coefficient |
//! | `model_order` | identify with a higher polynomial order | — |

use super::doc::{Action, ExplainedModel, Physics, SetValue};

/// The actions of an explained model, one per finding, in the findings' order.
pub fn actions(m: &ExplainedModel) -> Vec<Action> {
    m.physics.iter().map(action).collect()
}

fn signed(v: f64) -> String {
    format!("{v:+.2}")
}

fn axis(p: &Physics) -> String {
    p.axis.clone().unwrap_or_else(|| "the machine".into())
}

/// The reversal compensation of a backlash or a lost-motion profile: the text and the
/// value to set.
fn reversal(p: &Physics, ax: &str) -> (String, Option<SetValue>) {
    match p.effect.as_str() {
        "backlash" => {
            let (b, s) = p.get("lost_motion_um").unwrap_or((f64::NAN, None));
            (
                format!(
                    "set {ax}'s backlash compensation to {} µm (reversal value; today's controller value unknown: add it)",
                    signed(b)
                ),
                Some(SetValue {
                    what: format!("{ax} backlash compensation"),
                    value: b,
                    std: s,
                    unit: "um".into(),
                    source: "the lost motion at reversal fitted with the 21 terms (ISO 230-2 reversal value); add it to the value the controller holds today".into(),
                }),
            )
        }
        _ => {
            let points: Vec<String> = (1..=9)
                .filter_map(|n| {
                    let (b, _) = p.get(&format!("lost_motion_um_{n}"))?;
                    let (q, _) = p.get(&format!("target_mm_{n}"))?;
                    Some(format!("{} µm at {q:.1} mm", signed(b)))
                })
                .collect();
            let (mean, s) = p.get("mean_lost_motion_um").unwrap_or((f64::NAN, None));
            (
                format!(
                    "set {ax}'s reversal compensation per position (forward and reverse tables): lost motion {} (reversal values; today's controller values unknown: add them)",
                    points.join(", ")
                ),
                Some(SetValue {
                    what: format!("{ax} mean backlash compensation"),
                    value: mean,
                    std: s,
                    unit: "um".into(),
                    source: "the mean of the lost-motion profile fitted with the 21 terms; per position in the reversal table".into(),
                }),
            )
        }
    }
}

/// The action for an effect found changing during the session: its rate, and why one
/// compensation value does not hold it.
fn change(p: &Physics) -> String {
    let rate = p
        .parameters
        .iter()
        .find(|(k, _)| k.contains("_growth_") || k.starts_with("growth_"))
        .map(|(k, v)| format!("{k} = {}", signed(*v)))
        .unwrap_or_default();
    format!(
        "{} changes during the session ({rate}): a compensation holds one value only; find what warms or wears, and repeat the check warm",
        p.name_in_words()
    )
}

/// The action for one finding.
pub fn action(p: &Physics) -> Action {
    let ax = axis(p);
    let (text, set) = match p.effect.as_str() {
        "backlash" | "lost_motion_profile" => reversal(p, &ax),
        "servo_lag_growth"
        | "cyclic_growth"
        | "reversal_spike_growth"
        | "direction_coupling_growth" => (change(p), None),
        "servo_lag" => {
            let (lag, _) = p.get("lag_s").unwrap_or((f64::NAN, None));
            (
                format!(
                    "servo lag {ax} {:.1} ms: check velocity feed-forward and Kv",
                    lag * 1e3
                ),
                None,
            )
        }
        "reversal_spike" => {
            let (h, _) = p.get("height_um").unwrap_or((f64::NAN, None));
            let (l, _) = p.get("decay_mm").unwrap_or((f64::NAN, None));
            (
                format!(
                    "reversal spike {ax} {h:.2} µm over {l:.2} mm: check the reversal-peak (friction) compensation"
                ),
                None,
            )
        }
        "cyclic" => {
            let (per, _) = p.get("period_mm").unwrap_or((f64::NAN, None));
            let (amp, _) = p.get("amplitude_um").unwrap_or((f64::NAN, None));
            (
                format!("cyclic error {per:.3} mm on {ax} ({amp:.2} µm): ball screw or encoder"),
                None,
            )
        }
        "thermal_drift" => {
            let coefs: Vec<String> = p
                .parameters
                .iter()
                .filter(|(k, _)| !k.starts_with("std_"))
                .map(|(k, v)| format!("{k} = {v:.3}"))
                .collect();
            (
                format!(
                    "thermal drift: warm-up before checks, or thermal compensation with these coefficients ({})",
                    coefs.join(", ")
                ),
                None,
            )
        }
        "vibration" => {
            let (f, _) = p.get("frequency_hz").unwrap_or((f64::NAN, None));
            let (amp, _) = p.get("amplitude_um").unwrap_or((f64::NAN, None));
            (
                format!(
                    "vibration along {ax} at {f:.2} Hz ({amp:.2} µm): find the source (spindle, pumps, floor) and isolate it"
                ),
                None,
            )
        }
        "backlash_growth" => {
            let (g, _) = p.get("growth_um_per_h").unwrap_or((f64::NAN, None));
            let (b1, _) = p.get("lost_motion_end_um").unwrap_or((f64::NAN, None));
            (
                format!(
                    "{ax}'s lost motion changes by {} µm/h during the session ({} µm at its end): a backlash compensation holds one value only; check the screw's and nut's preload and lubrication, and repeat the check warm",
                    signed(g),
                    signed(b1)
                ),
                None,
            )
        }
        "step" => {
            let (s, _) = p.get("size_um").unwrap_or((f64::NAN, None));
            let (t, _) = p.get("time_s").unwrap_or((f64::NAN, None));
            (
                format!(
                    "step of {} µm along {ax} at t = {t:.1} s: check how the plate and the head are fixed, and repeat the check",
                    signed(s)
                ),
                None,
            )
        }
        "transient" => {
            let (a, _) = p.get("amplitude_um").unwrap_or((f64::NAN, None));
            let (tau, _) = p.get("decay_s").unwrap_or((f64::NAN, None));
            let (t, _) = p.get("time_s").unwrap_or((f64::NAN, None));
            (
                format!(
                    "transient of {} µm along {ax} at t = {t:.1} s that recovered over {tau:.2} s (a knock, a collision, a chip under the plate): check the plate's seat and the machine, and repeat the run",
                    signed(a)
                ),
                None,
            )
        }
        "waviness" | "velocity_coupling" | "direction_coupling" => (
            format!(
                "{}: check the guideways (gibs, preload, wear)",
                p.name_in_words()
            ),
            None,
        ),
        "model_order" => (
            format!(
                "{}: identify with a higher polynomial order of the error functions",
                p.name_in_words()
            ),
            None,
        ),
        _ => (format!("{}: review the finding", p.name_in_words()), None),
    };
    Action {
        finding: p.name_in_words(),
        text,
        set,
        predicted_rms_um: p.predicted_rms_um,
    }
}
