//! The results store as the commands use it: opened to record (`analyze`,
//! `discover`, `compensate --export --entered`) before the work starts, so
//! an unreachable server fails the run before anything is written, or to
//! read (`history`, `verify`). The options are `config/record.rs`'s.

use anyhow::{Context as _, bail};

use fivecal::store::{Access, Location, Record, Store};

use crate::config::record::{DbTimeout, Recording};

/// An open store, or none with `--no-record`.
pub struct Recorder(Option<Store>);

impl Recording {
    /// Opens the store (creating it when new).
    pub fn open(&self) -> anyhow::Result<Recorder> {
        match &self.location {
            None => Ok(Recorder(None)),
            Some(l) => Ok(Recorder(Some(
                Store::open_with(l, Access::ReadWrite, self.timeout).with_context(
                    || "cannot open the results store (--no-record runs without it)",
                )?,
            ))),
        }
    }
}

impl Recorder {
    /// Writes `records` in one transaction; prints their ids.
    pub fn save(&mut self, records: &[Record], say: &dyn Fn(String)) -> anyhow::Result<()> {
        let Some(store) = &mut self.0 else {
            return Ok(());
        };
        let mut b = store.batch()?;
        let mut ids = Vec::new();
        for r in records {
            ids.push(b.insert(r)?);
        }
        b.commit()?;
        let ids: Vec<String> = ids.iter().map(|i| i.to_string()).collect();
        say(format!(
            "recorded as {} {} in {}",
            if ids.len() == 1 { "record" } else { "records" },
            ids.join(", "),
            store.location()
        ));
        Ok(())
    }
}

/// The store's name for the machine of `--machine`: a machine file (a
/// path: a `/` or a `.yaml` extension) is read and named by the `name:`
/// inside it, as every command that records names it; a built-in or a
/// stored name is taken as given.
pub fn machine_key(spec: &str) -> anyhow::Result<String> {
    if fivecal::machine::is_path_spec(spec) {
        let (m, _) = fivecal::machine::Machine::resolve(spec)?;
        return Ok(m.name);
    }
    Ok(spec.to_string())
}

/// The store the history commands read: `--db`, else `$FIVECAL_DB`, else
/// the default file, which must exist (reading never creates a store). It
/// is opened read-only: reading it never changes it.
pub fn open_for_reading(db: Option<&str>, timeout: &DbTimeout) -> anyhow::Result<Store> {
    let l = Location::resolve(db)?;
    if let Location::Sqlite(p) = &l
        && !p.exists()
    {
        bail!(
            "no results store at {}: nothing recorded yet (give --db PATH or set FIVECAL_DB)",
            p.display()
        );
    }
    Ok(Store::open_with(&l, Access::ReadOnly, timeout.get()?)?)
}
