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

pub mod compensate;
pub mod compliance;
pub mod frames;
pub mod identify;
pub mod model;
pub mod register;
pub mod separability;
pub mod simulate;

pub use compensate::{Command, Compensated, compensate};
pub use compliance::{Dependence, RotationDependence, fit_dependence};
pub use frames::{PatentAnalysis, PoseRow, patent_frames};
pub use model::{Ball, Compliance, CradleModel, LocationErrors, ModelSpec, Tilt};
pub use register::RegistrationReport;
pub use separability::{SeparabilityReport, Term, TermSeparability};
pub use simulate::{CradleSimulation, Deflection, simulate_cradle};

use crate::datasets::RotaryPointSet;
use crate::error::SolverError;
use crate::identification::CONVENTION;
use frames::{AAxisFit, PosePoints};
use identify::{Obs, fit_kinematics, leave_one_pose_out, start};
use model::{params_from_model, unit_of, unit_scale};
use nalgebra::{Rotation3, Unit, Vector3};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

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

/// How a location error can be known from ball data.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema), schema(as = CradleObservability))]
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
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
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
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct KinematicSummary {
    /// `rigid` or `compliant` (anything depending on A).
    pub model: Dependence,
    /// The terms the model carries, and in words.
    #[serde(default)]
    pub spec: ModelSpec,
    #[serde(default)]
    pub description: String,
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
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
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
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
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

/// One A-dependent parameter of the chosen model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ModelParameter {
    /// s_A, k_A, m_B, m_C, tX_s, tX_c, tY_s, tY_c (µrad), z_M (mm), e_s, e_c, y_s, y_c (µm),
    /// e_1 … e_3 (µrad).
    pub name: String,
    pub unit: String,
    pub value: f64,
    pub std: f64,
    /// |value| ≥ 3·std; otherwise the term is possible but undetermined.
    pub determined: bool,
    /// Another model explains the data as well (a [`RivalModel`] of
    /// `kinematics.rivals`) and puts this parameter more than 2·std away (or does without
    /// it while |value| > 2·std): its value hangs on which of them is taken, and the
    /// data do not determine it.
    #[serde(default)]
    pub model_dependent: bool,
}

/// A model the forward selection cannot tell from the chosen one: a successor of the same
/// model as the chosen one (one term different) whose BIC is within 2·ln 20 ≈ 6 of the
/// chosen model's (posterior odds above 1 : 20), that the selection would have accepted
/// too (it lowers the held-out RMS of that model by more than `margin`) and whose
/// held-out RMS is within `margin` of the chosen model's.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct RivalModel {
    pub summary: KinematicSummary,
    /// BIC(rival) − BIC(chosen) (3N·ln(SSR/3N) + P·ln 3N).
    pub bic_difference: f64,
    /// The chosen model's A-dependent parameters as the rival has them (`None`: it does
    /// without them), where it puts them more than 2·std from the chosen value.
    pub differs: Vec<RivalValue>,
    /// In a sentence, with what would decide between the two.
    pub statement: String,
}

/// A parameter's value in a [`RivalModel`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct RivalValue {
    pub name: String,
    pub unit: String,
    /// In the rival (`None`: not in it).
    pub value: Option<f64>,
}

/// One A-dependent term of the chosen model as a function of A, evaluated over the
/// measured A range only.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ComplianceCurve {
    pub term: Term,
    /// What is drawn, short (e.g. "tilt about the mount, X: τ_X(A)"; the pivot tilt's
    /// components are in the machine frame, the mount's in the A body frame).
    pub name: String,
    /// `urad` or `um`.
    pub unit: String,
    pub a_deg: Vec<f64>,
    pub value: Vec<f64>,
    /// Standard uncertainty of each value, from the parameters' covariance (gᵀ·Σ·g).
    pub std: Vec<f64>,
}

