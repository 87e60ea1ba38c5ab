//! Subcommands. Each returns `Ok(code)` or an error; [`finish`] maps errors to exit codes:
//! 2 for bad input (a [`BadInput`] anywhere in the chain), 1 for everything else.

use std::process::ExitCode;

pub mod admin;
pub mod cradle;
pub mod demo;
pub mod diagnose;
pub mod identify;
pub mod sensitivity;
pub mod serve;
pub mod simulate;
pub mod standards;
pub mod submit;

/// Marks an error as the user's input being wrong (exit code 2).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct BadInput(pub String);

/// Prints the error chain to stderr and picks the exit code.
/// Writes a command's output to stdout. A closed pipe (`mtcal identify … --json | head`)
/// is not an error: the reader has what it wanted, so the command ends quietly instead of
/// panicking as `println!` does.
pub fn emit(text: &str) -> anyhow::Result<()> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => {
            Err(anyhow::Error::new(e).context("writing to stdout"))
        }
        _ => Ok(()),
    }
}

pub fn finish(result: anyhow::Result<ExitCode>) -> ExitCode {
    match result {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
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
