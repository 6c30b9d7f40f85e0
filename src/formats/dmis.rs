//! DMIS output (`.dmo`, `.out`; ANSI/DMIS 105 OUTPUT statements): the
//! vendor-neutral file most CMMs write. A measured point is a pair of
//! statements joined by label: the nominal `F(label)=FEAT/POINT,CART,x,y,z,i,j,k`
//! and the actual `FA(label)=FEAT/POINT,CART,x,y,z[,i,j,k]`.
//!
//! ```text
//! DMISMN/'stepped-square',04.0
//! UNITS/MM,ANGDEC
//! F(P0001)=FEAT/POINT,CART,-20.0000,-30.0000,45.0000,0.0000,-1.0000,0.0000
//! FA(P0001)=FEAT/POINT,CART,-19.9981,-30.0042,45.0007,0.0000,-1.0000,0.0000
//! T(P0001_DN)=TOL/PROFP,-0.0500,0.0500
//! TA(P0001_DN)=TOL/PROFP,-0.0042,INTOL
//! ENDFIL
//! ```
//!
//! The reader follows what real files do rather than only the standard
//! (see `notes/formats-and-crates.md` A.1): a line ending in `$` continues on
//! the next line and the two are joined by raw concatenation (real files
//! break inside labels and numbers); `$$` starts a comment, except that a
//! line ending in `,$$` is a continuation (a quirk of some writers, reported
//! as a warning); the verdicts `OUTTOL` and `OUTOL` are both accepted;
//! nominal lines may carry more fields than actual lines; whitespace after
//! commas is ignored; `UNITS/INCH` converts to mm; `POL` points are
//! converted to Cartesian. Every error names the file, line and column.
//!
//! The writer produces the same shape, so the simulator writes what a CMM
//! writes and the reader is tested against its own output as well as
//! against hand-written quirky files.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::Path;

use nalgebra::Vector3;

pub use super::inventory::Nominal;
use super::inventory::{Entry, Inventory, Unread};
use super::measured::MeasuredPoint;
use super::points::fmt_num;
use crate::source::SourceError;

/// One DMIS statement assembled from its lines, with the position of every
/// character in the source so that fields can be located exactly.
#[derive(Debug)]
struct Statement {
    text: String,
    /// (offset in `text`, 1-based line, 1-based column) at the start of each
    /// source segment, in order.
    segments: Vec<(usize, usize, usize)>,
}

impl Statement {
    /// Line and column of byte offset `off` in the statement.
    fn locate(&self, off: usize) -> (usize, usize) {
        let seg = self
            .segments
            .iter()
            .rev()
            .find(|s| s.0 <= off)
            .copied()
            .unwrap_or((0, 1, 1));
        (seg.1, seg.2 + off - seg.0)
    }

    fn line(&self) -> usize {
        self.segments.first().map_or(0, |s| s.1)
    }
}

/// Finds the start of a `$$` comment outside quotes, if any.
fn comment_start(s: &str) -> Option<usize> {
    let b = s.as_bytes();
    let mut quoted = false;
    let mut i = 0;
    while i < b.len() {
        match b[i] {
            b'\'' => quoted = !quoted,
            b'$' if !quoted && i + 1 < b.len() && b[i + 1] == b'$' => return Some(i),
            _ => {}
        }
        i += 1;
    }
    None
}

