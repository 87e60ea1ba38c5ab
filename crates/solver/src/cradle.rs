//! 5-axis cradle check (A about X carrying C about Z): the A/C connection's rigidity by the
//! seed patent's method, the ISO 230-7 location errors, a rigid-versus-compliant model of
//! the deflection, and compensation.
//!
//! Pipeline of [`check_cradle`]:
//!
//! 1. group the measured ball centres by commanded A ([`frames`]): circle per pose, A axis
//!    from the circle through the centres, actual and theoretical frames, rotation vector
//!    log(matR) per pose, with e₁ from the point at C = 0 (patent) and from the phase of
//!    all points (beyond the patent);
//! 2. rigid and compliant fits of the rotation vectors against A, with their
//!    leave-one-pose-out errors ([`compliance`], descriptive);
//! 3. the instrument frame registered ([`register`]): the best-fit rigid map to the
//!    nominal kinematics; a frame stated to be the machine's is kept when the data agree
//!    with it, otherwise the check works in the best-fit frame and reports only the
//!    intrinsic location errors (and says so);
//! 4. the full kinematic model ([`model`]) fitted to all points ([`identify`]), chosen by
//!    leave-one-pose-out RMS prediction error of the ball among A-dependent terms added
//!    one at a time (forward selection, each step must lower it by more than
//!    `compliance_margin`, relative): a tilt of the table with A about the pivot, a tilt
//!    of the C table about its mount about X (parallel to A) or about its Y, the A
//!    positioning error (s_A·sin A + k_A·(cos A − 1), or a polynomial EAA(A) of order
//!    1–3), a shift along A or sideways; a candidate whose terms the data cannot
//!    separate ([`separability`]) is not one. Then location errors with standard
//!    uncertainties, the ball, the A-dependent terms, what the data can separate among
//!    the whole family against the chosen model ([`separability::separability`]), and
//!    each A-dependent term as a function of A with its standard uncertainty;
//! 5. held-out compensation figures: each A pose left out in turn, the model fitted on the
//!    others; before = RMS distance of the pose's measured points from where the nominal
//!    kinematics put the ball (in the registered frame), after = RMS distance from where
//!    the model puts it. To first order the latter is the residual after
//!    [`compensate::compensate`] (which moves the axes by exactly the model's predicted
//!    error);
//! 6. the held-out residual compared with the tracker noise floor √3·σ, σ the noise per
//!    coordinate pooled from the per-pose circle fits (which no A-dependent effect
//!    reaches); a gap is reported when the lack-of-fit F test with that pure error
//!    ([`LackOfFit`]) rejects the chosen model at [`LACK_OF_FIT_ALPHA`] (without pure
//!    error to test against, when the held-out RMS exceeds the floor by more than
//!    [`FLOOR_RATIO`]).
//!
//! # Observability (ball data alone)
//!
//! Intrinsic to the cradle and observable in any instrument frame: EY0C (the C axis's
//! offset from the A axis) and EB0C (its squareness to A), the ball's radius and height.
//! Observable only when the instrument frame is registered to the machine axes (the
//! default assumption, `registered_frame = true`; `pivot_mm` is then the nominal
//! intersection of A and C in that frame): EY0A, EZ0A, EB0A, EC0A, EX0C and the sum
//! EA0A + EA0C. Never observable from a ball on the table: EA0A and EA0C separately (both
//! turn the table about the A axis) and EC0C (the same as the ball's unknown azimuth on the
//! table). Unobservable terms are reported without a value.

//!
//! The check's own steps, one module each: [`report`] (what it reports), [`poses`] (the
//! points grouped by pose and the data frame), [`location`] (the location errors and
//! their observability), [`selection`] (the forward selection of the A-dependent terms
//! and the rivals the data do not exclude), [`curves`] (the chosen terms as functions
//! of A) and [`floor`] (the held-out residual against the tracker noise floor).

pub mod compensate;
pub mod compliance;
mod curves;
mod floor;
pub mod frames;
pub mod identify;
mod location;
pub mod model;
mod poses;
pub mod register;
mod report;
mod selection;
pub mod separability;
pub mod simulate;

