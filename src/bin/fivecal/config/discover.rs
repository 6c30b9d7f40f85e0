//! `fivecal discover`'s options and their validation into one [`Config`]:
//! the tests (each `--plan` with the `--measured` files that follow it),
//! the starting model and the candidates, the significance and the number
//! of steps, and where the story, the report and the final model go.

use std::path::{Path, PathBuf};

use anyhow::bail;
use clap::Args;
use fivecal::discover::DiscoverOptions;
use fivecal::formats::detect::MeasuredOptions;
use fivecal::io::{Shape, check_outputs};

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
pub struct Config {
    /// Each test's plan manifest and measured files.
    pub tests: Vec<(PathBuf, Vec<PathBuf>)>,
    /// How the measured files are read.
    pub measured_options: MeasuredOptions,
    /// What the discovery starts from, tries and stops at.
    pub options: DiscoverOptions,
    /// `--json`: the story as JSON on standard output.
    pub json: bool,
    /// Where the HTML report goes.
    pub report: Option<PathBuf>,
    /// Where the final model goes.
    pub out: Option<PathBuf>,
    /// The instrument's noise the final model is judged against.
    pub noise: Option<f64>,
    /// Where the run is recorded.
    pub record: Recording,
}

/// The validated configuration of one `discover` run.
pub fn validate(a: DiscoverArgs) -> anyhow::Result<Config> {
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
