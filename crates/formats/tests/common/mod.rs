//! Helpers shared by the format tests.
#![allow(dead_code)]

use flate2::Compression;
use flate2::write::GzEncoder;
use mtcal_formats::FormatError;
use std::io::Write;

/// Asserts an error's file, line and column exactly and that its rule contains `rule`.
#[track_caller]
pub fn check(e: &FormatError, file: &str, line: u64, column: &str, rule: &str) {
    assert_eq!(
        (e.file.as_str(), e.line, e.column.as_str()),
        (file, line, column),
        "{e}"
    );
    assert!(
        e.rule.contains(rule),
        "rule `{}` should contain `{rule}`",
        e.rule
    );
    // The Display form carries the parts it is tied to (no `:0:` for a whole file).
    let place = match (line, column.is_empty()) {
        (0, true) => String::new(),
        (0, false) => format!(": {column}"),
        (l, true) => format!(":{l}"),
        (l, false) => format!(":{l}:{column}"),
    };
    assert_eq!(e.to_string(), format!("{file}{place}: {}", e.rule));
}

pub fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut e = GzEncoder::new(Vec::new(), Compression::default());
    e.write_all(bytes).unwrap();
    e.finish().unwrap()
}
