//! Noise floor of a session, independent of any model: repeated passes of the same test
//! in the same file follow the same commanded path sample by sample (same direction, same
//! profile, same rate), so their offset-free difference contains only what does not
//! repeat. For pairs (k, k+2) of line passes, d_i = r_k,i − r_k+2,i (run means removed)
//! and σ̂ = 1.4826·MAD(d)/√2 (robust to the few samples a reversal transient may differ by).
//!
//! Unlike `crate::noise` (identification's estimate: RMS of nearest-position differences)
//! this one is robust: a vibration or drift that does not repeat between passes inflates
//! an RMS floor by its full power, a MAD floor much less, and diagnosis stops when the
//! held-out residual reaches the floor, so an inflated floor would hide the effect.

use super::design::Design;

/// Noise floor estimate (µm) and the number of differences it rests on; `None` when the
/// session holds no repeated passes.
pub fn noise_floor(d: &Design) -> Option<(f64, usize)> {
    let mut diffs = Vec::new();
    for (i, a) in d.runs.iter().enumerate() {
        let Some(b) = d.runs[i + 1..]
            .iter()
            .find(|b| b.plane_idx == a.plane_idx && b.test == a.test && b.repeat == a.repeat + 2)
        else {
            continue;
        };
        if b.end - b.start != a.end - a.start {
            continue;
        }
        let same_path = (0..a.end - a.start).all(|k| {
            let (p, q) = (d.samples[a.start + k].q_mm, d.samples[b.start + k].q_mm);
            (0..3).all(|j| (p[j] - q[j]).abs() < 1e-6)
        });
        if !same_path {
            continue;
        }
        for k in 0..a.end - a.start {
            for c in 0..2 {
                diffs.push(d.y[2 * (a.start + k) + c] - d.y[2 * (b.start + k) + c]);
            }
        }
    }
    if diffs.len() < 20 {
        return None;
    }
    let n = diffs.len();
    let med = median(&mut diffs.clone());
    let mut dev: Vec<f64> = diffs.iter().map(|x| (x - med).abs()).collect();
    let mad = median(&mut dev);
    Some((1.4826 * mad / std::f64::consts::SQRT_2, n))
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}
