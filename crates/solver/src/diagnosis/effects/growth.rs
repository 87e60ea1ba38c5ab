//! The effects table's entries of the effects that change during the session (their
//! model, columns and parameters in `diagnosis::catalogue::growth`): a servo lag, a
//! cyclic error, a reversal spike and a direction coupling whose principal parameter
//! drifts in time, v(t) = v̄ + g·(t − t̄)/3600.

use super::{EffectSpec, ParamSpec, p};

const CENTRE: ParamSpec = p(
    "centre_s",
    "s",
    "t-bar: the session time at which the constant finding reads its value, v(t-bar) = the finding's",
);

const DECIDE: &str = "a longer session, or runs of the same test early and late in it";

/// A servo lag that changes during the session.
pub const LAG: EffectSpec = EffectSpec {
    name: "servo_lag_growth",
    physics: "servo following error that changes during the session (a drive's gain or friction changing as it warms, a lubricant thinning): the lag drifts in time, a constant lag cannot follow it",
    params: &[
        p(
            "lag_growth_ms_per_h",
            "ms/h",
            "g > 0 when the lag grows: tau(t) = tau0 + g*t/3600 ms, error = -tau(t)*v, t the session time (s)",
        ),
        p(
            "lag_start_s",
            "s",
            "tau0 = tau(0), the lag at session time 0 (sign of servo_lag)",
        ),
        p("lag_end_s", "s", "tau(t_end), t_end the last sample's time"),
        CENTRE,
    ],
    principal: &["lag_growth_ms_per_h"],
    any_of: false,
    decide: DECIDE,
};

/// A cyclic error whose amplitude changes during the session.
pub const CYCLIC: EffectSpec = EffectSpec {
    name: "cyclic_growth",
    physics: "cyclic error whose amplitude changes during the session (a screw's or an encoder's periodic error growing with its temperature or preload): the amplitude drifts in time at the same period and phase",
    params: &[
        p(
            "amplitude_growth_um_per_h",
            "um/h",
            "g > 0 when the amplitude grows: A(t) = A0 + g*t/3600, error = A(t)*sin(2*pi*q/P + phase) at the cyclic finding's period and phase",
        ),
        p(
            "amplitude_start_um",
            "um",
            "A0 = A(0), the amplitude at session time 0",
        ),
        p(
            "amplitude_end_um",
            "um",
            "A(t_end), t_end the last sample's time",
        ),
        p("period_mm", "mm", "P, the cyclic finding's period"),
        p("phase_rad", "rad", "the cyclic finding's phase"),
        CENTRE,
    ],
    principal: &["amplitude_growth_um_per_h"],
    any_of: false,
    decide: DECIDE,
};

/// A reversal spike whose height changes during the session.
pub const SPIKE: EffectSpec = EffectSpec {
    name: "reversal_spike_growth",
    physics: "friction transient after an axis reversal whose height changes during the session (friction of the guideways or the seals changing as they warm or the lubricant spreads)",
    params: &[
        p(
            "height_growth_um_per_h",
            "um/h",
            "g > 0 when the height grows: h(t) = h0 + g*t/3600, error = -d*h(t)*exp(-s/lambda) at the spike finding's decay length",
        ),
        p(
            "height_start_um",
            "um",
            "h0 = h(0), the height at session time 0 (sign of reversal_spike)",
        ),
        p(
            "height_end_um",
            "um",
            "h(t_end), t_end the last sample's time",
        ),
        p("decay_mm", "mm", "lambda, the spike finding's decay length"),
        CENTRE,
    ],
    principal: &["height_growth_um_per_h"],
    any_of: false,
    decide: DECIDE,
};

/// A direction coupling whose shift changes during the session.
pub const COUPLING: EffectSpec = EffectSpec {
    name: "direction_coupling_growth",
    physics: "lateral play (an error across an axis that flips with its direction of travel) whose size changes during the session (a gib or a guideway's clearance opening or closing as it warms)",
    params: &[
        p(
            "shift_growth_um_per_h",
            "um/h",
            "g > 0 when the shift grows: s(t) = s0 + g*t/3600 at the coupling finding's take-up",
        ),
        p(
            "shift_start_um",
            "um",
            "s0 = s(0), the shift at session time 0 (sign of direction_coupling)",
        ),
        p(
            "shift_end_um",
            "um",
            "s(t_end), t_end the last sample's time",
        ),
        p("take_up_mm", "mm", "the coupling finding's take-up travel"),
        CENTRE,
    ],
    principal: &["shift_growth_um_per_h"],
    any_of: false,
    decide: DECIDE,
};
