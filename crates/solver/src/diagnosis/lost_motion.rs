//! Lost motion that varies along the travel: the reversal error of an axis as a function
//! of its position, as ISO 230-2's reversal value B_i varies from target to target.
//!
//! Physics: a screw worn where the axis works most (more clearance there), a lead error
//! of a preloaded double nut, a coupling or a bearing whose stiffness varies with the
//! load along the travel: the lost motion at a reversal depends on where it happens.
//!
//! **Model** (the one both kinds of recording fit; sign convention of `backlash`,
//! [`super::effects`]): with d the sign of the axis's travel (approach direction) and q its
//! position,
//!
//! error = −d·b(q)/2, b(q) = Σ_{k=0..K} b_k P_k(s), s = (q − q_c)/h,
//!
//! P_k the Legendre polynomials and s the measured travel [q_c − h, q_c + h] mapped onto
//! [−1, 1] (nothing is evaluated outside it). b > 0 where the axis stops short of its
//! target in the direction of travel; ISO 230-2's B_i = x̄_i↑ − x̄_i↓ = −b(P_i). K = 0 is
//! the constant `backlash`. The columns are linear in b_k; their standard uncertainties
//! give the profile's at any position, σ²(b(q)) = pᵀ C p with p_k = P_k(s(q)) and C the
//! covariance of the b_k.

use crate::basis::legendre;
use nalgebra::DMatrix;

/// The travel [lo, hi] the model is written on, and its order K.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Profile {
    pub lo: f64,
    pub hi: f64,
    pub order: usize,
}

impl Profile {
    /// s of a position (module docs).
    pub fn s(&self, q: f64) -> f64 {
        (q - 0.5 * (self.lo + self.hi)) / (0.5 * (self.hi - self.lo))
    }

    /// P_k(s(q)), k = 0..=K.
    pub fn basis_at(&self, q: f64) -> Vec<f64> {
        let s = self.s(q);
        (0..=self.order).map(|k| legendre(k, s).0).collect()
    }

    /// The model's columns at readings of direction signs `d` (±1) and positions `q`:
    /// column k is −d·P_k(s)/2, named `b{k}`.
    pub fn columns(&self, d: &[f64], q: &[f64]) -> Vec<(String, Vec<f64>)> {
        let basis: Vec<Vec<f64>> = q.iter().map(|&v| self.basis_at(v)).collect();
        (0..=self.order)
            .map(|k| {
                (
                    format!("b{k}"),
                    d.iter()
                        .zip(&basis)
                        .map(|(dd, p)| -0.5 * dd * p[k])
                        .collect(),
                )
            })
            .collect()
    }

    /// b(q) and its standard uncertainty at each of `q`, from the coefficients b_k and
    /// their covariance `cov` (K + 1 square).
    pub fn at(&self, coef: &[f64], cov: &DMatrix<f64>, q: &[f64]) -> Vec<(f64, f64)> {
        q.iter()
            .map(|&v| {
                let p = self.basis_at(v);
                let b: f64 = p.iter().zip(coef).map(|(a, c)| a * c).sum();
                let mut var = 0.0;
                for i in 0..p.len() {
                    for j in 0..p.len() {
                        var += p[i] * cov[(i, j)] * p[j];
                    }
                }
                (b, var.max(0.0).sqrt())
            })
            .collect()
    }

    /// The mean of b over the points `q`, with its standard uncertainty: p̄ᵀb ± √(p̄ᵀ C p̄),
    /// p̄ the mean of the basis over the points.
    pub fn mean(&self, coef: &[f64], cov: &DMatrix<f64>, q: &[f64]) -> (f64, f64) {
        let m = q.len().max(1) as f64;
        let basis: Vec<Vec<f64>> = q.iter().map(|&v| self.basis_at(v)).collect();
        let pm: Vec<f64> = (0..=self.order)
            .map(|k| basis.iter().map(|p| p[k]).sum::<f64>() / m)
            .collect();
        let mean = pm.iter().zip(coef).map(|(a, b)| a * b).sum();
        let mut var = 0.0;
        for i in 0..pm.len() {
            for j in 0..pm.len() {
                var += pm[i] * cov[(i, j)] * pm[j];
            }
        }
        (mean, var.max(0.0).sqrt())
    }

