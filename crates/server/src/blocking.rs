//! Work that must not hold an async thread: parsing an upload, and result arithmetic
//! over stored results (differences, term trends, fleet rows, verdicts, compensation
//! tables, reports). Its cost grows with a request's parameters and a machine's history
//! (bounded by caps, still milliseconds to seconds), so it runs on tokio's blocking
//! pool: the async threads keep answering other requests meanwhile. A panic there is
//! answered as an internal error instead of taking the connection down.

use mtcal_store::StoreError;

/// Blocking work that did not finish: it panicked, or the runtime is shutting down.
#[derive(Debug)]
pub struct Failed(String);

impl From<Failed> for crate::ApiError {
    fn from(f: Failed) -> crate::ApiError {
        crate::ApiError::Internal(f.0)
    }
}

impl From<Failed> for StoreError {
    fn from(f: Failed) -> StoreError {
        StoreError::Backend(f.0)
    }
}

/// Runs `f` on the blocking pool and returns its value; the error type is the caller's
/// (an API or a store error).
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

    /// The value comes back; a panic in the work is an internal error (a JSON 500), not a
    /// dropped connection.
    #[tokio::test]
    async fn values_come_back_and_a_panic_is_an_internal_error() {
        assert_eq!(run::<_, crate::ApiError>(|| 6 * 7).await.unwrap(), 42);
        let e = run::<(), crate::ApiError>(|| panic!("arithmetic went wrong"))
            .await
            .unwrap_err();
        assert!(matches!(e, crate::ApiError::Internal(_)), "{e:?}");
    }
}
