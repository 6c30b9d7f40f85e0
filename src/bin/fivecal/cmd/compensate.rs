//! `fivecal compensate`: rewrite an NC program so the identified errors
//! cancel, and/or export them as a controller's pivot parameters.
//!
//! The raw arguments become one validated [`Config`] here (and the machine,
//! error and program options shared with `simulate nc` in [`Common`]); the
//! library does the work.

use std::io::{BufRead, BufReader, Cursor, Read};
use std::path::{Path, PathBuf};

use anyhow::{Context as _, bail};
use clap::{Args, ValueEnum};
use fivecal::compensate::{AtomicOutput, Compensator, Coordinates, Settings, Summary, export};
use fivecal::errorfile::{ErrorFile, LoadedErrors};
use fivecal::io::{Shape, check_outputs};
use fivecal::machine::MachineOrigin;
use fivecal::nc::dialect::Detection;
use fivecal::numbers::count;
use fivecal::{Dialect, Kinematics, Machine};
use nalgebra::Vector3;

/// How program coordinates are meant.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum CoordsArg {
    /// As the program switches tool centre point control on and off
    /// (G43.4/G43.5, Haas G234, M128, FUNCTION TCPM, TRAORI).
    Auto,
    /// Axis positions throughout (post-side program).
    Axes,
    /// Tool-tip coordinates in W throughout (a controller whose kinematics
    /// always runs TCP, e.g. LinuxCNC trt-kins).
    Tcp,
}

/// Options shared by `compensate` and `simulate nc`.
#[derive(Args, Debug)]
pub struct MachineArgs {
    /// Machine file or built-in name (bc-trunnion, ac-trunnion, head-table, head-head).
    #[arg(long, value_name = "M.yaml")]
    pub machine: String,
    /// Controller dialect of the program [default: what its text shows
    /// (BEGIN PGM, O-numbers, o-words, G43.4, %_N_.._MPF, TRAORI...), then
    /// its extension (.h, .ngc, .mpf, .spf), then the machine's].
    #[arg(long, value_name = "D", value_parser = ["fanuc", "heidenhain", "linuxcnc", "sinumerik"])]
    pub dialect: Option<String>,
    /// Where the program zero lies in W at rotary zero, mm [default: 0,0,0,
    /// as `fivecal plan` writes programs].
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true)]
    pub origin: Option<String>,
    /// How the program's coordinates are meant.
    #[arg(long, value_enum, default_value = "auto")]
    pub coordinates: CoordsArg,
    /// FANUC axis words without a decimal point: `mm` (calculator-type
    /// input), `um` (IS-B increments) or `0.1um` (IS-C) [default: the
    /// machine file's `integer_unit`]; without either such moves are left
    /// as written and reported.
    #[arg(long, value_name = "UNIT", value_parser = ["mm", "um", "0.1um"])]
    pub integer_unit: Option<String>,
    /// Position of a rotary axis before the program's first block, deg
    /// (`C=0`; repeat or list with commas: `A=0,C=90`), for an axis the
    /// program does not set before it moves (a four-axis program on a
    /// five-axis machine): a statement of yours, reported as assumed.
    /// Without it such an axis is unknown and its moves are left as written.
    #[arg(long, value_name = "AXIS=DEG", allow_hyphen_values = true)]
    pub rotary_start: Vec<String>,
    /// Gauge length of the tool in use, mm [default: the machine file's tool].
    #[arg(long, value_name = "MM")]
    pub tool_length: Option<f64>,
    /// LinuxCNC: a directory holding the subroutine files `name.ngc` that
    /// `o<name> call` runs (the control's SUBROUTINE_PATH; repeat for
    /// several, looked in in order after the program's own directory).
    #[arg(long, value_name = "DIR")]
    pub subroutine_path: Vec<PathBuf>,
    /// Reject words and codes fivecal does not know instead of keeping them.
    #[arg(long)]
    pub strict: bool,
}

