//! The moments of a sine/cosine pair s = sin(2πf x), c = cos(2πf x) on one run, at every
//! frequency of an evenly spaced grid f_k = f₀ + k·Δf: the inputs of a frequency scan.
//!
//! The raw sums [Σs, Σc, Σs², Σc², Σs·c, Σr·s, Σr·c] add over any split of the run's
//! samples, so the run is cut into maximal stretches evenly spaced in x (a line pass at
//! constant velocity, sampled at a constant rate, is one; a run in time is one whole):
//! those are summed in closed form ([`super::even_scan`], one multiply and two adds per
//! sample and frequency), the rest (acceleration ramps, circles, dwells) by rotating
//! phasors, sin/cos of ω_k·x following from ω₀·x by rotation through Δω·x. The run's
//! centred moments are then ss = Σs² − (Σs)²/n, cc = Σc² − (Σc)²/n, sc = Σs·c − Σs·Σc/n
//! (the model centres every column per run), rs = Σr·s, rc = Σr·c (the residual r is
//! already centred per run).

use super::even_scan;
use super::linalg::wide;
use std::f64::consts::PI;

/// Frequencies evaluated together (independent phasor chains, vectorised).
const LANES: usize = 4;

/// Shortest stretch summed in closed form: its closing costs a few sine/cosine
/// evaluations per frequency, which a shorter stretch does not repay.
const MIN_STRETCH: usize = 64;

/// Consecutive steps belong to one stretch while they differ by at most this fraction of
/// the first (a loose cut; [`even_scan::even_step`] then checks the stretch exactly).
const STEP_TOLERANCE: f64 = 1e-6;

/// The centred moments [ss, cc, sc, rs, rc] of a run of `n` samples from its raw sums
/// [Σs, Σc, Σs², Σc², Σs·c, Σr·s, Σr·c].
pub fn centred(sums: &[f64; 7], n: usize) -> [f64; 5] {
    let [s, c, ss, cc, sc, rs, rc] = *sums;
    let n = n as f64;
    [ss - s * s / n, cc - c * c / n, sc - s * c / n, rs, rc]
}

/// The run's centred moments [ss, cc, sc, rs, rc] at f = f0 + k·df (k < out.len()) for the
/// samples at `xs` with residual `rv`; `sums` is scratch of out.len() entries. Without
/// `FULL`, rs and rc alone (the same values; ss, cc, sc, which do not depend on the
/// residual, are left 0): a scan of the same samples and frequencies on another
/// residual takes them from the first.
pub fn run_moments<const FULL: bool>(
    rv: &[f64],
    xs: &[f64],
    f0: f64,
    df: f64,
    sums: &mut [[f64; 7]],
    out: &mut [[f64; 5]],
) {
    sums.iter_mut().for_each(|s| *s = [0.0; 7]);
    // Samples outside the even stretches, gathered for the phasor sums.
    let (mut rest_r, mut rest_x) = (Vec::new(), Vec::new());
    let mut i = 0;
    while i < xs.len() {
        let j = stretch_end(xs, i);
        let even = (j - i >= MIN_STRETCH)
            .then(|| even_scan::even_step(&xs[i..j]))
            .flatten();
        match even {
            Some((x0, h)) => even_scan::even_sums::<FULL>(x0, h, &rv[i..j], f0, df, sums),
            None => {
                rest_r.extend_from_slice(&rv[i..j]);
                rest_x.extend_from_slice(&xs[i..j]);
            }
        }
        i = j;
    }
    if !rest_x.is_empty() {
        phasor_sums::<FULL>(&rest_r, &rest_x, f0, df, sums);
    }
    for (o, s) in out.iter_mut().zip(sums.iter()) {
        *o = centred(s, rv.len());
    }
}

/// End (exclusive) of the stretch starting at `i`: the samples after it whose steps
/// equal its first step within [`STEP_TOLERANCE`] (at least one sample; two when the
/// first step is nonzero).
fn stretch_end(xs: &[f64], i: usize) -> usize {
    if i + 1 >= xs.len() {
        return xs.len();
    }
    let h = xs[i + 1] - xs[i];
    if h == 0.0 {
        return i + 1;
    }
    let tol = STEP_TOLERANCE * h.abs();
    let mut j = i + 2;
    while j < xs.len() && (xs[j] - xs[j - 1] - h).abs() <= tol {
        j += 1;
    }
    j
}

