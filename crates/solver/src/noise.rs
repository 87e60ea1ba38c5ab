//! Measurement noise estimated independently of any error model, from repeated passes.
//!
//! Two passes of the same test in the same direction (the seed plan runs every line back
//! and forth five times) see the same machine errors at the same commanded position;
//! their difference is noise plus a constant (the runs' zero offsets). Pairing each
//! sample of one pass with the sample of the next pass nearest in commanded position
//! (for circles: nearest in angle), removing the mean difference, gives
//!
//! σ̂² = Σ (d_i − d̄)² / (2 (n − 1))      (the difference of two readings has variance 2σ²).
//!
//! Reversal effects (backlash, servo lag) cancel because only passes of the same
//! direction are paired; slow drift between passes adds a small positive bias, which is
//! the safe side for a noise floor.

use crate::axis::Plane;
use crate::session::{Run, Session, TestKind};

/// The coordinate a pass is parametrised by, and its direction of travel.
fn pass_key(run: &Run, plane: Plane) -> Option<(TestKind, i8, Vec<f64>)> {
    let kind = run.test_kind(plane);
    let (u, v) = plane.axes();
    let coord: Vec<f64> = match kind {
        TestKind::LineX | TestKind::LineY | TestKind::LineZ => {
            let a = match kind {
                TestKind::LineX => 0,
                TestKind::LineY => 1,
                _ => 2,
            };
            run.pos_mm.iter().map(|q| q[a]).collect()
        }
        TestKind::CircleCcw | TestKind::CircleCw => {
            let n = run.len() as f64;
            let cu = run.pos_mm.iter().map(|q| q[u.index()]).sum::<f64>() / n;
            let cv = run.pos_mm.iter().map(|q| q[v.index()]).sum::<f64>() / n;
            run.pos_mm
                .iter()
                .map(|q| (q[v.index()] - cv).atan2(q[u.index()] - cu))
                .collect()
        }
        TestKind::Free => return None,
    };
    let first = *coord.first()?;
    let last = *coord.last()?;
    let dir = match kind {
        TestKind::CircleCcw => 1,
        TestKind::CircleCw => -1,
        _ if last > first => 1,
        _ => -1,
    };
    Some((kind, dir, coord))
}

/// Sum of squared centred differences and their count for one pair of passes.
fn pair_stats(a: &Run, ca: &[f64], b: &Run, cb: &[f64], angular: bool) -> (f64, usize) {
    // Sort b by coordinate for nearest-neighbour search.
    let mut idx: Vec<usize> = (0..cb.len()).collect();
    idx.sort_by(|&i, &j| cb[i].total_cmp(&cb[j]));
    let sorted: Vec<f64> = idx.iter().map(|&i| cb[i]).collect();
    let span = sorted.last().copied().unwrap_or(0.0) - sorted.first().copied().unwrap_or(0.0);
    let spacing = if sorted.len() > 1 {
        span / (sorted.len() - 1) as f64
    } else {
        0.0
    };
    let mut diffs = [Vec::new(), Vec::new()];
    for (i, &c) in ca.iter().enumerate() {
        let pos = sorted.partition_point(|&v| v < c);
        let cand = [pos.saturating_sub(1), pos.min(sorted.len() - 1)];
        let best = cand
            .into_iter()
            .min_by(|&x, &y| (sorted[x] - c).abs().total_cmp(&(sorted[y] - c).abs()))
            .unwrap();
        let gap = (sorted[best] - c).abs();
        // Only pair samples that really sit at the same place (within two spacings; on
        // circles, not across the seam).
        if gap > 2.0 * spacing.max(1e-9) || (angular && gap > 0.05) {
            continue;
        }
        let j = idx[best];
        diffs[0].push(a.du_um[i] - b.du_um[j]);
        diffs[1].push(a.dv_um[i] - b.dv_um[j]);
    }
    let mut ss = 0.0;
    let mut n = 0;
    for d in &diffs {
        if d.len() < 3 {
            continue;
        }
        let m = d.iter().sum::<f64>() / d.len() as f64;
        ss += d.iter().map(|x| (x - m).powi(2)).sum::<f64>();
        n += d.len() - 1;
    }
    (ss, n)
}

/// Noise standard deviation (µm) from repeated passes, `None` when the session has no
/// repeated pass.
pub fn noise_from_repeated_passes(session: &Session) -> Option<f64> {
    let mut ss = 0.0;
    let mut n = 0usize;
    for rec in &session.planes {
        let keyed: Vec<_> = rec
            .runs
            .iter()
            .filter_map(|r| pass_key(r, rec.plane).map(|k| (r, k)))
            .collect();
        for (i, (ra, (ka, da, ca))) in keyed.iter().enumerate() {
            // Pair with the next pass of the same test and direction.
            if let Some((rb, (_, _, cb))) = keyed[i + 1..]
                .iter()
                .find(|(_, (kb, db, _))| kb == ka && db == da)
            {
                let angular = matches!(ka, TestKind::CircleCcw | TestKind::CircleCw);
                let (s, m) = pair_stats(ra, ca, rb, cb, angular);
                ss += s;
                n += m;
            }
        }
    }
    (n > 10).then(|| (ss / (2.0 * n as f64)).sqrt())
}
