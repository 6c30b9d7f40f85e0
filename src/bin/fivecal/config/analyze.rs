//! `fivecal analyze`'s options and their validation into one [`Config`]:
//! the plan and measured files, the method and maps, the Monte-Carlo
//! study, the series and comparison, the limits, the result file and the
//! report. The `contour` mode's options are `cmd/contour.rs`'s.

use std::path::{Path, PathBuf};

use anyhow::{Context as _, bail};
use clap::{Args, Subcommand};
use fivecal::analyze::Request;
use fivecal::conformance::LimitsSource;
use fivecal::identify::Method;
use fivecal::identify::sphere::CircleMethod;
use fivecal::io::{Shape, check_outputs};

use super::record::Recording;

mod uncertainty;

#[derive(Args, Debug)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct AnalyzeCli {
    #[command(subcommand)]
    pub mode: Option<AnalyzeMode>,
    // Boxed: the many options would make `Command` lopsided.
    #[command(flatten)]
    pub args: Box<AnalyzeArgs>,
}

#[derive(Subcommand, Debug)]
pub enum AnalyzeMode {
    /// Distance of each measured point to the design surface of a part
    /// model (OBJ or glTF), with mean and maximum.
    Contour(crate::cmd::contour::ContourArgs),
}

/// Identify location errors and error maps from measurements of a plan.
#[derive(Args, Debug)]
pub struct AnalyzeArgs {
    /// The plan manifest written by `fivecal plan` (`DIR/<test>.plan.yaml`).
    #[arg(long, value_name = "PLAN", required = true)]
    plan: Option<PathBuf>,
    /// Measurement files: DMIS output, QIF results, ZEISS CALYPSO tables
    /// (_fet, _chr), CSV `label,x,y,z` or a table naming its columns, probe
    /// logs, nine-section heights `section,height_um`, or a point cloud `x
    /// y z [i j k]` (joined by nearest nominal point). The format is
    /// recognized from the content (`fivecal measured FILE` shows what it
    /// holds). Several files make one piece unless --series is given.
    #[arg(long, value_name = "FILE", num_args = 1.., required = true)]
    measured: Vec<PathBuf>,
    /// The result: an error file (the identified values with their u, and
    /// what the test cannot identify), or the nine-section statistics, or
    /// with --series the series table.
    #[arg(short, long, value_name = "RESULT.yaml", required = true)]
    out: Option<PathBuf>,
    /// Print the result as JSON on standard output (what the result file
    /// holds; with --series, the series table), and the rest on standard
    /// error. The result file's format follows its name: JSON for
    /// RESULT.json, else YAML.
    #[arg(long)]
    json: bool,
    /// Also write an HTML report with SVG plots and a .glb of the piece.
    #[arg(long, value_name = "DIR")]
    report: Option<PathBuf>,
    /// two-stage (a pose per cut or station, then the errors from the
    /// poses), global (one fit of all points, the default) or sphere (circle
    /// and plane fits of the sphere centres, the default for probe-sphere on
    /// a table-table machine; on a machine with a head the global fit is).
    #[arg(long, value_name = "METHOD")]
    method: Option<String>,
    /// Run a Monte-Carlo uncertainty study of N runs (seeded, parallel): a
    /// machine with the estimated errors plus a draw of the contributors,
    /// the test measured on it and identified again; the spread becomes the
    /// reported `u`. Each draw is mapped to the measurements by the
    /// simulator's forward-model Jacobians and re-identified by the fit's
    /// first-order response (errors of micrometres keep both linear). (A
    /// points file whose plan cannot be rebuilt from the manifest falls back
    /// to the rigid-pose model, and says so.)
    #[arg(long, value_name = "N")]
    mc: Option<usize>,
    /// With --mc: simulate the plan again and fit every run exactly (the
    /// reference the linearized study is tested against; seconds per
    /// hundred runs instead of milliseconds).
    #[arg(long, requires = "mc")]
    mc_exact: bool,
    /// With --mc: stop the study after this many seconds and refuse it
    /// (no u from fewer runs than asked), naming how many runs were done.
    /// A study that runs longer than 10 s writes a progress line every
    /// 10 s when stderr is not a terminal (a bar when it is).
    #[arg(long, requires = "mc", value_name = "S", allow_negative_numbers = true)]
    max_seconds: Option<f64>,
    /// Seed of the Monte-Carlo study.
    #[arg(long, value_name = "SEED", default_value_t = 1)]
    seed: u64,
    /// Contributors of the Monte-Carlo study: `seed001` (the machining
    /// default: Ibaraki & Ota 2014), `seed000` (the probing default:
    /// Ibaraki, Iritani & Matsushita 2013), `noise` (residual sigma only), or a YAML file with the keys `distribution` (uniform or
    /// normal), `linear_scale_um_per_m`, `straightness_um`,
    /// `squareness_urad`, `noise_um`, and optionally `setup_position_um` and
    /// `setup_orientation_urad` (three numbers each), `pretravel_um`
    /// (directional pre-travel variation) and `sphere_form_um`.
    #[arg(long, value_name = "PRESET|FILE")]
    contributors: Option<String>,
    /// Error maps to identify with the location errors, comma-separated
    /// map symbols (`EBB(B),EXC(B,C)`), on the grid of the plan's angles.
    #[arg(long, value_name = "SYMBOLS")]
    maps: Vec<String>,
    /// Each measured file is one piece of a series of the same plan:
    /// identify each and tabulate how the errors move.
    #[arg(long)]
    series: bool,
    /// An earlier result (e.g. a cold probing run) to compare with.
    #[arg(long, value_name = "RESULT.yaml")]
    compare: Option<PathBuf>,
    /// Sphere method: how the axis lines are fitted to the centres:
    /// robust (default), least-squares, or combinations (the three-point
    /// combinations of Cubas Brizuela & Yeh 2023).
    #[arg(long, value_name = "FIT", default_value = "robust")]
    circle_fit: String,
    /// The instrument's noise per measured point (standard deviation, um)
    /// the fit is judged against [default: 0.35 um for a CMM on a machined
    /// piece and for an on-machine probe, with the sphere's 0.1 um form
    /// error added for probe-sphere]. Residuals significantly larger mark
    /// the result as a misfit, which compensate refuses.
    #[arg(long, value_name = "UM")]
    noise: Option<f64>,
    /// The largest u a location error may have to count as identified
    /// (and be written among the values, exported and compensated): a
    /// position's in um, an orientation's in urad [default: 10,50]. A
    /// symbol with an acceptance limit in the machine file is held to
    /// half the limit's half-width instead (U = 2u inside the limit).
    #[arg(long, value_name = "UM,URAD")]
    useful_u: Option<String>,
    /// Acceptance limits per location symbol: a limits file or a machine
    /// file with a `limits:` section. Prints PASS, FAIL or "cannot decide"
    /// per symbol and for the machine (ISO 14253-1, U = 2u).
    #[arg(long, value_name = "FILE")]
    limits: Option<PathBuf>,
    /// Ball-bar plans: the spindle ball's run-out as the setup sheet's
    /// dial-indicator check measured it, um, and the spindle angle of its
    /// maximum, deg (`--runout 3,45`): taken out of every reading.
    #[arg(long, value_name = "UM[,DEG]")]
    runout: Option<String>,
    /// Ball-bar plans: standard uncertainty of the table ball's centre
    /// along the bar as set, um [default: 2].
    #[arg(long, value_name = "UM")]
    placement_u: Option<f64>,
    /// Ball-bar plans: an error file whose linear-axis errors (scale,
    /// squareness, straightness) are taken out of the readings at the
    /// positions the linear axes take.
    #[arg(long, value_name = "FILE")]
    linear_errors: Option<PathBuf>,
    #[command(flatten)]
    measured_flags: super::measured::MeasuredFlags,
    #[command(flatten)]
    record: super::record::RecordArgs,
}

