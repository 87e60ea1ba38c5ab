//! The physics a diagnosis found, in the tables: the reversal (lost motion) of each axis
//! at the positions of its table, and thermal coefficients per kelvin.
//!
//! **Reversal.** The diagnosis reports the lost motion b of an axis (sign convention of
//! the catalogue's `backlash`: error = −d·b/2, d the sign of the travel, b > 0 when the
//! axis stops short of its target in the direction of travel; ISO 230-2's reversal value
//! B = −b). A `backlash` finding gives a constant b (`lost_motion_um`); a
//! `lost_motion_profile` finding gives b(q) at points over the measured travel
//! (`lost_motion_um_{n}` at `target_mm_{n}`, the constant part included), which wins over
//! a constant of the same axis. Between two points b is interpolated linearly; before the
//! first and after the last it is the nearest point's (nothing extrapolated). The error of
//! the axis along itself is then e(q) − b(q)/2 travelling forward (toward +) and
//! e(q) + b(q)/2 travelling in reverse.
//!
//! **Thermal.** A `thermal_drift` finding with logged temperatures reports the growth per
//! kelvin: an offset (`offset_um_per_k[_{axis}]`, µm/K) and a scale
//! (`scale_ppm_per_k[_{axis}]`, ppm/K) per axis. Those go into the tables that can carry
//! them (the plain CSV) and are named in the others' headers. A drift in time without a
//! temperature has no per-kelvin coefficient and gives none.
//!
//! This is the one place the tables take physics from: a result decided on an explained
//! model gives its findings here.

use super::Compensation;
use mtcal_solver::Axis;
use mtcal_solver::diagnosis::Finding;
use mtcal_solver::explained::ExplainedModel;

/// A thermal coefficient per kelvin of one axis (or of the recording's one axis).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Thermal {
    pub axis: Option<Axis>,
    pub kind: ThermalKind,
    /// µm/K for an offset, ppm/K for a scale.
    pub per_k: f64,
}

/// Which growth a [`Thermal`] coefficient describes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ThermalKind {
    /// An offset growing with the temperature, µm/K.
    Offset,
    /// A scale growing with the temperature, ppm/K.
    Scale,
}

impl ThermalKind {
    /// Its name in the plain CSV's `term` column.
    pub fn term(self) -> &'static str {
        match self {
            ThermalKind::Offset => "thermal_offset",
            ThermalKind::Scale => "thermal_scale",
        }
    }

    /// Its unit.
    pub fn unit(self) -> &'static str {
        match self {
            ThermalKind::Offset => "um/K",
            ThermalKind::Scale => "ppm/K",
        }
    }

    /// The kind named `term` ([`ThermalKind::term`]).
    pub fn parse(term: &str) -> Option<ThermalKind> {
        [ThermalKind::Offset, ThermalKind::Scale]
            .into_iter()
            .find(|k| k.term() == term)
    }
}

/// The lost motion of an axis as the diagnosis found it.
#[derive(Debug, Clone, PartialEq)]
pub enum LostMotion {
    /// A backlash: b, µm.
    Constant(f64),
    /// A profile: (position mm, b µm), positions increasing.
    Profile(Vec<(f64, f64)>),
}

impl LostMotion {
    /// b at position `q`, µm (module docs: linear between points, the nearest point's
    /// outside them).
    pub fn at(&self, q: f64) -> f64 {
        match self {
            LostMotion::Constant(b) => *b,
            LostMotion::Profile(p) => {
                let Some(&(q0, b0)) = p.first() else {
                    return 0.0;
                };
                if q <= q0 {
                    return b0;
                }
                for w in p.windows(2) {
                    let ((qa, ba), (qb, bb)) = (w[0], w[1]);
                    if q <= qb {
                        let t = if qb > qa { (q - qa) / (qb - qa) } else { 1.0 };
                        return ba + t * (bb - ba);
                    }
                }
                p.last().map_or(b0, |&(_, b)| b)
            }
        }
    }
}

/// The lost motion of `axis` in `findings` (a profile wins over a constant).
pub fn lost_motion(findings: &[Finding], axis: Axis) -> Option<LostMotion> {
    let letter = axis.letter().to_string();
    let of = |effect: &str| {
        findings
            .iter()
            .find(|f| f.effect == effect && f.axis.as_deref() == Some(letter.as_str()))
    };
    if let Some(f) = of("lost_motion_profile") {
        let mut points: Vec<(f64, f64)> = (1..)
            .map_while(|n| {
                let q = f.parameters.get(&format!("target_mm_{n}"))?;
                let b = f.parameters.get(&format!("lost_motion_um_{n}"))?;
                Some((*q, *b))
            })
            .collect();
        points.sort_by(|a, b| a.0.total_cmp(&b.0));
        if !points.is_empty() {
            return Some(LostMotion::Profile(points));
        }
    }
    let b = of("backlash")?.parameters.get("lost_motion_um")?;
    Some(LostMotion::Constant(*b))
}

