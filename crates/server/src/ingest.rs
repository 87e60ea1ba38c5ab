//! Uploads: the files of a dataset (multipart or one .tar.gz): a measurement session, a
//! rotary point set, positioning runs or a drift log, checked completely before anything
//! is stored ([`read_dataset`]).
//!
//! The bytes are kept exactly as uploaded (gzip included); parsing works on the
//! decompressed text. Session parsing is the strict reader of `mtcal-formats`
//! ([`read_session`]); the sums of stored and of decompressed sizes are both limited.

use crate::error::ApiError;
use flate2::read::GzDecoder;
use mtcal_formats::DatasetKind;
use mtcal_solver::datasets::{DriftLog, PositioningRuns, RotaryPointSet};
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

/// Checks a session upload and parses it with the strict reader of `mtcal-formats`
/// (`read_session_files`): file names unique, `session.json` present, every plane file
/// present and valid, nothing extra. A file uploaded as `NAME.gz` serves a plane that
/// session.json lists as `NAME` (as in a session folder). Returns the session.
pub fn read_session(
    files: &[(String, Vec<u8>)],
    limits: UploadLimits,
) -> Result<Session, ApiError> {
    let mut session_json: Option<&[u8]> = None;
    for (name, bytes) in files {
        check_file_name(name)?;
        let is_json = name == "session.json" || name == "session.json.gz";
        if is_json && session_json.replace(bytes).is_some() {
            return Err(ApiError::InvalidDataset("session.json: given twice".into()));
        }
    }
    let session_json = session_json
        .ok_or_else(|| ApiError::InvalidDataset("session.json: missing from the upload".into()))?;
    // Names session.json lists (read leniently here; the strict reader checks it below).
    let listed: Vec<String> = {
        let plain = if is_gzip(session_json) {
            gunzip("session.json", session_json, limits.max_bytes)?
        } else {
            session_json.to_vec()
        };
        serde_json::from_slice::<serde_json::Value>(&plain)
            .ok()
            .and_then(|v| {
                v["planes"].as_array().map(|ps| {
                    ps.iter()
                        .filter_map(|p| p["file"].as_str().map(String::from))
                        .collect()
                })
            })
            .unwrap_or_default()
    };
    let mut planes: BTreeMap<String, Vec<u8>> = BTreeMap::new();
    for (name, bytes) in files {
        if name.starts_with("session.json") {
            continue;
        }
        let key = match name.strip_suffix(".gz") {
            Some(stem) if !listed.contains(name) && listed.iter().any(|l| l == stem) => stem,
            _ => name.as_str(),
        };
        if planes.insert(key.to_string(), bytes.clone()).is_some() {
            return Err(ApiError::InvalidDataset(format!("{key}: given twice")));
        }
    }
    let fl = mtcal_formats::Limits {
        max_bytes: limits.max_bytes,
        max_samples_per_file: limits.max_samples_per_file,
    };
    mtcal_formats::read_session_files(session_json, &planes, &fl)
        .map_err(|e| ApiError::InvalidDataset(e.to_string()))
}

/// A checked upload of any dataset kind the service accepts.
#[derive(Debug, Clone)]
pub enum DatasetData {
    /// A grid-encoder session (datasets contract, section 1).
    Session(Session),
    /// A rotary-axis point set, CSV with optional JSON sidecar (section 2).
    RotaryPoints(RotaryPointSet),
    /// Positioning runs (section 3).
    Positioning(PositioningRuns),
    /// A drift log (section 4).
    DriftLog(DriftLog),
}

impl DatasetData {
    /// The stored dataset kind: `session`, `rotary_points`, `positioning` or `drift_log`.
    pub fn kind(&self) -> &'static str {
        match self {
            DatasetData::Session(_) => "session",
            DatasetData::RotaryPoints(_) => "rotary_points",
            DatasetData::Positioning(_) => "positioning",
            DatasetData::DriftLog(_) => "drift_log",
        }
    }

    /// Samples (session samples, points, records or log rows).
    pub fn samples(&self) -> usize {
        match self {
            DatasetData::Session(s) => s.sample_count(),
            DatasetData::RotaryPoints(p) => p.points.len(),
            DatasetData::Positioning(r) => r.records.len(),
            DatasetData::DriftLog(l) => l.t_s.len(),
        }
    }
}

