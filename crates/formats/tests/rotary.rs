//! Rotary point-set reader (datasets contract, section 2): one test per rule (CSV and
//! sidecar), round trip.

use crate::common::{check, gzip};
use mtcal_formats::rotary::sidecar_name;
use mtcal_formats::{
    FormatError, Limits, read_rotary_points, read_rotary_points_path, write_rotary_points,
    write_rotary_sidecar,
};
use mtcal_solver::datasets::{RotaryPoint, RotaryPointSet};

const CSV: &str = "a_deg,c_deg,x_mm,y_mm,z_mm\n0,0,100,0,0\n0,90,0,100,0\n";
const SIDECAR: &str = "{\n  \"machine_id\": \"5AX-1\",\n  \"measured_at\": \"2026-11-02T08:30:00Z\",\n  \"nominal_radius_mm\": 100\n}\n";

fn read(csv: &str, sidecar: Option<&str>) -> Result<RotaryPointSet, FormatError> {
    read_rotary_points(
        "cradle.csv",
        csv.as_bytes(),
        sidecar.map(str::as_bytes),
        &Limits::default(),
    )
}

fn sidecar_err(sidecar: &str) -> FormatError {
    read(CSV, Some(sidecar)).expect_err("the sidecar must be rejected")
}

#[test]
fn reads_points_and_sidecar() {
    let set = read(CSV, Some(SIDECAR)).unwrap();
    assert_eq!(set.machine_id.as_deref(), Some("5AX-1"));
    assert_eq!(set.measured_at.as_deref(), Some("2026-11-02T08:30:00Z"));
    assert_eq!(set.nominal_radius_mm, Some(100.0));
    assert_eq!(set.points.len(), 2);
    assert_eq!(
        set.points[1],
        RotaryPoint {
            a_deg: 0.0,
            c_deg: 90.0,
            x_mm: 0.0,
            y_mm: 100.0,
            z_mm: 0.0,
            t_s: None
        }
    );
    let bare = read(CSV, None).unwrap();
    assert_eq!((bare.machine_id, bare.nominal_radius_mm), (None, None));
}

#[test]
fn sidecar_names() {
    assert_eq!(sidecar_name("cradle.csv"), "cradle.json");
    assert_eq!(sidecar_name("cradle.csv.gz"), "cradle.json");
    assert_eq!(sidecar_name("cradle"), "cradle.json");
}

#[test]
fn csv_rules() {
    let e = read("a_deg,c_deg,x_mm,y_mm\n0,0,1,1\n", None).unwrap_err();
    check(&e, "cradle.csv", 1, "z_mm", "required column is missing");
    let e = read("a_deg,b_deg,c_deg,x_mm,y_mm,z_mm\n0,0,0,1,1,1\n", None).unwrap_err();
    check(&e, "cradle.csv", 1, "b_deg", "unknown column");
    let e = read("a_deg,c_deg,x_mm,y_mm,z_mm\n0,0,1,1,NaN\n", None).unwrap_err();
    check(&e, "cradle.csv", 2, "z_mm", "must be finite");
    let e = read(
        "a_deg,c_deg,x_mm,y_mm,z_mm,t_s\n0,0,1,1,1,2\n0,0,1,1,1,1\n",
        None,
    )
    .unwrap_err();
    check(
        &e,
        "cradle.csv",
        3,
        "t_s",
        "strictly increasing within the file",
    );
    let e = read("a_deg,c_deg,x_mm,y_mm,z_mm\n", None).unwrap_err();
    check(&e, "cradle.csv", 1, "", "no points");
}

#[test]
fn sidecar_rules() {
    check(
        &sidecar_err("{\"machine_id\": \"M\""),
        "cradle.json",
        1,
        "",
        "invalid JSON",
    );
    let e = sidecar_err(&SIDECAR.replace("\"machine_id\": \"5AX-1\",", ""));
    check(
        &e,
        "cradle.json",
        1,
        "machine_id",
        "required field is missing",
    );
    let e = sidecar_err(&SIDECAR.replace("2026-11-02T08:30:00Z", "today"));
    check(
        &e,
        "cradle.json",
        3,
        "measured_at",
        "not an RFC 3339 time stamp",
    );
    let e = sidecar_err(&SIDECAR.replace("100", "-5"));
    check(
        &e,
        "cradle.json",
        4,
        "nominal_radius_mm",
        "must be a positive number",
    );
    let e = sidecar_err(&SIDECAR.replace("100", "\"100\""));
    check(
        &e,
        "cradle.json",
        4,
        "nominal_radius_mm",
        "must be a finite number",
    );
    let e = sidecar_err(&SIDECAR.replace("nominal_radius_mm", "radius"));
    check(&e, "cradle.json", 4, "radius", "unknown field");
    assert!(read(CSV, Some(&SIDECAR.replace("nominal_radius_mm", "x-radius"))).is_ok());
}

#[test]
fn path_reader_finds_the_sidecar_and_reads_gzip() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("cradle.csv.gz");
    std::fs::write(&p, gzip(CSV.as_bytes())).unwrap();
    let set = read_rotary_points_path(&p, &Limits::default()).unwrap();
    assert_eq!(set.machine_id, None);
    std::fs::write(dir.path().join("cradle.json"), SIDECAR).unwrap();
    let set = read_rotary_points_path(&p, &Limits::default()).unwrap();
    assert_eq!(set, read(CSV, Some(SIDECAR)).unwrap());
    std::fs::write(dir.path().join("cradle.json"), "{}").unwrap();
    let e = read_rotary_points_path(&p, &Limits::default()).unwrap_err();
    check(
        &e,
        "cradle.json",
        1,
        "machine_id",
        "required field is missing",
    );
}

#[test]
fn write_read_round_trip() {
    let set = RotaryPointSet {
        machine_id: Some("5AX-1".into()),
        measured_at: Some("2026-11-02T08:30:00Z".into()),
        nominal_radius_mm: Some(99.875),
        points: (0..48)
            .map(|i| {
                let (a, c) = ((i / 12) as f64 * -30.0, (i % 12) as f64 * 30.0);
                RotaryPoint {
                    a_deg: a,
                    c_deg: c,
                    x_mm: 100.0 * c.to_radians().cos() + 1e-4,
                    y_mm: 100.0 * c.to_radians().sin() * a.to_radians().cos(),
                    z_mm: 100.0 * c.to_radians().sin() * a.to_radians().sin(),
                    t_s: Some(2.5 * i as f64),
                }
            })
            .collect(),
    };
    let (mut csv, mut json) = (Vec::new(), Vec::new());
    write_rotary_points(&mut csv, &set).unwrap();
    write_rotary_sidecar(&mut json, &set).unwrap();
    let back = read_rotary_points("w.csv", &csv, Some(&json), &Limits::default()).unwrap();
    assert_eq!(back, set);
    let mut bad = set.clone();
    bad.points[3].t_s = None;
    assert!(write_rotary_points(Vec::new(), &bad).is_err());
    let mut bad = set;
    bad.machine_id = None;
    assert!(write_rotary_sidecar(Vec::new(), &bad).is_err());
}
