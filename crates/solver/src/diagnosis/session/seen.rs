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
//!
//! A candidate that qualified there too but whose held-out sum of squares was at least
//! [`FAR_HELDOUT`] times that of the candidate the first diagnosis admitted from the
//! same model is deferred ([`super::super::engine::Greedy::deferred`]): evaluated only
//! when the second diagnosis's choice among the others is set aside or none of them
//! qualifies. The loop chooses among qualifying candidates by their held-out sums of
//! squares; on a servo-lag session these are the effects that soak up part of the lag
//! (a backlash, a reversal spike, a cyclic error, a thermal drift: sums of squares 4 to
//! 13 times the lag's, by their ΔBIC), which a few hundred samples left out cannot
//! bring within reach of it. Should the second diagnosis set its choice aside, or none
//! of the others qualify, the deferred are evaluated and the choice is among all.

use crate::diagnosis::catalogue::Candidate;
use std::sync::Mutex;

/// The gain n·ln(SSR₀/SSR₁) of the first diagnosis below which a candidate is not
/// evaluated again in the second (module docs). On the servo-lag session of the benchmark
/// (BENCHMARKS.md, "Diagnosis against identification") no candidate's ΔBIC moved by more
/// than 11 between the two diagnoses but the lag's own and those it soaks up (gains of
/// thousands).
pub(super) const SPARE_GAIN: f64 = 10.0;

/// The ratio of a candidate's held-out sum of squares in the first diagnosis to that of
/// the candidate admitted from the same model at or above which the second defers it
/// (module docs). On the servo-lag session of the benchmark the lost-motion profile
/// that soaks up most of the lag is within it (a sum of squares about 1.9 times the
/// lag's, by their ΔBIC), and is evaluated.
pub(super) const FAR_HELDOUT: f64 = 2.0;

/// One candidate as a diagnosis evaluated it: the candidates admitted into the model it
/// extended (in order), the candidate, its gain and its held-out sum of squares.
type Record = (Vec<Candidate>, Candidate, f64, f64);

/// A candidate a diagnosis admitted, with the candidates admitted before it (in order).
type Admitted = (Vec<Candidate>, Candidate);

/// Each candidate as a diagnosis evaluated it, and the candidate admitted from each
/// model.
#[derive(Default)]
pub(super) struct Seen(Mutex<(Vec<Record>, Vec<Admitted>)>);

impl Seen {
    /// Records the candidate `c`'s `gain` (its ΔBIC less k·ln n: n·ln(SSR₁/SSR₀), ≤ 0) and
    /// its held-out sum of squares `heldout` on the model of the findings `path`.
    pub fn record(&self, path: &[Candidate], c: &Candidate, gain: f64, heldout: f64) {
        self.0
            .lock()
            .expect("seen candidates")
            .0
            .push((path.to_vec(), c.clone(), gain, heldout));
    }

    /// Records that the candidate `c` was admitted into the model of the findings `path`.
    pub fn admitted(&self, path: &[Candidate], c: &Candidate) {
        self.0
            .lock()
            .expect("seen candidates")
            .1
            .push((path.to_vec(), c.clone()));
    }

    /// Whether the candidate `c` on the model of the findings `path` need not be
    /// evaluated again: seen on that model with a gain of less than [`SPARE_GAIN`].
    pub fn spares(&self, path: &[Candidate], c: &Candidate) -> bool {
        self.0
            .lock()
            .expect("seen candidates")
            .0
            .iter()
            .any(|(p, seen, gain, _)| p == path && seen == c && *gain >= -SPARE_GAIN)
    }

    /// Whether the candidate `c` on the model of the findings `path` is deferred: seen on
    /// that model with a held-out sum of squares at least [`FAR_HELDOUT`] times that of
    /// the candidate admitted from it (module docs).
    pub fn defers(&self, path: &[Candidate], c: &Candidate) -> bool {
        let seen = self.0.lock().expect("seen candidates");
        let heldout = |x: &Candidate| {
            seen.0
                .iter()
                .find(|(p, s, _, _)| p == path && s == x)
                .map(|r| r.3)
        };
        let Some((_, chosen)) = seen.1.iter().find(|(p, _)| p == path) else {
            return false;
        };
        match (heldout(c), heldout(chosen)) {
            (Some(h), Some(h0)) => c != chosen && h >= FAR_HELDOUT * h0,
            _ => false,
        }
    }
}
