//! Sensitivity analysis of the volumetric error: which geometric errors matter most
//! (Cheng et al. 2012, J. Mech. Eng. 48(7), "An identification approach for key geometric
//! error sources of machine tool based on sensitivity analysis"), and beyond it a global,
//! variance-based analysis. Method and formats: docs/sensitivity.md.
//!
//! * [`chain`]: multi-body chain of linear and rotary axes with every error as a
//!   parameter; volumetric error by the exact HTM chain; analytic Jacobian.
//! * [`templates`]: `vmc3`, `hmc4-b` (the paper's 35-error machine), `cradle5-ac`.
//! * [`magnitudes`]: tolerances, values, functions, or an identification result.
//! * [`local`]: |∂E_c/∂g_i| at a point, along a path, over a grid; normalised
//!   coefficients; key error sets.
//! * [`global`]: Sobol first-order and total indices over the workspace.
//!
//! [`analyse`] runs it all from a [`SensitivityRequest`] (the `sensitivity` job kind).

pub mod chain;
pub mod global;
pub mod local;
pub mod magnitudes;
pub mod templates;

pub use chain::{AxisSpec, Chain, ErrorClass, ErrorParam, ErrorSpec, MachineDescription};
pub use global::{ErrorDistribution, GlobalOptions, GlobalResult, SobolEntry, SobolOutput};
pub use local::{ComponentRanking, GridAxis, Poses, RankEntry, Weighting};
pub use magnitudes::{Magnitude, MagnitudeSource, Magnitudes};

use crate::error::SolverError;
use crate::identification::{CONVENTION, IdentificationResult};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// The machine to analyse: a template by name, or a full description.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(rename_all = "snake_case")]
pub enum MachineRef {
    Template(String),
    Description(MachineDescription),
}

impl MachineRef {
    /// The description (a template resolved by name).
    pub fn resolve(&self) -> Result<MachineDescription, SolverError> {
        match self {
            MachineRef::Template(name) => templates::template(name).ok_or_else(|| {
                SolverError::InvalidInput(format!(
                    "unknown machine template `{name}` (known: {})",
                    templates::TEMPLATES.join(", ")
                ))
            }),
            MachineRef::Description(d) => Ok(d.clone()),
        }
    }
}

fn default_share() -> f64 {
    0.9
}

/// Input of a sensitivity analysis (the `sensitivity` job kind).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(deny_unknown_fields)]
pub struct SensitivityRequest {
    #[serde(default)]
    pub machine_id: String,
    pub machine: MachineRef,
    /// Evaluation points (poses in the machine's axis order X, Y, Z, A, B, C, those
    /// present; mm and degrees): one point, or a tool path.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub points: Vec<Vec<f64>>,
    /// Evaluation grid, one axis per machine axis. Without points or grid: a grid of 5
    /// positions per axis over the travel.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grid: Option<Vec<GridAxis>>,
    /// Replaces the machine's tool offset, mm.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tool_offset_mm: Option<[f64; 3]>,
    /// Share of each component the key error set must cover (default 0.9).
    #[serde(default = "default_share")]
    pub share: f64,
    #[serde(default)]
    pub weighting: Weighting,
    /// Error magnitudes from an identification of the same machine (its motion terms and
    /// squareness replace the description's magnitudes of the same names).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub identification: Option<Box<IdentificationResult>>,
    /// Evaluate the Jacobian at the machine's own error state (the given values and
    /// functions, e.g. an identification; tolerances count as 0) instead of at zero error.
    #[serde(default)]
    pub at_error_state: bool,
    /// Run the global analysis with these options.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub global: Option<GlobalOptions>,
}

impl SensitivityRequest {
    /// A request for a template with the default evaluation grid.
    pub fn template(name: &str) -> SensitivityRequest {
        SensitivityRequest {
            machine_id: String::new(),
            machine: MachineRef::Template(name.into()),
            points: Vec::new(),
            grid: None,
            tool_offset_mm: None,
            share: default_share(),
            weighting: Weighting::default(),
            identification: None,
            at_error_state: false,
            global: None,
        }
    }
}

