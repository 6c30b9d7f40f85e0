//! `fivecal plan laser-lines`, `fivecal simulate` and `fivecal analyze` on
//! a laser-lines plan: the laser interferometer's ten lines and their ISO
//! 230-2 figures (docs/laser-lines.md).

use std::path::Path;

use anyhow::Context as _;
use fivecal::ErrorFile;
use fivecal::formats::laser::LaserManifest;
use fivecal::io::{Shape, check_outputs};
use fivecal::simulate::laser::{LaserOptions, simulate as simulate_runs};
use serde::Serialize;

use crate::config::laser::{LaserAnalyzeConfig, LaserPlanConfig};

/// Plans and writes the ten lines; with `json`, what was planned as JSON
/// on standard output (the rest on standard error).
pub fn plan(cfg: LaserPlanConfig, json: bool) -> anyhow::Result<()> {
    if json {
        crate::out::to_stderr();
    }
    let inputs: Vec<&Path> = cfg.inputs.iter().map(|p| p.as_path()).collect();
    check_outputs(&inputs, &[("--out", &cfg.out, Shape::Dir)])?;
    let req = &cfg.request;
    let planned = fivecal::procedure::laser_lines::plan(req).with_context(|| {
        format!(
            "cannot plan laser-lines on {} ({})",
            req.machine.name, req.dialect
        )
    })?;
    let written = planned
        .write(&cfg.out, &inputs)
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let minutes: f64 = planned
        .lines
        .iter()
        .map(|l| planned.seconds(l))
        .sum::<f64>()
        / 60.0;
    outln!(
        "laser-lines on {}: {} lines, {} targets each, {} runs each way, about {:.0} min of measuring ({} dialect)",
        req.machine.name,
        planned.lines.len(),
        req.divisions + 1,
        req.runs,
        minutes,
        req.dialect
    );
    for l in &planned.lines {
        outln!(
            "  {:<4} {:<3} from {:.1},{:.1},{:.1} over {} mm, offset by {}",
            l.name,
            l.axes,
            l.start[0],
            l.start[1],
            l.start[2],
            l.targets[l.targets.len() - 1],
            l.offset_by
        );
    }
    outln!("note: {}", cfg.origin);
    for n in &planned.notes {
        outln!("note: {n}");
    }
    for w in &written {
        outln!("wrote {}", w.display());
    }
    if json {
        crate::out::json_of(&PlannedLines {
            test: "laser-lines",
            machine: &req.machine.name,
            dialect: req.dialect.to_string(),
            volume_mm: planned.volume,
            targets: req.divisions + 1,
            runs: req.runs,
            run_minutes: minutes,
            lines: planned
                .lines
                .iter()
                .map(|l| LineJson {
                    name: &l.name,
                    axes: &l.axes,
                    start_mm: l.start,
                    direction: l.direction,
                    length_mm: l.targets[l.targets.len() - 1],
                    offset_mm: l.offset,
                    offset_by: &l.offset_by,
                })
                .collect(),
            notes: &planned.notes,
            files: written.iter().map(|w| w.display().to_string()).collect(),
        })?;
    }
    Ok(())
}

/// What `plan laser-lines --json` prints.
#[derive(Serialize)]
struct PlannedLines<'a> {
    test: &'static str,
    machine: &'a str,
    dialect: String,
    /// X0, Y0, Z0, X1, Y1, Z1, machine coordinates of the measured point.
    volume_mm: [f64; 6],
    /// Targets per line.
    targets: usize,
    /// Runs in each direction.
    runs: usize,
    /// Measuring time of every line together, minutes.
    run_minutes: f64,
    lines: Vec<LineJson<'a>>,
    notes: &'a [String],
    files: Vec<String>,
}

#[derive(Serialize)]
struct LineJson<'a> {
    name: &'a str,
    axes: &'a str,
    start_mm: [f64; 3],
    direction: [f64; 3],
    length_mm: f64,
    /// The measured point's offset from the spindle point P.
    offset_mm: [f64; 3],
    /// `none`, `axes` or `bracket`.
    offset_by: &'a str,
}

/// Whether the plan file at `path` is a laser-lines plan.
pub fn is_laser(path: &Path) -> bool {
    std::fs::read_to_string(path).is_ok_and(|s| LaserManifest::sniff(&s))
}

