//! Uploads: the files of a measurement session (multipart or one .tar.gz), checked
//! completely before anything is stored.
//!
//! The bytes are kept exactly as uploaded (gzip included); parsing works on the
//! decompressed text. Session parsing is the strict reader of `mtcal-formats`
//! ([`read_session`]).

use crate::error::ApiError;
use flate2::read::GzDecoder;
use mtcal_solver::session::Session;
use std::collections::BTreeMap;
use std::io::Read;

/// Upload limits (datasets contract defaults: 5 million samples per file, 256 MiB per
/// upload).
#[derive(Debug, Clone, Copy)]
pub struct UploadLimits {
    pub max_bytes: usize,
    pub max_samples_per_file: usize,
}

impl Default for UploadLimits {
    fn default() -> Self {
        UploadLimits {
            max_bytes: 256 << 20,
            max_samples_per_file: 5_000_000,
        }
    }
}

/// Whether `bytes` start with the gzip magic number.
pub fn is_gzip(bytes: &[u8]) -> bool {
    bytes.starts_with(&[0x1f, 0x8b])
}

/// Decompresses gzip data, refusing to grow past `limit` bytes.
pub fn gunzip(name: &str, bytes: &[u8], limit: usize) -> Result<Vec<u8>, ApiError> {
    let mut out = Vec::new();
    GzDecoder::new(bytes)
        .take(limit as u64 + 1)
        .read_to_end(&mut out)
        .map_err(|e| ApiError::InvalidDataset(format!("{name}: not valid gzip data: {e}")))?;
    if out.len() > limit {
        return Err(ApiError::PayloadTooLarge(format!(
            "{name}: decompresses to more than {limit} bytes"
        )));
    }
    Ok(out)
}

/// A file name as stored: a plain name (no directories, no dot files).
pub fn check_file_name(name: &str) -> Result<(), ApiError> {
    let ok = !name.is_empty()
        && name.len() <= 200
        && !name.starts_with('.')
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-'));
    if ok {
        Ok(())
    } else {
        Err(ApiError::InvalidDataset(format!(
            "file name {name:?}: only letters, digits, '.', '_' and '-' are allowed"
        )))
    }
}

/// Files of a .tar.gz (or plain .tar) archive; directories inside are flattened (the
/// session may sit in one top-level folder).
pub fn untar(bytes: &[u8], limits: UploadLimits) -> Result<Vec<(String, Vec<u8>)>, ApiError> {
    let tar_bytes = if is_gzip(bytes) {
        gunzip("archive", bytes, limits.max_bytes)?
    } else {
        bytes.to_vec()
    };
    let mut archive = tar::Archive::new(tar_bytes.as_slice());
    let mut out: Vec<(String, Vec<u8>)> = Vec::new();
    let entries = archive
        .entries()
        .map_err(|e| ApiError::InvalidDataset(format!("archive: not a tar archive: {e}")))?;
    for entry in entries {
        let mut entry = entry
            .map_err(|e| ApiError::InvalidDataset(format!("archive: unreadable entry: {e}")))?;
        if !entry.header().entry_type().is_file() {
            continue;
        }
        let path = entry
            .path()
            .map_err(|e| ApiError::InvalidDataset(format!("archive: bad path: {e}")))?
            .into_owned();
        let name = path
            .file_name()
            .and_then(|n| n.to_str())
            .unwrap_or_default()
            .to_string();
        if name.starts_with("._") {
            continue; // macOS resource forks
        }
        check_file_name(&name)?;
        let mut data = Vec::new();
        entry
            .read_to_end(&mut data)
            .map_err(|e| ApiError::InvalidDataset(format!("archive: {name}: {e}")))?;
        out.push((name, data));
    }
    if out.is_empty() {
        return Err(ApiError::InvalidDataset("archive: no files in it".into()));
    }
    Ok(out)
}

/// Checks a session upload and parses it: file names unique, `session.json` present,
/// every plane file present and valid, nothing extra. Returns the session.
pub fn read_session(
    files: &[(String, Vec<u8>)],
    limits: UploadLimits,
) -> Result<Session, ApiError> {
    let mut texts: BTreeMap<String, Vec<u8>> = BTreeMap::new();
    let mut total = 0usize;
    for (name, bytes) in files {
        check_file_name(name)?;
        let plain = if is_gzip(bytes) {
            gunzip(name, bytes, limits.max_bytes)?
        } else {
            bytes.clone()
        };
        total += plain.len();
        if total > limits.max_bytes {
            return Err(ApiError::PayloadTooLarge(format!(
                "upload decompresses to more than {} bytes",
                limits.max_bytes
            )));
        }
        // A gzip file is referred to by its name without `.gz`.
        let key = name.strip_suffix(".gz").unwrap_or(name).to_string();
        if texts.insert(key.clone(), plain).is_some() {
            return Err(ApiError::InvalidDataset(format!("file {key} given twice")));
        }
    }
    let session_json = texts
        .remove("session.json")
        .ok_or_else(|| ApiError::InvalidDataset("session.json: missing from the upload".into()))?;
    let session = crate::session_reader::parse(&session_json, &texts, limits.max_samples_per_file)
        .map_err(|e| ApiError::InvalidDataset(e.to_string()))?;
    for name in texts.keys() {
        if !session.planes.iter().any(|p| &p.file == name) {
            return Err(ApiError::InvalidDataset(format!(
                "{name}: not listed in session.json `planes`"
            )));
        }
    }
    Ok(session)
}
