//! `mtcal identify` end to end: a simulated session written to disk in the datasets
//! format, identified by the command-line program; and a broken file rejected with the
//! file, line, column and rule, exit code 2.

use mtcal_solver::identification::{IdentificationResult, IdentifyOptions, identify};
use mtcal_solver::simulate::{Plan, SimOptions, random_truth, simulate};
use std::process::Command;

fn write_full_session(dir: &std::path::Path) -> mtcal_solver::session::Session {
    let out = simulate(
        &random_truth(21),
        &SimOptions {
            plan: Plan::Full,
            sample_rate_hz: 5.0,
            ..Default::default()
        },
    )
    .unwrap();
    mtcal_formats::write_session_dir(dir, &out.session).unwrap();
    out.session
}

#[test]
fn identify_json_matches_the_library_and_reads_back_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let session = write_full_session(dir.path());
    let out = Command::new(env!("CARGO_BIN_EXE_mtcal"))
        .args(["identify", dir.path().to_str().unwrap(), "--json"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let cli: IdentificationResult = serde_json::from_slice(&out.stdout).unwrap();
    let lib = identify(&session, &IdentifyOptions::default()).unwrap();
    assert_eq!(cli.observability.rank, 51);
    // The files round-trip the session, so the CLI's numbers are the library's (reported
    // values are rounded to 1e-6; the raw coefficients agree to rounding).
    let mut cli = cli;
    let mut lib = lib;
    for (name, t) in cli.terms.iter_mut() {
        let l = lib.terms.get_mut(name).unwrap();
        assert_eq!(t.coefficients.len(), l.coefficients.len());
        for (a, b) in t.coefficients.iter().zip(&l.coefficients) {
            assert!(
                (a - b).abs() <= 1e-12 * b.abs().max(1e-12),
                "{name}: {a} vs {b}"
            );
        }
        t.coefficients.clear();
        l.coefficients.clear();
    }
    assert_eq!(cli, lib);
    // The human summary names every term.
    let out = Command::new(env!("CARGO_BIN_EXE_mtcal"))
        .args(["identify", dir.path().to_str().unwrap()])
        .output()
        .unwrap();
    let text = String::from_utf8(out.stdout).unwrap();
    for name in ["EXX", "ECZ", "EC0Y", "EA0Z"] {
        assert!(text.contains(name), "{name} missing from:\n{text}");
    }
    assert!(text.contains("rank 51 of 51"), "{text}");
}

#[test]
fn a_bad_number_is_rejected_with_file_line_column_and_rule() {
    let dir = tempfile::tempdir().unwrap();
    write_full_session(dir.path());
    // Break one number on the 3rd data line of the first plane file.
    let first = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "csv"))
        .min()
        .unwrap();
    let text = std::fs::read_to_string(&first).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let header_line = lines.iter().position(|l| !l.starts_with('#')).unwrap();
    let cols: Vec<&str> = lines[header_line].split(',').collect();
    let du = cols.iter().position(|c| *c == "du_um").unwrap();
    let target = header_line + 3;
    let mut cells: Vec<String> = lines[target].split(',').map(String::from).collect();
    cells[du] = "NaN".into();
    lines[target] = cells.join(",");
    std::fs::write(&first, lines.join("\n") + "\n").unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_mtcal"))
        .args(["identify", dir.path().to_str().unwrap()])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    let name = first.file_name().unwrap().to_str().unwrap();
    let want = format!("{name}:{}:du_um:", target + 1);
    assert!(err.contains(&want), "expected `{want}` in: {err}");
    assert!(err.to_lowercase().contains("finite"), "{err}");
}

