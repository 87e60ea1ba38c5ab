//! The noise floor: one estimator of the reading noise σ, shared by identification and
//! diagnosis, that no structured signal can inflate.
//!
//! **The floor: the flat high-frequency part of the spectrum** ([`spectral_floor`]).
//! Everything a machine adds to a reading in a run — error functions of position (of any
//! order), steps at reversals, thermal drift, servo lag — is smooth in time between a few
//! discontinuities; a vibration is a narrow line. White reading noise alone is flat up to
//! the Nyquist frequency. So, for each run and reading direction in time order:
//!
//! 1. first differences d_t = x_{t+1} − x_t remove offsets and damp every smooth signal;
//!    values beyond 5 robust standard deviations (1.4826·MAD) of the run are clipped, so
//!    a step or a reversal transient becomes a bounded spike;
//! 2. Hann-windowed segments of 64 differences (hop 32) give the periodogram
//!    I_k = |Σ w_t d_t e^{−2πikt/64}|² / Σ w_t² at the bins k = 16..26 (0.25 to 0.41
//!    cycles per sample: away from the smooth signals at low frequency and from the
//!    Nyquist bin); for white noise of variance σ², d has the autocovariance
//!    (2σ², −σ² at lag 1), so E[I_k] = σ² G_k with
//!    G_k = 2 − 2 cos(2πk/64) Σ w_t w_{t+1} / Σ w_t², and J_k = I_k / G_k is σ²·Exp(1);
//! 3. per bin, the median of J_k over all segments (a spike or a transient touches few
//!    segments), then the median over the bins (a vibration line and its window
//!    leakage cover at most five of the eleven bins), divided by ln 2 (the median of
//!    Exp(1)): σ̂² = median_k median_seg J_k / ln 2.
//!
//! **The check: differences of repeated passes** ([`pass_differences`]). Two passes of the
//! same test in the same direction see the same machine errors at the same commanded
//! position; pairing each sample of one pass with the sample of the next pass nearest in
//! commanded position (circles: in angle), removing the mean difference, gives
//! σ̂² = Σ (d_i − d̄)² / (2 (n − 1)). Reversal effects and position-bound errors cancel;
//! what does not repeat — vibration, drift between passes, low-frequency noise — adds to
//! it. A pass-difference figure clearly above the floor therefore says that something
//! non-repeating is in the data ([`NoiseFloor::note`]).

use crate::axis::Plane;
use crate::session::{Run, Session, TestKind};

/// The coordinate a pass is parametrised by, and its direction of travel.
fn pass_key(run: &Run, plane: Plane) -> Option<(TestKind, i8, Vec<f64>)> {
    let kind = run.test_kind(plane);
    let (u, v) = plane.axes();
    let coord: Vec<f64> = match kind {
        TestKind::LineX | TestKind::LineY | TestKind::LineZ => {
            let a = match kind {
                TestKind::LineX => 0,
                TestKind::LineY => 1,
                _ => 2,
            };
            run.pos_mm.iter().map(|q| q[a]).collect()
        }
        TestKind::CircleCcw | TestKind::CircleCw => {
            let n = run.len() as f64;
            let cu = run.pos_mm.iter().map(|q| q[u.index()]).sum::<f64>() / n;
            let cv = run.pos_mm.iter().map(|q| q[v.index()]).sum::<f64>() / n;
            run.pos_mm
                .iter()
                .map(|q| (q[v.index()] - cv).atan2(q[u.index()] - cu))
                .collect()
        }
        TestKind::Free => return None,
    };
    let first = *coord.first()?;
    let last = *coord.last()?;
    let dir = match kind {
        TestKind::CircleCcw => 1,
        TestKind::CircleCw => -1,
        _ if last > first => 1,
        _ => -1,
    };
    Some((kind, dir, coord))
}

