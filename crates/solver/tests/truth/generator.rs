//! An independent session generator: its own motion, its own mechanisms, written from
//! the physics and not from the diagnosis's simulator or catalogue.
//!
//! Every axis is stepped on a 1 kHz grid over the whole session, the unrecorded moves
//! and pauses included, so every mechanism with a state (a play, a lateral clearance,
//! a reversal transient) carries it through standstill, dwells, run starts and the
//! moves between runs and between mountings. The record is sampled from that grid.
//!
//! Errors are tool-relative-to-workpiece deviations along the machine axes, µm
//! (measured − commanded, docs/conventions.md); the plate reads their in-plane
//! components, plus its own rotation and scale, a zero offset per run and noise.

use mtcal_solver::axis::{Axis, Plane, Topology};
use mtcal_solver::session::{PlaneRecord, Run, Session, TestKind};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};
use std::collections::VecDeque;

/// Internal time step, s (1 kHz).
const DT: f64 = 1e-3;
/// Acceleration of the feed ramps, mm/s² (peak of a sine-shaped ramp).
const ACCEL: f64 = 400.0;
/// Feed of the unrecorded moves, mm/min.
const RAPID_MM_MIN: f64 = 3000.0;

/// One effect put into a session, with its truth.
#[derive(Debug, Clone, PartialEq)]
pub enum Effect {
    /// A play of width `um` in the axis drive: the axis stops short of its set-point by
    /// `um`/2 in the direction of travel (error −d·b/2 once the play is taken up).
    Backlash { axis: Axis, um: f64 },
    /// A play whose width grows linearly in time: `from_um` at the session start,
    /// `from_um + per_h_um`·t_h after t_h hours.
    GrowingBacklash {
        axis: Axis,
        from_um: f64,
        per_h_um: f64,
    },
    /// The axis follows its set-point `ms` milliseconds late.
    ServoLag { axis: Axis, ms: f64 },
    /// A lag, a cyclic amplitude, a spike height or a lateral play's shift growing
    /// linearly in time: `from` at
    /// the session start (ms for a lag, µm otherwise), + `per_h` per hour.
    Growing {
        axis: Axis,
        grows: Grows,
        from: f64,
        per_h: f64,
    },
    /// An error periodic in the axis position: A·sin(2π q/P + φ).
    Cyclic {
        axis: Axis,
        amp_um: f64,
        period_mm: f64,
        phase_rad: f64,
    },
    /// A warm-up along `axis`: g(t)·(offset + scale·q·10⁻³), g = 1 − e^(−t/T).
    Thermal {
        axis: Axis,
        offset_um: f64,
        scale_ppm: f64,
        tau_s: f64,
    },
    /// A clearance across `moving`: the error along `axis` is ±`shift_um`/2 with the
    /// direction of travel of `moving` (taken up over 0.1 mm of its travel).
    LateralPlay {
        axis: Axis,
        moving: Axis,
        shift_um: f64,
    },
    /// A transient after each reversal of the axis: −d·h·e^(−s/λ), s its travel since.
    ReversalSpike {
        axis: Axis,
        height_um: f64,
        decay_mm: f64,
    },
    /// One knock along `axis`: `size_um`·e^(−(t − t₀)/τ)·cos(2π f (t − t₀)) from t₀ on
    /// (f = `ring_hz`, 0: a plain decay), t₀ at `at` of run `run` (1-based) of plane file
    /// `plane` (0-based).
    Knock {
        axis: Axis,
        size_um: f64,
        decay_s: f64,
        ring_hz: f64,
        plane: usize,
        run: i64,
        at: f64,
    },
    /// The grid of the plate of `plane` is `ppm` too long: the head reads (u, v)·(1 + k).
    PlateScale { plane: Plane, ppm: f64 },
    /// A vibration along `axis`, moving or at rest: A·sin(2π f t + φ) in session time.
    Vibration {
        axis: Axis,
        amp_um: f64,
        hz: f64,
        phase_rad: f64,
    },
    /// A play that widens and narrows again (a nut warming and cooling): `ends_um` at
    /// the session start and from `over_s` on, `ends_um + swell_um`·sin(π t/`over_s`)
    /// between; neither constant nor a steady growth (outside the catalogue).
    SwellingBacklash {
        axis: Axis,
        ends_um: f64,
        swell_um: f64,
        over_s: f64,
    },
}

