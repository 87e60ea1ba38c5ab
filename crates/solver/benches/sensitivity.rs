//! Sensitivity benchmarks: the 35-error model (hmc4-b) over a 100 × 100 × 100 grid of the
//! linear axes at B = 0 (10⁶ analytic Jacobians with mean/max accumulation), and the
//! global analysis on the default 256-pose subsample.
//!
//! Run: `cargo bench -p mtcal-solver --bench sensitivity`.

use criterion::{Criterion, criterion_group, criterion_main};
use mtcal_solver::sensitivity::{
    Chain, GlobalOptions, GridAxis, Magnitudes, Poses, global, local, templates,
};
use std::hint::black_box;

fn grid_100() -> Poses {
    let desc = templates::hmc4_b();
    let chain = Chain::new(&desc).unwrap();
    let mut axes: Vec<GridAxis> = chain
        .travel()
        .iter()
        .map(|t| GridAxis {
            min: t[0],
            max: t[1],
            n: 100,
        })
        .collect();
    axes[3] = GridAxis {
        min: 0.0,
        max: 0.0,
        n: 1,
    };
    Poses::Grid(axes)
}

/// User + system CPU time of this process, s (Linux /proc/self/stat, 100 ticks/s).
fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    let rest = &stat[stat.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}

fn bench(c: &mut Criterion) {
    let desc = templates::hmc4_b();
    let chain = Chain::new(&desc).unwrap();
    let mags = Magnitudes::new(&chain, &desc, None);
    let poses = grid_100();
    // CPU time per grid evaluation (wall time on a shared machine waits for a core).
    if let Some(t0) = cpu_seconds() {
        let runs = 3;
        for _ in 0..runs {
            black_box(local::local_stats(&chain, &mags, &poses, false));
        }
        if let Some(t1) = cpu_seconds() {
            println!(
                "CPU time per 10^6-pose grid evaluation: {:.3} s",
                (t1 - t0) / runs as f64
            );
        }
    }
    let mut g = c.benchmark_group("sensitivity");
    g.sample_size(10);
    g.bench_function("hmc4-b 35 errors, 100x100x100 grid", |b| {
        b.iter(|| local::local_stats(black_box(&chain), &mags, &poses, false))
    });
    let sub = poses.subsample(256);
    let opts = GlobalOptions {
        samples: 1024,
        ..Default::default()
    };
    g.bench_function("hmc4-b Sobol N=1024, 256 poses", |b| {
        b.iter(|| global::sobol(black_box(&chain), &mags, &sub, &opts).unwrap())
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