/// Sum of squared centred differences and their count for one pair of passes.
fn pair_stats(a: &Run, ca: &[f64], b: &Run, cb: &[f64], angular: bool) -> (f64, usize) {
    // Sort b by coordinate for nearest-neighbour search.
    let mut idx: Vec<usize> = (0..cb.len()).collect();
    idx.sort_by(|&i, &j| cb[i].total_cmp(&cb[j]));
    let sorted: Vec<f64> = idx.iter().map(|&i| cb[i]).collect();
    let span = sorted.last().copied().unwrap_or(0.0) - sorted.first().copied().unwrap_or(0.0);
    let spacing = if sorted.len() > 1 {
        span / (sorted.len() - 1) as f64
    } else {
        0.0
    };
    let mut diffs = [Vec::new(), Vec::new()];
    for (i, &c) in ca.iter().enumerate() {
        let pos = sorted.partition_point(|&v| v < c);
        let cand = [pos.saturating_sub(1), pos.min(sorted.len() - 1)];
        let best = cand
            .into_iter()
            .min_by(|&x, &y| (sorted[x] - c).abs().total_cmp(&(sorted[y] - c).abs()))
            .unwrap();
        let gap = (sorted[best] - c).abs();
        // Only pair samples that really sit at the same place (within two spacings; on
        // circles, not across the seam).
        if gap > 2.0 * spacing.max(1e-9) || (angular && gap > 0.05) {
            continue;
        }
        let j = idx[best];
        diffs[0].push(a.du_um[i] - b.du_um[j]);
        diffs[1].push(a.dv_um[i] - b.dv_um[j]);
    }
    let mut ss = 0.0;
    let mut n = 0;
    for d in &diffs {
        if d.len() < 3 {
            continue;
        }
        let m = d.iter().sum::<f64>() / d.len() as f64;
        ss += d.iter().map(|x| (x - m).powi(2)).sum::<f64>();
        n += d.len() - 1;
    }
    (ss, n)
}

/// Noise standard deviation (µm) from differences of repeated passes (the check of the
/// module documentation), `None` when the session has no repeated pass.
pub fn pass_differences(session: &Session) -> Option<f64> {
    let mut ss = 0.0;
    let mut n = 0usize;
    for rec in &session.planes {
        let keyed: Vec<_> = rec
            .runs
            .iter()
            .filter_map(|r| pass_key(r, rec.plane).map(|k| (r, k)))
            .collect();
        for (i, (ra, (ka, da, ca))) in keyed.iter().enumerate() {
            // Pair with the next pass of the same test and direction.
            if let Some((rb, (_, _, cb))) = keyed[i + 1..]
                .iter()
                .find(|(_, (kb, db, _))| kb == ka && db == da)
            {
                let angular = matches!(ka, TestKind::CircleCcw | TestKind::CircleCw);
                let (s, m) = pair_stats(ra, ca, rb, cb, angular);
                ss += s;
                n += m;
            }
        }
    }
    (n > 10).then(|| (ss / (2.0 * n as f64)).sqrt())
}

/// Length of the spectral segments (differences) and their hop.
const SEG: usize = 64;
const HOP: usize = 32;
/// First and last periodogram bin used (0.25 to 0.41 cycles per sample).
const BIN_LO: usize = 16;
const BIN_HI: usize = 26;
/// Differences beyond this many robust standard deviations are clipped.
const CLIP: f64 = 5.0;

