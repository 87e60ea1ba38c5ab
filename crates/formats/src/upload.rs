//! A whole upload, whatever its kind: the files of an HTTP request (multipart parts or
//! the entries of one archive), or a path on disk (a session folder, one dataset file, or
//! a `.tar`, `.tar.gz` or `.zip` archive). The CLI and the server both read through here, so they
//! accept and refuse the same inputs.
//!
//! Rules (datasets contract, "Uploads"):
//! * an upload holding `session.json` (or `session.json.gz`) is a session
//!   (`session::read_session_named`): its plane files may be gzip (`f` or `f.gz`); a CSV
//!   it does not name is refused; other files (`truth.json`, notes) are ignored and listed;
//! * otherwise it is exactly one CSV whose header names its kind ([`sniff_kind`]): a rotary
//!   point set (with at most its JSON sidecar `<stem>.json`, possibly `.json.gz`),
//!   positioning runs or a drift log; any other file is refused;
//! * every file read has a plain name (letters, digits, `.`, `_`, `-`; at most 200
//!   characters; not starting with `.`) given once; at most [`Limits::max_files`] files;
//! * the byte limit applies to the stored sizes of the files read and, separately, to
//!   their decompressed sizes;
//! * an archive (`.tar`, `.tar.gz`, `.zip`) is read as its files, folders flattened
//!   (the rules of `crate::archive`).

use crate::archive::{is_archive_name, read_archive};
use crate::rotary::sidecar_name;
use crate::session::{SESSION_JSON, SESSION_JSON_GZ, read_session_named};
use crate::{DatasetKind, FormatError, Limits, gzip, sniff_kind};
use mtcal_solver::datasets::{DriftLog, PositioningRuns, RotaryPointSet};
use mtcal_solver::session::Session;
use std::borrow::Cow;
use std::path::Path;

/// The parsed content of an upload.
// One value per upload, moved a few times: the session's stated conditions make its
// variant larger than the others, which costs nothing worth a box.
#[allow(clippy::large_enum_variant)]
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
}

/// A checked upload: its content and which of its files were read.
#[derive(Debug, Clone)]
pub struct Dataset {
    pub data: DatasetData,
    /// The files read, in the order read (the ones a service stores).
    pub files: Vec<String>,
    /// Files present but not part of the dataset (only beside a session).
    pub ignored: Vec<String>,
    /// The file that declares the machine and time (session.json, a rotary sidecar).
    pub declared_in: Option<String>,
}

impl Dataset {
    /// The stored dataset kind (see [`DatasetData::kind`]).
    pub fn kind(&self) -> &'static str {
        self.data.kind()
    }

    /// Samples (session samples, points, records or log rows).
    pub fn samples(&self) -> usize {
        match &self.data {
            DatasetData::Session(s) => s.sample_count(),
            DatasetData::RotaryPoints(p) => p.points.len(),
            DatasetData::Positioning(r) => r.records.len(),
            DatasetData::DriftLog(l) => l.t_s.len(),
        }
    }

    fn declared(&self) -> (Option<&str>, Option<&str>) {
        match &self.data {
            DatasetData::Session(s) => (Some(&s.machine_id), Some(&s.measured_at)),
            DatasetData::RotaryPoints(p) => (p.machine_id.as_deref(), p.measured_at.as_deref()),
            DatasetData::Positioning(_) | DatasetData::DriftLog(_) => (None, None),
        }
    }

    /// Where the files declare a machine (session.json, a rotary sidecar), it must be
    /// `machine_id`.
    pub fn check_machine(&self, machine_id: &str) -> Result<(), FormatError> {
        match self.declared().0 {
            Some(m) if m != machine_id => Err(FormatError::new(
                self.declared_in.as_deref().unwrap_or(SESSION_JSON),
                0,
                "machine_id",
                format!("machine_id {m:?} does not match the machine {machine_id:?} uploaded to"),
            )),
            _ => Ok(()),
        }
    }

    /// Positions that are micrometres where millimetres are required: refused when the
    /// span of a position column exceeds 100× the machine's registered travel of its
    /// axis (`travel`: `{"X": [min, max], …}`, mm; axes without a travel are not checked).
    /// A session's `x_mm`, `y_mm`, `z_mm` per plane file, positioning runs' `target_mm`
    /// per axis; rotary point sets are in the instrument's frame and not checked.
    pub fn check_travel(
        &self,
        travel: &std::collections::BTreeMap<String, [f64; 2]>,
    ) -> Result<(), FormatError> {
        use crate::units::check_span;
        match &self.data {
            DatasetData::Session(s) => {
                for p in &s.planes {
                    for (k, (axis, column)) in [("X", "x_mm"), ("Y", "y_mm"), ("Z", "z_mm")]
                        .into_iter()
                        .enumerate()
                    {
                        if let Some(&t) = travel.get(axis) {
                            let values = p.runs.iter().flat_map(|r| r.pos_mm.iter().map(|q| q[k]));
                            check_span(&p.file, column, axis, values, t)?;
                        }
                    }
                }
            }
            DatasetData::Positioning(r) => {
                let file = self.files.first().map_or("positioning", String::as_str);
                for (axis, t) in travel {
                    let values = r
                        .records
                        .iter()
                        .filter(|x| x.axis.to_string() == *axis)
                        .map(|x| x.target_mm);
                    check_span(file, "target_mm", axis, values, *t)?;
                }
            }
            DatasetData::RotaryPoints(_) | DatasetData::DriftLog(_) => {}
        }
        Ok(())
    }

    /// The measurement time the files declare, as RFC 3339 UTC (`…Z`, so that times
    /// sort as text); `None` when they declare none.
    pub fn measured_at_utc(&self) -> Result<Option<String>, FormatError> {
        use time::format_description::well_known::Rfc3339;
        let Some(t) = self.declared().1 else {
            return Ok(None);
        };
        let file = self.declared_in.as_deref().unwrap_or(SESSION_JSON);
        let bad = || FormatError::new(file, 0, "measured_at", format!("{t:?} is not RFC 3339"));
        let parsed = time::OffsetDateTime::parse(t, &Rfc3339).map_err(|_| bad())?;
        parsed
            .to_offset(time::UtcOffset::UTC)
            .format(&Rfc3339)
            .map(Some)
            .map_err(|_| bad())
    }
}

