//! `mtcal`: the command-line program. Every subcommand is a thin layer over the solver,
//! the formats crate, or the service; one module per subcommand in `src/cli/`.
//!
//! Nothing prints with `print!`/`eprint!` (they panic on a closed stream): stdout goes
//! through `cli::out::write`, notes to stderr through `cli::out::note`.
#![deny(clippy::print_stdout, clippy::print_stderr)]

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
use std::process::ExitCode;

mod cli;

#[derive(Parser)]
#[command(
    name = "mtcal",
    version,
    about = "Open calibration service for machine tools"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Simulate a measurement session of a machine with known errors (writes truth.json).
    Simulate(cli::simulate::Args),
    /// Identify the 21 geometric errors from a session folder.
    Identify(cli::identify::Args),
    /// Rank error sources by their sensitivity (Cheng et al. 2012).
    Sensitivity(cli::sensitivity::Args),
    /// Check a 5-axis cradle's A/C connection from a rotary point set.
    Cradle(cli::cradle::Args),
    /// Locate and explain mismatch between model and recordings.
    Diagnose(cli::diagnose::Args),
    /// Figures of ISO 230-2 and ISO 230-4 from a session or positioning runs.
    Standards(cli::standards::Args),
    /// Compensation table of an identification result for a controller (ISG, Etalon,
    /// Heidenhain, CSV).
    Export(cli::export::Args),
    /// How a machine changed between two identification results (drift and differences
    /// with their uncertainty, over the travel both measured).
    Compare(cli::compare::Args),
    /// The check report: one self-contained HTML page (prints on A4).
    Report(cli::report::Args),
    /// Run the HTTP API and its worker.
    Serve(cli::serve::Args),
    /// Run only the worker (API and worker processes on several hosts, one database).
    Worker(cli::serve::WorkerCmd),
    /// Upload a session to a running service and run identification on it.
    Submit(cli::submit::Args),
    /// Start the service on a fresh database with a simulated fleet to look at.
    Demo(cli::demo::Args),
    /// Administration (API keys).
    Admin(cli::admin::Args),
}

/// The command line with every option that takes a value accepting a negative number
/// (`--noise-um -1`), so that the command's own check says what is wrong with it instead
/// of clap calling it an unexpected argument.
fn command() -> clap::Command {
    fn negatives(c: clap::Command) -> clap::Command {
        c.mut_args(|a| {
            if a.get_action().takes_values() {
                a.allow_negative_numbers(true)
            } else {
                a
            }
        })
        .mut_subcommands(negatives)
    }
    negatives(Cli::command())
}

fn main() -> ExitCode {
    let cli = match Cli::from_arg_matches(&command().get_matches()) {
        Ok(cli) => cli,
        Err(e) => e.exit(),
    };
    let result = match cli.command {
        Command::Simulate(a) => cli::simulate::run(a),
        Command::Identify(a) => cli::identify::run(a),
        Command::Sensitivity(a) => cli::sensitivity::run(a),
        Command::Cradle(a) => cli::cradle::run(a),
        Command::Diagnose(a) => cli::diagnose::run(a),
        Command::Standards(a) => cli::standards::run(a),
        Command::Export(a) => cli::export::run(a),
        Command::Compare(a) => cli::compare::run(a),
        Command::Report(a) => cli::report::run(a),
        Command::Serve(a) => cli::serve::run(a),
        Command::Worker(a) => cli::serve::run_worker(a),
        Command::Submit(a) => cli::submit::run(a),
        Command::Demo(a) => cli::demo::run(a),
        Command::Admin(a) => cli::admin::run(a),
    };
    cli::finish(result)
}
