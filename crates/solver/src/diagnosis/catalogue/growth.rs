//! Effects that change during the session: the constancy test of a finding's principal
//! parameter. Once a servo lag, a cyclic error, a reversal spike or a direction coupling
//! is in the model, its growth is one candidate more: the finding's own column (its
//! shape per unit of the principal parameter, at the finding's nonlinear value and, for
//! a cyclic error, its phase) times (t − t̄)/3600, t the session time (s):
//!
//! v(t) = v̄ + g·k·(t − t̄)/3600,
//!
//! v̄ the finding's value (it reads v(t̄)), g the growth in the table's unit per hour ([`GROWTHS`], k its
//! scale to the finding's unit). t̄ ([`origin`]) is the time at which the constant
//! column's coefficient does not move when the growth joins it (the growth column
//! centred per run is orthogonal to the constant one), as for a lost motion's growth
//! (`lost_motion_growth`, which reads its t̄ here too).
//!
//! The column is 0 on the runs where the finding's axis stays parked when its column
//! follows that axis alone (a cyclic error or a clearance that grows while the axis
//! stands still does not move the carriage; a constant shape times t would otherwise
//! fit a drift there). A constant effect leaves the column nothing to fit; like every
//! candidate it is accepted only on the engine's evidence, ΔBIC ≤ −10 and a held-out
//! gain on whole runs left out of the fit, so a change must predict the runs of another
//! time of the session.

use super::{Candidate, Columns, specs};
use crate::diagnosis::design::Design;
use std::cell::{OnceCell, RefCell};
use std::collections::BTreeMap;

/// One effect whose principal parameter is tested for a change in time.
#[derive(Debug)]
pub struct Growth {
    /// The growth's effect name.
    pub name: &'static str,
    /// The finding it refines.
    pub parent: &'static str,
    /// The growth's coefficient (the finding's unit, or its `scale`-th part, per hour).
    pub param: &'static str,
    /// The finding's principal parameter, v̄.
    pub value: &'static str,
    /// Names of v at the session's start and end: `{stem}_start_{unit}`, `{stem}_end_{unit}`.
    pub stem: &'static str,
    pub unit: &'static str,
    /// The finding's unit per unit of the growth's, per hour (a lag in s, its growth in
    /// ms/h: 10⁻³).
    pub scale: f64,
    /// The finding's nonlinear parameter as reported (its column takes it: a period's
    /// inverse), if any; the growth reports it too, to be read back.
    pub theta: Option<&'static str>,
}

const fn growth(
    name: &'static str,
    parent: &'static str,
    param: &'static str,
    value: &'static str,
    stem: &'static str,
    scale: f64,
    theta: Option<&'static str>,
) -> Growth {
    let unit = if scale == 1.0 { "um" } else { "s" };
    Growth {
        name,
        parent,
        param,
        value,
        stem,
        unit,
        scale,
        theta,
    }
}

/// The effects tested for a change, each with its growth.
pub const GROWTHS: [Growth; 4] = [
    growth(
        "servo_lag_growth",
        "servo_lag",
        "lag_growth_ms_per_h",
        "lag_s",
        "lag",
        1e-3,
        None,
    ),
    growth(
        "cyclic_growth",
        "cyclic",
        "amplitude_growth_um_per_h",
        "amplitude_um",
        "amplitude",
        1.0,
        Some("period_mm"),
    ),
    growth(
        "reversal_spike_growth",
        "reversal_spike",
        "height_growth_um_per_h",
        "height_um",
        "height",
        1.0,
        Some("decay_mm"),
    ),
    growth(
        "direction_coupling_growth",
        "direction_coupling",
        "shift_growth_um_per_h",
        "shift_um",
        "shift",
        1.0,
        Some("take_up_mm"),
    ),
];

/// The growth of effect `parent`, if it is tested for one.
pub fn of_parent(parent: &str) -> Option<&'static Growth> {
    GROWTHS.iter().find(|g| g.parent == parent)
}

/// The growth named `name`.
pub fn named(name: &str) -> Option<&'static Growth> {
    GROWTHS.iter().find(|g| g.name == name)
}

