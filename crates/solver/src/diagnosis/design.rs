//! The rigid-body (21-term) model of a session as a design matrix for diagnosis, with the
//! samples' fields that effect columns and the residual split need.
//!
//! Rows: two per sample (du, dv). Columns: the error parameters of identification's
//! [`ErrorModel`] (Legendre basis on the measured travel, order N, straightness from 2,
//! then the three squareness constants: `ErrorModel::error_row`); one plate rotation per
//! mounting (du: +v·10⁻³, dv: −u·10⁻³ per µrad). The per-run zero offsets
//! are eliminated exactly by centring every column and the data within each (run,
//! component) — the Frisch–Waugh form of estimating them jointly.

use super::temperature::{LagInput, Smoother};
use crate::axis::{Axis, Plane, Topology};
use crate::basis::BasisKind;
use crate::design::ErrorModel;
use crate::error::SolverError;
use crate::session::{Session, TestKind};
use crate::simulate::motion::DriveState;
use crate::simulate::truth::measured_travel;

/// The samples of a session, one array per field and axis, indexed by sample: a pass
/// over the rows that reads one field streams 8 bytes per sample (the candidates'
/// columns and the frequency scans read them row by row, once per candidate). The
/// samples are held here only; what is constant over a run (its plane, test kind and
/// head offset) is in its [`RunInfo`].
#[derive(Debug, Clone, Default)]
pub struct SampleFields {
    /// Global run index (over all files) of every sample.
    pub run_idx: Vec<u32>,
    pub t_s: Vec<f64>,
    /// Commanded position per axis (mm).
    pub q_mm: [Vec<f64>; 3],
    /// Commanded velocity per axis from the set-points ([`velocity`], mm/s).
    pub vel_mm_s: [Vec<f64>; 3],
    /// Per axis, at a sample where [`velocity`] took a one-sided difference for a start
    /// or a stop of the motion, that velocity less the central difference (mm/s); 0
    /// elsewhere. The set-points do not tell which one the axis followed there
    /// ([`velocity_at_ends`]).
    pub vel_ends_mm_s: [Vec<f64>; 3],
    /// Commanded acceleration per axis from the set-points where they tell the velocity
    /// ([`acceleration`], mm/s²); 0 elsewhere.
    pub acc_mm_s2: [Vec<f64>; 3],
    /// Sign of each axis's last travel (before its first recorded move in a file: the
    /// opposite of that move, an approach from the other side; 0 for an axis that does
    /// not move in the file).
    pub dir: [Vec<f64>; 3],
    /// Travel since the last reversal of each axis (mm; infinite before one).
    pub since_reversal_mm: [Vec<f64>; 3],
    /// What a play of each axis follows: the travel since the axis last turned (mm,
    /// infinite before a turn), signed by the direction of that travel. A turn between
    /// two samples of a smooth motion (a circle's quadrant) is at the vertex of the
    /// parabola through the samples around it ([`turn_beyond`]), and a sample already
    /// past it travels the new way; elsewhere the same as `dir`·`since_reversal_mm`.
    pub play_travel_mm: [Vec<f64>; 3],
    /// The logged temperature, smoothed ([`super::temperature::Smoother`]), minus its
    /// smoothed value at the session's first sample (K), when every run logs `temp_c`.
    pub temp_k: Option<Vec<f64>>,
}

impl SampleFields {
    fn with_capacity(n: usize, temperature: bool) -> SampleFields {
        let axes = || std::array::from_fn(|_| Vec::with_capacity(n));
        SampleFields {
            run_idx: Vec::with_capacity(n),
            t_s: Vec::with_capacity(n),
            q_mm: axes(),
            vel_mm_s: axes(),
            vel_ends_mm_s: axes(),
            acc_mm_s2: axes(),
            dir: axes(),
            since_reversal_mm: axes(),
            play_travel_mm: axes(),
            temp_k: temperature.then(|| Vec::with_capacity(n)),
        }
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t_s.len()
    }

    pub fn is_empty(&self) -> bool {
        self.t_s.is_empty()
    }

    /// The commanded position of sample `s` (mm).
    #[inline]
    pub fn q(&self, s: usize) -> [f64; 3] {
        [self.q_mm[0][s], self.q_mm[1][s], self.q_mm[2][s]]
    }

