//! The blocking pool of the domain ([`mtcal_domain::blocking`]), answering a failure as
//! an internal error of the API.

pub use mtcal_domain::blocking::{Failed, run};

impl From<Failed> for crate::ApiError {
    fn from(f: Failed) -> crate::ApiError {
        crate::ApiError::Internal(f.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A panic in the work is an internal error (a JSON 500), not a dropped connection.
    #[tokio::test]
    async fn a_panic_is_an_internal_error() {
        assert_eq!(run::<_, crate::ApiError>(|| 6 * 7).await.unwrap(), 42);
        let e = run::<(), crate::ApiError>(|| panic!("arithmetic went wrong"))
            .await
            .unwrap_err();
        assert!(matches!(e, crate::ApiError::Internal(_)), "{e:?}");
    }
}
