//! `mtcal diagnose` on a session whose recorded samples were edited by hand: an effect
//! made outside the simulator and its catalogue, as a user's file would carry it.

use crate::common::*;
use mtcal_solver::diagnosis::{DiagnosisResult, Verdict};
use std::path::Path;

/// Adds `size` µm to the `du_um` reading of plane file `file` from the middle sample of
/// run `run` on, that run's later samples and every later run's (an encoder slip: a
/// lasting offset of one reading). Returns the time halfway between the last sample
/// before the step and the first after it.
fn slip(dir: &Path, file: &str, run: i64, size: f64) -> f64 {
    let path = dir.join(file);
    let text = std::fs::read_to_string(&path).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let header: Vec<&str> = lines[0].split(',').collect();
    let col = |name: &str| header.iter().position(|c| *c == name).unwrap();
    let (c_run, c_t, c_du) = (col("run"), col("t_s"), col("du_um"));
    let cells = |l: &str| -> Vec<String> { l.split(',').map(str::to_string).collect() };
    let of_run: Vec<usize> = (1..lines.len())
        .filter(|&i| cells(&lines[i])[c_run].parse::<i64>().unwrap() == run)
        .collect();
    let mid = of_run[of_run.len() / 2];
    let t = |i: usize| cells(&lines[i])[c_t].parse::<f64>().unwrap();
    let t_step = 0.5 * (t(mid - 1) + t(mid));
    for line in lines.iter_mut().skip(mid) {
        let mut c = cells(line);
        let du: f64 = c[c_du].parse().unwrap();
        c[c_du] = format!("{}", du + size);
        *line = c.join(",");
    }
    std::fs::write(&path, lines.join("\n") + "\n").unwrap();
    t_step
}

/// A slip of 10 and of 20 times the noise (σ = 0.15 µm) in the X reading of `xz_t1.csv`,
/// made by editing its samples from the middle of run 3 on: the session is not
/// `consistent`, the step is found in the X direction at its time within ±2 s, its size
/// within 3 reported σ + 2 %, and its place names the file, the run, the test and the
/// commanded position.
#[test]
fn a_slip_edited_into_the_recorded_samples_is_found_and_located() {
    for (seed, size) in [(31u64, 1.5), (32, 3.0)] {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path().join("s");
        let d = dir.to_str().unwrap();
        let seed_s = seed.to_string();
        mtcal(&["simulate", "--out", d, "--seed", &seed_s, "--rate-hz", "10"]);
        let t_step = slip(&dir, "xz_t1.csv", 3, size);
        let out = mtcal(&["diagnose", d, "--json"]);
        let r: DiagnosisResult = serde_json::from_str(&out).unwrap();
        assert_ne!(r.verdict, Verdict::Consistent, "{out}");
        let f = r
            .findings
            .iter()
            .find(|f| f.effect == "step")
            .unwrap_or_else(|| panic!("no step found: {out}"));
        assert_eq!(f.axis.as_deref(), Some("X"), "{out}");
        let p = |k: &str| f.parameters[k];
        assert!((p("time_s") - t_step).abs() <= 2.0, "{t_step}: {out}");
        assert!(
            (p("size_um") - size).abs() <= 3.0 * p("std_size_um") + 0.02 * size,
            "{out}"
        );
        let place = f.signature.as_deref().unwrap_or_default();
        for part in ["xz_t1.csv run 3", "line_X", "X = ", "Z = "] {
            assert!(place.contains(part), "{part} not in {place}");
        }
        // The summary names it too.
        let text = mtcal(&["diagnose", d]);
        assert!(text.contains("finding: step (X)"), "{text}");
    }
}
