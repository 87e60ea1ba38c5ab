//! ISO 230-4 figures on circles with known radius error, ovality, squareness and backlash,
//! where G, H, F and the mean radial deviation are known in closed form
//! (`docs/standards.md`), from hand-built runs and from the session simulator.

use mtcal_solver::axis::{Axis, Plane};
use mtcal_solver::basis::PolyErrors;
use mtcal_solver::session::{PlaneRecord, Run, Session, TestKind};
use mtcal_solver::simulate::{Effect, Plan, SimOptions, simulate};
use mtcal_solver::standards::iso230_4::{self, CirclePath, Iso2304};
use mtcal_solver::standards::{self, Standards};
use mtcal_solver::terms::Term;
use std::f64::consts::PI;

fn close(a: f64, b: f64, tol: f64, what: &str) {
    assert!((a - b).abs() <= tol, "{what}: {a} vs {b} (tol {tol})");
}

const R: f64 = 50.0;
const C: [f64; 2] = [10.0, -20.0];
/// Samples per turn; the angles sit half a step off the bin edges.
const N: usize = 7200;

/// A circle run in XY about `C`, radius `R`, 20 samples per 1° bin, counter-clockwise
/// when `ccw`, with deviations `dev(u, v, u̇, v̇)` → (du, dv) µm (u, v in mm about the
/// machine zero; velocities in the sense of the motion).
fn circle(ccw: bool, number: i64, dev: &dyn Fn(f64, f64, f64, f64) -> (f64, f64)) -> Run {
    let sense = if ccw { 1.0 } else { -1.0 };
    let mut run = Run {
        number,
        test: None,
        ..Run::default()
    };
    for k in 0..N {
        let th = sense * 2.0 * PI * (k as f64 + 0.5) / N as f64;
        let (u, v) = (C[0] + R * th.cos(), C[1] + R * th.sin());
        let (ud, vd) = (-sense * th.sin(), sense * th.cos());
        let (du, dv) = dev(u, v, ud, vd);
        run.t_s.push(k as f64 * 0.01);
        run.pos_mm.push([u, v, 0.0]);
        run.du_um.push(du);
        run.dv_um.push(dv);
    }
    run
}

fn session_of(runs: Vec<Run>) -> Session {
    Session {
        machine_id: "T".into(),
        measured_at: "2026-01-01T00:00:00Z".into(),
        topology: None,
        conditions: Default::default(),
        notes: None,
        planes: vec![PlaneRecord {
            file: "xy.csv".into(),
            plane: Plane::XY,
            head_offset_mm: [0.0, 0.0, -100.0],
            mounting: "xy".into(),
            runs,
        }],
    }
}

fn figures(dev: &dyn Fn(f64, f64, f64, f64) -> (f64, f64)) -> Iso2304 {
    let s = session_of(vec![circle(true, 1, dev), circle(false, 2, dev)]);
    let mut v = iso230_4::from_session(&s);
    assert_eq!(v.len(), 1);
    v.remove(0)
}

