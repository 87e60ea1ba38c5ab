//! Linear axes, measurement planes and machine topology (kinematics contract, "Frames").

use serde::{Deserialize, Serialize};
use std::fmt;

/// A nominal linear axis of a 3-axis machine (also used as a direction index 0, 1, 2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub enum Axis {
    X,
    Y,
    Z,
}

impl Axis {
    pub const ALL: [Axis; 3] = [Axis::X, Axis::Y, Axis::Z];

    /// Index of the axis as a direction: X → 0, Y → 1, Z → 2.
    pub fn index(self) -> usize {
        match self {
            Axis::X => 0,
            Axis::Y => 1,
            Axis::Z => 2,
        }
    }

    pub fn from_index(i: usize) -> Axis {
        Axis::ALL[i]
    }

    /// The translational letter (X, Y, Z).
    pub fn letter(self) -> char {
        ['X', 'Y', 'Z'][self.index()]
    }

    /// The rotational letter about this axis (A, B, C).
    pub fn rot_letter(self) -> char {
        ['A', 'B', 'C'][self.index()]
    }

    pub fn parse(s: &str) -> Option<Axis> {
        match s {
            "X" | "x" => Some(Axis::X),
            "Y" | "y" => Some(Axis::Y),
            "Z" | "z" => Some(Axis::Z),
            _ => None,
        }
    }
}

impl fmt::Display for Axis {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.letter())
    }
}

/// Plane of a grid-encoder plate. The in-plane axes (u, v) are (X, Y), (X, Z) or (Y, Z).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub enum Plane {
    XY,
    XZ,
    YZ,
}

impl Plane {
    pub const ALL: [Plane; 3] = [Plane::XY, Plane::XZ, Plane::YZ];

    /// The in-plane axes (u, v).
    pub fn axes(self) -> (Axis, Axis) {
        match self {
            Plane::XY => (Axis::X, Axis::Y),
            Plane::XZ => (Axis::X, Axis::Z),
            Plane::YZ => (Axis::Y, Axis::Z),
        }
    }

    /// The axis normal to the plane (not observed by the encoder).
    pub fn normal(self) -> Axis {
        match self {
            Plane::XY => Axis::Z,
            Plane::XZ => Axis::Y,
            Plane::YZ => Axis::X,
        }
    }

    pub fn parse(s: &str) -> Option<Plane> {
        match s {
            "XY" => Some(Plane::XY),
            "XZ" => Some(Plane::XZ),
            "YZ" => Some(Plane::YZ),
            _ => None,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Plane::XY => "XY",
            Plane::XZ => "XZ",
            Plane::YZ => "YZ",
        }
    }
}

impl fmt::Display for Plane {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Axes stacked on the workpiece side and on the tool side, each from the bed outward.
///
/// Default (the seed's vertical machining centre): workpiece `[X, Y]` (saddle X carries
/// table Y), tool `[Z]`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(deny_unknown_fields)]
pub struct Topology {
    pub workpiece: Vec<Axis>,
    pub tool: Vec<Axis>,
}

impl Default for Topology {
    fn default() -> Self {
        Topology {
            workpiece: vec![Axis::X, Axis::Y],
            tool: vec![Axis::Z],
        }
    }
}

impl Topology {
    /// Checks that X, Y and Z each appear exactly once across the two stacks.
    pub fn validate(&self) -> Result<(), String> {
        let mut seen = [0usize; 3];
        for a in self.workpiece.iter().chain(self.tool.iter()) {
            seen[a.index()] += 1;
        }
        if seen != [1, 1, 1] {
            return Err(format!(
                "topology must list X, Y and Z exactly once across workpiece and tool stacks, got workpiece {:?}, tool {:?}",
                self.workpiece, self.tool
            ));
        }
        Ok(())
    }
}
