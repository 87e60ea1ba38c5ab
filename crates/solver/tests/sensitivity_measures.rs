//! Sensitivity measures: normalised coefficients, key error sets, global (Sobol) indices
//! against the closed form of a linear model, magnitudes from an identification result,
//! machine description files and bad input.

use mtcal_solver::SolverError;
use mtcal_solver::sensitivity::global::{self, ErrorDistribution, GlobalOptions};
use mtcal_solver::sensitivity::{
    Chain, GridAxis, MachineDescription, MachineRef, MagnitudeSource, Magnitudes,
    SensitivityRequest, Weighting, analyse, templates,
};

#[test]
fn normalised_coefficients_sum_to_one_and_key_sets_are_minimal() {
    for name in templates::TEMPLATES {
        for weighting in [Weighting::Weighted, Weighting::Paper] {
            for at_point in [false, true] {
                let mut req = SensitivityRequest::template(name);
                req.weighting = weighting;
                req.share = 0.9;
                if at_point {
                    // One point in the middle of the travel.
                    let d = templates::template(name).unwrap();
                    let c = Chain::new(&d).unwrap();
                    req.points = vec![c.travel().iter().map(|t| 0.5 * (t[0] + t[1])).collect()];
                }
                let res = analyse(&req).unwrap();
                assert_eq!(res.kind, "sensitivity");
                for (comp, r) in &res.components {
                    let sum: f64 = r.ranking.iter().map(|e| e.coefficient).sum();
                    assert!((sum - 1.0).abs() < 1e-12, "{name} {comp}: sum {sum}");
                    assert!(
                        r.ranking
                            .windows(2)
                            .all(|w| w[0].coefficient >= w[1].coefficient)
                    );
                    let n = r.key_errors.len();
                    assert!(n >= 1 && r.covered >= 0.9 - 1e-12, "{name} {comp}");
                    let without_last: f64 = r.ranking[..n - 1].iter().map(|e| e.coefficient).sum();
                    assert!(without_last < 0.9, "{name} {comp}: key set not minimal");
                }
            }
        }
    }
}

/// The volumetric error's sensitivity is the length of the Jacobian column, so it is at
/// least each component's and at most their sum, pose by pose (and so in the mean).
#[test]
fn volumetric_sensitivity_bounds_the_components() {
    let res = analyse(&SensitivityRequest::template("cradle5-ac")).unwrap();
    let find = |c: &str, e: &str| {
        res.components[c]
            .ranking
            .iter()
            .find(|r| r.error == e)
            .unwrap()
            .sensitivity_mean
    };
    for e in &res.errors {
        let (x, y, z, n) = (
            find("Ex", &e.name),
            find("Ey", &e.name),
            find("Ez", &e.name),
            find("E", &e.name),
        );
        assert!(
            n >= x.max(y).max(z) - 1e-9 && n <= x + y + z + 1e-9,
            "{}",
            e.name
        );
    }
    assert_eq!(res.evaluation.kind, "grid");
    assert_eq!(res.evaluation.poses, 5usize.pow(5));
}

