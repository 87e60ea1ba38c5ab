//! A logged temperature as a measurement with noise of its own, not an exact regressor.
//!
//! The per-run zero offsets of a session leave only the change of the temperature
//! within each run; when that change is not large against the sensor's noise, a
//! coefficient fitted on the raw log is attenuated toward zero (errors in variables:
//! E[ĉ] = c·S/(S + N), S the within-run variance of the true temperature, N the
//! sensor's). The log is therefore smoothed first with a model of its own: a Legendre
//! polynomial in session time, P₀…P_p of τ = (t − t_mid)/t_half, fitted by least
//! squares (Householder QR, faer) with its order p ≤ [`MAX_ORDER`] chosen by the
//! Bayesian information criterion, n·ln(SSR_p/n) + (p + 1)·ln n, and the sensor's noise
//! estimated from the residual, σ_T² = SSR_p/(n − p − 1). The smoothed temperature
//! T̂ = Q_p·Q_pᵀ·T has an error Q_p·Q_pᵀ·ε of covariance σ_T²·Q_p·Q_pᵀ, whose effect on
//! the fitted coefficients is propagated by [`Smoother::coefficient_cov`]: with G the
//! Gram matrix of the centred temperature columns and B their cross-products with the
//! fitted growth times the smoother's basis, cov(δβ) = σ_T²·G⁻¹·B·Bᵀ·G⁻¹. Where the
//! within-run change is small against that, the coefficients' σ grow and the
//! determined rule (`effects::determined`) reports them undetermined.

use crate::basis::Legendre;
use nalgebra::{DMatrix, DVector};

/// Highest polynomial order of the smoother (a temperature that turns more than about a
/// dozen times in a session is not followed: `Smoother::follows` says so).
pub const MAX_ORDER: usize = 24;

/// The smoother of a session's logged temperature.
#[derive(Debug, Clone)]
pub struct Smoother {
    mid: f64,
    half: f64,
    /// Chosen polynomial order p.
    pub order: usize,
    /// Leading (p + 1) × (p + 1) block of the R factor of the Legendre columns.
    r: DMatrix<f64>,
    /// Legendre coefficients of the smoothed temperature (K).
    coef: Vec<f64>,
    /// The sensor's noise estimated from the residual (K per sample).
    pub noise_k: f64,
    /// The smoothed temperature at the first sample: [`Smoother::delta`]'s zero.
    zero: f64,
    /// Whether the residual is as rough as the sensor's noise: its RMS is within 1.5×
    /// the noise estimated from successive differences within runs (σ² = mean(Δ²)/2).
    /// When not, the polynomial does not follow the temperature and the coefficients
    /// fitted on it are reported undetermined.
    pub follows: bool,
}

