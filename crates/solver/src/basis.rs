//! Bases for the error functions (kinematics contract, "Making the problem well posed").
//!
//! Every error function is zero at its reference position q = 0 (no constant term), and
//! straightness functions carry no linear term (the slope is squareness):
//!
//! * positioning, roll, pitch, yaw: f(q) = Σ_{k=1..N} c_k q^k
//! * straightness:                  f(q) = Σ_{k=2..N} c_k q^k
//!
//! N = 3 by default (the seed patent's cubic model: 12·3 + 6·2 + 3 = 51 parameters).
//!
//! [`BasisKind::Legendre`] spans the same functions with Legendre polynomials P_k of the
//! position mapped onto the measured travel, s = (q − c)/h, each shifted so that it is
//! zero at q = 0 (and, for straightness, has zero slope there):
//! g_k(q) = P_k(s) − P_k(s₀) [− P_k'(s₀)(s − s₀)], s₀ = −c/h. Same span, better
//! conditioned columns on long travels; results (values on a grid) are identical.

use crate::axis::Axis;
use crate::kinematics::{ErrorSource, MotionErrors};
use crate::terms::{Squareness, Term, TermKind};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Family of basis functions.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(rename_all = "lowercase")]
pub enum BasisKind {
    /// Monomials q^k (the seed patent's form).
    #[default]
    Polynomial,
    /// Legendre polynomials on the measured travel (same span, better conditioning).
    Legendre,
}

impl BasisKind {
    pub fn name(self) -> &'static str {
        match self {
            BasisKind::Polynomial => "polynomial",
            BasisKind::Legendre => "legendre",
        }
    }
}

/// The basis of one error function: its family, order and the travel it lives on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Basis {
    pub kind: BasisKind,
    /// Highest power N (≥ 1; straightness functions use 2..N and vanish for N = 1).
    pub order: usize,
    /// Whether the function is a straightness (no linear term).
    pub straightness: bool,
    /// Centre and half-width (mm) of the travel the basis is scaled to. For monomials
    /// the scaling only improves conditioning: functions are (q/h)^k.
    pub centre_mm: f64,
    pub half_width_mm: f64,
}

impl Basis {
    /// Basis for `term` on the travel `[lo, hi]` (mm).
    pub fn for_term(kind: BasisKind, order: usize, term: Term, lo: f64, hi: f64) -> Basis {
        let (centre_mm, half_width_mm) = match kind {
            BasisKind::Polynomial => (0.0, lo.abs().max(hi.abs()).max(1.0)),
            BasisKind::Legendre => (0.5 * (lo + hi), (0.5 * (hi - lo)).max(1.0)),
        };
        Basis {
            kind,
            order,
            straightness: term.kind() == TermKind::Straightness,
            centre_mm,
            half_width_mm,
        }
    }

    /// Lowest power used: 2 for straightness, 1 otherwise.
    pub fn first_power(&self) -> usize {
        if self.straightness { 2 } else { 1 }
    }

