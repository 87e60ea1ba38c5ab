//! The coarse scan of a periodic candidate's frequency: the sine/cosine pair of every
//! frequency of a grid fitted to the current model's residual alone, on moments kept
//! between rounds.

use crate::axis::Axis;
use crate::diagnosis::design::{Design, RunInfo};
use crate::diagnosis::periodic_scan;
use crate::diagnosis::session::context::ScanMoments;

/// Most frequencies in one scan, and the most (row, frequency) pairs a scan evaluates.
/// A 300 000-sample session's widest scans (2001 frequencies over 200 000 rows of an
/// axis) so take every 41st run, 3–4 runs of about 1500 rows: a sine of amplitude A in
/// white noise σ over N rows scores about N·A²/2 against a noise maximum of about
/// 2σ²·ln(frequencies), so a sine stands out from about A = 2σ·(ln 2001 / 5000)^½ ≈
/// 0.08·σ, far below what the joint fit on every row admits; the chosen frequency is then
/// refined on that fit.
pub(super) const MAX_SCAN_FREQS: usize = 2000;
const MAX_SCAN_WORK: usize = 10_000_000;

/// A frequency scan's variable: the rows read along `axis`, the variable per sample
/// (time, or an axis's position), with each run's own phase (`per_run`: an incoherent
/// sum, for a coarse scan in time) or one phase for the session.
pub(super) struct ScanVar<'v> {
    pub(super) axis: Axis,
    pub(super) var: &'v [f64],
    pub(super) per_run: bool,
}

/// Frequency (in `freqs`, evenly spaced) whose sine/cosine pair of the scan's variable
/// explains most of the residual `r`, with the columns centred per (run, component) like
/// the model.
///
/// This is a scan heuristic only: the 2×2 moment system of each candidate frequency is
/// solved in closed form; the chosen frequency is then fitted jointly. The work is bounded:
/// whole runs, every `stride`-th, so that at most [`MAX_SCAN_WORK`] (row, frequency) pairs
/// are evaluated (the runs chosen still span the session). Each run's moments at every
/// frequency come from [`periodic_scan::run_moments`]; those that do not depend on the
/// residual from `kept` when the session has made the same scan before ([`ScanMoments`]),
/// and kept there otherwise.
pub(super) fn periodic_best(
    d: &Design,
    r: &[f64],
    v: &ScanVar,
    freqs: &[f64],
    kept: &ScanMoments,
) -> Option<f64> {
    let score = scan_scores(d, r, v, freqs, kept)?;
    let kbest = (0..freqs.len()).max_by(|&a, &b| score[a].total_cmp(&score[b]))?;
    Some(freqs[kbest])
}

