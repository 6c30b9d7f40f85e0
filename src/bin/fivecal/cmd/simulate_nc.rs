//! `fivecal simulate nc` (issue 7): the predicted tool-tip error along a
//! program.

use clap::Args;

use super::pending::PendingArgs;

#[derive(Args, Debug)]
pub struct SimulateNcArgs {
    #[command(flatten)]
    pending: PendingArgs,
}

pub fn run(_args: SimulateNcArgs) -> anyhow::Result<()> {
    super::pending::run("simulate nc", 7)
}
