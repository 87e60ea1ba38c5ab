//! `mtcal standards` and `mtcal diagnose` on a CSV that looks like positioning runs or a
//! drift log but breaks its format: the kind's strict reader says what is wrong (file,
//! line, column and rule), exit code 2, not a generic "not a positioning-run CSV". A CSV
//! that looks like no dataset still gets the generic message, exit code 2 too.

mod support;

use std::io::Write as _;
use std::path::Path;
use support::mtcal;

/// Runs `mtcal <cmd> <path>`, expects exit code 2 and returns its stderr.
fn refused(cmd: &str, path: &Path) -> String {
    let out = mtcal(&[cmd, path.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(
        out.status.code(),
        Some(2),
        "{cmd} {}: {err}",
        path.display()
    );
    err
}

#[test]
fn a_dataset_missing_a_column_is_named_by_its_reader() {
    let dir = tempfile::tempdir().unwrap();
    // Positioning runs without deviation_um, plain and gzip.
    let text = "axis,run,direction,target_mm\nX,1,+,0\nX,1,+,10\n";
    let runs = dir.path().join("runs.csv");
    std::fs::write(&runs, text).unwrap();
    let gz = dir.path().join("runs2.csv.gz");
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    enc.write_all(text.as_bytes()).unwrap();
    std::fs::write(&gz, enc.finish().unwrap()).unwrap();
    for (path, file) in [(&runs, "runs.csv"), (&gz, "runs2.csv.gz")] {
        for cmd in ["standards", "diagnose"] {
            let err = refused(cmd, path);
            assert!(
                err.contains(&format!(
                    "{file}:1:deviation_um: required column is missing from the header"
                )),
                "{cmd}: {err}"
            );
            assert!(!err.contains("not a session folder"), "{cmd}: {err}");
        }
    }
    // Positioning runs with t_s and temp_c but no target_mm: still positioning runs.
    let runs = dir.path().join("timed.csv");
    std::fs::write(
        &runs,
        "axis,run,direction,deviation_um,t_s,temp_c\nX,1,+,0.1,0,20\n",
    )
    .unwrap();
    let err = refused("diagnose", &runs);
    assert!(
        err.contains("timed.csv:1:target_mm: required column"),
        "{err}"
    );
    // A drift log with a column that is not a channel, and one without t_s.
    let log = dir.path().join("heat.csv");
    std::fs::write(&log, "t_s,spindle_um,ambient\n0,0.1,20\n15,0.2,20\n").unwrap();
    let err = refused("diagnose", &log);
    assert!(err.contains("heat.csv:1:ambient: unknown column"), "{err}");
    std::fs::write(&log, "time,spindle_um,t1_c\n0,0.1,20\n15,0.2,20\n").unwrap();
    let err = refused("diagnose", &log);
    assert!(err.contains("heat.csv:1:"), "{err}");
    assert!(!err.contains("not a session folder"), "{err}");
    // `standards` takes no drift log: the generic message.
    let err = refused("standards", &log);
    assert!(err.contains("not a session folder"), "{err}");
    // A CSV like no dataset: the generic message.
    let other = dir.path().join("other.csv");
    std::fs::write(&other, "a,b\n1,2\n").unwrap();
    for cmd in ["standards", "diagnose"] {
        let err = refused(cmd, &other);
        assert!(err.contains("not a session folder"), "{cmd}: {err}");
    }
}
