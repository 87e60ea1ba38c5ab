//! ISO 230-2 figures against cases worked by hand from the standard's formulas
//! (`docs/standards.md`), and against simulated line passes with a known error.

use mtcal_solver::axis::Axis;
use mtcal_solver::basis::PolyErrors;
use mtcal_solver::datasets::{Direction, PositioningRecord, PositioningRuns};
use mtcal_solver::simulate::{Effect, Plan, SimOptions, random_truth, simulate};
use mtcal_solver::standards::iso230_2::{
    FIGURES, NOT_FROM_LINE_PASSES, Reading, Source, evaluate, from_positioning_runs, iso230_2,
};
use mtcal_solver::standards::{self, Iso2302};
use mtcal_solver::terms::Term;

fn close(a: f64, b: f64, tol: f64, what: &str) {
    assert!((a - b).abs() <= tol, "{what}: {a} vs {b} (tol {tol})");
}

/// Three readings m − d, m, m + d per target and direction (sample standard deviation
/// exactly d), as positioning-run records of axis X.
fn records(up: &[(f64, f64)], down: &[(f64, f64)], targets: &[f64]) -> PositioningRuns {
    let mut records = vec![];
    for run in 0..3 {
        let k = run as f64 - 1.0;
        for (dir, set) in [(Direction::Plus, up), (Direction::Minus, down)] {
            for (&t, &(m, d)) in targets.iter().zip(set) {
                records.push(PositioningRecord {
                    axis: Axis::X,
                    run: run + 1,
                    direction: dir,
                    target_mm: t,
                    deviation_um: m + k * d,
                    t_s: None,
                    temp_c: None,
                });
            }
        }
    }
    PositioningRuns { records }
}

/// Worked by hand. Targets P1..P5 = 0, 25, 50, 75, 100 mm, 3 runs; readings m − d, m, m + d,
/// so x̄ = m and s = d:
///
/// ```text
///        x̄↑   s↑    x̄↓   s↓  | x̄_i   B_i  R_i↑ R_i↓  2s↑+2s↓+|B_i|  R_i
/// P1     1    1     −2    0   | −0.5  3    4    0     5              5
/// P2     3    0.5    0    0.5 |  1.5  3    2    2     5              5
/// P3     2    0      1    0.5 |  1.5  1    0    2     2              2
/// P4     6    1      4    0   |  5    2    4    0     4              4
/// P5     2    0      1    1   |  1.5  1    0    4     3              4
/// ```
///
/// B = max|B_i| = 3; B̄ = (3+3+1+2+1)/5 = 2; R↑ = 4, R↓ = 4, R = 5 > max(R↑, R↓).
/// E↑ = 6 − 1 = 5; E↓ = 4 − (−2) = 6; E = max(6, 4) − min(1, −2) = 8 ≠ E↑, E↓.
/// M = 5 − (−0.5) = 5.5.
/// x̄↑ + 2s↑ = 3, 4, 2, 8, 2; x̄↑ − 2s↑ = −1, 2, 2, 4, 2 → A↑ = 8 − (−1) = 9.
/// x̄↓ + 2s↓ = −2, 1, 2, 4, 3; x̄↓ − 2s↓ = −2, −1, 0, 4, −1 → A↓ = 4 − (−2) = 6.
/// A = max(8, 4) − min(−1, −2) = 10.
///
/// Uncertainties (n = 3): u(x̄) = s/√3, u(s) = s/√(2·2) = s/2.
/// u(E): max x̄↑ at P4 (s = 1) → 1/√3; min x̄↓ at P1 (s = 0) → 0; u(E) = 1/√3.
/// u(B): B at P1 (first of the ties) = √(1/3 + 0) = 1/√3.
/// u(R): R at P1 from 2s↑ + 2s↓ + |B_i|: √(4·(1/2)² + 0 + 1/3) = √(4/3).
/// u(B̄) = √(Σ u(B_i)²)/5, u(B_i)² = (s↑² + s↓²)/3 = 1/3, 1/6, 1/12, 1/3, 1/3 → √(5/4)/5.
fn hand_case() -> PositioningRuns {
    records(
        &[(1.0, 1.0), (3.0, 0.5), (2.0, 0.0), (6.0, 1.0), (2.0, 0.0)],
        &[(-2.0, 0.0), (0.0, 0.5), (1.0, 0.5), (4.0, 0.0), (1.0, 1.0)],
        &[0.0, 25.0, 50.0, 75.0, 100.0],
    )
}

