//! Where the misfit of a session's model is: the squared residual above the noise floor
//! split by place and signature (file and test; circle angle per plane, named by the axis
//! that reverses there; line passes of each axis near its reversals; session time when
//! the misfit follows time), each place with its share and the runs that carry it.

use super::Mismatch;
use super::design::Design;
use crate::session::TestKind;

fn run_id(d: &Design, ri: usize) -> String {
    let r = &d.runs[ri];
    format!("{}#run {}", d.files[r.plane_idx], r.number)
}

/// At most this many runs are listed under a place.
const MAX_RUNS: usize = 6;

/// The runs of a place that carry its misfit: by their excess in the place, largest
/// first, those with a positive excess until they hold 80 % of the place's, at most
/// [`MAX_RUNS`].
fn carriers(per_run: &[(usize, f64)]) -> Vec<usize> {
    let mut v: Vec<(usize, f64)> = per_run.iter().copied().filter(|r| r.1 > 0.0).collect();
    v.sort_by(|a, b| b.1.total_cmp(&a.1));
    let total: f64 = v.iter().map(|r| r.1).sum();
    let mut out = Vec::new();
    let mut held = 0.0;
    for (ri, e) in v {
        if out.len() >= MAX_RUNS || held >= 0.8 * total {
            break;
        }
        out.push(ri);
        held += e;
    }
    out
}

/// Of the places by file and test (they do not overlap), those listed: largest first
/// until they hold this share of the misfit.
const LISTED_SHARE: f64 = 0.9;

/// A test kind in words, as a place names it (`X line`, `clockwise circle`).
fn kind_words(kind: TestKind) -> &'static str {
    match kind {
        TestKind::LineX => "X line",
        TestKind::LineY => "Y line",
        TestKind::LineZ => "Z line",
        TestKind::CircleCcw => "counter-clockwise circle",
        TestKind::CircleCw => "clockwise circle",
        TestKind::Free => "free-form",
    }
}

