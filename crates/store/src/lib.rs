//! # mtcal-store
//!
//! Persistence for the mtcal service (placeholder: see the service issue).
