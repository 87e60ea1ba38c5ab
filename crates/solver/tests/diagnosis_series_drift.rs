//! Drift-log diagnosis against truth: the real FL_THERMAL heat run (fitted on the first
//! 60 %, against the dataset authors' own reference model on both later windows) and a simulated log with a known first-order response.

use mtcal_solver::datasets::{Channel, ChannelKind, DriftLog};
use mtcal_solver::diagnosis::Verdict;
use mtcal_solver::diagnosis::series::drift::{
    ChannelPrediction, diagnose_drift_log_with_predictions,
};
use mtcal_solver::diagnosis::series::{SeriesOptions, diagnose_drift_log};

/// Minimal reader for the drift-log CSV (the strict reader lives in mtcal-formats, which
/// depends on this crate).
fn read_heat_run() -> DriftLog {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../data/fl_thermal/heat_run.csv"
    );
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
        channels.push(Channel {
            name: name.to_string(),
            kind,
            values,
        });
    }
    DriftLog { t_s, channels }
}

/// The dataset authors' best model (seq2seq on the 16 temperatures; data/fl_thermal/
/// SOURCE.md) reports test MAE 3.56, 3.76, 3.70, 3.46 and 4.28 µm on ch1–ch5, trained on
/// rows 0–60 % and scored on rows 60–80 %. The diagnosis fits on rows 0–60 % only (model
/// and penalty chosen there by rolling-origin cross-validation) and must beat those
/// figures on every channel, on rows 60–80 % and on rows 80–100 % (which the reference
/// used to choose its epochs). Measured with the default options: MAE 1.25 / 2.02,
/// 1.21 / 2.81, 2.05 / 0.93, 1.61 / 0.81, 2.58 / 1.53 µm (60–80 % / 80–100 %).
#[test]
fn fl_thermal_beats_the_reference_model_on_every_channel_and_window() {
    const REFERENCE_MAE_UM: [f64; 5] = [3.56, 3.76, 3.70, 3.46, 4.28];
    let log = read_heat_run();
    let n = log.t_s.len();
    let (i60, i80) = (n * 6 / 10, n * 8 / 10);
    let (r, pred) =
        diagnose_drift_log_with_predictions(&log, "FL_THERMAL", &SeriesOptions::default()).unwrap();
    assert_eq!(pred.n_fit, i60);
    assert_eq!(pred.channels.len(), 5);
    let mae = |c: &ChannelPrediction, rows: std::ops::Range<usize>| {
        let k = rows.len() as f64;
        rows.map(|i| (c.measured_um[i] - c.model_um[i]).abs())
            .sum::<f64>()
            / k
    };
    let mut failures = vec![];
    for (c, reference) in pred.channels.iter().zip(REFERENCE_MAE_UM) {
        let (a, b) = (mae(c, i60..i80), mae(c, i80..n));
        println!(
            "| {} | {reference:.2} | {a:.2} | {b:.2} |",
            c.name.trim_end_matches("_um")
        );
        assert!(c.thermal_model, "{}: no thermal model kept", c.name);
        if a >= reference || b >= reference {
            failures.push(format!("{}: {a:.2} / {b:.2} vs {reference}", c.name));
        }
    }
    assert!(failures.is_empty(), "reference not beaten: {failures:?}");
    assert!(
        matches!(r.verdict, Verdict::Explained | Verdict::PartlyExplained),
        "{:?}",
        r.verdict
    );
    assert_eq!(r.source, "drift_log");
    assert_eq!(r.findings.len(), 5);
    // The drift is far above the sample-to-sample noise: the rigid model cannot be right.
    assert!(r.baseline.heldout_rms_um > 50.0 * r.baseline.noise_estimate_um);
    for f in &r.findings {
        assert_eq!(f.effect, "thermal_drift");
        // Names, units and signs are those of the effects table.
        mtcal_solver::diagnosis::effects::conforms(f).unwrap();
        // Every reported parameter is determined by the one rule of every diagnosis,
        // |value| ≥ 2 std; the rest is listed as undetermined, with what would decide it.
        for (k, v) in &f.parameters {
            if let Some(sd) = f.parameters.get(&format!("std_{k}")) {
                assert!(v.abs() >= 2.0 * sd, "{:?} {k} = {v} ± {sd}", f.axis);
            }
        }
        for u in &f.undetermined {
            assert!(u.std.is_none_or(|sd| u.value.abs() < 2.0 * sd), "{u:?}");
            assert!(!f.parameters.contains_key(&u.name), "{u:?}");
            assert!(u.decide.contains("would decide"), "{u:?}");
        }
    }
    // The prediction export covers every sample and agrees with the plotted model.
    assert!(pred.channels.iter().all(|c| c.model_um.len() == n));
    let p = r.plots.iter().find(|p| p.id == "drift_ch5").unwrap();
    assert!(p.series.iter().any(|s| s.name.contains("split")));
}

