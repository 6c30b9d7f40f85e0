//! The YAML form of a machine file and its validation into [`Machine`].

use std::collections::BTreeMap;
use std::path::Path;

use indexmap::IndexMap;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use super::acceptance::AcceptanceLimits;
use super::{
    Dialect, MCodes, Machine, Probe, Rapid, RotaryAxis, Structure, Table, Tool, ToolChange,
    ToolKind,
};
use crate::geom::Axis3;
use crate::limits::{
    MAX_MACHINE_MM, MAX_PLAN_MM, MIN_PLAN_MM, RAPID_LINEAR_MM_PER_MIN, RAPID_ROTARY_DEG_PER_MIN,
};
use crate::numbers::echo;
use crate::source::SourceError;

/// A machine file as written (see `examples/machines/*.yaml`).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MachineFile {
    /// Short name.
    pub name: String,
    /// One line on what it is.
    #[serde(default)]
    pub description: String,
    /// `table-table`, `head-table` or `head-head`.
    pub structure: Structure,
    /// Kinematic chain from workpiece to tool (`F` = frame/bed), e.g. `CBYFXZ`.
    pub chain: String,
    /// Default dialect.
    pub controller: Dialect,
    /// Strokes of X, Y, Z (machine coordinates of the spindle gauge point), mm.
    pub linear_axes: BTreeMap<String, [f64; 2]>,
    /// The tilt axis and C: limits (deg, `null` for continuous) and direction.
    pub rotary_axes: BTreeMap<String, RotaryAxisFile>,
    /// Machine coordinates of the W origin, mm.
    pub pivot: [f64; 3],
    /// Head machines: rotation centre to spindle gauge line, mm.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub head: Option<HeadFile>,
    /// Table geometry.
    pub table: Table,
    /// Default tool.
    pub tool: Tool,
    /// Default probe.
    pub probe: Probe,
    /// Rapid rates.
    #[serde(default)]
    pub rapid: Rapid,
    /// Acceptance limits per location symbol (um / urad), optional.
    #[serde(default, skip_serializing_if = "AcceptanceLimits::is_empty")]
    pub limits: AcceptanceLimits,
    /// What the control holds now, per export target and parameter name
    /// (mm for lengths, urad for angles), optional.
    #[serde(default, skip_serializing_if = "IndexMap::is_empty")]
    pub controller_parameters: ControllerParameters,
    /// The control's own M functions, optional.
    #[serde(default, skip_serializing_if = "MCodesFile::is_empty")]
    pub m_codes: MCodesFile,
    /// How a FANUC control reads an axis word without a decimal point,
    /// optional (`compensate --integer-unit` overrides it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub integer_unit: Option<IntegerUnit>,
    /// The axes a tool change may move, optional (default: the linear
    /// axes and the head's rotary axes, none of the table's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tool_change: Option<ToolChangeFile>,
    /// Where a SINUMERIK control holds this machine's kinematics,
    /// optional (`compensate --export sinumerik` needs it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sinumerik: Option<SinumerikFile>,
}

/// Where a SINUMERIK control holds the machine's kinematics: the number of
/// its swivel data record (orientable toolholder, `$TC_CARR..[n]`, the
/// `TCARR=n` a program selects and CYCLE996 measures).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SinumerikFile {
    /// The swivel data record number, 1 or more.
    pub swivel_record: u32,
}

/// How a FANUC control reads `X100` (no decimal point): parameter 3401#0
/// (DPI) set, in mm as a calculator does; else in least input increments
/// of its increment system, 1 um (IS-B) or 0.1 um (IS-C).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum IntegerUnit {
    /// Calculator-type input: `X100` is 100 mm.
    #[serde(rename = "mm")]
    Mm,
    /// IS-B: `X100` is 0.1 mm.
    #[serde(rename = "um")]
    Um,
    /// IS-C: `X100` is 0.01 mm.
    #[serde(rename = "0.1um")]
    TenthUm,
}

impl IntegerUnit {
    /// Millimetres per unit.
    pub fn mm(self) -> f64 {
        match self {
            IntegerUnit::Mm => 1.0,
            IntegerUnit::Um => 1e-3,
            IntegerUnit::TenthUm => 1e-4,
        }
    }
}

