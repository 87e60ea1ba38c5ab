//! The explained model: when a diagnosis explains a misfit, the 21 terms fitted jointly
//! with the physics it found (backlash, a lost-motion profile, servo lag, cyclic error,
//! thermal drift, steps, …), with the diagnosis's own columns for those effects.
//!
//! The fit is identification's joint one ([`crate::design::fit`]: streaming Householder
//! QR, SVD of the column-scaled triangular factor, never a normal matrix) with the
//! findings' columns added ([`columns`]); every nonlinear parameter (a period, a time
//! constant, a decay length, a step's time) is held at the diagnosis's value, so the
//! σ of the linear parameters are conditional on it. The result is an identification
//! result document whose terms, squareness and fit are the explained model's, with
//! [`ExplainedModel`] under `explained`: the physics with parameters and σ, residual,
//! held-out RMS (the diagnosis's folds of whole runs) and noise floor, what each
//! compensation is predicted to leave ([`predict`]) and the actions ([`actions`]).
//!
//! | diagnosis verdict | explained model | `model_check` |
//! |---|---|---|
//! | `consistent` (or no finding) | none: the plain identification | the plain gate |
//! | `explained`, the model's residual within 1.2 × the floor | fitted | `explains`, decided on the explained model, `explained_model` says what it adds |
//! | `explained`, the residual above | fitted | `misfit`: not decided, says so |
//! | `partly_explained`, or a finding that cannot be refitted | fitted | `misfit`: not decided, says what remains |

use crate::axis::Axis;
use crate::design::{self, ErrorModel};
use crate::diagnosis::design as ddesign;
use crate::diagnosis::lost_motion::Profile;
use crate::diagnosis::{BeforeAfter, DiagnosisResult, Finding, Verdict, catalogue};
use crate::error::SolverError;
use crate::identification::{self, Estimate, IdentificationResult, IdentifyOptions, Method};
use crate::misfit::ModelCheck;
use crate::session::Session;
use std::collections::BTreeMap;

pub mod actions;
pub mod columns;
pub mod doc;
pub mod predict;

pub use doc::{Action, ExplainedModel, Physics, RigidFigures, SetValue};

use columns::FindingColumns;
use predict::FittedEffects;

/// Number of points along the measured travel at which a lost-motion profile is reported
/// (as the diagnosis reports it).
const PROFILE_POINTS: usize = 5;

