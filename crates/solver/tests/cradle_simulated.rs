//! Simulated cradles with known location errors (and compliance) recovered from noisy
//! ball data.
//!
//! Tolerances: the simulator's tracker noise is σ = 2 µm per coordinate; each check fits
//! 13 A poses × 18 C angles = 234 points (702 coordinates). Every estimate is asserted
//! within 4 of its own stated standard uncertainties of the truth (a 4σ band: a false
//! alarm rate below 1e-4 per quantity), and every stated uncertainty is asserted below a
//! bound derived from σ and the geometry (so a huge σ cannot make the test pass):
//! offsets ≤ 0.5 µm (σ/√N·a few), tilts ≤ 5 µrad (σ over arms of 60–150 mm, /√N).

use mtcal_solver::cradle::*;
use mtcal_solver::datasets::RotaryPointSet;
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};

fn truth_value(t: &CradleModel, name: &str) -> f64 {
    let l = &t.location;
    match name {
        "EY0A" => l.ey0a_um,
        "EZ0A" => l.ez0a_um,
        "EB0A" => l.eb0a_urad,
        "EC0A" => l.ec0a_urad,
        "EX0C" => l.ex0c_um,
        "EY0C" => l.ey0c_um,
        "EB0C" => l.eb0c_urad,
        "EA0A+EA0C" => l.ea0a_urad + l.ea0c_urad,
        _ => panic!("{name}"),
    }
}

fn assert_location_errors(r: &CradleResult, truth: &CradleModel, registered: bool) {
    for e in &r.location_errors {
        match (e.observability, registered) {
            (Observability::NotObservable, _) | (Observability::RegisteredFrame, false) => {
                assert!(
                    e.value.is_none() && e.std.is_none(),
                    "{} must have no value",
                    e.name
                );
                continue;
            }
            _ => {}
        }
        let (v, s) = (e.value.unwrap(), e.std.unwrap());
        let bound = if e.unit == "um" { 0.5 } else { 5.0 };
        assert!(
            s > 0.0 && s < bound,
            "{}: std {s} {} not in (0, {bound})",
            e.name,
            e.unit
        );
        let t = truth_value(truth, &e.name);
        assert!(
            (v - t).abs() < 4.0 * s,
            "{}: {v} vs truth {t} (std {s})",
            e.name
        );
    }
}

fn check(points: &RotaryPointSet) -> CradleResult {
    check_cradle(points, &CradleOptions::default()).unwrap()
}

/// Rigid cradle, three noise seeds: location errors recovered, the rigid model chosen,
/// the pooled rotation vectors zero within their stated uncertainty (4σ on the norm of
/// three components: |r| < 4·√3·std).
#[test]
fn rigid_cradle_recovers_location_errors_and_chooses_rigid() {
    for seed in [1, 2, 3] {
        let sim = CradleSimulation::example(false, seed);
        let r = check(&simulate_cradle(&sim));
        assert_eq!(r.kind, "cradle");
        assert_eq!(r.n_poses, 13);
        assert_eq!(r.kinematics.chosen, Dependence::Rigid, "seed {seed}");
        assert_location_errors(&r, &sim.truth, true);
        for p in &r.poses {
            // The patent's own vectors (single point and phase variants) are also zero
            // within their stated uncertainty, and each circle has the ball's radius.
            for v in [p.rotation_point, p.rotation_phase] {
                assert!(
                    v.norm_urad < 4.0 * 3f64.sqrt() * v.std_urad,
                    "seed {seed} A {}: {v:?}",
                    p.a_deg
                );
            }
            assert!(
                (p.radius_mm - 150.0).abs() < 4.0 * p.radius_std_um * 1e-3,
                "{p:?}"
            );
            let v = p.rotation_pooled;
            assert!(
                v.norm_urad < 4.0 * 3f64.sqrt() * v.std_urad,
                "seed {seed} A {}: {v:?}",
                p.a_deg
            );
            // The stated std is dominated by the centres' angle about A: tangential centre
            // noise σ·√(2/18) ≈ 0.67 µm over the 60 mm ball height, ≈ 11 µrad, for this
            // pose and the reference (√2·11 ≈ 16 µrad); the frames add ≈ 5 µrad.
            assert!(v.std_urad < 25.0, "{v:?}");
        }
        // Ball radius: truth 150 mm.
        let b = &r.kinematics.ball;
        assert!((b.radius_mm - 150.0).abs() < 4.0 * b.radius_std_um * 1e-3);
        // Fit residual at the noise level: σ̂ within 10 % of 2 µm (702 − 11 dof).
        assert!(
            (r.kinematics.rigid.sigma_um - 2.0).abs() < 0.2,
            "{}",
            r.kinematics.rigid.sigma_um
        );
    }
}