/// `tool_change:` as written: `{moves: [X, Y, Z, B]}`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ToolChangeFile {
    /// The axes the machine builder's tool change sequence may move.
    pub moves: Vec<String>,
}

/// `tool_change:` validated: each entry X, Y, Z or one of the machine's
/// rotary axes, none twice; absent, the default for the structure.
fn tool_change(
    f: &MachineFile,
    structure: Structure,
    tilt: char,
    err: KeyError<'_>,
) -> Result<ToolChange, SourceError> {
    let Some(t) = &f.tool_change else {
        return Ok(ToolChange::default_for(structure, tilt));
    };
    let mut moves = Vec::new();
    for item in &t.moves {
        let a = item.trim().to_ascii_uppercase();
        let letter = match a.as_bytes() {
            [c] if b"XYZ".contains(c) || *c as char == tilt || *c == b'C' => *c as char,
            _ => {
                return Err(err(
                    &["tool_change", "moves"],
                    format!(
                        "`{}` is not an axis of this machine: expected X, Y, Z, {tilt} or C",
                        item.trim()
                    ),
                ));
            }
        };
        if moves.contains(&letter) {
            return Err(err(
                &["tool_change", "moves"],
                format!("{letter} is listed twice"),
            ));
        }
        moves.push(letter);
    }
    Ok(ToolChange {
        moves,
        stated: true,
    })
}

/// The M functions a control has beyond its dialect's standard ones, as
/// written (`M428`).
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MCodesFile {
    /// Switch tool-centre-point control on (LinuxCNC remaps such as M428).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub tcp_on: Vec<String>,
    /// Switch it off.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub tcp_off: Vec<String>,
    /// Further M functions of the machine that move no axis (clamps,
    /// conveyors, doors): known, so that `compensate --strict` accepts them.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub known: Vec<String>,
}

impl MCodesFile {
    fn is_empty(&self) -> bool {
        self.tcp_on.is_empty() && self.tcp_off.is_empty() && self.known.is_empty()
    }
}

/// `m_codes:` validated: each entry `M` and a whole number, none in two
/// lists.
fn m_codes(f: &MCodesFile, err: KeyError<'_>) -> Result<MCodes, SourceError> {
    let mut seen: BTreeMap<u32, &str> = BTreeMap::new();
    let mut list = |key: &'static str, items: &[String]| -> Result<Vec<u32>, SourceError> {
        let mut out = Vec::new();
        for item in items {
            let at = |msg: String| err(&["m_codes", key], msg);
            let t = item.trim();
            let n = t
                .strip_prefix(['M', 'm'])
                .filter(|d| !d.is_empty() && d.len() <= 5 && d.bytes().all(|b| b.is_ascii_digit()))
                .and_then(|d| d.parse::<u32>().ok())
                .ok_or_else(|| {
                    at(format!(
                        "`{t}` is not an M function: expected M and a whole number, e.g. M428"
                    ))
                })?;
            if let Some(other) = seen.insert(n, key) {
                return Err(at(format!(
                    "M{n} is listed under both `{other}` and `{key}`"
                )));
            }
            out.push(n);
        }
        Ok(out)
    };
    Ok(MCodes {
        tcp_on: list("tcp_on", &f.tcp_on)?,
        tcp_off: list("tcp_off", &f.tcp_off)?,
        known: list("known", &f.known)?,
    })
}

/// The values a control holds now: per controller, per parameter name as
/// `compensate --export` writes it (`19700`, `x-rot-point`, `B.X`).
pub type ControllerParameters = IndexMap<Dialect, IndexMap<String, f64>>;

/// A rotary axis as written.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RotaryAxisFile {
    /// `[min, max]` in degrees, or `null` for a continuous axis.
    pub limits: Option<[f64; 2]>,
    /// +1 (convention of docs/model.md) or -1.
    #[serde(default = "one")]
    pub direction: i32,
}

fn one() -> i32 {
    1
}

/// Head data as written.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HeadFile {
    /// Rotation centre to spindle gauge line along the tool axis, mm.
    pub pivot_length: f64,
}

/// How a located error of the file is made: the keys it concerns and the message.
type KeyError<'a> = &'a dyn Fn(&[&str], String) -> SourceError;

