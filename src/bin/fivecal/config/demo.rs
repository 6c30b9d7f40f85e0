//! `fivecal demo`'s options: where its files go and the simulation's seed.

use std::path::PathBuf;

use clap::Args;

#[derive(Args, Debug)]
pub struct DemoArgs {
    /// Where every artefact goes (created if needed; the demo's own files
    /// in it are replaced).
    #[arg(short, long, value_name = "DIR", default_value = "fivecal-demo")]
    pub out: PathBuf,
    /// Seed of the simulation (CMM placement and noise).
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub seed: u64,
}
