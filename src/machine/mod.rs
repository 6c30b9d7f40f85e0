//! Machine files: the structure of a five-axis machine (which rotary axes
//! sit on the table and which in the head), its strokes and rotary limits,
//! where the table frame W sits in machine coordinates, its controller
//! dialect and its default tool and probe.
//!
//! Machine files are YAML (see `examples/machines/`). The four example
//! machines are compiled into the binary as built-in defaults, so
//! `--machine bc-trunnion` works without any file on disk; a path always
//! wins over a built-in name. Every supported machine has exactly one C axis
//! (rotation about Z) and one tilt axis (A about X or B about Y); the
//! structure says where each of them sits.

pub mod acceptance;
mod file;

use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use crate::geom::Axis3;
use crate::source::SourceError;

pub use file::{ControllerParameters, MachineFile, SinumerikFile, check_tool};

/// Where the two rotary axes sit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Structure {
    /// Tilting rotary table (trunnion): the tilt axis carries the C table.
    TableTable,
    /// Swivel (tilt) head and C rotary table.
    HeadTable,
    /// Both axes in the head: C head carrying the tilt head.
    HeadHead,
}

impl fmt::Display for Structure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Structure::TableTable => "table-table",
            Structure::HeadTable => "head-table",
            Structure::HeadHead => "head-head",
        })
    }
}

/// Controller dialect of generated and rewritten NC programs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Dialect {
    /// FANUC (ISO G-code with Custom Macro B).
    Fanuc,
    /// HEIDENHAIN TNC Klartext.
    Heidenhain,
    /// LinuxCNC rs274ngc.
    Linuxcnc,
    /// SINUMERIK 840D sl / ONE (DIN 66025 words with Siemens high-level
    /// language: `;` comments, `X=expr`, R parameters, TRAORI, CYCLE800).
    Sinumerik,
}

impl Dialect {
    /// All dialects.
    pub const ALL: [Dialect; 4] = [
        Dialect::Fanuc,
        Dialect::Heidenhain,
        Dialect::Linuxcnc,
        Dialect::Sinumerik,
    ];

    /// Lower-case name as used on the command line and in files.
    pub fn name(self) -> &'static str {
        match self {
            Dialect::Fanuc => "fanuc",
            Dialect::Heidenhain => "heidenhain",
            Dialect::Linuxcnc => "linuxcnc",
            Dialect::Sinumerik => "sinumerik",
        }
    }
}

impl Dialect {
    /// The zero point the planned programs select, in the control's own
    /// words: what the operator sets before the run.
    pub fn work_offset(self) -> &'static str {
        match self {
            Dialect::Heidenhain => "preset 1 (preset table line 1, activated by CYCL DEF 247)",
            Dialect::Fanuc | Dialect::Linuxcnc | Dialect::Sinumerik => "work offset G54",
        }
    }
}

impl fmt::Display for Dialect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Dialect {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "fanuc" => Ok(Dialect::Fanuc),
            "heidenhain" => Ok(Dialect::Heidenhain),
            "linuxcnc" => Ok(Dialect::Linuxcnc),
            "sinumerik" => Ok(Dialect::Sinumerik),
            _ => Err(format!(
                "unknown dialect `{s}`: expected fanuc, heidenhain, linuxcnc or sinumerik"
            )),
        }
    }
}

/// Cutting-tool shape.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ToolKind {
    /// Straight (flat) end mill.
    Flat,
    /// Ball end mill.
    Ball,
    /// Bull-nose (torus) end mill with a corner radius.
    Bull,
}

/// A cutting tool.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Tool {
    /// Free text, shown in program headers and setup sheets.
    pub name: String,
    /// Shape.
    pub kind: ToolKind,
    /// Diameter, mm.
    pub diameter: f64,
    /// Gauge length (spindle gauge line to tip), mm.
    pub length: f64,
    /// Corner radius of a bull-nose tool, mm.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub corner_radius: Option<f64>,
    /// Number of flutes (for feeds).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub flutes: Option<u32>,
    /// Tool number used in tool calls.
    #[serde(default = "default_tool_number")]
    pub number: u32,
    /// The tool's name in the control's tool list, for a control that
    /// calls tools by name (SINUMERIK tool management `T="NAME"`,
    /// HEIDENHAIN `TOOL CALL "NAME"`); without it the tool is called by
    /// its number.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub id: Option<String>,
}

