//! Commanded motion of the simulator: trapezoidal feed profiles along lines and circles,
//! sampled at a fixed rate, with the per-axis travel state (direction, distance since the
//! last reversal) that drive-related effects need.

use crate::axis::Axis;

/// Trapezoidal feed profile over a path of length L: constant acceleration a up to the
/// feed v, cruise, constant deceleration. If L < v²/a the profile is triangular with peak
/// speed √(L·a).
#[derive(Debug, Clone, Copy)]
pub struct Profile {
    pub length_mm: f64,
    pub accel_mm_s2: f64,
    /// Peak speed reached (mm/s).
    pub peak_mm_s: f64,
    /// Duration of the acceleration ramp (s).
    pub t_ramp_s: f64,
    /// Duration of the cruise (s).
    pub t_cruise_s: f64,
}

impl Profile {
    pub fn new(length_mm: f64, feed_mm_s: f64, accel_mm_s2: f64) -> Profile {
        let peak = feed_mm_s.min((length_mm * accel_mm_s2).sqrt());
        let t_ramp = peak / accel_mm_s2;
        let d_ramp = 0.5 * peak * t_ramp;
        let t_cruise = ((length_mm - 2.0 * d_ramp) / peak).max(0.0);
        Profile {
            length_mm,
            accel_mm_s2,
            peak_mm_s: peak,
            t_ramp_s: t_ramp,
            t_cruise_s: t_cruise,
        }
    }

    /// Duration of the motion (s).
    pub fn duration_s(&self) -> f64 {
        2.0 * self.t_ramp_s + self.t_cruise_s
    }

    /// Path coordinate s (mm) and path speed (mm/s) at time `t` after the start; after the
    /// end, (L, 0).
    pub fn at(&self, t: f64) -> (f64, f64) {
        let (a, vp, tr, tc) = (
            self.accel_mm_s2,
            self.peak_mm_s,
            self.t_ramp_s,
            self.t_cruise_s,
        );
        if t <= 0.0 {
            (0.0, 0.0)
        } else if t < tr {
            (0.5 * a * t * t, a * t)
        } else if t < tr + tc {
            (0.5 * vp * tr + vp * (t - tr), vp)
        } else if t < 2.0 * tr + tc {
            let te = 2.0 * tr + tc - t;
            (self.length_mm - 0.5 * a * te * te, a * te)
        } else {
            (self.length_mm, 0.0)
        }
    }
}

/// Geometry of one run's path.
#[derive(Debug, Clone, Copy)]
pub enum Path {
    /// From `start` along unit direction `dir` for the profile's length.
    Line { start: [f64; 3], dir: [f64; 3] },
    /// Circle of `radius_mm` about `centre` in the plane of axes (u, v), starting at
    /// angle 0 (on +u); `sense` +1 counter-clockwise (from +u toward +v), −1 clockwise.
    Circle {
        centre: [f64; 3],
        u: Axis,
        v: Axis,
        radius_mm: f64,
        sense: f64,
    },
}

impl Path {
    pub fn length_mm(&self, line_length_mm: f64) -> f64 {
        match self {
            Path::Line { .. } => line_length_mm,
            Path::Circle { radius_mm, .. } => 2.0 * std::f64::consts::PI * radius_mm,
        }
    }

    /// Position (mm) and velocity (mm/s) at path coordinate s with path speed `speed`.
    pub fn at(&self, s: f64, speed: f64) -> ([f64; 3], [f64; 3]) {
        match *self {
            Path::Line { start, dir } => (
                [0, 1, 2].map(|i| start[i] + s * dir[i]),
                [0, 1, 2].map(|i| speed * dir[i]),
            ),
            Path::Circle {
                centre,
                u,
                v,
                radius_mm,
                sense,
            } => {
                let th = sense * s / radius_mm;
                let (sn, cs) = th.sin_cos();
                let mut q = centre;
                q[u.index()] += radius_mm * cs;
                q[v.index()] += radius_mm * sn;
                let mut vel = [0.0; 3];
                vel[u.index()] = -sense * speed * sn;
                vel[v.index()] = sense * speed * cs;
                (q, vel)
            }
        }
    }
}