    /// Number of coefficients.
    pub fn len(&self) -> usize {
        (self.order + 1).saturating_sub(self.first_power())
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Values of the basis functions at `q_mm` (each zero at q = 0).
    pub fn eval(&self, q_mm: f64) -> Vec<f64> {
        let mut out = Vec::with_capacity(self.len());
        self.eval_into(q_mm, &mut out);
        out
    }

    /// As [`Basis::eval`], appending to `out`: monomials (q/h)^k, or
    /// g_k(q) = P_k(s) − P_k(s₀) [− P_k'(s₀)(s − s₀)] (`Basis::shifted`).
    pub fn eval_into(&self, q_mm: f64, out: &mut Vec<f64>) {
        let h = self.half_width_mm;
        match self.kind {
            BasisKind::Polynomial => {
                let s = q_mm / h;
                for k in self.first_power()..=self.order {
                    out.push(s.powi(k as i32));
                }
            }
            BasisKind::Legendre => {
                let s = (q_mm - self.centre_mm) / h;
                let s0 = self.reference_s();
                for k in self.first_power()..=self.order {
                    let (p, _) = legendre(k, s);
                    out.push(self.shifted(s, p, legendre(k, s0)));
                }
            }
        }
    }

    /// g_k = P_k(s) − P_k(s₀) [− P_k'(s₀)(s − s₀) for a straightness] from p = P_k(s) and
    /// the terms at the reference position (P_k(s₀), P_k'(s₀)).
    #[inline]
    fn shifted(&self, s: f64, p: f64, (p0, dp0): (f64, f64)) -> f64 {
        let v = p - p0;
        if self.straightness {
            v - dp0 * (s - self.reference_s())
        } else {
            v
        }
    }

    /// The Legendre terms at the reference position s₀ = −c/h, (P_k(s₀), P_k'(s₀)) for
    /// k = 0..=N: the constant part of [`Basis::eval`], formed once for
    /// [`Basis::values_from`] at many positions.
    pub fn at_reference(&self) -> Vec<(f64, f64)> {
        Legendre::new(self.reference_s())
            .take(self.order + 1)
            .collect()
    }

    fn reference_s(&self) -> f64 {
        -self.centre_mm / self.half_width_mm
    }

    /// The values of [`Basis::eval`] (lowest power first, without a vector) for
    /// evaluating at many positions: the Legendre terms at s₀ given, from k = 0
    /// ([`Basis::at_reference`]), those at s from one pass of [`Legendre`].
    pub fn values_from<'a>(
        &'a self,
        q_mm: f64,
        reference: &'a [(f64, f64)],
    ) -> impl Iterator<Item = f64> + 'a {
        let h = self.half_width_mm;
        let s = match self.kind {
            BasisKind::Polynomial => q_mm / h,
            BasisKind::Legendre => (q_mm - self.centre_mm) / h,
        };
        let mut terms = Legendre::new(s).zip(reference).skip(self.first_power());
        (self.first_power()..=self.order).map(move |k| match self.kind {
            BasisKind::Polynomial => s.powi(k as i32),
            BasisKind::Legendre => {
                let ((p, _), &r) = terms.next().expect("reference terms up to the order");
                self.shifted(s, p, r)
            }
        })
    }
}

/// Legendre polynomial P_k(s) and its derivative ([`Legendre`]'s k-th term).
pub fn legendre(k: usize, s: f64) -> (f64, f64) {
    Legendre::new(s).nth(k).unwrap_or((0.0, 0.0))
}

/// P_k(s) and P_k'(s) for k = 0, 1, 2, …, by the three-term recurrence
/// (k+1) P_{k+1} = (2k+1) s P_k − k P_{k−1} and the derivative recurrence
/// P'_{k+1} = P'_{k−1} + (2k+1) P_k (P_k' = k (s P_k − P_{k−1}) / (s² − 1)).
pub struct Legendre {
    s: f64,
    /// Index of the next term (the state holds the last two terms yielded).
    k: usize,
    p_prev: f64,
    p: f64,
    d_prev: f64,
    d: f64,
}

impl Legendre {
    pub fn new(s: f64) -> Legendre {
        Legendre {
            s,
            k: 0,
            p_prev: 1.0,
            p: s,
            d_prev: 0.0,
            d: 1.0,
        }
    }
}

impl Iterator for Legendre {
    type Item = (f64, f64);

    fn next(&mut self) -> Option<(f64, f64)> {
        let k = self.k;
        self.k += 1;
        match k {
            0 => return Some((1.0, 0.0)),
            1 => {}
            // P_k from P_{k−1} and P_{k−2}: n = k − 1.
            _ => {
                let nf = (k - 1) as f64;
                let p_next = ((2.0 * nf + 1.0) * self.s * self.p - nf * self.p_prev) / (nf + 1.0);
                let d_next = self.d_prev + (2.0 * nf + 1.0) * self.p;
                (self.p_prev, self.p) = (self.p, p_next);
                (self.d_prev, self.d) = (self.d, d_next);
            }
        }
        Some((self.p, self.d))
    }
}

/// A machine whose 18 error functions are plain polynomials in the commanded position,
/// f(q) = Σ c_k q^k (q in mm; c_k in µm/mm^k or µrad/mm^k), plus the three squareness
/// constants. Straightness functions have no linear term, every function is zero at 0.
///
/// This is the form of a simulation's truth (`truth.json`) and of an identified model.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct PolyErrors {
    /// Coefficients per term, keyed by ISO 230-1 name; element i is the coefficient of
    /// q^(i+1) (so element 0 of a straightness function must be 0).
    pub coefficients: BTreeMap<String, Vec<f64>>,
    /// Squareness constants of the model (γ, β, α of u_Y and u_Z), µrad.
    pub squareness: Squareness,
}