/// A person's session as one `.tar.gz` (made with `tar czf s.tar.gz -C dir .`) is read
/// where a folder is; a misfit is said where the fit is (no verdict, no table, what to
/// run next); ISO 230-2 figures that line passes cannot determine are printed as "—"
/// with their reason once, not as numbers.
#[test]
fn identify_reads_an_archive_and_states_a_misfit_and_no_absent_figure() {
    use mtcal_solver::Axis;
    use mtcal_solver::simulate::Effect;
    let out = simulate(
        &random_truth(5),
        &SimOptions {
            plan: Plan::Seed,
            seed: 5,
            sample_rate_hz: 10.0,
            effects: vec![Effect::Backlash {
                axis: Axis::X,
                lost_motion_um: 6.0,
            }],
            ..Default::default()
        },
    )
    .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("s");
    std::fs::create_dir(&src).unwrap();
    mtcal_formats::write_session_dir(&src, &out.session).unwrap();
    let archive = dir.path().join("s.tar.gz");
    let tar = Command::new("tar")
        .arg("czf")
        .arg(&archive)
        .arg("-C")
        .arg(&src)
        .arg(".")
        .status()
        .unwrap();
    assert!(tar.success());
    let run = |args: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_mtcal"))
            .args(args)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8(out.stdout).unwrap()
    };
    let text = run(&["identify", archive.to_str().unwrap()]);
    assert!(
        text.contains("model check: the model does not explain this recording"),
        "{text}"
    );
    assert!(
        text.contains("no verdict and no compensation table"),
        "{text}"
    );
    assert!(text.contains("`mtcal diagnose`"), "{text}");
    for cmd in ["identify", "standards"] {
        let text = run(&[cmd, archive.to_str().unwrap()]);
        let row = text
            .lines()
            .find(|l| l.starts_with("axis X "))
            .unwrap_or_else(|| panic!("{cmd}: no ISO 230-2 row for X in:\n{text}"));
        assert!(row.contains('—'), "{cmd}: {row}");
        assert_eq!(
            text.matches("— not available (").count(),
            1,
            "{cmd}: the reason once:\n{text}"
        );
    }
}

/// `identify`, `standards` and `diagnose` read a session zipped or tarred as a person does
/// it (`zip -r s.zip s`, `tar czf s.tgz s`: the files in a top folder) as they read the
/// folder: the same document; an archive they cannot read (encrypted) is bad input,
/// exit code 2, with the archive and the entry named.
#[test]
fn commands_read_zip_and_tar_archives_where_they_read_a_folder() {
    let dir = tempfile::tempdir().unwrap();
    let out = simulate(
        &random_truth(8),
        &SimOptions {
            plan: Plan::Seed,
            seed: 8,
            sample_rate_hz: 5.0,
            ..Default::default()
        },
    )
    .unwrap();
    let src = dir.path().join("s");
    std::fs::create_dir(&src).unwrap();
    mtcal_formats::write_session_dir(&src, &out.session).unwrap();
    let make = |program: &str, args: &[&str]| {
        let ok = Command::new(program)
            .args(args)
            .current_dir(dir.path())
            .status()
            .unwrap();
        assert!(ok.success(), "{program} {args:?}");
    };
    make("zip", &["-qr", "s.zip", "s"]);
    make("tar", &["czf", "s.tgz", "s"]);
    make(
        "zip",
        &["-q", "-P", "secret", "locked.zip", "s/session.json"],
    );
    let run = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_mtcal"))
            .args(args)
            .output()
            .unwrap()
    };
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    for cmd in ["identify", "standards", "diagnose"] {
        let folder = run(&[cmd, &path("s"), "--json"]);
        assert!(folder.status.success(), "{cmd} on the folder");
        for archive in ["s.zip", "s.tgz"] {
            let o = run(&[cmd, &path(archive), "--json"]);
            assert!(
                o.status.success(),
                "{cmd} {archive}: {}",
                String::from_utf8_lossy(&o.stderr)
            );
            assert_eq!(o.stdout, folder.stdout, "{cmd} {archive}: as the folder");
        }
    }
    let o = run(&["identify", &path("locked.zip")]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("locked.zip") && err.contains("entry `s/session.json` is encrypted"),
        "{err}"
    );
}