    /// The run of sample `s`.
    #[inline]
    pub fn run(&self, s: usize) -> usize {
        self.run_idx[s] as usize
    }
}

/// One run's place in the session.
#[derive(Debug, Clone)]
pub struct RunInfo {
    pub plane_idx: usize,
    pub number: i64,
    pub test: TestKind,
    /// Sample range [start, end).
    pub start: usize,
    pub end: usize,
    /// Index of the run among the runs of its file with the same test kind.
    pub repeat: usize,
    /// Per axis: whether it keeps one position over the whole run (is parked).
    pub parked: [bool; 3],
    /// Declared head offset of the run's file (mm).
    pub head_mm: [f64; 3],
}

/// The session as rows and the rigid model's centred columns.
pub struct Design {
    pub runs: Vec<RunInfo>,
    /// Reading axes (u, v) of each plane file.
    pub plane_axes: Vec<(Axis, Axis)>,
    pub files: Vec<String>,
    pub planes: Vec<Plane>,
    /// Centred observations, row 2s + c.
    pub y: Vec<f64>,
    pub travel: [Option<[f64; 2]>; 3],
    pub topology: Topology,
    /// The rigid model (identification's [`ErrorModel`], Legendre basis): its parameters
    /// are the first rigid columns, in its order; one plate rotation per mounting follows
    /// (the columns themselves are only formed reduced, run by run, by the diagnosis's
    /// per-run reduction).
    pub model: ErrorModel,
    /// The samples, one array per field.
    pub fields: SampleFields,
    /// The reading axis of every row.
    pub row_axes: Vec<Axis>,
    /// The catalogue's time band of the session (duration, Nyquist frequency, longest
    /// run), formed on first use.
    pub time_band: std::sync::OnceLock<(f64, f64, f64)>,
    /// The smoother of the logged temperature, when every run logs `temp_c`.
    pub temperature: Option<Smoother>,
    /// The input of the smoothed temperature's lag at every sample, formed on first use
    /// ([`Design::lagged_temperature`]).
    pub lag_input: std::sync::OnceLock<Option<LagInput>>,
    /// Samples of the session left out ([`build_leaving_out`]).
    pub left_out: usize,
    /// The plate's mounting of each plane file (the session's `mounting`: files sharing
    /// it share the plate's rotation and scale).
    pub mountings: Vec<String>,
    /// The plate's thermal expansion coefficient the session states (its instrument's
    /// `expansion_ppm_per_k`), µm/(m·K).
    pub plate_expansion_ppm_per_k: Option<f64>,
}

impl Design {
    /// The smoothed temperature change through a first-order lag of time constant `tau`
    /// (s) at every sample ([`Smoother::lagged`]); `None` without a logged temperature.
    pub fn lagged_temperature(&self, tau: f64) -> Option<Vec<f64>> {
        let input = self.lag_input.get_or_init(|| {
            self.temperature
                .as_ref()
                .map(|sm| sm.lag_input(&self.fields.t_s))
        });
        input.as_ref().map(|i| i.lagged(tau))
    }

    pub fn rows(&self) -> usize {
        self.y.len()
    }

    /// The reading axis of row `r`.
    #[inline]
    pub fn row_axis(&self, r: usize) -> Axis {
        self.row_axes[r]
    }

    /// Centres `c` per (run, component) and returns the largest |value| before centring
    /// over the (run, component) groups where the column varies: where it is constant the
    /// run's zero offset absorbs it, and its value there (e.g. a function evaluated at a
    /// parked position outside the travel) says nothing of the effect's size.
    pub fn centre_with_peak(&self, c: &mut [f64]) -> f64 {
        let mut peak = 0.0f64;
        for run in &self.runs {
            for comp in 0..2 {
                let rows = (run.start..run.end).map(|s| 2 * s + comp);
                let n = (run.end - run.start) as f64;
                let m: f64 = rows.clone().map(|r| c[r]).sum::<f64>() / n;
                let raw = rows.clone().fold(0.0f64, |a, r| a.max(c[r].abs()));
                let dev = rows.clone().fold(0.0f64, |a, r| a.max((c[r] - m).abs()));
                if dev > 1e-9 * raw.max(1e-300) {
                    peak = peak.max(raw);
                }
                for r in rows {
                    c[r] -= m;
                }
            }
        }
        peak
    }