pub use compensate::{Command, Compensated, compensate};
pub use compliance::{Dependence, RotationDependence, fit_dependence};
pub use floor::{FLOOR_RATIO, LACK_OF_FIT_ALPHA};
pub use frames::{PatentAnalysis, PoseRow, patent_frames};
pub use location::angle_text;
pub use model::{Ball, Compliance, CradleModel, LocationErrors, ModelSpec, Tilt};
pub use register::RegistrationReport;
pub use report::{
    BallReport, CompensationReport, ComplianceCurve, ComplianceReport, CradleResult, FloorReport,
    HeldOutPose, KinematicReport, KinematicSummary, LackOfFit, LocationErrorReport, ModelParameter,
    Observability, RivalModel, RivalValue,
};
pub use separability::{SeparabilityReport, Term, TermSeparability};
pub use simulate::{CradleSimulation, Deflection, simulate_cradle};

use crate::datasets::RotaryPointSet;
use crate::error::SolverError;
use crate::identification::CONVENTION;
use curves::compliance_curves;
use floor::{floor_report, held_rms};
use frames::PosePoints;
use identify::{Obs, start};
use location::location_reports;
use nalgebra::Vector3;
use poses::{data_frame, group_poses, observations};
use selection::{Selection, forward_selection, model_parameters};
use serde::{Deserialize, Serialize};

/// Options of [`check_cradle`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(default)]
pub struct CradleOptions {
    /// The instrument frame is registered to the machine axes (X, Y, Z). When false the
    /// model is fitted in a frame built from the data (X along the fitted A axis) and
    /// only the intrinsic location errors are reported.
    pub registered_frame: bool,
    /// Nominal intersection of the A and C axes in the (registered) instrument frame, mm.
    pub pivot_mm: [f64; 3],
    /// Relative reduction of the held-out RMS each added A-dependent term must bring to
    /// be kept (parsimony: default 0.02; with 3N ≈ 700 coordinates and a few extra
    /// parameters the overfitting penalty and chance fluctuations of the held-out RMS are
    /// a few 0.1 %).
    pub compliance_margin: f64,
    /// Minimum number of points per A pose (at least 4: a circle has 6 parameters and
    /// 2 residuals per point, so 4 points leave 2 degrees of freedom for σ).
    pub min_points_per_pose: usize,
}

impl Default for CradleOptions {
    fn default() -> Self {
        CradleOptions {
            registered_frame: true,
            pivot_mm: [0.0; 3],
            compliance_margin: 0.02,
            min_points_per_pose: 4,
        }
    }
}

/// Runs the cradle check on measured ball centres (see the module docs).
pub fn check_cradle(
    points: &RotaryPointSet,
    opts: &CradleOptions,
) -> Result<CradleResult, SolverError> {
    let poses = group_poses(points, opts.min_points_per_pose)?;
    let pa = patent_frames(&poses)?;
    let a_rad: Vec<f64> = pa.poses.iter().map(|p| p.a_deg.to_radians()).collect();
    let r: Vec<Vector3<f64>> = pa
        .poses
        .iter()
        .map(|p| Vector3::from(p.rotation_pooled.vector_urad))
        .collect();
    let rotation_model = fit_dependence(&a_rad, &r);

    let frame = register_frame(&poses, &pa, opts)?;
    let (pivot, obs) = (frame.pivot, &frame.obs);
    let n_poses = poses.len();
    let Selection {
        best,
        candidates,
        compliant,
        rigid_summary,
        rivals,
    } = forward_selection(obs, pivot, n_poses, opts.compliance_margin)?;
    let fit = &best.fit;
    let use_compliant = !fit.spec.is_rigid();
    let std = |k: usize| fit.cov[(k, k)].sqrt();
    let compliance = use_compliant.then(|| compliance_report(fit));
    let held_poses = held_out_poses(&poses, best.held.as_deref());
    let floor = floor_report(&pa.poses, &held_poses, fit, obs.len());
    let compensation = compensation_report(held_poses);
    let notes = check_notes(opts, &frame, &pa, n_poses, floor.as_ref(), &rivals);
    Ok(CradleResult {
        kind: "cradle".into(),
        convention: CONVENTION.into(),
        machine_id: points.machine_id.clone(),
        measured_at: points.measured_at.clone(),
        n_points: points.points.len(),
        n_poses,
        registered_frame: frame.machine_frame,
        pivot_mm: pivot,
        reference_a_deg: pa.reference_a_deg,
        a_axis: pa.a_axis.clone(),
        poses: pa.poses.clone(),
        rotation_model,
        location_errors: location_reports(fit, frame.machine_frame),
        registration: frame.registration,
        kinematics: KinematicReport {
            chosen: if use_compliant {
                Dependence::Compliant
            } else {
                Dependence::Rigid
            },
            spec: fit.spec,
            description: fit.spec.describe(),
            margin: opts.compliance_margin,
            rigid: rigid_summary,
            compliant,
            candidates,
            parameters: model_parameters(fit, &rivals),
            rivals,
            separability: Some(separability::separability(obs, &fit.model, &fit.spec)),
            curves: compliance_curves(fit, &pa.poses),
            ball: BallReport {
                radius_mm: fit.q[8],
                radius_std_um: std(8) * 1e3,
                azimuth_deg: frame.machine_frame.then(|| fit.q[9].to_degrees()),
                height_mm: fit.q[10],
                height_std_um: std(10) * 1e3,
            },
            compliance,
            model: fit.model,
        },
        compensation,
        floor,
        notes,
    })
}

