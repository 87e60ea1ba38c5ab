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
//! * ρ(A) = s·sin A + k·(cos A − 1): compliance, a spatial rotation vector of the table
//!   about the pivot that vanishes at A = 0 (a rigid cradle has s = k = 0; constant
//!   deflections are location errors). Gravity loading of a tilting cradle has this
//!   form: the load's components across and along the table go as sin A and cos A.
//!
//! Nominal kinematics: p₀(A, C) = P + Rx(A)·Rz(C)·b.

use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

/// ISO 230-7 location errors of a cradle (µm, µrad).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
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
pub struct Ball {
    /// Distance from the C axis, mm.
    pub radius_mm: f64,
    /// Azimuth from the table's X at C = 0, degrees.
    pub azimuth_deg: f64,
    /// Height along the C axis above the pivot, mm.
    pub height_mm: f64,
}

/// ρ(A) = s·sin A + k·(cos A − 1), µrad (spatial rotation vector about the pivot).
///
/// Not all of it is observable: with δ = (0, δ_y, δ_z) ⊥ x, the family s = δ,
/// k = x × δ... precisely s = (0, δ_y, δ_z), k = (0, δ_z, −δ_y), is to first order a
/// rotation about the tilted axis x + δ, i.e. the same as the A axis tilts EB0A, EC0A
/// (with constant tilts of C). The observable part is s = (s_A, m_B, m_C),
/// k = (k_A, −m_C, m_B) ([`Compliance::observable`]); s_A, k_A are the A axis's angular
/// positioning deviation about the pivot.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Compliance {
    pub sin_urad: [f64; 3],
    pub cos_urad: [f64; 3],
}

impl Compliance {
    /// The observable compliance (s_A, k_A, m_B, m_C), µrad.
    pub fn from_observable(v: [f64; 4]) -> Self {
        let [sa, ka, mb, mc] = v;
        Compliance {
            sin_urad: [sa, mb, mc],
            cos_urad: [ka, -mc, mb],
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
}

/// A cradle: nominal pivot, location errors, ball and compliance.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CradleModel {
    pub pivot_mm: [f64; 3],
    pub location: LocationErrors,
    pub ball: Ball,
    pub compliance: Compliance,
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
        let l = &self.location;
        let p = Vector3::from(self.pivot_mm);
        let ta = iso(
            p + Vector3::new(0.0, l.ey0a_um, l.ez0a_um) * 1e-3,
            rz(l.ec0a_urad * 1e-6) * ry(l.eb0a_urad * 1e-6) * rx(a + l.ea0a_urad * 1e-6),
        );
        let tc = iso(
            Vector3::new(l.ex0c_um, l.ey0c_um, 0.0) * 1e-3,
            rx(l.ea0c_urad * 1e-6) * ry(l.eb0c_urad * 1e-6) * rz(c + l.ec0c_urad * 1e-6),
        );
        let rho = UnitQuaternion::from_scaled_axis(self.compliance.rotation_vector(a));
        let about_pivot = iso(p - rho * p, rho);
        about_pivot * ta * tc
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

/// Names of the identification parameters, in order, with their reporting unit. Internal
/// units: mm and rad (the first eight are location errors, then the ball, then the
/// compliance coefficients).
pub const PARAM_NAMES: [&str; 15] = [
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
    "s_A",
    "k_A",
    "m_B",
    "m_C",
];

/// Number of rigid-model parameters (location errors and ball).
pub const N_RIGID: usize = 11;

/// Parameter vector (mm, rad) ↔ model. EA0A and EA0C act identically on a ball on the
/// table (to first order), so one parameter carries their sum (stored in EA0A, EA0C = 0);
/// EC0C acts exactly like the ball's azimuth, so it is carried by the azimuth (EC0C = 0).
pub fn model_from_params(pivot_mm: [f64; 3], q: &[f64]) -> CradleModel {
    let mut compliance = Compliance::default();
    if q.len() >= 15 {
        compliance = Compliance::from_observable([q[11], q[12], q[13], q[14]].map(|v| v * 1e6));
    }
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
    }
}

/// Inverse of [`model_from_params`] (EA0A + EA0C summed, EC0C folded into the azimuth).
pub fn params_from_model(m: &CradleModel, compliant: bool) -> Vec<f64> {
    let l = &m.location;
    let mut q = vec![
        l.ey0a_um * 1e-3,
        l.ez0a_um * 1e-3,
        l.eb0a_urad * 1e-6,
        l.ec0a_urad * 1e-6,
        (l.ea0a_urad + l.ea0c_urad) * 1e-6,
        l.ex0c_um * 1e-3,
        l.ey0c_um * 1e-3,
        l.eb0c_urad * 1e-6,
        m.ball.radius_mm,
        m.ball.azimuth_deg.to_radians() + l.ec0c_urad * 1e-6,
        m.ball.height_mm,
    ];
    if compliant {
        q.extend(m.compliance.observable().iter().map(|v| v * 1e-6));
    }
    q
}
