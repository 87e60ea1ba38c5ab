//! Compensation exports: golden files against the published layouts, hand-worked values,
//! round trips of every format, and results whose terms the data could not determine.
//!
//! Where the layouts come from:
//! * ISG CSV: ISG kernel documentation, "ISG CSV format" (also Beckhoff TF5280,
//!   Volumetric Compensation): `//` comments, `#` file breaks, a header `X EXX EYX EZX
//!   EAX EBX ECX` over blank-separated records, a position-error block `C0Y …`; units
//!   mm and rad, arguments mm ("Units of measure").
//! * Etalon: ISG kernel documentation, "Etalon Exchange Format" (Vendor variant):
//!   `[C0Y]` / `VALUE = v` blocks and `[EXY]` / `Gridpoints = {` / `argument value` …
//!   / `}  // end of EXY`.
//! * Heidenhain: no complete published example of a KinematicsComp `*.COM` file was
//!   found; the layout follows the iTNC 530 HSCI Technical Manual's description (columns
//!   C1…C6 of a linear axis's COM file = EXX, EYX, EZX, EAX, EBX, ECX; TNC table framing
//!   `BEGIN … MM` / `[END]`). The golden file pins mtcal's own layout.
//! * plain CSV: mtcal's own layout (docs/compensation.md).
//!
//! Golden files: `tests/golden/compensation.*`; `UPDATE_GOLDEN=1` rewrites them.

use mtcal_formats::compensation::{Compensation, ExportError, Format};
use mtcal_solver::identification::{
    FitSummary, IdentificationResult, IdentifyOptions, Method, ModelInfo, Nuisance, Observability,
    SquarenessReport, TermReport, identify,
};
use mtcal_solver::simulate::{Plan, SimOptions, random_truth, simulate};
use mtcal_solver::terms::Term;
use std::collections::BTreeMap;
use std::path::PathBuf;

/// A hand-made result: X measured over [−20, 20] mm, Y over [0, 30] mm, Z not moved.
/// EXX = 0.01 q µm, EYX = 0.001 q² µm (raw), EAX = 0.05 q µrad, EYY = −0.02 q + 1e-4 q²
/// µm; EZX not identifiable; EC0Y = 12.5 µrad, EB0Z and EA0Z not identifiable.
fn hand_result() -> IdentificationResult {
    let mut terms = BTreeMap::new();
    let coeffs: BTreeMap<&str, Vec<f64>> = BTreeMap::from([
        ("EXX", vec![0.01]),
        ("EYX", vec![0.0, 1e-3]),
        ("EAX", vec![0.05]),
        ("EYY", vec![-0.02, 1e-4]),
    ]);
    for t in Term::all() {
        let c = coeffs.get(t.code()).cloned().unwrap_or_default();
        terms.insert(
            t.name(),
            TermReport {
                unit: t.unit().into(),
                positions_mm: vec![],
                values: vec![],
                std: vec![],
                identifiable: !c.is_empty(),
                confounded_with: vec![],
                coefficients: c,
                coefficient_covariance: vec![],
            },
        );
    }
    let sq = |v: Option<f64>| SquarenessReport {
        value_urad: v,
        std_urad: v.map(|_| 0.5),
        identifiable: v.is_some(),
        confounded_with: vec![],
        reported_as: v.map(|_| "ls_axis_lines".into()),
    };
    IdentificationResult {
        kind: "identification".into(),
        machine_id: "vmc-golden".into(),
        measured_at: "2026-11-24T08:00:00Z".into(),
        convention: mtcal_solver::identification::CONVENTION.into(),
        method: Method::Joint,
        model: ModelInfo {
            basis: Default::default(),
            order: 3,
            measured_travel_mm: BTreeMap::from([
                ("X".into(), [-20.0, 20.0]),
                ("Y".into(), [0.0, 30.0]),
            ]),
        },
        terms,
        squareness: BTreeMap::from([
            ("EC0Y".into(), sq(Some(12.5))),
            ("EB0Z".into(), sq(None)),
            ("EA0Z".into(), sq(None)),
        ]),
        observability: Observability {
            parameters: 51,
            rank: 10,
            condition_number: 1.0,
            identifiable: vec![],
            not_identifiable: vec![],
            confounded: vec![],
            advice: vec![],
        },
        fit: FitSummary {
            samples: 0,
            residual_rms_um: 0.0,
            noise_estimate_um: None,
            noise_pass_differences_um: None,
        },
        nuisance: Nuisance {
            mountings: BTreeMap::new(),
            runs: 0,
        },
        reporting: vec![],
        standards: Default::default(),
        circles: vec![],
        residuals: vec![],
        model_check: None,
        conditions: Default::default(),
        explained: None,
    }
}

