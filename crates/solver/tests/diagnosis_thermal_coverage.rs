//! Coverage of the temperature-driven thermal coefficients against truth: sessions whose
//! thermal growth is made by hand here (not by the simulator's effect catalogue) follow
//! a temperature logged by a noisy sensor (5 mK per sample); every coefficient the
//! diagnosis reports with its σ must lie within 2σ of the truth in ≥ 90 % of the seeds,
//! or be reported undetermined.
//!
//! The growth is made four ways: the structure follows the sensor's temperature; it
//! follows it with a lag of 30 s (a structure slower than its sensor); it grows with a
//! quadratic term of the temperature as well; and the simulator's own
//! `temperature_growth` effect with the sensor's noise added to its log. The temperature
//! heats (an exponential approach), cools, or rises then falls below its start. Every
//! way is held to the rule; the lag and the quadratic coefficients of the lagged and
//! quadratic forms are scored too where a finding reports them (truth 0 where the
//! growth was made without them).
//!
//! The full table of docs/diagnosis-catalogue.md ("Coverage of a logged temperature's
//! growth") is printed by
//! `COVERAGE_SEEDS=40 cargo test -p mtcal-solver --test solver thermal_coverage -- --nocapture`;
//! the normal test command runs a few seeds of every cell.

use super::diagnosis_sessions::z_of;
use mtcal_solver::axis::Axis;
use mtcal_solver::diagnosis::{DiagnoseOptions, DiagnosisResult, diagnose_session, effects};
use mtcal_solver::simulate::Effect;
use mtcal_solver::simulate::logged::first_order_lag;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};
use std::f64::consts::PI;

const RATE: f64 = 10.0;
/// Sensor noise of the logged temperature (K, per sample).
const SENSOR_K: f64 = 0.005;

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// ΔT = P·(1 − e^(−t/τ)), τ a third of the session.
    Heating,
    /// ΔT = −P·(1 − e^(−t/τ)).
    Cooling,
    /// ΔT = P·sin(2π·t/D), D the session's duration: up, then down below the start.
    RiseFall,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Make {
    /// The structure's growth follows the logged (sensor) temperature.
    Direct,
    /// The structure follows the sensor's temperature through a first-order lag (s).
    Lagged(f64),
    /// Growth o·ΔT + q2·ΔT² (q2 = 0.1·o per K): the coefficient at ΔT = 0 is the truth.
    Quadratic,
    /// The simulator's `temperature_growth` effect (its own rise-then-fall temperature),
    /// with the sensor's noise added to the log.
    Catalogue,
}

pub struct Case {
    pub shape: Shape,
    pub make: Make,
    /// Peak temperature change (K).
    pub peak_k: f64,
    /// Growth per kelvin along X, Y, Z (µm/K), and scale per kelvin (ppm/K).
    pub offset_um_per_k: [f64; 3],
    pub scale_ppm_per_k: [f64; 3],
}

/// How one seed's reported coefficients stand against the truth.
#[derive(Debug, Default, Clone, Copy)]
pub struct Tally {
    pub within: usize,
    pub outside: usize,
    pub undetermined: usize,
    /// Parameters neither reported nor undetermined (no thermal finding at all).
    pub missing: usize,
}

impl Tally {
    fn add(&mut self, o: Tally) {
        self.within += o.within;
        self.outside += o.outside;
        self.undetermined += o.undetermined;
        self.missing += o.missing;
    }
}

/// Session time of a run's samples → temperature change of the shape.
fn shape_k(shape: Shape, peak: f64, t: f64, dur: f64) -> f64 {
    let tau = dur / 3.0;
    match shape {
        Shape::Heating => peak * (1.0 - (-t / tau).exp()),
        Shape::Cooling => -peak * (1.0 - (-t / tau).exp()),
        Shape::RiseFall => peak * (2.0 * PI * t / dur).sin(),
    }
}