/// Adds to `out[k]` the raw sums [Σs, Σc, Σs², Σc², Σs·c, Σr·s, Σr·c] at f = f0 + k·df of
/// the samples `xs` with residual `rv`, by rotating phasors, [`LANES`] frequencies at a
/// time (without `FULL`, the residual's two alone, as [`even_scan::even_sums`]).
pub fn phasor_sums<const FULL: bool>(
    rv: &[f64],
    xs: &[f64],
    f0: f64,
    df: f64,
    out: &mut [[f64; 7]],
) {
    wide(Phasors::<FULL> {
        rv,
        xs,
        f0,
        df,
        out,
    });
}

/// [`phasor_sums`]' arguments, as the kernel [`wide`] runs.
struct Phasors<'a, const FULL: bool> {
    rv: &'a [f64],
    xs: &'a [f64],
    f0: f64,
    df: f64,
    out: &'a mut [[f64; 7]],
}

impl<const FULL: bool> pulp::WithSimd for Phasors<'_, FULL> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _: S) {
        phasors::<FULL>(self.rv, self.xs, self.f0, self.df, self.out)
    }
}

/// [`phasor_sums`]' work, inlined into its wide build.
#[inline(always)]
fn phasors<const FULL: bool>(rv: &[f64], xs: &[f64], f0: f64, df: f64, out: &mut [[f64; 7]]) {
    let two_pi = 2.0 * PI;
    let nf = out.len();
    let nb = nf.div_ceil(LANES);
    // Per sample: the rotation by LANES·Δw·x, and the phasors (sin, cos) of its LANES
    // current frequencies.
    let mut step = Vec::with_capacity(xs.len());
    let mut sn = Vec::with_capacity(xs.len() * LANES);
    let mut cs = Vec::with_capacity(xs.len() * LANES);
    for &x in xs {
        let (s1, c1) = (two_pi * df * x).sin_cos();
        step.push((two_pi * df * LANES as f64 * x).sin_cos());
        let (mut s, mut c) = (two_pi * f0 * x).sin_cos();
        for _ in 0..LANES {
            sn.push(s);
            cs.push(c);
            (s, c) = (s * c1 + c * s1, c * c1 - s * s1);
        }
    }
    // The groups [`GROUP_BLOCKS`] at a time (the residual's two sums alone: their
    // accumulators fit in the registers; two with all seven), then one at a time: each
    // sample's phasors are read and written once per run of groups instead of once per
    // group; each frequency's arithmetic and order are the same.
    let mut b = 0;
    while b < nb {
        let left = nb - b;
        b += if FULL && left >= 2 {
            blocks::<FULL, 2>(rv, &step, &mut sn, &mut cs, b, out)
        } else if !FULL && left >= GROUP_BLOCKS {
            blocks::<FULL, GROUP_BLOCKS>(rv, &step, &mut sn, &mut cs, b, out)
        } else {
            blocks::<FULL, 1>(rv, &step, &mut sn, &mut cs, b, out)
        };
    }
}

/// Groups of [`LANES`] frequencies taken together in one sweep of the samples by
/// [`phasors`] (without `FULL`).
const GROUP_BLOCKS: usize = 4;

