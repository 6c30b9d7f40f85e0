//! `fivecal compensate`'s options and their validation into one
//! [`Config`]: what to rewrite and where, what to export and where, the
//! tolerance, limits and decimals, and whether an export is recorded. The
//! machine, error and program options shared with `simulate nc` are
//! [`super::nc`]'s.

use std::path::{Path, PathBuf};

use anyhow::bail;
use clap::Args;
use fivecal::Dialect;
use fivecal::compensate::{Settings, export};
use fivecal::errorfile::LoadedErrors;
use fivecal::io::{Shape, check_outputs};

mod export_limits;
mod settings;
mod tables;

use export_limits::swivel_record_known;
pub use tables::TablesConfig;

use super::DialectArg;
use super::nc::{Common, MachineArgs, load_errors};
use super::record::{RecordArgs, Recording};

#[derive(Args, Debug)]
pub struct CompensateArgs {
    /// NC program to rewrite (optional with --export).
    #[arg(value_name = "IN")]
    input: Option<PathBuf>,
    /// The rewritten program (never the input; written only when complete);
    /// with a laser-lines result, the directory of the axis tables.
    #[arg(short = 'o', long = "out", value_name = "OUT")]
    output: Option<PathBuf>,
    #[command(flatten)]
    machine: MachineArgs,
    /// Error file: an `analyze` result (or a truth file); a laser-lines
    /// result gives the axes' compensation tables (--export CONTROLLER -o
    /// DIR: linuxcnc COMP_FILEs, the sinumerik LEC table).
    #[arg(long, value_name = "RESULT.yaml")]
    errors: PathBuf,
    /// Largest distance of the actual tool-tip path from the intended one
    /// between end points, um; longer moves are subdivided, arcs linearized.
    #[arg(
        long,
        value_name = "UM",
        default_value_t = 1.0,
        allow_negative_numbers = true
    )]
    tolerance: f64,
    /// Stop with the line named when a correction exceeds this: um for X, Y,
    /// Z, urad for the tool orientation.
    #[arg(
        long,
        value_name = "UM",
        default_value_t = 500.0,
        allow_negative_numbers = true
    )]
    max_correction: f64,
    /// Decimals written: LIN[,ROT] (mm, deg) [default: 4,6; more when the
    /// program writes more].
    #[arg(long, value_name = "LIN,ROT")]
    decimals: Option<String>,
    /// Next to the tilt singularity, the largest turn of C accepted for an
    /// exact correction, deg; beyond it C is held and only the tool tip is
    /// corrected exactly.
    #[arg(
        long,
        value_name = "DEG",
        default_value_t = 1.0,
        allow_negative_numbers = true
    )]
    max_c_swing: f64,
    /// Write the program flattened as its macro logic runs (parameters
    /// evaluated, loops, jumps and calls unrolled, every move a literal
    /// number) and correct that; without it a block that runs several
    /// times with different values is left as written and reported.
    #[arg(long)]
    expand: bool,
    /// Also write the location errors as the corrected pivot parameters of
    /// this controller (sinumerik: a part program writing the fine offsets
    /// of the machine file's swivel data record); from a laser-lines
    /// result, the axes' compensation tables.
    #[arg(long, value_name = "CONTROLLER", value_enum)]
    export: Option<DialectArg>,
    /// Where --export writes [default: standard output without a program,
    /// else next to OUT as OUT.<controller>.txt, or <OUT's name>_SWIVEL.MPF
    /// for sinumerik].
    #[arg(long, value_name = "FILE")]
    export_to: Option<PathBuf>,
    /// With --export: refuse (naming it, writing nothing) any parameter
    /// that would change by more than this from what the control holds now
    /// (the machine file's controller_parameters, else its nominal
    /// geometry): LEN in mm, ANG in mrad for angles. Axis tables: any
    /// point's error beyond LEN.
    #[arg(long, value_name = "LEN[,ANG]", default_value = "0.1,0.5")]
    max_change: String,
    /// With --export: refuse any parameter whose standard uncertainty is
    /// larger (from the error file's u): LEN in mm, ANG in mrad. A file
    /// without u (a truth file) is exported with `u not given`. Axis
    /// tables: any point's u beyond LEN.
    #[arg(long, value_name = "LEN[,ANG]", default_value = "0.01,0.05")]
    max_u: String,
    /// Use a result whose model does not fit its measurements (its `fit:`
    /// verdict is misfit): its values are biased by an effect the model
    /// lacks, so it is refused unless this is given.
    #[arg(long)]
    accept_misfit: bool,
    /// With --export: the values were entered into the control (now, or
    /// at --measured-at): the export is recorded in the results store as
    /// the point where the control was changed, which `fivecal history`
    /// and `fivecal verify --machine` start from. Without it an export is
    /// a preview and is not recorded.
    #[arg(long)]
    entered: bool,
    /// With --export --entered: where and what to record.
    #[command(flatten)]
    record: RecordArgs,
    /// Print what was done as JSON on standard output: the moves corrected
    /// and those left as written with the reason, the largest corrections,
    /// the exported parameters and the files written.
    #[arg(long)]
    json: bool,
}

/// What `compensate` does: rewrite and/or export from a model's errors,
/// or write a laser-lines result's axis tables.
pub enum Job {
    /// A result or truth file of the model.
    Model(Box<Config>),
    /// A laser-lines result's axis compensation tables.
    Tables(TablesConfig),
}

