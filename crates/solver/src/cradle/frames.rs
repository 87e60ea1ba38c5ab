//! The seed patent's method: circle per A pose, A axis through the centres, actual and
//! theoretical frames per pose, and the rotation vector between them.
//!
//! For A pose i (points pᵢⱼ at commanded Cⱼ):
//!
//! 1. circle fit → centre cᵢ, normal nᵢ (oriented so that +C turns right-handed about it);
//! 2. circle through the centres cᵢ → A axis (unit direction a, oriented so that +A turns
//!    right-handed about it, and a point, the centre of that circle);
//! 3. actual frame Eᵢ = [e₁ e₂ e₃]: e₃ = nᵢ, e₁ = the unit projection of (point at C = 0) − cᵢ
//!    on the circle's plane, e₂ = e₃ × e₁. When no point has C = 0 exactly, the point
//!    nearest C = 0 is rotated back by −C about nᵢ (noted in the report);
//! 4. theoretical frame Etᵢ = Rot(a, θᵢ)·E_ref, with E_ref the actual frame of the
//!    reference pose (the one with the smallest |A|) and θᵢ the signed angle about a from
//!    c_ref to cᵢ (both measured from the A axis);
//! 5. matRᵢ = Eᵢ·Etᵢ⁻¹ = Eᵢ·Etᵢᵀ; rotation vector rᵢ = log(matRᵢ) (axis × angle).
//!
//! A rigid connection rotates the whole table about the A axis, so rᵢ is constant (zero
//! by construction at the reference pose); its dependence on A measures the connection's
//! compliance.
//!
//! Beyond the patent, e₁ is also taken from the phase of all the circle's points with C
//! known: with in-plane basis (u, v = n × u) and point angles ϑⱼ, φ₀ = arg Σ exp(i(ϑⱼ − Cⱼ)),
//! e₁ = u cos φ₀ + v sin φ₀. Its noise is that of one point divided by √N. And the
//! theoretical frames are also built from an A = 0 frame pooled over all poses
//! ([`PoseRow::rotation_pooled`]).

use crate::error::SolverError;
use crate::fits::{CircleFit, fit_circle, perpendicular};
use nalgebra::{Matrix3, Rotation3, Unit, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

/// The points of one A pose: (commanded C in rad, measured position in mm).
#[derive(Debug, Clone)]
pub struct PosePoints {
    /// Commanded A as given, degrees, and in radians.
    pub a_deg: f64,
    pub a_rad: f64,
    pub points: Vec<(f64, Vector3<f64>)>,
}

/// A rotation vector in µrad with its norm, unit direction and an approximate standard
/// uncertainty per component (isotropic first-order propagation of the two frames' and
/// the centre angle's uncertainties).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct RotationVector {
    pub vector_urad: [f64; 3],
    pub norm_urad: f64,
    /// Unit direction (the axis of the deflection); `None` for a zero vector.
    pub axis: Option<[f64; 3]>,
    pub std_urad: f64,
}

impl RotationVector {
    fn new(r: Vector3<f64>, std_rad: f64) -> Self {
        let norm = r.norm();
        RotationVector {
            vector_urad: (r * 1e6).into(),
            norm_urad: norm * 1e6,
            axis: (norm > 0.0).then(|| (r / norm).into()),
            std_urad: std_rad * 1e6,
        }
    }
}

/// One row of the per-pose table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct PoseRow {
    pub a_deg: f64,
    pub n_points: usize,
    pub centre_mm: [f64; 3],
    pub centre_std_um: [f64; 3],
    /// Circle normal = measured C axis direction at this A.
    pub normal: [f64; 3],
    pub normal_std_urad: [f64; 2],
    pub radius_mm: f64,
    pub radius_std_um: f64,
    pub circle_rms_um: f64,
    pub circle_condition: f64,
    /// θ: angle about the A axis from the reference pose's centre to this one, degrees.
    pub angle_from_reference_deg: f64,
    /// θ − (A − A_ref): the A axis's angular positioning deviation seen by the centres, µrad.
    pub angle_deviation_urad: f64,
    /// |C| of the point used for e₁ in the patent's variant (0 when a point has C = 0).
    pub x_point_c_deg: f64,
    /// Angle between e₁ from one point and e₁ from the phase of all points, µrad.
    pub x_disagreement_urad: f64,
    /// Patent: e₁ from the point at C = 0.
    pub rotation_point: RotationVector,
    /// Beyond the patent: e₁ from the phase of all points.
    pub rotation_phase: RotationVector,
    /// Beyond the patent: e₁ from the phase, and the theoretical frames from the A = 0
    /// frame estimated from all poses (E₀ = the rotation nearest Σ Rot(a, −θᵢ)·Eᵢ) instead
    /// of the reference pose alone: the reference pose's noise, which enters every patent
    /// vector as −Rot(a, θᵢ)·δ_ref (a sin/cos pattern in A), is averaged down by √N. The
    /// rigid/compliant choice uses these.
    pub rotation_pooled: RotationVector,
}