fn golden(name: &str, text: &str) {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/golden")
        .join(name);
    if std::env::var_os("UPDATE_GOLDEN").is_some() {
        std::fs::write(&path, text).unwrap();
    }
    let want = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("{}: {e} (UPDATE_GOLDEN=1 writes it)", path.display()));
    assert_eq!(text, want, "{name} differs from its golden file");
}

fn file_name(f: Format) -> String {
    format!("compensation.{}.{}", f.name(), f.extension())
}

/// Values worked by hand from the hand-made result, step 10 mm.
#[test]
fn hand_worked_values() {
    let c = Compensation::from_result(&hand_result(), 10.0, false).unwrap();
    let x = &c.axes[0];
    assert_eq!(x.positions_mm, [-20.0, -10.0, 0.0, 10.0, 20.0]);
    let names: Vec<&str> = x.columns.iter().map(|c| c.term.as_str()).collect();
    assert_eq!(names, ["EXX", "EYX", "EAX"]);
    // EXX(−20) = 0.01 · (−20) µm = −0.0002 mm.
    assert!((x.columns[0].values[0] + 0.0002).abs() < 1e-15);
    // EYX = 0.001 q² about its least-squares line over [−20, 20]: the line of q² on a
    // symmetric interval is its mean h²/3 = 400/3 (slope 0), so EYX(−20) =
    // 0.001 (400 − 400/3) µm = 0.26667e-3 mm and EYX(0) = −0.13333e-3 mm.
    assert!((x.columns[1].values[0] - 0.001 * (400.0 - 400.0 / 3.0) * 1e-3).abs() < 1e-12);
    assert!((x.columns[1].values[2] + 0.001 * (400.0 / 3.0) * 1e-3).abs() < 1e-12);
    // EAX(10) = 0.5 µrad = 5e-7 rad.
    assert!((x.columns[2].values[3] - 5e-7).abs() < 1e-18);
    let y = &c.axes[1];
    assert_eq!(y.positions_mm, [0.0, 10.0, 20.0, 30.0]);
    // EYY(30) = −0.6 + 0.09 = −0.51 µm.
    assert!((y.columns[0].values[3] + 0.51e-3).abs() < 1e-15);
    assert_eq!(c.squareness.len(), 1);
    assert_eq!(c.squareness[0].0, "EC0Y");
    assert!((c.squareness[0].1 - 12.5e-6).abs() < 1e-18);
    for left in ["EZX", "EXZ", "EZZ", "ECZ", "EB0Z", "EA0Z", "EXY"] {
        assert!(
            c.not_identifiable.iter().any(|n| n == left),
            "{left}: {:?}",
            c.not_identifiable
        );
    }
    // A step that lands past the end still ends on it: [0, 30] at 7 mm.
    let c7 = Compensation::from_result(&hand_result(), 7.0, false).unwrap();
    assert_eq!(c7.axes[1].positions_mm, [0.0, 7.0, 14.0, 21.0, 28.0, 30.0]);
}

