//! `fivecal analyze`: identify location errors and error maps, with their
//! uncertainty, from CMM and probe files. The raw arguments are validated
//! into one [`Config`] here, the library's [`fivecal::analyze::run`] does
//! the analysis, and this prints what it found and writes the files. The
//! `contour` mode lives in `contour.rs`.

use std::path::{Path, PathBuf};

use anyhow::{Context as _, bail};
use clap::{Args, Subcommand};
use fivecal::analyze::{
    self, ContributorChoice, Found, Identified, IdentifiedPiece, McOptions, MonteCarlo,
    NineSectionOutcome, Outcome, Request,
};
use fivecal::conformance::{ConformanceVerdict, LimitsSource};
use fivecal::identify::Method;
use fivecal::identify::sphere::CircleMethod;
use fivecal::io::{Shape, check_outputs};
use fivecal::report::{self, ReportInput};
use fivecal::store::runs;

use super::record::Recording;

#[derive(Args, Debug)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct AnalyzeCli {
    #[command(subcommand)]
    mode: Option<AnalyzeMode>,
    // Boxed: the many options would make `Command` lopsided.
    #[command(flatten)]
    args: Box<AnalyzeArgs>,
}

#[derive(Subcommand, Debug)]
enum AnalyzeMode {
    /// Distance of each measured point to the design surface of a part
    /// model (OBJ or glTF), with mean and maximum.
    Contour(super::contour::ContourArgs),
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
    /// Write the result as JSON instead of YAML.
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
    /// Acceptance limits per location symbol: a limits file or a machine
    /// file with a `limits:` section. Prints PASS, FAIL or "cannot decide"
    /// per symbol and for the machine (ISO 14253-1, U = 2u).
    #[arg(long, value_name = "FILE")]
    limits: Option<PathBuf>,
    #[command(flatten)]
    measured_flags: super::measured::MeasuredFlags,
    #[command(flatten)]
    record: super::record::RecordArgs,
}

/// The validated configuration of one `analyze` run.
struct Config {
    request: Request,
    out: PathBuf,
    json: bool,
    report: Option<PathBuf>,
    limits: Option<LimitsSource>,
    record: Recording,
}

fn contributors(spec: Option<&str>) -> anyhow::Result<ContributorChoice> {
    Ok(match spec {
        None => ContributorChoice::TestDefault,
        Some("seed001") => ContributorChoice::Given(analyze::Contributors::seed001()),
        Some("seed000") => ContributorChoice::Given(analyze::Contributors::seed000()),
        Some("noise") => ContributorChoice::NoiseOnly,
        Some(path) => {
            let path = Path::new(path);
            let src = fivecal::input::read_text(
                path,
                "contributors file",
                fivecal::limits::MAX_YAML_BYTES,
            )?;
            ContributorChoice::Given(fivecal::input::parse_yaml(path, &src)?)
        }
    })
}

fn validate(a: AnalyzeArgs) -> anyhow::Result<Config> {
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
    let contributors = contributors(a.contributors.as_deref())?;
    let limits = a.limits.as_deref().map(LimitsSource::read).transpose()?;
    let record = a.record.validate()?;
    let monte_carlo = match a.mc {
        Some(n @ (0 | 1)) => bail!("--mc {n}: the Monte-Carlo study needs at least 2 runs"),
        Some(n) if n > fivecal::limits::MAX_MC_RUNS => bail!(
            "--mc {n}: at most {} runs (the spread of u settles within a few hundred)",
            fivecal::limits::MAX_MC_RUNS
        ),
        Some(_) if a.max_seconds.is_some_and(|s| !(s.is_finite() && s > 0.0)) => bail!(
            "--max-seconds {}: expected a time > 0 s",
            a.max_seconds.unwrap_or_default()
        ),
        Some(runs) => Some(MonteCarlo {
            options: McOptions {
                runs,
                seed: a.seed,
                progress: true,
                max_seconds: a.max_seconds,
            },
            contributors,
            exact: a.mc_exact,
        }),
        None => None,
    };
    let mut inputs: Vec<&Path> = a.measured.iter().map(|p| p.as_path()).collect();
    inputs.push(&manifest);
    inputs.extend(a.compare.as_deref());
    let mut outputs = vec![("--out", out.as_path(), Shape::File)];
    outputs.extend(a.report.as_deref().map(|r| ("--report", r, Shape::Dir)));
    check_outputs(&inputs, &outputs)?;
    if a.series && a.measured.len() < 2 {
        bail!("--series needs two or more measured files, one per piece");
    }
    Ok(Config {
        request: Request {
            method,
            maps: super::list_items(&a.maps),
            series: a.series,
            compare: a.compare,
            monte_carlo,
            circle,
            noise: super::noise_arg(a.noise)?,
            options: a.measured_flags.options()?,
            ..Request::new(&manifest, a.measured)
        },
        out,
        json: a.json,
        report: a.report,
        limits,
        record,
    })
}