pub(super) fn parse(path: &Path, src: &str) -> Result<Machine, SourceError> {
    let f: MachineFile = crate::input::parse_yaml(path, src)?;
    let err = |keys: &[&str], msg: String| SourceError::at_key(path, src, keys, msg);

    let strokes = strokes(&f, &err)?;
    let chain = Chain::parse(&f, &err)?;
    let (tilt, c) = rotary_axes(&f, &chain, &err)?;
    let pivot_length = pivot_length(&f, chain.structure, &err)?;
    check_numbers(&f, pivot_length, &err)?;
    // At rotary zero the spindle stands over the W origin to start every
    // test: a pivot beyond the X or Y stroke is a typing or sign mistake
    // that every later message would blame on something else. (Z is not
    // checked: the tool's length, not the gauge point, reaches down.)
    for (i, l) in ["X", "Y"].iter().enumerate() {
        let (lo, hi) = strokes[i];
        let v = f.pivot[i];
        if v.is_finite() && !(lo..=hi).contains(&v) {
            return Err(err(
                &["pivot"],
                format!(
                    "pivot {l} {} mm is outside the {l} stroke [{}, {}] of linear_axes: the spindle can never stand over the W origin; check the pivot's sign and the stroke",
                    crate::numbers::echo(v),
                    crate::numbers::echo(lo),
                    crate::numbers::echo(hi)
                ),
            ));
        }
    }

    // Every output is labelled with this name, and the history keys its
    // results on it: a blank one would file them under nobody.
    if f.name.trim().is_empty() || f.name.chars().any(char::is_control) {
        return Err(err(
            &["name"],
            "machine name is empty or has control characters: expected a short name such as my-dmu-50".to_string(),
        ));
    }
    let m_codes = m_codes(&f.m_codes, &err)?;
    let tool_change = tool_change(&f, chain.structure, tilt.letter, &err)?;
    if let Some(sk) = f.sinumerik
        && sk.swivel_record == 0
    {
        return Err(err(
            &["sinumerik", "swivel_record"],
            "swivel_record 0 deselects the swivel data record (TCARR=0): expected the record's number, 1 or more".to_string(),
        ));
    }
    Ok(Machine {
        name: f.name,
        description: f.description,
        structure: chain.structure,
        chain: chain.text,
        dialect: f.controller,
        strokes,
        tilt,
        c,
        pivot: Vector3::from(f.pivot),
        pivot_length,
        table: f.table,
        tool: f.tool,
        probe: f.probe,
        rapid: f.rapid,
        limits: f.limits,
        controller_parameters: f.controller_parameters,
        m_codes,
        integer_unit: f.integer_unit,
        tool_change,
        sinumerik: f.sinumerik,
        source: src.to_string(),
    })
}

/// `linear_axes:` validated: the strokes of exactly X, Y, Z, each with
/// min < max.
fn strokes(f: &MachineFile, err: KeyError<'_>) -> Result<[(f64, f64); 3], SourceError> {
    let mut strokes = [(0.0, 0.0); 3];
    for (k, v) in &f.linear_axes {
        let i = match k.as_str() {
            "X" => 0,
            "Y" => 1,
            "Z" => 2,
            _ => {
                return Err(err(
                    &["linear_axes", k],
                    format!("unknown linear axis `{k}`: expected X, Y and Z"),
                ));
            }
        };
        if !(v[0].is_finite() && v[1].is_finite() && v[0] < v[1]) {
            return Err(err(
                &["linear_axes", k],
                format!(
                    "stroke of {k} must be [min, max] with min < max, got [{}, {}]",
                    v[0], v[1]
                ),
            ));
        }
        strokes[i] = (v[0], v[1]);
    }
    for l in ["X", "Y", "Z"] {
        if !f.linear_axes.contains_key(l) {
            return Err(err(
                &["linear_axes"],
                format!("linear axis {l} is missing: expected X, Y and Z"),
            ));
        }
    }
    Ok(strokes)
}

/// `chain:` validated: the six letters from workpiece to tool, and the
/// structure they describe.
struct Chain {
    /// The chain as the machine keeps it (trimmed, upper case).
    text: String,
    letters: Vec<char>,
    /// `A` or `B`.
    tilt_letter: char,
    structure: Structure,
    /// Where the machine frame `F` sits in the chain.
    f_pos: usize,
}