    /// The run inside which time `t` falls (after its first sample, at or before its
    /// last), if any.
    pub fn run_at_time(&self, t: f64) -> Option<usize> {
        let ts = &self.fields.t_s;
        let g = self.runs.partition_point(|r| ts[r.start] < t);
        let g = g.checked_sub(1)?;
        (t <= ts[self.runs[g].end - 1]).then_some(g)
    }

    /// Removes the mean of each (run, component).
    pub fn centre(&self, c: &mut [f64]) {
        self.centre_with_peak(c);
    }

    /// Rows of the runs for which `keep(run)` holds.
    pub fn rows_of(&self, keep: impl Fn(&RunInfo) -> bool) -> Vec<usize> {
        self.runs
            .iter()
            .filter(|r| keep(r))
            .flat_map(|r| 2 * r.start..2 * r.end)
            .collect()
    }
}

/// The sign of each axis's first move along the positions `q` (0: it never moves).
fn first_moves<'a>(q: impl Iterator<Item = &'a [f64; 3]>) -> [f64; 3] {
    let mut first = [0.0; 3];
    let mut last: Option<[f64; 3]> = None;
    for q in q {
        if let Some(l) = last {
            for a in 0..3 {
                let dq = q[a] - l[a];
                if first[a] == 0.0 && dq.abs() > 1e-12 {
                    first[a] = dq.signum();
                }
            }
            if first.iter().all(|&f| f != 0.0) {
                break;
            }
        }
        last = Some(*q);
    }
    first
}

fn infer_test(pos: &[[f64; 3]]) -> TestKind {
    let range = |i: usize| {
        let (lo, hi) = pos
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), q| {
                (l.min(q[i]), h.max(q[i]))
            });
        hi - lo
    };
    let moving: Vec<usize> = (0..3).filter(|&i| range(i) > 1e-6).collect();
    match moving.as_slice() {
        [0] => TestKind::LineX,
        [1] => TestKind::LineY,
        [2] => TestKind::LineZ,
        _ => TestKind::Free,
    }
}

/// Commanded velocity at sample i (mm/s) from the set-points alone: 0 when the axis is
/// at rest on either side (dwell, start from rest); the forward difference at the first
/// sample after a start (the axis at rest before the previous sample, or the previous
/// sample the run's first, from rest: the step into
/// this sample began between samples and is shorter than the feed's), the backward one
/// at the last sample before a stop (at rest after the next sample); the central
/// difference where both one-sided differences agree within 10 % (cruise, circles:
/// O(dt²)) or change steadily (the change across the sample within half of it of the
/// changes one sample before and after: a steady acceleration, as around a circle's
/// reversal of the axis); otherwise the larger one-sided difference (the sample just inside a start or
/// stop of the motion, where the profile's ramp is shorter than the sample interval).
/// On a line the first rule matters: the central difference there is off the feed by
/// half the partial step (a 3 ms servo lag of 8 mm/s read 1 µm off at every start).
pub fn velocity(t: &[f64], q: &[[f64; 3]], i: usize) -> [f64; 3] {
    velocity_at_ends(t, q, i).0
}

/// [`velocity`] at sample i and, per axis, where it took a one-sided difference for a
/// start or a stop (or the larger one where the differences disagree), that velocity
/// less the central difference, 0 elsewhere. At those samples the path between the
/// set-points is not told by them: an axis that stops abruptly still moves at the feed
/// at its last moving sample (the one-sided difference), a smooth path through the
/// set-points (an interpolator's spline) moves at about the central difference there
/// (about half the feed at a stop between two samples).
pub fn velocity_at_ends(t: &[f64], q: &[[f64; 3]], i: usize) -> ([f64; 3], [f64; 3]) {
    let st = velocity_state(t, q, i);
    (st.map(|x| x.0), st.map(|x| x.1))
}

/// Commanded acceleration at sample i (mm/s²) from the set-points, where they tell the
/// velocity ([`velocity_known`]; 0 elsewhere): on a smooth or steady path sampled evenly
/// the five-point second difference (error (ω·dt)⁴/90 of a circle's), otherwise the
/// change of the one-sided differences over the half-interval; 0 at rest on either side.
/// A servo lag's second-order term reads it (`catalogue`, `servo_lag`).
pub fn acceleration(t: &[f64], q: &[[f64; 3]], i: usize) -> [f64; 3] {
    velocity_state(t, q, i).map(|x| x.3)
}

