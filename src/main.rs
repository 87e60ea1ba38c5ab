//! `mtcal`: the command-line program. The subcommands, their parsing and dispatch live in
//! `src/cli/` (one module per subcommand, the command line in `cli::command`).
//!
//! Nothing prints with `print!`/`eprint!` (they panic on a closed stream): stdout goes
//! through `cli::out::write`, notes to stderr through `cli::out::note`.
#![deny(clippy::print_stdout, clippy::print_stderr)]

mod cli;

fn main() -> std::process::ExitCode {
    cli::finish(cli::command::parse().run())
}
