//! A measurement session of planar grid-encoder tests (datasets contract, section 1), as
//! plain data. Readers in `mtcal-formats` build it; the simulator writes it; identification
//! and diagnosis read it.

use crate::axis::{Axis, Plane, Topology};
use crate::uncertainty::Conditions;
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

/// One measurement campaign on one machine: plate mountings (planes), each with runs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Session {
    pub machine_id: String,
    /// RFC 3339 time stamp of the campaign.
    pub measured_at: String,
    /// Machine topology; `None` when the session relies on the registered machine's.
    pub topology: Option<Topology>,
    pub notes: Option<String>,
    /// What session.json states about how the test was made (operator, instrument,
    /// temperature, expansion coefficients, alignment): the facts of a signed report
    /// and the inputs of the uncertainty budget ([`crate::uncertainty`]).
    #[serde(default)]
    pub conditions: Conditions,
    pub planes: Vec<PlaneRecord>,
}

/// One plane file: the runs recorded with one plate in one plane at one head offset.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct PlaneRecord {
    /// File name inside the session folder (used in messages and diagnosis reports).
    pub file: String,
    pub plane: Plane,
    /// Tool offset t (mm): vector from the tool reference point to the scanning head.
    pub head_offset_mm: [f64; 3],
    /// Physical mounting of the plate; files with the same mounting share its rotation.
    pub mounting: String,
    pub runs: Vec<Run>,
}

/// Label of a run (optional column `test`; inferred from the path when absent).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub enum TestKind {
    LineX,
    LineY,
    LineZ,
    /// Clockwise circle: from +v toward +u (see the circle-direction convention).
    CircleCw,
    /// Counter-clockwise circle: from +u toward +v.
    CircleCcw,
    Free,
}

impl TestKind {
    /// A line along one axis (`line_X`, `line_Y`, `line_Z`).
    pub fn is_line(self) -> bool {
        matches!(self, TestKind::LineX | TestKind::LineY | TestKind::LineZ)
    }

    /// A circle, either direction (`circle_cw`, `circle_ccw`).
    pub fn is_circle(self) -> bool {
        matches!(self, TestKind::CircleCw | TestKind::CircleCcw)
    }

    pub fn parse(s: &str) -> Option<TestKind> {
        Some(match s {
            "line_X" => TestKind::LineX,
            "line_Y" => TestKind::LineY,
            "line_Z" => TestKind::LineZ,
            "circle_cw" => TestKind::CircleCw,
            "circle_ccw" => TestKind::CircleCcw,
            "free" => TestKind::Free,
            _ => return None,
        })
    }

    pub fn name(self) -> &'static str {
        match self {
            TestKind::LineX => "line_X",
            TestKind::LineY => "line_Y",
            TestKind::LineZ => "line_Z",
            TestKind::CircleCw => "circle_cw",
            TestKind::CircleCcw => "circle_ccw",
            TestKind::Free => "free",
        }
    }
}

/// One continuous motion (a line pass with its end dwell, or one circle), columnar.
///
/// All vectors have the same length; `t_s` is strictly increasing.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Run {
    /// Run number within its file.
    pub number: i64,
    /// Label from the file, or `None` to infer from the path.
    pub test: Option<TestKind>,
    /// Time since the session started, s.
    pub t_s: Vec<f64>,
    /// Commanded axis positions (x, y, z), mm.
    pub pos_mm: Vec<[f64; 3]>,
    /// Measured minus commanded head position along u, µm.
    pub du_um: Vec<f64>,
    /// Measured minus commanded head position along v, µm.
    pub dv_um: Vec<f64>,
    /// Machine temperature, °C, when logged.
    pub temp_c: Option<Vec<f64>>,
}

impl Run {
    pub fn len(&self) -> usize {
        self.t_s.len()
    }

    pub fn is_empty(&self) -> bool {
        self.t_s.is_empty()
    }
}

