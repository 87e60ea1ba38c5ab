//! Kinematic model of a 3-axis machine (kinematics contract, "Error motions: exact model").
//!
//! Errors are in the **tool-relative-to-workpiece sense**. For axis k at position q:
//!
//! * translational error δ_k(q) = (E_Xk, E_Yk, E_Zk), angular error ε_k(q) = (E_Ak, E_Bk, E_Ck);
//! * error HTM E_k(q) = Trans(δ_k) · Rx(E_Ak) · Ry(E_Bk) · Rz(E_Ck);
//! * nominal directions with squareness: u_X = (1, 0, 0), u_Y = Rz(EC0Y)·(0, 1, 0),
//!   u_Z = Ry(EB0Z)·Rx(EA0Z)·(0, 0, 1);
//! * tool side, bed outward: T_t = Π_k [Trans(q_k u_k) · E_k(q_k)];
//! * workpiece side, bed outward: T_w = Π_k [Trans(−q_k u_k) · E_k(q_k)⁻¹];
//! * tool point in the workpiece frame for tool offset t: p = T_w⁻¹ · T_t · t;
//!   nominal p₀ = q + t; volumetric error e = p − p₀.
//!
//! [`exact_error_um`] evaluates that chain (what simulation uses). [`linear_error_um`] is
//! its first-order form (what identification solves):
//!
//! e ≈ Σ_k [δ_k(q_k) + ε_k(q_k) × a_k] + (−EC0Y·y + EB0Z·z, −EA0Z·z, 0),
//!
//! with the Abbe arm a_k of [`abbe_arm_mm`].

use crate::axis::{Axis, Topology};
use crate::terms::{Component, Squareness, Term};
use nalgebra::{Matrix3, Matrix4, Vector3, Vector4};
use serde::{Deserialize, Serialize};

/// The six motion errors of one axis at one position.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct MotionErrors {
    /// δ = (E_X·, E_Y·, E_Z·), µm.
    pub translation_um: [f64; 3],
    /// ε = (E_A·, E_B·, E_C·), µrad.
    pub rotation_urad: [f64; 3],
}

impl MotionErrors {
    /// The value of one component (µm or µrad).
    pub fn component(&self, c: Component) -> f64 {
        match c {
            Component::Translation(d) => self.translation_um[d.index()],
            Component::Rotation(d) => self.rotation_urad[d.index()],
        }
    }

    pub fn component_mut(&mut self, c: Component) -> &mut f64 {
        match c {
            Component::Translation(d) => &mut self.translation_um[d.index()],
            Component::Rotation(d) => &mut self.rotation_urad[d.index()],
        }
    }
}

/// Anything that gives a machine's geometric errors: the truth of a simulation, an
/// identified model, a tolerance budget.
pub trait ErrorSource {
    /// Motion errors of `axis` at commanded position `q_mm`.
    fn motion(&self, axis: Axis, q_mm: f64) -> MotionErrors;
    /// Squareness constants (µrad).
    fn squareness(&self) -> Squareness;
}

/// Error functions given as closures of (term, position) — convenient for tests and for
/// wrapping other representations.
pub struct FnErrors<F: Fn(Term, f64) -> f64> {
    pub f: F,
    pub squareness: Squareness,
}

impl<F: Fn(Term, f64) -> f64> ErrorSource for FnErrors<F> {
    fn motion(&self, axis: Axis, q_mm: f64) -> MotionErrors {
        let mut m = MotionErrors::default();
        for d in Axis::ALL {
            m.translation_um[d.index()] = (self.f)(
                Term {
                    axis,
                    component: Component::Translation(d),
                },
                q_mm,
            );
            m.rotation_urad[d.index()] = (self.f)(
                Term {
                    axis,
                    component: Component::Rotation(d),
                },
                q_mm,
            );
        }
        m
    }

    fn squareness(&self) -> Squareness {
        self.squareness
    }
}

/// A perfect machine.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoErrors;

impl ErrorSource for NoErrors {
    fn motion(&self, _axis: Axis, _q_mm: f64) -> MotionErrors {
        MotionErrors::default()
    }
    fn squareness(&self) -> Squareness {
        Squareness::default()
    }
}

/// Right-hand rotation about X by `a` rad.
pub fn rot_x(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c)
}

/// Right-hand rotation about Y by `b` rad.
pub fn rot_y(b: f64) -> Matrix3<f64> {
    let (s, c) = b.sin_cos();
    Matrix3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c)
}

