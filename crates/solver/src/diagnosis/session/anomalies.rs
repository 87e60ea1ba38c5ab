//! Local anomalies of a session: the scan of [`crate::diagnosis::local_scan`] on every run's
//! residual along each of its two reading directions, each anomaly named by its place
//! (file, run, test, reading direction, session time and commanded position).

use crate::axis::Axis;
use crate::diagnosis::design::{Design, RunInfo};
use crate::diagnosis::local_scan::{self, Anomaly, Kind};

/// One run's residual along one reading direction, in sample order.
pub(crate) struct Sequence {
    pub run: usize,
    /// The reading axis.
    pub axis: Axis,
    pub r: Vec<f64>,
}

/// Every run's residual `r` along each of its reading directions.
pub(crate) fn sequences(d: &Design, r: &[f64]) -> Vec<Sequence> {
    directions(d)
        .map(|(g, run, c, axis)| {
            let mut seq = Vec::new();
            sequence(run, c, r, &mut seq);
            Sequence {
                run: g,
                axis,
                r: seq,
            }
        })
        .collect()
}

/// The sequences of [`sequences`] read along `axis` alone, one at a time: `f(run, r)`
/// for each, in the same order (one buffer, not a copy of the whole residual).
pub(crate) fn each_sequence_along(
    d: &Design,
    r: &[f64],
    axis: Axis,
    mut f: impl FnMut(usize, &[f64]),
) {
    let mut seq = Vec::new();
    for (g, run, c, _) in directions(d).filter(|p| p.3 == axis) {
        sequence(run, c, r, &mut seq);
        f(g, &seq);
    }
}

/// Every run with each of its reading directions, in the order of the sequences: (run
/// index, run, direction c (0: the plane's first axis), its axis).
fn directions(d: &Design) -> impl Iterator<Item = (usize, &RunInfo, usize, Axis)> {
    d.runs.iter().enumerate().flat_map(|(g, run)| {
        let (u, v) = d.plane_axes[run.plane_idx];
        [(g, run, 0, u), (g, run, 1, v)]
    })
}

/// Run `run`'s residual `r` along its reading direction `c` (0: the plane's first axis)
/// into `out`.
fn sequence(run: &RunInfo, c: usize, r: &[f64], out: &mut Vec<f64>) {
    out.clear();
    out.extend((run.start..run.end).map(|s| r[2 * s + c]));
}

/// The family-wise thresholds of a scan of every sequence of the session.
pub(crate) fn thresholds(d: &Design) -> [f64; 3] {
    local_scan::ln_thresholds(local_scan::places(
        d.runs.iter().flat_map(|r| [r.end - r.start; 2]),
    ))
}

/// A local anomaly with its place in the session.
pub(crate) struct Located {
    pub anomaly: Anomaly,
    pub run: usize,
    pub axis: Axis,
    /// The sample where it is (the first after a step).
    pub sample: usize,
    /// Σ(r² − σ²) over the samples its statistic reads, the misfit above noise it holds.
    pub excess: f64,
}

/// The local anomalies of the residual `r` against the noise floor `sigma`.
pub(crate) fn scan(d: &Design, r: &[f64], sigma: f64) -> Vec<Located> {
    let seqs = sequences(d, r);
    let refs: Vec<&[f64]> = seqs.iter().map(|s| s.r.as_slice()).collect();
    local_scan::scan(&refs, sigma)
        .into_iter()
        .map(|a| {
            let s = &seqs[a.sequence];
            let excess = s.r[a.span.0..a.span.1]
                .iter()
                .map(|v| v * v - sigma * sigma)
                .sum();
            Located {
                run: s.run,
                axis: s.axis,
                sample: d.runs[s.run].start + a.at,
                excess,
                anomaly: a,
            }
        })
        .collect()
}

/// At most this many events in a session are one-off (a slip, a knock); more are a
/// misfit that recurs (at every reversal, every pass), which the places of the misfit
/// describe. An event is the anomalies of one run ([`events`]).
pub(crate) const MAX_ONE_OFF: usize = 2;

/// The number of events among `found`: anomalies in one run, along either reading
/// direction, are one event (a knock that decays is a step, a burst and an excursion
/// of one run); a misfit recurs across runs.
pub(crate) fn events(found: &[Located]) -> usize {
    let mut runs: Vec<usize> = found.iter().map(|a| a.run).collect();
    runs.sort_unstable();
    runs.dedup();
    runs.len()
}

/// `file run N (test)`: the run of a sample.
pub(crate) fn run_name(d: &Design, g: usize) -> String {
    let run = &d.runs[g];
    format!(
        "{} run {} ({})",
        d.files[run.plane_idx],
        run.number,
        run.test.name()
    )
}

/// The commanded position of sample `s`: `X = 12.30 mm, Y = 0.00 mm, Z = -40.00 mm`.
pub(crate) fn position(d: &Design, s: usize) -> String {
    let q = d.fields.q(s);
    Axis::ALL
        .map(|a| format!("{a} = {:.2} mm", q[a.index()]))
        .join(", ")
}

/// Session time of a step before sample `s`: halfway between the reading before it and
/// `s` (`s`'s time at a run's first sample).
pub(crate) fn step_time(d: &Design, s: usize) -> f64 {
    let t = &d.fields.t_s;
    let first = d.runs[d.fields.run(s)].start;
    if s > first {
        0.5 * (t[s - 1] + t[s])
    } else {
        t[s]
    }
}

impl Located {
    /// The anomaly in words, with its place: kind and size, reading direction, file,
    /// run, test, session time and commanded position.
    pub fn describe(&self, d: &Design) -> String {
        let a = &self.anomaly;
        let t = &d.fields.t_s;
        let start = d.runs[self.run].start;
        let what = match a.kind {
            Kind::Step => format!(
                "step of {:+.3} um in the {} reading at t = {:.2} s",
                a.size,
                self.axis,
                step_time(d, self.sample)
            ),
            Kind::Burst => format!(
                "burst of {:.3} um RMS in the {} reading over t = {:.2}..{:.2} s",
                a.size,
                self.axis,
                t[start + a.span.0],
                t[start + a.span.1 - 1]
            ),
            Kind::Excursion => format!(
                "excursion of {:+.3} um in the {} reading at t = {:.2} s",
                a.size, self.axis, t[self.sample]
            ),
        };
        format!(
            "local anomaly: {what}, {}, at {} (z = {:.1}, family-wise false-alarm rate {} %)",
            run_name(d, self.run),
            position(d, self.sample),
            a.z(),
            100.0 * local_scan::FAMILY_WISE_ALPHA
        )
    }

    /// The test id of its run, as in the mismatch list (`file#run N`).
    pub fn test_id(&self, d: &Design) -> String {
        let r = &d.runs[self.run];
        format!("{}#run {}", d.files[r.plane_idx], r.number)
    }
}
