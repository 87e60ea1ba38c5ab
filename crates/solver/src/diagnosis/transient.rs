//! A transient: an offset of one direction's readings that appears at once and
//! recovers, a·e^(−(t − t₀)/τ) from a time t₀ on, inside one run — a knock, a collision,
//! a chip under the plate that worked free. One-off: its column (`catalogue`,
//! "transient") varies on the run holding t₀ alone (later runs see nothing of it once it
//! has decayed).
//!
//! Its rivals: a lasting step (`step`: the offset stays, τ → ∞) and a burst of scatter
//! (no decay from an onset; the local scan names it). The search
//! (`session::trial::transient`): t₀ at the residual's most significant step along the
//! direction (the onset, by the local scan's rule) and three samples either side, τ on a
//! geometric grid within the run then by golden section in ln τ; a τ at the grid's top
//! (a decay the run does not see end) is a step's, not a transient's; a τ under
//! [`DECAY_LEAST_INTERVALS`] sample intervals is an excursion's.

use super::design::Design;

/// The decay grid's ratio.
pub const DECAY_RATIO: f64 = 1.5;

/// The decay grid's first value, in mean sample intervals: a decay within one interval
/// is one reading off (an excursion), not a transient.
pub const DECAY_FIRST_INTERVALS: f64 = 1.0;

/// The shortest decay of a transient, in mean sample intervals: a shorter one is one or
/// two readings off (an excursion, which the local scan names; a reversal's transient
/// the spike's column misses at a circle's turn reads so), not an offset seen to recover.
pub const DECAY_LEAST_INTERVALS: f64 = 2.0;

/// The longest decay, as a fraction of the run's time after t₀: a longer one does not
/// recover within the run and reads as a step.
pub const DECAY_MOST_OF_RUN: f64 = 0.25;

/// The mean sample interval of run `g` and the time from `t0` to its last sample.
pub fn run_times(d: &Design, g: usize, t0: f64) -> (f64, f64) {
    let run = &d.runs[g];
    let ts = &d.fields.t_s[run.start..run.end];
    let dt = (ts[ts.len() - 1] - ts[0]) / (ts.len() - 1).max(1) as f64;
    (dt, ts[ts.len() - 1] - t0)
}

/// The decay grid of a transient at `t0` in run `g`: from [`DECAY_FIRST_INTERVALS`]
/// sample intervals by [`DECAY_RATIO`] up to [`DECAY_MOST_OF_RUN`] of the run after t₀.
pub fn decay_grid(d: &Design, g: usize, t0: f64) -> Vec<f64> {
    let (dt, rest) = run_times(d, g, t0);
    let top = DECAY_MOST_OF_RUN * rest;
    (0..)
        .map(|i| DECAY_FIRST_INTERVALS * dt * DECAY_RATIO.powi(i))
        .take_while(|&v| v <= top)
        .collect()
}
