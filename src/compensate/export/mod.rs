//! The identified location errors as the corrected pivot data of a
//! controller (`fivecal compensate --export fanuc|heidenhain|linuxcnc|sinumerik`),
//! each value with its uncertainty and its change from what the control
//! holds now, refused when a change or an uncertainty is too large, a
//! value would drive an axis beyond its stroke, or none of the errors
//! reaches a parameter.
//!
//! The erroneous machine's rotary axis lines are computed at rotary zero
//! from the chain ([`geometry`]), in machine coordinates, from the location
//! errors alone: error maps, drift and the zero points of the axes are not
//! part of an axis line and are listed as not held, never folded in. Each
//! controller holds some of this geometry (`controllers.rs`; the meaning of
//! every parameter and its public source are in docs/controllers.md):
//!
//! - FANUC tool centre point control (parameters 19700-19714): absolute
//!   positions and offset vectors of the axis lines.
//! - HEIDENHAIN kinematics description: incremental corrections of the
//!   `Trans` X/Y/Z rows before each `MachAxis`; the axes' orientations are
//!   listed for the machine builder.
//! - LinuxCNC `xyzbc-trt-kins` / `xyzac-trt-kins` (tilting tables): the
//!   C axis position and the tilt axis's offset from it.
//! - SINUMERIK swivel data record (`$TC_CARR`, `sinumerik.rs`): the fine
//!   offsets of its vector chain, as a part program; the axis directions
//!   listed.
//!
//! The uncertainty of a parameter comes from the error file's `u` of each
//! symbol through the derivative of the parameter (central differences of
//! the same computation). The file holds no correlations, so a parameter
//! made of several symbols adds their parts: an upper bound of its `u`,
//! exact when one symbol makes it.

mod controllers;
mod geometry;
mod sinumerik;

use std::fmt::{self, Write as _};

pub use geometry::{AxisLine, Geometry, geometry};

use crate::errorfile::NotIdentified;
use crate::kinematics::symbols::{SymbolTable, Unit};
use crate::kinematics::{Axes, Kinematics, Perturbation, ToolPose};
use crate::machine::{Dialect, Machine, Structure};
use crate::model::{Context, Effect, Model};

/// What a parameter measures.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// A length, mm.
    Length,
    /// An angle, urad.
    Angle,
}

/// A parameter before its uncertainty and current value are known.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Raw {
    pub name: String,
    pub what: String,
    pub kind: Kind,
    pub value: f64,
    pub nominal: f64,
    /// Entered at the control (false: listed for the machine builder only).
    pub entered: bool,
}

/// One exported parameter.
#[derive(Clone, Debug, PartialEq)]
pub struct Parameter {
    /// As the controller (or docs/controllers.md) names it: `19700`,
    /// `x-rot-point`, `B.X`.
    pub name: String,
    /// What it is, in a few words.
    pub what: String,
    /// Length or angle.
    pub kind: Kind,
    /// The value to enter (mm or urad).
    pub value: f64,
    /// Its value on the machine file's nominal geometry.
    pub nominal: f64,
    /// What the control holds now, when the machine file says.
    pub current: Option<f64>,
    /// Standard uncertainty (k = 1), when the error file gives the `u` of
    /// every symbol it depends on.
    pub u: Option<f64>,
    /// Entered at the control; false for what is only listed for the
    /// machine builder (HEIDENHAIN's axis directions), which the limits do
    /// not refuse but mark.
    pub entered: bool,
    /// For a listed value: the limit it is beyond (`u 106.13 urad beyond
    /// --max-u 0.05 mrad`).
    pub beyond: Option<String>,
    /// No error the export holds moves it to first order: it keeps its
    /// nominal value by the way the errors are split (a tilt taken up by an axis's zero, an
    /// offset another row carries), so its `u` of 0 says nothing measured
    /// and is shown as `fixed`.
    pub fixed: bool,
    /// Not written: an error it depends on was not identified by the test
    /// the error file comes from; the control keeps what it holds. Why.
    pub withheld: Option<String>,
}

impl Parameter {
    /// The value the change is counted from: the current one, else the
    /// nominal one.
    pub fn reference(&self) -> f64 {
        self.current.unwrap_or(self.nominal)
    }

    /// The change from [`Parameter::reference`] (mm or urad).
    pub fn change(&self) -> f64 {
        self.value - self.reference()
    }

    /// A length in um, an angle in urad: the unit changes and `u` are shown
    /// in.
    fn small(&self, v: f64) -> f64 {
        match self.kind {
            Kind::Length => v * 1e3,
            Kind::Angle => v,
        }
    }

    /// The u as shown: in um or urad, `fixed` for a parameter no held
    /// error moves, `not given` when a symbol it depends on has none.
    fn u_text(&self) -> String {
        match self.u {
            _ if self.fixed => "fixed".to_string(),
            Some(u) => format!("{:.2} {}", self.small(u), self.small_unit()),
            None => "not given".to_string(),
        }
    }

