//! Unit mistakes (docs/datasets.md, "Unit mistakes"): one test per mistake, each on a
//! realistic file written with the wrong unit and asserting the message (file, column and
//! what to change); the same data in the right unit is read.

use crate::common::check;
use mtcal_formats::session::read_plane_csv;
use mtcal_formats::{Limits, read_drift_log, read_positioning, read_rotary_points, read_upload};
use std::collections::BTreeMap;
use std::fmt::Write;

/// A line pass as a grid encoder records it at 3 m/min: deviations under 1 µm (a slow
/// error curve) plus noise of ~50 nm, positions in mm; `scale` multiplies the deviations
/// (1e-3: the same data written in mm), `pos_scale` the positions (1000: written in µm).
fn plane(scale: f64, pos_scale: f64) -> String {
    plane_at(scale, pos_scale, 0.01)
}

/// [`plane`] with samples `dt_s` apart (0.5 mm a sample: 0.01 s is 3 m/min).
fn plane_at(scale: f64, pos_scale: f64, dt_s: f64) -> String {
    let mut s = String::from("run,t_s,x_mm,y_mm,z_mm,du_um,dv_um\n");
    let mut noise = 0x2545_f491_4f6c_dd1d_u64;
    let mut gauss = || {
        noise = noise
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1);
        ((noise >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 0.17 // ≈ 50 nm RMS
    };
    for i in 0..=400 {
        let x = -100.0 + 0.5 * i as f64;
        let du = 0.6 * (x / 60.0).sin() + gauss();
        let dv = 0.8 * (x / 100.0) + gauss();
        writeln!(
            s,
            "1,{},{},0,0,{},{}",
            i as f64 * dt_s,
            x * pos_scale,
            du * scale,
            dv * scale
        )
        .unwrap();
    }
    s
}

#[test]
fn deviations_in_mm_where_um_are_required() {
    let lim = Limits::default();
    assert_eq!(
        read_plane_csv("xy.csv", plane(1.0, 1.0).as_bytes(), &lim).unwrap()[0].len(),
        401
    );
    let e = read_plane_csv("xy.csv", plane(1e-3, 1.0).as_bytes(), &lim).unwrap_err();
    check(&e, "xy.csv", 0, "du_um", "multiply the column by 1000");
    assert!(
        e.rule.contains("every value lies within ±0.001 µm")
            && e.rule.contains("millimetres in a micrometre column"),
        "{e}"
    );
    // Positioning runs: sub-µm deviations of a short, good axis written in mm.
    let mut csv = String::from("axis,run,direction,target_mm,deviation_um\n");
    for (k, dev_um) in [0.12, 0.29, 0.41, 0.56, 0.63, 0.79].iter().enumerate() {
        for dir in ["+", "-"] {
            let d = if dir == "+" { *dev_um } else { dev_um - 0.14 };
            writeln!(csv, "X,1,{dir},{},{}", 100 * k, d * 1e-3).unwrap();
        }
    }
    let e = read_positioning("pos.csv", csv.as_bytes(), &lim).unwrap_err();
    check(
        &e,
        "pos.csv",
        0,
        "deviation_um",
        "multiply the column by 1000",
    );
    // A drift log's displacement channel, the same.
    let mut log = String::from("t_s,spindle_um,t1_c\n");
    for i in 0..50 {
        let um = 0.9 * (1.0 - (-(i as f64) / 20.0).exp());
        writeln!(log, "{},{},{}", 60 * i, um * 1e-3, 20.0 + i as f64 * 0.05).unwrap();
    }
    let e = read_drift_log("drift.csv", log.as_bytes(), &lim).unwrap_err();
    check(
        &e,
        "drift.csv",
        0,
        "spindle_um",
        "multiply the column by 1000",
    );
    // An all-zero column is no unit mistake (no factor changes it).
    let zeros = "run,t_s,x_mm,y_mm,z_mm,du_um,dv_um\n1,0,0,0,0,0,0\n1,1,1,0,0,0,0\n1,2,2,0,0,0,0\n";
    read_plane_csv("xy.csv", zeros.as_bytes(), &lim).unwrap();
}

#[test]
fn a_noise_floor_of_a_real_instrument_keeps_small_deviations() {
    // A column within ±1 nm whose noise floor is above 1 nm (alternating ±1 nm: second
    // differences of 4 nm, floor 4/√6 ≈ 1.6 nm) is read: the rule needs both.
    let alternating = [0.001, -0.001, 0.001, -0.001];
    assert!(mtcal_formats::units::noise_floor([alternating.as_slice()]) > 1e-3);
    let csv = "run,t_s,x_mm,y_mm,z_mm,du_um,dv_um\n1,0,0,0,0,0.001,1\n1,1,1,0,0,-0.001,2\n\
               1,2,2,0,0,0.001,1\n1,3,3,0,0,-0.001,2\n";
    read_plane_csv("xy.csv", csv.as_bytes(), &Limits::default()).unwrap();
    // The noise floor of white noise is its σ: second differences of σ = 0.05 give 0.05.
    let mut x = 1u64;
    let v: Vec<f64> = (0..20_000)
        .map(|_| {
            // Sum of 12 uniforms − 6: a normal deviate of σ 1.
            (0..12)
                .map(|_| {
                    x = x.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
                    (x >> 11) as f64 / (1u64 << 53) as f64
                })
                .sum::<f64>()
                - 6.0
        })
        .map(|g| 0.05 * g + 1.0)
        .collect();
    let floor = mtcal_formats::units::noise_floor([v.as_slice()]);
    assert!((floor - 0.05).abs() < 0.002, "{floor}");
}

#[test]
fn positions_in_um_where_mm_are_required() {
    let lim = Limits::default();
    // A target of 500 000 mm (500 mm written in µm) is beyond the plausible position.
    let csv = "axis,run,direction,target_mm,deviation_um\nX,1,+,0,1.5\nX,1,+,500000,2.5\n";
    let e = read_positioning("pos.csv", csv.as_bytes(), &lim).unwrap_err();
    check(
        &e,
        "pos.csv",
        3,
        "target_mm",
        "micrometres where millimetres are required? divide the column by 1000",
    );
    // Within the bound, a test at 3 m/min written in µm moves at 3000 m/min: faster than
    // any machine traverses, refused by the reader (the CLI's and the service's).
    let e = read_plane_csv("xy.csv", plane(1.0, 1000.0).as_bytes(), &lim).unwrap_err();
    check(
        &e,
        "xy.csv",
        0,
        "x_mm",
        "the positions move at 50000 mm/s (3000 m/min) between samples (median over the runs), \
         faster than any machine tool axis traverses (200 m/min): micrometres where \
         millimetres are required? divide x_mm, y_mm and z_mm by 1000",
    );
    // The same test at 3 mm/min written in µm moves at a plausible 3 m/min: the machine's
    // travel tells: ±100 mm of X written in µm spans 200 000 "mm", 1000× the travel of a
    // machine registered with X [-100, 100].
    let json = r#"{"machine_id": "M", "measured_at": "2026-01-01T00:00:00Z",
      "planes": [{"file": "xy.csv", "plane": "XY", "head_offset_mm": [0, 0, 0]}]}"#;
    let upload = |pos_scale: f64| {
        read_upload(
            &[
                ("session.json".to_string(), json.as_bytes().to_vec()),
                (
                    "xy.csv".to_string(),
                    plane_at(1.0, pos_scale, 10.0).into_bytes(),
                ),
            ],
            &lim,
        )
        .unwrap()
    };
    let travel: BTreeMap<String, [f64; 2]> = [
        ("X".to_string(), [-100.0, 100.0]),
        ("Y".to_string(), [-100.0, 100.0]),
    ]
    .into();
    upload(1.0).check_travel(&travel).unwrap();
    let e = upload(1000.0).check_travel(&travel).unwrap_err();
    check(
        &e,
        "xy.csv",
        0,
        "x_mm",
        "the positions span 200000 mm, 1000× the machine's X travel of 200 mm (-100 to 100): \
         micrometres where millimetres are required? divide the column by 1000",
    );
    // Positioning runs: the span of the targets of the axis.
    let csv = "axis,run,direction,target_mm,deviation_um\nX,1,+,0,1.5\nX,1,+,90000,2.5\n";
    let d = read_upload(&[("pos.csv".to_string(), csv.as_bytes().to_vec())], &lim).unwrap();
    let e = d.check_travel(&travel).unwrap_err();
    check(&e, "pos.csv", 0, "target_mm", "450× the machine's X travel");
    // A machine without a registered travel is not checked.
    d.check_travel(&BTreeMap::new()).unwrap();
}