/// Largest relative difference of the one-sided differences at a sample where the
/// set-points tell the velocity (off a smooth path): a cruise's agree to rounding, and a
/// start or stop of 33 ms between samples 62.5 ms apart changes the next one by 6 %, which
/// read a 3 ms lag 0.8 µm off at the sample before.
const STEADY: f64 = 0.01;

/// Per axis at sample i: [`velocity`], what [`velocity_at_ends`] gives beside it,
/// whether the set-points tell the velocity there ([`velocity_known`]) and
/// [`acceleration`].
fn velocity_state(t: &[f64], q: &[[f64; 3]], i: usize) -> [(f64, f64, bool, f64); 3] {
    let n = q.len();
    let rest = |k: usize, a: usize, b: usize| (q[b][k] - q[a][k]).abs() < 1e-9;
    let diff = |k: usize, a: usize| (q[a + 1][k] - q[a][k]) / (t[a + 1] - t[a]);
    // A smooth path: the change of the one-sided differences across the sample is within
    // half of it of the changes one sample before and after (a steady acceleration, as
    // around a circle's reversal of the axis, where the differences differ by more than
    // 10 % for about ten samples and the larger one read the lag 2.5 % low), not the
    // acceleration spike of a start or a stop.
    let smooth = |k: usize| {
        i >= 2
            && i + 2 < n
            && smooth_steps([diff(k, i - 2), diff(k, i - 1), diff(k, i), diff(k, i + 1)])
    };
    // On a smooth or steady path sampled evenly, the five-point difference: the central one reads
    // a circle's velocity low by (ω·dt)²/6 (0.07 % at 2000 mm/min on R50 at 10 Hz, which
    // moved a lag by more than its σ), this one by (ω·dt)⁴/30; and the five-point second
    // difference for the acceleration.
    let smooth_velocity = |k: usize| {
        let dt = t.get(i + 2)? - t.get(i + 1)?;
        let even = i >= 2
            && [t[i + 1] - t[i], t[i] - t[i - 1], t[i - 1] - t[i - 2]]
                .iter()
                .all(|h| (h - dt).abs() <= 1e-9 * dt.abs());
        // Smooth, or steady over the four steps (a cruise, or a circle near the axis's
        // fastest, where `smooth` does not hold): no start or stop among them.
        let steady =
            || steady_steps([diff(k, i - 2), diff(k, i - 1), diff(k, i), diff(k, i + 1)]).1;
        (even && (smooth(k) || steady())).then(|| {
            let (p1, m1, p2, m2) = (q[i + 1][k], q[i - 1][k], q[i + 2][k], q[i - 2][k]);
            (
                (8.0 * (p1 - m1) - (p2 - m2)) / (12.0 * dt),
                (16.0 * (p1 + m1) - (p2 + m2) - 30.0 * q[i][k]) / (12.0 * dt * dt),
            )
        })
    };
    [0, 1, 2].map(|k| {
        let back = (i > 0).then(|| (q[i][k] - q[i - 1][k]) / (t[i] - t[i - 1]));
        let fwd = (i + 1 < n).then(|| (q[i + 1][k] - q[i][k]) / (t[i + 1] - t[i]));
        match (back, fwd) {
            (Some(b), Some(f)) => {
                let started = i == 1 || (i >= 2 && rest(k, i - 2, i - 1));
                let stopping = i + 2 < n && rest(k, i + 1, i + 2);
                let central = (q[i + 1][k] - q[i - 1][k]) / (t[i + 1] - t[i - 1]);
                let v = if b.abs() < 1e-9 || f.abs() < 1e-9 {
                    return (0.0, 0.0, true, 0.0);
                } else if started && !stopping {
                    f
                } else if stopping && !started {
                    b
                } else if (b - f).abs() <= 0.1 * b.abs().max(f.abs()) || smooth(k) {
                    // Known where the motion is steady or smooth; a difference beyond
                    // `STEADY` and not smooth is a start or a stop between the samples
                    // around it (one that begins just after it: the axis still at the
                    // feed there, not at the central difference).
                    let known = (b - f).abs() <= STEADY * b.abs().max(f.abs()) || smooth(k);
                    let (v, acc) = smooth_velocity(k)
                        .or_else(|| known.then(|| one_sided(t, q, i, k)).flatten())
                        .unwrap_or((0.5 * (b + f), 2.0 * (f - b) / (t[i + 1] - t[i - 1])));
                    return (v, 0.0, known, if known { acc } else { 0.0 });
                } else if b.abs() > f.abs() {
                    b
                } else {
                    f
                };
                (v, v - central, false, 0.0)
            }
            (None, Some(f)) if f.abs() < 1e-9 => (0.0, 0.0, true, 0.0),
            // First sample of a run, already moving: lines and circles start from rest,
            // but where in its start the axis is the set-points do not tell.
            (None, Some(_)) => (0.0, 0.0, false, 0.0),
            (Some(b), None) => (b, 0.0, b.abs() < 1e-9, 0.0),
            _ => (0.0, 0.0, true, 0.0),
        }
    })
}