/// Splits the squared residual above the noise floor by place and signature. The
/// places by file and test (`xy.csv: X line runs`, named ending in ` runs`) split the
/// misfit without overlap: every one carrying misfit is listed, largest first, until
/// they hold [`LISTED_SHARE`] of it. The finer places (an angle sector, the stretch
/// after a reversal, a time; each inside those) are listed from 10 % of the misfit, at
/// most 6.
pub(crate) fn locate(d: &Design, r: &[f64], sigma: f64) -> Vec<Mismatch> {
    let ex = |i: usize| r[i] * r[i] - sigma * sigma;
    let total = (0..r.len()).map(ex).sum::<f64>().max(1e-300);
    let mut parts: Vec<Mismatch> = Vec::new();
    let mut out: Vec<Mismatch> = Vec::new();
    // A place: its rows' excess gathered per run.
    let mut add = |where_: String, per_run: &[(usize, f64)]| {
        let e: f64 = per_run.iter().map(|r| r.1).sum();
        if e / total >= 0.1 {
            out.push(Mismatch {
                where_,
                tests: carriers(per_run).iter().map(|&ri| run_id(d, ri)).collect(),
                share_of_misfit: (e / total).min(1.0),
            });
        }
    };
    let run_excess: Vec<f64> = d
        .runs
        .iter()
        .map(|run| (2 * run.start..2 * run.end).map(ex).sum())
        .collect();
    // By file and test kind: every place, kept or not below.
    let mut part = |where_: String, per_run: &[(usize, f64)]| {
        let e: f64 = per_run.iter().map(|r| r.1).sum();
        parts.push(Mismatch {
            where_,
            tests: carriers(per_run).iter().map(|&ri| run_id(d, ri)).collect(),
            share_of_misfit: (e / total).min(1.0),
        });
    };
    let kinds = [
        TestKind::LineX,
        TestKind::LineY,
        TestKind::LineZ,
        TestKind::CircleCcw,
        TestKind::CircleCw,
        TestKind::Free,
    ];
    for (pi, file) in d.files.iter().enumerate() {
        for kind in kinds {
            let per_run: Vec<(usize, f64)> = (0..d.runs.len())
                .filter(|&i| d.runs[i].plane_idx == pi && d.runs[i].test == kind)
                .map(|i| (i, run_excess[i]))
                .collect();
            if !per_run.is_empty() {
                part(format!("{file}: {} runs", kind_words(kind)), &per_run);
            }
        }
    }
    // Circles by angle sector, per plane: sectors of 30° centred on 0°, 30°, …; the
    // plane's u axis reverses at 0° and 180°, its v axis at 90° and 270°.
    for (pi, file) in d.files.iter().enumerate() {
        let (u, v) = d.plane_axes[pi];
        for sector in 0..12 {
            let centre = sector as f64 * 30.0;
            let mut per_run: Vec<(usize, f64)> = Vec::new();
            for (ri, run) in d.runs.iter().enumerate() {
                if run.plane_idx != pi
                    || !matches!(run.test, TestKind::CircleCcw | TestKind::CircleCw)
                {
                    continue;
                }
                let mut e = 0.0;
                let mut any = false;
                for s in run.start..run.end {
                    let q = d.fields.q(s);
                    let ang = q[v.index()].atan2(q[u.index()]).to_degrees();
                    if (ang - centre + 15.0).rem_euclid(360.0) < 30.0 {
                        e += ex(2 * s) + ex(2 * s + 1);
                        any = true;
                    }
                }
                if any {
                    per_run.push((ri, e));
                }
            }
            if per_run.is_empty() {
                continue;
            }
            let at = match sector % 6 {
                0 => format!(" ({u} reverses)"),
                3 => format!(" ({v} reverses)"),
                _ => String::new(),
            };
            add(
                format!(
                    "{file}: circle runs, angle {:.0}..{:.0} deg{at}",
                    centre - 15.0,
                    centre + 15.0
                ),
                &per_run,
            );
        }
    }
    // Circles near the reversals of each axis, over every plane that moves it: within
    // 15° of the angles where it reverses (0°/180° for a plane's u axis, 90°/270° for v).
    for axis in crate::axis::Axis::ALL {
        let mut per_run: Vec<(usize, f64)> = Vec::new();
        for (ri, run) in d.runs.iter().enumerate() {
            if !matches!(run.test, TestKind::CircleCcw | TestKind::CircleCw) {
                continue;
            }
            let (u, v) = d.plane_axes[run.plane_idx];
            let base = if u == axis {
                0.0
            } else if v == axis {
                90.0
            } else {
                continue;
            };
            let e = (run.start..run.end)
                .filter(|&s| {
                    let q = d.fields.q(s);
                    let ang = q[v.index()].atan2(q[u.index()]).to_degrees();
                    (ang - base + 15.0).rem_euclid(180.0) < 30.0
                })
                .map(|s| ex(2 * s) + ex(2 * s + 1))
                .sum();
            per_run.push((ri, e));
        }
        if !per_run.is_empty() {
            add(
                format!("circle runs, within 15 deg of the {axis} reversals ({axis} reverses)"),
                &per_run,
            );
        }
    }
    // Line passes of each axis near its reversals (first 10 % of its travel).
    for (i, kind) in [TestKind::LineX, TestKind::LineY, TestKind::LineZ]
        .into_iter()
        .enumerate()
    {
        let Some([lo, hi]) = d.travel[i] else {
            continue;
        };
        let per_run: Vec<(usize, f64)> = d
            .runs
            .iter()
            .enumerate()
            .filter(|(_, run)| run.test == kind)
            .map(|(ri, run)| {
                let e = (run.start..run.end)
                    .filter(|&s| d.fields.since_reversal_mm[i][s] < 0.1 * (hi - lo))
                    .map(|s| ex(2 * s) + ex(2 * s + 1))
                    .sum();
                (ri, e)
            })
            .collect();
        let axis = crate::axis::Axis::ALL[i];
        add(
            format!(
                "{axis} line passes, first 10 % of travel after each {axis} reversal ({axis} reverses)"
            ),
            &per_run,
        );
    }
    // By time, in fifths of the session, only where the misfit follows time: a fifth
    // is a place when its excess is more than 1.5 × what its runs' (file, test) groups
    // hold on average per row (a misfit that only follows which plane or test was being
    // measured is placed there, not in time).
    let group = |ri: usize| (d.runs[ri].plane_idx, d.runs[ri].test);
    let mut groups: Vec<((usize, TestKind), f64, usize)> = Vec::new();
    for (ri, run) in d.runs.iter().enumerate() {
        let rows = 2 * (run.end - run.start);
        match groups.iter_mut().find(|g| g.0 == group(ri)) {
            Some(g) => {
                g.1 += run_excess[ri];
                g.2 += rows;
            }
            None => groups.push((group(ri), run_excess[ri], rows)),
        }
    }
    let expected = |ri: usize| {
        let g = groups.iter().find(|g| g.0 == group(ri)).expect("group");
        g.1 / g.2.max(1) as f64 * (2 * (d.runs[ri].end - d.runs[ri].start)) as f64
    };
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
        let e: f64 = runs.iter().map(|&i| run_excess[i]).sum();
        let want: f64 = runs.iter().map(|&i| expected(i)).sum();
        if e > 1.5 * want.max(0.0) {
            let per_run: Vec<(usize, f64)> = runs.iter().map(|&i| (i, run_excess[i])).collect();
            add(format!("session time {a:.0}..{b:.0} s"), &per_run);
        }
    }
    out.sort_by(|a, b| b.share_of_misfit.total_cmp(&a.share_of_misfit));
    out.truncate(6);
    parts.sort_by(|a, b| b.share_of_misfit.total_cmp(&a.share_of_misfit));
    let mut held = 0.0;
    for p in parts {
        if held >= LISTED_SHARE || p.share_of_misfit <= 0.0 {
            break;
        }
        held += p.share_of_misfit;
        out.push(p);
    }
    out.sort_by(|a, b| b.share_of_misfit.total_cmp(&a.share_of_misfit));
    out
}
