//! `fivecal compensate`: rewrite an NC program so the identified errors
//! cancel, and/or export them as a controller's pivot parameters. The
//! options are validated into one [`Config`] in `config/compensate.rs`;
//! this runs the library's rewrite and export and prints what they did.

use anyhow::{Context as _, bail};
use fivecal::compensate::{AtomicOutput, Compensator, Rewrite, export, reasons};
use fivecal::numbers::count;

use super::compensate_json::{Compensated, Exported, Rewritten};
use crate::config::compensate::{CompensateArgs, Config, Job, TablesConfig};

pub fn run(args: CompensateArgs) -> anyhow::Result<()> {
    let cfg = match args.validate()? {
        Job::Model(c) => *c,
        Job::Tables(t) => return tables(&t),
    };
    if cfg.json {
        // Standard output is the JSON's: what the run says goes to
        // standard error.
        crate::out::to_stderr();
    }
    let mut report = Compensated {
        machine: cfg.common.machine.name.clone(),
        errors: cfg.errors_path.display().to_string(),
        ..Compensated::default()
    };
    // An export changes the control: kept in the store, opened first so an
    // unreachable store stops the run before anything is written.
    // A preview (no --entered) changes nothing and is not recorded.
    let mut recorder = match &cfg.export {
        Some(_) if cfg.entered => Some(cfg.record.open()?),
        _ => None,
    };
    // The export is computed before the program is rewritten: refused (a
    // limit, a stroke, nothing held), the run writes nothing at all.
    let exported = match &cfg.export {
        Some((d, _)) => Some(export::export_identified(
            &cfg.errors.model,
            &cfg.errors.theta,
            &cfg.errors.u,
            *d,
            &cfg.errors_path.display().to_string(),
            &cfg.limits,
            &cfg.errors.not_identifiable,
        )?),
        None => None,
    };
    // What the run leaves as it was, said in its last line.
    let mut copy: Option<String> = None;
    if let Some((input, output)) = &cfg.rewrite {
        // The output first: a program coming through a FIFO may keep the
        // run waiting for its beginning, and an interrupted run then still
        // has its temporary file to remove.
        let mut out = AtomicOutput::create(output)?;
        let (detection, file) = cfg.common.open_program(input)?;
        let mut settings = cfg.settings.clone();
        settings.dialect = detection.dialect;
        let c = Compensator::new(&cfg.errors.model, &cfg.errors.theta, settings);
        // On any error `out` is dropped: its temporary file goes, nothing is written.
        let summary = c.run(input, file, &mut out)?;
        report.rewrite = Some(Rewritten::new(&summary, input, output, detection.dialect));
        report.files.push(output.display().to_string());
        let unchanged = summary.changed == 0 && summary.inserted == 0;
        if let Some(why) = &summary.no_motion {
            // Nothing to correct in it, and nothing wrong with it: a
            // program of tool changes and calls is passed on as it is.
            out.commit()?;
            out!("{}", describe(&summary, input, output, &detection, &cfg));
            copy = Some(format!(
                "{why}: {} is a copy of {}",
                output.display(),
                input.display()
            ));
        } else {
            if unchanged && summary.largest_linear.is_none() {
                // Moves there were (a program without is passed on above or
                // refused by the library), and every one was left as
                // written: a copy is no compensation.
                bail!(
                    "{}: none of its {} could be rewritten ({}); nothing written",
                    input.display(),
                    count(summary.moves, "move", "moves"),
                    reasons(&summary.skipped)
                );
            }
            let any_error = cfg.errors.theta.iter().any(|&v| v != 0.0);
            let felt = |l: Option<fivecal::compensate::Largest>| l.is_some_and(|l| l.value > 1e-6);
            if unchanged
                && any_error
                && !felt(summary.largest_linear)
                && !felt(summary.largest_rotary)
            {
                // Errors there are, and not one moves a pose this program
                // writes (a tool radius error, a probing effect): a copy is
                // not what was asked for.
                bail!(
                    "{}: its errors move no tool pose of {} ({}); nothing written",
                    cfg.errors_path.display(),
                    input.display(),
                    if summary.not_compensated.is_empty() {
                        "none is of a kind a rewrite corrects".to_string()
                    } else {
                        summary.not_compensated.join("; ")
                    }
                );
            }
            out.commit()?;
            out!("{}", describe(&summary, input, output, &detection, &cfg));
            if unchanged {
                // Legitimate (a machine whose errors are all but zero), but
                // never silent.
                let why = if any_error {
                    format!(
                        "every correction is below the resolution written ({} decimals in mm, {} in deg)",
                        cfg.settings.linear_decimals, cfg.settings.rotary_decimals
                    )
                } else {
                    format!(
                        "{} holds no error (every value 0)",
                        cfg.errors_path.display()
                    )
                };
                copy = Some(format!(
                    "{why}: {} is a copy of {}",
                    output.display(),
                    input.display()
                ));
            }
        }
    }
    report.unchanged.clone_from(&copy);
    let Some(((d, target), exported)) = cfg.export.as_ref().zip(exported) else {
        if let Some(c) = copy {
            outln!("nothing changed: {c}");
        }
        return json(&cfg, &report);
    };
    report.export = Some(Exported::new(&exported, target.as_deref()));
    report
        .files
        .extend(target.iter().map(|t| t.display().to_string()));
    let text = &exported.file_text(target.as_deref());
    match target {
        Some(p) => {
            fivecal::io::write_atomic(p, text.as_bytes())?;
            outln!("{d} parameters written to {}:", p.display());
            for line in exported.table() {
                outln!("  {line}");
            }
        }
        None => out!("{text}"),
    }
    if let Some(r) = &mut recorder {
        let content = std::fs::read_to_string(&cfg.errors_path)
            .with_context(|| format!("cannot read {} to record it", cfg.errors_path.display()))?;
        let rec = fivecal::store::runs::export(
            &cfg.common.machine.name,
            &cfg.errors_path,
            &content,
            &d.to_string(),
            text,
            &cfg.record.notes,
        )?;
        // Beside parameters printed to standard output, the note goes
        // to standard error.
        let to_stdout = target.is_some();
        r.save(&[rec], &|s| {
            if to_stdout {
                outln!("{s}")
            } else {
                eprintln!("{s}")
            }
        })?;
    }
    // Beside parameters on standard output, the notes go to standard
    // error; the last says whether anything changes.
    for n in exported.closing_notes(&cfg.errors_path, cfg.entered, copy) {
        if target.is_some() {
            outln!("{n}")
        } else {
            eprintln!("{n}")
        }
    }
    json(&cfg, &report)
}

