//! Why a call failed: [`ClientError`].

use reqwest::StatusCode;

/// Why a call failed.
#[derive(Debug, thiserror::Error)]
pub enum ClientError {
    /// The service refused the request (`{"error": {"code", "message"}}`).
    #[error("service answered {status}: {message} ({code})")]
    Api {
        status: StatusCode,
        code: String,
        message: String,
    },
    /// The service could not be reached, or the answer could not be read.
    #[error("{context}: {source}")]
    Http {
        context: String,
        #[source]
        source: reqwest::Error,
    },
    /// A local input could not be read (files to upload).
    #[error("{0}")]
    Input(String),
    /// A job did not end in time.
    #[error("job {id} still {state} after {waited_s} s")]
    Timeout {
        id: String,
        state: String,
        waited_s: u64,
    },
}

impl ClientError {
    /// The HTTP status of a refusal.
    pub fn status(&self) -> Option<StatusCode> {
        match self {
            ClientError::Api { status, .. } => Some(*status),
            _ => None,
        }
    }

    /// The stable error code of a refusal.
    pub fn code(&self) -> Option<&str> {
        match self {
            ClientError::Api { code, .. } => Some(code),
            _ => None,
        }
    }
}

pub type Result<T, E = ClientError> = std::result::Result<T, E>;
