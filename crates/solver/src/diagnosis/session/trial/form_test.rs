//! The lack-of-fit test of a one-column effect's form on its own support, and the
//! spread between its places (DerSimonian & Laird 1986).

use crate::diagnosis::catalogue;
use crate::diagnosis::session::context::{Ctx, State};
use crate::diagnosis::session::trial::Trial;

/// The lack-of-fit test of a one-column effect's form on its own support
/// ([`Ctx::form_test`]).
pub(crate) struct FormTest {
    /// χ² = (SSR of the effect − SSR with a coefficient per place)/σ².
    pub chi2: f64,
    /// Its degrees of freedom: the places where the column varies, less one.
    pub dof: usize,
    /// Its p-value (upper tail of χ² with `dof` degrees of freedom).
    pub p: f64,
    /// Per place: its name, the coefficient there and its σ.
    pub places: Vec<(String, f64, f64)>,
}

impl FormTest {
    /// The spread between the places beyond their own σ: the DerSimonian–Laird estimate
    /// of a random-effects model (DerSimonian & Laird 1986; the "dark uncertainty" of an
    /// interlaboratory comparison). With weights wᵢ = 1/σᵢ², the weighted mean x̄ and
    /// Q = Σ wᵢ(xᵢ − x̄)², τ² = max(0, (Q − (k − 1)) / (Σwᵢ − Σwᵢ²/Σwᵢ)), in the
    /// coefficient's units squared. Where the places read the effect differently (a
    /// delay whose circles read it lower than its lines), τ² is how much one figure for
    /// all places is uncertain by that disagreement. Where the form holds, Q is about
    /// χ²(k − 1) and τ² is 0 in about half the checks; in the others it is of the order of
    /// the less precise places' σ², which makes the one figure's σ conservative (the
    /// coverage table's sharp direction couplings: z spread 0.7).
    pub fn between_places_variance(&self) -> f64 {
        let (w, sw, mean) = self.weighted_mean();
        if self.places.len() < 2 || !(sw.is_finite() && sw > 0.0) {
            return 0.0;
        }
        let q: f64 = self
            .places
            .iter()
            .zip(&w)
            .map(|(p, w)| w * (p.1 - mean).powi(2))
            .sum();
        let c = sw - w.iter().map(|w| w * w).sum::<f64>() / sw;
        ((q - (self.places.len() - 1) as f64) / c).max(0.0)
    }

    /// The places' spread beyond their σ relative to the one coefficient:
    /// √τ² ([`FormTest::between_places_variance`]) over |x̄|, x̄ the places' mean weighted by
    /// 1/σᵢ² (infinite where x̄ is 0 or the places are not at hand).
    pub fn relative_spread(&self) -> f64 {
        let r = self.between_places_variance().sqrt() / self.weighted_mean().2.abs();
        if r.is_finite() { r } else { f64::INFINITY }
    }

    /// The places' weights wᵢ = 1/σᵢ², their sum and the weighted mean x̄.
    fn weighted_mean(&self) -> (Vec<f64>, f64, f64) {
        let w: Vec<f64> = self.places.iter().map(|p| 1.0 / (p.2 * p.2)).collect();
        let sw: f64 = w.iter().sum();
        let mean = self
            .places
            .iter()
            .zip(&w)
            .map(|(p, w)| w * p.1)
            .sum::<f64>()
            / sw;
        (w, sw, mean)
    }
}

/// The lack-of-fit χ² of a split model against the one it refines (sums of squares
/// `ssr` and `split_ssr`, σ of the residual) and its upper-tail p-value on `dof`
/// degrees of freedom.
pub(super) fn lack_of_fit(ssr: f64, split_ssr: f64, sigma: f64, dof: usize) -> Option<(f64, f64)> {
    let chi2 = ((ssr - split_ssr) / (sigma * sigma)).max(0.0);
    let p = statrs::distribution::ChiSquared::new(dof as f64)
        .map(|c| 1.0 - statrs::distribution::ContinuousCDF::cdf(&c, chi2))
        .ok()?;
    Some((chi2, p))
}