/// Right-hand rotation about Z by `c` rad.
pub fn rot_z(c: f64) -> Matrix3<f64> {
    let (s, co) = c.sin_cos();
    Matrix3::new(co, -s, 0.0, s, co, 0.0, 0.0, 0.0, 1.0)
}

fn htm(r: Matrix3<f64>, p: Vector3<f64>) -> Matrix4<f64> {
    let mut m = Matrix4::identity();
    m.fixed_view_mut::<3, 3>(0, 0).copy_from(&r);
    m.fixed_view_mut::<3, 1>(0, 3).copy_from(&p);
    m
}

/// Inverse of a rigid HTM: [Rᵀ, −Rᵀp].
fn htm_inv(m: &Matrix4<f64>) -> Matrix4<f64> {
    let rt = m.fixed_view::<3, 3>(0, 0).transpose();
    let p = m.fixed_view::<3, 1>(0, 3).into_owned();
    htm(rt, -(rt * p))
}

/// Nominal direction u_k of an axis including squareness (contract: u_X = (1, 0, 0),
/// u_Y = Rz(EC0Y)·ŷ, u_Z = Ry(EB0Z)·Rx(EA0Z)·ẑ).
pub fn axis_direction(axis: Axis, sq: &Squareness) -> Vector3<f64> {
    match axis {
        Axis::X => Vector3::x(),
        Axis::Y => rot_z(sq.ec0y_urad * 1e-6) * Vector3::y(),
        Axis::Z => rot_y(sq.eb0z_urad * 1e-6) * rot_x(sq.ea0z_urad * 1e-6) * Vector3::z(),
    }
}

/// Error HTM E_k = Trans(δ) · Rx(E_A) · Ry(E_B) · Rz(E_C), in mm and rad.
pub fn error_htm(m: &MotionErrors) -> Matrix4<f64> {
    let d = Vector3::from(m.translation_um) * 1e-3;
    let [a, b, c] = m.rotation_urad.map(|v| v * 1e-6);
    htm(rot_x(a) * rot_y(b) * rot_z(c), d)
}

/// Actual tool point p = T_w⁻¹ · T_t · t in the workpiece frame, mm, by the exact HTM chain.
pub fn exact_tool_point_mm(
    topology: &Topology,
    errors: &dyn ErrorSource,
    q_mm: [f64; 3],
    t_mm: [f64; 3],
) -> Vector3<f64> {
    let sq = errors.squareness();
    let mut t_tool = Matrix4::identity();
    for &k in &topology.tool {
        let q = q_mm[k.index()];
        t_tool *= htm(Matrix3::identity(), axis_direction(k, &sq) * q);
        t_tool *= error_htm(&errors.motion(k, q));
    }
    let mut t_work = Matrix4::identity();
    for &k in &topology.workpiece {
        let q = q_mm[k.index()];
        t_work *= htm(Matrix3::identity(), -axis_direction(k, &sq) * q);
        t_work *= htm_inv(&error_htm(&errors.motion(k, q)));
    }
    let p = htm_inv(&t_work) * t_tool * Vector4::new(t_mm[0], t_mm[1], t_mm[2], 1.0);
    Vector3::new(p.x, p.y, p.z)
}

/// Volumetric error e = p − (q + t), µm, by the exact HTM chain.
pub fn exact_error_um(
    topology: &Topology,
    errors: &dyn ErrorSource,
    q_mm: [f64; 3],
    t_mm: [f64; 3],
) -> Vector3<f64> {
    let p = exact_tool_point_mm(topology, errors, q_mm, t_mm);
    (p - Vector3::from(q_mm) - Vector3::from(t_mm)) * 1e3
}

/// Abbe arm a_k (mm) from axis k's frame origin to the tool point, nominal geometry.
///
/// Tool-side axis: t plus the displacements of the tool-side axes stacked on k (outboard,
/// exclusive of k). Workpiece-side axis: t plus the displacements of all tool-side axes
/// and of the workpiece-side axes from the bed up to and including k. Default topology:
/// a_Y = q + t, a_X = (x, 0, z) + t, a_Z = t.
pub fn abbe_arm_mm(
    topology: &Topology,
    axis: Axis,
    q_mm: [f64; 3],
    t_mm: [f64; 3],
) -> Vector3<f64> {
    let mut arm = Vector3::from(t_mm);
    let add = |arm: &mut Vector3<f64>, k: Axis| arm[k.index()] += q_mm[k.index()];
    if let Some(pos) = topology.tool.iter().position(|&k| k == axis) {
        for &k in &topology.tool[pos + 1..] {
            add(&mut arm, k);
        }
    } else if let Some(pos) = topology.workpiece.iter().position(|&k| k == axis) {
        for &k in &topology.tool {
            add(&mut arm, k);
        }
        for &k in &topology.workpiece[..=pos] {
            add(&mut arm, k);
        }
    }
    arm
}