/// The validated shared options.
pub struct Common {
    pub machine: Machine,
    /// Where the machine came from (built in or a file).
    pub machine_origin: MachineOrigin,
    pub kin: Kinematics,
    /// `--dialect`, if given; else the program's text decides ([`open_program`]).
    pub dialect: Option<Dialect>,
    pub origin: Vector3<f64>,
    pub coordinates: Coordinates,
    pub integer_unit: Option<f64>,
    /// `--rotary-start`: (axis letter, deg), each a rotary axis of the
    /// machine at most once, within its stroke.
    pub rotary_start: Vec<(char, f64)>,
    /// `--subroutine-path` directories, each one that exists.
    pub subroutine_path: Vec<PathBuf>,
    pub strict: bool,
    /// Input files of the run (never to be overwritten).
    pub inputs: Vec<PathBuf>,
}

fn parse_triple(s: &str, what: &str) -> anyhow::Result<Vector3<f64>> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .ok()
        .filter(|v: &Vec<f64>| {
            v.len() == 3
                && v.iter()
                    .all(|x| x.is_finite() && x.abs() <= fivecal::limits::MAX_MACHINE_MM)
        })
        .with_context(|| {
            format!(
                "{what} `{s}`: expected three numbers X,Y,Z (mm, each within {} mm)",
                fivecal::limits::MAX_MACHINE_MM
            )
        })?;
    Ok(Vector3::new(v[0], v[1], v[2]))
}

/// `--rotary-start` values (`C=0`, `A=0,C=90`, repeated or listed) as
/// (axis, deg): each names a rotary axis of `machine` once, with a finite
/// angle inside its stroke.
fn parse_rotary_start(values: &[String], machine: &Machine) -> anyhow::Result<Vec<(char, f64)>> {
    let mut out: Vec<(char, f64)> = Vec::new();
    for item in values.iter().flat_map(|v| v.split(',')) {
        let item = item.trim();
        let (letter, value) = item
            .split_once('=')
            .with_context(|| format!("--rotary-start `{item}`: expected AXIS=DEG, e.g. C=0"))?;
        let letter = letter.trim().to_ascii_uppercase();
        let axis = [&machine.tilt, &machine.c]
            .into_iter()
            .find(|a| a.letter.to_string() == letter)
            .with_context(|| {
                format!(
                    "--rotary-start `{item}`: {letter} is not a rotary axis of machine {} (its rotary axes are {} and {})",
                    machine.name, machine.tilt.letter, machine.c.letter
                )
            })?;
        let v = value
            .trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .with_context(|| {
                format!("--rotary-start `{item}`: expected an angle in deg after `=`")
            })?;
        if !axis.within(v, 0.0) {
            let (lo, hi) = axis.limits.unwrap_or((f64::NEG_INFINITY, f64::INFINITY));
            bail!(
                "--rotary-start `{item}`: {v} deg is outside the stroke of {} ({lo} to {hi} deg)",
                axis.letter
            );
        }
        if out.iter().any(|(l, _)| *l == axis.letter) {
            bail!("--rotary-start: {} is given more than once", axis.letter);
        }
        out.push((axis.letter, v));
    }
    Ok(out)
}

/// What `--rotary-start` makes the run assume, for its report.
pub fn rotary_start_note(start: &[(char, f64)]) -> Option<String> {
    if start.is_empty() {
        return None;
    }
    let axes: Vec<String> = start
        .iter()
        .map(|(a, v)| format!("{a} taken at {v} deg"))
        .collect();
    Some(format!(
        "{} before the first block, as --rotary-start states (until the program sets or forgets it)",
        axes.join(", ")
    ))
}

impl MachineArgs {
    pub fn validate(&self) -> anyhow::Result<Common> {
        let (machine, machine_origin) = Machine::resolve(&self.machine)
            .with_context(|| format!("cannot load machine `{}`", self.machine))?;
        let kin = match self.tool_length {
            Some(l) if l.is_finite() && l > 0.0 && l <= fivecal::limits::MAX_MACHINE_MM => {
                Kinematics::with_gauge_length(&machine, l)
            }
            Some(l) => bail!(
                "--tool-length {l}: expected a gauge length > 0 mm and at most {} mm",
                fivecal::limits::MAX_MACHINE_MM
            ),
            None => Kinematics::new(&machine),
        };
        let dialect = match &self.dialect {
            Some(d) => Some(d.parse::<Dialect>().map_err(anyhow::Error::msg)?),
            None => None,
        };
        let origin = match &self.origin {
            Some(s) => parse_triple(s, "--origin")?,
            None => Vector3::zeros(),
        };
        // The flag, else the machine file's setting of its control.
        let integer_unit = match self.integer_unit.as_deref() {
            Some("mm") => Some(1.0),
            Some("um") => Some(1e-3),
            Some(_) => Some(1e-4),
            None => machine.integer_unit.map(|u| u.mm()),
        };
        let rotary_start = parse_rotary_start(&self.rotary_start, &machine)?;
        for d in &self.subroutine_path {
            if !d.is_dir() {
                bail!(
                    "--subroutine-path {}: no such directory (the directory holding the LinuxCNC subroutine files name.ngc that o<name> call runs)",
                    d.display()
                );
            }
        }
        let mut inputs = Vec::new();
        if let MachineOrigin::File(p) = &machine_origin {
            inputs.push(p.clone());
        }
        Ok(Common {
            machine,
            machine_origin,
            kin,
            dialect,
            origin,
            coordinates: match self.coordinates {
                CoordsArg::Auto => Coordinates::Auto,
                CoordsArg::Axes => Coordinates::Axes,
                CoordsArg::Tcp => Coordinates::Tcp,
            },
            integer_unit,
            rotary_start,
            subroutine_path: self.subroutine_path.clone(),
            strict: self.strict,
            inputs,
        })
    }
}

