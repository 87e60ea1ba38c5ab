//! A rejected input ([`FormatError`]): which file, where, and which rule it broke.

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
    /// A size limit of [`crate::Limits`] was exceeded (bytes, samples, files).
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
