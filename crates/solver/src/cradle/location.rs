//! The ISO 230-7 location errors of the fitted model, with their observability from
//! ball data and the kinematic summary.

use crate::cradle::identify;
use crate::cradle::*;

pub(super) fn summary(
    fit: &identify::KinematicFit,
    held: Option<&[identify::HeldOut]>,
) -> KinematicSummary {
    KinematicSummary {
        model: if fit.spec.is_rigid() {
            Dependence::Rigid
        } else {
            Dependence::Compliant
        },
        spec: fit.spec,
        description: fit.spec.describe(),
        n_params: fit.q.len(),
        rank: fit.rank,
        condition: fit.condition,
        fit_rms_um: fit.rms * 1e3,
        sigma_um: fit.sigma * 1e3,
        held_out_rms_um: held.map(|h| held_rms(h) * 1e3),
        converged: fit.converged,
        iterations: fit.iterations,
    }
}

pub(super) fn location_reports(
    fit: &identify::KinematicFit,
    registered: bool,
) -> Vec<LocationErrorReport> {
    // (name, parameter index, scale to report unit, unit, observability, note)
    type Row<'a> = (
        &'a str,
        Option<usize>,
        f64,
        &'a str,
        Observability,
        Option<&'a str>,
    );
    let rows: [Row; 11] = [
        (
            "EY0A",
            Some(0),
            1e3,
            "um",
            Observability::RegisteredFrame,
            None,
        ),
        (
            "EZ0A",
            Some(1),
            1e3,
            "um",
            Observability::RegisteredFrame,
            None,
        ),
        (
            "EB0A",
            Some(2),
            1e6,
            "urad",
            Observability::RegisteredFrame,
            None,
        ),
        (
            "EC0A",
            Some(3),
            1e6,
            "urad",
            Observability::RegisteredFrame,
            None,
        ),
        (
            "EX0C",
            Some(5),
            1e3,
            "um",
            Observability::RegisteredFrame,
            None,
        ),
        (
            "EY0C",
            Some(6),
            1e3,
            "um",
            Observability::Intrinsic,
            Some("offset of the C axis from the A axis"),
        ),
        (
            "EB0C",
            Some(7),
            1e6,
            "urad",
            Observability::Intrinsic,
            Some("squareness of C to A"),
        ),
        (
            "EA0A+EA0C",
            Some(4),
            1e6,
            "urad",
            Observability::RegisteredFrame,
            Some(
                "EA0A and EA0C both turn the table about the A axis: only their sum is observable",
            ),
        ),
        (
            "EA0A",
            None,
            1e6,
            "urad",
            Observability::NotObservable,
            Some("not separable from EA0C; see EA0A+EA0C"),
        ),
        (
            "EA0C",
            None,
            1e6,
            "urad",
            Observability::NotObservable,
            Some("not separable from EA0A; see EA0A+EA0C"),
        ),
        (
            "EC0C",
            None,
            1e6,
            "urad",
            Observability::NotObservable,
            Some(
                "identical in effect to the ball's unknown azimuth on the table (carried by the ball azimuth)",
            ),
        ),
    ];
    rows.iter()
        .map(|(name, idx, scale, unit, obs, note)| {
            let known = match obs {
                Observability::Intrinsic => true,
                Observability::RegisteredFrame => registered,
                Observability::NotObservable => false,
            };
            let (value, std) = match (idx, known) {
                (Some(k), true) => (
                    Some(fit.q[*k] * scale),
                    Some(fit.cov[(*k, *k)].sqrt() * scale),
                ),
                _ => (None, None),
            };
            let note = match (obs, registered) {
                (Observability::RegisteredFrame, false) => {
                    Some("needs the instrument frame registered to the machine axes".to_string())
                }
                _ => note.map(str::to_string),
            };
            LocationErrorReport {
                name: name.to_string(),
                unit: unit.to_string(),
                value,
                std,
                observability: *obs,
                note,
            }
        })
        .collect()
}

/// An angle for reports: µrad when small, degrees otherwise.
pub fn angle_text(rad: f64) -> String {
    if rad.abs() < 1e-2 {
        format!("{:.0} µrad", rad * 1e6)
    } else {
        format!("{:.3}°", rad.to_degrees())
    }
}
