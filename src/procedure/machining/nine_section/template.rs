//! The nine-section template (`templates/nine-section.yaml`): the block,
//! the depth of the cut, the angles of sections 2 to 9, the tool (a ball or
//! bull-nose end mill), cutting data, clearances and points per section.

use serde::Deserialize;

use crate::machine::ToolKind;
use crate::procedure::bounds::{angle, count, length, length_or_zero};
use crate::procedure::machining::template::{
    Clearance, CuttingData, Holder, SpindleNose, Stock, ToolChoice, check_assembly, check_common,
    tool_choice,
};
use crate::procedure::{TemplateSource, Test};
use crate::source::SourceError;

/// The built-in template.
pub const BUILTIN_TEMPLATE: &str = include_str!("../../../../templates/nine-section.yaml");

/// One section of the nine-section test.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SectionAngles {
    /// Tilt, deg.
    pub tilt: f64,
    /// C, deg.
    pub c: f64,
}

/// The nine-section template, checked.
#[derive(Clone, Debug, PartialEq)]
pub struct NineSectionTemplate {
    /// Where it came from (for messages and for copying next to a plan).
    pub source: TemplateSource,
    /// Stock block.
    pub stock: Stock,
    /// Depth of the cut below the stock top, mm.
    pub depth: f64,
    /// Sections 2..9 (section 1 is the centre at tilt = C = 0).
    pub sections: Vec<SectionAngles>,
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
    /// Points per section.
    pub points_per_section: usize,
    /// Margin of the points from the section borders, mm.
    pub point_margin: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct NineSectionFile {
    test: String,
    stock: Stock,
    depth: f64,
    sections: Vec<SectionAngles>,
    tool: serde_yaml::Value,
    cutting: CuttingData,
    clearance: Clearance,
    #[serde(default)]
    holder: Option<Holder>,
    #[serde(default)]
    spindle_nose: Option<SpindleNose>,
    points: NinePointsFile,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct NinePointsFile {
    per_section: usize,
    margin: f64,
}

fn check(src: &TemplateSource, t: &NineSectionTemplate) -> Result<(), SourceError> {
    check_common(src, &t.stock, &t.cutting, &t.clearance)?;
    if let Some((holder, nose)) = &t.assembly {
        check_assembly(src, holder, nose)?;
    }
    length(src, &["depth"], t.depth)?;
    length(src, &["cutting", "stepover"], t.cutting.stepover)?;
    if t.sections.len() != 8 {
        return Err(src.error(
            &["sections"],
            format!(
                "sections lists sections 2 to 9 (section 1 is the centre at tilt = C = 0): expected 8 entries, got {}",
                t.sections.len()
            ),
        ));
    }
    for (i, s) in t.sections.iter().enumerate() {
        let item = format!("sections[{i}]");
        angle(src, &[item.as_str(), "tilt"], s.tilt)?;
        angle(src, &[item.as_str(), "c"], s.c)?;
    }
    count(
        src,
        &["points", "per_section"],
        t.points_per_section,
        (1, 9),
    )?;
    length_or_zero(src, &["points", "margin"], t.point_margin)?;
    if let ToolChoice::Tool(tool) = &t.tool
        && tool.kind == ToolKind::Flat
    {
        return Err(src.error(
                &["tool", "kind"],
                "the nine-section test needs a ball or bull-nose end mill (a round-tip tool, as Cubas Brizuela & Yeh 2023 use), got a flat end mill",
            ));
    }
    Ok(())
}

impl NineSectionTemplate {
    /// The built-in template.
    pub fn builtin() -> NineSectionTemplate {
        NineSectionTemplate::parse(TemplateSource::builtin(Test::NineSection))
            .expect("the built-in template is valid")
    }

    /// Parses and checks a template.
    pub fn parse(source: TemplateSource) -> Result<NineSectionTemplate, SourceError> {
        let f: NineSectionFile = crate::input::parse_yaml(&source.path, &source.text)?;
        source.check_test(&f.test, Test::NineSection)?;
        let t = NineSectionTemplate {
            tool: tool_choice(&source, &f.tool)?,
            stock: f.stock,
            depth: f.depth,
            sections: f.sections,
            cutting: f.cutting,
            clearance: f.clearance,
            assembly: match (f.holder, f.spindle_nose) {
                (None, None) => None,
                (h, n) => Some((h.unwrap_or_default(), n.unwrap_or_default())),
            },
            points_per_section: f.points.per_section,
            point_margin: f.points.margin,
            source,
        };
        check(&t.source, &t)?;
        Ok(t)
    }
}
