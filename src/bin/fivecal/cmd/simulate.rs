//! `fivecal simulate` (issue 5): run a plan on the virtual machine and write
//! what the CMM or the probe would have written. The `nc` mode (issue 7)
//! lives in `simulate_nc.rs`.

use std::path::{Path, PathBuf};

use anyhow::{Context as _, bail};
use clap::{Args, Subcommand};
use fivecal::ErrorFile;
use fivecal::formats::manifest::{Manifest, TestKind};
use fivecal::io::{Shape, check_outputs};
use fivecal::simulate::{
    self, Format, NoiseOverrides, Placement, SetupErrors, SimOptions, SimOutput,
};
use fivecal::{Kinematics, Machine};

#[derive(Args, Debug)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct SimulateCli {
    #[command(subcommand)]
    mode: Option<SimulateMode>,
    #[command(flatten)]
    args: SimulateArgs,
}

#[derive(Subcommand, Debug)]
enum SimulateMode {
    /// Predict the tool-tip error along an NC program on a machine with
    /// known errors.
    Nc(super::simulate_nc::SimulateNcArgs),
}

/// Run a plan on a machine whose errors are known (a truth file) and write
/// what the CMM (machining tests) or the machine's probe (probing tests)
/// would have measured.
#[derive(Args, Debug)]
pub struct SimulateArgs {
    /// The plan's manifest, as `fivecal plan` wrote it.
    #[arg(long, value_name = "DIR/TEST.plan.yaml")]
    plan: Option<PathBuf>,
    /// The machine's errors: a truth file (docs/formats.md; see
    /// --truth-example) or a result of `fivecal analyze`.
    #[arg(long, value_name = "TRUTH.yaml")]
    errors: Option<PathBuf>,
    /// The measurement file to write (never one of the inputs).
    #[arg(long, short, value_name = "FILE")]
    out: Option<PathBuf>,
    /// csv (label,x,y,z), dmis (a CMM's DMIS output), qif (a CMM's QIF 3
    /// results, by the ids and names of the plan's .qif), log (the probe log
    /// the plan's program makes the control write) or heights (nine-section
    /// section,height_um). Default: from the file extension (.dmo/.out
    /// dmis, .qif qif, .log/.txt log, .csv csv, heights for nine-section),
    /// else csv for a machined piece (heights for nine-section) and log
    /// for probing.
    #[arg(long, value_name = "FORMAT")]
    format: Option<String>,
    /// Seed of every random draw (placement, setups, noise): the same seed
    /// writes the same bytes.
    #[arg(long, value_name = "N", default_value_t = 1)]
    seed: u64,
    /// Where the machined piece lies on the CMM: random (any rotation, any
    /// offset) or aligned (the part frame on W, as the plan's DMIS program
    /// asks). Default: random for csv, aligned for dmis, qif and heights.
    #[arg(long, value_name = "random|aligned")]
    placement: Option<String>,
    /// Probed pieces exactly at their nominal places (default: each set up
    /// with a seeded error up to 0.1 mm and 1 mrad).
    #[arg(long)]
    nominal_setup: bool,
    /// No CMM noise, no probe repeatability, a perfect sphere: the machine's
    /// errors alone.
    #[arg(long)]
    no_noise: bool,
    /// Form error of the calibration sphere, um (largest radial deviation).
    #[arg(long, value_name = "UM")]
    sphere_form: Option<f64>,
    /// Ball-bar plans: radial run-out of the spindle ball, um, and the
    /// spindle angle of its maximum, deg (`--runout 5,30`).
    #[arg(long, value_name = "UM[,DEG]")]
    runout: Option<String>,
    /// Print a commented truth file with every supported effect and exit.
    #[arg(long)]
    truth_example: bool,
    /// The machine of --truth-example: a built-in name or a machine file.
    #[arg(long, value_name = "M.yaml|NAME", default_value = "bc-trunnion")]
    machine: String,
}

/// The validated configuration of one run.
struct Config {
    plan_path: PathBuf,
    errors: PathBuf,
    out: PathBuf,
    format: Option<Format>,
    placement: Option<Placement>,
    opts: SimOptions,
    /// A ball-bar plan's run-out and noise.
    ball_bar: fivecal::simulate::ball_bar::BallBarOptions,
}

