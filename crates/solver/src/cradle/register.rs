//! Registration of the instrument frame to the nominal kinematics.
//!
//! A laser tracker measures in its own frame. Before location errors and before/after
//! figures can mean anything, that frame must be related to the machine's. The best-fit
//! registration is the rigid map x = Rot(ω)·R₀ᵀ·(p − o) + t (R₀, o: a frame built from
//! the data with X along the fitted A axis, [`super::data_frame`]) that brings the
//! measured points p closest to the nominal kinematics p₀(A, C) = Rx(A)·Rz(C)·b with the
//! pivot at the origin: min over (ω, t, b) of Σ |x(pᵢ) − p₀(Aᵢ, Cᵢ)|² by Gauss–Newton
//! ([`super::identify::gauss_newton`]; 9 parameters). The six rigid degrees of freedom
//! absorb exactly the location errors that depend on the frame (EY0A, EZ0A, EB0A, EC0A,
//! EX0C and EA0A + EA0C); what remains after it is the error no choice of frame removes.
//!
//! A frame stated to be registered (the instrument frame is the machine's, pivot at
//! `pivot_mm`) is accepted when the best-fit map differs from it by at most
//! [`MAX_ROTATION_RAD`] and [`MAX_SHIFT_MM`] (far beyond any plausible location error);
//! otherwise the check falls back to the best-fit frame and says so.

use super::frames::PosePoints;
use super::identify::gauss_newton;
use crate::error::SolverError;
use nalgebra::{DVector, Rotation3, Vector3};
use serde::{Deserialize, Serialize};

/// Largest rotation between a stated registered frame and the best-fit one, rad.
pub const MAX_ROTATION_RAD: f64 = 2e-3;
/// Largest distance between the stated pivot and the best-fit one, mm.
pub const MAX_SHIFT_MM: f64 = 1.0;

/// The best-fit map from the instrument frame to the registered frame (pivot at the
/// origin): x = rotation·p + translation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Registration {
    pub rotation: Rotation3<f64>,
    pub translation: Vector3<f64>,
    /// RMS 3-D distance of the points from the nominal kinematics after it, mm.
    pub residual_rms_mm: f64,
    pub converged: bool,
}

impl Registration {
    pub fn apply(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.rotation * p + self.translation
    }
}

/// How the frame was chosen, for the result document.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct RegistrationReport {
    /// `machine`: the instrument frame is the machine's as stated (and the data agree);
    /// `best_fit`: the points were registered to the nominal kinematics and only the
    /// location errors intrinsic to the cradle are reported.
    pub frame: String,
    /// Rotation of the best-fit frame relative to the stated one (rotation vector, µrad)
    /// and where it puts the stated pivot (mm).
    pub rotation_urad: [f64; 3],
    pub pivot_offset_mm: [f64; 3],
    /// RMS 3-D distance of the points from the nominal kinematics in the best-fit frame,
    /// µm: the error no choice of frame removes.
    pub residual_rms_um: f64,
}

/// Best-fit registration (module docs), starting from the data frame `(r0, o)` and the
/// ball `ball0` = (radius, azimuth rad, height) in it.
pub fn register(
    poses: &[PosePoints],
    r0: &Rotation3<f64>,
    o: &Vector3<f64>,
    ball0: [f64; 3],
) -> Result<Registration, SolverError> {
    let pts: Vec<(f64, f64, Vector3<f64>)> = poses
        .iter()
        .flat_map(|pose| {
            pose.points
                .iter()
                .map(move |(c, p)| (pose.a_rad, *c, r0.inverse() * (p - o)))
        })
        .collect();
    let map = |q: &[f64]| {
        (
            Rotation3::new(Vector3::new(q[0], q[1], q[2])),
            Vector3::new(q[3], q[4], q[5]),
        )
    };
    let f = |q: &[f64]| {
        let (rot, t) = map(q);
        let b = Vector3::new(q[6] * q[7].cos(), q[6] * q[7].sin(), q[8]);
        let mut r = DVector::zeros(3 * pts.len());
        for (i, (a, c, p)) in pts.iter().enumerate() {
            let nominal = Rotation3::from_axis_angle(&Vector3::x_axis(), *a)
                * Rotation3::from_axis_angle(&Vector3::z_axis(), *c)
                * b;
            r.fixed_rows_mut::<3>(3 * i)
                .copy_from(&(rot * p + t - nominal));
        }
        r
    };
    let q0 = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, ball0[0], ball0[1], ball0[2]];
    // Steps: 1 µrad for the rotation and the ball's azimuth, 1 µm for lengths (which
    // enter linearly).
    let steps = [1e-6, 1e-6, 1e-6, 1e-3, 1e-3, 1e-3, 1e-3, 1e-6, 1e-3];
    let sol = gauss_newton(f, &q0, &steps, "frame registration")?;
    let (rot, t) = map(&sol.q);
    Ok(Registration {
        rotation: rot * r0.inverse(),
        translation: t - rot * (r0.inverse() * o),
        residual_rms_mm: (sol.residual.norm_squared() / pts.len().max(1) as f64).sqrt(),
        converged: sol.converged,
    })
}