/// [`periodic_best`]'s score of every frequency: the residual's sum of squares its pair
/// explains (`None`: no run reads the axis).
fn scan_scores(
    d: &Design,
    r: &[f64],
    v: &ScanVar,
    freqs: &[f64],
    kept: &ScanMoments,
) -> Option<Vec<f64>> {
    let ScanVar { axis, var, per_run } = *v;
    let nf = freqs.len();
    let f0 = *freqs.first()?;
    let reads = |run: &RunInfo| {
        let (u, v) = d.plane_axes[run.plane_idx];
        u == axis || v == axis
    };
    let axis_rows: usize = d
        .runs
        .iter()
        .filter(|r| reads(r))
        .map(|r| r.end - r.start)
        .sum();
    let stride = (axis_rows * nf).div_ceil(MAX_SCAN_WORK).max(1);
    let df = if nf > 1 { freqs[1] - f0 } else { 0.0 };
    // Explained sum of squares of the centred 2-column fit from its moments
    // (ss, cc, sc, rs, rc).
    let solve = |m: &[f64; 5]| {
        let [ss, cc, sc, rs, rc] = *m;
        let det = ss * cc - sc * sc;
        if det <= 1e-12 * (ss * cc).max(1e-300) {
            return 0.0;
        }
        let a = (cc * rs - sc * rc) / det;
        let b = (ss * rc - sc * rs) / det;
        a * rs + b * rc
    };
    let key = (
        axis.index(),
        var.as_ptr() as usize,
        f0.to_bits(),
        df.to_bits(),
        nf,
        per_run,
    );
    let known = kept.get(&key);
    // The moments that do not depend on the residual: taken from `known` (from its
    // first entry, run by run when per run), or gathered into `fresh` to keep.
    let (from, mut fresh) = (if known.is_some() { 3 } else { 0 }, Vec::new());
    let mut scanned = 0;
    let mut score = vec![0.0; nf];
    let mut total = vec![[0.0; 5]; nf];
    let mut mom = vec![[0.0; 5]; nf];
    let mut sums = vec![[0.0; 7]; nf];
    let mut any = false;
    // Per row of a run: its residual and variable.
    let mut rv = Vec::new();
    let mut xs = Vec::new();
    for (ri, run) in d.runs.iter().enumerate() {
        if ri % stride != 0 || !reads(run) {
            continue;
        }
        rv.clear();
        xs.clear();
        // The run's rows read along `axis` (one component of each sample).
        for row in 2 * run.start..2 * run.end {
            if d.row_axis(row) != axis {
                continue;
            }
            rv.push(r[row]);
            xs.push(var[row / 2]);
        }
        if rv.is_empty() {
            continue;
        }
        any = true;
        // A variable constant over the run gives constant columns, which its centring
        // removes: the run adds nothing to any frequency's moments.
        if xs.iter().all(|&x| x == xs[0]) {
            continue;
        }
        // The run's moments [ss, cc, sc, rs, rc] at every frequency: in closed form on
        // its evenly spaced stretches, by rotating phasors elsewhere ([`periodic_scan`]).
        match known {
            Some(_) => periodic_scan::run_moments::<false>(&rv, &xs, f0, df, &mut sums, &mut mom),
            None => periodic_scan::run_moments::<true>(&rv, &xs, f0, df, &mut sums, &mut mom),
        }
        for (k, m) in mom.iter_mut().enumerate() {
            if per_run {
                match &known {
                    Some(kn) => m[..3].copy_from_slice(&kn[scanned * nf + k]),
                    None => fresh.push([m[0], m[1], m[2]]),
                }
                score[k] += solve(m);
            } else {
                for j in from..5 {
                    total[k][j] += m[j];
                }
            }
        }
        scanned += 1;
    }
    if !any {
        return None;
    }
    if !per_run {
        for k in 0..nf {
            match &known {
                Some(kn) => total[k][..3].copy_from_slice(&kn[k]),
                None => fresh.push([total[k][0], total[k][1], total[k][2]]),
            }
            score[k] = solve(&total[k]);
        }
    }
    if known.is_none() {
        kept.insert(key, fresh);
    }
    Some(score)
}

#[cfg(test)]
mod tests {
    use super::{ScanMoments, ScanVar};
    use crate::axis::Axis;
    use crate::diagnosis::design;
    use crate::simulate::seed_session;

    /// A frequency scan of a second residual on the moments kept from the first (the
    /// same rows and grid) scores every frequency bit for bit as the scan made afresh:
    /// in position over the whole session and in time run by run.
    #[test]
    fn a_scan_on_kept_moments_is_the_fresh_scan() {
        let session = seed_session(3);
        let d = design::build(&session, &Default::default(), 3).unwrap();
        let resid = |a: f64| -> Vec<f64> {
            (0..d.rows())
                .map(|i| (a * i as f64).sin() + 0.01 * ((i * 7919) % 13) as f64)
                .collect()
        };
        let (r1, r2) = (resid(0.37), resid(0.011));
        let scans = [
            (Axis::X, &d.fields.q_mm[0], false, 1.0 / 30.0, 0.0025),
            (Axis::Y, &d.fields.t_s, true, 0.01, 0.013),
        ];
        for (axis, var, per_run, f0, df) in scans {
            let v = ScanVar { axis, var, per_run };
            let freqs: Vec<f64> = (0..300).map(|k| f0 + k as f64 * df).collect();
            let kept = ScanMoments::default();
            let first = super::scan_scores(&d, &r1, &v, &freqs, &kept).unwrap();
            let again = super::scan_scores(&d, &r2, &v, &freqs, &kept).unwrap();
            let fresh = super::scan_scores(&d, &r2, &v, &freqs, &Default::default()).unwrap();
            assert!(
                again
                    .iter()
                    .zip(&fresh)
                    .all(|(a, b)| a.to_bits() == b.to_bits())
            );
            // Not the first residual's scores: the residual's sums were formed anew.
            assert!(again.iter().zip(&first).any(|(a, b)| a != b));
            assert!(fresh.iter().any(|&x| x > 0.0));
        }
    }
}
