//! The truth of a simulation (`truth.json`), including the error functions on the
//! reporting grid under the reporting conventions of the kinematics contract, so that an
//! identification result can be compared with it number for number.

use super::effects::Effect;
use crate::axis::Axis;
use crate::basis::PolyErrors;
use crate::session::Session;
use crate::terms::{SquarenessTerm, Term, TermKind};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Zero offsets of one run (µm), as the simulator added them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunOffset {
    pub file: String,
    pub run: i64,
    pub du_um: f64,
    pub dv_um: f64,
}

/// Values of one error function on the reporting grid.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TruthTerm {
    /// `um` or `urad`.
    pub unit: String,
    pub positions_mm: Vec<f64>,
    pub values: Vec<f64>,
}

/// Everything the simulator put into a session.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Truth {
    /// Always `simulation_truth`.
    pub kind: String,
    pub seed: u64,
    pub noise_um: f64,
    pub sample_rate_hz: f64,
    pub feed_mm_min: f64,
    pub accel_mm_s2: f64,
    pub dwell_s: f64,
    /// The geometric errors (model form: polynomial coefficients, squareness constants).
    pub errors: PolyErrors,
    /// Plate rotation of each mounting (µrad, +φ from u toward v).
    pub mounting_rotation_urad: BTreeMap<String, f64>,
    pub run_offsets: Vec<RunOffset>,
    pub effects: Vec<Effect>,
    /// Measured travel of each axis (mm), as identification will see it.
    pub travel_mm: BTreeMap<String, [f64; 2]>,
    /// The 18 functions on the reporting grid, in the units and conventions of the
    /// identification result (straightness minus its least-squares line).
    pub terms: BTreeMap<String, TruthTerm>,
    /// Reported squareness (angle between the least-squares axis lines), µrad.
    pub squareness_urad: BTreeMap<String, f64>,
    pub reporting: Vec<String>,
}

/// Measured travel of each axis as identification sees it ([`crate::design::measured_travel`]).
pub fn measured_travel(session: &Session) -> [Option<[f64; 2]>; 3] {
    crate::design::measured_travel(session).map(|t| t.map(|(lo, hi)| [lo, hi]))
}

/// Least-squares line a + b·q of f over [lo, hi], continuous and uniformly weighted:
/// with s = (q − c)/h, a₀ = ½∫f ds and a₁ = (3/2)∫f·s ds (Legendre projections), by
/// 5-point Gauss–Legendre quadrature (exact up to degree 9). Returns (intercept at q = 0,
/// slope per mm).
pub fn ls_line(f: impl Fn(f64) -> f64, lo: f64, hi: f64) -> (f64, f64) {
    const NODES: [f64; 5] = [
        -0.906_179_845_938_664,
        -0.538_469_310_105_683_1,
        0.0,
        0.538_469_310_105_683_1,
        0.906_179_845_938_664,
    ];
    const WEIGHTS: [f64; 5] = [
        0.236_926_885_056_189_1,
        0.478_628_670_499_366_5,
        0.568_888_888_888_888_9,
        0.478_628_670_499_366_5,
        0.236_926_885_056_189_1,
    ];
    let (c, h) = (0.5 * (lo + hi), 0.5 * (hi - lo));
    let (mut a0, mut a1) = (0.0, 0.0);
    for (s, w) in NODES.iter().zip(WEIGHTS) {
        let v = f(c + h * s);
        a0 += 0.5 * w * v;
        a1 += 1.5 * w * v * s;
    }
    let slope = a1 / h;
    (a0 - slope * c, slope)
}

/// The 18 functions on the reporting grid and the reported squareness.
pub fn reported_values(
    errors: &PolyErrors,
    travel: &[Option<[f64; 2]>; 3],
    step_mm: f64,
) -> (BTreeMap<String, TruthTerm>, BTreeMap<String, f64>) {
    let mut terms = BTreeMap::new();
    let mut slope_urad = BTreeMap::new();
    for term in Term::all() {
        let Some([lo, hi]) = travel[term.axis.index()] else {
            continue;
        };
        let f = |q: f64| errors.value(term, q);
        let (a, b) = if term.kind() == TermKind::Straightness {
            ls_line(f, lo, hi)
        } else {
            (0.0, 0.0)
        };
        slope_urad.insert(term.name(), b * 1e3);
        let positions_mm = crate::identification::grid(lo, hi, step_mm);
        let values = positions_mm.iter().map(|&q| f(q) - a - b * q).collect();
        terms.insert(
            term.name(),
            TruthTerm {
                unit: term.unit().into(),
                positions_mm,
                values,
            },
        );
    }
    let s = |n: &str| slope_urad.get(n).copied().unwrap_or(0.0);
    let sq = errors.squareness;
    let mut squareness = BTreeMap::new();
    for t in SquarenessTerm::ALL {
        let v = match t {
            SquarenessTerm::EC0Y => sq.ec0y_urad - s("EXY") - s("EYX"),
            SquarenessTerm::EB0Z => sq.eb0z_urad + s("EXZ") + s("EZX"),
            SquarenessTerm::EA0Z => sq.ea0z_urad - s("EYZ") - s("EZY"),
        };
        squareness.insert(t.name().to_string(), v);
    }
    (terms, squareness)
}

/// Sentences of the reporting conventions used for `terms` and `squareness_urad`.
pub fn reporting_sentences(travel: &[Option<[f64; 2]>; 3], step_mm: f64) -> Vec<String> {
    let mut v = vec![
        "straightness values are the function minus its least-squares line over the measured travel (continuous, uniform weight)".to_string(),
        "squareness is the angle between the least-squares axis lines: X-Y = 90 deg + EC0Y, X-Z = 90 deg - EB0Z, Y-Z = 90 deg + EA0Z".to_string(),
        format!("values on a {step_mm} mm grid over the measured travel, including 0"),
    ];
    for a in Axis::ALL {
        match travel[a.index()] {
            Some([lo, hi]) => v.push(format!("measured travel of {a}: {lo} .. {hi} mm")),
            None => v.push(format!("{a} did not move: its terms are not reported")),
        }
    }
    v
}
