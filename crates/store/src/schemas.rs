//! The JSON Schemas of the machine fields and one-line text fields, kept with the API
//! types (see `mtcal_api::schemas`).

pub use mtcal_api::schemas::*;
