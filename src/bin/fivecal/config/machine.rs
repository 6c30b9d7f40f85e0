//! `fivecal machine`'s subcommands and their options: show a machine
//! file, list the built-in machines, write a new machine file.

use clap::Subcommand;

#[derive(Subcommand, Debug)]
pub enum MachineCommand {
    /// Print a machine file as parsed: axes, limits, pivot, tool, probe, the
    /// kinematic chain and the error symbols it accepts. FILE is a path or a
    /// built-in name (bc-trunnion, ac-trunnion, head-table, head-head).
    Show {
        /// Machine file or built-in name.
        file: String,
    },
    /// List the built-in machines.
    List,
    /// Write a machine file to start one's own from: a copy of MACHINE (a
    /// built-in name or a file) under the new name, so that every output
    /// is labelled with the machine it is about. Edit its strokes, pivot,
    /// limits, tool and probe before use.
    New {
        /// The new machine's name (letters, digits, `-`, `_`, `.`).
        name: String,
        /// The machine to start from: a built-in name or a file.
        #[arg(long, default_value = "bc-trunnion")]
        from: String,
        /// Where to write it (`-`: standard output) [default: NAME.yaml].
        #[arg(short = 'o', long = "out")]
        output: Option<std::path::PathBuf>,
    },
}
