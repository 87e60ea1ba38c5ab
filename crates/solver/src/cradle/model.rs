//! Forward kinematics of a cradle (A about X carrying C about Z) with ISO 230-7 location
//! errors and an optional A-dependent compliance, and its parameter vector.
//!
//! # Convention (stated, because every number depends on it)
//!
//! Frames: the instrument frame is taken to be the machine frame (registered to the
//! linear axes); `pivot_mm` is the nominal point where the nominal A axis (along X) and
//! the nominal C axis (along Z at A = 0) intersect. The tool is fixed; the ball sits on
//! the C table at b = (R cos φ, R sin φ, h) in the table frame (h measured along the C
//! axis from the pivot). The measured ball centre at commanded (A, C) is
//!
//! p(A, C) = P + Rot(ρ(A))·(T_A(A)·T_C(C)·b − P),  P = pivot,
//!
//! * T_A(A) = Trans(P + (0, EY0A, EZ0A)) · Rz(EC0A) · Ry(EB0A) · Rx(A + EA0A):
//!   the A axis direction is u_A = Rz(EC0A)·Ry(EB0A)·x̂ ≈ (1, EC0A, −EB0A) and passes
//!   through P + (0, EY0A, EZ0A);
//! * T_C(C) = Trans(EX0C, EY0C, 0) · Rx(EA0C) · Ry(EB0C) · Rz(C + EC0C): the C axis, in the
//!   A body frame, has direction ≈ (EB0C, −EA0C, 1) and passes through (EX0C, EY0C, 0);
//! * ρ(A) = s·sin A + k·(cos A − 1): a spatial rotation vector of the table about the
//!   pivot that vanishes at A = 0 (a rigid cradle has s = k = 0; constant deflections are
//!   location errors): the classic compliance of a tilting cradle, whose whole A body
//!   tilts in the machine frame as the load turns with A (its x component is the A
//!   positioning error s_A·sin A + k_A·(cos A − 1)).
//! * The **C table tilts about its mount**: in the A body frame (x along A, z along C),
//!   a small rotation ω(A) = (τ_X(A), τ_Y(A), 0) about the point M = (0, 0, z_M) on the C
//!   axis, τ_X(A) = tX_s·sin A + tX_c·(cos A − 1) about the axis through M parallel to A,
//!   τ_Y(A) = tY_s·sin A + tY_c·(cos A − 1) about the table's Y through M (perpendicular
//!   to A and C). About M rather than about the A axis, τ_X also moves the table
//!   sideways by z_M·τ_X (along the table's Y) and τ_Y moves it along A by −z_M·τ_Y.
//! * Pure shifts of the table with A: along the A axis, t_X(A) = e_s·sin A +
//!   e_c·(cos A − 1) (the trunnions' axial compliance), and sideways in the A body frame
//!   (along the table's Y), t_Y(A) = y_s·sin A + y_c·(cos A − 1).
//!
//!   The full expression is
//!   p(A, C) = t_X(A)·x̂ + P + Rot(ρ(A))·(T_A(A)·Trans(0, t_Y(A), 0)·Mount(A)·T_C(C)·b − P),
//!   Mount(A) = Trans(M)·Rot(ω(A))·Trans(−M).
//! * EAA(A) = Σ_{j=1..3} e_j·(A/90°)^j: the angular positioning error of A beyond its
//!   zero EA0A (a scale error, and a curvature of the A encoder or drive), added to the
//!   commanded A in T_A: Rx(A + EA0A + EAA(A)).
//!
//! Nominal kinematics: p₀(A, C) = P + Rx(A)·Rz(C)·b.

use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

/// ISO 230-7 location errors of a cradle (µm, µrad).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct LocationErrors {
    pub ey0a_um: f64,
    pub ez0a_um: f64,
    pub eb0a_urad: f64,
    pub ec0a_urad: f64,
    /// Zero-angle error of A.
    pub ea0a_urad: f64,
    pub ex0c_um: f64,
    pub ey0c_um: f64,
    pub ea0c_urad: f64,
    pub eb0c_urad: f64,
    /// Zero-angle error of C.
    pub ec0c_urad: f64,
}

