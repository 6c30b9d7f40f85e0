//! `fivecal simulate`'s options and their validation into one [`Config`]:
//! the plan, the truth, the measurement file and its format, the seed and
//! what the virtual instrument adds (placement, setups, noise, sphere
//! form); and those of `simulate nc` into one [`NcConfig`]: the machine and
//! program options shared with `compensate` ([`super::nc`]), the error
//! file, the sampling step, the CMM points and the original to measure
//! against.

use std::path::PathBuf;

use anyhow::{Context as _, bail};
use clap::{Args, Subcommand};
use fivecal::simulate::{Format, NoiseOverrides, Placement, SetupErrors, SimOptions};

use super::nc::{Common, MachineArgs};

#[derive(Args, Debug)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct SimulateCli {
    #[command(subcommand)]
    pub mode: Option<SimulateMode>,
    #[command(flatten)]
    pub args: SimulateArgs,
}

#[derive(Subcommand, Debug)]
pub enum SimulateMode {
    /// Predict the tool-tip error along an NC program on a machine with
    /// known errors.
    Nc(SimulateNcArgs),
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
    /// Print what was simulated as JSON on standard output: the test,
    /// machine, seed, format, counts, heights and the file written.
    #[arg(long, conflicts_with = "truth_example")]
    json: bool,
    /// Print a commented truth file with every supported effect and exit.
    #[arg(long)]
    pub truth_example: bool,
    /// The machine of --truth-example: a built-in name or a machine file.
    #[arg(long, value_name = "M.yaml|NAME", default_value = "bc-trunnion")]
    pub machine: String,
}

/// The validated configuration of one run.
pub struct Config {
    pub plan_path: PathBuf,
    pub errors: PathBuf,
    pub out: PathBuf,
    pub format: Option<Format>,
    pub placement: Option<Placement>,
    pub opts: SimOptions,
    /// `--json`: what was simulated, as JSON on standard output.
    pub json: bool,
    /// A ball-bar plan's run-out and noise.
    pub ball_bar: fivecal::simulate::ball_bar::BallBarOptions,
}

pub fn validate(a: SimulateArgs) -> anyhow::Result<Config> {
    let plan_path = a
        .plan
        .context("--plan is required (the plan's DIR/<test>.plan.yaml)")?;
    let errors = a
        .errors
        .context("--errors is required (a truth file; --truth-example prints one)")?;
    let out = a.out.context("--out is required")?;
    super::json_or_stdout(a.json, &[Some(&out)])?;
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
        (ball_bar.runout_um, ball_bar.runout_phase_deg) = super::ball_bar::runout(r)?;
    }
    Ok(Config {
        plan_path,
        errors,
        out,
        format,
        placement,
        opts,
        json: a.json,
        ball_bar,
    })
}

#[derive(Args, Debug)]
pub struct SimulateNcArgs {
    #[command(flatten)]
    machine: MachineArgs,
    /// Error file of the machine (a truth file, or an analyze result).
    #[arg(long, value_name = "TRUTH.yaml")]
    errors: PathBuf,
    /// The NC program to run.
    #[arg(value_name = "P.nc")]
    program: PathBuf,
    /// Sample feed moves every STEP mm of tool path (and at least every
    /// degree a rotary axis turns) as well as at their end points.
    #[arg(
        long,
        value_name = "MM",
        default_value_t = 0.0,
        allow_negative_numbers = true
    )]
    step: f64,
    /// Write every sample (nominal tip and axis, tip error) as CSV.
    #[arg(short = 'o', long = "out", value_name = "ERRORS.csv")]
    output: Option<PathBuf>,
    /// Nominal surface points a CMM measures on the part the program cuts
    /// (canonical `label,x,y,z`, in W): with --measured, write what it would
    /// find (the tool cutting at its tip, normal to the surface).
    #[arg(long, value_name = "POINTS.csv", requires = "measured")]
    cmm: Option<PathBuf>,
    /// Where the simulated CMM points go (canonical `label,x,y,z`).
    #[arg(long, value_name = "CMM.csv", requires = "cmm")]
    measured: Option<PathBuf>,
    /// The program P.nc was made from (the original of a compensated
    /// program): measure P.nc's tool tip, run on the machine with the
    /// errors, against the path ORIGINAL.nc asks for on the nominal
    /// machine, instead of against P.nc's own nominal path. Feed moves are
    /// sampled every --step mm (0.5 mm when --step is not given).
    #[arg(long, value_name = "ORIGINAL.nc")]
    against: Option<PathBuf>,
    /// Largest distance of a CMM point from the tool path, mm.
    #[arg(long, value_name = "MM", default_value_t = 0.5)]
    max_distance: f64,
    /// Print the prediction as JSON on standard output: counts, the
    /// tool-tip error, the deviation from the original's path, what was
    /// not simulated and why, and the files written.
    #[arg(long)]
    json: bool,
}

/// The step along feed moves, mm, of a run `--against` an original when no
/// `--step` is given (the demo's).
const AGAINST_STEP_MM: f64 = 0.5;

/// The validated configuration of one `simulate nc` run.
pub struct NcConfig {
    pub common: Common,
    pub errors: PathBuf,
    pub program: PathBuf,
    /// The sampling step along feed moves, mm (0: end points only).
    pub step: f64,
    pub output: Option<PathBuf>,
    pub cmm: Option<PathBuf>,
    pub measured: Option<PathBuf>,
    pub against: Option<PathBuf>,
    pub max_distance: f64,
    pub json: bool,
}

impl SimulateNcArgs {
    pub fn validate(self) -> anyhow::Result<NcConfig> {
        let mut common = self.machine.validate()?;
        let min_step = fivecal::limits::MIN_SAMPLE_STEP_MM;
        if !(self.step.is_finite() && (self.step == 0.0 || self.step >= min_step)) {
            bail!(
                "--step {}: expected 0 (end points only) or a distance of at least {min_step} mm",
                self.step
            );
        }
        if !(self.max_distance.is_finite() && self.max_distance > 0.0) {
            bail!(
                "--max-distance {}: expected a distance > 0 mm from the tool path",
                self.max_distance
            );
        }
        super::json_or_stdout(
            self.json,
            &[self.output.as_deref(), self.measured.as_deref()],
        )?;
        common.inputs.push(self.errors.clone());
        common.inputs.push(self.program.clone());
        common.inputs.extend(self.against.iter().cloned());
        common.inputs.extend(self.cmm.iter().cloned());
        let inputs: Vec<&std::path::Path> = common.inputs.iter().map(|p| p.as_path()).collect();
        let outputs: Vec<_> = [("--out", &self.output), ("--measured", &self.measured)]
            .into_iter()
            .filter_map(|(f, p)| Some((f, p.as_deref()?, fivecal::io::Shape::File)))
            .collect();
        fivecal::io::check_outputs(&inputs, &outputs)?;
        // Against an original, the path between end points is what is
        // compared: feed moves are sampled along, never only at their ends.
        let step = match (&self.against, self.step) {
            (Some(_), 0.0) => AGAINST_STEP_MM,
            (_, s) => s,
        };
        Ok(NcConfig {
            common,
            errors: self.errors,
            program: self.program,
            step,
            output: self.output,
            cmm: self.cmm,
            measured: self.measured,
            against: self.against,
            max_distance: self.max_distance,
            json: self.json,
        })
    }
}
