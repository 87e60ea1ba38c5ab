//! Standard output of every command: what a command prints goes through [`write`] (or
//! [`outln!`]), so that a closed pipe is handled in one place and the same way.
//!
//! A reader that stops reading (`mtcal identify … --json | head -1`) closes the pipe. Rust
//! ignores SIGPIPE, so the next write fails with EPIPE instead of killing the process;
//! [`write`] gives that as [`ClosedPipe`], the command returns it with `?` (dropping its
//! guards on the way: a demo's temporary folder, a progress bar) and [`super::finish`]
//! ends the process quietly with exit code 0: the reader asked for no more, which is not
//! a failure. Any other write error (a full disk behind a redirection) is an error, exit
//! code 1. `println!` is not used: it panics on a closed pipe.
//!
//! The long-running commands (`serve`, `worker`, `demo`) print only announcements (the
//! address they listen on, the demo's URLs) through [`announce`]: a closed stdout does
//! not stop them, since their work is answering requests and running jobs and their logs
//! go to stderr; the line is dropped. SIGPIPE is deliberately not reset to its default
//! action: that would end a service without a word whenever a pipe it writes to closed.
//!
//! Notes for a person (what was written where, progress, an error's message) go to
//! stderr through [`note`] (or [`noteln!`]): a closed stderr loses the note and changes
//! nothing else, the command keeps its work and its exit code. `eprintln!` is not used:
//! it panics on a closed stderr (the crate denies clippy's `print_stderr`).

use anyhow::Context;
use std::io::Write;

/// The reader of stdout has gone: the command ends quietly, exit code 0.
#[derive(Debug, thiserror::Error)]
#[error("stdout was closed by its reader")]
pub struct ClosedPipe;

/// Writes `text` to stdout and flushes it; a closed pipe is [`ClosedPipe`].
pub fn write(text: &str) -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Err(ClosedPipe.into()),
        Err(e) => Err(anyhow::Error::new(e).context("writing to stdout")),
    }
}

/// Writes a command's document: as pretty JSON with a final line end when `json`
/// (`--json`), else the text `summary` makes of it; through [`write`].
pub fn document<T: serde::Serialize>(
    json: bool,
    doc: &T,
    summary: impl FnOnce(&T) -> String,
) -> anyhow::Result<()> {
    let text = if json {
        serde_json::to_string_pretty(doc).context("serialising the document")? + "\n"
    } else {
        summary(doc)
    };
    write(&text)
}

/// Whether an error is (or was caused by) a closed stdout.
pub fn is_closed_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| c.is::<ClosedPipe>())
}

/// Writes a long-running command's announcement line: dropped when stdout is closed (the
/// command carries on), any other failure noted in the log.
pub fn announce(line: &str) {
    if let Err(e) = write(&format!("{line}\n"))
        && !is_closed_pipe(&e)
    {
        tracing::warn!("{e:#}");
    }
}

/// Writes `text` and a line end to stderr; a failure (a closed stderr) is ignored: the
/// note is lost, the command carries on.
pub fn note(text: &str) {
    let mut err = std::io::stderr().lock();
    let _ = err
        .write_all(text.as_bytes())
        .and_then(|()| err.write_all(b"\n"))
        .and_then(|()| err.flush());
}

/// `eprintln!` through [`note`]: `noteln!("…", args)`.
macro_rules! noteln {
    ($($arg:tt)*) => {
        $crate::cli::out::note(&format!($($arg)*))
    };
}
pub(crate) use noteln;

/// `println!` through [`write`]: `outln!("…", args)?`.
macro_rules! outln {
    ($($arg:tt)*) => {
        $crate::cli::out::write(&format!("{}\n", format_args!($($arg)*)))
    };
}
pub(crate) use outln;