/// What grows in an [`Effect::Growing`], with the parameters that stay.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Grows {
    /// A servo lag (ms).
    Lag,
    /// A cyclic error's amplitude (µm).
    Cyclic { period_mm: f64, phase_rad: f64 },
    /// A reversal spike's height (µm).
    Spike { decay_mm: f64 },
    /// A lateral play's shift (µm) with the travel of `moving`.
    Lateral { moving: Axis },
}

impl Grows {
    /// The constant effect on `axis` with value `v`.
    fn constant(self, axis: Axis, v: f64) -> Effect {
        match self {
            Grows::Lag => Effect::ServoLag { axis, ms: v },
            Grows::Cyclic {
                period_mm,
                phase_rad,
            } => Effect::Cyclic {
                axis,
                amp_um: v,
                period_mm,
                phase_rad,
            },
            Grows::Spike { decay_mm } => Effect::ReversalSpike {
                axis,
                height_um: v,
                decay_mm,
            },
            Grows::Lateral { moving } => Effect::LateralPlay {
                axis,
                moving,
                shift_um: v,
            },
        }
    }
}

impl Effect {
    /// The effect as it acts at session time `t` (s): a growing lag, cyclic error or
    /// spike as its constant form with its value then; every other effect as it is.
    pub fn at(&self, t: f64) -> Effect {
        match *self {
            Effect::Growing {
                axis,
                grows,
                from,
                per_h,
            } => grows.constant(axis, from + per_h * t / 3600.0),
            ref e => e.clone(),
        }
    }

    /// A play's axis and width at session time `t` (s), µm: constant, growing linearly,
    /// or widening and narrowing; `None` for every other effect.
    fn play_width_um(&self, t: f64) -> Option<(Axis, f64)> {
        match *self {
            Effect::Backlash { axis, um } => Some((axis, um)),
            Effect::GrowingBacklash {
                axis,
                from_um,
                per_h_um,
            } => Some((axis, from_um + per_h_um * t / 3600.0)),
            Effect::SwellingBacklash {
                axis,
                ends_um,
                swell_um,
                over_s,
            } => {
                let swell = (std::f64::consts::PI * (t / over_s).min(1.0)).sin();
                Some((axis, ends_um + swell_um * swell))
            }
            _ => None,
        }
    }

    /// `backlash X 6 µm`: the truth in words.
    pub fn describe(&self) -> String {
        match self {
            Effect::Backlash { axis, um } => format!("backlash {axis} {um} µm"),
            Effect::GrowingBacklash {
                axis,
                from_um,
                per_h_um,
            } => format!("growing backlash {axis} {from_um} µm + {per_h_um} µm/h"),
            Effect::ServoLag { axis, ms } => format!("servo lag {axis} {ms} ms"),
            Effect::Growing {
                axis,
                grows,
                from,
                per_h,
            } => format!(
                "growing {} + {per_h}/h",
                grows.constant(*axis, *from).describe()
            ),
            Effect::Cyclic {
                axis,
                amp_um,
                period_mm,
                ..
            } => format!("cyclic {axis} {amp_um} µm / {period_mm} mm"),
            Effect::Thermal {
                axis,
                offset_um,
                scale_ppm,
                tau_s,
            } => format!("thermal {axis} {offset_um} µm, {scale_ppm} ppm, T {tau_s} s"),
            Effect::LateralPlay {
                axis,
                moving,
                shift_um,
            } => format!("lateral play {axis} with {moving} {shift_um} µm"),
            Effect::ReversalSpike {
                axis,
                height_um,
                decay_mm,
            } => format!("reversal spike {axis} {height_um} µm / {decay_mm} mm"),
            Effect::Knock {
                axis,
                size_um,
                decay_s,
                ring_hz,
                ..
            } if *ring_hz > 0.0 => {
                format!("knock {axis} {size_um} µm, {decay_s} s, ringing {ring_hz} Hz")
            }
            Effect::Knock {
                axis,
                size_um,
                decay_s,
                ..
            } => format!("knock {axis} {size_um} µm, {decay_s} s"),
            Effect::PlateScale { plane, ppm } => format!("plate scale {plane} {ppm} ppm"),
            Effect::Vibration {
                axis, amp_um, hz, ..
            } => {
                format!("vibration {axis} {amp_um} µm at {hz} Hz")
            }
            Effect::SwellingBacklash {
                axis,
                ends_um,
                swell_um,
                over_s,
            } => format!("backlash {axis} {ends_um} µm swelling by {swell_um} µm over {over_s} s"),
        }
    }
}

