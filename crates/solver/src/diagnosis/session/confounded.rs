//! Candidates whose fit the data cannot tell from another mechanism's, left out of the
//! findings with the reason (docs/diagnosis.md, "A model form that does not hold"):
//!
//! | candidate | read instead | rule |
//! |---|---|---|
//! | `vibration` | an error that changes during the session or follows the plan's motion | its amplitude and phase differ between the quarters of the session ([`super::trial`]'s stationarity test, p below `FORM_ALPHA`) |
//! | `step`, `transient` | the play of its axis wider or narrower at that reversal than the model's | its time is where its axis reverses (within a sample interval) |

use super::context::State;
use super::trial::Trial;
use super::{FORM_ALPHA, SessionProblem};
use crate::diagnosis::catalogue::Candidate;
use crate::diagnosis::design::Design;

impl SessionProblem<'_> {
    /// Why candidate `c`'s trial `t` is not what it names (module documentation), or
    /// `None`.
    pub(super) fn confounded(
        &self,
        s: &State,
        c: &Candidate,
        t: &Trial,
        sigma: f64,
    ) -> Option<String> {
        match c.effect {
            "vibration" => self
                .ctx
                .stationarity(s, t, sigma)
                .filter(|st| st.p < FORM_ALPHA)
                .map(|st| st.sentence()),
            "step" | "transient" => at_reversal(self.ctx.d, c, t.theta?.1),
            _ => None,
        }
    }
}

/// Why a one-off event of candidate `c` at time `t0` (s) is read as the play instead:
/// its axis reverses between the samples around `t0`, where a play whose width differs
/// from the model's moves the readings by as much as a step or a decay would.
fn at_reversal(d: &Design, c: &Candidate, t0: f64) -> Option<String> {
    let a = c.direction.or(c.axis)?;
    let g = d.run_at_time(t0)?;
    let r = &d.runs[g];
    let ts = &d.fields.t_s;
    let since = &d.fields.since_reversal_mm[a.index()];
    let k = r.start + ts[r.start..r.end].partition_point(|&x| x < t0);
    let (lo, hi) = (k.saturating_sub(2).max(r.start), (k + 1).min(r.end - 1));
    // The travel since the last reversal starts again from 0: a reversal (or the first
    // motion the other way after a standstill) between two of these samples.
    let reverses = (lo..hi).any(|i| since[i + 1] < since[i]);
    reverses.then(|| {
        format!(
            "not a one-off event: at t = {t0:.2} s {a} reverses, where a play of {a} wider or narrower than the model's moves the readings as much; the same reversal recorded again, or a standstill before and after it, would tell a lost count or a knock from the play"
        )
    })
}
