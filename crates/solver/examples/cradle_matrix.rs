//! The cradle rigidity test matrix, every case and seed, as the table of docs/cradle.md:
//! `cargo run -p mtcal-solver --example cradle_matrix [SEEDS] [THREADS] [FILTER]`
//! (default 20 seeds, 2 threads, every case). SEEDS is a count (seeds 1 to SEEDS) or a
//! range FIRST-LAST; FILTER keeps the cases whose label contains it, or, with `|` in it,
//! the cases whose label is one of the `|`-separated labels. After the table: each
//! (case, parameter) pair's share within 2σ with its 95 % interval (Clopper–Pearson),
//! the held-out / floor ratio's distribution over the checks with those above
//! [`FLOOR_LIMIT`] and their lack-of-fit p, and the lack-of-fit rejections per maker.
//! The cases and how the points are made:
//! `crates/solver/tests/cradle_matrix_common/mod.rs`; the test `cradle_matrix` runs a
//! subset in the normal test command.

#[path = "../tests/cradle_matrix_common/mod.rs"]
mod common;

use common::{CaseTally, FLOOR_LIMIT, HEADER, Maker, matrix, row, run_case};
use statrs::distribution::{Beta, Binomial, ContinuousCDF, DiscreteCDF};
use std::collections::BTreeMap;
use std::sync::Mutex;

fn main() {
    let mut args = std::env::args().skip(1);
    let (first, last): (u64, u64) = args.next().map_or((1, 20), |s| match s.split_once('-') {
        Some((a, b)) => (a.parse().expect("FIRST"), b.parse().expect("LAST")),
        None => (1, s.parse().expect("SEEDS")),
    });
    let seeds = last + 1 - first;
    let threads: usize = args.next().map_or(2, |s| s.parse().expect("THREADS"));
    // Optional: only some cases (module docs).
    let filter = args.next();
    let keep = |label: &str| match filter.as_deref() {
        None => true,
        Some(f) if f.contains('|') => f.split('|').any(|l| l == label),
        Some(f) => label.contains(f),
    };
    let cases: Vec<_> = matrix().into_iter().filter(|c| keep(&c.label())).collect();
    let next = Mutex::new(0usize);
    let done: Mutex<Vec<(usize, CaseTally)>> = Mutex::new(vec![]);
    let t0 = std::time::Instant::now();
    std::thread::scope(|s| {
        for _ in 0..threads.max(1) {
            s.spawn(|| {
                loop {
                    let i = {
                        let mut n = next.lock().unwrap();
                        let i = *n;
                        *n += 1;
                        i
                    };
                    let Some(case) = cases.get(i) else { break };
                    let t = run_case(case, first..=last);
                    // The case's own figures as it ends (a run stopped early keeps them).
                    let checks: Vec<String> = t
                        .checks
                        .iter()
                        .map(|(seed, r, p)| format!("{seed}:{r:.3}:{p:.4}"))
                        .collect();
                    let missed: Vec<String> = t
                        .params
                        .iter()
                        .map(|(n, p)| format!("{n} {}/{} {:?}", p.within_2sigma, p.n_z(), p.missed))
                        .collect();
                    eprintln!(
                        "{} ({:?})\n  checks (seed:ratio:p) {}\n  within 2σ (missed seeds) {}",
                        row(case, &t),
                        t0.elapsed(),
                        checks.join(" "),
                        missed.join("; ")
                    );
                    done.lock().unwrap().push((i, t));
                }
            });
        }
    });
    let mut done = done.into_inner().unwrap();
    done.sort_by_key(|(i, _)| *i);
    // Pooled figures: the tilts and the mount height put in, the other terms (truth 0).
    let (mut main, mut main_in, mut other, mut other_in) = (0, 0, 0, 0);
    let (mut over, mut checks, mut ratio_max) = (0usize, 0usize, 0.0f64);
    let mut off_seeds = vec![];
    let mut lof = 0usize;
    // Signed z per parameter over every case, and the (case, parameter) pairs expected to
    // miss 2σ in more than 10 % of the seeds with honest σ (each seed misses with 5 %).
    let mut z: BTreeMap<String, (f64, f64, f64)> = BTreeMap::new();
    let (mut pairs, mut expected_off) = (0usize, 0.0f64);
    for (k, (i, t)) in done.iter().enumerate() {
        // Two tables: the tilts alone, then with an A positioning error.
        let with_a = cases[*i].a_error != [0.0; 2];
        if k == 0 || with_a != (cases[done[k - 1].0].a_error != [0.0; 2]) {
            println!("{}{HEADER}", if k == 0 { "" } else { "\n" });
        }
        println!("{}", row(&cases[*i], t));
        for (n, p) in &t.params {
            if p.truth.is_nan() {
                continue;
            } else if p.truth == 0.0 {
                other += p.reported;
                other_in += p.within_2sigma + p.not_separable;
            } else {
                main += p.reported;
                main_in += p.within_2sigma + p.not_separable;
            }
            let e = z.entry(n.clone()).or_default();
            *e = (e.0 + p.n_z() as f64, e.1 + p.sum_z, e.2 + p.sum_z2);
            if p.n_z() > 0 {
                pairs += 1;
                let b = Binomial::new(0.05, p.n_z() as u64).expect("binomial");
                expected_off += b.sf((0.1 * t.seeds as f64).floor() as u64);
            }
            // Seeds reporting the parameter off by more than 2σ, against 10 % of the seeds.
            let off = p.reported - p.within_2sigma - p.not_separable - p.no_truth;
            if off as f64 > 0.1 * t.seeds as f64 {
                off_seeds.push(format!(
                    "{} {n} ({off} of {} seeds)",
                    cases[*i].label(),
                    t.seeds
                ));
            }
        }
        over += t.over;
        lof += t.lack_of_fit;
        checks += t.seeds;
        ratio_max = ratio_max.max(t.ratio_max);
    }
    println!(
        "\n{} cases × {seeds} seeds ({first}–{last}, {checks} checks) in {:.0?}.\nHeld-out / floor above {FLOOR_LIMIT}: {over} of {checks} checks (largest {ratio_max:.3}).\nWithin 2σ of the truth (or reported as not separable): tilts and mount height {main_in}/{main} ({:.1} %), other terms {other_in}/{other} ({:.1} %).\nParameters off by more than 2σ in more than 10 % of a case's seeds: {}.",
        cases.len(),
        t0.elapsed(),
        100.0 * main_in as f64 / main.max(1) as f64,
        100.0 * other_in as f64 / other.max(1) as f64,
        if off_seeds.is_empty() {
            "none".to_string()
        } else {
            off_seeds.join(", ")
        }
    );
    println!(
        "Expected by chance with honest σ: {expected_off:.1} of the {pairs} (case, parameter) pairs.\nLack-of-fit test rejecting at 1 %: {lof} of {checks} checks ({:.1} expected by chance).",
        0.01 * checks as f64
    );
    let zs: Vec<String> = z
        .iter()
        .filter(|(_, v)| v.0 > 1.0)
        .map(|(n, (k, s, s2))| {
            let m = s / k;
            format!(
                "{n} {m:+.2}/{:.2} ({k})",
                ((s2 - k * m * m) / (k - 1.0)).sqrt()
            )
        })
        .collect();
    println!(
        "z = (value − truth)/σ over every case, mean/spread (seeds): {}.",
        zs.join(", ")
    );
    per_pair(&cases, &done);
    ratios_and_lack_of_fit(&cases, &done);
}

