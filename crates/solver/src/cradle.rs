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
//! 3. the full kinematic model ([`model`]) fitted to all points ([`identify`]), rigid
//!    (ρ = 0) and compliant (ρ(A) = s·sin A + k·(cos A − 1), observable part): the model
//!    is chosen by leave-one-pose-out RMS prediction error of the ball (the compliant one
//!    only when it lowers it by more than `compliance_margin`, relative); then location
//!    errors with standard uncertainties, the ball, the compliance coefficients;
//! 4. held-out compensation figures: each A pose left out in turn, the model fitted on the
//!    others; before = RMS distance of the pose's measured points from where the nominal
//!    kinematics put the ball, after = RMS distance from where the model puts it. To first
//!    order the latter is the residual after [`compensate::compensate`] (which moves the
//!    axes by exactly the model's predicted error).
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

pub mod compensate;
pub mod compliance;
pub mod frames;
pub mod identify;
pub mod model;
pub mod simulate;

pub use compensate::{Command, Compensated, compensate};
pub use compliance::{Dependence, RotationDependence, fit_dependence};
pub use frames::{PatentAnalysis, PoseRow, patent_frames};
pub use model::{Ball, Compliance, CradleModel, LocationErrors};
pub use simulate::{CradleSimulation, simulate_cradle};

use crate::datasets::RotaryPointSet;
use crate::error::SolverError;
use crate::identification::CONVENTION;
use frames::{AAxisFit, PosePoints};
use identify::{Obs, fit_kinematics, leave_one_pose_out, start};
use model::{N_RIGID, PARAM_NAMES};
use nalgebra::{Rotation3, Unit, Vector3};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Options of [`check_cradle`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct CradleOptions {
    /// The instrument frame is registered to the machine axes (X, Y, Z). When false the
    /// model is fitted in a frame built from the data (X along the fitted A axis) and
    /// only the intrinsic location errors are reported.
    pub registered_frame: bool,
    /// Nominal intersection of the A and C axes in the (registered) instrument frame, mm.
    pub pivot_mm: [f64; 3],
    /// Relative reduction of the held-out RMS the compliant model must bring to be chosen
    /// (parsimony: default 0.02; with 3N ≈ 700 coordinates and 4 extra parameters the
    /// overfitting penalty and chance fluctuations of the held-out RMS are a few 0.1 %).
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

/// How a location error can be known from ball data.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Observability {
    /// From ball data alone, in any instrument frame.
    Intrinsic,
    /// Only with the instrument frame registered to the machine axes.
    RegisteredFrame,
    /// Not from a ball on the table (see `note`).
    NotObservable,
}

/// One ISO 230-7 location error.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LocationErrorReport {
    pub name: String,
    /// `um` or `urad`.
    pub unit: String,
    pub value: Option<f64>,
    pub std: Option<f64>,
    pub observability: Observability,
    pub note: Option<String>,
}

/// Summary of one kinematic model fit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct KinematicSummary {
    pub model: Dependence,
    pub n_params: usize,
    pub rank: usize,
    pub condition: f64,
    pub fit_rms_um: f64,
    pub sigma_um: f64,
    /// Leave-one-pose-out RMS prediction error of the ball, µm.
    pub held_out_rms_um: Option<f64>,
    pub converged: bool,
    pub iterations: usize,
}

/// The ball's identified position on the table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BallReport {
    pub radius_mm: f64,
    pub radius_std_um: f64,
    /// Includes EC0C (indistinguishable). `None` in an unregistered frame.
    pub azimuth_deg: Option<f64>,
    pub height_mm: f64,
    pub height_std_um: f64,
}

/// Compliance of the kinematic model, ρ(A) = s·sin A + k·(cos A − 1) about the pivot
/// (spatial frame), µrad, in its observable form s = (s_A, m_B, m_C),
/// k = (k_A, −m_C, m_B) (see [`Compliance`]; the rest is an A axis tilt).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ComplianceReport {
    pub s_a_urad: f64,
    pub k_a_urad: f64,
    pub m_b_urad: f64,
    pub m_c_urad: f64,
    /// Standard uncertainties of (s_A, k_A, m_B, m_C).
    pub std_urad: [f64; 4],
    pub sin_urad: [f64; 3],
    pub cos_urad: [f64; 3],
}

/// The identified kinematic model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct KinematicReport {
    /// Chosen by leave-one-pose-out RMS of the ball (see `margin`).
    pub chosen: Dependence,
    pub margin: f64,
    pub rigid: KinematicSummary,
    pub compliant: Option<KinematicSummary>,
    pub ball: BallReport,
    pub compliance: Option<ComplianceReport>,
    /// The model itself (for compensation). Its `location.ea0a_urad` holds the sum
    /// EA0A + EA0C, and `ea0c_urad`, `ec0c_urad` are 0 by convention (not observable; EC0C
    /// is carried by the ball azimuth); in an unregistered frame the model is expressed
    /// in the data frame (see `registered_frame`).
    pub model: CradleModel,
}

