//! Subcommands whose issue has not landed yet.

use clap::Args;

/// Arguments of a subcommand that is not implemented yet (accepted and
/// ignored, so that the message below is what the user sees).
#[derive(Args, Debug)]
pub struct PendingArgs {
    #[arg(trailing_var_arg = true, allow_hyphen_values = true, hide = true)]
    rest: Vec<String>,
}

pub fn run(name: &str, issue: u32) -> anyhow::Result<()> {
    anyhow::bail!("`fivecal {name}` is not implemented yet (tracked in issue {issue})")
}