impl Chain {
    /// Reads the chain, refusing one that is not F, X, Y, Z, C and one tilt
    /// axis, that disagrees with `structure:`, or whose rotary axes sit in an
    /// order docs/model.md does not describe.
    fn parse(f: &MachineFile, err: KeyError<'_>) -> Result<Chain, SourceError> {
        let chain = f.chain.trim().to_ascii_uppercase();
        let letters: Vec<char> = chain.chars().collect();
        let count = |c: char| letters.iter().filter(|&&x| x == c).count();
        let tilt_letter = match (count('A'), count('B')) {
            (1, 0) => 'A',
            (0, 1) => 'B',
            _ => {
                return Err(err(
                    &["chain"],
                    format!(
                        "chain `{chain}` must contain exactly one tilt axis (A or B) and one C"
                    ),
                ));
            }
        };
        for c in ['F', 'X', 'Y', 'Z', 'C'] {
            if count(c) != 1 {
                return Err(err(
                    &["chain"],
                    format!(
                        "chain `{chain}` must contain {c} exactly once (letters from workpiece to tool, F = machine frame)"
                    ),
                ));
            }
        }
        if letters.len() != 6 {
            return Err(err(
                &["chain"],
                format!(
                    "chain `{chain}` has unexpected letters: expected the six letters F, X, Y, Z, C and A or B"
                ),
            ));
        }
        let pos = |c: char| letters.iter().position(|&x| x == c).unwrap();
        let f_pos = pos('F');
        let (t_pos, c_pos) = (pos(tilt_letter), pos('C'));
        let derived = match (t_pos < f_pos, c_pos < f_pos) {
            (true, true) => Structure::TableTable,
            (false, true) => Structure::HeadTable,
            (false, false) => Structure::HeadHead,
            (true, false) => {
                return Err(err(
                    &["chain"],
                    format!("chain `{chain}`: a tilting table under a C head is not supported"),
                ));
            }
        };
        if derived != f.structure {
            return Err(err(
                &["structure"],
                format!(
                    "structure `{}` does not match chain `{chain}`, which describes a {derived} machine",
                    f.structure
                ),
            ));
        }
        // C must carry the tilt in head-head machines, and sit on the tilt in
        // table-table machines (the order of docs/model.md).
        match derived {
            Structure::TableTable if c_pos > t_pos => {
                return Err(err(
                    &["chain"],
                    format!(
                        "chain `{chain}`: the C table must sit on the tilt axis (C before {tilt_letter})"
                    ),
                ));
            }
            Structure::HeadHead if c_pos > t_pos => {
                return Err(err(
                    &["chain"],
                    format!(
                        "chain `{chain}`: the tilt head must sit on the C head (C before {tilt_letter})"
                    ),
                ));
            }
            _ => {}
        }
        Ok(Chain {
            text: chain,
            letters,
            tilt_letter,
            structure: derived,
            f_pos,
        })
    }

    /// Where `c` sits in the chain.
    fn pos(&self, c: char) -> usize {
        self.letters.iter().position(|&x| x == c).unwrap()
    }

    /// The parent of the axis at `p`: its neighbour towards F.
    fn parent(&self, p: usize) -> char {
        if p < self.f_pos {
            self.letters[p + 1]
        } else {
            self.letters[p - 1]
        }
    }
}

