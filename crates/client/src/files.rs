//! The files an upload of a path on disk sends, read first with the service's own reader.

use crate::error::{ClientError, Result};
use mtcal_formats::CsvDialect;
use std::path::Path;

/// Files as uploaded: (name, bytes).
pub type Files = Vec<(String, Vec<u8>)>;

/// The files of a dataset on disk that an upload sends: those the service's reader reads
/// (files a session ignores are left out), in the order read.
pub fn files_to_upload(path: &Path) -> Result<Files> {
    files_to_upload_in(path, CsvDialect::Plain)
}

/// [`files_to_upload`] with CSV files written in `dialect`.
pub fn files_to_upload_in(path: &Path, dialect: CsvDialect) -> Result<Files> {
    let limits = mtcal_formats::Limits::default().with_dialect(dialect);
    let dataset =
        mtcal_formats::read_path(path, &limits).map_err(|e| ClientError::Input(e.to_string()))?;
    let read = |p: &Path| {
        std::fs::read(p).map_err(|e| ClientError::Input(format!("{}: {e}", p.display())))
    };
    let mut files: Files =
        if !path.is_dir() && mtcal_formats::is_archive_name(&path.to_string_lossy()) {
            let name = path.file_name().unwrap_or_default().to_string_lossy();
            mtcal_formats::read_archive(&name, &read(path)?, &limits)
                .map_err(|e| ClientError::Input(e.to_string()))?
        } else {
            // The files read sit in the folder, or beside the file given.
            let dir = if path.is_dir() {
                path
            } else {
                path.parent().unwrap_or(Path::new("."))
            };
            dataset
                .files
                .iter()
                .map(|n| read(&dir.join(n)).map(|b| (n.clone(), b)))
                .collect::<Result<_>>()?
        };
    files.retain(|(n, _)| dataset.files.contains(n));
    Ok(files)
}