/// The explained model of `session` from its `diagnosis` (docs/compensation.md, "The
/// explained model"): see the module documentation. A diagnosis that found nothing (the
/// 21-term model explains the recording) gives the plain identification.
pub fn explain(
    session: &Session,
    opts: &IdentifyOptions,
    diagnosis: &DiagnosisResult,
) -> Result<IdentificationResult, SolverError> {
    if diagnosis.findings.is_empty() || diagnosis.verdict == Verdict::Consistent {
        return identification::identify(session, opts);
    }
    if diagnosis.source != "session" {
        return Err(SolverError::InvalidInput(format!(
            "the explained model is fitted on a session, not on a {} diagnosis",
            diagnosis.source
        )));
    }
    let model = identification::prepare(session, opts)?;
    let topology = session
        .topology
        .clone()
        .or_else(|| opts.topology.clone())
        .unwrap_or_default();
    let d = ddesign::build_every_sample(session, &topology, opts.order)?;
    let mut refitted: Vec<&Finding> = Vec::new();
    let mut cands = Vec::new();
    let mut not_refitted = Vec::new();
    for f in &diagnosis.findings {
        match columns::candidate_of(f) {
            Ok(c) => {
                refitted.push(f);
                cands.push(c);
            }
            Err(why) => not_refitted.push(why),
        }
    }
    let cols = FindingColumns::new(session, &d, &cands);
    let fit = design::fit(session, &model, &|_, _| true, Some(&cols));
    let floor = crate::noise::session_floor(session);
    let noise = floor.map(|f| identification::report::round(f.sigma_um));
    let ident = crate::observability::analyse(&fit, &model);
    let adds = adds_sentence(&refitted);
    let est = Estimate {
        ident,
        advice: vec![],
        seen_as: None,
        reporting: vec![format!(
            "explained model: the 21 terms fitted jointly with {adds} (the diagnosis's columns; its nonlinear parameters held at the diagnosis's values)"
        )],
        fit,
    };
    let mut result = identification::report::report_with(
        session,
        &model,
        opts,
        Method::Joint,
        noise,
        &est,
        Some(&cols),
    );
    result.fit.noise_pass_differences_um =
        floor.and_then(|f| f.pass_differences_um.map(identification::report::round));
    let fit = est.fit;
    let x_extra = fit.solution.x[fit.layout.extra_range()].to_vec();
    let sd_extra: Vec<f64> = fit
        .layout
        .extra_range()
        .map(|j| fit.solution.cov[(j, j)].max(0.0).sqrt())
        .collect();
    let rows = fit.reduced.rows.max(1) as f64;
    let residual = (fit.solution.rss / rows).sqrt();
    let heldout = heldout_rms(session, &model, &cols);
    let effects = FittedEffects {
        columns: &cols,
        coef: &x_extra,
    };
    let rigid_now = predict::rigid_rms(session, &model);
    let all: Vec<usize> = (0..refitted.len()).collect();
    let predicted_all = predict::rms_after_compensation(session, &model, &effects, &all);
    let cov_extra = |i: usize, j: usize| {
        let base = fit.layout.extra_range().start;
        fit.solution.cov[(base + i, base + j)]
    };
    let mut physics: Vec<Physics> = Vec::new();
    for (i, f) in refitted.iter().enumerate() {
        let block = cols.blocks()[i].clone();
        let fitted = Block {
            names: cols.names(i),
            coef: &x_extra[block.clone()],
            sd: &sd_extra[block.clone()],
        };
        let after = predict::rms_after_compensation(session, &model, &effects, &[i]);
        let mut parameters = physics_parameters(&cands[i].0, &fitted);
        if let Some(p) = profile_parameters(&d, &cands, &cols, i, &x_extra, &cov_extra) {
            parameters.extend(p);
        }
        physics.push(Physics {
            effect: f.effect.clone(),
            axis: f.axis.clone(),
            depends_on: f.depends_on.clone(),
            parameters,
            held: held(f, cands[i].1),
            predicted_rms_um: BeforeAfter {
                before: rigid_now,
                after,
            },
        });
    }
    let floor_um = noise.unwrap_or(diagnosis.baseline.noise_estimate_um);
    let mut remains = not_refitted;
    if diagnosis.verdict == Verdict::PartlyExplained {
        remains.extend(diagnosis.unexplained.iter().cloned());
        if remains.is_empty() {
            remains.push("the diagnosis explains the misfit only partly".into());
        }
    }
    let mut explained = ExplainedModel {
        verdict: diagnosis.verdict,
        physics,
        residual_rms_um: residual,
        heldout_rms_um: heldout,
        noise_floor_um: floor_um,
        rigid: RigidFigures {
            residual_rms_um: diagnosis.baseline.residual_rms_um,
            heldout_rms_um: diagnosis.baseline.heldout_rms_um,
        },
        adds: adds.clone(),
        remains,
        predicted_residual_rms_um: predicted_all,
        actions: vec![],
        original_result_id: None,
        diagnosis_result_id: None,
    };
    explained.actions = actions::actions(&explained);
    result.model_check = Some(ModelCheck::explained(
        residual,
        noise,
        &adds,
        explained.verdict == Verdict::Explained && explained.remains.is_empty(),
        &explained.remains,
    ));
    result.explained = Some(explained);
    Ok(result)
}

/// "backlash (X), backlash (Y)": the physics the model adds, in words.
fn adds_sentence(findings: &[&Finding]) -> String {
    let names: Vec<String> = findings.iter().map(|f| f.name_in_words()).collect();
    if names.is_empty() {
        "no physics (no finding could be refitted)".into()
    } else {
        names.join(", ")
    }
}

/// One finding's fitted columns: names, coefficients and standard uncertainties.
struct Block<'a> {
    names: &'a [String],
    coef: &'a [f64],
    sd: &'a [f64],
}

/// A finding's parameters from its fitted columns, named as the diagnosis names them:
/// an amplitude and phase from a sine and cosine, the named coefficients otherwise (the
/// nuisance columns are fitted, not reported).
fn physics_parameters(cand: &catalogue::Candidate, b: &Block) -> BTreeMap<String, f64> {
    let mut p = BTreeMap::new();
    let idx = |n: &str| b.names.iter().position(|x| x == n);
    if let (Some(i), Some(j)) = (idx("sin"), idx("cos")) {
        let (s, c) = (b.coef[i], b.coef[j]);
        p.insert("amplitude_um".into(), s.hypot(c));
        p.insert("std_amplitude_um".into(), b.sd[i].max(b.sd[j]));
        p.insert("phase_rad".into(), c.atan2(s));
        return p;
    }
    if matches!(cand.effect, "lost_motion_profile" | "lost_motion_variation") {
        return p;
    }
    for (k, name) in b.names.iter().enumerate() {
        if catalogue::is_nuisance(name) {
            continue;
        }
        p.insert(name.clone(), b.coef[k]);
        p.insert(format!("std_{name}"), b.sd[k]);
    }
    p
}

