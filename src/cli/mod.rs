//! Subcommands. Each returns `Ok(code)` or an error; [`finish`] maps errors to exit codes:
//! 2 for bad input (a [`BadInput`] anywhere in the chain), 0 without a word for a stdout
//! closed by its reader ([`out`]), 1 for everything else.

use std::process::ExitCode;

pub mod admin;
pub mod compare;
pub mod cradle;
pub mod demo;
pub mod diagnose;
pub mod export;
pub mod identify;
pub mod out;
pub mod report;
pub mod sensitivity;
pub mod serve;
pub mod simulate;
pub mod standards;
pub mod submit;

/// How the commands that read datasets read their CSV files (flattened into each).
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct ReadArgs {
    /// CSV dialect: `plain` (`,` separators, `.` decimal points: the datasets format) or
    /// `excel` (`;` separators and decimal commas, as a spreadsheet saves CSV in many
    /// locales; a UTF-8 byte-order mark is fine in both).
    #[arg(long, default_value = "plain", value_parser = parse_dialect)]
    pub csv_dialect: mtcal_formats::CsvDialect,
}

fn parse_dialect(s: &str) -> Result<mtcal_formats::CsvDialect, String> {
    mtcal_formats::CsvDialect::parse(s).ok_or_else(|| format!("{s:?}: plain or excel"))
}

impl ReadArgs {
    /// The readers' default limits, reading CSV in the chosen dialect.
    pub fn limits(&self) -> mtcal_formats::Limits {
        mtcal_formats::Limits::default().with_dialect(self.csv_dialect)
    }
}

/// The kind of dataset a CSV file that matches no kind ([`mtcal_formats::sniff_path`]
/// is `None`) resembles by its header, so that the kind's strict reader can say what is
/// wrong (a missing column, with file, line, column and rule) instead of a generic "not
/// a positioning-run CSV": positioning runs when the header names `axis` and
/// `target_mm`, or three of the five required columns; a drift log when it names `t_s`
/// and a channel (`<name>_um`, `_c`, `_rpm`, `_mm`), or only channels and one other
/// column, and no column of a session's plane CSV or a rotary point set. `None` for a
/// folder, a JSON file, an unreadable file or any other header.
pub fn resembled_kind(path: &std::path::Path) -> Option<mtcal_formats::DatasetKind> {
    use mtcal_formats::DatasetKind;
    use mtcal_formats::drift::channel_kind;
    use std::io::Read;
    const HEAD: u64 = 64 * 1024;
    if !path.is_file() {
        return None;
    }
    let mut raw = Vec::new();
    std::fs::File::open(path)
        .ok()?
        .take(HEAD)
        .read_to_end(&mut raw)
        .ok()?;
    let head = if raw.starts_with(&[0x1f, 0x8b]) {
        let mut text = Vec::new();
        // A prefix of a gzip stream ends early: what was decoded so far is the head.
        let _ = flate2::read::GzDecoder::new(raw.as_slice())
            .take(HEAD)
            .read_to_end(&mut text);
        text
    } else {
        raw
    };
    let text = String::from_utf8_lossy(&head);
    let text = text.trim_start_matches('\u{feff}').trim_start();
    if text.starts_with('{') {
        return None;
    }
    let header = text
        .lines()
        .map(str::trim)
        .find(|l| !l.is_empty() && !l.starts_with('#'))?;
    let sep = if header.contains(';') && !header.contains(',') {
        ';'
    } else {
        ','
    };
    let cols: Vec<&str> = header
        .split(sep)
        .map(|c| c.trim().trim_matches('"'))
        .filter(|c| !c.starts_with("x-"))
        .collect();
    let has = |n: &str| cols.contains(&n);
    let positioning = ["axis", "run", "direction", "target_mm", "deviation_um"];
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

/// Marks an error as the user's input being wrong (exit code 2).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct BadInput(pub String);

/// Reads a JSON document, reporting the file, line and column of a syntax or schema error;
/// a file that cannot be read (missing, not readable, not UTF-8) is named with the
/// system's reason. Both are bad input, exit code 2.
pub fn read_json<T: serde::de::DeserializeOwned>(
    path: &std::path::Path,
    what: &str,
) -> anyhow::Result<T> {
    let text = std::fs::read_to_string(path).map_err(|e| {
        BadInput(format!(
            "{}: cannot read the {what} file: {e}",
            path.display()
        ))
    })?;
    serde_json::from_str(&text).map_err(|e| {
        anyhow::Error::new(BadInput(format!(
            "{}: line {} column {}: {e}",
            path.display(),
            e.line(),
            e.column()
        )))
    })
}

/// Prints the error chain to stderr and picks the exit code.
pub fn finish(result: anyhow::Result<ExitCode>) -> ExitCode {
    match result {
        Ok(code) => code,
        Err(e) if out::is_closed_pipe(&e) => ExitCode::SUCCESS,
        Err(e) => {
            out::noteln!("error: {e:#}");
            if e.chain()
                .any(|c| c.is::<BadInput>() || c.is::<mtcal_formats::FormatError>())
            {
                ExitCode::from(2)
            } else {
                ExitCode::from(1)
            }
        }
    }
}
