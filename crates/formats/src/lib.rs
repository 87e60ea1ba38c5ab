//! # mtcal-formats
//!
//! Strict readers (and writers) of the dataset formats in `docs/datasets.md`: every
//! rejected file gets an error naming the file, the line, the column and the rule, and
//! nothing of a rejected upload is returned.
//!
//! * [`session`]: measurement sessions (section 1: `session.json` + plane CSVs);
//! * [`rotary`]: rotary-axis point sets (section 2);
//! * [`positioning`]: positioning runs (section 3);
//! * [`drift`]: drift logs (section 4);
//! * [`sniff`]: which of these a file is, from its header;
//! * [`units`]: unit mistakes (millimetres in a micrometre column, micrometres in a
//!   millimetre one, radians in a degree one) refused with what to change;
//! * [`upload`]: a whole upload (files in memory, an archive, or a path), whatever its
//!   kind: the one entry point the CLI and the server share, so that both accept and
//!   refuse the same inputs.
//!
//! The rules shared by every CSV format live once in `csv_core`, limits in [`limits`],
//! gzip handling in `gzip`, the files of one read (in memory or in a folder) in `files`.

pub mod compensation;
mod csv_core;
mod csv_out;
pub mod drift;
mod files;
mod gzip;
mod json;
pub mod limits;
pub mod positioning;
pub mod rotary;
pub mod session;
pub mod sniff;
pub mod units;
pub mod upload;

pub use drift::{read_drift_log, read_drift_log_path, write_drift_log, write_drift_predictions};
pub use json::is_rfc3339;
pub use limits::{CsvDialect, Limits};
pub use positioning::{read_positioning, read_positioning_path, write_positioning};
pub use rotary::{
    read_rotary_points, read_rotary_points_path, write_rotary_points, write_rotary_sidecar,
};
pub use session::{read_session_dir, read_session_files, write_session_dir};
pub use sniff::{DatasetKind, sniff_kind, sniff_path};
pub use upload::{
    Dataset, DatasetData, is_archive_name, read_archive, read_path, read_upload,
    unpack_single_archive,
};

/// A rejected input: which file, where, and which rule it broke. Shown as
/// `file:line:column: rule`, leaving out what it is not tied to: `file:line: rule`
/// without a column, `file: column: rule` without a line, `file: rule` for a whole file.
#[derive(Debug, Clone, PartialEq)]
pub struct FormatError {
    pub file: String,
    /// 1-based line number; 0 when the problem is not tied to a line (e.g. a missing file).
    pub line: u64,
    /// Column name (or JSON field), empty when not tied to a column.
    pub column: String,
    /// The rule that was broken, as a sentence.
    pub rule: String,
    /// A format rule, or a size limit (a service answers the latter with 413).
    pub kind: ErrorKind,
}

/// What a [`FormatError`] is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ErrorKind {
    /// A rule of the format was broken.
    #[default]
    Rule,
    /// A size limit of [`Limits`] was exceeded (bytes, samples, files).
    Limit,
}

/// Longest file name, column name or rule kept in a [`FormatError`], bytes: the cell or
/// header a message quotes comes from the input, and a 10 MB cell must not make a 10 MB
/// message (in a log line or an HTTP answer).
pub const MAX_MESSAGE_PART: usize = 512;

impl std::fmt::Display for FormatError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.file)?;
        match (self.line, self.column.is_empty()) {
            (0, true) => {}
            (0, false) => write!(f, ": {}", self.column)?,
            (line, true) => write!(f, ":{line}")?,
            (line, false) => write!(f, ":{line}:{}", self.column)?,
        }
        write!(f, ": {}", self.rule)
    }
}

impl std::error::Error for FormatError {}

/// `s`, cut to [`MAX_MESSAGE_PART`] bytes (at a character boundary) with its full length
/// said when longer.
fn bounded(s: String) -> String {
    if s.len() <= MAX_MESSAGE_PART {
        return s;
    }
    let mut end = MAX_MESSAGE_PART;
    while !s.is_char_boundary(end) {
        end -= 1;
    }
    format!("{}… ({} bytes in all)", &s[..end], s.len())
}

