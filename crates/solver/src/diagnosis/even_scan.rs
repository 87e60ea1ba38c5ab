//! The sums of a sine/cosine pair over an evenly spaced frequency grid, for a stretch of
//! samples evenly spaced in its variable (a run in time, a constant-velocity pass in
//! position), without evaluating the pair at every (sample, frequency).
//!
//! With x_i = x₀ + i·h (i < n), ω = 2πf and θ = ωh, the column sums are geometric:
//!
//!   Σ e^(iωx_i) = e^(iωx₀) D_n(θ),  D_n(θ) = Σ_{i<n} e^(iθi) = e^(iθ(n−1)/2) sin(nθ/2)/sin(θ/2),
//!
//! so Σsin, Σcos follow from D_n(θ), and Σsin² = (n − Re Σe^(2iωx))/2,
//! Σcos² = (n + Re Σe^(2iωx))/2, Σsin·cos = Im Σe^(2iωx)/2 from D_n(2θ). Only the
//! residual's sums Σ r_i e^(iωx_i) = e^(iωx₀) Σ r_i e^(iθi) need the samples: by
//! Goertzel's recurrence s_k = r_k + 2cos θ·s_{k−1} − s_{k−2} (s_{−1} = s_{−2} = 0),
//! Σ_{k<n} r_k e^(iθk) = e^(iθ(n−1)) (s_{n−1} − e^(iθ) s_{n−2}): one multiply and two
//! adds per (sample, frequency), [`LANES`] frequencies at a time (G. Goertzel, "An
//! algorithm for the evaluation of finite trigonometric series", Amer. Math. Monthly 65,
//! 1958). Its rounding error grows like n²·ε near θ = 0 (about 10⁻⁹ relative for a run
//! of 3 000 samples): well below what a scan's choice of frequency can notice.

use super::linalg::wide;
use std::f64::consts::PI;

/// Frequencies evaluated together: independent recurrences, enough of them to hide the
/// latency of each one's chain of multiply-adds (each frequency's arithmetic is the same
/// whatever the grouping).
const LANES: usize = 16;

/// A run's samples count as evenly spaced when every x_i is within this fraction of the
/// step h of x₀ + i·h (a phase error below 2π·10⁻⁹ at the Nyquist frequency).
const EVEN_TOLERANCE: f64 = 1e-9;

/// x₀ and the step h when `xs` (at least two values) are evenly spaced with h ≠ 0.
pub fn even_step(xs: &[f64]) -> Option<(f64, f64)> {
    let n = xs.len();
    if n < 2 {
        return None;
    }
    let (x0, h) = (xs[0], (xs[n - 1] - xs[0]) / (n - 1) as f64);
    if h == 0.0 {
        return None;
    }
    let tol = EVEN_TOLERANCE * h.abs();
    xs.iter()
        .enumerate()
        .all(|(i, &x)| (x - (x0 + i as f64 * h)).abs() <= tol)
        .then_some((x0, h))
}

/// D_n(θ) = Σ_{i<n} e^(iθi) as (re, im).
fn dirichlet(n: usize, theta: f64) -> (f64, f64) {
    let half = 0.5 * theta;
    let den = half.sin();
    let nf = n as f64;
    if den.abs() < 1e-12 {
        // θ = 2πm: every term is 1.
        return (nf, 0.0);
    }
    let amp = (nf * half).sin() / den;
    let (s, c) = (half * (nf - 1.0)).sin_cos();
    (amp * c, amp * s)
}

/// Complex product of (re, im) pairs.
fn mul((a, b): (f64, f64), (c, d): (f64, f64)) -> (f64, f64) {
    (a * c - b * d, a * d + b * c)
}