impl PolyErrors {
    /// Value of `term` at `q_mm` (µm or µrad).
    pub fn value(&self, term: Term, q_mm: f64) -> f64 {
        match self.coefficients.get(term.code()) {
            None => 0.0,
            Some(c) => {
                // Horner on q·(c1 + q·(c2 + …)).
                let mut acc = 0.0;
                for &ck in c.iter().rev() {
                    acc = acc * q_mm + ck;
                }
                acc * q_mm
            }
        }
    }

    /// Sets the coefficients of `term` (index i ↔ power i+1).
    pub fn set(&mut self, term: Term, coefficients: Vec<f64>) {
        self.coefficients
            .insert(term.code().to_string(), coefficients);
    }
}

impl ErrorSource for PolyErrors {
    fn motion(&self, axis: Axis, q_mm: f64) -> MotionErrors {
        let mut m = MotionErrors::default();
        for term in Term::all().into_iter().filter(|t| t.axis == axis) {
            *m.component_mut(term.component) = self.value(term, q_mm);
        }
        m
    }

    fn squareness(&self) -> Squareness {
        self.squareness
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn legendre_matches_closed_forms() {
        for &s in &[-1.0, -0.3, 0.0, 0.45, 1.0] {
            let p2 = 0.5 * (3.0 * s * s - 1.0);
            let p3 = 0.5 * (5.0 * s * s * s - 3.0 * s);
            let d3 = 0.5 * (15.0 * s * s - 3.0);
            assert!((legendre(2, s).0 - p2).abs() < 1e-14);
            assert!((legendre(3, s).0 - p3).abs() < 1e-14);
            assert!((legendre(3, s).1 - d3).abs() < 1e-13);
        }
    }

    /// Both families vanish at q = 0; straightness functions also have zero slope there,
    /// and the two families span the same space (monomials of degree first..N).
    #[test]
    fn bases_vanish_at_reference_and_span_the_same_space() {
        let exx = Term::parse("EXX").unwrap();
        let eyx = Term::parse("EYX").unwrap();
        for term in [exx, eyx] {
            let p = Basis::for_term(BasisKind::Polynomial, 3, term, -40.0, 70.0);
            let l = Basis::for_term(BasisKind::Legendre, 3, term, -40.0, 70.0);
            assert_eq!(p.len(), l.len());
            assert!(p.eval(0.0).iter().all(|v| v.abs() < 1e-14));
            assert!(l.eval(0.0).iter().all(|v| v.abs() < 1e-12));
            if term == eyx {
                let h = 1e-5;
                for v in l.eval(h) {
                    assert!(v.abs() < 1e-8, "slope at 0 must vanish: {v}");
                }
            }
            // Legendre functions are exact combinations of the monomials: fit on 6 points,
            // check on others.
            let qs: Vec<f64> = (0..6).map(|i| -40.0 + 22.0 * i as f64).collect();
            for j in 0..l.len() {
                let a = nalgebra::DMatrix::from_fn(qs.len(), p.len(), |r, c| p.eval(qs[r])[c]);
                let b = nalgebra::DVector::from_fn(qs.len(), |r, _| l.eval(qs[r])[j]);
                let x = a.clone().svd(true, true).solve(&b, 1e-12).unwrap();
                let resid = (&a * &x - &b).norm();
                assert!(
                    resid < 1e-10,
                    "Legendre function {j} not in the span: {resid}"
                );
            }
        }
        let p1 = Basis::for_term(BasisKind::Polynomial, 1, eyx, -1.0, 1.0);
        assert!(p1.is_empty());
    }

    #[test]
    fn poly_errors_evaluate_by_horner() {
        let mut e = PolyErrors::default();
        let exx = Term::parse("EXX").unwrap();
        e.set(exx, vec![0.01, -2e-4, 3e-6]);
        let q: f64 = 37.0;
        let want = 0.01 * q - 2e-4 * q * q + 3e-6 * q.powi(3);
        assert!((e.value(exx, q) - want).abs() < 1e-12);
        assert_eq!(e.motion(Axis::X, q).translation_um[0], e.value(exx, q));
        assert_eq!(e.motion(Axis::Y, q).translation_um[0], 0.0);
    }
}
