//! A test's design in W, before kinematics: the piece, the poses with their
//! cutting strokes as tool-tip paths, and the points. Each test module
//! (`stepped_square`, `nine_section`) produces one; `program` turns it into
//! machine moves and a program.

use std::collections::BTreeMap;

use nalgebra::{Matrix3, Vector3};

use super::Pass;
use super::cutter::ToolPart;
use super::template::{Clearance, CuttingData, ToolChoice};
pub(crate) use crate::kinematics::pose_frame::pose_frame;
use crate::machine::{Machine, Tool};
use crate::mesh::Cuboid;
use crate::procedure::short;
use crate::procedure::{PlanConfig, PlanError, TemplateSource};

/// A continuous cutting path: entered by feed from the clearance plane
/// above `start` (along the tool axis), left by a rapid lift.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Stroke {
    /// First tool-tip position, W.
    pub start: Vector3<f64>,
    /// Following tool-tip positions with the pass of the segment ending there.
    pub segs: Vec<(Vector3<f64>, Pass)>,
}

/// One pose of the design.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct PoseDesign {
    pub id: String,
    pub tilt: f64,
    pub c: f64,
    /// Tool axis in W.
    pub axis: Vector3<f64>,
    /// Program frame (columns in W).
    pub frame: Matrix3<f64>,
    pub feature: String,
    pub strokes: Vec<Stroke>,
}

/// One point of the design.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct PointDesign {
    pub label: String,
    pub pose: usize,
    pub p: Vector3<f64>,
    pub n: Vector3<f64>,
    pub surface: String,
    pub part: ToolPart,
}

/// A test's design.
#[derive(Clone, Debug)]
pub(crate) struct MachiningDesign {
    pub title: String,
    pub description: String,
    pub program_number: u32,
    pub tool: Tool,
    pub cutting: CuttingData,
    pub clearance: Clearance,
    pub stock: Cuboid,
    pub fixture: Option<Cuboid>,
    pub solid: crate::mesh::Solid,
    /// The piece's boundary polygons.
    pub csg: crate::mesh::Csg,
    /// Mesh group names by tag.
    pub groups: BTreeMap<u32, String>,
    pub poses: Vec<PoseDesign>,
    pub points: Vec<PointDesign>,
    pub notes: Vec<String>,
    /// One line on the stock and fixturing for the header and setup sheet.
    pub stock_text: String,
}

/// The tool of a plan: `--tool`, else the template's, else the machine's.
pub(crate) fn tool_of(cfg: &PlanConfig, choice: &ToolChoice) -> Tool {
    match (&cfg.tool, choice) {
        (Some(t), _) => t.clone(),
        (None, ToolChoice::Tool(t)) => t.clone(),
        (None, ToolChoice::Machine) => cfg.machine.tool.clone(),
    }
}

/// Refuses, before any toolpath is made, a block no machine of these
/// strokes could cut round (the tool circles the whole top face at C = 0,
/// so the block must fit the X and Y strokes) and a tool out of range (a
/// library caller may hand over a tool nobody checked).
pub(crate) fn check_work_area(
    cfg: &PlanConfig,
    src: &TemplateSource,
    size: f64,
    tool: &Tool,
) -> Result<(), PlanError> {
    crate::machine::check_tool(tool).map_err(|(_, msg)| {
        PlanError::Impossible(format!("tool T{} `{}`: {msg}", tool.number, tool.name))
    })?;
    let m = &cfg.machine;
    let (axis, span) = ['X', 'Y']
        .into_iter()
        .zip(&m.strokes)
        .map(|(a, (lo, hi))| (a, hi - lo))
        .fold(('X', f64::INFINITY), |b, x| if x.1 < b.1 { x } else { b });
    if size.is_nan() || size > span {
        return Err(src
            .error(
                &["stock", "size"],
                format!(
                    "stock.size {} mm is wider than the {axis} stroke of {} ({} mm): no pose could cut round the block",
                    crate::procedure::echo(size),
                    m.name,
                    short(span)
                ),
            )
            .into());
    }
    Ok(())
}

/// Checks a rotary angle against the machine's limits.
pub(crate) fn within_limits(m: &Machine, letter: char, angle: f64) -> Result<(), String> {
    let axis = if letter == 'C' { &m.c } else { &m.tilt };
    if axis.within(angle, 1e-9) {
        return Ok(());
    }
    let (lo, hi) = axis.limits.unwrap_or((f64::NEG_INFINITY, f64::INFINITY));
    Err(format!(
        "{letter} = {angle} is outside the limits [{lo}, {hi}] of machine {}",
        m.name
    ))
}

/// Pose id `B90C180`, `A-30C270`.
pub(crate) fn pose_id(letter: char, tilt: f64, c: f64) -> String {
    format!("{letter}{}C{}", short(tilt), short(c))
}

/// Group names of a design's mesh: stock, then the pose ids.
pub(crate) fn groups(poses: &[String]) -> BTreeMap<u32, String> {
    let mut g = BTreeMap::new();
    let _ = g.insert(0, "stock".to_string());
    for (i, id) in poses.iter().enumerate() {
        let _ = g.insert(i as u32 + 1, id.clone());
    }
    g
}

/// A label suffix for a W direction: `XP`, `XN`, ... or `None` when the
/// direction is not along an axis.
pub(crate) fn dir_code(n: &Vector3<f64>) -> Option<&'static str> {
    const CODES: [(&str, &str); 3] = [("XP", "XN"), ("YP", "YN"), ("ZP", "ZN")];
    (0..3).find_map(|i| {
        if (n[i].abs() - 1.0).abs() < 1e-9 {
            Some(if n[i] > 0.0 { CODES[i].0 } else { CODES[i].1 })
        } else {
            None
        }
    })
}

/// Human name of a W direction (`+X`, or the vector).
pub(crate) fn dir_name(n: &Vector3<f64>) -> String {
    match dir_code(n) {
        Some(c) => format!("{}{}", if c.ends_with('P') { "+" } else { "-" }, &c[..1]),
        None => format!("({:.3}, {:.3}, {:.3})", n.x, n.y, n.z),
    }
}
