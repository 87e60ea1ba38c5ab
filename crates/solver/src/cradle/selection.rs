//! The forward selection of the A-dependent terms by leave-one-pose-out prediction
//! error, and the rival models the BIC does not exclude.

use crate::cradle::identify::{self, Obs, fit_kinematics, leave_one_pose_out, start};
use crate::cradle::location::summary;
use crate::cradle::model::{params_from_model, unit_of, unit_scale};
use crate::cradle::*;
use crate::error::SolverError;

/// One fitted model with its leave-one-pose-out figures.
pub(super) struct Candidate {
    pub(super) fit: identify::KinematicFit,
    pub(super) held: Option<Vec<identify::HeldOut>>,
    /// Held-out RMS, mm (∞ without held-out poses).
    pub(super) rms: f64,
}

pub(super) fn try_model(
    obs: &[Obs],
    pivot: [f64; 3],
    spec: &ModelSpec,
    from: &CradleModel,
    n_poses: usize,
    lopo: bool,
) -> Result<Candidate, SolverError> {
    let fit = fit_kinematics(obs, pivot, spec, &params_from_model(from, spec))?;
    with_held_out(fit, obs, pivot, n_poses, lopo)
}

pub(super) fn with_held_out(
    fit: identify::KinematicFit,
    obs: &[Obs],
    pivot: [f64; 3],
    n_poses: usize,
    lopo: bool,
) -> Result<Candidate, SolverError> {
    let held = if lopo {
        Some(leave_one_pose_out(obs, pivot, &fit.spec, &fit.q, n_poses)?)
    } else {
        None
    };
    let rms = held.as_deref().map_or(f64::INFINITY, held_rms);
    Ok(Candidate { fit, held, rms })
}

/// Bayesian information criterion of a fit on 3N coordinates: 3N·ln(SSR/3N) + P·ln 3N.
pub(super) fn bic(fit: &identify::KinematicFit, n_obs: usize) -> f64 {
    let n = 3.0 * n_obs as f64;
    let ssr = fit.rms * fit.rms * n_obs as f64;
    n * (ssr.max(1e-300) / n).ln() + fit.q.len() as f64 * n.ln()
}

/// Successors validated on held-out poses at each step: the best ones by BIC (the
/// held-out validation is the expensive part).
pub(super) const VALIDATED_PER_STEP: usize = 2;

/// The models one step richer than `spec` (module docs, step 4): one more term of the
/// family, and the classic compliant pair from the rigid model. (Each tilt about the
/// mount pays off alone, its lever giving z_M, so they are not offered as a pair: a
/// pair would win over its better half by chance as often as not.)
pub(super) fn successors(spec: &ModelSpec) -> Vec<ModelSpec> {
    let mut v = vec![];
    if spec.is_rigid() {
        v.push(ModelSpec::COMPLIANT);
    }
    for t in [
        Term::PivotTilt,
        Term::MountX,
        Term::MountY,
        Term::Axial,
        Term::Lateral,
    ] {
        if !t.in_spec(spec)
            && let Some(s) = t.add_to(spec)
        {
            v.push(s);
        }
    }
    if !spec.a_harmonic && spec.eaa_order == 0 {
        v.push(ModelSpec {
            a_harmonic: true,
            ..*spec
        });
    }
    if !spec.a_harmonic && spec.eaa_order < 3 {
        v.push(ModelSpec {
            eaa_order: spec.eaa_order + 1,
            ..*spec
        });
    }
    v.dedup();
    v
}

/// The chosen model's A-dependent parameters in reporting units, flagged
/// `model_dependent` where a rival puts them elsewhere.
pub(super) fn model_parameters(
    fit: &identify::KinematicFit,
    rivals: &[RivalModel],
) -> Vec<ModelParameter> {
    fit.spec
        .names()
        .iter()
        .enumerate()
        .skip(model::N_RIGID)
        .map(|(k, name)| {
            let (scale, unit) = (unit_scale(name), unit_of(name));
            let (value, std) = (fit.q[k] * scale, fit.cov[(k, k)].sqrt() * scale);
            ModelParameter {
                name: name.to_string(),
                unit: unit.into(),
                value,
                std,
                determined: value.abs() >= 3.0 * std && std.is_finite(),
                model_dependent: rivals
                    .iter()
                    .any(|r| r.differs.iter().any(|d| d.name == *name)),
            }
        })
        .collect()
}