/// One error of the model, as reported.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ErrorInfo {
    pub name: String,
    pub class: ErrorClass,
    pub unit: String,
    /// The axis the error depends on (motion errors).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axis: Option<char>,
    pub magnitude_source: MagnitudeSource,
}

/// Machine summary in a result.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct MachineSummary {
    pub name: String,
    pub description: String,
    /// Workpiece-side axes, bed outward.
    pub workpiece: Vec<char>,
    /// Tool-side axes, bed outward.
    pub tool: Vec<char>,
    /// Pose order of the axes.
    pub axes: Vec<char>,
    pub tool_offset_mm: [f64; 3],
}

/// Where the local sensitivities were evaluated.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Evaluation {
    /// `point`, `path` or `grid`.
    pub kind: String,
    pub poses: usize,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub points: Vec<Vec<f64>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grid: Option<Vec<GridAxis>>,
}

/// The sensitivity result document.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct SensitivityResult {
    /// Always `sensitivity`.
    pub kind: String,
    pub machine_id: String,
    pub convention: String,
    pub machine: MachineSummary,
    pub errors: Vec<ErrorInfo>,
    pub evaluation: Evaluation,
    pub weighting: Weighting,
    pub share: f64,
    /// Rankings of `Ex`, `Ey`, `Ez` and `E` (the volumetric error, column norms).
    pub components: BTreeMap<String, ComponentRanking>,
    /// Whether the Jacobian was taken at zero error (`false`) or at the error state.
    pub at_error_state: bool,
    /// The volumetric error of the given values/functions (tolerances as 0) over the
    /// poses, by the exact chain: `Ex`, `Ey`, `Ez`, `E` (|E|); absent when every error is
    /// a tolerance.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub volumetric_error_um: Option<BTreeMap<String, local::ErrorSummary>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub global: Option<GlobalResult>,
    /// Sentences stating how the numbers were obtained.
    pub notes: Vec<String>,
}

/// Runs the analysis a request describes.
pub fn analyse(req: &SensitivityRequest) -> Result<SensitivityResult, SolverError> {
    let mut desc = req.machine.resolve()?;
    if let Some(t) = req.tool_offset_mm {
        desc.tool_offset_mm = t;
    }
    if !(req.share > 0.0 && req.share <= 1.0) {
        return Err(SolverError::InvalidInput(format!(
            "share must be in (0, 1], got {}",
            req.share
        )));
    }
    let chain = Chain::new(&desc)?;
    let n_axes = chain.axis_names().len();
    // With an identification, the identified functions exist only over the travel it
    // measured: the default grid stays inside it, and a given pose outside is refused
    // (nothing is extrapolated).
    let measured = measured_limits(&chain, req.identification.as_deref());
    let travel = evaluation_travel(&chain, &measured)?;
    let poses = poses_of(req, &travel)?;
    poses.validate(n_axes)?;
    check_inside_measured(&poses, &measured, chain.axis_names())?;
    const MAX_POSES: usize = 10_000_000;
    if poses.len() > MAX_POSES {
        return Err(SolverError::Limit(format!(
            "{} poses; at most {MAX_POSES}",
            poses.len()
        )));
    }
    let mags = Magnitudes::new(&chain, &desc, req.identification.as_deref());
    let stats = local::local_stats(&chain, &mags, &poses, req.at_error_state);
    let volumetric_error_um = local::volumetric_error(&chain, &mags, &poses);
    let components = local::COMPONENTS
        .iter()
        .enumerate()
        .map(|(c, name)| {
            (
                (*name).to_string(),
                local::rank(&chain, &stats, c, req.weighting, req.share),
            )
        })
        .collect();
    let global = global_analysis(req, &chain, &mags, &poses)?;
    let notes = notes_of(req, measured.iter().any(Option::is_some), global.is_some());
    let errors = chain
        .params()
        .iter()
        .zip(&mags.sources)
        .map(|(p, s)| ErrorInfo {
            name: p.name.clone(),
            class: p.class,
            unit: p.unit().into(),
            axis: p.axis.map(|k| chain.axis_names()[k]),
            magnitude_source: *s,
        })
        .collect();
    let (points, grid) = match &poses {
        Poses::Points(p) => (p.clone(), None),
        Poses::Grid(g) => (Vec::new(), Some(g.clone())),
    };
    Ok(SensitivityResult {
        kind: "sensitivity".into(),
        machine_id: req.machine_id.clone(),
        convention: CONVENTION.into(),
        machine: MachineSummary {
            name: desc.name.clone(),
            description: desc.description.clone(),
            workpiece: desc.workpiece.iter().map(|a| a.axis).collect(),
            tool: desc.tool.iter().map(|a| a.axis).collect(),
            axes: chain.axis_names().to_vec(),
            tool_offset_mm: desc.tool_offset_mm,
        },
        errors,
        evaluation: Evaluation {
            kind: poses.kind().into(),
            poses: poses.len(),
            points,
            grid,
        },
        weighting: req.weighting,
        share: req.share,
        components,
        at_error_state: req.at_error_state,
        volumetric_error_um,
        global,
        notes,
    })
}

