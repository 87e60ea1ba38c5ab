//! The decision rule of conformity (ISO 14253-1): a value with its expanded uncertainty
//! U = k·u against a limit, pass, fail or undecided; on one value or pointwise on a
//! function over the travel.

use serde::{Deserialize, Serialize};

/// Coverage factor of the expanded uncertainty U = k·u used by every decision.
pub const COVERAGE_K: f64 = 2.0;

/// The decision rule in one sentence (reported with every verdict).
pub const RULE: &str = "ISO 14253-1, U = 2u with u the combined standard uncertainty of the \
                        budget (ISO/TR 230-9: instrument, thermal, setup, fit): pass when \
                        value + U <= limit, fail when value - U > limit, else undecided; an \
                        error function is judged by its range (max - min) over the measured \
                        travel (ISO 230-1), a squareness or a figure of a standard by its \
                        magnitude; the values of a model that does not explain its recording \
                        are not decided (model misfit)";

/// Outcome of comparing a measured value with a limit. Ordered so that the combination
/// of several is their maximum: pass < undecided < misfit < fail.
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Decision {
    Pass,
    Undecided,
    /// Not decided: the model does not explain its recording (the misfit gate).
    Misfit,
    Fail,
}

impl Decision {
    pub fn as_str(self) -> &'static str {
        match self {
            Decision::Pass => "pass",
            Decision::Undecided => "undecided",
            Decision::Misfit => "misfit",
            Decision::Fail => "fail",
        }
    }

    /// What a person reads: `pass`, `fail`, `undecided`, `not decided: model misfit`.
    pub fn label(self) -> &'static str {
        match self {
            Decision::Misfit => "not decided: model misfit",
            d => d.as_str(),
        }
    }

    pub fn parse(s: &str) -> Option<Decision> {
        match s {
            "pass" => Some(Decision::Pass),
            "undecided" => Some(Decision::Undecided),
            "misfit" => Some(Decision::Misfit),
            "fail" => Some(Decision::Fail),
            _ => None,
        }
    }
}

/// The decision rule: `value` with standard uncertainty `u` against a limit on |value|,
/// with U = [`COVERAGE_K`]·u. A non-finite value or uncertainty, or a negative
/// uncertainty, decides nothing (undecided).
pub fn decide(value: f64, u: f64, limit: f64) -> Decision {
    if !(value.is_finite() && u.is_finite() && u >= 0.0) {
        return Decision::Undecided;
    }
    let big_u = COVERAGE_K * u;
    if value.abs() + big_u <= limit {
        Decision::Pass
    } else if value.abs() - big_u > limit {
        Decision::Fail
    } else {
        Decision::Undecided
    }
}

/// One value of a pointwise figure: where it was taken (None for a constant), the value
/// and its standard uncertainty.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Point {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position_mm: Option<f64>,
    pub value: f64,
    /// Standard uncertainty (1σ); `None` when the source gives none (then U = 0).
    pub u: Option<f64>,
}

impl Point {
    pub(super) fn big_u(&self) -> f64 {
        COVERAGE_K * self.u.unwrap_or(0.0)
    }
}

/// A change since a baseline judged pointwise against a drift threshold: a constant, or
/// the two deciding points of a function over the travel both checks measured — the one
/// where |value| + U is largest (it decides "within") and the one where |value| − U is
/// largest (it decides "beyond"): every point is within when the first is, some point is
/// beyond when the second is.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Figure {
    /// `um` or `urad`.
    pub unit: String,
    /// The point where |value| + U is largest.
    pub upper: Point,
    /// The point where |value| − U is largest.
    pub lower: Point,
    /// The range the function was evaluated over, mm (None for a constant).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub travel_mm: Option<[f64; 2]>,
}

impl Figure {
    /// A constant figure (a squareness's change).
    pub fn constant(unit: &str, value: f64, u: Option<f64>) -> Figure {
        let p = Point {
            position_mm: None,
            value,
            u,
        };
        Figure {
            unit: unit.to_string(),
            upper: p,
            lower: p,
            travel_mm: None,
        }
    }

    /// A function known at `(position_mm, value, u)` points; `None` when there is no
    /// point or one of them is not finite (such a function cannot be decided).
    pub fn over_travel(
        unit: &str,
        points: impl IntoIterator<Item = (f64, f64, f64)>,
    ) -> Option<Figure> {
        let mut upper: Option<Point> = None;
        let mut lower: Option<Point> = None;
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for (q, value, u) in points {
            if !(q.is_finite() && value.is_finite() && u.is_finite() && u >= 0.0) {
                return None;
            }
            let p = Point {
                position_mm: Some(q),
                value,
                u: Some(u),
            };
            lo = lo.min(q);
            hi = hi.max(q);
            if upper.is_none_or(|b| value.abs() + p.big_u() > b.value.abs() + b.big_u()) {
                upper = Some(p);
            }
            if lower.is_none_or(|b| value.abs() - p.big_u() > b.value.abs() - b.big_u()) {
                lower = Some(p);
            }
        }
        Some(Figure {
            unit: unit.to_string(),
            upper: upper?,
            lower: lower?,
            travel_mm: Some([lo, hi]),
        })
    }