/// Splits the source into statements, joining continuation lines.
fn statements(src: &str, warnings: &mut Vec<String>) -> Vec<Statement> {
    let mut out: Vec<Statement> = Vec::new();
    let mut cur: Option<Statement> = None;
    let mut dollar_quirks: Vec<usize> = Vec::new();
    for (i, raw) in src.lines().enumerate() {
        let line = i + 1;
        let raw = raw.strip_suffix('\r').unwrap_or(raw);
        let mut body = raw;
        let mut quirk = false;
        if let Some(c) = comment_start(body) {
            let before = body[..c].trim_end();
            // `,$$` at the end of a line: the writer meant a continuation.
            if before.ends_with(',') && body[c + 2..].trim().is_empty() {
                quirk = true;
            }
            body = &body[..c];
        }
        let trimmed_end = body.trim_end();
        let (content, continues) = if quirk {
            (trimmed_end, true)
        } else if let Some(s) = trimmed_end.strip_suffix('$') {
            (s, true)
        } else {
            (trimmed_end, false)
        };
        if quirk {
            dollar_quirks.push(line);
        }
        let lead = if cur.is_none() {
            content.len() - content.trim_start().len()
        } else {
            0
        };
        let piece = &content[lead..];
        // A line that starts with a comma continues the statement before
        // it, whose writer wrapped it without the `$` (a real writer does
        // this inside long OUTPUT lists).
        if cur.is_none()
            && piece.starts_with(',')
            && let Some(prev) = out.pop()
        {
            warnings.push(format!(
                "line {line}: a line starting with `,` read as the continuation of line {} (its `$` is missing)",
                prev.line()
            ));
            cur = Some(prev);
        }
        let st = cur.get_or_insert_with(|| Statement {
            text: String::new(),
            segments: Vec::new(),
        });
        if !piece.is_empty() {
            st.segments.push((st.text.len(), line, lead + 1));
            st.text.push_str(piece);
        }
        if !continues {
            let st = cur.take().unwrap();
            if !st.text.trim().is_empty() {
                out.push(st);
            }
        }
    }
    if let Some(st) = cur.take()
        && !st.text.trim().is_empty()
    {
        warnings.push(format!(
            "line {}: the file ends inside a continued statement",
            st.line()
        ));
        out.push(st);
    }
    if let Some(first) = dollar_quirks.first() {
        warnings.push(format!(
            "line {first}: `,$$` at the end of a line read as a continuation ({} lines; in standard DMIS `$$` starts a comment)",
            dollar_quirks.len()
        ));
    }
    out
}

/// Length unit of the file.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Units {
    Mm,
    Inch,
}

/// What a feature is.
#[derive(Clone, Debug, PartialEq)]
pub enum FeatureKind {
    /// A surface point.
    Point,
    /// A sphere (centre and diameter).
    Sphere,
    /// Anything else (kept with its name; not used for identification).
    Other(String),
}

/// The data of one `F(..)` or `FA(..)` statement, lengths in mm.
#[derive(Clone, Debug, PartialEq)]
pub struct FeatureData {
    /// Kind of feature.
    pub kind: FeatureKind,
    /// Position (point, or sphere centre), mm.
    pub xyz: Vector3<f64>,
    /// Direction (surface normal of a point), when given.
    pub ijk: Option<Vector3<f64>>,
    /// Diameter of a sphere (the size of a circle, cylinder or cone), mm.
    pub diameter: Option<f64>,
    /// 1-based line of the statement.
    pub line: usize,
}

/// A label with its nominal and actual data.
#[derive(Clone, Debug, PartialEq)]
pub struct DmisFeature {
    /// The feature label.
    pub label: String,
    /// `F(label)`.
    pub nominal: Option<FeatureData>,
    /// `FA(label)`.
    pub actual: Option<FeatureData>,
}

/// An actual tolerance result, `TA(label)=TOL/<kind>,<deviation>,<verdict>`.
#[derive(Clone, Debug, PartialEq)]
pub struct ToleranceResult {
    /// The tolerance label.
    pub label: String,
    /// Tolerance kind (`PROFP`, `CORTOL`, ...).
    pub kind: String,
    /// The reported deviation, mm (the last number before the verdict).
    pub deviation: f64,
    /// Whether the CMM flagged it out of tolerance (`OUTTOL` or `OUTOL`).
    pub out_of_tolerance: bool,
    /// 1-based line.
    pub line: usize,
}

/// A parsed DMIS output file.
#[derive(Clone, Debug, PartialEq)]
pub struct DmisOutput {
    /// The DMIS version of `DMISMN/'name',version`, if stated.
    pub version: Option<String>,
    /// Whether the file said `UNITS/INCH` (every length is in mm anyway).
    pub inch: bool,
    /// Features in order of first appearance.
    pub features: Vec<DmisFeature>,
    /// Actual tolerance results.
    pub tolerances: Vec<ToleranceResult>,
    /// Statements of a DMIS program (MEAS/, PTMEAS/, GOTO/) met: the file
    /// is a program to run on a CMM, not what a CMM wrote.
    pub program_statements: usize,
    /// Features not read, and why.
    pub skipped: Vec<Unread>,
    /// Quirks met on the way (not errors).
    pub warnings: Vec<String>,
}

