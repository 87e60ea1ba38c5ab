//! Where the misfit of a session's model is: the squared residual above the noise floor
//! split by place and signature (file and test, circle angle, line passes near their
//! reversal, session time), each place with its share and the runs concerned.

use super::Mismatch;
use super::design::Design;
use crate::session::TestKind;

fn run_id(d: &Design, ri: usize) -> String {
    let r = &d.runs[ri];
    format!("{}#run {}", d.files[r.plane_idx], r.number)
}

/// Splits the squared residual above the noise floor by place and signature.
pub(crate) fn locate(d: &Design, r: &[f64], sigma: f64) -> Vec<Mismatch> {
    let excess = |rows: &mut dyn Iterator<Item = usize>| -> f64 {
        rows.map(|i| r[i] * r[i] - sigma * sigma).sum::<f64>()
    };
    let total = excess(&mut (0..r.len())).max(1e-300);
    let mut out: Vec<Mismatch> = Vec::new();
    let mut add = |where_: String, runs: Vec<usize>, e: f64| {
        if e / total >= 0.1 {
            out.push(Mismatch {
                where_,
                tests: runs.iter().take(6).map(|&ri| run_id(d, ri)).collect(),
                share_of_misfit: (e / total).min(1.0),
            });
        }
    };
    // By file and test kind.
    for (pi, file) in d.files.iter().enumerate() {
        for kind in [
            TestKind::LineX,
            TestKind::LineY,
            TestKind::LineZ,
            TestKind::CircleCcw,
            TestKind::CircleCw,
            TestKind::Free,
        ] {
            let runs: Vec<usize> = (0..d.runs.len())
                .filter(|&i| d.runs[i].plane_idx == pi && d.runs[i].test == kind)
                .collect();
            if runs.is_empty() {
                continue;
            }
            let e = excess(
                &mut runs
                    .iter()
                    .flat_map(|&i| 2 * d.runs[i].start..2 * d.runs[i].end),
            );
            add(format!("{file}: {} runs", kind.name()), runs, e);
        }
    }
    // Circles by angle sector (all circles together).
    for sector in 0..12 {
        let lo = sector as f64 * 30.0;
        let mut runs = Vec::new();
        let mut rows = Vec::new();
        for (ri, run) in d.runs.iter().enumerate() {
            if !matches!(run.test, TestKind::CircleCcw | TestKind::CircleCw) {
                continue;
            }
            let (u, v) = d.plane_axes[run.plane_idx];
            for s in run.start..run.end {
                let q = d.fields.q(s);
                let ang = q[v.index()]
                    .atan2(q[u.index()])
                    .to_degrees()
                    .rem_euclid(360.0);
                if ang >= lo && ang < lo + 30.0 {
                    rows.push(2 * s);
                    rows.push(2 * s + 1);
                    if runs.last() != Some(&ri) {
                        runs.push(ri);
                    }
                }
            }
        }
        let e = excess(&mut rows.into_iter());
        add(
            format!("circle runs, angle {lo:.0}..{:.0} deg", lo + 30.0),
            runs,
            e,
        );
    }
    // Line passes near their reversal (first 10 % of travel) versus the rest.
    let mut near = Vec::new();
    let mut near_runs = Vec::new();
    for (ri, run) in d.runs.iter().enumerate() {
        let i = match run.test {
            TestKind::LineX => 0,
            TestKind::LineY => 1,
            TestKind::LineZ => 2,
            _ => continue,
        };
        let Some([lo, hi]) = d.travel[i] else {
            continue;
        };
        for s in run.start..run.end {
            if d.fields.since_reversal_mm[i][s] < 0.1 * (hi - lo) {
                near.push(2 * s);
                near.push(2 * s + 1);
                if near_runs.last() != Some(&ri) {
                    near_runs.push(ri);
                }
            }
        }
    }
    let e = excess(&mut near.into_iter());
    add(
        "line passes, first 10 % of travel after each reversal".into(),
        near_runs,
        e,
    );
    // By time, in fifths of the session.
    let t = &d.fields.t_s;
    let (t0, t1) = (t[0], t[t.len() - 1]);
    for k in 0..5 {
        let (a, b) = (
            t0 + (t1 - t0) * k as f64 / 5.0,
            t0 + (t1 - t0) * (k + 1) as f64 / 5.0,
        );
        let runs: Vec<usize> = (0..d.runs.len())
            .filter(|&i| {
                let t = t[d.runs[i].start];
                t >= a && (t < b || k == 4)
            })
            .collect();
        let e = excess(
            &mut runs
                .iter()
                .flat_map(|&i| 2 * d.runs[i].start..2 * d.runs[i].end),
        );
        add(format!("session time {a:.0}..{b:.0} s"), runs, e);
    }
    out.sort_by(|a, b| b.share_of_misfit.total_cmp(&a.share_of_misfit));
    out.truncate(6);
    out
}