/// The validated configuration of one `analyze` run.
pub struct Config {
    /// What the library analyses, and how.
    pub request: Request,
    /// The result file.
    pub out: PathBuf,
    /// Whether the result file is JSON (its name ends in `.json`, or the
    /// `--json` of earlier releases asks for it).
    pub json: bool,
    /// `--json`: the result as JSON on standard output.
    pub json_stdout: bool,
    /// Where the HTML report goes.
    pub report: Option<PathBuf>,
    /// The acceptance limits the result is checked against.
    pub limits: Option<LimitsSource>,
    /// A ball-bar plan's analysis, instead of `request`'s.
    pub ball_bar: Option<fivecal::analyze::ball_bar::Request>,
    /// Where the run is recorded.
    pub record: Recording,
}

impl AnalyzeArgs {
    /// `analyze` of a laser-lines plan (its ISO 230-2 figures, see
    /// `cmd/laser.rs`), when `--plan` is one; the identification's options
    /// do not apply to it and are refused.
    pub fn laser_lines(&self) -> Option<anyhow::Result<super::laser::LaserAnalyzeConfig>> {
        let plan = self.plan.as_ref()?;
        let src = std::fs::read_to_string(plan).ok()?;
        if !fivecal::formats::laser::LaserManifest::sniff(&src) {
            return None;
        }
        let given = [
            ("--method", self.method.is_some()),
            ("--mc", self.mc.is_some()),
            ("--maps", !self.maps.is_empty()),
            ("--series", self.series),
            ("--compare", self.compare.is_some()),
            ("--contributors", self.contributors.is_some()),
            ("--noise", self.noise.is_some()),
            ("--useful-u", self.useful_u.is_some()),
            ("--limits", self.limits.is_some()),
        ];
        if let Some((flag, _)) = given.iter().find(|(_, g)| *g) {
            return Some(Err(anyhow::anyhow!(
                "{flag} does not apply to a laser-lines plan ({}): its analysis is the ISO 230-2 figures of each line",
                plan.display()
            )));
        }
        Some(Ok(super::laser::LaserAnalyzeConfig {
            plan: plan.clone(),
            measured: self.measured.clone(),
            out: self.out.clone()?,
            json: self.json,
            report: self.report.clone(),
        }))
    }
}