/// The finding a growth refines, as it is in the model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Parent {
    /// Its nonlinear value as its columns take it (a cyclic error's frequency, 1/mm; a
    /// spike's decay, mm; a clearance's take-up, mm; a lag's second order, the lag, s).
    pub theta: f64,
    /// A cyclic error's phase φ (rad): its shape per unit amplitude is
    /// cos φ·sin + sin φ·cos; 0 for the others.
    pub phase_rad: f64,
    /// Its principal value v̄ and σ.
    pub value: (f64, f64),
}

impl Parent {
    /// The parent of a finding of effect `parent` with `params` (its reported
    /// parameters) at nonlinear value `theta`, when it is tested for a change.
    pub fn of(parent: &str, params: &BTreeMap<String, f64>, theta: f64) -> Option<Parent> {
        let g = of_parent(parent)?;
        let v = *params.get(g.value)?;
        let sv = params.get(&format!("std_{}", g.value)).copied();
        Some(Parent {
            theta,
            phase_rad: params.get("phase_rad").copied().unwrap_or(0.0),
            value: (v, sv.unwrap_or(0.0)),
        })
    }
}

/// The growth candidate of a finding's candidate `c` in the model, with its `parent`.
pub fn candidate(c: &Candidate, parent: Parent) -> Option<Candidate> {
    Some(Candidate {
        effect: of_parent(c.effect)?.name,
        parent: Some(parent),
        ..c.clone()
    })
}

/// t̄ (s): the time at which a column of shape p (per row), centred per (run, reading
/// direction) as the design centres every column, is orthogonal to p itself:
/// t̄ = Σ p_c·p·t / Σ p_c·p, p_c the centred p; the mean sample time when p never
/// varies within a run.
pub fn origin(d: &Design, mut p: impl FnMut(usize) -> f64) -> f64 {
    let t = &d.fields.t_s;
    let (mut num, mut den) = (0.0, 0.0);
    // p at one (run, component)'s rows, formed once for its mean and its sums.
    let mut vals = Vec::new();
    for run in &d.runs {
        let n = run.end - run.start;
        if n == 0 {
            continue;
        }
        for comp in 0..2 {
            vals.clear();
            vals.extend((run.start..run.end).map(|s| p(2 * s + comp)));
            let mean = vals.iter().sum::<f64>() / n as f64;
            for (s, &v) in (run.start..run.end).zip(&vals) {
                num += (v - mean) * v * t[s];
                den += (v - mean) * v;
            }
        }
    }
    if den > 0.0 {
        num / den
    } else {
        t.iter().sum::<f64>() / t.len().max(1) as f64
    }
}

/// The finding's columns and the weights of its shape per unit of its principal value.
fn base<'a>(d: &'a Design, c: &Candidate) -> Option<(&'static Growth, Columns<'a>, [f64; 2])> {
    let (g, p) = (named(c.effect)?, c.parent?);
    let parent = Candidate {
        effect: g.parent,
        parent: None,
        ..c.clone()
    };
    let cols = specs(d, &parent, p.theta, None);
    let w = if cols.len() >= 2 && g.parent == "cyclic" {
        let (s, c) = p.phase_rad.sin_cos();
        [c, s]
    } else {
        [1.0, 0.0]
    };
    (!cols.is_empty()).then_some((g, cols, w))
}

/// The finding's shape per unit of its principal value at `row`, from its columns' values.
fn shape(w: [f64; 2], o: &[f64]) -> f64 {
    w[0] * o[0] + w[1] * o.get(1).copied().unwrap_or(0.0)
}

/// t̄ of growth candidate `c` ([`origin`] of the finding's shape).
pub fn centre_s(d: &Design, c: &Candidate) -> Option<f64> {
    let (_, cols, w) = base(d, c)?;
    let mut buf = vec![0.0; cols.len()];
    Some(origin(d, |r| {
        cols.at(d, r, &mut buf);
        shape(w, &buf)
    }))
}

