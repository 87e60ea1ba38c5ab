//! The columns of a diagnosis's findings as extra columns of identification's design: each
//! finding's effect is read back as the catalogue's candidate it was chosen as (its label
//! opens the finding's `evidence`) with its nonlinear parameter at the diagnosis's value,
//! and its columns are the diagnosis's own (`catalogue::specs`), so the explained model
//! fits exactly the physics the diagnosis found.

use crate::axis::Axis;
use crate::design::{ExtraColumns, RowMeta};
use crate::diagnosis::Finding;
use crate::diagnosis::catalogue::growth::{self, Parent};
use crate::diagnosis::catalogue::{self, Candidate, Columns};
use crate::diagnosis::design::Design;
use crate::session::Session;

/// The effects of the catalogue a finding can be read back as (its `evidence` label's
/// first word).
const EFFECTS: [&str; 24] = [
    "backlash",
    "backlash_growth",
    "cyclic",
    "cyclic_growth",
    "direction_coupling",
    "direction_coupling_growth",
    "lost_motion_profile",
    "lost_motion_variation",
    "model_order",
    "plate_scale",
    "reversal_spike",
    "reversal_spike_growth",
    "servo_lag",
    "servo_lag_growth",
    "setup_offset",
    "step",
    "thermal_drift",
    "thermal_temperature",
    "thermal_temperature_lag",
    "thermal_temperature_quadratic",
    "transient",
    "velocity_coupling",
    "vibration",
    "waviness",
];

/// A nonlinear parameter: its name and the value the columns take (a frequency for a
/// period).
pub type Theta = Option<(&'static str, f64)>;

/// A finding read back as the candidate it was chosen as, with its nonlinear parameter,
/// or why not.
pub fn candidate_of(f: &Finding) -> Result<(Candidate, Theta), String> {
    let label = f.evidence.split(':').next().unwrap_or("");
    let words: Vec<&str> = label.split_whitespace().collect();
    let effect = words
        .first()
        .and_then(|w| EFFECTS.iter().find(|e| *e == w))
        .copied()
        .ok_or_else(|| {
            format!(
                "{}: its evidence does not name a catalogue effect",
                f.name_in_words()
            )
        })?;
    if effect == "setup_offset" {
        return Err(format!(
            "{}: a head offset's columns follow the model's rotations and are not refitted",
            f.name_in_words()
        ));
    }
    let axis = words.get(1).and_then(|w| Axis::parse(w));
    let after = |key: &str| {
        words
            .windows(2)
            .find(|w| w[0] == key)
            .map(|w| w[1].to_string())
    };
    let direction = after("along").and_then(|w| Axis::parse(&w));
    let order = after("order")
        .and_then(|w| w.parse::<usize>().ok())
        .unwrap_or(0);
    let width_s = after("over")
        .and_then(|w| w.parse::<f64>().ok())
        .unwrap_or(0.0);
    // A step's width and a transient's decay are reported with more digits than its
    // label's.
    let width_s = match effect {
        "transient" => value(f, "decay_s").unwrap_or(width_s),
        _ => value(f, "width_s").unwrap_or(width_s),
    };
    let cand = Candidate {
        effect,
        axis,
        direction,
        group: None,
        order,
        width_s: if matches!(effect, "step" | "transient") {
            width_s
        } else {
            0.0
        },
        lost_motion_um: 0.0,
        // A plate's scale names its mounting: `plate_scale of mounting `xz``.
        mounting: (effect == "plate_scale")
            .then(|| label.split('`').nth(1).map(str::to_string))
            .flatten(),
        parent: growth_parent(f, effect),
    };
    let theta_name = match effect {
        "reversal_spike" => Some("decay_mm"),
        "thermal_drift" => Some("time_constant_s"),
        "cyclic" | "waviness" => Some("period_mm"),
        "thermal_temperature_lag" => Some("lag_s"),
        "step" | "transient" => Some("time_s"),
        "vibration" => Some("frequency_hz"),
        _ => None,
    };
    let theta = match theta_name {
        None => None,
        Some(name) => {
            let v = value(f, name).ok_or_else(|| {
                format!("{}: its {name} is not in the finding", f.name_in_words())
            })?;
            let col = if name == "period_mm" { 1.0 / v } else { v };
            Some((name, col))
        }
    };
    Ok((cand, theta))
}

/// For a growth (`catalogue::growth`): the finding it refines, from the nonlinear value
/// and phase the growth reports of it (its value is not needed by the columns).
fn growth_parent(f: &Finding, effect: &str) -> Option<Parent> {
    let g = growth::named(effect)?;
    let theta = match g.theta {
        Some("period_mm") => 1.0 / value(f, "period_mm")?,
        Some(name) => value(f, name)?,
        None => 0.0,
    };
    Some(Parent {
        theta,
        phase_rad: value(f, "phase_rad").unwrap_or(0.0),
        value: (0.0, 0.0),
    })
}

/// A parameter of a finding, determined or not.
fn value(f: &Finding, name: &str) -> Option<f64> {
    f.parameters.get(name).copied().or_else(|| {
        f.undetermined
            .iter()
            .find(|u| u.name == name)
            .map(|u| u.value)
    })
}

/// The findings' columns as extra columns of identification's design, in the findings'
/// order; each block's coefficient names.
pub struct FindingColumns<'a> {
    d: &'a Design,
    specs: Vec<Columns<'a>>,
    /// First sample of every (plane, run) of the session.
    starts: Vec<Vec<usize>>,
    blocks: Vec<std::ops::Range<usize>>,
    count: usize,
}