/// The ball's position on the C table (table frame).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Ball {
    /// Distance from the C axis, mm.
    pub radius_mm: f64,
    /// Azimuth from the table's X at C = 0, degrees.
    pub azimuth_deg: f64,
    /// Height along the C axis above the pivot, mm.
    pub height_mm: f64,
}

/// The A-dependent deflections of the table (module docs), all zero at A = 0.
///
/// The spatial tilt ρ(A) = s·sin A + k·(cos A − 1) (µrad, about the pivot) is not all
/// observable: with δ = (0, δ_y, δ_z) ⊥ x, the family s = (0, δ_y, δ_z),
/// k = (0, δ_z, −δ_y), is to first order a rotation about the tilted axis x + δ, i.e. the
/// same as the A axis tilts EB0A, EC0A (with constant tilts of C). The observable part is
/// s = (s_A, m_B, m_C), k = (k_A, −m_C, m_B) ([`Compliance::observable`]); s_A, k_A are
/// the A axis's angular positioning deviation about the pivot.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Compliance {
    pub sin_urad: [f64; 3],
    pub cos_urad: [f64; 3],
    /// z_M: height of the C table's mount on the C axis (mm from the pivot, in the A body
    /// frame), the point the table tilts about (`mount_x_urad`, `mount_y_urad`).
    #[serde(default)]
    pub centre_height_mm: f64,
    /// Shift of the table along the A axis, t_X(A) = e_s·sin A + e_c·(cos A − 1):
    /// (e_s, e_c), µm.
    #[serde(default)]
    pub axial_um: [f64; 2],
    /// Tilt of the C table about its mount, about the axis parallel to A:
    /// τ_X(A) = tX_s·sin A + tX_c·(cos A − 1): (tX_s, tX_c), µrad.
    #[serde(default)]
    pub mount_x_urad: [f64; 2],
    /// Tilt of the C table about its mount, about the table's Y (perpendicular to A and
    /// C): τ_Y(A) = tY_s·sin A + tY_c·(cos A − 1): (tY_s, tY_c), µrad.
    #[serde(default)]
    pub mount_y_urad: [f64; 2],
    /// Sideways shift of the table along its Y in the A body frame,
    /// t_Y(A) = y_s·sin A + y_c·(cos A − 1): (y_s, y_c), µm.
    #[serde(default)]
    pub lateral_um: [f64; 2],
}

/// a·sin A + b·(cos A − 1) for a pair (a, b).
pub fn harmonic(ab: [f64; 2], a_rad: f64) -> f64 {
    let (s, c) = a_rad.sin_cos();
    ab[0] * s + ab[1] * (c - 1.0)
}

impl Compliance {
    /// The observable compliance (s_A, k_A, m_B, m_C), µrad.
    pub fn from_observable(v: [f64; 4]) -> Self {
        let [sa, ka, mb, mc] = v;
        Compliance {
            sin_urad: [sa, mb, mc],
            cos_urad: [ka, -mc, mb],
            ..Compliance::default()
        }
    }

    /// Projection on the observable family: (s_A, k_A, m_B, m_C), µrad. The remainder,
    /// s = (0, δ_y, δ_z), k = (0, δ_z, −δ_y), acts as an A axis tilt.
    pub fn observable(&self) -> [f64; 4] {
        let (s, k) = (self.sin_urad, self.cos_urad);
        [s[0], k[0], 0.5 * (s[1] + k[2]), 0.5 * (s[2] - k[1])]
    }

    /// ρ(A) in rad.
    pub fn rotation_vector(&self, a_rad: f64) -> Vector3<f64> {
        let (s, c) = a_rad.sin_cos();
        (Vector3::from(self.sin_urad) * s + Vector3::from(self.cos_urad) * (c - 1.0)) * 1e-6
    }

    /// t_X(A) in mm.
    pub fn axial_mm(&self, a_rad: f64) -> f64 {
        harmonic(self.axial_um, a_rad) * 1e-3
    }

    /// t_Y(A) in mm.
    pub fn lateral_mm(&self, a_rad: f64) -> f64 {
        harmonic(self.lateral_um, a_rad) * 1e-3
    }