/// Compliant cradle: the compliant model chosen, its observable coefficients and the
/// location errors recovered within 4σ.
#[test]
fn compliant_cradle_recovers_compliance_and_chooses_compliant() {
    for seed in [1, 2] {
        let sim = CradleSimulation::example(true, seed);
        let r = check(&simulate_cradle(&sim));
        assert_eq!(r.kinematics.chosen, Dependence::Compliant, "seed {seed}");
        assert_location_errors(&r, &sim.truth, true);
        let c = r.kinematics.compliance.as_ref().unwrap();
        let est = [c.s_a_urad, c.k_a_urad, c.m_b_urad, c.m_c_urad];
        let truth = sim.truth.compliance.observable();
        for k in 0..4 {
            assert!(c.std_urad[k] < 5.0);
            assert!(
                (est[k] - truth[k]).abs() < 4.0 * c.std_urad[k],
                "{k}: {est:?} vs {truth:?}"
            );
        }
        // The rigid model cannot predict held-out poses as well.
        let hr = r.kinematics.rigid.held_out_rms_um.unwrap();
        let hc = r
            .kinematics
            .compliant
            .as_ref()
            .unwrap()
            .held_out_rms_um
            .unwrap();
        assert!(hc < 0.8 * hr, "{hc} vs {hr}");
    }
}

/// Without noise: a rigid cradle gives rotation vectors of zero (patent, phase and pooled
/// variants, to numerical precision) and the location errors exactly; a compliant cradle
/// gives rotation vectors that the sin/cos model describes (to < 0.1 µrad) and the
/// constant model does not (> 10 µrad).
#[test]
fn noise_free_rotation_vectors() {
    let mut sim = CradleSimulation::example(false, 0);
    sim.noise_um = 0.0;
    let r = check(&simulate_cradle(&sim));
    for p in &r.poses {
        for v in [p.rotation_point, p.rotation_phase, p.rotation_pooled] {
            assert!(v.norm_urad < 1e-3, "A {}: {v:?}", p.a_deg);
        }
        assert!(p.angle_deviation_urad.abs() < 1e-3);
    }
    for e in r.location_errors.iter().filter(|e| e.value.is_some()) {
        assert!(
            (e.value.unwrap() - truth_value(&sim.truth, &e.name)).abs() < 1e-4,
            "{}",
            e.name
        );
    }
    sim.truth = CradleSimulation::example(true, 0).truth;
    let r = check(&simulate_cradle(&sim));
    let dep = &r.rotation_model;
    assert!(
        dep.compliant.as_ref().unwrap().fit_rms_urad < 0.1,
        "{dep:?}"
    );
    assert!(dep.rigid.fit_rms_urad > 10.0, "{dep:?}");
    // The deflection is visible in the patent's own vectors.
    assert!(r.poses.iter().any(|p| p.rotation_point.norm_urad > 50.0));
}