/// Each (case, parameter) pair with a truth: seeds within 2σ of the seeds with a z, the
/// share and its 95 % Clopper–Pearson interval.
fn per_pair(cases: &[common::Case], done: &[(usize, CaseTally)]) {
    let bound = |k: u64, n: u64, lower: bool| -> f64 {
        let (a, b) = if lower {
            (k as f64, (n - k + 1) as f64)
        } else {
            ((k + 1) as f64, (n - k) as f64)
        };
        match (lower, k) {
            (true, 0) => 0.0,
            (false, k) if k == n => 1.0,
            _ => Beta::new(a, b)
                .expect("beta")
                .inverse_cdf(if lower { 0.025 } else { 0.975 }),
        }
    };
    println!(
        "\nWithin 2σ per (case, parameter): seeds within / seeds with a z (share, 95 % interval):"
    );
    let mut below = vec![];
    for (i, t) in done {
        let mut v = vec![];
        for (n, p) in &t.params {
            let nz = p.n_z() as u64;
            if nz == 0 {
                continue;
            }
            let k = p.within_2sigma as u64;
            let share = k as f64 / nz as f64;
            let (lo, hi) = (bound(k, nz, true), bound(k, nz, false));
            v.push(format!(
                "{n} {k}/{nz} ({:.0} %, {:.0}–{:.0} %)",
                100.0 * share,
                100.0 * lo,
                100.0 * hi
            ));
            if hi < 0.9 {
                below.push(format!("{} {n}", cases[*i].label()));
            }
        }
        if !v.is_empty() {
            println!("* {}: {}", cases[*i].label(), v.join("; "));
        }
    }
    println!(
        "Pairs whose 95 % interval lies below 90 %: {}.",
        if below.is_empty() {
            "none".to_string()
        } else {
            below.join(", ")
        }
    );
}

/// The held-out / floor ratio over every check (mean, 99th percentile, largest), the checks
/// above [`FLOOR_LIMIT`] with their lack-of-fit p, and the lack-of-fit test's rejections
/// at 1 % and 5 % and its p-values by decile, per maker.
fn ratios_and_lack_of_fit(cases: &[common::Case], done: &[(usize, CaseTally)]) {
    let mut ratios: Vec<f64> = done
        .iter()
        .flat_map(|(_, t)| t.checks.iter().map(|c| c.1))
        .collect();
    ratios.sort_by(f64::total_cmp);
    let n = ratios.len();
    let q99 = ratios[((0.99 * n as f64).ceil() as usize).clamp(1, n) - 1];
    println!(
        "\nHeld-out / floor over {n} checks: mean {:.3}, 99th percentile {q99:.3}, largest {:.3}.",
        ratios.iter().sum::<f64>() / n as f64,
        ratios[n - 1]
    );
    for (i, t) in done {
        for (seed, ratio, p) in &t.checks {
            if *ratio > FLOOR_LIMIT {
                println!(
                    "  above {FLOOR_LIMIT}: {} seed {seed}: {ratio:.3}, lack-of-fit p = {p:.3}",
                    cases[*i].label()
                );
            }
        }
    }
    for maker in Maker::ALL {
        let p: Vec<f64> = done
            .iter()
            .filter(|(i, _)| cases[*i].maker == maker)
            .flat_map(|(_, t)| t.checks.iter().map(|c| c.2))
            .collect();
        if p.is_empty() {
            continue;
        }
        let mut deciles = [0usize; 10];
        for v in &p {
            deciles[((v * 10.0) as usize).min(9)] += 1;
        }
        println!(
            "Lack-of-fit test, {}: {} checks, p < 1 %: {}, p < 5 %: {}, p by decile {deciles:?}.",
            maker.name(),
            p.len(),
            p.iter().filter(|v| **v < 0.01).count(),
            p.iter().filter(|v| **v < 0.05).count()
        );
    }
}