/// Of four successive differences of an axis's set-points (evenly spaced): whether they
/// go one way, and whether they are steady (one way and within [`STEADY`] of each other:
/// a cruise, or a circle near the axis's fastest; no start or stop among them).
fn steady_steps(d: [f64; 4]) -> (bool, bool) {
    let (lo, hi) = d
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| {
            (l.min(x), h.max(x))
        });
    let one_way = lo * hi > 0.0;
    (
        one_way,
        one_way && hi - lo <= STEADY * lo.abs().max(hi.abs()),
    )
}

/// Of four successive differences (evenly spaced): whether the change across the middle
/// is within half of it of the changes before and after (a steady acceleration, as around
/// a circle's reversal of the axis), not the acceleration spike of a start or a stop.
fn smooth_steps(d: [f64; 4]) -> bool {
    let (before, at, after) = (d[1] - d[0], d[2] - d[1], d[3] - d[2]);
    (before - at).abs() <= 0.5 * at.abs() && (after - at).abs() <= 0.5 * at.abs()
}

/// Velocity and acceleration of axis `k` at a sample i where the set-points tell the
/// velocity but the five-point stencil around it reaches into a start or a stop (a ramp
/// longer than a sample interval, as a fast circle's, whose end bends the difference
/// before the sample by under [`STEADY`] yet read a 4 ms lag 0.8 µm off): from the four
/// evenly spaced samples on the side whose next four differences move one way and
/// change steadily (all within `STEADY`, or each change within half of the middle one
/// of the changes beside it, as [`velocity`]'s smooth path), forward first; error O(dt³)
/// of the velocity, O(dt²) of the acceleration. `None` when neither side is.
fn one_sided(t: &[f64], q: &[[f64; 3]], i: usize, k: usize) -> Option<(f64, f64)> {
    let side = |sgn: isize| {
        let at = |j: isize| i.checked_add_signed(sgn * j).filter(|&x| x < q.len());
        let idx = [at(0)?, at(1)?, at(2)?, at(3)?, at(4)?];
        let h = (t[idx[1]] - t[idx[0]]) * sgn as f64;
        let even = idx
            .windows(2)
            .all(|w| ((t[w[1]] - t[w[0]]) * sgn as f64 - h).abs() <= 1e-9 * h.abs());
        let x = idx.map(|j| q[j][k]);
        let d = [x[1] - x[0], x[2] - x[1], x[3] - x[2], x[4] - x[3]];
        let (one_way, steady) = steady_steps(d);
        (h > 0.0 && even && (steady || (one_way && smooth_steps(d)))).then(|| {
            let v = (-11.0 * x[0] + 18.0 * x[1] - 9.0 * x[2] + 2.0 * x[3]) / (6.0 * h);
            let a = (2.0 * x[0] - 5.0 * x[1] + 4.0 * x[2] - x[3]) / (h * h);
            (v * sgn as f64, a)
        })
    };
    side(1).or_else(|| side(-1))
}

/// Per axis, whether the set-points tell the velocity at sample i: at rest on one side
/// of it (0), or moving alike on both sides (the central difference of a cruise, or a
/// smooth path as a circle's). Not at a sample inside a start or a stop of the motion,
/// where [`velocity`] takes a one-sided difference: the axis there may be anywhere in
/// its acceleration ramp between the samples around it (at 10 Hz a start of 33 ms at
/// 500 mm/min falls before the first moving sample or after it by the clock's luck), nor
/// at a run's first or last sample while it moves.
pub fn velocity_known(t: &[f64], q: &[[f64; 3]], i: usize) -> [bool; 3] {
    velocity_state(t, q, i).map(|x| x.2)
}