/// The phase of all points gives a less noisy e₁ than the single point at C = 0: over
/// the poses of a rigid cradle, the RMS norm of the phase vectors is below that of the
/// patent's single-point vectors.
#[test]
fn phase_frame_is_less_noisy_than_single_point() {
    let r = check(&simulate_cradle(&CradleSimulation::example(false, 4)));
    let rms = |f: &dyn Fn(&PoseRow) -> f64| {
        (r.poses.iter().map(|p| f(p).powi(2)).sum::<f64>() / r.poses.len() as f64).sqrt()
    };
    let point = rms(&|p| p.rotation_point.norm_urad);
    let phase = rms(&|p| p.rotation_phase.norm_urad);
    assert!(phase < point, "phase {phase} vs point {point}");
    assert!(r.poses.iter().all(|p| p.x_point_c_deg == 0.0));
}

/// Compensation with the identified model, evaluated against the truth: the workpiece
/// point under the tool misses by the location errors and compliance before (tens of
/// µm), and by the model's estimation error after (below 1.5 µm, from parameter
/// uncertainties of ~0.2 µm and ~2 µrad over a 160 mm arm). The held-out report of the
/// check itself falls from tens of µm to the noise level (√3·2 µm ≈ 3.5 µm RMS in 3-D).
#[test]
fn compensation_puts_the_point_where_it_was_meant_to_be() {
    let sim = CradleSimulation::example(true, 5);
    let r = check(&simulate_cradle(&sim));
    assert!(r.compensation.before_rms_um > 20.0, "{:?}", r.compensation);
    assert!(r.compensation.after_rms_um < 4.0, "{:?}", r.compensation);
    assert_eq!(r.compensation.poses.len(), 13);
    let model = r.kinematics.model;
    let truth = sim.truth;
    let w = truth.ball_in_table();
    let (mut before, mut after) = (0.0f64, 0.0f64);
    for (a, c) in [
        (-80.0, 10.0),
        (-37.0, 200.0),
        (-10.0, 95.0),
        (22.0, 300.0),
        (53.0, 47.0),
        (88.0, 170.0),
    ] {
        let (ar, cr) = (f64::to_radians(a), f64::to_radians(c));
        let x = truth.nominal_pose(ar, cr) * w;
        let cmd = Command {
            x_mm: x.x,
            y_mm: x.y,
            z_mm: x.z,
            a_deg: a,
            c_deg: c,
        };
        let err0 = (truth.table_pose(ar, cr) * w - x).norm() * 1e3;
        let k = compensate(&model, &cmd);
        let cc = k.command;
        let landed = truth.table_pose(cc.a_deg.to_radians(), cc.c_deg.to_radians()) * w;
        let err1 = (landed - Point3::new(cc.x_mm, cc.y_mm, cc.z_mm)).norm() * 1e3;
        before = before.max(err0);
        after = after.max(err1);
        assert!(
            k.orientation_residual_urad < 5.0,
            "A {a}: {}",
            k.orientation_residual_urad
        );
    }
    assert!(before > 20.0, "{before}");
    assert!(after < 1.5, "{after}");
}

/// An unregistered instrument (arbitrary rigid placement): the intrinsic location errors
/// (EY0C, EB0C) are still recovered, the frame-dependent ones are not reported, and the
/// rotation vectors' norms do not change (they are frame-invariant).
#[test]
fn unregistered_frame_reports_only_intrinsic_errors() {
    let sim = CradleSimulation::example(false, 6);
    let pts = simulate_cradle(&sim);
    let moved = {
        let t = Isometry3::from_parts(
            Translation3::new(812.0, -340.0, 95.0),
            UnitQuaternion::from_scaled_axis(Vector3::new(0.3, -0.5, 1.1)),
        );
        let mut m = pts.clone();
        for p in &mut m.points {
            let q = t * Point3::new(p.x_mm, p.y_mm, p.z_mm);
            (p.x_mm, p.y_mm, p.z_mm) = (q.x, q.y, q.z);
        }
        m
    };
    let opts = CradleOptions {
        registered_frame: false,
        ..CradleOptions::default()
    };
    let r0 = check(&pts);
    let r = check_cradle(&moved, &opts).unwrap();
    assert_location_errors(&r, &sim.truth, false);
    assert!(r.kinematics.ball.azimuth_deg.is_none());
    assert!(
        (r.kinematics.ball.height_mm - 60.0).abs() < 4.0 * r.kinematics.ball.height_std_um * 1e-3
    );
    for (a, b) in r.poses.iter().zip(&r0.poses) {
        assert!((a.rotation_point.norm_urad - b.rotation_point.norm_urad).abs() < 1e-3);
    }
}