/// How a session is recorded.
#[derive(Debug, Clone)]
pub struct Setup {
    pub seed: u64,
    pub noise_um: f64,
    /// Record rate, Hz (a divisor of 1000).
    pub rate_hz: f64,
    pub line_feed_mm_min: f64,
    pub circle_feed_mm_min: f64,
    /// Round trips of each line (two runs each).
    pub round_trips: usize,
    /// Whether each plate's two circles are recorded after its lines.
    pub circles: bool,
    /// Standstill recorded after each run's motion, s.
    pub dwell_s: f64,
    /// Unrecorded pause between runs, s.
    pub pause_s: f64,
    /// Small geometric errors of the machine (translational, within the rigid model).
    pub geometry: bool,
    /// The recorder samples on its own clock, from 0.2 s before each run's motion (true),
    /// or is started with each run's motion (false: a sample at its first instant).
    pub free_running: bool,
    /// Standstill recorded before each run's motion on a free-running recorder, s.
    pub lead_s: f64,
    /// Per-run zero offsets (±3 µm) and plate rotations (±100 µrad), as on a real
    /// set-up; off only for the generator's own tests.
    pub nuisance: bool,
    pub effects: Vec<Effect>,
}

impl Default for Setup {
    fn default() -> Self {
        Setup {
            seed: 1,
            noise_um: 0.15,
            rate_hz: 10.0,
            line_feed_mm_min: 500.0,
            circle_feed_mm_min: 500.0,
            round_trips: 5,
            circles: true,
            dwell_s: DWELL_S,
            pause_s: 3.0,
            geometry: true,
            free_running: true,
            lead_s: 0.2,
            nuisance: true,
            effects: Vec::new(),
        }
    }
}

/// A motion segment of the commanded path.
#[derive(Clone, Copy)]
enum Path {
    Line {
        from: [f64; 3],
        to: [f64; 3],
    },
    /// Circle about `c` of radius `r` in axes (u, v) from angle 0, `sense` +1 ccw.
    Circle {
        c: [f64; 3],
        u: usize,
        v: usize,
        r: f64,
        sense: f64,
    },
    Still([f64; 3]),
}

impl Path {
    fn length(&self) -> f64 {
        match *self {
            Path::Line { from, to } => (0..3)
                .map(|i| (to[i] - from[i]).powi(2))
                .sum::<f64>()
                .sqrt(),
            Path::Circle { r, .. } => 2.0 * std::f64::consts::PI * r,
            Path::Still(_) => 0.0,
        }
    }

    fn at(&self, s: f64) -> [f64; 3] {
        match *self {
            Path::Line { from, to } => {
                let l = self.length().max(1e-12);
                [0, 1, 2].map(|i| from[i] + (to[i] - from[i]) * s / l)
            }
            Path::Circle { c, u, v, r, sense } => {
                let th = sense * s / r;
                let mut q = c;
                q[u] += r * th.cos();
                q[v] += r * th.sin();
                q
            }
            Path::Still(q) => q,
        }
    }
}