impl Tool {
    /// How headers and setup sheets name the tool: `T1`, or `T1 "EM_D8"`
    /// when the control calls it by name.
    pub fn label(&self) -> String {
        tool_label(self.number, self.id.as_deref())
    }
}

/// `T<number>`, followed by the tool-list name when there is one.
fn tool_label(number: u32, id: Option<&str>) -> String {
    match id {
        Some(id) => format!("T{number} \"{id}\""),
        None => format!("T{number}"),
    }
}

fn default_tool_number() -> u32 {
    1
}

/// A touch-trigger probe.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Probe {
    /// Free text.
    pub name: String,
    /// Calibrated ball diameter, mm.
    pub ball_diameter: f64,
    /// Gauge length (spindle gauge line to ball centre), mm.
    pub length: f64,
    /// Tool number of the probe.
    #[serde(default = "default_probe_number")]
    pub number: u32,
    /// The probe's name in the control's tool list (see [`Tool::id`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub id: Option<String>,
}

impl Probe {
    /// How headers and setup sheets name the probe (see [`Tool::label`]).
    pub fn label(&self) -> String {
        tool_label(self.number, self.id.as_deref())
    }
}

fn default_probe_number() -> u32 {
    99
}

/// One rotary axis.
#[derive(Clone, Debug, PartialEq)]
pub struct RotaryAxis {
    /// `A`, `B` or `C`.
    pub letter: char,
    /// The machine axis it rotates about at zero position.
    pub about: Axis3,
    /// Whether it moves the workpiece (table) or the tool (head).
    pub on_table: bool,
    /// +1 when a positive command rotates as docs/model.md writes it
    /// (`R(-angle)` for table axes, `R(+angle)` for head axes), -1 otherwise.
    pub direction: f64,
    /// AcceptanceLimits in degrees; `None` for a continuous axis.
    pub limits: Option<(f64, f64)>,
    /// The body it is mounted on, as a chain letter (`Y`, `Z`, `B`, ...),
    /// used in error-term names such as `dx_BY`.
    pub parent: char,
}

impl RotaryAxis {
    /// Whether `angle` (deg) is inside the limits, with `tol` of slack.
    pub fn within(&self, angle: f64, tol: f64) -> bool {
        match self.limits {
            None => true,
            Some((lo, hi)) => angle >= lo - tol && angle <= hi + tol,
        }
    }
}

/// Table geometry, in W.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Table {
    /// Z of the table top in W, mm.
    pub surface: f64,
    /// Radius of the usable table, mm.
    pub radius: f64,
}

/// Rapid traverse rates.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Rapid {
    /// Linear rapid, mm/min.
    pub linear: f64,
    /// Rotary rapid, deg/min.
    pub rotary: f64,
}

impl Default for Rapid {
    fn default() -> Self {
        Rapid {
            linear: 15000.0,
            rotary: 3600.0,
        }
    }
}

/// M functions a control has beyond its dialect's standard ones, by
/// number.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct MCodes {
    /// Switch tool-centre-point control on (`M428` of LinuxCNC's 5-axis
    /// configurations, which remap it).
    pub tcp_on: Vec<u32>,
    /// Switch it off.
    pub tcp_off: Vec<u32>,
    /// Move no axis (clamps, conveyors).
    pub known: Vec<u32>,
}

/// The axes a tool change may move: what the machine builder's tool change
/// sequence (FANUC's and LinuxCNC's `M6` macro, HEIDENHAIN's `TOOL CALL`
/// PLC sequence, SINUMERIK's `M6` cycle) moves before the program takes over
/// again. Each of them is machine-dependent in the vendors' manuals; an axis
/// not listed keeps its position across the change.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ToolChange {
    /// Axis letters (X Y Z and the machine's rotary axes), each at most once.
    pub moves: Vec<char>,
    /// Whether the machine file stated the list (else it is the default).
    pub stated: bool,
}

