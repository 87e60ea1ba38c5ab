//! Identification against truth: simulate machines with known errors (exact HTM chain,
//! realistic motion, per-run offsets, plate rotations, Gaussian noise), identify them
//! back, and compare with the truth on the reporting grid; and the contract's
//! identifiability table, plan by plan.

use mtcal_solver::identification::{IdentificationResult, IdentifyOptions, identify};
use mtcal_solver::simulate::{Plan, SimOptions, random_truth, simulate};

/// Sample rate of the test sessions: enough samples per pass for the estimator, small
/// enough to keep the suite fast (the benchmark runs the full 1 M-sample case).
const RATE_HZ: f64 = 10.0;

fn session_for(
    plan: Plan,
    seed: u64,
) -> (
    mtcal_solver::session::Session,
    mtcal_solver::simulate::Truth,
) {
    let truth = random_truth(seed);
    let out = simulate(
        &truth,
        &SimOptions {
            plan,
            seed,
            sample_rate_hz: RATE_HZ,
            ..Default::default()
        },
    )
    .expect("simulation");
    (out.session, out.truth)
}

fn sorted(mut v: Vec<String>) -> Vec<String> {
    v.sort();
    v
}

fn names(list: &[&str]) -> Vec<String> {
    sorted(list.iter().map(|s| s.to_string()).collect())
}

const ALL21: [&str; 21] = [
    "EXX", "EYX", "EZX", "EAX", "EBX", "ECX", "EXY", "EYY", "EZY", "EAY", "EBY", "ECY", "EXZ",
    "EYZ", "EZZ", "EAZ", "EBZ", "ECZ", "EC0Y", "EB0Z", "EA0Z",
];

fn complement(of: &[&str]) -> Vec<String> {
    names(
        &ALL21
            .iter()
            .copied()
            .filter(|n| !of.contains(n))
            .collect::<Vec<_>>(),
    )
}

/// The contract's identifiability table (default topology, cubic model), row by row:
/// rank of the error block after eliminating nuisance parameters, and which terms
/// separate. No number is reported for a term that does not.
#[test]
fn identifiability_table_of_the_contract() {
    let rows: Vec<(Plan, usize, Vec<String>)> = vec![
        (
            Plan::Seed,
            34,
            names(&["EXX", "EZX", "EBX", "EYY", "EAY", "ECY", "EZZ"]),
        ),
        (
            Plan::custom(&[[0.0, 0.0, -100.0], [0.0, 0.0, -200.0]], false),
            45,
            complement(&["EYX", "ECX", "EAX", "EBY", "ECZ", "EA0Z"]),
        ),
        (
            Plan::custom(
                &[[0.0, 0.0, -100.0], [0.0, 0.0, -200.0], [40.0, 0.0, -100.0]],
                false,
            ),
            50,
            complement(&["EAX", "EBY", "ECZ", "EA0Z"]),
        ),
        (Plan::Full, 51, names(&ALL21)),
    ];
    for (plan, rank, separable) in rows {
        let label = format!("{plan:?}").chars().take(40).collect::<String>();
        let (session, _) = session_for(plan, 3);
        let r = identify(&session, &IdentifyOptions::default()).unwrap();
        assert_eq!(r.observability.parameters, 51, "{label}");
        assert_eq!(r.observability.rank, rank, "{label}");
        assert_eq!(
            sorted(r.observability.identifiable.clone()),
            separable,
            "{label}"
        );
        for (name, t) in &r.terms {
            if !t.identifiable {
                assert!(
                    t.values.is_empty() && t.std.is_empty(),
                    "{name} has numbers"
                );
                // Listed in exactly one confounded group, with its partners (a group of
                // one is a term the plan does not see at all).
                let groups: Vec<_> = r
                    .observability
                    .confounded
                    .iter()
                    .filter(|g| g.terms.contains(name))
                    .collect();
                assert_eq!(groups.len(), 1, "{name}");
                assert_eq!(groups[0].terms.len(), t.confounded_with.len() + 1, "{name}");
            }
        }
        for (name, q) in &r.squareness {
            assert_eq!(q.identifiable, q.value_urad.is_some(), "{name}");
        }
        if rank < 51 {
            assert!(!r.observability.confounded.is_empty());
            assert!(
                !r.observability.advice.is_empty(),
                "{label}: advice expected"
            );
        } else {
            assert!(r.observability.confounded.is_empty());
        }
    }
}