    /// ω(A) = (τ_X(A), τ_Y(A), 0) in rad, the tilt of the C table about its mount (A body
    /// frame).
    pub fn mount_rotation(&self, a_rad: f64) -> Vector3<f64> {
        Vector3::new(
            harmonic(self.mount_x_urad, a_rad),
            harmonic(self.mount_y_urad, a_rad),
            0.0,
        ) * 1e-6
    }
}

/// EAA(A) = Σ_{j=1..3} e_j·(A/90°)^j in rad, for coefficients `e_urad` (µrad).
pub fn eaa_rad(e_urad: &[f64; 3], a_rad: f64) -> f64 {
    let x = a_rad / std::f64::consts::FRAC_PI_2;
    (e_urad[0] * x + e_urad[1] * x * x + e_urad[2] * x * x * x) * 1e-6
}

/// A cradle: nominal pivot, location errors, ball and compliance.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct CradleModel {
    pub pivot_mm: [f64; 3],
    pub location: LocationErrors,
    pub ball: Ball,
    pub compliance: Compliance,
    /// Angular positioning error of A beyond EA0A: EAA(A) = Σ e_j·(A/90°)^j, (e₁, e₂, e₃)
    /// in µrad ([`eaa_rad`]).
    #[serde(default)]
    pub eaa_urad: [f64; 3],
}

fn rx(t: f64) -> UnitQuaternion<f64> {
    UnitQuaternion::from_axis_angle(&Vector3::x_axis(), t)
}
fn ry(t: f64) -> UnitQuaternion<f64> {
    UnitQuaternion::from_axis_angle(&Vector3::y_axis(), t)
}
fn rz(t: f64) -> UnitQuaternion<f64> {
    UnitQuaternion::from_axis_angle(&Vector3::z_axis(), t)
}
fn iso(t: Vector3<f64>, r: UnitQuaternion<f64>) -> Isometry3<f64> {
    Isometry3::from_parts(Translation3::from(t), r)
}

impl CradleModel {
    /// Pose of the table frame in the machine frame at commanded (A, C) in radians:
    /// p = pose · w for a table point w.
    pub fn table_pose(&self, a: f64, c: f64) -> Isometry3<f64> {
        self.a_part(a) * self.c_part(c)
    }

    /// The part of [`Self::table_pose`] that depends on A only: the spatial tilt and the
    /// shift along A, T_A(A), the sideways shift and the tilt about the C table's mount.
    pub fn a_part(&self, a: f64) -> Isometry3<f64> {
        let l = &self.location;
        let p = Vector3::from(self.pivot_mm);
        let ta = iso(
            p + Vector3::new(0.0, l.ey0a_um, l.ez0a_um) * 1e-3,
            rz(l.ec0a_urad * 1e-6)
                * ry(l.eb0a_urad * 1e-6)
                * rx(a + l.ea0a_urad * 1e-6 + eaa_rad(&self.eaa_urad, a)),
        );
        let k = &self.compliance;
        let rho = UnitQuaternion::from_scaled_axis(k.rotation_vector(a));
        let shift = Vector3::x() * k.axial_mm(a);
        let about_pivot = iso(shift + p - rho * p, rho);
        let omega = k.mount_rotation(a);
        if omega == Vector3::zeros() && k.lateral_um == [0.0; 2] {
            return about_pivot * ta;
        }
        let tau = UnitQuaternion::from_scaled_axis(omega);
        let mount = Vector3::new(0.0, 0.0, k.centre_height_mm);
        let body = iso(
            Vector3::new(0.0, k.lateral_mm(a), 0.0) + mount - tau * mount,
            tau,
        );
        about_pivot * ta * body
    }

    /// T_C(C), the part of [`Self::table_pose`] that depends on C only.
    pub fn c_part(&self, c: f64) -> Isometry3<f64> {
        let l = &self.location;
        iso(
            Vector3::new(l.ex0c_um, l.ey0c_um, 0.0) * 1e-3,
            rx(l.ea0c_urad * 1e-6) * ry(l.eb0c_urad * 1e-6) * rz(c + l.ec0c_urad * 1e-6),
        )
    }

