//! What every step of a session's diagnosis shares: the design, its per-run reduction
//! and the run sets of the folds ([`Ctx`]), and the current model fitted on them
//! ([`State`]: its [`Fit`] and the rigid model's rotation errors per sample when a
//! candidate reads them). Each helper of the session's diagnosis is a method of the
//! context taking the state it extends, instead of the six arguments it would need.

use super::super::catalogue::{self, Candidate, Columns};
use super::super::design::Design;
use super::super::linalg::{Cols, dot};
use super::super::moments::{self, Extra, Moments, Sets};
use super::super::reduced::Reduction;
use super::super::search::{delta_bic, passes_bic_gate};
use super::super::thermal_search::ThermalBasis;
use crate::axis::Axis;
use crate::terms::{Component, Term};
use std::sync::Arc;

/// The design, its reduction, the folds' run sets and the noise floor.
#[derive(Clone, Copy)]
pub(crate) struct Ctx<'a> {
    pub d: &'a Design,
    pub red: &'a Reduction,
    pub sets: &'a Sets,
    /// The noise floor (µm), estimated without a model (NaN until it is).
    pub floor: f64,
    /// The engine's BIC threshold ([`super::super::engine::Rules::bic_threshold`]): a
    /// candidate whose ΔBIC is above −`bic_threshold` cannot qualify
    /// ([`Ctx::may_qualify`]).
    pub bic_threshold: f64,
}

/// The current model (rigid terms and the accepted effects) fitted on all runs and on
/// each fold's training runs.
pub(crate) struct Fit {
    /// Accepted effect columns (centred, unit norm).
    pub cols: Cols,
    /// Per accepted column: whether it is local (a step: refitted on a held-out run).
    pub local: Vec<bool>,
    /// Moments of [accepted effects | y] (the base of every joint fit).
    pub base: moments::Base,
    /// Coefficients of the rigid columns (scaled) on all runs.
    pub a: Vec<f64>,
    pub resid: Vec<f64>,
    pub ssr: f64,
    pub heldout_ssr: f64,
    /// Numerical rank of [rigid | effects] on all runs.
    pub rank: usize,
    /// Where each base column [effects | y] is nonzero ([`Extra`]).
    pub support: Option<Vec<[u64; 2]>>,
}

/// The current model: its fit, the number of parameters added to the rigid model, and
/// the rigid model's rotation errors at every sample when a candidate needs them.
pub(crate) struct State {
    pub fit: Fit,
    pub k: usize,
    pub eps: Option<Vec<[f64; 3]>>,
    /// Per axis: the constant lost motion of its `backlash` finding in the model (value
    /// and σ, µm), which a position-dependent profile of that axis refines.
    pub backlash: [Option<(f64, f64)>; 3],
    /// Per axis: whether a whole position-dependent lost motion (constant part included)
    /// is in the model.
    pub profiled: [bool; 3],
    /// The moments of the candidates without a nonlinear parameter on this model, kept
    /// for the next ([`Ctx::moments_kept`]).
    pub kept: std::sync::Mutex<Vec<(Candidate, Moments)>>,
    /// Those of the model before it, with its number of base columns.
    pub prior: Option<(Vec<(Candidate, Moments)>, usize)>,
    /// The thermal searches' basis moments on this model, formed once for its time form
    /// and its lagged form ([`Ctx::thermal_basis`]).
    pub thermal: std::sync::OnceLock<Arc<ThermalBasis>>,
    /// That basis on the model before it, with its number of base columns, when formed.
    pub thermal_prior: Option<(Arc<ThermalBasis>, usize)>,
}

impl State {
    /// Σ_k ε_k(q_k) (µrad) per sample, for the setup-offset candidates.
    pub fn eps(&self) -> Option<&[[f64; 3]]> {
        self.eps.as_deref()
    }
}