#[test]
fn angles_in_radians_where_degrees_are_required() {
    let lim = Limits::default();
    // A cradle check: A at 0, −45, −90; C through a full turn in 30° steps.
    let mut deg = String::from("a_deg,c_deg,x_mm,y_mm,z_mm\n");
    let mut rad = deg.clone();
    for a in [0.0f64, -45.0, -90.0] {
        for k in 0..12 {
            let c = 30.0 * k as f64;
            let (x, y) = (100.0 * c.to_radians().cos(), 100.0 * c.to_radians().sin());
            writeln!(deg, "{a},{c},{x},{y},0").unwrap();
            writeln!(rad, "{},{},{x},{y},0", a.to_radians(), c.to_radians()).unwrap();
        }
    }
    assert_eq!(
        read_rotary_points("cradle.csv", deg.as_bytes(), None, &lim)
            .unwrap()
            .points
            .len(),
        36
    );
    let e = read_rotary_points("cradle.csv", rad.as_bytes(), None, &lim).unwrap_err();
    check(
        &e,
        "cradle.csv",
        0,
        "c_deg",
        "these look like radians in a degree column; multiply a_deg and c_deg by 180/π",
    );
    // Small A tilts with C held still are degrees.
    let small = "a_deg,c_deg,x_mm,y_mm,z_mm\n-5,0,100,0,0\n0,0,100,0,0\n5,0,100,0,0\n";
    read_rotary_points("cradle.csv", small.as_bytes(), None, &lim).unwrap();
}