/// The A axis from the circle through the pose centres.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct AAxisFit {
    pub direction: [f64; 3],
    pub direction_std_urad: [f64; 2],
    /// A point of the axis (the centre of the circle of centres), mm.
    pub point_mm: [f64; 3],
    pub point_std_um: [f64; 3],
    /// Radius of the circle of centres, mm.
    pub radius_mm: f64,
    pub rms_um: f64,
    pub condition: f64,
}

/// Output of [`patent_frames`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct PatentAnalysis {
    pub reference_a_deg: f64,
    pub a_axis: AAxisFit,
    pub poses: Vec<PoseRow>,
}

fn wrap(t: f64) -> f64 {
    let tau = std::f64::consts::TAU;
    t - tau * (t / tau).round()
}

/// Mean resultant of exp(i(ϑⱼ − qⱼ)) for angles of `d` about `n`: (length / N, phase).
fn phase(
    n: &Vector3<f64>,
    items: &[(f64, Vector3<f64>)],
) -> (f64, f64, Vector3<f64>, Vector3<f64>) {
    let u = perpendicular(n);
    let v = n.cross(&u);
    let (mut s, mut c) = (0.0, 0.0);
    for (q, d) in items {
        let t = d.dot(&v).atan2(d.dot(&u)) - q;
        s += t.sin();
        c += t.cos();
    }
    (
        (s * s + c * c).sqrt() / items.len() as f64,
        s.atan2(c),
        u,
        v,
    )
}

/// Orients `n` so that the angles of `items` about it increase with their command.
fn orient(n: Vector3<f64>, items: &[(f64, Vector3<f64>)]) -> Vector3<f64> {
    if phase(&n, items).0 >= phase(&-n, items).0 {
        n
    } else {
        -n
    }
}

struct PoseFit {
    a_deg: f64,
    a_rad: f64,
    circle: CircleFit,
    x_point: Vector3<f64>,
    x_point_c: f64,
    x_phase: Vector3<f64>,
    /// In-plane angle noise of e₁: one point and all points, rad.
    x_point_std: f64,
    x_phase_std: f64,
}

fn fit_pose(p: &PosePoints) -> Result<PoseFit, SolverError> {
    let pts: Vec<Vector3<f64>> = p.points.iter().map(|(_, x)| *x).collect();
    let circle = fit_circle(&pts)?;
    let rel: Vec<(f64, Vector3<f64>)> = p
        .points
        .iter()
        .map(|(c, x)| (*c, x - circle.centre))
        .collect();
    let n = orient(circle.normal, &rel);
    let circle = circle.oriented(&n);
    let (_, phi0, u, v) = phase(&n, &rel);
    let x_phase = u * phi0.cos() + v * phi0.sin();
    let (c0, d0) = rel
        .iter()
        .min_by(|a, b| wrap(a.0).abs().total_cmp(&wrap(b.0).abs()))
        .copied()
        .expect("circle has points");
    let back = Rotation3::from_axis_angle(&Unit::new_normalize(n), -wrap(c0)) * d0;
    let x_point = (back - n * back.dot(&n)).normalize();
    let sigma = if circle.sigma.is_finite() {
        circle.sigma
    } else {
        0.0
    };
    Ok(PoseFit {
        a_deg: p.a_deg,
        a_rad: p.a_rad,
        x_point,
        x_point_c: wrap(c0).abs(),
        x_phase,
        x_point_std: sigma / circle.radius,
        x_phase_std: sigma / (circle.radius * (pts.len() as f64).sqrt()),
        circle,
    })
}

/// log(R) as a rotation vector, via the unit quaternion (robust near the identity).
fn log_so3(r: &Rotation3<f64>) -> Vector3<f64> {
    UnitQuaternion::from_rotation_matrix(r).scaled_axis()
}

/// The rotation nearest `m` in the Frobenius norm: U·diag(1, 1, det(U·Vᵀ))·Vᵀ.
fn nearest_rotation(m: &Matrix3<f64>) -> Rotation3<f64> {
    let svd = m.svd(true, true);
    let (u, vt) = (svd.u.expect("U"), svd.v_t.expect("V"));
    let d = (u * vt).determinant().signum();
    Rotation3::from_matrix_unchecked(u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * vt)
}

fn frame(z: &Vector3<f64>, x: &Vector3<f64>) -> Rotation3<f64> {
    Rotation3::from_basis_unchecked(&[*x, z.cross(x), *z])
}