impl Session {
    /// The conditions of the test as the budget and the report read them: the stated
    /// ones, with the temperature taken from the plane files' `temp_c` column (the mean
    /// of every logged sample, `temperature_source: logged`) when session.json states
    /// none and every run logs one.
    pub fn test_conditions(&self) -> Conditions {
        let mut c = self.conditions.clone();
        if c.temperature_c.is_none() {
            let runs = || self.planes.iter().flat_map(|p| &p.runs);
            let logged: Option<Vec<&Vec<f64>>> = runs().map(|r| r.temp_c.as_ref()).collect();
            if let Some(cols) = logged {
                let n: usize = cols.iter().map(|c| c.len()).sum();
                if n > 0 {
                    let mean = cols.iter().flat_map(|c| c.iter()).sum::<f64>() / n as f64;
                    if mean.is_finite() {
                        c.temperature_c = Some(mean);
                        c.temperature_source = Some("logged".into());
                    }
                }
            }
        } else if c.temperature_source.is_none() {
            c.temperature_source = Some("stated".into());
        }
        c
    }

    /// Total number of samples over all planes and runs.
    pub fn sample_count(&self) -> usize {
        self.planes
            .iter()
            .flat_map(|p| p.runs.iter())
            .map(Run::len)
            .sum()
    }
}

/// Range (max − min) of commanded positions below which an axis counts as parked when
/// the test kind is inferred, mm. Commanded set-points of a parked axis are constant, so
/// 1 µm only absorbs rounding in the file.
pub const PARKED_RANGE_MM: f64 = 1e-3;

/// Largest radial deviation of the commanded path from its fitted circle, relative to the
/// radius, for a run to be inferred as a circle.
pub const CIRCLE_RADIAL_TOLERANCE: f64 = 0.01;

/// Smallest swept angle (rad) for a run to be inferred as a circle: half a turn.
pub const CIRCLE_MIN_SWEEP_RAD: f64 = std::f64::consts::PI;

impl Run {
    /// The run's test kind: its label when the file gives one, else inferred from the
    /// commanded path in the plate's plane (u, v) (datasets contract, section 1):
    ///
    /// * the normal axis moves (range > [`PARKED_RANGE_MM`]) → [`TestKind::Free`];
    /// * exactly one in-plane axis moves → `line_X`, `line_Y` or `line_Z` after that axis;
    /// * both move, the path stays within [`CIRCLE_RADIAL_TOLERANCE`]·R of the least-squares
    ///   (Kåsa) circle through it and sweeps at least [`CIRCLE_MIN_SWEEP_RAD`] in one sense
    ///   → `circle_ccw` when the swept angle Σ Δθ, θ = atan2(v − v₀, u − u₀), is positive
    ///   (counter-clockwise: from +u toward +v), `circle_cw` when negative;
    /// * anything else (including a run with no motion) → [`TestKind::Free`].
    pub fn test_kind(&self, plane: Plane) -> TestKind {
        if let Some(kind) = self.test {
            return kind;
        }
        infer_test_kind(&self.pos_mm, plane)
    }
}

fn range(pos: &[[f64; 3]], axis: usize) -> f64 {
    let (lo, hi) = pos
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p[axis]), hi.max(p[axis]))
        });
    hi - lo
}

fn infer_test_kind(pos: &[[f64; 3]], plane: Plane) -> TestKind {
    if pos.len() < 2 || range(pos, plane.normal().index()) > PARKED_RANGE_MM {
        return TestKind::Free;
    }
    let (u_axis, v_axis) = plane.axes();
    let (iu, iv) = (u_axis.index(), v_axis.index());
    let moves_u = range(pos, iu) > PARKED_RANGE_MM;
    let moves_v = range(pos, iv) > PARKED_RANGE_MM;
    let line = |axis: Axis| match axis {
        Axis::X => TestKind::LineX,
        Axis::Y => TestKind::LineY,
        Axis::Z => TestKind::LineZ,
    };
    match (moves_u, moves_v) {
        (false, false) => TestKind::Free,
        (true, false) => line(u_axis),
        (false, true) => line(v_axis),
        (true, true) => {
            let uv: Vec<(f64, f64)> = pos.iter().map(|p| (p[iu], p[iv])).collect();
            circle_direction(&uv).unwrap_or(TestKind::Free)
        }
    }
}