/// Bad input is an error naming the problem.
#[test]
fn bad_input_is_rejected() {
    let mut sim = CradleSimulation::example(false, 7);
    sim.a_deg = vec![0.0, 30.0];
    let e = check_cradle(&simulate_cradle(&sim), &CradleOptions::default()).unwrap_err();
    assert!(e.to_string().contains("at least 3"), "{e}");
    let mut sim = CradleSimulation::example(false, 7);
    sim.c_deg = vec![0.0, 90.0, 180.0];
    let e = check_cradle(&simulate_cradle(&sim), &CradleOptions::default()).unwrap_err();
    assert!(e.to_string().contains("points"), "{e}");
    let mut pts = simulate_cradle(&CradleSimulation::example(false, 7));
    pts.points[5].y_mm = f64::NAN;
    let e = check_cradle(&pts, &CradleOptions::default()).unwrap_err();
    assert!(e.to_string().contains("point 5: y_mm"), "{e}");
}

/// The result is a serde document with `"kind": "cradle"` that round-trips.
#[test]
fn result_serialises() {
    let r = check(&simulate_cradle(&CradleSimulation::example(false, 8)));
    let v = serde_json::to_value(&r).unwrap();
    assert_eq!(v["kind"], "cradle");
    let back: CradleResult = serde_json::from_value(v).unwrap();
    assert_eq!(back.n_points, r.n_points);
}

/// Parameter of the chosen model by name.
fn parameter<'a>(r: &'a CradleResult, name: &str) -> &'a ModelParameter {
    r.kinematics
        .parameters
        .iter()
        .find(|p| p.name == name)
        .unwrap_or_else(|| panic!("{name} not in {}", r.kinematics.description))
}

/// A C table that tilts with A about its own mount (150 mm below the pivot, about X by
/// 60·sin A and about its Y by −25·sin A µrad), checked as the user did: the
/// classic compliant model (tilt about the pivot with s_A, k_A) leaves a gap above the
/// tracker floor (√3 · 2 µm ≈ 3.5 µm): about the mount, the tilt about X also moves the
/// table sideways by z_M·τ_X and the tilt about Y moves it along A by −z_M·τ_Y, which no
/// tilt about the pivot follows. The forward selection finds both tilts about the mount,
/// brings the held-out A poses to the floor, and recovers the tilts with the right signs
/// and the mount height within 4 of their stated uncertainties (the location errors too).
#[test]
fn mount_tilts_brought_to_the_tracker_floor() {
    for seed in [1, 2] {
        let sim = CradleSimulation::example_with(Deflection::Mount, seed);
        let r = check(&simulate_cradle(&sim));
        let k = &r.kinematics;
        assert!(
            k.spec.mount_x && k.spec.mount_y,
            "seed {seed}: {}",
            k.description
        );
        let f = r.floor.as_ref().unwrap();
        // σ̂ from the circle fits: 2 µm within 10 %.
        assert!((f.noise_um - 2.0).abs() < 0.2, "{f:?}");
        assert!(f.at_floor && f.ratio <= 1.1, "seed {seed}: {f:?}");
        let classic = k.compliant.as_ref().unwrap().held_out_rms_um.unwrap();
        assert!(
            classic > 1.2 * f.floor_rms_um,
            "seed {seed}: classic {classic}"
        );
        for (name, truth) in [
            ("z_M", -150.0),
            ("tX_s", 60.0),
            ("tX_c", 0.0),
            ("tY_s", -25.0),
            ("tY_c", 0.0),
        ] {
            let p = parameter(&r, name);
            assert!((p.value - truth).abs() < 4.0 * p.std, "seed {seed}: {p:?}");
            assert!(p.std < if name == "z_M" { 15.0 } else { 4.0 }, "{p:?}");
        }
        assert_location_errors(&r, &sim.truth, true);
        assert!(r.compensation.before_rms_um > 20.0, "{:?}", r.compensation);
        assert!(r.compensation.after_rms_um <= 1.1 * f.floor_rms_um);
        // What the data can separate, against the chosen model (separability.rs): both
        // tilts are in the model; the tilt about X would be lost to an A positioning
        // error with a free shift; nothing absent is confounded with the model alone
        // but the mount height (which comes with the tilts).
        let sep = k.separability.as_ref().unwrap();
        assert_eq!(sep.rank, sep.n_params);
        let row = |t: Term| sep.terms.iter().find(|x| x.term == t).unwrap();
        assert!(row(Term::MountX).in_model && row(Term::MountY).in_model);
        assert!(
            row(Term::MountX)
                .confounded_with
                .iter()
                .any(|s| s.contains(&Term::APositioning) && s.contains(&Term::Lateral)),
            "{:?}",
            row(Term::MountX)
        );
        assert!(row(Term::MountY).confounded_with.is_empty());
        for t in [
            Term::APositioning,
            Term::Axial,
            Term::Lateral,
            Term::PivotTilt,
        ] {
            assert!(row(t).separable && !row(t).in_model, "{:?}", row(t));
        }
    }
}