impl Smoother {
    /// Fits the smoother to the temperatures `temp` (K) logged at times `t_s`; `runs`
    /// gives the sample ranges of the runs (for the difference-based noise estimate).
    pub fn fit(t_s: &[f64], temp: &[f64], runs: &[std::ops::Range<usize>]) -> Smoother {
        let n = t_s.len();
        let (lo, hi) = t_s
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &t| {
                (l.min(t), h.max(t))
            });
        let mid = 0.5 * (lo + hi);
        let half = (0.5 * (hi - lo)).max(1e-9);
        let pmax = MAX_ORDER.min((n / 10).saturating_sub(1));
        let k = pmax + 1;
        let mean = temp.iter().sum::<f64>() / n.max(1) as f64;
        // [P₀ … P_pmax | T − mean] column-major, each Legendre column from the two
        // before it (`Legendre`'s recurrence, column by column).
        let mut a = vec![0.0; n * (k + 1)];
        for j in 0..k {
            let (done, col) = a.split_at_mut(j * n);
            let col = &mut col[..n];
            match j {
                0 => col.fill(1.0),
                1 => col
                    .iter_mut()
                    .zip(t_s)
                    .for_each(|(p, &t)| *p = (t - mid) / half),
                _ => {
                    let nf = (j - 1) as f64;
                    let (s, p2) = (&done[n..2 * n], &done[(j - 2) * n..(j - 1) * n]);
                    let p1 = &done[(j - 1) * n..j * n];
                    for (i, p) in col.iter_mut().enumerate() {
                        *p = ((2.0 * nf + 1.0) * s[i] * p1[i] - nf * p2[i]) / (nf + 1.0);
                    }
                }
            }
        }
        for (v, &y) in a[k * n..].iter_mut().zip(temp) {
            *v = y - mean;
        }
        // Householder QR in place (faer's, as `Mat::qr` runs it on its copy): R is the
        // upper triangle of the first k + 1 rows.
        {
            use faer::dyn_stack::{MemBuffer, MemStack};
            use faer::linalg::qr::no_pivoting::factor;
            let (par, size) = (faer::get_global_parallelism(), n.min(k + 1));
            let block = factor::recommended_block_size::<f64>(n, k + 1);
            let mut coeff = faer::Mat::<f64>::zeros(block, size);
            let scratch =
                factor::qr_in_place_scratch::<f64>(n, k + 1, block, par, Default::default());
            factor::qr_in_place(
                faer::MatMut::from_column_major_slice_mut(&mut a, n, k + 1),
                coeff.as_mut(),
                par,
                MemStack::new(&mut MemBuffer::new(scratch)),
                Default::default(),
            );
            crate::upper_state::clear();
        }
        let rf = |i: usize, j: usize| if i <= j { a[j * n + i] } else { 0.0 };
        // SSR of order p: the tail of Qᵀy below p, plus the final residual.
        let tail: Vec<f64> = (0..=k).map(|j| rf(j.min(k), k).powi(2)).collect();
        let nn = n as f64;
        let ssr_of = |p: usize| tail[p + 1..].iter().sum::<f64>().max(1e-300);
        let order = (0..k)
            .min_by(|&p, &q| {
                let bic = |p: usize| nn * (ssr_of(p) / nn).ln() + (p + 1) as f64 * nn.ln();
                bic(p).total_cmp(&bic(q))
            })
            .unwrap_or(0);
        let m = order + 1;
        let r = DMatrix::from_fn(m, m, &rf);
        let qty = DVector::from_fn(m, |i, _| rf(i, k));
        let mut coef = r
            .solve_upper_triangular(&qty)
            .map(|c| c.as_slice().to_vec())
            .unwrap_or_else(|| vec![0.0; m]);
        coef[0] += mean;
        let noise_k = (ssr_of(order) / (nn - m as f64).max(1.0)).sqrt();
        let (mut d2, mut nd) = (0.0, 0usize);
        for run in runs {
            for i in run.start + 1..run.end {
                d2 += (temp[i] - temp[i - 1]).powi(2);
                nd += 1;
            }
        }
        let diff_noise = (d2 / (2.0 * nd.max(1) as f64)).sqrt();
        let mut s = Smoother {
            mid,
            half,
            order,
            r,
            coef,
            noise_k,
            zero: 0.0,
            follows: noise_k <= 1.5 * diff_noise + 1e-9,
        };
        s.zero = t_s.first().map_or(0.0, |&t| s.value(t));
        s
    }

    /// The smoothed temperature at time `t` minus that at the first sample (K).
    pub fn delta(&self, t: f64) -> f64 {
        self.value(t) - self.zero
    }

    /// [`Smoother::delta`] at every time of `t_s`, the same values: the Legendre terms
    /// by the same recurrence, one term at a time over all the times, each time's sum
    /// taken in the terms' order.
    pub fn deltas(&self, t_s: &[f64]) -> Vec<f64> {
        let s: Vec<f64> = t_s.iter().map(|&t| self.tau(t)).collect();
        // `Iterator::sum`'s start for f64 (−0.0, the neutral element of +).
        let mut acc = vec![-0.0; s.len()];
        let (mut p_prev, mut p) = (vec![1.0; s.len()], s.clone());
        for (k, &c) in self.coef.iter().enumerate() {
            match k {
                0 => acc.iter_mut().for_each(|a| *a += 1.0 * c),
                1 => acc.iter_mut().zip(&p).for_each(|(a, p)| *a += p * c),
                _ => {
                    let nf = (k - 1) as f64;
                    for (((a, p), q), s) in acc.iter_mut().zip(&mut p).zip(&mut p_prev).zip(&s) {
                        let next = ((2.0 * nf + 1.0) * s * *p - nf * *q) / (nf + 1.0);
                        (*q, *p) = (*p, next);
                        *a += next * c;
                    }
                }
            }
        }
        acc.iter().map(|a| a - self.zero).collect()
    }

    fn tau(&self, t: f64) -> f64 {
        (t - self.mid) / self.half
    }

    /// The smoothed temperature at time `t` (K).
    pub fn value(&self, t: f64) -> f64 {
        Legendre::new(self.tau(t))
            .zip(&self.coef)
            .map(|((p, _), c)| p * c)
            .sum()
    }

    /// The smoothed temperature change ΔT̂ passed through a first-order lag of time
    /// constant `tau` (s): the temperature of a structure that follows its sensor's
    /// with the response τ·dT_s/dt = ΔT̂ − T_s, at the times `t_s` (any order), in
    /// equilibrium with the sensor at the first time. Integrated exactly for an input
    /// linear between successive times (steps of at most 1 s through gaps):
    /// T_s(t + h) = u₁ − rτ + (T_s(t) − u₀ + rτ)·e^(−h/τ), r = (u₁ − u₀)/h.
    pub fn lagged(&self, t_s: &[f64], tau: f64) -> Vec<f64> {
        self.lag_input(t_s).lagged(tau)
    }

    /// The input of [`Smoother::lagged`] at the times `t_s`, for any time constant: the
    /// steps and ΔT̂ at their ends, evaluated once.
    pub fn lag_input(&self, t_s: &[f64]) -> LagInput {
        let mut order: Vec<usize> = (0..t_s.len()).collect();
        if t_s.windows(2).any(|w| w[1] < w[0]) {
            order.sort_by(|&a, &b| t_s[a].total_cmp(&t_s[b]));
        }
        let mut input = LagInput {
            u0: 0.0,
            steps: Vec::with_capacity(t_s.len()),
            ends: Vec::with_capacity(t_s.len()),
        };
        let Some(&first) = order.first() else {
            return input;
        };
        let mut t0 = t_s[first];
        input.u0 = self.delta(t0);
        // The step times first, then the smoothed temperature at all of them.
        let mut times = Vec::with_capacity(t_s.len());
        for i in order {
            let t1 = t_s[i];
            let steps = ((t1 - t0) / 1.0).ceil().max(1.0);
            let h = (t1 - t0) / steps;
            for k in 1..=steps as usize {
                input.steps.push((h, 0.0));
                times.push(t0 + h * k as f64);
            }
            t0 = t1;
            input.ends.push((i, input.steps.len()));
        }
        for (step, u) in input.steps.iter_mut().zip(self.deltas(&times)) {
            step.1 = u;
        }
        input
    }

    /// Covariance of the coefficients β of a model fitted on columns made from the
    /// smoothed temperature, caused by the smoother's error δT̂ = L(t)ᵀ·δc (L the
    /// Legendre values, δc of covariance σ_T²·R⁻¹R⁻ᵀ): σ_T²·G⁻¹·B·Bᵀ·G⁻¹ with
    /// B = Zᵀ·diag(∂ŷ/∂T̂)·Q_p, Z the columns centred per group, ∂ŷ/∂T̂ the fitted
    /// growth's derivative with respect to the temperature at each row (Σ_k β_k w_k for
    /// columns ΔT̂·w_k; 2ΔT̂·w_k more for columns ΔT̂²·w_k). `groups` lists, per group of
    /// rows centred together (a run's component), its samples' times, column values and
    /// derivatives, made one at a time (a session's would hold every row's columns);
    /// `gram` is G. Returns `None` when G is singular.
    pub fn coefficient_cov(
        &self,
        groups: impl IntoIterator<Item = Group>,
        gram: &DMatrix<f64>,
    ) -> Option<DMatrix<f64>> {
        let kc = gram.nrows();
        let m = self.order + 1;
        let mut ba = DMatrix::<f64>::zeros(kc, m);
        let mut leg = vec![0.0; m];
        for g in groups {
            let n = g.t_s.len();
            if n == 0 {
                continue;
            }
            // Means of the columns over the group (the run offsets' centring).
            let means: Vec<f64> = (0..kc)
                .map(|k| (0..n).map(|i| g.z[i * kc + k]).sum::<f64>() / n as f64)
                .collect();
            for i in 0..n {
                let z = &g.z[i * kc..(i + 1) * kc];
                for (l, (p, _)) in leg.iter_mut().zip(Legendre::new(self.tau(g.t_s[i]))) {
                    *l = p * g.growth[i];
                }
                for k in 0..kc {
                    let zc = z[k] - means[k];
                    if zc != 0.0 {
                        for (j, l) in leg.iter().enumerate() {
                            ba[(k, j)] += zc * l;
                        }
                    }
                }
            }
        }
        // B·Q-basis: B_A·R⁻¹ (Qᵀh = R⁻ᵀAᵀh).
        let bq = self
            .r
            .transpose()
            .solve_lower_triangular(&ba.transpose())?
            .transpose();
        let svd = gram.clone().svd(true, true);
        let smax = svd.singular_values.max();
        if svd.singular_values.min() <= 1e-12 * smax {
            return None;
        }
        let gb = svd.solve(&bq, 0.0).ok()?;
        Some(&gb * gb.transpose() * self.noise_k.powi(2))
    }
}