/// Each format against its golden file, and the published layout's shape.
#[test]
fn golden_files_and_published_shapes() {
    let c = Compensation::from_result(&hand_result(), 10.0, false).unwrap();
    for f in Format::ALL {
        golden(&file_name(f), &f.write(&c));
    }
    let isg = Format::Isg.write(&c);
    let lines: Vec<&str> = isg.lines().filter(|l| !l.starts_with("//")).collect();
    // Position errors first (header of names without E, one record), then a file break
    // and the component errors of X under the argument X, as in the ISG example.
    assert_eq!(lines[0], "C0Y");
    assert_eq!(lines[1], "0.000012500000");
    assert_eq!(lines[2], "#");
    assert_eq!(lines[3], "X EXX EYX EAX");
    assert_eq!(lines[4].split_whitespace().count(), 4);
    assert!(
        isg.contains("// sign: the values are the machine's errors"),
        "{isg}"
    );
    let etalon = Format::Etalon.write(&c);
    assert!(
        etalon.contains("[C0Y]\nVALUE = 0.000012500000\n"),
        "{etalon}"
    );
    assert!(
        etalon.contains("[EXX]\nGridpoints = {\n-20.000000 -0.000200000\n"),
        "{etalon}"
    );
    assert!(etalon.contains("}  // end of EXX\n"), "{etalon}");
    let heid = Format::Heidenhain.write(&c);
    assert!(heid.contains("BEGIN X.COM MM\nNR"), "{heid}");
    assert!(
        heid.contains("; X.COM columns: C1 = EXX, C2 = EYX, C4 = EAX"),
        "{heid}"
    );
    assert_eq!(heid.matches("[END]").count(), 2);
    let csv = Format::Csv.write(&c);
    assert!(csv.contains(
        "\nterm,axis,position_mm,error,unit,error_forward,error_reverse\nEXX,X,-20.000000,-0.200000,um,,\n"
    ));
    assert!(csv.contains("\nEC0Y,,,12.500000,urad,,\n"));
    // LinuxCNC (INI manual, [JOINT_n] COMP_FILE): triplets first, nominal ascending, the
    // forward and reverse actual positions; no reversal here, so both are q + EXX(q).
    let lcnc = Format::Linuxcnc.write(&c);
    assert!(
        lcnc.starts_with("-20.000000 -20.000200 -20.000200\n"),
        "{lcnc}"
    );
    assert!(
        lcnc.contains(
            "\n# end of X (JOINT_0 COMP_FILE, COMP_FILE_TYPE = 0): EXX (no reversal found)\n"
        ),
        "{lcnc}"
    );
    // The formats that cannot carry a reversal or thermal coefficients say so.
    for f in [Format::Isg, Format::Etalon, Format::Heidenhain] {
        let text = f.write(&c);
        assert!(
            text.contains("this format does not carry the reversal"),
            "{text}"
        );
        assert!(
            text.contains("this format does not carry thermal compensation"),
            "{text}"
        );
    }
}