/// What to do, validated.
pub struct Config {
    /// The machine and the program's options.
    pub common: Common,
    /// The error file.
    pub errors_path: PathBuf,
    /// The error file, read against the machine.
    pub errors: LoadedErrors,
    /// The rewrite's settings (the dialect settled when the program is
    /// opened).
    pub settings: Settings,
    /// The program to rewrite and where the rewritten one goes.
    pub rewrite: Option<(PathBuf, PathBuf)>,
    /// The controller to export for and the file (`None`: standard output).
    pub export: Option<(Dialect, Option<PathBuf>)>,
    /// What an export may change, and with which u.
    pub limits: export::Limits,
    /// Where an entered export is recorded.
    pub record: Recording,
    /// `--entered`: the export's values are in the control.
    pub entered: bool,
    /// `--json`: what was done, as JSON on standard output.
    pub json: bool,
}

impl CompensateArgs {
    pub fn validate(self) -> anyhow::Result<Job> {
        let common = self.machine.validate()?;
        // A laser-lines result is no model: it goes to the axis tables.
        let src =
            fivecal::input::read_text(&self.errors, "error file", fivecal::limits::MAX_YAML_BYTES)
                .unwrap_or_default();
        if fivecal::compensate::axis_tables::laser::sniff(&src) {
            return Ok(Job::Tables(self.tables(common, &src)?));
        }
        Ok(Job::Model(Box::new(self.model(common)?)))
    }

    fn model(self, mut common: Common) -> anyhow::Result<Config> {
        let errors = load_errors(&self.errors, &common.kin)?;
        if let Some(f) = errors.not_converged() {
            // No flag accepts it: values a fit stopped at are no estimate.
            bail!(
                "{}: the fit of this result did not converge ({}): its values are no estimate, and nothing is compensated or exported from them. \
                 Analyze the measurements again (another --method, fewer maps) until the verdict is a fit",
                self.errors.display(),
                f.stopped
                    .as_deref()
                    .unwrap_or("fit: {verdict: not-converged}")
            );
        }
        if let Some(f) = errors.misfit()
            && !self.accept_misfit
        {
            bail!(
                "{}: the model of this result does not fit its measurements (residuals {:.3} um against {:.3} um expected, ratio {:.2}): \
                 its values are biased by an effect the model lacks. Find it with `fivecal discover` and compensate with the refined model, \
                 or give --accept-misfit to use this result anyway",
                self.errors.display(),
                f.sigma_um,
                f.expected_um,
                f.ratio
            );
        }
        common.inputs.push(self.errors.clone());
        let settings = self.settings(&common)?;
        // Read before the options are taken apart, refused after the
        // outputs are checked, as before.
        let limits = self.limits();
        let export = match &self.export {
            Some(d) => Some((Dialect::from(*d), self.export_to.clone())),
            None if self.export_to.is_some() => bail!("--export-to needs --export CONTROLLER"),
            None => None,
        };
        let rewrite = match (self.input, self.output) {
            (Some(i), Some(o)) => {
                if !i.exists() {
                    bail!("cannot read program {}: no such file", i.display());
                }
                common.inputs.push(i.clone());
                Some((i, o))
            }
            (Some(i), None) => bail!(
                "{}: name the rewritten program with -o OUT (the input is never overwritten)",
                i.display()
            ),
            (None, Some(_)) => {
                bail!("-o names the rewritten program: give the program to rewrite (IN) too")
            }
            (None, None) if export.is_some() => None,
            (None, None) => {
                bail!("nothing to do: give a program (IN -o OUT) and/or --export CONTROLLER")
            }
        };
        // With a program, the parameters go next to the rewritten one.
        if export.as_ref().is_some_and(|(_, t)| t.is_none())
            && rewrite.as_ref().is_some_and(|(_, o)| o.as_os_str() == "-")
        {
            bail!(
                "-o - writes the program to standard output: name the --export parameter file with --export-to FILE"
            );
        }
        if self.json
            && (export.as_ref().is_some_and(|(_, t)| t.is_none()) && rewrite.is_none()
                || rewrite.as_ref().is_some_and(|(_, o)| o.as_os_str() == "-"))
        {
            bail!(
                "--json prints on standard output, and so does the program or the parameters: name their file (-o OUT, --export-to FILE), or leave out --json"
            );
        }
        let export = export.map(|(d, target)| {
            let target = target.or_else(|| {
                rewrite
                    .as_ref()
                    .map(|(_, out)| export::default_file(d, out))
            });
            (d, target)
        });
        // Every output checked before any work: none is an input, none is
        // another output, each can be written as a file.
        let inputs: Vec<&Path> = common.inputs.iter().map(|p| p.as_path()).collect();
        let mut outputs = Vec::new();
        outputs.extend(
            rewrite
                .as_ref()
                .map(|(_, o)| ("-o", o.as_path(), Shape::File)),
        );
        outputs.extend(
            export
                .as_ref()
                .and_then(|(_, t)| t.as_deref())
                .map(|t| ("--export-to", t, Shape::File)),
        );
        if export.is_none()
            && let Some(flag) = self.record.first_given()
        {
            bail!(
                "{flag} goes with a record, and compensate records only an export (--export): a rewritten program is not recorded"
            );
        }
        if let Some((d, _)) = &export {
            swivel_record_known(*d, &common)?;
        }
        if export.is_none() && self.entered {
            bail!(
                "--entered says an export's values were entered into the control: give --export CONTROLLER"
            );
        }
        if !self.entered
            && let Some(flag) = self.record.first_given()
        {
            bail!(
                "{flag} goes with a record, and an export is recorded only once its values are in the control: add --entered"
            );
        }
        // The store first: it is an input the outputs may not name.
        let record = self.record.validate()?;
        check_outputs(&inputs, &outputs)?;
        let limits = limits?;
        Ok(Config {
            limits,
            record,
            entered: self.entered,
            json: self.json,
            common,
            errors_path: self.errors,
            errors,
            settings,
            rewrite,
            export,
        })
    }
}