impl<'a> Ctx<'a> {
    /// Fits the rigid model plus the effect columns `cols` (`local`: which are local) on
    /// all runs and on the training runs of each fold, and forms the residual on all
    /// rows.
    pub fn fit(&self, cols: Cols, local: Vec<bool>) -> Fit {
        let Ctx { d, red, sets, .. } = *self;
        let base_cols = self.base_columns(&cols);
        let mut mom = Moments::of_columns(red, &base_cols);
        let support = Extra::support_of(red, &base_cols);
        mom.local = local.iter().copied().chain([false]).collect();
        let base = moments::Base::new(red, sets, mom);
        let jf = moments::joint_fit(red, sets, None, &base, true);
        let mut resid = d.y.clone();
        for (col, e) in cols.iter().zip(&jf.all.x) {
            resid.iter_mut().zip(col).for_each(|(r, v)| *r -= e * v);
        }
        for (g, rs) in red.runs.iter().enumerate() {
            let pa = red.predict_reduced(g, &jf.all.a);
            for i in 0..rs.rows {
                let (off, q) = rs.row(i);
                resid[rs.row0 + i] -= dot(&pa[off..off + q.len()], q);
            }
        }
        Fit {
            rank: sets.all.rank() + jf.all.rank,
            cols,
            local,
            base,
            a: jf.all.a,
            resid,
            ssr: jf.all.ssr,
            heldout_ssr: jf.heldout_ssr,
            support,
        }
    }

