//! Multi-body chain of linear and rotary axes with every geometric error as a parameter,
//! evaluated through the exact HTM chain, and its analytic Jacobian.
//!
//! # Model (kinematics contract, "Error motions: exact model", generalised)
//!
//! The tool point in the workpiece frame is p = T_w⁻¹ · T_t · t with
//!
//! * tool side, bed outward: T_t = Π_k [M_k(q_k) · E_k(q_k)] · S_T,
//! * workpiece side, bed outward: T_w = Π_k [M_k(−q_k) · E_k(q_k)⁻¹] · S_W⁻¹,
//!
//! so that T_w⁻¹ = S_W · Π_{k outermost first} [E_k · M_k(+q_k)]. Every error is in the
//! tool-relative-to-workpiece sense.
//!
//! * Motion errors of axis K (ISO 230-1 / ISO 230-7 names E + direction + K):
//!   E_K = Trans(E_XK, E_YK, E_ZK) · Rx(E_AK) · Ry(E_BK) · Rz(E_CK).
//! * Linear axis K along ê: M_K(q) = L · Trans(q ê) · L⁻¹ with L the product, in the order
//!   C, B, A, of its location tilts (Rz(E_C0K) · Ry(E_B0K) · Rx(E_A0K)): the nominal
//!   direction u_K = L ê. For Y that is u_Y = Rz(EC0Y)·ŷ and for Z u_Z = Ry(EB0Z)·Rx(EA0Z)·ẑ,
//!   exactly the contract's squareness.
//! * Rotary axis K about ê through centre c (ISO 230-7 location errors):
//!   M_K(θ) = Trans(c) · Trans(E_X0K, E_Y0K, E_Z0K) · Rz·Ry·Rx(tilts) · Rot_ê(θ + E_K0K) ·
//!   (tilts)⁻¹ · Trans(offsets)⁻¹ · Trans(−c): the axis line is moved by the offsets and
//!   tilted by the tilts (the conjugation keeps the motion a rotation about the actual
//!   line), E_K0K is the zero-position error.
//! * Setup errors: S_T = Trans(E_X0T, E_Y0T, E_Z0T) · Rx(E_A0T) · Ry(E_B0T) · Rz(E_C0T)
//!   (tool in the spindle), S_W likewise with suffix 0W (workpiece on the table).
//!
//! Units: positions in mm, rotary positions in degrees, translational errors in µm,
//! angular errors in µrad.
//!
//! # Analytic Jacobian
//!
//! Every factor of the flat chain p = F_1 ⋯ F_N · t is elementary: a rotation about a frame
//! axis or a translation along one, exp(a·ξ) with ξ a unit twist (ω, v) and a the amount.
//! If error g enters factor j as a = c·g (c = ±1 times the unit scale), then exactly
//!
//! ∂p/∂g = c · R_j · (ω × s_j + v),
//!
//! with R_j the rotation of F_1 ⋯ F_j and s_j = F_{j+1} ⋯ F_N · t the outboard point (an
//! error that appears several times, as a location error does, sums its occurrences). This
//! is exact at any error state, not only at zero; the tests check it against central
//! finite differences.

use crate::error::SolverError;
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// One axis of a machine description.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(deny_unknown_fields)]
pub struct AxisSpec {
    /// X, Y, Z (linear, along that direction) or A, B, C (rotary, about X, Y, Z).
    pub axis: char,
    /// Travel [min, max] in mm (linear) or degrees (rotary), used for default grids.
    pub travel: [f64; 2],
    /// Rotary axes: a point of the nominal axis line, mm (default the origin).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub centre_mm: Option<[f64; 3]>,
}

impl AxisSpec {
    pub fn is_rotary(&self) -> bool {
        matches!(self.axis, 'A' | 'B' | 'C')
    }

    /// The frame direction index 0, 1, 2 of the motion (X/A → 0, Y/B → 1, Z/C → 2).
    pub fn direction(&self) -> usize {
        dir_index(self.axis).expect("validated axis letter")
    }
}

/// The magnitude of one error: a tolerance (±, constant over the travel), a signed constant
/// value, polynomial coefficients in the axis position (element i ↔ q^(i+1)), or a table of
/// values on positions (linear interpolation, end values held outside).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(deny_unknown_fields)]
pub struct ErrorSpec {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tolerance: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub value: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub coefficients: Option<Vec<f64>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub positions: Option<Vec<f64>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub values: Option<Vec<f64>>,
}