impl DmisOutput {
    /// The measured points (actual `POINT` features) in canonical form.
    pub fn measured_points(&self) -> Vec<MeasuredPoint> {
        self.features
            .iter()
            .filter_map(|f| {
                let a = f.actual.as_ref()?;
                (a.kind == FeatureKind::Point).then(|| MeasuredPoint {
                    label: f.label.clone(),
                    p: a.xyz,
                    line: a.line,
                    normal: None,
                })
            })
            .collect()
    }

    /// Nominal points by label (the CMM program's nominals, in its
    /// alignment), with their directions where given.
    pub fn nominal_points(&self) -> Vec<Nominal> {
        self.features
            .iter()
            .filter_map(|f| {
                let n = f.nominal.as_ref()?;
                (n.kind == FeatureKind::Point).then(|| Nominal {
                    label: f.label.clone(),
                    p: n.xyz,
                    n: n.ijk,
                    line: n.line,
                })
            })
            .collect()
    }

    /// Everything the file holds, for `fivecal measured`: each feature with
    /// its nominal and actual, each actual tolerance with its deviation.
    pub fn inventory(&self) -> Inventory {
        let mut inv = Inventory::new("dmis");
        inv.version.clone_from(&self.version);
        inv.units = if self.inch { "inch" } else { "mm" }.into();
        for f in &self.features {
            let any = f.actual.as_ref().or(f.nominal.as_ref());
            let kind = match any.map(|d| &d.kind) {
                Some(FeatureKind::Point) | None => "point".to_string(),
                Some(FeatureKind::Sphere) => "sphere".to_string(),
                Some(FeatureKind::Other(k)) => k.to_ascii_lowercase(),
            };
            let line = any.map_or(0, |d| d.line);
            let mut e = Entry::new(f.label.clone(), kind, line);
            e.nominal = f.nominal.as_ref().map(|d| d.xyz);
            e.actual = f.actual.as_ref().map(|d| d.xyz);
            e.normal = f
                .actual
                .as_ref()
                .and_then(|d| d.ijk)
                .or_else(|| f.nominal.as_ref().and_then(|d| d.ijk));
            e.value = f
                .actual
                .as_ref()
                .and_then(|d| d.diameter)
                .or_else(|| f.nominal.as_ref().and_then(|d| d.diameter));
            inv.entries.push(e);
        }
        for t in &self.tolerances {
            let mut e = Entry::new(
                t.label.clone(),
                format!("tol/{}", t.kind.to_ascii_lowercase()),
                t.line,
            );
            e.value = Some(t.deviation);
            inv.entries.push(e);
        }
        inv.skipped.clone_from(&self.skipped);
        inv.warnings.clone_from(&self.warnings);
        inv
    }
}

/// Whether a text looks like DMIS output: its first statements are DMIS
/// keywords or feature definitions.
pub(crate) fn looks_like_dmis(src: &str) -> bool {
    src.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with("$$"))
        .take(8)
        .any(|l| {
            let u = l.to_ascii_uppercase();
            u.starts_with("DMISMN/")
                || u.starts_with("FA(")
                || (u.starts_with("F(") && u.contains("FEAT/"))
                || u.starts_with("OUTPUT/")
                || u.starts_with("UNITS/")
        })
}

/// Skips ASCII whitespace from byte `i` of `s`.
fn skip_ws(s: &str, mut i: usize) -> usize {
    let b = s.as_bytes();
    while i < b.len() && (b[i] == b' ' || b[i] == b'\t') {
        i += 1;
    }
    i
}

/// `kw` (ASCII, upper case) at byte `i` of `s`, case-insensitively, with
/// whitespace before it skipped: the offset after it.
fn keyword(s: &str, i: usize, kw: &str) -> Option<usize> {
    let i = skip_ws(s, i);
    let end = i + kw.len();
    (s.get(i..end)?.eq_ignore_ascii_case(kw)).then_some(end)
}