    /// The variation of b along the points `q`: the RMS of b(q_i) − mean b over them,
    /// with its standard uncertainty (first order in the coefficients). The square of the
    /// estimated RMS exceeds the true one's by the mean variance of the deviations,
    /// E[v̂²] = v² + tr(C_c)/m (C_c their covariance at the m points), which is
    /// subtracted: v = √max(v̂² − tr(C_c)/m, 0) (without it, a variation of a few σ read
    /// about 2σ high with a profile of high order). Where nothing is left, v = 0 with the
    /// σ of the deviations, √(tr(C_c)/m).
    pub fn variation(&self, coef: &[f64], cov: &DMatrix<f64>, q: &[f64]) -> (f64, f64) {
        let m = q.len().max(1) as f64;
        let basis: Vec<Vec<f64>> = q.iter().map(|&v| self.basis_at(v)).collect();
        let mean_p: Vec<f64> = (0..=self.order)
            .map(|k| basis.iter().map(|p| p[k]).sum::<f64>() / m)
            .collect();
        // Centred rows: c_i = p_i − mean p; dev_i = c_i · b.
        let centred: Vec<Vec<f64>> = basis
            .iter()
            .map(|p| p.iter().zip(&mean_p).map(|(a, b)| a - b).collect())
            .collect();
        let dev: Vec<f64> = centred
            .iter()
            .map(|c| c.iter().zip(coef).map(|(a, b)| a * b).sum())
            .collect();
        let quad = |c: &[f64]| {
            let mut var = 0.0;
            for i in 0..c.len() {
                for j in 0..c.len() {
                    var += c[i] * cov[(i, j)] * c[j];
                }
            }
            var
        };
        let noise = centred.iter().map(|c| quad(c)).sum::<f64>() / m;
        let v2 = dev.iter().map(|x| x * x).sum::<f64>() / m - noise;
        if v2 <= 0.0 {
            return (0.0, noise.max(0.0).sqrt());
        }
        let v = v2.sqrt();
        // ∂v/∂b = Σ_i dev_i c_i / (m v)
        let grad: Vec<f64> = (0..=self.order)
            .map(|k| centred.iter().zip(&dev).map(|(c, d)| d * c[k]).sum::<f64>() / (m * v))
            .collect();
        (v, quad(&grad).max(0.0).sqrt())
    }
}

/// How the constant part (the mean lost motion `mean`) and the part varying along the
/// travel (`v`, RMS about the mean) share the reversal error's squares at the points, in
/// words: whether a constant backlash explains most of it and a position-dependent part
/// remains, or the lost motion is mostly position-dependent.
pub fn shares(mean: f64, v: f64) -> String {
    let share = mean * mean / (mean * mean + v * v).max(1e-300);
    format!(
        "the constant part (mean lost motion {mean:+.3} µm) carries {:.0} % of the reversal's squares at the targets, the part varying along the travel ({v:.3} µm RMS) {:.0} %{}",
        100.0 * share,
        100.0 * (1.0 - share),
        if share >= 0.5 {
            ": a constant backlash explains most of it and a position-dependent part remains"
        } else {
            ": the lost motion is mostly position-dependent"
        }
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Worked by hand on the travel [0, 100]: K = 1, b(q) = 4 + 2 s, so b = 2, 4, 6 at
    /// q = 0, 50, 100; a + approach at q = 100 gets the column values −1/2, −1/2 (error
    /// −3 µm), a − approach at q = 0 +1/2, −1/2 (error +1 µm). Variation over the three
    /// targets: √((4 + 0 + 4)/3).
    #[test]
    fn columns_and_profile_by_hand() {
        let p = Profile {
            lo: 0.0,
            hi: 100.0,
            order: 1,
        };
        let cols = p.columns(&[1.0, -1.0], &[100.0, 0.0]);
        assert_eq!(cols[0].1, vec![-0.5, 0.5]);
        assert_eq!(cols[1].1, vec![-0.5, -0.5]);
        let cov = DMatrix::from_row_slice(2, 2, &[0.01, 0.0, 0.0, 0.04]);
        let at = p.at(&[4.0, 2.0], &cov, &[0.0, 50.0, 100.0]);
        assert!((at[0].0 - 2.0).abs() < 1e-12 && (at[2].0 - 6.0).abs() < 1e-12);
        assert!((at[0].1 - 0.05f64.sqrt()).abs() < 1e-12, "{at:?}");
        let (v, sv) = p.variation(&[4.0, 2.0], &cov, &[0.0, 50.0, 100.0]);
        // The deviations 2s (s = −1, 0, 1) have variance 0.04·s², mean 0.08/3: v² =
        // 8/3 − 0.08/3; ∂v/∂b₁ = Σ 2s²/(3v) = 4/(3v), so σ = 0.2·4/(3v).
        let want = (8.0f64 / 3.0 - 0.08 / 3.0).sqrt();
        assert!((v - want).abs() < 1e-12, "{v}");
        assert!((sv - 0.2 * 4.0 / (3.0 * want)).abs() < 1e-12, "{sv}");
        // Nothing left beyond the deviations' own variance: v = 0, σ their RMS σ.
        let (v, sv) = p.variation(&[4.0, 0.1], &cov, &[0.0, 50.0, 100.0]);
        assert!(
            v == 0.0 && (sv - (0.08f64 / 3.0).sqrt()).abs() < 1e-12,
            "{v} {sv}"
        );
    }
}