/// `rotary_axes:` validated against the chain: the tilt axis (with limits)
/// and C, each with its direction and place in the chain.
fn rotary_axes(
    f: &MachineFile,
    chain: &Chain,
    err: KeyError<'_>,
) -> Result<(RotaryAxis, RotaryAxis), SourceError> {
    let tilt_letter = chain.tilt_letter;
    let mut tilt = None;
    let mut c_axis = None;
    for (k, v) in &f.rotary_axes {
        let letter = match k.as_str() {
            "A" | "B" | "C" => k.chars().next().unwrap(),
            _ => {
                return Err(err(
                    &["rotary_axes", k],
                    format!("unknown rotary axis `{k}`: expected {tilt_letter} and C"),
                ));
            }
        };
        if letter != 'C' && letter != tilt_letter {
            return Err(err(
                &["rotary_axes", k],
                format!(
                    "rotary axis {k} is not in chain `{}` (expected {tilt_letter} and C)",
                    chain.text
                ),
            ));
        }
        if v.direction != 1 && v.direction != -1 {
            return Err(err(
                &["rotary_axes", k, "direction"],
                format!("direction of {k} must be 1 or -1, got {}", v.direction),
            ));
        }
        let limits = match v.limits {
            None => None,
            Some([lo, hi]) => {
                if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                    return Err(err(
                        &["rotary_axes", k, "limits"],
                        format!(
                            "limits of {k} must be [min, max] in degrees with min < max, got [{lo}, {hi}]"
                        ),
                    ));
                }
                Some((lo, hi))
            }
        };
        if letter != 'C' && limits.is_none() {
            return Err(err(
                &["rotary_axes", k, "limits"],
                format!("the tilt axis {k} needs limits [min, max] in degrees"),
            ));
        }
        let p = chain.pos(letter);
        let axis = RotaryAxis {
            letter,
            about: match letter {
                'A' => Axis3::X,
                'B' => Axis3::Y,
                _ => Axis3::Z,
            },
            on_table: p < chain.f_pos,
            direction: v.direction as f64,
            limits,
            parent: chain.parent(p),
        };
        if letter == 'C' {
            c_axis = Some(axis);
        } else {
            tilt = Some(axis);
        }
    }
    let tilt = tilt.ok_or_else(|| {
        err(
            &["rotary_axes"],
            format!("rotary axis {tilt_letter} is missing"),
        )
    })?;
    let c = c_axis.ok_or_else(|| err(&["rotary_axes"], "rotary axis C is missing".to_string()))?;
    Ok((tilt, c))
}

/// `head:` validated against the structure: the head's pivot length (0 for
/// a table-table machine, which has no head).
fn pivot_length(
    f: &MachineFile,
    derived: Structure,
    err: KeyError<'_>,
) -> Result<f64, SourceError> {
    Ok(match (derived, &f.head) {
        (Structure::TableTable, Some(_)) => {
            return Err(err(
                &["head"],
                "a table-table machine has no head: remove `head`".to_string(),
            ));
        }
        (Structure::TableTable, None) => 0.0,
        (_, None) => {
            return Err(err(
                &["structure"],
                format!(
                    "a {derived} machine needs `head: {{pivot_length: ...}}` (rotation centre to spindle gauge line, mm)"
                ),
            ));
        }
        (_, Some(h)) => {
            if !(h.pivot_length.is_finite() && h.pivot_length >= 0.0) {
                return Err(err(
                    &["head", "pivot_length"],
                    format!(
                        "pivot_length must be a length >= 0 mm, got {}",
                        h.pivot_length
                    ),
                ));
            }
            h.pivot_length
        }
    })
}