/// Path coordinate over time with sine-shaped acceleration ramps (jerk-limited, unlike a
/// trapezoid): returns the duration and s(t).
fn profile(length: f64, feed_mm_s: f64) -> (f64, impl Fn(f64) -> f64) {
    // A ramp of duration Tr to speed F covers F·Tr/2; its peak acceleration is π F/(2 Tr).
    let ramp = |f: f64| std::f64::consts::PI * f / (2.0 * ACCEL);
    let mut f = feed_mm_s;
    if f * ramp(f) > length {
        // Shortened: F·Tr(F) = L with Tr proportional to F.
        f = (length * 2.0 * ACCEL / std::f64::consts::PI).sqrt();
    }
    let tr = ramp(f);
    let cruise = (length - f * tr) / f;
    let total = 2.0 * tr + cruise.max(0.0);
    let s = move |t: f64| {
        let up = |t: f64| {
            0.5 * f * (t - tr / std::f64::consts::PI * (std::f64::consts::PI * t / tr).sin())
        };
        if t <= 0.0 {
            0.0
        } else if t < tr {
            up(t)
        } else if t < tr + cruise {
            0.5 * f * tr + f * (t - tr)
        } else if t < total {
            length - up(total - t)
        } else {
            length
        }
    };
    (total, s)
}

/// The state of the machine's mechanisms, stepped on the grid.
struct Machine {
    effects: Vec<Effect>,
    /// Commanded positions of the last steps (servo lag reads back into them).
    history: VecDeque<[f64; 3]>,
    /// Where each play holds its axis (the driven element's position), mm.
    play: [f64; 3],
    /// Lateral clearance state per effect, in [−1, 1].
    lateral: Vec<f64>,
    /// Last direction of travel and travel since the last reversal per axis.
    dir: [f64; 3],
    since_rev: [f64; 3],
    last_cmd: [f64; 3],
    /// Geometric errors: coefficients per (moving axis, direction): linear µm/mm and
    /// quadratic µm/mm².
    geom: [[(f64, f64); 3]; 3],
}

impl Machine {
    fn new(effects: &[Effect], q0: [f64; 3], rng: &mut StdRng, geometry: bool) -> Machine {
        let mut play = q0;
        for e in effects {
            if let Effect::Backlash { axis, um } = e {
                play[axis.index()] += rng.random_range(-0.5..0.5) * um * 1e-3;
            }
            if let Effect::GrowingBacklash { axis, from_um, .. }
            | Effect::SwellingBacklash {
                axis,
                ends_um: from_um,
                ..
            } = e
            {
                play[axis.index()] += rng.random_range(-0.5..0.5) * from_um * 1e-3;
            }
        }
        let mut geom = [[(0.0, 0.0); 3]; 3];
        if geometry {
            for (a, row) in geom.iter_mut().enumerate() {
                for (j, g) in row.iter_mut().enumerate() {
                    // Scale ±10 ppm along the axis; squareness ±20 µrad (one per pair);
                    // straightness ±2 µm of bow over ±50 mm.
                    let lin = if a == j {
                        rng.random_range(-10.0..10.0) * 1e-3
                    } else if j < a {
                        rng.random_range(-20.0..20.0) * 1e-3
                    } else {
                        0.0
                    };
                    *g = (lin, rng.random_range(-2.0..2.0) / 2500.0);
                }
            }
        }
        Machine {
            lateral: vec![rng.random_range(-1.0..1.0); effects.len()],
            effects: effects.to_vec(),
            history: VecDeque::from(vec![q0; 64]),
            play,
            dir: [0.0; 3],
            since_rev: [f64::INFINITY; 3],
            last_cmd: q0,
            geom,
        }
    }

