//! The stationarity test of a vibration: one amplitude and phase over the whole session
//! against one per segment of it in time.
//!
//! A vibration of the machine runs on whatever the axes do, with one amplitude and one
//! phase in time. A slow error that changes during the session (a warm-up, a play that
//! widens and narrows) or one bound to the motion (a scale of the plate, read through a
//! plan whose runs repeat every few tens of seconds) can also take a sine in time at a
//! frequency near the plan's own cadence, but with another amplitude and phase in each
//! part of the session. Fitted per segment, such a sine gains far more than its
//! stationary form allows; a vibration's does not.

use crate::diagnosis::catalogue;
use crate::diagnosis::session::context::{Ctx, State};
use crate::diagnosis::session::trial::Trial;
use crate::diagnosis::session::trial::form_test::lack_of_fit;

/// Segments of the session's time the test fits the vibration in.
pub(crate) const SEGMENTS: usize = 4;

/// The test's outcome: χ² of the per-segment fit's gain, its degrees of freedom, its
/// p-value and the amplitude read in each segment (µm, with its σ).
pub(crate) struct Stationarity {
    pub chi2: f64,
    pub dof: usize,
    pub p: f64,
    pub amplitudes: Vec<(f64, f64)>,
}

impl Stationarity {
    /// The sentence a vibration set aside by the test carries.
    pub fn sentence(&self) -> String {
        let amps: Vec<String> = self
            .amplitudes
            .iter()
            .map(|(a, sd)| format!("{a:.3} ± {sd:.3}"))
            .collect();
        format!(
            "not a vibration: fitted in each quarter of the session its amplitude reads {} um (chi2 = {:.1} on {} degrees of freedom, p = {:.1e}); a vibration keeps its amplitude and phase, while an error that changes during the session or follows the plan's motion does not; a recording at standstill would decide it",
            amps.join(", "),
            self.chi2,
            self.dof,
            self.p
        )
    }
}

impl Ctx<'_> {
    /// The trial's sine and cosine fitted with a pair per quarter of the session's time
    /// instead: where the vibration is stationary the drop of the sum of squares is σ²
    /// times a χ² with 2·(segments − 1) degrees of freedom. `None` when the columns vary
    /// in one segment only.
    pub fn stationarity(&self, s: &State, t: &Trial, sigma: f64) -> Option<Stationarity> {
        let th = t.theta.map_or(0.0, |x| x.1);
        let inner = catalogue::specs(self.d, &t.cand, th, self.eps(s));
        let m = inner.len();
        if m == 0 || m > catalogue::SPLIT_MAX_COLUMNS {
            return None;
        }
        let times = &self.d.fields.t_s;
        let t0 = times.iter().copied().fold(f64::INFINITY, f64::min);
        let t1 = times.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let specs = inner.per_segment(SEGMENTS, times, (t0, t1));
        let (_, keep, jf) = self.evaluate(&s.fit, &specs, false)?;
        let dof = keep.len().checked_sub(m).filter(|&k| k > 0)?;
        let (chi2, p) = lack_of_fit(t.ssr, jf.all.ssr, sigma, dof)?;
        let at = |j: usize| keep.iter().position(|&k| k == j);
        let amplitudes = (0..SEGMENTS)
            .filter_map(|g| {
                let (i, k) = (at(g * m)?, at(g * m + 1)?);
                let (a, b) = (jf.all.x[i], jf.all.x[k]);
                let sd = (jf.all.sd[i].max(jf.all.sd[k])) * sigma;
                Some((a.hypot(b), sd))
            })
            .collect();
        Some(Stationarity {
            chi2,
            dof,
            p,
            amplitudes,
        })
    }
}
