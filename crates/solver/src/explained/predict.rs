//! What a check is predicted to show once findings are compensated: the readings less the
//! compensated effects' share as the explained model fitted it, identified by the 21-term
//! model alone; its residual RMS is the prediction (µm).
//!
//! This is the one place the prediction is made: the explained model's document carries it
//! per finding (`Physics::predicted_rms_um`, `Action::predicted_rms_um`) and for every
//! finding at once (`ExplainedModel::predicted_residual_rms_um`), and
//! [`rms_after_compensation`] makes it for any set of findings.

use super::columns::FindingColumns;
use crate::design::{self, ErrorModel, for_each_row};
use crate::session::Session;

/// The explained model's fitted effects on a session: their columns and coefficients.
pub struct FittedEffects<'a> {
    pub columns: &'a FindingColumns<'a>,
    /// The coefficients of every finding's columns, in the columns' order.
    pub coef: &'a [f64],
}

impl FittedEffects<'_> {
    /// The session with the share of the findings `compensated` (indices into the
    /// findings) taken out of every reading: what the machine reads once they are
    /// compensated, as the explained model predicts it.
    pub fn compensated(&self, session: &Session, compensated: &[usize]) -> Session {
        let mut out = session.clone();
        let blocks = self.columns.blocks();
        let width = blocks.iter().map(|b| b.len()).max().unwrap_or(0);
        let mut buf = vec![0.0; width];
        for (p, rec) in session.planes.iter().enumerate() {
            for r in 0..rec.runs.len() {
                let run = &mut out.planes[p].runs[r];
                for_each_row(session, p, r, |m| {
                    let mut share = 0.0;
                    for &i in compensated {
                        let b = &blocks[i];
                        let vals = &mut buf[..b.len()];
                        self.columns.block_at(i, p, r, m.sample, m.comp, vals);
                        share += vals
                            .iter()
                            .zip(&self.coef[b.clone()])
                            .map(|(a, c)| a * c)
                            .sum::<f64>();
                    }
                    let y = if m.comp == 0 {
                        &mut run.du_um[m.sample]
                    } else {
                        &mut run.dv_um[m.sample]
                    };
                    *y -= share;
                });
            }
        }
        out
    }
}

/// Residual RMS of the 21-term model `model` fitted to `session`, µm (what the misfit gate
/// judges).
pub fn rigid_rms(session: &Session, model: &ErrorModel) -> f64 {
    let fit = design::fit(session, model, &|_, _| true, None);
    (fit.solution.rss / fit.reduced.rows.max(1) as f64).sqrt()
}

/// The residual RMS of the 21-term model predicted once the findings `compensated` are
/// compensated (their share taken out of the readings), µm.
pub fn rms_after_compensation(
    session: &Session,
    model: &ErrorModel,
    effects: &FittedEffects,
    compensated: &[usize],
) -> f64 {
    rigid_rms(&effects.compensated(session, compensated), model)
}
