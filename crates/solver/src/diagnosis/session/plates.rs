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

    /// The form test of a plate scale `t` of candidate `c` on the model `s`: a plate
    /// scales both readings of its mounting alike, so its one column must fit better than
    /// either reading's scale alone on the same runs (`plate_scale::half`, one parameter
    /// each). When one axis alone fits as well, the mounting's misfit is that axis's
    /// scale differing from the other mountings' readings of it — a warm-up of the axis
    /// between the mountings, not the plate: why the plate is set aside. The plate must
    /// fit better by the engine's own ΔBIC for admitting an effect (the options'
    /// `min_bic_gain`, 10 by default: "very strong" evidence, odds of about 150 to one).
    /// `None` for any other candidate, or when the form holds.
    pub(super) fn plate_form_broken(&self, s: &State, c: &Candidate, t: &Trial) -> Option<String> {
        let m = c.mounting.as_deref().filter(|_| c.axis.is_none())?;
        let n = self.ctx.d.rows() as f64;
        let halves: Vec<(Axis, f64)> = plate_scale::axes_read(self.ctx.d, m)
            .into_iter()
            .filter_map(|a| Some((a, self.ctx.try_candidate(s, &plate_scale::half(m, a))?.ssr)))
            .collect();
        let (a, ssr) = halves.into_iter().min_by(|x, y| x.1.total_cmp(&y.1))?;
        let gap = n * (ssr / t.ssr).ln();
        let need = self.ctx.bic_threshold;
        (gap < need).then(|| {
            format!(
                "{}: a plate scales both readings of its mounting alike, but the {a} reading's scale alone on its runs fits within ΔBIC {gap:+.1} of it (from {need:.0} on a plate): the {a} axis's scale changed between mountings (a warm-up of {a}), not the plate",
                c.label()
            )
        })
    }
}