    /// The ball in the table frame, mm.
    pub fn ball_in_table(&self) -> Point3<f64> {
        let b = &self.ball;
        let phi = b.azimuth_deg.to_radians();
        Point3::new(
            b.radius_mm * phi.cos(),
            b.radius_mm * phi.sin(),
            b.height_mm,
        )
    }

    /// Measured-ball prediction p(A, C), mm (angles in radians).
    pub fn ball(&self, a: f64, c: f64) -> Vector3<f64> {
        (self.table_pose(a, c) * self.ball_in_table()).coords
    }

    /// Nominal table pose P·Rx(A)·Rz(C).
    pub fn nominal_pose(&self, a: f64, c: f64) -> Isometry3<f64> {
        iso(Vector3::from(self.pivot_mm), rx(a) * rz(c))
    }

    /// Nominal ball position p₀(A, C), mm.
    pub fn nominal_ball(&self, a: f64, c: f64) -> Vector3<f64> {
        (self.nominal_pose(a, c) * self.ball_in_table()).coords
    }
}

/// The spatial tilt ρ(A) of the table about the pivot (m_B, m_C).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(rename_all = "snake_case")]
pub enum Tilt {
    /// No spatial tilt with A (m_B = m_C = 0).
    None,
    /// About the pivot.
    Pivot,
    /// Written by earlier versions: the spatial tilt about the C table's mount (now
    /// modelled per axis in the A body frame: [`ModelSpec::mount_x`],
    /// [`ModelSpec::mount_y`]). Kept so that their documents still read; never fitted.
    Mount,
}

/// Which A-dependent terms a kinematic model carries beyond the rigid one (the location
/// errors and the ball). Parameter vector (mm, rad): the 11 rigid ones ([`RIGID_NAMES`]),
/// then, when present and in this order, s_A, k_A (`a_harmonic`); m_B, m_C (`tilt`);
/// z_M (a tilt about the mount); tX_s, tX_c (`mount_x`); tY_s, tY_c (`mount_y`); e_s, e_c
/// (`axial`); y_s, y_c (`lateral`); e₁ … e_order (`eaa_order`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ModelSpec {
    pub tilt: Tilt,
    /// Rotation about A of the form s_A·sin A + k_A·(cos A − 1) (gravity torque against
    /// a stiff drive).
    pub a_harmonic: bool,
    /// Polynomial order of EAA(A) (0–3).
    pub eaa_order: usize,
    /// Shift along the A axis with A.
    pub axial: bool,
    /// The C table tilts about its mount about the axis parallel to A.
    #[serde(default)]
    pub mount_x: bool,
    /// The C table tilts about its mount about its Y (perpendicular to A and C).
    #[serde(default)]
    pub mount_y: bool,
    /// The table shifts sideways (along its Y) with A.
    #[serde(default)]
    pub lateral: bool,
}

impl Default for ModelSpec {
    fn default() -> Self {
        ModelSpec::RIGID
    }
}

impl ModelSpec {
    /// Location errors and ball only.
    pub const RIGID: ModelSpec = ModelSpec {
        tilt: Tilt::None,
        a_harmonic: false,
        eaa_order: 0,
        axial: false,
        mount_x: false,
        mount_y: false,
        lateral: false,
    };
    /// The classic compliant model: ρ(A) about the pivot, observable form (s_A, k_A, m_B,
    /// m_C).
    pub const COMPLIANT: ModelSpec = ModelSpec {
        tilt: Tilt::Pivot,
        a_harmonic: true,
        ..ModelSpec::RIGID
    };

    /// Whether anything depends on A beyond the rigid model.
    pub fn is_rigid(&self) -> bool {
        *self == ModelSpec::RIGID
    }

    /// Whether the table tilts about its mount (z_M is a parameter).
    pub fn has_mount(&self) -> bool {
        self.mount_x || self.mount_y || self.tilt == Tilt::Mount
    }

