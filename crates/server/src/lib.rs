//! # mtcal-server
//!
//! The HTTP API and the job worker (placeholder: see the service issue).