/// First-order sensitivity (µm per unit of the term: µm/µm or µm/µrad) of the volumetric
/// error to motion-error component `c` of `axis`, at commanded position q and offset t.
///
/// Translation along d: the unit vector d. Rotation about d: d × a_k · 10⁻³.
pub fn term_gradient(
    topology: &Topology,
    axis: Axis,
    c: Component,
    q_mm: [f64; 3],
    t_mm: [f64; 3],
) -> Vector3<f64> {
    match c {
        Component::Translation(d) => {
            let mut g = Vector3::zeros();
            g[d.index()] = 1.0;
            g
        }
        Component::Rotation(d) => {
            let mut u = Vector3::zeros();
            u[d.index()] = 1.0;
            u.cross(&abbe_arm_mm(topology, axis, q_mm, t_mm)) * 1e-3
        }
    }
}

/// First-order sensitivity (µm/µrad) of the volumetric error to the squareness constants
/// (EC0Y, EB0Z, EA0Z): columns (−y, 0, 0), (z, 0, 0), (0, −z, 0), times 10⁻³.
pub fn squareness_gradient(q_mm: [f64; 3]) -> [Vector3<f64>; 3] {
    let [_, y, z] = q_mm;
    [
        Vector3::new(-y, 0.0, 0.0) * 1e-3,
        Vector3::new(z, 0.0, 0.0) * 1e-3,
        Vector3::new(0.0, -z, 0.0) * 1e-3,
    ]
}

