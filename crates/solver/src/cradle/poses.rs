//! The measured ball centres grouped by commanded A, their observations in a frame, and
//! the data frame of the patent's analysis.

use crate::cradle::frames::PosePoints;
use crate::cradle::identify::Obs;
use crate::cradle::*;
use crate::datasets::RotaryPointSet;
use crate::error::SolverError;
use nalgebra::{Rotation3, Unit, Vector3};
use std::collections::BTreeMap;

pub(super) fn group_poses(
    points: &RotaryPointSet,
    min_points: usize,
) -> Result<Vec<PosePoints>, SolverError> {
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
pub(super) fn observations(
    poses: &[PosePoints],
    map: &dyn Fn(&Vector3<f64>) -> Vector3<f64>,
) -> Vec<Obs> {
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
pub(super) fn data_frame(pa: &PatentAnalysis) -> (Rotation3<f64>, Vector3<f64>) {
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
