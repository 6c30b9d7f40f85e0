//! `fivecal verify`: the machine before and after compensation. Two
//! result files, or from the results store the latest result before the
//! machine's last export and the latest after it (without an export: its
//! two latest results). Prints the change of every location error with
//! its u and, given limits, whether the compensated machine conforms.

use std::path::{Path, PathBuf};

use anyhow::{Context as _, bail};
use fivecal::conformance::LimitsSource;
use fivecal::errorfile::ErrorFile;
use fivecal::history::compare::Comparison;
use fivecal::io::{ensure_not_input, write_atomic};
use fivecal::store::{RecordKind, Stored};

use super::history::machine_history;
use super::record::open_for_reading;
use crate::config::verify::VerifyArgs;

pub fn run(a: VerifyArgs) -> anyhow::Result<()> {
    if a.json {
        if a.out.as_deref().is_some_and(|o| o.as_os_str() == "-") {
            bail!(
                "--json prints on standard output, and so does `-o -`: name a file, or leave out --json"
            );
        }
        // Standard output is the JSON's: what the run says goes to
        // standard error.
        crate::out::to_stderr();
    }
    // The output is checked before anything is read or written: it names
    // none of the inputs, the results store included.
    if let Some(out) = &a.out {
        if a.machine.is_some() {
            fivecal::store::Location::resolve(a.db.as_deref())?;
        }
        let machine_file = a
            .machine
            .as_deref()
            .filter(|m| fivecal::machine::is_path_spec(m))
            .map(PathBuf::from);
        let inputs: Vec<&Path> = [&a.before, &a.after, &a.limits, &machine_file]
            .into_iter()
            .flatten()
            .map(PathBuf::as_path)
            .collect();
        fivecal::io::check_outputs(&inputs, &[("--out", out, fivecal::io::Shape::File)])?;
    }
    let limits = a.limits.as_deref().map(LimitsSource::read).transpose()?;
    let ((bn, b), (an, af)) = match (&a.before, &a.after, &a.machine) {
        (Some(b), Some(af), None) => (from_file(b)?, from_file(af)?),
        (None, None, Some(m)) => {
            from_store(a.db.as_deref(), &a.timeout, &super::record::machine_key(m)?)?
        }
        _ => bail!("give --before R1 --after R2, or --machine NAME to take both from the store"),
    };
    if let Some(l) = &limits {
        l.check_result(&af)?;
    }
    let c = Comparison::new((&bn, &b), (&an, &af), limits.as_ref().map(|l| &l.limits))?;
    out!("{}", c.render());
    if a.json {
        // The comparison as the `-o FILE.json` file holds it.
        crate::out::json_of(&c)?;
    }
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
    let (f, src) = ErrorFile::read(p)?;
    plausible(p, &src, &f)?;
    Ok((p.display().to_string(), f))
}

/// Refuses a location error whose value or u no machine has (`u: 1e300`):
/// the comparison would print it, and a change with an infinite u, as a
/// result. The range is the error files' own (within 10,000 um or urad).
fn plausible(path: &Path, src: &str, f: &ErrorFile) -> anyhow::Result<()> {
    let max = fivecal::limits::MAX_ERROR_UM;
    for (name, q) in &f.location_errors {
        let bad = |x: f64| !(x.is_finite() && x.abs() <= max);
        let what = if bad(q.value) {
            Some(("value", q.value))
        } else {
            q.u.filter(|&u| bad(u) || u < 0.0).map(|u| ("u", u))
        };
        if let Some((key, x)) = what {
            return Err(fivecal::source::SourceError::at_key(
                path,
                src,
                &["location_errors", name],
                format!(
                    "{name}: {key} {x:e} is beyond any machine (expected a finite number within {max} um or urad)"
                ),
            )
            .into());
        }
    }
    Ok(())
}

fn from_record(r: &Stored) -> anyhow::Result<(String, ErrorFile)> {
    let name = format!("record {} ({})", r.id, r.record.result_name);
    let mut f = ErrorFile::parse(Path::new(&name), &r.record.content)
        .with_context(|| format!("record {} is not an error file", r.id))?;
    // A result written before result files named their test: the
    // record's.
    if f.test.is_none() {
        f.test = r.record.test.clone();
    }
    plausible(Path::new(&name), &r.record.content, &f)?;
    Ok((name, f))
}

type Pair = ((String, ErrorFile), (String, ErrorFile));

fn from_store(
    db: Option<&str>,
    timeout: &crate::config::record::DbTimeout,
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
    // The result after (the latest), and before it the latest of the same
    // test: another test sees the errors through another design.
    let same_test = |a: &Stored, b: &Stored| a.record.test == b.record.test;
    let pick = match h.exports.last() {
        Some(e) => {
            let after = results.iter().rev().find(|r| r.record.measured_at > e.at);
            let Some(after) = after else {
                bail!(
                    "machine `{machine}`: no result after its last export (record {}): measure the compensated machine first",
                    e.id
                )
            };
            let before = results
                .iter()
                .rev()
                .find(|r| r.record.measured_at <= e.at && same_test(r, after));
            match before {
                Some(b) => (*b, *after),
                None => bail!(
                    "machine `{machine}`: no result of the {} test before its last export (record {}) to compare record {} with",
                    after.record.test.as_deref().unwrap_or("same"),
                    e.id,
                    after.id
                ),
            }
        }
        None => {
            let Some(after) = results.last() else {
                bail!(
                    "machine `{machine}` has no result with location errors in the store: verify needs two"
                );
            };
            match results[..results.len() - 1]
                .iter()
                .rev()
                .find(|r| same_test(r, after))
            {
                Some(b) => (*b, *after),
                None => bail!(
                    "machine `{machine}` has no earlier result of the {} test than record {}: verify needs two of one test",
                    after.record.test.as_deref().unwrap_or("same"),
                    after.id
                ),
            }
        }
    };
    Ok((from_record(pick.0)?, from_record(pick.1)?))
}
