//! ISO 230-2 figures from the constant-feed line passes of a grid-encoder session
//! (the parent module's docs, "Line passes of a session").

use super::{Iso2302, PASS_ID, Reading, Source, evaluate};
use crate::axis::Axis;
use crate::error::SolverError;
use crate::session::{Session, TestKind};
use crate::standards::{NotEvaluated, nearest_first};

/// One line pass: positions along the line (mm) and along-line deviations (µm) of the
/// samples taken while the command progressed (the end dwell dropped).
struct Pass {
    run: i64,
    up: bool,
    pos: Vec<f64>,
    dev: Vec<f64>,
}

impl Pass {
    /// The samples of a line run along `axis` in plane component `comp` (0: u, 1: v),
    /// keeping each sample only when the command has advanced past the previous kept one
    /// (so neither the standstill at the start nor the end dwell).
    fn of(run: &crate::session::Run, axis: Axis, comp: usize) -> Option<Pass> {
        let i = axis.index();
        let first = run.pos_mm.first()?[i];
        let last = run.pos_mm.last()?[i];
        let up = last > first;
        let sgn = if up { 1.0 } else { -1.0 };
        let dev = if comp == 0 { &run.du_um } else { &run.dv_um };
        let (mut pos, mut d) = (vec![], vec![]);
        for (p, &v) in run.pos_mm.iter().zip(dev) {
            // The samples before the command leaves the start still belong to the
            // previous motion (standstill after the reversal): dropped.
            let last = pos.last().copied().unwrap_or(first);
            if sgn * (p[i] - last) > 0.0 {
                pos.push(p[i]);
                d.push(v);
            }
        }
        (pos.len() >= 2).then_some(Pass {
            run: run.number,
            up,
            pos,
            dev: d,
        })
    }

    fn lo(&self) -> f64 {
        self.pos.iter().copied().fold(f64::INFINITY, f64::min)
    }

    fn hi(&self) -> f64 {
        self.pos.iter().copied().fold(f64::NEG_INFINITY, f64::max)
    }

    /// Deviation at `p`: straight-line least-squares fit of the samples within ±`w`,
    /// evaluated at `p`; linear interpolation when fewer than 3 samples fall in it.
    fn at(&self, p: f64, w: f64) -> f64 {
        let near: Vec<(f64, f64)> = self
            .pos
            .iter()
            .zip(&self.dev)
            .filter(|(q, _)| (*q - p).abs() <= w)
            .map(|(&q, &d)| (q - p, d))
            .collect();
        if near.len() >= 3 {
            let n = near.len() as f64;
            let (mq, md) = near
                .iter()
                .fold((0.0, 0.0), |(a, b), (q, d)| (a + q / n, b + d / n));
            let sqq: f64 = near.iter().map(|(q, _)| (q - mq).powi(2)).sum();
            let sqd: f64 = near.iter().map(|(q, d)| (q - mq) * (d - md)).sum();
            let slope = if sqq > 0.0 { sqd / sqq } else { 0.0 };
            return md - slope * mq;
        }
        // Samples are sorted along the pass's direction; interpolate between neighbours.
        let mut idx: Vec<usize> = (0..self.pos.len()).collect();
        idx.sort_by(|&a, &b| self.pos[a].total_cmp(&self.pos[b]));
        let k = idx
            .windows(2)
            .position(|w2| self.pos[w2[1]] >= p)
            .unwrap_or(idx.len() - 2);
        let (a, b) = (idx[k], idx[k + 1]);
        let (pa, pb) = (self.pos[a], self.pos[b]);
        if pb == pa {
            return self.dev[a];
        }
        let f = ((p - pa) / (pb - pa)).clamp(0.0, 1.0);
        self.dev[a] + f * (self.dev[b] - self.dev[a])
    }
}

/// The line passes along each axis of every plane file: (plane index, axis) → passes.
fn line_passes(session: &Session) -> Vec<(usize, Axis, Vec<Pass>)> {
    let mut out: Vec<(usize, Axis, Vec<Pass>)> = vec![];
    for (p, rec) in session.planes.iter().enumerate() {
        let (u_ax, v_ax) = rec.plane.axes();
        for run in &rec.runs {
            let axis = match run.test_kind(rec.plane) {
                TestKind::LineX => Axis::X,
                TestKind::LineY => Axis::Y,
                TestKind::LineZ => Axis::Z,
                _ => continue,
            };
            let comp = if axis == u_ax {
                0
            } else if axis == v_ax {
                1
            } else {
                continue;
            };
            let Some(pass) = Pass::of(run, axis, comp) else {
                continue;
            };
            match out.iter_mut().find(|(pp, a, _)| *pp == p && *a == axis) {
                Some(e) => e.2.push(pass),
                None => out.push((p, axis, vec![pass])),
            }
        }
    }
    out
}