impl Common {
    /// Opens the NC program at `path` and settles the dialect it is read
    /// in: `--dialect` if given, else what its beginning shows
    /// ([`fivecal::nc::dialect::detect`]). The beginning read to decide is
    /// handed on in front of the rest, so a FIFO or a pipe is read once.
    pub fn open_program(&self, path: &Path) -> anyhow::Result<(Detection, impl BufRead)> {
        let mut file = fivecal::input::open_stream(path, "NC program")?;
        let mut head = Vec::new();
        if let Err(e) = (&mut file)
            .take(fivecal::nc::dialect::DETECT_BYTES as u64)
            .read_to_end(&mut head)
        {
            return Err(match fivecal::input::LineError::located(path, &e) {
                Some(located) => located.into(),
                None => anyhow::Error::new(e)
                    .context(format!("cannot read NC program {}", path.display())),
            });
        }
        let detection = match self.dialect {
            Some(d) => Detection {
                dialect: d,
                why: "--dialect".to_string(),
            },
            None => fivecal::nc::dialect::detect(path, &head, self.machine.dialect),
        };
        Ok((detection, BufReader::new(Cursor::new(head).chain(file))))
    }
}

/// Loads an error file against the machine.
pub fn load_errors(path: &Path, kin: &Kinematics) -> anyhow::Result<LoadedErrors> {
    Ok(ErrorFile::load(path, kin)?)
}

#[derive(Args, Debug)]
pub struct CompensateArgs {
    /// NC program to rewrite (optional with --export).
    #[arg(value_name = "IN")]
    input: Option<PathBuf>,
    /// The rewritten program (never the input; written only when complete).
    #[arg(short = 'o', long = "out", value_name = "OUT")]
    output: Option<PathBuf>,
    #[command(flatten)]
    machine: MachineArgs,
    /// Error file: an `analyze` result (or a truth file).
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
    /// of the machine file's swivel data record).
    #[arg(long, value_name = "CONTROLLER", value_parser = ["fanuc", "heidenhain", "linuxcnc", "sinumerik"])]
    export: Option<String>,
    /// Where --export writes [default: standard output without a program,
    /// else next to OUT as OUT.<controller>.txt, or <OUT's name>_SWIVEL.MPF
    /// for sinumerik].
    #[arg(long, value_name = "FILE")]
    export_to: Option<PathBuf>,
    /// With --export: refuse (naming it, writing nothing) any parameter
    /// that would change by more than this from what the control holds now
    /// (the machine file's controller_parameters, else its nominal
    /// geometry): LEN in mm, ANG in mrad for angles.
    #[arg(long, value_name = "LEN[,ANG]", default_value = "0.1,0.5")]
    max_change: String,
    /// With --export: refuse any parameter whose standard uncertainty is
    /// larger (from the error file's u): LEN in mm, ANG in mrad. A file
    /// without u (a truth file) is exported with `u not given`.
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
    record: super::record::RecordArgs,
}

/// What to do, validated.
pub struct Config {
    common: Common,
    errors_path: PathBuf,
    errors: LoadedErrors,
    settings: Settings,
    rewrite: Option<(PathBuf, PathBuf)>,
    export: Option<(Dialect, Option<PathBuf>)>,
    limits: export::Limits,
    record: super::record::Recording,
    entered: bool,
}