/// Runs the patent's analysis on the poses (at least 3 poses, at least 4 points each).
pub fn patent_frames(poses: &[PosePoints]) -> Result<PatentAnalysis, SolverError> {
    if poses.len() < 3 {
        return Err(SolverError::InvalidInput(format!(
            "cradle check needs at least 3 A poses (the A axis is a circle through their centres), got {}",
            poses.len()
        )));
    }
    let fits = poses.iter().map(fit_pose).collect::<Result<Vec<_>, _>>()?;
    let centres: Vec<Vector3<f64>> = fits.iter().map(|f| f.circle.centre).collect();
    let axis_circle = fit_circle(&centres)?;
    let rel: Vec<(f64, Vector3<f64>)> = fits
        .iter()
        .map(|f| (f.a_rad, f.circle.centre - axis_circle.centre))
        .collect();
    let a = orient(axis_circle.normal, &rel);
    let axis_circle = axis_circle.oriented(&a);
    let ua = Unit::new_normalize(a);
    let iref = (0..fits.len())
        .min_by(|&i, &j| fits[i].a_rad.abs().total_cmp(&fits[j].a_rad.abs()))
        .expect("poses");
    let fr = &fits[iref];
    let proj = |c: &Vector3<f64>| {
        let d = c - axis_circle.centre;
        d - a * d.dot(&a)
    };
    let vref = proj(&fr.circle.centre);
    let e_ref_point = frame(&fr.circle.normal, &fr.x_point);
    let e_ref_phase = frame(&fr.circle.normal, &fr.x_phase);
    let frame_std = |f: &PoseFit, x_std: f64| {
        let sn = f.circle.normal_std_rad;
        ((sn[0] * sn[0] + sn[1] * sn[1] + x_std * x_std) / 3.0).sqrt()
    };
    // Angle noise of a centre about the A axis: its tangential standard uncertainty over
    // its distance from the axis.
    let centre_angle_std = |f: &PoseFit| {
        let r = proj(&f.circle.centre);
        let t = a.cross(&r).normalize();
        let cov = &f.circle.covariance;
        let mut var = 0.0;
        for i in 0..3 {
            for j in 0..3 {
                var += t[i] * cov[i][j] * t[j];
            }
        }
        var.max(0.0).sqrt() / r.norm().max(1e-300)
    };
    let thetas: Vec<f64> = fits
        .iter()
        .map(|f| {
            let vi = proj(&f.circle.centre);
            vref.cross(&vi).dot(&a).atan2(vref.dot(&vi))
        })
        .collect();
    let mut sum = Matrix3::zeros();
    for (f, t) in fits.iter().zip(&thetas) {
        sum += (Rotation3::from_axis_angle(&ua, -t) * frame(&f.circle.normal, &f.x_phase)).matrix();
    }
    let e_pooled = nearest_rotation(&sum);
    let mut rows = Vec::with_capacity(fits.len());
    for (f, &theta) in fits.iter().zip(&thetas) {
        let rot = Rotation3::from_axis_angle(&ua, theta);
        let sa = centre_angle_std(f).hypot(centre_angle_std(fr));
        let rv = |e_ref: &Rotation3<f64>, x: &Vector3<f64>, si: f64, sr: f64| {
            let et = rot * e_ref;
            let mat_r = frame(&f.circle.normal, x) * et.inverse();
            RotationVector::new(log_so3(&mat_r), (si * si + sr * sr + sa * sa).sqrt())
        };
        let c = &f.circle;
        rows.push(PoseRow {
            a_deg: f.a_deg,
            n_points: c.radial.len(),
            centre_mm: c.centre.into(),
            centre_std_um: c.centre_std.map(|s| s * 1e3),
            normal: c.normal.into(),
            normal_std_urad: c.normal_std_rad.map(|s| s * 1e6),
            radius_mm: c.radius,
            radius_std_um: c.radius_std * 1e3,
            circle_rms_um: c.rms * 1e3,
            circle_condition: c.condition,
            angle_from_reference_deg: theta.to_degrees(),
            angle_deviation_urad: wrap(theta - (f.a_rad - fr.a_rad)) * 1e6,
            x_point_c_deg: f.x_point_c.to_degrees(),
            x_disagreement_urad: f.x_point.angle(&f.x_phase) * 1e6,
            rotation_point: rv(
                &e_ref_point,
                &f.x_point,
                frame_std(f, f.x_point_std),
                frame_std(fr, fr.x_point_std),
            ),
            rotation_phase: rv(
                &e_ref_phase,
                &f.x_phase,
                frame_std(f, f.x_phase_std),
                frame_std(fr, fr.x_phase_std),
            ),
            rotation_pooled: rv(
                &e_pooled,
                &f.x_phase,
                frame_std(f, f.x_phase_std),
                frame_std(fr, fr.x_phase_std) / (fits.len() as f64).sqrt(),
            ),
        });
    }
    let ac = &axis_circle;
    Ok(PatentAnalysis {
        reference_a_deg: fr.a_deg,
        a_axis: AAxisFit {
            direction: a.into(),
            direction_std_urad: ac.normal_std_rad.map(|s| s * 1e6),
            point_mm: ac.centre.into(),
            point_std_um: ac.centre_std.map(|s| s * 1e3),
            radius_mm: ac.radius,
            rms_um: ac.rms * 1e3,
            condition: ac.condition,
        },
        poses: rows,
    })
}
