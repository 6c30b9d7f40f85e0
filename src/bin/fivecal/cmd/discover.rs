//! `fivecal discover` (issue 8): find the effect the model is missing, add
//! it, show the gap shrink. The raw arguments are validated into one
//! [`Config`] here; everything else is the library's
//! ([`fivecal::discover`]).

use std::path::{Path, PathBuf};

use anyhow::bail;
use clap::Args;
use fivecal::analyze;
use fivecal::discover::{self, DiscoverOptions, Inputs};
use fivecal::formats::detect::MeasuredOptions;
use fivecal::io::shell_word;
use fivecal::io::{Shape, check_outputs, write_atomic};
use fivecal::store::runs;

use super::record::Recording;

/// Find where model and measurement disagree, name the missing effect, add
/// it and show the gap shrink.
#[derive(Args, Debug)]
pub struct DiscoverArgs {
    #[command(flatten)]
    tests: Tests,
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
    #[arg(short, long, value_name = "RESULT.yaml")]
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

/// The tests a discovery fits: each `--plan` with the `--measured` files
/// that follow it (clap's derive does not group an option's values by
/// occurrence, its matches do).
#[derive(Debug)]
struct Tests {
    plans: Vec<PathBuf>,
    measured: Vec<Vec<PathBuf>>,
}

impl clap::FromArgMatches for Tests {
    fn from_arg_matches(m: &clap::ArgMatches) -> Result<Self, clap::Error> {
        Ok(Tests {
            plans: m
                .get_many::<PathBuf>("plan")
                .map(|v| v.cloned().collect())
                .unwrap_or_default(),
            measured: m
                .get_occurrences::<PathBuf>("measured")
                .map(|o| o.map(|g| g.cloned().collect()).collect())
                .unwrap_or_default(),
        })
    }

    fn update_from_arg_matches(&mut self, m: &clap::ArgMatches) -> Result<(), clap::Error> {
        *self = Self::from_arg_matches(m)?;
        Ok(())
    }
}

impl clap::Args for Tests {
    fn augment_args(cmd: clap::Command) -> clap::Command {
        use clap::{Arg, ArgAction, value_parser};
        cmd.arg(
            Arg::new("plan")
                .long("plan")
                .value_name("PLAN")
                .value_parser(value_parser!(PathBuf))
                .action(ArgAction::Append)
                .required(true)
                .help(
                    "The plan manifest written by `fivecal plan` (`DIR/<test>.plan.yaml`). Give \
                     `--plan` again, each followed by its `--measured`, to fit several tests of \
                     one machine together (a test and the supplementary test its ambiguity asked \
                     for)",
                ),
        )
        .arg(
            Arg::new("measured")
                .long("measured")
                .value_name("FILE")
                .value_parser(value_parser!(PathBuf))
                .num_args(1..)
                .action(ArgAction::Append)
                .required(true)
                .help(
                    "Measurement files of one piece or probing run (DMIS output, QIF results, \
                     CALYPSO tables, CSV `label,x,y,z` and tables naming their columns, probe \
                     logs, point clouds `x y z [i j k]`), recognized from their content; one \
                     `--measured` per `--plan`, in the same order",
                ),
        )
    }