/// For a linear model with independent errors, E_c = Σ s_i g_i, the first-order Sobol
/// indices are (s_i σ_i)² / Σ_j (s_j σ_j)² and the total indices equal them (no
/// interactions). At one pose of vmc3 (the Jacobian is the linear model) with N = 4096,
/// each estimate must lie within 4 of its own standard errors (the Monte-Carlo error the
/// estimator reports) plus 1e-3 of the closed form: for 21 × 3 × 2 checks a 4σ bound
/// fails by chance with probability ~1 %, and the seed is fixed.
#[test]
fn sobol_indices_of_a_linear_model_match_the_closed_form() {
    let desc = templates::vmc3();
    let chain = Chain::new(&desc).unwrap();
    let k = chain.params().len();
    let tol: Vec<f64> = (0..k).map(|i| 2.0 + (i % 5) as f64 * 3.0).collect();
    let mags = Magnitudes::tolerances(&chain, &tol);
    let q = vec![420.0, 310.0, -150.0];
    let jac = chain.jacobian(&q, &vec![0.0; k]);
    for dist in [ErrorDistribution::Uniform, ErrorDistribution::Normal] {
        let opts = GlobalOptions {
            samples: 4096,
            distribution: dist,
            seed: 11,
            max_poses: 1,
        };
        let res = global::sobol(&chain, &mags, std::slice::from_ref(&q), &opts).unwrap();
        // E_x, E_y, E_z, and the vector E (variance Var E_x + Var E_y + Var E_z, so its
        // closed form uses ‖J_i‖²).
        for (c, comp) in ["Ex", "Ey", "Ez", "E"].iter().enumerate() {
            let s = |i: usize| {
                if c < 3 {
                    jac[i][c].abs()
                } else {
                    jac[i].norm()
                }
            };
            let w: Vec<f64> = (0..k).map(|i| (s(i) * tol[i]).powi(2)).collect();
            let total: f64 = w.iter().sum();
            let out = &res.outputs[*comp];
            for e in &out.indices {
                let i = chain
                    .params()
                    .iter()
                    .position(|p| p.name == e.error)
                    .unwrap();
                let truth = w[i] / total;
                assert!(
                    (e.first_order - truth).abs() < 4.0 * e.first_order_se + 1e-3,
                    "{dist:?} {comp} {}: S1 {} ± {} vs {truth}",
                    e.error,
                    e.first_order,
                    e.first_order_se
                );
                assert!(
                    (e.total - truth).abs() < 4.0 * e.total_se + 1e-3,
                    "{dist:?} {comp} {}: ST {} ± {} vs {truth}",
                    e.error,
                    e.total,
                    e.total_se
                );
                assert!(
                    (e.total - e.first_order).abs()
                        < 4.0 * (e.total_se.powi(2) + e.first_order_se.powi(2)).sqrt() + 1e-3
                );
            }
            // The closed form is not trivial: some errors matter, others do not.
            assert!(w.iter().cloned().fold(0.0, f64::max) / total > 0.05);
        }
    }
}

/// An identification result's terms replace the description's tolerances; the ranking
/// then follows the identified values where the machine works.
#[test]
fn identified_magnitudes_drive_the_ranking() {
    let mut terms = serde_json::Map::new();
    for t in mtcal_solver::terms::Term::all() {
        let n = t.name();
        let (ident, coef) = match n.as_str() {
            // EXX: 0.05 µm/mm → 25 µm at X = 500: the dominant error of E_x.
            "EXX" => (true, vec![0.05]),
            "EAX" => (false, vec![]),
            _ => (true, vec![1e-4]),
        };
        terms.insert(
            n,
            serde_json::json!({"unit": t.unit(), "positions_mm": [], "values": [], "std": [],
                "identifiable": ident, "coefficients": coef}),
        );
    }
    let ident = serde_json::json!({
        "kind": "identification", "machine_id": "VMC-1", "measured_at": "2026-11-20T10:00:00Z",
        "convention": "mtcal kinematics v1", "method": "joint",
        "model": {"basis": "polynomial", "order": 3},
        "terms": terms,
        "squareness": {"EC0Y": {"value_urad": 0.5, "std_urad": 0.1, "identifiable": true},
                       "EB0Z": {"value_urad": null, "std_urad": null, "identifiable": false}},
        "observability": {"parameters": 51, "rank": 50, "condition_number": 10.0,
            "identifiable": [], "not_identifiable": [], "confounded": [], "advice": []},
        "fit": {"samples": 10, "residual_rms_um": 0.1, "noise_estimate_um": null},
        "nuisance": {"mountings": {}, "runs": 1},
        "reporting": []
    });
    let mut req = SensitivityRequest::template("vmc3");
    req.identification = Some(Box::new(serde_json::from_value(ident).unwrap()));
    req.points = vec![vec![500.0, 200.0, -100.0]];
    let res = analyse(&req).unwrap();
    let src = |n: &str| {
        res.errors
            .iter()
            .find(|e| e.name == n)
            .unwrap()
            .magnitude_source
    };
    assert_eq!(src("EXX"), MagnitudeSource::Identified);
    assert_eq!(src("EAX"), MagnitudeSource::NotIdentifiable);
    assert_eq!(src("EC0Y"), MagnitudeSource::Identified);
    assert_eq!(src("EB0Z"), MagnitudeSource::NotIdentifiable);
    assert_eq!(src("EA0Z"), MagnitudeSource::Tolerance);
    let ex = &res.components["Ex"];
    assert_eq!(ex.ranking[0].error, "EXX");
    assert!((ex.ranking[0].contribution_mean_um - 25.0).abs() < 1e-9);

    // The same identification stating that X was measured over [−100, 100] mm: X = 500
    // would extrapolate its functions, and is refused; the default grid stays inside.
    let mut ident = req.identification.take().unwrap();
    ident
        .model
        .measured_travel_mm
        .insert("X".into(), [-100.0, 100.0]);
    req.identification = Some(ident);
    let msg = invalid(&req);
    assert!(
        msg.contains("axis X at 500 mm") && msg.contains("[-100, 100]"),
        "{msg}"
    );
    req.points.clear();
    let res = analyse(&req).unwrap();
    assert!(
        res.notes
            .iter()
            .any(|n| n.contains("inside the travel the identification measured")),
        "{:?}",
        res.notes
    );
}

