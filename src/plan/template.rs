//! Test-piece templates: the YAML files in `templates/`, embedded as
//! defaults and overridable by path. A template fixes the test's geometry,
//! angle set, tool, cutting data and clearances; the machine file and the
//! command line supply the rest. Every value is checked here or by the test
//! that uses it, and errors point at the key: `file:line:column: ...`.

use std::path::{Path, PathBuf};

use serde::Deserialize;

pub use crate::machine::check_tool;
use crate::machine::{Tool, ToolKind};
use crate::post::Coolant;
use crate::source::SourceError;

/// Built-in templates: (test name, YAML text).
pub const BUILTIN: [(&str, &str); 2] = [
    (
        "stepped-square",
        include_str!("../../templates/stepped-square.yaml"),
    ),
    (
        "nine-section",
        include_str!("../../templates/nine-section.yaml"),
    ),
];

/// A template's text and where it came from, for error positions.
#[derive(Clone, Debug, PartialEq)]
pub struct TemplateSource {
    /// The file as named (or `<built-in NAME>`).
    pub path: PathBuf,
    /// Its text.
    pub text: String,
}

impl TemplateSource {
    /// An error at a key path of the template.
    pub fn error(&self, keys: &[&str], msg: impl Into<String>) -> SourceError {
        SourceError::at_key(&self.path, &self.text, keys, msg)
    }
}

/// The tool a template asks for.
#[derive(Clone, Debug, PartialEq)]
pub enum ToolChoice {
    /// The machine file's default tool.
    Machine,
    /// This tool.
    Tool(Tool),
}

/// The stock block.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Stock {
    /// Side of the square block (X and Y in W), mm.
    pub size: f64,
    /// Height, mm.
    pub height: f64,
    /// Riser between the table top and the block, mm.
    #[serde(default)]
    pub fixture_height: f64,
    /// Raise the riser as far as the machine's Z stroke needs to reach
    /// every pose (head machines reaching the side faces).
    #[serde(default)]
    pub raise: bool,
}

/// Cutting data.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Cutting {
    /// Spindle speed, rpm.
    pub spindle: f64,
    /// Cutting feed, mm/min.
    pub feed: f64,
    /// Plunge (entry) feed, mm/min.
    pub plunge_feed: f64,
    /// Deepest cut per roughing layer, mm (stepped-square).
    #[serde(default)]
    pub axial_depth: Option<f64>,
    /// Stepover: fraction of the diameter (stepped-square roughing) or mm
    /// between raster passes (nine-section).
    pub stepover: f64,
    /// Radial stock roughing leaves for finishing, mm (stepped-square).
    #[serde(default)]
    pub finish_allowance: Option<f64>,
    /// Repeat the finishing pass with zero radial depth (seed 001).
    #[serde(default)]
    pub zero_cut: bool,
    /// Coolant or air blow.
    pub coolant: Coolant,
}

/// Clearances.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Clearance {
    /// Rapids stop this far above the stock along the tool axis, mm.
    pub rapid: f64,
    /// The safe height is this far beyond everything the rotary axes swing, mm.
    pub safe: f64,
}

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

/// The stepped-square test (seed 001).
#[derive(Clone, Debug, PartialEq)]
pub struct SteppedSquare {
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
    /// Cutting data.
    pub cutting: Cutting,
    /// Clearances.
    pub clearance: Clearance,
    /// Points.
    pub points: StepPoints,
}

/// One section of the nine-section test.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SectionAngles {
    /// Tilt, deg.
    pub tilt: f64,
    /// C, deg.
    pub c: f64,
}

/// The nine-section test (seed 004).
#[derive(Clone, Debug, PartialEq)]
pub struct NineSection {
    /// Stock block.
    pub stock: Stock,
    /// Depth of the cut below the stock top, mm.
    pub depth: f64,
    /// Sections 2..9 (section 1 is the centre at tilt = C = 0).
    pub sections: Vec<SectionAngles>,
    /// Tool.
    pub tool: ToolChoice,
    /// Cutting data.
    pub cutting: Cutting,
    /// Clearances.
    pub clearance: Clearance,
    /// Points per section.
    pub points_per_section: usize,
    /// Margin of the points from the section borders, mm.
    pub point_margin: f64,
}

/// A parsed template.
#[derive(Clone, Debug, PartialEq)]
pub enum TemplateKind {
    /// `stepped-square`.
    SteppedSquare(SteppedSquare),
    /// `nine-section`.
    NineSection(NineSection),
}

