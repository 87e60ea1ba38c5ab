//! Coverage of the parameters of every effect of the catalogue and the signature space
//! other than the temperature-driven growth (diagnosis_thermal_coverage.rs holds that
//! one) against truth: for each effect, each of two ways of making it and two or three
//! magnitudes (one near the floor, a few times the noise of 0.15 µm), sessions of the
//! seed plan at 10 Hz are diagnosed with no hint, and every parameter the finding reports
//! with its σ is scored: within 2σ of the truth or not, and z = (estimate − truth)/σ.
//!
//! The two ways: the simulator's `Effect` where it has one, and a second way made in this
//! file, outside the simulator, from the set-points alone (a dead band carried through
//! each file, a pure delay through a spline of the path, a periodic table interpolated by
//! a spline, a head offset declared wrongly, …; `Way`). Effects the simulator lacks
//! (lost motion along the travel, a step, a shift at reversal) are made in two shapes,
//! one of them outside the candidate's model.
//!
//! The full table (docs/diagnosis-catalogue.md, "Coverage of the other effects", holds it
//! condensed to one row per cell) is printed by
//! `COVERAGE_SEEDS=40 cargo test -p mtcal-solver --test solver effect_coverage -- --nocapture`;
//! the normal test command runs 2 seeds of every cell and holds the pooled share.

use super::diagnosis_sessions::{
    RATE, add_error, add_lost_motion, clean_session, commanded_at, delayed, is_circle, par_map,
    session_with, travel_through_file, z_of,
};
use mtcal_solver::axis::Axis;
use mtcal_solver::diagnosis::{DiagnoseOptions, DiagnosisResult, Finding, diagnose_session};
use mtcal_solver::session::{Run, Session};
use mtcal_solver::simulate::{Effect, Plan, SimOptions, random_truth, simulate};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use std::collections::BTreeMap;
use std::f64::consts::PI;

/// An effect made for one seed: the session, the finding expected and the truth of each
/// parameter it reports.
struct Made {
    session: Session,
    /// The finding's `effect`.
    effect: &'static str,
    /// The finding's `axis` (None: not checked).
    axis: Option<Axis>,
    /// The truth of each scored parameter; a lost motion along the travel is scored at
    /// the targets the finding reports (`profile`).
    truth: Vec<(String, f64)>,
    /// b(q) of a lost motion made along the travel.
    profile: Option<Box<dyn Fn(f64) -> f64 + Send + Sync>>,
}

/// The effects, each with its two ways and its magnitudes (the unit of the first named
/// parameter).
const EFFECTS: [(&str, [&str; 2], &[f64]); 12] = [
    ("backlash", ["simulator", "dead band"], &[0.5, 1.5, 5.0]),
    ("lost_motion_profile", ["worn", "tanh"], &[1.0, 3.0, 6.0]),
    ("servo_lag", ["simulator", "delay"], &[0.3e-3, 1e-3, 3e-3]),
    ("reversal_spike", ["simulator", "by hand"], &[0.5, 1.5, 4.0]),
    ("cyclic", ["simulator", "table"], &[0.3, 0.8, 2.0]),
    ("setup_offset", ["simulator", "declared"], &[5.0, 15.0]),
    ("waviness", ["simulator", "table"], &[0.3, 0.8, 2.0]),
    ("vibration", ["simulator", "by hand"], &[0.2, 0.6, 1.5]),
    ("step", ["sharp", "ramp"], &[0.45, 1.5, 3.0]),
    (
        "direction_coupling",
        ["sharp", "settling"],
        &[0.3, 1.0, 3.0],
    ),
    (
        "velocity_coupling",
        ["simulator", "spline"],
        &[0.01, 0.03, 0.1],
    ),
    (
        "thermal_drift",
        ["simulator", "by hand"],
        &[5.0, 15.0, 40.0],
    ),
];

