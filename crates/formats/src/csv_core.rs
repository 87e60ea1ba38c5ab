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
//!
//! How a file is split into records and fields is csv-core's (RFC 4180 quoting; `\n`,
//! `\r` and `\r\n` each end a record; blank lines skipped; `#` starts a comment line,
//! also as the last line without a line break). A record without a quoted field is
//! split here directly, by `memchr` over the file's text, into ranges of that text (no
//! copy, and no UTF-8 check per cell: the whole file was checked once); a record with
//! one is handed to csv-core, whose unquoted fields are kept in a reused buffer. Both
//! give the same fields as csv-core's definition (tested).
//!
//! A reader that declares its numeric columns ([`CsvTable::scan`]) has each row read in
//! one pass in file order, every number parsed where it stands and checked (finite,
//! within its bound); a row that does not pass is read cell by cell, whose rules give
//! the error, so both give the same values and errors (tested).

use crate::limits::Quantity;
use crate::{FormatError, Limits};
use std::ops::Range;

/// The UTF-8 encoding of U+FEFF, which some tools write at the start of a file.
pub(crate) const UTF8_BOM: [u8; 3] = [0xef, 0xbb, 0xbf];

/// Prefix of the columns that are accepted and ignored.
pub const IGNORED_PREFIX: &str = "x-";

pub(crate) struct CsvTable<'a> {
    file: &'a str,
    /// The file after its byte-order mark, checked as UTF-8 once.
    text: &'a str,
    /// Where the next record is looked for.
    pos: usize,
    /// The fields of the current record: ranges of `text`, or of `quoted` when the
    /// record held a quote character.
    fields: Vec<Range<usize>>,
    quoted: Option<String>,
    /// Reused by records with quotes: csv-core's reader, its output and field ends.
    core: csv_core::Reader,
    out: Vec<u8>,
    ends: Vec<usize>,
    header: Vec<String>,
    /// What each column holds, when the reader declared its numbers ([`Self::scan`]):
    /// rows are then read in one pass, and the numbers of a row that passes it kept in
    /// `values` (`scanned`).
    plan: Vec<Cell>,
    values: Vec<f64>,
    scanned: bool,
    /// Byte offsets where the header and the current record begin; line numbers are
    /// computed from them only when an error is reported, so reading pays nothing for
    /// them.
    header_pos: usize,
    rec_pos: usize,
    rows: usize,
    delimiter: u8,
    limits: Limits,
}

fn count_newlines(bytes: &[u8]) -> u64 {
    memchr::memchr_iter(b'\n', bytes).count() as u64
}

