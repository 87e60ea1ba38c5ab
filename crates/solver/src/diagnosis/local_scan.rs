//! Local anomalies: a scan of residual sequences (a run's readings along one direction, in
//! the order they were taken) for structure confined to one place — a step that persists
//! (an encoder slip, a lost count, a knock that moved the head), a burst (a stretch of
//! larger scatter) or an isolated excursion (one reading far off) — with the family-wise
//! false-alarm rate controlled over every place scanned.
//!
//! For a sequence r_1..r_n (the model's residual, centred) and the noise floor σ
//! (estimated without the model), the places and their statistics are:
//!
//! | family | place | statistic | null distribution |
//! |---|---|---|---|
//! | step | between samples k and k + 1, scale w ∈ [`STEP_WINDOWS`] | z = (mean r_{k+1..k+R} − mean r_{k−L+1..k}) / (σ √(1/L + 1/R)), L = min(w, k), R = min(w, n − k), both ≥ [`MIN_SIDE`] | N(0, 1) |
//! | burst | a window of w ∈ [`BURST_WINDOWS`] samples starting every w/2 | E = Σ r²/σ² over the window | χ²_w |
//! | excursion | sample i | z = r_i/σ | N(0, 1) |
//!
//! **Rule**: a place is an anomaly when its p-value (two-sided for z) is below
//! α / (3·N_f), N_f the number of places of its family over all the sequences scanned,
//! α = [`FAMILY_WISE_ALPHA`] = 0.1 %. By Bonferroni's inequality the probability that
//! white Gaussian noise of standard deviation σ gives any anomaly anywhere is at most α,
//! whatever the correlation between places (neighbouring places share samples, so the
//! true rate is lower). A fitted model's residual has slightly less than σ² variance,
//! which only lowers it further.
//!
//! In each sequence the most significant step is taken when there is one and the scatter
//! about its two window means is noise (not itself a burst by the burst rule: a burst's
//! random walk also moves window means), otherwise the most significant place of any
//! family (the smallest ln p − ln threshold); it is removed (a step
//! by subtracting the step fitted at its place, a burst or an excursion by setting its
//! samples to 0, the sequence's mean) and the sequence scanned again, at most
//! [`MAX_PER_SEQUENCE`] times: a step, which moves every later sample off the mean, does
//! not also count as a burst or a row of excursions.
//!
//! The scan is pure and knows nothing of sessions: the session's diagnosis scans each
//! run's rows read along each direction (the session's diagnosis names file, run, test, time
//! and commanded position of each anomaly), and positioning runs may scan each run's
//! readings per approach direction.

/// The family-wise false-alarm rate of one scan (all its sequences and families).
pub const FAMILY_WISE_ALPHA: f64 = 0.001;
/// Half-widths (samples) of the step statistic's two windows.
pub const STEP_WINDOWS: [usize; 2] = [8, 32];
/// Lengths (samples, even) of the burst windows.
pub const BURST_WINDOWS: [usize; 2] = [8, 32];
/// Fewest samples on either side of a step.
pub const MIN_SIDE: usize = 4;
/// Most anomalies taken from one sequence.
pub const MAX_PER_SEQUENCE: usize = 3;

/// The kind of a local anomaly.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// A lasting offset from a sample on.
    Step,
    /// A stretch of larger scatter.
    Burst,
    /// One reading far off.
    Excursion,
}

impl Kind {
    pub fn name(self) -> &'static str {
        match self {
            Kind::Step => "step",
            Kind::Burst => "burst",
            Kind::Excursion => "excursion",
        }
    }
}

/// One anomaly found.
#[derive(Debug, Clone, PartialEq)]
pub struct Anomaly {
    pub kind: Kind,
    /// Index of the sequence.
    pub sequence: usize,
    /// First sample of the place: the first sample after a step, a burst's first sample,
    /// the excursion's sample.
    pub at: usize,
    /// The samples the place's statistic reads, [from, to): a step's two windows, a
    /// burst's window, the excursion.
    pub span: (usize, usize),
    /// Size in the residual's unit: a step's offset (after − before), a burst's RMS, an
    /// excursion's value.
    pub size: f64,
    /// ln of the place's p-value.
    pub ln_p: f64,
    /// ln of the threshold the p-value was held to, α/(3·N_f).
    pub ln_threshold: f64,
}

impl Anomaly {
    /// The place's significance as the z of a two-sided normal test with the same
    /// p-value (for reporting).
    pub fn z(&self) -> f64 {
        z_of_ln_p(self.ln_p)
    }
}