/// Scale errors s_u = 10 ppm, s_v = 30 ppm about the machine zero (du = s_u·u·10³ µm):
/// about the centre the radial deviation is R·10³·(s_u cos²θ + s_v sin²θ) = 0.5 cos²θ +
/// 1.5 sin²θ µm, plus a centre shift (s_u·C_u, s_v·C_v) the LSC removes. So mean radial
/// deviation R(s_u + s_v)/2 = 1.0 µm, G = R|s_u − s_v| = 1.0 µm (ovality), F_max = 1.5,
/// F_min = 0.5 µm, H = 0. Bins average cos 2θ over 1° (factor 1 − 5e-5) and sit at
/// 0.5° + k°: errors below 1e-3 µm; the exact geometry adds δ_t²/2R (δ_t the tangential
/// deviation, ~1 µm) ≈ 1e-5 µm to the first-order values.
#[test]
fn radius_error_and_ovality() {
    let f = figures(&|u, v, _, _| (0.01 * u, 0.03 * v));
    assert_eq!(f.plane, Plane::XY);
    close(f.diameter_mm, 2.0 * R, 1e-9, "diameter");
    assert_eq!(f.directions.len(), 2);
    for d in &f.directions {
        close(d.mean_radial_um, 1.0, 1e-4, "mean radial");
        close(d.g_um, 1.0, 1e-3, "G");
        close(d.f_max_um, 1.5, 1e-3, "F_max");
        close(d.f_min_um, 0.5, 1e-3, "F_min");
        // The LSC centre moves by the scale of the centre: (0.01·10, 0.03·(−20)) µm.
        close(d.centre_mm[0], C[0] + 1e-4, 1e-8, "centre u");
        close(d.centre_mm[1], C[1] - 6e-4, 1e-8, "centre v");
        // (chord, not arc, between samples: relative 1e-7)
        close(
            d.feed_mm_min,
            60.0 * 2.0 * PI * R / N as f64 / 0.01,
            1e-4,
            "feed",
        );
    }
    assert_eq!(f.directions[0].direction, "cw");
    assert_eq!(f.directions[1].direction, "ccw");
    close(f.directions[1].start_angle_deg, 0.025, 1e-9, "start angle");
    let b = f.bidirectional.as_ref().unwrap();
    close(b.h_um, 0.0, 1e-9, "H");
    close(b.g_um, 1.0, 1e-3, "G(b)");
    close(b.mean_radial_um, 1.0, 1e-4, "mean radial (b)");
}

/// Squareness γ = 20 µrad of v: du = −γ·10⁻³·(v − C_v) µm. Radial deviation
/// −γ·10⁻³·R·sinθ·cosθ = −(γR/2)·10⁻³·sin 2θ: G = γ·R·10⁻³ = 1.0 µm, F = ±0.5 µm, mean 0.
#[test]
fn squareness_gives_an_ellipse_at_45_degrees() {
    let f = figures(&|_, v, _, _| (-0.02 * (v - C[1]), 0.0));
    for d in &f.directions {
        close(d.g_um, 1.0, 1e-3, "G");
        close(d.f_max_um, 0.5, 1e-3, "F_max");
        close(d.f_min_um, -0.5, 1e-3, "F_min");
        close(d.mean_radial_um, 0.0, 1e-4, "mean radial");
    }
}

/// Backlash b = 2 µm on both axes, tool-relative (e = −sign(velocity)·b/2 per axis). For
/// ccw, u̇ = −R sinθ, v̇ = R cosθ, so the radial deviation is
/// f(θ) = (b/2)(sign(sin θ) cos θ − sign(cos θ) sin θ), a step of b at every axis
/// reversal; cw gives −f. f has no mean, no cos θ and no sin θ component (symmetry), so
/// the LSC is the nominal circle. Over bin centres 0.5° + k°, max f = (b/2)(cos 0.5° −
/// sin 0.5°) at 0.5°, min = −max at 359.5°: G(cw) = G(ccw) = G(b) = H =
/// b(cos 0.5° − sin 0.5°) = 1.98247 µm, to within the 1° bin averaging of cos θ − sin θ
/// and the second-order geometry (both ~1e-5 µm).
#[test]
fn backlash_gives_hysteresis() {
    let b = 2.0;
    let bl =
        move |_: f64, _: f64, ud: f64, vd: f64| (-ud.signum() * b / 2.0, -vd.signum() * b / 2.0);
    let f = figures(&bl);
    let expect = b * (0.5f64.to_radians().cos() - 0.5f64.to_radians().sin());
    for d in &f.directions {
        close(d.g_um, expect, 1e-4, "G");
        close(d.mean_radial_um, 0.0, 1e-4, "mean radial");
    }
    let bi = f.bidirectional.as_ref().unwrap();
    close(bi.h_um, expect, 1e-4, "H");
    close(bi.g_um, expect, 1e-4, "G(b)");
}

