//! Chebyshev interpolation on [−1, 1] at the n Chebyshev nodes (of the first kind):
//! f(s) ≈ Σ_{k<n} c_k T_k(s), exact at the nodes s_i = cos θ_i, θ_i = π(i + ½)/n, with
//! c_k = (2/n)·Σ_i f(s_i) cos(kθ_i) (c₀ halved). For e^(βs), cos(φ + βs) and sin(φ + βs)
//! the error is about 2(β/2)^n/n! (the first neglected term of their Chebyshev series,
//! whose coefficients are Bessel functions, I_k(β) or J_k(β) ≈ (β/2)^k/k!).

use std::f64::consts::PI;

/// cos θ_i of the n nodes.
pub fn node_cosines<const N: usize>() -> [f64; N] {
    std::array::from_fn(|i| (PI * (i as f64 + 0.5) / N as f64).cos())
}

/// The coefficients c_k of the interpolant through the values `f` at the nodes
/// ([`node_cosines`]).
pub fn coefficients<const N: usize>(f: [f64; N]) -> [f64; N] {
    let mut c = [0.0; N];
    for (i, fi) in f.iter().enumerate() {
        let th = PI * (i as f64 + 0.5) / N as f64;
        for (k, ck) in c.iter_mut().enumerate() {
            *ck += 2.0 / N as f64 * fi * (k as f64 * th).cos();
        }
    }
    c[0] *= 0.5;
    c
}

/// T_0(s) … T_{N−1}(s) by the three-term recurrence T_{k+1} = 2s·T_k − T_{k−1}.
#[inline]
pub fn values<const N: usize>(s: f64) -> [f64; N] {
    let mut t = [0.0; N];
    t[0] = 1.0;
    if N > 1 {
        t[1] = s;
    }
    for k in 2..N {
        t[k] = 2.0 * s * t[k - 1] - t[k - 2];
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The interpolant of cos(φ + βs) and sin(φ + βs) (β = 0.3, the widest band a
    /// frequency's refinement takes over one run) is within the bound 2(β/2)^N/N!
    /// everywhere on [−1, 1].
    #[test]
    fn interpolates_a_rotating_phase_within_its_bound() {
        const N: usize = 8;
        let (phi, beta) = (0.7, 0.3f64);
        let nodes = node_cosines::<N>();
        let c = coefficients(nodes.map(|s| (phi + beta * s).cos()));
        let d = coefficients(nodes.map(|s| (phi + beta * s).sin()));
        let fact: f64 = (1..=N).map(|k| k as f64).product();
        let bound = 2.0 * (beta / 2.0).powi(N as i32) / fact;
        for i in 0..=40 {
            let s = -1.0 + 0.05 * i as f64;
            let t = values::<N>(s);
            let cos: f64 = c.iter().zip(&t).map(|(c, t)| c * t).sum();
            let sin: f64 = d.iter().zip(&t).map(|(d, t)| d * t).sum();
            assert!((cos - (phi + beta * s).cos()).abs() < bound, "{s}: cos");
            assert!((sin - (phi + beta * s).sin()).abs() < bound, "{s}: sin");
        }
    }
}