#[test]
fn figures_worked_by_hand() {
    let (figs, skipped) = from_positioning_runs(&hand_case());
    assert!(skipped.is_empty(), "{skipped:?}");
    let f = &figs[0];
    let t = 1e-12;
    close(f.reversal_b_um.unwrap(), 3.0, t, "B");
    close(f.mean_reversal_b_um.unwrap(), 2.0, t, "B mean");
    close(f.repeatability_r_up_um.unwrap(), 4.0, t, "R up");
    close(f.repeatability_r_down_um.unwrap(), 4.0, t, "R down");
    close(f.repeatability_r_um.unwrap(), 5.0, t, "R");
    close(f.systematic_e_up_um.unwrap(), 5.0, t, "E up");
    close(f.systematic_e_down_um.unwrap(), 6.0, t, "E down");
    close(f.systematic_e_um.unwrap(), 8.0, t, "E");
    close(f.mean_range_m_um.unwrap(), 5.5, t, "M");
    close(f.accuracy_a_up_um.unwrap(), 9.0, t, "A up");
    close(f.accuracy_a_down_um.unwrap(), 6.0, t, "A down");
    close(f.accuracy_a_um.unwrap(), 10.0, t, "A");
    // The two figures report generators most often get wrong.
    assert!(
        f.systematic_e_um.unwrap()
            > f.systematic_e_up_um
                .unwrap()
                .max(f.systematic_e_down_um.unwrap())
    );
    assert!(
        f.repeatability_r_um.unwrap()
            > f.repeatability_r_up_um
                .unwrap()
                .max(f.repeatability_r_down_um.unwrap())
    );
    // Per target: P5's R_i comes from R_i↓ = 4s↓ = 4, not from 2s↑ + 2s↓ + |B_i| = 3.
    let p5 = &f.per_target[4];
    close(p5.r_um, 4.0, t, "R_5");
    close(p5.b_um, 1.0, t, "B_5");
    close(p5.mean_um, 1.5, t, "x̄_5");
    close(f.per_target[0].mean_um, -0.5, t, "x̄_1");
    // Uncertainties.
    let u = |k: &str| f.u[k];
    close(u("E_um"), 1.0 / 3f64.sqrt(), 1e-12, "u(E)");
    close(u("B_um"), 1.0 / 3f64.sqrt(), 1e-12, "u(B)");
    close(u("R_um"), (4.0f64 / 3.0).sqrt(), 1e-12, "u(R)");
    close(u("B_mean_um"), 1.25f64.sqrt() / 5.0, 1e-12, "u(B mean)");
    assert_eq!((f.targets, f.runs, f.n_up, f.n_down), (5, 3, 3, 3));
    assert_eq!(f.source, Source::PositioningRuns);
    // Fewer than 5 runs: said.
    assert!(
        f.notes.iter().any(|n| n.contains("5 readings")),
        "{:?}",
        f.notes
    );
}

/// Stored names and values: `iso230_2.<axis>.<figure>`, and the JSON keys are the same.
#[test]
fn scalar_figures_and_json_names() {
    let f = &standards::iso230_2(&hand_case())[0];
    let s = f.scalar_figures();
    assert_eq!(s.len(), 12);
    let e = s.iter().find(|x| x.name == "iso230_2.X.E_um").unwrap();
    close(e.value, 8.0, 1e-12, "E");
    assert!(e.u.is_some());
    assert!(s.iter().any(|x| x.name == "iso230_2.X.R_up_um"));
    let json = serde_json::to_value(f).unwrap();
    assert_eq!(json["E_um"], 8.0);
    assert_eq!(json["R_um"], 5.0);
    assert_eq!(json["per_target"][0]["B_um"], 3.0);
    let back: Iso2302 = serde_json::from_value(json).unwrap();
    assert_eq!(&back, f);
}

