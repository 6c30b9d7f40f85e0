//! `fivecal verify`: the machine before and after compensation. Two
//! result files, or from the results store the latest result before the
//! machine's last export and the latest after it (without an export: its
//! two latest results). Prints the change of every location error with
//! its u and, given limits, whether the compensated machine conforms.

use std::path::{Path, PathBuf};

use anyhow::{Context as _, bail};
use clap::Args;
use fivecal::conformance::LimitsSource;
use fivecal::errorfile::ErrorFile;
use fivecal::history::compare::Comparison;
use fivecal::io::{ensure_not_input, write_atomic};
use fivecal::store::{RecordKind, Stored};

use super::history::machine_history;
use super::record::open_for_reading;

/// Compare a machine before and after compensation.
#[derive(Args, Debug)]
pub struct VerifyArgs {
    /// The result before compensation.
    #[arg(long, value_name = "RESULT.yaml", requires = "after")]
    before: Option<PathBuf>,
    /// The result after compensation.
    #[arg(long, value_name = "RESULT.yaml", requires = "before")]
    after: Option<PathBuf>,
    /// Take both from the results store: this machine's latest result
    /// before its last export and the latest after it.
    #[arg(long, value_name = "NAME", conflicts_with_all = ["before", "after"])]
    machine: Option<String>,
    /// The results store (with --machine) [default: $FIVECAL_DB, else
    /// history.db in the user's data directory].
    #[arg(long, value_name = "PATH|URL", requires = "machine")]
    db: Option<String>,
    #[command(flatten)]
    timeout: super::record::DbTimeout,
    /// Acceptance limits: a limits file or a machine file with a `limits:`
    /// section.
    #[arg(long, value_name = "FILE")]
    limits: Option<PathBuf>,
    /// Also write the comparison as YAML (JSON if the name ends in .json).
    #[arg(short, long, value_name = "FILE")]
    out: Option<PathBuf>,
}

pub fn run(a: VerifyArgs) -> anyhow::Result<()> {
    // The output is checked before anything is read or written: it names
    // none of the inputs, the results store included.
    if let Some(out) = &a.out {
        if a.machine.is_some() {
            fivecal::store::Location::resolve(a.db.as_deref())?;
        }
        let inputs: Vec<&Path> = [&a.before, &a.after, &a.limits]
            .into_iter()
            .flatten()
            .map(PathBuf::as_path)
            .collect();
        fivecal::io::check_outputs(&inputs, &[("--out", out, fivecal::io::Shape::File)])?;
    }
    let limits = a.limits.as_deref().map(LimitsSource::read).transpose()?;
    let ((bn, b), (an, af)) = match (&a.before, &a.after, &a.machine) {
        (Some(b), Some(af), None) => (from_file(b)?, from_file(af)?),
        (None, None, Some(m)) => from_store(a.db.as_deref(), &a.timeout, m)?,
        _ => bail!("give --before R1 --after R2, or --machine NAME to take both from the store"),
    };
    if let Some(l) = &limits {
        l.check_result(&af)?;
    }
    let c = Comparison::new((&bn, &b), (&an, &af), limits.as_ref().map(|l| &l.limits))?;
    out!("{}", c.render());
    if let Some(out) = &a.out {
        let mut inputs: Vec<&Path> = [&a.before, &a.after, &a.limits]
            .into_iter()
            .flatten()
            .map(PathBuf::as_path)
            .collect();
        inputs.dedup();
        ensure_not_input(out, &inputs)?;
        let text = if out.extension().is_some_and(|e| e == "json") {
            serde_json::to_string_pretty(&c)? + "\n"
        } else {
            serde_yaml::to_string(&c)?
        };
        write_atomic(out, text.as_bytes())?;
        outln!("wrote {}", out.display());
    }
    Ok(())
}

fn from_file(p: &Path) -> anyhow::Result<(String, ErrorFile)> {
    let (f, _) = ErrorFile::read(p)?;
    Ok((p.display().to_string(), f))
}

fn from_record(r: &Stored) -> anyhow::Result<(String, ErrorFile)> {
    let name = format!("record {} ({})", r.id, r.record.result_name);
    let f = ErrorFile::parse(Path::new(&name), &r.record.content)
        .with_context(|| format!("record {} is not an error file", r.id))?;
    Ok((name, f))
}

type Pair = ((String, ErrorFile), (String, ErrorFile));

fn from_store(
    db: Option<&str>,
    timeout: &super::record::DbTimeout,
    machine: &str,
) -> anyhow::Result<Pair> {
    let mut store = open_for_reading(db, timeout)?;
    let h = machine_history(&mut store, Some(machine))?;
    // Results with location errors, the later result of a measurement.
    let results: Vec<&Stored> = h
        .records
        .iter()
        .filter(|r| r.record.kind != RecordKind::Export && !h.superseded.contains(&r.id))
        .filter(|r| fivecal::history::location_errors(&r.record.content).is_some())
        .collect();
    let pick = match h.exports.last() {
        Some(e) => {
            let before = results.iter().rev().find(|r| r.record.measured_at <= e.at);
            let after = results.iter().rev().find(|r| r.record.measured_at > e.at);
            match (before, after) {
                (Some(b), Some(a)) => (*b, *a),
                (None, _) => bail!(
                    "machine `{machine}`: no result before its last export (record {})",
                    e.id
                ),
                (_, None) => bail!(
                    "machine `{machine}`: no result after its last export (record {}): measure the compensated machine first",
                    e.id
                ),
            }
        }
        None => match results.as_slice() {
            [.., b, a] => (*b, *a),
            _ => bail!(
                "machine `{machine}` has {} result(s) with location errors in the store: verify needs two",
                results.len()
            ),
        },
    };
    Ok((from_record(pick.0)?, from_record(pick.1)?))
}