/// The number of places of each family (step, burst, excursion) in sequences of
/// lengths `lens`.
pub fn places(lens: impl IntoIterator<Item = usize>) -> [usize; 3] {
    let mut n = [0usize; 3];
    for len in lens {
        for &w in &STEP_WINDOWS {
            n[0] += step_places(len, w).count();
        }
        for &w in &BURST_WINDOWS {
            n[1] += burst_starts(len, w).count();
        }
        n[2] += len;
    }
    n
}

/// The family-wise thresholds ln(α/(3·N_f)) of a scan with `places` per family.
pub fn ln_thresholds(places: [usize; 3]) -> [f64; 3] {
    places.map(|n| (FAMILY_WISE_ALPHA / (3.0 * n.max(1) as f64)).ln())
}

/// Scans every sequence (module docs) with noise floor `sigma`; the anomalies in the
/// order of the sequences, each sequence's in the order found (most significant first).
pub fn scan(seqs: &[&[f64]], sigma: f64) -> Vec<Anomaly> {
    let thr = ln_thresholds(places(seqs.iter().map(|s| s.len())));
    let mut out = Vec::new();
    if !(sigma > 0.0 && sigma.is_finite()) {
        return out;
    }
    for (i, s) in seqs.iter().enumerate() {
        out.extend(scan_one(s, sigma, thr).into_iter().map(|mut a| {
            a.sequence = i;
            a
        }));
    }
    out
}

/// The anomalies of one sequence against the thresholds `thr` (module docs).
pub fn scan_one(seq: &[f64], sigma: f64, thr: [f64; 3]) -> Vec<Anomaly> {
    let mut r = seq.to_vec();
    let mut out: Vec<Anomaly> = Vec::new();
    while out.len() < MAX_PER_SEQUENCE {
        let found: Vec<Anomaly> = [
            best_step(&r, sigma),
            best_burst(&r, sigma),
            best_excursion(&r, sigma),
        ]
        .into_iter()
        .zip(thr)
        .filter_map(|(a, t)| {
            a.filter(|a| a.ln_p < t).map(|a| Anomaly {
                ln_threshold: t,
                ..a
            })
        })
        .collect();
        let clean_step = |a: &&Anomaly| a.kind == Kind::Step && !scattered(&r, a, sigma, thr[1]);
        let best = match found.iter().find(clean_step) {
            Some(step) => Some(step.clone()),
            None => found
                .into_iter()
                .min_by(|a, b| (a.ln_p - a.ln_threshold).total_cmp(&(b.ln_p - b.ln_threshold))),
        };
        let Some(a) = best else { break };
        remove(&mut r, &a);
        out.push(a);
    }
    out
}

/// Whether the samples of step `a`'s two windows scatter about their own means more than
/// noise does, by the burst rule (ln p of χ² with len − 2 degrees of freedom, rounded
/// down to even, below `ln_threshold`).
fn scattered(r: &[f64], a: &Anomaly, sigma: f64, ln_threshold: f64) -> bool {
    let ((from, to), k) = (a.span, a.at);
    let ss = |s: &[f64]| {
        let m = s.iter().sum::<f64>() / s.len() as f64;
        s.iter().map(|v| (v - m) * (v - m)).sum::<f64>()
    };
    let e = (ss(&r[from..k]) + ss(&r[k..to])) / (sigma * sigma);
    let dof = (to - from - 2) & !1;
    ln_p_chi2_even(e, dof.max(2)) < ln_threshold
}

/// The step places between samples k and k + 1 at scale w: (k + 1, L, R).
fn step_places(n: usize, w: usize) -> impl Iterator<Item = (usize, usize, usize)> {
    (MIN_SIDE..=n.saturating_sub(MIN_SIDE)).filter_map(move |k| {
        let (l, r) = (w.min(k), w.min(n - k));
        (l >= MIN_SIDE && r >= MIN_SIDE).then_some((k, l, r))
    })
}

/// The starts of the burst windows of length w (every w/2).
fn burst_starts(n: usize, w: usize) -> impl Iterator<Item = usize> {
    (0..n).step_by((w / 2).max(1)).filter(move |&i| i + w <= n)
}

