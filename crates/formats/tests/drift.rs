//! Drift-log reader (datasets contract, section 4): the real heat run, one test per rule,
//! round trip.

use crate::common::{check, gzip};
use mtcal_formats::drift::channel_kind;
use mtcal_formats::{Limits, read_drift_log, read_drift_log_path, write_drift_log};
use mtcal_solver::datasets::{Channel, ChannelKind, DriftLog};
use std::path::PathBuf;

fn heat_run() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data/fl_thermal/heat_run.csv")
}

fn err(csv: &str) -> mtcal_formats::FormatError {
    read_drift_log("log.csv", csv.as_bytes(), &Limits::default()).expect_err("must be rejected")
}

#[test]
fn reads_the_real_heat_run() {
    let log = read_drift_log_path(&heat_run(), &Limits::default()).unwrap();
    // 22 channels: spindle_rpm, ch1..ch5 (µm), t1..t16 (°C); 11 115 rows at 15 s.
    assert_eq!(log.channels.len(), 22);
    assert_eq!(log.t_s.len(), 11_115);
    assert!(log.t_s.windows(2).all(|w| w[1] - w[0] == 15.0));
    assert_eq!(log.t_s.last(), Some(&166_710.0));
    let count = |k| log.channels.iter().filter(|c| c.kind == k).count();
    assert_eq!(count(ChannelKind::DisplacementUm), 5);
    assert_eq!(count(ChannelKind::TemperatureC), 16);
    assert_eq!(count(ChannelKind::SpeedRpm), 1);
    assert_eq!(log.channels[0].name, "spindle_rpm");
    // First and last values as in the file.
    assert_eq!(log.channels[1].name, "ch1_um");
    assert_eq!(log.channels[1].values[0], 0.3775);
    assert_eq!(log.channels[5].values.last(), Some(&14.0461));
    assert!(log.channels.iter().all(|c| c.values.len() == log.t_s.len()));
    // The same file gzip-compressed reads the same.
    let raw = std::fs::read(heat_run()).unwrap();
    let gz = read_drift_log("heat_run.csv.gz", &gzip(&raw), &Limits::default()).unwrap();
    assert_eq!(gz, log);
}

#[test]
fn channel_kinds_from_suffix() {
    assert_eq!(channel_kind("ch5_um"), Some(ChannelKind::DisplacementUm));
    assert_eq!(channel_kind("t1_c"), Some(ChannelKind::TemperatureC));
    assert_eq!(channel_kind("spindle_rpm"), Some(ChannelKind::SpeedRpm));
    assert_eq!(channel_kind("x_mm"), Some(ChannelKind::PositionMm));
    assert_eq!(channel_kind("_um"), None);
    assert_eq!(channel_kind("temp"), None);
}

#[test]
fn unknown_column_rejected_unless_x_prefixed() {
    check(
        &err("t_s,ch1_um,load_kw\n0,1,2\n"),
        "log.csv",
        1,
        "load_kw",
        "unknown column",
    );
    check(
        &err("t_s,_um\n0,1\n"),
        "log.csv",
        1,
        "_um",
        "unknown column",
    );
    let ok = read_drift_log(
        "log.csv",
        b"t_s,ch1_um,x-load_kw\n0,1,2\n",
        &Limits::default(),
    );
    assert_eq!(ok.unwrap().channels.len(), 1);
}

#[test]
fn t_s_required_and_a_channel_required() {
    check(
        &err("ch1_um\n1\n"),
        "log.csv",
        1,
        "t_s",
        "required column is missing",
    );
    check(
        &err("# c\nt_s,x-a\n0,1\n"),
        "log.csv",
        2,
        "",
        "at least one channel",
    );
}

#[test]
fn time_strictly_increasing() {
    let e = err("t_s,ch1_um\n0,1\n15,1\n# pause\n15,2\n");
    check(
        &e,
        "log.csv",
        5,
        "t_s",
        "strictly increasing within the file: 15 follows 15",
    );
}

#[test]
fn values_finite_decimal() {
    check(
        &err("t_s,ch1_um\n0,nan\n"),
        "log.csv",
        2,
        "ch1_um",
        "must be finite",
    );
    check(
        &err("t_s,ch1_um\n0,\n"),
        "log.csv",
        2,
        "ch1_um",
        "empty cell",
    );
    check(
        &err("t_s,ch1_um\n0,1;2\n"),
        "log.csv",
        2,
        "ch1_um",
        "not a decimal number",
    );
}

#[test]
fn header_and_rows_required() {
    check(&err("\n# nothing\n"), "log.csv", 3, "", "header required");
    check(&err("t_s,ch1_um\n"), "log.csv", 1, "", "no rows");
    check(
        &err("t_s,ch1_um\n0,1,2\n"),
        "log.csv",
        2,
        "",
        "row has 3 fields",
    );
}

#[test]
fn limits() {
    let limits = Limits {
        max_samples_per_file: 1,
        ..Limits::default()
    };
    let e = read_drift_log("log.csv", b"t_s,ch1_um\n0,1\n1,1\n", &limits).unwrap_err();
    check(&e, "log.csv", 3, "", "exceeds the limit of 1 samples");
    let limits = Limits {
        max_bytes: 10,
        ..Limits::default()
    };
    let e = read_drift_log("log.csv", b"t_s,ch1_um\n0,1\n1,1\n", &limits).unwrap_err();
    check(&e, "log.csv", 0, "", "exceeds the byte limit");
}

#[test]
fn write_read_round_trip() {
    let log = DriftLog {
        t_s: (0..100).map(|i| 15.0 * i as f64 + 0.125).collect(),
        channels: vec![
            Channel {
                name: "ch1_um".into(),
                kind: ChannelKind::DisplacementUm,
                values: (0..100).map(|i| (i as f64).sqrt() / 7.0).collect(),
            },
            Channel {
                name: "spindle_rpm".into(),
                kind: ChannelKind::SpeedRpm,
                values: vec![5000.0; 100],
            },
            Channel {
                name: "t1_c".into(),
                kind: ChannelKind::TemperatureC,
                values: (0..100).map(|i| 20.0 + 1e-3 * i as f64).collect(),
            },
            Channel {
                name: "z_mm".into(),
                kind: ChannelKind::PositionMm,
                values: vec![-1e-12; 100],
            },
        ],
    };
    let mut buf = Vec::new();
    write_drift_log(&mut buf, &log).unwrap();
    assert_eq!(
        read_drift_log("w.csv", &buf, &Limits::default()).unwrap(),
        log
    );
    let mut bad = log.clone();
    bad.channels[0].kind = ChannelKind::TemperatureC;
    assert!(write_drift_log(Vec::new(), &bad).is_err());
    let mut bad = log;
    bad.t_s[3] = bad.t_s[2];
    assert!(write_drift_log(Vec::new(), &bad).is_err());
}
