//! The `fivecal` binary: parses the command line, turns it into one
//! validated configuration per command, calls the library and reports
//! errors with their context chain. Exit codes: 0 success, 2 error.

mod cmd;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// Geometric calibration of five-axis machine tools: plan machining and
/// probing tests as NC programs, simulate them, identify location errors and
/// error maps with their uncertainty, discover missing effects, and rewrite
/// NC programs so the identified errors cancel.
#[derive(Parser, Debug)]
#[command(name = "fivecal", version, about, long_about = None, propagate_version = true)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Write a test as an NC program for a controller, with its nominal
    /// points, a CMM program, a 3-D model of the piece and a setup sheet.
    Plan(cmd::plan::PlanArgs),
    /// Run a plan on a virtual machine with known errors and write what a
    /// CMM or the probe would have measured.
    Simulate(cmd::simulate::SimulateCli),
    /// Identify location errors and error maps, with their uncertainty, from
    /// CMM and probe files.
    Analyze(cmd::analyze::AnalyzeCli),
    /// Rewrite NC programs so the identified errors cancel, or export them
    /// as controller parameters.
    Compensate(cmd::compensate::CompensateArgs),
    /// Find where simulation and measurement disagree, name the missing
    /// effect, add it to the model and show the gap shrink.
    Discover(cmd::discover::DiscoverArgs),
    /// Run the whole job on the built-in example machine: plan, simulate,
    /// analyze, discover and compensate, with a one-screen summary.
    Demo(cmd::demo::DemoArgs),
    /// Show what a measurement file holds before any plan is involved: its
    /// format, units, runs, and each feature or point with its nominal,
    /// actual and normal, and what was skipped and why.
    Measured(cmd::measured::MeasuredArgs),
    /// Inspect machine files.
    #[command(subcommand)]
    Machine(cmd::machine::MachineCommand),
    /// Print shell completions for bash, zsh, fish, powershell or elvish.
    Completions(cmd::docs::CompletionsArgs),
    /// Print the man page (roff) to standard output.
    Man,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Plan(a) => cmd::plan::run(a),
        Command::Simulate(a) => cmd::simulate::run(a),
        Command::Analyze(a) => cmd::analyze::run(a),
        Command::Compensate(a) => cmd::compensate::run(a),
        Command::Discover(a) => cmd::discover::run(a),
        Command::Demo(a) => cmd::demo::run(a),
        Command::Measured(a) => cmd::measured::run(a),
        Command::Machine(m) => cmd::machine::run(m),
        Command::Completions(a) => cmd::docs::completions(a),
        Command::Man => cmd::docs::man(),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            if err.chain().any(|e| {
                e.downcast_ref::<std::io::Error>()
                    .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
            }) {
                return ExitCode::SUCCESS;
            }
            eprintln!("error: {err:#}");
            ExitCode::from(2)
        }
    }
}