/// The thermal coefficients per kelvin of `findings`.
pub fn thermal(findings: &[Finding]) -> Vec<Thermal> {
    let mut out = Vec::new();
    for f in findings.iter().filter(|f| f.effect == "thermal_drift") {
        let own = f.axis.as_deref().and_then(axis_named);
        for (kind, stem) in [
            (ThermalKind::Offset, "offset_um_per_k"),
            (ThermalKind::Scale, "scale_ppm_per_k"),
        ] {
            if let Some(v) = f.parameters.get(stem) {
                out.push(Thermal {
                    axis: own,
                    kind,
                    per_k: *v,
                });
            }
            for a in Axis::ALL {
                if let Some(v) = f.parameters.get(&format!("{stem}_{}", a.letter())) {
                    out.push(Thermal {
                        axis: Some(a),
                        kind,
                        per_k: *v,
                    });
                }
            }
        }
    }
    out
}

/// The physics of an explained model as findings (effect, axis and its jointly fitted
/// parameters with the held ones): what the tables of a result decided on it take their
/// reversal and thermal coefficients from. The figures a table does not read (residuals,
/// evidence) are the model's predictions, not the diagnosis's.
pub fn explained_findings(m: &ExplainedModel) -> Vec<Finding> {
    m.physics
        .iter()
        .map(|p| Finding {
            effect: p.effect.clone(),
            axis: p.axis.clone(),
            depends_on: p.depends_on.clone(),
            parameters: p
                .held
                .iter()
                .chain(&p.parameters)
                .map(|(k, v)| (k.clone(), *v))
                .collect(),
            physics: String::new(),
            signature: None,
            residual_rms_um: p.predicted_rms_um,
            heldout_rms_um: p.predicted_rms_um,
            evidence: String::new(),
            undetermined: vec![],
            rivals: Vec::new(),
        })
        .collect()
}

fn axis_named(s: &str) -> Option<Axis> {
    Axis::ALL.into_iter().find(|a| a.letter().to_string() == s)
}

impl Compensation {
    /// This table with the physics of `findings` (the determined findings of a diagnosis
    /// of the same recording): each axis's reversal at its positions and the thermal
    /// coefficients (module docs).
    pub fn with_findings(mut self, findings: &[Finding]) -> Compensation {
        for a in &mut self.axes {
            a.reversal_mm = lost_motion(findings, a.axis)
                .map(|lm| a.positions_mm.iter().map(|&q| lm.at(q) * 1e-3).collect());
        }
        self.thermal = thermal(findings);
        self
    }

    /// The header sentences on the physics found: each axis's reversal (its range along
    /// the travel) and the thermal coefficients; for a format that cannot carry one, that
    /// it is not in the file and where it belongs.
    pub fn physics_header(&self, carries: Carries) -> Vec<String> {
        let mut h = Vec::new();
        let rev: Vec<String> = self
            .axes
            .iter()
            .filter_map(|a| {
                let b = a.reversal_mm.as_ref()?;
                let lo = b.iter().copied().fold(f64::INFINITY, f64::min) * 1e3;
                let hi = b.iter().copied().fold(f64::NEG_INFINITY, f64::max) * 1e3;
                Some(if (hi - lo).abs() < 5e-4 {
                    format!("{} b = {lo:.3} um", a.axis)
                } else {
                    format!("{} b = {lo:.3} .. {hi:.3} um along the travel", a.axis)
                })
            })
            .collect();
        let rev_list = if rev.is_empty() {
            "none found".to_string()
        } else {
            rev.join("; ")
        };
        h.push(format!(
            "{REVERSAL}{rev_list} (b > 0: the axis stops short in the direction of travel; \
             error forward = -b/2, reverse = +b/2; ISO 230-2 B = -b)"
        ));
        if !carries.reversal {
            h.push(
                "this format does not carry the reversal: set it in the controller's backlash \
                 (reversal) compensation, or export format linuxcnc or csv"
                    .into(),
            );
        }
        let th: Vec<String> = self
            .thermal
            .iter()
            .map(|t| {
                let axis = t.axis.map_or(String::new(), |a| format!("{a} "));
                format!("{axis}{} {:.4} {}", t.kind.term(), t.per_k, t.kind.unit())
            })
            .collect();
        h.push(format!(
            "thermal coefficients per kelvin: {}",
            if th.is_empty() {
                "none found".to_string()
            } else {
                th.join("; ")
            }
        ));
        if !carries.thermal {
            h.push(
                "this format does not carry thermal compensation: set the coefficients in the \
                 controller's thermal compensation, or export format csv"
                    .into(),
            );
        }
        h
    }
}

/// Start of the header line on the reversal found.
pub const REVERSAL: &str = "reversal (lost motion) found: ";

/// What a format holds besides the geometric errors.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Carries {
    /// Forward and reverse values per position.
    pub reversal: bool,
    /// Thermal coefficients per kelvin.
    pub thermal: bool,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_profile_is_interpolated_and_held_at_its_ends() {
        let p = LostMotion::Profile(vec![(0.0, 2.0), (10.0, 4.0), (20.0, 4.0)]);
        assert_eq!(p.at(-5.0), 2.0);
        assert_eq!(p.at(5.0), 3.0);
        assert_eq!(p.at(15.0), 4.0);
        assert_eq!(p.at(25.0), 4.0);
        assert_eq!(LostMotion::Constant(6.0).at(1e3), 6.0);
    }
}