/// Kåsa circle fit u² + v² = 2a·u + 2b·v + c solved by SVD (no normal equations), on
/// coordinates centred at their mean for conditioning; exact for points on a circle.
/// Returns the centre (u, v) and the radius, `None` when the points fit no circle.
pub(crate) fn kasa_circle(uv: &[(f64, f64)]) -> Option<(f64, f64, f64)> {
    let n = uv.len() as f64;
    let (mu, mv) = uv
        .iter()
        .fold((0.0, 0.0), |(su, sv), &(u, v)| (su + u / n, sv + v / n));
    let a = DMatrix::from_fn(uv.len(), 3, |i, j| match j {
        0 => 2.0 * (uv[i].0 - mu),
        1 => 2.0 * (uv[i].1 - mv),
        _ => 1.0,
    });
    let b = DVector::from_fn(uv.len(), |i, _| {
        let (u, v) = (uv[i].0 - mu, uv[i].1 - mv);
        u * u + v * v
    });
    let sol = a.svd(true, true).solve(&b, 1e-12).ok()?;
    let (cu, cv) = (sol[0], sol[1]);
    let r2 = sol[2] + cu * cu + cv * cv;
    if !r2.is_finite() || r2 <= 0.0 {
        return None;
    }
    Some((mu + cu, mv + cv, r2.sqrt()))
}

