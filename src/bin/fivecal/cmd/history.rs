//! `fivecal history`: what the results store keeps of a machine. Without
//! a subcommand it lists the records; `show` prints one, `export` writes
//! them as CSV or JSON, `trend` prints whether each location error is
//! drifting toward its limit, and `plot` writes the HTML page with each
//! error over time. The store is only read, never created here.

use std::path::Path;

use anyhow::{Context as _, bail};
use fivecal::conformance::{AcceptanceLimits, LimitsSource};
use fivecal::history::{self, History};
use fivecal::io::write_atomic;
use fivecal::store::Store;

use super::record::open_for_reading;
use crate::config::history::{Action, HistoryCli, LimitsArg};

pub fn run(cli: HistoryCli) -> anyhow::Result<()> {
    let mut store = open_for_reading(cli.db.as_deref(), &cli.timeout)?;
    let machine = cli
        .machine
        .as_deref()
        .map(super::record::machine_key)
        .transpose()?;
    let machine = machine.as_deref();
    // A machine file named by --machine is read: no output may land on it.
    let machine_file: Vec<&Path> = cli
        .machine
        .as_deref()
        .filter(|m| fivecal::machine::is_path_spec(m))
        .map(Path::new)
        .into_iter()
        .collect();
    let action = cli.action.unwrap_or(Action::List { json: false });
    let json = match action {
        Action::List { json } | Action::Show { json, .. } => json || cli.json,
        Action::Trend { json, .. } | Action::Plot { json, .. } => json || cli.json,
        _ if cli.json => bail!(
            "history --json: the JSON of list (the default), show, trend and plot; export has its own --json"
        ),
        _ => false,
    };
    if json {
        // Standard output is the JSON's.
        crate::out::to_stderr();
    }
    match action {
        Action::List { .. } => {
            let records = store.list(machine)?;
            if json {
                // The records as `history export --json` writes them (an
                // empty list when there are none).
                crate::out::json(&history::to_json(&records))?;
            } else if records.is_empty() {
                outln!(
                    "no records{} in {}",
                    machine.map_or(String::new(), |m| format!(" of machine `{m}`")),
                    store.location()
                );
            } else {
                out!("{}", history::render_list(&records));
            }
        }
        Action::Show { id, .. } => {
            let r = store
                .get(id)?
                .with_context(|| format!("no record {id} in {}", store.location()))?;
            if json {
                // The one record as the export writes each.
                crate::out::json(&history::record_to_json(&r))?;
            } else {
                out!("{}", history::render_record(&r));
            }
        }
        Action::Export { json, out } => {
            let records = store.list(machine)?;
            let named_json = out
                .as_deref()
                .and_then(Path::extension)
                .is_some_and(|e| e.eq_ignore_ascii_case("json"));
            let text = if json || named_json {
                history::to_json(&records)
            } else {
                history::to_csv(&records)?
            };
            match out {
                Some(p) => {
                    fivecal::io::check_outputs(
                        &machine_file,
                        &[("--out", &p, fivecal::io::Shape::File)],
                    )?;
                    write_atomic(&p, text.as_bytes())?;
                    outln!("wrote {} records to {}", records.len(), p.display());
                }
                None => out!("{text}"),
            }
        }
        Action::Trend { limits: l, .. } => {
            let h = machine_history(&mut store, machine)?;
            let limits = limits(&l, &h)?;
            if json {
                crate::out::json(&history::trends_to_json(&h, &limits))?;
            } else {
                out!("{}", history::render_outlooks(&h, &limits));
            }
        }
        Action::Plot { out, limits: l, .. } => {
            let h = machine_history(&mut store, machine)?;
            let limits = limits(&l, &h)?;
            // Checked before writing, as every command does: an existing
            // file named as the page's directory is refused with its name
            // instead of the OS's "Not a directory".
            fivecal::io::check_outputs(&machine_file, &[("--out", &out, fivecal::io::Shape::Dir)])?;
            let files = history::page::write(&out, &h, &limits)?;
            if json {
                crate::out::json(&plot_json(&h.machine, &out, &files))?;
            }
            outln!(
                "history of {}: {} ({} files)",
                h.machine,
                out.join("index.html").display(),
                files.len()
            );
        }
    }
    Ok(())
}

/// The history of the machine asked for, or of the only one in the store.
pub fn machine_history(store: &mut Store, machine: Option<&str>) -> anyhow::Result<History> {
    let name = match machine {
        Some(m) => m.to_string(),
        None => {
            let all = store.machines()?;
            match all.as_slice() {
                [(m, _)] => m.clone(),
                [] => bail!("no records in {}", store.location()),
                _ => bail!(
                    "the store holds several machines ({}): name one with --machine",
                    all.iter()
                        .map(|(m, n)| format!("{m}: {n} records"))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            }
        }
    };
    let records = store.list(Some(&name))?;
    if records.is_empty() {
        bail!("no records of machine `{name}` in {}", store.location());
    }
    Ok(History::new(&name, records))
}

/// The limits of `--limits`, checked against the machine's name.
fn limits(l: &LimitsArg, h: &History) -> anyhow::Result<AcceptanceLimits> {
    let Some(path) = &l.limits else {
        return Ok(AcceptanceLimits::default());
    };
    let src = LimitsSource::read(path)?;
    if let Some(m) = &src.machine
        && *m != h.machine
    {
        bail!(
            "{}: the limits are for machine `{m}`, the history is of `{}`",
            path.display(),
            h.machine
        );
    }
    Ok(src.limits)
}

/// `history plot --json`: the machine, the page and every file written.
fn plot_json(machine: &str, dir: &Path, files: &[std::path::PathBuf]) -> String {
    #[derive(serde::Serialize)]
    struct Written<'a> {
        machine: &'a str,
        page: String,
        files: Vec<String>,
    }
    let w = Written {
        machine,
        page: dir.join("index.html").display().to_string(),
        files: files.iter().map(|f| f.display().to_string()).collect(),
    };
    serde_json::to_string_pretty(&w).expect("paths serialize") + "\n"
}