/// Export → read back → the table's values within print precision, for every format, on
/// a simulated check where every term is identifiable (and on the hand-made one).
#[test]
fn every_format_round_trips() {
    let truth = random_truth(5);
    let out = simulate(
        &truth,
        &SimOptions {
            plan: Plan::Full,
            seed: 5,
            sample_rate_hz: 10.0,
            ..Default::default()
        },
    )
    .unwrap();
    let r = identify(&out.session, &IdentifyOptions::default()).unwrap();
    for (what, c) in [
        (
            "simulated",
            Compensation::from_result(&r, 5.0, false).unwrap(),
        ),
        (
            "hand-made",
            Compensation::from_result(&hand_result(), 10.0, false).unwrap(),
        ),
    ] {
        if what == "simulated" {
            assert_eq!(c.axes.iter().map(|a| a.columns.len()).sum::<usize>(), 18);
            assert_eq!(c.squareness.len(), 3);
            assert!(c.not_identifiable.is_empty());
            // The table agrees with the values the result reports where positions meet.
            let exx = &r.terms["EXX"];
            for (q, v) in exx.positions_mm.iter().zip(&exx.values) {
                if let Some(k) = c.axes[0]
                    .positions_mm
                    .iter()
                    .position(|p| (p - q).abs() < 1e-9)
                {
                    assert!((c.axes[0].columns[0].values[k] * 1e3 - v).abs() < 2e-6);
                }
            }
        }
        for f in Format::ALL.into_iter().filter(|f| f.holds_every_term()) {
            let text = f.write(&c);
            let back = f
                .read(&file_name(f), &text)
                .unwrap_or_else(|e| panic!("{what} {}: {e}", f.name()));
            assert_eq!(
                back.not_identifiable,
                c.not_identifiable,
                "{what} {}",
                f.name()
            );
            assert_eq!(back.axes.len(), c.axes.len());
            for (a, b) in c.axes.iter().zip(&back.axes) {
                assert_eq!(a.axis, b.axis);
                assert_eq!(a.positions_mm.len(), b.positions_mm.len());
                for (p, q) in a.positions_mm.iter().zip(&b.positions_mm) {
                    assert!(
                        (p - q).abs() <= 5e-7,
                        "{what} {} position {p} vs {q}",
                        f.name()
                    );
                }
                assert_eq!(a.columns.len(), b.columns.len());
                for (x, y) in a.columns.iter().zip(&b.columns) {
                    assert_eq!(x.term, y.term);
                    // Printed to 1e-9 mm (µm: 1e-6 µm) and 1e-12 rad (Heidenhain: 1e-11°):
                    // half of the last printed digit.
                    let tol = if Term::parse(&x.term).unwrap().is_angular() {
                        5.01e-13
                    } else {
                        5.01e-10
                    };
                    for (u, v) in x.values.iter().zip(&y.values) {
                        assert!(
                            (u - v).abs() <= tol,
                            "{what} {} {}: {u} vs {v}",
                            f.name(),
                            x.term
                        );
                    }
                }
            }
            assert_eq!(back.squareness.len(), c.squareness.len());
            for ((n, u), (m, v)) in c.squareness.iter().zip(&back.squareness) {
                assert_eq!(n, m);
                assert!(
                    (u - v).abs() <= 5.01e-13,
                    "{what} {} {n}: {u} vs {v}",
                    f.name()
                );
            }
        }
    }
}

/// A check whose plan cannot determine every term (the seed patent's plan: rank 34 of
/// 51): those terms are left out of every file and listed in its header.
#[test]
fn terms_the_data_could_not_determine_are_left_out_and_named() {
    let out = simulate(
        &random_truth(3),
        &SimOptions {
            plan: Plan::Seed,
            seed: 3,
            sample_rate_hz: 10.0,
            ..Default::default()
        },
    )
    .unwrap();
    let r = identify(&out.session, &IdentifyOptions::default()).unwrap();
    let missing: Vec<String> = r.observability.not_identifiable.clone();
    assert!(!missing.is_empty());
    let c = Compensation::from_result(&r, 5.0, false).unwrap();
    let mut want = missing.clone();
    want.sort();
    let mut got = c.not_identifiable.clone();
    got.sort();
    assert_eq!(got, want);
    for f in Format::ALL {
        let text = f.write(&c);
        let header = text
            .lines()
            .find(|l| l.contains("not identifiable, left out: "))
            .unwrap_or_else(|| panic!("{}: no line naming the terms left out", f.name()));
        for m in &missing {
            assert!(header.contains(m.as_str()), "{}: {m} not named", f.name());
            // Nowhere else (but in the sentence on the squareness convention): no column,
            // block, row or column assignment of it.
            let elsewhere = text
                .lines()
                .filter(|l| *l != header && !l.contains("squareness: angle between"))
                .any(|l| {
                    l.split(|ch: char| !ch.is_ascii_alphanumeric())
                        .any(|w| w == m || (m.len() == 4 && w == &m[1..]))
                });
            assert!(
                !elsewhere,
                "{}: {m} appears outside the header\n{text}",
                f.name()
            );
        }
    }
}