/// Noise standard deviation (µm) from the flat high-frequency part of the spectrum of
/// time-ordered sequences (module documentation), with the number of periodogram
/// ordinates it rests on; `None` when no sequence is long enough for one segment
/// (65 samples).
pub fn spectral_floor<'a>(sequences: impl IntoIterator<Item = &'a [f64]>) -> Option<(f64, usize)> {
    let w: Vec<f64> = (0..SEG)
        .map(|t| {
            (std::f64::consts::PI * (t as f64 + 0.5) / SEG as f64)
                .sin()
                .powi(2)
        })
        .collect();
    let w2: f64 = w.iter().map(|v| v * v).sum();
    let w11: f64 = w.windows(2).map(|p| p[0] * p[1]).sum();
    let nb = BIN_HI - BIN_LO + 1;
    // Window × twiddle table (cos, sin) per bin, and the gain G_k of white noise.
    // (w_t cos, w_t sin) of bin b at t, t-major: table[t·nb + b].
    let mut table = vec![(0.0, 0.0); nb * SEG];
    let mut gain = vec![0.0; nb];
    for (b, k) in (BIN_LO..=BIN_HI).enumerate() {
        let om = 2.0 * std::f64::consts::PI * k as f64 / SEG as f64;
        for t in 0..SEG {
            let (s, c) = (om * t as f64).sin_cos();
            table[t * nb + b] = (w[t] * c, w[t] * s);
        }
        gain[b] = (2.0 - 2.0 * om.cos() * w11 / w2) * w2;
    }
    let mut ordinates: Vec<Vec<f64>> = vec![Vec::new(); nb];
    let mut d: Vec<f64> = Vec::new();
    for x in sequences {
        if x.len() < SEG + 1 {
            continue;
        }
        d.clear();
        d.extend(x.windows(2).map(|p| p[1] - p[0]));
        let centre = median(&mut d.clone());
        let mut dev: Vec<f64> = d.iter().map(|v| (v - centre).abs()).collect();
        let scale = 1.4826 * median(&mut dev);
        if scale > 0.0 {
            let (lo, hi) = (centre - CLIP * scale, centre + CLIP * scale);
            d.iter_mut().for_each(|v| *v = v.clamp(lo, hi));
        }
        let mut start = 0;
        while start + SEG <= d.len() {
            // Every bin's sums at once, each in the order of t (their chains of
            // additions overlap).
            let (mut re, mut im) = ([0.0; BIN_HI - BIN_LO + 1], [0.0; BIN_HI - BIN_LO + 1]);
            for (v, row) in d[start..start + SEG].iter().zip(table.chunks_exact(nb)) {
                for (b, (c, s)) in row.iter().enumerate() {
                    re[b] += v * c;
                    im[b] += v * s;
                }
            }
            for b in 0..nb {
                ordinates[b].push((re[b] * re[b] + im[b] * im[b]) / gain[b]);
            }
            start += HOP;
        }
    }
    let count: usize = ordinates.iter().map(Vec::len).sum();
    if ordinates[0].is_empty() {
        return None;
    }
    let mut per_bin: Vec<f64> = ordinates.iter_mut().map(|o| median(o)).collect();
    let s2 = median(&mut per_bin) / std::f64::consts::LN_2;
    Some((s2.sqrt(), count))
}

/// Median of a non-empty slice (reorders it).
fn median(v: &mut [f64]) -> f64 {
    let n = v.len();
    let (_, &mut hi, _) = v.select_nth_unstable_by(n / 2, f64::total_cmp);
    if !n.is_multiple_of(2) {
        hi
    } else {
        let lo = v[..n / 2].iter().copied().fold(f64::NEG_INFINITY, f64::max);
        0.5 * (lo + hi)
    }
}

/// The noise floor of a session and its check.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseFloor {
    /// σ̂ (µm): the spectral floor, or the pass-difference figure when no run is long
    /// enough for the spectrum (then `spectral` is false).
    pub sigma_um: f64,
    pub spectral: bool,
    /// Periodogram ordinates (spectral) or differences (pass) it rests on.
    pub count: usize,
    /// The check from differences of repeated passes, when the session repeats passes.
    pub pass_differences_um: Option<f64>,
}

/// Pass differences above this multiple of the spectral floor mean non-repeating content.
pub const NON_REPEATING_RATIO: f64 = 1.2;

impl NoiseFloor {
    /// One sentence on how the floor was obtained and what the check says.
    pub fn note(&self) -> String {
        let how = if self.spectral {
            format!(
                "noise floor {:.3} um from the flat high-frequency part of the reading spectrum ({} ordinates)",
                self.sigma_um, self.count
            )
        } else {
            format!(
                "noise floor {:.3} um from differences of repeated passes (no run is long enough for the spectrum)",
                self.sigma_um
            )
        };
        match (self.spectral, self.pass_differences_um) {
            (true, Some(p)) if p > NON_REPEATING_RATIO * self.sigma_um => format!(
                "{how}; repeated passes differ by {p:.3} um: content that does not repeat from pass to pass (vibration, drift, or noise that is not white)"
            ),
            (true, Some(p)) => format!("{how}; repeated passes agree ({p:.3} um)"),
            _ => how,
        }
    }
}

