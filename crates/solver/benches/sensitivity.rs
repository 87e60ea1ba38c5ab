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

fn bench(c: &mut Criterion) {
    let desc = templates::hmc4_b();
    let chain = Chain::new(&desc).unwrap();
    let mags = Magnitudes::new(&chain, &desc, None);
    let poses = grid_100();
    let mut g = c.benchmark_group("sensitivity");
    g.sample_size(10);
    g.bench_function("hmc4-b 35 errors, 100x100x100 grid", |b| {
        b.iter(|| local::local_stats(black_box(&chain), &mags, &poses))
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
