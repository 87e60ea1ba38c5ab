//! Uploads over HTTP, translated: the files of a request (multipart parts, or the entries
//! of one archive) are read by `mtcal_formats::upload` — the reader the CLI uses, so both
//! accept and refuse the same inputs — and its errors become HTTP errors (a size limit
//! 413, anything else 422 naming file, line, column and rule).

use crate::error::ApiError;
use mtcal_formats::FormatError;

pub use mtcal_formats::{Dataset, DatasetData};

/// Upload limits: the readers' limits (datasets contract defaults: 5 million samples per
/// file, 256 MiB per upload, 1000 files).
pub type UploadLimits = mtcal_formats::Limits;

impl From<FormatError> for ApiError {
    fn from(e: FormatError) -> ApiError {
        if e.is_limit() {
            ApiError::PayloadTooLarge(e.to_string())
        } else {
            ApiError::InvalidDataset(e.to_string())
        }
    }
}

/// The files of a `.tar.gz` (or plain `.tar`) request body (`name` as the archive's in
/// messages).
pub fn untar(
    name: &str,
    bytes: &[u8],
    limits: &UploadLimits,
) -> Result<Vec<(String, Vec<u8>)>, ApiError> {
    Ok(mtcal_formats::read_archive(name, bytes, limits)?)
}

/// Reads the files of an upload; blocking (parsing), call it off the async threads.
pub fn read_dataset(
    files: &[(String, Vec<u8>)],
    limits: &UploadLimits,
) -> Result<Dataset, ApiError> {
    Ok(mtcal_formats::read_upload(files, limits)?)
}