    /// Parameter names in order (module docs).
    pub fn names(&self) -> Vec<&'static str> {
        let mut v = RIGID_NAMES.to_vec();
        if self.a_harmonic {
            v.extend(["s_A", "k_A"]);
        }
        if self.tilt != Tilt::None {
            v.extend(["m_B", "m_C"]);
        }
        if self.has_mount() {
            v.push("z_M");
        }
        if self.mount_x {
            v.extend(["tX_s", "tX_c"]);
        }
        if self.mount_y {
            v.extend(["tY_s", "tY_c"]);
        }
        if self.axial {
            v.extend(["e_s", "e_c"]);
        }
        if self.lateral {
            v.extend(["y_s", "y_c"]);
        }
        v.extend(["e_1", "e_2", "e_3"].iter().take(self.eaa_order.min(3)));
        v
    }

    pub fn n_params(&self) -> usize {
        self.names().len()
    }

    /// Index of a parameter by name.
    pub fn index(&self, name: &str) -> Option<usize> {
        self.names().iter().position(|n| *n == name)
    }

    /// Central-difference steps of the parameters (mm or rad): every length enters the
    /// ball position linearly (a translation, the ball's radius and height, the mount's
    /// lever), so a step of 1 µm is exact and far above rounding; angles take 1 µrad.
    pub fn steps(&self) -> Vec<f64> {
        self.names()
            .iter()
            .map(|n| if unit_of(n) == "urad" { 1e-6 } else { 1e-3 })
            .collect()
    }

    /// A sentence naming the model.
    pub fn describe(&self) -> String {
        if self.is_rigid() {
            return "rigid".into();
        }
        let mut parts = vec![];
        match self.tilt {
            Tilt::None => {}
            Tilt::Pivot => parts.push("table tilts with A about the pivot".to_string()),
            Tilt::Mount => parts.push(
                "table tilts with A about the C table's mount (spatial form of earlier versions)"
                    .to_string(),
            ),
        }
        match (self.mount_x, self.mount_y) {
            (true, true) => parts.push(
                "C table tilts about its mount about X (parallel to A) and about its Y".to_string(),
            ),
            (true, false) => {
                parts.push("C table tilts about its mount about X (parallel to A)".to_string())
            }
            (false, true) => parts.push("C table tilts about its mount about its Y".to_string()),
            (false, false) => {}
        }
        if self.a_harmonic {
            parts.push("A positioning error s_A·sin A + k_A·(cos A − 1)".to_string());
        }
        if self.eaa_order > 0 {
            parts.push(format!(
                "A positioning error EAA(A) of order {}",
                self.eaa_order
            ));
        }
        if self.axial {
            parts.push("table shifts along A with A".to_string());
        }
        if self.lateral {
            parts.push("table shifts sideways with A".to_string());
        }
        parts.join(" + ")
    }
}

/// The reporting unit of a parameter: `mm` (the ball's radius and height, z_M), `um`
/// (offsets and shifts) or `urad` (angles).
pub fn unit_of(name: &str) -> &'static str {
    match name {
        "ball_radius" | "ball_height" | "z_M" => "mm",
        "EY0A" | "EZ0A" | "EX0C" | "EY0C" | "e_s" | "e_c" | "y_s" | "y_c" => "um",
        _ => "urad",
    }
}

/// The factor from internal units (mm, rad) to [`unit_of`].
pub fn unit_scale(name: &str) -> f64 {
    match unit_of(name) {
        "mm" => 1.0,
        "um" => 1e3,
        _ => 1e6,
    }
}

/// Names of the rigid model's parameters (internal units mm and rad): the first eight are
/// location errors, then the ball.
pub const RIGID_NAMES: [&str; 11] = [
    "EY0A",
    "EZ0A",
    "EB0A",
    "EC0A",
    "EA0A+EA0C",
    "EX0C",
    "EY0C",
    "EB0C",
    "ball_radius",
    "ball_azimuth",
    "ball_height",
];

/// Number of rigid-model parameters (location errors and ball).
pub const N_RIGID: usize = 11;