/// The label of `F(label)`, `FA(label)`, `TA(label)` starting at `open`
/// (just after the letters): (label, offset after `)`).
fn label_at(s: &str, open: usize) -> Option<(String, usize)> {
    let i = keyword(s, open, "(")?;
    let close = s[i..].find(')')? + i;
    Some((s[i..close].trim().to_string(), close + 1))
}

/// Parses DMIS output text.
pub fn parse(path: &Path, src: &str) -> Result<DmisOutput, SourceError> {
    let mut warnings = Vec::new();
    let stmts = statements(src, &mut warnings);
    let mut units = Units::Mm;
    let mut version = None;
    let mut features: Vec<DmisFeature> = Vec::new();
    let mut tolerances = Vec::new();
    let mut skipped = Vec::new();
    let mut program_statements = 0;
    let mut index: HashMap<String, usize> = HashMap::new();
    for st in &stmts {
        let text = st.text.as_str();
        let upper = text.to_ascii_uppercase();
        let err = |off: usize, msg: String| {
            let (l, c) = st.locate(off);
            SourceError::new(path, l, c, msg)
        };
        if upper.starts_with("DMISMN/") {
            // DMISMN/'name',version: the version after the quoted name.
            if let Some(q) = text.rfind('\'')
                && let Some(v) = text[q + 1..].trim().strip_prefix(',')
            {
                version = Some(v.trim().to_string());
            }
            continue;
        }
        if ["MEAS/", "PTMEAS/", "GOTO/", "ENDMES"]
            .iter()
            .any(|k| upper.starts_with(k))
        {
            program_statements += 1;
            continue;
        }
        if let Some(rest) = upper.strip_prefix("UNITS/") {
            let first = rest.split(',').next().unwrap_or("").trim();
            units = match first {
                "MM" => Units::Mm,
                "INCH" => Units::Inch,
                other => {
                    return Err(err(
                        6,
                        format!("UNITS/{other} is not supported: expected MM or INCH"),
                    ));
                }
            };
            if let Some(ang) = rest.split(',').nth(1)
                && ang.trim() != "ANGDEC"
            {
                return Err(err(
                    6 + rest.find(',').unwrap_or(0) + 1,
                    format!(
                        "angle unit {} is not supported: expected ANGDEC",
                        ang.trim()
                    ),
                ));
            }
            continue;
        }
        if upper.starts_with("TA(") || upper.starts_with("TA ") {
            if let Some(t) = parse_tolerance(text, st, path, units, &mut warnings)? {
                tolerances.push(t);
            }
            continue;
        }
        let (actual, open) = if upper.starts_with("FA") && keyword(&upper, 2, "(").is_some() {
            (true, 2)
        } else if upper.starts_with('F') && keyword(&upper, 1, "(").is_some() {
            (false, 1)
        } else {
            continue;
        };
        let Some((label, after)) = label_at(text, open) else {
            return Err(err(0, "expected `)` closing the feature label".into()));
        };
        if label.is_empty() {
            return Err(err(open + 1, "missing feature label".into()));
        }
        // `=FEAT/`, with whatever spaces a writer puts around the tokens.
        let Some(body_off) = keyword(&upper, after, "=")
            .and_then(|i| keyword(&upper, i, "FEAT"))
            .and_then(|i| keyword(&upper, i, "/"))
        else {
            // F(x)=... statements that are not features are not ours to read.
            continue;
        };
        let data = match parse_feature(&text[body_off..], body_off, units, st, path)? {
            Ok(d) => d,
            Err(why) => {
                skipped.push(Unread {
                    line: st.line(),
                    what: format!("{}({label})", if actual { "FA" } else { "F" }),
                    why,
                });
                continue;
            }
        };
        let i = *index.entry(label.clone()).or_insert_with(|| {
            features.push(DmisFeature {
                label: label.clone(),
                nominal: None,
                actual: None,
            });
            features.len() - 1
        });
        let slot = if actual {
            &mut features[i].actual
        } else {
            &mut features[i].nominal
        };
        if let Some(prev) = slot {
            return Err(err(
                0,
                format!(
                    "{}({label}) appears twice (first at line {})",
                    if actual { "FA" } else { "F" },
                    prev.line
                ),
            ));
        }
        *slot = Some(data);
    }
    Ok(DmisOutput {
        version,
        inch: units == Units::Inch,
        features,
        tolerances,
        program_statements,
        skipped,
        warnings,
    })
}

