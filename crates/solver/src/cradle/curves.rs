//! The chosen model's A-dependent terms as functions of A with their standard
//! uncertainties.

use crate::cradle::identify;
use crate::cradle::model::{unit_of, unit_scale};
use crate::cradle::*;

/// Points per curve of [`compliance_curves`].
pub(super) const CURVE_POINTS: usize = 61;

/// The chosen model's A-dependent terms as functions of A over the measured A range, each
/// linear in its parameters q: value(A) = g(A)ᵀ·q, variance g(A)ᵀ·Σ·g(A).
pub(super) fn compliance_curves(
    fit: &identify::KinematicFit,
    poses: &[PoseRow],
) -> Vec<ComplianceCurve> {
    let spec = &fit.spec;
    let (lo, hi) = poses
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p.a_deg), hi.max(p.a_deg))
        });
    if hi.partial_cmp(&lo) != Some(std::cmp::Ordering::Greater) {
        return vec![];
    }
    let a_deg: Vec<f64> = (0..CURVE_POINTS)
        .map(|i| lo + (hi - lo) * i as f64 / (CURVE_POINTS - 1) as f64)
        .collect();
    let harmonic = |a: f64| {
        let (s, c) = a.sin_cos();
        vec![s, c - 1.0]
    };
    // (term, name, parameters, g(A) over them)
    type Basis = Box<dyn Fn(f64) -> Vec<f64>>;
    let mut rows: Vec<(Term, &str, Vec<&str>, Basis)> = vec![];
    if spec.a_harmonic {
        rows.push((
            Term::APositioning,
            "A positioning error: s_A·sin A + k_A·(cos A − 1)",
            vec!["s_A", "k_A"],
            Box::new(harmonic),
        ));
    }
    if spec.eaa_order > 0 {
        let order = spec.eaa_order.min(3);
        rows.push((
            Term::AEncoder,
            "A positioning error: EAA(A)",
            ["e_1", "e_2", "e_3"][..order].to_vec(),
            Box::new(move |a: f64| {
                let x = a / std::f64::consts::FRAC_PI_2;
                (1..=order as i32).map(|j| x.powi(j)).collect()
            }),
        ));
    }
    if spec.tilt != model::Tilt::None {
        // ρ_y = m_B·sin A − m_C·(cos A − 1), ρ_z = m_C·sin A + m_B·(cos A − 1).
        rows.push((
            Term::PivotTilt,
            "tilt about the pivot, Y: ρ_y(A)",
            vec!["m_B", "m_C"],
            Box::new(|a: f64| {
                let (s, c) = a.sin_cos();
                vec![s, 1.0 - c]
            }),
        ));
        rows.push((
            Term::PivotTilt,
            "tilt about the pivot, Z: ρ_z(A)",
            vec!["m_B", "m_C"],
            Box::new(|a: f64| {
                let (s, c) = a.sin_cos();
                vec![c - 1.0, s]
            }),
        ));
    }
    for (on, term, name, params) in [
        (
            spec.mount_x,
            Term::MountX,
            "tilt about the mount, X: τ_X(A)",
            ["tX_s", "tX_c"],
        ),
        (
            spec.mount_y,
            Term::MountY,
            "tilt about the mount, Y: τ_Y(A)",
            ["tY_s", "tY_c"],
        ),
        (
            spec.axial,
            Term::Axial,
            "shift along A: t_X(A)",
            ["e_s", "e_c"],
        ),
        (
            spec.lateral,
            Term::Lateral,
            "sideways shift: t_Y(A)",
            ["y_s", "y_c"],
        ),
    ] {
        if on {
            rows.push((term, name, params.to_vec(), Box::new(harmonic)));
        }
    }
    rows.into_iter()
        .filter_map(|(term, name, params, g)| {
            let idx: Vec<usize> = params
                .iter()
                .map(|p| spec.index(p))
                .collect::<Option<Vec<usize>>>()?;
            let scale = unit_scale(params[0]);
            let (mut value, mut std) = (vec![], vec![]);
            for &a in &a_deg {
                let gv = g(a.to_radians());
                let v: f64 = idx.iter().zip(&gv).map(|(&k, g)| g * fit.q[k]).sum();
                let mut var = 0.0;
                for (i, &ki) in idx.iter().enumerate() {
                    for (j, &kj) in idx.iter().enumerate() {
                        var += gv[i] * fit.cov[(ki, kj)] * gv[j];
                    }
                }
                value.push(v * scale);
                std.push(var.max(0.0).sqrt() * scale);
            }
            Some(ComplianceCurve {
                term,
                name: name.into(),
                unit: unit_of(params[0]).into(),
                a_deg: a_deg.clone(),
                value,
                std,
            })
        })
        .collect()
}
