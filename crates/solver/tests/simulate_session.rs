//! The simulator against its own definition and against the linear model.

use mtcal_solver::axis::{Axis, Plane, Topology};
use mtcal_solver::basis::PolyErrors;
use mtcal_solver::kinematics::linear_error_um;
use mtcal_solver::session::{Session, TestKind};
use mtcal_solver::simulate::{Effect, Plan, SimOptions, SimOutput, Truth, random_truth, simulate};
use mtcal_solver::terms::Term;

/// A small sample rate keeps these tests fast; the motion is the same.
fn opts(plan: Plan, seed: u64, noise: f64) -> SimOptions {
    SimOptions {
        plan,
        seed,
        noise_um: noise,
        sample_rate_hz: 20.0,
        ..SimOptions::default()
    }
}

/// (du, dv) with the simulator's own plate rotation and run offsets removed.
/// (plane, commanded q, head offset, du, dv) of one sample.
type Reading = (Plane, [f64; 3], [f64; 3], f64, f64);

fn stripped(out: &SimOutput) -> Vec<Reading> {
    let t = &out.truth;
    let mut v = Vec::new();
    for p in &out.session.planes {
        let phi = t.mounting_rotation_urad[&p.mounting];
        let (ua, va) = p.plane.axes();
        for r in &p.runs {
            let off = t
                .run_offsets
                .iter()
                .find(|o| o.file == p.file && o.run == r.number)
                .unwrap();
            for i in 0..r.len() {
                let q = r.pos_mm[i];
                let u = q[ua.index()] + p.head_offset_mm[ua.index()];
                let w = q[va.index()] + p.head_offset_mm[va.index()];
                v.push((
                    p.plane,
                    q,
                    p.head_offset_mm,
                    r.du_um[i] - off.du_um - phi * w * 1e-3,
                    r.dv_um[i] - off.dv_um + phi * u * 1e-3,
                ));
            }
        }
    }
    v
}

