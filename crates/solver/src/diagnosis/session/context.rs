//! What every step of a session's diagnosis shares: the design, its per-run reduction
//! and the run sets of the folds ([`Ctx`]), and the current model fitted on them
//! ([`State`]: its [`Fit`] and the rigid model's rotation errors per sample when a
//! candidate reads them). Each helper of the session's diagnosis is a method of the
//! context taking the state it extends, instead of the six arguments it would need.

use crate::axis::Axis;
use crate::basis::Basis;
use crate::diagnosis::catalogue::{self, Candidate, Columns};
use crate::diagnosis::design::Design;
use crate::diagnosis::linalg::{Cols, dot};
use crate::diagnosis::moments::{self, Extra, Moments, Sets};
use crate::diagnosis::reduced::{Reduction, RunSpace};
use crate::diagnosis::search::{delta_bic, passes_bic_gate};
use crate::diagnosis::thermal_search::ThermalBasis;
use crate::terms::{Component, Term};
use std::collections::HashMap;
use std::sync::Arc;

/// The design, its reduction, the folds' run sets and the noise floor.
#[derive(Clone, Copy)]
pub(crate) struct Ctx<'a> {
    pub d: &'a Design,
    pub red: &'a Reduction,
    pub sets: &'a Sets,
    /// The noise floor (µm), estimated without a model (NaN until it is).
    pub floor: f64,
    /// The engine's BIC threshold ([`crate::diagnosis::engine::Rules::bic_threshold`]): a
    /// candidate whose ΔBIC is above −`bic_threshold` cannot qualify
    /// ([`Ctx::may_qualify`]).
    pub bic_threshold: f64,
    /// The frequency scans' moments that do not depend on the residual, kept for the
    /// session's later rounds ([`ScanMoments`]).
    pub scans: &'a ScanMoments,
}

/// A frequency scan: its reading axis, its variable (the address of the design's field
/// it reads), its grid's first frequency and step (their bits) and size, and whether it
/// sums each run's fit apart.
pub(crate) type ScanKey = (usize, usize, u64, u64, usize, bool);

/// The moments [ss, cc, sc] of every frequency scan the session has made, which depend
/// on the rows, the variable and the grid and not on the residual (the sines' and
/// cosines' sums of squares and products, [`crate::diagnosis::periodic_scan`]): per
/// frequency, summed over the runs scanned, or per run scanned then frequency when the
/// scan fits each run apart. A later round's scan of the same rows on the same grid
/// (every coarse scan; a fine one about the same frequency) forms the residual's two
/// sums alone and takes these: the same values.
#[derive(Default)]
pub(crate) struct ScanMoments(std::sync::Mutex<HashMap<ScanKey, Arc<Vec<[f64; 3]>>>>);

impl ScanMoments {
    pub fn get(&self, key: &ScanKey) -> Option<Arc<Vec<[f64; 3]>>> {
        self.0.lock().expect("scan moments").get(key).cloned()
    }

    pub fn insert(&self, key: ScanKey, v: Vec<[f64; 3]>) {
        self.0
            .lock()
            .expect("scan moments")
            .insert(key, Arc::new(v));
    }
}

/// Which rows a candidate's pass visits, for the moments kept on a model
/// ([`Ctx::moments_kept`]).
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub(crate) enum Visit {
    /// Every row where its columns may vary ([`LiveRows`]).
    Live,
    /// The rows within its reach at θ of the last reversal of its axis (a reversal
    /// spike's search: [`Ctx::near_rows`]).
    Near,
    /// A vibration's band basis at its scanned frequency, on every row where it may vary.
    Band,
}

/// Moments formed on a model, per candidate, by the rows visited and θ (its bits; 0 for a
/// candidate without a nonlinear parameter).
pub(crate) type Kept = Vec<(Candidate, HashMap<(Visit, u64), Arc<Moments>>)>;

/// The rows where a candidate's columns `specs` may vary: the rows of their reading
/// axes, on the runs that move the axis they follow (on the others they are constant and
/// the centring per run removes them), on their one run for a local effect.
pub(crate) struct LiveRows<'c> {
    d: &'c Design,
    specs: &'c Columns<'c>,
    parked: Option<Vec<bool>>,
}