/// The most significant step of `r` (module docs), over every place and scale: the first
/// place of largest |z|, scales in the order of [`STEP_WINDOWS`], places in order.
pub fn best_step(r: &[f64], sigma: f64) -> Option<Anomaly> {
    let n = r.len();
    // Prefix sums: the mean of any stretch in O(1).
    let mut c = vec![0.0; n + 1];
    for (i, v) in r.iter().enumerate() {
        c[i + 1] = c[i] + v;
    }
    let mut best: Option<(f64, Anomaly)> = None;
    let mut take = |(k, l, rr): (usize, usize, usize), z: f64| {
        if best.as_ref().is_none_or(|(bz, _)| z.abs() > *bz) {
            let (before, after) = step_means(&c, k, l, rr);
            best = Some((
                z.abs(),
                Anomaly {
                    kind: Kind::Step,
                    sequence: 0,
                    at: k,
                    span: (k - l, k + rr),
                    size: after - before,
                    ln_p: ln_p_normal(z),
                    ln_threshold: 0.0,
                },
            ));
        }
    };
    let z_at = |(k, l, rr): (usize, usize, usize)| {
        let (before, after) = step_means(&c, k, l, rr);
        (after - before) / (sigma * (1.0 / l as f64 + 1.0 / rr as f64).sqrt())
    };
    for &w in &STEP_WINDOWS {
        // The inner places k ∈ [w, n − w] (w samples on each side) share one
        // denominator: their z are taken a block at a time in a loop over three shifted
        // slices that the compiler makes wide, the places near the ends one by one; the
        // same z at each place, visited in order.
        let inner = w..(n + 1).saturating_sub(w).max(w);
        for p in step_places(n, w).take_while(|p| p.0 < inner.start) {
            take(p, z_at(p));
        }
        let (wf, mut zs) = (w as f64, [0.0; STEP_BLOCK]);
        let den = sigma * (1.0 / wf + 1.0 / wf).sqrt();
        for lo in inner.clone().step_by(STEP_BLOCK) {
            let hi = (lo + STEP_BLOCK).min(inner.end);
            let (a, m, b) = (&c[lo - w..hi - w], &c[lo..hi], &c[lo + w..hi + w]);
            for (z, ((&a, &m), &b)) in zs.iter_mut().zip(a.iter().zip(m).zip(b)) {
                *z = ((b - m) / wf - (m - a) / wf) / den;
            }
            for (k, &z) in (lo..hi).zip(&zs) {
                take((k, w, w), z);
            }
        }
        for p in step_places(n, w).skip_while(|p| p.0 < inner.end) {
            take(p, z_at(p));
        }
    }
    best.map(|b| b.1)
}

/// Places whose step z are taken together ([`best_step`]).
const STEP_BLOCK: usize = 256;

/// The means of the `l` samples before place k and of the `rr` after it, from the prefix
/// sums `c`.
#[inline(always)]
fn step_means(c: &[f64], k: usize, l: usize, rr: usize) -> (f64, f64) {
    ((c[k] - c[k - l]) / l as f64, (c[k + rr] - c[k]) / rr as f64)
}

/// The most significant burst window of `r`.
fn best_burst(r: &[f64], sigma: f64) -> Option<Anomaly> {
    let mut best: Option<Anomaly> = None;
    for &w in &BURST_WINDOWS {
        // ln p falls as E rises (w fixed): a window no larger in E than one already
        // taken at this w cannot have a smaller ln p, and is not evaluated.
        let mut top = f64::NEG_INFINITY;
        for i in burst_starts(r.len(), w) {
            let e: f64 = r[i..i + w].iter().map(|v| v * v).sum::<f64>() / (sigma * sigma);
            if e <= top {
                continue;
            }
            top = e;
            let ln_p = ln_p_chi2_even(e, w);
            if best.as_ref().is_none_or(|b| ln_p < b.ln_p) {
                best = Some(Anomaly {
                    kind: Kind::Burst,
                    sequence: 0,
                    at: i,
                    span: (i, i + w),
                    size: sigma * (e / w as f64).sqrt(),
                    ln_p,
                    ln_threshold: 0.0,
                });
            }
        }
    }
    best
}

/// The most significant single reading of `r`.
fn best_excursion(r: &[f64], sigma: f64) -> Option<Anomaly> {
    let (i, v) = r
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))?;
    Some(Anomaly {
        kind: Kind::Excursion,
        sequence: 0,
        at: i,
        span: (i, i + 1),
        size: *v,
        ln_p: ln_p_normal(v / sigma),
        ln_threshold: 0.0,
    })
}

