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
//! * at most [`Limits::max_samples_per_file`] rows, [`Limits::max_columns`] columns and
//!   [`Limits::max_line_bytes`] bytes per record; the deadline of [`Limits`], when set,
//!   is looked at when a file is opened and every [`Limits::DEADLINE_CHECK_ROWS`] rows.
//!
//! Line numbers are 1-based physical lines of the file (comments and blank lines count).
//! Rows are read into a reused [`csv::ByteRecord`]: no allocation per row.

use crate::limits::Quantity;
use crate::{FormatError, Limits};

/// The UTF-8 encoding of U+FEFF, which some tools write at the start of a file.
pub(crate) const UTF8_BOM: [u8; 3] = [0xef, 0xbb, 0xbf];

/// Prefix of the columns that are accepted and ignored.
pub const IGNORED_PREFIX: &str = "x-";

pub(crate) struct CsvTable<'a> {
    file: &'a str,
    bytes: &'a [u8],
    rdr: csv::Reader<&'a [u8]>,
    rec: csv::ByteRecord,
    header: Vec<String>,
    /// Byte offsets where the reader began the header and the current record (just after
    /// the previous record's terminator); line numbers are computed from them only when
    /// an error is reported, so reading pays nothing for them.
    header_pos: usize,
    rec_pos: usize,
    rows: usize,
    limits: Limits,
}

fn count_newlines(bytes: &[u8]) -> u64 {
    bytes.iter().filter(|&&b| b == b'\n').count() as u64
}

impl<'a> CsvTable<'a> {
    /// Checks the encoding and reads the header.
    /// A leading UTF-8 byte-order mark (spreadsheet exports) is skipped.
    pub fn open(file: &'a str, bytes: &'a [u8], limits: &Limits) -> Result<Self, FormatError> {
        let bom = bytes.starts_with(&UTF8_BOM);
        let bytes = bytes.strip_prefix(UTF8_BOM.as_slice()).unwrap_or(bytes);
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
            .delimiter(limits.csv_dialect.delimiter())
            .flexible(true)
            .from_reader(bytes);
        let mut t = CsvTable {
            file,
            bytes,
            rdr,
            rec: csv::ByteRecord::new(),
            header: Vec::new(),
            header_pos: 0,
            rec_pos: 0,
            rows: 0,
            limits: *limits,
        };
        limits.check_deadline(file, 0)?;
        if !t.read_record()? {
            return Err(FormatError::new(
                file,
                count_newlines(bytes) + 1,
                "",
                "header required: the file has no header line (only comments or nothing)",
            ));
        }
        t.header_pos = t.rec_pos;
        t.check_dialect(bom)?;
        let mut header: Vec<String> = Vec::with_capacity(t.rec.len());
        for (i, f) in t.rec.iter().enumerate() {
            // UTF-8 was checked above for the whole file.
            let name = String::from_utf8_lossy(f).trim().to_string();
            if name.is_empty() {
                return Err(t.header_error("", format!("empty column name (column {})", i + 1)));
            }
            header.push(name);
        }
        // The duplicate check through a set: a header of n columns costs O(n), not O(n²).
        let mut seen = std::collections::HashSet::with_capacity(header.len());
        if let Some(dup) = header.iter().find(|n| !seen.insert(n.as_str())) {
            return Err(t.header_error(dup, "duplicate column name"));
        }
        drop(seen);
        t.header = header;
        Ok(t)
    }