impl Ctx<'_> {
    /// The trial's one column fitted with a coefficient per place instead
    /// ([`catalogue::split`]: lines or circles, near or beyond the axis's reversals), on
    /// all runs: where the effect's form holds, the drop of the sum of squares is σ²
    /// times a χ² with (places − 1) degrees of freedom. `None` for an effect of more
    /// than one column, or whose column varies in one place only.
    pub fn form_test(&self, s: &State, t: &Trial, sigma: f64) -> Option<FormTest> {
        let th = t.theta.map_or(0.0, |x| x.1);
        let specs = catalogue::split(self.d, &t.cand, th, self.eps(s))?;
        let (_, keep, jf) = self.evaluate(&s.fit, &specs, false)?;
        // The places' columns, not the nuisance ones that follow them.
        let n_places = catalogue::SPLIT_PLACES.len();
        let at_places = keep.iter().filter(|&&j| j < n_places).count();
        let dof = at_places.checked_sub(1).filter(|&k| k > 0)?;
        let (chi2, p) = lack_of_fit(t.ssr, jf.all.ssr, sigma, dof)?;
        let places = keep
            .iter()
            .enumerate()
            .filter(|&(_, &j)| j < n_places)
            .map(|(i, &j)| {
                let name = catalogue::SPLIT_PLACES[j].to_string();
                (name, jf.all.x[i], jf.all.sd[i] * sigma)
            })
            .collect();
        Some(FormTest {
            chi2,
            dof,
            p,
            places,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::FormTest;

    fn places(v: &[(f64, f64)]) -> FormTest {
        FormTest {
            chi2: 0.0,
            dof: v.len() - 1,
            p: 1.0,
            places: v.iter().map(|&(x, s)| ("place".into(), x, s)).collect(),
        }
    }

    /// DerSimonian–Laird by hand: four places 1, 2, 3, 4 with σ = 0.5 (w = 4): x̄ = 2.5,
    /// Q = 4·(2.25 + 0.25 + 0.25 + 2.25) = 20, C = 16 − 64/16 = 12, τ² = (20 − 3)/12.
    /// Places that agree within their σ (Q below its degrees of freedom) add nothing.
    #[test]
    fn the_spread_between_places_is_the_dersimonian_laird_variance() {
        let t = places(&[(1.0, 0.5), (2.0, 0.5), (3.0, 0.5), (4.0, 0.5)]);
        assert!((t.between_places_variance() - 17.0 / 12.0).abs() < 1e-12);
        let agree = places(&[(1.0, 0.5), (1.2, 0.5), (0.9, 0.4), (1.1, 0.6)]);
        assert_eq!(agree.between_places_variance(), 0.0);
        // Unequal weights: the precise places pull the mean, the spread is still found.
        let t = places(&[(3.0, 0.002), (2.99, 0.001), (2.97, 0.001), (2.99, 0.004)]);
        let tau = t.between_places_variance().sqrt();
        assert!(tau > 0.005 && tau < 0.02, "{tau}");
    }

    /// The spread relative to the weighted mean: a delay read alike on lines and circles
    /// within 10 % (the ramps' second order) against a lost motion read as a delay, whose
    /// places differ by the feeds' ratio (lines at 500, circles at 2000 mm/min: 4×).
    #[test]
    fn the_relative_spread_tells_a_feed_dependence() {
        let delay = places(&[
            (1.001, 0.004),
            (1.031, 0.008),
            (1.003, 0.001),
            (0.893, 0.009),
        ]);
        let r = delay.relative_spread();
        assert!(r > 0.02 && r < 0.1, "{r}");
        let lost_motion = places(&[(0.36, 0.002), (0.40, 0.004), (0.09, 0.001), (0.6, 0.01)]);
        assert!(lost_motion.relative_spread() > 0.5);
        assert_eq!(
            places(&[(0.0, 0.1), (0.0, 0.1)]).relative_spread(),
            f64::INFINITY
        );
    }
}