/// A session of `case` for `seed`, with the truth's growth per kelvin.
pub fn session(case: &Case, seed: u64) -> mtcal_solver::session::Session {
    let mut rng = StdRng::seed_from_u64(seed ^ 0x7e3a);
    let effects = if case.make == Make::Catalogue {
        vec![Effect::TemperatureGrowth {
            peak_k: case.peak_k,
            peak_at_s: rng.random_range(250.0..500.0),
            offset_um_per_k: case.offset_um_per_k,
            scale_ppm_per_k: case.scale_ppm_per_k,
        }]
    } else {
        Vec::new()
    };
    let mut s = super::diagnosis_sessions::session_with(seed, RATE, effects);
    let sensor = Normal::new(0.0, SENSOR_K).unwrap();
    if case.make == Make::Catalogue {
        for r in s.planes.iter_mut().flat_map(|p| &mut p.runs) {
            for t in r.temp_c.as_mut().unwrap() {
                *t += sensor.sample(&mut rng);
            }
        }
        return s;
    }
    let dur = duration(&s);
    // The structure's temperature: the sensor's, or lagged by a first-order response
    // ([`first_order_lag`]: the clock continuous over the gaps between runs).
    let mut structure = 0.0;
    let mut last_t = 0.0;
    for p in &mut s.planes {
        let (u, v) = p.plane.axes();
        for r in &mut p.runs {
            let mut temp = Vec::with_capacity(r.len());
            for i in 0..r.len() {
                let t = r.t_s[i];
                let dt = shape_k(case.shape, case.peak_k, t, dur);
                structure = match case.make {
                    Make::Lagged(tau) => first_order_lag(structure, last_t, t, tau, |tm| {
                        shape_k(case.shape, case.peak_k, tm, dur)
                    }),
                    _ => dt,
                };
                last_t = t;
                let q = r.pos_mm[i];
                let growth = |j: Axis| {
                    let j = j.index();
                    let lin = case.offset_um_per_k[j] + case.scale_ppm_per_k[j] * q[j] * 1e-3;
                    let quad = if case.make == Make::Quadratic {
                        0.1 * case.offset_um_per_k[j] * structure
                    } else {
                        0.0
                    };
                    structure * (lin + quad)
                };
                r.du_um[i] += growth(u);
                r.dv_um[i] += growth(v);
                temp.push(20.0 + dt + sensor.sample(&mut rng));
            }
            r.temp_c = Some(temp);
        }
    }
    s
}

/// The truth's parameters by their reported names.
fn truth(case: &Case) -> Vec<(String, f64)> {
    Axis::ALL
        .into_iter()
        .flat_map(|a| {
            let i = a.index();
            [
                (format!("offset_um_per_k_{a}"), case.offset_um_per_k[i]),
                (format!("scale_ppm_per_k_{a}"), case.scale_ppm_per_k[i]),
            ]
        })
        .collect()
}

/// The truth of the parameters of the lagged and the quadratic forms, scored when a
/// finding reports them (a form not chosen reports none): the lag (0 where the
/// structure follows its sensor) and the quadratic coefficients (0 where the growth is
/// linear).
fn truth_of_forms(case: &Case) -> Vec<(String, f64)> {
    let lag = match case.make {
        Make::Lagged(tau) => tau,
        _ => 0.0,
    };
    let mut out = vec![("lag_s".to_string(), lag)];
    for a in Axis::ALL {
        let i = a.index();
        let q = if case.make == Make::Quadratic {
            0.1 * case.offset_um_per_k[i]
        } else {
            0.0
        };
        out.push((format!("offset_um_per_k2_{a}"), q));
        out.push((format!("scale_ppm_per_k2_{a}"), 0.0));
    }
    out
}

