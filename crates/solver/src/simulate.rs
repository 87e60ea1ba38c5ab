//! Simulator of planar grid-encoder sessions, with the effects the rigid model leaves out.
//!
//! A machine with known errors runs a test plan; the simulator records what a grid encoder
//! would read. For every sample at commanded position q with declared head offset t:
//!
//! (du, dv) = in-plane components of e_exact(q, t_true)   (exact HTM chain, µm)
//!          + φ·(v, −u)·10⁻³                               (plate rotation φ µrad; (u, v) = in-plane q + t, mm)
//!          + (o_u, o_v)                                   (per-run zero offsets, µm)
//!          + Σ effects                                    (see [`effects`])
//!          + N(0, σ²) per component                       (noise)
//!
//! Motion: lines and circles at feed F (default 500 mm/min) with a trapezoidal profile of
//! acceleration 500 mm/s², sampled at 100 Hz by default, with a dwell (default 0.5 s) at
//! the end of every run (the reversal of a line pass). Between runs of one plate the
//! approach moves are not recorded (5 s); re-mounting a plate takes 300 s. Time `t_s`
//! increases over the whole session.
//!
//! Deterministic for a given seed. Random parts: [`random_truth`] (the machine), the
//! mounting rotations (uniform ±100 µrad), the zero offsets (uniform ±3 µm), the noise.

pub mod effects;
pub mod logged;
pub mod motion;
pub mod plan;
pub mod truth;

pub use effects::Effect;
pub use plan::{Plan, PlaneTest};
pub use truth::{RunOffset, Truth, TruthTerm};

use crate::axis::{Axis, Topology};
use crate::basis::PolyErrors;
use crate::error::SolverError;
use crate::kinematics::exact_error_um;
use crate::session::{PlaneRecord, Run, Session, TestKind};
use crate::terms::{Squareness, Term, TermKind};
use motion::{MotionSample, Path, Profile, Travel};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};
use std::collections::BTreeMap;

/// Acceleration of the feed profile (mm/s²).
pub const ACCEL_MM_S2: f64 = 500.0;
/// Unrecorded time between two runs of one plate (approach moves), s.
pub const RUN_GAP_S: f64 = 5.0;
/// Unrecorded time to change the plate's plane or riser, s.
pub const REMOUNT_GAP_S: f64 = 300.0;

/// Options of a simulation.
#[derive(Debug, Clone, PartialEq)]
pub struct SimOptions {
    pub plan: Plan,
    /// Seed of every random draw (mountings, offsets, noise; effects are given).
    pub seed: u64,
    /// Standard deviation of the measurement noise per component (µm), default 0.15.
    pub noise_um: f64,
    /// Sample rate (Hz), default 100.
    pub sample_rate_hz: f64,
    /// Programmed feed (mm/min), default 500.
    pub feed_mm_min: f64,
    /// Dwell at the end of each run (s), default 0.5.
    pub dwell_s: f64,
    pub topology: Topology,
    pub machine_id: String,
    pub measured_at: String,
    /// Reporting grid step for the truth (mm), default 5.
    pub grid_step_mm: f64,
    pub effects: Vec<Effect>,
}

impl Default for SimOptions {
    fn default() -> Self {
        SimOptions {
            plan: Plan::Seed,
            seed: 1,
            noise_um: 0.15,
            sample_rate_hz: 100.0,
            feed_mm_min: 500.0,
            dwell_s: 0.5,
            topology: Topology::default(),
            machine_id: "SIM-0001".into(),
            measured_at: "2026-11-02T08:30:00Z".into(),
            grid_step_mm: 5.0,
            effects: Vec::new(),
        }
    }
}

/// A simulated session and what was put into it.
#[derive(Debug, Clone, PartialEq)]
pub struct SimOutput {
    pub session: Session,
    pub truth: Truth,
}

/// Scale (mm) at which [`random_truth`]'s magnitudes are stated: the seed plan's ±50 mm.
pub const TRUTH_SCALE_MM: f64 = 50.0;