/// `LEN[,ANG]` of --max-change and --max-u: a length in mm and an angle in
/// mrad, each > 0 (the angle keeps `default` when not given).
fn parse_limit(option: &str, s: &str, default: f64) -> anyhow::Result<(f64, f64)> {
    let parts: Vec<Option<f64>> = s
        .split(',')
        .map(|x| {
            x.trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite() && *v > 0.0)
        })
        .collect();
    match parts.as_slice() {
        [Some(l)] => Ok((*l, default)),
        [Some(l), Some(a)] => Ok((*l, *a)),
        _ => bail!(
            "{option} `{s}`: expected LEN or LEN,ANG, a length in mm and an angle in mrad, each > 0"
        ),
    }
}

impl CompensateArgs {
    fn validate(self) -> anyhow::Result<Config> {
        let mut common = self.machine.validate()?;
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
        let min_tol = fivecal::limits::MIN_TOLERANCE_UM;
        if !(self.tolerance.is_finite() && self.tolerance >= min_tol) {
            bail!(
                "--tolerance {}: expected a distance of at least {min_tol} um (finer than any control resolves)",
                self.tolerance
            );
        }
        if !(self.max_correction.is_finite() && self.max_correction > 0.0) {
            bail!(
                "--max-correction {}: expected a limit > 0 um",
                self.max_correction
            );
        }
        if !(self.max_c_swing.is_finite() && self.max_c_swing >= 0.0) {
            bail!(
                "--max-c-swing {}: expected an angle >= 0 deg",
                self.max_c_swing
            );
        }
        // The program's dialect is settled when it is opened.
        let mut settings = Settings::new(common.dialect.unwrap_or(common.machine.dialect));
        settings.strict = common.strict;
        settings.tolerance = self.tolerance * 1e-3;
        settings.max_correction = self.max_correction;
        settings.origin = common.origin;
        settings.coordinates = common.coordinates;
        settings.max_c_swing = self.max_c_swing;
        settings.fanuc_integer_unit = common.integer_unit;
        settings.rotary_start = common.rotary_start.clone();
        settings.subroutine_path = common.subroutine_path.clone();
        if self.expand && self.input.is_none() {
            bail!("--expand flattens an NC program: give the program to rewrite (IN)");
        }
        settings.expand = self.expand;
        if let Some(d) = &self.decimals {
            let parts: Vec<Option<u8>> =
                d.split(',').map(|x| x.trim().parse::<u8>().ok()).collect();
            match parts.as_slice() {
                [Some(l)] if *l <= 9 => settings.linear_decimals = *l,
                [Some(l), Some(r)] if *l <= 9 && *r <= 9 => {
                    settings.linear_decimals = *l;
                    settings.rotary_decimals = *r;
                }
                _ => bail!("--decimals `{d}`: expected LIN or LIN,ROT, each 0 to 9"),
            }
        }
        // The written decimals round every word: a tolerance finer than
        // that rounding could be reported met while the tip misses it.
        let (lin, rot) = (settings.linear_decimals, settings.rotary_decimals);
        let smallest =
            fivecal::compensate::tolerance::smallest_tolerance_um(&common.machine, lin, rot);
        if self.tolerance < smallest {
            bail!(
                "--tolerance {}: the words written with {lin} decimals in mm and {rot} in degrees round the tool tip by up to {:.3} um on {}, so the smallest tolerance that holds is {smallest:.3} um (as much again for the path between the written points; more decimals with --decimals LIN,ROT allow a finer one)",
                self.tolerance,
                fivecal::compensate::tolerance::rounding_bound_mm(&common.machine, lin, rot) * 1e3,
                common.machine.name
            );
        }
        let export = match &self.export {
            Some(d) => Some((
                d.parse::<Dialect>().map_err(anyhow::Error::msg)?,
                self.export_to.clone(),
            )),
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
        if let Some((Dialect::Sinumerik, _)) = &export
            && common.machine.sinumerik.is_none()
        {
            // Named, never pasted: the file is the user's own.
            let fix = match &common.machine_origin {
                MachineOrigin::File(p) => {
                    format!("add `sinumerik: {{swivel_record: N}}` to {}", p.display())
                }
                MachineOrigin::BuiltIn => format!(
                    "copy it with `fivecal machine new NAME --from {}` and add `sinumerik: {{swivel_record: N}}` to the copy",
                    common.machine.name
                ),
            };
            bail!(
                "--export sinumerik: {} ({}) does not say which swivel data record holds its kinematics: {fix} (N as in TCARR=N, the record CYCLE800 and CYCLE996 use); nothing written",
                common.machine_origin,
                common.machine.name
            );
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
        let defaults = export::Limits::default();
        let (change_mm, change_mrad) =
            parse_limit("--max-change", &self.max_change, defaults.change_mrad)?;
        let (u_mm, u_mrad) = parse_limit("--max-u", &self.max_u, defaults.u_mrad)?;
        Ok(Config {
            limits: export::Limits {
                change_mm,
                change_mrad,
                u_mm,
                u_mrad,
            },
            record,
            entered: self.entered,
            common,
            errors_path: self.errors,
            errors,
            settings,
            rewrite,
            export,
        })
    }
}

pub fn run(args: CompensateArgs) -> anyhow::Result<()> {
    let cfg = args.validate()?;
    // An export changes the control: kept in the store, opened first so an
    // unreachable store stops the run before anything is written.
    // A preview (no --entered) changes nothing and is not recorded.
    let mut recorder = match &cfg.export {
        Some(_) if cfg.entered => Some(cfg.record.open()?),
        _ => None,
    };
    // The export is computed before the program is rewritten: refused (a
    // limit, a stroke, nothing held), the run writes nothing at all.
    let exported = match &cfg.export {
        Some((d, _)) => Some(export::export_identified(
            &cfg.errors.model,
            &cfg.errors.theta,
            &cfg.errors.u,
            *d,
            &cfg.errors_path.display().to_string(),
            &cfg.limits,
            &cfg.errors.not_identifiable,
        )?),
        None => None,
    };
    // What the run leaves as it was, said in its last line.
    let mut copy: Option<String> = None;
    if let Some((input, output)) = &cfg.rewrite {
        // The output first: a program coming through a FIFO may keep the
        // run waiting for its beginning, and an interrupted run then still
        // has its temporary file to remove.
        let mut out = AtomicOutput::create(output)?;
        let (detection, file) = cfg.common.open_program(input)?;
        let mut settings = cfg.settings.clone();
        settings.dialect = detection.dialect;
        let c = Compensator::new(&cfg.errors.model, &cfg.errors.theta, settings);
        // On any error `out` is dropped: its temporary file goes, nothing is written.
        let summary = c.run(input, file, &mut out)?;
        let unchanged = summary.changed == 0 && summary.inserted == 0;
        if let Some(why) = &summary.no_motion {
            // Nothing to correct in it, and nothing wrong with it: a
            // program of tool changes and calls is passed on as it is.
            out.commit()?;
            out!("{}", describe(&summary, input, output, &detection, &cfg));
            copy = Some(format!(
                "{why}: {} is a copy of {}",
                output.display(),
                input.display()
            ));
        } else {
            if unchanged && summary.largest_linear.is_none() {
                // Moves there were (a program without is passed on above or
                // refused by the library), and every one was left as
                // written: a copy is no compensation.
                bail!(
                    "{}: none of its {} could be rewritten ({}); nothing written",
                    input.display(),
                    count(summary.moves, "move", "moves"),
                    reasons(&summary.skipped)
                );
            }
            let any_error = cfg.errors.theta.iter().any(|&v| v != 0.0);
            let felt = |l: Option<fivecal::compensate::Largest>| l.is_some_and(|l| l.value > 1e-6);
            if unchanged
                && any_error
                && !felt(summary.largest_linear)
                && !felt(summary.largest_rotary)
            {
                // Errors there are, and not one moves a pose this program
                // writes (a tool radius error, a probing effect): a copy is
                // not what was asked for.
                bail!(
                    "{}: its errors move no tool pose of {} ({}); nothing written",
                    cfg.errors_path.display(),
                    input.display(),
                    if summary.not_compensated.is_empty() {
                        "none is of a kind a rewrite corrects".to_string()
                    } else {
                        summary.not_compensated.join("; ")
                    }
                );
            }
            out.commit()?;
            out!("{}", describe(&summary, input, output, &detection, &cfg));
            if unchanged {
                // Legitimate (a machine whose errors are all but zero), but
                // never silent.
                let why = if any_error {
                    format!(
                        "every correction is below the resolution written ({} decimals in mm, {} in deg)",
                        cfg.settings.linear_decimals, cfg.settings.rotary_decimals
                    )
                } else {
                    format!(
                        "{} holds no error (every value 0)",
                        cfg.errors_path.display()
                    )
                };
                copy = Some(format!(
                    "{why}: {} is a copy of {}",
                    output.display(),
                    input.display()
                ));
            }
        }
    }
    let Some(((d, target), exported)) = cfg.export.as_ref().zip(exported) else {
        if let Some(c) = copy {
            outln!("nothing changed: {c}");
        }
        return Ok(());
    };
    let text = &exported.file_text(target.as_deref());
    match target {
        Some(p) => {
            fivecal::io::write_atomic(p, text.as_bytes())?;
            outln!("{d} parameters written to {}:", p.display());
            for line in exported.table() {
                outln!("  {line}");
            }
        }
        None => out!("{text}"),
    }
    if let Some(r) = &mut recorder {
        let content = std::fs::read_to_string(&cfg.errors_path)
            .with_context(|| format!("cannot read {} to record it", cfg.errors_path.display()))?;
        let rec = fivecal::store::runs::export(
            &cfg.common.machine.name,
            &cfg.errors_path,
            &content,
            &d.to_string(),
            text,
            &cfg.record.notes,
        )?;
        // Beside parameters printed to standard output, the note goes
        // to standard error.
        let to_stdout = target.is_some();
        r.save(&[rec], &|s| {
            if to_stdout {
                outln!("{s}")
            } else {
                eprintln!("{s}")
            }
        })?;
    }
    // Beside parameters on standard output, the notes go to standard
    // error; the last says whether anything changes.
    let note = |s: String| {
        if target.is_some() {
            outln!("{s}")
        } else {
            eprintln!("{s}")
        }
    };
    if !cfg.entered {
        note(
            "not recorded: a preview changes no control; once these values are entered, give the same command with --entered to record the change in the history".to_string(),
        );
    }
    let without = exported.without_u();
    if !without.is_empty() {
        note(format!(
            "note: {} gives no u for what {} depend on: --max-u not checked for them (an analyze result has u; a truth file has none)",
            cfg.errors_path.display(),
            without.join(", ")
        ));
    }
    let from = if exported.from_current {
        "what the control holds now (the machine file's controller_parameters)"
    } else {
        "the machine file's nominal geometry"
    };
    let listed = exported.listed_changed();
    let listed = if listed.is_empty() {
        String::new()
    } else {
        format!(
            "; listed for the machine builder, not entered: {}",
            listed.join(", ")
        )
    };
    let parameters = if exported.changes_nothing() {
        format!("every {d} parameter to enter equals {from} to the resolution written{listed}")
    } else {
        format!(
            "{} of {} {d} parameters to enter change from {from}: {}{listed}",
            exported.changed().len(),
            exported.parameters.iter().filter(|p| p.entered).count(),
            exported.changed().join(", ")
        )
    };
    match (copy, exported.changes_nothing()) {
        (Some(c), true) => note(format!("nothing changed: {c}, and {parameters}")),
        (Some(c), false) => {
            note(parameters);
            note(format!("program unchanged: {c}"));
        }
        (None, true) => note(format!("nothing to change: {parameters}")),
        (None, false) => note(parameters),
    }
    Ok(())
}

/// Moves left out, by reason: `why: lines 3, 7; why: lines 9`.
pub fn reasons(skipped: &[(String, fivecal::compensate::Lines)]) -> String {
    skipped
        .iter()
        .map(|(why, lines)| format!("{why}: lines {}", lines.list()))
        .collect::<Vec<_>>()
        .join("; ")
}

/// The summary a user reads after a rewrite.
fn describe(
    s: &Summary,
    input: &Path,
    output: &Path,
    detection: &Detection,
    cfg: &Config,
) -> String {
    use std::fmt::Write;
    let mut t = String::new();
    let m = &cfg.common.machine;
    let _ = writeln!(
        t,
        "compensated {} -> {} (machine {} ({}), errors {})",
        input.display(),
        output.display(),
        m.name,
        cfg.common.machine_origin,
        cfg.errors_path.display()
    );
    let _ = writeln!(t, "  read as {detection}");
    if let Some(n) = rotary_start_note(&cfg.settings.rotary_start) {
        let _ = writeln!(t, "  {n}");
    }
    let _ = writeln!(
        t,
        "  {}, {}: {}, {} ({}, {}) to stay within {} um",
        count(s.blocks, "block", "blocks"),
        count(s.moves, "move", "moves"),
        count(s.changed, "block changed", "blocks changed"),
        count(s.inserted, "block added", "blocks added"),
        count(s.subdivided.len(), "move subdivided", "moves subdivided"),
        count(s.linearized.len(), "arc linearized", "arcs linearized"),
        cfg.settings.tolerance * 1e3
    );
    let _ = writeln!(
        t,
        "  {} of {} motion blocks (blocks that move an axis) corrected",
        s.corrected_blocks, s.motion_blocks
    );
    match (s.largest_linear, s.largest_rotary) {
        (Some(l), Some(r)) => {
            let _ = writeln!(
                t,
                "  largest correction: {:.2} um in X, Y, Z (line {}); {:.2} urad of tool orientation (line {})",
                l.value, l.line, r.value, r.line
            );
        }
        _ => {
            let _ = writeln!(t, "  no move was corrected");
        }
    }
    if !s.held_c.is_empty() {
        let _ = writeln!(
            t,
            "  C held next to the tilt singularity (tool along C) in {} moves (lines {}): tip exact, tool axis within {:.1} urad",
            s.held_c.len(),
            s.held_c.list(),
            s.held_c_axis_error
        );
    }
    if !s.held_tilt.is_empty() {
        let _ = writeln!(
            t,
            "  {} held at its limit (the correction needs it a little beyond) in {} moves (lines {}): tip exact, tool axis within {:.1} urad",
            m.tilt.letter,
            s.held_tilt.len(),
            s.held_tilt.list(),
            s.held_tilt_axis_error
        );
    }
    if !s.tilted_plane.is_empty() {
        let _ = writeln!(
            t,
            "  3+2 in a tilted working plane: {} moves corrected in the plane (lines {}): tip exact; the tool axis keeps up to {:.1} urad of the machine's orientation error (not correctable by coordinates; the plane and its rotary positions are as written)",
            s.tilted_plane.len(),
            s.tilted_plane.list(),
            s.tilted_plane_axis_error
        );
    }
    if !s.drilled.is_empty() {
        let _ = writeln!(
            t,
            "  canned cycles: {} holes corrected at their bottom (lines {}): tip exact there; the cycle drills along the actual tool axis, which keeps up to {:.1} urad of the machine's orientation error (rotary positions as written), up to {:.2} um off the intended hole axis at the R level",
            s.drilled.len(),
            s.drilled.list(),
            s.drilled_axis_error,
            s.drilled_residual
        );
    }
    match s.coordinates.as_slice() {
        [] => {}
        [one] => {
            let _ = writeln!(t, "  coordinates: {} ({})", one.meaning, one.why);
        }
        many => {
            let _ = writeln!(t, "  coordinates, section by section:");
            for c in many {
                let _ = writeln!(
                    t,
                    "    lines {}-{}: {} ({})",
                    c.lines.0, c.lines.1, c.meaning, c.why
                );
            }
        }
    }
    if !s.unmodelled.is_empty() {
        let _ = writeln!(
            t,
            "  kept as written, effect not modelled (--strict refuses them):"
        );
        for (what, lines) in &s.unmodelled {
            let _ = writeln!(t, "    {what}: lines {}", lines.list());
        }
    }
    if let Some(m) = &s.macro_logic {
        let _ = writeln!(t, "  {m}");
    }
    if s.skipped.is_empty() {
        let _ = writeln!(t, "  no move left as written");
    } else {
        let moves = s.skipped_count() - s.unreadable.len();
        if s.unreadable.is_empty() {
            let _ = writeln!(t, "  {moves} moves left as written:");
        } else {
            let _ = writeln!(
                t,
                "  {moves} moves and {} unreadable blocks left as written (no correction across an unreadable block; --strict refuses them):",
                s.unreadable.len()
            );
        }
        for (reason, lines) in &s.skipped {
            let _ = writeln!(t, "    {reason}: lines {}", lines.list());
        }
    }
    for n in &s.not_compensated {
        let _ = writeln!(t, "  not compensated: {n}");
    }
    t
}
