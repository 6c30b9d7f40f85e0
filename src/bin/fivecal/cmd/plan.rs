//! `fivecal plan` (issue 3).

use clap::Args;

use super::pending::PendingArgs;

#[derive(Args, Debug)]
pub struct PlanArgs {
    #[command(flatten)]
    pending: PendingArgs,
}

pub fn run(_args: PlanArgs) -> anyhow::Result<()> {
    super::pending::run("plan", 3)
}
