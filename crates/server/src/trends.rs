//! Figures derived from stored results: term values at chosen positions, differences
//! between two results, and drift since a baseline.
//!
//! A term f(q) = Σ_{i≥1} c_i q^i (monomial coefficients, results contract) is evaluated
//! by Horner's rule. Drift between a baseline b and a later result r is the largest
//! |f_r(q) − f_b(q)| over 41 evenly spaced positions of the machine's registered travel
//! of the term's axis (±100 mm when none is registered), taken separately over the
//! translational terms (µm) and over the angular terms and squareness (µrad). A term that
//! is not identifiable in either result is left out and listed.

use mtcal_solver::terms::Term;
use mtcal_store::{Machine, ResultScalars};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use utoipa::ToSchema;

/// Travel used when a machine has none registered for an axis, mm.
pub const DEFAULT_TRAVEL_MM: [f64; 2] = [-100.0, 100.0];
const GRID_POINTS: usize = 41;

/// f(q) = Σ c_i q^(i+1).
pub fn eval(coefficients: &[f64], q_mm: f64) -> f64 {
    coefficients
        .iter()
        .rev()
        .fold(0.0, |acc, &c| acc * q_mm + c)
        * q_mm
}

/// `unit` and axis letter of an ISO 230-1 term name (`None` if not one of the 18).
pub fn term_info(name: &str) -> Option<(&'static str, char)> {
    let t = Term::parse(name)?;
    Some((t.unit(), t.axis.letter()))
}

/// Registered travel of an axis, or the default.
pub fn travel(machine: &Machine, axis: char) -> [f64; 2] {
    machine
        .travel_mm
        .get(&axis.to_string())
        .copied()
        .unwrap_or(DEFAULT_TRAVEL_MM)
}

fn grid([lo, hi]: [f64; 2]) -> impl Iterator<Item = f64> {
    (0..GRID_POINTS).map(move |i| lo + (hi - lo) * i as f64 / (GRID_POINTS - 1) as f64)
}

/// Drift of one machine since its baseline.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct Drift {
    /// Largest change of a translational term over the travel, µm.
    pub drift_um: f64,
    /// Largest change of an angular term or a squareness, µrad.
    pub drift_urad: f64,
    /// Term with the largest change in µm.
    pub worst_term_um: Option<String>,
    /// Term with the largest change in µrad.
    pub worst_term_urad: Option<String>,
    /// Terms not identifiable in the baseline or the latest result (left out).
    pub not_compared: Vec<String>,
}

/// Drift between two results' scalars for `machine`.
pub fn drift(machine: &Machine, base: &ResultScalars, latest: &ResultScalars) -> Drift {
    let mut d = Drift {
        drift_um: 0.0,
        drift_urad: 0.0,
        worst_term_um: None,
        worst_term_urad: None,
        not_compared: Vec::new(),
    };
    for t in Term::all() {
        let name = t.name();
        let (Some(b), Some(l)) = (
            base.term_coefficients.get(&name),
            latest.term_coefficients.get(&name),
        ) else {
            d.not_compared.push(name);
            continue;
        };
        let m = grid(travel(machine, t.axis.letter()))
            .map(|q| (eval(l, q) - eval(b, q)).abs())
            .fold(0.0, f64::max);
        let (best, worst) = if t.is_angular() {
            (&mut d.drift_urad, &mut d.worst_term_urad)
        } else {
            (&mut d.drift_um, &mut d.worst_term_um)
        };
        if m > *best {
            *best = m;
            *worst = Some(name);
        }
    }
    for (name, b, l) in [
        ("EC0Y", base.ec0y_urad, latest.ec0y_urad),
        ("EB0Z", base.eb0z_urad, latest.eb0z_urad),
        ("EA0Z", base.ea0z_urad, latest.ea0z_urad),
    ] {
        match (b, l) {
            (Some(b), Some(l)) => {
                if (l - b).abs() > d.drift_urad {
                    d.drift_urad = (l - b).abs();
                    d.worst_term_urad = Some(name.into());
                }
            }
            _ => d.not_compared.push(name.into()),
        }
    }
    d
}

/// Change of one term between two results on a grid.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct TermDiff {
    pub unit: String,
    pub positions_mm: Vec<f64>,
    /// other − baseline at each position; empty when `identifiable` is false.
    pub delta: Vec<f64>,
    /// Identifiable in both results.
    pub identifiable: bool,
}

