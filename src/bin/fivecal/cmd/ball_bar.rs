//! `fivecal plan ball-bar`, `fivecal simulate` on a ball-bar plan and
//! `fivecal analyze` on its runs: the ball bar under tool-centre-point
//! control (docs/ball-bar.md).

use std::path::Path;

use anyhow::Context as _;
use fivecal::ErrorFile;
use fivecal::formats::ball_bar::BallBarManifest;
use fivecal::io::{Shape, check_outputs};
use fivecal::simulate::ball_bar::{BallBarOptions, simulate as simulate_runs};

use crate::config::ball_bar::BallBarPlanConfig;

/// Plans and writes the ball-bar test.
pub fn plan(cfg: BallBarPlanConfig) -> anyhow::Result<()> {
    let inputs: Vec<&Path> = cfg.inputs.iter().map(|p| p.as_path()).collect();
    check_outputs(&inputs, &[("--out", &cfg.out, Shape::Dir)])?;
    let req = &cfg.request;
    let planned = fivecal::procedure::ball_bar::plan(req).with_context(|| {
        format!(
            "cannot plan ball-bar on {} ({})",
            req.machine.name, req.dialect
        )
    })?;
    let written = planned
        .write(&cfg.out, &inputs)
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let angles: usize = planned.setups.iter().map(|s| s.angles.len()).sum();
    outln!(
        "ball-bar on {}: {} setups, {} readings ({} dialect)",
        req.machine.name,
        planned.setups.len(),
        angles,
        req.dialect
    );
    out!("{}", planned.prediction.render());
    outln!("note: {}", cfg.origin);
    for n in &planned.notes {
        outln!("note: {n}");
    }
    for w in written {
        outln!("wrote {}", w.display());
    }
    Ok(())
}

/// Whether the plan file at `path` is a ball-bar plan.
pub fn is_ball_bar(path: &Path) -> bool {
    std::fs::read_to_string(path).is_ok_and(|s| BallBarManifest::sniff(&s))
}

/// Writes one run file per setup of the ball-bar plan `plan_path` into the
/// directory `out`.
pub fn simulate(
    plan_path: &Path,
    errors: &Path,
    out: &Path,
    opts: BallBarOptions,
) -> anyhow::Result<()> {
    let man = BallBarManifest::read(plan_path)?;
    let dir = plan_path.parent().unwrap_or(Path::new("."));
    let machine_path = dir.join(&man.machine_file);
    let machine_text = fivecal::input::read_text(
        &machine_path,
        "ball-bar plan's machine copy",
        fivecal::limits::MAX_YAML_BYTES,
    )?;
    let machine = fivecal::Machine::from_yaml(&machine_path, &machine_text)?;
    let inputs = [plan_path, errors, machine_path.as_path()];
    check_outputs(&inputs, &[("--out", out, Shape::Dir)])?;
    let (truth, src) = ErrorFile::read(errors)?;
    let runs = simulate_runs(&man, &machine, &truth, errors, &src, &opts).with_context(|| {
        format!(
            "cannot simulate {} with the errors of {}",
            plan_path.display(),
            errors.display()
        )
    })?;
    let files: Vec<_> = runs
        .iter()
        .map(|r| (format!("{}.txt", r.setup).into(), r.to_text().into_bytes()))
        .collect();
    let written =
        fivecal::io::write_dir(out, &files, &inputs).map_err(|e| anyhow::anyhow!("{e}"))?;
    outln!(
        "simulated {} ball-bar runs on {} (seed {}, run-out {} um at {} deg)",
        runs.len(),
        machine.name,
        opts.seed,
        opts.runout_um,
        opts.runout_phase_deg
    );
    for w in written {
        outln!("wrote {}", w.display());
    }
    Ok(())
}

/// Identifies the rotary axes' errors from the runs of a ball-bar plan,
/// prints what it found (the circularity figures first) and writes the
/// result file, the report and the history record.
pub fn analyze(
    c: &crate::config::analyze::Config,
    req: &fivecal::analyze::ball_bar::Request,
) -> anyhow::Result<()> {
    let mut recorder = c.record.open()?;
    let found = fivecal::analyze::ball_bar::run(req)
        .with_context(|| format!("cannot analyze the ball-bar runs of {}", req.plan.display()))?;
    out!("{}", found.render());
    let text = if c.json {
        found.file.to_json() + "\n"
    } else {
        found.file.to_yaml()
    };
    fivecal::io::write_atomic(&c.out, text.as_bytes()).map_err(|e| anyhow::anyhow!("{e}"))?;
    if c.out.as_os_str() != "-" {
        outln!("wrote {}", c.out.display());
    }
    if c.json_stdout {
        crate::out::json(&found.file.to_json())?;
    }
    if let Some(dir) = &c.report {
        let files = fivecal::report::ball_bar::write(dir, &found.file)?;
        outln!(
            "report: {} ({} files)",
            dir.join("index.html").display(),
            files.len()
        );
    }
    let records = fivecal::store::runs::ball_bar(
        &found.file,
        &req.plan,
        &req.runs,
        &c.out,
        &text,
        &c.record.notes,
    )?;
    recorder.save(&records, &|s| outln!("{s}"))
}