impl FormatError {
    pub fn new(
        file: impl Into<String>,
        line: u64,
        column: impl Into<String>,
        rule: impl Into<String>,
    ) -> FormatError {
        FormatError {
            file: bounded(file.into()),
            line,
            column: bounded(column.into()),
            rule: bounded(rule.into()),
            kind: ErrorKind::Rule,
        }
    }

    /// The same error, marked as an exceeded size limit.
    pub fn as_limit(mut self) -> FormatError {
        self.kind = ErrorKind::Limit;
        self
    }

    /// Whether a size limit was exceeded (rather than a format rule broken).
    pub fn is_limit(&self) -> bool {
        self.kind == ErrorKind::Limit
    }

    /// An error about a whole file (line 0, no column).
    pub fn file(file: impl Into<String>, rule: impl Into<String>) -> FormatError {
        FormatError::new(file, 0, "", rule)
    }
}

/// Reads a whole file for a path-based reader, mapping IO errors to a [`FormatError`]
/// and refusing files larger than the byte limit before reading them.
pub(crate) fn read_file_limited(
    path: &std::path::Path,
    name: &str,
    limits: &Limits,
) -> Result<Vec<u8>, FormatError> {
    read_file_into(path, name, limits, Vec::new())
}

/// [`read_file_limited`] into `buf`, emptied first: its memory is reused (a session's
/// plane files are read one after the other into the buffers of the files already
/// parsed, so their pages are not faulted in anew for every file).
pub(crate) fn read_file_into(
    path: &std::path::Path,
    name: &str,
    limits: &Limits,
    mut buf: Vec<u8>,
) -> Result<Vec<u8>, FormatError> {
    use std::io::Read;
    let cannot = |e: std::io::Error| FormatError::file(name, format!("cannot read file: {e}"));
    let mut file = std::fs::File::open(path).map_err(cannot)?;
    let len = file.metadata().map_err(cannot)?.len();
    if len > limits.max_bytes as u64 {
        return Err(FormatError::file(
            name,
            format!(
                "upload exceeds the byte limit ({} bytes allowed in what remains of the upload)",
                limits.max_bytes
            ),
        )
        .as_limit());
    }
    buf.clear();
    buf.reserve_exact(len as usize);
    file.read_to_end(&mut buf).map_err(cannot)?;
    Ok(buf)
}

/// The metadata of a dataset path given by a user, or an error naming the full path and
/// the system's reason (`/no/such/dir: cannot read: No such file or directory (os
/// error 2)`).
pub fn stat_path(path: &std::path::Path) -> Result<std::fs::Metadata, FormatError> {
    std::fs::metadata(path)
        .map_err(|e| FormatError::file(path.display().to_string(), format!("cannot read: {e}")))
}

/// The file name of a path, for messages.
pub(crate) fn display_name(path: &std::path::Path) -> String {
    path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}

/// Reads a single-file dataset given by path (still compressed if it is gzip: the
/// byte-based readers decompress); returns its display name and contents.
pub(crate) fn read_single(
    path: &std::path::Path,
    limits: &Limits,
) -> Result<(String, Vec<u8>), FormatError> {
    let name = display_name(path);
    let raw = read_file_limited(path, &name, limits)?;
    Ok((name, raw))
}

/// Decompresses (when gzip) one uploaded file under the byte limit.
pub(crate) fn decode_single<'a>(
    name: &str,
    bytes: &'a [u8],
    limits: &Limits,
) -> Result<std::borrow::Cow<'a, [u8]>, FormatError> {
    let mut budget = limits.max_bytes;
    gzip::decode(name, bytes, &mut budget)
}

/// Shared by the writers: an `InvalidInput` error.
pub(crate) fn invalid_input(msg: impl Into<String>) -> std::io::Error {
    std::io::Error::new(std::io::ErrorKind::InvalidInput, msg.into())
}
