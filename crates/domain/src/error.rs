//! What a rule of the domain can refuse or fail with; the server maps each to its status
//! and stable code in one place (crates/server/src/error.rs).

use mtcal_store::StoreError;

#[derive(Debug, thiserror::Error)]
pub enum DomainError {
    /// The store refused or failed (not found, conflict, backend).
    #[error(transparent)]
    Store(#[from] StoreError),
    /// A request the rules refuse (the message names the field and the rule).
    #[error("{0}")]
    Invalid(String),
    /// Something named does not exist (the message names it).
    #[error("{0}")]
    NotFound(String),
    /// Something named belongs elsewhere (e.g. a result of another machine).
    #[error("{0}")]
    Conflict(String),
    /// A position outside the travel the checks measured (nothing is extrapolated).
    #[error("{0}")]
    OutsideTravel(String),
    /// Work that did not finish (a panic on the blocking pool, a shutdown).
    #[error("{0}")]
    Internal(String),
}
