//! Machine templates selectable by name (docs/sensitivity.md, "Templates"); each is also
//! written out as docs/machines/<name>.json.
//!
//! * `vmc3`: the contract's default 3-axis vertical machining centre, workpiece [X, Y],
//!   tool [Z]; the 21 terms (18 motion errors + EC0Y, EB0Z, EA0Z).
//! * `hmc4-b`: the 4-axis horizontal machining centre of Cheng et al. (2012): column X and
//!   headstock Y on the tool side, table Z carrying the rotary table B on the workpiece
//!   side. 35 errors: 24 motion errors (X, Y, Z, B), 3 squareness (EC0Y, EB0Z, EA0Z),
//!   4 location errors of B (offsets EX0B, EZ0B; tilts EA0B, EC0B) and 4 setup errors:
//!   the tool's radial offsets and length error (EX0T, EY0T, EZ0T) and the workpiece's
//!   clamping angle on the table about B (EB0W; it plays the role of B's zero-position
//!   error, which the contract keeps out of the motion errors, zero at q = 0).
//! * `cradle5-ac`: 5-axis machine with an A/C cradle (A tilts about X and carries the
//!   rotary table C), workpiece [Y, A, C], tool [X, Z]; 43 errors: 30 motion errors,
//!   3 squareness, the ISO 230-7 location errors of A (EY0A, EZ0A, EB0A, EC0A, EA0A) and of
//!   C relative to A (EX0C, EY0C, EA0C, EB0C, EC0C).
//!
//! Tolerances are a plausible budget for a mid-size precision machine (positioning 6-8 µm,
//! straightness 4 µm, pitch/yaw 15 µrad, roll 10 µrad, squareness 15 µrad, rotary-axis
//! runout 3 µm and tilt 10 µrad, location offsets 10 µm and tilts 20 µrad), not a
//! specification: replace them with the machine's own.

use super::chain::{AxisSpec, ErrorSpec, MachineDescription};
use std::collections::BTreeMap;

/// Names of the built-in templates.
pub const TEMPLATES: [&str; 3] = ["vmc3", "hmc4-b", "cradle5-ac"];

/// The template of that name.
pub fn template(name: &str) -> Option<MachineDescription> {
    match name {
        "vmc3" => Some(vmc3()),
        "hmc4-b" => Some(hmc4_b()),
        "cradle5-ac" => Some(cradle5_ac()),
        _ => None,
    }
}

fn linear(axis: char, lo: f64, hi: f64) -> AxisSpec {
    AxisSpec {
        axis,
        travel: [lo, hi],
        centre_mm: None,
    }
}

fn rotary(axis: char, lo: f64, hi: f64, centre: [f64; 3]) -> AxisSpec {
    AxisSpec {
        axis,
        travel: [lo, hi],
        centre_mm: Some(centre),
    }
}

/// Motion-error tolerances of a linear axis K: positioning, straightness, roll, pitch/yaw.
fn linear_motion(e: &mut BTreeMap<String, ErrorSpec>, k: char, positioning: f64) {
    for d in ['X', 'Y', 'Z'] {
        let tol = if d == k { positioning } else { 4.0 };
        e.insert(format!("E{d}{k}"), ErrorSpec::tolerance(tol));
    }
    let own = ['A', 'B', 'C'][['X', 'Y', 'Z'].iter().position(|&c| c == k).expect("XYZ")];
    for d in ['A', 'B', 'C'] {
        let tol = if d == own { 10.0 } else { 15.0 };
        e.insert(format!("E{d}{k}"), ErrorSpec::tolerance(tol));
    }
}

/// Motion-error tolerances of a rotary axis K: runout 3 µm, tilt 10 µrad, positioning
/// 25 µrad (5″).
fn rotary_motion(e: &mut BTreeMap<String, ErrorSpec>, k: char) {
    let own = ['A', 'B', 'C'].iter().position(|&c| c == k).expect("ABC");
    for (i, d) in ['X', 'Y', 'Z'].into_iter().enumerate() {
        e.insert(format!("E{d}{k}"), ErrorSpec::tolerance(3.0));
        let r = ['A', 'B', 'C'][i];
        let tol = if i == own { 25.0 } else { 10.0 };
        e.insert(format!("E{r}{k}"), ErrorSpec::tolerance(tol));
    }
}

