//! Positioning-run reader (datasets contract, section 3): one test per rule, round trip.

use crate::common::check;
use mtcal_formats::{
    FormatError, Limits, read_positioning, read_positioning_path, write_positioning,
};
use mtcal_solver::Axis;
use mtcal_solver::datasets::{Direction, PositioningRecord, PositioningRuns};

const HEADER: &str = "axis,run,direction,target_mm,deviation_um";

fn err(csv: &str) -> FormatError {
    read_positioning("pos.csv", csv.as_bytes(), &Limits::default()).expect_err("must be rejected")
}

#[test]
fn reads_valid_runs() {
    let csv = "# ISO 230-2, X axis\nrun,axis,direction,deviation_um,target_mm,t_s,temp_c,x-op\n\
               1,X,+,1.5,0,0,20.1,a\n1,X,+,2.5,100,10,20.1,a\n1,X,-,-0.5,100,20,20.2,\n2,X,+,1.0,0,5,20.3,\n";
    let runs = read_positioning("pos.csv", csv.as_bytes(), &Limits::default()).unwrap();
    assert_eq!(runs.records.len(), 4);
    assert_eq!(
        runs.records[2],
        PositioningRecord {
            axis: Axis::X,
            run: 1,
            direction: Direction::Minus,
            target_mm: 100.0,
            deviation_um: -0.5,
            t_s: Some(20.0),
            temp_c: Some(20.2),
        }
    );
    // Time restarts in a new run.
    assert_eq!(runs.records[3].t_s, Some(5.0));
}

#[test]
fn axis_must_be_x_y_or_z() {
    let e = err(&format!("{HEADER}\nX,1,+,0,0\nW,1,+,0,0\n"));
    check(&e, "pos.csv", 3, "axis", "`W` is not an axis (X, Y or Z)");
}

#[test]
fn direction_must_be_plus_or_minus() {
    let e = err(&format!("{HEADER}\nX,1,up,0,0\n"));
    check(
        &e,
        "pos.csv",
        2,
        "direction",
        "`up` is not a direction (+ or -)",
    );
}

#[test]
fn run_must_be_an_integer() {
    check(
        &err(&format!("{HEADER}\nX,one,+,0,0\n")),
        "pos.csv",
        2,
        "run",
        "`one` is not an integer",
    );
}

#[test]
fn numbers_finite() {
    check(
        &err(&format!("{HEADER}\nX,1,+,inf,0\n")),
        "pos.csv",
        2,
        "target_mm",
        "must be finite",
    );
    check(
        &err(&format!("{HEADER}\nX,1,+,0,\n")),
        "pos.csv",
        2,
        "deviation_um",
        "empty cell",
    );
}

#[test]
fn time_strictly_increasing_within_axis_and_run() {
    let e = err(&format!(
        "{HEADER},t_s\nX,1,+,0,0,1\nX,2,+,0,0,0\nX,1,-,0,0,0.5\n"
    ));
    check(
        &e,
        "pos.csv",
        4,
        "t_s",
        "strictly increasing within axis X run 1: 0.5 follows 1",
    );
}

#[test]
fn columns_required_known_unique() {
    check(
        &err("axis,run,direction,target_mm\nX,1,+,0\n"),
        "pos.csv",
        1,
        "deviation_um",
        "required column is missing",
    );
    check(
        &err(&format!("{HEADER},speed\nX,1,+,0,0,1\n")),
        "pos.csv",
        1,
        "speed",
        "unknown column",
    );
    check(
        &err(&format!("{HEADER},run\n")),
        "pos.csv",
        1,
        "run",
        "duplicate column name",
    );
    check(&err(&format!("{HEADER}\n")), "pos.csv", 1, "", "no rows");
}

#[test]
fn path_reader_and_utf8() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("p.csv");
    std::fs::write(&p, format!("{HEADER}\nY,1,-,0,0\n")).unwrap();
    let runs = read_positioning_path(&p, &Limits::default()).unwrap();
    assert_eq!(runs.records[0].axis, Axis::Y);
    std::fs::write(
        &p,
        b"axis,run,direction,target_mm,deviation_um\nY,1,-,0,\xe9\n",
    )
    .unwrap();
    let e = read_positioning_path(&p, &Limits::default()).unwrap_err();
    check(
        &e,
        "p.csv",
        2,
        "",
        "not valid UTF-8 (invalid byte at character 9 of the line)",
    );
    let e = read_positioning_path(&dir.path().join("missing.csv"), &Limits::default()).unwrap_err();
    check(&e, "missing.csv", 0, "", "cannot read file");
}

#[test]
fn write_read_round_trip() {
    let records = (0..40)
        .map(|i| PositioningRecord {
            axis: [Axis::X, Axis::Z][i / 20],
            run: (i % 20 / 10) as i64 + 1,
            direction: if i % 2 == 0 {
                Direction::Plus
            } else {
                Direction::Minus
            },
            target_mm: 12.5 * (i % 10) as f64,
            deviation_um: (i as f64 * 0.37).sin() * 3.3,
            t_s: Some(i as f64 * 1.1),
            temp_c: Some(20.0 + 0.01 * i as f64),
        })
        .collect();
    let runs = PositioningRuns { records };
    let mut buf = Vec::new();
    write_positioning(&mut buf, &runs).unwrap();
    assert_eq!(
        read_positioning("w.csv", &buf, &Limits::default()).unwrap(),
        runs
    );
    let mut bad = runs.clone();
    bad.records[5].t_s = None;
    assert!(write_positioning(Vec::new(), &bad).is_err());
    let mut bad = runs;
    bad.records[5].deviation_um = f64::NAN;
    assert!(write_positioning(Vec::new(), &bad).is_err());
}

/// Deviations in mm or targets in µm beyond the plausibility bounds are refused at their
/// cell (a target of 500 000 mm is a unit mistake).
#[test]
fn implausible_targets_and_deviations_are_refused() {
    let e = err(&format!("{HEADER}\nX,1,+,500000,1.5\n"));
    check(&e, "pos.csv", 2, "target_mm", "plausible position (mm)");
    let e = err(&format!("{HEADER}\nX,1,+,100,2e7\n"));
    check(&e, "pos.csv", 2, "deviation_um", "plausible deviation (µm)");
}