/// The held-out residual against the tracker noise floor.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct FloorReport {
    /// Tracker noise per coordinate pooled from the per-pose circle fits, µm.
    pub noise_um: f64,
    /// The floor of a 3-D RMS, √3·noise, µm.
    pub floor_rms_um: f64,
    /// Held-out RMS of the chosen model (leave one A pose out), µm.
    pub held_out_rms_um: f64,
    /// held_out / floor.
    pub ratio: f64,
    /// The unexplained part in quadrature, √(held_out² − floor²), µm (0 at the floor).
    pub gap_um: f64,
    /// The verdict: the lack-of-fit test does not reject the model at
    /// [`LACK_OF_FIT_ALPHA`] (or, without it, the held-out ratio is within [`FLOOR_RATIO`]).
    pub at_floor: bool,
    /// The lack-of-fit F test of the chosen model against the tracker noise (`None`
    /// when the fit leaves no degrees of freedom beyond the circles').
    #[serde(default)]
    pub lack_of_fit: Option<LackOfFit>,
    /// In a sentence, with the poses where the gap is largest when there is one.
    pub statement: String,
}

/// Lack-of-fit F test with pure error (Draper & Smith, Applied Regression Analysis,
/// 3rd ed., section 2.1): the chosen model's residual sum of squares SSR (3N − P degrees
/// of freedom) is split into the per-pose circle fits' SSR_c (pure error: the tracker
/// noise, ν_c = Σ(2N − 6)) and the rest, SSR − SSR_c with ν = 3N − P − ν_c (the circles'
/// placement and the points' phase, which every A-dependent effect moves);
/// F = ((SSR − SSR_c)/ν) / (SSR_c/ν_c) follows F(ν, ν_c) when the model is right.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct LackOfFit {
    pub f: f64,
    pub dof: f64,
    pub dof_pure: f64,
    /// P(F(ν, ν_c) ≥ f).
    pub p_value: f64,
    /// The false-alarm rate of the verdict ([`LACK_OF_FIT_ALPHA`]).
    pub alpha: f64,
}

/// The identified kinematic model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct KinematicReport {
    /// Chosen by leave-one-pose-out RMS of the ball (see `margin`): `rigid`, or
    /// `compliant` when any A-dependent term was kept (see `spec`).
    pub chosen: Dependence,
    /// The chosen model's terms, and in words.
    #[serde(default)]
    pub spec: ModelSpec,
    #[serde(default)]
    pub description: String,
    pub margin: f64,
    pub rigid: KinematicSummary,
    /// The classic compliant model (ρ(A) about the pivot, observable form), for
    /// comparison.
    pub compliant: Option<KinematicSummary>,
    /// Every model tried by the forward selection, in the order tried.
    #[serde(default)]
    pub candidates: Vec<KinematicSummary>,
    /// The chosen model's A-dependent parameters.
    #[serde(default)]
    pub parameters: Vec<ModelParameter>,
    /// Models the data cannot tell from the chosen one ([`RivalModel`]); the parameters
    /// they put elsewhere are flagged `model_dependent`.
    #[serde(default)]
    pub rivals: Vec<RivalModel>,
    /// What the ball data can separate among the A-dependent terms of the family, against
    /// the chosen model ([`separability`]).
    #[serde(default)]
    pub separability: Option<SeparabilityReport>,
    /// The chosen model's A-dependent terms as functions of A over the measured A range,
    /// with standard uncertainties.
    #[serde(default)]
    pub curves: Vec<ComplianceCurve>,
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
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct HeldOutPose {
    pub a_deg: f64,
    pub before_rms_um: f64,
    pub after_rms_um: f64,
    pub after_max_um: f64,
}

/// Compensation before/after on held-out poses (chosen model).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct CompensationReport {
    pub method: String,
    pub poses: Vec<HeldOutPose>,
    pub before_rms_um: f64,
    pub after_rms_um: f64,
}

