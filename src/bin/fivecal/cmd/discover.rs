//! `fivecal discover` (issue 8).

use clap::Args;

use super::pending::PendingArgs;

#[derive(Args, Debug)]
pub struct DiscoverArgs {
    #[command(flatten)]
    pending: PendingArgs,
}

pub fn run(_args: DiscoverArgs) -> anyhow::Result<()> {
    super::pending::run("discover", 8)
}
