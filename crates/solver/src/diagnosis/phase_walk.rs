//! sin(ω·x_s) and cos(ω·x_s) over samples taken in order, by rotation from the sample
//! before instead of a `sincos` call each: the columns of the cyclic error and the
//! waviness (the catalogue's) along a run, where x_s (a position) moves by a small step
//! from sample to sample.
//!
//! With δ = x_s − x_{s−1} (exact by Sterbenz's lemma where the two are within a factor 2
//! of each other, which is checked) and φ = ω·δ,
//!
//!   e^(iωx_s) = e^(iωx_{s−1}) · e^(iφ),
//!
//! sin φ and cos φ from their Taylor series while |φ| ≤ [`MAX_STEP`] (to φ¹³ and φ¹⁴: the
//! next terms are below 10⁻²¹ of them). Each rotation adds a rounding of order 10⁻¹⁶;
//! the pair is evaluated directly ("anchored") at every sample whose index is a multiple
//! of [`ANCHOR`], at a sample that does not follow the one before, and wherever a check
//! fails. A walked value is then within about [`ANCHOR`]·10⁻¹⁶ of its anchor's value
//! carried exactly over the steps since; that anchor, like every direct evaluation,
//! carries the rounding of its argument ω·x (10⁻¹⁶ of the whole phase, 10⁻¹⁴ absolute at
//! a few hundred radians), so walked and direct values differ by about as much as the
//! direct ones differ from the exact sine and cosine. The value at a sample depends only
//! on the samples since its anchor, and on which of them the caller asked for just
//! before it (a walk resumes only from the sample before): passes that visit different
//! rows may differ at a sample by that rounding, and the same passes in the same order
//! give the same values.

use std::cell::Cell;

/// Samples between two direct evaluations (at most).
pub const ANCHOR: usize = 32;

/// Largest |φ| of a rotation (rad).
const MAX_STEP: f64 = 0.25;

/// sin ωx and cos ωx of the samples of one frequency ω, taken in order.
pub struct PhaseWalk {
    w: f64,
    /// The last sample: its index, x, sin ωx and cos ωx.
    last: Cell<Option<(usize, f64, f64, f64)>>,
}

impl PhaseWalk {
    pub fn new(w: f64) -> PhaseWalk {
        PhaseWalk {
            w,
            last: Cell::new(None),
        }
    }

    /// (sin ωx, cos ωx) at sample `s` whose variable is `x`.
    #[inline]
    pub fn at(&self, s: usize, x: f64) -> (f64, f64) {
        let w = self.w;
        let (sin, cos) = match self.last.get() {
            Some((ls, lx, sin, cos)) if ls == s && lx == x => return (sin, cos),
            Some((ls, lx, sin, cos))
                if ls + 1 == s && !s.is_multiple_of(ANCHOR) && within_2(x, lx) =>
            {
                let phi = w * (x - lx);
                if phi.abs() <= MAX_STEP {
                    let (sp, cp) = small_sin_cos(phi);
                    (sin * cp + cos * sp, cos * cp - sin * sp)
                } else {
                    (w * x).sin_cos()
                }
            }
            _ => (w * x).sin_cos(),
        };
        self.last.set(Some((s, x, sin, cos)));
        (sin, cos)
    }
}

/// sin φ and cos φ for |φ| ≤ [`MAX_STEP`], from their Taylor series (Horner's scheme in φ²).
#[inline(always)]
fn small_sin_cos(phi: f64) -> (f64, f64) {
    let p2 = phi * phi;
    let s = phi
        + phi
            * p2
            * (-1.0 / 6.0
                + p2 * (1.0 / 120.0
                    + p2 * (-1.0 / 5040.0
                        + p2 * (1.0 / 362_880.0
                            + p2 * (-1.0 / 39_916_800.0 + p2 * (1.0 / 6_227_020_800.0))))));
    let c = 1.0
        + p2 * (-0.5
            + p2 * (1.0 / 24.0
                + p2 * (-1.0 / 720.0
                    + p2 * (1.0 / 40_320.0
                        + p2 * (-1.0 / 3_628_800.0
                            + p2 * (1.0 / 479_001_600.0 + p2 * (-1.0 / 87_178_291_200.0)))))));
    (s, c)
}

/// Whether a − b is exact (Sterbenz: b/2 ≤ a ≤ 2b, the same sign, neither 0).
#[inline]
fn within_2(a: f64, b: f64) -> bool {
    (a > 0.0 && b > 0.0 || a < 0.0 && b < 0.0)
        && a.abs() <= 2.0 * b.abs()
        && b.abs() <= 2.0 * a.abs()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// A line pass as the simulator samples it (positions x0 + v·t at a constant rate,
    /// each rounded on its own, then a reversal and a second pass), a dwell (repeated
    /// positions), a circle's axis position (x = c + R cos(t): the step changes at every
    /// sample), a pass through 0 and a jump: every value within 10⁻¹³ of the direct
    /// sin/cos (the direct argument's own rounding is 10⁻¹⁴ here), the anchors and the
    /// repeated samples exactly equal to it, and most samples by rotation (which a walk
    /// that always evaluated directly would not show: the count of samples whose values
    /// differ from the direct ones is checked).
    #[test]
    fn walk_follows_the_direct_values() {
        let w = 2.0 * PI / 10.0;
        let mut xs: Vec<f64> = (0..3000)
            .map(|i| -50.0 + 8.33 * (i as f64 / 102.0))
            .collect();
        let top = *xs.last().unwrap();
        xs.extend((0..500).map(|i| top - 8.33 * (i as f64 / 102.0)));
        xs.extend(std::iter::repeat_n(xs[xs.len() - 1], 40));
        xs.extend((0..2000).map(|i| 80.0 + 60.0 * (i as f64 * 1.3e-3).cos()));
        xs.extend((0..800).map(|i| 123.456 + 0.25 * i as f64));
        let walk = PhaseWalk::new(w);
        let mut rotated = 0;
        for (s, &x) in xs.iter().enumerate() {
            let (sd, cd) = (w * x).sin_cos();
            let (sw, cw) = walk.at(s, x);
            assert!(
                (sw - sd).abs() <= 1e-13 && (cw - cd).abs() <= 1e-13,
                "sample {s}"
            );
            if s.is_multiple_of(ANCHOR) {
                assert_eq!((sw.to_bits(), cw.to_bits()), (sd.to_bits(), cd.to_bits()));
            }
            rotated += usize::from(sw != sd || cw != cd);
            // The same sample again: the same values.
            assert_eq!(walk.at(s, x), (sw, cw));
        }
        assert!(
            rotated > xs.len() / 4,
            "{rotated} of {} by rotation",
            xs.len()
        );
        // A sample that does not follow the one before is evaluated directly.
        let x = 77.7;
        assert_eq!(walk.at(10, x), (w * x).sin_cos());
    }

    /// The series against glibc's sin and cos over the range it is used on.
    #[test]
    fn small_angles() {
        for i in -1000..=1000 {
            let phi = MAX_STEP * i as f64 / 1000.0;
            let (s, c) = small_sin_cos(phi);
            assert!(
                (s - phi.sin()).abs() <= 2.0 * f64::EPSILON * phi.abs(),
                "{phi}"
            );
            assert!((c - phi.cos()).abs() <= 2.0 * f64::EPSILON, "{phi}");
        }
    }

    #[test]
    fn sterbenz_condition() {
        assert!(within_2(1.0, 2.0) && within_2(-3.0, -2.0));
        assert!(!within_2(1.0, 2.5) && !within_2(-1.0, 1.0) && !within_2(0.0, 0.0));
    }
}
