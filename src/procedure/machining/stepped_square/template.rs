//! The stepped-square template (`templates/stepped-square.yaml`): the
//! block, the angle set, the steps on the top and the side faces, the tool
//! (a flat end mill), cutting data, clearances and points per step.

use serde::Deserialize;

use crate::limits::MAX_PLAN_POINTS;
use crate::machine::ToolKind;
use crate::procedure::bounds::{angles, count, echo, length, length_or_zero};
use crate::procedure::machining::template::{
    Clearance, CuttingData, Holder, SpindleNose, Stock, ToolChoice, check_assembly, check_common,
    tool_choice,
};
use crate::procedure::{TemplateSource, Test};
use crate::source::SourceError;

/// The built-in template.
pub const BUILTIN_TEMPLATE: &str = include_str!("../../../../templates/stepped-square.yaml");

/// The tilt angles of the stepped-square test.
#[derive(Clone, Debug, PartialEq)]
pub enum TiltSet {
    /// 0, 90, -90 where the machine reaches them.
    Auto,
    /// These angles, deg (each must be reachable).
    List(Vec<f64>),
}

/// Angle set of the stepped-square test.
#[derive(Clone, Debug, PartialEq)]
pub struct Angles {
    /// Tilt angles.
    pub tilt: TiltSet,
    /// C angles, deg, in execution order.
    pub c: Vec<f64>,
}

/// The stepped squares on one kind of face.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Steps {
    /// Side of the first (innermost, highest) square, mm.
    pub first_size: f64,
    /// Each further square on the same face is this much wider, mm.
    pub size_increment: f64,
    /// Height (top face) or depth (side faces) of each step, mm.
    pub step: f64,
    /// Side faces: uncut band at the bottom of the face, mm.
    #[serde(default)]
    pub bottom_lip: f64,
}

/// Plan points per step.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StepPoints {
    /// Points on each of the four walls.
    pub per_wall: usize,
    /// Points on the floor next to each wall.
    pub per_floor_side: usize,
}