/// `fit_fraction` moves the split: fitted on the first 70 %, the held-out part is the
/// last 30 %, the export marks the same rows, and the model still predicts most of the
/// held-out drift of every channel.
#[test]
fn fit_fraction_moves_the_split() {
    let log = read_heat_run();
    let opts = SeriesOptions {
        train_fraction: 0.7,
        ..SeriesOptions::default()
    };
    let (r, pred) = diagnose_drift_log_with_predictions(&log, "FL_THERMAL", &opts).unwrap();
    assert_eq!(pred.n_fit, log.t_s.len() * 7 / 10);
    for f in &r.findings {
        assert!(
            f.heldout_rms_um.after < 0.5 * f.heldout_rms_um.before,
            "{:?}: {:?}",
            f.axis,
            f.heldout_rms_um
        );
    }
    let bad = SeriesOptions {
        train_fraction: 0.95,
        ..SeriesOptions::default()
    };
    assert!(diagnose_drift_log_with_predictions(&log, "x", &bad).is_err());
}

/// A simulated log with a known first-order response to the spindle speed (24 h, 30 s
/// sampling, 0.1 µm noise): τ within 2 % and the gain within 1 % (the reported standard
/// uncertainties are ≈ 0.1 % and 0.05 %), held-out RMS down to 1.5 × the noise.
#[test]
fn simulated_first_order_response_recovered() {
    use mtcal_solver::diagnosis::series::simulate::{DriftSim, simulate_drift_log};
    for (seed, tau, gain) in [(1u64, 5400.0, 20.0), (2, 2400.0, -12.0), (3, 9000.0, 30.0)] {
        let cfg = DriftSim {
            tau_s: tau,
            gain_um: gain,
            seed,
            ..Default::default()
        };
        let r = diagnose_drift_log(&simulate_drift_log(&cfg), "sim", &SeriesOptions::default())
            .unwrap();
        let f = r
            .findings
            .iter()
            .find(|f| f.axis.as_deref() == Some("ch1"))
            .expect("ch1 finding");
        let p = &f.parameters;
        assert!(
            !p.contains_key("tau2_s"),
            "one lag expected: {p:?} {:?}",
            f.undetermined
        );
        assert!(
            (p["tau1_s"] - tau).abs() <= 0.02 * tau,
            "{p:?} {:?}",
            f.undetermined
        );
        assert!((p["gain1_um"] - gain).abs() <= 0.01 * gain.abs(), "{p:?}");
        assert_eq!(p["rpm_exponent"], 1.0);
        assert!(
            f.heldout_rms_um.after <= 1.5 * cfg.noise_um,
            "{:?}",
            f.heldout_rms_um
        );
        assert_eq!(r.verdict, Verdict::Explained);
    }
}

#[test]
fn flat_log_is_consistent() {
    use mtcal_solver::diagnosis::series::simulate::{DriftSim, simulate_drift_log};
    let cfg = DriftSim {
        gain_um: 0.0,
        ..Default::default()
    };
    let r =
        diagnose_drift_log(&simulate_drift_log(&cfg), "sim", &SeriesOptions::default()).unwrap();
    assert_eq!(r.verdict, Verdict::Consistent, "{r:#?}");
}

#[test]
fn rejects_time_going_backwards_and_missing_outputs() {
    use mtcal_solver::diagnosis::series::simulate::{DriftSim, simulate_drift_log};
    let mut log = simulate_drift_log(&DriftSim::default());
    log.t_s[10] = log.t_s[9];
    let e = diagnose_drift_log(&log, "sim", &SeriesOptions::default()).unwrap_err();
    assert!(e.to_string().contains("strictly increasing"), "{e}");
    let mut log = simulate_drift_log(&DriftSim::default());
    log.channels
        .retain(|c| c.kind != ChannelKind::DisplacementUm);
    let e = diagnose_drift_log(&log, "sim", &SeriesOptions::default()).unwrap_err();
    assert!(e.to_string().contains("no displacement channel"), "{e}");
}

/// Progress over two displacement channels: fractions start at 0, never decrease and end
/// at 1 with `done`; each channel's phases come in order, ch1's before ch2's; the result
/// and predictions are those without a callback.
#[test]
fn progress_is_monotone_over_the_channels_and_ends_at_one() {
    use mtcal_solver::diagnosis::series::drift::diagnose_drift_log_with_progress;
    use mtcal_solver::diagnosis::series::simulate::{DriftSim, simulate_drift_log};
    let mut log = simulate_drift_log(&DriftSim {
        duration_s: 12.0 * 3600.0,
        ..Default::default()
    });
    let ch1 = log.channels.iter().find(|c| c.name == "ch1_um").unwrap();
    let ch2 = Channel {
        name: "ch2_um".into(),
        kind: ChannelKind::DisplacementUm,
        values: ch1.values.iter().map(|v| -0.5 * v).collect(),
    };
    log.channels.push(ch2);
    let opts = SeriesOptions::default();
    let mut seen: Vec<(String, f64)> = Vec::new();
    let r = diagnose_drift_log_with_progress(&log, "sim", &opts, &mut |p: &str, f: f64| {
        seen.push((p.to_string(), f))
    })
    .unwrap();
    assert_eq!(
        r,
        diagnose_drift_log_with_predictions(&log, "sim", &opts).unwrap()
    );
    let order = crate::progress_common::check(
        &seen,
        &[
            "ch1_um: thermal model",
            "ch1_um: round 1 of candidates",
            "ch2_um: thermal model",
            "ch2_um: round 1 of candidates",
        ],
    );
    // Half of the work is done when the second of two channels starts.
    assert_eq!(seen[order[2]].1, 0.5, "{seen:?}");
}
