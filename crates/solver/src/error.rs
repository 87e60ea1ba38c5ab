//! Errors of the solver. Numerical outcomes (rank deficiency, non-convergence) are data in
//! the result documents, not errors; an error here means the input cannot be solved at all.

/// Why a solver call could not produce a result.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SolverError {
    /// The input is structurally unusable (e.g. no samples, a plane with no travel).
    #[error("invalid input: {0}")]
    InvalidInput(String),
    /// The problem has fewer observations than unknowns or is otherwise degenerate.
    #[error("degenerate problem: {0}")]
    Degenerate(String),
    /// The caller's limits (size, iterations) were exceeded.
    #[error("limit exceeded: {0}")]
    Limit(String),
}