/// A second case, with unequal numbers of readings per direction and a reversal whose sign
/// changes along the travel (B̄ small, B large), worked by hand.
///
/// Targets 10, 20, 30 mm. ↑ readings (4 runs): P1 0, 2, 0, 2 (x̄ 1, s = √(4/3)); P2 1, 1,
/// 1, 1 (1, 0); P3 4, 4, 4, 4 (4, 0). ↓ readings (2 runs): P1 3, 3 (3, 0); P2 1, 1 (1, 0);
/// P3 0, 2 (1, √2).
/// B_i = −2, 0, 3 → B = 3, B̄ = 1/3.
/// R_i↑ = 4√(4/3) ≈ 4.6188, 0, 0; R_i↓ = 0, 0, 4√2 ≈ 5.6569.
/// R_1 = max(2·1.1547 + 0 + 2, 4.6188, 0) = 4.6188 (= 2.3094 + 2 = 4.3094 < 4.6188);
/// R_3 = max(0 + 2√2 + 3 = 5.8284, 0, 5.6569) = 5.8284 → R = 3 + 2√2.
/// E↑ = 4 − 1 = 3, E↓ = 3 − 1 = 2, E = 4 − 1 = 3.
/// A↑: x̄ + 2s = 1 + 2.3094, 1, 4 → 4; x̄ − 2s = 1 − 2.3094 = −1.3094, 1, 4 → A↑ = 5.3094.
/// A↓: 3, 1, 1 + 2.8284 → 3.8284; 3, 1, 1 − 2.8284 = −1.8284 → A↓ = 5.6569.
/// A = max(4, 3.8284) − min(−1.3094, −1.8284) = 5.8284.
#[test]
fn unequal_runs_worked_by_hand() {
    let mut r = vec![];
    let mut push = |t: f64, up: bool, run: i64, d: f64| {
        r.push(Reading {
            target_mm: t,
            up,
            run,
            deviation_um: d,
        })
    };
    for (run, v) in [
        [0.0, 1.0, 4.0],
        [2.0, 1.0, 4.0],
        [0.0, 1.0, 4.0],
        [2.0, 1.0, 4.0],
    ]
    .iter()
    .enumerate()
    {
        for (t, d) in [10.0, 20.0, 30.0].iter().zip(v) {
            push(*t, true, run as i64, *d);
        }
    }
    for (run, v) in [[3.0, 1.0, 0.0], [3.0, 1.0, 2.0]].iter().enumerate() {
        for (t, d) in [10.0, 20.0, 30.0].iter().zip(v) {
            push(*t, false, run as i64, *d);
        }
    }
    let f = evaluate(Axis::Y, Source::PositioningRuns, &r).unwrap();
    let s43 = (4.0f64 / 3.0).sqrt();
    let r2 = 2f64.sqrt();
    let t = 1e-12;
    close(f.reversal_b_um.unwrap(), 3.0, t, "B");
    close(f.mean_reversal_b_um.unwrap(), 1.0 / 3.0, t, "B mean");
    close(f.repeatability_r_up_um.unwrap(), 4.0 * s43, t, "R up");
    close(f.repeatability_r_down_um.unwrap(), 4.0 * r2, t, "R down");
    close(f.repeatability_r_um.unwrap(), 3.0 + 2.0 * r2, t, "R");
    close(f.per_target[0].r_um, 4.0 * s43, t, "R_1");
    close(f.systematic_e_up_um.unwrap(), 3.0, t, "E up");
    close(f.systematic_e_down_um.unwrap(), 2.0, t, "E down");
    close(f.systematic_e_um.unwrap(), 3.0, t, "E");
    close(f.accuracy_a_up_um.unwrap(), 3.0 + 2.0 * s43, t, "A up");
    close(f.accuracy_a_down_um.unwrap(), 4.0 * r2, t, "A down");
    close(f.accuracy_a_um.unwrap(), 3.0 + 2.0 * r2, t, "A");
    assert_eq!((f.n_up, f.n_down, f.runs), (4, 2, 4));
}

#[test]
fn too_few_readings_are_named() {
    let mut runs = hand_case();
    // Keep only run 1 of the − approach at 50 mm.
    runs.records
        .retain(|r| !(r.direction == Direction::Minus && r.target_mm == 50.0 && r.run != 1));
    let (figs, skipped) = from_positioning_runs(&runs);
    assert!(figs.is_empty());
    assert_eq!(skipped.len(), 1);
    let why = &skipped[0].reason;
    assert!(
        why.contains("target 50 mm has 1 reading(s) approached with decreasing command"),
        "{why}"
    );
}

