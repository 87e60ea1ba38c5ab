//! What a session's first diagnosis saw of each candidate, which its second diagnosis
//! (the ramps' samples left out: [`super::diagnose_session_with_progress`]) reads to
//! spare the searches of candidates that were nowhere near qualifying.
//!
//! The second diagnosis fits the same catalogue on the same session less a few hundred
//! samples (the starts and stops of the motion of the lagging axes: about 0.1 % of the
//! rows). On a model the first diagnosis also reached (the same findings admitted in the
//! same order), a candidate whose columns lowered n·ln SSR by less than [`SPARE_GAIN`]
//! there (its ΔBIC less its k·ln n) is not evaluated again: it explained no more than
//! noise, and to qualify (ΔBIC ≤ −10, a gain of at least 10 + k·ln n) it would need to
//! gain k·ln n more (about 13 for one parameter, 38 for three at 300 000 rows) from
//! leaving those samples out. Every other candidate, and every candidate of a model the first diagnosis did not
//! reach, is evaluated as in the first. Only the choice among qualifying candidates reads
//! a round's trials (a rival is fitted afresh, [`super::rivals`]), so a spared candidate
//! changes a result only if it would have qualified.

use crate::diagnosis::catalogue::Candidate;
use std::sync::Mutex;

/// The gain n·ln(SSR₀/SSR₁) of the first diagnosis below which a candidate is not
/// evaluated again in the second (module docs). On the servo-lag session of the benchmark
/// (BENCHMARKS.md, "Diagnosis against identification") no candidate's ΔBIC moved by more
/// than 11 between the two diagnoses but the lag's own and those it soaks up (gains of
/// thousands).
pub(super) const SPARE_GAIN: f64 = 10.0;

/// Each candidate's gain as a diagnosis evaluated it, with the candidates admitted into
/// the model it extended (in order).
#[derive(Default)]
pub(super) struct Seen(Mutex<Vec<(Vec<Candidate>, Candidate, f64)>>);

impl Seen {
    /// Records the candidate `c`'s `gain` (its ΔBIC less k·ln n: n·ln(SSR₁/SSR₀), ≤ 0) on
    /// the model of the findings `path`.
    pub fn record(&self, path: &[Candidate], c: &Candidate, gain: f64) {
        self.0
            .lock()
            .expect("seen candidates")
            .push((path.to_vec(), c.clone(), gain));
    }

    /// Whether the candidate `c` on the model of the findings `path` need not be
    /// evaluated again: seen on that model with a gain of less than [`SPARE_GAIN`].
    pub fn spares(&self, path: &[Candidate], c: &Candidate) -> bool {
        self.0
            .lock()
            .expect("seen candidates")
            .iter()
            .any(|(p, seen, gain)| p == path && seen == c && *gain >= -SPARE_GAIN)
    }
}
