//! Compensation: the corrected command (X′, Y′, Z′, A′, C′) that puts a workpiece point
//! where the commanded (X, Y, Z, A, C) meant it to be, under the identified model.
//!
//! Kinematic convention: cradle A about X carrying C about Z, tool fixed in orientation
//! (along Z); the linear axes place the tool at (X, Y, Z) in the machine frame and are
//! taken as exact (this check concerns A and C). Nominally the table point under the
//! tool is w = (P·Rx(A)·Rz(C))⁻¹·(X, Y, Z). The corrected rotary command makes the tool
//! axis, seen from the table, the intended one: T(A′, C′)⁻¹·ẑ = (Rx(A)·Rz(C))⁻¹·ẑ, solved
//! by Gauss–Newton on the model's forward kinematics (derivatives by central
//! differences, SVD steps; near A = 0 the C direction is singular and left unchanged,
//! the small orientation remainder is reported). Then (X′, Y′, Z′) = T(A′, C′)·w exactly,
//! so the point lands under the tool whatever remains of the orientation.

use super::model::CradleModel;
use nalgebra::{Matrix3x2, Point3, Vector2, Vector3};
use serde::{Deserialize, Serialize};

/// A 5-axis command: mm and degrees.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Command {
    pub x_mm: f64,
    pub y_mm: f64,
    pub z_mm: f64,
    pub a_deg: f64,
    pub c_deg: f64,
}

/// The corrected command and how well its orientation matches.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Compensated {
    pub command: Command,
    /// Angle between the achieved and intended tool axis in the table frame, µrad.
    pub orientation_residual_urad: f64,
    pub iterations: usize,
}

fn tool_axis_in_table(m: &CradleModel, a: f64, c: f64) -> Vector3<f64> {
    m.table_pose(a, c).rotation.inverse() * Vector3::z()
}

/// Corrected command for `cmd` under `model`.
pub fn compensate(model: &CradleModel, cmd: &Command) -> Compensated {
    let (a0, c0) = (cmd.a_deg.to_radians(), cmd.c_deg.to_radians());
    let nominal = model.nominal_pose(a0, c0);
    let target = nominal.rotation.inverse() * Vector3::z();
    let w = nominal.inverse() * Point3::new(cmd.x_mm, cmd.y_mm, cmd.z_mm);
    let (mut a, mut c) = (a0, c0);
    let mut iterations = 0;
    const H: f64 = 1e-7;
    for _ in 0..20 {
        iterations += 1;
        let f = tool_axis_in_table(model, a, c) - target;
        let da =
            (tool_axis_in_table(model, a + H, c) - tool_axis_in_table(model, a - H, c)) / (2.0 * H);
        let dc =
            (tool_axis_in_table(model, a, c + H) - tool_axis_in_table(model, a, c - H)) / (2.0 * H);
        let j = Matrix3x2::from_columns(&[da, dc]);
        // Singular values below 1e-2 (|sin A| < 0.01) are the C singularity near A = 0.
        let step: Vector2<f64> = j.svd(true, true).solve(&(-f), 1e-2).unwrap_or_default();
        a += step[0];
        c += step[1];
        if step.norm() < 1e-13 {
            break;
        }
    }
    let p = model.table_pose(a, c) * w;
    let achieved = tool_axis_in_table(model, a, c);
    Compensated {
        command: Command {
            x_mm: p.x,
            y_mm: p.y,
            z_mm: p.z,
            a_deg: a.to_degrees(),
            c_deg: c.to_degrees(),
        },
        orientation_residual_urad: achieved.angle(&target) * 1e6,
        iterations,
    }
}