/// Line passes of a simulated session: X has the positioning error EXX = 2e-5·x³ µm (x in
/// mm) and a reversal spike e = −d·h·exp(−s/λ) (h = 1.5 µm, λ = 8 mm; d the direction, s
/// the travel since the reversal); nothing else. Lines run over ±50 mm, 5 round trips, at
/// z = 0 with t = (0, 0, −100) (no angular error, so no Abbe term): along X the reading is
/// du = EXX(x) − d·h·exp(−s/λ) + the pass's encoder zero + noise (σ = 0.05 µm).
///
/// Expected, per target x over the 11 targets (each pass referred to its mean over the
/// targets): x̄↑(x) = f↑(x) − mean(f↑), f↑ = EXX(x) − h·exp(−(x + 50)/λ);
/// x̄↓(x) = f↓(x) − mean(f↓), f↓ = EXX(x) + h·exp(−(50 − x)/λ). The figures follow from
/// the module's formulas on these curves (computed below independently of the code:
/// plain maxima and minima); s ≈ 0 (noise only), so R↑, R↓ ≈ 0 and R ≈ B.
#[test]
fn line_passes_of_a_simulated_session() {
    let (h, lambda) = (1.5, 8.0);
    let mut truth = PolyErrors::default();
    truth.set(Term::parse("EXX").unwrap(), vec![0.0, 0.0, 2e-5]);
    let out = simulate(
        &truth,
        &SimOptions {
            plan: Plan::Seed,
            noise_um: 0.05,
            effects: vec![Effect::ReversalSpike {
                axis: Axis::X,
                height_um: h,
                decay_mm: lambda,
            }],
            ..Default::default()
        },
    )
    .unwrap();
    let st = standards::from_session(&out.session);
    let f = st.iso230_2.iter().find(|f| f.axis == Axis::X).unwrap();
    assert_eq!(f.source, Source::LinePasses);
    assert_eq!(f.file.as_deref(), Some("xy_t1.csv"));
    assert_eq!((f.targets, f.runs, f.n_up, f.n_down), (11, 10, 5, 5));
    assert!(
        f.notes[0].contains("not a standstill test"),
        "{:?}",
        f.notes
    );
    assert!(
        st.not_available[0].reason.contains("lost motion"),
        "{:?}",
        st.not_available
    );
    // 11 evenly spaced targets, inset from the ends of the travel by the reading window.
    let xs: Vec<f64> = f.per_target.iter().map(|p| p.target_mm).collect();
    let inset = 50.0 + xs[0];
    // (0.5 mm, plus the first step of the command off the standstill.)
    assert!((0.5..0.6).contains(&inset), "{xs:?}");
    assert!((xs[10] + xs[0]).abs() < 1e-6, "{xs:?}");
    for w in xs.windows(2) {
        close(w[1] - w[0], (100.0 - 2.0 * inset) / 10.0, 1e-9, "spacing");
    }
    let exx = |x: f64| 2e-5 * x * x * x;
    let centred = |v: Vec<f64>| {
        let m = v.iter().sum::<f64>() / v.len() as f64;
        v.into_iter().map(|x| x - m).collect::<Vec<f64>>()
    };
    let up = centred(
        xs.iter()
            .map(|&x| exx(x) - h * (-(x + 50.0) / lambda).exp())
            .collect(),
    );
    let down = centred(
        xs.iter()
            .map(|&x| exx(x) + h * (-(50.0 - x) / lambda).exp())
            .collect(),
    );
    let max = |v: &[f64]| v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let min = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
    let mean: Vec<f64> = up.iter().zip(&down).map(|(a, b)| 0.5 * (a + b)).collect();
    // Tolerance: a reading is a local fit of ~12 samples of σ = 0.05 µm, a mean of 5
    // such readings; the window's curvature bias on the spike is h·w²/(6λ²) ≈ 1e-3 µm.
    let tol = 0.05;
    // B, B̄ (0 by construction), R, E and A depend on each pass's zero: withheld.
    for v in [
        f.reversal_b_um,
        f.mean_reversal_b_um,
        f.repeatability_r_um,
        f.systematic_e_um,
        f.accuracy_a_um,
    ] {
        assert_eq!(v, None);
    }
    close(
        f.systematic_e_up_um.unwrap(),
        max(&up) - min(&up),
        tol,
        "E up",
    );
    close(
        f.systematic_e_down_um.unwrap(),
        max(&down) - min(&down),
        tol,
        "E down",
    );
    close(
        f.mean_range_m_um.unwrap(),
        max(&mean) - min(&mean),
        tol,
        "M",
    );
    for (p, (u, d)) in f.per_target.iter().zip(up.iter().zip(&down)) {
        close(p.mean_up_um, *u, tol, "x̄↑");
        close(p.mean_down_um, *d, tol, "x̄↓");
    }
    // Y has passes as well (no error): small figures.
    let y = st.iso230_2.iter().find(|f| f.axis == Axis::Y).unwrap();
    assert!(
        y.mean_range_m_um.unwrap() < 0.2,
        "{}",
        y.mean_range_m_um.unwrap()
    );
}