/// The truth of the time form g = 1 − e^(−t/T) of `thermal_drift`, which a heating or a
/// cooling made directly also is (T a third of the session `dur`, the final offset and
/// scale ±P times the growth per kelvin).
fn truth_in_time(case: &Case, dur: f64) -> Option<Vec<(String, f64)>> {
    let sign = match (case.shape, case.make) {
        (Shape::Heating, Make::Direct) => 1.0,
        (Shape::Cooling, Make::Direct) => -1.0,
        _ => return None,
    };
    let p = sign * case.peak_k;
    let mut out = vec![("time_constant_s".to_string(), dur / 3.0)];
    for a in Axis::ALL {
        let i = a.index();
        out.push((format!("offset_um_{a}"), p * case.offset_um_per_k[i]));
        out.push((format!("scale_ppm_{a}"), p * case.scale_ppm_per_k[i]));
    }
    Some(out)
}

/// The session's duration (s): the last sample's time.
pub(crate) fn duration(s: &mtcal_solver::session::Session) -> f64 {
    s.planes
        .iter()
        .flat_map(|p| &p.runs)
        .flat_map(|r| r.t_s.last())
        .fold(0.0f64, |a, &t| a.max(t))
}

/// Scores a diagnosis against the truth of `case` (a session `dur` long): the per-kelvin
/// form, or the time form where the growth is also one.
pub fn score(case: &Case, r: &DiagnosisResult, dur: f64) -> Tally {
    let mut t = Tally::default();
    let thermal = r
        .findings
        .iter()
        .chain(&r.possible)
        .find(|f| f.effect == "thermal_drift");
    if let Some(f) = thermal {
        // Every name it reports (the lagged and quadratic forms' too) is the effects
        // table's.
        effects::conforms(f).unwrap_or_else(|e| panic!("{e}: {f:#?}"));
    }
    let in_time = thermal.is_some_and(|f| {
        f.parameters.contains_key("time_constant_s")
            || f.undetermined.iter().any(|u| u.name == "time_constant_s")
    });
    let (truth, optional) = match truth_in_time(case, dur) {
        Some(tt) if in_time => (tt, vec![]),
        _ => (truth(case), truth_of_forms(case)),
    };
    let n_required = truth.len();
    for (k, (name, want)) in truth.into_iter().chain(optional).enumerate() {
        let Some(f) = thermal else {
            t.missing += usize::from(k < n_required);
            continue;
        };
        if let (Some(&v), Some(&sd), Some(z)) = (
            f.parameters.get(&name),
            f.parameters.get(&format!("std_{name}")),
            z_of(f, &name, want),
        ) {
            if z.abs() <= 2.0 {
                t.within += 1;
            } else {
                if std::env::var("COVERAGE_DEBUG").is_ok() {
                    eprintln!(
                        "  {name}: {v:.3} ± {sd:.3} truth {want:.3} z {:.1}",
                        (v - want) / sd
                    );
                }
                t.outside += 1;
            }
        } else if f.undetermined.iter().any(|u| u.name == name) {
            t.undetermined += 1;
        } else {
            t.missing += usize::from(k < n_required);
        }
    }
    t
}

fn diagnose(s: &mtcal_solver::session::Session) -> DiagnosisResult {
    diagnose_session(s, &DiagnoseOptions::default()).unwrap()
}

/// Every cell of the table: shape × way made × peak temperature change (K). The
/// simulator's own effect has its own (rise-then-fall) shape.
fn cells() -> Vec<(Shape, Make, f64)> {
    let mut out = Vec::new();
    for make in [Make::Direct, Make::Lagged(30.0), Make::Quadratic] {
        for shape in [Shape::Heating, Shape::Cooling, Shape::RiseFall] {
            for peak in [0.2, 0.6, 2.0] {
                out.push((shape, make, peak));
            }
        }
    }
    for peak in [0.2, 0.6, 2.0] {
        out.push((Shape::RiseFall, Make::Catalogue, peak));
    }
    out
}