/// The growth column of candidate `c` (module docs): its coefficient is g in the
/// table's unit per hour.
pub(crate) fn columns<'a>(d: &'a Design, c: &Candidate) -> Columns<'a> {
    let Some((g, cols, w)) = base(d, c) else {
        return Columns::none();
    };
    // t̄, a pass over the samples: formed at the first row a pass over the moments asks
    // for (none when they are kept from before).
    let (tc, cand) = (OnceCell::new(), c.clone());
    let (axis, follows, scale) = (cols.axes[0], cols.follows(), g.scale);
    let buf = RefCell::new(vec![0.0; cols.len()]);
    let out = Columns::new(vec![g.param.into()], vec![axis], move |s, read, o| {
        let parked = follows.is_some_and(|a| d.runs[d.fields.run(s)].parked[a.index()]);
        o[0] = if parked {
            0.0
        } else {
            let tc = *tc.get_or_init(|| centre_s(d, &cand).unwrap_or(0.0));
            let mut b = buf.borrow_mut();
            (cols.fill)(s, read, &mut b);
            shape(w, &b) * scale * (d.fields.t_s[s] - tc) / 3600.0
        };
    });
    match follows {
        Some(a) => out.following(a),
        None => out,
    }
}

/// Adds the finding's value at the session's start and end, t̄ and the finding's
/// nonlinear value to the parameters of an accepted growth (its rate with σ already
/// there), from the finding's v̄ ± σ (module docs).
pub(crate) fn parameters(p: &mut BTreeMap<String, f64>, d: &Design, c: &Candidate) {
    let (Some(g), Some(par), Some(tc)) = (named(c.effect), c.parent, centre_s(d, c)) else {
        return;
    };
    let (Some(&r), Some(&sr)) = (p.get(g.param), p.get(&format!("std_{}", g.param))) else {
        return;
    };
    for (at, (v, sv)) in start_and_end(d, par.value, (r * g.scale, sr * g.scale), tc) {
        p.insert(format!("{}_{at}_{}", g.stem, g.unit), v);
        p.insert(format!("std_{}_{at}_{}", g.stem, g.unit), sv);
    }
    p.insert("centre_s".into(), tc);
    if let Some(name) = g.theta {
        let th = if name == "period_mm" {
            1.0 / par.theta
        } else {
            par.theta
        };
        p.insert(name.into(), th);
    }
    if g.parent == "cyclic" {
        p.insert("phase_rad".into(), par.phase_rad);
    }
}

/// The finding's value ± σ at the session's start (t = 0) and end (the last sample's
/// time): on the line through v̄ ± σ at t̄ with slope r ± σ per hour.
pub(super) fn start_and_end(
    d: &Design,
    value: (f64, f64),
    rate: (f64, f64),
    tc: f64,
) -> [(&'static str, (f64, f64)); 2] {
    let t_end = d.fields.t_s.iter().copied().fold(0.0, f64::max);
    [
        ("start", line_at(value, rate, tc, 0.0)),
        ("end", line_at(value, rate, tc, t_end)),
    ]
}

/// v(t) ± σ on the line through v̄ ± σ_v̄ at t̄ with slope r ± σ_r (per hour), the two
/// taken independent (as a profile's varying part of its constant).
fn line_at((v, sv): (f64, f64), (r, sr): (f64, f64), tc: f64, t: f64) -> (f64, f64) {
    let h = (t - tc) / 3600.0;
    (v + r * h, sv.hypot(sr * h))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn start_and_end_follow_the_line_through_the_constant() {
        // b̄ = 4 ± 0.1 µm at t̄ = 0.2 h, g = 10 ± 0.5 µm/h: b₀ = 2 µm at t = 0, σ from
        // both; at t̄ itself the constant's own σ.
        let (b0, s0) = line_at((4.0, 0.1), (10.0, 0.5), 720.0, 0.0);
        assert!((b0 - 2.0).abs() < 1e-12);
        assert!((s0 - 0.1f64.hypot(0.1)).abs() < 1e-12);
        assert_eq!(line_at((4.0, 0.1), (10.0, 0.5), 720.0, 720.0), (4.0, 0.1));
    }

    #[test]
    fn every_growth_has_a_table_entry_naming_its_rate_as_principal() {
        for g in &GROWTHS {
            let spec = crate::diagnosis::effects::spec(g.name).expect("in the table");
            assert_eq!(spec.principal, [g.param]);
            let parent = crate::diagnosis::effects::spec(g.parent).expect("parent");
            assert!(
                parent.params.iter().any(|p| p.name == g.value),
                "{}",
                g.name
            );
        }
    }
}