/// The session of an effect made the first way (`effect`, by the simulator) or the
/// second (`by_hand` applied to the clean session), one simulation either way.
fn either_way(
    seed: u64,
    way: usize,
    effect: Effect,
    by_hand: impl FnOnce(&mut Session),
) -> Session {
    if way == 0 {
        session_with(seed, RATE, vec![effect])
    } else {
        let mut session = clean_session(seed, RATE);
        by_hand(&mut session);
        session
    }
}

fn random_axis(rng: &mut StdRng) -> Axis {
    Axis::from_index(rng.random_range(0..3))
}

/// Another axis than `a`.
fn other_axis(rng: &mut StdRng, a: Axis) -> Axis {
    Axis::from_index((a.index() + 1 + rng.random_range(0..2)) % 3)
}

/// The measured travel of axis `a` over the session (mm).
fn travel(s: &Session, a: usize) -> (f64, f64) {
    s.planes
        .iter()
        .flat_map(|p| &p.runs)
        .flat_map(|r| &r.pos_mm)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), q| {
            (lo.min(q[a]), hi.max(q[a]))
        })
}

/// Adds `e(run, sample, d, s)` µm along `dir` with d and s the direction and the travel
/// since the last reversal of axis `a` carried through each file.
fn add_by_travel(session: &mut Session, a: Axis, dir: Axis, e: impl Fn(f64, f64) -> f64) {
    for p in &mut session.planes {
        let (u, v) = p.plane.axes();
        if u != dir && v != dir {
            continue;
        }
        let state = travel_through_file(p, a.index());
        for (run, st) in p.runs.iter_mut().zip(state) {
            let reading = if u == dir {
                &mut run.du_um
            } else {
                &mut run.dv_um
            };
            for (r, (d, s)) in reading.iter_mut().zip(st) {
                *r += e(d, s);
            }
        }
    }
}

/// A periodic table of `per` values of A·sin(2πq/P + φ) per period, interpolated by the
/// periodic Catmull-Rom spline: a cyclic error or a waviness read from a table, as a
/// compensation table holds it, not the closed-form sine.
fn periodic_table(q: f64, amp: f64, period: f64, phase: f64, per: usize) -> f64 {
    let h = period / per as f64;
    let x = q / h;
    let i = x.floor();
    let u = x - i;
    let p = |k: f64| amp * (2.0 * PI * (k * h) / period + phase).sin();
    let (p0, p1, p2, p3) = (p(i - 1.0), p(i), p(i + 1.0), p(i + 2.0));
    0.5 * (2.0 * p1
        + (p2 - p0) * u
        + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * u * u
        + (3.0 * p1 - p0 - 3.0 * p2 + p3) * u * u * u)
}

/// The velocity of axis `a` (mm/s) at sample `i`: on a circle the derivative of the
/// Catmull-Rom spline through the set-points, on a line the feed (as the candidate's).
fn spline_velocity(run: &Run, a: usize, i: usize) -> f64 {
    if is_circle(run) {
        let (t, h) = (run.t_s[i], 1e-4);
        return (commanded_at(run, a, t + h) - commanded_at(run, a, t - h)) / (2.0 * h);
    }
    mtcal_solver::diagnosis::design::velocity(&run.t_s, &run.pos_mm, i)[a]
}

fn named(pairs: &[(&str, f64)]) -> Vec<(String, f64)> {
    pairs.iter().map(|(n, v)| (n.to_string(), *v)).collect()
}