/// Term-by-term differences (other − baseline) on every `step_mm` of the travel
/// (always including 0), plus the squareness differences.
pub fn diff(
    machine: &Machine,
    base: &ResultScalars,
    other: &ResultScalars,
    step_mm: f64,
) -> (BTreeMap<String, TermDiff>, BTreeMap<String, Option<f64>>) {
    let mut terms = BTreeMap::new();
    for t in Term::all() {
        let name = t.name();
        let [lo, hi] = travel(machine, t.axis.letter());
        let k0 = (lo / step_mm).ceil() as i64;
        let k1 = (hi / step_mm).floor() as i64;
        let positions: Vec<f64> = (k0..=k1).map(|k| k as f64 * step_mm).collect();
        let entry = match (
            base.term_coefficients.get(&name),
            other.term_coefficients.get(&name),
        ) {
            (Some(b), Some(o)) => TermDiff {
                unit: t.unit().into(),
                delta: positions.iter().map(|&q| eval(o, q) - eval(b, q)).collect(),
                positions_mm: positions,
                identifiable: true,
            },
            _ => TermDiff {
                unit: t.unit().into(),
                positions_mm: Vec::new(),
                delta: Vec::new(),
                identifiable: false,
            },
        };
        terms.insert(name, entry);
    }
    let sq = |b: Option<f64>, o: Option<f64>| Some(o? - b?);
    let squareness = BTreeMap::from([
        ("EC0Y".to_string(), sq(base.ec0y_urad, other.ec0y_urad)),
        ("EB0Z".to_string(), sq(base.eb0z_urad, other.eb0z_urad)),
        ("EA0Z".to_string(), sq(base.ea0z_urad, other.ea0z_urad)),
    ]);
    (terms, squareness)
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn machine() -> Machine {
        Machine {
            id: "M".into(),
            name: "M".into(),
            topology: json!({}),
            travel_mm: BTreeMap::from([("X".into(), [-200.0, 300.0])]),
            site: None,
            tags: vec![],
            baseline_result_id: None,
            created_at: String::new(),
            updated_at: String::new(),
        }
    }

    fn scalars(exx: Vec<f64>, eax: Option<Vec<f64>>, ec0y: f64) -> ResultScalars {
        let mut s = ResultScalars {
            ec0y_urad: Some(ec0y),
            ..Default::default()
        };
        s.term_coefficients.insert("EXX".into(), exx);
        if let Some(a) = eax {
            s.term_coefficients.insert("EAX".into(), a);
        }
        s
    }

    #[test]
    fn horner_matches_the_power_sum() {
        let c = [0.5, -0.01, 2e-4];
        for q in [-120.0, 0.0, 7.5, 250.0] {
            let direct = 0.5 * q - 0.01 * q * q + 2e-4 * q * q * q;
            assert!((eval(&c, q) - direct).abs() < 1e-9 * (1.0 + direct.abs()));
        }
    }

    #[test]
    fn drift_is_the_largest_change_over_the_registered_travel() {
        // ΔEXX(q) = 0.01 q: largest at the far end of the X travel, |0.01 · 300| = 3 µm.
        let b = scalars(vec![0.0], Some(vec![0.001]), 5.0);
        let l = scalars(vec![0.01], Some(vec![0.001]), 3.5);
        let d = drift(&machine(), &b, &l);
        assert!((d.drift_um - 3.0).abs() < 1e-12, "{d:?}");
        assert_eq!(d.worst_term_um.as_deref(), Some("EXX"));
        // Squareness moved by 1.5 µrad; EAX did not move.
        assert!((d.drift_urad - 1.5).abs() < 1e-12);
        assert_eq!(d.worst_term_urad.as_deref(), Some("EC0Y"));
        assert!(d.not_compared.contains(&"EYY".to_string()));
        assert!(!d.not_compared.contains(&"EAX".to_string()));
    }

    #[test]
    fn diff_grid_includes_zero_and_follows_the_travel() {
        let b = scalars(vec![0.0, 1e-4], None, 1.0);
        let o = scalars(vec![0.002, 1e-4], None, 2.0);
        let (terms, sq) = diff(&machine(), &b, &o, 50.0);
        let exx = &terms["EXX"];
        assert_eq!(exx.positions_mm.first(), Some(&-200.0));
        assert_eq!(exx.positions_mm.last(), Some(&300.0));
        let i0 = exx.positions_mm.iter().position(|&q| q == 0.0).unwrap();
        assert_eq!(exx.delta[i0], 0.0);
        let i = exx.positions_mm.iter().position(|&q| q == 100.0).unwrap();
        assert!((exx.delta[i] - 0.2).abs() < 1e-12);
        assert!(!terms["EAX"].identifiable);
        assert_eq!(sq["EC0Y"], Some(1.0));
        assert_eq!(sq["EB0Z"], None);
    }
}