/// Volumetric error (µm) of the linearised model:
/// e = Σ_k [δ_k + ε_k × a_k] + squareness terms.
pub fn linear_error_um(
    topology: &Topology,
    errors: &dyn ErrorSource,
    q_mm: [f64; 3],
    t_mm: [f64; 3],
) -> Vector3<f64> {
    let mut e = Vector3::zeros();
    for axis in Axis::ALL {
        let m = errors.motion(axis, q_mm[axis.index()]);
        e += Vector3::from(m.translation_um);
        let arm = abbe_arm_mm(topology, axis, q_mm, t_mm);
        e += Vector3::from(m.rotation_urad).cross(&arm) * 1e-3;
    }
    let sq = errors.squareness();
    let g = squareness_gradient(q_mm);
    e + g[0] * sq.ec0y_urad + g[1] * sq.eb0z_urad + g[2] * sq.ea0z_urad
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::terms::SquarenessTerm;

    fn topologies() -> Vec<Topology> {
        use Axis::*;
        vec![
            Topology::default(),
            Topology {
                workpiece: vec![],
                tool: vec![X, Y, Z],
            },
            Topology {
                workpiece: vec![Y],
                tool: vec![X, Z],
            },
            Topology {
                workpiece: vec![X, Y, Z],
                tool: vec![],
            },
            Topology {
                workpiece: vec![Z, X],
                tool: vec![Y],
            },
        ]
    }

    const Q: [f64; 3] = [230.0, -140.0, 310.0];
    const T: [f64; 3] = [40.0, -15.0, -100.0];

    /// Every one of the 21 terms alone: the exact chain and the linear model agree to
    /// first order (difference is second order: ≤ 1e-3 µm for a 10-unit error over
    /// arms of a few hundred mm, while the first-order effect is several µm).
    #[test]
    fn exact_chain_equals_linear_model_to_first_order_for_each_term() {
        for topo in topologies() {
            for term in Term::all() {
                let src = FnErrors {
                    f: move |tm: Term, q: f64| {
                        if tm == term {
                            10.0 * (q / 300.0) + 3.0
                        } else {
                            0.0
                        }
                    },
                    squareness: Squareness::default(),
                };
                let ex = exact_error_um(&topo, &src, Q, T);
                let li = linear_error_um(&topo, &src, Q, T);
                assert!(
                    li.norm() > 0.05,
                    "{term} has no first-order effect in {topo:?}"
                );
                assert!(
                    (ex - li).norm() < 1e-3,
                    "{term} {topo:?}: exact {ex:?} linear {li:?}"
                );
            }
            for s in SquarenessTerm::ALL {
                let mut sq = Squareness::default();
                match s {
                    SquarenessTerm::EC0Y => sq.ec0y_urad = 25.0,
                    SquarenessTerm::EB0Z => sq.eb0z_urad = 25.0,
                    SquarenessTerm::EA0Z => sq.ea0z_urad = 25.0,
                }
                let src = FnErrors {
                    f: |_: Term, _: f64| 0.0,
                    squareness: sq,
                };
                let ex = exact_error_um(&topo, &src, Q, T);
                let li = linear_error_um(&topo, &src, Q, T);
                assert!(li.norm() > 1.0);
                assert!((ex - li).norm() < 1e-3, "{s:?}: exact {ex:?} linear {li:?}");
            }
        }
    }

    /// The second-order remainder shrinks quadratically: halving every error quarters the
    /// exact-minus-linear difference (all 21 terms active at once).
    #[test]
    fn remainder_is_second_order() {
        let topo = Topology::default();
        let make = |scale: f64| FnErrors {
            f: move |tm: Term, q: f64| {
                scale * (1.0 + tm.name().len() as f64) * (q / 100.0 + (q / 70.0).powi(2))
            },
            squareness: Squareness {
                ec0y_urad: 20.0 * scale,
                eb0z_urad: -15.0 * scale,
                ea0z_urad: 9.0 * scale,
            },
        };
        let d = |s: f64| {
            let src = make(s);
            (exact_error_um(&topo, &src, Q, T) - linear_error_um(&topo, &src, Q, T)).norm()
        };
        let (d1, d2) = (d(40.0), d(20.0));
        let ratio = d1 / d2;
        assert!(
            (ratio - 4.0).abs() < 0.05,
            "remainder ratio {ratio}, d1 {d1} d2 {d2}"
        );
    }

    /// Hand-derived cases in the default topology (workpiece [X, Y], tool [Z]).
    #[test]
    fn textbook_cases_default_topology() {
        let topo = Topology::default();
        let one = |name: &'static str, v: f64| FnErrors {
            f: move |tm: Term, _q: f64| if tm.name() == name { v } else { 0.0 },
            squareness: Squareness::default(),
        };
        // Pitch of Y about X (EAY = ε): e = ε × (q + t) = (0, −ε(z+tz), ε(y+ty)).
        let e = exact_error_um(&topo, &one("EAY", 10.0), Q, T);
        let (y, z) = (Q[1] + T[1], Q[2] + T[2]);
        assert!((e - Vector3::new(0.0, -10e-3 * z, 10e-3 * y)).norm() < 1e-4);
        // Yaw of Z (tool side) acts on t only: ECZ = ε gives ε × t.
        let e = exact_error_um(&topo, &one("ECZ", 10.0), Q, T);
        assert!((e - Vector3::new(-10e-3 * T[1], 10e-3 * T[0], 0.0)).norm() < 1e-4);
        // Positioning error of a workpiece-side axis adds directly, in the tool sense.
        let e = exact_error_um(&topo, &one("EXX", 4.0), Q, T);
        assert!((e - Vector3::new(4.0, 0.0, 0.0)).norm() < 1e-9);
        // EC0Y > 0 opens the X–Y angle: +y travel shifts the tool toward −X.
        let src = FnErrors {
            f: |_: Term, _: f64| 0.0,
            squareness: Squareness {
                ec0y_urad: 100.0,
                ..Default::default()
            },
        };
        let e = exact_error_um(&topo, &src, [0.0, 100.0, 0.0], [0.0; 3]);
        assert!((e.x + 10.0).abs() < 1e-6 && e.y.abs() < 1e-3);
    }

    #[test]
    fn abbe_arms_match_contract_example() {
        let topo = Topology::default();
        let q = [1.0, 2.0, 3.0];
        let t = [0.0, 0.0, -100.0];
        assert_eq!(
            abbe_arm_mm(&topo, Axis::Y, q, t),
            Vector3::new(1.0, 2.0, -97.0)
        );
        assert_eq!(
            abbe_arm_mm(&topo, Axis::X, q, t),
            Vector3::new(1.0, 0.0, -97.0)
        );
        assert_eq!(
            abbe_arm_mm(&topo, Axis::Z, q, t),
            Vector3::new(0.0, 0.0, -100.0)
        );
    }
}