/// Largest normalised deviation |identified − truth| / max(floor, 3σ) over every grid
/// value of every term and every squareness; must stay ≤ 1.
fn worst_ratio(r: &IdentificationResult, truth: &mtcal_solver::simulate::Truth) -> (f64, String) {
    let mut worst = (0.0, String::new());
    for (name, t) in &r.terms {
        let tt = &truth.terms[name];
        assert!(
            t.identifiable,
            "{name} must be identifiable in the full plan"
        );
        for (k, q) in t.positions_mm.iter().enumerate() {
            let j = tt
                .positions_mm
                .iter()
                .position(|p| (p - q).abs() < 1e-9)
                .unwrap_or_else(|| panic!("{name}: grid point {q} missing from truth"));
            let floor: f64 = if t.unit == "um" { 0.1 } else { 1.0 };
            let ratio = (t.values[k] - tt.values[j]).abs() / floor.max(3.0 * t.std[k]);
            if ratio > worst.0 {
                worst = (ratio, format!("{name} at {q} mm"));
            }
        }
    }
    for (name, q) in &r.squareness {
        let v = q.value_urad.expect("squareness identifiable");
        let ratio = (v - truth.squareness_urad[name]).abs() / 1.0f64.max(3.0 * q.std_urad.unwrap());
        if ratio > worst.0 {
            worst = (ratio, name.clone());
        }
    }
    worst
}

/// Full plan, noise 0.15 µm, several random machines: every term within 0.1 µm /
/// 1 µrad of the truth over the travel, or within 3 of the reported standard
/// uncertainties, whichever is larger.
#[test]
fn full_plan_recovers_random_machines() {
    for seed in [11, 12, 13, 14] {
        let (session, truth) = session_for(Plan::Full, seed);
        let r = identify(&session, &IdentifyOptions::default()).unwrap();
        assert_eq!(r.observability.rank, 51);
        let (ratio, at) = worst_ratio(&r, &truth);
        eprintln!(
            "seed {seed}: worst {ratio:.2} at {at}; EXX std {:?}",
            r.terms["EXX"].std.iter().cloned().fold(0.0, f64::max)
        );
        assert!(ratio <= 1.0, "seed {seed}: worst {ratio:.2} at {at}");
        // The residual is at the noise level and the independent estimate agrees.
        let noise = r.fit.noise_estimate_um.expect("repeated passes");
        assert!((noise - 0.15).abs() < 0.03, "noise estimate {noise}");
        assert!(
            (r.fit.residual_rms_um - 0.15).abs() < 0.03,
            "residual {}",
            r.fit.residual_rms_um
        );
        // Mounting rotations recovered.
        for (m, rep) in &r.nuisance.mountings {
            let want = truth.mounting_rotation_urad[m];
            let got = rep.rotation_urad.expect("rotation determined");
            assert!(
                (got - want).abs() <= 1.0f64.max(3.0 * rep.std_urad.unwrap()),
                "{m}: {got} vs {want}"
            );
        }
    }
}

/// The reported uncertainties are honest: over many seeds about 95 % of the errors of
/// the reported values lie within 2σ (checked on the 7 terms' values at the travel
/// ends and the squareness, where the uncertainty is largest; band 0.90–0.99).
#[test]
fn reported_uncertainties_are_honest() {
    let mut inside = 0usize;
    let mut total = 0usize;
    for seed in 100..124 {
        let (session, truth) = session_for(Plan::Full, seed);
        let r = identify(&session, &IdentifyOptions::default()).unwrap();
        for (name, t) in &r.terms {
            let tt = &truth.terms[name];
            for (k, q) in t.positions_mm.iter().enumerate() {
                if t.std[k] == 0.0 {
                    continue;
                }
                let j = tt.positions_mm.iter().position(|p| p == q).unwrap();
                total += 1;
                if (t.values[k] - tt.values[j]).abs() <= 2.0 * t.std[k] {
                    inside += 1;
                }
            }
        }
        for (name, q) in &r.squareness {
            total += 1;
            if (q.value_urad.unwrap() - truth.squareness_urad[name]).abs()
                <= 2.0 * q.std_urad.unwrap()
            {
                inside += 1;
            }
        }
    }
    let share = inside as f64 / total as f64;
    eprintln!("honesty: {inside}/{total} = {share:.3}");
    assert!(
        (0.90..=0.99).contains(&share),
        "{inside} of {total} within 2σ ({share:.3})"
    );
}

