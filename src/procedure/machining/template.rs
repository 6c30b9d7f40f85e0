//! What the templates of the machining tests share: the stock block, the
//! tool, the cutting data and the clearances, read from the template and
//! checked (every error names the key, `file:line:column`). Each test reads
//! the rest of its template in its own folder.

use serde::Deserialize;

use crate::limits::PLAN_SPINDLE_RPM;
use crate::machine::{Tool, check_tool};
use crate::post::Coolant;
use crate::procedure::TemplateSource;
use crate::procedure::bounds::{feed, length, length_or_zero, within};
use crate::source::SourceError;

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

/// CuttingData data.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CuttingData {
    /// Spindle speed, rpm.
    pub spindle: f64,
    /// CuttingData feed, mm/min.
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
    /// Repeat the finishing pass with zero radial depth (as Ibaraki & Ota
    /// 2014 do).
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

/// The tool holder: one cylinder from the spindle gauge line towards the
/// tip, as wide as its widest part.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Holder {
    /// Diameter, mm.
    pub diameter: f64,
    /// Length from the gauge line towards the tip, mm.
    pub length: f64,
}

impl Default for Holder {
    /// A short HSK-A63 (or SK40) chuck seen as one cylinder as wide as
    /// its 63 mm flange, 35 mm below the gauge line: shorter than every
    /// built-in tool, so the tool sticks out of it.
    fn default() -> Self {
        Holder {
            diameter: 63.0,
            length: 35.0,
        }
    }
}

/// The spindle nose: one cylinder from the gauge line away from the tip.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpindleNose {
    /// Diameter, mm.
    pub diameter: f64,
    /// Length modelled beyond the gauge line, mm.
    pub length: f64,
}

impl Default for SpindleNose {
    /// The probing templates' spindle: 120 mm wide, 150 mm modelled (a
    /// motor spindle for HSK-A63 tools).
    fn default() -> Self {
        SpindleNose {
            diameter: 120.0,
            length: 150.0,
        }
    }
}

/// Checks the holder and spindle nose of a template (a template giving
/// one of them gets the default of the other).
pub(crate) fn check_assembly(
    src: &TemplateSource,
    holder: &Holder,
    nose: &SpindleNose,
) -> Result<(), SourceError> {
    length(src, &["holder", "diameter"], holder.diameter)?;
    length(src, &["holder", "length"], holder.length)?;
    length(src, &["spindle_nose", "diameter"], nose.diameter)?;
    length(src, &["spindle_nose", "length"], nose.length)?;
    Ok(())
}

pub(crate) fn tool_choice(
    src: &TemplateSource,
    v: &serde_yaml::Value,
) -> Result<ToolChoice, SourceError> {
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

pub(crate) fn check_common(
    src: &TemplateSource,
    stock: &Stock,
    cutting: &CuttingData,
    clearance: &Clearance,
) -> Result<(), SourceError> {
    length(src, &["stock", "size"], stock.size)?;
    length(src, &["stock", "height"], stock.height)?;
    length_or_zero(src, &["stock", "fixture_height"], stock.fixture_height)?;
    within(
        src,
        &["cutting", "spindle"],
        cutting.spindle,
        PLAN_SPINDLE_RPM,
        "rpm",
        "",
    )?;
    feed(src, &["cutting", "feed"], cutting.feed)?;
    feed(src, &["cutting", "plunge_feed"], cutting.plunge_feed)?;
    length(src, &["clearance", "rapid"], clearance.rapid)?;
    length(src, &["clearance", "safe"], clearance.safe)?;
    Ok(())
}
