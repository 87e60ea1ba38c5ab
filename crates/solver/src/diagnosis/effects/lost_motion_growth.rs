//! The effects table's entry of a lost motion that changes during the session
//! (`backlash_growth`: its model, columns and parameters in
//! `diagnosis::catalogue::lost_motion_growth`).

use super::{EffectSpec, p};

/// The effects table's entry ([`super::EFFECTS`]).
pub const SPEC: EffectSpec = EffectSpec {
    name: "backlash_growth",
    physics: "lost motion at direction reversal that changes during the session (a screw and nut warming up, wearing in or losing their preload while the machine works): the play's width drifts in time, a constant backlash cannot follow it",
    params: &[
        p(
            "growth_um_per_h",
            "um/h",
            "g > 0 when the lost motion grows: b(t) = b0 + g*t/3600, error = -d*b(t)/2, t the session time (s)",
        ),
        p(
            "lost_motion_start_um",
            "um",
            "b0 = b(0), the lost motion at session time 0 (sign of backlash: b > 0 when the axis stops short in the direction of travel)",
        ),
        p(
            "lost_motion_end_um",
            "um",
            "b(t_end), t_end the last sample's time",
        ),
        p(
            "centre_s",
            "s",
            "t-bar: the session time at which the axis's backlash finding reads the lost motion, b(t-bar) = its lost_motion_um",
        ),
    ],
    principal: &["growth_um_per_h"],
    any_of: false,
    decide: "a longer session, or runs that reverse the axis early and late in it",
};