pub use crate::limits::MAX_NAME_LEN;

/// A file name as an upload may carry it: a plain name (no directories, no dot files).
pub fn check_file_name(name: &str) -> Result<(), FormatError> {
    let ok = !name.is_empty()
        && name.len() <= MAX_NAME_LEN
        && !name.starts_with('.')
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-'));
    if ok {
        Ok(())
    } else {
        let shown: String = name.chars().take(MAX_NAME_LEN).collect();
        Err(FormatError::file(
            shown,
            format!(
                "file name: only letters, digits, '.', '_' and '-' are allowed (at most \
                 {MAX_NAME_LEN} characters, not starting with '.')"
            ),
        ))
    }
}

/// Reads the files of an upload (name, bytes as stored).
pub fn read_upload(files: &[(String, Vec<u8>)], limits: &Limits) -> Result<Dataset, FormatError> {
    let names: Vec<String> = files.iter().map(|(n, _)| n.clone()).collect();
    let mut load = |name: &str, _: Vec<u8>| -> Result<Cow<'_, [u8]>, FormatError> {
        let (_, bytes) = files
            .iter()
            .find(|(n, _)| n == name)
            .expect("only listed names are loaded");
        Ok(Cow::Borrowed(bytes.as_slice()))
    };
    read_named(&names, &mut load, limits)
}

/// Reads a dataset from disk: a folder (its files, as an upload of them), a `.tar`,
/// `.tar.gz`, `.tgz` or `.zip` archive, or one dataset file (with the sidecar `<stem>.json` of a
/// rotary point set when it exists beside it).
pub fn read_path(path: &Path, limits: &Limits) -> Result<Dataset, FormatError> {
    let meta = crate::stat_path(path)?;
    if meta.is_dir() {
        let (names, mut load) = crate::files::folder(path, limits)?;
        return read_named(&names, &mut load, limits);
    }
    if !meta.is_file() {
        return Err(FormatError::file(
            path.display().to_string(),
            "neither a file nor a folder",
        ));
    }
    let (name, bytes) = crate::read_single(path, limits)?;
    if is_archive_name(&name) {
        return read_upload(&read_archive(&name, &bytes, limits)?, limits);
    }
    let mut files = vec![(name, bytes)];
    if sniff_kind(&files[0].0, &files[0].1) == Some(DatasetKind::RotaryPoints) {
        let side = sidecar_name(&files[0].0);
        for candidate in [side.clone(), format!("{side}.gz")] {
            let p = path.with_file_name(&candidate);
            if p.is_file() {
                let limits = Limits {
                    max_bytes: limits.max_bytes.saturating_sub(files[0].1.len()),
                    ..*limits
                };
                let b = crate::read_file_limited(&p, &candidate, &limits)?;
                files.push((candidate, b));
            }
        }
    }
    read_upload(&files, limits)
}

