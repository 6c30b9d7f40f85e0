//! `fivecal analyze` (issue 6): identify errors from measurements. The
//! `contour` mode (issue 7) lives in `contour.rs`.

use clap::{Args, Subcommand};

use super::pending::PendingArgs;

#[derive(Args, Debug)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct AnalyzeCli {
    #[command(subcommand)]
    mode: Option<AnalyzeMode>,
    #[command(flatten)]
    args: AnalyzeArgs,
}

#[derive(Subcommand, Debug)]
enum AnalyzeMode {
    /// Distance of each measured point to the design surface of a part
    /// model (OBJ or glTF), with mean and maximum.
    Contour(super::contour::ContourArgs),
}

#[derive(Args, Debug)]
pub struct AnalyzeArgs {
    #[command(flatten)]
    pending: PendingArgs,
}

pub fn run(cli: AnalyzeCli) -> anyhow::Result<()> {
    match cli.mode {
        Some(AnalyzeMode::Contour(a)) => super::contour::run(a),
        None => super::pending::run("analyze", 6),
    }
}