/// A result with nothing identifiable gives no table, saying why; a bad step too.
#[test]
fn nothing_identifiable_and_bad_steps_are_refused() {
    let mut r = hand_result();
    for t in r.terms.values_mut() {
        t.identifiable = false;
    }
    r.squareness.get_mut("EC0Y").unwrap().identifiable = false;
    match Compensation::from_result(&r, 5.0, false) {
        Err(ExportError::NothingIdentifiable(m)) => assert!(m.contains("EXX"), "{m}"),
        other => panic!("{other:?}"),
    }
    for step in [0.0, -1.0, f64::NAN, 1e-6] {
        assert!(matches!(
            Compensation::from_result(&hand_result(), step, false),
            Err(ExportError::BadStep(_))
        ));
    }
}

/// A result whose model does not explain its recording (residual 6.5 × the noise floor)
/// gives no table unless forced; a forced table says why in its first header line, and
/// every reader reads the reason back.
#[test]
fn a_misfit_gives_no_table_unless_forced() {
    let mut r = hand_result();
    r.fit.residual_rms_um = 0.976;
    r.fit.noise_estimate_um = Some(0.149);
    match Compensation::from_result(&r, 10.0, false) {
        Err(e @ ExportError::ModelMisfit(_)) => {
            let m = e.to_string();
            assert!(
                m.starts_with("the model does not explain this recording"),
                "{m}"
            );
            assert!(m.contains("unless forced"), "{m}");
        }
        other => panic!("{other:?}"),
    }
    let c = Compensation::from_result(&r, 10.0, true).unwrap();
    let why = c.forced.clone().unwrap();
    assert!(why.contains("6.6 × the noise floor"), "{why}");
    for f in Format::ALL {
        let text = f.write(&c);
        let first = text.lines().next().unwrap();
        assert!(
            first.contains("FORCED, NOT FOR USE WITHOUT REVIEW: the model does not explain"),
            "{}: {first}",
            f.name()
        );
        let back = f.read("t", &text).unwrap();
        assert_eq!(back.forced.as_deref(), Some(why.as_str()), "{}", f.name());
    }
    // A result at noise level is not forced, forced or not.
    let ok = Compensation::from_result(&hand_result(), 10.0, true).unwrap();
    assert_eq!(ok.forced, None);
}

/// Readers refuse broken files naming file, line, column and rule.
#[test]
fn readers_name_what_is_wrong() {
    let e = Format::Isg
        .read("t.csv", "X EXX EQX\n0 0.1 0.2\n")
        .unwrap_err();
    assert_eq!((e.line, e.column.as_str()), (1, "EQX"), "{e}");
    let e = Format::Isg
        .read("t.csv", "X EXX\n0 0.1\n5 abc\n")
        .unwrap_err();
    assert_eq!((e.line, e.column.as_str()), (3, "EXX"), "{e}");
    assert!(e.rule.contains("not a finite number"), "{e}");
    let e = Format::Etalon
        .read("t.txt", "[EXX]\nGridpoints = {\n0 0.1\n")
        .unwrap_err();
    assert!(e.rule.contains("not closed"), "{e}");
    let e = Format::Heidenhain
        .read("t.com", "BEGIN X.COM MM\nNR ADDR C1\n1 0 0.1\n[END]\n")
        .unwrap_err();
    assert_eq!((e.line, e.column.as_str()), (3, "NR"), "{e}");
    let e = Format::Csv
        .read("t.csv", "term,axis,position_mm,error,unit\nEXX,Y,0,1,um\n")
        .unwrap_err();
    assert_eq!((e.line, e.column.as_str()), (2, "axis"), "{e}");
}