/// The one reader of uploads, over names and a loader (see the module documentation).
fn read_named<'a>(
    names: &[String],
    load: &mut crate::files::Loader<'a>,
    limits: &Limits,
) -> Result<Dataset, FormatError> {
    if names.len() > limits.max_files {
        return Err(FormatError::file(
            "upload",
            format!(
                "{} files exceed the limit of {} files per upload",
                names.len(),
                limits.max_files
            ),
        )
        .as_limit());
    }
    for (i, n) in names.iter().enumerate() {
        if names[..i].contains(n) {
            return Err(FormatError::file(n.as_str(), "given twice in the upload"));
        }
    }
    // Only files that are read must have plain names (they are the ones stored).
    let mut load = |name: &str, spare: Vec<u8>| {
        check_file_name(name)?;
        load(name, spare)
    };
    if names
        .iter()
        .any(|n| n == SESSION_JSON || n == SESSION_JSON_GZ)
    {
        let r = read_session_named(names, &mut load, limits)?;
        return Ok(Dataset {
            data: DatasetData::Session(r.session),
            files: r.files,
            ignored: r.ignored,
            declared_in: Some(r.description),
        });
    }
    let is_json = |n: &str| n.ends_with(".json") || n.ends_with(".json.gz");
    let csvs: Vec<&String> = names.iter().filter(|n| !is_json(n)).collect();
    let [name] = csvs.as_slice() else {
        return Err(FormatError::file(
            "upload",
            format!(
                "expected session.json with its plane CSVs, or one CSV (rotary point set, \
                 positioning runs or drift log); got {} non-JSON files",
                csvs.len()
            ),
        ));
    };
    let name = name.as_str();
    let jsons: Vec<&String> = names.iter().filter(|n| is_json(n)).collect();
    let bytes = load(name, Vec::new())?;
    let kind = sniff_kind(name, &bytes).ok_or_else(|| {
        FormatError::new(
            name,
            1,
            "",
            "header names no dataset kind (rotary point set: a_deg,c_deg,x_mm,y_mm,z_mm; \
             positioning runs: axis,run,direction,target_mm,deviation_um; drift log: \
             t_s,<name>_um,...)",
        )
    })?;
    let sidecar = sidecar_name(name);
    let rest = Limits {
        max_bytes: limits.max_bytes.saturating_sub(bytes.len()),
        ..*limits
    };
    let mut files = vec![name.to_string()];
    let mut declared_in = None;
    let data = match kind {
        DatasetKind::RotaryPoints => {
            let side = match jsons.as_slice() {
                [] => None,
                [j] if **j == sidecar || **j == format!("{sidecar}.gz") => {
                    let raw = load(j, Vec::new())?;
                    let mut budget = rest.max_bytes;
                    let plain = gzip::decode(j, &raw, &mut budget)?.into_owned();
                    files.push(j.to_string());
                    declared_in = Some(sidecar.clone());
                    Some(plain)
                }
                [j, ..] => {
                    return Err(FormatError::file(
                        j.as_str(),
                        format!("unexpected file (the sidecar of {name} is named {sidecar})"),
                    ));
                }
            };
            DatasetData::RotaryPoints(crate::read_rotary_points(
                name,
                &bytes,
                side.as_deref(),
                limits,
            )?)
        }
        DatasetKind::Positioning | DatasetKind::DriftLog => {
            if let Some(j) = jsons.first() {
                return Err(FormatError::file(
                    j.as_str(),
                    format!(
                        "unexpected file (only a rotary point set takes a JSON sidecar, \
                         named {sidecar})"
                    ),
                ));
            }
            if kind == DatasetKind::Positioning {
                DatasetData::Positioning(crate::read_positioning(name, &bytes, limits)?)
            } else {
                DatasetData::DriftLog(crate::read_drift_log(name, &bytes, limits)?)
            }
        }
        DatasetKind::PlaneCsv | DatasetKind::Session => {
            return Err(FormatError::file(
                name,
                "a session plane file needs its session.json in the same upload",
            ));
        }
    };
    Ok(Dataset {
        data,
        files,
        ignored: vec![],
        declared_in,
    })
}