fn validate(a: SimulateArgs) -> anyhow::Result<Config> {
    let plan_path = a
        .plan
        .context("--plan is required (the plan's DIR/<test>.plan.yaml)")?;
    let errors = a
        .errors
        .context("--errors is required (a truth file; --truth-example prints one)")?;
    let out = a.out.context("--out is required")?;
    let format = a
        .format
        .as_deref()
        .map(|f| f.parse::<Format>().map_err(anyhow::Error::msg))
        .transpose()?;
    let placement = match a.placement.as_deref() {
        None => None,
        Some("random") => Some(Placement::Random),
        Some("aligned") => Some(Placement::Aligned),
        Some(other) => bail!("--placement {other}: expected random or aligned"),
    };
    let mut opts = SimOptions {
        seed: a.seed,
        ..SimOptions::default()
    };
    if let Some(f) = a.sphere_form {
        if !(f.is_finite() && (0.0..=fivecal::limits::MAX_ERROR_UM).contains(&f)) {
            bail!(
                "--sphere-form {f}: expected a form error from 0 to {} um",
                fivecal::limits::MAX_ERROR_UM
            );
        }
        opts.sphere_form_um = f;
    }
    if a.nominal_setup {
        opts.setup = SetupErrors::Nominal;
    }
    if a.no_noise {
        opts.noise = NoiseOverrides {
            cmm_um: Some(0.0),
            probe_um: Some(0.0),
        };
        opts.sphere_form_um = 0.0;
    }
    let mut ball_bar = fivecal::simulate::ball_bar::BallBarOptions {
        seed: a.seed,
        noise_um: a.no_noise.then_some(0.0),
        ..Default::default()
    };
    if let Some(r) = &a.runout {
        let v: Vec<f64> = r
            .split(',')
            .map(|x| x.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| anyhow::anyhow!("--runout {r}: expected UM or UM,DEG"))?;
        match v.as_slice() {
            [u] => ball_bar.runout_um = *u,
            [u, p] => (ball_bar.runout_um, ball_bar.runout_phase_deg) = (*u, *p),
            _ => bail!("--runout {r}: expected UM or UM,DEG"),
        }
    }
    Ok(Config {
        ball_bar,
        plan_path,
        errors,
        out,
        format,
        placement,
        opts,
    })
}

pub fn run(cli: SimulateCli) -> anyhow::Result<()> {
    match cli.mode {
        Some(SimulateMode::Nc(a)) => super::simulate_nc::run(a),
        None if cli.args.truth_example => truth_example(&cli.args.machine),
        None => simulate(validate(cli.args)?),
    }
}

fn truth_example(machine: &str) -> anyhow::Result<()> {
    let (m, origin) =
        Machine::resolve(machine).with_context(|| format!("cannot load machine `{machine}`"))?;
    // Standard output is the truth file itself.
    eprintln!("note: machine {}: {origin}", m.name);
    out!("{}", simulate::truth::example(&Kinematics::new(&m)));
    Ok(())
}

/// Every file of the plan directory the manifest names, and the manifest.
fn plan_inputs(manifest_path: &Path) -> anyhow::Result<Vec<PathBuf>> {
    let m = Manifest::read(manifest_path)?;
    let mut v = vec![
        manifest_path.to_path_buf(),
        m.resolve(manifest_path, &m.machine_file),
        m.resolve(manifest_path, &m.template_file),
    ];
    v.extend(m.files.values().map(|f| m.resolve(manifest_path, f)));
    Ok(v)
}

fn simulate(c: Config) -> anyhow::Result<()> {
    if super::ball_bar::is_ball_bar(&c.plan_path) {
        return super::ball_bar::simulate(&c.plan_path, &c.errors, &c.out, c.ball_bar);
    }
    let mut inputs = plan_inputs(&c.plan_path)?;
    inputs.push(c.errors.clone());
    let refs: Vec<&Path> = inputs.iter().map(|p| p.as_path()).collect();
    check_outputs(&refs, &[("--out", &c.out, Shape::File)])?;
    let plan = fivecal::procedure::load(&c.plan_path)?;
    let kind = plan.kind();
    let format = c
        .format
        .unwrap_or_else(|| Format::for_path(&c.out, kind, plan.test()));
    simulate::output::check(format, kind, plan.test())?;
    let kin = simulate::plan_kinematics(&plan);
    let truth = ErrorFile::load(&c.errors, &kin)?;
    let mut opts = c.opts;
    opts.placement = c.placement.unwrap_or(match format {
        Format::Csv => Placement::Random,
        _ => Placement::Aligned,
    });
    let out = simulate::run(&plan, &truth, &opts).with_context(|| {
        format!(
            "cannot simulate {} with the errors of {}",
            c.plan_path.display(),
            c.errors.display()
        )
    })?;
    out.write(format, &c.out)?;
    summary(&out, format, &c.out, &opts);
    Ok(())
}

fn summary(out: &SimOutput, format: Format, path: &Path, opts: &SimOptions) {
    let what = match out.kind {
        TestKind::Machining if format == Format::Heights => format!(
            "heights of {} sections from {} points of the machined piece",
            out.heights.as_ref().map_or(0, |h| h.len()),
            out.points.len()
        ),
        TestKind::Machining => format!(
            "{} points of the machined piece, measured on a CMM ({})",
            out.points.len(),
            if opts.placement == Placement::Aligned {
                "part frame aligned on W"
            } else {
                "placed at random"
            }
        ),
        TestKind::Probing => format!(
            "{} touches probed on the machine ({})",
            out.points.len(),
            if out
                .setups
                .iter()
                .all(|s| s.1 == nalgebra::Isometry3::identity())
            {
                "pieces at their nominal places".to_string()
            } else {
                let n = out.setups.len();
                format!(
                    "{n} {} set up with seeded errors",
                    if n == 1 { "piece" } else { "pieces" }
                )
            }
        ),
    };
    outln!(
        "wrote {} ({format}): {} on {}, seed {}: {what}",
        path.display(),
        out.test,
        out.machine,
        out.seed
    );
    if let Some(h) = &out.heights {
        for s in h {
            outln!("  section {:>2}: {:>9.3} um", s.section, s.height_um);
        }
    }
}