/// The validated configuration of one `analyze` run.
pub fn validate(a: AnalyzeArgs) -> anyhow::Result<Config> {
    let manifest = a.plan.context("--plan is required")?;
    let out = a.out.context("--out is required")?;
    let method = a
        .method
        .as_deref()
        .map(|m| m.parse::<Method>().map_err(anyhow::Error::msg))
        .transpose()?;
    let circle = a
        .circle_fit
        .parse::<CircleMethod>()
        .map_err(anyhow::Error::msg)?;
    let contributors = uncertainty::contributors(a.contributors.as_deref())?;
    let limits = a.limits.as_deref().map(LimitsSource::read).transpose()?;
    let record = a.record.validate()?;
    let monte_carlo = uncertainty::monte_carlo(a.mc, a.seed, a.max_seconds, a.mc_exact)?;
    let mut inputs: Vec<&Path> = a.measured.iter().map(|p| p.as_path()).collect();
    inputs.push(&manifest);
    inputs.extend(a.compare.as_deref());
    inputs.extend(a.linear_errors.as_deref());
    let mut outputs = vec![("--out", out.as_path(), Shape::File)];
    outputs.extend(a.report.as_deref().map(|r| ("--report", r, Shape::Dir)));
    check_outputs(&inputs, &outputs)?;
    // `-o -` puts the result itself on standard output: in JSON with --json.
    let to_stdout = out.as_os_str() == "-";
    let named_json = out
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("json"));
    if a.json && !named_json && !to_stdout {
        // Earlier releases' --json chose the file's format; kept one
        // release more, said once.
        eprintln!(
            "note: `--json` now prints the result on standard output, as in every command, and the result file's format follows its name (-o {}.json); {} is written as JSON as before until the next release",
            out.with_extension("").display(),
            out.display()
        );
    }
    let json_file = a.json || named_json;
    if a.series && a.measured.len() < 2 {
        bail!("--series needs two or more measured files, one per piece");
    }
    let noise = super::noise_arg(a.noise)?;
    let usefulness = super::useful_u(a.useful_u.as_deref())?;
    let ball_bar = super::ball_bar::analysis(
        &manifest,
        &a.measured,
        super::ball_bar::BallBarAnalyzeArgs {
            runout: a.runout,
            placement_u: a.placement_u,
            linear_errors: a.linear_errors,
        },
        noise,
        usefulness,
        &[
            ("--method", a.method.is_some()),
            ("--mc", a.mc.is_some()),
            ("--maps", !a.maps.is_empty()),
            ("--series", a.series),
            ("--compare", a.compare.is_some()),
            ("--limits", a.limits.is_some()),
        ],
    )?;
    Ok(Config {
        request: Request {
            method,
            maps: super::list_items(&a.maps),
            series: a.series,
            compare: a.compare,
            contributors,
            monte_carlo,
            circle,
            noise,
            usefulness,
            options: a.measured_flags.options()?,
            ..Request::new(&manifest, a.measured)
        },
        out,
        json: json_file,
        json_stdout: a.json && !to_stdout,
        report: a.report,
        limits,
        ball_bar,
        record,
    })
}