impl<'a> CsvTable<'a> {
    /// Checks the encoding and reads the header.
    /// A leading UTF-8 byte-order mark (spreadsheet exports) is skipped.
    pub fn open(file: &'a str, bytes: &'a [u8], limits: &Limits) -> Result<Self, FormatError> {
        let bom = bytes.starts_with(&UTF8_BOM);
        let bytes = bytes.strip_prefix(UTF8_BOM.as_slice()).unwrap_or(bytes);
        let text = match std::str::from_utf8(bytes) {
            Ok(text) => text,
            Err(e) => {
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
        };
        let mut t = CsvTable::over(file, text, limits);
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
        let mut header: Vec<String> = Vec::with_capacity(t.fields.len());
        for i in 0..t.fields.len() {
            let name = t.cell(i).trim().to_string();
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

    /// A table over `text`, before its first record.
    fn over(file: &'a str, text: &'a str, limits: &Limits) -> Self {
        let delimiter = limits.csv_dialect.delimiter();
        CsvTable {
            file,
            text,
            pos: 0,
            fields: Vec::new(),
            quoted: None,
            core: csv_core_reader(delimiter),
            out: Vec::new(),
            ends: Vec::new(),
            header: Vec::new(),
            plan: Vec::new(),
            values: Vec::new(),
            scanned: false,
            header_pos: 0,
            rec_pos: 0,
            rows: 0,
            delimiter,
            limits: *limits,
        }
    }

    /// Refuses a header written in the other dialect (one column whose name holds the
    /// other dialect's separator between several names), saying what to change.
    fn check_dialect(&self, bom: bool) -> Result<(), FormatError> {
        use crate::CsvDialect::{Excel, Plain};
        if self.fields.len() != 1 {
            return Ok(());
        }
        let only = self.cell(0);
        let other = match self.limits.csv_dialect {
            Plain => ';',
            Excel => ',',
        };
        let names = only
            .split(other)
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

    /// Reads the next record (its fields into `self.fields`), remembering where it
    /// began; `false` at the end of the file.
    fn read_record(&mut self) -> Result<bool, FormatError> {
        match self.next_record_start() {
            Some(p) => self.split_record(p).map(|()| true),
            None => Ok(false),
        }
    }

    /// Where the next record begins, after the line terminators (blank lines) and
    /// comment lines (a `#` up to the next `\n`) csv-core skips before a record; `None`
    /// at the end of the file.
    fn next_record_start(&mut self) -> Option<usize> {
        let b = self.text.as_bytes();
        let mut p = self.pos;
        loop {
            match b.get(p) {
                None => {
                    self.pos = p;
                    return None;
                }
                Some(b'\n' | b'\r') => p += 1,
                Some(b'#') => p = memchr::memchr(b'\n', &b[p..]).map_or(b.len(), |n| p + n + 1),
                Some(_) => return Some(p),
            }
        }
    }

    /// Splits the record that begins at `p` into `self.fields`.
    fn split_record(&mut self, p: usize) -> Result<(), FormatError> {
        let b = self.text.as_bytes();
        self.rec_pos = p;
        self.scanned = false;
        // One pass over the record: separators and terminators. A quote character only
        // matters at the start of a field (elsewhere csv-core keeps it as text): a record
        // with a quoted field, or with more fields than the limit, goes to csv-core.
        self.quoted = None;
        self.fields.clear();
        let mut start = p;
        let mut hits = memchr::memchr3_iter(self.delimiter, b'\n', b'\r', &b[p..]);
        let end = loop {
            if b.get(start) == Some(&b'"') || self.fields.len() == self.limits.max_columns {
                return self.read_record_by_csv_core(p);
            }
            match hits.next() {
                Some(i) if b[p + i] == self.delimiter => {
                    self.fields.push(start..p + i);
                    start = p + i + 1;
                }
                Some(i) => break p + i,
                None => break b.len(),
            }
        };
        self.fields.push(start..end);
        self.pos = end;
        // The record's bytes plus one separator per field, as csv-core counts them.
        self.check_record_bytes(end - p + 1)
    }

    /// Declares the numeric columns a reader takes (column index and quantity; the other
    /// columns are text to it): from here on each row is read in one pass in file order,
    /// every number parsed where it stands ([`Self::scan_row`]), and [`Self::quantity`]
    /// answers from that pass. A row the pass does not accept is read cell by cell as
    /// without a declaration, so values and errors are the same.
    pub fn scan(&mut self, numbers: &[(usize, Quantity)]) {
        self.plan = vec![Cell::Text; self.header.len()];
        for &(i, q) in numbers {
            self.plan[i] = Cell::Number(q);
        }
        self.values = vec![0.0; self.header.len()];
    }

    /// One pass over the row that begins at `p`, in file order: each declared number is
    /// parsed where it stands by `fast_float2::parse_partial` (Eisel–Lemire, the
    /// algorithm of the standard library's parser, which finds the number's end as it
    /// parses: no separate search for the separator) and must be followed by the
    /// separator (by the line's end for the last column), finite and within its bound;
    /// the other fields are delimited. `false` (a quoted field, a number with anything
    /// else around it, a value beyond its bound, another field count, a long line):
    /// nothing is kept and the row takes the general path, whose rules give the error.
    fn scan_row(&mut self, p: usize) -> bool {
        let b = self.text.as_bytes();
        let d = self.delimiter;
        let last = self.plan.len() - 1;
        self.fields.clear();
        self.quoted = None;
        let mut at = p;
        for (i, cell) in self.plan.iter().enumerate() {
            let end = match *cell {
                Cell::Number(q) => match fast_float2::parse_partial::<f64, _>(&b[at..]) {
                    Ok((v, n)) if v.is_finite() && v.abs() <= q.bound(&self.limits) => {
                        self.values[i] = v;
                        at + n
                    }
                    _ => return false,
                },
                Cell::Text if b.get(at) == Some(&b'"') => return false,
                Cell::Text => field_end(&b[at..], d).map_or(b.len(), |n| at + n),
            };
            let next = b.get(end).copied();
            let ends_field = if i < last {
                next == Some(d)
            } else {
                matches!(next, None | Some(b'\n' | b'\r'))
            };
            if !ends_field {
                return false;
            }
            self.fields.push(at..end);
            at = end + 1;
        }
        let end = at - 1;
        if end - p + 1 > self.limits.max_line_bytes {
            return false;
        }
        self.rec_pos = p;
        self.pos = end;
        self.scanned = true;
        true
    }

    /// A record split by csv-core from byte `start` on: one holding a quoted field (which
    /// may span lines), or more fields than the limit. Its fields and their ends are kept up to the limits
    /// (a record beyond them is refused: past a limit csv-core's output is only counted,
    /// so a huge record costs no memory and gets the error a kept one would).
    fn read_record_by_csv_core(&mut self, start: usize) -> Result<(), FormatError> {
        use csv_core::ReadRecordResult as R;
        let input = &self.text.as_bytes()[start..];
        let max_bytes = self.limits.max_line_bytes.saturating_add(1);
        let max_ends = self.limits.max_columns.saturating_add(1);
        self.core.reset();
        let (mut nin, mut nout, mut nends) = (0, 0, 0);
        loop {
            let (res, i, o, e) = self.core.read_record(
                &input[nin..],
                window(&mut self.out, nout, max_bytes),
                window(&mut self.ends, nends, max_ends),
            );
            nin += i;
            nout += o;
            nends += e;
            if matches!(res, R::Record | R::End) {
                break;
            }
        }
        self.pos = start + nin;
        if nends > self.limits.max_columns {
            return Err(self.too_many_fields(nends));
        }
        // The record's bytes without quotes, plus one separator per field.
        self.check_record_bytes(nout + nends)?;
        // The fields are the record's text without some ASCII bytes (quotes, separators):
        // still UTF-8, cut at character boundaries.
        let unquoted = String::from_utf8_lossy(&self.out[..nout]).into_owned();
        self.fields.clear();
        let mut from = 0;
        for &to in &self.ends[..nends] {
            self.fields.push(from..to);
            from = to;
        }
        self.quoted = Some(unquoted);
        Ok(())
    }

    /// The column limit, for a record of `n` fields.
    fn too_many_fields(&self, n: usize) -> FormatError {
        let max_columns = self.limits.max_columns;
        self.row_error(
            "",
            if self.header.is_empty() {
                format!(
                    "the header has {n} columns, more than the limit of {max_columns} \
                     (configurable)"
                )
            } else {
                format!(
                    "row has {n} fields, more than the limit of {max_columns} columns \
                     (configurable)"
                )
            },
        )
        .as_limit()
    }

    /// The record-length limit, for a record of `len` bytes (quotes not counted, one
    /// separator per field).
    fn check_record_bytes(&self, len: usize) -> Result<(), FormatError> {
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
        Ok(())
    }

    /// The text of field `idx` of the current record (untrimmed).
    #[inline]
    fn cell(&self, idx: usize) -> &str {
        let r = self.fields[idx].clone();
        match &self.quoted {
            None => &self.text[r],
            Some(q) => &q[r],
        }
    }

    /// The 1-based physical line of the first record starting at or after `pos`: the
    /// reader skips blank lines and `#` comment lines before a record.
    fn line_at(&self, pos: usize) -> u64 {
        let b = self.text.as_bytes();
        let mut p = pos.min(b.len());
        let mut line = 1 + count_newlines(&b[..p]);
        while p < b.len() {
            match b[p] {
                b'\n' => {
                    line += 1;
                    p += 1;
                }
                b'\r' => p += 1,
                b'#' => match memchr::memchr(b'\n', &b[p..]) {
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
        let Some(p) = self.next_record_start() else {
            return Ok(false);
        };
        if self.plan.is_empty() || !self.scan_row(p) {
            self.split_record(p)?;
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
                .check_deadline_at(self.file, || self.line_at(self.rec_pos))?;
        }
        if self.fields.len() != self.header.len() {
            return Err(self.row_error(
                "",
                format!(
                    "row has {} fields but the header has {} columns",
                    self.fields.len(),
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
        let row_len = self.pos - self.rec_pos + 1;
        let left = self.text.len().saturating_sub(self.rec_pos);
        (left / row_len + 1).min(self.limits.max_samples_per_file)
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
        self.cell(idx).trim()
    }

    /// The cell as a finite decimal number (in the Excel dialect, a decimal comma reads
    /// as a decimal point).
    pub fn f64(&self, idx: usize) -> Result<f64, FormatError> {
        if let Ok(v) = self.cell(idx).parse::<f64>()
            && v.is_finite()
        {
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
    #[inline]
    pub fn quantity(&self, idx: usize, q: Quantity) -> Result<f64, FormatError> {
        if self.scanned && self.plan[idx] == Cell::Number(q) {
            return Ok(self.values[idx]);
        }
        self.quantity_of_cell(idx, q)
    }

    /// [`Self::quantity`] from the cell's text.
    fn quantity_of_cell(&self, idx: usize, q: Quantity) -> Result<f64, FormatError> {
        let v = self.f64(idx)?;
        match q.beyond(v, &self.limits) {
            Some(why) => Err(self.err_at(idx, why)),
            None => Ok(v),
        }
    }

    /// The cell as a decimal integer.
    pub fn int(&self, idx: usize) -> Result<i64, FormatError> {
        if let Ok(v) = self.cell(idx).parse::<i64>() {
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

/// Where the field at the start of `b` ends (its separator `d` or a line end): a short
/// field (a run number, a label) is searched byte by byte, a longer one by `memchr`.
#[inline]
fn field_end(b: &[u8], d: u8) -> Option<usize> {
    const SHORT: usize = 16;
    let head = &b[..b.len().min(SHORT)];
    match head
        .iter()
        .position(|&c| c == d || c == b'\n' || c == b'\r')
    {
        Some(n) => Some(n),
        None if b.len() <= SHORT => None,
        None => memchr::memchr3(d, b'\n', b'\r', &b[SHORT..]).map(|n| SHORT + n),
    }
}

/// What a reader takes from a column, for the one-pass row scan ([`CsvTable::scan`]).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Cell {
    /// A finite number within the bound of its quantity.
    Number(Quantity),
    /// Anything else (an integer, a label, an ignored column): read from its text.
    Text,
}

/// The part of a record buffer csv-core writes next: from `used` on, grown (by doubling)
/// up to `cap` elements; once `cap` is reached, a window at the start, overwritten (the
/// record is then refused, only the counts matter).
fn window<T: Default + Clone>(buf: &mut Vec<T>, used: usize, cap: usize) -> &mut [T] {
    if used >= cap {
        if buf.is_empty() {
            buf.push(T::default());
        }
        let n = buf.len().min(64);
        return &mut buf[..n];
    }
    if buf.len() <= used {
        let len = (2 * buf.len()).max(used + 64).min(cap);
        buf.resize(len, T::default());
    }
    &mut buf[used..]
}

/// csv-core's reader with the datasets' settings: `delimiter`, `"` quoting, `#`
/// comment lines, any of `\n`, `\r`, `\r\n` ending a record.
fn csv_core_reader(delimiter: u8) -> csv_core::Reader {
    csv_core::ReaderBuilder::new()
        .delimiter(delimiter)
        .comment(Some(b'#'))
        .build()
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

/// Checks that `t` is strictly greater than the previous time `prev` of the same series
/// (`scope` names the series in the message: formatted only for an error).
pub(crate) fn check_increasing(
    t: &CsvTable<'_>,
    idx: usize,
    prev: Option<f64>,
    value: f64,
    scope: impl std::fmt::Display,
) -> Result<(), FormatError> {
    match prev {
        Some(p) if value <= p => Err(t.cell_error(
            idx,
            format!("time must be strictly increasing within {scope}: {value} follows {p}"),
        )),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests;
