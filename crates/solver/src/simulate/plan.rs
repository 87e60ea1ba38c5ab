//! Test plans of the simulator: which plate mountings, head offsets and tests a session
//! holds (kinematics contract, "Planar grid encoder measurement" and its
//! identifiability table).

use crate::axis::{Axis, Plane};
use serde::{Deserialize, Serialize};

/// The tests recorded with one plate in one plane at one head offset (one plane file).
///
/// In order: lines along u (back and forth, `round_trips` times), lines along v, then
/// one counter-clockwise and one clockwise circle about the plane origin.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlaneTest {
    /// File name in the session folder.
    pub file: String,
    pub plane: Plane,
    /// Declared tool offset t (mm).
    pub head_offset_mm: [f64; 3],
    /// Mounting name: files sharing it share the plate rotation.
    pub mounting: String,
    /// Position of the axis normal to the plane during the tests (mm).
    pub park_mm: f64,
    /// Lines run over ±`half_travel_mm` along each in-plane axis (other in-plane axis at 0).
    pub half_travel_mm: f64,
    /// Round trips per line (each gives two passes, i.e. two runs).
    pub round_trips: usize,
    /// Circle radius (mm); `None` for no circles.
    pub circle_radius_mm: Option<f64>,
}

/// A test plan.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Plan {
    /// The seed patent's plan: XY at z = 0, XZ at y = 0, YZ at x = 120 mm; lines ±50 mm,
    /// 5 round trips; circles R50 ccw and cw; t = (0, 0, −100); one mounting per plane.
    /// Rank 34 of 51 (kinematics contract).
    Seed,
    /// The seed plan at t = (0, 0, −100), (0, 0, −200) and (40, 0, −100), each plane's
    /// mounting kept across offsets: all 51 parameters identifiable.
    Full,
    /// Any list of plane tests (e.g. the intermediate rows of the contract's table).
    Custom(Vec<PlaneTest>),
}

/// Head offsets of the full plan (mm).
pub const FULL_OFFSETS: [[f64; 3]; 3] =
    [[0.0, 0.0, -100.0], [0.0, 0.0, -200.0], [40.0, 0.0, -100.0]];

/// Position of the normal axis of each plane in the seed plan (XY at z = 0, XZ at y = 0,
/// YZ at x = 120 mm).
pub fn seed_park_mm(plane: Plane) -> f64 {
    match plane.normal() {
        Axis::Z | Axis::Y => 0.0,
        Axis::X => 120.0,
    }
}

impl Plan {
    /// The seed plan's three planes repeated at each head offset. With `keep_mountings`
    /// each plane keeps one mounting name across offsets (`xy`, `xz`, `yz`); otherwise
    /// every offset is a new mounting (`xy-1`, `xy-2`, …).
    pub fn custom(offsets: &[[f64; 3]], keep_mountings: bool) -> Plan {
        let mut tests = Vec::new();
        for (k, t) in offsets.iter().enumerate() {
            for plane in Plane::ALL {
                let p = plane.name().to_lowercase();
                tests.push(PlaneTest {
                    file: format!("{p}_t{}.csv", k + 1),
                    plane,
                    head_offset_mm: *t,
                    mounting: if keep_mountings {
                        p.clone()
                    } else {
                        format!("{p}-{}", k + 1)
                    },
                    park_mm: seed_park_mm(plane),
                    half_travel_mm: 50.0,
                    round_trips: 5,
                    circle_radius_mm: Some(50.0),
                });
            }
        }
        Plan::Custom(tests)
    }

    /// The plane tests of this plan, in recording order.
    pub fn tests(&self) -> Vec<PlaneTest> {
        match self {
            Plan::Seed => match Plan::custom(&FULL_OFFSETS[..1], true) {
                Plan::Custom(t) => t,
                _ => unreachable!(),
            },
            Plan::Full => match Plan::custom(&FULL_OFFSETS, true) {
                Plan::Custom(t) => t,
                _ => unreachable!(),
            },
            Plan::Custom(t) => t.clone(),
        }
    }

    /// `seed` or `full`.
    pub fn parse(s: &str) -> Option<Plan> {
        match s {
            "seed" => Some(Plan::Seed),
            "full" => Some(Plan::Full),
            _ => None,
        }
    }
}