impl<'a> FindingColumns<'a> {
    /// The columns of `cands` (each with its nonlinear value) on design `d` of `session`.
    pub fn new(
        session: &Session,
        d: &'a Design,
        cands: &[(Candidate, Theta)],
    ) -> FindingColumns<'a> {
        let specs: Vec<Columns<'a>> = cands
            .iter()
            .map(|(c, th)| catalogue::specs(d, c, th.map_or(0.0, |x| x.1), None))
            .collect();
        let mut next = 0;
        let starts = session
            .planes
            .iter()
            .map(|p| {
                p.runs
                    .iter()
                    .map(|r| {
                        let s = next;
                        next += r.len();
                        s
                    })
                    .collect()
            })
            .collect();
        let mut at = 0;
        let blocks = specs
            .iter()
            .map(|s| {
                at += s.len();
                at - s.len()..at
            })
            .collect();
        FindingColumns {
            d,
            specs,
            starts,
            blocks,
            count: at,
        }
    }

    /// The column range of each finding's block.
    pub fn blocks(&self) -> &[std::ops::Range<usize>] {
        &self.blocks
    }

    /// The coefficient names of finding `i`'s block.
    pub fn names(&self, i: usize) -> &[String] {
        &self.specs[i].names
    }

    /// The values of finding `i`'s columns at every reading of plane `p`, run `r`
    /// (sample, component).
    pub fn block_at(
        &self,
        i: usize,
        p: usize,
        r: usize,
        sample: usize,
        comp: usize,
        out: &mut [f64],
    ) {
        let row = 2 * (self.starts[p][r] + sample) + comp;
        self.specs[i].at(self.d, row, out);
    }
}

impl ExtraColumns for FindingColumns<'_> {
    fn count(&self) -> usize {
        self.count
    }

    fn fill(&self, row: &RowMeta, out: &mut [f64]) {
        for (i, b) in self.blocks.iter().enumerate() {
            self.block_at(
                i,
                row.plane,
                row.run,
                row.sample,
                row.comp,
                &mut out[b.clone()],
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A plate scale is read back with its mounting (its evidence's label names it).
    #[test]
    fn a_plate_scale_reads_back_with_its_mounting() {
        let f: Finding = serde_json::from_value(serde_json::json!({
            "effect": "plate_scale",
            "parameters": {"scale_ppm": -8.0, "std_scale_ppm": 0.1},
            "physics": "",
            "residual_rms_um": {"before": 1.0, "after": 0.2},
            "heldout_rms_um": {"before": 1.0, "after": 0.2},
            "evidence": "plate_scale of mounting `xz`: BIC -8538.8 with 1 extra parameter(s)",
        }))
        .expect("a finding");
        let (c, theta) = candidate_of(&f).expect("a catalogue effect");
        assert_eq!(
            (c.effect, c.mounting.as_deref()),
            ("plate_scale", Some("xz"))
        );
        assert!(theta.is_none());
    }
}