impl ToolChange {
    /// The safe default for a structure: the linear axes (the spindle goes
    /// to its tool change position) and every rotary axis the head carries
    /// (a swivel head may be turned upright for the changer); a rotary
    /// table is not turned by a tool change on the machines the vendors
    /// describe, so its axes keep their positions.
    pub fn default_for(structure: Structure, tilt: char) -> ToolChange {
        let mut moves = vec!['X', 'Y', 'Z'];
        match structure {
            Structure::TableTable => {}
            Structure::HeadTable => moves.push(tilt),
            Structure::HeadHead => {
                moves.push(tilt);
                moves.push('C');
            }
        }
        ToolChange {
            moves,
            stated: false,
        }
    }

    /// Whether a tool change may move this axis.
    pub fn moves(&self, axis: char) -> bool {
        self.moves.contains(&axis)
    }
}

/// A validated machine.
#[derive(Clone, Debug, PartialEq)]
pub struct Machine {
    /// Short name (`bc-trunnion`).
    pub name: String,
    /// One line on what it is.
    pub description: String,
    /// Where the rotary axes sit.
    pub structure: Structure,
    /// Kinematic chain from workpiece to tool, e.g. `CBYFXZ`.
    pub chain: String,
    /// Default dialect of its controller.
    pub dialect: Dialect,
    /// Strokes of X, Y, Z in machine coordinates of the spindle gauge point, mm.
    pub strokes: [(f64, f64); 3],
    /// The tilt axis (A or B).
    pub tilt: RotaryAxis,
    /// The C axis.
    pub c: RotaryAxis,
    /// Machine coordinates of the W origin (reached by the spindle gauge
    /// point with all rotary axes at zero), mm.
    pub pivot: Vector3<f64>,
    /// Head machines: distance from the head's rotation centre to the
    /// spindle gauge line along the tool axis, mm (0 for table-table).
    pub pivot_length: f64,
    /// Table geometry.
    pub table: Table,
    /// Default cutting tool.
    pub tool: Tool,
    /// Default probe.
    pub probe: Probe,
    /// Rapid rates.
    pub rapid: Rapid,
    /// Acceptance limits per location symbol (the file's optional
    /// `limits:` section; see [`crate::conformance`]).
    pub limits: acceptance::AcceptanceLimits,
    /// What the control holds now, per export target and parameter (the
    /// file's optional `controller_parameters:` section; `compensate
    /// --export` prints each change from these, else from the nominal
    /// geometry).
    pub controller_parameters: file::ControllerParameters,
    /// The control's own M functions (the file's optional `m_codes:`).
    pub m_codes: MCodes,
    /// How its FANUC control reads an axis word without a decimal point
    /// (the file's optional `integer_unit:`); unknown when absent.
    pub integer_unit: Option<file::IntegerUnit>,
    /// The axes a tool change may move (the file's optional
    /// `tool_change: {moves: [..]}`; [`ToolChange::default_for`] else).
    pub tool_change: ToolChange,
    /// Where a SINUMERIK control holds the kinematics (the file's optional
    /// `sinumerik: {swivel_record: N}`).
    pub sinumerik: Option<file::SinumerikFile>,
    /// The file text it was read from (for `machine show` and provenance).
    pub source: String,
}

/// Why a machine could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum MachineError {
    /// The name is neither a built-in machine nor a path.
    #[error(
        "no built-in machine `{0}` (built-in: {1}); a machine file is named by its path, with a `/` or a `.yaml` extension (./{0}.yaml)"
    )]
    NotFound(String, String),
    /// The file is malformed or inconsistent.
    #[error(transparent)]
    Invalid(#[from] SourceError),
}

/// Where a machine named on the command line came from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum MachineOrigin {
    /// One of [`BUILTIN`].
    BuiltIn,
    /// A machine file.
    File(PathBuf),
}