/// The travel the poses are taken in: the machine's, inside what an identification
/// measured (`measured`, per axis); refused when the two do not overlap.
fn evaluation_travel(
    chain: &Chain,
    measured: &[Option<[f64; 2]>],
) -> Result<Vec<[f64; 2]>, SolverError> {
    let travel: Vec<[f64; 2]> = chain
        .travel()
        .iter()
        .zip(measured)
        .map(|(&[lo, hi], m)| match m {
            Some([a, b]) => [lo.max(*a), hi.min(*b)],
            None => [lo, hi],
        })
        .collect();
    if let Some(k) = travel.iter().position(|[lo, hi]| hi < lo) {
        return Err(SolverError::InvalidInput(format!(
            "axis {}: the machine's travel {:?} mm and the travel the identification measured \
             {:?} mm do not overlap",
            chain.axis_names()[k],
            chain.travel()[k],
            measured[k].unwrap_or_default()
        )));
    }
    Ok(travel)
}

/// The poses of the request: its points or grid, else a 5-point grid over `travel`.
fn poses_of(req: &SensitivityRequest, travel: &[[f64; 2]]) -> Result<Poses, SolverError> {
    Ok(match (&req.grid, req.points.is_empty()) {
        (Some(_), false) => {
            return Err(SolverError::InvalidInput(
                "give either points or a grid, not both".into(),
            ));
        }
        (Some(g), true) => Poses::Grid(g.clone()),
        (None, false) => Poses::Points(req.points.clone()),
        (None, true) => Poses::Grid(
            travel
                .iter()
                .map(|t| GridAxis {
                    min: t[0],
                    max: t[1],
                    n: 5,
                })
                .collect(),
        ),
    })
}

/// The global (Sobol) analysis when the request asks for one, within its work limits.
fn global_analysis(
    req: &SensitivityRequest,
    chain: &Chain,
    mags: &Magnitudes,
    poses: &Poses,
) -> Result<Option<GlobalResult>, SolverError> {
    Ok(match &req.global {
        Some(opts) => {
            if opts.samples > 1_000_000 || opts.max_poses == 0 || opts.max_poses > 100_000 {
                return Err(SolverError::Limit(
                    "global analysis: samples <= 1000000 and 1 <= max_poses <= 100000".into(),
                ));
            }
            let sub = poses.subsample(opts.max_poses);
            // Work ~ samples × poses × errors; 5e8 is a few seconds on one core.
            let work = opts.samples as f64 * sub.len() as f64 * chain.params().len() as f64;
            if work > 5e8 {
                return Err(SolverError::Limit(format!(
                    "global analysis: samples × poses × errors = {work:.1e} > 5e8; lower \
                     samples or max_poses"
                )));
            }
            Some(global::sobol(chain, mags, &sub, opts)?)
        }
        None => None,
    })
}

