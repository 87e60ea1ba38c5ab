//! # mtcal-formats
//!
//! Strict readers (and writers) of the dataset formats in `docs/datasets.md`: every
//! rejected file gets an error naming the file, the line, the column and the rule.

pub mod plots;

/// A rejected input: which file, where, and which rule it broke.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{file}:{line}:{column}: {rule}")]
pub struct FormatError {
    pub file: String,
    /// 1-based line number; 0 when the problem is not tied to a line (e.g. a missing file).
    pub line: u64,
    /// Column name (or JSON field), empty when not tied to a column.
    pub column: String,
    /// The rule that was broken, as a sentence.
    pub rule: String,
}
