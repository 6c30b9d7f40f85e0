//! The options every recording command shares (`analyze`, `discover`,
//! `compensate --export --entered`): where the results store is, whether
//! to record, and what to note with the record; and how long the store may
//! take, which the reading commands (`history`, `verify`) share too.

use std::time::Duration;

use anyhow::bail;
use clap::Args;
use fivecal::store::runs::RunNotes;
use fivecal::store::{Location, parse_time};

/// Recording into the results store.
#[derive(Args, Debug, Clone)]
pub struct RecordArgs {
    /// The results store: an SQLite file, or `postgres://user@host/db` for
    /// a server [default: $FIVECAL_DB, else history.db in the user's data
    /// directory, ~/.local/share/fivecal on Linux].
    #[arg(long, value_name = "PATH|URL")]
    db: Option<String>,
    /// Do not record this run in the results store.
    #[arg(long, conflicts_with_all = ["db", "db_timeout", "note", "temperature", "measured_at"])]
    no_record: bool,
    #[command(flatten)]
    timeout: DbTimeout,
    /// A note kept with the record (why the machine was measured, ...).
    #[arg(long, value_name = "TEXT")]
    note: Option<String>,
    /// The machine's temperature when it was measured, deg C.
    #[arg(long, value_name = "DEG_C", allow_negative_numbers = true)]
    temperature: Option<f64>,
    /// When the machine was measured, RFC 3339 (2026-03-01T08:30:00Z)
    /// [default: now]; the history's trends use this time.
    #[arg(long, value_name = "TIME")]
    measured_at: Option<String>,
}

/// How long the store may take (`--db-timeout`).
#[derive(Args, Debug, Clone, Default)]
pub struct DbTimeout {
    /// Seconds the results store may take to connect, to answer, and to
    /// let go of a lock another run holds, before the run ends with an
    /// error naming the store [default: 30].
    #[arg(long, value_name = "SECONDS", global = true)]
    db_timeout: Option<f64>,
}

impl DbTimeout {
    /// The timeout given, or the default.
    pub fn get(&self) -> anyhow::Result<Duration> {
        match self.db_timeout {
            None => Ok(fivecal::store::DEFAULT_TIMEOUT),
            Some(s) if s.is_finite() && s > 0.0 && s <= 3600.0 => Ok(Duration::from_secs_f64(s)),
            Some(s) => bail!("--db-timeout {s}: expected seconds above 0 and at most 3600"),
        }
    }
}

/// Where and what to record, validated.
pub struct Recording {
    /// The store, or none with `--no-record`.
    pub location: Option<Location>,
    pub timeout: Duration,
    pub notes: RunNotes,
}

impl RecordArgs {
    /// The first flag given that only matters when the run records.
    pub fn first_given(&self) -> Option<&'static str> {
        [
            ("--note", self.note.is_some()),
            ("--temperature", self.temperature.is_some()),
            ("--measured-at", self.measured_at.is_some()),
            ("--db", self.db.is_some()),
        ]
        .into_iter()
        .find_map(|(flag, given)| given.then_some(flag))
    }

    pub fn validate(self) -> anyhow::Result<Recording> {
        if let Some(t) = self.temperature
            && !(t.is_finite() && (-50.0..=100.0).contains(&t))
        {
            bail!("--temperature {t}: expected the machine's temperature in deg C (-50 to 100)");
        }
        if self.note.as_deref().is_some_and(|n| n.trim().is_empty()) {
            bail!("--note is empty");
        }
        let measured_at = self
            .measured_at
            .as_deref()
            .map(parse_time)
            .transpose()
            .map_err(|e| anyhow::anyhow!("--measured-at {e}"))?;
        let location = if self.no_record {
            None
        } else {
            Some(Location::resolve(self.db.as_deref())?)
        };
        Ok(Recording {
            location,
            timeout: self.timeout.get()?,
            notes: RunNotes {
                note: self.note,
                temperature: self.temperature,
                measured_at,
            },
        })
    }
}