/// The file's numbers checked: pivot, table, tool, probe and rapid rates in
/// range, controller parameters a control's, and no length beyond a
/// machine tool's (a unit mistake).
fn check_numbers(f: &MachineFile, pivot_length: f64, err: KeyError<'_>) -> Result<(), SourceError> {
    if f.pivot.iter().any(|v| !v.is_finite()) {
        return Err(err(
            &["pivot"],
            "pivot must be three finite numbers (mm)".to_string(),
        ));
    }
    if !(f.table.radius.is_finite() && f.table.radius > 0.0 && f.table.surface.is_finite()) {
        return Err(err(
            &["table"],
            "table needs a finite surface (mm) and a radius > 0 (mm)".to_string(),
        ));
    }
    check_tool(&f.tool).map_err(|(k, m)| err(&["tool", k], m))?;
    check_tool_id(f.probe.id.as_deref()).map_err(|m| err(&["probe", "id"], m))?;
    for (k, v) in [
        ("ball_diameter", f.probe.ball_diameter),
        ("length", f.probe.length),
    ] {
        if !(v.is_finite() && v > 0.0) {
            return Err(err(
                &["probe", k],
                format!("probe {k} must be > 0 mm, got {}", echo(v)),
            ));
        }
    }
    for (k, v, (lo, hi), unit) in [
        ("linear", f.rapid.linear, RAPID_LINEAR_MM_PER_MIN, "mm/min"),
        (
            "rotary",
            f.rapid.rotary,
            RAPID_ROTARY_DEG_PER_MIN,
            "deg/min",
        ),
    ] {
        if !(v.is_finite() && (lo..=hi).contains(&v)) {
            return Err(err(
                &["rapid", k],
                format!(
                    "rapid {k} rate {} {unit} is not a machine's: expected {lo} to {hi} {unit}",
                    echo(v)
                ),
            ));
        }
    }
    // Lengths beyond 100 m are a unit mistake (um for mm), and would make
    // every later check (stock on the table, strokes) blame the wrong key.
    let mut lengths: Vec<(Vec<&str>, f64)> = Vec::new();
    for (k, v) in &f.linear_axes {
        lengths.push((vec!["linear_axes", k.as_str()], v[0]));
        lengths.push((vec!["linear_axes", k.as_str()], v[1]));
    }
    for v in f.pivot {
        lengths.push((vec!["pivot"], v));
    }
    lengths.push((vec!["table", "surface"], f.table.surface));
    lengths.push((vec!["table", "radius"], f.table.radius));
    lengths.push((vec!["head", "pivot_length"], pivot_length));
    lengths.push((vec!["tool", "diameter"], f.tool.diameter));
    lengths.push((vec!["tool", "length"], f.tool.length));
    lengths.push((vec!["probe", "ball_diameter"], f.probe.ball_diameter));
    lengths.push((vec!["probe", "length"], f.probe.length));
    for (d, values) in &f.controller_parameters {
        for (k, v) in values {
            if !(v.is_finite() && v.abs() <= MAX_MACHINE_MM) {
                return Err(err(
                    &["controller_parameters", d.name(), k],
                    format!(
                        "{d} parameter {k} = {v:e} is not a control's value: expected mm (lengths) or urad (angles), at most {MAX_MACHINE_MM} in size"
                    ),
                ));
            }
        }
    }
    for (keys, v) in lengths {
        if v.abs() > MAX_MACHINE_MM {
            return Err(err(
                &keys,
                format!(
                    "{} {} mm is beyond any machine tool (at most {MAX_MACHINE_MM} mm): is it in um?",
                    keys.join("."),
                    echo(v)
                ),
            ));
        }
    }
    Ok(())
}

/// Checks a tool's numbers; returns the offending key and a message.
pub fn check_tool(t: &Tool) -> Result<(), (&'static str, String)> {
    // From what a control resolves to what a test piece needs: a diameter
    // of 1e-9 mm or 1e300 mm would make a toolpath without end.
    let (lo, hi) = (MIN_PLAN_MM, MAX_PLAN_MM);
    for (key, v) in [("diameter", t.diameter), ("length", t.length)] {
        if !(v.is_finite() && (lo..=hi).contains(&v)) {
            return Err((
                key,
                format!(
                    "tool {key} must be between {lo} and {hi} mm, got {}",
                    echo(v)
                ),
            ));
        }
    }
    match (t.kind, t.corner_radius) {
        (ToolKind::Bull, None) => {
            return Err((
                "corner_radius",
                "a bull-nose tool needs corner_radius (mm)".to_string(),
            ));
        }
        (ToolKind::Bull, Some(r)) if !(r > 0.0 && r < t.diameter / 2.0) => {
            return Err((
                "corner_radius",
                format!(
                    "corner_radius must be between 0 and half the diameter ({} mm), got {r}",
                    t.diameter / 2.0
                ),
            ));
        }
        _ => {}
    }
    check_tool_id(t.id.as_deref()).map_err(|m| ("id", m))
}

/// Checks a tool-list name: what every control that calls tools by name
/// accepts (SINUMERIK: up to 32 characters between double quotes; a
/// HEIDENHAIN tool name up to 32), so a program never calls a tool its
/// control cannot find by that spelling.
pub(super) fn check_tool_id(id: Option<&str>) -> Result<(), String> {
    let Some(id) = id else { return Ok(()) };
    const MAX: usize = 32;
    if id.is_empty() || id.len() > MAX {
        return Err(format!(
            "a tool-list name (id) has 1 to {MAX} characters, got {}",
            id.chars().count()
        ));
    }
    if let Some(c) = id
        .chars()
        .find(|c| !(c.is_ascii_graphic() || *c == ' ') || *c == '"' || *c == ';')
    {
        return Err(format!(
            "a tool-list name (id) holds printable ASCII characters other than `\"` and `;`, got {c:?}"
        ));
    }
    Ok(())
}
