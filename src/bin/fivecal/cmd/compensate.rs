//! `fivecal compensate` (issue 7).

use clap::Args;

use super::pending::PendingArgs;

#[derive(Args, Debug)]
pub struct CompensateArgs {
    #[command(flatten)]
    pending: PendingArgs,
}

pub fn run(_args: CompensateArgs) -> anyhow::Result<()> {
    super::pending::run("compensate", 7)
}