/// [`phasors`]' sums of the `G` groups of [`LANES`] frequencies from group `b` on: per
/// sample, the stored phasors of group b are those of its first group; each next group's
/// are the previous group's rotated by the sample's step (the rotation [`phasors`] stores
/// between two groups), and the last group's, rotated once more, are stored for the
/// groups after these. Adds each frequency's sums to `out` (those past its end dropped)
/// and returns `G`.
#[inline(always)]
fn blocks<const FULL: bool, const G: usize>(
    rv: &[f64],
    step: &[(f64, f64)],
    sn: &mut [f64],
    cs: &mut [f64],
    b: usize,
    out: &mut [[f64; 7]],
) -> usize {
    // Σsin, Σcos, Σsin², Σcos², Σsin·cos, Σr·sin, Σr·cos of each group, by lane.
    let mut acc = [[[0.0; LANES]; 7]; G];
    for (i, (&r, &(s4, c4))) in rv.iter().zip(step).enumerate() {
        let ps = &mut sn[i * LANES..(i + 1) * LANES];
        let pc = &mut cs[i * LANES..(i + 1) * LANES];
        let (mut s, mut c): ([f64; LANES], [f64; LANES]) = (
            std::array::from_fn(|l| ps[l]),
            std::array::from_fn(|l| pc[l]),
        );
        for a in acc.iter_mut() {
            for l in 0..LANES {
                let (sl, cl) = (s[l], c[l]);
                if FULL {
                    a[0][l] += sl;
                    a[1][l] += cl;
                    a[2][l] += sl * sl;
                    a[3][l] += cl * cl;
                    a[4][l] += sl * cl;
                }
                a[5][l] += r * sl;
                a[6][l] += r * cl;
                s[l] = sl * c4 + cl * s4;
                c[l] = cl * c4 - sl * s4;
            }
        }
        ps.copy_from_slice(&s);
        pc.copy_from_slice(&c);
    }
    for (gi, a) in acc.iter().enumerate() {
        for l in 0..LANES {
            let k = (b + gi) * LANES + l;
            if k >= out.len() {
                break;
            }
            for (j, v) in a.iter().enumerate() {
                out[k][j] += v[l];
            }
        }
    }
    G
}