/// At sample `i`, the first after a reversal of axis `a` within a smooth motion (the axis
/// moving on both sides of sample i − 1, as around a circle): the turn is the vertex of
/// the parabola through samples i − 2, i − 1, i, when it lies between them. Returns how
/// far from sample i − 1 the axis turned (mm) and whether sample i − 1 is already past
/// the turn (a set-point that still moves the old way from i − 2 to i − 1 can be). (0,
/// false) where the axis stopped to reverse (a line's end, at rest) or the samples do not
/// bracket a turn: the reversal is then at the sample.
fn turn_beyond(t: &[f64], q: &[[f64; 3]], i: usize, a: usize) -> (f64, bool) {
    if i < 2 {
        return (0.0, false);
    }
    let (t0, t1, t2) = (t[i - 2], t[i - 1], t[i]);
    let (x0, x1, x2) = (q[i - 2][a], q[i - 1][a], q[i][a]);
    if (x1 - x0) * (x2 - x1) >= 0.0 || t1 <= t0 || t2 <= t1 {
        return (0.0, false);
    }
    let (f01, f12) = ((x1 - x0) / (t1 - t0), (x2 - x1) / (t2 - t1));
    let f012 = (f12 - f01) / (t2 - t0);
    let ts = 0.5 * (t0 + t1) - f01 / (2.0 * f012);
    if !(t0..=t2).contains(&ts) {
        return (0.0, false);
    }
    let top = x0 + f01 * (ts - t0) + f012 * (ts - t0) * (ts - t1);
    ((top - x1).abs(), ts < t1)
}

/// Whether a run's first sample `q` may read the play on the other side than the approach
/// gives it (left out: on a file's first run, or when the set-points are already at
/// speed there, [`at_speed`]): an axis that an unrecorded approach
/// brought to it (`approach`: the approach to a file's first sample, or a move from where
/// the last run ended) moves on from it (to `next`) against `dir`, the way the approach
/// is taken to have reached it. The axis turned then somewhere between the last recorded
/// sample and the next one, and where is not recorded: at the sample after a standstill,
/// or before it when the recorder started with the motion (a circle begun at its reversal
/// of the axis, a file's first run already moving), where the sample reads the play on
/// its new side, not the approach's. An axis that rested at the sample since the last
/// run ended turns there.
fn turns_at_start(dir: [f64; 3], approach: [bool; 3], q: [f64; 3], next: [f64; 3]) -> bool {
    (0..3).any(|a| {
        let step = next[a] - q[a];
        approach[a] && step.abs() > 1e-12 && dir[a] != 0.0 && step.signum() != dir[a]
    })
}

/// Whether the set-points are already at speed at a run's first sample `q`: an axis's
/// first step (to `next`) and its second (to `then`) agree within [`STEADY`], where a
/// start from rest at the sample makes the first short by half its ramp's time (a third
/// of a 10 Hz step at 500 mm/min, 400 mm/s²).
fn at_speed(q: [f64; 3], next: [f64; 3], then: [f64; 3]) -> bool {
    (0..3).any(|a| {
        let (s1, s2) = ((next[a] - q[a]).abs(), (then[a] - next[a]).abs());
        s2 > 1e-12 && (s1 - s2).abs() <= STEADY * s2
    })
}

/// Builds the design of `session` with error functions of polynomial order `order`.
pub fn build(session: &Session, topology: &Topology, order: usize) -> Result<Design, SolverError> {
    build_leaving_out(session, topology, order, [false; 3])
}

/// [`build`] with every sample of the session, a run's first sample of unknown approach
/// too ([`turns_at_start`]): rows 2s, 2s + 1 for the session's sample s in file and run
/// order (the explained model's columns follow the session's samples).
pub fn build_every_sample(
    session: &Session,
    topology: &Topology,
    order: usize,
) -> Result<Design, SolverError> {
    build_with(session, topology, order, [false; 3], true)
}

/// The travel state through a plane file, the approach moves between runs included.
struct FileWalk {
    state: DriveState,
    /// Per axis, how far beyond the last sample before its last reversal the axis
    /// turned (mm).
    beyond: [f64; 3],
    /// Whether a run of the file has been walked.
    started: bool,
    /// Keep a run's first sample of unknown approach ([`turns_at_start`]).
    keep_starts: bool,
}