    fn small_unit(&self) -> &'static str {
        match self.kind {
            Kind::Length => "um",
            Kind::Angle => "urad",
        }
    }

    /// The value as written: mm with five decimals (0.01 um, so that a
    /// value rounded as written moves the tool by well under 0.1 um), urad
    /// with two.
    pub(super) fn written(&self, v: f64) -> String {
        match self.kind {
            Kind::Length => signed(v, MM_DECIMALS),
            Kind::Angle => signed(v, 2),
        }
    }

    /// Whether the change is below what the written value resolves.
    fn unchanged(&self) -> bool {
        self.below_resolution(self.change())
    }

    /// Whether the value is the nominal one to the resolution written.
    fn at_nominal(&self) -> bool {
        self.below_resolution(self.value - self.nominal)
    }

    fn below_resolution(&self, d: f64) -> bool {
        match self.kind {
            Kind::Length => d.abs() < 0.5e-5,
            Kind::Angle => d.abs() < 0.5e-2,
        }
    }
}

/// How far an export may go: the largest change from the current value
/// and the largest standard uncertainty, for lengths and for angles.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    /// Largest change of a length, mm.
    pub change_mm: f64,
    /// Largest change of an angle, mrad.
    pub change_mrad: f64,
    /// Largest u of a length, mm.
    pub u_mm: f64,
    /// Largest u of an angle, mrad.
    pub u_mrad: f64,
}

impl Default for Limits {
    /// 0.1 mm and 0.5 mrad of change (the order of HEIDENHAIN
    /// KinematicsOpt's own guard, MP6600, default 0.05 mm), and a tenth of
    /// that in u: 0.01 mm and 0.05 mrad.
    fn default() -> Self {
        Limits {
            change_mm: 0.1,
            change_mrad: 0.5,
            u_mm: 0.01,
            u_mrad: 0.05,
        }
    }
}

impl Limits {
    /// The limit for a kind, in the parameter's unit (mm or urad).
    fn change(&self, kind: Kind) -> f64 {
        match kind {
            Kind::Length => self.change_mm,
            Kind::Angle => self.change_mrad * 1e3,
        }
    }

    fn u(&self, kind: Kind) -> f64 {
        match kind {
            Kind::Length => self.u_mm,
            Kind::Angle => self.u_mrad * 1e3,
        }
    }
}

/// Decimals of a length written in mm (0.01 um).
pub(super) const MM_DECIMALS: usize = 5;

/// `v` with its sign and `decimals` decimals, a value that rounds to zero
/// written `+0.00..` (never `-0.0000`).
pub(super) fn signed(v: f64, decimals: usize) -> String {
    let t = format!("{v:+.decimals$}");
    if t[1..].bytes().all(|c| c == b'0' || c == b'.') {
        format!("+{}", &t[1..])
    } else {
        t
    }
}

/// A limit as the option writes it: `0.1 mm`, `0.5 mrad`.
fn limit_text(kind: Kind, v: f64) -> String {
    match kind {
        Kind::Length => format!("{v} mm"),
        Kind::Angle => format!("{} mrad", v * 1e-3),
    }
}

/// Why an export is refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ExportError {
    /// The controller has no kinematics for this structure.
    #[error("{0}")]
    Unsupported(String),
    /// A change beyond `--max-change`.
    #[error(
        "{controller} parameter {name} ({what}) would change by {change} (from {from}): beyond --max-change {limit}; nothing written. Check the error file (a unit mistake, a failed fit), or give a larger --max-change if the change is real"
    )]
    TooLarge {
        /// The controller.
        controller: Dialect,
        /// The parameter.
        name: String,
        /// What it is.
        what: String,
        /// The change, with its unit.
        change: String,
        /// What it is counted from.
        from: String,
        /// The limit, with its unit.
        limit: String,
    },
    /// An uncertainty beyond `--max-u`.
    #[error(
        "{controller} parameter {name} ({what}) has u = {u}: beyond --max-u {limit}; nothing written. Measure again (more points, a second setup) or give a larger --max-u"
    )]
    Uncertain {
        /// The controller.
        controller: Dialect,
        /// The parameter.
        name: String,
        /// What it is.
        what: String,
        /// Its u, with its unit.
        u: String,
        /// The limit, with its unit.
        limit: String,
    },
    /// A value that would drive a linear axis beyond its stroke.
    #[error(
        "with the exported values ({changed}) the control would drive {axis} to {value:.4} mm, beyond its stroke [{lo}, {hi}] of the machine file, to put the tool tip on the W origin at {tilt_letter} = {tilt}, C = {c} deg (nominally at {nominal:.4} mm); nothing written"
    )]
    Stroke {
        /// The linear axis.
        axis: char,
        /// Where it would go, machine coordinates, mm.
        value: f64,
        /// Where it goes nominally.
        nominal: f64,
        /// Its stroke's lower end.
        lo: f64,
        /// Its stroke's upper end.
        hi: f64,
        /// The tilt axis letter.
        tilt_letter: char,
        /// The tilt angle, deg.
        tilt: f64,
        /// The C angle, deg.
        c: f64,
        /// The parameters that change, named.
        changed: String,
    },
    /// Every error of the file is of a kind the controller's parameters do
    /// not hold: an export would enter the nominal values again.
    #[error(
        "--export {controller}: none of the errors in {file} is held by {controller}'s parameters (every one equals the nominal geometry to the resolution written); the file holds only {not_held}; nothing written. Rewrite programs with `fivecal compensate IN -o OUT` (without --export): that compensates them"
    )]
    NothingHeld {
        /// The controller.
        controller: Dialect,
        /// The error file.
        file: String,
        /// What the file holds, each with why no parameter holds it.
        not_held: String,
    },
    /// The machine file lists a current value for a parameter the export
    /// does not write.
    #[error(
        "machine file: controller_parameters.{controller}.{name} is not a parameter of this export (it writes {expected})"
    )]
    UnknownCurrent {
        /// The controller.
        controller: Dialect,
        /// The name given.
        name: String,
        /// The names the export writes.
        expected: String,
    },
}

