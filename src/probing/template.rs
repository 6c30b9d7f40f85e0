//! The YAML templates of the two probing tests: `templates/probe-columns.yaml`
//! and `templates/probe-sphere.yaml`, compiled in as defaults and
//! overridable by a path. Parsing checks everything the template can say
//! on its own (positive sizes, known face and direction names, margins
//! below the clearance, ...), reporting `file:line:column` and the key;
//! what depends on the machine (rotary limits, the table's size, strokes)
//! is checked when the plan is made, with the same kind of message.

use std::path::{Path, PathBuf};

use nalgebra::Vector2;
use serde::Deserialize;

use super::ProbingSettings;
use crate::formats::valid_label;
use crate::source::SourceError;

/// The built-in column template.
pub const BUILTIN_COLUMNS: &str = include_str!("../../templates/probe-columns.yaml");
/// The built-in sphere template.
pub const BUILTIN_SPHERE: &str = include_str!("../../templates/probe-sphere.yaml");

/// A template's text and where it came from.
#[derive(Clone, Debug, PartialEq)]
pub struct TemplateSource {
    /// The path (or `<built-in NAME>`).
    pub path: PathBuf,
    /// The YAML text.
    pub text: String,
}

impl TemplateSource {
    /// A built-in template by test name (`probe-columns`, `probe-sphere`).
    pub fn builtin(name: &str) -> Option<TemplateSource> {
        let text = match name {
            "probe-columns" => BUILTIN_COLUMNS,
            "probe-sphere" => BUILTIN_SPHERE,
            _ => return None,
        };
        Some(TemplateSource {
            path: PathBuf::from(format!("<built-in {name}>")),
            text: text.to_string(),
        })
    }

    /// A file when `spec` names one, else a built-in template of that name.
    pub fn load(spec: &str) -> Result<TemplateSource, SourceError> {
        let path = Path::new(spec);
        if path.exists() {
            let text = crate::input::read_text(path, "template", crate::limits::MAX_YAML_BYTES)?;
            return Ok(TemplateSource {
                path: path.to_path_buf(),
                text,
            });
        }
        TemplateSource::builtin(spec.strip_suffix(".yaml").unwrap_or(spec)).ok_or_else(|| {
            SourceError::new(
                path,
                0,
                0,
                "no such template file, and no built-in template of that name (built-in: probe-columns, probe-sphere)",
            )
        })
    }

    /// An error at the key path `keys` (`"columns[1]"` selects the second
    /// item of the list `columns`).
    pub fn error_at(&self, keys: &[&str], msg: impl Into<String>) -> SourceError {
        let (line, column) = locate(&self.text, keys).unwrap_or((0, 0));
        SourceError::new(&self.path, line, column, msg)
    }
}

/// Finds a key path whose elements may be `name[i]` (the `i`-th item of a
/// block list, inline-flow items included).
fn locate(src: &str, keys: &[&str]) -> Option<(usize, usize)> {
    let Some(pos) = keys.iter().position(|k| k.ends_with(']')) else {
        return crate::source::locate_yaml_key(src, keys);
    };
    let (name, idx) = keys[pos].trim_end_matches(']').split_once('[')?;
    let idx: usize = idx.parse().ok()?;
    let mut head: Vec<&str> = keys[..pos].to_vec();
    head.push(name);
    let (line, _) = crate::source::locate_yaml_key(src, &head)?;
    let lines: Vec<&str> = src.lines().collect();
    let indent = |l: &str| l.len() - l.trim_start().len();
    let key_indent = indent(lines[line - 1]);
    let mut count = 0;
    for (i, l) in lines.iter().enumerate().skip(line) {
        let t = l.trim_start();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        if indent(l) <= key_indent && !t.starts_with("- ") {
            return None;
        }
        if t.starts_with("- ") {
            if count == idx {
                // Rest of the path inside this item: search from here.
                let rest = &keys[pos + 1..];
                if rest.is_empty() {
                    return Some((i + 1, indent(l) + 1));
                }
                // An inline item: the key on the item's own line.
                let own = lines[i];
                let pat = format!("{}:", rest[0]);
                let mut from = 0;
                while let Some(off) = own[from..].find(&pat) {
                    let at = from + off;
                    let before = own[..at].chars().last().unwrap_or(' ');
                    if before == '{' || before == ' ' || before == ',' {
                        return Some((i + 1, at + 1));
                    }
                    from = at + 1;
                }
                let tail: String = lines[i..].join("\n");
                let item = tail.replacen("- ", "  ", 1);
                return crate::source::locate_yaml_key(&item, rest).map(|(li, c)| (i + li, c));
            }
            count += 1;
        }
    }
    None
}