impl FileWalk {
    /// Pushes the samples of `run` (global index, reading axes, the session's first
    /// temperature) onto the fields and the rows, but those where the velocity of an axis
    /// of `leave_out` is not known ([`velocity_known`]; all of them when fewer than half
    /// of the run's samples, or fewer than 3, would be left): how many it left out.
    fn push_run(
        &mut self,
        run: &crate::session::Run,
        (run_idx, (u, v), temp0): (u32, (Axis, Axis), Option<f64>),
        f: &mut SampleFields,
        (y, row_axes): (&mut Vec<f64>, &mut Vec<Axis>),
        leave_out: [bool; 3],
    ) -> usize {
        // Each sample's motion, formed once for what is left out and what is kept.
        let motion: Vec<_> = (0..run.len())
            .map(|i| velocity_state(&run.t_s, &run.pos_mm, i))
            .collect();
        // Whether the velocity of an axis left out is not known there ([`velocity_known`]).
        let unknown = |m: &[(f64, f64, bool, f64); 3]| (0..3).any(|a| leave_out[a] && !m[a].2);
        let mut skip: Vec<bool> = motion.iter().map(unknown).collect();
        let kept = skip.iter().filter(|&&s| !s).count();
        if kept < 3 || 2 * kept < run.len() {
            skip.iter_mut().for_each(|s| *s = false);
        }
        let left_out = skip.iter().filter(|&&s| s).count();
        let mut last_kept = false;
        for i in 0..run.len() {
            let q = run.pos_mm[i];
            let st = &mut self.state;
            let (before, from) = (st.dir, st.q_mm);
            st.move_to(q);
            if i == 0 && run.len() > 3 && !self.keep_starts {
                // Not counted with the velocity's.
                let approach = [0, 1, 2].map(|a| !self.started || q[a] != from[a]);
                let p = &run.pos_mm;
                skip[0] = skip[0]
                    || (turns_at_start(st.dir, approach, q, p[1])
                        && (!self.started || at_speed(q, p[1], p[2])));
                self.started = true;
            }
            for a in 0..3 {
                if st.dir[a] != before[a] && before[a] != 0.0 {
                    let (b, past) = turn_beyond(&run.t_s, &run.pos_mm, i, a);
                    self.beyond[a] = b;
                    if past && last_kept {
                        // The sample before, already past the turn.
                        let k = f.len() - 1;
                        f.play_travel_mm[a][k] = st.dir[a] * b;
                    }
                }
            }
            last_kept = !skip[i];
            if skip[i] {
                continue;
            }
            let motion = &motion[i];
            f.run_idx.push(run_idx);
            f.t_s.push(run.t_s[i]);
            for a in 0..3 {
                f.q_mm[a].push(q[a]);
                f.vel_mm_s[a].push(motion[a].0);
                f.vel_ends_mm_s[a].push(motion[a].1);
                f.acc_mm_s2[a].push(motion[a].3);
                f.dir[a].push(st.dir[a]);
                f.since_reversal_mm[a].push(st.since_reversal_mm[a]);
                f.play_travel_mm[a].push(if st.dir[a] == 0.0 {
                    0.0
                } else {
                    st.dir[a] * (st.since_reversal_mm[a] + self.beyond[a])
                });
            }
            if let (Some(t), Some(t0), Some(temp)) = (f.temp_k.as_mut(), temp0, run.temp_c.as_ref())
            {
                t.push(temp[i] - t0);
            }
            y.push(run.du_um[i]);
            y.push(run.dv_um[i]);
            row_axes.push(u);
            row_axes.push(v);
        }
        left_out
    }
}

/// [`build`], leaving out the samples where the set-points do not tell the velocity of
/// an axis of `leave_out` ([`velocity_known`]): inside the starts and stops of the
/// motion, where an effect of the axis's velocity (a servo lag) is not known. Their
/// count is [`Design::left_out`].
pub fn build_leaving_out(
    session: &Session,
    topology: &Topology,
    order: usize,
    leave_out: [bool; 3],
) -> Result<Design, SolverError> {
    build_with(session, topology, order, leave_out, false)
}

