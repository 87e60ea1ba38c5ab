//! A first diagnosis whose findings read a velocity: the session is diagnosed again
//! without the ramps' samples of those axes ([`super::diagnose_session_with_progress`]).

use super::{DiagnosisResult, Finding};

/// What [`super::diagnose_design`] gives: the diagnosis, or, from a first diagnosis (one that
/// keeps a record, [`super::seen`]) whose findings read a velocity, the axes whose velocity
/// they read ([`velocity_axes`]): the session is diagnosed again without the ramps'
/// samples of those axes, which reads nothing else of the first, so its report (the
/// final model's anomalies and misfit, the plots) is not formed.
// Returned once per diagnosis, at once taken apart: not worth a box.
#[allow(clippy::large_enum_variant)]
pub(super) enum Diagnosed {
    Done(DiagnosisResult),
    Again([bool; 3]),
}

impl Diagnosed {
    /// The diagnosis (a diagnosis that keeps no record always gives it).
    pub fn done(self) -> DiagnosisResult {
        match self {
            Diagnosed::Done(r) => r,
            Diagnosed::Again(_) => unreachable!("only a first diagnosis stops at its findings"),
        }
    }
}

/// Per axis, whether a finding or a possible finding among `found` reads its velocity
/// (a servo lag of the axis, a velocity coupling following it).
pub(super) fn velocity_axes<'f>(found: impl Iterator<Item = &'f Finding>) -> [bool; 3] {
    let mut axes = [false; 3];
    for f in found {
        let axis = match f.effect.as_str() {
            "servo_lag" => f.axis.as_deref(),
            "velocity_coupling" => f.depends_on.as_deref(),
            _ => None,
        };
        if let Some(a) = axis.and_then(crate::axis::Axis::parse) {
            axes[a.index()] = true;
        }
    }
    axes
}