/// A finished export: its parameters and the text to enter.
#[derive(Clone, Debug)]
pub struct Export {
    /// The controller.
    pub dialect: Dialect,
    /// Every parameter written, in order.
    pub parameters: Vec<Parameter>,
    /// Whether the changes are counted from the control's current values
    /// (the machine file's `controller_parameters`) rather than from the
    /// nominal geometry.
    pub from_current: bool,
    /// The text (a comment header, the values, what is not held).
    pub text: String,
}

/// Where an export goes by default when a rewritten program `program` is
/// written too: beside it, `<program>.<controller>.txt`; a SINUMERIK
/// export is a part program of its own, `<NAME>_SWIVEL.MPF` with a name
/// the control accepts (see [`crate::post::sinumerik_program_name`]).
pub fn default_file(dialect: Dialect, program: &std::path::Path) -> std::path::PathBuf {
    if dialect == Dialect::Sinumerik {
        let stem = program
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let mut name = crate::post::sinumerik_program_name(&stem);
        name.truncate(24 - "_SWIVEL".len());
        return program.with_file_name(format!("{name}_SWIVEL.MPF"));
    }
    let mut name = program.as_os_str().to_owned();
    name.push(format!(".{dialect}.txt"));
    std::path::PathBuf::from(name)
}

impl Export {
    /// The text as a file `file` holds it (standard output with `None`):
    /// a SINUMERIK part program opens with the `%_N_<NAME>_MPF` and
    /// `;$PATH=/_N_MPF_DIR` lines a control expects of a program loaded
    /// from outside, its name from the file's.
    pub fn file_text(&self, file: Option<&std::path::Path>) -> String {
        if self.dialect != Dialect::Sinumerik {
            return self.text.clone();
        }
        let stem = file
            .and_then(|f| f.file_stem())
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "FIVECAL_SWIVEL".to_string());
        format!(
            "%_N_{}_MPF\n;$PATH=/_N_MPF_DIR\n{}",
            crate::post::sinumerik_program_name(&stem),
            self.text
        )
    }

    /// Whether no entered parameter changes (every change below the
    /// written resolution).
    pub fn changes_nothing(&self) -> bool {
        self.parameters.iter().all(|p| !p.entered || p.unchanged())
    }

    /// The parameters listed for the machine builder (not entered) whose
    /// value is not the current one, named (`B.A, C.A`).
    pub fn listed_changed(&self) -> Vec<&str> {
        self.parameters
            .iter()
            .filter(|p| !p.entered && !p.unchanged())
            .map(|p| p.name.as_str())
            .collect()
    }

    /// The entered parameters that change, named (`19700, 19702`).
    pub fn changed(&self) -> Vec<&str> {
        self.parameters
            .iter()
            .filter(|p| p.entered && !p.unchanged())
            .map(|p| p.name.as_str())
            .collect()
    }

    /// The lines that close an export of the error file `errors`: that a
    /// preview (`entered` false) is not recorded, which parameters have no
    /// u, and the last, which says how many parameters change from what
    /// (or that none does), together with `copy`, why a program rewritten
    /// in the same run is a copy of its input, if it is.
    pub fn closing_notes(
        &self,
        errors: &std::path::Path,
        entered: bool,
        copy: Option<String>,
    ) -> Vec<String> {
        let d = self.dialect;
        let mut notes = Vec::new();
        if !entered {
            notes.push(
                "not recorded: a preview changes no control; once these values are entered, give the same command with --entered to record the change in the history".to_string(),
            );
        }
        let without = self.without_u();
        if !without.is_empty() {
            notes.push(format!(
                "note: {} gives no u for what {} depend on: --max-u not checked for them (an analyze result has u; a truth file has none)",
                errors.display(),
                without.join(", ")
            ));
        }
        let from = if self.from_current {
            "what the control holds now (the machine file's controller_parameters)"
        } else {
            "the machine file's nominal geometry"
        };
        let listed = self.listed_changed();
        let listed = if listed.is_empty() {
            String::new()
        } else {
            format!(
                "; listed for the machine builder, not entered: {}",
                listed.join(", ")
            )
        };
        let parameters = if self.changes_nothing() {
            format!("every {d} parameter to enter equals {from} to the resolution written{listed}")
        } else {
            format!(
                "{} of {} {d} parameters to enter change from {from}: {}{listed}",
                self.changed().len(),
                self.parameters.iter().filter(|p| p.entered).count(),
                self.changed().join(", ")
            )
        };
        match (copy, self.changes_nothing()) {
            (Some(c), true) => notes.push(format!("nothing changed: {c}, and {parameters}")),
            (Some(c), false) => {
                notes.push(parameters);
                notes.push(format!("program unchanged: {c}"));
            }
            (None, true) => notes.push(format!("nothing to change: {parameters}")),
            (None, false) => notes.push(parameters),
        }
        notes
    }

    /// The parameters without an uncertainty (the error file gives no `u`
    /// for a symbol they depend on).
    pub fn without_u(&self) -> Vec<&str> {
        self.parameters
            .iter()
            .filter(|p| p.u.is_none())
            .map(|p| p.name.as_str())
            .collect()
    }

    /// One line per parameter: name, value, change, u, what (the table of
    /// the header, and what the command prints).
    pub fn table(&self) -> Vec<String> {
        let from = if self.from_current {
            "from now"
        } else {
            "from nominal"
        };
        let mut out = vec![format!(
            "{:<14} {:>12}  {:>14}  {:>10}  what",
            "parameter",
            "value",
            format!("change {from}"),
            "u"
        )];
        for p in &self.parameters {
            let unit = match p.kind {
                Kind::Length => "mm",
                Kind::Angle => "urad",
            };
            let u = p.u_text();
            out.push(format!(
                "{:<14} {:>12}  {:>14}  {:>10}  {}{}",
                p.name,
                format!("{} {unit}", p.written(p.value)),
                format!("{} {}", signed(p.small(p.change()), 2), p.small_unit()),
                u,
                p.what,
                if p.withheld.is_some() {
                    " (not written: keep what the control holds)"
                } else if p.entered {
                    ""
                } else {
                    " (listed, not entered)"
                }
            ));
        }
        out
    }
}