impl LiveRows<'_> {
    fn live(&self, row: usize) -> bool {
        let d = self.d;
        self.specs.live(d, row)
            && self
                .parked
                .as_ref()
                .is_none_or(|p| !p[d.fields.run(row / 2)])
    }

    /// Pushes run g's rows to visit ([`Moments::over_rows`]): a local effect's live rows
    /// on its run alone, the live reading directions ([`moments::live_directions`])
    /// otherwise.
    pub fn push(&self, g: usize, rs: &RunSpace, out: &mut Vec<usize>) {
        if !self.specs.on_run_of(g) {
            return;
        }
        match self.specs.run() {
            Some(h) if h == g => out.extend((0..rs.rows).filter(|&i| self.live(rs.row0 + i))),
            Some(_) => {}
            None => moments::live_directions(|row| self.live(row))(g, rs, out),
        }
    }
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
    /// The rigid model's rotation errors at every sample ([`Ctx::eps`]), formed when
    /// a candidate first reads them: none of a round's candidates may (a second
    /// diagnosis spares the setup offsets where the first saw no evidence of them).
    pub eps: std::sync::OnceLock<Option<Vec<[f64; 3]>>>,
    /// The head offsets of the setup-offset candidates, whose columns read them (none:
    /// not needed).
    pub eps_groups: Vec<[f64; 3]>,
    /// Per axis: the constant lost motion of its `backlash` finding in the model (value
    /// and σ, µm), which a position-dependent profile of that axis refines.
    pub backlash: [Option<(f64, f64)>; 3],
    /// Per axis: whether a whole position-dependent lost motion (constant part included)
    /// is in the model.
    pub profiled: [bool; 3],
    /// Per axis: whether a growth of its lost motion in time (`backlash_growth`) is in
    /// the model.
    pub grown: [bool; 3],
    /// The mountings whose plate scale (`plate_scale`) is in the model.
    pub plates: Vec<String>,
    /// The index in `fit.cols` of each of `plates`' columns.
    pub plate_cols: Vec<usize>,
    /// The growth candidates of the findings in the model that are tested for a change
    /// in time (`catalogue::growth`), each until its growth is in the model.
    pub growths: Vec<Candidate>,
    /// The candidates' moments formed on this model, kept for the next
    /// ([`Ctx::moments_kept`]).
    pub kept: std::sync::Mutex<Kept>,
    /// Those of the model before it, with its number of base columns (taken when the
    /// next model is formed: a state the loop has moved past keeps none).
    pub prior: std::sync::Mutex<Option<(Kept, usize)>>,
    /// The thermal searches' basis moments on this model, formed once for its time form
    /// and its lagged form ([`Ctx::thermal_basis`]).
    pub thermal: std::sync::OnceLock<Arc<ThermalBasis>>,
    /// That basis on the model before it, with its number of base columns, when formed;
    /// taken when this model's is carried from it.
    pub thermal_prior: std::sync::Mutex<Option<(Arc<ThermalBasis>, usize)>>,
    /// The candidates admitted into this model, in order (the round it starts).
    pub path: Vec<Candidate>,
    /// Per direction: the residual's most significant step along it, which a step and a
    /// transient of that direction both start from, scanned once on this model
    /// ([`Ctx::step_of`]).
    pub steps: [std::sync::OnceLock<Option<(usize, usize)>>; 3],
}