/// Held-out compensation figures of one A pose.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HeldOutPose {
    pub a_deg: f64,
    pub before_rms_um: f64,
    pub after_rms_um: f64,
    pub after_max_um: f64,
}

/// Compensation before/after on held-out poses (chosen model).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CompensationReport {
    pub method: String,
    pub poses: Vec<HeldOutPose>,
    pub before_rms_um: f64,
    pub after_rms_um: f64,
}

/// The cradle result document.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CradleResult {
    /// Always `cradle`.
    pub kind: String,
    pub convention: String,
    pub machine_id: Option<String>,
    pub measured_at: Option<String>,
    pub n_points: usize,
    pub n_poses: usize,
    pub registered_frame: bool,
    pub pivot_mm: [f64; 3],
    /// A of the pose whose actual frame defines the theoretical frames.
    pub reference_a_deg: f64,
    pub a_axis: AAxisFit,
    /// Per A pose: circle, frames and rotation vectors (patent and phase variants).
    pub poses: Vec<PoseRow>,
    /// Rigid and compliant fits of the pooled rotation vectors against A (descriptive;
    /// the model is chosen in `kinematics`).
    pub rotation_model: RotationDependence,
    pub location_errors: Vec<LocationErrorReport>,
    pub kinematics: KinematicReport,
    pub compensation: CompensationReport,
    /// Conventions and assumptions, in sentences.
    pub notes: Vec<String>,
}

fn group_poses(points: &RotaryPointSet, min_points: usize) -> Result<Vec<PosePoints>, SolverError> {
    let mut map: BTreeMap<i64, PosePoints> = BTreeMap::new();
    for (i, p) in points.points.iter().enumerate() {
        for (v, name) in [
            (p.a_deg, "a_deg"),
            (p.c_deg, "c_deg"),
            (p.x_mm, "x_mm"),
            (p.y_mm, "y_mm"),
            (p.z_mm, "z_mm"),
        ] {
            if !v.is_finite() {
                return Err(SolverError::InvalidInput(format!(
                    "point {i}: {name} is not finite"
                )));
            }
        }
        let key = (p.a_deg * 1e6).round() as i64;
        map.entry(key)
            .or_insert_with(|| PosePoints {
                a_deg: p.a_deg,
                a_rad: p.a_deg.to_radians(),
                points: Vec::new(),
            })
            .points
            .push((p.c_deg.to_radians(), Vector3::new(p.x_mm, p.y_mm, p.z_mm)));
    }
    let poses: Vec<PosePoints> = map.into_values().collect();
    if let Some(p) = poses.iter().find(|p| p.points.len() < min_points.max(4)) {
        return Err(SolverError::InvalidInput(format!(
            "A = {}°: {} points, at least {} needed per A pose",
            p.a_deg,
            p.points.len(),
            min_points.max(4)
        )));
    }
    if poses.len() < 3 {
        return Err(SolverError::InvalidInput(format!(
            "{} A pose(s): at least 3 needed (the A axis is the circle through their centres)",
            poses.len()
        )));
    }
    Ok(poses)
}

/// Frame built from the data for an unregistered instrument: X along the A axis, origin
/// on it at the reference centre's foot, Z the reference normal turned back by −A_ref.
fn data_frame(pa: &PatentAnalysis) -> (Rotation3<f64>, Vector3<f64>) {
    let a = Vector3::from(pa.a_axis.direction);
    let apt = Vector3::from(pa.a_axis.point_mm);
    let r = pa
        .poses
        .iter()
        .find(|p| p.a_deg == pa.reference_a_deg)
        .expect("reference pose");
    let c = Vector3::from(r.centre_mm);
    let origin = apt + a * (c - apt).dot(&a);
    let n = Vector3::from(r.normal);
    let z = (n - a * n.dot(&a)).normalize();
    let z =
        Rotation3::from_axis_angle(&Unit::new_normalize(a), -pa.reference_a_deg.to_radians()) * z;
    let rot = Rotation3::from_basis_unchecked(&[a, z.cross(&a), z]);
    (rot, origin)
}

fn summary(
    fit: &identify::KinematicFit,
    model: Dependence,
    held: Option<&[identify::HeldOut]>,
) -> KinematicSummary {
    KinematicSummary {
        model,
        n_params: fit.q.len(),
        rank: fit.rank,
        condition: fit.condition,
        fit_rms_um: fit.rms * 1e3,
        sigma_um: fit.sigma * 1e3,
        held_out_rms_um: held.map(|h| {
            (h.iter().map(|x| x.after_rms * x.after_rms).sum::<f64>() / h.len() as f64).sqrt() * 1e3
        }),
        converged: fit.converged,
        iterations: fit.iterations,
    }
}

