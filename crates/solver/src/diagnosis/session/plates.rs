//! The plate scales of the final model restated (`catalogue::plate_scale`): the data
//! determine only the differences between a group's mountings, so the loop's choice of
//! which k − 1 of k enter the model (the first that explains most, then the next) is a
//! gauge, not physics. After the loop each group's scales are refitted jointly with the
//! final model and reported against the group's median mounting
//! ([`plate_scale::median_reference`]); a plate scale found for that mounting moves to
//! the one left as the reference before (the same model: any k − 1 of the group's
//! columns span the same space with the axes' scales).

use super::catalogue::{self, Candidate, plate_scale};
use super::context::State;
use super::trial::{Trial, report_parameters};
use super::{Finding, SessionProblem};
use crate::axis::Axis;
use crate::diagnosis::linalg::dot;

impl SessionProblem<'_> {
    /// Each mounting of `set` fitted jointly with the final model `s`'s columns other than
    /// its plate scales and the plate scales of the rest of `set`: the trial and its
    /// residual σ (µm), in `set`'s order; `None` when one cannot be fitted.
    fn plates_joint(&self, s: &State, set: &[String]) -> Option<Vec<(Trial, f64)>> {
        let d = self.ctx.d;
        let mut out = Vec::new();
        for m in set {
            let mut cols = Vec::new();
            let mut local = Vec::new();
            for (i, c) in s.fit.cols.iter().enumerate() {
                if !s.plate_cols.contains(&i) {
                    cols.push(c.clone());
                    local.push(s.fit.local[i]);
                }
            }
            for other in set.iter().filter(|o| *o != m) {
                let cand = plate_scale::candidate(other);
                for mut col in catalogue::columns(d, &cand, 0.0, None).0 {
                    let nrm = dot(&col, &col).sqrt().max(1e-300);
                    col.iter_mut().for_each(|v| *v /= nrm);
                    cols.push(col);
                    local.push(false);
                }
            }
            let k = s.k + set.len() - s.plates.len() - 1;
            let base = self.state(
                self.ctx.fit(cols, local),
                k,
                s.backlash,
                s.profiled,
                None,
                None,
            );
            let t = self.ctx.try_candidate(&base, &plate_scale::candidate(m))?;
            let sigma = (t.ssr / self.dof.saturating_sub(k + t.ncols).max(1) as f64).sqrt();
            out.push((t, sigma));
        }
        Some(out)
    }

    /// The final model's plate-scale findings restated against each group's median
    /// mounting (module docs).
    pub(super) fn restate_plates(&self, s: &State, findings: &mut [Finding]) {
        let d = self.ctx.d;
        for group in plate_scale::groups(d) {
            let held: Vec<String> = s
                .plates
                .iter()
                .filter(|m| group.contains(m))
                .cloned()
                .collect();
            if held.is_empty() {
                continue;
            }
            let Some(now) = self.plates_joint(s, &held) else {
                continue;
            };
            let value = |t: &Trial| t.coef.first().copied().unwrap_or(0.0);
            let values: Vec<(String, f64)> = group
                .iter()
                .map(|m| {
                    let v = held.iter().zip(&now).find(|(h, _)| *h == m);
                    (m.clone(), v.map_or(0.0, |(_, (t, _))| value(t)))
                })
                .collect();
            let Some(reference) = plate_scale::median_reference(&values) else {
                continue;
            };
            // The group's reference is the one mounting left out: swap only when all
            // others are in the model and the median is one of them.
            let swap = held.len() + 1 == group.len() && held.iter().any(|h| h == reference);
            let set: Vec<String> = if swap {
                group.iter().filter(|m| *m != reference).cloned().collect()
            } else {
                held.clone()
            };
            let trials = if swap {
                match self.plates_joint(s, &set) {
                    Some(t) => t,
                    None => continue,
                }
            } else {
                now
            };
            for (m, (t, sigma)) in set.iter().zip(trials) {
                let label = |x: &str| format!("{} of mounting `{x}`:", plate_scale::NAME);
                let at = findings
                    .iter()
                    .position(|f| f.evidence.starts_with(&label(m)))
                    .or_else(|| {
                        findings
                            .iter()
                            .position(|f| f.evidence.starts_with(&label(reference)))
                    });
                let Some(i) = at else { continue };
                let mut params = report_parameters(&t, sigma, d);
                plate_scale::parameters(&mut params, d);
                let f = &mut findings[i];
                f.evidence = f.evidence.replacen(
                    &label(reference),
                    &label(m),
                    usize::from(!f.evidence.starts_with(&label(m))),
                );
                f.signature = Some(plate_scale::signature(
                    d,
                    &set,
                    m,
                    params.get("scale_ppm").copied(),
                ));
                let refs: Vec<String> = group
                    .iter()
                    .filter(|g| !set.contains(g))
                    .map(|g| format!("`{g}`"))
                    .collect();
                f.evidence += &format!(
                    "; refitted in the final model against the group's median, mounting(s) {}",
                    refs.join(", ")
                );
                f.parameters = params;
            }
        }
    }

    /// The form tests of a plate scale `t` of candidate `c` on the model `s`; the reasons
    /// it is set aside, `None` for any other candidate or when both hold.
    ///
    /// - **Both readings alike.** A plate scales both readings of its mounting alike, so
    ///   its one column must fit better than either reading's scale alone on the same runs
    ///   (`plate_scale::half`, one parameter each). When one axis alone fits as well, the
    ///   mounting's misfit is that axis's scale differing from the other mountings'
    ///   readings of it — a warm-up of the axis between the mountings, not the plate. The
    ///   plate must fit better by the engine's own ΔBIC for admitting an effect (the
    ///   options' `min_bic_gain`, 10 by default: "very strong" evidence, odds of about 150
    ///   to one).
    /// - **Constant in time.** A plate's scale is its temperature against its
    ///   certificate's, or the certificate: constant over its mounting, while a warm-up
    ///   grows in time. Fitted per reading axis with one scale per quarter of the
    ///   mounting's time ([`Self::plate_constancy`]), scales that change must not gain
    ///   that same ΔBIC over one constant scale per axis (their extra parameters
    ///   counted).
    pub(super) fn plate_form_broken(&self, s: &State, c: &Candidate, t: &Trial) -> Option<String> {
        let m = c.mounting.as_deref().filter(|_| c.axis.is_none())?;
        let n = self.ctx.d.rows() as f64;
        let need = self.ctx.bic_threshold;
        let halves: Vec<(Axis, f64)> = plate_scale::axes_read(self.ctx.d, m)
            .into_iter()
            .filter_map(|a| Some((a, self.ctx.try_candidate(s, &plate_scale::half(m, a))?.ssr)))
            .collect();
        let mut why = Vec::new();
        if let Some((a, ssr)) = halves.into_iter().min_by(|x, y| x.1.total_cmp(&y.1)) {
            let gap = n * (ssr / t.ssr).ln();
            if gap < need {
                why.push(format!(
                    "a plate scales both readings of its mounting alike, but the {a} reading's scale alone on its runs fits within ΔBIC {gap:+.1} of it (from {need:.0} on a plate): the {a} axis's scale changed between mountings (a warm-up of {a}), not the plate"
                ));
            }
        }
        if let Some(k) = self.plate_constancy(s, m).filter(|k| k.gain >= need) {
            why.push(k.sentence(need));
        }
        (!why.is_empty()).then(|| format!("{}: {}", c.label(), why.join("; ")))
    }

    /// The constancy test of mounting `m`'s plate scale on the model `s`: the scale of
    /// each reading axis on the mounting's runs (`plate_scale::apart`: the test of
    /// both-readings-alike is the form test's), constant, against one per quarter of the
    /// mounting's recorded time. The plan reads one axis's lines after the other's, so
    /// a scale per quarter of the plate's one column would read two axes that differ as
    /// a change in time; per axis it does not. `None` when no axis's scale varies in two
    /// quarters.
    fn plate_constancy(&self, s: &State, m: &str) -> Option<Constancy> {
        let d = self.ctx.d;
        let times = &d.fields.t_s;
        let (mut t0, mut t1) = (f64::INFINITY, f64::NEG_INFINITY);
        for run in d.runs.iter().filter(|r| d.mountings[r.plane_idx] == m) {
            for &x in &times[run.start..run.end] {
                (t0, t1) = (t0.min(x), t1.max(x));
            }
        }
        let axes = plate_scale::axes_read(d, m);
        let apart = plate_scale::apart(d, m, &axes);
        let (_, keep0, constant) = self.ctx.evaluate(&s.fit, &apart, false)?;
        // Samples of other mountings fall in any segment: the columns are 0 there.
        let split = apart.per_segment(PLATE_SEGMENTS, times, (t0, t1));
        let (_, keep, jf) = self.ctx.evaluate(&s.fit, &split, false)?;
        let extra = keep.len().checked_sub(keep0.len()).filter(|&k| k > 0)?;
        let n = d.rows() as f64;
        let gain = n * (constant.all.ssr / jf.all.ssr).ln() - extra as f64 * n.ln();
        let sigma = (jf.all.ssr / self.dof.saturating_sub(s.k + keep.len()).max(1) as f64).sqrt();
        let scales = axes
            .iter()
            .enumerate()
            .map(|(j, &a)| {
                let quarters = (0..PLATE_SEGMENTS)
                    .filter_map(|g| {
                        let i = keep.iter().position(|&k| k == g * axes.len() + j)?;
                        Some((jf.all.x[i], jf.all.sd[i] * sigma))
                    })
                    .collect();
                (a, quarters)
            })
            .collect();
        Some(Constancy { gain, scales })
    }
}

/// Quarters of a mounting's recorded time the constancy test fits its plate scale in.
const PLATE_SEGMENTS: usize = 4;

/// The constancy test's outcome: the ΔBIC of a scale per quarter of the mounting's time
/// over one constant scale (its extra parameters counted), and the scale read in each
/// quarter where it varies, per reading axis (ppm, with its σ).
struct Constancy {
    gain: f64,
    scales: Vec<(Axis, Vec<(f64, f64)>)>,
}

impl Constancy {
    /// The sentence a plate scale set aside by the test carries.
    fn sentence(&self, need: f64) -> String {
        let scales: Vec<String> = self
            .scales
            .iter()
            .map(|(a, q)| {
                let q: Vec<String> = q
                    .iter()
                    .map(|(k, sd)| format!("{k:.2} ± {sd:.2}"))
                    .collect();
                format!("{a} {}", q.join(", "))
            })
            .collect();
        format!(
            "a plate's scale is constant over its mounting (its temperature or its certificate), but the scale of each reading fitted per quarter of the mounting's time reads {} ppm (ΔBIC {:+.1} for scales that change, from {need:.0}): a scale that grows in time (a warm-up of the axes it reads), not the plate",
            scales.join("; "),
            self.gain
        )
    }
}