/// `TA(label)=TOL/<kind>,...,<deviation>,<verdict>`; the verdict is
/// `INTOL`, `OUTTOL` (as real files write it) or `OUTOL` (the standard's
/// spelling).
fn parse_tolerance(
    text: &str,
    st: &Statement,
    path: &Path,
    units: Units,
    warnings: &mut Vec<String>,
) -> Result<Option<ToleranceResult>, SourceError> {
    let Some((label, after)) = label_at(text, 2) else {
        return Ok(None);
    };
    let Some(body_at) = keyword(text, after, "=")
        .and_then(|i| keyword(text, i, "TOL"))
        .and_then(|i| keyword(text, i, "/"))
    else {
        return Ok(None);
    };
    let body = &text[body_at..];
    let fields: Vec<&str> = body.split(',').map(str::trim).collect();
    let verdict = fields.last().copied().unwrap_or("").to_ascii_uppercase();
    let out = match verdict.as_str() {
        "INTOL" => false,
        "OUTTOL" | "OUTOL" => true,
        other => {
            warnings.push(format!(
                "line {}: TA({label}) has verdict `{other}`; expected INTOL, OUTTOL or OUTOL",
                st.line()
            ));
            return Ok(None);
        }
    };
    let dev_field = fields.len().checked_sub(2).map(|i| fields[i]).unwrap_or("");
    let deviation = match dev_field.parse::<f64>() {
        Ok(v) if v.is_finite() => v,
        _ => {
            let off = text.rfind(dev_field).unwrap_or(0);
            let (l, c) = st.locate(off);
            return Err(SourceError::new(
                path,
                l,
                c,
                format!("expected the deviation of TA({label}) as a number, got `{dev_field}`"),
            ));
        }
    };
    Ok(Some(ToleranceResult {
        label,
        kind: fields[0].to_ascii_uppercase(),
        deviation: deviation * if units == Units::Inch { 25.4 } else { 1.0 },
        out_of_tolerance: out,
        line: st.line(),
    }))
}

/// Reads a file.
pub fn read(path: &Path) -> Result<DmisOutput, SourceError> {
    let src = crate::input::read_text(path, "DMIS file", crate::limits::MAX_MEASUREMENT_BYTES)?;
    parse(path, &src)
}

