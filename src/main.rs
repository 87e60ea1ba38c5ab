//! `mtcal`: the command-line program. The subcommands, their parsing and dispatch live in
//! `src/cli/` (one module per subcommand, the command line in `cli::command`).
//!
//! Nothing prints with `print!`/`eprint!` (they panic on a closed stream): stdout goes
//! through `cli::out::write`, notes to stderr through `cli::out::note`.
#![deny(clippy::print_stdout, clippy::print_stderr)]

mod cli;

/// mimalloc, not the system's malloc: the service allocates and frees per request
/// (BENCHMARKS.md, "A plant group").
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() -> std::process::ExitCode {
    cli::finish(cli::command::parse().run())
}