/// docs/machines/<template>.json are exactly the templates (the files document them).
#[test]
fn machine_description_files_equal_the_templates() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/machines");
    for name in templates::TEMPLATES {
        let path = dir.join(format!("{name}.json"));
        let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path:?}: {e}"));
        let d: MachineDescription = serde_json::from_str(&text).unwrap();
        assert_eq!(d, templates::template(name).unwrap(), "{path:?}");
    }
}

fn invalid(req: &SensitivityRequest) -> String {
    match analyse(req) {
        Err(SolverError::InvalidInput(m)) => m,
        other => panic!("expected invalid input, got {other:?}"),
    }
}

#[test]
fn bad_input_is_rejected_with_the_rule() {
    let mut d = templates::vmc3();
    d.errors.insert(
        "EX0B".into(),
        mtcal_solver::sensitivity::ErrorSpec::tolerance(1.0),
    );
    let mut req = SensitivityRequest::template("vmc3");
    req.machine = MachineRef::Description(d);
    assert!(invalid(&req).contains("EX0B"));

    let mut d = templates::vmc3();
    d.workpiece[1].axis = 'X';
    req.machine = MachineRef::Description(d);
    assert!(invalid(&req).contains("twice"));

    let mut d = templates::vmc3();
    d.errors.get_mut("EC0Y").unwrap().coefficients = Some(vec![1.0]);
    req.machine = MachineRef::Description(d);
    assert!(invalid(&req).contains("exactly one"));

    let mut req = SensitivityRequest::template("vmc3");
    req.points = vec![vec![1.0, 2.0]];
    assert!(invalid(&req).contains("3 axes"));

    let mut req = SensitivityRequest::template("hmc4-b");
    req.grid = Some(vec![
        GridAxis {
            min: 0.0,
            max: 1.0,
            n: 2
        };
        3
    ]);
    assert!(invalid(&req).contains("4"));

    let req = SensitivityRequest::template("nope");
    assert!(invalid(&req).contains("unknown machine template"));

    let text = r#"{"machine": {"template": "vmc3"}, "share": 0.9, "colour": 1}"#;
    assert!(serde_json::from_str::<SensitivityRequest>(text).is_err());
}

fn row<'a>(
    res: &'a mtcal_solver::sensitivity::SensitivityResult,
    comp: &str,
    e: &str,
) -> &'a mtcal_solver::sensitivity::RankEntry {
    res.components[comp]
        .ranking
        .iter()
        .find(|r| r.error == e)
        .unwrap()
}

