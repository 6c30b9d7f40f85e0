//! `fivecal history`'s options: the store, the machine, and what to do
//! with its records (list, show, export, trend, plot), each with its own.

use std::path::PathBuf;

use clap::{Args, Subcommand};

/// List, show, export, trend and plot the results kept in the store.
#[derive(Args, Debug)]
pub struct HistoryCli {
    #[command(subcommand)]
    pub action: Option<Action>,
    /// The results store: an SQLite file or a `postgres://` URL [default:
    /// $FIVECAL_DB, else history.db in the user's data directory].
    #[arg(long, value_name = "PATH|URL", global = true)]
    pub db: Option<String>,
    /// Only this machine's records [needed for trend and plot when the
    /// store holds several machines]: a machine file (known by the `name:`
    /// inside it) or a name.
    #[arg(long, value_name = "M.yaml|NAME", global = true)]
    pub machine: Option<String>,
    #[command(flatten)]
    pub timeout: super::record::DbTimeout,
    /// Without a subcommand (the list): the records as JSON on standard
    /// output.
    #[arg(long)]
    pub json: bool,
}

#[derive(Subcommand, Debug)]
pub enum Action {
    /// List the records, oldest measurement first (the default).
    List {
        /// Print the records as JSON on standard output (as `history
        /// export --json` writes them).
        #[arg(long)]
        json: bool,
    },
    /// Print one record: its fields, the files it read with their SHA-256,
    /// and the result as kept.
    Show {
        /// The record's id (first column of the list).
        id: i64,
        /// Print the record as JSON on standard output: its fields, files
        /// and content, and its location errors.
        #[arg(long)]
        json: bool,
    },
    /// Write the records as CSV (one row per record and symbol) or JSON.
    Export {
        /// Write JSON instead of CSV (also when the --out file's name ends
        /// in .json).
        #[arg(long)]
        json: bool,
        /// The file [default: standard output].
        #[arg(short, long, value_name = "FILE")]
        out: Option<PathBuf>,
    },
    /// Whether each location error drifts, since when, and when it reaches
    /// its limit at the current rate (since the last export).
    Trend {
        #[command(flatten)]
        limits: LimitsArg,
        /// Print the trends as JSON on standard output (one entry per
        /// location error: outlook, slope and its u, the forecast).
        #[arg(long)]
        json: bool,
    },
    /// Write an HTML page with each location error over time (u band, fit
    /// verdicts, exports, limits, trend).
    Plot {
        /// The directory of the page (index.html and one SVG per error).
        #[arg(short, long, value_name = "DIR")]
        out: PathBuf,
        #[command(flatten)]
        limits: LimitsArg,
        /// Print what was written as JSON on standard output (the
        /// machine, the page, the files).
        #[arg(long)]
        json: bool,
    },
}

#[derive(Args, Debug)]
pub struct LimitsArg {
    /// Acceptance limits: a limits file or a machine file with a
    /// `limits:` section.
    #[arg(long, value_name = "FILE")]
    pub limits: Option<PathBuf>,
}
