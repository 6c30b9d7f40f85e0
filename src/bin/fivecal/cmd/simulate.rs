//! `fivecal simulate` (issue 5): run a plan on the virtual machine. The
//! `nc` mode (issue 7) lives in `simulate_nc.rs`.

use clap::{Args, Subcommand};

use super::pending::PendingArgs;

#[derive(Args, Debug)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct SimulateCli {
    #[command(subcommand)]
    mode: Option<SimulateMode>,
    #[command(flatten)]
    args: SimulateArgs,
}

#[derive(Subcommand, Debug)]
enum SimulateMode {
    /// Predict the tool-tip error along an NC program on a machine with
    /// known errors.
    Nc(super::simulate_nc::SimulateNcArgs),
}

#[derive(Args, Debug)]
pub struct SimulateArgs {
    #[command(flatten)]
    pending: PendingArgs,
}

pub fn run(cli: SimulateCli) -> anyhow::Result<()> {
    match cli.mode {
        Some(SimulateMode::Nc(a)) => super::simulate_nc::run(a),
        None => super::pending::run("simulate", 5),
    }
}
