//! Lost motion that changes during the session: the play of an axis's drive widening (or
//! narrowing) in time, as a screw and nut warm up, wear in, or lose their preload while
//! the machine works.
//!
//! **Model** (sign convention of `backlash`, [`crate::diagnosis::effects`]): with d the sign of the
//! axis's travel and t the session time (s, the clock of the samples),
//!
//! error = −d·b(t)/2, b(t) = b₀ + g·t/3600,
//!
//! b₀ the lost motion at t = 0 (µm), g its growth (µm/h, > 0 when the play widens). It
//! refines the axis's `backlash` (the constant b̄ already in the model): the candidate
//! `backlash_growth` adds one column, −d/2·(t − t̄)/3600 on the rows read along the axis,
//! 0 on the runs where the axis stays parked (a play that widens while the drive stands
//! still does not move the carriage). t̄ ([`origin_s`]) is the time at which the constant
//! column's coefficient does not move when the growth joins it (the growth column
//! centred per run is orthogonal to the constant one): the backlash's b̄ reads b(t̄), so
//! b₀ = b̄ − g·t̄/3600 and σ²(b₀) = σ²(b̄) + (t̄/3600)²·σ²(g) (taken independent, as a
//! profile's varying part of its constant).
//!
//! The play is taken up over its first b of travel after a reversal (the `backlash`'s
//! column at its fixed point), so a wider play is also taken up over a longer travel: the
//! column ([`columns`]) is the change of the play's error from b̄ to b(t), divided by g,
//! at the growth's own fixed point (g₀ = the fitted g, from the sharp form), kept only
//! when it fits better than the sharp form (the backlash's rule). Left out, samples
//! within a few µm of a reversal late in a session keep an excursion of about
//! (b(t) − b̄)/2 that the local scan calls an anomaly.
//!
//! Like every candidate it is accepted only on the engine's evidence: ΔBIC ≤ −10 and a
//! held-out gain on whole runs left out of the fit (a growth must predict the runs of
//! another time of the session). A constant play leaves its column nothing to fit. Its
//! rivals: a one-off `step` of the axis's readings (a lasting offset from one time on,
//! not flipping with the direction of travel), a `thermal_drift` (a smooth offset and
//! scale in time, the same in both directions of travel).

use super::{Candidate, Columns, play};
use crate::axis::Axis;
use crate::diagnosis::design::Design;
use std::collections::BTreeMap;

/// The candidate's effect name (its entry in the effects table:
/// `diagnosis::effects::lost_motion_growth`).
pub const NAME: &str = "backlash_growth";

/// Whether sample `s` is on a run where axis `a` stays parked.
fn parked(d: &Design, a: Axis, s: usize) -> bool {
    d.runs[d.fields.run(s)].parked[a.index()]
}

/// The play's sharp shape per unit width at sample `s`, −d/2 (0 on a parked run).
fn shape(d: &Design, a: Axis, s: usize) -> f64 {
    if parked(d, a, s) {
        0.0
    } else {
        -0.5 * d.fields.dir[a.index()][s]
    }
}

/// t̄ (s): the time at which the growth column, centred per (run, reading direction) as
/// the design centres every column, is orthogonal to the play's constant column p:
/// t̄ = Σ p_c·p·t / Σ p_c·p over the rows read along `a`, p_c the centred p (module
/// docs). The mean sample time when p never varies within a run.
pub fn origin_s(d: &Design, a: Axis) -> f64 {
    super::growth::origin(d, |r| {
        if d.row_axis(r) == a {
            shape(d, a, r / 2)
        } else {
            0.0
        }
    })
}

/// The growth column of candidate `c` (module docs): its coefficient is g, µm/h. At
/// `theta` = g₀ > 0 (the take-up's fixed point, [`super::Search::TakeUp`])
/// the play's take-up follows the width: the column is
/// [b(t)·P(b(t)) − b̄·P(b̄)]/g₀ with b(t) = b̄ + g₀·(t − t̄)/3600 (≥ 0), P(w) the play's
/// error per unit width taken up over w ([`play`]) and b̄ the candidate's
/// `lost_motion_um`; at 0 (or without b̄) the sharp −d/2·(t − t̄)/3600, its limit.
pub(crate) fn columns<'a>(d: &'a Design, c: &Candidate, theta: f64) -> Columns<'a> {
    let Some(a) = c.axis else {
        return Columns::new(Vec::new(), Vec::new(), |_, _, _| {});
    };
    let tc = origin_s(d, a);
    let (g0, b) = (theta, c.lost_motion_um);
    let travel = &d.fields.play_travel_mm[a.index()];
    Columns::new(
        vec!["growth_um_per_h".into()],
        vec![Some(a)],
        move |s, _, o| {
            let h = (d.fields.t_s[s] - tc) / 3600.0;
            o[0] = if parked(d, a, s) {
                0.0
            } else if g0 > 0.0 && b > 0.0 {
                let bt = (b + g0 * h).max(0.0);
                let at = |w: f64| w * play(travel[s], w * 1e-3);
                (at(bt) - at(b)) / g0
            } else {
                shape(d, a, s) * h
            };
        },
    )
    .following(a)
}

/// Adds the lost motion at the session's start and end and t̄ to the parameters of an
/// accepted growth (`growth_um_per_h` with its σ already there), from the axis's
/// constant lost motion `constant` = (b̄, σ) in the model (module docs).
pub(crate) fn parameters(
    p: &mut BTreeMap<String, f64>,
    d: &Design,
    a: Axis,
    constant: Option<(f64, f64)>,
) {
    let (Some(&g), Some(&sg), Some((b, sb))) = (
        p.get("growth_um_per_h"),
        p.get("std_growth_um_per_h"),
        constant,
    ) else {
        return;
    };
    let tc = origin_s(d, a);
    for (at, (v, sv)) in super::growth::start_and_end(d, (b, sb), (g, sg), tc) {
        p.insert(format!("lost_motion_{at}_um"), v);
        p.insert(format!("std_lost_motion_{at}_um"), sv);
    }
    p.insert("centre_s".into(), tc);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_entry_names_the_growth_as_principal() {
        let spec = crate::diagnosis::effects::spec(NAME).expect("in the table");
        assert!(spec.params.iter().any(|p| p.name == spec.principal[0]));
    }
}