/// An A-dependent error the model has no term for (a 12 µm Y displacement ∝ sin 4A added
/// to every point) is not absorbed silently: the held-out residual stays well above the
/// tracker floor and the report says a gap remains and where.
#[test]
fn a_gap_above_the_tracker_floor_is_reported() {
    let mut pts = simulate_cradle(&CradleSimulation::example(false, 3));
    for p in &mut pts.points {
        p.y_mm += 0.012 * (4.0 * p.a_deg.to_radians()).sin();
    }
    let r = check(&pts);
    let f = r.floor.as_ref().unwrap();
    assert!(!f.at_floor && f.ratio > 1.5, "{f:?}");
    // The lack-of-fit test (pure error from the circle fits) rejects the model outright.
    let l = f.lack_of_fit.as_ref().unwrap();
    assert!(l.p_value < 1e-9 && l.f > 3.0, "{l:?}");
    assert!(f.gap_um > 5.0, "{f:?}");
    assert!(f.statement.contains("gap"), "{}", f.statement);
    assert!(r.notes.iter().any(|n| n.contains("gap")));
}

/// A tracker frame that is not the machine's (an arbitrary rigid placement) while the
/// options state a registered frame: the check registers the points to the nominal
/// kinematics first, says so, reports only the intrinsic location errors, and its
/// before/after figures are those of the cradle (tens of µm), not of the frame (hundreds
/// of mm). A frame that is the machine's with the pivot elsewhere is kept when the pivot
/// is given.
#[test]
fn unregistered_instrument_is_registered_before_reporting() {
    let sim = CradleSimulation::example(true, 9);
    let pts = simulate_cradle(&sim);
    let moved = |t: Isometry3<f64>| {
        let mut m = pts.clone();
        for p in &mut m.points {
            let q = t * Point3::new(p.x_mm, p.y_mm, p.z_mm);
            (p.x_mm, p.y_mm, p.z_mm) = (q.x, q.y, q.z);
        }
        m
    };
    let far = moved(Isometry3::from_parts(
        Translation3::new(2150.0, -340.0, 95.0),
        UnitQuaternion::from_scaled_axis(Vector3::new(0.3, -0.5, 1.1)),
    ));
    let r = check(&far);
    assert_eq!(r.registration.frame, "best_fit");
    assert!(!r.registered_frame);
    assert!(r.notes.iter().any(|n| n.contains("not the machine's")));
    assert_location_errors(&r, &sim.truth, false);
    let c = &r.compensation;
    assert!(
        c.before_rms_um > 5.0 && c.before_rms_um < 100.0,
        "{:?}",
        c.before_rms_um
    );
    assert!(c.after_rms_um < 4.0, "{c:?}");
    assert!(r.floor.as_ref().unwrap().at_floor);

    let shifted = moved(Isometry3::translation(400.0, 250.0, -300.0));
    let opts = CradleOptions {
        pivot_mm: [400.0, 250.0, -300.0],
        ..CradleOptions::default()
    };
    let r = check_cradle(&shifted, &opts).unwrap();
    assert_eq!(r.registration.frame, "machine");
    assert!(r.registered_frame);
    assert_location_errors(&r, &sim.truth, true);
}