    /// The base columns of every joint fit on the current model `f`, with where each is
    /// nonzero.
    pub fn extra<'c>(&self, f: &'c Fit) -> Extra<'c>
    where
        'a: 'c,
    {
        Extra {
            cols: self.base_columns(&f.cols),
            support: f.support.as_deref(),
        }
    }

    /// The base columns U = [accepted effects `cols` | y] of every joint fit.
    pub fn base_columns<'c>(&self, cols: &'c Cols) -> Vec<&'c [f64]>
    where
        'a: 'c,
    {
        cols.iter()
            .map(Vec::as_slice)
            .chain([self.d.y.as_slice()])
            .collect()
    }

    /// The joint fit of the current model `f` plus a candidate's columns: its moments
    /// (one pass over the rows), the columns that vary, and the fit on all runs (and the
    /// folds, with `heldout`).
    pub fn evaluate(
        &self,
        f: &Fit,
        specs: &Columns,
        heldout: bool,
    ) -> Option<(Moments, Vec<usize>, moments::JointFit)> {
        self.fit_moments(f, self.moments(f, specs), heldout)
    }

    /// The moments of a candidate's columns with the current model's base (one pass over
    /// the rows where they can vary).
    pub fn moments(&self, f: &Fit, specs: &Columns) -> Moments {
        let d = self.d;
        // Columns that follow one axis are constant on the runs that do not move it: the
        // centring per run removes them there (their moments are 0).
        let parked = specs.follows().map(|a| self.parked_runs(a));
        let live =
            |row| specs.live(d, row) && parked.as_ref().is_none_or(|p| !p[d.fields.run(row / 2)]);
        let base = self.extra(f);
        let fill = |row, out: &mut [f64]| specs.at(d, row, out);
        match specs.run() {
            // A local effect varies on its run alone: only that run's live rows.
            Some(g) => {
                let mut mom = Moments::over_rows(
                    self.red,
                    specs.len(),
                    &base,
                    |h, rs, out| {
                        if h == g {
                            out.extend((0..rs.rows).filter(|&i| live(rs.row0 + i)));
                        }
                    },
                    fill,
                );
                mom.local = vec![true; mom.m];
                mom
            }
            None => Moments::new_on(self.red, specs.len(), &base, live, fill),
        }
    }

    /// [`Ctx::moments`] of a candidate whose columns do not depend on the model (no
    /// nonlinear parameter, not the setup offset's), kept on the state for the next
    /// round. On a state after its model gained columns, from the candidate's moments on
    /// the model before: its moments with the rigid basis, among its columns and with
    /// the earlier base columns are those; only its cross-moments with the columns added
    /// since are formed ([`Moments::cross`]: one pass over the same rows, without the
    /// other products), the same sums.
    pub fn moments_kept(&self, s: &State, cand: &Candidate, specs: &Columns) -> Moments {
        let f = &s.fit;
        let prior = s.prior.as_ref().and_then(|(list, u_prev)| {
            let m = list.iter().find(|(c, _)| c == cand)?;
            Some((&m.1, *u_prev))
        });
        let mom = match prior {
            Some((p, u_prev)) if specs.run().is_none() && p.m == specs.len() => {
                self.moments_after(f, specs, p, u_prev)
            }
            _ => self.moments(f, specs),
        };
        s.kept
            .lock()
            .expect("kept moments")
            .push((cand.clone(), mom.clone()));
        mom
    }

    /// The moments of `specs` on the model `f` from `prior`, theirs on the model of the
    /// first `u_prev − 1` of f's columns ([`Ctx::moments_kept`]).
    fn moments_after(&self, f: &Fit, specs: &Columns, prior: &Moments, u_prev: usize) -> Moments {
        let d = self.d;
        let parked = specs.follows().map(|a| self.parked_runs(a));
        let live =
            |row| specs.live(d, row) && parked.as_ref().is_none_or(|p| !p[d.fields.run(row / 2)]);
        prior.carried(&self.extra(f), u_prev, |new| {
            Moments::cross(
                self.red,
                specs.len(),
                new,
                moments::live_directions(live),
                |row, out: &mut [f64]| specs.at(d, row, out),
            )
        })
    }

    /// The basis moments of the thermal searches on the state `s`
    /// ([`ThermalBasis`]), formed on the first call (the time form's or the lagged
    /// form's search, whichever asks first) and shared: on a state after its model gained
    /// columns, carried from the model before ([`ThermalBasis::carried`], the same sums).
    pub fn thermal_basis<'s>(&self, s: &'s State) -> &'s ThermalBasis {
        s.thermal.get_or_init(|| {
            let extra = self.extra(&s.fit);
            Arc::new(match &s.thermal_prior {
                Some((b, u_prev)) => b.carried(self.d, self.red, &extra, *u_prev),
                None => ThermalBasis::new(self.d, self.red, &extra),
            })
        })
    }

    /// Per run: whether axis `a` keeps one position over the whole run.
    pub fn parked_runs(&self, a: Axis) -> Vec<bool> {
        self.d.runs.iter().map(|r| r.parked[a.index()]).collect()
    }

    /// The joint fit of the current model plus the columns of `mom` that vary (none vary:
    /// `None`), with those columns' indices.
    pub fn fit_moments(
        &self,
        f: &Fit,
        mom: Moments,
        heldout: bool,
    ) -> Option<(Moments, Vec<usize>, moments::JointFit)> {
        let keep: Vec<usize> = (0..mom.m).filter(|&j| mom.varies[j]).collect();
        if keep.is_empty() {
            return None;
        }
        let mom = if keep.len() == mom.m {
            mom
        } else {
            mom.select(&keep)
        };
        let jf = moments::joint_fit(self.red, self.sets, Some(&mom), &f.base, heldout);
        Some((mom, keep, jf))
    }

    /// Whether a candidate whose joint fit with the current model `s` leaves the sum of
    /// squares `ssr` with `k` parameters more (its varying columns and searched θ) may
    /// qualify: its ΔBIC = BIC(ssr, k_s + k) − BIC(SSR_s, k_s) passes the engine's gate,
    /// by the functions the engine uses ([`delta_bic`], [`passes_bic_gate`]: the same
    /// value, the same rule). One that cannot qualify is never chosen, whatever its held-out
    /// sum of squares: that figure, a fit on every fold, is not formed for it.
    pub fn may_qualify(&self, s: &State, ssr: f64, k: usize) -> bool {
        let dbic = delta_bic(ssr, (s.k + k) as f64, s.fit.ssr, s.k as f64, self.d.rows());
        passes_bic_gate(dbic, self.bic_threshold)
    }

    /// The held-out sum of squares of the current model `s` plus the columns of `mom`
    /// (those that vary, as [`Ctx::fit_moments`] keeps them).
    pub fn heldout_ssr(&self, s: &State, mom: &Moments) -> f64 {
        moments::heldout_ssr(self.red, self.sets, Some(mom), &s.fit.base)
    }

    /// [`Ctx::fit_moments`] of a candidate's columns `mom` with `extra` searched
    /// parameters, its held-out sum of squares formed only when it may qualify
    /// ([`Ctx::may_qualify`]; NaN otherwise).
    pub fn fit_candidate(
        &self,
        s: &State,
        mom: Moments,
        extra: usize,
    ) -> Option<(Moments, Vec<usize>, moments::JointFit)> {
        let (mom, keep, mut jf) = self.fit_moments(&s.fit, mom, false)?;
        if self.may_qualify(s, jf.all.ssr, keep.len() + extra) {
            jf.heldout_ssr = self.heldout_ssr(s, &mom);
        }
        Some((mom, keep, jf))
    }

    /// SSR of the current model plus the candidate's columns at θ (∞ when it has none).
    pub fn ssr_at(&self, s: &State, cand: &Candidate, theta: f64) -> f64 {
        let specs = catalogue::specs(self.d, cand, theta, s.eps());
        self.evaluate(&s.fit, &specs, false)
            .map_or(f64::INFINITY, |(_, _, jf)| jf.all.ssr)
    }

    /// Per run that moves `axis`: the rows read along it less than `reach` mm of travel
    /// after the axis's last reversal, as (index counted from the run's first row, travel
    /// since reversal). A run that does not move the axis has a constant column (none).
    pub fn near_rows(&self, axis: Axis, reach: f64) -> Vec<Vec<(usize, f64)>> {
        let d = self.d;
        let parked = self.parked_runs(axis);
        self.red
            .runs
            .iter()
            .zip(parked)
            .map(|(rs, parked)| {
                (0..if parked { 0 } else { rs.rows })
                    .filter_map(|i| {
                        let row = rs.row0 + i;
                        let x = d.fields.since_reversal_mm[axis.index()][row / 2];
                        (d.row_axis(row) == axis && x < reach).then_some((i, x))
                    })
                    .collect()
            })
            .collect()
    }

    /// Σ_k ε_k(q_k) (µrad) at every sample of the runs whose head offset is one of
    /// `groups`, from the fit's error parameters; 0 on the other runs (the setup-offset
    /// columns, which alone read it, are 0 there).
    pub fn eps_per_sample(&self, f: &Fit, groups: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let (d, red) = (self.d, self.red);
        let x: Vec<f64> = (0..d.model.len()).map(|j| f.a[j] / red.scale[j]).collect();
        // The rotation terms: (its value as a function of q, its axis, the rotation's
        // direction).
        let rot: Vec<_> = Term::all()
            .into_iter()
            .enumerate()
            .filter_map(|(i, term)| match term.component {
                Component::Rotation(dir) => {
                    Some((d.model.term_fn(i, &x), term.axis.index(), dir.index()))
                }
                _ => None,
            })
            .collect();
        // Consecutive samples often share an axis position (a parked axis): a term's value
        // is evaluated again only when its axis's position changes. One pass over the
        // samples, each sample's terms added in term order.
        let mut last = vec![(f64::NAN, 0.0); rot.len()];
        let mut out = vec![[0.0; 3]; d.fields.len()];
        let runs = d.runs.iter().filter(|r| groups.contains(&r.head_mm));
        for s in runs.flat_map(|r| r.start..r.end) {
            let o = &mut out[s];
            for ((value, a, dir), last) in rot.iter().zip(last.iter_mut()) {
                let (a, dir) = (*a, *dir);
                let q = d.fields.q_mm[a][s];
                if q != last.0 {
                    *last = (q, value(q));
                }
                o[dir] += last.1;
            }
        }
        out
    }
}
