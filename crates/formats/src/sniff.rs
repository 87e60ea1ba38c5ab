//! Which dataset a file holds, from its name and first bytes (the header), so that the
//! CLI (`mtcal diagnose PATH`) and the API can pick the reader. Sniffing only guesses;
//! the strict reader still decides.

use crate::CsvDialect;
use crate::drift::channel_kind;
use crate::gzip;
use crate::positioning::POSITIONING_COLUMNS;
use crate::rotary::ROTARY_COLUMNS;
use crate::session::{PLANE_COLUMNS, SESSION_JSON};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The dataset kinds of the datasets contract.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum DatasetKind {
    /// A `session.json` (section 1), or a folder holding one.
    Session,
    /// One plane CSV of a session (section 1).
    PlaneCsv,
    /// A rotary-axis point set (section 2).
    RotaryPoints,
    /// Positioning runs (section 3).
    Positioning,
    /// A drift log (section 4).
    DriftLog,
}

/// Bytes looked at when sniffing (after decompression).
const SNIFF_BYTES: usize = 64 * 1024;

/// The kind of the file `name` with contents `bytes` (gzip accepted), or `None` when it
/// matches no format. A JSON object with `machine_id` and `planes` is a session; a CSV is
/// classified by the column names of its header (first line that is neither blank nor a
/// `#` comment; `x-` columns ignored; separated by `,`, or by `;` when it holds no `,`).
pub fn sniff_kind(name: &str, bytes: &[u8]) -> Option<DatasetKind> {
    let head = gzip::prefix(bytes, SNIFF_BYTES)?;
    let text = String::from_utf8_lossy(&head);
    let trimmed = text.trim_start_matches('\u{feff}').trim_start();
    if trimmed.starts_with('{') || name.ends_with(".json") {
        let is_session = text.contains("\"planes\"") && text.contains("\"machine_id\"");
        return is_session.then_some(DatasetKind::Session);
    }
    let header = header_line(trimmed)?;
    // A spreadsheet's `;` header (the Excel dialect) names its kind too; the reader then
    // reads it or says what to change.
    let sep = char::from(dialect_of_header(header).delimiter());
    let cols: Vec<&str> = header
        .split(sep)
        .map(|c| c.trim().trim_matches('"'))
        .filter(|c| !c.starts_with("x-"))
        .collect();
    let has_all = |names: &[&str]| names.iter().all(|n| cols.contains(n));
    if has_all(&PLANE_COLUMNS[..7]) {
        Some(DatasetKind::PlaneCsv)
    } else if has_all(&ROTARY_COLUMNS[..5]) {
        Some(DatasetKind::RotaryPoints)
    } else if has_all(&POSITIONING_COLUMNS[..5]) {
        Some(DatasetKind::Positioning)
    } else if cols.contains(&"t_s")
        && cols.len() > 1
        && cols
            .iter()
            .all(|c| *c == "t_s" || channel_kind(c).is_some())
    {
        Some(DatasetKind::DriftLog)
    } else {
        None
    }
}

/// [`sniff_kind`] for a path: a folder holding `session.json` is a session; a file is
/// sniffed from its first bytes. `None` when unreadable or unrecognised.
pub fn sniff_path(path: &Path) -> Option<DatasetKind> {
    if path.is_dir() {
        return path
            .join(SESSION_JSON)
            .is_file()
            .then_some(DatasetKind::Session);
    }
    if crate::is_archive_name(&crate::display_name(path)) {
        // An archive is read as a session folder (read_session_dir says when it is not).
        return path.is_file().then_some(DatasetKind::Session);
    }
    use std::io::Read;
    let mut head = Vec::new();
    std::fs::File::open(path)
        .ok()?
        .take(SNIFF_BYTES as u64)
        .read_to_end(&mut head)
        .ok()?;
    sniff_kind(&crate::display_name(path), &head)
}

/// The first line that is neither blank nor a `#` comment.
fn header_line(text: &str) -> Option<&str> {
    text.lines()
        .map(str::trim)
        .find(|l| !l.is_empty() && !l.starts_with('#'))
}

/// The dialect a header line is written in: Excel when it holds `;` and no `,`.
fn dialect_of_header(header: &str) -> CsvDialect {
    if header.contains(';') && !header.contains(',') {
        CsvDialect::Excel
    } else {
        CsvDialect::Plain
    }
}

/// The CSV dialect of an upload's files as stored: Excel when a CSV file's header is
/// separated by `;`. Only for files already accepted (a service's stored datasets): the
/// plain dialect refuses such a header, so a stored one was uploaded in the Excel dialect
/// and is read again in it. New uploads name their dialect; it is never guessed.
pub fn stored_dialect(files: &[(String, Vec<u8>)]) -> CsvDialect {
    let excel = files.iter().any(|(name, bytes)| {
        crate::session::is_csv_name(name)
            && gzip::prefix(bytes, SNIFF_BYTES).is_some_and(|head| {
                let text = String::from_utf8_lossy(&head);
                header_line(text.trim_start_matches('\u{feff}'))
                    .is_some_and(|h| dialect_of_header(h) == CsvDialect::Excel)
            })
    });
    if excel {
        CsvDialect::Excel
    } else {
        CsvDialect::Plain
    }
}
