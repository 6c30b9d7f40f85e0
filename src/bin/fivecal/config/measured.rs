//! `fivecal measured`'s options, and the flags every command that reads
//! measurement files shares (`--run`, `--units`, `--encoding`) with their
//! validation into the library's [`MeasuredOptions`].

use std::path::PathBuf;

use anyhow::{Context as _, bail};
use clap::Args;
use fivecal::formats::detect::{LengthUnit, MeasuredOptions};
use fivecal::formats::encoding;

/// What the user says about measurement files where a file cannot.
#[derive(Args, Debug, Clone, Default)]
pub struct MeasuredFlags {
    /// Read measurement run N (from 1) of a file holding several (QIF
    /// results, CALYPSO tables of several parts).
    #[arg(long, value_name = "N")]
    pub run: Option<usize>,
    /// Length unit of a measurement file that does not state it (QIF
    /// without FileUnits, CALYPSO tables without a unit column, point
    /// tables and clouds): mm or inch.
    #[arg(long, value_name = "UNIT")]
    pub units: Option<String>,
    /// Encoding of a measurement file not in UTF-8 (windows-1252,
    /// iso-8859-1, utf-16le, shift_jis, ...).
    #[arg(long, value_name = "NAME")]
    pub encoding: Option<String>,
}

impl MeasuredFlags {
    /// The validated options.
    pub fn options(&self) -> anyhow::Result<MeasuredOptions> {
        let units = match &self.units {
            None => None,
            Some(u) => Some(
                LengthUnit::parse(u)
                    .with_context(|| format!("--units {u}: expected mm or inch"))?,
            ),
        };
        let encoding = match &self.encoding {
            None => None,
            Some(e) => Some(encoding::by_name(e).with_context(|| {
                format!("--encoding {e}: not an encoding name (expected e.g. windows-1252, iso-8859-1, utf-16le)")
            })?),
        };
        if self.run == Some(0) {
            bail!("--run 0: runs are numbered from 1");
        }
        Ok(MeasuredOptions {
            run: self.run,
            units,
            encoding,
        })
    }
}

#[derive(Args, Debug)]
pub struct MeasuredArgs {
    /// The measurement file (DMIS output, QIF results, CALYPSO table, CSV,
    /// point list, nine-section heights, a probe log as the control wrote
    /// it).
    pub file: PathBuf,
    /// Print JSON: the file's format, units and runs, and one object per
    /// point with `label`, `nominal`, `actual` and `normal`.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub flags: MeasuredFlags,
}