/// The result states the travel each axis measured (where it moved in the plan's runs),
/// and each identifiable term's coefficient covariance gives back the reported standard
/// uncertainty at every reported position: u(q) = √(gᵀ Σ g), g = (q, q², q³). Checked on
/// the positioning, roll, pitch and yaw terms (straightness values are reported after
/// removing their least-squares line, so their u(q) is that of the raw function only at
/// the coefficients' level).
#[test]
fn measured_travel_and_coefficient_covariance_reproduce_the_reported_uncertainty() {
    let (session, _) = session_for(Plan::Full, 21);
    let r = identify(&session, &IdentifyOptions::default()).unwrap();
    let travel = &r.model.measured_travel_mm;
    for axis in ["X", "Y", "Z"] {
        let [lo, hi] = travel[axis];
        let idx = ["X", "Y", "Z"].iter().position(|a| *a == axis).unwrap();
        // Over the runs in which the axis moved (a parked axis determines nothing).
        let span = |r: &mtcal_solver::session::Run| {
            r.pos_mm
                .iter()
                .map(|q| q[idx])
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), q| {
                    (a.min(q), b.max(q))
                })
        };
        let (plo, phi) = session
            .planes
            .iter()
            .flat_map(|p| p.runs.iter().map(span))
            .filter(|(a, b)| b - a > mtcal_solver::session::PARKED_RANGE_MM)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), (l, h)| {
                (a.min(l), b.max(h))
            });
        assert!(
            (lo - plo).abs() < 1e-6 && (hi - phi).abs() < 1e-6,
            "{axis}: {lo}..{hi} vs {plo}..{phi}"
        );
        for (name, t) in &r.terms {
            if !name.ends_with(axis) || !t.identifiable {
                continue;
            }
            assert!(
                t.positions_mm
                    .iter()
                    .all(|q| *q >= lo - 1e-9 && *q <= hi + 1e-9),
                "{name}"
            );
        }
    }
    let mut checked = 0;
    for (name, t) in &r.terms {
        let straightness = name.as_bytes()[1] != name.as_bytes()[2]
            && matches!(name.as_bytes()[1], b'X' | b'Y' | b'Z');
        if !t.identifiable || straightness {
            continue;
        }
        let n = t.coefficients.len();
        assert_eq!(t.coefficient_covariance.len(), n, "{name}");
        for (q, u) in t.positions_mm.iter().zip(&t.std) {
            let g: Vec<f64> = (1..=n).map(|k| q.powi(k as i32)).collect();
            let var: f64 = (0..n)
                .flat_map(|a| (0..n).map(move |b| (a, b)))
                .map(|(a, b)| g[a] * g[b] * t.coefficient_covariance[a][b])
                .sum();
            let from_cov = var.max(0.0).sqrt();
            // The reported std is rounded (results contract); compare to that precision.
            assert!(
                (from_cov - u).abs() <= 1e-3 + 1e-3 * u,
                "{name} at {q}: {from_cov} vs reported {u}"
            );
            checked += 1;
        }
    }
    assert!(checked > 100, "{checked}");
}

/// Evaluating a result document anywhere: `reported_value_at` (the stored monomial
/// coefficients, and for a straightness minus its least-squares line over the measured
/// travel) gives back every reported value of every identifiable term. The reported
/// values come from the fit's parameters by another path (the functionals of the model
/// basis), so this checks the coefficients and the line removal against them; reported
/// values are rounded to 1e-6.
#[test]
fn reported_value_at_reproduces_every_reported_value() {
    let (session, _) = session_for(Plan::Full, 22);
    let r = identify(&session, &IdentifyOptions::default()).unwrap();
    let mut straight = 0;
    for (name, t) in &r.terms {
        if !t.identifiable {
            assert_eq!(r.reported_value_at(name, 10.0), None, "{name}");
            continue;
        }
        if name.as_bytes()[1] != name.as_bytes()[2]
            && matches!(name.as_bytes()[1], b'X' | b'Y' | b'Z')
        {
            straight += 1;
        }
        let term = mtcal_solver::terms::Term::parse(name).unwrap();
        for ((q, v), u) in t.positions_mm.iter().zip(&t.values).zip(&t.std) {
            let got = r.reported_value_at(name, *q).unwrap();
            assert!((got - v).abs() < 2e-6, "{name} at {q}: {got} vs {v}");
            // Its uncertainty from the stored coefficient covariance (the line removal
            // included for a straightness) against the reported std, which comes from
            // the fit's covariance of the parameters.
            let from_cov = mtcal_solver::comparison::term_value(&r, term, *q)
                .and_then(|v| v.u)
                .unwrap();
            assert!(
                (from_cov - u).abs() <= 2e-6 + 1e-3 * u,
                "{name} at {q}: {from_cov} vs reported {u}"
            );
        }
        // Nothing outside the measured travel.
        let [_, hi] = r.model.measured_travel_mm[&name[2..3]];
        assert_eq!(r.reported_value_at(name, hi + 1.0), None, "{name}");
    }
    assert!(straight >= 4, "straightness terms checked: {straight}");
    assert_eq!(r.reported_value_at("EQX", 0.0), None);
}