/// Along a path the mean and max are those of the points; a one-point grid is the point;
/// magnitudes given as position-dependent tables of a constant value give the same
/// weighted figures as tolerances of that value (the two accumulation paths agree).
#[test]
fn path_grid_and_point_evaluations_agree() {
    let p1 = vec![100.0, 50.0, -300.0, 30.0, 10.0];
    let p2 = vec![-200.0, 150.0, -50.0, -60.0, 250.0];
    let at = |points: Vec<Vec<f64>>| {
        let mut req = SensitivityRequest::template("cradle5-ac");
        req.points = points;
        analyse(&req).unwrap()
    };
    let (r1, r2, path) = (
        at(vec![p1.clone()]),
        at(vec![p2.clone()]),
        at(vec![p1.clone(), p2]),
    );
    assert_eq!(path.evaluation.kind, "path");
    let mut grid_req = SensitivityRequest::template("cradle5-ac");
    grid_req.grid = Some(
        p1.iter()
            .map(|&v| GridAxis {
                min: v,
                max: v + 1.0,
                n: 1,
            })
            .collect(),
    );
    let grid = analyse(&grid_req).unwrap();
    let mut tabled = templates::cradle5_ac();
    for (name, spec) in tabled.errors.iter_mut() {
        let t = spec.tolerance.unwrap();
        if name.len() == 3 {
            // Motion errors: a table of the constant value ±t (sign must not matter).
            *spec = mtcal_solver::sensitivity::ErrorSpec {
                positions: Some(vec![-1000.0, 1000.0]),
                values: Some(vec![-t, -t]),
                ..Default::default()
            };
        }
    }
    let mut tab_req = SensitivityRequest::template("cradle5-ac");
    tab_req.machine = MachineRef::Description(tabled);
    tab_req.points = vec![p1.clone()];
    let tab = analyse(&tab_req).unwrap();
    let mut checked = 0;
    for comp in ["Ex", "Ey", "Ez", "E"] {
        for e in &path.errors {
            let (a, b, p) = (
                row(&r1, comp, &e.name),
                row(&r2, comp, &e.name),
                row(&path, comp, &e.name),
            );
            let close = |x: f64, y: f64| (x - y).abs() <= 1e-9 * (1.0 + x.abs());
            assert!(close(
                p.sensitivity_mean,
                0.5 * (a.sensitivity_mean + b.sensitivity_mean)
            ));
            assert!(close(
                p.sensitivity_max,
                a.sensitivity_max.max(b.sensitivity_max)
            ));
            assert!(close(
                p.contribution_max_um,
                a.contribution_max_um.max(b.contribution_max_um)
            ));
            let g = row(&grid, comp, &e.name);
            assert!(
                close(g.sensitivity_mean, a.sensitivity_mean)
                    && close(g.coefficient, a.coefficient)
            );
            let t = row(&tab, comp, &e.name);
            assert!(
                close(t.contribution_mean_um, a.contribution_mean_um),
                "{comp} {}",
                e.name
            );
            assert!(close(t.contribution_max_um, a.contribution_max_um));
            if a.sensitivity_mean != b.sensitivity_mean {
                checked += 1;
            }
        }
    }
    // The two points differ for most errors, so the mean/max checks are not vacuous.
    assert!(checked > 50, "{checked}");
}

/// The paper's 581.54 / 499.98 mm through the whole API: hmc4-b with EXX and EYY given as
/// functions (EXX(500) = −20 µm, EYY(581.5) = +40 µm), evaluated at the machine's error
/// state at (500, 581.5, 118, 0) on the paper's scale. The volumetric error of that state
/// is (−20, +40, 0) µm (positioning errors add directly), so |E| = √2000.
#[test]
fn paper_figures_at_the_error_state_through_analyse() {
    let mut d = templates::hmc4_b();
    let coef = |v: f64, q: f64| mtcal_solver::sensitivity::ErrorSpec {
        coefficients: Some(vec![v / q]),
        ..Default::default()
    };
    d.errors.insert("EXX".into(), coef(-20.0, 500.0));
    d.errors.insert("EYY".into(), coef(40.0, 581.5));
    let mut req = SensitivityRequest::template("hmc4-b");
    req.machine = MachineRef::Description(d);
    req.points = vec![vec![500.0, 581.5, 118.0, 0.0]];
    req.weighting = Weighting::Paper;
    req.at_error_state = true;
    let res = analyse(&req).unwrap();
    assert!((row(&res, "Ex", "ECZ").sensitivity_mean - 581.54).abs() < 1e-6);
    assert!((row(&res, "Ey", "ECZ").sensitivity_mean - 499.98).abs() < 1e-6);
    let v = res.volumetric_error_um.as_ref().unwrap();
    assert!((v["Ex"].rms_um - 20.0).abs() < 1e-9 && (v["Ey"].rms_um - 40.0).abs() < 1e-9);
    assert!((v["E"].max_um - 2000f64.sqrt()).abs() < 1e-9);
    // At zero error (the default) the arms are the nominal 581.5 and 500.
    req.at_error_state = false;
    let res = analyse(&req).unwrap();
    assert!((row(&res, "Ex", "ECZ").sensitivity_mean - 581.5).abs() < 1e-9);
    assert!((row(&res, "Ey", "ECZ").sensitivity_mean - 500.0).abs() < 1e-9);
    // Tolerances only: no volumetric error to report.
    assert!(
        analyse(&SensitivityRequest::template("vmc3"))
            .unwrap()
            .volumetric_error_um
            .is_none()
    );
}