/// A random machine with realistic cubic errors. Each power k contributes a_k·(q/L)^k,
/// L = 50 mm, a_k ~ N(0, σ): positioning σ = 2 µm, straightness σ = 0.8 µm (powers 2, 3
/// only: no linear term), roll/pitch/yaw σ = 6 µrad; squareness uniform in ±30 µrad. So
/// over ±50 mm: positioning a few µm, straightness 1–2 µm, angles 5–20 µrad (larger at
/// ±100 mm, as a cubic grows).
pub fn random_truth(seed: u64) -> PolyErrors {
    let mut rng = StdRng::seed_from_u64(seed ^ 0x7275_7468);
    let n = Normal::new(0.0, 1.0).expect("unit normal");
    let mut e = PolyErrors::default();
    for term in Term::all() {
        let sigma = match term.kind() {
            TermKind::Positioning => 2.0,
            TermKind::Straightness => 0.8,
            TermKind::Roll | TermKind::PitchYaw => 6.0,
        };
        let c = (1..=3)
            .map(|k| {
                if k == 1 && term.kind() == TermKind::Straightness {
                    0.0
                } else {
                    sigma * n.sample(&mut rng) / TRUTH_SCALE_MM.powi(k)
                }
            })
            .collect();
        e.set(term, c);
    }
    e.squareness = Squareness {
        ec0y_urad: rng.random_range(-30.0..30.0),
        eb0z_urad: rng.random_range(-30.0..30.0),
        ea0z_urad: rng.random_range(-30.0..30.0),
    };
    e
}

fn check(truth: &PolyErrors, opts: &SimOptions) -> Result<(), SolverError> {
    let bad = |m: String| Err(SolverError::InvalidInput(m));
    opts.topology
        .validate()
        .map_err(SolverError::InvalidInput)?;
    if !(opts.sample_rate_hz.is_finite() && opts.sample_rate_hz > 0.0) {
        return bad(format!(
            "sample rate must be positive, got {}",
            opts.sample_rate_hz
        ));
    }
    if !(opts.feed_mm_min.is_finite() && opts.feed_mm_min > 0.0) {
        return bad(format!("feed must be positive, got {}", opts.feed_mm_min));
    }
    if !(opts.noise_um.is_finite() && opts.noise_um >= 0.0) {
        return bad(format!("noise must be ≥ 0, got {}", opts.noise_um));
    }
    if !(opts.dwell_s.is_finite() && opts.dwell_s >= 0.0) {
        return bad(format!("dwell must be ≥ 0, got {}", opts.dwell_s));
    }
    for (name, c) in &truth.coefficients {
        let term = Term::parse(name);
        if term.is_none() {
            return bad(format!("unknown error term `{name}` in the truth"));
        }
        if c.iter().any(|v| !v.is_finite()) {
            return bad(format!("non-finite coefficient in `{name}`"));
        }
    }
    let tests = opts.plan.tests();
    if tests.is_empty() {
        return bad("the plan has no tests".into());
    }
    for t in &tests {
        if !(t.half_travel_mm > 0.0 && t.round_trips > 0) {
            return bad(format!(
                "{}: lines need a positive travel and round trips",
                t.file
            ));
        }
    }
    Ok(())
}

/// The benchmarks' session: the full plan (three head offsets, 9 plane files) at 340 Hz
/// on the machine of `random_truth(1)`, 999 972 samples, as `mtcal simulate --plan full
/// --rate-hz 340 --seed 1` writes it (BENCHMARKS.md).
pub fn benchmark_session() -> Result<SimOutput, SolverError> {
    simulate(
        &random_truth(1),
        &SimOptions {
            plan: Plan::Full,
            sample_rate_hz: 340.0,
            ..Default::default()
        },
    )
}

/// The seed plan at 10 Hz on the random machine of `seed`: the small session of the
/// solver's unit tests.
#[cfg(test)]
pub(crate) fn seed_session(seed: u64) -> Session {
    let o = SimOptions {
        plan: Plan::Seed,
        sample_rate_hz: 10.0,
        ..Default::default()
    };
    simulate(&random_truth(seed), &o)
        .expect("the seed plan simulates")
        .session
}

