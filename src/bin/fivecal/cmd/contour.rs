//! `fivecal analyze contour` (issue 7): contour errors against a part model.

use clap::Args;

use super::pending::PendingArgs;

#[derive(Args, Debug)]
pub struct ContourArgs {
    #[command(flatten)]
    pending: PendingArgs,
}

pub fn run(_args: ContourArgs) -> anyhow::Result<()> {
    super::pending::run("analyze contour", 7)
}