impl ErrorSpec {
    pub fn tolerance(t: f64) -> ErrorSpec {
        ErrorSpec {
            tolerance: Some(t),
            ..Default::default()
        }
    }
}

/// A machine: its axes on the workpiece and tool sides (bed outward), its tool offset, and
/// the errors taken into account with their magnitudes (docs/sensitivity.md, "Machine
/// description").
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(deny_unknown_fields)]
pub struct MachineDescription {
    pub name: String,
    #[serde(default)]
    pub description: String,
    /// Workpiece-side axes, from the bed outward.
    pub workpiece: Vec<AxisSpec>,
    /// Tool-side axes, from the bed outward.
    pub tool: Vec<AxisSpec>,
    /// Vector from the tool reference point to the functional point, mm.
    pub tool_offset_mm: [f64; 3],
    /// The errors of the model, by ISO name, with their magnitudes. Their order in the
    /// results is the canonical order of [`MachineDescription::error_names`].
    pub errors: BTreeMap<String, ErrorSpec>,
}

/// What kind of geometric error a parameter is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(rename_all = "snake_case")]
pub enum ErrorClass {
    /// One of the six motion errors of an axis (a function of its position).
    Motion,
    /// Squareness / orientation of a linear axis (constant).
    Squareness,
    /// Offset, tilt or zero-position error of a rotary axis (ISO 230-7, constant).
    Location,
    /// Setup of the tool (suffix 0T) or of the workpiece (suffix 0W).
    Setup,
}

/// One error parameter of a compiled chain.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ErrorParam {
    pub name: String,
    pub class: ErrorClass,
    /// Index (in [`Chain::axis_names`]) of the axis whose position the error depends on,
    /// for motion errors.
    pub axis: Option<usize>,
    pub angular: bool,
}