/// A case of the cell with random growth per kelvin for `seed`.
fn case(shape: Shape, make: Make, peak_k: f64, seed: u64) -> Case {
    let mut rng = StdRng::seed_from_u64(seed ^ 0xc0fe);
    let signed = |rng: &mut StdRng, lo: f64, hi: f64| {
        let v: f64 = rng.random_range(lo..hi);
        if rng.random_bool(0.5) { v } else { -v }
    };
    Case {
        shape,
        make,
        peak_k,
        offset_um_per_k: [0; 3].map(|_| signed(&mut rng, 1.0, 8.0)),
        scale_ppm_per_k: [0; 3].map(|_| signed(&mut rng, 5.0, 15.0)),
    }
}

/// Every growth per kelvin within 2σ of the truth, or not reported with a σ
/// (undetermined, or no thermal finding), in ≥ 90 % of the (seed, parameter) pairs of
/// every cell; of the parameters reported, ≥ 90 % within 2σ pooled over the cells; the
/// large changes determined. `COVERAGE_SEEDS` seeds per cell (2 in the normal test command, where the
/// share is pooled over the cells; per cell from 20 seeds on).
#[test]
fn thermal_coverage_with_a_noisy_sensor() {
    let seeds: u64 = std::env::var("COVERAGE_SEEDS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(2);
    let mut total = Tally::default();
    let mut rows = Vec::new();
    let mut failed = Vec::new();
    let only = std::env::var("COVERAGE_CELLS").unwrap_or_default();
    for (ci, (shape, make, peak)) in cells().into_iter().enumerate() {
        if !format!("{shape:?} {make:?} {peak}").contains(&only) {
            continue;
        }
        let mut cell = Tally::default();
        let mut found = 0;
        for k in 0..seeds {
            // Seeds of their own per cell: the cells are independent samples.
            let seed = 1000 * ci as u64 + k;
            let c = case(shape, make, peak, seed);
            let s = session(&c, seed);
            let r = diagnose(&s);
            let t = score(&c, &r, duration(&s));
            if std::env::var("COVERAGE_DEBUG").is_ok() {
                eprintln!(
                    "seed {seed}: {:?} {:?} possible {:?} rejected {:?}",
                    r.verdict,
                    r.findings
                        .iter()
                        .map(|f| (&f.effect, &f.parameters))
                        .collect::<Vec<_>>(),
                    r.possible
                        .iter()
                        .map(|f| (&f.effect, &f.undetermined))
                        .collect::<Vec<_>>(),
                    r.rejected
                );
            }
            found += usize::from(t.missing == 0);
            cell.add(t);
        }
        total.add(cell);
        let reported = cell.within + cell.outside;
        let share = cell.within as f64 / reported.max(1) as f64;
        // The rule per (seed, parameter): within 2σ, or not reported with a σ.
        let pairs = reported + cell.undetermined + cell.missing;
        let wrong = cell.outside as f64 / pairs.max(1) as f64;
        rows.push(format!(
            "| {shape:?} | {make:?} | {peak} | {seeds} | {found} | {reported} | {:.0} % | {} | {:.0} % |",
            100.0 * share,
            cell.undetermined,
            100.0 * wrong,
        ));
        eprintln!("{}", rows.last().unwrap());
        if seeds >= 20 && wrong > 0.1 {
            failed.push(format!("coverage {}", rows.last().unwrap()));
        }
        // A change of 2 K is found and its coefficients determined in most seeds.
        if peak >= 2.0 && make == Make::Direct && 2 * reported < 6 * seeds as usize {
            failed.push(format!("undetermined {}", rows.last().unwrap()));
        }
    }
    eprintln!(
        "| shape | made | peak K | seeds | thermal found | reported | within 2σ | undetermined | reported outside 2σ |\n|---|---|---|---|---|---|---|---|---|"
    );
    for r in &rows {
        eprintln!("{r}");
    }
    let reported = total.within + total.outside;
    let share = total.within as f64 / reported.max(1) as f64;
    eprintln!("pooled: {share:.3} of {reported} reported, {total:?}");
    assert!(reported > 0 && share >= 0.9, "pooled {share}: {total:?}");
    assert!(failed.is_empty(), "{failed:#?}");
}