/// A sibling within this BIC of the chosen model is a rival: by the BIC approximation
/// its posterior odds against the chosen model are exp(−ΔBIC/2), above 1 : 20 below
/// 2·ln 20 ≈ 6 (the edge of "strong" evidence, Kass & Raftery 1995, J. Am. Stat. Assoc.
/// 90, 773): the chosen model's ±2σ then cannot hold 95 % of what the data allow.
pub(super) const RIVAL_BIC: f64 = 5.991_464_547_107_979; // 2·ln 20

/// The chosen model's rivals among its siblings ([`RivalModel`]). The forward
/// selection's standard uncertainties are those of the chosen model taken as given; when
/// a sibling explains the data as well and gives a parameter another value, that σ does
/// not cover the choice, and the parameter is reported as not determined instead.
/// (Example: with every deflection ∝ sin A, a tilt about the mount parallel to A with an
/// A positioning error, and the same tilt larger with a shift along A or sideways,
/// move the ball identically to first order.) A richer successor of the chosen model
/// (`richer`: the step the held-out margin refused) is a rival too when BIC prefers it
/// (ΔBIC < 0) and its held-out RMS is within the margin of the chosen model's: the margin
/// kept the simpler model, but the data do not let its σ ignore the richer one. (Example:
/// an A positioning error whose 1.6 % gain in held-out RMS misses the 2 % margin while it
/// lowers BIC by 6, and without which the tilt about X absorbs it.)
pub(super) fn rivals(
    best: &Candidate,
    siblings: Vec<Candidate>,
    richer: Vec<Candidate>,
    parent_rms: f64,
    obs: &[Obs],
    pivot: [f64; 3],
    n_poses: usize,
    margin: f64,
) -> Vec<RivalModel> {
    let n = obs.len();
    let bic_best = bic(&best.fit, n);
    let names = best.fit.spec.names();
    let mut out = vec![];
    let candidates = siblings
        .into_iter()
        .map(|c| (c, false))
        .chain(richer.into_iter().map(|c| (c, true)));
    for (sib, is_richer) in candidates {
        let d_bic = bic(&sib.fit, n) - bic_best;
        if d_bic > if is_richer { 0.0 } else { RIVAL_BIC } {
            continue;
        }
        let sib = if sib.held.is_some() {
            sib
        } else {
            match with_held_out(sib.fit, obs, pivot, n_poses, true) {
                Ok(c) => c,
                Err(_) => continue,
            }
        };
        let would_be_chosen = is_richer || sib.rms < (1.0 - margin) * parent_rms;
        if !would_be_chosen || sib.rms > (1.0 + margin) * best.rms {
            continue;
        }
        let differs: Vec<RivalValue> = names
            .iter()
            .enumerate()
            .skip(model::N_RIGID)
            .filter_map(|(k, name)| {
                let theirs = sib.fit.spec.index(name).map(|j| sib.fit.q[j]);
                let off = (best.fit.q[k] - theirs.unwrap_or(0.0)).abs();
                (off > 2.0 * best.fit.cov[(k, k)].sqrt()).then(|| RivalValue {
                    name: name.to_string(),
                    unit: unit_of(name).into(),
                    value: theirs.map(|v| v * unit_scale(name)),
                })
            })
            .collect();
        if differs.is_empty() {
            continue;
        }
        let values: Vec<String> = differs
            .iter()
            .map(|d| match d.value {
                Some(v) => format!("{} = {v:.1} {}", d.name, d.unit),
                None => format!("no {}", d.name),
            })
            .collect();
        let statement = format!(
            "The data cannot tell the chosen model from \"{}\" (held-out RMS {:.3} µm against {:.3} µm, BIC difference {d_bic:.1}), which has {}: these are reported as not determined. To first order the two move the ball alike over the measured A poses (as when every deflection has the same form in A, e.g. ∝ sin A); what would decide is a measurement that sees one of the terms in which they differ directly (e.g. the A positioning error with an angle reference on A, ISO 230-2) or a deflection whose A dependence differs between them.",
            sib.fit.spec.describe(),
            sib.rms * 1e3,
            best.rms * 1e3,
            values.join(", ")
        );
        out.push(RivalModel {
            summary: summary(&sib.fit, sib.held.as_deref()),
            bic_difference: d_bic,
            differs,
            statement,
        });
    }
    out
}