/// Parses `POINT,CART,x,y,z,...` (the text after `FEAT/`) at offset `off`.
/// A point or sphere must be well formed (an error names the field); any
/// other feature is read as far as it goes and, where it has no position,
/// comes back as the reason it was skipped.
fn parse_feature(
    body: &str,
    off: usize,
    units: Units,
    st: &Statement,
    path: &Path,
) -> Result<Result<FeatureData, String>, SourceError> {
    // Fields with their offsets in the statement.
    let mut fields: Vec<(usize, &str)> = Vec::new();
    let mut start = 0;
    for part in body.split(',') {
        let lead = part.len() - part.trim_start().len();
        fields.push((off + start + lead, part.trim()));
        start += part.len() + 1;
    }
    let err = |at: usize, msg: String| {
        let (l, c) = st.locate(at);
        SourceError::new(path, l, c, msg)
    };
    let line = st.line();
    let kind_name = fields[0].1.to_ascii_uppercase();
    let strict = matches!(kind_name.as_str(), "POINT" | "SPHERE");
    let scale = match units {
        Units::Mm => 1.0,
        Units::Inch => 25.4,
    };
    // A number, or None for a missing or empty field (real writers leave
    // the fields they do not know empty: `CART,,,,0,0,1,22`).
    let opt = |i: usize, what: &str| -> Result<Option<f64>, SourceError> {
        let Some(&(at, s)) = fields.get(i) else {
            return Ok(None);
        };
        if s.is_empty() {
            return Ok(None);
        }
        match s.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(Some(v)),
            Ok(_) => Err(err(
                at,
                format!("expected a finite number for {what}, got `{s}`"),
            )),
            Err(_) => Err(err(at, format!("expected a number for {what}, got `{s}`"))),
        }
    };
    // Qualifiers (INNER/OUTER, ROUND/FLAT, ...), then CART or POL.
    let Some(k) = fields
        .iter()
        .position(|f| matches!(f.1.to_ascii_uppercase().as_str(), "CART" | "POL"))
    else {
        if strict {
            let at = fields.get(1).map_or(off, |f| f.0);
            return Err(err(
                at,
                format!(
                    "expected CART or POL after FEAT/{kind_name}, got `{}`",
                    fields.get(1).map_or("", |f| f.1)
                ),
            ));
        }
        return Ok(Err(format!(
            "FEAT/{kind_name} without CART or POL coordinates"
        )));
    };
    let polar = fields[k].1.eq_ignore_ascii_case("POL");
    let k = k + 1;
    let coords = if strict {
        let need = |i: usize, what: &str| -> Result<f64, SourceError> {
            opt(i, what)?.ok_or_else(|| {
                let at = fields
                    .get(i)
                    .map_or_else(|| fields.last().map_or(off, |f| f.0 + f.1.len()), |f| f.0);
                err(at, format!("expected a number for {what}, got ``"))
            })
        };
        Some((need(k, "x")?, need(k + 1, "y")?, need(k + 2, "z")?))
    } else {
        match (opt(k, "x"), opt(k + 1, "y"), opt(k + 2, "z")) {
            (Ok(Some(a)), Ok(Some(b)), Ok(Some(c))) => Some((a, b, c)),
            _ => None,
        }
    };
    let Some((a, b, c)) = coords else {
        return Ok(Err(format!(
            "FEAT/{kind_name} without a position (empty or unreadable x, y, z)"
        )));
    };
    let xyz = if polar {
        // POL: radius, angle (deg), height.
        Vector3::new(a * b.to_radians().cos(), a * b.to_radians().sin(), c) * scale
    } else {
        Vector3::new(a, b, c) * scale
    };
    let k = k + 3;
    let kind = match kind_name.as_str() {
        "POINT" => FeatureKind::Point,
        "SPHERE" => FeatureKind::Sphere,
        other => FeatureKind::Other(other.to_string()),
    };
    let mut ijk = None;
    let mut diameter = None;
    match kind {
        FeatureKind::Point => {
            // i, j, k when present (renormalized: writers print 4
            // decimals; refused when not a unit vector); anything beyond is an extra field, ignored.
            let given = (k..k + 3)
                .filter(|&i| fields.get(i).is_some_and(|f| !f.1.is_empty()))
                .count();
            match given {
                0 => {}
                3 => {
                    let v = Vector3::new(
                        opt(k, "i")?.unwrap_or(0.0),
                        opt(k + 1, "j")?.unwrap_or(0.0),
                        opt(k + 2, "k")?.unwrap_or(0.0),
                    );
                    ijk = Some(
                        super::unit_direction(v, "the direction i,j,k of a point")
                            .map_err(|m| err(fields[k].0, m))?,
                    );
                }
                n => {
                    return Err(err(
                        fields[k].0,
                        format!(
                            "a point carries x,y,z or x,y,z,i,j,k; got {} numbers",
                            n + 3
                        ),
                    ));
                }
            }
        }
        FeatureKind::Sphere => {
            diameter = Some(
                opt(k, "diameter")?.ok_or_else(|| {
                    err(
                        fields.get(k).map_or(off, |f| f.0),
                        "missing the diameter of the sphere".into(),
                    )
                })? * scale,
            );
        }
        FeatureKind::Other(_) => {
            // Circles, cylinders, cones...: i, j, k, and then the diameter
            // of a circle or cylinder, when given.
            if let (Ok(Some(i)), Ok(Some(j)), Ok(Some(kk))) =
                (opt(k, "i"), opt(k + 1, "j"), opt(k + 2, "k"))
            {
                // Only informative here: a direction that is not a rounded
                // unit vector is dropped, never stretched into one.
                ijk = super::unit_direction(Vector3::new(i, j, kk), "").ok();
            }
            if matches!(kind_name.as_str(), "CIRCLE" | "CYLINDER")
                && let Ok(Some(d)) = opt(k + 3, "size")
            {
                diameter = Some(d * scale);
            }
        }
    }
    Ok(Ok(FeatureData {
        kind,
        xyz,
        ijk,
        diameter,
        line,
    }))
}

