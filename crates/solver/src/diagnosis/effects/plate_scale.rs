//! The effects table's entry of a grid plate's scale per mounting (`plate_scale`: its
//! model, columns and what the data separate in `diagnosis::catalogue::plate_scale`).

use super::{EffectSpec, p};

/// The effects table's entry ([`super::EFFECTS`]).
pub const SPEC: EffectSpec = EffectSpec {
    name: "plate_scale",
    physics: "the grid plate of one mounting reads both its coordinates longer or shorter than its certificate (the plate at another temperature than its certificate's, or a wrong certificate): unlike an axis's scale, which acts on that axis in every plane that reads it, it scales the two readings of its own mounting alike; a scale common to every mounting is not told from the axes' scales",
    params: &[
        p(
            "scale_ppm",
            "ppm",
            "s > 0 when the plate reads long: du = s*u*1e-3, dv = s*v*1e-3 (um; u, v the in-plane position plus head offset, mm), relative to the mountings with no plate scale in the model (the finding's signature names them)",
        ),
        p(
            "temperature_offset_k",
            "K",
            "dT = s/alpha, alpha the plate's expansion coefficient the session states: > 0 for a plate warmer than its certificate (only when the session states alpha)",
        ),
    ],
    principal: &["scale_ppm"],
    any_of: false,
    decide: "the plate mounted again in another plane that shares an axis with this one, or its temperature logged",
};
