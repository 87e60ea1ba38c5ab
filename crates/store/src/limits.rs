//! Bounds on the numbers a client gives, shared by the records (the module `model`) and
//! the API document's schemas (the module `schemas`), which both state them.

/// Largest |travel end| of a machine accepted, mm (100 m: beyond any machine tool's axis).
pub const MAX_TRAVEL_MM: f64 = 100_000.0;
