//! The 21 geometric error terms of a 3-axis machine, with ISO 230-1 names.
//!
//! Component errors are named `E` + direction of error + moving axis: EXX is the
//! positioning error of X, EYX and EZX its straightness, EAX its roll, EBX and ECX its
//! pitch and yaw. The three squareness (location) errors are EC0Y, EB0Z, EA0Z.
//! 18 functions of axis position + 3 constants = the 21 terms.

use crate::axis::Axis;
use serde::{Deserialize, Serialize};
use std::fmt;

/// Kind of a motion error, as ISO 230-1 classifies it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub enum TermKind {
    Positioning,
    Straightness,
    Roll,
    PitchYaw,
}

/// Whether an error component is a translation (µm) or a rotation (µrad).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub enum Component {
    /// Translation along the given direction.
    Translation(Axis),
    /// Rotation about the given direction (A about X, B about Y, C about Z).
    Rotation(Axis),
}

/// One of the 18 motion-error functions: the error `component` of the moving `axis`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Term {
    pub axis: Axis,
    pub component: Component,
}

impl Term {
    /// All 18 functions, grouped by axis (X, Y, Z), each as
    /// [translation X, Y, Z, rotation A, B, C].
    pub fn all() -> [Term; 18] {
        let mut out = [Term {
            axis: Axis::X,
            component: Component::Translation(Axis::X),
        }; 18];
        for (i, axis) in Axis::ALL.into_iter().enumerate() {
            for (j, dir) in Axis::ALL.into_iter().enumerate() {
                out[6 * i + j] = Term {
                    axis,
                    component: Component::Translation(dir),
                };
                out[6 * i + 3 + j] = Term {
                    axis,
                    component: Component::Rotation(dir),
                };
            }
        }
        out
    }

    /// Position of the term in [`Term::all`]: 6 · axis + (0, 1, 2 for translations along
    /// X, Y, Z; 3, 4, 5 for rotations about them).
    pub fn index(self) -> usize {
        let (offset, dir) = match self.component {
            Component::Translation(d) => (0, d),
            Component::Rotation(d) => (3, d),
        };
        6 * self.axis.index() + offset + dir.index()
    }

    /// ISO 230-1 name, e.g. `EXX`, `EAY`, `ECZ`, without allocating (per-sample code
    /// looks coefficients up by it).
    pub fn code(self) -> &'static str {
        const NAMES: [&str; 18] = [
            "EXX", "EYX", "EZX", "EAX", "EBX", "ECX", "EXY", "EYY", "EZY", "EAY", "EBY", "ECY",
            "EXZ", "EYZ", "EZZ", "EAZ", "EBZ", "ECZ",
        ];
        NAMES[self.index()]
    }

    /// ISO 230-1 name, e.g. `EXX`, `EAY`, `ECZ`, as an owned string.
    pub fn name(self) -> String {
        self.code().to_string()
    }

    pub fn parse(name: &str) -> Option<Term> {
        Term::all().into_iter().find(|t| t.code() == name)
    }

    pub fn kind(self) -> TermKind {
        match self.component {
            Component::Translation(d) if d == self.axis => TermKind::Positioning,
            Component::Translation(_) => TermKind::Straightness,
            Component::Rotation(d) if d == self.axis => TermKind::Roll,
            Component::Rotation(_) => TermKind::PitchYaw,
        }
    }

    pub fn is_angular(self) -> bool {
        matches!(self.component, Component::Rotation(_))
    }

    /// Unit of the term's values in reports: `um` or `urad`.
    pub fn unit(self) -> &'static str {
        if self.is_angular() { "urad" } else { "um" }
    }
}

impl fmt::Display for Term {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.name())
    }
}

/// The three squareness errors (constants, µrad), as right-hand rotations of the
/// secondary axis about the normal: X–Y = 90° + EC0Y, X–Z = 90° − EB0Z, Y–Z = 90° + EA0Z.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub enum SquarenessTerm {
    /// Y about Z, relative to X.
    EC0Y,
    /// Z about Y, relative to X.
    EB0Z,
    /// Z about X, relative to Y.
    EA0Z,
}

impl SquarenessTerm {
    pub const ALL: [SquarenessTerm; 3] = [
        SquarenessTerm::EC0Y,
        SquarenessTerm::EB0Z,
        SquarenessTerm::EA0Z,
    ];

    pub fn name(self) -> &'static str {
        match self {
            SquarenessTerm::EC0Y => "EC0Y",
            SquarenessTerm::EB0Z => "EB0Z",
            SquarenessTerm::EA0Z => "EA0Z",
        }
    }

    pub fn parse(name: &str) -> Option<SquarenessTerm> {
        SquarenessTerm::ALL.into_iter().find(|s| s.name() == name)
    }
}

/// Values of the three squareness constants, µrad (model constants γ, β, α of the
/// contract's nominal axis directions u_Y, u_Z).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Squareness {
    pub ec0y_urad: f64,
    pub eb0z_urad: f64,
    pub ea0z_urad: f64,
}

impl Squareness {
    pub fn get(&self, s: SquarenessTerm) -> f64 {
        match s {
            SquarenessTerm::EC0Y => self.ec0y_urad,
            SquarenessTerm::EB0Z => self.eb0z_urad,
            SquarenessTerm::EA0Z => self.ea0z_urad,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_follow_iso_230_1_table() {
        let names: Vec<String> = Term::all().iter().map(|t| t.name()).collect();
        assert_eq!(
            names,
            [
                "EXX", "EYX", "EZX", "EAX", "EBX", "ECX", "EXY", "EYY", "EZY", "EAY", "EBY", "ECY",
                "EXZ", "EYZ", "EZZ", "EAZ", "EBZ", "ECZ"
            ]
        );
        assert_eq!(Term::parse("EYY").unwrap().kind(), TermKind::Positioning);
        assert_eq!(Term::parse("EZX").unwrap().kind(), TermKind::Straightness);
        assert_eq!(Term::parse("ECZ").unwrap().kind(), TermKind::Roll);
        assert_eq!(Term::parse("EAY").unwrap().kind(), TermKind::PitchYaw);
        assert_eq!(Term::parse("EQX"), None);
        for (i, t) in Term::all().into_iter().enumerate() {
            assert_eq!(t.index(), i);
            let dir = match t.component {
                Component::Translation(d) => d.letter(),
                Component::Rotation(d) => d.rot_letter(),
            };
            assert_eq!(t.code(), format!("E{dir}{}", t.axis.letter()));
        }
    }
}