/// The session of `effect` made the `way` (0: the first of its two, 1: the second) at
/// magnitude `m`, for `seed`.
fn make(effect: &str, way: usize, m: f64, seed: u64) -> Made {
    let mut rng = StdRng::seed_from_u64(seed ^ 0xc0_7e2a);
    let a = random_axis(&mut rng);
    let ai = a.index();
    let plain = |effect: &'static str,
                 axis: Option<Axis>,
                 truth: Vec<(String, f64)>,
                 session: Session| Made {
        session,
        effect,
        axis,
        truth,
        profile: None,
    };
    match effect {
        "backlash" => {
            let session = either_way(
                seed,
                way,
                Effect::Backlash {
                    axis: a,
                    lost_motion_um: m,
                },
                |s| add_lost_motion(s, a, |_| m),
            );
            plain(
                "backlash",
                Some(a),
                named(&[("lost_motion_um", m)]),
                session,
            )
        }
        "lost_motion_profile" => {
            let mut made = plain(
                "lost_motion_profile",
                Some(a),
                Vec::new(),
                clean_session(seed, RATE),
            );
            let (lo, hi) = travel(&made.session, ai);
            let u = move |q: f64| (2.0 * q - lo - hi) / (hi - lo);
            // Worn in the middle (the model's own order 2), or a pitch error of the
            // screw changing sign along the travel (tanh: outside the model's form).
            let b: Box<dyn Fn(f64) -> f64 + Send + Sync> = if way == 0 {
                Box::new(move |q| 2.0 + m * (1.0 - u(q).powi(2)))
            } else {
                Box::new(move |q| 3.0 + m * (2.0 * u(q)).tanh())
            };
            add_lost_motion(&mut made.session, a, &b);
            made.profile = Some(b);
            made
        }
        "servo_lag" => {
            let session = either_way(seed, way, Effect::ServoLag { axis: a, lag_s: m }, |s| {
                add_error(s, a, |run, i| delayed(run, ai, i, m))
            });
            plain("servo_lag", Some(a), named(&[("lag_s", m)]), session)
        }
        "reversal_spike" => {
            let decay: f64 = rng.random_range(0.5..2.0);
            let session = either_way(
                seed,
                way,
                Effect::ReversalSpike {
                    axis: a,
                    height_um: m,
                    decay_mm: decay,
                },
                |s| add_by_travel(s, a, a, |d, s| -d * m * (-s / decay).exp()),
            );
            plain(
                "reversal_spike",
                Some(a),
                named(&[("height_um", m), ("decay_mm", decay)]),
                session,
            )
        }
        "cyclic" | "waviness" => {
            // A cyclic error along the axis itself, or a waviness across it.
            let cyclic = effect == "cyclic";
            let dir = if cyclic { a } else { other_axis(&mut rng, a) };
            let period: f64 = if cyclic {
                [5.0, 10.0, 16.0, 20.0][rng.random_range(0..4)]
            } else {
                rng.random_range(25.0..45.0)
            };
            let phase: f64 = rng.random_range(0.0..2.0 * PI);
            // The table's truth: the fundamental of the interpolated table (the spline
            // through 12 values a period reads a little below the sine's amplitude).
            let amp = if way == 0 {
                m
            } else {
                let k = 1200;
                let (mut c, mut sn) = (0.0, 0.0);
                for i in 0..k {
                    let q = period * i as f64 / k as f64;
                    let w = 2.0 * PI * i as f64 / k as f64;
                    let v = periodic_table(q, m, period, phase, 12);
                    c += v * w.cos();
                    sn += v * w.sin();
                }
                2.0 * c.hypot(sn) / k as f64
            };
            let e = if cyclic {
                Effect::Cyclic {
                    axis: a,
                    period_mm: period,
                    amplitude_um: m,
                    phase_rad: phase,
                }
            } else {
                Effect::Waviness {
                    axis: a,
                    direction: dir,
                    amplitude_um: m,
                    period_mm: period,
                    phase_rad: phase,
                }
            };
            let session = either_way(seed, way, e, |s| {
                add_error(s, dir, |run, i| {
                    periodic_table(run.pos_mm[i][ai], m, period, phase, 12)
                })
            });
            plain(
                if cyclic { "cyclic" } else { "waviness" },
                Some(a),
                named(&[
                    ("amplitude_um", amp),
                    ("period_mm", period),
                    ("phase_rad", phase),
                ]),
                session,
            )
        }
        "setup_offset" => {
            let sign = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
            let delta = sign * m;
            let declared = [0.0, 0.0, -200.0];
            let offsets = |middle: [f64; 3]| {
                Plan::custom(
                    &[
                        [0.0, 0.0, -100.0],
                        middle,
                        [0.0, 0.0, -300.0],
                        [40.0, 0.0, -100.0],
                    ],
                    true,
                )
            };
            let true_offset = [0.0, 0.0, -200.0 + delta];
            let (plan, effects) = if way == 0 {
                (
                    offsets(declared),
                    vec![Effect::SetupOffset {
                        delta_mm: [0.0, 0.0, delta],
                        applies_to_offset_mm: Some(declared),
                    }],
                )
            } else {
                (offsets(true_offset), Vec::new())
            };
            let o = SimOptions {
                plan,
                seed,
                sample_rate_hz: 5.0,
                effects,
                ..SimOptions::default()
            };
            let mut session = simulate(&random_truth(seed), &o).unwrap().session;
            // The second way: measured at the true offset, declared at the nominal one.
            for p in &mut session.planes {
                if p.head_offset_mm == true_offset {
                    p.head_offset_mm = declared;
                }
            }
            Made {
                session,
                effect: "setup_offset",
                axis: None,
                truth: named(&[
                    ("delta_mm_X", 0.0),
                    ("delta_mm_Y", 0.0),
                    ("delta_mm_Z", delta),
                ]),
                profile: None,
            }
        }
        "vibration" => {
            let phase: f64 = rng.random_range(0.0..2.0 * PI);
            // The simulator's range, or a lower band (0.2–2 Hz) made by hand.
            let f: f64 = if way == 0 {
                rng.random_range(0.1..0.8) * RATE / 2.0
            } else {
                rng.random_range(0.2..2.0)
            };
            let session = either_way(
                seed,
                way,
                Effect::Vibration {
                    direction: a,
                    amplitude_um: m,
                    frequency_hz: f,
                    phase_rad: phase,
                },
                |s| add_error(s, a, |run, i| m * (2.0 * PI * f * run.t_s[i] + phase).sin()),
            );
            plain(
                "vibration",
                Some(a),
                named(&[
                    ("amplitude_um", m),
                    ("frequency_hz", f),
                    ("phase_rad", phase),
                ]),
                session,
            )
        }
        "step" => {
            let mut made = plain("step", Some(a), Vec::new(), clean_session(seed, RATE));
            // A run reading along `a`, a time in its middle third.
            let runs: Vec<&Run> = made
                .session
                .planes
                .iter()
                .filter(|p| {
                    let (u, v) = p.plane.axes();
                    u == a || v == a
                })
                .flat_map(|p| &p.runs)
                .filter(|r| r.len() > 60)
                .collect();
            let run = runs[rng.random_range(0..runs.len())];
            let n = run.len();
            let i = rng.random_range(n / 3..2 * n / 3);
            let t0 = 0.5 * (run.t_s[i - 1] + run.t_s[i]);
            // Sharp: between two samples; ramp: over 1 s (a slip taking ten samples).
            let width = if way == 0 { 0.0 } else { 1.0 };
            made.truth = named(&[("size_um", m), ("time_s", t0), ("width_s", width)]);
            add_error(&mut made.session, a, |run, k| {
                let t = run.t_s[k];
                if width == 0.0 {
                    if t >= t0 { m } else { 0.0 }
                } else {
                    m * ((t - t0) / width + 0.5).clamp(0.0, 1.0)
                }
            });
            made
        }
        "direction_coupling" => {
            let dir = other_axis(&mut rng, a);
            let mut made = plain(
                "direction_coupling",
                Some(dir),
                named(&[("shift_um", m)]),
                clean_session(seed, RATE),
            );
            // Sharp: ±s/2 by the direction of travel of `a`; settling: the same shift
            // reached over 0.5 mm of travel after each reversal, continuous through it.
            add_by_travel(&mut made.session, a, dir, |d, s| {
                if way == 0 {
                    d * m / 2.0
                } else {
                    d * m / 2.0 * (1.0 - 2.0 * (-s / 0.5).exp())
                }
            });
            made
        }
        "velocity_coupling" => {
            let dir = other_axis(&mut rng, a);
            let c = if rng.random_bool(0.5) { m } else { -m };
            let session = either_way(
                seed,
                way,
                Effect::VelocityCoupling {
                    axis: a,
                    direction: dir,
                    coefficient_um_per_mm_s: c,
                },
                |s| add_error(s, dir, |run, i| c * spline_velocity(run, ai, i)),
            );
            plain(
                "velocity_coupling",
                Some(dir),
                named(&[("coefficient_um_per_mm_s", c)]),
                session,
            )
        }
        "thermal_drift" => {
            // Growth over session time, g = 1 − e^(−t/T): scales of ±m ppm, offsets of
            // ±m/3 µm, T from 600 to 1800 s (a session lasts about 1000 s).
            let t_c: f64 = rng.random_range(600.0..1800.0);
            let mut signed = |v: f64| if rng.random_bool(0.5) { v } else { -v };
            let scale = [0; 3].map(|_| signed(m));
            let offset = [0; 3].map(|_| signed(m / 3.0));
            let mut truth = vec![("time_constant_s".to_string(), t_c)];
            for j in Axis::ALL {
                truth.push((format!("scale_ppm_{j}"), scale[j.index()]));
                truth.push((format!("offset_um_{j}"), offset[j.index()]));
            }
            let session = either_way(
                seed,
                way,
                Effect::ThermalDrift {
                    time_constant_s: t_c,
                    offset_um: offset,
                    scale_ppm: scale,
                },
                |s| {
                    for j in Axis::ALL {
                        let i = j.index();
                        add_error(s, j, |run, k| {
                            let g = 1.0 - (-run.t_s[k] / t_c).exp();
                            g * (offset[i] + scale[i] * run.pos_mm[k][i] * 1e-3)
                        });
                    }
                },
            );
            // The growth over the recorded span, g(t_end)·(o, k): t_end the last sample's.
            let t_end = super::diagnosis_thermal_coverage::duration(&session);
            let g = 1.0 - (-t_end / t_c).exp();
            for j in Axis::ALL {
                truth.push((format!("span_scale_ppm_{j}"), g * scale[j.index()]));
                truth.push((format!("span_offset_um_{j}"), g * offset[j.index()]));
            }
            plain("thermal_drift", None, truth, session)
        }
        other => panic!("no effect {other}"),
    }
}

