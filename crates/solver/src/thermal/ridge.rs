//! Ridge regression with an unpenalised intercept, from the thin QR of [1 | X | y].
//!
//! With the triangular factor R of [1 | X] and Qᵀy (a [`Reduced`] problem), the first
//! row holds the intercept and the trailing block R₂₂ is the factor of the centred
//! columns X − 1x̄ᵀ (Householder's first reflection makes the other columns orthogonal to
//! 1), with right-hand side (Qᵀy)₂. Columns are scaled to unit norm, D = their norms
//! (those of the centred columns; QR keeps column norms), and R₂₂D⁻¹ = U S Vᵀ. Then for a
//! penalty λ on the scaled coefficients:
//!
//! * b = D⁻¹ V diag(sᵢ/(sᵢ² + λ)) Uᵀ (Qᵀy)₂ (minimises ‖y_c − X_c b‖² + λ‖Db‖²);
//! * c = ((Qᵀy)₁ − R₁₂ b)/R₁₁ (the intercept, unpenalised);
//! * edf = Σ sᵢ²/(sᵢ² + λ), the effective number of parameters (plus one for c);
//! * cov(b) = σ² D⁻¹ V diag(sᵢ²/(sᵢ² + λ)²) Vᵀ D⁻¹ (variance only; the ridge bias is
//!   not included).
//!
//! Hoerl & Kennard (1970); Hastie, Tibshirani & Friedman, *The Elements of Statistical
//! Learning*, 2nd ed., section 3.4.1 (the SVD form and the effective degrees of freedom).

use crate::lsq::Reduced;
use faer::Mat;

/// The SVD of a reduced ridge problem, ready for any λ.
#[derive(Debug, Clone)]
pub struct RidgeSvd {
    s: Vec<f64>,
    /// V (p × p), columns the right singular vectors.
    v: Mat<f64>,
    /// Uᵀ (Qᵀy)₂.
    uty: Vec<f64>,
    norms: Vec<f64>,
    r11: f64,
    r12: Vec<f64>,
    qty1: f64,
}

impl RidgeSvd {
    /// From the reduction of [1 | X] with right-hand side y (column 0 the intercept).
    pub fn new(red: &Reduced) -> RidgeSvd {
        let k = red.r.ncols();
        let p = k - 1;
        let norms: Vec<f64> = (1..k)
            .map(|j| {
                let n = (1..k).map(|i| red.r[(i, j)].powi(2)).sum::<f64>().sqrt();
                if n > 0.0 { n } else { 1.0 }
            })
            .collect();
        let m = Mat::<f64>::from_fn(p, p, |i, j| red.r[(i + 1, j + 1)] / norms[j]);
        let svd = m.svd().expect("SVD of a small dense matrix converges");
        crate::upper_state::clear();
        let s: Vec<f64> = (0..p).map(|i| svd.S().column_vector()[i]).collect();
        let u = svd.U();
        let uty = (0..p)
            .map(|c| (0..p).map(|i| u[(i, c)] * red.qtb[i + 1]).sum())
            .collect();
        RidgeSvd {
            s,
            v: svd.V().to_owned(),
            uty,
            norms,
            r11: red.r[(0, 0)],
            r12: (1..k).map(|j| red.r[(0, j)]).collect(),
            qty1: red.qtb[0],
        }
    }

    /// Intercept and coefficients (original units) at penalty `lambda`.
    pub fn coefficients(&self, lambda: f64) -> (f64, Vec<f64>) {
        let p = self.s.len();
        let mut b = vec![0.0; p];
        for c in 0..p {
            let w = self.s[c] / (self.s[c] * self.s[c] + lambda) * self.uty[c];
            for (j, bj) in b.iter_mut().enumerate() {
                *bj += self.v[(j, c)] * w;
            }
        }
        for (bj, n) in b.iter_mut().zip(&self.norms) {
            *bj /= n;
        }
        let c = if self.r11 != 0.0 {
            (self.qty1 - self.r12.iter().zip(&b).map(|(r, v)| r * v).sum::<f64>()) / self.r11
        } else {
            0.0
        };
        (c, b)
    }

    /// Effective number of penalised parameters Σ s²/(s² + λ).
    pub fn edf(&self, lambda: f64) -> f64 {
        self.s.iter().map(|s| s * s / (s * s + lambda)).sum()
    }

    /// Covariance of the coefficients (original units) for residual variance `sigma2`.
    pub fn covariance(&self, lambda: f64, sigma2: f64) -> Mat<f64> {
        let p = self.s.len();
        let w: Vec<f64> = self
            .s
            .iter()
            .map(|s| (s / (s * s + lambda)).powi(2))
            .collect();
        Mat::<f64>::from_fn(p, p, |a, b| {
            let acc: f64 = (0..p).map(|c| self.v[(a, c)] * self.v[(b, c)] * w[c]).sum();
            sigma2 * acc / (self.norms[a] * self.norms[b])
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lsq::QrAccumulator;

    /// One centred regressor: the ridge slope has the closed form b = Sxy/(Sxx + λ·Sxx)
    /// in unit-norm coordinates (λ on the scaled coefficient b·√Sxx), i.e.
    /// b = Sxy/(Sxx(1 + λ)); the intercept ȳ − b x̄; edf = 1/(1 + λ). λ = 0 is least
    /// squares.
    #[test]
    fn one_regressor_matches_the_closed_form() {
        let x: Vec<f64> = (0..50).map(|i| 3.0 + 0.2 * f64::from(i)).collect();
        let y: Vec<f64> = x
            .iter()
            .enumerate()
            .map(|(i, v)| 1.5 - 0.8 * v + if i % 2 == 0 { 0.1 } else { -0.1 })
            .collect();
        let mut acc = QrAccumulator::new(2);
        for (a, b) in x.iter().zip(&y) {
            acc.push(&[1.0, *a], *b);
        }
        let svd = RidgeSvd::new(&acc.finish());
        let n = x.len() as f64;
        let (xm, ym) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
        let sxx: f64 = x.iter().map(|v| (v - xm).powi(2)).sum();
        let sxy: f64 = x.iter().zip(&y).map(|(a, b)| (a - xm) * (b - ym)).sum();
        for lambda in [0.0, 0.3, 2.0] {
            let (c, b) = svd.coefficients(lambda);
            let want = sxy / (sxx * (1.0 + lambda));
            assert!((b[0] - want).abs() < 1e-12, "{lambda}: {} vs {want}", b[0]);
            assert!((c - (ym - want * xm)).abs() < 1e-10);
            assert!((svd.edf(lambda) - 1.0 / (1.0 + lambda)).abs() < 1e-12);
            // Variance: σ² Sxx/(Sxx(1+λ))² = σ²/(Sxx (1+λ)²).
            let v = svd.covariance(lambda, 2.0)[(0, 0)];
            assert!((v - 2.0 / (sxx * (1.0 + lambda).powi(2))).abs() < 1e-12 * v.max(1.0));
        }
    }
}