fn location_reports(fit: &identify::KinematicFit, registered: bool) -> Vec<LocationErrorReport> {
    // (name, parameter index, scale to report unit, unit, observability, note)
    type Row<'a> = (
        &'a str,
        Option<usize>,
        f64,
        &'a str,
        Observability,
        Option<&'a str>,
    );
    let rows: [Row; 11] = [
        (
            "EY0A",
            Some(0),
            1e3,
            "um",
            Observability::RegisteredFrame,
            None,
        ),
        (
            "EZ0A",
            Some(1),
            1e3,
            "um",
            Observability::RegisteredFrame,
            None,
        ),
        (
            "EB0A",
            Some(2),
            1e6,
            "urad",
            Observability::RegisteredFrame,
            None,
        ),
        (
            "EC0A",
            Some(3),
            1e6,
            "urad",
            Observability::RegisteredFrame,
            None,
        ),
        (
            "EX0C",
            Some(5),
            1e3,
            "um",
            Observability::RegisteredFrame,
            None,
        ),
        (
            "EY0C",
            Some(6),
            1e3,
            "um",
            Observability::Intrinsic,
            Some("offset of the C axis from the A axis"),
        ),
        (
            "EB0C",
            Some(7),
            1e6,
            "urad",
            Observability::Intrinsic,
            Some("squareness of C to A"),
        ),
        (
            "EA0A+EA0C",
            Some(4),
            1e6,
            "urad",
            Observability::RegisteredFrame,
            Some(
                "EA0A and EA0C both turn the table about the A axis: only their sum is observable",
            ),
        ),
        (
            "EA0A",
            None,
            1e6,
            "urad",
            Observability::NotObservable,
            Some("not separable from EA0C; see EA0A+EA0C"),
        ),
        (
            "EA0C",
            None,
            1e6,
            "urad",
            Observability::NotObservable,
            Some("not separable from EA0A; see EA0A+EA0C"),
        ),
        (
            "EC0C",
            None,
            1e6,
            "urad",
            Observability::NotObservable,
            Some(
                "identical in effect to the ball's unknown azimuth on the table (carried by the ball azimuth)",
            ),
        ),
    ];
    rows.iter()
        .map(|(name, idx, scale, unit, obs, note)| {
            let known = match obs {
                Observability::Intrinsic => true,
                Observability::RegisteredFrame => registered,
                Observability::NotObservable => false,
            };
            let (value, std) = match (idx, known) {
                (Some(k), true) => (
                    Some(fit.q[*k] * scale),
                    Some(fit.cov[(*k, *k)].sqrt() * scale),
                ),
                _ => (None, None),
            };
            let note = match (obs, registered) {
                (Observability::RegisteredFrame, false) => {
                    Some("needs the instrument frame registered to the machine axes".to_string())
                }
                _ => note.map(str::to_string),
            };
            LocationErrorReport {
                name: name.to_string(),
                unit: unit.to_string(),
                value,
                std,
                observability: *obs,
                note,
            }
        })
        .collect()
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

    // Observations, in the registered frame or in the data frame.
    let (pivot, transform) = if opts.registered_frame {
        (opts.pivot_mm, None)
    } else {
        ([0.0; 3], Some(data_frame(&pa)))
    };
    let mut obs = Vec::with_capacity(points.points.len());
    for (k, pose) in poses.iter().enumerate() {
        for (c, p) in &pose.points {
            let p = match &transform {
                Some((rot, o)) => rot.inverse() * (p - o),
                None => *p,
            };
            obs.push(Obs {
                a: pose.a_rad,
                c: *c,
                p,
                pose: k,
            });
        }
    }
    let n_poses = poses.len();
    let q0 = start(&obs, pivot, N_RIGID);
    let rigid = fit_kinematics(&obs, pivot, &q0)?;
    let lopo_ok = n_poses >= 4;
    let rigid_held = if lopo_ok {
        Some(leave_one_pose_out(&obs, pivot, &rigid.q, n_poses)?)
    } else {
        None
    };
    let (compliant, compliant_held) = if n_poses >= 4 {
        let mut q = rigid.q.clone();
        q.resize(PARAM_NAMES.len(), 0.0);
        let fit = fit_kinematics(&obs, pivot, &q)?;
        let held = if n_poses >= 5 {
            Some(leave_one_pose_out(&obs, pivot, &fit.q, n_poses)?)
        } else {
            None
        };
        (Some(fit), held)
    } else {
        (None, None)
    };
    let held_rms = |h: &[identify::HeldOut]| {
        (h.iter().map(|x| x.after_rms * x.after_rms).sum::<f64>() / h.len() as f64).sqrt()
    };
    let use_compliant = match (&rigid_held, &compliant_held) {
        (Some(hr), Some(hc)) => held_rms(hc) < (1.0 - opts.compliance_margin) * held_rms(hr),
        _ => false,
    };
    let (fit, held) = if use_compliant {
        (
            compliant.as_ref().expect("compliant fit"),
            compliant_held.as_deref(),
        )
    } else {
        (&rigid, rigid_held.as_deref())
    };
    let std = |k: usize| fit.cov[(k, k)].sqrt();
    let compliance = use_compliant.then(|| ComplianceReport {
        s_a_urad: fit.q[11] * 1e6,
        k_a_urad: fit.q[12] * 1e6,
        m_b_urad: fit.q[13] * 1e6,
        m_c_urad: fit.q[14] * 1e6,
        std_urad: [std(11) * 1e6, std(12) * 1e6, std(13) * 1e6, std(14) * 1e6],
        sin_urad: fit.model.compliance.sin_urad,
        cos_urad: fit.model.compliance.cos_urad,
    });
    let held_poses: Vec<HeldOutPose> = held
        .unwrap_or(&[])
        .iter()
        .map(|h| HeldOutPose {
            a_deg: poses[h.pose].a_deg,
            before_rms_um: h.before_rms * 1e3,
            after_rms_um: h.after_rms * 1e3,
            after_max_um: h.after_max * 1e3,
        })
        .collect();
    let rms = |f: fn(&HeldOutPose) -> f64| {
        if held_poses.is_empty() {
            f64::NAN
        } else {
            (held_poses.iter().map(|h| f(h).powi(2)).sum::<f64>() / held_poses.len() as f64).sqrt()
        }
    };
    let compensation = CompensationReport {
        method: "leave-one-pose-out: each A pose predicted by the model fitted on the others; before = distance from the nominal kinematics, after = distance from the model (first-order residual after compensation)".into(),
        before_rms_um: rms(|h| h.before_rms_um),
        after_rms_um: rms(|h| h.after_rms_um),
        poses: held_poses,
    };
    let mut notes = vec![
        "Cradle: A about X carries C about Z; tool fixed; linear axes taken as exact.".to_string(),
        "Rotation vectors: matR = [e1 e2 e3]·[et1 et2 et3]^-1 in the instrument frame, log(matR) = axis × angle, µrad; e1 from the point at C = 0 (patent) and from the phase of all points (phase).".to_string(),
        "Compliance model of the kinematics: spatial rotation ρ(A) = s·sin A + k·(cos A − 1) of the table about the pivot.".to_string(),
    ];
    if opts.registered_frame {
        notes.push(format!(
            "Instrument frame assumed registered to the machine axes; nominal A/C intersection (pivot) at {:?} mm.",
            opts.pivot_mm
        ));
    } else {
        notes.push("Instrument frame not registered: the model is fitted in a frame with X along the fitted A axis; only intrinsic location errors are reported.".to_string());
    }
    if pa.poses.iter().any(|p| p.x_point_c_deg > 0.0) {
        notes.push("Some poses have no point at C = 0: the patent's e1 uses the point nearest C = 0 rotated back by −C about the normal.".to_string());
    }
    if n_poses < 5 {
        notes.push(
            "Fewer than 5 A poses: the compliant model cannot be validated; rigid kept."
                .to_string(),
        );
    }
    Ok(CradleResult {
        kind: "cradle".into(),
        convention: CONVENTION.into(),
        machine_id: points.machine_id.clone(),
        measured_at: points.measured_at.clone(),
        n_points: points.points.len(),
        n_poses,
        registered_frame: opts.registered_frame,
        pivot_mm: pivot,
        reference_a_deg: pa.reference_a_deg,
        a_axis: pa.a_axis.clone(),
        poses: pa.poses.clone(),
        rotation_model,
        location_errors: location_reports(fit, opts.registered_frame),
        kinematics: KinematicReport {
            chosen: if use_compliant {
                Dependence::Compliant
            } else {
                Dependence::Rigid
            },
            margin: opts.compliance_margin,
            rigid: summary(&rigid, Dependence::Rigid, rigid_held.as_deref()),
            compliant: compliant
                .as_ref()
                .map(|c| summary(c, Dependence::Compliant, compliant_held.as_deref())),
            ball: BallReport {
                radius_mm: fit.q[8],
                radius_std_um: std(8) * 1e3,
                azimuth_deg: opts.registered_frame.then(|| fit.q[9].to_degrees()),
                height_mm: fit.q[10],
                height_std_um: std(10) * 1e3,
            },
            compliance,
            model: fit.model,
        },
        compensation,
        notes,
    })
}