    /// One grid step to commanded position `q` at session time `t`: the error vector
    /// along X, Y, Z (µm).
    fn step(&mut self, t: f64, q: [f64; 3]) -> [f64; 3] {
        self.history.pop_front();
        self.history.push_back(q);
        // Travel state of the set-point.
        for i in 0..3 {
            let dq = q[i] - self.last_cmd[i];
            if dq.abs() > 1e-9 {
                let s = dq.signum();
                if s != self.dir[i] {
                    if self.dir[i] != 0.0 {
                        self.since_rev[i] = 0.0;
                    }
                    self.dir[i] = s;
                }
                self.since_rev[i] += dq.abs();
            }
        }
        let dq = [0, 1, 2].map(|i| q[i] - self.last_cmd[i]);
        self.last_cmd = q;
        // The drive's position: the set-point, late by the axis's lag.
        let mut drive = q;
        for e in &self.effects {
            if let Effect::ServoLag { axis, ms } = e.at(t) {
                let i = axis.index();
                let back = ms * 1e-3 / DT;
                let n = self.history.len() - 1;
                let k = back.floor() as usize;
                let f = back - k as f64;
                let a = self.history[n - k][i];
                let b = self.history[n - k - 1][i];
                drive[i] = a + (b - a) * f;
            }
        }
        let mut e = [0.0; 3];
        for i in 0..3 {
            e[i] = (drive[i] - q[i]) * 1e3;
        }
        for (k, eff) in self.effects.iter().enumerate() {
            match eff.at(t) {
                Effect::Backlash { .. }
                | Effect::GrowingBacklash { .. }
                | Effect::SwellingBacklash { .. } => {
                    let (axis, um) = eff.play_width_um(t).expect("a play");
                    let (i, h) = (axis.index(), um * 1e-3 / 2.0);
                    self.play[i] = self.play[i].clamp(drive[i] - h, drive[i] + h);
                    e[i] += (self.play[i] - drive[i]) * 1e3;
                }
                Effect::Vibration {
                    axis,
                    amp_um,
                    hz,
                    phase_rad,
                } => {
                    let w = 2.0 * std::f64::consts::PI * hz;
                    e[axis.index()] += amp_um * (w * t + phase_rad).sin();
                }
                Effect::ServoLag { .. } => {}
                Effect::Cyclic {
                    axis,
                    amp_um,
                    period_mm,
                    phase_rad,
                } => {
                    let x = drive[axis.index()];
                    e[axis.index()] +=
                        amp_um * (2.0 * std::f64::consts::PI * x / period_mm + phase_rad).sin();
                }
                Effect::Thermal {
                    axis,
                    offset_um,
                    scale_ppm,
                    tau_s,
                } => {
                    let g = 1.0 - (-t / tau_s).exp();
                    e[axis.index()] += g * (offset_um + scale_ppm * q[axis.index()] * 1e-3);
                }
                Effect::LateralPlay {
                    axis,
                    moving,
                    shift_um,
                } => {
                    let m = moving.index();
                    self.lateral[k] = (self.lateral[k] + dq[m] / 0.05).clamp(-1.0, 1.0);
                    e[axis.index()] += shift_um / 2.0 * self.lateral[k];
                }
                Effect::ReversalSpike {
                    axis,
                    height_um,
                    decay_mm,
                } => {
                    let i = axis.index();
                    if self.dir[i] != 0.0 && self.since_rev[i].is_finite() {
                        e[i] -= self.dir[i] * height_um * (-self.since_rev[i] / decay_mm).exp();
                    }
                }
                Effect::Knock { .. } | Effect::PlateScale { .. } | Effect::Growing { .. } => {}
            }
        }
        for (a, row) in self.geom.iter().enumerate() {
            let x = q[a];
            for (j, &(lin, quad)) in row.iter().enumerate() {
                e[j] += lin * x + quad * x * x;
            }
        }
        e
    }
}

/// A segment of the programme: path, feed (mm/min), the kind of run it records.
type Segment = (Path, f64, Option<TestKind>);

/// One plane file of the plan.
struct PlaneTest {
    file: &'static str,
    plane: Plane,
    mounting: &'static str,
    park: f64,
}

const PLAN: [PlaneTest; 3] = [
    PlaneTest {
        file: "xy.csv",
        plane: Plane::XY,
        mounting: "xy",
        park: 0.0,
    },
    PlaneTest {
        file: "xz.csv",
        plane: Plane::XZ,
        mounting: "xz",
        park: 0.0,
    },
    PlaneTest {
        file: "yz.csv",
        plane: Plane::YZ,
        mounting: "yz",
        park: 120.0,
    },
];