/// The instrument frame the check works in (module docs, step 3), with the
/// observations in it.
struct Frame {
    /// The frame is the machine's as stated (else the best-fit frame).
    machine_frame: bool,
    pivot: [f64; 3],
    obs: Vec<Obs>,
    registration: RegistrationReport,
    /// The best-fit registration's rotation (rad) and the stated pivot's offset (mm).
    rotation_vec: Vector3<f64>,
    pivot_offset: Vector3<f64>,
}

/// Registration of the instrument frame (module docs, step 3): the best-fit rigid map
/// to the nominal kinematics; a frame stated to be the machine's is kept when the data
/// agree with it, otherwise the check works in the best-fit frame.
fn register_frame(
    poses: &[PosePoints],
    pa: &PatentAnalysis,
    opts: &CradleOptions,
) -> Result<Frame, SolverError> {
    let to_obs = |map: &dyn Fn(&Vector3<f64>) -> Vector3<f64>| observations(poses, map);
    let (r0, o) = data_frame(pa);
    let q_ball = start(
        &to_obs(&|p| r0.inverse() * (p - o)),
        [0.0; 3],
        &ModelSpec::RIGID,
    );
    let reg = register::register(poses, &r0, &o, [q_ball[8], q_ball[9], q_ball[10]])?;
    let rotation_vec = reg.rotation.scaled_axis();
    let pivot_offset = reg.apply(&Vector3::from(opts.pivot_mm));
    let machine_frame = opts.registered_frame
        && rotation_vec.norm() <= register::MAX_ROTATION_RAD
        && pivot_offset.norm() <= register::MAX_SHIFT_MM;
    let (pivot, obs) = if machine_frame {
        (opts.pivot_mm, to_obs(&|p| *p))
    } else {
        ([0.0; 3], to_obs(&|p| reg.apply(p)))
    };
    let registration = RegistrationReport {
        frame: if machine_frame { "machine" } else { "best_fit" }.into(),
        rotation_urad: (rotation_vec * 1e6).into(),
        pivot_offset_mm: pivot_offset.into(),
        residual_rms_um: reg.residual_rms_mm * 1e3,
    };
    Ok(Frame {
        machine_frame,
        pivot,
        obs,
        registration,
        rotation_vec,
        pivot_offset,
    })
}

/// The chosen model's compliance terms with their standard uncertainties.
fn compliance_report(fit: &identify::KinematicFit) -> ComplianceReport {
    let std = |k: usize| fit.cov[(k, k)].sqrt();
    let std_of = |name: &str| fit.spec.index(name).map_or(0.0, std);
    let [sa, ka, mb, mc] = fit.model.compliance.observable();
    ComplianceReport {
        s_a_urad: sa,
        k_a_urad: ka,
        m_b_urad: mb,
        m_c_urad: mc,
        std_urad: ["s_A", "k_A", "m_B", "m_C"].map(|n| std_of(n) * 1e6),
        sin_urad: fit.model.compliance.sin_urad,
        cos_urad: fit.model.compliance.cos_urad,
    }
}

