//! The options `compensate` and `simulate nc` share: the machine, the
//! program's dialect, origin, coordinates, integer unit and assumed rotary
//! positions, the tool length, `--strict`; validated once into [`Common`],
//! which also opens the program in the dialect it is read in.

use std::io::{BufRead, BufReader, Cursor, Read};
use std::path::{Path, PathBuf};

use anyhow::{Context as _, bail};
use clap::{Args, ValueEnum};
use fivecal::compensate::Coordinates;
use fivecal::errorfile::{ErrorFile, LoadedErrors};
use fivecal::machine::MachineOrigin;
use fivecal::nc::dialect::Detection;
use fivecal::{Dialect, Kinematics, Machine};
use nalgebra::Vector3;

use super::DialectArg;

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
    #[arg(long, value_name = "M.yaml|NAME")]
    pub machine: String,
    /// Controller dialect of the program [default: what its text shows
    /// (BEGIN PGM, O-numbers, o-words, G43.4, %_N_.._MPF, TRAORI...), then
    /// its extension (.h, .ngc, .mpf, .spf), then the machine's].
    #[arg(long, value_name = "D", value_enum)]
    pub dialect: Option<DialectArg>,
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
        let dialect = self.dialect.map(Dialect::from);
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
