//! A measurement session of planar grid-encoder tests (datasets contract, section 1), as
//! plain data. Readers in `mtcal-formats` build it; the simulator writes it; identification
//! and diagnosis read it.

use crate::axis::{Plane, Topology};
use serde::{Deserialize, Serialize};

/// One measurement campaign on one machine: plate mountings (planes), each with runs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Session {
    pub machine_id: String,
    /// RFC 3339 time stamp of the campaign.
    pub measured_at: String,
    /// Machine topology; `None` when the session relies on the registered machine's.
    pub topology: Option<Topology>,
    pub temperature_c: Option<f64>,
    pub notes: Option<String>,
    pub planes: Vec<PlaneRecord>,
}

/// One plane file: the runs recorded with one plate in one plane at one head offset.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
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
    /// Total number of samples over all planes and runs.
    pub fn sample_count(&self) -> usize {
        self.planes
            .iter()
            .flat_map(|p| p.runs.iter())
            .map(Run::len)
            .sum()
    }
}
