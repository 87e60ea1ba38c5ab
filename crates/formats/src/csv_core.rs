//! The strict CSV core shared by every CSV format (datasets contract, "Rules for every
//! format"), so that each rule is written once:
//!
//! * UTF-8 (checked once over the whole file);
//! * a header is required; lines whose first character is `#` are comments, before or
//!   after the header; blank lines are skipped;
//! * column names are trimmed, must be non-empty and unique; column order is free;
//!   unknown columns are rejected unless their name starts with `x-` (kept, ignored);
//! * every row has as many fields as the header;
//! * numbers are finite decimal numbers (NaN, Inf and empty cells are errors), integers
//!   are decimal integers;
//! * at most [`Limits::max_samples_per_file`] rows.
//!
//! Line numbers are 1-based physical lines of the file (comments and blank lines count).
//! Rows are read into a reused [`csv::ByteRecord`]: no allocation per row.

use crate::{FormatError, Limits};

/// Prefix of the columns that are accepted and ignored.
pub const IGNORED_PREFIX: &str = "x-";

pub(crate) struct CsvTable<'a> {
    file: &'a str,
    bytes: &'a [u8],
    rdr: csv::Reader<&'a [u8]>,
    rec: csv::ByteRecord,
    header: Vec<String>,
    header_line: u64,
    /// Line of the current row.
    line: u64,
    /// Scan state: byte offset whose line number is `scan_line`.
    scan_pos: usize,
    scan_line: u64,
    rows: usize,
    max_rows: usize,
    total_lines: u64,
}

fn count_newlines(bytes: &[u8]) -> u64 {
    bytes.iter().filter(|&&b| b == b'\n').count() as u64
}

impl<'a> CsvTable<'a> {
    /// Checks the encoding and reads the header.
    pub fn open(file: &'a str, bytes: &'a [u8], limits: &Limits) -> Result<Self, FormatError> {
        if let Err(e) = std::str::from_utf8(bytes) {
            let at = e.valid_up_to();
            let line = 1 + count_newlines(&bytes[..at]);
            let line_start = bytes[..at]
                .iter()
                .rposition(|&b| b == b'\n')
                .map_or(0, |p| p + 1);
            return Err(FormatError::new(
                file,
                line,
                "",
                format!(
                    "file is not valid UTF-8 (invalid byte at character {} of the line)",
                    1 + String::from_utf8_lossy(&bytes[line_start..at])
                        .chars()
                        .count()
                ),
            ));
        }
        let rdr = csv::ReaderBuilder::new()
            .has_headers(false)
            .comment(Some(b'#'))
            .flexible(true)
            .from_reader(bytes);
        let mut t = CsvTable {
            file,
            bytes,
            rdr,
            rec: csv::ByteRecord::new(),
            header: Vec::new(),
            header_line: 0,
            line: 0,
            scan_pos: 0,
            scan_line: 1,
            rows: 0,
            max_rows: limits.max_samples_per_file,
            total_lines: 0,
        };
        if !t.read_record()? {
            return Err(FormatError::new(
                file,
                t.scan_line,
                "",
                "header required: the file has no header line (only comments or nothing)",
            ));
        }
        t.header_line = t.line;
        let mut header: Vec<String> = Vec::with_capacity(t.rec.len());
        for (i, f) in t.rec.iter().enumerate() {
            // UTF-8 was checked above for the whole file.
            let name = String::from_utf8_lossy(f).trim().to_string();
            if name.is_empty() {
                return Err(t.header_error("", format!("empty column name (column {})", i + 1)));
            }
            if header.contains(&name) {
                return Err(t.header_error(&name, "duplicate column name"));
            }
            header.push(name);
        }
        t.header = header;
        t.total_lines = count_newlines(bytes) + 1;
        Ok(t)
    }

    pub fn header(&self) -> &[String] {
        &self.header
    }

    /// Index of a column by name.
    pub fn col(&self, name: &str) -> Option<usize> {
        self.header.iter().position(|h| h == name)
    }

    /// An error on the header line.
    pub fn header_error(&self, column: &str, rule: impl Into<String>) -> FormatError {
        FormatError::new(self.file, self.header_line, column, rule)
    }

    /// Rejects unknown columns (neither `known` nor `x-`) and missing required ones.
    /// `expected` describes the accepted columns for the message.
    pub fn check_columns(
        &self,
        required: &[&str],
        known: impl Fn(&str) -> bool,
        expected: &str,
    ) -> Result<(), FormatError> {
        for name in &self.header {
            if !name.starts_with(IGNORED_PREFIX) && !known(name) {
                return Err(self.header_error(
                    name,
                    format!(
                        "unknown column (expected {expected}; other columns must start with `{IGNORED_PREFIX}`)"
                    ),
                ));
            }
        }
        for r in required {
            if self.col(r).is_none() {
                return Err(self.header_error(r, "required column is missing from the header"));
            }
        }
        Ok(())
    }