/// The mounting name of the plate's plane `plane` in the plan.
pub fn mounting_of(plane: Plane) -> &'static str {
    PLAN.iter()
        .find(|t| t.plane == plane)
        .map_or("", |t| t.mounting)
}

/// Head offset of every plane file, mm.
pub const HEAD_OFFSET_MM: [f64; 3] = [0.0, 0.0, -100.0];
const HALF_TRAVEL: f64 = 50.0;
const RADIUS: f64 = 50.0;
const DWELL_S: f64 = 0.5;
const REMOUNT_S: f64 = 240.0;

/// Records a session of `setup`: see the module documentation.
pub fn generate(setup: &Setup) -> Session {
    let mut rng = StdRng::seed_from_u64(setup.seed ^ 0x7a07_5eed);
    let noise = Normal::new(0.0, setup.noise_um).expect("finite noise");
    let home = [0.0, 0.0, 50.0];
    let mut machine = Machine::new(&setup.effects, home, &mut rng, setup.geometry);
    let every = (1000.0 / setup.rate_hz).round() as u64;
    let mut tick: u64 = 0;
    let mut here = home;
    let mut planes = Vec::new();
    for (pi, test) in PLAN.iter().enumerate() {
        let (ua, va) = test.plane.axes();
        let (iu, iv) = (ua.index(), va.index());
        let n = test.plane.normal().index();
        let phi_urad = rng.random_range(-100.0..100.0) * f64::from(u8::from(setup.nuisance));
        let scale_ppm: f64 = setup
            .effects
            .iter()
            .filter_map(|e| match e {
                Effect::PlateScale { plane, ppm } if *plane == test.plane => Some(*ppm),
                _ => None,
            })
            .sum();
        // The programme: (path, feed mm/min, recorded as run kind).
        let mut prog: Vec<Segment> = Vec::new();
        let base = {
            let mut b = [0.0; 3];
            b[n] = test.park;
            b
        };
        let point = |iu_val: f64, iv_val: f64| {
            let mut p = base;
            p[iu] = iu_val;
            p[iv] = iv_val;
            p
        };
        let mut cursor = here;
        let mut go = |prog: &mut Vec<Segment>, to: [f64; 3], rec: Option<(TestKind, f64)>| {
            let path = Path::Line { from: cursor, to };
            match rec {
                Some((k, f)) => prog.push((path, f, Some(k))),
                None => prog.push((path, RAPID_MM_MIN, None)),
            }
            cursor = to;
        };
        for (axis, idx) in [(ua, iu), (va, iv)] {
            let kind = match axis {
                Axis::X => TestKind::LineX,
                Axis::Y => TestKind::LineY,
                Axis::Z => TestKind::LineZ,
            };
            let end = |s: f64| {
                if idx == iu {
                    point(s, 0.0)
                } else {
                    point(0.0, s)
                }
            };
            go(&mut prog, end(-HALF_TRAVEL), None);
            for _ in 0..setup.round_trips {
                go(
                    &mut prog,
                    end(HALF_TRAVEL),
                    Some((kind, setup.line_feed_mm_min)),
                );
                go(
                    &mut prog,
                    end(-HALF_TRAVEL),
                    Some((kind, setup.line_feed_mm_min)),
                );
            }
        }
        go(&mut prog, point(RADIUS, 0.0), None);
        let senses = [(1.0, TestKind::CircleCcw), (-1.0, TestKind::CircleCw)];
        for (sense, kind) in senses.into_iter().filter(|_| setup.circles) {
            let c = point(0.0, 0.0);
            prog.push((
                Path::Circle {
                    c,
                    u: iu,
                    v: iv,
                    r: RADIUS,
                    sense,
                },
                setup.circle_feed_mm_min,
                Some(kind),
            ));
        }
        here = cursor;

        // Execute: every segment on the grid; recorded ones become runs.
        let mut runs: Vec<Run> = Vec::new();
        if pi > 0 {
            let idle = Path::Still(machine.last_cmd);
            run_idle(&mut machine, &mut tick, idle, REMOUNT_S);
        }
        for (path, feed, kind) in prog {
            let record = kind.map(|k| {
                let number = runs.len() as i64 + 1;
                Run {
                    number,
                    test: Some(k),
                    ..Run::default()
                }
            });
            let (dur, s_of) = profile(path.length(), feed / 60.0);
            let mut run = record;
            let on = f64::from(u8::from(setup.nuisance));
            let (ou, ov) = (
                on * rng.random_range(-3.0..3.0),
                on * rng.random_range(-3.0..3.0),
            );
            let pre = if run.is_some() && setup.free_running {
                setup.lead_s
            } else {
                0.0
            };
            let post = if run.is_some() { setup.dwell_s } else { 0.0 };
            let t0 = tick;
            let number = run.as_ref().map_or(0, |r| r.number);
            let run_knocks = knocks(&setup.effects, pi, number);
            let steps = ((pre + dur + post) / DT).ceil() as u64;
            for k in 0..=steps {
                let tl = k as f64 * DT - pre;
                let q = path.at(s_of(tl));
                let t = tick as f64 * DT;
                let mut e = machine.step(t, q);
                // A knock of this run, from `at` of its motion on.
                for &(axis, size, decay, ring, at) in &run_knocks {
                    let tk = (t0 as f64 + (pre + at * dur) / DT) * DT;
                    if t >= tk {
                        let ph = 2.0 * std::f64::consts::PI * ring * (t - tk);
                        e[axis.index()] += size * (-(t - tk) / decay).exp() * ph.cos();
                    }
                }
                if let Some(r) = run.as_mut() {
                    let clock = if setup.free_running { tick } else { tick - t0 };
                    if clock % every == 0 {
                        let hu = q[iu] + HEAD_OFFSET_MM[iu];
                        let hv = q[iv] + HEAD_OFFSET_MM[iv];
                        let du = e[iu] + phi_urad * hv * 1e-3 + scale_ppm * hu * 1e-3;
                        let dv = e[iv] - phi_urad * hu * 1e-3 + scale_ppm * hv * 1e-3;
                        r.t_s.push(t);
                        r.pos_mm.push(q);
                        r.du_um.push(du + ou + noise.sample(&mut rng));
                        r.dv_um.push(dv + ov + noise.sample(&mut rng));
                    }
                }
                tick += 1;
            }
            if let Some(r) = run {
                runs.push(r);
                run_idle(&mut machine, &mut tick, path_end(&path), setup.pause_s);
            }
        }
        planes.push(PlaneRecord {
            file: test.file.to_string(),
            plane: test.plane,
            head_offset_mm: HEAD_OFFSET_MM,
            mounting: test.mounting.to_string(),
            runs,
        });
    }
    Session {
        machine_id: "truth".into(),
        measured_at: "2026-12-01T08:00:00Z".into(),
        topology: Some(Topology::default()),
        notes: None,
        conditions: Default::default(),
        planes,
    }
}

/// The knocks of run `number` (1-based; 0: an unrecorded move) of plane file `pi`:
/// (axis, size µm, decay s, ringing Hz, fraction of the motion at which it happens).
fn knocks(effects: &[Effect], pi: usize, number: i64) -> Vec<(Axis, f64, f64, f64, f64)> {
    effects
        .iter()
        .filter_map(|e| match *e {
            Effect::Knock {
                axis,
                size_um,
                decay_s,
                ring_hz,
                plane,
                run,
                at,
            } if plane == pi && run == number && number > 0 => {
                Some((axis, size_um, decay_s, ring_hz, at))
            }
            _ => None,
        })
        .collect()
}

fn path_end(p: &Path) -> Path {
    Path::Still(p.at(p.length()))
}

/// Standstill at `p` for `secs` (the mechanisms keep their state).
fn run_idle(m: &mut Machine, tick: &mut u64, p: Path, secs: f64) {
    let q = p.at(0.0);
    for _ in 0..(secs / DT) as u64 {
        m.step(*tick as f64 * DT, q);
        *tick += 1;
    }
}
