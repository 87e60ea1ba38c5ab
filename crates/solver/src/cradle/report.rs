//! What the cradle check reports: its result and the reports of its steps.

use crate::cradle::frames::AAxisFit;
use crate::cradle::*;
use serde::{Deserialize, Serialize};

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