/// A machine with 6 µm of X backlash: line passes zeroed per pass show a reversal of a
/// few hundredths of a µm, which would pass any limit on B. The figures that depend on
/// each pass's zero are therefore not available from this plan: named with the reason,
/// never stored, trended or judged; E↑, E↓ and M are.
#[test]
fn line_passes_do_not_give_what_depends_on_each_pass_zero() {
    let out = simulate(
        &random_truth(5),
        &SimOptions {
            plan: Plan::Seed,
            seed: 5,
            sample_rate_hz: 20.0,
            effects: vec![Effect::Backlash {
                axis: Axis::X,
                lost_motion_um: 6.0,
            }],
            ..Default::default()
        },
    )
    .unwrap();
    let st = standards::from_session(&out.session);
    let f = st.iso230_2.iter().find(|f| f.axis == Axis::X).unwrap();
    // The zeroed passes hide the lost motion: no number is given for B.
    assert_eq!(f.reversal_b_um, None);
    for name in [
        "B_um",
        "B_mean_um",
        "R_up_um",
        "R_down_um",
        "R_um",
        "E_um",
        "A_up_um",
        "A_down_um",
        "A_um",
    ] {
        let why = f
            .not_available(name)
            .unwrap_or_else(|| panic!("{name} available"));
        assert!(why.starts_with("not available from this plan"), "{why}");
    }
    for name in ["E_up_um", "E_down_um", "M_um"] {
        assert_eq!(f.not_available(name), None, "{name}");
    }
    let names: Vec<String> = st.scalar_figures().into_iter().map(|s| s.name).collect();
    assert!(
        names.contains(&"iso230_2.X.E_up_um".to_string()),
        "{names:?}"
    );
    assert!(
        !names
            .iter()
            .any(|n| n.ends_with(".B_um") || n.ends_with(".E_um")),
        "{names:?}"
    );
    // The document holds null for each, its reason once for the list of them.
    let text = serde_json::to_string(&st).unwrap();
    assert_eq!(text.matches(NOT_FROM_LINE_PASSES).count(), 1, "{text}");
    let doc: serde_json::Value = serde_json::from_str(&text).unwrap();
    let x = doc["iso230_2"]
        .as_array()
        .unwrap()
        .iter()
        .find(|a| a["axis"] == "X")
        .unwrap();
    assert!(
        x["B_um"].is_null() && x["A_um"].is_null() && x["u"].get("B_um").is_none(),
        "{x}"
    );
    assert!(x["E_up_um"].is_number(), "{x}");
    let listed = doc["not_available"][0]["figures"].as_array().unwrap();
    assert_eq!(listed.len(), 9 * st.iso230_2.len());
    assert!(listed.iter().any(|n| n == "iso230_2.X.B_um"), "{listed:?}");
    // A document of an earlier version (a number for B, the reason per figure, no list)
    // reads with B withheld, and the same reasons.
    let mut old = x.clone();
    old["B_um"] = serde_json::json!(0.044);
    old["not_available"] = serde_json::json!({"B_um": NOT_FROM_LINE_PASSES});
    let old: Iso2302 = serde_json::from_value(old).unwrap();
    assert_eq!(old.values()[0], None);
    assert_eq!(old.not_available("B_um"), f.not_available("B_um"));
    let mut earlier = doc.clone();
    earlier.as_object_mut().unwrap().remove("not_available");
    let earlier: mtcal_solver::standards::Standards = serde_json::from_value(earlier).unwrap();
    assert_eq!(earlier.not_available(), st.not_available);
    // A limit on B is undecided with that reason.
    let mut figures = mtcal_solver::tolerance::Figures::default();
    figures.add_standards(&st);
    assert!(figures.undetermined["iso230_2.X.B_um"].starts_with("not available from this plan"));
    // Positioning runs give every figure.
    let p = mtcal_solver::standards::iso230_2::Source::PositioningRuns;
    assert_ne!(p, f.source);
}

