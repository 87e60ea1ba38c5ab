//! Work that must not hold an async thread: result arithmetic over stored results
//! (differences, term trends, fleet rows, verdicts) and, in the server, parsing an
//! upload, compensation tables and reports. Its cost grows with a request's parameters
//! and a machine's history (bounded by caps, still milliseconds to seconds), so it runs
//! on tokio's blocking pool: the async threads keep answering other requests meanwhile.
//! A panic there is answered as an internal error instead of taking the connection down.

use crate::error::DomainError;
use mtcal_store::StoreError;

/// Blocking work that did not finish: it panicked, or the runtime is shutting down.
#[derive(Debug)]
pub struct Failed(pub String);

impl From<Failed> for StoreError {
    fn from(f: Failed) -> StoreError {
        StoreError::Backend(f.0)
    }
}

impl From<Failed> for DomainError {
    fn from(f: Failed) -> DomainError {
        DomainError::Internal(f.0)
    }
}

/// Runs `f` on the blocking pool and returns its value; the error type is the caller's
/// (a domain, store or API error).
pub async fn run<T, E>(f: impl FnOnce() -> T + Send + 'static) -> Result<T, E>
where
    T: Send + 'static,
    E: From<Failed>,
{
    tokio::task::spawn_blocking(f)
        .await
        .map_err(|e| Failed(format!("blocking work did not finish: {e}")).into())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The value comes back; a panic in the work is an internal error, not a dropped
    /// connection.
    #[tokio::test]
    async fn values_come_back_and_a_panic_is_an_internal_error() {
        assert_eq!(run::<_, DomainError>(|| 6 * 7).await.unwrap(), 42);
        let e = run::<(), DomainError>(|| panic!("arithmetic went wrong"))
            .await
            .unwrap_err();
        assert!(matches!(e, DomainError::Internal(_)), "{e:?}");
    }
}