// ---------------------------------------------------------------- serde forms

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ProbingFile {
    clearance: f64,
    overtravel: f64,
    feed: f64,
    positioning_feed: f64,
    safe_margin: f64,
    touch_overhead: f64,
    pose_overhead: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ProbeFile {
    stylus_length: f64,
    stylus_diameter: f64,
    body_diameter: f64,
    #[serde(default)]
    body_length: Option<f64>,
    spindle_diameter: f64,
    spindle_length: f64,
}

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

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SphereGeomFile {
    diameter: f64,
    position: [f64; 2],
    height: f64,
    stem_diameter: f64,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(deny_unknown_fields)]
struct RangeFile {
    from: f64,
    to: f64,
    step: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CSweepFile {
    tilt: f64,
    c: RangeFile,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TiltSweepFile {
    c: f64,
    tilt: RangeFile,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Seed004File {
    c_sweep: CSweepFile,
    tilt_sweep: TiltSweepFile,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SpanFile {
    from: f64,
    to: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Seed003File {
    poses: usize,
    tilt: SpanFile,
    turns: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CheckFile {
    radius_tolerance: f64,
    form_tolerance: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SphereFile {
    test: String,
    sphere: SphereGeomFile,
    touches: Vec<String>,
    pattern: String,
    #[serde(rename = "seed-004")]
    seed004: Seed004File,
    #[serde(rename = "seed-003")]
    seed003: Seed003File,
    check: CheckFile,
    probing: ProbingFile,
    probe: ProbeFile,
}

// ---------------------------------------------------------------- validated forms

/// Stylus and body of the probe (the ball comes from the machine file).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StylusSpec {
    /// Ball centre to the probe body, mm.
    pub stylus_length: f64,
    /// Shaft diameter, mm.
    pub stylus_diameter: f64,
    /// Body diameter, mm.
    pub body_diameter: f64,
    /// Body length, mm; `None`: up to the spindle gauge line.
    pub body_length: Option<f64>,
    /// Diameter of the spindle nose, mm.
    pub spindle_diameter: f64,
    /// Length of the spindle nose modelled above the gauge line, mm.
    pub spindle_length: f64,
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

/// The probe-sphere pose pattern.
#[derive(Clone, Debug, PartialEq)]
pub enum SpherePattern {
    /// Seed 004: a C sweep at one tilt, then a tilt sweep at one C.
    Seed004 {
        /// Tilt of the C sweep, deg.
        c_sweep_tilt: f64,
        /// C angles of the C sweep, deg.
        c_sweep: Vec<f64>,
        /// C of the tilt sweep, deg.
        tilt_sweep_c: f64,
        /// Tilt angles of the tilt sweep, deg.
        tilt_sweep: Vec<f64>,
    },
    /// Seed 003: `poses` poses with the tilt evenly spread from `tilt.0`
    /// to `tilt.1` while C advances `turns` full turns.
    Seed003 {
        /// Number of poses.
        poses: usize,
        /// First and last tilt, deg.
        tilt: (f64, f64),
        /// Turns of C over the poses.
        turns: f64,
    },
}

/// The probe-sphere template, validated.
#[derive(Clone, Debug, PartialEq)]
pub struct SphereTemplate {
    /// Where it came from.
    pub source: TemplateSource,
    /// Sphere diameter, mm.
    pub diameter: f64,
    /// Centre (x, y) in W, mm.
    pub position: Vector2<f64>,
    /// Centre above the table surface, mm.
    pub height: f64,
    /// Stem diameter, mm.
    pub stem_diameter: f64,
    /// Approach directions in program coordinates (unit vectors along
    /// axes) with their feature names (`xp` for +x, ...).
    pub touches: Vec<(nalgebra::Vector3<f64>, &'static str)>,
    /// The pose pattern.
    pub pattern: SpherePattern,
    /// Largest accepted radius error of a pose's fit, mm.
    pub radius_tolerance: f64,
    /// Largest accepted form error of a pose's fit, mm.
    pub form_tolerance: f64,
    /// Probing settings.
    pub probing: ProbingSettings,
    /// Probe geometry.
    pub probe: StylusSpec,
}

fn positive(src: &TemplateSource, keys: &[&str], v: f64, what: &str) -> Result<(), SourceError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(src.error_at(keys, format!("{what} must be a positive number, got {v}")))
    }
}

fn settings(src: &TemplateSource, p: &ProbingFile) -> Result<ProbingSettings, SourceError> {
    let k = |key: &'static str| ["probing", key];
    positive(src, &k("clearance"), p.clearance, "probing.clearance")?;
    positive(src, &k("overtravel"), p.overtravel, "probing.overtravel")?;
    positive(src, &k("feed"), p.feed, "probing.feed")?;
    positive(
        src,
        &k("positioning_feed"),
        p.positioning_feed,
        "probing.positioning_feed",
    )?;
    if !(p.safe_margin.is_finite() && p.safe_margin >= 0.0 && p.safe_margin < p.clearance) {
        return Err(src.error_at(
            &k("safe_margin"),
            format!(
                "probing.safe_margin must be at least 0 and smaller than the clearance ({} mm), got {}",
                p.clearance, p.safe_margin
            ),
        ));
    }
    for (key, v) in [
        ("touch_overhead", p.touch_overhead),
        ("pose_overhead", p.pose_overhead),
    ] {
        if !(v.is_finite() && v >= 0.0) {
            return Err(src.error_at(
                &k(key),
                format!("probing.{key} must be a time of at least 0 s, got {v}"),
            ));
        }
    }
    Ok(ProbingSettings {
        clearance: p.clearance,
        overtravel: p.overtravel,
        feed: p.feed,
        positioning_feed: p.positioning_feed,
        safe_margin: p.safe_margin,
        touch_overhead: p.touch_overhead,
        pose_overhead: p.pose_overhead,
    })
}

fn stylus(src: &TemplateSource, p: &ProbeFile) -> Result<StylusSpec, SourceError> {
    let k = |key: &'static str| ["probe", key];
    positive(
        src,
        &k("stylus_length"),
        p.stylus_length,
        "probe.stylus_length",
    )?;
    positive(
        src,
        &k("stylus_diameter"),
        p.stylus_diameter,
        "probe.stylus_diameter",
    )?;
    positive(
        src,
        &k("body_diameter"),
        p.body_diameter,
        "probe.body_diameter",
    )?;
    if let Some(l) = p.body_length {
        positive(src, &k("body_length"), l, "probe.body_length")?;
    }
    positive(
        src,
        &k("spindle_diameter"),
        p.spindle_diameter,
        "probe.spindle_diameter",
    )?;
    positive(
        src,
        &k("spindle_length"),
        p.spindle_length,
        "probe.spindle_length",
    )?;
    Ok(StylusSpec {
        stylus_length: p.stylus_length,
        stylus_diameter: p.stylus_diameter,
        body_diameter: p.body_diameter,
        body_length: p.body_length,
        spindle_diameter: p.spindle_diameter,
        spindle_length: p.spindle_length,
    })
}

fn check_test(src: &TemplateSource, got: &str, want: &str) -> Result<(), SourceError> {
    if got == want {
        Ok(())
    } else {
        Err(src.error_at(
            &["test"],
            format!("this is a `{want}` template: expected `test: {want}`, got `{got}`"),
        ))
    }
}

fn angles(src: &TemplateSource, keys: &[&str], v: &[f64]) -> Result<(), SourceError> {
    if v.is_empty() {
        return Err(src.error_at(keys, format!("{} needs at least one angle", keys.join("."))));
    }
    if let Some(a) = v.iter().find(|a| !a.is_finite()) {
        return Err(src.error_at(keys, format!("{}: {a} is not an angle", keys.join("."))));
    }
    Ok(())
}

impl ColumnsTemplate {
    /// The built-in template.
    pub fn builtin() -> ColumnsTemplate {
        ColumnsTemplate::parse(TemplateSource::builtin("probe-columns").expect("built in"))
            .expect("the built-in template is valid")
    }

    /// Parses and validates a template.
    pub fn parse(source: TemplateSource) -> Result<ColumnsTemplate, SourceError> {
        crate::input::check_yaml(&source.path, &source.text)?;
        let f: ColumnsFile = serde_yaml::from_str(&source.text)
            .map_err(|e| SourceError::from_yaml(&source.path, &e))?;
        let src = &source;
        check_test(src, &f.test, "probe-columns")?;
        if f.columns.is_empty() {
            return Err(src.error_at(&["columns"], "columns: at least one column is needed"));
        }
        let mut columns: Vec<ColumnSpec> = Vec::new();
        for (i, c) in f.columns.iter().enumerate() {
            let item = format!("columns[{i}]");
            let at = |key: &str, msg: String| src.error_at(&[item.as_str(), key], msg);
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
            if !(c.size.iter().all(|v| v.is_finite() && *v > 0.0)) {
                return Err(at(
                    "size",
                    format!(
                        "{item} ({}): size must be two positive lengths (x, y), got [{}, {}]",
                        c.name, c.size[0], c.size[1]
                    ),
                ));
            }
            if !(c.height.is_finite() && c.height > 0.0) {
                return Err(at(
                    "height",
                    format!(
                        "{item} ({}): height must be positive, got {}",
                        c.name, c.height
                    ),
                ));
            }
            if !(c.centre.iter().all(|v| v.is_finite()) && c.yaw.is_finite()) {
                return Err(at(
                    "centre",
                    format!("{item} ({}): centre and yaw must be numbers", c.name),
                ));
            }
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
            return Err(src.error_at(&["points"], "points: give top points, side faces or both"));
        }
        let min_half = columns
            .iter()
            .map(|c| c.size.min() / 2.0)
            .fold(f64::INFINITY, f64::min);
        for t in &f.points.top {
            if !(t[0].abs() < min_half && t[1].abs() < min_half) {
                return Err(src.error_at(
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
                return Err(src.error_at(
                    &["points", "sides"],
                    format!("points.sides: unknown side `{s}`: expected +x, -x, +y or -y"),
                ));
            };
            if sides.contains(&side) {
                return Err(src.error_at(
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
        let depth_ok = f.points.side_depth > 0.0 && f.points.side_depth < min_height;
        if !sides.is_empty() && !depth_ok {
            return Err(src.error_at(
                &["points", "side_depth"],
                format!(
                    "points.side_depth must lie between 0 and the lowest column's height ({min_height} mm), got {}",
                    f.points.side_depth
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

fn range(src: &TemplateSource, keys: &[&str], r: RangeFile) -> Result<Vec<f64>, SourceError> {
    if !(r.from.is_finite()
        && r.to.is_finite()
        && r.step.is_finite()
        && r.step > 0.0
        && r.from <= r.to)
    {
        return Err(src.error_at(
            keys,
            format!(
                "{}: expected from <= to and a positive step, got from {} to {} step {}",
                keys.join("."),
                r.from,
                r.to,
                r.step
            ),
        ));
    }
    let n = ((r.to - r.from) / r.step + 1e-9).floor() as usize;
    if n > 10_000 {
        return Err(src.error_at(keys, format!("{}: more than 10000 poses", keys.join("."))));
    }
    Ok((0..=n).map(|i| r.from + r.step * i as f64).collect())
}

impl SphereTemplate {
    /// The built-in template.
    pub fn builtin() -> SphereTemplate {
        SphereTemplate::parse(TemplateSource::builtin("probe-sphere").expect("built in"))
            .expect("the built-in template is valid")
    }

    /// Parses and validates a template.
    pub fn parse(source: TemplateSource) -> Result<SphereTemplate, SourceError> {
        crate::input::check_yaml(&source.path, &source.text)?;
        let f: SphereFile = serde_yaml::from_str(&source.text)
            .map_err(|e| SourceError::from_yaml(&source.path, &e))?;
        let src = &source;
        check_test(src, &f.test, "probe-sphere")?;
        let s = &f.sphere;
        positive(src, &["sphere", "diameter"], s.diameter, "sphere.diameter")?;
        positive(
            src,
            &["sphere", "stem_diameter"],
            s.stem_diameter,
            "sphere.stem_diameter",
        )?;
        if s.stem_diameter >= s.diameter {
            return Err(src.error_at(
                &["sphere", "stem_diameter"],
                format!(
                    "sphere.stem_diameter ({}) must be smaller than the sphere's diameter ({})",
                    s.stem_diameter, s.diameter
                ),
            ));
        }
        if !(s.height.is_finite() && s.height > s.diameter / 2.0) {
            return Err(src.error_at(
                &["sphere", "height"],
                format!(
                    "sphere.height (centre above the table) must exceed the radius {} mm, got {}",
                    s.diameter / 2.0,
                    s.height
                ),
            ));
        }
        if !s.position.iter().all(|v| v.is_finite()) {
            return Err(src.error_at(
                &["sphere", "position"],
                "sphere.position must be two numbers",
            ));
        }
        let mut touches: Vec<(nalgebra::Vector3<f64>, &'static str)> = Vec::new();
        for t in &f.touches {
            let d = match t.as_str() {
                "+x" => (nalgebra::Vector3::x(), "xp"),
                "-x" => (-nalgebra::Vector3::x(), "xm"),
                "+y" => (nalgebra::Vector3::y(), "yp"),
                "-y" => (-nalgebra::Vector3::y(), "ym"),
                "-z" => (-nalgebra::Vector3::z(), "zm"),
                _ => {
                    return Err(src.error_at(
                        &["touches"],
                        format!(
                            "touches: unknown approach `{t}`: expected +x, -x, +y, -y or -z (the stem is below the sphere)"
                        ),
                    ));
                }
            };
            if touches.iter().any(|o| o.1 == d.1) {
                return Err(src.error_at(&["touches"], format!("touches: `{t}` is listed twice")));
            }
            touches.push(d);
        }
        if touches.len() < 4 || !touches.iter().any(|t| t.1 == "zm") {
            return Err(src.error_at(
                &["touches"],
                "touches: a sphere needs at least four touches, one of them -z (the equator alone lies in one plane)",
            ));
        }
        let pattern = match f.pattern.as_str() {
            "seed-004" => SpherePattern::Seed004 {
                c_sweep_tilt: f.seed004.c_sweep.tilt,
                c_sweep: range(src, &["seed-004", "c_sweep", "c"], f.seed004.c_sweep.c)?,
                tilt_sweep_c: f.seed004.tilt_sweep.c,
                tilt_sweep: range(
                    src,
                    &["seed-004", "tilt_sweep", "tilt"],
                    f.seed004.tilt_sweep.tilt,
                )?,
            },
            "seed-003" => {
                let p = &f.seed003;
                if p.poses < 2 || p.poses > 10_000 {
                    return Err(src.error_at(
                        &["seed-003", "poses"],
                        format!(
                            "seed-003.poses must be between 2 and 10000, got {}",
                            p.poses
                        ),
                    ));
                }
                positive(src, &["seed-003", "turns"], p.turns, "seed-003.turns")?;
                if !(p.tilt.from.is_finite() && p.tilt.to.is_finite()) {
                    return Err(
                        src.error_at(&["seed-003", "tilt"], "seed-003.tilt must be two angles")
                    );
                }
                SpherePattern::Seed003 {
                    poses: p.poses,
                    tilt: (p.tilt.from, p.tilt.to),
                    turns: p.turns,
                }
            }
            other => {
                return Err(src.error_at(
                    &["pattern"],
                    format!("pattern: unknown `{other}`: expected seed-004 or seed-003"),
                ));
            }
        };
        positive(
            src,
            &["check", "radius_tolerance"],
            f.check.radius_tolerance,
            "check.radius_tolerance",
        )?;
        positive(
            src,
            &["check", "form_tolerance"],
            f.check.form_tolerance,
            "check.form_tolerance",
        )?;
        Ok(SphereTemplate {
            diameter: s.diameter,
            position: Vector2::new(s.position[0], s.position[1]),
            height: s.height,
            stem_diameter: s.stem_diameter,
            touches,
            pattern,
            radius_tolerance: f.check.radius_tolerance,
            form_tolerance: f.check.form_tolerance,
            probing: settings(src, &f.probing)?,
            probe: stylus(src, &f.probe)?,
            source,
        })
    }

    /// The per-pose sphere check for touches logged as ball centres of a
    /// ball of radius `ball_radius`.
    pub fn sphere_check(&self, ball_radius: f64) -> crate::fit::SphereCheck {
        crate::fit::SphereCheck {
            expected_radius: self.diameter / 2.0 + ball_radius,
            radius_tolerance: self.radius_tolerance,
            form_tolerance: self.form_tolerance,
        }
    }
}

/// Either probing template, chosen by its `test:` key.
#[derive(Clone, Debug, PartialEq)]
pub enum ProbeTemplate {
    /// `probe-columns`.
    Columns(ColumnsTemplate),
    /// `probe-sphere`.
    Sphere(SphereTemplate),
}

/// The names of the probing tests.
pub const PROBING_TESTS: [&str; 2] = ["probe-columns", "probe-sphere"];

impl ProbeTemplate {
    /// The built-in template of a probing test.
    pub fn builtin(test: &str) -> Option<ProbeTemplate> {
        match test {
            "probe-columns" => Some(ProbeTemplate::Columns(ColumnsTemplate::builtin())),
            "probe-sphere" => Some(ProbeTemplate::Sphere(SphereTemplate::builtin())),
            _ => None,
        }
    }

    /// Parses a template of either test, as its `test:` key says.
    pub fn parse(source: TemplateSource) -> Result<ProbeTemplate, SourceError> {
        #[derive(Deserialize)]
        struct Head {
            #[serde(default)]
            test: Option<String>,
        }
        crate::input::check_yaml(&source.path, &source.text)?;
        let head: Head = serde_yaml::from_str(&source.text)
            .map_err(|e| SourceError::from_yaml(&source.path, &e))?;
        match head.test.as_deref() {
            Some("probe-columns") => ColumnsTemplate::parse(source).map(ProbeTemplate::Columns),
            Some("probe-sphere") => SphereTemplate::parse(source).map(ProbeTemplate::Sphere),
            Some(other) => Err(source.error_at(
                &["test"],
                format!(
                    "`test: {other}` is not a probing test: expected probe-columns or probe-sphere"
                ),
            )),
            None => Err(SourceError::new(
                &source.path,
                1,
                1,
                "a probing template needs `test: probe-columns` or `test: probe-sphere`",
            )),
        }
    }

    /// The test name.
    pub fn test(&self) -> &'static str {
        match self {
            ProbeTemplate::Columns(_) => "probe-columns",
            ProbeTemplate::Sphere(_) => "probe-sphere",
        }
    }

    /// Where it came from, with its text.
    pub fn source(&self) -> &TemplateSource {
        match self {
            ProbeTemplate::Columns(t) => &t.source,
            ProbeTemplate::Sphere(t) => &t.source,
        }
    }

    /// Its probing settings.
    pub fn probing(&self) -> &ProbingSettings {
        match self {
            ProbeTemplate::Columns(t) => &t.probing,
            ProbeTemplate::Sphere(t) => &t.probing,
        }
    }
}
