//! The misfit gate's factor: the ratio residual RMS / noise floor of identification on
//! clean simulated sessions (both plans, three noise levels, many seeds) and on sessions
//! with each effect of the catalogue (default and random sizes, and a quarter of them).
//! Prints one line per session; docs/conventions.md ("The misfit gate") summarises it.
//!
//! `cargo run -p mtcal-solver --example misfit_sweep -- [SEEDS]`

use mtcal_solver::identification::{IdentifyOptions, identify};
use mtcal_solver::simulate::effects::EFFECT_NAMES;
use mtcal_solver::simulate::{Effect, Plan, SimOptions, random_truth, simulate};
use rand::SeedableRng;
use rand::rngs::StdRng;

fn ratio(plan: &Plan, seed: u64, noise: f64, rate: f64, effects: Vec<Effect>) -> (f64, f64, f64) {
    let o = SimOptions {
        plan: plan.clone(),
        seed,
        sample_rate_hz: rate,
        noise_um: noise,
        effects,
        ..SimOptions::default()
    };
    let s = simulate(&random_truth(seed), &o).unwrap().session;
    let r = identify(&s, &IdentifyOptions::default()).unwrap();
    let f = r.fit.noise_estimate_um.unwrap_or(f64::NAN);
    (r.fit.residual_rms_um / f, r.fit.residual_rms_um, f)
}

fn main() {
    let seeds: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(20);
    let plans = [("seed", Plan::Seed), ("full", Plan::Full)];
    for (pname, plan) in &plans {
        for noise in [0.05, 0.15, 0.5] {
            let mut rs = vec![];
            for seed in 0..seeds {
                let (q, res, f) = ratio(plan, 1000 + seed, noise, 20.0, vec![]);
                println!(
                    "clean {pname} noise {noise} seed {seed} ratio {q:.4} residual {res:.4} floor {f:.4}"
                );
                rs.push(q);
            }
            rs.sort_by(f64::total_cmp);
            println!(
                "SUMMARY clean {pname} noise {noise}: min {:.4} median {:.4} max {:.4}",
                rs[0],
                rs[rs.len() / 2],
                rs[rs.len() - 1]
            );
        }
        // 100 Hz, a few seeds.
        for seed in 0..seeds.min(5) {
            let (q, res, f) = ratio(plan, 2000 + seed, 0.15, 100.0, vec![]);
            println!(
                "clean100 {pname} noise 0.15 seed {seed} ratio {q:.4} residual {res:.4} floor {f:.4}"
            );
        }
    }
    for (pname, plan) in &plans {
        for name in EFFECT_NAMES {
            let e = Effect::default_for(name).unwrap();
            let (q, _, _) = ratio(plan, 7, 0.15, 20.0, vec![e]);
            println!("EFFECT default {pname} {name} ratio {q:.4}");
            for seed in 0..3u64 {
                let mut rng = StdRng::seed_from_u64(seed + 77);
                let e = Effect::random(name, &mut rng, 10.0).unwrap();
                let (q, _, _) = ratio(plan, 100 + seed, 0.15, 20.0, vec![e.clone()]);
                println!("EFFECT random {pname} {name} seed {seed} ratio {q:.4} {e:?}");
            }
        }
    }
}