    fn augment_args_for_update(cmd: clap::Command) -> clap::Command {
        Self::augment_args(cmd)
    }
}

/// The validated configuration of one `discover` run.
struct Config {
    /// Each test's plan manifest and measured files.
    tests: Vec<(PathBuf, Vec<PathBuf>)>,
    measured_options: MeasuredOptions,
    options: DiscoverOptions,
    json: bool,
    report: Option<PathBuf>,
    out: Option<PathBuf>,
    noise: Option<f64>,
    record: Recording,
}

fn validate(a: DiscoverArgs) -> anyhow::Result<Config> {
    let Tests { plans, measured } = a.tests;
    if plans.len() != measured.len() {
        bail!(
            "{} --plan and {} --measured: each --plan takes its own --measured files (`--plan A --measured a.dmo --plan B --measured b.log`)",
            plans.len(),
            measured.len()
        );
    }
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
    let mut inputs: Vec<&Path> = measured.iter().flatten().map(|p| p.as_path()).collect();
    inputs.extend(plans.iter().map(|p| p.as_path()));
    let mut outputs = Vec::new();
    outputs.extend(a.out.as_deref().map(|o| ("--out", o, Shape::File)));
    outputs.extend(a.report.as_deref().map(|r| ("--report", r, Shape::Dir)));
    // The store first: it is an input the outputs may not name.
    let record = a.record.validate()?;
    check_outputs(&inputs, &outputs)?;
    let noise = super::noise_arg(a.noise)?;
    Ok(Config {
        noise,
        tests: plans
            .iter()
            .cloned()
            .zip(measured.iter().cloned())
            .collect(),
        measured_options: a.measured_flags.options()?,
        options: DiscoverOptions {
            start: super::list_items(&a.start),
            only: super::list_items(&a.candidates),
            exclude: super::list_items(&a.exclude),
            alpha: a.alpha,
            max_steps: a.max_steps,
            noise,
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
    let mut inputs = Vec::new();
    for (manifest, measured) in &c.tests {
        inputs.push(Inputs::load(manifest, measured, &c.measured_options)?);
    }
    for i in &inputs {
        for w in &i.data.warnings {
            eprintln!("warning: {w}");
        }
    }
    let d = discover::inputs::discover_together(&inputs, &c.options)?;
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
    let labels = discover::inputs::labels(&inputs);
    let view = discover::merged(&discover::inputs::parts(&inputs, &labels));
    // The report first: it is the part that can fail (a plot), and a
    // failed run leaves no result file behind.
    if let Some(dir) = &c.report {
        let files = discover::report::write(dir, &d, &view)?;
        say(format!(
            "report: {} ({} files)",
            dir.join("index.html").display(),
            files.len()
        ));
    }
    if let Some(out) = &c.out {
        let expected: Vec<analyze::goodness::ExpectedNoise> = inputs
            .iter()
            .map(|i| analyze::goodness::ExpectedNoise::new(c.noise, i.data.kind, i.plan.test()))
            .collect();
        let mut f = d.error_file(&view, &expected);
        if let Some(s) = f.ambiguity.as_mut().and_then(|a| a.supplement.as_mut()) {
            s.plan = Some(c.tests[0].0.display().to_string());
        }
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
        if let Some(a) = &f.ambiguity {
            say(format!(
                "{} states the ambiguity: its model holds none of {}",
                out.display(),
                a.rivals
                    .iter()
                    .map(|r| r.effect.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
            if a.supplement.is_some() {
                let mut again = String::new();
                for (m, files) in &c.tests {
                    again.push_str(&format!(
                        " --plan {} --measured",
                        shell_word(&m.display().to_string())
                    ));
                    for f in files {
                        again.push_str(&format!(" {}", shell_word(&f.display().to_string())));
                    }
                }
                say(format!(
                    "next: fivecal plan --supplement {} --out supplement\n  run supplement/probe-sphere.nc on the machine, then\n  fivecal discover{again} --plan supplement/probe-sphere.plan.yaml --measured LOG",
                    shell_word(&out.display().to_string())
                ));
            }
        }
        if let Some(r) = &mut recorder {
            let measured: Vec<PathBuf> = c.tests.iter().flat_map(|t| t.1.clone()).collect();
            let manifests: Vec<PathBuf> = c.tests.iter().map(|t| t.0.clone()).collect();
            let rec = runs::discovery(
                &f.machine,
                &d.story.test,
                &manifests,
                &measured,
                out,
                &text,
                &c.record.notes,
            )?;
            r.save(&[rec], &say)?;
        }
    }
    Ok(())
}