impl fmt::Display for Kind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Kind::Length => "length",
            Kind::Angle => "angle",
        })
    }
}

/// The parameter vector of the location errors a controller's axis lines
/// hold: the location symbols but the zero points of the axes; every other
/// effect (maps, drift, linear axes, tool, probe) left out.
fn held(model: &Model) -> Vec<usize> {
    let mut out = Vec::new();
    for (i, e) in model.effects.iter().enumerate() {
        if let Effect::Location { symbols } = e {
            let r = model.param_range(i);
            for (k, &s) in symbols.iter().enumerate() {
                if !model.symbols.location[s].is_zero_point() {
                    out.push(r.start + k);
                }
            }
        }
    }
    out
}

/// `theta` with only the entries `keep` (and, with `lengths_only`, only
/// the lengths among them).
fn masked(model: &Model, theta: &[f64], keep: &[usize], lengths_only: bool) -> Vec<f64> {
    let mut out = vec![0.0; theta.len()];
    let units = location_units(model);
    for &i in keep {
        if !lengths_only || units[i] == Some(Unit::Um) {
            out[i] = theta[i];
        }
    }
    out
}

/// The unit of each location parameter (None for other effects').
fn location_units(model: &Model) -> Vec<Option<Unit>> {
    let mut out = vec![None; model.n_params()];
    for (i, e) in model.effects.iter().enumerate() {
        if let Effect::Location { symbols } = e {
            let r = model.param_range(i);
            for (k, &s) in symbols.iter().enumerate() {
                out[r.start + k] = Some(model.symbols.location[s].unit);
            }
        }
    }
    out
}

/// The corrected pivot data of `dialect`'s controller for the errors
/// `theta` (with uncertainties `u`) of `model`; `source` names the error
/// file in the header. Refused, with nothing produced, when a change or a
/// `u` of a value to enter is beyond `limits`, a value would drive an axis
/// beyond its stroke, or the file has errors and none reaches a parameter.
pub fn export(
    model: &Model,
    theta: &[f64],
    u: &[Option<f64>],
    dialect: Dialect,
    source: &str,
    limits: &Limits,
) -> Result<Export, ExportError> {
    export_identified(model, theta, u, dialect, source, limits, &[])
}