/// Removes anomaly `a` from `r`: a step by subtracting the step fitted over the whole
/// sequence at its place (two means, about the sequence's mean), a burst or an excursion
/// by setting its samples to 0.
fn remove(r: &mut [f64], a: &Anomaly) {
    match a.kind {
        Kind::Step => {
            let n = r.len();
            let k = a.at;
            let m1 = r[..k].iter().sum::<f64>() / k as f64;
            let m2 = r[k..].iter().sum::<f64>() / (n - k) as f64;
            r[..k].iter_mut().for_each(|v| *v -= m1);
            r[k..].iter_mut().for_each(|v| *v -= m2);
        }
        Kind::Burst | Kind::Excursion => r[a.span.0..a.span.1].iter_mut().for_each(|v| *v = 0.0),
    }
}

/// ln P(|Z| ≥ |z|) for a standard normal Z: ln erfc(|z|/√2), with erfc's asymptotic
/// expansion where it underflows.
pub fn ln_p_normal(z: f64) -> f64 {
    let x = z.abs() / std::f64::consts::SQRT_2;
    let e = statrs::function::erf::erfc(x);
    if e > 1e-300 {
        e.ln()
    } else {
        // erfc x = e^(−x²)/(x√π)·(1 − 1/(2x²) + 3/(4x⁴) − …), x > 26 here.
        -x * x - (x * std::f64::consts::PI.sqrt()).ln() + (1.0 - 0.5 / (x * x)).ln()
    }
}

/// ln P(χ²_w ≥ e) for an even number of degrees of freedom w: the Poisson sum
/// P = e^(−e/2) Σ_{k < w/2} (e/2)^k / k!, summed in logs.
pub fn ln_p_chi2_even(e: f64, w: usize) -> f64 {
    let x = 0.5 * e.max(0.0);
    if x == 0.0 {
        return 0.0;
    }
    let ln_x = x.ln();
    let term = |k: usize| k as f64 * ln_x - ln_factorial(k);
    let top = (0..w / 2).map(term).fold(f64::NEG_INFINITY, f64::max);
    (-x + top + (0..w / 2).map(|k| (term(k) - top).exp()).sum::<f64>().ln()).min(0.0)
}

/// ln k! (`statrs`'s ln Γ(k + 1)), from a table made once for the k of the scan's
/// windows.
fn ln_factorial(k: usize) -> f64 {
    const TABLED: usize = 64;
    static TABLE: std::sync::OnceLock<[f64; TABLED]> = std::sync::OnceLock::new();
    let ln_gamma = |k: usize| statrs::function::gamma::ln_gamma(k as f64 + 1.0);
    match TABLE.get_or_init(|| std::array::from_fn(ln_gamma)).get(k) {
        Some(&v) => v,
        None => ln_gamma(k),
    }
}

