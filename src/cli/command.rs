//! The command line: the subcommands, their parsing and the dispatch to each module's
//! `run`.

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
use std::process::ExitCode;

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

/// One subcommand with its arguments.
#[derive(Subcommand)]
pub enum Command {
    /// Simulate a measurement session of a machine with known errors (writes truth.json).
    Simulate(super::simulate::Args),
    /// Identify the 21 geometric errors from a session folder.
    Identify(super::identify::Args),
    /// Rank error sources by their sensitivity (Cheng et al. 2012).
    Sensitivity(super::sensitivity::Args),
    /// Check a 5-axis cradle's A/C connection from a rotary point set.
    Cradle(super::cradle::Args),
    /// Locate and explain mismatch between model and recordings.
    Diagnose(super::diagnose::Args),
    /// Figures of ISO 230-2 and ISO 230-4 from a session or positioning runs.
    Standards(super::standards::Args),
    /// Compensation table of an identification result for a controller (ISG, Etalon,
    /// Heidenhain, CSV).
    Export(super::export::Args),
    /// How a machine changed between two identification results (drift and differences
    /// with their uncertainty, over the travel both measured).
    Compare(super::compare::Args),
    /// The check report: one self-contained HTML page (prints on A4).
    Report(super::report::Args),
    /// Run the HTTP API and its worker.
    Serve(super::serve::Args),
    /// Run only the worker (API and worker processes on several hosts, one database).
    Worker(super::serve::WorkerCmd),
    /// Upload a session to a running service and run identification on it.
    Submit(super::submit::Args),
    /// Start the service on a fresh database with a simulated fleet to look at.
    Demo(super::demo::Args),
    /// Administration (API keys).
    Admin(super::admin::Args),
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

/// The subcommand of this process's arguments; exits with clap's message (and code 2)
/// when they do not parse, or after printing help or the version.
pub fn parse() -> Command {
    match Cli::from_arg_matches(&command().get_matches()) {
        Ok(cli) => cli.command,
        Err(e) => e.exit(),
    }
}

impl Command {
    /// Runs the subcommand.
    pub fn run(self) -> anyhow::Result<ExitCode> {
        use super::*;
        match self {
            Command::Simulate(a) => simulate::run(a),
            Command::Identify(a) => identify::run(a),
            Command::Sensitivity(a) => sensitivity::run(a),
            Command::Cradle(a) => cradle::run(a),
            Command::Diagnose(a) => diagnose::run(a),
            Command::Standards(a) => standards::run(a),
            Command::Export(a) => export::run(a),
            Command::Compare(a) => compare::run(a),
            Command::Report(a) => report::run(a),
            Command::Serve(a) => serve::run(a),
            Command::Worker(a) => serve::run_worker(a),
            Command::Submit(a) => submit::run(a),
            Command::Demo(a) => demo::run(a),
            Command::Admin(a) => admin::run(a),
        }
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_command_line_is_consistent() {
        super::command().debug_assert();
    }
}
