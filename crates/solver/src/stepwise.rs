//! The seed patent's stepwise method (CN101982726): lines → the 12 translational terms,
//! circles → the 9 angular terms (implementation in progress).

use crate::design::ErrorModel;
use crate::error::SolverError;
use crate::identification::{IdentificationResult, IdentifyOptions};
use crate::session::Session;

/// Stepwise identification.
pub fn identify(
    _session: &Session,
    _model: &ErrorModel,
    _opts: &IdentifyOptions,
) -> Result<IdentificationResult, SolverError> {
    Err(SolverError::InvalidInput(
        "the stepwise method is not implemented yet; use --method joint".into(),
    ))
}
