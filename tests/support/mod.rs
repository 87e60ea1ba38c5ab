//! What the top-level tests share: running the `mtcal` program under test. Each test
//! binary declares it (`mod support;`; the end-to-end tests by its path) and uses what it
//! needs.

#![allow(dead_code)]

use std::process::{Command, Output};

/// The program under test, as Cargo built it for these tests.
pub const BIN: &str = env!("CARGO_BIN_EXE_mtcal");

/// `mtcal` with `args`, not yet run (to set its environment, input or streams).
pub fn command(args: &[&str]) -> Command {
    let mut c = Command::new(BIN);
    c.args(args);
    c
}

/// Runs `mtcal` with `args`: its exit status and output, whatever they are.
pub fn mtcal(args: &[&str]) -> Output {
    command(args).output().expect("mtcal runs")
}

/// Runs `mtcal` with `args`, which must succeed (its standard error in the failure
/// message otherwise): its standard output.
pub fn mtcal_ok(args: &[&str]) -> String {
    let o = mtcal(args);
    assert!(
        o.status.success(),
        "mtcal {args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8(o.stdout).expect("mtcal writes UTF-8")
}