pub fn run(cli: AnalyzeCli) -> anyhow::Result<()> {
    match cli.mode {
        Some(AnalyzeMode::Contour(a)) => super::contour::run(a),
        None => {
            let c = validate(*cli.args)?;
            let mut recorder = c.record.open()?;
            let outcome = analyze::run(&c.request)?;
            for w in &outcome.warnings {
                eprintln!("warning: {w}");
            }
            match &outcome.found {
                Found::Identified(id) => identified(&c, &outcome, id)?,
                Found::NineSection(n) => nine_section(&c, &outcome, n)?,
            }
            let written = analyze::result::files(&outcome, &c.out, c.json)?;
            let records = runs::analysis(
                &outcome,
                &c.request.manifest,
                &c.request.measured,
                &written,
                &c.record.notes,
            )?;
            recorder.save(&records, &|s| outln!("{s}"))
        }
    }
}

fn identified(c: &Config, outcome: &Outcome, id: &Identified) -> anyhow::Result<()> {
    if let Some(l) = &c.limits {
        for piece in &id.pieces {
            l.check_result(&piece.file)?;
        }
    }
    for piece in &id.pieces {
        print_piece(c, piece);
        if let Some(l) = &c.limits {
            outln!("limits from {}:", l.path.display());
            out!(
                "{}",
                ConformanceVerdict::of(&piece.file, &l.limits).render()
            );
        }
        if let Some(dir) = &c.report {
            let dir = piece.report_dir(dir);
            let files = report::write(&dir, &ReportInput::for_piece(id.test.as_str(), piece))?;
            outln!(
                "report: {} ({} files)",
                dir.join("index.html").display(),
                files.len()
            );
        }
    }
    if let Some(series) = &id.series {
        out!(
            "\nseries of {} pieces:\n{}",
            id.pieces.len(),
            series.render()
        );
    }
    analyze::result::write(outcome, &c.out, c.json)?;
    if id.series.is_some() {
        outln!(
            "wrote {} and one error file per piece beside it",
            c.out.display()
        );
    } else {
        outln!("wrote {}", c.out.display());
    }
    if let Some(cmp) = &id.comparison {
        out!(
            "\ncomparison with {}: the value (u) in each result, then the change from it (combined u):\n{}",
            cmp.table.pieces[0],
            cmp.render()
        );
    }
    Ok(())
}

/// What the analysis of one piece found: identifiability and values, the
/// Monte-Carlo study, the residuals.
fn print_piece(c: &Config, p: &IdentifiedPiece) {
    for w in &p.data.warnings {
        eprintln!("warning: {w}");
    }
    if let Some(k) = p.number {
        outln!("== piece {k}: {}", p.name());
    }
    // The verdict first: it says whether anything below may be acted on.
    out!("{}", analyze::verdict::render(p.fit.as_ref()));
    if let Some(f) = p.misfit() {
        let next = analyze::goodness::discover_command(&c.request.manifest, &p.data.files);
        outln!("{}\n", analyze::goodness::banner(f, &next));
    }
    out!("{}", p.est.summary_with(&p.u));
    if let Some(s) = &p.monte_carlo {
        if let Some(w) = &s.warning {
            eprintln!("warning: {w}");
        }
        outln!(
            "monte carlo: {} runs (seed {}) {}",
            s.result.runs,
            s.seed,
            s.how
        );
        for n in &s.not_included {
            outln!("  not included: {n}");
        }
        if let Some(w) = s.widened {
            outln!(
                "  u widened by the Birge ratio {w:.2}: the model does not fit, the runs drew only the stated noise"
            );
        }
        for r in &s.rows {
            outln!(
                "  {:<24} u(covariance) {:>8.3}   u(monte carlo) {:>8.3}",
                r.name,
                r.covariance.unwrap_or(f64::NAN),
                r.monte_carlo
            );
        }
    }
    outln!("residuals by pose and face (um):");
    outln!(
        "  {:<12} {:<22} {:>6} {:>9} {:>9} {:>9}",
        "pose",
        "face",
        "points",
        "mean",
        "rms",
        "max"
    );
    for r in p.est.residual_table(&p.data) {
        outln!(
            "  {:<12} {:<22} {:>6} {:>9.3} {:>9.3} {:>9.3}",
            r.pose,
            r.face,
            r.points,
            r.mean_um,
            r.rms_um,
            r.max_um
        );
    }
}

/// The nine-section statistics of each piece, and what the test cannot
/// identify.
fn nine_section(c: &Config, outcome: &Outcome, n: &NineSectionOutcome) -> anyhow::Result<()> {
    for (p, s) in &n.stats {
        outln!("{}:\n{}", p.display(), s.render());
    }
    if let Some(r) = n.improvement {
        let rate =
            |r: Option<f64>| r.map_or("- (zero on the first)".into(), |r| format!("{r:.2} %"));
        outln!(
            "rate of improvement from the first to the last: AVG {}, MAX {}, RMS {}",
            rate(r[0]),
            rate(r[1]),
            rate(r[2])
        );
    }
    if let Some(first) = n.not_identifiable.first() {
        outln!(
            "not identifiable: {} ({})",
            n.not_identifiable
                .iter()
                .map(|n| n.symbol.as_str())
                .collect::<Vec<_>>()
                .join(", "),
            first.reason
        );
    }
    analyze::result::write(outcome, &c.out, c.json)?;
    outln!("wrote {}", c.out.display());
    if let Some(dir) = &c.report {
        let files = report::nine_section::write(dir, n)?;
        outln!(
            "report: {} ({} files)",
            dir.join("index.html").display(),
            files.len()
        );
    }
    Ok(())
}
