//! `fivecal discover` (issue 8): find the effect the model is missing, add
//! it, show the gap shrink. The raw arguments are validated into one
//! [`Config`] here; everything else is the library's
//! ([`fivecal::discover`]).

use std::path::{Path, PathBuf};

use anyhow::{Context as _, bail};
use clap::Args;
use fivecal::analyze;
use fivecal::discover::{self, DiscoverOptions, Inputs};
use fivecal::formats::detect::MeasuredOptions;
use fivecal::io::{Shape, check_outputs, write_atomic};
use fivecal::store::runs;

use super::record::Recording;

/// Find where model and measurement disagree, name the missing effect, add
/// it and show the gap shrink.
#[derive(Args, Debug)]
pub struct DiscoverArgs {
    /// The plan manifest written by `fivecal plan` (`DIR/<test>.plan.yaml`).
    #[arg(long, value_name = "PLAN", required = true)]
    plan: Option<PathBuf>,
    /// Measurement files of one piece or probing run (DMIS output, QIF
    /// results, CALYPSO tables, CSV `label,x,y,z` and tables naming their
    /// columns, probe logs, point clouds `x y z [i j k]`), recognized from
    /// their content.
    #[arg(long, value_name = "FILE", num_args = 1.., required = true)]
    measured: Vec<PathBuf>,
    /// The starting model, comma-separated: `location` (the location errors
    /// the test identifies) and candidate names (`map.EBB(B)`,
    /// `drift.EZ0B/seq`, ...).
    #[arg(long, value_name = "EFFECTS", default_value = "location")]
    start: Vec<String>,
    /// Try only these candidates: names or families (`drift`, `map`,
    /// `scale`, `squareness`, `straightness`, `tool_radius`, ...).
    #[arg(long, value_name = "CANDIDATES")]
    candidates: Vec<String>,
    /// Leave these candidates out (names or families).
    #[arg(long, value_name = "CANDIDATES")]
    exclude: Vec<String>,
    /// Significance level of each step, after the adjustment for the number
    /// of candidates tried.
    #[arg(long, value_name = "ALPHA", default_value_t = 0.01)]
    alpha: f64,
    /// Stop after this many steps.
    #[arg(long, value_name = "N", default_value_t = 12)]
    max_steps: usize,
    /// Write the story as JSON to standard output instead of text.
    #[arg(long)]
    json: bool,
    /// Also write an HTML report (the gap per step, residual patterns
    /// before and after) into this directory.
    #[arg(long, value_name = "DIR")]
    report: Option<PathBuf>,
    /// Write the final model as an error file (docs/formats.md; JSON if the
    /// name ends in `.json`, else YAML).
    #[arg(long, value_name = "RESULT.yaml")]
    out: Option<PathBuf>,
    /// The instrument's noise per measured point (standard deviation, um)
    /// the final model's fit is judged against, as for `analyze --noise`.
    #[arg(long, value_name = "UM")]
    noise: Option<f64>,
    #[command(flatten)]
    measured_flags: super::measured::MeasuredFlags,
    #[command(flatten)]
    record: super::record::RecordArgs,
}

/// The validated configuration of one `discover` run.
struct Config {
    manifest: PathBuf,
    measured: Vec<PathBuf>,
    measured_options: MeasuredOptions,
    options: DiscoverOptions,
    json: bool,
    report: Option<PathBuf>,
    out: Option<PathBuf>,
    noise: Option<f64>,
    record: Recording,
}

fn validate(a: DiscoverArgs) -> anyhow::Result<Config> {
    let manifest = a.plan.context("--plan is required")?;
    if !(a.alpha > 0.0 && a.alpha < 1.0) {
        bail!(
            "--alpha {}: expected a significance level between 0 and 1 (e.g. 0.01)",
            a.alpha
        );
    }
    if a.max_steps == 0 {
        bail!("--max-steps must be at least 1");
    }
    if a.start.iter().all(|s| s.trim().is_empty()) {
        bail!("--start names no effect: expected `location` and/or candidate names");
    }
    let mut inputs: Vec<&Path> = a.measured.iter().map(|p| p.as_path()).collect();
    inputs.push(&manifest);
    let mut outputs = Vec::new();
    outputs.extend(a.out.as_deref().map(|o| ("--out", o, Shape::File)));
    outputs.extend(a.report.as_deref().map(|r| ("--report", r, Shape::Dir)));
    check_outputs(&inputs, &outputs)?;
    let record = a.record.validate()?;
    let noise = super::noise_arg(a.noise)?;
    Ok(Config {
        noise,
        manifest,
        measured: a.measured,
        measured_options: a.measured_flags.options()?,
        options: DiscoverOptions {
            start: super::list_items(&a.start),
            only: super::list_items(&a.candidates),
            exclude: super::list_items(&a.exclude),
            alpha: a.alpha,
            max_steps: a.max_steps,
            ..DiscoverOptions::default()
        },
        json: a.json,
        report: a.report,
        out: a.out,
        record,
    })
}

pub fn run(args: DiscoverArgs) -> anyhow::Result<()> {
    let c = validate(args)?;
    // Only the final model written to --out is a result to keep.
    let mut recorder = match &c.out {
        Some(_) => Some(c.record.open()?),
        None => None,
    };
    let inputs = Inputs::load(&c.manifest, &c.measured, &c.measured_options)?;
    for w in &inputs.data.warnings {
        eprintln!("warning: {w}");
    }
    let d = inputs.discover(&c.options)?;
    if c.json {
        outln!("{}", serde_json::to_string_pretty(&d.story)?);
    } else {
        out!("{}", d.story.render());
    }
    let say = |s: String| {
        if c.json {
            eprintln!("{s}");
        } else {
            outln!("{s}");
        }
    };
    // The report first: it is the part that can fail (a plot), and a
    // failed run leaves no result file behind.
    if let Some(dir) = &c.report {
        let files = discover::report::write(dir, &d, &inputs.data)?;
        say(format!(
            "report: {} ({} files)",
            dir.join("index.html").display(),
            files.len()
        ));
    }
    if let Some(out) = &c.out {
        let expected =
            analyze::fit::ExpectedNoise::new(c.noise, inputs.data.kind, inputs.plan.test());
        let f = d.error_file(&inputs.data, &expected);
        if let Some(fit) = &f.fit {
            say(format!(
                "fit of the final model: {} (residuals {:.3} um against {:.3} um expected, {}; ratio {:.2})",
                fit.verdict, fit.sigma_um, fit.expected_um, fit.expected_from, fit.ratio
            ));
        }
        let json = out.extension().is_some_and(|e| e == "json");
        let text = if json {
            f.to_json() + "\n"
        } else {
            f.to_yaml()
        };
        write_atomic(out, text.as_bytes())?;
        say(format!("wrote {}", out.display()));
        if let Some(r) = &mut recorder {
            let rec = runs::discovery(
                &f.machine,
                inputs.plan.test().as_str(),
                &c.manifest,
                &c.measured,
                out,
                &text,
                &c.record.notes,
            )?;
            r.save(&[rec], &say)?;
        }
    }
    Ok(())
}