impl State {
    /// The model's residual on all rows and its held-out sum of squares, the rest of the
    /// state (columns, moments, rotation errors) freed.
    pub fn into_residual(self) -> (Vec<f64>, f64) {
        (self.fit.resid, self.fit.heldout_ssr)
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
            let mut q = vec![0.0; rs.width()];
            for i in 0..rs.rows {
                let off = rs.row_into(i, &mut q);
                resid[rs.row0 + i] -= dot(&pa[off..off + q.len()], &q);
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
    ) -> Option<(Arc<Moments>, Vec<usize>, moments::JointFit)> {
        self.fit_moments(f, self.moments(f, specs), heldout)
    }

    /// The rows where the columns `specs` may vary ([`LiveRows`]).
    pub fn live_rows<'c>(&self, specs: &'c Columns<'c>) -> LiveRows<'c>
    where
        'a: 'c,
    {
        LiveRows {
            d: self.d,
            specs,
            parked: specs.follows().map(|a| self.parked_runs(a)),
        }
    }

    /// The moments of a candidate's columns with the current model's base (one pass over
    /// the rows where they can vary).
    pub fn moments(&self, f: &Fit, specs: &Columns) -> Moments {
        let rows = self.live_rows(specs);
        self.fresh(f, specs, |g, rs, out| rows.push(g, rs, out))
    }

    /// One pass over the rows `rows` with the columns `specs` (local on their one run,
    /// [`Moments::local`]).
    fn fresh(
        &self,
        f: &Fit,
        specs: &Columns,
        rows: impl FnMut(usize, &RunSpace, &mut Vec<usize>),
    ) -> Moments {
        let d = self.d;
        let fill = |row, out: &mut [f64]| specs.at(d, row, out);
        let mut mom = Moments::over_rows(self.red, specs.len(), &self.extra(f), rows, fill);
        if specs.run().is_some() {
            mom.local = vec![true; mom.m];
        }
        mom
    }

    /// The moments of the candidate `cand` at θ (0 without a nonlinear parameter) on the
    /// rows where its columns may vary ([`Ctx::moments_kept`]; the setup offset's columns
    /// follow the model's rotations: formed afresh).
    pub fn moments_at(&self, s: &State, cand: &Candidate, theta: f64) -> Arc<Moments> {
        let specs = catalogue::specs(self.d, cand, theta, self.eps(s));
        if cand.effect == "setup_offset" {
            return Arc::new(self.moments(&s.fit, &specs));
        }
        let rows = self.live_rows(&specs);
        self.moments_kept(s, (cand, Visit::Live, theta), &specs, |g, rs, out| {
            rows.push(g, rs, out)
        })
    }

    /// The moments of a candidate's columns `specs` (the candidate at θ, over the rows
    /// `rows`, as `visit` says), kept on the state for the rest of its round and the next.
    /// Already formed on this model: those. Formed on the model before (the same
    /// candidate, θ and rows): its moments with the rigid basis, among its columns and
    /// with the earlier base columns are those; only its cross-moments with the columns
    /// added since are formed ([`Moments::carried`], [`Moments::cross`]: one pass over
    /// the same rows of the (run, direction) groups where an added column is nonzero,
    /// without the other products), the same sums. Otherwise one pass over the rows.
    pub fn moments_kept(
        &self,
        s: &State,
        (cand, visit, theta): (&Candidate, Visit, f64),
        specs: &Columns,
        rows: impl FnMut(usize, &RunSpace, &mut Vec<usize>),
    ) -> Arc<Moments> {
        let key = (visit, theta.to_bits());
        let find = |list: &Kept| {
            list.iter()
                .find(|(c, _)| c == cand)
                .and_then(|(_, by)| by.get(&key).cloned())
        };
        if let Some(mom) = find(&s.kept.lock().expect("kept moments")) {
            return mom;
        }
        // Taken out of the model before's: a carried entry is asked again of this
        // model's kept moments, never of those, which so shrink as this round's grow.
        let prior = s
            .prior
            .lock()
            .expect("prior moments")
            .as_mut()
            .and_then(|(list, u_prev)| {
                let (_, by) = list.iter_mut().find(|(c, _)| c == cand)?;
                Some((by.remove(&key)?, *u_prev))
            });
        let (d, f) = (self.d, &s.fit);
        let mom = match prior {
            Some((p, u_prev)) if p.m == specs.len() => {
                Arc::new(p.carried(&self.extra(f), u_prev, |new| {
                    Moments::cross(self.red, specs.len(), new, rows, |row, out| {
                        specs.at(d, row, out)
                    })
                }))
            }
            _ => Arc::new(self.fresh(f, specs, rows)),
        };
        let mut kept = s.kept.lock().expect("kept moments");
        match kept.iter_mut().find(|(c, _)| c == cand) {
            Some((_, by)) => {
                by.insert(key, mom.clone());
            }
            None => kept.push((cand.clone(), HashMap::from([(key, mom.clone())]))),
        }
        mom
    }

    /// The basis moments of the thermal searches on the state `s`
    /// ([`ThermalBasis`]), formed on the first call (the time form's or the lagged
    /// form's search, whichever asks first) and shared: on a state after its model gained
    /// columns, carried from the model before ([`ThermalBasis::carried`], the same sums).
    pub fn thermal_basis<'s>(&self, s: &'s State) -> &'s ThermalBasis {
        s.thermal.get_or_init(|| {
            let extra = self.extra(&s.fit);
            let prior = s.thermal_prior.lock().expect("prior basis").take();
            Arc::new(match prior {
                Some((b, u_prev)) => b.carried(self.d, self.red, &extra, u_prev),
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
        mom: impl Into<Arc<Moments>>,
        heldout: bool,
    ) -> Option<(Arc<Moments>, Vec<usize>, moments::JointFit)> {
        let mom = mom.into();
        let keep: Vec<usize> = (0..mom.m).filter(|&j| mom.varies[j]).collect();
        if keep.is_empty() {
            return None;
        }
        let mom = if keep.len() == mom.m {
            mom
        } else {
            Arc::new(mom.select(&keep))
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

    /// Whether a candidate whose joint fit with the current model `s` leaves the sum of
    /// squares `ssr` with `k` parameters more shows no evidence: its ΔBIC, as
    /// [`Ctx::may_qualify`] forms it ([`delta_bic`]), is ≥ 0. A search that would only
    /// refine such a candidate's θ is spared: within it the candidate cannot reach the
    /// gate of [`Ctx::may_qualify`].
    pub fn lacks_evidence(&self, s: &State, ssr: f64, k: usize) -> bool {
        delta_bic(ssr, (s.k + k) as f64, s.fit.ssr, s.k as f64, self.d.rows()) >= 0.0
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
        mom: impl Into<Arc<Moments>>,
        extra: usize,
    ) -> Option<(Arc<Moments>, Vec<usize>, moments::JointFit)> {
        let (mom, keep, mut jf) = self.fit_moments(&s.fit, mom, false)?;
        if self.may_qualify(s, jf.all.ssr, keep.len() + extra) {
            jf.heldout_ssr = self.heldout_ssr(s, &mom);
        }
        Some((mom, keep, jf))
    }

    /// SSR of the current model plus the candidate's columns at θ (∞ when it has none).
    pub fn ssr_at(&self, s: &State, cand: &Candidate, theta: f64) -> f64 {
        self.fit_moments(&s.fit, self.moments_at(s, cand, theta), false)
            .map_or(f64::INFINITY, |(_, _, jf)| jf.all.ssr)
    }

    /// [`Ctx::ssr_at`] of a thermal drift at the time constant `v`, or (`lagged`) of a
    /// growth following the logged temperature lagged by `v`, taken on the state's
    /// thermal basis ([`Ctx::thermal_basis`]) instead of a pass over the rows: the profile
    /// the round's search of these two reads, and the cheap profile their intervals are
    /// located on. ∞ where the lagged form is not defined.
    pub fn basis_ssr(&self, s: &State, lagged: bool, v: f64) -> f64 {
        let b = self.thermal_basis(s);
        let mom = if lagged { b.lagged(v) } else { Some(b.at(v)) };
        mom.map_or(f64::INFINITY, |mom| {
            moments::joint_fit(self.red, self.sets, Some(&mom), &s.fit.base, false)
                .all
                .ssr
        })
    }

    /// Per run that moves `axis`: the rows read along it less than `reach` mm of travel
    /// after the axis last turned (from the turn itself: [`catalogue::spike_travel`]), as
    /// (index counted from the run's first row, that travel). A run that does not move the axis has a constant column (none).
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
                        let x =
                            catalogue::spike_travel(d.fields.play_travel_mm[axis.index()][row / 2]);
                        (d.row_axis(row) == axis && x < reach).then_some((i, x))
                    })
                    .collect()
            })
            .collect()
    }