fn build_with(
    session: &Session,
    topology: &Topology,
    order: usize,
    leave_out: [bool; 3],
    keep_starts: bool,
) -> Result<Design, SolverError> {
    topology.validate().map_err(SolverError::InvalidInput)?;
    let travel = measured_travel(session);
    let n = session.sample_count();
    let mut runs = Vec::new();
    let mut plane_axes = Vec::new();
    let mut y = Vec::with_capacity(2 * n);
    let mut row_axes = Vec::with_capacity(2 * n);
    let all_runs = || session.planes.iter().flat_map(|p| &p.runs);
    let temp0 = all_runs()
        .all(|r| r.temp_c.as_ref().is_some_and(|t| t.len() == r.len()))
        .then(|| all_runs().find_map(|r| r.temp_c.as_ref()?.first().copied()))
        .flatten();
    let mut f = SampleFields::with_capacity(n, temp0.is_some());
    let mut left_out = 0;
    for (pi, p) in session.planes.iter().enumerate() {
        let (u, v) = p.plane.axes();
        plane_axes.push((u, v));
        // Travel state through the file, approach moves between runs included. The
        // approach to the file's first sample is not recorded: each axis is taken to
        // have reached it travelling against its first recorded move (an approach from
        // the other side, a reversal at its first move), as a test plan approaches its
        // start from the centre of the travel; a run's first sample from which an axis
        // moves on against the way it reached the sample is left out ([`turns_at_start`]).
        let mut walk = FileWalk {
            state: DriveState {
                q_mm: p
                    .runs
                    .first()
                    .and_then(|r| r.pos_mm.first())
                    .copied()
                    .unwrap_or_default(),
                dir: first_moves(p.runs.iter().flat_map(|r| &r.pos_mm)).map(|s| -s),
                since_reversal_mm: [f64::INFINITY; 3],
            },
            beyond: [0.0; 3],
            started: false,
            keep_starts,
        };
        let mut counts: std::collections::HashMap<TestKind, usize> = Default::default();
        for run in &p.runs {
            if run.len() < 3 {
                return Err(SolverError::InvalidInput(format!(
                    "{} run {}: diagnosis needs at least 3 samples per run",
                    p.file, run.number
                )));
            }
            let test = run.test.unwrap_or_else(|| infer_test(&run.pos_mm));
            let rep = counts.entry(test).or_insert(0);
            let start = f.len();
            let run_idx = u32::try_from(runs.len())
                .map_err(|_| SolverError::InvalidInput("diagnosis: more than 2^32 runs".into()))?;
            left_out += walk.push_run(
                run,
                (run_idx, (u, v), temp0),
                &mut f,
                (&mut y, &mut row_axes),
                leave_out,
            );
            runs.push(RunInfo {
                plane_idx: pi,
                number: run.number,
                test,
                start,
                end: f.len(),
                repeat: *rep,
                parked: std::array::from_fn(|k| {
                    run.pos_mm.iter().all(|q| q[k] == run.pos_mm[0][k])
                }),
                head_mm: p.head_offset_mm,
            });
            *rep += 1;
        }
    }
    if f.is_empty() {
        return Err(SolverError::InvalidInput(
            "the session has no samples".into(),
        ));
    }
    // The logged temperature is a noisy measurement: the columns follow its smoother.
    let temperature = f.temp_k.as_mut().map(|temp| {
        let ranges: Vec<_> = runs.iter().map(|r| r.start..r.end).collect();
        let sm = Smoother::fit(&f.t_s, temp, &ranges);
        *temp = sm.deltas(&f.t_s);
        sm
    });
    let mut d = Design {
        fields: f,
        row_axes,
        runs,
        plane_axes,
        files: session.planes.iter().map(|p| p.file.clone()).collect(),
        planes: session.planes.iter().map(|p| p.plane).collect(),
        y,
        travel,
        topology: topology.clone(),
        model: ErrorModel::new(
            topology.clone(),
            BasisKind::Legendre,
            order,
            travel.map(|t| t.map(|[lo, hi]| (lo, hi))),
        ),
        time_band: std::sync::OnceLock::new(),
        temperature,
        lag_input: std::sync::OnceLock::new(),
        left_out,
        mountings: session.planes.iter().map(|p| p.mounting.clone()).collect(),
        plate_expansion_ppm_per_k: session
            .conditions
            .instrument
            .as_ref()
            .and_then(|i| i.expansion_ppm_per_k),
    };
    let mut y = std::mem::take(&mut d.y);
    d.centre(&mut y);
    d.y = y;
    Ok(d)
}