/// Every held-out pose's prediction errors before and after, µm (module docs, step 5).
fn held_out_poses(poses: &[PosePoints], held: Option<&[identify::HeldOut]>) -> Vec<HeldOutPose> {
    held.unwrap_or(&[])
        .iter()
        .map(|h| HeldOutPose {
            a_deg: poses[h.pose].a_deg,
            before_rms_um: h.before_rms * 1e3,
            after_rms_um: h.after_rms * 1e3,
            after_max_um: h.after_max * 1e3,
        })
        .collect()
}

/// The held-out compensation figures: RMS over the held-out poses before and after.
fn compensation_report(held_poses: Vec<HeldOutPose>) -> CompensationReport {
    let rms = |f: fn(&HeldOutPose) -> f64| {
        if held_poses.is_empty() {
            f64::NAN
        } else {
            (held_poses.iter().map(|h| f(h).powi(2)).sum::<f64>() / held_poses.len() as f64).sqrt()
        }
    };
    CompensationReport {
        method: "leave-one-pose-out: each A pose predicted by the model fitted on the others; before = distance from the nominal kinematics in the registered frame, after = distance from the model (first-order residual after compensation)".into(),
        before_rms_um: rms(|h| h.before_rms_um),
        after_rms_um: rms(|h| h.after_rms_um),
        poses: held_poses,
    }
}

/// The check's conventions and assumptions, in sentences: the model, the frame, the
/// poses, the floor's statement and the rivals'.
fn check_notes(
    opts: &CradleOptions,
    frame: &Frame,
    pa: &PatentAnalysis,
    n_poses: usize,
    floor: Option<&FloorReport>,
    rivals: &[RivalModel],
) -> Vec<String> {
    let (rotation_vec, pivot_offset) = (frame.rotation_vec, frame.pivot_offset);
    let mut notes = vec![
        "Cradle: A about X carries C about Z; tool fixed; linear axes taken as exact.".to_string(),
        "Rotation vectors: matR = [e1 e2 e3]·[et1 et2 et3]^-1 in the instrument frame, log(matR) = axis × angle, µrad; e1 from the point at C = 0 (patent) and from the phase of all points (phase).".to_string(),
        "Model of the kinematics: location errors, ball, and the A-dependent terms kept by forward selection on held-out A poses: a tilt ρ(A) = s·sin A + k·(cos A − 1) about the pivot, tilts of the C table about its mount about X and about its Y (each a·sin A + b·(cos A − 1)), an A positioning error, a shift along A or sideways.".to_string(),
    ];
    if frame.machine_frame {
        notes.push(format!(
            "Instrument frame registered to the machine axes as stated; nominal A/C intersection (pivot) at {:?} mm (the best-fit registration agrees within {} and {:.3} mm).",
            opts.pivot_mm,
            angle_text(rotation_vec.norm()),
            pivot_offset.norm()
        ));
    } else if opts.registered_frame {
        notes.push(format!(
            "The instrument frame is not the machine's as stated: the best-fit registration to the nominal kinematics turns it by {} and puts the stated pivot {:.3} mm away (limits {:.0} µrad, {} mm). The check used the best-fit frame: only the location errors intrinsic to the cradle are reported. Give --pivot-mm if the frame is the machine's with the pivot elsewhere, or register the instrument to the machine axes.",
            angle_text(rotation_vec.norm()),
            pivot_offset.norm(),
            register::MAX_ROTATION_RAD * 1e6,
            register::MAX_SHIFT_MM
        ));
    } else {
        notes.push("Instrument frame not registered: the points were registered to the nominal kinematics (best fit); only intrinsic location errors are reported.".to_string());
    }
    if pa.poses.iter().any(|p| p.x_point_c_deg > 0.0) {
        notes.push("Some poses have no point at C = 0: the patent's e1 uses the point nearest C = 0 rotated back by −C about the normal.".to_string());
    }
    if n_poses < 5 {
        notes.push(
            "Fewer than 5 A poses: no A-dependent model can be validated; rigid kept.".to_string(),
        );
    }
    if let Some(f) = floor {
        notes.push(f.statement.clone());
    }
    notes.extend(rivals.iter().map(|r| r.statement.clone()));
    notes
}
