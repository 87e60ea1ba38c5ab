//! The cradle rigidity test matrix, every case and seed, as the table of docs/cradle.md:
//! `cargo run -p mtcal-solver --example cradle_matrix [SEEDS] [THREADS] [FILTER]`
//! (default 20 seeds, 2 threads, every case; FILTER keeps the cases whose label contains
//! it). The cases and how the points are made:
//! `crates/solver/tests/cradle_matrix_common/mod.rs`; the test `cradle_matrix` runs a
//! subset in the normal test command.

#[path = "../tests/cradle_matrix_common/mod.rs"]
mod common;

use common::{CaseTally, FLOOR_LIMIT, HEADER, matrix, row, run_case};
use statrs::distribution::{Binomial, DiscreteCDF};
use std::collections::BTreeMap;
use std::sync::Mutex;

fn main() {
    let mut args = std::env::args().skip(1);
    let seeds: u64 = args.next().map_or(20, |s| s.parse().expect("SEEDS"));
    let threads: usize = args.next().map_or(2, |s| s.parse().expect("THREADS"));
    // Optional: only the cases whose label contains FILTER (diagnostics).
    let filter = args.next();
    let cases: Vec<_> = matrix()
        .into_iter()
        .filter(|c| filter.as_deref().is_none_or(|f| c.label().contains(f)))
        .collect();
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
                    let t = run_case(case, 1..=seeds);
                    eprintln!("{} ({:?})", row(case, &t), t0.elapsed());
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
        "\n{} cases × {seeds} seeds ({checks} checks) in {:.0?}.\nHeld-out / floor above {FLOOR_LIMIT}: {over} of {checks} checks (largest {ratio_max:.3}).\nWithin 2σ of the truth (or reported as not separable): tilts and mount height {main_in}/{main} ({:.1} %), other terms {other_in}/{other} ({:.1} %).\nParameters off by more than 2σ in more than 10 % of a case's seeds: {}.",
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
}