/// The cradle result document.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
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
    /// How the instrument frame was registered.
    pub registration: RegistrationReport,
    pub kinematics: KinematicReport,
    pub compensation: CompensationReport,
    /// The held-out residual against the tracker noise floor (`None` without held-out
    /// poses).
    pub floor: Option<FloorReport>,
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

/// The points of every pose as observations of the model, each mapped by `map` (into
/// the frame the model is fitted in).
fn observations(poses: &[PosePoints], map: &dyn Fn(&Vector3<f64>) -> Vector3<f64>) -> Vec<Obs> {
    poses
        .iter()
        .enumerate()
        .flat_map(|(k, pose)| {
            pose.points.iter().map(move |(c, p)| Obs {
                a: pose.a_rad,
                c: *c,
                p: map(p),
                pose: k,
            })
        })
        .collect()
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

fn summary(fit: &identify::KinematicFit, held: Option<&[identify::HeldOut]>) -> KinematicSummary {
    KinematicSummary {
        model: if fit.spec.is_rigid() {
            Dependence::Rigid
        } else {
            Dependence::Compliant
        },
        spec: fit.spec,
        description: fit.spec.describe(),
        n_params: fit.q.len(),
        rank: fit.rank,
        condition: fit.condition,
        fit_rms_um: fit.rms * 1e3,
        sigma_um: fit.sigma * 1e3,
        held_out_rms_um: held.map(|h| held_rms(h) * 1e3),
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

/// An angle for reports: µrad when small, degrees otherwise.
pub fn angle_text(rad: f64) -> String {
    if rad.abs() < 1e-2 {
        format!("{:.0} µrad", rad * 1e6)
    } else {
        format!("{:.3}°", rad.to_degrees())
    }
}

/// RMS over the held-out poses of their RMS prediction error (mm).
fn held_rms(h: &[identify::HeldOut]) -> f64 {
    (h.iter().map(|x| x.after_rms * x.after_rms).sum::<f64>() / h.len().max(1) as f64).sqrt()
}

/// Without a lack-of-fit test ([`LackOfFit`]: no degrees of freedom beyond the circle
/// fits), a gap is reported when the held-out RMS exceeds the tracker floor by more than
/// this ratio: the ratio of the two noise estimates scatters by ≈ 3 % for 234 points
/// (more with fewer) and the model's own estimation error adds about P/(6N).
pub const FLOOR_RATIO: f64 = 1.1;

/// False-alarm rate of the lack-of-fit verdict ([`LackOfFit`]): a right model is said to
/// leave a gap in 1 % of checks.
pub const LACK_OF_FIT_ALPHA: f64 = 0.01;

/// The lack-of-fit test ([`LackOfFit`]) of a fit with residual sum of squares `ssr_um2`
/// (µm²) over `n_coords` coordinates and `n_params` parameters.
fn lack_of_fit(
    poses: &[PoseRow],
    ssr_um2: f64,
    n_coords: usize,
    n_params: usize,
) -> Option<LackOfFit> {
    use statrs::distribution::{ContinuousCDF, FisherSnedecor};
    let (ss_c, dof_c) = pure_error(poses);
    let dof = n_coords as f64 - n_params as f64 - dof_c;
    if dof < 1.0 || dof_c < 1.0 || ss_c <= 0.0 {
        return None;
    }
    let f = ((ssr_um2 - ss_c).max(0.0) / dof) / (ss_c / dof_c);
    let p_value = FisherSnedecor::new(dof, dof_c).ok()?.sf(f);
    Some(LackOfFit {
        f,
        dof,
        dof_pure: dof_c,
        p_value,
        alpha: LACK_OF_FIT_ALPHA,
    })
}

/// The per-pose circle fits' residual sum of squares (µm²) and degrees of freedom: the
/// pure error of the tracker, which no A-dependent effect reaches.
fn pure_error(poses: &[PoseRow]) -> (f64, f64) {
    poses.iter().fold((0.0, 0.0), |(ss, dof), p| {
        let n = p.n_points as f64;
        (
            ss + n * p.circle_rms_um.powi(2),
            dof + (2.0 * n - 6.0).max(0.0),
        )
    })
}

/// Tracker noise per coordinate (µm) pooled from the per-pose circle fits, whose
/// orthogonal residuals (radial and axial, 2 per point, 6 parameters per circle) no
/// A-dependent effect reaches: σ² = Σ N·rms² / Σ (2N − 6).
fn tracker_noise_um(poses: &[PoseRow]) -> f64 {
    let (ss, dof) = pure_error(poses);
    if dof > 0.0 {
        (ss / dof).sqrt()
    } else {
        f64::NAN
    }
}

/// One fitted model with its leave-one-pose-out figures.
struct Candidate {
    fit: identify::KinematicFit,
    held: Option<Vec<identify::HeldOut>>,
    /// Held-out RMS, mm (∞ without held-out poses).
    rms: f64,
}

fn try_model(
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

fn with_held_out(
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
fn bic(fit: &identify::KinematicFit, n_obs: usize) -> f64 {
    let n = 3.0 * n_obs as f64;
    let ssr = fit.rms * fit.rms * n_obs as f64;
    n * (ssr.max(1e-300) / n).ln() + fit.q.len() as f64 * n.ln()
}

/// Successors validated on held-out poses at each step: the best ones by BIC (the
/// held-out validation is the expensive part).
const VALIDATED_PER_STEP: usize = 2;

/// The models one step richer than `spec` (module docs, step 4): one more term of the
/// family, and the classic compliant pair from the rigid model. (Each tilt about the
/// mount pays off alone, its lever giving z_M, so they are not offered as a pair: a
/// pair would win over its better half by chance as often as not.)
fn successors(spec: &ModelSpec) -> Vec<ModelSpec> {
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
fn model_parameters(fit: &identify::KinematicFit, rivals: &[RivalModel]) -> Vec<ModelParameter> {
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
const RIVAL_BIC: f64 = 5.991_464_547_107_979; // 2·ln 20

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
fn rivals(
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

/// Points per curve of [`compliance_curves`].
const CURVE_POINTS: usize = 61;

/// The chosen model's A-dependent terms as functions of A over the measured A range, each
/// linear in its parameters q: value(A) = g(A)ᵀ·q, variance g(A)ᵀ·Σ·g(A).
fn compliance_curves(fit: &identify::KinematicFit, poses: &[PoseRow]) -> Vec<ComplianceCurve> {
    let spec = &fit.spec;
    let (lo, hi) = poses
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p.a_deg), hi.max(p.a_deg))
        });
    if hi.partial_cmp(&lo) != Some(std::cmp::Ordering::Greater) {
        return vec![];
    }
    let a_deg: Vec<f64> = (0..CURVE_POINTS)
        .map(|i| lo + (hi - lo) * i as f64 / (CURVE_POINTS - 1) as f64)
        .collect();
    let harmonic = |a: f64| {
        let (s, c) = a.sin_cos();
        vec![s, c - 1.0]
    };
    // (term, name, parameters, g(A) over them)
    type Basis = Box<dyn Fn(f64) -> Vec<f64>>;
    let mut rows: Vec<(Term, &str, Vec<&str>, Basis)> = vec![];
    if spec.a_harmonic {
        rows.push((
            Term::APositioning,
            "A positioning error: s_A·sin A + k_A·(cos A − 1)",
            vec!["s_A", "k_A"],
            Box::new(harmonic),
        ));
    }
    if spec.eaa_order > 0 {
        let order = spec.eaa_order.min(3);
        rows.push((
            Term::AEncoder,
            "A positioning error: EAA(A)",
            ["e_1", "e_2", "e_3"][..order].to_vec(),
            Box::new(move |a: f64| {
                let x = a / std::f64::consts::FRAC_PI_2;
                (1..=order as i32).map(|j| x.powi(j)).collect()
            }),
        ));
    }
    if spec.tilt != model::Tilt::None {
        // ρ_y = m_B·sin A − m_C·(cos A − 1), ρ_z = m_C·sin A + m_B·(cos A − 1).
        rows.push((
            Term::PivotTilt,
            "tilt about the pivot, Y: ρ_y(A)",
            vec!["m_B", "m_C"],
            Box::new(|a: f64| {
                let (s, c) = a.sin_cos();
                vec![s, 1.0 - c]
            }),
        ));
        rows.push((
            Term::PivotTilt,
            "tilt about the pivot, Z: ρ_z(A)",
            vec!["m_B", "m_C"],
            Box::new(|a: f64| {
                let (s, c) = a.sin_cos();
                vec![c - 1.0, s]
            }),
        ));
    }
    for (on, term, name, params) in [
        (
            spec.mount_x,
            Term::MountX,
            "tilt about the mount, X: τ_X(A)",
            ["tX_s", "tX_c"],
        ),
        (
            spec.mount_y,
            Term::MountY,
            "tilt about the mount, Y: τ_Y(A)",
            ["tY_s", "tY_c"],
        ),
        (
            spec.axial,
            Term::Axial,
            "shift along A: t_X(A)",
            ["e_s", "e_c"],
        ),
        (
            spec.lateral,
            Term::Lateral,
            "sideways shift: t_Y(A)",
            ["y_s", "y_c"],
        ),
    ] {
        if on {
            rows.push((term, name, params.to_vec(), Box::new(harmonic)));
        }
    }
    rows.into_iter()
        .filter_map(|(term, name, params, g)| {
            let idx: Vec<usize> = params
                .iter()
                .map(|p| spec.index(p))
                .collect::<Option<Vec<usize>>>()?;
            let scale = unit_scale(params[0]);
            let (mut value, mut std) = (vec![], vec![]);
            for &a in &a_deg {
                let gv = g(a.to_radians());
                let v: f64 = idx.iter().zip(&gv).map(|(&k, g)| g * fit.q[k]).sum();
                let mut var = 0.0;
                for (i, &ki) in idx.iter().enumerate() {
                    for (j, &kj) in idx.iter().enumerate() {
                        var += gv[i] * fit.cov[(ki, kj)] * gv[j];
                    }
                }
                value.push(v * scale);
                std.push(var.max(0.0).sqrt() * scale);
            }
            Some(ComplianceCurve {
                term,
                name: name.into(),
                unit: unit_of(params[0]).into(),
                a_deg: a_deg.clone(),
                value,
                std,
            })
        })
        .collect()
}

fn floor_report(
    poses: &[PoseRow],
    held: &[HeldOutPose],
    fit: &identify::KinematicFit,
    n_points: usize,
) -> Option<FloorReport> {
    if held.is_empty() {
        return None;
    }
    let lof = lack_of_fit(
        poses,
        (fit.rms * 1e3).powi(2) * n_points as f64,
        3 * n_points,
        fit.q.len(),
    );
    let noise = tracker_noise_um(poses);
    let floor = 3f64.sqrt() * noise;
    let h = (held.iter().map(|p| p.after_rms_um.powi(2)).sum::<f64>() / held.len() as f64).sqrt();
    let ratio = h / floor;
    let gap = (h * h - floor * floor).max(0.0).sqrt();
    let at_floor = lof
        .as_ref()
        .map_or(ratio <= FLOOR_RATIO, |l| l.p_value >= l.alpha);
    let test = lof.as_ref().map_or(String::new(), |l| {
        format!(
            "; lack-of-fit test F = {:.2} on ({:.0}, {:.0}) degrees of freedom, p = {:.3}",
            l.f, l.dof, l.dof_pure, l.p_value
        )
    });
    let statement = if at_floor {
        format!(
            "held-out RMS {h:.2} µm is at the tracker floor {floor:.2} µm (ratio {ratio:.2}{test}): \
             the model explains everything but the tracker noise"
        )
    } else {
        let mut worst: Vec<&HeldOutPose> = held.iter().collect();
        worst.sort_by(|a, b| b.after_rms_um.total_cmp(&a.after_rms_um));
        let at: Vec<String> = worst
            .iter()
            .take(3)
            .map(|p| format!("{} ({:.1} µm)", p.a_deg, p.after_rms_um))
            .collect();
        format!(
            "held-out RMS {h:.2} µm against a tracker floor of {floor:.2} µm (ratio {ratio:.2}{test}): \
             a gap of {gap:.2} µm remains, largest at A = {} °: an A-dependent effect the \
             model does not carry, or tracker noise that is not isotropic",
            at.join(", ")
        )
    };
    Some(FloorReport {
        noise_um: noise,
        floor_rms_um: floor,
        held_out_rms_um: h,
        ratio,
        gap_um: gap,
        at_floor,
        lack_of_fit: lof,
        statement,
    })
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

    let to_obs = |map: &dyn Fn(&Vector3<f64>) -> Vector3<f64>| observations(&poses, map);

    // Registration of the instrument frame (module docs, step 3).
    let (r0, o) = data_frame(&pa);
    let q_ball = start(
        &to_obs(&|p| r0.inverse() * (p - o)),
        [0.0; 3],
        &ModelSpec::RIGID,
    );
    let reg = register::register(&poses, &r0, &o, [q_ball[8], q_ball[9], q_ball[10]])?;
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

    // Forward selection of the A-dependent terms (module docs, step 4).
    let n_poses = poses.len();
    let lopo_rigid = n_poses >= 4;
    let lopo = n_poses >= 5;
    let q0 = start(&obs, pivot, &ModelSpec::RIGID);
    let start_model = model::model_from_params(pivot, &ModelSpec::RIGID, &q0);
    let rigid = try_model(
        &obs,
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
                    fit_kinematics(&obs, pivot, spec, &params_from_model(&best.fit.model, spec))
                        .ok()
                        .filter(|f| separability::separable(&obs, &f.model, &f.spec))
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
                let Ok(c) = with_held_out(fit, &obs, pivot, n_poses, true) else {
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
                Some(i) if step[i].rms < (1.0 - opts.compliance_margin) * best.rms => {
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
        &best,
        siblings,
        richer,
        parent_rms,
        &obs,
        pivot,
        n_poses,
        opts.compliance_margin,
    );
    if compliant.is_none() && n_poses >= 4 {
        // The classic compliant model, for comparison (validated with 5 poses or more).
        compliant = try_model(
            &obs,
            pivot,
            &ModelSpec::COMPLIANT,
            &best.fit.model,
            n_poses,
            lopo,
        )
        .ok()
        .map(|c| summary(&c.fit, c.held.as_deref()));
    }
    let fit = &best.fit;
    let held = best.held.as_deref();
    let use_compliant = !fit.spec.is_rigid();
    let std = |k: usize| fit.cov[(k, k)].sqrt();
    let std_of = |name: &str| fit.spec.index(name).map_or(0.0, std);
    let compliance = use_compliant.then(|| {
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
    let floor = floor_report(&pa.poses, &held_poses, fit, obs.len());
    let compensation = CompensationReport {
        method: "leave-one-pose-out: each A pose predicted by the model fitted on the others; before = distance from the nominal kinematics in the registered frame, after = distance from the model (first-order residual after compensation)".into(),
        before_rms_um: rms(|h| h.before_rms_um),
        after_rms_um: rms(|h| h.after_rms_um),
        poses: held_poses,
    };
    let mut notes = vec![
        "Cradle: A about X carries C about Z; tool fixed; linear axes taken as exact.".to_string(),
        "Rotation vectors: matR = [e1 e2 e3]·[et1 et2 et3]^-1 in the instrument frame, log(matR) = axis × angle, µrad; e1 from the point at C = 0 (patent) and from the phase of all points (phase).".to_string(),
        "Model of the kinematics: location errors, ball, and the A-dependent terms kept by forward selection on held-out A poses: a tilt ρ(A) = s·sin A + k·(cos A − 1) about the pivot, tilts of the C table about its mount about X and about its Y (each a·sin A + b·(cos A − 1)), an A positioning error, a shift along A or sideways.".to_string(),
    ];
    if machine_frame {
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
    if let Some(f) = &floor {
        notes.push(f.statement.clone());
    }
    notes.extend(rivals.iter().map(|r| r.statement.clone()));
    Ok(CradleResult {
        kind: "cradle".into(),
        convention: CONVENTION.into(),
        machine_id: points.machine_id.clone(),
        measured_at: points.measured_at.clone(),
        n_points: points.points.len(),
        n_poses,
        registered_frame: machine_frame,
        pivot_mm: pivot,
        reference_a_deg: pa.reference_a_deg,
        a_axis: pa.a_axis.clone(),
        poses: pa.poses.clone(),
        rotation_model,
        location_errors: location_reports(fit, machine_frame),
        registration,
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
            separability: Some(separability::separability(&obs, &fit.model, &fit.spec)),
            curves: compliance_curves(fit, &pa.poses),
            ball: BallReport {
                radius_mm: fit.q[8],
                radius_std_um: std(8) * 1e3,
                azimuth_deg: machine_frame.then(|| fit.q[9].to_degrees()),
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The lack-of-fit test's false-alarm rate against the truth: the simulated cradle
    /// whose C table tilts about its mount ([`Deflection::Mount`], 2 µm isotropic noise),
    /// fitted with the model that made it (both tilts about the mount, no selection), over
    /// 400 noise draws. For a right model p is uniform on (0, 1): the Kolmogorov–Smirnov
    /// distance of the 400 p-values from it stays below 1.95/√400 (exceeded by chance
    /// with probability 0.1 %), and the rejections at 5 % stay within 6–35 (20 expected,
    /// binomial standard deviation 4.4). Degrees of freedom miscounted by the model's
    /// parameters (ν = 3N − ν_c, 16 too many) move the distance to 0.20 and fail.
    #[test]
    fn lack_of_fit_rejects_a_right_model_at_its_stated_rate() {
        let spec = ModelSpec {
            mount_x: true,
            mount_y: true,
            ..ModelSpec::RIGID
        };
        let n = 400;
        let mut p: Vec<f64> = (1..=n)
            .map(|seed| {
                let sim = CradleSimulation::example_with(Deflection::Mount, seed);
                let points = simulate_cradle(&sim);
                let poses = group_poses(&points, 4).unwrap();
                let pa = patent_frames(&poses).unwrap();
                let obs = observations(&poses, &|p| *p);
                let q0 = params_from_model(&sim.truth, &spec);
                let fit = fit_kinematics(&obs, [0.0; 3], &spec, &q0).unwrap();
                assert!(fit.converged);
                let ssr_um2 = (fit.rms * 1e3).powi(2) * obs.len() as f64;
                lack_of_fit(&pa.poses, ssr_um2, 3 * obs.len(), fit.q.len())
                    .unwrap()
                    .p_value
            })
            .collect();
        p.sort_by(f64::total_cmp);
        let ks = p
            .iter()
            .enumerate()
            .map(|(i, v)| (v - i as f64 / n as f64).max((i + 1) as f64 / n as f64 - v))
            .fold(0.0, f64::max);
        let at_5 = p.iter().filter(|v| **v < 0.05).count();
        eprintln!("KS distance {ks:.3}; rejections at 5 %: {at_5} of {n}");
        assert!(ks < 1.95 / (n as f64).sqrt(), "KS distance {ks}");
        assert!((6..=35).contains(&at_5), "{at_5} of {n} rejected at 5 %");
    }
}