/// The input of a first-order lag ([`Smoother::lagged`]) at a set of times, for any
/// time constant: ΔT̂ at the first time, then every integration step (its length h and
/// ΔT̂ at its end) in time order.
pub struct LagInput {
    u0: f64,
    steps: Vec<(f64, f64)>,
    /// Per time asked, in time order: its index among the times and the number of steps
    /// up to it.
    ends: Vec<(usize, usize)>,
}

impl LagInput {
    /// The lag's output at the times asked, for time constant `tau` (s).
    pub fn lagged(&self, tau: f64) -> Vec<f64> {
        let mut out = vec![0.0; self.ends.len()];
        let tau = tau.max(1e-9);
        let (mut u0, mut y) = (self.u0, self.u0);
        // e^(−h/τ) of the last step length (runs are sampled at one rate).
        let mut decay = (f64::NAN, f64::NAN);
        let mut done = 0;
        for &(i, end) in &self.ends {
            for &(h, u1) in &self.steps[done..end] {
                if h > 0.0 {
                    if decay.0 != h {
                        decay = (h, (-h / tau).exp());
                    }
                    let r = (u1 - u0) / h;
                    y = u1 - r * tau + (y - u0 + r * tau) * decay.1;
                }
                u0 = u1;
            }
            done = end;
            out[i] = y;
        }
        out
    }
}