/// Runs the plan on a machine with errors `truth` and records the session.
pub fn simulate(truth: &PolyErrors, opts: &SimOptions) -> Result<SimOutput, SolverError> {
    check(truth, opts)?;
    let mut rng = StdRng::seed_from_u64(opts.seed);
    let tests = opts.plan.tests();
    let rotations = mounting_rotations(&tests, &mut rng);
    let mut rec = Recorder {
        truth,
        opts,
        noise: Normal::new(0.0, opts.noise_um.max(0.0)).expect("finite σ"),
        rng,
        clock: 0.0,
        offsets: Vec::new(),
    };
    let mut planes = Vec::with_capacity(tests.len());
    for (ti, test) in tests.iter().enumerate() {
        if ti > 0 {
            rec.clock += REMOUNT_GAP_S;
        }
        planes.push(rec.plane(test, rotations[&test.mounting]));
    }
    let session = Session {
        machine_id: opts.machine_id.clone(),
        measured_at: opts.measured_at.clone(),
        topology: Some(opts.topology.clone()),
        conditions: crate::uncertainty::Conditions {
            temperature_c: Some(20.0),
            temperature_source: Some("stated".into()),
            ..Default::default()
        },
        notes: Some(session_notes(opts)),
        planes,
    };
    let truth_doc = truth_document(truth, opts, &session, rotations, rec.offsets);
    Ok(SimOutput {
        session,
        truth: truth_doc,
    })
}

/// The plate rotation of each mounting (µrad), drawn in the order of the plan's tests.
fn mounting_rotations(tests: &[PlaneTest], rng: &mut StdRng) -> BTreeMap<String, f64> {
    let mut rotations: BTreeMap<String, f64> = BTreeMap::new();
    for t in tests {
        if !rotations.contains_key(&t.mounting) {
            rotations.insert(t.mounting.clone(), rng.random_range(-100.0..100.0));
        }
    }
    rotations
}

/// The session's note: seed, noise and effects.
fn session_notes(opts: &SimOptions) -> String {
    let effects = if opts.effects.is_empty() {
        String::new()
    } else {
        format!(
            ", effects: {}",
            opts.effects
                .iter()
                .map(Effect::name)
                .collect::<Vec<_>>()
                .join(", ")
        )
    };
    format!(
        "simulated by mtcal (seed {}, noise {} µm{effects})",
        opts.seed, opts.noise_um
    )
}

/// The truth document of a simulated `session`.
fn truth_document(
    truth: &PolyErrors,
    opts: &SimOptions,
    session: &Session,
    rotations: BTreeMap<String, f64>,
    offsets: Vec<RunOffset>,
) -> Truth {
    let travel = truth::measured_travel(session);
    let (terms, squareness_urad) = truth::reported_values(truth, &travel, opts.grid_step_mm);
    Truth {
        kind: "simulation_truth".into(),
        seed: opts.seed,
        noise_um: opts.noise_um,
        sample_rate_hz: opts.sample_rate_hz,
        feed_mm_min: opts.feed_mm_min,
        accel_mm_s2: ACCEL_MM_S2,
        dwell_s: opts.dwell_s,
        errors: truth.clone(),
        mounting_rotation_urad: rotations,
        run_offsets: offsets,
        effects: opts.effects.clone(),
        travel_mm: Axis::ALL
            .iter()
            .filter_map(|a| travel[a.index()].map(|r| (a.to_string(), r)))
            .collect(),
        terms,
        squareness_urad,
        reporting: truth::reporting_sentences(&travel, opts.grid_step_mm),
    }
}

/// The recording of a session in progress: the machine, the options, the random draws
/// (zero offsets, then noise, run by run), the session's clock and the offsets drawn.
struct Recorder<'a> {
    truth: &'a PolyErrors,
    opts: &'a SimOptions,
    noise: Normal<f64>,
    rng: StdRng,
    clock: f64,
    offsets: Vec<RunOffset>,
}

/// How one plane test's plate is mounted: its file, in-plane axes, true head offset and
/// rotation (µrad).
struct Mount<'t> {
    file: &'t str,
    axes: (Axis, Axis),
    t_true: [f64; 3],
    phi_urad: f64,
}