/// Circle direction of a path: the [`kasa_circle`] through it, then the radial and sweep
/// tests.
fn circle_direction(uv: &[(f64, f64)]) -> Option<TestKind> {
    let (cu, cv, r) = kasa_circle(uv)?;
    if r <= PARKED_RANGE_MM {
        return None;
    }
    let centred = uv.iter().map(|&(u, v)| (u - cu, v - cv));
    if centred
        .clone()
        .any(|(u, v)| ((u * u + v * v).sqrt() - r).abs() > CIRCLE_RADIAL_TOLERANCE * r)
    {
        return None;
    }
    let angles: Vec<f64> = centred.map(|(u, v)| v.atan2(u)).collect();
    let sweep: f64 = angles
        .windows(2)
        .map(|w| {
            let d = w[1] - w[0];
            // Wrap each increment into (−π, π].
            d - (2.0 * std::f64::consts::PI)
                * ((d + std::f64::consts::PI) / (2.0 * std::f64::consts::PI)).floor()
        })
        .sum();
    if sweep >= CIRCLE_MIN_SWEEP_RAD {
        Some(TestKind::CircleCcw)
    } else if sweep <= -CIRCLE_MIN_SWEEP_RAD {
        Some(TestKind::CircleCw)
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn run_of(pos_mm: Vec<[f64; 3]>) -> Run {
        Run {
            t_s: (0..pos_mm.len()).map(|i| i as f64).collect(),
            du_um: vec![0.0; pos_mm.len()],
            dv_um: vec![0.0; pos_mm.len()],
            pos_mm,
            ..Run::default()
        }
    }

    /// Circle of radius `r` about (cu, cv) in `plane`, swept from θ0 by `sweep` rad, with
    /// the normal axis parked at `w`.
    fn circle(plane: Plane, cu: f64, cv: f64, r: f64, theta0: f64, sweep: f64, w: f64) -> Run {
        let (u, v) = plane.axes();
        let n = plane.normal();
        let pos = (0..=360)
            .map(|i| {
                let th = theta0 + sweep * i as f64 / 360.0;
                let mut p = [0.0; 3];
                p[u.index()] = cu + r * th.cos();
                p[v.index()] = cv + r * th.sin();
                p[n.index()] = w;
                p
            })
            .collect();
        run_of(pos)
    }

    #[test]
    fn label_wins_over_path() {
        let mut run = circle(Plane::XY, 0.0, 0.0, 50.0, 0.0, 2.0 * PI, 0.0);
        run.test = Some(TestKind::LineY);
        assert_eq!(run.test_kind(Plane::XY), TestKind::LineY);
    }

    #[test]
    fn lines_along_each_in_plane_axis() {
        // Back and forth along X at y = 10, z = 0 (XY plane) → line_X.
        let x: Vec<[f64; 3]> = (0..200)
            .map(|i| [-50.0 + (i % 100) as f64, 10.0, 0.0])
            .collect();
        assert_eq!(run_of(x).test_kind(Plane::XY), TestKind::LineX);
        // Along Z in the XZ plane at x = 5, y = 0 → line_Z.
        let z: Vec<[f64; 3]> = (0..100).map(|i| [5.0, 0.0, i as f64]).collect();
        assert_eq!(run_of(z.clone()).test_kind(Plane::XZ), TestKind::LineZ);
        assert_eq!(run_of(z).test_kind(Plane::YZ), TestKind::LineZ);
        // Along Y in the YZ plane at x = 120 (parked normal axis) → line_Y.
        let y: Vec<[f64; 3]> = (0..100).map(|i| [120.0, i as f64, -3.0]).collect();
        assert_eq!(run_of(y).test_kind(Plane::YZ), TestKind::LineY);
    }

    #[test]
    fn circle_direction_follows_u_toward_v() {
        for plane in Plane::ALL {
            for theta0 in [0.0, 1.0, -2.5] {
                let ccw = circle(plane, 12.0, -7.0, 50.0, theta0, 2.0 * PI, 3.0);
                assert_eq!(
                    ccw.test_kind(plane),
                    TestKind::CircleCcw,
                    "{plane} {theta0}"
                );
                let cw = circle(plane, 12.0, -7.0, 50.0, theta0, -2.0 * PI, 3.0);
                assert_eq!(cw.test_kind(plane), TestKind::CircleCw, "{plane} {theta0}");
            }
        }
        // A half circle (sweep exactly π plus a little) is still a circle; a quarter is not.
        let half = circle(Plane::XY, 0.0, 0.0, 30.0, 0.0, 1.01 * PI, 0.0);
        assert_eq!(half.test_kind(Plane::XY), TestKind::CircleCcw);
        let quarter = circle(Plane::XY, 0.0, 0.0, 30.0, 0.0, 0.5 * PI, 0.0);
        assert_eq!(quarter.test_kind(Plane::XY), TestKind::Free);
    }

    #[test]
    fn other_paths_are_free() {
        // The normal axis moves: XY circle with a ramp in Z.
        let mut helix = circle(Plane::XY, 0.0, 0.0, 50.0, 0.0, 2.0 * PI, 0.0);
        for (i, p) in helix.pos_mm.iter_mut().enumerate() {
            p[2] = i as f64 * 0.01;
        }
        assert_eq!(helix.test_kind(Plane::XY), TestKind::Free);
        // A diagonal line: both in-plane axes move, not on a circle.
        let diag: Vec<[f64; 3]> = (0..100).map(|i| [i as f64, i as f64, 0.0]).collect();
        assert_eq!(run_of(diag).test_kind(Plane::XY), TestKind::Free);
        // A square path: both move, radial deviation ~41 % of the fitted radius.
        let mut square = Vec::new();
        for i in 0..100 {
            let s = i as f64;
            square.push([s, 0.0, 0.0]);
        }
        for i in 0..100 {
            square.push([100.0, i as f64, 0.0]);
        }
        for i in 0..100 {
            square.push([100.0 - i as f64, 100.0, 0.0]);
        }
        for i in 0..100 {
            square.push([0.0, 100.0 - i as f64, 0.0]);
        }
        assert_eq!(run_of(square).test_kind(Plane::XY), TestKind::Free);
        // No motion at all (a dwell) and a single sample.
        assert_eq!(
            run_of(vec![[1.0, 2.0, 3.0]; 10]).test_kind(Plane::XY),
            TestKind::Free
        );
        assert_eq!(
            run_of(vec![[1.0, 2.0, 3.0]]).test_kind(Plane::XY),
            TestKind::Free
        );
    }
}