/// The raw sums [Σs, Σc, Σs², Σc², Σs·c, Σr·s, Σr·c] at frequency `f`, term by term (the
/// reference of the tests).
#[cfg(test)]
pub(super) fn direct_sums(xs: &[f64], r: &[f64], f: f64) -> [f64; 7] {
    let mut out = [0.0; 7];
    for (&x, &ri) in xs.iter().zip(r) {
        let (s, c) = (2.0 * PI * f * x).sin_cos();
        for (o, v) in out
            .iter_mut()
            .zip([s, c, s * s, c * c, s * c, ri * s, ri * c])
        {
            *o += v;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A line pass as the drive makes it: a dwell, an acceleration ramp, a constant
    /// velocity stretch, a ramp down and a dwell, with a residual holding a tone; the
    /// moments from the split (closed form on the constant-velocity stretch, phasors on
    /// the rest) against the sums evaluated term by term over the whole run.
    #[test]
    fn split_run_moments_match_the_direct_sums() {
        let (rate, v, acc) = (100.0, 20.0, 500.0);
        let mut xs = vec![10.0; 30];
        let ramp = v / acc;
        let t_ramp = (ramp * rate) as usize;
        for i in 1..=t_ramp {
            let t = i as f64 / rate;
            xs.push(10.0 + 0.5 * acc * t * t);
        }
        let x1 = 10.0 + 0.5 * acc * (t_ramp as f64 / rate).powi(2);
        for i in 1..=900 {
            xs.push(x1 + v * i as f64 / rate);
        }
        let x2 = *xs.last().unwrap();
        for i in 1..=t_ramp {
            let t = i as f64 / rate;
            xs.push(x2 + v * t - 0.5 * acc * t * t);
        }
        let x3 = *xs.last().unwrap();
        xs.extend(std::iter::repeat_n(x3, 25));
        // The constant-velocity pass is one stretch, evenly spaced: summed in closed form.
        let i1 = 30 + t_ramp;
        assert!(stretch_end(&xs, i1) >= i1 + 900);
        assert!(even_scan::even_step(&xs[i1..i1 + 900]).is_some());
        let r: Vec<f64> = xs
            .iter()
            .enumerate()
            .map(|(i, &x)| 0.3 * (2.0 * PI * x / 7.0 + 0.2).sin() + 0.05 * ((i * 31) % 7) as f64)
            .collect();
        let (f0, df, nf) = (1.0 / 30.0, 0.0031, 150);
        let mut sums = vec![[0.0; 7]; nf];
        let mut got = vec![[0.0; 5]; nf];
        run_moments::<true>(&r, &xs, f0, df, &mut sums, &mut got);
        let n = xs.len() as f64;
        for (k, g) in got.iter().enumerate() {
            let [s, c, ss, cc, sc, rs, rc] = direct_sums(&xs, &r, f0 + k as f64 * df);
            let want = [ss - s * s / n, cc - c * c / n, sc - s * c / n, rs, rc];
            for j in 0..5 {
                assert!(
                    (g[j] - want[j]).abs() <= 1e-9 * n,
                    "f {} moment {j}: {} vs {}",
                    f0 + k as f64 * df,
                    g[j],
                    want[j]
                );
            }
        }
        // The residual's two sums alone (a later scan of the same samples and grid):
        // bit for bit those of the whole scan, closed-form stretch and phasors alike.
        let mut alone = vec![[0.0; 5]; nf];
        run_moments::<false>(&r, &xs, f0, df, &mut sums, &mut alone);
        for (a, g) in alone.iter().zip(&got) {
            assert_eq!(a[3].to_bits(), g[3].to_bits());
            assert_eq!(a[4].to_bits(), g[4].to_bits());
        }
    }

    /// The groups taken several at a time ([`blocks`]) give the sums and the stored
    /// phasors of the groups taken one at a time, bit for bit, with and without `FULL`.
    #[test]
    fn groups_together_are_groups_one_by_one() {
        let n = 700;
        let xs: Vec<f64> = (0..n)
            .map(|i| 3.0 + 0.37 * i as f64 + 0.01 * (i as f64).sin())
            .collect();
        let rv: Vec<f64> = xs.iter().map(|x| (0.9 * x).cos() - 0.2).collect();
        let (df, f0) = (0.0123, 0.05);
        let step: Vec<(f64, f64)> = xs
            .iter()
            .map(|x| (2.0 * PI * df * LANES as f64 * x).sin_cos())
            .collect();
        let (sn, cs): (Vec<f64>, Vec<f64>) = xs
            .iter()
            .flat_map(|x| (0..LANES).map(move |l| (2.0 * PI * (f0 + l as f64 * df) * x).sin_cos()))
            .unzip();
        let bits = |v: &[[f64; 7]]| v.iter().flatten().map(|x| x.to_bits()).collect::<Vec<_>>();
        let nf = GROUP_BLOCKS * LANES - 1;
        for full in [false, true] {
            let g = if full { 2 } else { GROUP_BLOCKS };
            let (mut sa, mut ca, mut oa) = (sn.clone(), cs.clone(), vec![[0.0; 7]; nf]);
            let (mut sb, mut cb, mut ob) = (sn.clone(), cs.clone(), vec![[0.0; 7]; nf]);
            for b in 0..g {
                if full {
                    blocks::<true, 1>(&rv, &step, &mut sa, &mut ca, b, &mut oa);
                } else {
                    blocks::<false, 1>(&rv, &step, &mut sa, &mut ca, b, &mut oa);
                }
            }
            if full {
                blocks::<true, 2>(&rv, &step, &mut sb, &mut cb, 0, &mut ob);
            } else {
                blocks::<false, GROUP_BLOCKS>(&rv, &step, &mut sb, &mut cb, 0, &mut ob);
            }
            assert_eq!(bits(&oa), bits(&ob), "full {full}");
            assert!(oa[..g * LANES - 1].iter().all(|o| o[6] != 0.0));
            assert_eq!(sa, sb);
            assert_eq!(ca, cb);
        }
    }

    /// The cut: a dwell gives stretches of one sample, a constant step one stretch, a
    /// change of step a new stretch.
    #[test]
    fn stretches_follow_the_step() {
        let xs = [1.0, 1.0, 1.0, 2.0, 3.0, 4.0, 5.0, 5.5, 6.0, 6.5];
        assert_eq!(stretch_end(&xs, 0), 1);
        assert_eq!(stretch_end(&xs, 2), 7);
        assert_eq!(stretch_end(&xs, 7), 10);
        assert_eq!(stretch_end(&xs, 9), 10);
    }
}