/// The sentences stating how the numbers were obtained.
fn notes_of(req: &SensitivityRequest, within_measured: bool, global: bool) -> Vec<String> {
    let mut notes = vec![
        format!(
            "sensitivities are the analytic Jacobian of the exact HTM chain at {}; paper \
             scale: mm/mm for translational errors, mm/rad (the Abbe arm) for angular ones",
            if req.at_error_state {
                "the machine's error state (given values and functions; tolerances as 0)"
            } else {
                "zero error"
            }
        ),
        "sensitivity of E is the length of the Jacobian column, ||dE/dg||".to_string(),
        format!(
            "normalised coefficients from the {} sensitivities' means over the poses",
            match req.weighting {
                Weighting::Weighted => "magnitude-weighted (um)",
                Weighting::Paper => "paper-scale",
            }
        ),
    ];
    if within_measured {
        notes.push(
            "poses lie inside the travel the identification measured (the identified \
             functions are not evaluated beyond it)"
                .into(),
        );
    }
    if req.identification.is_some() {
        notes.push(
            "magnitudes of identified terms are the identified functions as reported \
             (straightness without its least-squares line, squareness between the \
             least-squares axis lines); the volumetric error they give differs from the \
             model's by a rigid rotation of the frame, which does not change the ranking's \
             meaning"
                .into(),
        );
    }
    if global {
        notes.push(
            "global indices: first-order model E = J(q)·g, errors independent, pooled over \
             the poses; estimators Saltelli 2010 (first order) and Jansen 1999 (total)"
                .into(),
        );
    }
    notes
}

/// Travel the identification measured on each chain axis that it has motion terms for
/// (its `model.measured_travel_mm`; for a document without it, the range of the
/// identifiable terms' reported positions).
fn measured_limits(chain: &Chain, ident: Option<&IdentificationResult>) -> Vec<Option<[f64; 2]>> {
    chain
        .axis_names()
        .iter()
        .map(|&a| {
            let id = ident?;
            if let Some(t) = id.model.measured_travel_mm.get(&a.to_string()) {
                return Some(*t);
            }
            let positions = id
                .terms
                .iter()
                .filter(|(n, t)| n.ends_with(a) && t.identifiable)
                .flat_map(|(_, t)| t.positions_mm.iter().copied());
            let (lo, hi) = positions.fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), q| {
                (l.min(q), h.max(q))
            });
            (hi > lo).then_some([lo, hi])
        })
        .collect()
}

/// Refuses poses outside the measured travel of an axis (`measured[k]`).
fn check_inside_measured(
    poses: &Poses,
    measured: &[Option<[f64; 2]>],
    names: &[char],
) -> Result<(), SolverError> {
    let outside = |k: usize, q: f64| -> Result<(), SolverError> {
        match measured.get(k).copied().flatten() {
            Some([lo, hi]) if q < lo - 1e-9 || q > hi + 1e-9 => {
                Err(SolverError::InvalidInput(format!(
                    "axis {} at {q} mm: outside the travel the identification measured \
                     [{lo}, {hi}] mm (its functions are not evaluated beyond it)",
                    names[k]
                )))
            }
            _ => Ok(()),
        }
    };
    match poses {
        Poses::Points(p) => {
            for q in p {
                for (k, &v) in q.iter().enumerate() {
                    outside(k, v)?;
                }
            }
        }
        Poses::Grid(g) => {
            for (k, a) in g.iter().enumerate() {
                outside(k, a.min)?;
                outside(k, a.max)?;
            }
        }
    }
    Ok(())
}