fn squareness(e: &mut BTreeMap<String, ErrorSpec>) {
    for n in ["EC0Y", "EB0Z", "EA0Z"] {
        e.insert(n.into(), ErrorSpec::tolerance(15.0));
    }
}

fn put(e: &mut BTreeMap<String, ErrorSpec>, names: &[&str], tol: f64) {
    for n in names {
        e.insert((*n).into(), ErrorSpec::tolerance(tol));
    }
}

/// The contract's default 3-axis vertical machining centre (21 errors).
pub fn vmc3() -> MachineDescription {
    let mut errors = BTreeMap::new();
    linear_motion(&mut errors, 'X', 8.0);
    linear_motion(&mut errors, 'Y', 8.0);
    linear_motion(&mut errors, 'Z', 6.0);
    squareness(&mut errors);
    MachineDescription {
        name: "vmc3".into(),
        description: "3-axis vertical machining centre (contract default topology): saddle X \
                      carries table Y on the workpiece side, head Z on the tool side; 21 errors"
            .into(),
        workpiece: vec![linear('X', 0.0, 600.0), linear('Y', 0.0, 400.0)],
        tool: vec![linear('Z', -400.0, 0.0)],
        tool_offset_mm: [0.0, 0.0, -100.0],
        errors,
    }
}

/// The 4-axis horizontal machining centre of Cheng et al. (2012) with a B rotary table
/// (35 errors).
pub fn hmc4_b() -> MachineDescription {
    let mut errors = BTreeMap::new();
    linear_motion(&mut errors, 'X', 8.0);
    linear_motion(&mut errors, 'Y', 8.0);
    linear_motion(&mut errors, 'Z', 8.0);
    rotary_motion(&mut errors, 'B');
    squareness(&mut errors);
    put(&mut errors, &["EX0B", "EZ0B"], 10.0);
    put(&mut errors, &["EA0B", "EC0B"], 20.0);
    put(&mut errors, &["EX0T", "EY0T"], 5.0);
    put(&mut errors, &["EZ0T"], 10.0);
    put(&mut errors, &["EB0W"], 20.0);
    MachineDescription {
        name: "hmc4-b".into(),
        description: "4-axis horizontal machining centre (Cheng et al. 2012): column X and \
                      headstock Y on the tool side, table Z carrying rotary table B on the \
                      workpiece side; 35 errors"
            .into(),
        workpiece: vec![
            linear('Z', 0.0, 700.0),
            rotary('B', 0.0, 360.0, [0.0, 0.0, 0.0]),
        ],
        tool: vec![linear('X', 0.0, 800.0), linear('Y', 0.0, 700.0)],
        tool_offset_mm: [0.0, 0.0, -150.0],
        errors,
    }
}

/// A 5-axis machine with an A/C cradle (43 errors).
pub fn cradle5_ac() -> MachineDescription {
    let mut errors = BTreeMap::new();
    linear_motion(&mut errors, 'X', 6.0);
    linear_motion(&mut errors, 'Y', 6.0);
    linear_motion(&mut errors, 'Z', 6.0);
    rotary_motion(&mut errors, 'A');
    rotary_motion(&mut errors, 'C');
    squareness(&mut errors);
    put(&mut errors, &["EY0A", "EZ0A", "EX0C", "EY0C"], 10.0);
    put(&mut errors, &["EB0A", "EC0A", "EA0C", "EB0C"], 20.0);
    put(&mut errors, &["EA0A", "EC0C"], 20.0);
    MachineDescription {
        name: "cradle5-ac".into(),
        description: "5-axis machine with an A/C cradle: table Y carries the cradle A (about \
                      X, line 150 mm below the tool reference point) which carries the rotary \
                      table C; X and Z on the tool side; 43 errors"
            .into(),
        workpiece: vec![
            linear('Y', -250.0, 250.0),
            rotary('A', -90.0, 90.0, [0.0, 0.0, -150.0]),
            rotary('C', 0.0, 360.0, [0.0, 0.0, 0.0]),
        ],
        tool: vec![linear('X', -300.0, 300.0), linear('Z', -300.0, 0.0)],
        tool_offset_mm: [0.0, 0.0, -100.0],
        errors,
    }
}