/// The z of a two-sided normal test with p-value e^(ln_p) (bisection on
/// [`ln_p_normal`]).
pub fn z_of_ln_p(ln_p: f64) -> f64 {
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    while ln_p_normal(hi) > ln_p && hi < 1e6 {
        hi *= 2.0;
    }
    for _ in 0..80 {
        let mid = 0.5 * (lo + hi);
        if ln_p_normal(mid) > ln_p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    /// The step scan's place and figures are those of the rule of the module docs taken
    /// place by place (every scale, every k, L and R cut at the ends), bit for bit, on
    /// noise with a step and on sequences shorter than two windows.
    #[test]
    fn best_step_is_the_place_by_place_rule() {
        let one_by_one = |r: &[f64], sigma: f64| {
            let n = r.len();
            let mut c = vec![0.0; n + 1];
            for (i, v) in r.iter().enumerate() {
                c[i + 1] = c[i] + v;
            }
            let mut best: Option<(f64, usize, usize, usize, f64, f64)> = None;
            for &w in &STEP_WINDOWS {
                for k in MIN_SIDE..=n.saturating_sub(MIN_SIDE) {
                    let (l, rr) = (w.min(k), w.min(n - k));
                    if l < MIN_SIDE || rr < MIN_SIDE {
                        continue;
                    }
                    let before = (c[k] - c[k - l]) / l as f64;
                    let after = (c[k + rr] - c[k]) / rr as f64;
                    let z = (after - before) / (sigma * (1.0 / l as f64 + 1.0 / rr as f64).sqrt());
                    if best.is_none_or(|b| z.abs() > b.0) {
                        best = Some((z.abs(), k, k - l, k + rr, after - before, ln_p_normal(z)));
                    }
                }
            }
            best
        };
        let mut rng = rand::rngs::StdRng::seed_from_u64(11);
        let noise = Normal::new(0.0, 0.2).unwrap();
        for (n, step) in [9, 40, 63, 64, 65, 500, 500, 2000]
            .into_iter()
            .zip([0.9, 0.0].repeat(4))
        {
            let r: Vec<f64> = (0..n)
                .map(|i| noise.sample(&mut rng) + if i >= n / 3 { step } else { 0.0 })
                .collect();
            let got = best_step(&r, 0.2).map(|a| (a.at, a.span, a.size, a.ln_p));
            let want = one_by_one(&r, 0.2).map(|b| (b.1, (b.2, b.3), b.4, b.5));
            assert_eq!(
                got.map(|g| (g.0, g.1, g.2.to_bits(), g.3.to_bits())),
                want.map(|w| (w.0, w.1, w.2.to_bits(), w.3.to_bits())),
                "n {n}"
            );
        }
    }

    /// Textbook values: P(|Z| ≥ 1.96) = 0.05, P(|Z| ≥ 3) = 0.0026998, P(χ²_2 ≥ 2·ln 20) =
    /// 0.05, P(χ²_8 ≥ 15.507) = 0.05 (tables); the asymptotic branch meets erfc.
    #[test]
    fn tails_by_the_tables() {
        assert!((ln_p_normal(1.959964).exp() - 0.05).abs() < 1e-6);
        assert!((ln_p_normal(3.0).exp() - 0.0026998).abs() < 1e-7);
        assert!((ln_p_chi2_even(2.0 * 20f64.ln(), 2).exp() - 0.05).abs() < 1e-12);
        assert!((ln_p_chi2_even(15.507, 8).exp() - 0.05).abs() < 1e-4);
        // Continuity across the underflow of erfc (x ≈ 26.5).
        let (a, b) = (ln_p_normal(37.4), ln_p_normal(37.6));
        assert!(a > b && a - b < 10.0, "{a} {b}");
        assert!((z_of_ln_p(0.05f64.ln()) - 1.959964).abs() < 1e-5);
    }

    fn noise(n: usize, sigma: f64, seed: u64) -> Vec<f64> {
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        let g = Normal::new(0.0, sigma).unwrap();
        (0..n).map(|_| g.sample(&mut rng)).collect()
    }

    /// White noise: over 400 scans of 50 sequences of 120 samples, at most 3 scans with
    /// an anomaly (α = 0.1 % each: at most 0.4 expected; P(more than 3) < 10⁻³ for a
    /// Poisson count of mean 0.4).
    #[test]
    fn white_noise_raises_few_false_alarms() {
        let mut alarms = 0;
        for seed in 0..400 {
            let seqs: Vec<Vec<f64>> = (0..50).map(|i| noise(120, 0.3, seed * 100 + i)).collect();
            let refs: Vec<&[f64]> = seqs.iter().map(Vec::as_slice).collect();
            alarms += usize::from(!scan(&refs, 0.3).is_empty());
        }
        assert!(alarms <= 3, "{alarms} of 400 scans raised an alarm");
    }

    /// A step of 5σ inside one sequence of 50, a burst of 4σ RMS over 16 samples in
    /// another, a 9σ excursion in a third: each found once, at its place, with its kind
    /// and size; nothing else.
    #[test]
    fn step_burst_and_excursion_found_where_they_are() {
        let sigma = 0.15;
        let mut seqs: Vec<Vec<f64>> = (0..50).map(|i| noise(150, sigma, 1000 + i)).collect();
        seqs[7][90..].iter_mut().for_each(|v| *v += 5.0 * sigma);
        let burst = noise(16, 4.0 * sigma, 77);
        seqs[20][40..56]
            .iter_mut()
            .zip(&burst)
            .for_each(|(v, b)| *v += b);
        seqs[33][12] += 9.0 * sigma;
        // Centred, as a model's residual with its run offsets is.
        for s in &mut seqs {
            let m = s.iter().sum::<f64>() / s.len() as f64;
            s.iter_mut().for_each(|v| *v -= m);
        }
        let refs: Vec<&[f64]> = seqs.iter().map(Vec::as_slice).collect();
        let found = scan(&refs, sigma);
        assert_eq!(found.len(), 3, "{found:#?}");
        let step = &found[0];
        assert_eq!((step.kind, step.sequence), (Kind::Step, 7));
        assert!(step.at.abs_diff(90) <= 2, "{step:?}");
        assert!((step.size - 5.0 * sigma).abs() < 2.0 * sigma, "{step:?}");
        let b = &found[1];
        assert_eq!((b.kind, b.sequence), (Kind::Burst, 20), "{b:?}");
        assert!(b.span.1 > 40 && b.span.0 < 56, "{b:?}");
        let e = &found[2];
        assert_eq!((e.kind, e.sequence, e.at), (Kind::Excursion, 33, 12));
    }
}