/// The outcome of the forward selection ([`forward_selection`]).
pub(super) struct Selection {
    /// The chosen model with its held-out figures.
    pub(super) best: Candidate,
    /// Every model fitted, in the order tried.
    pub(super) candidates: Vec<KinematicSummary>,
    /// The classic compliant model, for comparison.
    pub(super) compliant: Option<KinematicSummary>,
    pub(super) rigid_summary: KinematicSummary,
    /// The rival models the data do not exclude ([`rivals`]).
    pub(super) rivals: Vec<RivalModel>,
}

/// Forward selection of the A-dependent terms (module docs, step 4): from the rigid
/// model, the richer models fitted and the best by BIC validated on held-out poses, a
/// step kept when it lowers the held-out RMS by more than `margin` (relative); then the
/// rivals and the classic compliant model for comparison.
pub(super) fn forward_selection(
    obs: &[Obs],
    pivot: [f64; 3],
    n_poses: usize,
    margin: f64,
) -> Result<Selection, SolverError> {
    let lopo_rigid = n_poses >= 4;
    let lopo = n_poses >= 5;
    let q0 = start(obs, pivot, &ModelSpec::RIGID);
    let start_model = model::model_from_params(pivot, &ModelSpec::RIGID, &q0);
    let rigid = try_model(
        obs,
        pivot,
        &ModelSpec::RIGID,
        &start_model,
        n_poses,
        lopo_rigid,
    )?;
    let mut candidates = vec![summary(&rigid.fit, rigid.held.as_deref())];
    let mut compliant: Option<KinematicSummary> = None;
    let mut best = rigid;
    let rigid_summary = candidates[0].clone();
    // The other successors of the step that chose `best`, and the held-out RMS of the
    // model it was chosen over (for the rivals, [`rivals`]).
    let mut siblings: Vec<Candidate> = vec![];
    let mut parent_rms = f64::INFINITY;
    // The successors of the chosen model (the step the margin refused).
    let mut richer: Vec<Candidate> = vec![];
    if lopo {
        loop {
            // Richer models fitted; the best by BIC validated on held-out poses.
            let mut fits: Vec<identify::KinematicFit> = successors(&best.fit.spec)
                .iter()
                .filter_map(|spec| {
                    // A degenerate richer model is simply not a candidate.
                    // … nor is one whose terms the data cannot separate.
                    fit_kinematics(obs, pivot, spec, &params_from_model(&best.fit.model, spec))
                        .ok()
                        .filter(|f| separability::separable(obs, &f.model, &f.spec))
                })
                .collect();
            fits.sort_by(|a, b| bic(a, obs.len()).total_cmp(&bic(b, obs.len())));
            let mut step: Vec<Candidate> = vec![];
            for (k, fit) in fits.into_iter().enumerate() {
                if k >= VALIDATED_PER_STEP {
                    candidates.push(summary(&fit, None));
                    step.push(Candidate {
                        fit,
                        held: None,
                        rms: f64::INFINITY,
                    });
                    continue;
                }
                let Ok(c) = with_held_out(fit, obs, pivot, n_poses, true) else {
                    continue;
                };
                let sum = summary(&c.fit, c.held.as_deref());
                if c.fit.spec == ModelSpec::COMPLIANT {
                    compliant = Some(sum.clone());
                }
                candidates.push(sum);
                step.push(c);
            }
            let pick = (0..step.len()).min_by(|&a, &b| step[a].rms.total_cmp(&step[b].rms));
            match pick {
                Some(i) if step[i].rms < (1.0 - margin) * best.rms => {
                    parent_rms = best.rms;
                    best = step.swap_remove(i);
                    siblings = step;
                }
                _ => {
                    richer = step;
                    break;
                }
            }
        }
    }
    let rivals = rivals(
        &best, siblings, richer, parent_rms, obs, pivot, n_poses, margin,
    );
    if compliant.is_none() && n_poses >= 4 {
        // The classic compliant model, for comparison (validated with 5 poses or more).
        compliant = try_model(
            obs,
            pivot,
            &ModelSpec::COMPLIANT,
            &best.fit.model,
            n_poses,
            lopo,
        )
        .ok()
        .map(|c| summary(&c.fit, c.held.as_deref()));
    }
    Ok(Selection {
        best,
        candidates,
        compliant,
        rigid_summary,
        rivals,
    })
}