/// Writes one run file per line of the plan `plan_path` into `out`.
pub fn simulate(
    plan_path: &Path,
    errors: &Path,
    out: &Path,
    opts: LaserOptions,
) -> anyhow::Result<()> {
    let man = LaserManifest::read(plan_path)?;
    let dir = plan_path.parent().unwrap_or(Path::new("."));
    let machine_path = dir.join(&man.machine_file);
    let machine = fivecal::Machine::from_file(&machine_path, "laser-lines plan's machine copy")?;
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
        .map(|r| (format!("{}.txt", r.line).into(), r.to_text().into_bytes()))
        .collect();
    let written =
        fivecal::io::write_dir(out, &files, &inputs).map_err(|e| anyhow::anyhow!("{e}"))?;
    outln!(
        "simulated {} laser lines on {} (seed {}, reading noise {} um)",
        runs.len(),
        machine.name,
        opts.seed,
        opts.noise_um.unwrap_or(man.reading_u_um)
    );
    outln!(
        "note: the model has no reversal of the linear axes: the reversal value is the noise's (docs/laser-lines.md)"
    );
    for w in written {
        outln!("wrote {}", w.display());
    }
    Ok(())
}

/// The ISO 230-2 figures of each measured line.
pub fn analyze(c: LaserAnalyzeConfig) -> anyhow::Result<()> {
    let man = LaserManifest::read(&c.plan)?;
    let mut inputs: Vec<&Path> = vec![c.plan.as_path()];
    inputs.extend(c.measured.iter().map(|p| p.as_path()));
    let dir = c.plan.parent().unwrap_or(Path::new("."));
    let machine_path = dir.join(&man.machine_file);
    // The identification needs the machine's chain; the figures do not.
    let machine = fivecal::input::read_text(
        &machine_path,
        "laser-lines plan's machine copy",
        fivecal::limits::MAX_YAML_BYTES,
    )
    .map_err(anyhow::Error::from)
    .and_then(|t| Ok(fivecal::Machine::from_yaml(&machine_path, &t)?));
    let machine = match machine {
        Ok(m) => {
            inputs.push(machine_path.as_path());
            Some(m)
        }
        Err(e) => {
            eprintln!(
                "warning: the linear axes' errors are not identified, the plan's machine copy does not read: {e:#}"
            );
            None
        }
    };
    let errors_out = fivecal::analyze::laser::LaserResult::errors_path(&c.out);
    let mut outs = vec![
        ("--out", c.out.as_path(), Shape::File),
        ("--out (its errors file)", errors_out.as_path(), Shape::File),
    ];
    if let Some(r) = &c.report {
        outs.push(("--report", r.as_path(), Shape::Dir));
    }
    check_outputs(&inputs, &outs)?;
    let mut result = fivecal::analyze::laser::analyze(&man, machine.as_ref(), &c.measured)?;
    if c.json {
        crate::out::to_stderr();
    }
    for l in &result.lines {
        out!("{}", l.figures.render());
        if !l.environment.is_empty() {
            let env: Vec<String> = l
                .environment
                .iter()
                .map(|(k, v)| format!("{k} {v}"))
                .collect();
            outln!("  environment ({}): {}", l.format, env.join(", "));
        }
        if l.figures.runs != man.runs {
            eprintln!(
                "warning: line {}: {} runs each way in the file, {} planned",
                l.figures.line, l.figures.runs, man.runs
            );
        }
        if l.figures.runs < 5 {
            eprintln!(
                "warning: line {}: {} runs each way; ISO 230-2 asks five",
                l.figures.line, l.figures.runs
            );
        }
    }
    outln!("u: {}", result.uncertainty);
    if !result.not_measured.is_empty() {
        outln!("not measured: {}", result.not_measured.join(", "));
    }
    if let Some(id) = &result.identification {
        out!("{}", id.render());
        let f = id.error_file(&man.machine);
        let text = if fivecal::analyze::laser::LaserResult::json_name(&errors_out) {
            f.to_json() + "\n"
        } else {
            f.to_yaml()
        };
        fivecal::io::write_atomic(&errors_out, text.as_bytes())
            .map_err(|e| anyhow::anyhow!("{e}"))?;
        outln!(
            "wrote {} (the linear axes' errors, an error file)",
            errors_out.display()
        );
        result.linear_errors = Some(errors_out.clone());
    }
    let json_file = fivecal::analyze::laser::LaserResult::json_name(&c.out);
    fivecal::io::write_atomic(&c.out, result.to_text(json_file).as_bytes())
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    outln!("wrote {}", c.out.display());
    if c.json {
        crate::out::json(&result.to_text(true))?;
    }
    if let Some(dir) = &c.report {
        let files = fivecal::report::laser::write(dir, &result)?;
        outln!(
            "report: {} ({} files)",
            dir.join("index.html").display(),
            files.len()
        );
    }
    Ok(())
}