/// One commanded sample with the drive state at that instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionSample {
    pub t_s: f64,
    /// Commanded position (mm).
    pub q_mm: [f64; 3],
    /// Commanded velocity (mm/s).
    pub vel_mm_s: [f64; 3],
    /// Sign of each axis's last travel (+1, −1; 0 if it has not moved yet).
    pub dir: [f64; 3],
    /// Travel of each axis since its last reversal (mm; infinite if it never reversed).
    pub since_reversal_mm: [f64; 3],
    /// Sign of each axis's travel at this instant, and its travel since it turned (mm;
    /// infinite if it never did), followed along the path between the samples
    /// ([`Travel::traced`]): on a circle an axis turns between two samples, and a sample
    /// just after the turn is already travelling the new way.
    pub turn_dir: [f64; 3],
    pub since_turn_mm: [f64; 3],
}

/// Per-axis travel state, carried through a plane's recording (including the unrecorded
/// approach moves between runs).
#[derive(Debug, Clone, Copy)]
pub struct DriveState {
    pub q_mm: [f64; 3],
    pub dir: [f64; 3],
    pub since_reversal_mm: [f64; 3],
}

impl DriveState {
    pub fn at(q_mm: [f64; 3]) -> DriveState {
        DriveState {
            q_mm,
            dir: [0.0; 3],
            since_reversal_mm: [f64::INFINITY; 3],
        }
    }

    /// Moves the axes to `q` (a straight move): reversals are detected per axis.
    pub fn move_to(&mut self, q: [f64; 3]) {
        for i in 0..3 {
            let dq = q[i] - self.q_mm[i];
            if dq.abs() > 1e-12 {
                let s = dq.signum();
                if s != self.dir[i] {
                    if self.dir[i] != 0.0 {
                        self.since_reversal_mm[i] = 0.0;
                    }
                    self.dir[i] = s;
                }
                self.since_reversal_mm[i] += dq.abs();
            }
            self.q_mm[i] = q[i];
        }
    }
}

/// The travel state of the axes two ways: from sample to sample (`at_samples`: what the
/// set-points tell), and followed along the path in steps of [`TRACE_STEP_S`] between the
/// samples (`traced`: where the axes really turn).
#[derive(Debug, Clone, Copy)]
pub struct Travel {
    pub at_samples: DriveState,
    pub traced: DriveState,
}

/// The time step (s) at which [`Travel::traced`] follows a circle between its samples.
pub const TRACE_STEP_S: f64 = 1e-3;

impl Travel {
    pub fn at(q_mm: [f64; 3]) -> Travel {
        Travel {
            at_samples: DriveState::at(q_mm),
            traced: DriveState::at(q_mm),
        }
    }

    /// A straight move to `q` (both states alike: no turn inside it).
    pub fn move_to(&mut self, q: [f64; 3]) {
        self.at_samples.move_to(q);
        self.traced.move_to(q);
    }
}

/// Samples of one run: the motion along `path` with `profile`, then `dwell_s` at the end,
/// at `rate_hz` starting at `t0_s`. Updates `state`.
pub fn run_samples(
    path: &Path,
    profile: &Profile,
    dwell_s: f64,
    t0_s: f64,
    rate_hz: f64,
    state: &mut Travel,
) -> Vec<MotionSample> {
    let total = profile.duration_s() + dwell_s;
    let n = (total * rate_hz).floor() as usize + 1;
    let mut out = Vec::with_capacity(n);
    let curved = matches!(path, Path::Circle { .. });
    for k in 0..n {
        let tr = k as f64 / rate_hz;
        if curved && k > 0 {
            // Between the samples along the path: a line's axes turn only at its ends.
            let t_prev = (k - 1) as f64 / rate_hz;
            let m = ((tr - t_prev) / TRACE_STEP_S).ceil().max(1.0) as usize;
            for j in 1..m {
                let t = t_prev + (tr - t_prev) * j as f64 / m as f64;
                state.traced.move_to(path.at(profile.at(t).0, 0.0).0);
            }
        }
        let (s, v) = profile.at(tr);
        let (q, vel) = path.at(s, v);
        state.move_to(q);
        out.push(MotionSample {
            t_s: t0_s + tr,
            q_mm: q,
            vel_mm_s: vel,
            dir: state.at_samples.dir,
            since_reversal_mm: state.at_samples.since_reversal_mm,
            turn_dir: state.traced.dir,
            since_turn_mm: state.traced.since_reversal_mm,
        });
    }
    out
}