    /// Reads the next record into `self.rec`, tracking its physical line.
    fn read_record(&mut self) -> Result<bool, FormatError> {
        let ok = self.rdr.read_byte_record(&mut self.rec).map_err(|e| {
            FormatError::new(self.file, self.scan_line, "", format!("malformed CSV: {e}"))
        })?;
        if !ok {
            self.scan_line += count_newlines(&self.bytes[self.scan_pos..]);
            return Ok(false);
        }
        // The reader reports where it began this record: just after the previous
        // record's terminator, before any blank or comment lines it skipped.
        let mut p = self.rec.position().map_or(0, |p| p.byte() as usize);
        self.scan_line += count_newlines(&self.bytes[self.scan_pos..p]);
        let b = self.bytes;
        while p < b.len() {
            match b[p] {
                b'\n' => {
                    self.scan_line += 1;
                    p += 1;
                }
                b'\r' => p += 1,
                b'#' => match b[p..].iter().position(|&c| c == b'\n') {
                    Some(n) => {
                        p += n + 1;
                        self.scan_line += 1;
                    }
                    None => p = b.len(),
                },
                _ => break,
            }
        }
        self.scan_pos = p;
        self.line = self.scan_line;
        Ok(true)
    }

    /// Advances to the next data row; `false` at the end of the file.
    pub fn next_row(&mut self) -> Result<bool, FormatError> {
        if !self.read_record()? {
            return Ok(false);
        }
        self.rows += 1;
        if self.rows > self.max_rows {
            return Err(self.row_error(
                "",
                format!("file exceeds the limit of {} samples", self.max_rows),
            ));
        }
        if self.rec.len() != self.header.len() {
            return Err(self.row_error(
                "",
                format!(
                    "row has {} fields but the header has {} columns",
                    self.rec.len(),
                    self.header.len()
                ),
            ));
        }
        Ok(true)
    }

    /// Data rows read so far.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Rough number of rows still to come (physical lines left), for reserving columns.
    pub fn remaining_rows_hint(&self) -> usize {
        (self.total_lines.saturating_sub(self.line) + 1) as usize
    }

    /// An error on the current row, in column `column` (empty for the whole row).
    pub fn row_error(&self, column: &str, rule: impl Into<String>) -> FormatError {
        FormatError::new(self.file, self.line, column, rule)
    }

    fn err_at(&self, idx: usize, rule: impl Into<String>) -> FormatError {
        self.row_error(&self.header[idx], rule)
    }

    /// The trimmed cell text of column `idx` in the current row.
    pub fn text(&self, idx: usize) -> &str {
        // UTF-8 was validated for the whole file; a field never splits a character.
        std::str::from_utf8(&self.rec[idx]).map_or("", str::trim)
    }

    /// The cell as a finite decimal number.
    pub fn f64(&self, idx: usize) -> Result<f64, FormatError> {
        let s = self.text(idx);
        match s.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(self.err_at(idx, number_rule(s))),
        }
    }

    /// The cell as a decimal integer.
    pub fn int(&self, idx: usize) -> Result<i64, FormatError> {
        let s = self.text(idx);
        s.parse::<i64>().map_err(|_| {
            self.err_at(
                idx,
                if s.is_empty() {
                    "empty cell: an integer is required".to_string()
                } else {
                    format!("`{s}` is not an integer")
                },
            )
        })
    }

    /// An error about the cell of column `idx` in the current row.
    pub fn cell_error(&self, idx: usize, rule: impl Into<String>) -> FormatError {
        self.err_at(idx, rule)
    }
}

fn number_rule(s: &str) -> String {
    if s.is_empty() {
        return "empty cell: a finite decimal number is required".to_string();
    }
    let lower = s.to_ascii_lowercase();
    let bare = lower.trim_start_matches(['+', '-']);
    if bare.starts_with("nan") || bare.starts_with("inf") {
        format!("`{s}` is not allowed: numbers must be finite (no NaN or infinity)")
    } else if s.parse::<f64>().is_ok() {
        format!("`{s}` overflows: numbers must be finite")
    } else {
        format!("`{s}` is not a decimal number")
    }
}

/// Checks that `t` is strictly greater than the previous time `prev` of the same series.
pub(crate) fn check_increasing(
    t: &CsvTable<'_>,
    idx: usize,
    prev: Option<f64>,
    value: f64,
    scope: &str,
) -> Result<(), FormatError> {
    match prev {
        Some(p) if value <= p => Err(t.cell_error(
            idx,
            format!("time must be strictly increasing within {scope}: {value} follows {p}"),
        )),
        _ => Ok(()),
    }
}

/// Writes `v` so that it reads back to the same `f64` (shortest round-trip form).
pub(crate) fn fmt_f64(out: &mut String, v: f64) {
    use std::fmt::Write;
    let _ = write!(out, "{v}");
}