/// The stepped-square template, checked.
#[derive(Clone, Debug, PartialEq)]
pub struct SteppedSquareTemplate {
    /// Where it came from (for messages and for copying next to a plan).
    pub source: TemplateSource,
    /// Stock block.
    pub stock: Stock,
    /// Angle set.
    pub angles: Angles,
    /// Steps on the top face.
    pub top: Steps,
    /// Steps on the side faces.
    pub side: Steps,
    /// Tool.
    pub tool: ToolChoice,
    /// CuttingData data.
    pub cutting: CuttingData,
    /// Clearances.
    pub clearance: Clearance,
    /// The tool holder and spindle nose, checked against the table, the
    /// riser and the block; `None` when the template gives neither (a
    /// template written before they existed plans as it did then).
    pub assembly: Option<(Holder, SpindleNose)>,
    /// Points.
    pub points: StepPoints,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SteppedSquareFile {
    test: String,
    stock: Stock,
    angles: AnglesFile,
    top: Steps,
    side: Steps,
    tool: serde_yaml::Value,
    cutting: CuttingData,
    clearance: Clearance,
    #[serde(default)]
    holder: Option<Holder>,
    #[serde(default)]
    spindle_nose: Option<SpindleNose>,
    points: StepPoints,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct AnglesFile {
    tilt: serde_yaml::Value,
    c: Vec<f64>,
}

fn tilt_set(src: &TemplateSource, v: &serde_yaml::Value) -> Result<TiltSet, SourceError> {
    if v.as_str() == Some("auto") {
        return Ok(TiltSet::Auto);
    }
    let list: Vec<f64> = serde_yaml::from_value(v.clone()).map_err(|_| {
        src.error(
            &["angles", "tilt"],
            "tilt must be `auto` (0, 90, -90 where the machine reaches them) or a list of angles in degrees",
        )
    })?;
    angles(src, &["angles", "tilt"], &list)?;
    Ok(TiltSet::List(list))
}

fn check(src: &TemplateSource, t: &SteppedSquareTemplate) -> Result<(), SourceError> {
    check_common(src, &t.stock, &t.cutting, &t.clearance)?;
    if let Some((holder, nose)) = &t.assembly {
        check_assembly(src, holder, nose)?;
    }
    for (face, s) in [("top", &t.top), ("side", &t.side)] {
        length(src, &[face, "first_size"], s.first_size)?;
        length(src, &[face, "size_increment"], s.size_increment)?;
        length(src, &[face, "step"], s.step)?;
    }
    length_or_zero(src, &["side", "bottom_lip"], t.side.bottom_lip)?;
    // The lists are bounded before the quadratic search for repeats.
    angles(src, &["angles", "c"], &t.angles.c)?;
    for (i, a) in t.angles.c.iter().enumerate() {
        if t.angles.c[..i].iter().any(|b| (a - b).abs() < 1e-9) {
            return Err(src.error(&["angles", "c"], format!("C = {a} appears twice")));
        }
    }
    if let TiltSet::List(l) = &t.angles.tilt {
        for (i, a) in l.iter().enumerate() {
            if l[..i].iter().any(|b| (a - b).abs() < 1e-9) {
                return Err(src.error(&["angles", "tilt"], format!("tilt = {a} appears twice")));
            }
        }
    }
    let axial = t.cutting.axial_depth.unwrap_or(f64::NAN);
    length(src, &["cutting", "axial_depth"], axial)?;
    let allow = t.cutting.finish_allowance.unwrap_or(0.0);
    length_or_zero(src, &["cutting", "finish_allowance"], allow)?;
    // A fraction of the tool diameter; the design checks that the rings it
    // makes are at least 1 um apart once the tool is known.
    if !(t.cutting.stepover > 0.0 && t.cutting.stepover <= 0.8) {
        return Err(src.error(
            &["cutting", "stepover"],
            format!(
                "cutting.stepover is a fraction of the tool diameter and must be above 0 and at most 0.8 (no uncut corners between rings), got {}",
                echo(t.cutting.stepover)
            ),
        ));
    }
    for key in ["per_wall", "per_floor_side"] {
        let n = if key == "per_wall" {
            t.points.per_wall
        } else {
            t.points.per_floor_side
        };
        // At least one: every step needs walls and floor.
        count(src, &["points", key], n, (1, MAX_PLAN_POINTS))?;
    }
    if let ToolChoice::Tool(tool) = &t.tool
        && tool.kind != ToolKind::Flat
    {
        return Err(src.error(
            &["tool", "kind"],
            format!(
                "the stepped-square test needs a straight (flat) end mill, got {:?}",
                tool.kind
            ),
        ));
    }
    Ok(())
}

impl SteppedSquareTemplate {
    /// The built-in template.
    pub fn builtin() -> SteppedSquareTemplate {
        SteppedSquareTemplate::parse(TemplateSource::builtin(Test::SteppedSquare))
            .expect("the built-in template is valid")
    }

    /// Parses and checks a template.
    pub fn parse(source: TemplateSource) -> Result<SteppedSquareTemplate, SourceError> {
        let f: SteppedSquareFile = crate::input::parse_yaml(&source.path, &source.text)?;
        source.check_test(&f.test, Test::SteppedSquare)?;
        let t = SteppedSquareTemplate {
            tool: tool_choice(&source, &f.tool)?,
            angles: Angles {
                tilt: tilt_set(&source, &f.angles.tilt)?,
                c: f.angles.c,
            },
            stock: f.stock,
            top: f.top,
            side: f.side,
            cutting: f.cutting,
            clearance: f.clearance,
            assembly: match (f.holder, f.spindle_nose) {
                (None, None) => None,
                (h, n) => Some((h.unwrap_or_default(), n.unwrap_or_default())),
            },
            points: f.points,
            source,
        };
        check(&t.source, &t)?;
        Ok(t)
    }
}
