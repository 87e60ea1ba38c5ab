//! Subcommands. Each returns `Ok(code)` or an error; [`finish`] maps errors to exit codes:
//! 2 for bad input (a [`BadInput`] anywhere in the chain), 0 without a word for a stdout
//! closed by its reader ([`out`]), 1 for everything else.

use std::process::ExitCode;

pub mod admin;
pub mod command;
pub mod compare;
pub mod cradle;
pub mod demo;
pub mod diagnose;
pub mod explain;
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
