//! `fivecal verify`'s options: two result files, or a machine whose
//! results the store keeps; the limits; where the comparison is written
//! and whether it is printed as JSON. `cmd/verify.rs` checks them against
//! each other and the store as it reads them.

use std::path::PathBuf;

use clap::Args;

/// Compare a machine before and after compensation.
#[derive(Args, Debug)]
pub struct VerifyArgs {
    /// The result before compensation.
    #[arg(long, value_name = "RESULT.yaml", requires = "after")]
    pub before: Option<PathBuf>,
    /// The result after compensation.
    #[arg(long, value_name = "RESULT.yaml", requires = "before")]
    pub after: Option<PathBuf>,
    /// Take both from the results store: this machine's latest result
    /// before its last export and the latest after it.
    /// A machine file or a name: a file is known by the `name:` inside it.
    #[arg(long, value_name = "M.yaml|NAME", conflicts_with_all = ["before", "after"])]
    pub machine: Option<String>,
    /// The results store (with --machine) [default: $FIVECAL_DB, else
    /// history.db in the user's data directory].
    #[arg(long, value_name = "PATH|URL", requires = "machine")]
    pub db: Option<String>,
    #[command(flatten)]
    pub timeout: super::record::DbTimeout,
    /// Acceptance limits: a limits file or a machine file with a `limits:`
    /// section.
    #[arg(long, value_name = "FILE")]
    pub limits: Option<PathBuf>,
    /// Also write the comparison as YAML (JSON if the name ends in .json).
    #[arg(short, long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Print the comparison as JSON on standard output (as `-o FILE.json`
    /// writes it).
    #[arg(long)]
    pub json: bool,
}
