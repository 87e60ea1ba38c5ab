//! The service's side of result arithmetic: the stored scalars of a result
//! ([`ResultScalars`]) seen as a check of [`mtcal_solver::comparison`], which evaluates
//! terms (in the reporting convention, with their standard uncertainty), differences and
//! drift, only inside the travel a check measured. This module only adapts the stored
//! row and words the travel for messages.

use mtcal_solver::comparison::{self, CheckFunctions, Value};
pub use mtcal_solver::comparison::{Drift, TermDiff};
use mtcal_solver::terms::Term;
use mtcal_solver::tolerance::Figure;
use mtcal_store::ResultScalars;
use std::collections::BTreeMap;

/// A stored result's scalars as a check of the solver's result arithmetic.
struct Stored<'a>(&'a ResultScalars);

impl CheckFunctions for Stored<'_> {
    fn coefficients(&self, term: &str) -> Option<&[f64]> {
        self.0.term_coefficients.get(term).map(Vec::as_slice)
    }
    fn coefficient_covariance(&self, term: &str) -> Option<&[Vec<f64>]> {
        self.0.term_covariance.get(term).map(Vec::as_slice)
    }
    fn measured_travel(&self, axis: char) -> Option<[f64; 2]> {
        measured(self.0, axis)
    }
    fn squareness(&self, name: &str) -> Option<f64> {
        match name {
            "EC0Y" => self.0.ec0y_urad,
            "EB0Z" => self.0.eb0z_urad,
            "EA0Z" => self.0.ea0z_urad,
            _ => None,
        }
    }
    /// Stored as a 1 × 1 covariance under the squareness's name.
    fn squareness_std(&self, name: &str) -> Option<f64> {
        Some(
            self.0
                .term_covariance
                .get(name)?
                .first()?
                .first()?
                .max(0.0)
                .sqrt(),
        )
    }
}

/// Value of term `name` of a stored result at `q_mm`, with its standard uncertainty
/// (`None`: not one of the 18 terms, not identifiable, or outside the measured travel).
pub fn value(s: &ResultScalars, name: &str, q_mm: f64) -> Option<Value> {
    comparison::term_value(&Stored(s), Term::parse(name)?, q_mm)
}

/// Standard uncertainty of squareness `name` (`EC0Y`, `EB0Z`, `EA0Z`) of a stored
/// result, µrad (`None`: not stored).
pub fn squareness_u(s: &ResultScalars, name: &str) -> Option<f64> {
    Stored(s).squareness_std(name)
}

/// `unit` and axis letter of an ISO 230-1 term name (`None` if not one of the 18).
pub fn term_info(name: &str) -> Option<(&'static str, char)> {
    let t = Term::parse(name)?;
    Some((t.unit(), t.axis.letter()))
}

/// Travel the check measured on `axis`, [min, max] mm (`None`: the axis did not move,
/// or the result predates the record).
pub fn measured(s: &ResultScalars, axis: char) -> Option<[f64; 2]> {
    s.measured_travel_mm.get(&axis.to_string()).copied()
}

/// Whether the check measured position `q_mm` of `axis`.
pub fn measured_at(s: &ResultScalars, axis: char, q_mm: f64) -> bool {
    measured(s, axis).is_some_and(|t| comparison::inside(t, q_mm))
}

/// The travel both checks measured on `axis` (`None`: unknown or no overlap).
pub fn common_travel(a: &ResultScalars, b: &ResultScalars, axis: char) -> Option<[f64; 2]> {
    comparison::common_travel(&Stored(a), &Stored(b), axis)
}

/// A sentence stating the measured travel of `axis` in `s`.
pub fn travel_sentence(s: &ResultScalars, axis: char) -> String {
    match measured(s, axis) {
        Some([lo, hi]) => format!("{axis} was measured over [{lo}, {hi}] mm"),
        None => format!("{axis} has no measured travel in this check"),
    }
}

/// Drift between two stored results ([`comparison::drift`]).
pub fn drift(base: &ResultScalars, latest: &ResultScalars) -> Drift {
    comparison::drift(&Stored(base), &Stored(latest))
}

/// Each change since the baseline as a figure of the decision rule
/// ([`comparison::changes`]).
pub fn changes(base: &ResultScalars, latest: &ResultScalars) -> BTreeMap<String, Figure> {
    comparison::changes(&Stored(base), &Stored(latest))
}

/// Checks a diff's step ([`comparison::check_diff_step`]).
pub fn check_diff_step(
    base: &ResultScalars,
    other: &ResultScalars,
    step_mm: f64,
) -> Result<(), String> {
    comparison::check_diff_step(&Stored(base), &Stored(other), step_mm)
}

/// Term-by-term and squareness differences ([`comparison::diff`]).
pub fn diff(
    base: &ResultScalars,
    other: &ResultScalars,
    step_mm: f64,
) -> (BTreeMap<String, TermDiff>, BTreeMap<String, Option<f64>>) {
    comparison::diff(&Stored(base), &Stored(other), step_mm)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The stored row's squareness and its 1 × 1 variance reach the solver's arithmetic
    /// under the right names (the arithmetic itself is tested in the solver).
    #[test]
    fn stored_scalars_are_read_under_their_names() {
        let mut s = ResultScalars {
            ec0y_urad: Some(5.0),
            ea0z_urad: Some(-2.0),
            ..Default::default()
        };
        s.measured_travel_mm.insert("X".into(), [-50.0, 50.0]);
        s.term_coefficients.insert("EXX".into(), vec![0.01]);
        s.term_covariance.insert("EXX".into(), vec![vec![1e-6]]);
        s.term_covariance.insert("EC0Y".into(), vec![vec![0.04]]);
        let mut l = s.clone();
        l.ec0y_urad = Some(6.5);
        l.ea0z_urad = Some(-2.5);
        l.term_covariance.insert("EA0Z".into(), vec![vec![0.09]]);
        let v = value(&s, "EXX", 50.0).unwrap();
        assert!((v.value - 0.5).abs() < 1e-12 && (v.u.unwrap() - 0.05).abs() < 1e-12);
        assert!(value(&s, "EXX", 60.0).is_none());
        assert!(measured_at(&s, 'X', 50.0) && !measured_at(&s, 'Y', 0.0));
        assert_eq!(Stored(&s).squareness_std("EC0Y"), Some(0.2));
        let (_, sq) = diff(&s, &l, 10.0);
        assert_eq!(sq["EC0Y"], Some(1.5));
        assert_eq!(sq["EA0Z"], Some(-0.5));
        assert_eq!(sq["EB0Z"], None);
        let d = drift(&s, &l);
        assert_eq!(d.worst_term_urad.as_deref(), Some("EC0Y"));
        // EA0Z has no variance in the baseline: its change is not judged.
        let ch = changes(&s, &l);
        assert!(
            ch.contains_key("EC0Y") && !ch.contains_key("EA0Z"),
            "{ch:?}"
        );
    }
}
