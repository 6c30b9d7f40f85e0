//! `fivecal history`: what the results store keeps of a machine. Without
//! a subcommand it lists the records; `show` prints one, `export` writes
//! them as CSV or JSON, `trend` prints whether each location error is
//! drifting toward its limit, and `plot` writes the HTML page with each
//! error over time. The store is only read, never created here.

use std::path::{Path, PathBuf};

use anyhow::{Context as _, bail};
use clap::{Args, Subcommand};
use fivecal::conformance::{AcceptanceLimits, LimitsSource};
use fivecal::history::{self, History};
use fivecal::io::write_atomic;
use fivecal::store::Store;

use super::record::open_for_reading;

/// List, show, export, trend and plot the results kept in the store.
#[derive(Args, Debug)]
pub struct HistoryCli {
    #[command(subcommand)]
    action: Option<Action>,
    /// The results store: an SQLite file or a `postgres://` URL [default:
    /// $FIVECAL_DB, else history.db in the user's data directory].
    #[arg(long, value_name = "PATH|URL", global = true)]
    db: Option<String>,
    /// Only this machine's records [needed for trend and plot when the
    /// store holds several machines]: a machine file (known by the `name:`
    /// inside it) or a name.
    #[arg(long, value_name = "M.yaml|NAME", global = true)]
    machine: Option<String>,
    #[command(flatten)]
    timeout: super::record::DbTimeout,
}

#[derive(Subcommand, Debug)]
enum Action {
    /// List the records, oldest measurement first (the default).
    List,
    /// Print one record: its fields, the files it read with their SHA-256,
    /// and the result as kept.
    Show {
        /// The record's id (first column of the list).
        id: i64,
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
    Trend(LimitsArg),
    /// Write an HTML page with each location error over time (u band, fit
    /// verdicts, exports, limits, trend).
    Plot {
        /// The directory of the page (index.html and one SVG per error).
        #[arg(short, long, value_name = "DIR")]
        out: PathBuf,
        #[command(flatten)]
        limits: LimitsArg,
    },
}

#[derive(Args, Debug)]
struct LimitsArg {
    /// Acceptance limits: a limits file or a machine file with a
    /// `limits:` section.
    #[arg(long, value_name = "FILE")]
    limits: Option<PathBuf>,
}

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
    match cli.action.unwrap_or(Action::List) {
        Action::List => {
            let records = store.list(machine)?;
            if records.is_empty() {
                outln!(
                    "no records{} in {}",
                    machine.map_or(String::new(), |m| format!(" of machine `{m}`")),
                    store.location()
                );
            } else {
                out!("{}", history::render_list(&records));
            }
        }
        Action::Show { id } => {
            let r = store
                .get(id)?
                .with_context(|| format!("no record {id} in {}", store.location()))?;
            out!("{}", history::render_record(&r));
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
        Action::Trend(l) => {
            let h = machine_history(&mut store, machine)?;
            let limits = limits(&l, &h)?;
            out!("{}", history::render_outlooks(&h, &limits));
        }
        Action::Plot { out, limits: l } => {
            let h = machine_history(&mut store, machine)?;
            let limits = limits(&l, &h)?;
            // Checked before writing, as every command does: an existing
            // file named as the page's directory is refused with its name
            // instead of the OS's "Not a directory".
            fivecal::io::check_outputs(&machine_file, &[("--out", &out, fivecal::io::Shape::Dir)])?;
            let files = history::page::write(&out, &h, &limits)?;
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