/// The motions behind the separability verdicts, from the model's forward kinematics
/// (the truth the first-order analysis must reproduce): a tilt τ_X about the mount
/// parallel to A is the same motion, to second order in the tilt, as an A positioning
/// error τ_X with a sideways shift z_M·τ_X; a tilt τ_Y about the mount is a tilt about the
/// pivot's height with a shift along A of −z_M·τ_Y. The analysis finds these, and finds
/// the models without such a pair separable, with a wide gap between the null singular
/// values and the rest.
#[test]
fn separability_finds_the_motions_that_coincide() {
    use mtcal_solver::cradle::identify::Obs;
    use mtcal_solver::cradle::separability::{RANK_TOL, first_order};
    let sim = CradleSimulation::example(false, 1);
    let (z, tx, ty) = (-150.0, [60.0, -20.0], [-25.0, 15.0]);
    let with = |f: &dyn Fn(&mut Compliance)| {
        let mut m = sim.truth;
        m.compliance.centre_height_mm = z;
        f(&mut m.compliance);
        m
    };
    let mount_x = with(&|c| c.mount_x_urad = tx);
    let a_error_and_shift = with(&|c| {
        c.sin_urad[0] = tx[0];
        c.cos_urad[0] = tx[1];
        c.lateral_um = tx.map(|t| z * t * 1e-3);
    });
    let mount_y = with(&|c| c.mount_y_urad = ty);
    let pivot_y_and_shift = with(&|c| {
        c.centre_height_mm = 0.0;
        c.mount_y_urad = ty;
        c.axial_um = ty.map(|t| -z * t * 1e-3);
    });
    for a in (-90..=90).step_by(10).map(|a| f64::from(a).to_radians()) {
        for c in (0..360).step_by(30).map(|c| f64::from(c).to_radians()) {
            let d1 = (mount_x.ball(a, c) - a_error_and_shift.ball(a, c)).norm();
            // Second order: z·τ²/2 ≈ 0.3 nm; the location errors times τ·arm, a few nm.
            assert!(d1 < 1e-5, "{d1} mm at A {a} C {c}");
            let d2 = (mount_y.ball(a, c) - pivot_y_and_shift.ball(a, c)).norm();
            assert!(d2 < 1e-5, "{d2} mm at A {a} C {c}");
            // …while the tilt itself moves the ball by micrometres.
            assert!((mount_x.ball(a, c) - sim.truth.ball(a, c)).norm() > 1e-4 || a.abs() < 0.2);
        }
    }
    let obs: Vec<Obs> = sim
        .a_deg
        .iter()
        .enumerate()
        .flat_map(|(k, a)| {
            sim.c_deg.iter().map(move |c| Obs {
                a: a.to_radians(),
                c: c.to_radians(),
                p: Vector3::zeros(),
                pose: k,
            })
        })
        .collect();
    let fitted = with(&|c| {
        c.mount_x_urad = tx;
        c.mount_y_urad = ty;
    });
    let spec = |f: &dyn Fn(&mut ModelSpec)| {
        let mut s = ModelSpec::RIGID;
        f(&mut s);
        s
    };
    let fitted_spec = spec(&|s| {
        s.mount_x = true;
        s.mount_y = true;
    });
    use Term::*;
    // (model, the A-dependent terms that must come out not separable)
    let cases: Vec<(ModelSpec, Vec<Term>)> = vec![
        (
            spec(&|s| {
                s.mount_x = true;
                s.a_harmonic = true;
                s.lateral = true;
            }),
            vec![APositioning, MountX, MountHeight, Lateral],
        ),
        (
            spec(&|s| {
                s.mount_x = true;
                s.a_harmonic = true;
            }),
            vec![APositioning, MountX, MountHeight],
        ),
        (
            spec(&|s| {
                s.mount_y = true;
                s.axial = true;
            }),
            vec![MountHeight, Axial],
        ),
        (
            spec(&|s| {
                s.mount_x = true;
                s.lateral = true;
            }),
            vec![MountHeight, Lateral],
        ),
        (
            spec(&|s| {
                s.mount_x = true;
                s.mount_y = true;
                s.a_harmonic = true;
            }),
            vec![],
        ),
        (
            spec(&|s| {
                s.mount_x = true;
                s.mount_y = true;
                s.axial = true;
            }),
            vec![],
        ),
        (
            spec(&|s| {
                s.mount_x = true;
                s.mount_y = true;
                s.lateral = true;
            }),
            vec![],
        ),
        (
            spec(&|s| {
                s.mount_x = true;
                s.mount_y = true;
                s.tilt = Tilt::Pivot;
                s.eaa_order = 2;
            }),
            vec![],
        ),
        (ModelSpec::COMPLIANT, vec![]),
    ];
    for (s, want) in cases {
        let fo = first_order(&obs, &fitted, &fitted_spec, &s);
        assert_eq!(fo.undetermined_terms(), want, "{}", s.describe());
        assert_eq!(fo.full_rank(), want.is_empty(), "{}", s.describe());
        // The verdict does not hang on the threshold: nulls far below it, the rest far
        // above.
        if want.is_empty() {
            assert!(
                fo.smallest > 1e4 * RANK_TOL,
                "{}: {}",
                s.describe(),
                fo.smallest
            );
        } else {
            assert!(
                fo.smallest < 1e-2 * RANK_TOL,
                "{}: {}",
                s.describe(),
                fo.smallest
            );
        }
    }
}