/// [`export`] of a result whose test did not identify some errors:
/// `not_identified` holds the result file's `not_identifiable` entries
/// (a symbol, or a combination naming symbols, and why). A parameter an
/// unidentified error moves is not written: the control keeps what it
/// holds, and the export says so and why (a value computed without that
/// error would enter the nominal geometry, or a guess, over what the
/// control holds).
pub fn export_identified(
    model: &Model,
    theta: &[f64],
    u: &[Option<f64>],
    dialect: Dialect,
    source: &str,
    limits: &Limits,
    not_identified: &[NotIdentified],
) -> Result<Export, ExportError> {
    let kin = &model.kin;
    let m = kin.machine();
    let keep = held(model);
    let theta_held = masked(model, theta, &keep, false);
    let nominal_geometry = geometry(kin, &Perturbation::zero());
    let params = |p: &Perturbation| {
        controllers::parameters(kin, &geometry(kin, p), &nominal_geometry, dialect)
    };
    // A value to enter holds positions only: it is computed from the
    // position errors alone, so that an error it does not hold (an axis's
    // orientation, listed as not held) never changes a row the operator
    // enters. What is only listed for the machine builder (the directions)
    // comes from every held error.
    let values = |t: &[f64]| -> Result<Vec<Raw>, ExportError> {
        let pos = masked(model, t, &keep, true);
        let entered = params(&model.perturbation(&pos, &Context::default()))?;
        let all = params(&model.perturbation(t, &Context::default()))?;
        Ok(entered
            .into_iter()
            .zip(all)
            .map(|(e, a)| if e.entered { e } else { a })
            .collect())
    };
    let raw = values(&theta_held)?;
    let unidentified = unidentified_parameters(model, &theta_held, &raw, not_identified, &params)?;
    // Each parameter's u: its derivative by every held symbol (central
    // differences of 1 um or 1 urad; the geometry is smooth and nearly
    // linear at this scale), times that symbol's u.
    let mut us: Vec<Option<f64>> = vec![Some(0.0); raw.len()];
    let mut moved = vec![false; raw.len()];
    for &k in &keep {
        let mut plus = theta_held.clone();
        let mut minus = theta_held.clone();
        plus[k] += 1.0;
        minus[k] -= 1.0;
        let (vp, vm) = (values(&plus)?, values(&minus)?);
        for (i, slot) in us.iter_mut().enumerate() {
            let d = 0.5 * (vp[i].value - vm[i].value);
            let tiny = match raw[i].kind {
                Kind::Length => 1e-9,
                Kind::Angle => 1e-6,
            };
            // Moved to first order: 1 um or 1 urad of a symbol moves a
            // length by at least nanometres over the machine's lever
            // arms, an angle by about as much; second-order couplings of
            // the other errors (1e-4 of that) do not count.
            let first_order = match raw[i].kind {
                Kind::Length => 1e-6,
                Kind::Angle => 1e-2,
            };
            moved[i] |= d.abs() > first_order;
            if d.abs() > tiny {
                *slot = match (*slot, u[k]) {
                    (Some(s), Some(uk)) => Some(s + d.abs() * uk),
                    _ => None,
                };
            }
        }
    }
    let current = m.controller_parameters.get(&dialect);
    if let Some(cur) = current {
        for name in cur.keys() {
            if raw.iter().all(|p| &p.name != name) {
                return Err(ExportError::UnknownCurrent {
                    controller: dialect,
                    name: name.clone(),
                    expected: raw
                        .iter()
                        .map(|p| p.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", "),
                });
            }
        }
    }
    let mut parameters: Vec<Parameter> = raw
        .into_iter()
        .zip(us)
        .zip(moved)
        .zip(unidentified)
        .map(|(((r, u), moved), withheld)| {
            let current = current.and_then(|c| c.get(&r.name).copied());
            Parameter {
                // Kept as the control holds it: no change, nothing to
                // limit, nothing written.
                value: if withheld.is_some() {
                    current.unwrap_or(r.nominal)
                } else {
                    r.value
                },
                u: if withheld.is_some() { Some(0.0) } else { u },
                current,
                name: r.name,
                what: r.what,
                kind: r.kind,
                nominal: r.nominal,
                entered: r.entered,
                beyond: None,
                fixed: !moved,
                withheld,
            }
        })
        .collect();
    check_limits(&mut parameters, dialect, limits)?;
    let export = Export {
        dialect,
        from_current: current.is_some_and(|c| !c.is_empty()),
        text: String::new(),
        parameters,
    };
    let theta_pos = masked(model, theta, &keep, true);
    check_strokes(
        kin,
        &model.perturbation(&theta_pos, &Context::default()),
        &export,
    )?;
    let mut not_held = not_held(model, theta, dialect);
    not_held.extend(withheld_lines(&export));
    if dialect == Dialect::Sinumerik {
        let g = geometry(kin, &model.perturbation(&theta_held, &Context::default()));
        not_held.extend(sinumerik::tool_tilt(&g));
    }
    // Errors there are, and none reaches a parameter: an export that
    // enters the nominal values again compensates nothing.
    if export.changes_nothing()
        && export
            .parameters
            .iter()
            .all(|p| p.unchanged() && p.at_nominal())
        && !not_held.is_empty()
    {
        return Err(ExportError::NothingHeld {
            controller: dialect,
            file: source.to_string(),
            not_held: not_held.join("; "),
        });
    }
    let text = controllers::render(m, &export, &not_held, source);
    Ok(Export { text, ..export })
}

