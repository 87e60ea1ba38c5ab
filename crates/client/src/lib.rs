//! # mtcal-client
//!
//! The typed HTTP client of the mtcal service: one method per operation of API v1, with
//! the request and response types of API v1 (`mtcal_api`, shared with the server), so
//! that a change of the API breaks its clients at compile time; it links neither the
//! server nor the store. Used by `mtcal submit`, the load generator and the end-to-end
//! tests.
//!
//! Every refusal of the service is a [`ClientError::Api`] with its status and the stable
//! error code of docs/api.md.

//!
//! Modules: [`error`] (why a call failed), [`files`] (what an upload of a path sends),
//! [`client`] (the calls).

pub mod client;
pub mod error;
pub mod files;

pub use client::{Client, Download};
pub use error::{ClientError, Result};
pub use files::{Files, files_to_upload, files_to_upload_in};