/// For the stretch x_i = x0 + i·h with residual `r` (one value per sample), adds to
/// `out[k]` the raw sums [Σs, Σc, Σs², Σc², Σs·c, Σr·s, Σr·c] of s = sin(2πf x),
/// c = cos(2πf x) at f = f0 + k·df (k < out.len()) (the periodic scan's
/// `centred` turns a run's total into its centred moments). Without `FULL`, the
/// residual's two alone (the first five, which do not depend on it, left as they are):
/// the same values of those two.
pub fn even_sums<const FULL: bool>(
    x0: f64,
    h: f64,
    r: &[f64],
    f0: f64,
    df: f64,
    out: &mut [[f64; 7]],
) {
    let n = r.len();
    let nf = n as f64;
    for (b, block) in out.chunks_mut(LANES).enumerate() {
        let w: [f64; LANES] =
            std::array::from_fn(|l| 2.0 * PI * (f0 + (b * LANES + l) as f64 * df));
        let coef = w.map(|w| 2.0 * (w * h).cos());
        let (s1, s2) = wide(|| goertzel(r, &coef));
        for (l, m) in block.iter_mut().enumerate() {
            let theta = w[l] * h;
            let start = (w[l] * x0).sin_cos();
            let start = (start.1, start.0);
            // Σ r_k e^(iθk) = e^(iθ(n−1)) (s_{n−1} − e^(iθ) s_{n−2}).
            let (st, ct) = theta.sin_cos();
            let tail = (s1[l] - ct * s2[l], -st * s2[l]);
            let (sn, cn) = (theta * (nf - 1.0)).sin_cos();
            let rsum = mul(start, mul((cn, sn), tail));
            if !FULL {
                m[5] += rsum.1;
                m[6] += rsum.0;
                continue;
            }
            let s1sum = mul(start, dirichlet(n, theta));
            let start2 = mul(start, start);
            let s2sum = mul(start2, dirichlet(n, 2.0 * theta));
            let (sum_c, sum_s) = s1sum;
            let add = [
                sum_s,
                sum_c,
                0.5 * (nf - s2sum.0),
                0.5 * (nf + s2sum.0),
                0.5 * s2sum.1,
                rsum.1,
                rsum.0,
            ];
            for (o, a) in m.iter_mut().zip(add) {
                *o += a;
            }
        }
    }
}

/// Goertzel's recurrence s_k = r_k + coef·s_{k−1} − s_{k−2} over `r` on every lane:
/// (s_{n−1}, s_{n−2}).
#[inline(always)]
fn goertzel(r: &[f64], coef: &[f64; LANES]) -> ([f64; LANES], [f64; LANES]) {
    let (mut s1, mut s2) = ([0.0; LANES], [0.0; LANES]);
    for &rk in r {
        for l in 0..LANES {
            let s0 = rk + coef[l] * s1[l] - s2[l];
            s2[l] = s1[l];
            s1[l] = s0;
        }
    }
    (s1, s2)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against the sums evaluated term by term on an evenly sampled run (hand-made
    /// residual with a known tone), including a frequency at the Nyquist limit and one
    /// where 2θ = 2π (the sum of e^(2iθi) is n).
    #[test]
    fn sums_match_the_direct_sums() {
        let (x0, h, n) = (1234.5, 0.01, 2999);
        let r: Vec<f64> = (0..n)
            .map(|i| {
                let x = x0 + i as f64 * h;
                0.7 * (2.0 * PI * 3.3 * x + 0.4).sin() + 0.1 * ((i * 7919) % 13) as f64 - 0.6
            })
            .collect();
        let (f0, df, nf) = (0.02, 0.37, 137);
        let mut got = vec![[0.0; 7]; nf];
        even_sums::<true>(x0, h, &r, f0, df, &mut got);
        let mut freqs: Vec<f64> = (0..nf).map(|k| f0 + k as f64 * df).collect();
        freqs.push(50.0);
        let mut nyq = [[0.0; 7]; 1];
        even_sums::<true>(x0, h, &r, 50.0, 1.0, &mut nyq);
        got.push(nyq[0]);
        let xs: Vec<f64> = (0..n).map(|i| x0 + i as f64 * h).collect();
        for (k, &f) in freqs.iter().enumerate() {
            let want = crate::diagnosis::periodic_scan::direct_sums(&xs, &r, f);
            for j in 0..7 {
                assert!(
                    (got[k][j] - want[j]).abs() <= 1e-9 * n as f64,
                    "f {f} moment {j}: {} vs {}",
                    got[k][j],
                    want[j]
                );
            }
        }
    }

    #[test]
    fn uneven_samples_are_refused() {
        assert_eq!(even_step(&[0.0, 1.0, 2.0, 3.0]), Some((0.0, 1.0)));
        assert_eq!(even_step(&[0.0, 1.0, 2.1, 3.0]), None);
        assert_eq!(even_step(&[5.0, 5.0]), None);
        assert_eq!(even_step(&[5.0]), None);
    }
}
