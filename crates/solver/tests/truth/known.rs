//! The false findings the diagnosis makes today on the truth sessions, and the counts of
//! right sessions: the gate of the test `truth_suite` (docs/truth-suite.md).

/// The false findings seen today, per case: each the exact label the scorer gives and
/// one line of what is wrong. Tick an entry off when the diagnosis no longer makes it
/// (a listed one that no longer occurs fails the suite, so the list only shrinks).
/// `TRUTH_KNOWN=1 cargo test -p mtcal-solver --test truth_suite full -- --ignored`
/// prints the entries of today's diagnosis in this form.
pub const KNOWN_DEFECTS: &[(&str, &[(&str, &str)])] = &[];

/// Sessions of the CI subset that are right (no false finding, no missed effect) today.
pub const RIGHT_CI: usize = 52;
/// Sessions of the full suite that are right today.
pub const RIGHT_ALL: usize = 79;
