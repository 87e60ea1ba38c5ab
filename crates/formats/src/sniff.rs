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
    let cols = header_columns(trimmed)?;
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

/// The column names of the header of a CSV's text (after any byte-order mark): its first
/// line that is neither blank nor a `#` comment, split at `,` (at `;` when it holds no
/// `,`: a spreadsheet's header names its kind too, and the reader then reads it or says
/// what to change), `x-` columns left out.
fn header_columns(text: &str) -> Option<Vec<&str>> {
    let header = header_line(text)?;
    let sep = char::from(dialect_of_header(header).delimiter());
    Some(
        header
            .split(sep)
            .map(|c| c.trim().trim_matches('"'))
            .filter(|c| !c.starts_with("x-"))
            .collect(),
    )
}

/// The kind a CSV that matches no kind ([`sniff_kind`] is `None`) resembles by its
/// header, so that the kind's strict reader can say what is wrong (a missing column,
/// with file, line, column and rule) instead of a generic "not a positioning-run CSV":
/// positioning runs when the header names `axis` and `target_mm`, or three of the five
/// required columns; a drift log when it names `t_s` and a channel (`<name>_um`, `_c`,
/// `_rpm`, `_mm`), or only channels and one other column, and no column of a session's
/// plane CSV or a rotary point set. `None` for JSON or any other header.
pub fn resembled_kind(bytes: &[u8]) -> Option<DatasetKind> {
    let head = gzip::prefix(bytes, SNIFF_BYTES)?;
    let text = String::from_utf8_lossy(&head);
    let trimmed = text.trim_start_matches('\u{feff}').trim_start();
    if trimmed.starts_with('{') {
        return None;
    }
    let cols = header_columns(trimmed)?;
    let has = |n: &str| cols.contains(&n);
    let positioning = &POSITIONING_COLUMNS[..5];
    if (has("axis") && has("target_mm")) || positioning.iter().filter(|c| has(c)).count() >= 3 {
        return Some(DatasetKind::Positioning);
    }
    if ["run", "test", "du_um", "dv_um", "a_deg", "c_deg"]
        .iter()
        .any(|c| has(c))
    {
        return None;
    }
    let channels = cols.iter().filter(|c| channel_kind(c).is_some()).count();
    let drift = channels >= 1 && (has("t_s") || channels + 1 == cols.len());
    drift.then_some(DatasetKind::DriftLog)
}

/// [`resembled_kind`] for a file's path (`None` for a folder or an unreadable file).
pub fn resembled_path(path: &Path) -> Option<DatasetKind> {
    if !path.is_file() {
        return None;
    }
    resembled_kind(&file_head(path)?)
}

/// The first [`SNIFF_BYTES`] of a file as stored (still compressed when gzip).
fn file_head(path: &Path) -> Option<Vec<u8>> {
    use std::io::Read;
    let mut head = Vec::new();
    std::fs::File::open(path)
        .ok()?
        .take(SNIFF_BYTES as u64)
        .read_to_end(&mut head)
        .ok()?;
    Some(head)
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
    sniff_kind(&crate::display_name(path), &file_head(path)?)
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