/// A template with its source.
#[derive(Clone, Debug, PartialEq)]
pub struct Template {
    /// Test name.
    pub test: String,
    /// What it asks for.
    pub kind: TemplateKind,
    /// Where it came from.
    pub source: TemplateSource,
}

/// Why a template could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum TemplateError {
    /// Neither a file nor a built-in template.
    #[error(
        "no template file `{0}` and no built-in test of that name (built-in: stepped-square, nine-section)"
    )]
    NotFound(String),
    /// The file could not be read.
    #[error("cannot read template {path}: {source}")]
    Read {
        /// Path.
        path: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
    /// Malformed template.
    #[error(transparent)]
    Invalid(#[from] SourceError),
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
    cutting: Cutting,
    clearance: Clearance,
    points: StepPoints,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct AnglesFile {
    tilt: serde_yaml::Value,
    c: Vec<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct NineSectionFile {
    test: String,
    stock: Stock,
    depth: f64,
    sections: Vec<SectionAngles>,
    tool: serde_yaml::Value,
    cutting: Cutting,
    clearance: Clearance,
    points: NinePointsFile,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct NinePointsFile {
    per_section: usize,
    margin: f64,
}

#[derive(Deserialize)]
struct Head {
    test: String,
}

impl Template {
    /// The built-in template of a test.
    pub fn builtin(test: &str) -> Option<Template> {
        BUILTIN.iter().find(|(n, _)| *n == test).map(|(n, src)| {
            Template::parse(Path::new(&format!("<built-in {n}>")), src)
                .expect("built-in templates are valid")
        })
    }

    /// Loads a template: a path when it exists, else a built-in test name.
    pub fn load(spec: &str) -> Result<Template, TemplateError> {
        let path = Path::new(spec);
        if path.exists() {
            let src = std::fs::read_to_string(path).map_err(|source| TemplateError::Read {
                path: path.to_path_buf(),
                source,
            })?;
            return Ok(Template::parse(path, &src)?);
        }
        let stem = spec.strip_suffix(".yaml").unwrap_or(spec);
        Template::builtin(stem).ok_or_else(|| TemplateError::NotFound(spec.to_string()))
    }

    /// Parses and checks a template's text; `path` is used in errors.
    pub fn parse(path: &Path, src: &str) -> Result<Template, SourceError> {
        let source = TemplateSource {
            path: path.to_path_buf(),
            text: src.to_string(),
        };
        crate::input::check_yaml(path, src)?;
        let yaml = |e: serde_yaml::Error| SourceError::from_yaml(path, &e);
        let head: Head = serde_yaml::from_str(src).map_err(|e| {
            let mut se = yaml(e);
            if se.message.contains("missing field `test`") {
                se.message =
                    "missing field `test`: expected `test: stepped-square` or `test: nine-section`"
                        .into();
            }
            se
        })?;
        let kind = match head.test.as_str() {
            "stepped-square" => {
                let f: SteppedSquareFile = serde_yaml::from_str(src).map_err(yaml)?;
                let _ = f.test;
                let t = SteppedSquare {
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
                    points: f.points,
                };
                check_stepped_square(&source, &t)?;
                TemplateKind::SteppedSquare(t)
            }
            "nine-section" => {
                let f: NineSectionFile = serde_yaml::from_str(src).map_err(yaml)?;
                let _ = f.test;
                let t = NineSection {
                    tool: tool_choice(&source, &f.tool)?,
                    stock: f.stock,
                    depth: f.depth,
                    sections: f.sections,
                    cutting: f.cutting,
                    clearance: f.clearance,
                    points_per_section: f.points.per_section,
                    point_margin: f.points.margin,
                };
                check_nine_section(&source, &t)?;
                TemplateKind::NineSection(t)
            }
            other => {
                return Err(source.error(
                    &["test"],
                    format!("unknown test `{other}`: expected stepped-square or nine-section"),
                ));
            }
        };
        Ok(Template {
            test: head.test,
            kind,
            source,
        })
    }
}

fn tool_choice(src: &TemplateSource, v: &serde_yaml::Value) -> Result<ToolChoice, SourceError> {
    if v.as_str() == Some("machine") {
        return Ok(ToolChoice::Machine);
    }
    let tool: Tool = serde_yaml::from_value(v.clone()).map_err(|e| {
        src.error(
            &["tool"],
            format!("tool must be `machine` or a tool (name, kind, diameter, length, ...): {e}"),
        )
    })?;
    check_tool(&tool).map_err(|(k, m)| src.error(&["tool", k], m))?;
    Ok(ToolChoice::Tool(tool))
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
    if list.is_empty() || list.iter().any(|a| !a.is_finite()) {
        return Err(src.error(
            &["angles", "tilt"],
            "tilt needs at least one finite angle (deg)",
        ));
    }
    Ok(TiltSet::List(list))
}

fn positive(src: &TemplateSource, keys: &[&str], v: f64) -> Result<(), SourceError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(src.error(keys, format!("{} must be > 0, got {v}", keys.join("."))))
    }
}

fn check_common(
    src: &TemplateSource,
    stock: &Stock,
    cutting: &Cutting,
    clearance: &Clearance,
) -> Result<(), SourceError> {
    positive(src, &["stock", "size"], stock.size)?;
    positive(src, &["stock", "height"], stock.height)?;
    if !(stock.fixture_height.is_finite() && stock.fixture_height >= 0.0) {
        return Err(src.error(
            &["stock", "fixture_height"],
            format!(
                "stock.fixture_height must be >= 0 mm, got {}",
                stock.fixture_height
            ),
        ));
    }
    positive(src, &["cutting", "spindle"], cutting.spindle)?;
    positive(src, &["cutting", "feed"], cutting.feed)?;
    positive(src, &["cutting", "plunge_feed"], cutting.plunge_feed)?;
    positive(src, &["cutting", "stepover"], cutting.stepover)?;
    positive(src, &["clearance", "rapid"], clearance.rapid)?;
    positive(src, &["clearance", "safe"], clearance.safe)?;
    Ok(())
}

fn check_stepped_square(src: &TemplateSource, t: &SteppedSquare) -> Result<(), SourceError> {
    check_common(src, &t.stock, &t.cutting, &t.clearance)?;
    for (face, s) in [("top", &t.top), ("side", &t.side)] {
        positive(src, &[face, "first_size"], s.first_size)?;
        positive(src, &[face, "size_increment"], s.size_increment)?;
        positive(src, &[face, "step"], s.step)?;
    }
    if !(t.side.bottom_lip.is_finite() && t.side.bottom_lip >= 0.0) {
        return Err(src.error(
            &["side", "bottom_lip"],
            format!("side.bottom_lip must be >= 0 mm, got {}", t.side.bottom_lip),
        ));
    }
    if t.angles.c.is_empty() || t.angles.c.iter().any(|c| !c.is_finite()) {
        return Err(src.error(&["angles", "c"], "c needs at least one finite angle (deg)"));
    }
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
    positive(src, &["cutting", "axial_depth"], axial)?;
    let allow = t.cutting.finish_allowance.unwrap_or(0.0);
    if !(allow.is_finite() && allow >= 0.0) {
        return Err(src.error(
            &["cutting", "finish_allowance"],
            format!("cutting.finish_allowance must be >= 0 mm, got {allow}"),
        ));
    }
    if t.cutting.stepover > 0.8 {
        return Err(src.error(
            &["cutting", "stepover"],
            format!(
                "cutting.stepover is a fraction of the tool diameter and must be at most 0.8 (no uncut corners between rings), got {}",
                t.cutting.stepover
            ),
        ));
    }
    if t.points.per_wall == 0 || t.points.per_floor_side == 0 {
        return Err(src.error(
            &["points"],
            "points.per_wall and points.per_floor_side must be at least 1 (every step needs walls and floor)",
        ));
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

fn check_nine_section(src: &TemplateSource, t: &NineSection) -> Result<(), SourceError> {
    check_common(src, &t.stock, &t.cutting, &t.clearance)?;
    positive(src, &["depth"], t.depth)?;
    if t.sections.len() != 8 {
        return Err(src.error(
            &["sections"],
            format!(
                "sections lists sections 2 to 9 (section 1 is the centre at tilt = C = 0): expected 8 entries, got {}",
                t.sections.len()
            ),
        ));
    }
    for s in &t.sections {
        if !(s.tilt.is_finite() && s.c.is_finite()) {
            return Err(src.error(&["sections"], "section angles must be finite (deg)"));
        }
    }
    if t.points_per_section == 0 {
        return Err(src.error(
            &["points", "per_section"],
            "points.per_section must be at least 1",
        ));
    }
    if !(t.point_margin.is_finite() && t.point_margin >= 0.0) {
        return Err(src.error(
            &["points", "margin"],
            format!("points.margin must be >= 0 mm, got {}", t.point_margin),
        ));
    }
    if let ToolChoice::Tool(tool) = &t.tool
        && tool.kind == ToolKind::Flat
    {
        return Err(src.error(
                &["tool", "kind"],
                "the nine-section test needs a ball or bull-nose end mill (seed 004: round-tip tool), got a flat end mill",
            ));
    }
    Ok(())
}