/// One point as a CMM reports it.
#[derive(Clone, Debug, PartialEq)]
pub struct DmisPoint {
    /// Label (the plan point's).
    pub label: String,
    /// Nominal position and direction (the CMM program's), mm.
    pub nominal: (Vector3<f64>, Vector3<f64>),
    /// Measured position, mm.
    pub actual: Vector3<f64>,
}

/// Options of [`write_output`].
#[derive(Clone, Debug)]
pub struct WriteOptions {
    /// Program name in `DMISMN`.
    pub name: String,
    /// Profile tolerance for the `TA(..)=TOL/PROFP` verdicts, mm; `None`
    /// writes no tolerance statements.
    pub tolerance: Option<f64>,
    /// Decimal places of coordinates (CMMs write 4 or 5).
    pub decimals: usize,
}

impl Default for WriteOptions {
    fn default() -> Self {
        WriteOptions {
            name: "fivecal".into(),
            tolerance: Some(0.05),
            decimals: 5,
        }
    }
}

/// Writes DMIS output as a CMM does: a header, then for each point its
/// nominal and actual features and, optionally, the profile deviation
/// along the nominal direction with its verdict (`INTOL`/`OUTOL`).
pub fn write_output(points: &[DmisPoint], opts: &WriteOptions) -> String {
    let d = opts.decimals;
    let mut s = String::new();
    let _ = writeln!(s, "DMISMN/'{}',04.0", opts.name.replace('\'', ""));
    s.push_str("UNITS/MM,ANGDEC\n");
    let v3 = |v: &Vector3<f64>, d: usize| {
        format!(
            "{},{},{}",
            fmt_num(v.x, d),
            fmt_num(v.y, d),
            fmt_num(v.z, d)
        )
    };
    for p in points {
        let (np, nn) = &p.nominal;
        let mut out = format!("OUTPUT/F({0}),FA({0})", p.label);
        if opts.tolerance.is_some() {
            let _ = write!(out, ",T({0}_DN),TA({0}_DN)", p.label);
        }
        let _ = writeln!(s, "{out}");
        let _ = writeln!(
            s,
            "F({})=FEAT/POINT,CART,{},{}",
            p.label,
            v3(np, d),
            v3(nn, 6)
        );
        let _ = writeln!(
            s,
            "FA({})=FEAT/POINT,CART,{},{}",
            p.label,
            v3(&p.actual, d),
            v3(nn, 6)
        );
        if let Some(t) = opts.tolerance {
            let dev = nn.dot(&(p.actual - np));
            let _ = writeln!(
                s,
                "T({}_DN)=TOL/PROFP,{},{}",
                p.label,
                fmt_num(-t, d),
                fmt_num(t, d)
            );
            let verdict = if dev.abs() <= t { "INTOL" } else { "OUTOL" };
            let _ = writeln!(
                s,
                "TA({}_DN)=TOL/PROFP,{},{verdict}",
                p.label,
                fmt_num(dev, d)
            );
        }
    }
    s.push_str("ENDFIL\n");
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn joins_continuations_by_raw_concatenation() {
        let src = "FA(P0$\n001)=FEAT/POINT,CART,1.5,2.$\n25,3\n";
        let o = parse(Path::new("m.dmo"), src).unwrap();
        let p = o.measured_points();
        assert_eq!(p[0].label, "P0001");
        assert_eq!(p[0].p, Vector3::new(1.5, 2.25, 3.0));
        assert_eq!(p[0].line, 1);
    }

    #[test]
    fn locates_fields_across_continuation_lines() {
        let src = "UNITS/MM,ANGDEC\nFA(P1)=FEAT/POINT,CART,1,$\n  2,x3\n";
        let e = parse(Path::new("m.dmo"), src).unwrap_err().to_string();
        assert_eq!(e, "m.dmo:3:5: expected a number for z, got `x3`");
    }
}