/// The nonlinear parameter held at the diagnosis's value, with its σ there.
fn held(f: &Finding, theta: columns::Theta) -> BTreeMap<String, f64> {
    let mut h = BTreeMap::new();
    if let Some((name, _)) = theta {
        let get = |n: &str| {
            f.parameters
                .get(n)
                .copied()
                .or_else(|| f.undetermined.iter().find(|u| u.name == n).map(|u| u.value))
        };
        if let Some(v) = get(name) {
            h.insert(name.to_string(), v);
        }
        if let Some(s) = f.parameters.get(&format!("std_{name}")) {
            h.insert(format!("std_{name}"), *s);
        }
    }
    h
}

/// A lost-motion profile's figures (the diagnosis's: b(q) at evenly spaced points of the
/// measured travel, its mean and its variation, each with σ) from the joint fit; for the
/// varying part of an axis whose backlash is in the model, with that backlash as its
/// constant (their covariance from the same fit).
fn profile_parameters(
    d: &ddesign::Design,
    cands: &[(catalogue::Candidate, columns::Theta)],
    cols: &FindingColumns,
    i: usize,
    x: &[f64],
    cov: &dyn Fn(usize, usize) -> f64,
) -> Option<BTreeMap<String, f64>> {
    let c = &cands[i].0;
    if !matches!(c.effect, "lost_motion_profile" | "lost_motion_variation") {
        return None;
    }
    let a: Axis = c.axis?;
    let prof: Profile = catalogue::profile(d, a, c.order)?;
    let mut idx: Vec<usize> = Vec::new();
    if c.effect == "lost_motion_variation" {
        let b = cands
            .iter()
            .position(|(o, _)| o.effect == "backlash" && o.axis == Some(a))?;
        idx.push(cols.blocks()[b].start);
    }
    idx.extend(cols.blocks()[i].clone());
    let coef: Vec<f64> = idx.iter().map(|&j| x[j]).collect();
    let cm = nalgebra::DMatrix::from_fn(idx.len(), idx.len(), |r, s| cov(idx[r], idx[s]));
    let points: Vec<f64> = (0..PROFILE_POINTS)
        .map(|k| prof.lo + (prof.hi - prof.lo) * k as f64 / (PROFILE_POINTS - 1) as f64)
        .collect();
    let mut p = BTreeMap::new();
    for (n, ((b, sb), q)) in prof.at(&coef, &cm, &points).iter().zip(&points).enumerate() {
        p.insert(format!("lost_motion_um_{}", n + 1), *b);
        p.insert(format!("std_lost_motion_um_{}", n + 1), *sb);
        p.insert(format!("target_mm_{}", n + 1), *q);
    }
    let (m, sm) = prof.mean(&coef, &cm, &points);
    let (v, sv) = prof.variation(&coef, &cm, &points);
    p.insert("mean_lost_motion_um".into(), m);
    p.insert("std_mean_lost_motion_um".into(), sm);
    p.insert("variation_um".into(), v);
    p.insert("std_variation_um".into(), sv);
    p.insert("order".into(), prof.order as f64);
    Some(p)
}

/// Number of held-out folds of whole runs (the diagnosis's: run index within its file
/// mod K).
const FOLDS: usize = 3;

/// RMS on whole runs held out of the fit: each fold's runs predicted by the model fitted
/// on the others (each run's zero offsets its own), µm.
fn heldout_rms(session: &Session, model: &ErrorModel, cols: &FindingColumns) -> f64 {
    let (mut ssr, mut n) = (0.0, 0usize);
    for k in 0..FOLDS {
        let fit = design::fit(session, model, &|_, r| r % FOLDS != k, Some(cols));
        let res = design::residuals(session, model, &fit, Some(cols));
        for runs in &res {
            for (r, run) in runs.iter().enumerate() {
                if r % FOLDS == k {
                    ssr += run.iter().map(|v| v[0] * v[0] + v[1] * v[1]).sum::<f64>();
                    n += 2 * run.len();
                }
            }
        }
    }
    (ssr / n.max(1) as f64).sqrt()
}