/// The compliance curves of the chosen model: over the measured A range only, each the
/// model's own function of its parameters, and the ±2σ band covering the simulated tilts.
#[test]
fn compliance_curves_cover_the_simulated_tilts() {
    let sim = CradleSimulation::example_with(Deflection::Mount, 3);
    let r = check(&simulate_cradle(&sim));
    let k = &r.kinematics;
    let terms: Vec<Term> = k.curves.iter().map(|c| c.term).collect();
    assert!(
        terms.contains(&Term::MountX) && terms.contains(&Term::MountY),
        "{terms:?}"
    );
    for c in &k.curves {
        assert_eq!(c.a_deg.first(), Some(&-90.0));
        assert_eq!(c.a_deg.last(), Some(&90.0));
        let (ps, pc) = match c.term {
            Term::MountX => ("tX_s", "tX_c"),
            Term::MountY => ("tY_s", "tY_c"),
            _ => continue,
        };
        let (s, k_) = (parameter(&r, ps).value, parameter(&r, pc).value);
        let truth = if c.term == Term::MountX { 60.0 } else { -25.0 };
        for ((a, v), u) in c.a_deg.iter().zip(&c.value).zip(&c.std) {
            let (sa, ca) = a.to_radians().sin_cos();
            assert!((v - (s * sa + k_ * (ca - 1.0))).abs() < 1e-9, "{}", c.name);
            assert!(*u >= 0.0 && *u < 5.0, "{u}");
            assert!(
                (v - truth * sa).abs() <= 3.0 * u + 1e-9,
                "{} at A {a}: {v} ± {u}",
                c.name
            );
        }
        // No uncertainty where the model is pinned (A = 0): every term vanishes there.
        let mid = c.a_deg.iter().position(|a| *a == 0.0).unwrap();
        assert!(c.std[mid] < 1e-9 && c.value[mid].abs() < 1e-9);
    }
    let rigid = check(&simulate_cradle(&CradleSimulation::example(false, 3)));
    assert!(rigid.kinematics.curves.is_empty());
}
