//! The refinement of a vibration's frequency within a band, on a basis of its own.
//!
//! The vibration's columns along its direction are sin 2πft and cos 2πft. Within run g,
//! with t_m its middle time, h its half duration and s = (t − t_m)/h ∈ [−1, 1], a
//! frequency f = f₀ + ε of the band about the scanned f₀ has the phase
//! 2πft = 2πf₀t + ψ_g(s), ψ_g(s) = 2πε(t_m + h s), so
//!
//!   sin 2πft = sin 2πf₀t · cos ψ_g(s) + cos 2πf₀t · sin ψ_g(s),
//!   cos 2πft = cos 2πf₀t · cos ψ_g(s) − sin 2πf₀t · sin ψ_g(s),
//!
//! and cos ψ_g, sin ψ_g are interpolated at the N Chebyshev nodes of the run
//! ([`chebyshev`](super::chebyshev)), within 2(β/2)^N/N!, β = 2π|ε|h. So every
//! frequency's columns are, run by run, fixed combinations of the 2N basis columns
//! sin 2πf₀t·T_k(s) and cos 2πf₀t·T_k(s), whose moments ([`Moments`]) are formed in one
//! pass over the rows ([`Moments::combine`]); the profile S(f) of the joint fit then
//! costs only small products per run and frequency, instead of a pass over the rows
//! with a sine and a cosine at every row per frequency tried. The basis is used when the
//! interpolation's bound is below [`TOLERANCE`] on the longest run (sessions of many
//! runs; a session of a few long runs is refined on the exact columns).

use super::chebyshev;
use super::design::Design;
use super::moments::Moments;

/// Chebyshev terms per run.
pub const N: usize = 8;

/// Largest error of the interpolated columns (whose values are at most 1 in size): the
/// profile then agrees with the exact columns' to the rounding of its sums.
pub const TOLERANCE: f64 = 1e-14;

/// Middle time and half duration of every run.
pub fn spans(d: &Design) -> Vec<(f64, f64)> {
    d.runs
        .iter()
        .map(|r| {
            let (a, b) = (d.fields.t_s[r.start], d.fields.t_s[r.end - 1]);
            (0.5 * (a + b), (0.5 * (b - a)).max(1e-9))
        })
        .collect()
}

/// Whether the basis about f₀ holds every frequency within `eps_max` of f₀ on the runs
/// of `spans` within [`TOLERANCE`].
pub fn holds(spans: &[(f64, f64)], eps_max: f64) -> bool {
    let h = spans.iter().map(|s| s.1).fold(0.0, f64::max);
    let beta = 2.0 * std::f64::consts::PI * eps_max * h;
    let fact: f64 = (1..=N).map(|k| k as f64).product();
    2.0 * (0.5 * beta).powi(N as i32) / fact <= TOLERANCE
}

/// The values of the 2N basis columns at sample `s` (sin 2πf₀t·T_k, then cos 2πf₀t·T_k),
/// `w0` = 2πf₀.
#[inline]
pub fn fill(d: &Design, spans: &[(f64, f64)], w0: f64, s: usize, out: &mut [f64]) {
    let t = d.fields.t_s[s];
    let (tm, h) = spans[d.fields.run(s)];
    let tk = chebyshev::values::<N>((t - tm) / h);
    let (sin, cos) = (w0 * t).sin_cos();
    for k in 0..N {
        out[k] = sin * tk[k];
        out[N + k] = cos * tk[k];
    }
}

/// The moments of the vibration's two columns (sin, cos) at f₀ + `eps` from those of
/// the basis about f₀ (`basis`, [`fill`]'s columns).
pub fn at(basis: &Moments, spans: &[(f64, f64)], eps: f64) -> Moments {
    let nodes = chebyshev::node_cosines::<N>();
    let w = 2.0 * std::f64::consts::PI * eps;
    basis.combine(2, |g| {
        let (tm, h) = spans[g];
        let c = chebyshev::coefficients(nodes.map(|x| (w * (tm + h * x)).cos()));
        let s = chebyshev::coefficients(nodes.map(|x| (w * (tm + h * x)).sin()));
        let sin = (0..N)
            .map(|k| (k, c[k]))
            .chain((0..N).map(|k| (N + k, s[k])));
        let cos = (0..N)
            .map(|k| (k, -s[k]))
            .chain((0..N).map(|k| (N + k, c[k])));
        vec![sin.collect(), cos.collect()]
    })
}
