//! # mtcal-domain
//!
//! The service's rules over stored results, below HTTP: what a fleet row holds and how
//! it is kept up to date ([`fleet`]), which tolerance profile applies and how a result
//! is judged against it ([`profiles`], [`verdicts`]), when a drift alert is raised and
//! where it is delivered ([`alerts`], [`webhooks`]), what follows a landed result
//! ([`landing`]), and the arithmetic of trends and differences over a machine's history
//! ([`trends`], [`history`]), the rules of a machine's fields ([`machines`]), and the
//! verification of a check against the predictions of the check before it
//! ([`verification`]).
//!
//! Layers: this crate reads and writes through [`mtcal_store::Store`] and computes with
//! [`mtcal_solver`] (result arithmetic, decision rule); it knows nothing of HTTP. The
//! server's API routes and dashboard pages (crates/server) only turn requests into calls
//! of these functions and their answers into JSON or pages. Its answers derive their
//! OpenAPI schema behind the feature `openapi` (derive only).
//!
//! Module order (each imports only those before it): [`kinds`], [`error`], [`paging`], [`blocking`],
//! [`trends`], [`history`], [`webhooks`], [`profiles`], [`verdicts`], [`alerts`],
//! [`fleet`], [`machines`], [`landing`], [`verification`].
#![deny(clippy::print_stdout, clippy::print_stderr)]

pub mod alerts;
pub mod blocking;
pub mod error;
pub mod fleet;
pub mod history;
pub mod kinds;
pub mod landing;
pub mod machines;
pub mod paging;
pub mod profiles;
pub mod trends;
pub mod verdicts;
pub mod verification;
pub mod webhooks;

pub use error::DomainError;