/// For each parameter, why it is not written: the names of the errors the
/// test did not identify that move it (to first order, as for its u), with
/// the result file's reason. Only a value to enter is withheld.
fn unidentified_parameters(
    model: &Model,
    theta_held: &[f64],
    raw: &[Raw],
    not_identified: &[NotIdentified],
    params: &dyn Fn(&Perturbation) -> Result<Vec<Raw>, ExportError>,
) -> Result<Vec<Option<String>>, ExportError> {
    let mut out: Vec<Option<String>> = vec![None; raw.len()];
    if not_identified.is_empty() {
        return Ok(out);
    }
    let kin = &model.kin;
    let symbols = SymbolTable::for_kinematics(kin);
    let base = model.perturbation(
        &masked(model, theta_held, &held(model), true),
        &Context::default(),
    );
    for s in symbols.location.iter().filter(|s| s.unit == Unit::Um) {
        let Some(why) = not_identified
            .iter()
            .find(|n| names_symbol(&n.symbol, &s.name))
        else {
            continue;
        };
        // One micrometre of the symbol, in its canonical term.
        let (slot, coef) = s.canonical;
        let mut p = base;
        p.0[slot] += s.unit.scale() / coef;
        let moved = params(&p)?;
        for (i, (a, b)) in raw.iter().zip(&moved).enumerate() {
            if a.entered && (b.value - a.value).abs() > 1e-6 {
                let line = format!("{} (not identified: {})", s.name, why.reason);
                out[i] = Some(match out[i].take() {
                    Some(before) => format!("{before}; {line}"),
                    None => line,
                });
            }
        }
    }
    Ok(out)
}

/// Whether a `not_identifiable` entry (a symbol, or a combination such as
/// `EX0B + EZ0B`) names the symbol `name`.
fn names_symbol(entry: &str, name: &str) -> bool {
    entry
        .split(|c: char| c.is_whitespace() || matches!(c, '+' | '-' | '*' | ',' | '='))
        .any(|word| word == name)
}

/// The lines of the not-held list for the parameters kept as the control
/// holds them.
fn withheld_lines(export: &Export) -> Vec<String> {
    export
        .parameters
        .iter()
        .filter_map(|p| {
            p.withheld.as_ref().map(|why| {
                format!(
                    "{}: keep what the control holds (not written): it depends on {why}",
                    p.name
                )
            })
        })
        .collect()
}

/// Refuses the first entered parameter beyond `limits` (a change first,
/// then a u); a listed one is marked with the limit it is beyond.
fn check_limits(
    parameters: &mut [Parameter],
    dialect: Dialect,
    limits: &Limits,
) -> Result<(), ExportError> {
    let too_large = |p: &Parameter| {
        let from = match p.current {
            Some(c) => format!("the control's current {} {}", p.written(c), unit_of(p.kind)),
            None => format!("the nominal {} {}", p.written(p.nominal), unit_of(p.kind)),
        };
        let lim = limits.change(p.kind);
        (p.change().abs() > lim).then(|| ExportError::TooLarge {
            controller: dialect,
            name: p.name.clone(),
            what: p.what.clone(),
            change: format!("{} {}", signed(p.small(p.change()), 2), p.small_unit()),
            from,
            limit: limit_text(p.kind, lim),
        })
    };
    let uncertain = |p: &Parameter| {
        let lim = limits.u(p.kind);
        p.u.filter(|&u| u > lim).map(|u| ExportError::Uncertain {
            controller: dialect,
            name: p.name.clone(),
            what: p.what.clone(),
            u: format!("{:.2} {}", p.small(u), p.small_unit()),
            limit: limit_text(p.kind, lim),
        })
    };
    for check in [
        &too_large as &dyn Fn(&Parameter) -> Option<ExportError>,
        &uncertain,
    ] {
        for p in parameters.iter_mut() {
            match check(p) {
                Some(e) if p.entered => return Err(e),
                Some(ExportError::TooLarge { change, limit, .. }) => {
                    p.beyond
                        .get_or_insert(format!("change {change} beyond --max-change {limit}"));
                }
                Some(ExportError::Uncertain { u, limit, .. }) => {
                    p.beyond
                        .get_or_insert(format!("u {u} beyond --max-u {limit}"));
                }
                _ => {}
            }
        }
    }
    Ok(())
}

fn unit_of(kind: Kind) -> &'static str {
    match kind {
        Kind::Length => "mm",
        Kind::Angle => "urad",
    }
}

/// The poses the stroke check visits: the tilt at its limits and at zero,
/// C at the quarter turns inside its limits (or its own limits).
fn check_poses(m: &Machine) -> Vec<(f64, f64)> {
    let mut tilts = vec![0.0];
    if let Some((lo, hi)) = m.tilt.limits {
        tilts.extend([lo, hi]);
    }
    let mut cs: Vec<f64> = [0.0, 90.0, 180.0, 270.0, -90.0, -180.0]
        .into_iter()
        .filter(|&c| m.c.within(c, 0.0))
        .collect();
    if let Some((lo, hi)) = m.c.limits {
        cs.extend([lo, hi]);
    }
    tilts
        .iter()
        .filter(|&&t| m.tilt.within(t, 0.0))
        .flat_map(|&t| cs.iter().map(move |&c| (t, c)))
        .collect()
}