    /// Refuses a header written in the other dialect (one column whose name holds the
    /// other dialect's separator between several names), saying what to change.
    fn check_dialect(&self, bom: bool) -> Result<(), FormatError> {
        use crate::CsvDialect::{Excel, Plain};
        let [only] = self.rec.iter().collect::<Vec<_>>()[..] else {
            return Ok(());
        };
        let other = match self.limits.csv_dialect {
            Plain => b';',
            Excel => b',',
        };
        let names = only
            .split(|&b| b == other)
            .filter(|n| !n.trim_ascii().is_empty())
            .count();
        if names < 2 {
            return Ok(());
        }
        let bom = if bom {
            " (its UTF-8 byte-order mark, also written by spreadsheets, is fine in either \
             dialect)"
        } else {
            ""
        };
        Err(self.header_error(
            "",
            match self.limits.csv_dialect {
                Plain => format!(
                    "the header is separated by `;`, as a spreadsheet saves CSV in a locale \
                     with decimal commas{bom}: save the file with `,` separators and `.` \
                     decimal points, or have it read in the Excel dialect ({EXCEL_OPTION})"
                ),
                Excel => format!(
                    "the header is separated by `,` but the file is read in the Excel \
                     dialect (`;` separators){bom}: read it in the plain dialect (leave out \
                     `--csv-dialect excel` or the upload field `csv_dialect=excel`)"
                ),
            },
        ))
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
        FormatError::new(self.file, self.line_at(self.header_pos), column, rule)
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

    /// [`Self::check_columns`] for a fixed list of columns, the first `required` of them
    /// required and the rest optional; returns the indices of the required ones in order.
    pub fn check_schema(
        &self,
        columns: &[&str],
        required: usize,
    ) -> Result<Vec<usize>, FormatError> {
        let mut expected = columns[..required].join(", ");
        if required < columns.len() {
            expected += &format!(" and optionally {}", columns[required..].join(", "));
        }
        self.check_columns(&columns[..required], |c| columns.contains(&c), &expected)?;
        Ok(columns[..required]
            .iter()
            .map(|n| self.col(n).unwrap_or_default())
            .collect())
    }

    /// Reads the next record into `self.rec`, remembering where it began.
    fn read_record(&mut self) -> Result<bool, FormatError> {
        let ok = self.rdr.read_byte_record(&mut self.rec).map_err(|e| {
            let pos = e.position().map_or(self.rec_pos, |p| p.byte() as usize);
            FormatError::new(
                self.file,
                self.line_at(pos),
                "",
                format!("malformed CSV: {e}"),
            )
        })?;
        if ok {
            self.rec_pos = self.rec.position().map_or(0, |p| p.byte() as usize);
            let max_columns = self.limits.max_columns;
            if self.rec.len() > max_columns {
                let n = self.rec.len();
                return Err(self
                    .row_error(
                        "",
                        if self.header.is_empty() {
                            format!(
                                "the header has {n} columns, more than the limit of \
                                 {max_columns} (configurable)"
                            )
                        } else {
                            format!(
                                "row has {n} fields, more than the limit of {max_columns} \
                                 columns (configurable)"
                            )
                        },
                    )
                    .as_limit());
            }
            // The record's bytes without quotes, plus one separator per field.
            let len = self.rec.as_slice().len() + self.rec.len();
            if len > self.limits.max_line_bytes {
                return Err(self
                    .row_error(
                        "",
                        format!(
                            "line is longer than the limit of {} bytes (configurable)",
                            self.limits.max_line_bytes
                        ),
                    )
                    .as_limit());
            }
        }
        Ok(ok)
    }

    /// The 1-based physical line of the first record starting at or after `pos`: the
    /// reader skips blank lines and `#` comment lines before a record.
    fn line_at(&self, pos: usize) -> u64 {
        let b = self.bytes;
        let mut p = pos.min(b.len());
        let mut line = 1 + count_newlines(&b[..p]);
        while p < b.len() {
            match b[p] {
                b'\n' => {
                    line += 1;
                    p += 1;
                }
                b'\r' => p += 1,
                b'#' => match b[p..].iter().position(|&c| c == b'\n') {
                    Some(n) => {
                        p += n + 1;
                        line += 1;
                    }
                    None => p = b.len(),
                },
                _ => break,
            }
        }
        line
    }

    /// Advances to the next data row; `false` at the end of the file.
    pub fn next_row(&mut self) -> Result<bool, FormatError> {
        if !self.read_record()? {
            return Ok(false);
        }
        self.rows += 1;
        if self.rows > self.limits.max_samples_per_file {
            return Err(self
                .row_error(
                    "",
                    format!(
                        "file exceeds the limit of {} samples",
                        self.limits.max_samples_per_file
                    ),
                )
                .as_limit());
        }
        if self.rows.is_multiple_of(Limits::DEADLINE_CHECK_ROWS) {
            self.limits
                .check_deadline(self.file, self.line_at(self.rec_pos))?;
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

    /// Rough number of rows still to come, for reserving columns: the bytes left divided
    /// by the length of the current row (+ 1 for its terminator).
    pub fn remaining_rows_hint(&self) -> usize {
        let row_len = self.rec.as_slice().len() + self.rec.len();
        let left = self.bytes.len().saturating_sub(self.rec_pos);
        (left / row_len.max(1) + 1).min(self.limits.max_samples_per_file)
    }

    /// An error on the current row, in column `column` (empty for the whole row).
    pub fn row_error(&self, column: &str, rule: impl Into<String>) -> FormatError {
        FormatError::new(self.file, self.line_at(self.rec_pos), column, rule)
    }

    fn err_at(&self, idx: usize, rule: impl Into<String>) -> FormatError {
        self.row_error(&self.header[idx], rule)
    }

    /// The trimmed cell text of column `idx` in the current row.
    pub fn text(&self, idx: usize) -> &str {
        // UTF-8 was validated for the whole file; a field never splits a character.
        std::str::from_utf8(&self.rec[idx]).map_or("", str::trim)
    }

    /// The cell as a finite decimal number (in the Excel dialect, a decimal comma reads
    /// as a decimal point).
    pub fn f64(&self, idx: usize) -> Result<f64, FormatError> {
        if let Some(v) = fast_decimal(&self.rec[idx]) {
            return Ok(v);
        }
        let s = self.text(idx);
        let parsed = if self.limits.csv_dialect == crate::CsvDialect::Excel && s.contains(',') {
            s.replacen(',', ".", 1).parse::<f64>()
        } else {
            s.parse::<f64>()
        };
        match parsed {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(self.err_at(idx, number_rule(s, self.limits.csv_dialect))),
        }
    }

    /// The cell as a number within the plausibility bound of [`Limits`] for quantity `q`.
    pub fn quantity(&self, idx: usize, q: Quantity) -> Result<f64, FormatError> {
        let v = self.f64(idx)?;
        let max = q.bound(&self.limits);
        if v.abs() > max {
            return Err(self.err_at(
                idx,
                format!(
                    "{v:e} is beyond the plausible {} of ±{max} ({}; the limit is configurable)",
                    q.what(),
                    q.hint()
                ),
            ));
        }
        Ok(v)
    }

    /// The cell as a decimal integer.
    pub fn int(&self, idx: usize) -> Result<i64, FormatError> {
        if let Some(v) = fast_int(&self.rec[idx]) {
            return Ok(v);
        }
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

/// Exact powers of ten representable in an `f64` (10²² is the largest).
const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// Fast path for the common cell `[+-]digits[.digits]` (no exponent, no spaces): with at
/// most 19 digits, a mantissa m ≤ 2⁵³ and k ≤ 22 decimals, m and 10^k are exact doubles
/// and one IEEE division m / 10^k is correctly rounded (Clinger 1990, "How to read
/// floating point numbers accurately"), so the result equals `str::parse::<f64>`.
/// Anything else returns `None` and takes the general path.
fn fast_decimal(b: &[u8]) -> Option<f64> {
    let (neg, digits) = match b.first()? {
        b'-' => (true, &b[1..]),
        b'+' => (false, &b[1..]),
        _ => (false, b),
    };
    let (mut m, mut n, mut frac, mut dot) = (0u64, 0u32, 0usize, false);
    for &c in digits {
        match c {
            b'0'..=b'9' => {
                n += 1;
                if n > 19 {
                    return None;
                }
                m = m * 10 + u64::from(c - b'0');
                frac += usize::from(dot);
            }
            b'.' if !dot => dot = true,
            _ => return None,
        }
    }
    if n == 0 || m > 1 << 53 || frac >= POW10.len() {
        return None;
    }
    let v = m as f64 / POW10[frac];
    Some(if neg { -v } else { v })
}

/// Fast path for `[+-]digits` with at most 18 digits (no overflow possible).
fn fast_int(b: &[u8]) -> Option<i64> {
    let (neg, digits) = match b.first()? {
        b'-' => (true, &b[1..]),
        b'+' => (false, &b[1..]),
        _ => (false, b),
    };
    if digits.is_empty() || digits.len() > 18 {
        return None;
    }
    let mut v = 0i64;
    for &c in digits {
        if !c.is_ascii_digit() {
            return None;
        }
        v = v * 10 + i64::from(c - b'0');
    }
    Some(if neg { -v } else { v })
}

/// How to have a file read in the Excel dialect, for messages.
const EXCEL_OPTION: &str = "`--csv-dialect excel`, or the upload field `csv_dialect=excel`";

fn number_rule(s: &str, dialect: crate::CsvDialect) -> String {
    if s.is_empty() {
        return "empty cell: a finite decimal number is required".to_string();
    }
    let dotted = s.replace(',', ".");
    if dialect == crate::CsvDialect::Plain
        && s.matches(',').count() == 1
        && dotted.parse::<f64>().is_ok()
    {
        return format!(
            "`{s}` has a decimal comma: write `{dotted}` (`.` is the decimal point), or have \
             the file read in the Excel dialect ({EXCEL_OPTION})"
        );
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The fast path must agree bit for bit with the standard parser wherever it answers.
    #[test]
    fn fast_paths_agree_with_std() {
        let mut cases: Vec<String> = [
            "0",
            "-0",
            "+0",
            "1.",
            "-1.",
            ".5",
            "-.5",
            "0.1",
            "0.3",
            "123.456",
            "-100.0000",
            "9007199254740992",
            "9007199254740993",
            "0.0000000000000000000001",
            "1234567890123456789",
            "12345678901234567890",
            "1e5",
            " 1",
            "1 ",
            "1..2",
            ".",
            "-",
            "",
            "+-1",
            "0x10",
            "1,5",
            "٣",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        // Pseudo-random decimals of every length and precision (a fixed LCG: reproducible).
        let mut x: u64 = 0x2545_f491_4f6c_dd1d;
        for _ in 0..200_000 {
            x = x
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            let digits = 1 + (x >> 60) as usize;
            let mant = (x >> 4) % 10u64.pow(digits.min(18) as u32);
            let dot = ((x >> 32) % (digits as u64 + 2)) as usize;
            let mut s = format!("{mant:0digits$}");
            if dot <= s.len() {
                s.insert(dot, '.');
            }
            if x & 1 == 1 {
                s.insert(0, '-');
            }
            cases.push(s);
        }
        let mut fast_hits = 0;
        for s in &cases {
            if let Some(v) = fast_decimal(s.as_bytes()) {
                fast_hits += 1;
                let std: f64 = s.parse().expect(s);
                assert_eq!(v.to_bits(), std.to_bits(), "{s}");
            }
            if let Some(v) = fast_int(s.as_bytes()) {
                assert_eq!(Ok(v), s.parse::<i64>(), "{s}");
            }
        }
        // The generator must exercise the fast path, not only the fallback.
        assert!(fast_hits > 150_000, "{fast_hits}");
        for s in ["", "-", ".", "1e5", " 1", "0x10", "1..2"] {
            assert_eq!(fast_decimal(s.as_bytes()), None, "{s}");
        }
    }
}