/// The two real runs of `data/ecmccfg_iso230` against an independent calculation of the
/// standard's formulas (`crates/solver/tests/data/iso230_2_reference.py`, NumPy, written
/// from the standard and not from this code; its printed figures, µm, 4 decimals). The
/// reports' own printed figures differ where they are not the standard's (docs/standards.md,
/// "Real runs"): ESS R = 204.76 and A = 204.76 agree, its E = 65.14 is max x̄↓ − min x̄↑,
/// not E = 74.77; PSI R = 0.0629 is max(R↑, R↓), not R = 0.0688.
#[test]
fn real_runs_against_the_reference_script() {
    let cases: [(&str, [f64; 12]); 2] = [
        (
            "ess_mcu1025_axis1.csv",
            [
                43.4594, -7.1849, 204.7595, 18.297, 204.7595, 46.1162, 74.772, 74.772, 48.0935,
                204.7595, 89.2653, 204.7595,
            ],
        ),
        (
            "psi_test_stage.csv",
            [
                0.0122, -0.0054, 0.0629, 0.0503, 0.0688, 0.033, 0.0246, 0.0368, 0.0277, 0.0888,
                0.0643, 0.0888,
            ],
        ),
    ];
    for (file, want) in cases {
        let runs = crate::diagnosis_positioning_real::read(file);
        let f = &iso230_2(&runs)[0];
        for ((name, got), want) in FIGURES.iter().zip(f.values()).zip(want) {
            close(got.unwrap(), want, 6e-5, &format!("{file} {name}"));
        }
    }
    // ESS: R and A come from cycle 1's first approach alone. The outlier test sets aside
    // exactly run 1's + readings at 15.0 and 25.2 mm, and the figures without them are the
    // script's "without rows 0, 1": R = 58.2781, A = 89.2653, R↑ = 11.3404, A↑ = 45.5042,
    // E↑ = 36.4732, B̄ = −13.6916 (B, E, M unchanged).
    let f = &iso230_2(&crate::diagnosis_positioning_real::read(
        "ess_mcu1025_axis1.csv",
    ))[0];
    let w = f.without_outlying.as_ref().expect("outlying readings");
    let aside: Vec<(i64, f64, bool)> = w
        .readings
        .iter()
        .map(|r| (r.run, r.target_mm, r.up))
        .collect();
    assert_eq!(aside, [(1, 15.0, true), (1, 25.2, true)]);
    let want = [
        ("B_um", 43.4594),
        ("B_mean_um", -13.6916),
        ("R_up_um", 11.3404),
        ("R_down_um", 18.297),
        ("R_um", 58.2781),
        ("E_up_um", 36.4732),
        ("E_down_um", 74.772),
        ("E_um", 74.772),
        ("M_um", 48.0935),
        ("A_up_um", 45.5042),
        ("A_down_um", 89.2653),
        ("A_um", 89.2653),
    ];
    for (name, v) in want {
        close(w.figures[name], v, 6e-5, &format!("without {name}"));
    }
    for name in ["R_um", "A_um", "R_up_um", "A_up_um"] {
        assert!(w.dominated.iter().any(|d| d == name), "{:?}", w.dominated);
    }
    assert!(!w.dominated.iter().any(|d| d == "B_um" || d == "E_um"));
    assert!(
        f.notes.iter().any(|n| n.contains("R = 204.8 µm")
            && n.contains("without them")
            && n.contains("R = 58.28 µm")),
        "{:?}",
        f.notes
    );
    // PSI: nothing set aside.
    let p = &iso230_2(&crate::diagnosis_positioning_real::read(
        "psi_test_stage.csv",
    ))[0];
    assert!(p.without_outlying.is_none(), "{:?}", p.without_outlying);
}