/// A perfect machine: after removing rotation and offsets the readings are pure noise,
/// mean 0 and standard deviation σ. With n ≈ 2·10⁴ values per component the sample σ is
/// within ±2 % of σ (1σ ≈ 0.5 %), the mean within ±0.01 µm (4σ of the mean: 0.0011 µm).
#[test]
fn perfect_machine_is_noise_offsets_and_rotation() {
    let out = simulate(&PolyErrors::default(), &opts(Plan::Seed, 3, 0.15)).unwrap();
    let s = stripped(&out);
    assert!(s.len() > 10_000, "{} samples", s.len());
    for comp in 0..2 {
        let x: Vec<f64> = s
            .iter()
            .map(|r| if comp == 0 { r.3 } else { r.4 })
            .collect();
        let n = x.len() as f64;
        let mean = x.iter().sum::<f64>() / n;
        let sd = (x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        assert!(mean.abs() < 0.01, "mean {mean}");
        assert!((sd / 0.15 - 1.0).abs() < 0.02, "sd {sd}");
    }
    // Offsets are a few µm and rotations tens of µrad: they are really there.
    assert!(out.truth.run_offsets.iter().any(|o| o.du_um.abs() > 1.0));
    assert!(
        out.truth
            .mounting_rotation_urad
            .values()
            .any(|r| r.abs() > 10.0)
    );
}

/// Noise-free readings equal the in-plane components of the linear model to first order:
/// the exact-chain remainder is second order, about (Σ angles)² · arm ≈ (100 µrad)² ·
/// 300 mm ≈ 3e-3 µm here (tolerance 1e-2 µm), against errors of several µm; and halving
/// every error quarters it (quadratic remainder, ratio within 4 ± 0.2).
#[test]
fn readings_equal_linear_model_to_first_order() {
    let truth = random_truth(11);
    let dev = |scale: f64| {
        let mut t = truth.clone();
        for c in t.coefficients.values_mut() {
            c.iter_mut().for_each(|v| *v *= scale);
        }
        t.squareness.ec0y_urad *= scale;
        t.squareness.eb0z_urad *= scale;
        t.squareness.ea0z_urad *= scale;
        let out = simulate(&t, &opts(Plan::Full, 11, 0.0)).unwrap();
        let topo = Topology::default();
        let mut max_dev: f64 = 0.0;
        let mut max_signal: f64 = 0.0;
        for (plane, q, off, du, dv) in stripped(&out) {
            let e = linear_error_um(&topo, &t, q, off);
            let (ua, va) = plane.axes();
            max_dev = max_dev.max((e[ua.index()] - du).abs().max((e[va.index()] - dv).abs()));
            max_signal = max_signal.max(du.abs()).max(dv.abs());
        }
        (max_dev, max_signal)
    };
    let (d1, signal) = dev(1.0);
    assert!(signal > 2.0, "signal {signal}");
    assert!(d1 < 1e-2, "exact vs linear: {d1} µm");
    let (d2, _) = dev(0.5);
    assert!((d1 / d2 - 4.0).abs() < 0.2, "remainder ratio {}", d1 / d2);
}

fn all_times(s: &Session) -> Vec<f64> {
    s.planes
        .iter()
        .flat_map(|p| p.runs.iter())
        .flat_map(|r| r.t_s.iter().copied())
        .collect()
}

/// Time increases strictly within runs and across the whole session, and sample spacing
/// is 1/rate inside a run.
#[test]
fn timing_is_monotonic_over_the_session() {
    let o = opts(Plan::Full, 2, 0.15);
    let out = simulate(&random_truth(2), &o).unwrap();
    let t = all_times(&out.session);
    assert!(t.windows(2).all(|w| w[1] > w[0]));
    for r in out.session.planes.iter().flat_map(|p| p.runs.iter()) {
        for w in r.t_s.windows(2) {
            assert!((w[1] - w[0] - 1.0 / o.sample_rate_hz).abs() < 1e-9);
        }
    }
}

/// Path speed never exceeds the feed, reaches it on lines and circles (cruise), and the
/// acceleration stays within the profile's 500 mm/s² (finite differences at 200 Hz:
/// exact for the piecewise-quadratic path except across a ramp boundary).
#[test]
fn feed_and_acceleration_are_respected() {
    let o = SimOptions {
        sample_rate_hz: 200.0,
        ..opts(Plan::Seed, 5, 0.0)
    };
    let out = simulate(&PolyErrors::default(), &o).unwrap();
    let feed = 500.0 / 60.0;
    for p in &out.session.planes {
        for r in &p.runs {
            let dt = 1.0 / o.sample_rate_hz;
            let speeds: Vec<f64> = r
                .pos_mm
                .windows(2)
                .map(|w| {
                    let d: f64 = (0..3).map(|i| (w[1][i] - w[0][i]).powi(2)).sum();
                    d.sqrt() / dt
                })
                .collect();
            let vmax = speeds.iter().cloned().fold(0.0, f64::max);
            assert!(
                vmax <= feed * (1.0 + 1e-9),
                "{} run {}: {vmax}",
                p.file,
                r.number
            );
            assert!(vmax > feed * 0.999, "{} run {}: {vmax}", p.file, r.number);
            // Along a line the speed changes by at most a·dt per sample.
            if r.test.is_some_and(|t| t.is_line()) {
                for w in speeds.windows(2) {
                    assert!((w[1] - w[0]).abs() <= 500.0 * dt * (1.0 + 1e-6));
                }
            }
            // The run ends with a dwell at its end point.
            let n = r.len();
            assert_eq!(r.pos_mm[n - 1], r.pos_mm[n - 2]);
        }
    }
}

/// The seed plan as the contract states it: XY at z = 0, XZ at y = 0, YZ at x = 120;
/// per plane 2 lines × 10 passes over ±50 mm then a ccw and a cw circle of R50;
/// t = (0, 0, −100); one mounting per plane. Full: three offsets, mountings kept.
#[test]
fn seed_and_full_plan_structure() {
    let out = simulate(&random_truth(1), &opts(Plan::Seed, 1, 0.15)).unwrap();
    let s = &out.session;
    assert_eq!(s.planes.len(), 3);
    let park = [
        (Plane::XY, Axis::Z, 0.0),
        (Plane::XZ, Axis::Y, 0.0),
        (Plane::YZ, Axis::X, 120.0),
    ];
    for (p, (plane, normal, at)) in s.planes.iter().zip(park) {
        assert_eq!(p.plane, plane);
        assert_eq!(p.head_offset_mm, [0.0, 0.0, -100.0]);
        assert_eq!(p.runs.len(), 22);
        let (ua, va) = plane.axes();
        for r in &p.runs {
            assert!(r.pos_mm.iter().all(|q| q[normal.index()] == at));
        }
        for (k, r) in p.runs.iter().enumerate() {
            assert_eq!(r.number, k as i64 + 1);
            let (axis, kind) = match k {
                0..=9 => (Some(ua), TestKind::LineX),
                10..=19 => (Some(va), TestKind::LineX),
                20 => (None, TestKind::CircleCcw),
                _ => (None, TestKind::CircleCw),
            };
            match axis {
                Some(a) => {
                    let first = r.pos_mm[0][a.index()];
                    let last = r.pos_mm[r.len() - 1][a.index()];
                    let sense = if k % 2 == 0 { 1.0 } else { -1.0 };
                    assert_eq!((first, last), (-50.0 * sense, 50.0 * sense));
                    let other = if a == ua { va } else { ua };
                    assert!(r.pos_mm.iter().all(|q| q[other.index()] == 0.0));
                }
                None => {
                    assert_eq!(r.test, Some(kind));
                    for q in &r.pos_mm {
                        let rad = q[ua.index()].hypot(q[va.index()]);
                        assert!((rad - 50.0).abs() < 1e-9);
                    }
                    // Direction: at a quarter of the circle the ccw run is at +v.
                    let q = r.pos_mm[r.len() / 4];
                    let sign = if kind == TestKind::CircleCcw {
                        1.0
                    } else {
                        -1.0
                    };
                    assert!(q[va.index()] * sign > 40.0, "{q:?}");
                }
            }
        }
    }
    let mounts: std::collections::BTreeSet<_> = s.planes.iter().map(|p| &p.mounting).collect();
    assert_eq!(mounts.len(), 3);

    let full = simulate(&random_truth(1), &opts(Plan::Full, 1, 0.15)).unwrap();
    assert_eq!(full.session.planes.len(), 9);
    let mounts: std::collections::BTreeSet<_> =
        full.session.planes.iter().map(|p| &p.mounting).collect();
    assert_eq!(mounts.len(), 3, "full plan keeps each plane's mounting");
    let offsets: std::collections::BTreeSet<String> = full
        .session
        .planes
        .iter()
        .map(|p| format!("{:?}", p.head_offset_mm))
        .collect();
    assert_eq!(offsets.len(), 3);
    // Separate mountings per offset for the intermediate rows of the table.
    let sep = Plan::custom(&[[0.0, 0.0, -100.0], [0.0, 0.0, -200.0]], false).tests();
    let m: std::collections::BTreeSet<_> = sep.iter().map(|p| p.mounting.clone()).collect();
    assert_eq!((sep.len(), m.len()), (6, 6));
}

/// Line labels name the moving axis.
#[test]
fn line_labels_name_the_moving_axis() {
    let out = simulate(&PolyErrors::default(), &opts(Plan::Seed, 1, 0.0)).unwrap();
    for p in &out.session.planes {
        let (ua, va) = p.plane.axes();
        let want = |a: Axis| match a {
            Axis::X => TestKind::LineX,
            Axis::Y => TestKind::LineY,
            Axis::Z => TestKind::LineZ,
        };
        assert_eq!(p.runs[0].test, Some(want(ua)));
        assert_eq!(p.runs[10].test, Some(want(va)));
    }
}

/// The truth on the reporting grid: straightness has a zero least-squares line over the
/// travel (checked by a fine Riemann sum, tolerance from its O(h²) error), positioning is
/// the function itself, the squareness follows the contract's formula, and the document
/// survives a JSON round trip.
#[test]
fn truth_uses_the_reporting_conventions() {
    let truth = random_truth(7);
    let out = simulate(&truth, &opts(Plan::Seed, 7, 0.15)).unwrap();
    let t = &out.truth;
    assert_eq!(t.travel_mm["X"], [-50.0, 50.0]);
    let eyx = &t.terms["EYX"];
    assert_eq!(eyx.positions_mm.len(), 21);
    // LS line of the reported straightness (re-evaluated finely) vanishes.
    let f = |q: f64| {
        let term = Term::parse("EYX").unwrap();
        truth.value(term, q)
    };
    let (a, b) = mtcal_solver::simulate::truth::ls_line(f, -50.0, 50.0);
    let n = 20_000;
    let (mut s0, mut s1) = (0.0, 0.0);
    for i in 0..n {
        let q = -50.0 + 100.0 * (i as f64 + 0.5) / n as f64;
        let r = f(q) - a - b * q;
        s0 += r / n as f64;
        s1 += r * q / n as f64;
    }
    assert!(s0.abs() < 1e-6 && s1.abs() < 1e-4, "{s0} {s1}");
    for (q, v) in eyx.positions_mm.iter().zip(&eyx.values) {
        assert!((v - (f(*q) - a - b * q)).abs() < 1e-12);
    }
    let exx = &t.terms["EXX"];
    let term = Term::parse("EXX").unwrap();
    for (q, v) in exx.positions_mm.iter().zip(&exx.values) {
        assert_eq!(*v, truth.value(term, *q));
    }
    let slope = |n: &str| {
        let term = Term::parse(n).unwrap();
        mtcal_solver::simulate::truth::ls_line(|q| truth.value(term, q), -50.0, 50.0).1 * 1e3
    };
    let want = truth.squareness.ec0y_urad - slope("EXY") - slope("EYX");
    assert!((t.squareness_urad["EC0Y"] - want).abs() < 1e-9);
    let json = serde_json::to_string(t).unwrap();
    // serde_json's default float parsing may move the last bit: compare within 1e-12.
    let back: Truth = serde_json::from_str(&json).unwrap();
    assert_eq!(
        (back.seed, &back.effects, &back.travel_mm),
        (t.seed, &t.effects, &t.travel_mm)
    );
    for (name, tt) in &t.terms {
        for (a, b) in tt.values.iter().zip(&back.terms[name].values) {
            assert!((a - b).abs() <= 1e-12 * a.abs().max(1.0));
        }
    }
    assert_eq!(back.run_offsets.len(), t.run_offsets.len());
}

/// Same seed, same session; another seed, other noise.
#[test]
fn simulation_is_deterministic() {
    let truth = random_truth(4);
    let a = simulate(&truth, &opts(Plan::Seed, 4, 0.15)).unwrap();
    let b = simulate(&truth, &opts(Plan::Seed, 4, 0.15)).unwrap();
    let c = simulate(&truth, &opts(Plan::Seed, 5, 0.15)).unwrap();
    assert_eq!(a, b);
    assert_ne!(
        a.session.planes[0].runs[0].du_um,
        c.session.planes[0].runs[0].du_um
    );
    assert_ne!(random_truth(4), random_truth(5));
}

/// random_truth magnitudes over the seed travel (±50 mm), over 20 machines: positioning
/// within ±15 µm, straightness (no linear term) within ±6 µm, angles within ±60 µrad,
/// squareness within ±30 µrad; and not all tiny.
#[test]
fn random_truth_has_realistic_magnitudes() {
    let mut peak_pos: f64 = 0.0;
    for seed in 0..20 {
        let e = random_truth(seed);
        for term in Term::all() {
            let c = &e.coefficients[&term.name()];
            let peak = (-50..=50)
                .map(|q| e.value(term, q as f64).abs())
                .fold(0.0, f64::max);
            use mtcal_solver::terms::TermKind::*;
            let lim = match term.kind() {
                Positioning => {
                    peak_pos = peak_pos.max(peak);
                    15.0
                }
                Straightness => {
                    assert_eq!(c[0], 0.0);
                    6.0
                }
                _ => 60.0,
            };
            assert!(peak < lim, "seed {seed} {term}: {peak}");
        }
        let s = e.squareness;
        assert!(
            s.ec0y_urad.abs() <= 30.0 && s.eb0z_urad.abs() <= 30.0 && s.ea0z_urad.abs() <= 30.0
        );
    }
    assert!(peak_pos > 3.0);
}

/// Each effect adds exactly its formula: same seed with and without the effect differ by
/// the effect's in-plane error (the random draws do not depend on the effects).
#[test]
fn effects_add_their_formula() {
    let truth = random_truth(9);
    let base = simulate(&truth, &opts(Plan::Seed, 9, 0.15)).unwrap();
    for name in mtcal_solver::simulate::effects::EFFECT_NAMES {
        if name == "setup_offset" {
            continue;
        }
        let eff = Effect::default_for(name).unwrap();
        let o = SimOptions {
            effects: vec![eff.clone()],
            ..opts(Plan::Seed, 9, 0.15)
        };
        let with = simulate(&truth, &o).unwrap();
        let mut max_effect: f64 = 0.0;
        for (pb, pw) in base.session.planes.iter().zip(&with.session.planes) {
            for (rb, rw) in pb.runs.iter().zip(&pw.runs) {
                for i in 0..rb.len() {
                    let d = (rw.du_um[i] - rb.du_um[i])
                        .abs()
                        .max((rw.dv_um[i] - rb.dv_um[i]).abs());
                    max_effect = max_effect.max(d);
                }
            }
        }
        assert!(max_effect > 0.1, "{name}: {max_effect}");
        assert_eq!(with.truth.effects, vec![eff]);
    }
    // Backlash: on an X line pass in +X, du is lower by b/2 than with no effect.
    let o = SimOptions {
        effects: vec![Effect::from_spec("backlash:axis=X,lost_motion_um=6").unwrap()],
        ..opts(Plan::Seed, 9, 0.15)
    };
    let with = simulate(&truth, &o).unwrap();
    let (rb, rw) = (
        &base.session.planes[0].runs[0],
        &with.session.planes[0].runs[0],
    );
    for i in 1..rb.len() {
        assert!((rw.du_um[i] - rb.du_um[i] + 3.0).abs() < 1e-9);
    }
    let (rb, rw) = (
        &base.session.planes[0].runs[1],
        &with.session.planes[0].runs[1],
    );
    for i in 1..rb.len() {
        assert!((rw.du_um[i] - rb.du_um[i] - 3.0).abs() < 1e-9);
    }
}

/// A wrong declared head offset changes readings through the Abbe arms only.
#[test]
fn setup_offset_acts_through_abbe_arms() {
    let truth = random_truth(9);
    let base = simulate(&truth, &opts(Plan::Seed, 9, 0.0)).unwrap();
    let o = SimOptions {
        effects: vec![Effect::from_spec("setup_offset:delta_mm=0/0/10").unwrap()],
        ..opts(Plan::Seed, 9, 0.0)
    };
    let with = simulate(&truth, &o).unwrap();
    let topo = Topology::default();
    let pb = &base.session.planes[0];
    let pw = &with.session.planes[0];
    let mut max: f64 = 0.0;
    for (rb, rw) in pb.runs.iter().zip(&pw.runs) {
        for i in 0..rb.len() {
            let q = rb.pos_mm[i];
            let e0 = linear_error_um(&topo, &truth, q, [0.0, 0.0, -100.0]);
            let e1 = linear_error_um(&topo, &truth, q, [0.0, 0.0, -90.0]);
            // XY plate: the rotation term uses in-plane (x, y), unchanged by a Z shift.
            let want = e1 - e0;
            assert!((rw.du_um[i] - rb.du_um[i] - want.x).abs() < 2e-3);
            assert!((rw.dv_um[i] - rb.dv_um[i] - want.y).abs() < 2e-3);
            max = max.max(want.x.abs());
        }
    }
    assert!(max > 0.01, "{max}");
}

/// Bad effect specifications are refused with a message naming the problem.
#[test]
fn effect_specs_are_checked() {
    let e = Effect::from_spec("cyclic:axis=Y,period_mm=16").unwrap();
    assert!(matches!(e, Effect::Cyclic { axis: Axis::Y, period_mm, .. } if period_mm == 16.0));
    assert!(
        Effect::from_spec("wobble")
            .unwrap_err()
            .contains("unknown effect `wobble`")
    );
    assert!(
        Effect::from_spec("backlash:size=3")
            .unwrap_err()
            .contains("no parameter `size`")
    );
    assert!(
        Effect::from_spec("backlash:axis=Q")
            .unwrap_err()
            .contains("not an axis")
    );
    assert!(
        Effect::from_spec("backlash:lost_motion_um=abc")
            .unwrap_err()
            .contains("not a number")
    );
    assert!(
        Effect::from_spec("thermal_drift:offset_um=1/2")
            .unwrap_err()
            .contains("three values")
    );
}
