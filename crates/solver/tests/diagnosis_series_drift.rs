//! Drift-log diagnosis against truth: the real FL_THERMAL heat run (fixed 60/40 split,
//! asserted held-out improvement) and a simulated log with a known first-order response.

use mtcal_solver::datasets::{Channel, ChannelKind, DriftLog};
use mtcal_solver::diagnosis::Verdict;
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

/// Measured on this recording with the default options (fit on the first 60 %, judged on
/// the last 40 %): held-out RMS ch1 5.56 → 2.33, ch2 5.65 → 3.57, ch3 20.53 → 13.18,
/// ch4 20.04 → 6.96, ch5 10.80 → 8.44 µm; overall (quadratic mean) 14.16 → 7.89 µm, 69 %
/// of the held-out drift SSE predicted. The asserted margins sit below these so that small
/// numerical changes pass while a model that loses the spindle history or the
/// temperatures fails (the spindle-only or temperature-only candidates predict far less on
/// ch3 and ch5).
#[test]
fn fl_thermal_heat_run_explained_by_thermal_growth() {
    let log = read_heat_run();
    let r = diagnose_drift_log(&log, "FL_THERMAL", &SeriesOptions::default()).unwrap();
    for f in &r.findings {
        println!(
            "| {} | {:.2} | {:.2} | {:.0} % | {} |",
            f.axis.as_deref().unwrap_or(""),
            f.heldout_rms_um.before,
            f.heldout_rms_um.after,
            100.0 * f.parameters["share_predicted"],
            f.physics
        );
    }
    assert!(
        matches!(r.verdict, Verdict::Explained | Verdict::PartlyExplained),
        "{:?}",
        r.verdict
    );
    assert_eq!(r.source, "drift_log");
    // Every channel: thermal drift found, held-out RMS down by at least 15 %.
    assert_eq!(r.findings.len(), 5);
    for f in &r.findings {
        assert_eq!(f.effect, "thermal_drift");
        let gain = 1.0 - f.heldout_rms_um.after / f.heldout_rms_um.before;
        assert!(
            gain >= 0.15,
            "{:?}: held-out RMS only {:.0} % lower",
            f.axis,
            100.0 * gain
        );
    }
    // ch5 (axial spindle growth): driven by the spindle's running history.
    let ch5 = r
        .findings
        .iter()
        .find(|f| f.axis.as_deref() == Some("ch5"))
        .unwrap();
    assert!(ch5.physics.contains("spindle"), "{}", ch5.physics);
    assert!(
        ch5.heldout_rms_um.after <= 0.85 * ch5.heldout_rms_um.before,
        "{:?}",
        ch5.heldout_rms_um
    );
    assert!(ch5.parameters["share_predicted"] >= 0.30);
    // Overall: quadratic mean of the channels' held-out RMS down by at least 35 %, and at
    // least 60 % of the held-out drift (sum of squares) predicted.
    let after = (r
        .findings
        .iter()
        .map(|f| f.heldout_rms_um.after.powi(2))
        .sum::<f64>()
        / 5.0)
        .sqrt();
    assert!(
        after <= 0.65 * r.baseline.heldout_rms_um,
        "{after} vs {}",
        r.baseline.heldout_rms_um
    );
    assert!(1.0 - (after / r.baseline.heldout_rms_um).powi(2) >= 0.60);
    // The drift is far above the sample-to-sample noise: the rigid model cannot be right.
    assert!(r.baseline.heldout_rms_um > 50.0 * r.baseline.noise_estimate_um);
    // A plot per channel with the split marked.
    let p = r.plots.iter().find(|p| p.id == "drift_ch5").unwrap();
    assert!(p.series.iter().any(|s| s.name.contains("split")));
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
        assert!(!p.contains_key("tau2_s"), "one lag expected: {p:?}");
        assert!((p["tau1_s"] - tau).abs() <= 0.02 * tau, "{p:?}");
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
