//! Bounds on the numbers a client gives, shared by the records (the module `model`) and
//! the API document's schemas, which both state them.

pub use mtcal_api::limits::MAX_TRAVEL_MM;
