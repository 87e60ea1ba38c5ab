//! The greedy selection of one axis (the parent module's "Selection"): each candidate's
//! nonlinear parameter by a 1-D search, leave-one-run-out held-out scores, and the loop
//! that adds the best qualifying candidate until none qualifies.

use super::super::lsq;
use super::super::{SeriesOptions, bic, grid_then_golden, rms};
use super::columns::{Effect, Model, Term};
use super::data::AxisData;
use crate::diagnosis::{BeforeAfter, Monotone};

impl AxisData {
    /// Fits `m + e` on `rows`, searching e's nonlinear parameter; returns the term.
    pub(super) fn search(&self, m: &Model, e: Effect, rows: &[usize]) -> Term {
        if !e.nonlinear() {
            return Term {
                effect: e,
                theta: 0.0,
            };
        }
        let y: Vec<f64> = rows.iter().map(|&i| self.y[i]).collect();
        let sse_at = |v: f64| {
            let mut mm = m.clone();
            mm.terms.push(Term {
                effect: e,
                theta: AxisData::theta_of(e, v),
            });
            lsq::sse(&self.design(&mm).rows(rows), &y)
        };
        let (v, _) = grid_then_golden(&self.grid(e), 20, sse_at);
        Term {
            effect: e,
            theta: AxisData::theta_of(e, v),
        }
    }

    /// Leave-one-run-out held-out SSE of `m` (+ `extra`, re-searched in every fold).
    pub(super) fn loro(&self, m: &Model, extra: Option<Effect>) -> f64 {
        let mut total = 0.0;
        for &r in &self.runs {
            let train: Vec<usize> = (0..self.n()).filter(|&i| self.run[i] != r).collect();
            let test: Vec<usize> = (0..self.n()).filter(|&i| self.run[i] == r).collect();
            let mut mm = m.clone();
            if let Some(e) = extra {
                mm.terms.push(self.search(m, e, &train));
            }
            let d = self.design(&mm);
            let fit = lsq::solve(
                &d.rows(&train),
                &train.iter().map(|&i| self.y[i]).collect::<Vec<_>>(),
            );
            let pred = d.rows(&test).predict(&fit.coef);
            total += test
                .iter()
                .zip(&pred)
                .map(|(&i, p)| (self.y[i] - p).powi(2))
                .sum::<f64>();
        }
        total
    }

    pub(super) fn fit_all(&self, m: &Model) -> (lsq::LsqFit, Vec<f64>) {
        let d = self.design(m);
        let fit = lsq::solve(&d, &self.y);
        let res = self
            .y
            .iter()
            .zip(d.predict(&fit.coef))
            .map(|(a, b)| a - b)
            .collect();
        (fit, res)
    }
}

/// One accepted step of the greedy search.
pub(super) struct Step {
    pub(super) label: &'static str,
    pub(super) rms: BeforeAfter,
    pub(super) heldout: BeforeAfter,
    pub(super) dbic: f64,
    pub(super) order: Option<(usize, usize)>,
    pub(super) effect: Option<Effect>,
}

/// The outcome of the greedy selection of one axis.
pub(super) struct Selection {
    pub(super) noise: f64,
    /// The rigid model's residuals (all rows), their RMS and its LORO held-out RMS.
    pub(super) base_res: Vec<f64>,
    pub(super) base_rms: f64,
    pub(super) base_heldout: f64,
    /// The final model, the steps that built it and its LORO held-out SSE.
    pub(super) model: Model,
    pub(super) steps: Vec<Step>,
    pub(super) heldout_sse: f64,
}

/// Chooses the rigid order by LORO error, then adds effects greedily (parent module docs);
/// reports its phases within the part `span` of the whole work.
pub(super) fn select(
    a: &AxisData,
    opts: &SeriesOptions,
    progress: &mut Monotone,
    span: (f64, f64),
) -> Selection {
    let n = a.n();
    progress.report_in(
        span,
        &format!("axis {}: noise floor and rigid order", a.axis),
        0.0,
    );
    let noise = a.noise_floor();
    // Rigid model: order by LORO among 1..=max_base_order.
    let mut model = (1..=opts.max_base_order.max(1))
        .map(|k| Model {
            order: k,
            terms: vec![],
        })
        .min_by(|m1, m2| a.loro(m1, None).total_cmp(&a.loro(m2, None)))
        .expect("at least one order");
    let (base_fit, base_res) = a.fit_all(&model);
    let base_rms = rms(&base_res);
    let mut cur_loro = a.loro(&model, None);
    let base_heldout = (cur_loro / n as f64).sqrt();
    let mut cur_sse = base_fit.sse;
    let mut steps: Vec<Step> = vec![];

    let mut effects = vec![
        Effect::Backlash,
        Effect::Spike,
        Effect::Cyclic,
        Effect::Thermal,
    ];
    if a.temp.is_some() {
        effects.push(Effect::ThermalTemp);
    }
    while steps.len() < opts.max_findings {
        progress.report_in(
            span,
            &format!("axis {}: round {} of candidates", a.axis, steps.len() + 1),
            0.1 + 0.85 * steps.len() as f64 / opts.max_findings as f64,
        );
        if (cur_loro / n as f64).sqrt() <= opts.stop_ratio * noise {
            break;
        }
        let k_cur = model.n_params();
        let cur_bic = bic(cur_sse, n, k_cur);
        // (candidate model, held-out SSE, ΔBIC, effect or order change)
        let mut best: Option<(Model, f64, f64, Option<Effect>)> = None;
        let mut consider = |m: Model, ho: f64, sse: f64, e: Option<Effect>| {
            let dbic = bic(sse, n, m.n_params()) - cur_bic;
            let ok = dbic <= -opts.bic_threshold && ho <= (1.0 - opts.min_heldout_gain) * cur_loro;
            if ok && best.as_ref().is_none_or(|b| ho < b.1) {
                best = Some((m, ho, dbic, e));
            }
        };
        for &e in &effects {
            let taken = model
                .terms
                .iter()
                .any(|t| t.effect == e || (t.effect.name() == e.name()));
            if taken {
                continue;
            }
            let term = a.search(&model, e, &a.all_rows());
            let mut m = model.clone();
            m.terms.push(term);
            let sse = a.fit_all(&m).0.sse;
            let ho = a.loro(&model, Some(e));
            consider(m, ho, sse, Some(e));
        }
        for k in model.order + 1..=opts.max_order {
            let m = Model {
                order: k,
                ..model.clone()
            };
            let sse = a.fit_all(&m).0.sse;
            let ho = a.loro(&m, None);
            consider(m, ho, sse, None);
        }
        let Some((m, ho, dbic, e)) = best else { break };
        let sse = a.fit_all(&m).0.sse;
        steps.push(Step {
            label: e.map_or("model_order", Effect::name),
            rms: BeforeAfter {
                before: (cur_sse / n as f64).sqrt(),
                after: (sse / n as f64).sqrt(),
            },
            heldout: BeforeAfter {
                before: (cur_loro / n as f64).sqrt(),
                after: (ho / n as f64).sqrt(),
            },
            dbic,
            order: e.is_none().then_some((model.order, m.order)),
            effect: e,
        });
        model = m;
        cur_loro = ho;
        cur_sse = sse;
    }
    Selection {
        noise,
        base_res,
        base_rms,
        base_heldout,
        model,
        steps,
        heldout_sse: cur_loro,
    }
}