/// The tally of one parameter over the seeds of a cell.
#[derive(Debug, Default, Clone)]
struct Stat {
    reported: usize,
    within: usize,
    undetermined: usize,
    /// z of every reported estimate.
    z: Vec<f64>,
}

impl Stat {
    fn z_mean_sd(&self) -> (f64, f64) {
        let n = self.z.len() as f64;
        if n == 0.0 {
            return (f64::NAN, f64::NAN);
        }
        let m = self.z.iter().sum::<f64>() / n;
        let v = self.z.iter().map(|z| (z - m) * (z - m)).sum::<f64>() / (n - 1.0).max(1.0);
        (m, v.sqrt())
    }
}

/// The finding of `made` among the findings and the possible ones.
fn finding_of<'a>(made: &Made, r: &'a DiagnosisResult) -> Option<&'a Finding> {
    r.findings.iter().chain(&r.possible).find(|f| {
        f.effect == made.effect
            && made
                .axis
                .is_none_or(|a| f.axis.as_deref() == Some(a.to_string().as_str()))
    })
}

/// Scores one diagnosis: per parameter name, (reported with σ: z, or undetermined).
fn score(made: &Made, r: &DiagnosisResult) -> (bool, BTreeMap<String, Option<f64>>) {
    let mut out = BTreeMap::new();
    let Some(f) = finding_of(made, r) else {
        return (false, out);
    };
    let mut truth = made.truth.clone();
    if let Some(b) = &made.profile {
        let at = |n: usize| {
            f.parameters
                .get(&format!("target_mm_{n}"))
                .or_else(|| {
                    f.undetermined
                        .iter()
                        .find(|u| u.name == format!("target_mm_{n}"))
                        .map(|u| &u.value)
                })
                .copied()
        };
        let targets: Vec<f64> = (1..=5).filter_map(at).collect();
        if targets.len() == 5 {
            let vals: Vec<f64> = targets.iter().map(|&q| b(q)).collect();
            let mean = vals.iter().sum::<f64>() / 5.0;
            let var = (vals.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / 5.0).sqrt();
            for (n, v) in vals.iter().enumerate() {
                truth.push((format!("lost_motion_um_{}", n + 1), *v));
            }
            truth.push(("mean_lost_motion_um".into(), mean));
            truth.push(("variation_um".into(), var));
        }
    }
    for (name, want) in truth {
        if let (Some(&v), Some(&sd)) = (
            f.parameters.get(&name),
            f.parameters.get(&format!("std_{name}")),
        ) {
            let z = if name.starts_with("phase") {
                ((v - want + PI).rem_euclid(2.0 * PI) - PI) / sd
            } else {
                z_of(f, &name, want).unwrap_or(f64::NAN)
            };
            out.insert(name, Some(z));
        } else if f.undetermined.iter().any(|u| u.name == name) {
            out.insert(name, None);
        }
    }
    (true, out)
}