/// One group of rows centred together, for [`Smoother::coefficient_cov`].
pub struct Group {
    pub t_s: Vec<f64>,
    /// Row-major column values (before centring): sample i, column k at `i·K + k`.
    pub z: Vec<f64>,
    /// The fitted growth's derivative with respect to the temperature at each sample.
    pub growth: Vec<f64>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    fn sample(noise: f64, seed: u64) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        let e = Normal::new(0.0, noise).unwrap();
        let t: Vec<f64> = (0..4000).map(|i| i as f64 * 0.25).collect();
        let truth: Vec<f64> = t
            .iter()
            .map(|&t| 0.8 * (2.0 * std::f64::consts::PI * t / 1000.0).sin())
            .collect();
        let obs = truth.iter().map(|v| v + e.sample(&mut rng)).collect();
        (t, truth, obs)
    }

    /// A rise then a fall below the start, 5 mK noise: the smoother follows the truth
    /// within a tenth of the noise and estimates the noise within 5 %.
    #[test]
    fn follows_a_smooth_temperature_and_estimates_the_sensor_noise() {
        let (t, truth, obs) = sample(0.005, 3);
        let s = Smoother::fit(&t, &obs, std::slice::from_ref(&(0..t.len())));
        assert!(s.follows);
        assert!((s.noise_k / 0.005 - 1.0).abs() < 0.05, "{}", s.noise_k);
        let err = t
            .iter()
            .zip(&truth)
            .map(|(&t, v)| (s.value(t) - v).powi(2))
            .sum::<f64>()
            / t.len() as f64;
        assert!(err.sqrt() < 0.0005, "{}", err.sqrt());
    }

    /// The smoothed change at many times at once is the one at each time, bit for bit
    /// (the design's ΔT̂ and the lag's input take it), here at times inside and outside
    /// the logged span.
    #[test]
    fn deltas_are_delta_at_every_time() {
        let (t, _, obs) = sample(0.005, 7);
        let s = Smoother::fit(&t, &obs, std::slice::from_ref(&(0..t.len())));
        assert!(s.order >= 2, "{}", s.order);
        let ts: Vec<f64> = (0..500).map(|i| -20.0 + i as f64 * 2.17).collect();
        for (&t, d) in ts.iter().zip(s.deltas(&ts)) {
            assert_eq!(d.to_bits(), s.delta(t).to_bits(), "{t}");
        }
    }

    /// The lag of a ramp settles to the ramp delayed by τ (T_s = T̂ − τ·r), and of a
    /// sine to its amplitude 1/√(1 + (ωτ)²) and phase −atan(ωτ) (the textbook first-order
    /// response), within 1 % of the amplitude.
    #[test]
    fn lagged_follows_the_first_order_response() {
        let (t, _, obs) = sample(0.0, 5);
        let s = Smoother::fit(&t, &obs, std::slice::from_ref(&(0..t.len())));
        let tau = 30.0;
        // Uneven times with gaps, in reverse order.
        let ts: Vec<f64> = (0..300).rev().map(|i| i as f64 * 3.3).collect();
        let lag = s.lagged(&ts, tau);
        let w = 2.0 * std::f64::consts::PI / 1000.0;
        let (gain, phase) = (1.0 / (1.0 + (w * tau).powi(2)).sqrt(), (w * tau).atan());
        for (&t, &y) in ts.iter().zip(&lag) {
            if t > 5.0 * tau {
                let want = 0.8 * gain * (w * t - phase).sin();
                assert!(
                    (y - (want - s.value(0.0))).abs() < 0.008,
                    "{t}: {y} vs {want}"
                );
            }
        }
    }

    /// A temperature with a jump is not followed by a polynomial: said so.
    #[test]
    fn a_jump_is_not_followed() {
        let (t, _, mut obs) = sample(0.005, 4);
        for (v, &t) in obs.iter_mut().zip(&t) {
            if t > 500.0 {
                *v += 0.5;
            }
        }
        let s = Smoother::fit(&t, &obs, std::slice::from_ref(&(0..t.len())));
        assert!(!s.follows, "{}", s.noise_k);
    }
}
