//! One axis's positioning runs as a [`Problem`] of the diagnosis engine: the rigid
//! Legendre model, the candidate effects of the parent module's table (each not yet in the
//! model) and every higher polynomial order up to `max_order`, leave-one-run-out folds,
//! and the noise floor of repeated readings. The rigid order itself is chosen by the
//! same held-out figure among 1..=`max_base_order`.

use super::super::SeriesOptions;
use super::columns::{Effect, Model, Term};
use super::data::AxisData;
use crate::diagnosis::Monotone;
use crate::diagnosis::engine::{self, Fold, Problem, Rules, Selection};
use crate::diagnosis::lsq::Design;

/// A candidate: an effect of the table, or the polynomial raised to an order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Candidate {
    Effect(Effect),
    Order(usize),
}

/// One axis with the candidates it offers.
pub(super) struct Positioning<'a> {
    pub(super) a: &'a AxisData,
    max_order: usize,
    effects: Vec<Effect>,
}

impl<'a> Positioning<'a> {
    pub(super) fn new(a: &'a AxisData, opts: &SeriesOptions) -> Positioning<'a> {
        let mut effects = vec![
            Effect::Backlash,
            Effect::Spike,
            Effect::Cyclic,
            Effect::Thermal,
        ];
        if a.temp.is_some() {
            effects.push(Effect::ThermalTemp);
        }
        Positioning {
            a,
            max_order: opts.max_order,
            effects,
        }
    }
}

impl Problem for Positioning<'_> {
    type Model = Model;
    type Candidate = Candidate;

    fn readings(&self) -> &[f64] {
        &self.a.y
    }
    fn fit_rows(&self) -> Vec<usize> {
        (0..self.a.n()).collect()
    }
    /// Leave one run out: every run is predicted by the fit on the others.
    fn folds(&self) -> Vec<Fold> {
        let a = self.a;
        a.runs
            .iter()
            .map(|&r| Fold {
                train: (0..a.n()).filter(|&i| a.run[i] != r).collect(),
                test: (0..a.n()).filter(|&i| a.run[i] == r).collect(),
            })
            .collect()
    }
    fn noise_floor(&self) -> f64 {
        self.a.repeat_scatter()
    }
    fn columns(&self, m: &Model) -> Design {
        self.a.design(m)
    }
    fn n_params(&self, m: &Model) -> f64 {
        m.n_params() as f64
    }
    /// Effects of another name than those in `m` (one `thermal_drift` at most), and every
    /// higher order.
    fn candidates(&self, m: &Model) -> Vec<Candidate> {
        let free = self
            .effects
            .iter()
            .filter(|e| !m.terms.iter().any(|t| t.effect.name() == e.name()))
            .map(|&e| Candidate::Effect(e));
        free.chain((m.order + 1..=self.max_order).map(Candidate::Order))
            .collect()
    }
    fn grid(&self, c: Candidate) -> Vec<f64> {
        match c {
            Candidate::Effect(e) if e.nonlinear() => self.a.grid(e),
            _ => vec![],
        }
    }
    fn extend(&self, m: &Model, c: Candidate, v: f64) -> Model {
        let mut m = m.clone();
        match c {
            Candidate::Effect(e) => m.terms.push(Term {
                effect: e,
                theta: AxisData::theta_of(e, v),
            }),
            Candidate::Order(k) => m.order = k,
        }
        m
    }
}

/// The rigid order by held-out error, then the engine's loop; phases reported within the
/// part `span` of the whole work.
pub(super) fn select<'a>(
    p: &Positioning<'a>,
    opts: &SeriesOptions,
    progress: &mut Monotone,
    span: (f64, f64),
) -> Selection<Positioning<'a>> {
    progress.report_in(
        span,
        &format!("axis {}: noise floor and rigid order", p.a.axis),
        0.0,
    );
    let rigid = (1..=opts.max_base_order.max(1))
        .map(|order| {
            let m = Model {
                order,
                terms: vec![],
            };
            (engine::heldout_sse(p, &m, None, &m), m)
        })
        .min_by(|x, y| x.0.total_cmp(&y.0))
        .expect("at least one order")
        .1;
    let rules = Rules {
        bic_threshold: opts.bic_threshold,
        min_heldout_gain: opts.min_heldout_gain,
        stop_ratio: opts.stop_ratio,
        max_findings: opts.max_findings,
    };
    engine::select(
        p,
        rigid,
        &rules,
        &format!("axis {}", p.a.axis),
        progress,
        span,
    )
}
