//! `fivecal plan ball-bar`, `fivecal simulate` on a ball-bar plan and
//! `fivecal analyze` on its runs: the ball bar under tool-centre-point
//! control (docs/ball-bar.md).

use std::path::Path;

use anyhow::Context as _;
use fivecal::ErrorFile;
use fivecal::formats::ball_bar::BallBarManifest;
use fivecal::io::{Shape, check_outputs};
use fivecal::simulate::ball_bar::{BallBarOptions, simulate as simulate_runs};
use serde::Serialize;

use crate::config::ball_bar::BallBarPlanConfig;

/// Plans and writes the ball-bar test; with `json`, what was planned as
/// JSON on standard output (the rest on standard error).
pub fn plan(cfg: BallBarPlanConfig, json: bool) -> anyhow::Result<()> {
    if json {
        crate::out::to_stderr();
    }
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
    for w in &written {
        outln!("wrote {}", w.display());
    }
    if json {
        crate::out::json_of(&PlannedBallBar {
            test: "ball-bar",
            machine: &req.machine.name,
            dialect: req.dialect.to_string(),
            setups: planned.setups.len(),
            readings: angles,
            sigma_um: planned.prediction.sigma_um,
            axes: planned
                .prediction
                .axes
                .iter()
                .map(|a| AxisJson {
                    axis: a.axis,
                    setups: a.setups,
                    angles: a.angles.len(),
                    rank: a.rank,
                    terms: (0..a.symbols.len())
                        .map(|k| TermJson {
                            symbol: &a.symbols[k],
                            unit: a.units[k],
                            u_max: a.u_max[k],
                            unseen_at_deg: &a.unseen_at[k],
                        })
                        .collect(),
                })
                .collect(),
            notes: &planned.notes,
            files: written.iter().map(|w| w.display().to_string()).collect(),
        })?;
    }
    Ok(())
}

/// What `plan ball-bar --json` prints.
#[derive(Serialize)]
struct PlannedBallBar<'a> {
    test: &'static str,
    machine: &'a str,
    dialect: String,
    setups: usize,
    /// Readings over every setup (one per angle).
    readings: usize,
    /// Standard deviation of one reading the prediction used, um.
    sigma_um: f64,
    /// What each axis' runs will identify.
    axes: Vec<AxisJson<'a>>,
    notes: &'a [String],
    files: Vec<String>,
}

#[derive(Serialize)]
struct AxisJson<'a> {
    axis: char,
    setups: usize,
    angles: usize,
    /// Rank of the per-angle design, smallest over the sweep (6: every
    /// term seen).
    rank: usize,
    terms: Vec<TermJson<'a>>,
}

#[derive(Serialize)]
struct TermJson<'a> {
    symbol: &'a str,
    unit: &'static str,
    /// The largest predicted u over the sweep; null: unseen somewhere.
    u_max: Option<f64>,
    unseen_at_deg: &'a [f64],
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
    let machine = fivecal::Machine::from_file(&machine_path, "ball-bar plan's machine copy")?;
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