/// Backlash with radius error and ovality: H depends on the backlash only (the common
/// pattern cancels in e_cw − e_ccw); the mean radial deviation on the scales only.
#[test]
fn hysteresis_is_independent_of_the_common_pattern() {
    let b = 1.0;
    let dev = move |u: f64, v: f64, ud: f64, vd: f64| {
        (
            0.01 * u - ud.signum() * b / 2.0,
            0.03 * v - vd.signum() * b / 2.0,
        )
    };
    let f = figures(&dev);
    let bi = f.bidirectional.as_ref().unwrap();
    let expect = b * (0.5f64.to_radians().cos() - 0.5f64.to_radians().sin());
    close(bi.h_um, expect, 1e-4, "H");
    close(bi.mean_radial_um, 1.0, 1e-4, "mean radial (b)");
    // G(b) encloses both paths: at least each one's G.
    assert!(bi.g_um >= f.directions[0].g_um.max(f.directions[1].g_um));
    // Each path's own zero: shifting one run by a constant changes nothing (to second
    // order: (3.6 µm)²/2R ≈ 1e-4 µm).
    let shifted = move |u: f64, v: f64, ud: f64, vd: f64| {
        let (a, c) = dev(u, v, ud, vd);
        (a + 3.0, c - 2.0)
    };
    let s = session_of(vec![circle(true, 1, &dev), circle(false, 2, &shifted)]);
    let g = iso230_4::from_session(&s).remove(0);
    close(
        g.bidirectional.unwrap().h_um,
        bi.h_um,
        5e-4,
        "H with a zero offset",
    );
}

/// Stored names, uncertainty and the noise estimate: white noise σ = 0.1 µm per component
/// on a perfect circle has a radial component of σ too (√(cos²θ σ² + sin²θ σ²)), so
/// σ̂ ≈ 0.1 µm and u(G) = √2·σ/√20 with 20 samples per bin.
#[test]
fn noise_uncertainty_and_names() {
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};
    let rng = std::cell::RefCell::new(rand::rngs::StdRng::seed_from_u64(3));
    let n = Normal::new(0.0, 0.1).unwrap();
    let noisy = |_: f64, _: f64, _: f64, _: f64| {
        let mut r = rng.borrow_mut();
        (n.sample(&mut *r), n.sample(&mut *r))
    };
    let f = figures(&noisy);
    let d = &f.directions[0];
    close(d.noise_um, 0.1, 0.005, "σ̂");
    close(d.u["G_um"], 2f64.sqrt() * 0.1 / 20f64.sqrt(), 0.002, "u(G)");
    close(
        d.u["mean_radial_um"],
        0.1 / (N as f64).sqrt(),
        1e-4,
        "u(mean)",
    );
    let names: Vec<String> = f.scalar_figures().into_iter().map(|s| s.name).collect();
    for n in [
        "iso230_4.XY.cw.G_um",
        "iso230_4.XY.ccw.G_um",
        "iso230_4.XY.ccw.mean_radial_um",
        "iso230_4.XY.ccw.F_max_um",
        "iso230_4.XY.bi.G_um",
        "iso230_4.XY.bi.H_um",
    ] {
        assert!(names.iter().any(|x| x == n), "{n} missing from {names:?}");
    }
    assert_eq!(names.len(), 4 + 4 + 5);
}

/// A partial arc is reported as such.
#[test]
fn partial_arc_is_said() {
    let mut run = circle(true, 1, &|_, _, _, _| (0.0, 0.0));
    run.t_s.truncate(N / 2 + 100);
    run.pos_mm.truncate(N / 2 + 100);
    run.du_um.truncate(N / 2 + 100);
    run.dv_um.truncate(N / 2 + 100);
    assert_eq!(run.test_kind(Plane::XY), TestKind::CircleCcw);
    let f = iso230_4::from_session(&session_of(vec![run])).remove(0);
    assert!(f.bidirectional.is_none());
    assert!(
        f.notes.iter().any(|n| n.contains("not a full circle")),
        "{:?}",
        f.notes
    );
}