impl ErrorParam {
    /// `um` or `urad`.
    pub fn unit(&self) -> &'static str {
        if self.angular { "urad" } else { "um" }
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Elem {
    Rot(usize),
    Trans(usize),
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Amount {
    /// The position of axis `index` times `scale` (1 mm, or π/180 for degrees).
    Axis {
        index: usize,
        scale: f64,
    },
    /// Error parameter `index` times `coef` (±10⁻³ for µm → mm, ±10⁻⁶ for µrad → rad).
    Param {
        index: usize,
        coef: f64,
    },
    Const(f64),
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Factor {
    elem: Elem,
    amount: Amount,
}

/// A compiled machine: the flat chain of elementary factors p = F_1 ⋯ F_N · t.
#[derive(Debug, Clone)]
pub struct Chain {
    factors: Vec<Factor>,
    /// Zero-error fast path: the factors that move anything at zero error (axes and
    /// constants), and every error occurrence as (boundary b = number of active factors
    /// before it, factor, parameter, coefficient in µm per unit).
    active: Vec<Factor>,
    occurrences: Vec<(usize, Elem, usize, f64)>,
    params: Vec<ErrorParam>,
    axis_names: Vec<char>,
    travel: Vec<[f64; 2]>,
    tool_offset: Vector3<f64>,
}

fn dir_index(c: char) -> Option<usize> {
    match c {
        'X' | 'A' => Some(0),
        'Y' | 'B' => Some(1),
        'Z' | 'C' => Some(2),
        _ => None,
    }
}

const TRANS: [char; 3] = ['X', 'Y', 'Z'];
const ROTS: [char; 3] = ['A', 'B', 'C'];

/// Canonical axis order of positions in poses: X, Y, Z, A, B, C (those present).
const AXIS_ORDER: [char; 6] = ['X', 'Y', 'Z', 'A', 'B', 'C'];

/// Every error name a machine with these axes can carry, in canonical order: per axis
/// (X, Y, Z, A, B, C) its six motion errors, then its location errors, then the setup
/// errors of the tool (0T) and the workpiece (0W).
pub fn possible_errors(axes: &[&AxisSpec]) -> Vec<(String, ErrorClass, Option<char>, bool)> {
    let mut out = Vec::new();
    let mut sorted: Vec<&AxisSpec> = axes.to_vec();
    sorted.sort_by_key(|a| AXIS_ORDER.iter().position(|&c| c == a.axis));
    for a in &sorted {
        let k = a.axis;
        for d in TRANS {
            out.push((format!("E{d}{k}"), ErrorClass::Motion, Some(k), false));
        }
        for d in ROTS {
            out.push((format!("E{d}{k}"), ErrorClass::Motion, Some(k), true));
        }
    }
    for a in &sorted {
        let k = a.axis;
        let own = a.direction();
        if a.is_rotary() {
            for (i, d) in TRANS.iter().enumerate() {
                if i != own {
                    out.push((format!("E{d}0{k}"), ErrorClass::Location, None, false));
                }
            }
            for (i, d) in ROTS.iter().enumerate() {
                if i != own {
                    out.push((format!("E{d}0{k}"), ErrorClass::Location, None, true));
                }
            }
            out.push((format!("E{k}0{k}"), ErrorClass::Location, None, true));
        } else {
            for (i, d) in ROTS.iter().enumerate() {
                if i != own {
                    out.push((format!("E{d}0{k}"), ErrorClass::Squareness, None, true));
                }
            }
        }
    }
    for s in ['T', 'W'] {
        for d in TRANS {
            out.push((format!("E{d}0{s}"), ErrorClass::Setup, None, false));
        }
        for d in ROTS {
            out.push((format!("E{d}0{s}"), ErrorClass::Setup, None, true));
        }
    }
    out
}

impl MachineDescription {
    /// Checks the description: known axis letters, each at most once, travels, error
    /// names valid for these axes, magnitudes well formed.
    pub fn validate(&self) -> Result<(), SolverError> {
        let bad = |m: String| {
            Err(SolverError::InvalidInput(format!(
                "machine {}: {m}",
                self.name
            )))
        };
        let axes: Vec<&AxisSpec> = self.workpiece.iter().chain(self.tool.iter()).collect();
        if axes.is_empty() {
            return bad("no axes".into());
        }
        let mut seen = Vec::new();
        for a in &axes {
            if dir_index(a.axis).is_none() {
                return bad(format!("axis `{}` is not one of X, Y, Z, A, B, C", a.axis));
            }
            if seen.contains(&a.axis) {
                return bad(format!("axis {} appears twice", a.axis));
            }
            seen.push(a.axis);
            if !(a.travel[0].is_finite() && a.travel[1].is_finite() && a.travel[0] <= a.travel[1]) {
                return bad(format!(
                    "axis {}: travel must be [min, max] with min <= max",
                    a.axis
                ));
            }
            if a.centre_mm.is_some() && !a.is_rotary() {
                return bad(format!(
                    "axis {}: centre_mm is for rotary axes only",
                    a.axis
                ));
            }
        }
        if !self.tool_offset_mm.iter().all(|v| v.is_finite()) {
            return bad("tool_offset_mm must be finite".into());
        }
        let possible = possible_errors(&axes);
        for (name, spec) in &self.errors {
            let Some((_, class, _, _)) = possible.iter().find(|p| &p.0 == name) else {
                return bad(format!(
                    "error `{name}` is not an error of a machine with axes {}",
                    seen.iter().collect::<String>()
                ));
            };
            check_spec(name, spec, *class == ErrorClass::Motion).map_err(|m| {
                SolverError::InvalidInput(format!("machine {}: error {name}: {m}", self.name))
            })?;
        }
        if self.errors.is_empty() {
            return bad("no errors listed".into());
        }
        Ok(())
    }

    /// Names of the description's errors in canonical order.
    pub fn error_names(&self) -> Vec<String> {
        let axes: Vec<&AxisSpec> = self.workpiece.iter().chain(self.tool.iter()).collect();
        possible_errors(&axes)
            .into_iter()
            .map(|p| p.0)
            .filter(|n| self.errors.contains_key(n))
            .collect()
    }
}

fn check_spec(name: &str, s: &ErrorSpec, motion: bool) -> Result<(), String> {
    let given = [
        s.tolerance.is_some(),
        s.value.is_some(),
        s.coefficients.is_some(),
        s.positions.is_some() || s.values.is_some(),
    ];
    if given.iter().filter(|&&g| g).count() != 1 {
        return Err(
            "give exactly one of `tolerance`, `value`, `coefficients`, or `positions` with `values`"
                .into(),
        );
    }
    if let Some(t) = s.tolerance
        && !(t.is_finite() && t >= 0.0)
    {
        return Err(format!("tolerance must be finite and >= 0, got {t}"));
    }
    if let Some(v) = s.value
        && !v.is_finite()
    {
        return Err("value must be finite".into());
    }
    if !motion && (s.coefficients.is_some() || s.positions.is_some()) {
        return Err(format!(
            "{name} is a constant: give `tolerance` or `value`, not a function of position"
        ));
    }
    if let Some(c) = &s.coefficients
        && (c.is_empty() || !c.iter().all(|v| v.is_finite()))
    {
        return Err("coefficients must be a non-empty list of finite numbers".into());
    }
    if s.positions.is_some() || s.values.is_some() {
        let (Some(p), Some(v)) = (&s.positions, &s.values) else {
            return Err("`positions` and `values` go together".into());
        };
        if p.len() != v.len() || p.is_empty() {
            return Err("`positions` and `values` must have the same, non-zero length".into());
        }
        if !p.windows(2).all(|w| w[0] < w[1]) {
            return Err("`positions` must be strictly increasing".into());
        }
        if !v.iter().all(|x| x.is_finite()) {
            return Err("`values` must be finite".into());
        }
    }
    Ok(())
}

impl Chain {
    /// Compiles a validated description into the flat chain.
    pub fn new(desc: &MachineDescription) -> Result<Chain, SolverError> {
        desc.validate()?;
        let axes: Vec<&AxisSpec> = desc.workpiece.iter().chain(desc.tool.iter()).collect();
        let axis_names: Vec<char> = AXIS_ORDER
            .iter()
            .copied()
            .filter(|c| axes.iter().any(|a| a.axis == *c))
            .collect();
        let travel = axis_names
            .iter()
            .map(|c| axes.iter().find(|a| a.axis == *c).expect("present").travel)
            .collect();
        let possible = possible_errors(&axes);
        let params: Vec<ErrorParam> = possible
            .into_iter()
            .filter(|p| desc.errors.contains_key(&p.0))
            .map(|(name, class, axis, angular)| ErrorParam {
                name,
                class,
                axis: axis.map(|c| axis_names.iter().position(|&a| a == c).expect("axis")),
                angular,
            })
            .collect();
        let mut chain = Chain {
            factors: Vec::new(),
            active: Vec::new(),
            occurrences: Vec::new(),
            params,
            axis_names,
            travel,
            tool_offset: Vector3::from(desc.tool_offset_mm),
        };
        chain.push_setup('W');
        for a in desc.workpiece.iter().rev() {
            chain.push_motion_errors(a.axis);
            chain.push_motion(a);
        }
        for a in &desc.tool {
            chain.push_motion(a);
            chain.push_motion_errors(a.axis);
        }
        chain.push_setup('T');
        for f in &chain.factors {
            match f.amount {
                Amount::Param { index, coef } => {
                    chain
                        .occurrences
                        .push((chain.active.len(), f.elem, index, coef * 1e3))
                }
                _ => chain.active.push(*f),
            }
        }
        Ok(chain)
    }

    fn param(&self, name: &str) -> Option<usize> {
        self.params.iter().position(|p| p.name == name)
    }

    /// Pushes factor `elem` driven by the named error (if the model has it) with sign `sign`.
    fn push_param(&mut self, elem: Elem, name: &str, sign: f64) {
        if let Some(index) = self.param(name) {
            let unit = if self.params[index].angular {
                1e-6
            } else {
                1e-3
            };
            self.factors.push(Factor {
                elem,
                amount: Amount::Param {
                    index,
                    coef: sign * unit,
                },
            });
        }
    }

    /// Trans(δ) · Rx · Ry · Rz of errors named `E{d}{infix}{k}`.
    fn push_six(&mut self, infix: &str, k: char) {
        for (i, d) in TRANS.iter().enumerate() {
            self.push_param(Elem::Trans(i), &format!("E{d}{infix}{k}"), 1.0);
        }
        for (i, d) in ROTS.iter().enumerate() {
            self.push_param(Elem::Rot(i), &format!("E{d}{infix}{k}"), 1.0);
        }
    }

    fn push_motion_errors(&mut self, k: char) {
        self.push_six("", k);
    }

    fn push_setup(&mut self, s: char) {
        self.push_six("0", s);
    }

    fn push_const(&mut self, elem: Elem, v: f64) {
        if v != 0.0 {
            self.factors.push(Factor {
                elem,
                amount: Amount::Const(v),
            });
        }
    }

    fn push_motion(&mut self, a: &AxisSpec) {
        let k = a.axis;
        let own = a.direction();
        let index = self.axis_names.iter().position(|&c| c == k).expect("axis");
        // Location tilts in the order C, B, A (Rz · Ry · Rx), excluding the own direction.
        let tilts: Vec<(usize, String)> = [2usize, 1, 0]
            .into_iter()
            .filter(|&i| i != own)
            .map(|i| (i, format!("E{}0{k}", ROTS[i])))
            .collect();
        if a.is_rotary() {
            let c = a.centre_mm.unwrap_or([0.0; 3]);
            let offsets: Vec<(usize, String)> = (0..3)
                .filter(|&i| i != own)
                .map(|i| (i, format!("E{}0{k}", TRANS[i])))
                .collect();
            for (i, v) in c.iter().enumerate() {
                self.push_const(Elem::Trans(i), *v);
            }
            for (i, n) in &offsets {
                self.push_param(Elem::Trans(*i), n, 1.0);
            }
            for (i, n) in &tilts {
                self.push_param(Elem::Rot(*i), n, 1.0);
            }
            self.factors.push(Factor {
                elem: Elem::Rot(own),
                amount: Amount::Axis {
                    index,
                    scale: std::f64::consts::PI / 180.0,
                },
            });
            self.push_param(Elem::Rot(own), &format!("E{k}0{k}"), 1.0);
            for (i, n) in tilts.iter().rev() {
                self.push_param(Elem::Rot(*i), n, -1.0);
            }
            for (i, n) in offsets.iter().rev() {
                self.push_param(Elem::Trans(*i), n, -1.0);
            }
            for (i, v) in c.iter().enumerate().rev() {
                self.push_const(Elem::Trans(i), -*v);
            }
        } else {
            for (i, n) in &tilts {
                self.push_param(Elem::Rot(*i), n, 1.0);
            }
            self.factors.push(Factor {
                elem: Elem::Trans(own),
                amount: Amount::Axis { index, scale: 1.0 },
            });
            for (i, n) in tilts.iter().rev() {
                self.push_param(Elem::Rot(*i), n, -1.0);
            }
        }
    }

    /// The error parameters, in canonical order (the columns of the Jacobian).
    pub fn params(&self) -> &[ErrorParam] {
        &self.params
    }

    /// Axis letters in pose order (X, Y, Z, A, B, C, those present).
    pub fn axis_names(&self) -> &[char] {
        &self.axis_names
    }

    /// Travel of each axis, in pose order.
    pub fn travel(&self) -> &[[f64; 2]] {
        &self.travel
    }

    pub fn tool_offset_mm(&self) -> Vector3<f64> {
        self.tool_offset
    }

    fn check_dims(&self, q: &[f64], values: &[f64]) {
        assert_eq!(q.len(), self.axis_names.len(), "pose length");
        assert_eq!(values.len(), self.params.len(), "error values length");
    }

    #[inline]
    fn amount(&self, f: &Factor, q: &[f64], values: &[f64]) -> f64 {
        match f.amount {
            Amount::Axis { index, scale } => q[index] * scale,
            Amount::Param { index, coef } => values[index] * coef,
            Amount::Const(v) => v,
        }
    }

    /// Actual tool point in the workpiece frame (mm) at axis positions `q` (pose order) and
    /// error values `values` (µm / µrad, parameter order), by the exact chain.
    pub fn tool_point_mm(&self, q: &[f64], values: &[f64]) -> Vector3<f64> {
        self.check_dims(q, values);
        let mut s = self.tool_offset;
        for f in self.factors.iter().rev() {
            let a = self.amount(f, q, values);
            apply(f.elem, a, &mut s);
        }
        s
    }

    /// Volumetric error e = p(values) − p(0), µm, by the exact chain.
    pub fn error_um(&self, q: &[f64], values: &[f64]) -> Vector3<f64> {
        let zero = vec![0.0; self.params.len()];
        (self.tool_point_mm(q, values) - self.tool_point_mm(q, &zero)) * 1e3
    }

    /// Analytic Jacobian ∂e/∂g (µm per µm or per µrad), one column per parameter, at
    /// pose `q` and error state `values`, written into `jac` (resized).
    pub fn jacobian_into(
        &self,
        q: &[f64],
        values: &[f64],
        ws: &mut Workspace,
        jac: &mut Vec<Vector3<f64>>,
    ) {
        self.check_dims(q, values);
        let n = self.factors.len();
        ws.outboard.resize(n, Vector3::zeros());
        ws.amounts.resize(n, 0.0);
        let mut s = self.tool_offset;
        for (j, f) in self.factors.iter().enumerate().rev() {
            ws.outboard[j] = s;
            let a = self.amount(f, q, values);
            ws.amounts[j] = a;
            apply(f.elem, a, &mut s);
        }
        jac.clear();
        jac.resize(self.params.len(), Vector3::zeros());
        let mut r = Matrix3::identity();
        for (j, f) in self.factors.iter().enumerate() {
            let a = ws.amounts[j];
            if let Elem::Rot(d) = f.elem
                && a != 0.0
            {
                post_rotate(&mut r, d, a);
            }
            if let Amount::Param { index, coef } = f.amount {
                let local = match f.elem {
                    Elem::Trans(d) => {
                        let mut v = Vector3::zeros();
                        v[d] = 1.0;
                        v
                    }
                    Elem::Rot(d) => unit_cross(d, &ws.outboard[j]),
                };
                jac[index] += r * local * (coef * 1e3);
            }
        }
    }

    /// The Jacobian at zero error (what the sensitivity measures use), by the screw form
    /// of the same formula: with P_b = (R_b, o_b) the nominal prefix transform at the
    /// error's place and u = R_b e_d, a translation's column is u and a rotation's is
    /// u × (p − o_b), p the nominal tool point. Equal to [`Chain::jacobian_into`] at
    /// `values = 0` (tested), several times faster.
    pub fn jacobian_zero_into(&self, q: &[f64], ws: &mut Workspace, jac: &mut Vec<Vector3<f64>>) {
        assert_eq!(q.len(), self.axis_names.len(), "pose length");
        let n = self.active.len();
        ws.prefix
            .resize(n + 1, (Matrix3::identity(), Vector3::zeros()));
        let mut r = Matrix3::identity();
        let mut o = Vector3::zeros();
        ws.prefix[0] = (r, o);
        for (b, f) in self.active.iter().enumerate() {
            let a = match f.amount {
                Amount::Axis { index, scale } => q[index] * scale,
                Amount::Const(v) => v,
                Amount::Param { .. } => 0.0,
            };
            if a != 0.0 {
                match f.elem {
                    Elem::Trans(d) => o += r.column(d) * a,
                    Elem::Rot(d) => post_rotate(&mut r, d, a),
                }
            }
            ws.prefix[b + 1] = (r, o);
        }
        let p = r * self.tool_offset + o;
        jac.clear();
        jac.resize(self.params.len(), Vector3::zeros());
        for &(b, elem, index, coef) in &self.occurrences {
            let (rb, ob) = &ws.prefix[b];
            let col = match elem {
                Elem::Trans(d) => rb.column(d).into_owned(),
                Elem::Rot(d) => rb.column(d).cross(&(p - ob)),
            };
            jac[index] += col * coef;
        }
    }

    /// Convenience form of [`Chain::jacobian_into`].
    pub fn jacobian(&self, q: &[f64], values: &[f64]) -> Vec<Vector3<f64>> {
        let mut ws = Workspace::default();
        let mut jac = Vec::new();
        self.jacobian_into(q, values, &mut ws, &mut jac);
        jac
    }
}

/// Scratch space of [`Chain::jacobian_into`], reused across poses.
#[derive(Debug, Default, Clone)]
pub struct Workspace {
    prefix: Vec<(Matrix3<f64>, Vector3<f64>)>,
    outboard: Vec<Vector3<f64>>,
    amounts: Vec<f64>,
}

/// e_d × s.
#[inline]
fn unit_cross(d: usize, s: &Vector3<f64>) -> Vector3<f64> {
    match d {
        0 => Vector3::new(0.0, -s.z, s.y),
        1 => Vector3::new(s.z, 0.0, -s.x),
        _ => Vector3::new(-s.y, s.x, 0.0),
    }
}

/// s ← F(a) · s for an elementary factor.
#[inline]
fn apply(elem: Elem, a: f64, s: &mut Vector3<f64>) {
    if a == 0.0 {
        return;
    }
    match elem {
        Elem::Trans(d) => s[d] += a,
        Elem::Rot(d) => {
            let (sn, c) = a.sin_cos();
            let (i, k) = ((d + 1) % 3, (d + 2) % 3);
            let (u, v) = (s[i], s[k]);
            s[i] = c * u - sn * v;
            s[k] = sn * u + c * v;
        }
    }
}

/// r ← r · Rot_d(a).
#[inline]
fn post_rotate(r: &mut Matrix3<f64>, d: usize, a: f64) {
    let (sn, c) = a.sin_cos();
    let (i, k) = ((d + 1) % 3, (d + 2) % 3);
    for row in 0..3 {
        let (u, v) = (r[(row, i)], r[(row, k)]);
        r[(row, i)] = c * u + sn * v;
        r[(row, k)] = -sn * u + c * v;
    }
}