    /// Σ_k ε_k(q_k) (µrad) per sample on the model `s`, for the setup-offset candidates
    /// ([`Ctx::eps_per_sample`] of its fit and groups), formed on the first call.
    pub fn eps<'s>(&self, s: &'s State) -> Option<&'s [[f64; 3]]> {
        s.eps
            .get_or_init(|| {
                (!s.eps_groups.is_empty()).then(|| self.eps_per_sample(&s.fit, &s.eps_groups))
            })
            .as_deref()
    }

    /// Σ_k ε_k(q_k) (µrad) at every sample of the runs whose head offset is one of
    /// `groups`, from the fit's error parameters; 0 on the other runs (the setup-offset
    /// columns, which alone read it, are 0 there).
    pub fn eps_per_sample(&self, f: &Fit, groups: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let (d, red) = (self.d, self.red);
        let x: Vec<f64> = (0..d.model.len()).map(|j| f.a[j] / red.scale[j]).collect();
        // The bases of the rotation terms, one per axis and basis (an axis's rotation
        // terms share its basis: its values at a position are formed once for them all),
        // with its terms at the reference position ([`Basis::at_reference`]).
        type Source<'b> = (usize, &'b Basis, Vec<(f64, f64)>);
        let mut bases: Vec<Source> = Vec::new();
        // The rotation terms: (the index of its basis, none without one; its
        // coefficients; the rotation's direction).
        let mut rot = Vec::new();
        for (i, term) in Term::all().into_iter().enumerate() {
            let Component::Rotation(dir) = term.component else {
                continue;
            };
            let a = term.axis.index();
            let source = d.model.bases[i].as_ref().map(|b| {
                bases
                    .iter()
                    .position(|(ba, bb, _)| *ba == a && *bb == b)
                    .unwrap_or_else(|| {
                        bases.push((a, b, b.at_reference()));
                        bases.len() - 1
                    })
            });
            rot.push((source, &x[d.model.term_range(i)], dir.index()));
        }
        // Consecutive samples often share an axis position (a parked axis): a basis's
        // values, and its terms' values Σ_k v_k c_k ([`crate::design::combine`], as
        // [`crate::design::ErrorModel::term_fn`] sums them), are formed again only when
        // its axis's position changes. One pass over the samples, each sample's terms
        // added in term order.
        let mut at: Vec<(f64, Vec<f64>, bool)> = bases
            .iter()
            .map(|_| (f64::NAN, Vec::new(), false))
            .collect();
        let mut value = vec![0.0; rot.len()];
        let mut out = vec![[0.0; 3]; d.fields.len()];
        let runs = d.runs.iter().filter(|r| groups.contains(&r.head_mm));
        for s in runs.flat_map(|r| r.start..r.end) {
            for ((a, b, reference), (q0, values, moved)) in bases.iter().zip(at.iter_mut()) {
                let q = d.fields.q_mm[*a][s];
                *moved = q != *q0;
                if *moved {
                    *q0 = q;
                    values.resize(b.len(), 0.0);
                    for (o, v) in values.iter_mut().zip(b.values_from(q, reference)) {
                        *o = v;
                    }
                }
            }
            let o = &mut out[s];
            for ((source, c, dir), v) in rot.iter().zip(value.iter_mut()) {
                if let Some(k) = *source {
                    let (_, values, moved) = &at[k];
                    if *moved {
                        *v = crate::design::combine(values.iter().copied(), c);
                    }
                }
                o[*dir] += *v;
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnosis::design;
    use crate::simulate::seed_session;

    fn state(fit: Fit, prior: Option<(Kept, usize)>) -> State {
        State {
            fit,
            k: 0,
            eps: Default::default(),
            eps_groups: Vec::new(),
            backlash: [None; 3],
            profiled: [false; 3],
            grown: [false; 3],
            plates: Vec::new(),
            plate_cols: Vec::new(),
            growths: Vec::new(),
            kept: Default::default(),
            steps: Default::default(),
            prior: std::sync::Mutex::new(prior),
            thermal: Default::default(),
            thermal_prior: Default::default(),
            path: Vec::new(),
        }
    }

    use crate::diagnosis::moments::assert_same_bits as same;

    /// Moments kept on a model and carried to the next, after it gained a backlash of X
    /// (nonzero on the X readings of the runs that move X only) and a column nonzero
    /// everywhere, are bit for bit those formed on the new model in one pass: a reversal
    /// spike's on the rows within its reach (at every decay length of its grid), a cyclic
    /// error's and a step's on the rows where they may vary; and they carry the new
    /// columns' products.
    #[test]
    fn carried_moments_are_the_moments_formed_on_the_new_model() {
        let session = seed_session(3);
        let d = design::build(&session, &Default::default(), 3).unwrap();
        let red = Reduction::new(&session, &d);
        let sets = Sets::new(&d, &red, 3);
        let ctx = Ctx {
            d: &d,
            red: &red,
            sets: &sets,
            floor: 0.15,
            bic_threshold: 10.0,
            scans: &Default::default(),
        };
        let cands = catalogue::candidates(&d);
        let pick = |effect: &str, axis: Option<Axis>| {
            cands
                .iter()
                .find(|c| c.effect == effect && c.axis == axis)
                .cloned()
                .unwrap_or_else(|| panic!("{effect}"))
        };
        let spike = pick("reversal_spike", Some(Axis::X));
        let cyclic = pick("cyclic", Some(Axis::X));
        let step = Candidate {
            effect: "step",
            axis: None,
            direction: Some(Axis::Y),
            group: None,
            order: 0,
            width_s: 0.0,
            lost_motion_um: 0.0,
            mounting: None,
            parent: None,
        };
        let t_step = d.fields.t_s[(d.runs[2].start + d.runs[2].end) / 2];
        let grid = match catalogue::search(&d, &spike) {
            catalogue::Search::Grid(_, v) => v,
            _ => unreachable!(),
        };
        let near = ctx.near_rows(Axis::X, 1e9);
        // Every moment the searches form: the spike's at each grid value on its rows
        // within reach, the cyclic error's and the step's on their live rows.
        let all = |s: &State| {
            let mut out: Vec<Arc<Moments>> = grid
                .iter()
                .map(|&v| {
                    let specs = catalogue::specs(&d, &spike, v, None);
                    let reach = catalogue::reach(&spike, v).unwrap().1;
                    ctx.moments_kept(s, (&spike, Visit::Near, v), &specs, |g, _, out| {
                        out.extend(near[g].iter().filter(|p| p.1 < reach).map(|p| p.0))
                    })
                })
                .collect();
            out.push(ctx.moments_at(s, &cyclic, 1.0 / 7.0));
            out.push(ctx.moments_at(s, &step, t_step));
            out
        };
        let s0 = state(ctx.fit(Vec::new(), Vec::new()), None);
        let before = all(&s0);
        // Asked again on the same model: the kept moments themselves, not a copy.
        for (a, b) in before.iter().zip(all(&s0)) {
            assert!(Arc::ptr_eq(a, &b));
        }
        let (mut cols, _, _) = catalogue::columns(&d, &pick("backlash", Some(Axis::X)), 0.0, None);
        cols.push((0..d.rows()).map(|r| (0.013 * r as f64).cos()).collect());
        let fit = ctx.fit(cols, vec![false; 2]);
        let kept = std::mem::take(&mut *s0.kept.lock().unwrap());
        let s1 = state(fit, Some((kept, 1)));
        let carried = all(&s1);
        // The same on a state formed without the model before: every pass afresh.
        let fresh = all(&state(ctx.fit(s1.fit.cols.clone(), vec![false; 2]), None));
        for (a, b) in carried.iter().zip(&fresh) {
            same(a, b);
        }
        assert!(carried.last().unwrap().local.iter().all(|&l| l));
        // The added columns' products are there: not the moments carried from.
        for (a, b) in carried.iter().zip(&before) {
            assert_eq!((a.u, b.u), (3, 1));
            assert!(a.runs.iter().any(|r| r.xu[..2].iter().any(|&v| v != 0.0)));
        }
    }
}