/// The session simulator (exact HTM chain, trapezoidal feed, per-run encoder zeros, plate
/// rotations, noise σ = 0.02 µm): EXX = 0.01·x, EYY = 0.03·y µm (10 and 30 ppm), nothing
/// else, circles R50 about the origin in XY. As in `radius_error_and_ovality`: mean radial
/// deviation 1.0 µm, G = 1.0 µm, F_max 1.5, F_min 0.5 µm (a plate rotation has no radial
/// component). With backlash b = 1.5 µm on X and Y added: H = b(cos 0.5° − sin 0.5°)
/// (bin-centre sampling of the step, as above) within the noise of two bin means.
#[test]
fn simulated_session_circles() {
    let mut truth = PolyErrors::default();
    truth.set(Term::parse("EXX").unwrap(), vec![0.01]);
    truth.set(Term::parse("EYY").unwrap(), vec![0.03]);
    let opts = SimOptions {
        plan: Plan::Seed,
        noise_um: 0.02,
        ..Default::default()
    };
    let out = simulate(&truth, &opts).unwrap();
    let st: Standards = standards::from_session(&out.session);
    assert_eq!(st.iso230_4.len(), 3, "XY, XZ, YZ");
    let xy = st.iso230_4.iter().find(|f| f.plane == Plane::XY).unwrap();
    assert_eq!(xy.file, "xy_t1.csv");
    close(xy.diameter_mm, 100.0, 1e-6, "diameter");
    for d in &xy.directions {
        close(d.mean_radial_um, 1.0, 0.01, "mean radial");
        close(d.g_um, 1.0, 0.05, "G");
        close(d.f_max_um, 1.5, 0.03, "F_max");
        close(d.f_min_um, 0.5, 0.03, "F_min");
        close(d.feed_mm_min, 500.0, 1.0, "feed");
    }
    let xz = st.iso230_4.iter().find(|f| f.plane == Plane::XZ).unwrap();
    assert!(xz.notes.iter().any(|n| n.contains("G18")));

    let b = 1.5;
    let out = simulate(
        &truth,
        &SimOptions {
            effects: vec![
                Effect::Backlash {
                    axis: Axis::X,
                    lost_motion_um: b,
                },
                Effect::Backlash {
                    axis: Axis::Y,
                    lost_motion_um: b,
                },
            ],
            ..opts
        },
    )
    .unwrap();
    let st = standards::from_session(&out.session);
    let xy = st.iso230_4.iter().find(|f| f.plane == Plane::XY).unwrap();
    let bi = xy.bidirectional.as_ref().unwrap();
    let expect = b * (0.5f64.to_radians().cos() - 0.5f64.to_radians().sin());
    close(bi.h_um, expect, 0.06, "H");
    close(bi.mean_radial_um, 1.0, 0.01, "mean radial (b)");
}

/// CirclePath keeps the moving samples only: a dwell at the end adds nothing.
#[test]
fn dwell_is_dropped() {
    let mut run = circle(true, 1, &|u, _, _, _| (0.01 * u, 0.0));
    let p0 = CirclePath::of(&run, Plane::XY, &run.du_um, &run.dv_um).unwrap();
    let last = *run.pos_mm.last().unwrap();
    for k in 0..500 {
        run.t_s.push(100.0 + k as f64 * 0.01);
        run.pos_mm.push(last);
        run.du_um.push(50.0);
        run.dv_um.push(50.0);
    }
    let p1 = CirclePath::of(&run, Plane::XY, &run.du_um, &run.dv_um).unwrap();
    assert_eq!(p0, p1);
}