    /// The decision against `limit`, and the point that decided it.
    pub fn decide(&self, limit: f64) -> (Decision, Point) {
        let up = self.upper;
        let low = self.lower;
        if low.value.abs() - low.big_u() > limit {
            (Decision::Fail, low)
        } else if up.value.abs() + up.big_u() <= limit {
            (Decision::Pass, up)
        } else {
            (Decision::Undecided, up)
        }
    }
}

/// Fail over misfit over undecided over pass; `None` for no decision at all.
pub fn combine(decisions: impl IntoIterator<Item = Decision>) -> Option<Decision> {
    decisions.into_iter().max()
}

#[cfg(test)]
mod tests {
    use super::*;

    // The rule at the limit L = 10 with u = 1 (U = 2). Values chosen exactly
    // representable, so "at the limit" is exact: 8 + 2 = 10 ≤ 10 passes.
    #[test]
    fn pass_boundary_value_plus_u() {
        assert_eq!(decide(8.0, 1.0, 10.0), Decision::Pass); // |y| + U = 10 = L
        assert_eq!(decide(7.999, 1.0, 10.0), Decision::Pass); // 9.999, just below
        assert_eq!(decide(8.001, 1.0, 10.0), Decision::Undecided); // 10.001, just above
        assert_eq!(decide(-8.0, 1.0, 10.0), Decision::Pass); // on |y|
        assert_eq!(decide(-8.001, 1.0, 10.0), Decision::Undecided);
    }

    #[test]
    fn fail_boundary_value_minus_u() {
        assert_eq!(decide(12.0, 1.0, 10.0), Decision::Undecided); // |y| − U = 10, not > L
        assert_eq!(decide(11.999, 1.0, 10.0), Decision::Undecided); // 9.999, just below
        assert_eq!(decide(12.001, 1.0, 10.0), Decision::Fail); // 10.001, just above
        assert_eq!(decide(-12.001, 1.0, 10.0), Decision::Fail);
        assert_eq!(decide(10.5, 0.0, 10.0), Decision::Fail); // no uncertainty: plain compare
        assert_eq!(decide(10.0, 0.0, 10.0), Decision::Pass);
    }

    #[test]
    fn the_coverage_factor_is_two() {
        // With U = 1·u this would pass (9.5 + 0.5 ≤ 10); with U = 2u it must not.
        assert_eq!(decide(9.5, 0.5, 10.0), Decision::Undecided);
        assert_eq!(decide(9.0, 0.5, 10.0), Decision::Pass);
    }

    #[test]
    fn nonsense_decides_nothing() {
        assert_eq!(decide(f64::NAN, 1.0, 10.0), Decision::Undecided);
        assert_eq!(decide(1.0, f64::INFINITY, 10.0), Decision::Undecided);
        assert_eq!(decide(1.0, -1.0, 10.0), Decision::Undecided);
        assert_eq!(decide(f64::INFINITY, 0.0, 10.0), Decision::Undecided);
    }

    #[test]
    fn decisions_combine_fail_over_misfit_over_undecided_over_pass() {
        use Decision::*;
        assert_eq!(combine([Pass, Undecided]), Some(Undecided));
        assert_eq!(combine([Pass, Misfit, Undecided]), Some(Misfit));
        assert_eq!(combine([Misfit, Fail]), Some(Fail));
        assert_eq!(combine([]), None);
        for d in [Pass, Undecided, Misfit, Fail] {
            assert_eq!(Decision::parse(d.as_str()), Some(d));
        }
        assert_eq!(Misfit.label(), "not decided: model misfit");
        assert_eq!(serde_json::to_value(Misfit).unwrap(), "misfit");
    }

    #[test]
    fn a_change_is_within_only_when_every_point_is() {
        // f = 1, 8, −6 µm with u = 0.5, 0.4, 2: |f| + U = 2, 8.8, 10 → the deciding point
        // for "within" is q = 10 (|f| + U = 10), although q = 0 has the largest |f|.
        let fig = Figure::over_travel(
            "um",
            [(-10.0, 1.0, 0.5), (0.0, 8.0, 0.4), (10.0, -6.0, 2.0)],
        )
        .unwrap();
        assert_eq!(fig.upper.position_mm, Some(10.0));
        assert_eq!(fig.lower.position_mm, Some(0.0)); // |f| − U = 7.2
        assert_eq!(fig.travel_mm, Some([-10.0, 10.0]));
        assert_eq!(fig.decide(10.0).0, Decision::Pass);
        assert_eq!(fig.decide(9.99).0, Decision::Undecided);
        let (d, p) = fig.decide(7.19);
        assert_eq!((d, p.position_mm), (Decision::Fail, Some(0.0)));
        assert_eq!(fig.decide(7.2).0, Decision::Undecided);
        assert!(Figure::over_travel("um", []).is_none());
        assert!(Figure::over_travel("um", [(0.0, f64::NAN, 1.0)]).is_none());
    }
}