/// One cell's rows: per parameter, its tally; and the seeds whose finding was found.
fn run_cell(effect: &str, way: usize, m: f64, seeds: &[u64]) -> (usize, BTreeMap<String, Stat>) {
    let scored = par_map(seeds, |seed| {
        let made = make(effect, way, m, seed);
        let r = diagnose_session(&made.session, &DiagnoseOptions::default()).unwrap();
        let s = score(&made, &r);
        if std::env::var("COVERAGE_DEBUG").is_ok() {
            eprintln!(
                "{effect} {way} {m} seed {seed}: {:?} {:?} possible {:?} rejected {:?} scored {:?}",
                r.verdict,
                r.findings
                    .iter()
                    .map(|f| (&f.effect, &f.axis, &f.parameters))
                    .collect::<Vec<_>>(),
                r.possible
                    .iter()
                    .map(|f| (&f.effect, &f.axis, &f.undetermined))
                    .collect::<Vec<_>>(),
                r.rejected,
                s.1
            );
        }
        s
    });
    let mut found = 0;
    let mut stats: BTreeMap<String, Stat> = BTreeMap::new();
    for (f, params) in scored {
        found += usize::from(f);
        for (name, z) in params {
            let st = stats.entry(name).or_default();
            match z {
                Some(z) => {
                    st.reported += 1;
                    st.within += usize::from(z.abs() <= 2.0);
                    st.z.push(z);
                }
                None => st.undetermined += 1,
            }
        }
    }
    (found, stats)
}

