//! One axis's positioning runs as a [`Problem`] of the diagnosis engine: the rigid
//! Legendre model, the candidate effects of the parent module's table (each not yet in the
//! model) and every higher polynomial order up to `max_order`, leave-one-run-out folds,
//! and the noise floor of repeated readings. The rigid order itself is chosen by the
//! same held-out figure among 1..=`max_base_order`.

use super::columns::{Effect, Model, Term};
use super::data::AxisData;
use crate::diagnosis::Monotone;
use crate::diagnosis::engine::{self, Fold, Problem, Rules, Selection};
use crate::diagnosis::lsq::Design;
use crate::diagnosis::repeatability::Repeatability;
use crate::diagnosis::series::SeriesOptions;
use crate::error::SolverError;

/// A candidate: an effect of the table, the polynomial raised to an order, or the lost
/// motion varying along the travel with the order of its profile.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Candidate {
    Effect(Effect),
    Order(usize),
    LostMotion(usize),
}

/// One axis with the candidates it offers.
pub(super) struct Positioning<'a> {
    pub(super) a: &'a AxisData,
    max_order: usize,
    effects: Vec<Effect>,
    /// The noise floor and the outlying approaches it set aside.
    pub(super) rep: Repeatability,
}

impl<'a> Positioning<'a> {
    pub(super) fn new(
        a: &'a AxisData,
        opts: &SeriesOptions,
    ) -> Result<Positioning<'a>, SolverError> {
        let mut effects = vec![
            Effect::Backlash,
            Effect::Spike,
            Effect::Cyclic,
            Effect::Thermal,
            Effect::Transient,
        ];
        if a.temp.is_some() {
            effects.push(Effect::ThermalTemp);
        }
        Ok(Positioning {
            a,
            max_order: opts.max_order,
            effects,
            rep: a.repeatability()?,
        })
    }

    /// Highest order of the lost-motion profile: below the number of targets.
    fn max_lost_motion_order(&self) -> usize {
        self.max_order.min(self.a.targets.len() - 1)
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
    /// Leave one run out: every run is predicted by the fit on the others. The readings
    /// the noise floor set aside as outlying are scored in no fold: a one-off reading is
    /// not predictable from other runs, and would add the same square to every model.
    fn folds(&self) -> Vec<Fold> {
        let a = self.a;
        let aside: Vec<usize> = self.rep.set_aside.iter().map(|o| o.index).collect();
        a.runs
            .iter()
            .map(|&r| Fold {
                train: (0..a.n()).filter(|&i| a.run[i] != r).collect(),
                test: (0..a.n())
                    .filter(|&i| a.run[i] == r && !aside.contains(&i))
                    .collect(),
            })
            .collect()
    }
    fn noise_floor(&self) -> f64 {
        self.rep.sigma_um
    }
    fn columns(&self, m: &Model) -> Design {
        self.a.design(m)
    }
    fn n_params(&self, m: &Model) -> f64 {
        m.n_params() as f64
    }
    /// Effects of another name than those in `m` (one `thermal_drift` at most; no
    /// constant `backlash` once the lost motion varies along the travel), every higher
    /// order, and every higher order of the lost-motion profile.
    fn candidates(&self, m: &Model) -> Vec<Candidate> {
        let free = self
            .effects
            .iter()
            .filter(|e| !m.terms.iter().any(|t| t.effect.name() == e.name()))
            .filter(|e| !(**e == Effect::Backlash && m.lost_motion.is_some()))
            .map(|&e| Candidate::Effect(e));
        let from = m.lost_motion.map_or(1, |k| k + 1);
        free.chain((m.order + 1..=self.max_order).map(Candidate::Order))
            .chain((from..=self.max_lost_motion_order()).map(Candidate::LostMotion))
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
            // The profile's constant column is the constant backlash's.
            Candidate::LostMotion(k) => {
                m.terms.retain(|t| t.effect != Effect::Backlash);
                m.lost_motion = Some(k);
            }
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
            let m = Model::rigid(order);
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