/// Checks an upload of any kind and parses it with the strict reader of `mtcal-formats`.
/// An upload holding `session.json` is a session ([`read_session`]); otherwise it must be
/// one CSV (possibly gzip) whose header names its kind (`sniff_kind`): a rotary point set
/// (with at most its JSON sidecar `<stem>.json` beside it), positioning runs or a drift
/// log. Errors name file, line, column and rule.
pub fn read_dataset(
    files: &[(String, Vec<u8>)],
    limits: UploadLimits,
) -> Result<DatasetData, ApiError> {
    for (name, _) in files {
        check_file_name(name)?;
    }
    if files
        .iter()
        .any(|(n, _)| n == "session.json" || n == "session.json.gz")
    {
        return read_session(files, limits).map(DatasetData::Session);
    }
    let fl = mtcal_formats::Limits {
        max_bytes: limits.max_bytes,
        max_samples_per_file: limits.max_samples_per_file,
    };
    let csvs: Vec<&(String, Vec<u8>)> = files.iter().filter(|(n, _)| !is_json(n)).collect();
    let [(name, bytes)] = csvs.as_slice() else {
        return Err(ApiError::InvalidDataset(format!(
            "upload: expected session.json with its plane CSVs, or one CSV (rotary point set, \
             positioning runs or drift log); got {} non-JSON files",
            csvs.len()
        )));
    };
    let jsons: Vec<&(String, Vec<u8>)> = files.iter().filter(|(n, _)| is_json(n)).collect();
    let kind = mtcal_formats::sniff_kind(name, bytes).ok_or_else(|| {
        ApiError::InvalidDataset(format!(
            "{name}:1:1: header names no dataset kind (rotary point set: a_deg,c_deg,x_mm,\
             y_mm,z_mm; positioning runs: axis,run,direction,target_mm,deviation_um; drift \
             log: t_s,<name>_um,...)"
        ))
    })?;
    let sidecar = mtcal_formats::rotary::sidecar_name(name);
    let bad = |e: mtcal_formats::FormatError| ApiError::InvalidDataset(e.to_string());
    let no_json = || -> Result<(), ApiError> {
        match jsons.first() {
            Some((j, _)) => Err(ApiError::InvalidDataset(format!(
                "{j}: unexpected file (only a rotary point set takes a JSON sidecar, \
                 named {sidecar})"
            ))),
            None => Ok(()),
        }
    };
    match kind {
        DatasetKind::RotaryPoints => {
            let side = match jsons.as_slice() {
                [] => None,
                [(j, b)] if *j == sidecar => Some(b.as_slice()),
                [(j, _), ..] => {
                    return Err(ApiError::InvalidDataset(format!(
                        "{j}: unexpected file (the sidecar of {name} is named {sidecar})"
                    )));
                }
            };
            mtcal_formats::read_rotary_points(name, bytes, side, &fl)
                .map(DatasetData::RotaryPoints)
                .map_err(bad)
        }
        DatasetKind::Positioning => {
            no_json()?;
            mtcal_formats::read_positioning(name, bytes, &fl)
                .map(DatasetData::Positioning)
                .map_err(bad)
        }
        DatasetKind::DriftLog => {
            no_json()?;
            mtcal_formats::read_drift_log(name, bytes, &fl)
                .map(DatasetData::DriftLog)
                .map_err(bad)
        }
        DatasetKind::PlaneCsv | DatasetKind::Session => Err(ApiError::InvalidDataset(format!(
            "{name}: a session plane file needs its session.json in the same upload"
        ))),
    }
}

fn is_json(name: &str) -> bool {
    name.ends_with(".json") || name.ends_with(".json.gz")
}