/// With `--json`, what was done, on standard output.
fn json(cfg: &Config, report: &Compensated) -> anyhow::Result<()> {
    if cfg.json {
        crate::out::json_of(report)?;
    }
    Ok(())
}

/// The summary of the rewrite of `input` into `output`, in the library's
/// words.
fn describe(
    s: &fivecal::compensate::Summary,
    input: &std::path::Path,
    output: &std::path::Path,
    detection: &fivecal::nc::dialect::Detection,
    cfg: &Config,
) -> String {
    s.describe(&Rewrite {
        input,
        output,
        machine: &cfg.common.machine,
        machine_origin: &cfg.common.machine_origin,
        errors: &cfg.errors_path,
        detection,
        settings: &cfg.settings,
    })
}

/// Writes a laser-lines result's axis tables for the controller: every
/// table printed first (also when the controller's format is refused, so
/// the values can be entered by hand), then the files, all or nothing.
fn tables(cfg: &TablesConfig) -> anyhow::Result<()> {
    use fivecal::compensate::axis_tables::{self, TablePoint};
    let t = &cfg.tables;
    outln!(
        "axis tables of {} from {}: positioning error = actual minus commanded, um (k = 1 for u)",
        t.machine,
        cfg.errors_path.display()
    );
    for (axis, line) in &t.missing {
        outln!("note: no table for {axis}: its base line {line} is not in the result");
    }
    let mean = |p: &TablePoint| format!("{:+.3} u {:.3}", p.mean_um(), p.u_mean_um());
    for table in &t.tables {
        for line in table.listing(("mean um", &mean)).lines() {
            outln!("  {line}");
        }
    }
    let files = axis_tables::write(cfg.dialect, &t.tables, &cfg.limits)?;
    let inputs: Vec<&std::path::Path> = cfg.inputs.iter().map(|p| p.as_path()).collect();
    let bytes: Vec<_> = files
        .into_iter()
        .map(|(n, s)| (n, s.into_bytes()))
        .collect();
    let written =
        fivecal::io::write_dir(&cfg.out, &bytes, &inputs).map_err(|e| anyhow::anyhow!("{e}"))?;
    for w in written {
        outln!("wrote {}", w.display());
    }
    outln!(
        "note: the tables correct the axes as measured; measured with a compensation table active, add them to it (see {})",
        cfg.out.join("axis-tables.txt").display()
    );
    Ok(())
}