/// Number of targets over a travel of `len` mm for line passes: ISO 230-2's at least
/// five per metre, and never fewer than 11.
pub fn line_target_count(len_mm: f64) -> usize {
    ((5.0 * len_mm / 1000.0).ceil() as usize + 1).max(11)
}

/// ISO 230-2 figures per axis from the line passes of a session (module docs), one per
/// axis: from the plane file whose head offset is nearest the tool reference point
/// (smallest |t|; the first in the session on ties) among those with at least two passes
/// in each direction. Axes with line passes but no usable file are listed as not
/// evaluated.
pub fn from_session(session: &Session) -> (Vec<Iso2302>, Vec<NotEvaluated>) {
    let groups = line_passes(session);
    let mut out = vec![];
    let mut skipped = vec![];
    for axis in Axis::ALL {
        if !groups.iter().any(|(_, a, _)| *a == axis) {
            continue;
        }
        let mut cands: Vec<usize> = (0..groups.len())
            .filter(|&g| {
                let (_, a, passes) = &groups[g];
                *a == axis
                    && passes.iter().filter(|p| p.up).count() >= 2
                    && passes.iter().filter(|p| !p.up).count() >= 2
            })
            .map(|g| groups[g].0)
            .collect();
        nearest_first(session, &mut cands);
        let chosen = cands
            .first()
            .and_then(|&p| groups.iter().find(|(q, a, _)| *q == p && *a == axis));
        let Some((p, _, passes)) = chosen else {
            skipped.push(NotEvaluated {
                standard: "iso230_2".into(),
                what: axis.to_string(),
                reason: format!(
                    "no plane file has at least two line passes along {axis} in each direction"
                ),
            });
            continue;
        };
        match evaluate_passes(axis, passes) {
            Ok(mut f) => {
                let rec = &session.planes[*p];
                f.file = Some(rec.file.clone());
                f.head_offset_mm = Some(rec.head_offset_mm);
                let others: Vec<&str> = cands[1..]
                    .iter()
                    .map(|&q| session.planes[q].file.as_str())
                    .collect();
                if !others.is_empty() {
                    f.notes.push(format!(
                        "other files with passes along {axis}, not evaluated here: {}",
                        others.join(", ")
                    ));
                }
                out.push(f);
            }
            Err(e) => skipped.push(NotEvaluated {
                standard: "iso230_2".into(),
                what: axis.to_string(),
                reason: e.to_string(),
            }),
        }
    }
    (out, skipped)
}

/// ISO 230-2 figures of one axis from line passes (module docs).
fn evaluate_passes(axis: Axis, passes: &[Pass]) -> Result<Iso2302, SolverError> {
    let lo = passes
        .iter()
        .map(Pass::lo)
        .fold(f64::NEG_INFINITY, f64::max);
    let hi = passes.iter().map(Pass::hi).fold(f64::INFINITY, f64::min);
    if hi.is_nan() || hi - lo < 1e-3 {
        return Err(SolverError::InvalidInput(format!(
            "axis {axis}: the line passes share no common travel"
        )));
    }
    let m = line_target_count(hi - lo);
    // Window: ±0.5 mm, at least two sample steps, at most a quarter of the spacing. The
    // targets are inset by it, so that every window is two-sided.
    let mut steps: Vec<f64> = passes
        .iter()
        .flat_map(|p| p.pos.windows(2).map(|w| (w[1] - w[0]).abs()))
        .collect();
    steps.sort_by(f64::total_cmp);
    let step = steps.get(steps.len() / 2).copied().unwrap_or(0.0);
    let w = (0.5f64)
        .max(2.0 * step)
        .min(0.25 * (hi - lo) / (m - 1) as f64);
    let (lo, hi) = (lo + w, hi - w);
    let spacing = (hi - lo) / (m - 1) as f64;
    let targets: Vec<f64> = (0..m).map(|i| lo + spacing * i as f64).collect();
    let mut readings = vec![];
    for (k, pass) in passes.iter().enumerate() {
        let dev: Vec<f64> = targets.iter().map(|&t| pass.at(t, w)).collect();
        let mean = dev.iter().sum::<f64>() / m as f64;
        for (&t, d) in targets.iter().zip(dev) {
            readings.push(Reading {
                target_mm: t,
                up: pass.up,
                // Passes of one file are distinct runs even when numbered alike.
                run: pass.run * PASS_ID + k as i64,
                deviation_um: d - mean,
            });
        }
    }
    let mut f = evaluate(axis, Source::LinePasses, &readings)?;
    f.runs = passes.len();
    f.notes.insert(
        0,
        format!(
            "from constant-feed line passes: each pass is one approach of a bidirectional run over {m} evenly spaced targets ({lo:.3} to {hi:.3} mm), read on the fly (local straight-line fit within ±{w:.3} mm); this is not a standstill test"
        ),
    );
    // Why B, B̄, R, E and A are not given is said once for every axis, in the standards'
    // `not_available` (NOT_FROM_LINE_PASSES).
    Ok(f)
}