/// Parameter vector (mm, rad) ↔ model, for the terms `spec` carries. EA0A and EA0C act
/// identically on a ball on the table (to first order), so one parameter carries their
/// sum (stored in EA0A, EA0C = 0); EC0C acts exactly like the ball's azimuth, so it is
/// carried by the azimuth (EC0C = 0).
pub fn model_from_params(pivot_mm: [f64; 3], spec: &ModelSpec, q: &[f64]) -> CradleModel {
    let get = |name: &str| spec.index(name).map_or(0.0, |i| q[i]);
    let mut compliance =
        Compliance::from_observable(["s_A", "k_A", "m_B", "m_C"].map(|n| get(n) * 1e6));
    compliance.centre_height_mm = get("z_M");
    compliance.axial_um = [get("e_s") * 1e3, get("e_c") * 1e3];
    compliance.mount_x_urad = [get("tX_s") * 1e6, get("tX_c") * 1e6];
    compliance.mount_y_urad = [get("tY_s") * 1e6, get("tY_c") * 1e6];
    compliance.lateral_um = [get("y_s") * 1e3, get("y_c") * 1e3];
    CradleModel {
        pivot_mm,
        location: LocationErrors {
            ey0a_um: q[0] * 1e3,
            ez0a_um: q[1] * 1e3,
            eb0a_urad: q[2] * 1e6,
            ec0a_urad: q[3] * 1e6,
            ea0a_urad: q[4] * 1e6,
            ex0c_um: q[5] * 1e3,
            ey0c_um: q[6] * 1e3,
            ea0c_urad: 0.0,
            eb0c_urad: q[7] * 1e6,
            ec0c_urad: 0.0,
        },
        ball: Ball {
            radius_mm: q[8],
            azimuth_deg: q[9].to_degrees(),
            height_mm: q[10],
        },
        compliance,
        eaa_urad: ["e_1", "e_2", "e_3"].map(|n| get(n) * 1e6),
    }
}

/// Inverse of [`model_from_params`] (EA0A + EA0C summed, EC0C folded into the azimuth;
/// terms `spec` does not carry are dropped).
pub fn params_from_model(m: &CradleModel, spec: &ModelSpec) -> Vec<f64> {
    let l = &m.location;
    let [sa, ka, mb, mc] = m.compliance.observable();
    spec.names()
        .iter()
        .map(|name| match *name {
            "EY0A" => l.ey0a_um * 1e-3,
            "EZ0A" => l.ez0a_um * 1e-3,
            "EB0A" => l.eb0a_urad * 1e-6,
            "EC0A" => l.ec0a_urad * 1e-6,
            "EA0A+EA0C" => (l.ea0a_urad + l.ea0c_urad) * 1e-6,
            "EX0C" => l.ex0c_um * 1e-3,
            "EY0C" => l.ey0c_um * 1e-3,
            "EB0C" => l.eb0c_urad * 1e-6,
            "ball_radius" => m.ball.radius_mm,
            "ball_azimuth" => m.ball.azimuth_deg.to_radians() + l.ec0c_urad * 1e-6,
            "ball_height" => m.ball.height_mm,
            "s_A" => sa * 1e-6,
            "k_A" => ka * 1e-6,
            "m_B" => mb * 1e-6,
            "m_C" => mc * 1e-6,
            "z_M" => m.compliance.centre_height_mm,
            "e_s" => m.compliance.axial_um[0] * 1e-3,
            "e_c" => m.compliance.axial_um[1] * 1e-3,
            "tX_s" => m.compliance.mount_x_urad[0] * 1e-6,
            "tX_c" => m.compliance.mount_x_urad[1] * 1e-6,
            "tY_s" => m.compliance.mount_y_urad[0] * 1e-6,
            "tY_c" => m.compliance.mount_y_urad[1] * 1e-6,
            "y_s" => m.compliance.lateral_um[0] * 1e-3,
            "y_c" => m.compliance.lateral_um[1] * 1e-3,
            "e_1" => m.eaa_urad[0] * 1e-6,
            "e_2" => m.eaa_urad[1] * 1e-6,
            "e_3" => m.eaa_urad[2] * 1e-6,
            other => unreachable!("parameter {other}"),
        })
        .collect()
}