/// The noise floor of a session (module documentation): the spectral floor over every
/// run's two reading directions, checked against the differences of repeated passes;
/// `None` when neither can be computed.
pub fn session_floor(session: &Session) -> Option<NoiseFloor> {
    NoiseFloor::of(session_spectral_floor(session), pass_differences(session))
}

/// The spectral floor ([`spectral_floor`]) over every run's two reading directions: σ̂
/// and the number of ordinates.
pub fn session_spectral_floor(session: &Session) -> Option<(f64, usize)> {
    spectral_floor(
        session
            .planes
            .iter()
            .flat_map(|p| &p.runs)
            .flat_map(|r| [r.du_um.as_slice(), r.dv_um.as_slice()]),
    )
}

impl NoiseFloor {
    /// The floor from a session's spectral floor (σ̂, ordinates) and its pass-difference
    /// figure: the spectral one checked against the pass differences, or the pass
    /// differences alone when no run is long enough for the spectrum; `None` when
    /// neither is known.
    pub fn of(spectral: Option<(f64, usize)>, pass: Option<f64>) -> Option<NoiseFloor> {
        match spectral {
            Some((s, n)) => Some(NoiseFloor {
                sigma_um: s,
                spectral: true,
                count: n,
                pass_differences_um: pass,
            }),
            None => pass.map(|p| NoiseFloor {
                sigma_um: p,
                spectral: false,
                count: 0,
                pass_differences_um: Some(p),
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    fn white(seed: u64, n: usize, sigma: f64) -> Vec<f64> {
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        let g = Normal::new(0.0, sigma).unwrap();
        (0..n).map(|_| g.sample(&mut rng)).collect()
    }

    /// White noise: σ recovered (≈ 3 000 segments × 11 bins: the median of the per-bin
    /// medians is within ≈ 1 % of σ).
    #[test]
    fn white_noise_is_recovered() {
        let x = white(1, 100_000, 0.15);
        let (s, n) = spectral_floor([x.as_slice()]).unwrap();
        assert!((s / 0.15 - 1.0).abs() < 0.03, "{s}");
        assert_eq!(n, 11 * ((100_000 - 1 - SEG) / HOP + 1));
    }

    /// Large smooth structure, steps and a strong sinusoid on top of the noise move the
    /// floor by less than 10 % (each would inflate an RMS by far more).
    #[test]
    fn structure_does_not_inflate_the_floor() {
        let n = 100_000;
        let x = white(2, n, 0.15);
        let with = |f: &dyn Fn(usize) -> f64| -> f64 {
            let y: Vec<f64> = x.iter().enumerate().map(|(i, v)| v + f(i)).collect();
            spectral_floor([y.as_slice()]).unwrap().0
        };
        let base = with(&|_| 0.0);
        // A cubic of 20 µm over every 500 samples, steps of 4 µm every 190 samples, a
        // 0.8 µm line at 0.3 cycles per sample (a 7 Hz vibration sampled at 10 Hz, aliased).
        let cubic = |i: usize| {
            let s = (i % 500) as f64 / 250.0 - 1.0;
            20.0 * s * s * s
        };
        let steps = |i: usize| {
            if (i / 190).is_multiple_of(2) {
                2.0
            } else {
                -2.0
            }
        };
        let line = |i: usize| 0.8 * (2.0 * std::f64::consts::PI * 0.3 * i as f64).sin();
        for (name, f) in [
            ("cubic", &cubic as &dyn Fn(usize) -> f64),
            ("steps", &steps),
            ("line", &line),
        ] {
            let s = with(f);
            assert!((s / base - 1.0).abs() < 0.10, "{name}: {s} vs {base}");
            let rms = (x
                .iter()
                .enumerate()
                .map(|(i, v)| (v + f(i)).powi(2))
                .sum::<f64>()
                / n as f64)
                .sqrt();
            assert!(rms > 1.5 * base, "{name} would inflate an RMS: {rms}");
        }
    }
}