/// The control, with the exported positions (its kinematics holds the
/// positions of the axis lines, their directions nominal), brings the tool
/// tip to the W origin at every corner of the rotary range: the linear axes
/// must stay inside the strokes wherever they do nominally.
fn check_strokes(
    kin: &Kinematics,
    held: &Perturbation,
    export: &Export,
) -> Result<(), ExportError> {
    let m = kin.machine();
    for (tilt, c) in check_poses(m) {
        let start = Axes::new(0.0, 0.0, 0.0, tilt, c);
        let target = ToolPose {
            tip: nalgebra::Vector3::zeros(),
            axis: kin.forward_nominal(&start).axis,
        };
        let Ok(nominal) = kin.inverse_nominal(&target, Some(&start)) else {
            continue;
        };
        // Machine coordinates are those of the spindle gauge point.
        let gauge = |a: &Axes| a.xyz + nalgebra::Vector3::z() * kin.gauge_length();
        if m.check_strokes(&gauge(&nominal)).is_err() {
            // Out of reach already on the nominal machine: not a pose the
            // machine is used at.
            continue;
        }
        let Ok(actual) = kin.inverse(&target, Some(&nominal), |_| *held) else {
            continue;
        };
        if let Err((axis, value, (lo, hi))) = m.check_strokes(&gauge(&actual)) {
            let i = ['X', 'Y', 'Z'].iter().position(|&a| a == axis).unwrap_or(0);
            return Err(ExportError::Stroke {
                axis,
                value,
                nominal: gauge(&nominal)[i] + m.pivot[i],
                lo,
                hi,
                tilt_letter: m.tilt.letter,
                tilt,
                c,
                changed: export.changed().join(", "),
            });
        }
    }
    Ok(())
}

/// What the error file holds, not zero, that no parameter of `dialect`
/// holds: the zero points and the orientations of the axes (HEIDENHAIN
/// and SINUMERIK list the directions for the machine builder, entered
/// nowhere), maps, drift, linear-axis, tool and probe errors.
fn not_held(model: &Model, theta: &[f64], dialect: Dialect) -> Vec<String> {
    let mut out = Vec::new();
    let sym = &model.symbols;
    for (i, e) in model.effects.iter().enumerate() {
        let r = model.param_range(i);
        if theta[r.clone()].iter().all(|&v| v == 0.0) {
            continue;
        }
        match e {
            Effect::Location { symbols } => {
                for (k, &s) in symbols.iter().enumerate() {
                    let ls = &sym.location[s];
                    let v = theta[r.start + k];
                    if ls.unit != Unit::Urad || v == 0.0 {
                        continue;
                    }
                    if ls.is_zero_point() {
                        out.push(format!(
                            "{} = {v:.2} urad ({}): where the axis reads zero, set at the axis (its reference offset), not in the kinematics",
                            ls.name, ls.description
                        ));
                    } else {
                        // No target enters an orientation: HEIDENHAIN and
                        // SINUMERIK list the directions for the machine
                        // builder, which holds nothing at the control.
                        let listed = match dialect {
                            Dialect::Heidenhain => "; in the directions listed for the machine builder, not entered",
                            Dialect::Sinumerik if ls.canonical.0 / 6 < 2 => {
                                "; in the directions v1, v2 listed for the machine builder, not entered"
                            }
                            _ => "",
                        };
                        out.push(format!(
                            "{} = {v:.2} urad ({}{listed})",
                            ls.name, ls.description
                        ));
                    }
                }
            }
            other => out.push(format!(
                "{}: {}",
                other.id(sym),
                match other {
                    Effect::Map { .. } => {
                        "an error map over the rotary angles (not even its value at rotary zero is in the parameters)"
                    }
                    Effect::Drift { .. } => "a thermal drift",
                    Effect::Scale { .. }
                    | Effect::Squareness { .. }
                    | Effect::Straightness { .. }
                    | Effect::Positioning { .. }
                    | Effect::Angular { .. } => {
                        "a linear-axis error (the controller's pitch and straightness compensation holds it, not the pivot data)"
                    }
                    Effect::ToolLength => "a tool length error (the tool table holds it)",
                    Effect::ToolRadius => "a tool radius error (the tool table holds it)",
                    Effect::ProbePretravel => "a probing effect",
                    // The arms above the match take these.
                    Effect::Location { .. } => "a location error",
                }
            )),
        }
    }
    out
}

/// The values listed for the machine builder (not entered), a comment
/// line each: value and u in urad, what it is, the limit it is beyond.
fn listed_lines(s: &mut String, export: &Export, comment: &str) {
    for p in export.parameters.iter().filter(|p| !p.entered) {
        let _ = writeln!(
            s,
            "{comment}   {} = {}, {}  ({}){}",
            p.name,
            signed(p.value, 2),
            if p.fixed {
                "fixed: no error held here moves it".to_string()
            } else {
                format!("u {}", p.u_text())
            },
            p.what,
            p.beyond
                .as_ref()
                .map_or_else(String::new, |b| format!(": {b}, not to be entered"))
        );
    }
}

/// What no parameter holds, a comment line each (`(nothing)` for none).
fn not_held_lines(s: &mut String, not_held: &[String], comment: &str) {
    if not_held.is_empty() {
        let _ = writeln!(s, "{comment}   (nothing)");
    }
    for b in not_held {
        let _ = writeln!(s, "{comment}   {b}");
    }
}