/// Every effect × way × magnitude: the share of each reported parameter within 2σ of the
/// truth and its z mean and spread. `COVERAGE_SEEDS` seeds per cell (2 in the normal
/// test command), `COVERAGE_CELLS` a filter on "effect way magnitude".
///
/// Held in the normal test command: pooled over every cell and parameter, ≥ 90 % of the
/// reported estimates within 2σ and at most 10 % of the (seed, parameter) pairs reported
/// outside 2σ; and the large magnitude of each effect found in every seed. From 20 seeds
/// on, every (cell, parameter) reported in at least 10 seeds holds 90 % within 2σ up to two binomial standard errors
/// (≥ 81 % at 40 seeds), or (a parameter of truth 0, reported only where |value| ≥ 2σ)
/// has ≤ 10 % of its pairs reported outside.
#[test]
fn effect_coverage_over_seeds_magnitudes_and_ways() {
    let n: u64 = std::env::var("COVERAGE_SEEDS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(2);
    let only = std::env::var("COVERAGE_CELLS").unwrap_or_default();
    let mut rows = Vec::new();
    let mut failed = Vec::new();
    let (mut reported, mut within, mut all_pairs) = (0, 0, 0);
    for (ei, (effect, ways, mags)) in EFFECTS.iter().enumerate() {
        for (way, way_name) in ways.iter().enumerate() {
            for (mi, &m) in mags.iter().enumerate() {
                let label = format!("{effect} {way_name} {m}");
                if !label.contains(&only) {
                    continue;
                }
                let base = 100_000 * ei as u64 + 10_000 * way as u64 + 1_000 * mi as u64;
                let seeds: Vec<u64> = (base..base + n).collect();
                let (found, stats) = run_cell(effect, way, m, &seeds);
                if mi + 1 == mags.len() && found < seeds.len() {
                    failed.push(format!("{label}: found in {found} of {n} seeds"));
                }
                // The lack-of-fit test of the model's form (docs/diagnosis.md, "A model
                // form that does not hold"): a shift at reversal made in the model's own
                // (sharp) form is reported in every seed. One that settles over 0.5 mm of
                // travel is a clearance taken up over travel, which the model's take-up
                // (linear over `take_up_mm`) follows within the noise at 1 µm: reported
                // there, it holds its σ (the rows below); from 3 µm the exponential shape
                // shows and the form test sets it aside.
                if *effect == "direction_coupling" {
                    let st = stats.get("shift_um").cloned().unwrap_or_default();
                    let set_aside = st.undetermined > 0 && way == 0;
                    let kept = st.reported > 0 && way == 1 && m >= 3.0;
                    if set_aside || kept {
                        failed.push(format!(
                            "{label}: shift reported in {}, undetermined in {} of {found} seeds",
                            st.reported, st.undetermined
                        ));
                    }
                }
                for (name, st) in &stats {
                    let (zm, zs) = st.z_mean_sd();
                    let share = st.within as f64 / st.reported.max(1) as f64;
                    // Of the seeds where the finding was found, the share that reports
                    // the parameter with a σ missing the truth (a parameter of truth 0
                    // reported only when |value| ≥ 2σ is outside whenever reported).
                    let pairs = st.reported + st.undetermined;
                    let outside = (st.reported - st.within) as f64 / pairs.max(1) as f64;
                    rows.push(format!(
                        "| {effect} | {way_name} | {m} | {name} | {n} | {found} | {} | {:.0} % | {zm:+.2} | {zs:.2} | {} | {:.0} % |",
                        st.reported,
                        100.0 * share,
                        st.undetermined,
                        100.0 * outside,
                    ));
                    eprintln!("{}", rows.last().unwrap());
                    reported += st.reported;
                    within += st.within;
                    all_pairs += pairs;
                    // 90 % less two binomial standard errors of a share of 90 % over
                    // the seeds reported (81 % at 40): a cell that holds 90 % falls
                    // below this by chance in about 2 % of the cells.
                    let floor = 0.9 - 2.0 * (0.09 / st.reported.max(1) as f64).sqrt();
                    if n >= 20 && st.reported >= 10 && share < floor && outside > 0.1 {
                        failed.push(format!("coverage {}", rows.last().unwrap()));
                    }
                }
            }
        }
    }
    eprintln!(
        "| effect | made | magnitude | parameter | seeds | found | reported | within 2σ | z mean | z spread | undetermined | reported outside 2σ |\n|---|---|---|---|---|---|---|---|---|---|---|---|"
    );
    for r in &rows {
        eprintln!("{r}");
    }
    let share = within as f64 / reported.max(1) as f64;
    let outside = (reported - within) as f64 / all_pairs.max(1) as f64;
    eprintln!(
        "pooled: {within} of {reported} reported within 2σ ({share:.3}); {:.3} of {all_pairs} (seed, parameter) pairs reported outside 2σ",
        outside
    );
    assert!(reported > 0 && share >= 0.9, "pooled {share}");
    assert!(outside <= 0.1, "pooled outside {outside}");
    assert!(failed.is_empty(), "{failed:#?}");
}
