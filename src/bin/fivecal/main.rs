//! The `fivecal` binary: parses the command line, turns it into one
//! validated configuration per command, calls the library and reports
//! errors with their context chain. Exit codes: 0 success, 2 error, 141
//! when standard output's reader went away (after every file was written),
//! and the signal's own status on SIGINT or SIGTERM (temporary files
//! removed first).

#[macro_use]
mod out;
mod cmd;
mod config;

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
    Plan(config::plan::PlanArgs),
    /// Run a plan on a virtual machine with known errors and write what a
    /// CMM or the probe would have measured.
    Simulate(config::simulate::SimulateCli),
    /// Identify location errors and error maps, with their uncertainty, from
    /// CMM and probe files.
    Analyze(config::analyze::AnalyzeCli),
    /// Rewrite NC programs so the identified errors cancel, or export them
    /// as controller parameters.
    ///
    /// Nothing is done silently. A program is refused (exit 2, nothing
    /// written) when its text shows another dialect than the one it is read
    /// in, when no motion block of it is understood and nothing in it shows
    /// its dialect, or when every move is left as written. A program whose
    /// corrections all round away (errors all but zero), or one in its own
    /// dialect that moves no axis itself (tool changes, calls of
    /// subprograms), is written as an unchanged copy, exit 0, and the last
    /// line says so. An export prints every parameter with its u and its
    /// change from what the control holds now (the machine file's
    /// controller_parameters, else its nominal geometry), refuses a change
    /// beyond --max-change, a u beyond --max-u and a value that drives an
    /// axis beyond its stroke, naming the parameter; its last line says how
    /// many parameters change, or that none does (exit 0).
    Compensate(config::compensate::CompensateArgs),
    /// Find where simulation and measurement disagree, name the missing
    /// effect, add it to the model and show the gap shrink.
    Discover(config::discover::DiscoverArgs),
    /// What the results store keeps of a machine: list, show, export, the
    /// trend of each error toward its limit, and a plot over time.
    History(config::history::HistoryCli),
    /// Compare a machine before and after compensation: the change of
    /// every error with its u, and whether it is within its limits.
    Verify(config::verify::VerifyArgs),
    /// Run the whole job on the built-in example machine: plan, simulate,
    /// analyze, discover and compensate, with a one-screen summary.
    Demo(config::demo::DemoArgs),
    /// Show what a measurement file holds before any plan is involved: its
    /// format, units, runs, and each feature or point with its nominal,
    /// actual and normal, and what was skipped and why.
    Measured(config::measured::MeasuredArgs),
    /// Inspect machine files.
    #[command(subcommand)]
    Machine(config::machine::MachineCommand),
    /// Print shell completions for bash, zsh, fish, powershell or elvish.
    Completions(config::completions::CompletionsArgs),
    /// Print the man page (roff) to standard output.
    Man,
}

/// On SIGINT, SIGTERM or SIGHUP: remove the temporary files of outputs
/// not yet complete, then end as the signal would have.
fn clean_up_on_signals() {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP]) else {
        return;
    };
    std::thread::spawn(move || {
        if let Some(sig) = signals.forever().next() {
            fivecal::io::remove_temporaries();
            let _ = signal_hook::low_level::emulate_default_handler(sig);
            std::process::exit(128 + sig);
        }
    });
}

/// The status of a process ended by SIGPIPE (128 + 13).
const BROKEN_PIPE: u8 = 141;

fn main() -> ExitCode {
    // Earlier releases' spellings (`--output`, `simulate nc --program`)
    // mapped onto the one vocabulary before clap parses, with a note each.
    let (args, notes) = cmd::vocabulary::normalize(std::env::args_os());
    let cli = Cli::parse_from(args);
    for note in notes {
        eprintln!("{note}");
    }
    clean_up_on_signals();
    // Every file this run reads is noted, and no output may land on one.
    fivecal::io::guard_inputs();
    let result = match cli.command {
        Command::Plan(a) => cmd::plan::run(a),
        Command::Simulate(a) => cmd::simulate::run(a),
        Command::Analyze(a) => cmd::analyze::run(a),
        Command::Compensate(a) => cmd::compensate::run(a),
        Command::Discover(a) => cmd::discover::run(a),
        Command::Demo(a) => cmd::demo::run(a),
        Command::History(a) => cmd::history::run(a),
        Command::Verify(a) => cmd::verify::run(a),
        Command::Measured(a) => cmd::measured::run(a),
        Command::Machine(m) => cmd::machine::run(m),
        Command::Completions(a) => cmd::docs::completions(a),
        Command::Man => cmd::docs::man(),
    };
    for p in fivecal::io::stale_removed() {
        eprintln!(
            "note: removed {}, left by an earlier run that was killed while writing it",
            p.display()
        );
    }
    match result {
        Ok(()) if fivecal::io::stdout_closed() => ExitCode::from(BROKEN_PIPE),
        Ok(()) => match out::failure() {
            None => ExitCode::SUCCESS,
            Some(e) => {
                eprintln!("error: cannot write to standard output: {e}");
                ExitCode::from(2)
            }
        },
        Err(err) => {
            let broken_pipe = err.chain().any(|e| {
                e.downcast_ref::<std::io::Error>()
                    .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
                    || e.downcast_ref::<fivecal::io::OutputError>()
                        .is_some_and(|o| o.is_broken_pipe())
            });
            if broken_pipe {
                return ExitCode::from(BROKEN_PIPE);
            }
            // Whatever a message quotes (a name, a rendered template) is
            // cut: an error never pastes its input.
            eprintln!(
                "error: {}",
                fivecal::source::short_message(&format!("{err:#}"))
            );
            ExitCode::from(2)
        }
    }
}