/// The header lines every target starts with, after `comment`.
fn header(m: &Machine, export: &Export, title: &str, source: &str, comment: &str) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "{comment} {title}");
    let _ = writeln!(
        s,
        "{comment} meanings and public sources of every value: docs/controllers.md (fivecal)"
    );
    let _ = writeln!(
        s,
        "{comment} machine {} ({}), errors from {source}",
        m.name, m.structure
    );
    let _ = writeln!(
        s,
        "{comment} lengths in mm, machine coordinates of the machine file (nominal pivot X {}  Y {}  Z {})",
        signed(m.pivot.x, 4),
        signed(m.pivot.y, 4),
        signed(m.pivot.z, 4)
    );
    let _ = writeln!(
        s,
        "{comment} u: standard uncertainty (k = 1) from the error file's u; a value made of several symbols adds their parts"
    );
    let _ = writeln!(
        s,
        "{comment}   (the file holds no correlations: an upper bound); `not given` where the file has no u"
    );
    if export.from_current {
        let _ = writeln!(
            s,
            "{comment} change: from what the control holds now (the machine file's controller_parameters.{})",
            export.dialect
        );
    } else {
        let _ = writeln!(
            s,
            "{comment} change: from the machine file's nominal geometry (the machine file has no controller_parameters.{}:",
            export.dialect
        );
        let _ = writeln!(s, "{comment}   it does not say what the control holds now)");
    }
    let _ = writeln!(s, "{comment}");
    for line in export.table() {
        let _ = writeln!(s, "{comment}   {line}");
    }
    let _ = writeln!(s, "{comment}");
    s
}

/// How far the readout that puts the tool tip on a given point moves at
/// rotary zero when the entered values replace what the control held, mm,
/// machine axes: what a work offset (or preset) probed before entering is
/// off by. Only a head's tool-side values move it: at rotary zero a table's
/// rows place the table where it was, and the SINUMERIK record and the
/// LinuxCNC pins change nothing there.
fn zero_shift(m: &Machine, export: &Export) -> nalgebra::Vector3<f64> {
    let mut out = nalgebra::Vector3::zeros();
    if m.structure == Structure::TableTable {
        return out;
    }
    for p in export
        .parameters
        .iter()
        .filter(|p| p.entered && p.withheld.is_none())
    {
        let axis = match export.dialect {
            // D -> E (19709-19711) and E -> F (19712-19714).
            Dialect::Fanuc => p
                .name
                .parse::<u32>()
                .ok()
                .filter(|n| (19709..=19714).contains(n))
                .map(|n| ((n - 19709) % 3) as usize),
            // Tool reference point -> head axis, and the C head's rows on a
            // head-head; the C table's rows of a head-table are table side.
            Dialect::Heidenhain => {
                let table_c = m.structure == Structure::HeadTable && p.name.starts_with("C.");
                (!table_c)
                    .then(|| ['X', 'Y', 'Z'].iter().position(|&c| p.name.ends_with(c)))
                    .flatten()
            }
            Dialect::Linuxcnc | Dialect::Sinumerik => None,
        };
        if let Some(i) = axis {
            out[i] += p.change();
        }
    }
    out
}

/// What to do after entering: the convention assumed, which work offsets
/// move and by how much at rotary zero, and the check that confirms it.
fn after_entering(m: &Machine, export: &Export, c: &str) -> String {
    let t = m.tilt.letter;
    let convention = match (export.dialect, m.structure) {
        (Dialect::Fanuc, Structure::TableTable) => format!(
            "19680 = 12 ({t} master, C slave); the controlled point is the tool tip plus the tool length offset"
        ),
        (Dialect::Fanuc, _) => format!(
            "the controlled point lies on the head's rotary axis (the manual's convention): the readout\n{c}     refers to a point {:.4} mm (the pivot length, 19666) above the spindle gauge point",
            m.pivot_length
        ),
        (Dialect::Heidenhain, _) => {
            "each Trans row is the step from the element before it to the one after it, in the order of\n{c}     the description from the tool reference point (table-side rows: to be confirmed, above)".replace("{c}", c)
        }
        (Dialect::Linuxcnc, _) => {
            "trt-kins with the tool length on its tool-offset pin; the joints are the spindle gauge point".to_string()
        }
        (Dialect::Sinumerik, _) => {
            "the record type and axis order stated above, chains closed as [IM9] describes them".to_string()
        }
    };
    let shift = zero_shift(m, export) * 1e3;
    let mut s = String::new();
    let _ = writeln!(s, "{c}");
    let _ = writeln!(s, "{c} After entering:");
    let _ = writeln!(s, "{c}   convention assumed: {convention}");
    if shift.norm() < 0.005 {
        let _ = writeln!(
            s,
            "{c}   work offsets: nothing moves at rotary zero; work offsets and presets probed before entering stay valid"
        );
    } else {
        let _ = writeln!(
            s,
            "{c}   work offsets: at rotary zero the readout that puts the tool tip on a point moves by X {} Y {} Z {} um:",
            signed(shift.x, 2),
            signed(shift.y, 2),
            signed(shift.z, 2)
        );
        let _ = writeln!(
            s,
            "{c}     every work offset (and preset) probed before entering is off by that; probe them again (or add it)"
        );
    }
    let _ = writeln!(
        s,
        "{c}   check: probe a short test planned by `fivecal plan`, analyze it, and `fivecal verify` it against this"
    );
    let _ = writeln!(
        s,
        "{c}     result: the errors held here must come out zero within their u"
    );
    s
}

#[cfg(test)]
mod tests;