impl std::fmt::Display for MachineOrigin {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            MachineOrigin::BuiltIn => f.write_str("built in"),
            MachineOrigin::File(p) => write!(f, "machine file {}", p.display()),
        }
    }
}

/// Whether a command-line name is a path (with a `/` or a `.yaml` or
/// `.yml` extension) rather than a built-in name.
pub fn is_path_spec(spec: &str) -> bool {
    spec.contains('/')
        || spec.contains(std::path::MAIN_SEPARATOR)
        || spec.ends_with(".yaml")
        || spec.ends_with(".yml")
}

fn builtin_names() -> String {
    BUILTIN
        .iter()
        .map(|(n, _)| *n)
        .collect::<Vec<_>>()
        .join(", ")
}

/// Built-in machines: (name, YAML text).
pub const BUILTIN: [(&str, &str); 4] = [
    (
        "bc-trunnion",
        include_str!("../../examples/machines/bc-trunnion.yaml"),
    ),
    (
        "ac-trunnion",
        include_str!("../../examples/machines/ac-trunnion.yaml"),
    ),
    (
        "head-table",
        include_str!("../../examples/machines/head-table.yaml"),
    ),
    (
        "head-head",
        include_str!("../../examples/machines/head-head.yaml"),
    ),
];

impl Machine {
    /// Parses and validates a machine file's text; `path` is used in errors.
    pub fn from_yaml(path: &Path, src: &str) -> Result<Machine, MachineError> {
        Ok(file::parse(path, src)?)
    }

    /// A built-in machine by name.
    pub fn builtin(name: &str) -> Option<Machine> {
        BUILTIN.iter().find(|(n, _)| *n == name).map(|(n, src)| {
            Machine::from_yaml(Path::new(&format!("<built-in {n}>")), src)
                .expect("built-in machine files are valid")
        })
    }

    /// Reads a machine file at `path` (whatever its name); `what` names it
    /// in a refusal (a plan's machine copy is not the user's machine file).
    pub fn from_file(path: &Path, what: &str) -> Result<Machine, MachineError> {
        let src = crate::input::read_text(path, what, crate::limits::MAX_YAML_BYTES)?;
        Machine::from_yaml(path, &src)
    }

    /// Loads a machine named on the command line (see [`Machine::resolve`]).
    pub fn load(spec: &str) -> Result<Machine, MachineError> {
        Ok(Machine::resolve(spec)?.0)
    }

    /// Loads a machine named on the command line, and says where it came
    /// from: a built-in name means the built-in machine (a file of that
    /// name in the working directory does not replace it); a file is taken
    /// only as a path, with a `/` or a `.yaml`/`.yml` extension.
    pub fn resolve(spec: &str) -> Result<(Machine, MachineOrigin), MachineError> {
        if let Some(m) = Machine::builtin(spec) {
            return Ok((m, MachineOrigin::BuiltIn));
        }
        let path = Path::new(spec);
        if !is_path_spec(spec) {
            return Err(MachineError::NotFound(spec.to_string(), builtin_names()));
        }
        Ok((
            Machine::from_file(path, "machine file")?,
            MachineOrigin::File(path.to_path_buf()),
        ))
    }

    /// Letter of the tilt axis (`A` or `B`).
    pub fn tilt_letter(&self) -> char {
        self.tilt.letter
    }

    /// Whether the spindle gauge point, given in program coordinates (work
    /// offset on the W origin at rotary zero), is inside the strokes.
    /// Returns the first violation as (axis letter, machine coordinate,
    /// stroke).
    pub fn check_strokes(
        &self,
        gauge_point_prog: &Vector3<f64>,
    ) -> Result<(), (char, f64, (f64, f64))> {
        let m = gauge_point_prog + self.pivot;
        for i in 0..3 {
            let (lo, hi) = self.strokes[i];
            if m[i] < lo - 1e-9 || m[i] > hi + 1e-9 {
                return Err((Axis3::from_index(i).letter(), m[i], (lo, hi)));
            }
        }
        Ok(())
    }
}