impl Recorder<'_> {
    /// The runs of one plane test: line passes along both in-plane axes, then the circles
    /// when the test has them.
    fn plane(&mut self, test: &PlaneTest, phi_urad: f64) -> PlaneRecord {
        let (ua, va) = test.plane.axes();
        let mut base = [0.0; 3];
        base[test.plane.normal().index()] = test.park_mm;
        let mut state = Travel::at(base);
        let mut t_true = test.head_offset_mm;
        for eff in &self.opts.effects {
            let d = eff.head_offset_delta_mm(test.head_offset_mm);
            for i in 0..3 {
                t_true[i] += d[i];
            }
        }
        let mount = Mount {
            file: &test.file,
            axes: (ua, va),
            t_true,
            phi_urad,
        };
        let mut runs = Vec::new();
        for (axis, kind) in [(ua, line_kind(ua)), (va, line_kind(va))] {
            let h = test.half_travel_mm;
            self.clock += RUN_GAP_S;
            for pass in 0..2 * test.round_trips {
                let sense = if pass % 2 == 0 { 1.0 } else { -1.0 };
                let mut start = base;
                start[axis.index()] = -sense * h;
                let mut dir = [0.0; 3];
                dir[axis.index()] = sense;
                let number = runs.len() as i64 + 1;
                let path = Path::Line { start, dir };
                runs.push(self.run(&mount, path, 2.0 * h, kind, number, &mut state));
            }
        }
        if let Some(r) = test.circle_radius_mm {
            for (sense, kind) in [(1.0, TestKind::CircleCcw), (-1.0, TestKind::CircleCw)] {
                self.clock += RUN_GAP_S;
                let path = Path::Circle {
                    centre: base,
                    u: ua,
                    v: va,
                    radius_mm: r,
                    sense,
                };
                let number = runs.len() as i64 + 1;
                runs.push(self.run(&mount, path, path.length_mm(0.0), kind, number, &mut state));
            }
        }
        PlaneRecord {
            file: test.file.clone(),
            plane: test.plane,
            head_offset_mm: test.head_offset_mm,
            mounting: test.mounting.clone(),
            runs,
        }
    }

    /// One run along `path` (`length` mm) from where the drive is: its samples with the
    /// run's zero offsets and noise; the clock moves on past it.
    fn run(
        &mut self,
        m: &Mount<'_>,
        path: Path,
        length: f64,
        kind: TestKind,
        number: i64,
        state: &mut Travel,
    ) -> Run {
        let opts = self.opts;
        let rate = opts.sample_rate_hz;
        state.move_to(path.at(0.0, 0.0).0);
        let profile = Profile::new(length, opts.feed_mm_min / 60.0, ACCEL_MM_S2);
        let samples = motion::run_samples(&path, &profile, opts.dwell_s, self.clock, rate, state);
        let rng = &mut self.rng;
        let (ou, ov) = (rng.random_range(-3.0..3.0), rng.random_range(-3.0..3.0));
        self.offsets.push(RunOffset {
            file: m.file.to_string(),
            run: number,
            du_um: ou,
            dv_um: ov,
        });
        let mut run = Run {
            number,
            test: Some(kind),
            ..Run::default()
        };
        let logs_temperature = opts
            .effects
            .iter()
            .any(|e| e.temperature_rise_k(0.0).is_some());
        if logs_temperature {
            run.temp_c = Some(Vec::with_capacity(samples.len()));
        }
        for s in &samples {
            if let Some(temp) = run.temp_c.as_mut() {
                let rise: f64 = opts
                    .effects
                    .iter()
                    .filter_map(|e| e.temperature_rise_k(s.t_s))
                    .sum();
                temp.push(20.0 + rise);
            }
            let (du, dv) = measure(self.truth, opts, s, m.t_true, m.axes, m.phi_urad);
            run.t_s.push(s.t_s);
            run.pos_mm.push(s.q_mm);
            let (nu, nv) = if opts.noise_um > 0.0 {
                (self.noise.sample(rng), self.noise.sample(rng))
            } else {
                (0.0, 0.0)
            };
            run.du_um.push(du + ou + nu);
            run.dv_um.push(dv + ov + nv);
        }
        self.clock = samples.last().map_or(self.clock, |s| s.t_s) + 1.0 / rate;
        run
    }
}

fn line_kind(a: Axis) -> TestKind {
    match a {
        Axis::X => TestKind::LineX,
        Axis::Y => TestKind::LineY,
        Axis::Z => TestKind::LineZ,
    }
}

/// Noise-free reading (du, dv) without zero offsets at one sample.
fn measure(
    truth: &PolyErrors,
    opts: &SimOptions,
    s: &MotionSample,
    t_true: [f64; 3],
    (ua, va): (Axis, Axis),
    phi_urad: f64,
) -> (f64, f64) {
    let mut e = exact_error_um(&opts.topology, truth, s.q_mm, t_true);
    for eff in &opts.effects {
        e += eff.error_um(s);
    }
    let u = s.q_mm[ua.index()] + t_true[ua.index()];
    let v = s.q_mm[va.index()] + t_true[va.index()];
    (
        e[ua.index()] + phi_urad * v * 1e-3,
        e[va.index()] - phi_urad * u * 1e-3,
    )
}
