//! The probe-columns template (`templates/probe-columns.yaml`): the square
//! columns standing on the table, the points on their tops and sides, the
//! pose grid, how touches are made and the probe's stylus.

use nalgebra::Vector2;
use serde::Deserialize;

use crate::formats::valid_label;
use crate::limits::MIN_PLAN_MM;
use crate::procedure::bounds::{angle, angles, echo, entries, length, position};
use crate::procedure::probing::ProbingSettings;
use crate::procedure::probing::template::{ProbeFile, ProbingFile, StylusSpec, settings, stylus};
use crate::procedure::{TemplateSource, Test};
use crate::source::SourceError;

/// The built-in template.
pub const BUILTIN_TEMPLATE: &str = include_str!("../../../../templates/probe-columns.yaml");

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ColumnFile {
    name: String,
    centre: [f64; 2],
    size: [f64; 2],
    height: f64,
    #[serde(default)]
    yaw: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PointsFile {
    top: Vec<[f64; 2]>,
    sides: Vec<String>,
    side_depth: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct GridFile {
    tilt: Vec<f64>,
    c: Vec<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ColumnsFile {
    test: String,
    columns: Vec<ColumnFile>,
    points: PointsFile,
    poses: GridFile,
    probing: ProbingFile,
    probe: ProbeFile,
}

/// A square column.
#[derive(Clone, Debug, PartialEq)]
pub struct ColumnSpec {
    /// Name (`C1`), used in labels.
    pub name: String,
    /// Footprint centre in W, mm.
    pub centre: Vector2<f64>,
    /// Footprint size along its own x and y, mm.
    pub size: Vector2<f64>,
    /// Height above the table, mm.
    pub height: f64,
    /// Rotation about Z, deg.
    pub yaw: f64,
}

/// A side face of a column, by its outward normal in the column's frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// +x
    XPlus,
    /// -x
    XMinus,
    /// +y
    YPlus,
    /// -y
    YMinus,
}

impl Side {
    /// The feature name used in labels (`xp`, `xn`, `yp`, `yn`).
    pub fn feature(self) -> &'static str {
        match self {
            Side::XPlus => "xp",
            Side::XMinus => "xn",
            Side::YPlus => "yp",
            Side::YMinus => "yn",
        }
    }

    fn parse(s: &str) -> Option<Side> {
        Some(match s {
            "+x" => Side::XPlus,
            "-x" => Side::XMinus,
            "+y" => Side::YPlus,
            "-y" => Side::YMinus,
            _ => return None,
        })
    }
}

/// The probe-columns template, validated.
#[derive(Clone, Debug, PartialEq)]
pub struct ColumnsTemplate {
    /// Where it came from (for messages and for copying next to a plan).
    pub source: TemplateSource,
    /// The columns.
    pub columns: Vec<ColumnSpec>,
    /// Top-face points: offsets from the top's centre in the column's frame.
    pub top: Vec<Vector2<f64>>,
    /// Side faces probed.
    pub sides: Vec<Side>,
    /// Depth of side points below the top, mm.
    pub side_depth: f64,
    /// Tilt angles, deg.
    pub tilts: Vec<f64>,
    /// C angles, deg.
    pub cs: Vec<f64>,
    /// Probing settings.
    pub probing: ProbingSettings,
    /// Probe geometry.
    pub probe: StylusSpec,
}

impl ColumnsTemplate {
    /// The built-in template.
    pub fn builtin() -> ColumnsTemplate {
        ColumnsTemplate::parse(TemplateSource::builtin(Test::ProbeColumns))
            .expect("the built-in template is valid")
    }

    /// Parses and validates a template.
    pub fn parse(source: TemplateSource) -> Result<ColumnsTemplate, SourceError> {
        let f: ColumnsFile = crate::input::parse_yaml(&source.path, &source.text)?;
        let src = &source;
        src.check_test(&f.test, Test::ProbeColumns)?;
        // Bounded before the quadratic overlap test.
        entries(src, &["columns"], f.columns.len(), 1)?;
        entries(src, &["points", "top"], f.points.top.len(), 0)?;
        let mut columns: Vec<ColumnSpec> = Vec::new();
        for (i, c) in f.columns.iter().enumerate() {
            let item = format!("columns[{i}]");
            let at = |key: &str, msg: String| src.error(&[item.as_str(), key], msg);
            if !valid_label(&c.name) || c.name.contains('_') {
                return Err(at(
                    "name",
                    format!(
                        "column name `{}` must be letters, digits, `.` and `-` (it becomes part of point labels)",
                        c.name
                    ),
                ));
            }
            if columns.iter().any(|o| o.name == c.name) {
                return Err(at(
                    "name",
                    format!("column name `{}` is used twice", c.name),
                ));
            }
            for v in c.size {
                length(src, &[item.as_str(), "size"], v)?;
            }
            length(src, &[item.as_str(), "height"], c.height)?;
            for v in c.centre {
                position(src, &[item.as_str(), "centre"], v)?;
            }
            angle(src, &[item.as_str(), "yaw"], c.yaw)?;
            let spec = ColumnSpec {
                name: c.name.clone(),
                centre: Vector2::new(c.centre[0], c.centre[1]),
                size: Vector2::new(c.size[0], c.size[1]),
                height: c.height,
                yaw: c.yaw,
            };
            if let Some(o) = columns.iter().find(|o| footprints_overlap(o, &spec)) {
                return Err(at(
                    "centre",
                    format!(
                        "{item} ({}): its footprint overlaps column {}",
                        c.name, o.name
                    ),
                ));
            }
            columns.push(spec);
        }
        if f.points.top.is_empty() && f.points.sides.is_empty() {
            return Err(src.error(&["points"], "points: give top points, side faces or both"));
        }
        let min_half = columns
            .iter()
            .map(|c| c.size.min() / 2.0)
            .fold(f64::INFINITY, f64::min);
        for t in &f.points.top {
            if !(t[0].abs() < min_half && t[1].abs() < min_half) {
                return Err(src.error(
                    &["points", "top"],
                    format!(
                        "points.top: offset [{}, {}] does not lie on the top face of every column (half size {min_half} mm)",
                        t[0], t[1]
                    ),
                ));
            }
        }
        let mut sides = Vec::new();
        for s in &f.points.sides {
            let Some(side) = Side::parse(s) else {
                return Err(src.error(
                    &["points", "sides"],
                    format!("points.sides: unknown side `{s}`: expected +x, -x, +y or -y"),
                ));
            };
            if sides.contains(&side) {
                return Err(src.error(
                    &["points", "sides"],
                    format!("points.sides: `{s}` is listed twice"),
                ));
            }
            sides.push(side);
        }
        let min_height = columns
            .iter()
            .map(|c| c.height)
            .fold(f64::INFINITY, f64::min);
        let depth_ok = f.points.side_depth >= MIN_PLAN_MM && f.points.side_depth < min_height;
        if !sides.is_empty() && !depth_ok {
            return Err(src.error(
                &["points", "side_depth"],
                format!(
                    "points.side_depth must lie between {MIN_PLAN_MM} mm and the lowest column's height ({min_height} mm), got {}",
                    echo(f.points.side_depth)
                ),
            ));
        }
        angles(src, &["poses", "tilt"], &f.poses.tilt)?;
        angles(src, &["poses", "c"], &f.poses.c)?;
        Ok(ColumnsTemplate {
            columns,
            top: f
                .points
                .top
                .iter()
                .map(|t| Vector2::new(t[0], t[1]))
                .collect(),
            sides,
            side_depth: f.points.side_depth,
            tilts: f.poses.tilt.clone(),
            cs: f.poses.c.clone(),
            probing: settings(src, &f.probing)?,
            probe: stylus(src, &f.probe)?,
            source,
        })
    }
}

/// Whether two column footprints (rectangles turned by their yaw) overlap
/// (separating-axis test on their four edge directions).
fn footprints_overlap(a: &ColumnSpec, b: &ColumnSpec) -> bool {
    let axes = |c: &ColumnSpec| {
        let (s, co) = c.yaw.to_radians().sin_cos();
        [Vector2::new(co, s), Vector2::new(-s, co)]
    };
    let (aa, ba) = (axes(a), axes(b));
    let half = |c: &ColumnSpec, ax: &[Vector2<f64>; 2], d: &Vector2<f64>| {
        (ax[0].dot(d) * c.size.x / 2.0).abs() + (ax[1].dot(d) * c.size.y / 2.0).abs()
    };
    aa.iter().chain(ba.iter()).all(|d| {
        let gap = (b.centre - a.centre).dot(d).abs();
        gap < half(a, &aa, d) + half(b, &ba, d)
    })
}
