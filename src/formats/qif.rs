//! QIF results (ISO 23952, Quality Information Framework 3.0; the 2.x
//! files as far as they share its shape): the XML most modern CMM software
//! exports.
//!
//! What is read, per measurement run (`Results/MeasurementResultsSet/
//! MeasurementResults`, one run per measured piece):
//! - each feature measurement (`PointFeatureMeasurement`, ...; QIF 2
//!   `...FeatureActual`), joined to its name and nominal through the id
//!   chain measurement -> `FeatureItemId` -> feature item (`FeatureName`,
//!   `FeatureNominalId`) -> feature nominal (`Location`, `Normal`, or an
//!   `Axis` with `AxisPoint` and `Direction`);
//! - its measured location and normal, and the raw points of its
//!   `PointList`: a `MeasuredPointSet` referenced whole
//!   (`WholePointSetId`), by a 1-based range (`RangePointSetId range="3 8"`)
//!   or by index (`SinglePointSetId index="1"`). Points of a set with
//!   `Compensated` false are probe-ball centres; they are moved onto the
//!   surface by `ProbeRadius` against the normal (the set's own `Normals`,
//!   else the feature's measured normal, else its nominal one). A point
//!   feature without a `Location` takes the mean of its surface points;
//! - characteristic measurements (`DiameterCharacteristicMeasurement`, ...)
//!   with their `Value`, reported as the file states them, never turned
//!   into coordinates.
//!
//! Lengths are converted to mm by the `FileUnits` linear unit (its
//! `UnitConversion` factor to metres, or its name); a file with
//! coordinates and no units is refused unless the user names the unit. A
//! file without results (a plan, a product definition) or whose results
//! are kept in another QIF file (`ExternalQIFReferences`) is refused with
//! what it is. Ignored: datums, tolerances, statistics, transforms of the
//! measurement coordinate systems (coordinates are taken as written, in
//! the part frame of the CMM program), and the measurement resources.

use std::collections::HashMap;
use std::path::Path;

use nalgebra::Vector3;
use roxmltree::{Document, Node};

use super::inventory::{Entry, Inventory, MeasuredOptions, Unread};
use crate::source::SourceError;

/// Whether a text is a QIF document.
pub(crate) fn looks_like_qif(src: &str) -> bool {
    let head: String = src.chars().take(4000).collect();
    head.trim_start().starts_with('<') && head.contains("<QIFDocument")
}

/// Local name of an element.
fn name<'a>(n: &Node<'a, '_>) -> &'a str {
    n.tag_name().name()
}

/// The first child element named `tag`.
fn child<'a, 'i>(n: Node<'a, 'i>, tag: &str) -> Option<Node<'a, 'i>> {
    n.children().find(|c| c.is_element() && name(c) == tag)
}

/// Text of all text nodes under `n` (comments inside `Points` are left
/// out), trimmed.
fn text_of(n: Node<'_, '_>) -> String {
    let mut s = String::new();
    for d in n.descendants().filter(|d| d.is_text()) {
        s.push_str(d.text().unwrap_or(""));
        s.push(' ');
    }
    s.trim().to_string()
}

/// A location and a direction, each where given.
type Place = (Option<Vector3<f64>>, Option<Vector3<f64>>);

/// The point sets a point list refers to (named for messages), and the
/// references that lead nowhere.
type PointRefs = (Vec<(String, PointSetData)>, Vec<String>);

struct Ctx<'a, 'i> {
    path: &'a Path,
    doc: &'a Document<'i>,
}

impl Ctx<'_, '_> {
    fn err(&self, n: Node<'_, '_>, msg: String) -> SourceError {
        let p = self.doc.text_pos_at(n.range().start);
        SourceError::new(self.path, p.row as usize, p.col as usize, msg)
    }

    fn line(&self, n: Node<'_, '_>) -> usize {
        self.doc.text_pos_at(n.range().start).row as usize
    }

    /// The numbers of an element's text.
    fn numbers(&self, n: Node<'_, '_>) -> Result<Vec<f64>, SourceError> {
        text_of(n)
            .split_whitespace()
            .map(|t| match t.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(v),
                _ => Err(self.err(n, format!("<{}>: expected numbers, got `{t}`", name(&n)))),
            })
            .collect()
    }

    /// Three numbers (a point or a direction).
    fn triple(&self, n: Node<'_, '_>) -> Result<Vector3<f64>, SourceError> {
        let v = self.numbers(n)?;
        if v.len() != 3 {
            return Err(self.err(
                n,
                format!(
                    "<{}>: expected three numbers x y z, got {}",
                    name(&n),
                    v.len()
                ),
            ));
        }
        Ok(Vector3::new(v[0], v[1], v[2]))
    }

    /// A unit direction (renormalized when rounded, refused when not one).
    fn direction(&self, n: Node<'_, '_>) -> Result<Vector3<f64>, SourceError> {
        let v = self.triple(n)?;
        super::unit_direction(v, &format!("<{}>", name(&n))).map_err(|m| self.err(n, m))
    }

    /// Location and direction of a feature nominal or measurement:
    /// `Location`/`Normal`, or `Axis/AxisPoint`/`Axis/Direction`.
    fn place(&self, n: Node<'_, '_>) -> Result<Place, SourceError> {
        let mut loc = None;
        let mut dir = None;
        if let Some(l) = child(n, "Location") {
            loc = Some(self.triple(l)?);
        }
        if let Some(d) = child(n, "Normal") {
            dir = Some(self.direction(d)?);
        }
        if let Some(axis) = child(n, "Axis") {
            if loc.is_none()
                && let Some(p) = child(axis, "AxisPoint")
            {
                loc = Some(self.triple(p)?);
            }
            if dir.is_none()
                && let Some(d) = child(axis, "Direction")
            {
                dir = Some(self.direction(d)?);
            }
        }
        Ok((loc, dir))
    }
}

/// Millimetres per unit of the file's `FileUnits/PrimaryUnits/LinearUnit`,
/// with the unit's name.
fn file_units(ctx: &Ctx<'_, '_>) -> Result<Option<(f64, String)>, SourceError> {
    let Some(lin) = ctx
        .doc
        .descendants()
        .find(|n| name(n) == "FileUnits")
        .and_then(|u| child(u, "PrimaryUnits"))
        .and_then(|p| child(p, "LinearUnit"))
    else {
        return Ok(None);
    };
    let unit = child(lin, "UnitName").map(text_of).unwrap_or_default();
    if let Some(f) = child(lin, "UnitConversion").and_then(|c| child(c, "Factor")) {
        let v = ctx.numbers(f)?;
        match v.as_slice() {
            [x] if *x > 0.0 => return Ok(Some((x * 1000.0, unit))),
            _ => {
                return Err(ctx.err(
                    f,
                    "<Factor>: expected one positive number (metres per unit)".into(),
                ));
            }
        }
    }
    let mm = match unit.to_ascii_lowercase().as_str() {
        "mm" | "millimeter" | "millimetre" => 1.0,
        "inch" | "in" => 25.4,
        "m" | "meter" | "metre" => 1000.0,
        other => {
            return Err(ctx.err(
                lin,
                format!("unknown length unit `{other}` without a UnitConversion factor: expected mm, inch or m"),
            ));
        }
    };
    Ok(Some((mm, unit)))
}

/// A measured point set: its points (as written) and how to take them.
struct PointSetData {
    points: Vec<Vector3<f64>>,
    normals: Option<Vec<Vector3<f64>>>,
    compensated: bool,
    probe_radius: Option<f64>,
}

fn point_set(ctx: &Ctx<'_, '_>, n: Node<'_, '_>) -> Result<PointSetData, SourceError> {
    let triples = |tag: &str| -> Result<Option<Vec<Vector3<f64>>>, SourceError> {
        let Some(p) = child(n, tag) else {
            return Ok(None);
        };
        let v = ctx.numbers(p)?;
        if v.len() % 3 != 0 {
            return Err(ctx.err(
                p,
                format!("<{tag}>: expected x y z triples, got {} numbers", v.len()),
            ));
        }
        Ok(Some(
            v.chunks(3)
                .map(|c| Vector3::new(c[0], c[1], c[2]))
                .collect(),
        ))
    };
    let points = triples("Points")?.unwrap_or_default();
    let normals = triples("Normals")?;
    let compensated = child(n, "Compensated").is_none_or(|c| text_of(c) != "false");
    let probe_radius = match child(n, "ProbeRadius") {
        Some(r) => match ctx.numbers(r)?.as_slice() {
            [x] if *x >= 0.0 => Some(*x),
            _ => {
                return Err(ctx.err(r, "<ProbeRadius>: expected one number >= 0".into()));
            }
        },
        None => None,
    };
    if let Some(ns) = &normals
        && ns.len() != points.len()
    {
        return Err(ctx.err(
            n,
            format!(
                "<MeasuredPointSet>: {} points but {} normals",
                points.len(),
                ns.len()
            ),
        ));
    }
    Ok(PointSetData {
        points,
        normals,
        compensated,
        probe_radius,
    })
}

/// The points a `PointList` refers to, each reference as its own small
/// set (the chosen points with their compensation), with a name for
/// messages; a reference to a set the run does not have is returned as a
/// skipped note (a real writer refers to its feature's own id).
fn point_refs(
    ctx: &Ctx<'_, '_>,
    list: Node<'_, '_>,
    sets: &HashMap<String, PointSetData>,
) -> Result<PointRefs, SourceError> {
    let mut out = Vec::new();
    let mut dangling = Vec::new();
    for r in list.children().filter(|c| c.is_element()) {
        // QIF 2: the points inline, one `MeasurePoint` each.
        if name(&r) == "MeasurePoint" {
            let mut d = point_set(ctx, r)?;
            if let Some(p) = child(r, "Point") {
                d.points = vec![ctx.triple(p)?];
            }
            if let Some(n) = child(r, "Normal") {
                d.normals = Some(vec![ctx.direction(n)?]);
            }
            out.push((
                format!("MeasurePoint {}", r.attribute("id").unwrap_or("?")),
                d,
            ));
            continue;
        }
        let id = text_of(r);
        let Some(set) = sets.get(&id) else {
            dangling.push(format!(
                "<{}> refers to MeasuredPointSet id {id}, which the run does not have",
                name(&r)
            ));
            continue;
        };
        let n = set.points.len();
        let idx: Vec<usize> = match name(&r) {
            "WholePointSetId" => (0..n).collect(),
            "RangePointSetId" => {
                let range = r.attribute("range").unwrap_or("");
                let v: Vec<usize> = range
                    .split_whitespace()
                    .filter_map(|t| t.parse().ok())
                    .collect();
                match v.as_slice() {
                    [a, b] if 1 <= *a && a <= b && *b <= n => (a - 1..*b).collect(),
                    _ => {
                        return Err(ctx.err(
                            r,
                            format!(
                                "range=\"{range}\": expected two 1-based indices `first last` within the set's {n} points"
                            ),
                        ));
                    }
                }
            }
            "SinglePointSetId" => {
                let i = r.attribute("index").unwrap_or("");
                match i.parse::<usize>() {
                    Ok(k) if (1..=n).contains(&k) => vec![k - 1],
                    _ => {
                        return Err(ctx.err(
                            r,
                            format!(
                                "index=\"{i}\": expected a 1-based index within the set's {n} points"
                            ),
                        ));
                    }
                }
            }
            other => {
                return Err(ctx.err(
                    r,
                    format!("<{other}>: expected WholePointSetId, RangePointSetId, SinglePointSetId or MeasurePoint"),
                ));
            }
        };
        out.push((
            format!("MeasuredPointSet {id}"),
            PointSetData {
                points: idx.iter().map(|&k| set.points[k]).collect(),
                normals: set
                    .normals
                    .as_ref()
                    .map(|ns| idx.iter().map(|&k| ns[k]).collect()),
                compensated: set.compensated,
                probe_radius: set.probe_radius,
            },
        ));
    }
    Ok((out, dangling))
}

/// The feature kind of an element name, e.g. `point` for
/// `PointFeatureMeasurement`, `edge point` for `EdgePoint...`.
fn kind_of(element: &str, suffix: &str) -> String {
    let base = element.strip_suffix(suffix).unwrap_or(element);
    match base {
        "Point" | "EdgePoint" | "SurfacePoint" => "point".into(),
        other => {
            let mut s = String::new();
            for (i, c) in other.chars().enumerate() {
                if c.is_ascii_uppercase() && i > 0 {
                    s.push(' ');
                }
                s.push(c.to_ascii_lowercase());
            }
            s
        }
    }
}

/// Everything in a document with an id, for the id chains.
type Ids<'a, 'i> = HashMap<&'a str, Node<'a, 'i>>;

/// The element an id child `tag` of `n` refers to.
fn deref<'a, 'i>(by_id: &Ids<'a, 'i>, n: Node<'a, 'i>, tag: &str) -> Option<Node<'a, 'i>> {
    let id = text_of(child(n, tag)?);
    by_id.get(id.as_str()).copied()
}

/// Whether an element is a feature measurement (QIF 3) or actual (QIF 2).
fn is_feature(n: &Node<'_, '_>) -> bool {
    n.is_element()
        && (name(n).ends_with("FeatureMeasurement") || name(n).ends_with("FeatureActual"))
}

/// Whether an element is a characteristic measurement or actual.
fn is_characteristic(n: &Node<'_, '_>) -> bool {
    n.is_element()
        && (name(n).ends_with("CharacteristicMeasurement")
            || name(n).ends_with("CharacteristicActual"))
}

/// Reads a QIF document into an inventory (lengths in mm).
pub(crate) fn parse(
    path: &Path,
    src: &str,
    options: &MeasuredOptions,
) -> Result<Inventory, SourceError> {
    let doc = document(path, src)?;
    let ctx = Ctx { path, doc: &doc };
    let root = doc.root_element();
    if name(&root) != "QIFDocument" {
        return Err(ctx.err(
            root,
            format!(
                "expected a <QIFDocument> root element, got <{}>",
                name(&root)
            ),
        ));
    }
    let mut inv = Inventory::new("qif");
    inv.version = root.attribute("versionQIF").map(str::to_string);

    let by_id: Ids<'_, '_> = doc
        .descendants()
        .filter(|n| n.is_element())
        .filter_map(|n| n.attribute("id").map(|id| (id, n)))
        .collect();
    let runs: Vec<Node<'_, '_>> = doc
        .descendants()
        .filter(|n| name(n) == "MeasurementResults")
        .collect();
    if runs.is_empty() {
        return Err(nothing_measured(path, &doc));
    }
    // QIF 2 may keep the feature actuals beside the runs: with one run,
    // the whole document is its scope.
    let single_run_outside = runs.len() == 1 && !runs[0].descendants().any(|d| is_feature(&d));
    let units = file_units(&ctx)?;
    let mm = length_unit(&units, options, &mut inv);
    let mut unit_needed: Option<Node<'_, '_>> = None;

    inv.runs.clear();
    for (ri, run) in runs.iter().enumerate() {
        inv.runs.push(run_name(&by_id, *run));
        let nodes = if single_run_outside {
            vec![root]
        } else {
            vec![*run]
        };
        let mut sets: HashMap<String, PointSetData> = HashMap::new();
        for s in nodes
            .iter()
            .flat_map(|n| n.descendants())
            .filter(|n| name(n) == "MeasuredPointSet")
        {
            let id = s.attribute("id").unwrap_or("").to_string();
            let _ = sets.insert(id, point_set(&ctx, s)?);
        }
        let reader = Run {
            ctx: &ctx,
            by_id: &by_id,
            index: ri,
            sets,
            mm,
        };
        let mut features = 0;
        for f in nodes
            .iter()
            .flat_map(|n| n.descendants())
            .filter(is_feature)
        {
            features += 1;
            reader.feature(f, &mut inv, &mut unit_needed)?;
        }
        for c in nodes
            .iter()
            .flat_map(|n| n.descendants())
            .filter(is_characteristic)
        {
            inv.entries.push(reader.characteristic(c)?);
        }
        if features == 0 {
            reader.external_features(&mut inv)?;
        }
    }
    if let Some(n) = unit_needed
        && units.is_none()
        && options.units.is_none()
    {
        return Err(ctx.err(
            n,
            "the file states no length unit (no FileUnits/PrimaryUnits/LinearUnit): give --units mm or --units inch".into(),
        ));
    }
    if inv.entries.is_empty() {
        return Err(SourceError::new(
            path,
            0,
            0,
            "nothing measured: the QIF results hold no feature or characteristic measurement",
        ));
    }
    Ok(inv)
}

/// The XML document, refused when not well-formed (DTDs refused too).
fn document<'i>(path: &Path, src: &'i str) -> Result<Document<'i>, SourceError> {
    Document::parse_with_options(
        src,
        roxmltree::ParsingOptions {
            allow_dtd: false,
            ..Default::default()
        },
    )
    .map_err(|e| {
        let p = e.pos();
        SourceError::new(
            path,
            p.row as usize,
            p.col as usize,
            format!("not well-formed XML: {e}"),
        )
    })
}

/// The refusal of a document without measurement results, saying what it
/// is instead.
fn nothing_measured(path: &Path, doc: &Document<'_>) -> SourceError {
    // QIF 3 keeps a plan in `Plan` (QIF 2 in `MeasurementPlan`).
    let what = if doc
        .root_element()
        .children()
        .any(|n| n.is_element() && matches!(name(&n), "Plan" | "MeasurementPlan"))
    {
        "a QIF plan (what to measure), not results"
    } else {
        "a QIF document without measurement results (a product definition or a plan)"
    };
    SourceError::new(
        path,
        0,
        0,
        format!("nothing measured: this is {what}; give the QIF results file the CMM wrote"),
    )
}

/// Millimetres per length unit: the file's, else `--units`, else 1 (and
/// a refusal later if a length is read); the unit noted in the inventory.
fn length_unit(
    units: &Option<(f64, String)>,
    options: &MeasuredOptions,
    inv: &mut Inventory,
) -> f64 {
    match (units, options.units) {
        (Some((mm, u)), _) => {
            inv.units = if u.is_empty() {
                format!("{mm} mm")
            } else {
                u.clone()
            };
            *mm
        }
        (None, Some(u)) => {
            inv.units = format!("{} (given with --units; the file states none)", u.name());
            u.mm()
        }
        (None, None) => {
            inv.units = "none stated".into();
            1.0
        }
    }
}

/// A run's name: the measured part's serial number if the id chain gives
/// one, and the results' id.
fn run_name(by_id: &Ids<'_, '_>, run: Node<'_, '_>) -> String {
    let serial = child(run, "ActualComponentIds")
        .and_then(|ids| child(ids, "Id"))
        .and_then(|id| by_id.get(text_of(id).as_str()).copied())
        .and_then(|c| child(c, "SerialNumber"))
        .map(text_of);
    match serial {
        Some(s) => format!(
            "{} (MeasurementResults id {})",
            s,
            run.attribute("id").unwrap_or("?")
        ),
        None => format!(
            "MeasurementResults id {}",
            run.attribute("id").unwrap_or("?")
        ),
    }
}

/// One run of results being read: the document, its ids, the run's point
/// sets and the length unit.
struct Run<'r, 'a, 'i> {
    ctx: &'r Ctx<'a, 'i>,
    by_id: &'r Ids<'a, 'i>,
    /// The run's place among the document's runs.
    index: usize,
    sets: HashMap<String, PointSetData>,
    /// Millimetres per length unit.
    mm: f64,
}

impl<'a, 'i> Run<'_, 'a, 'i> {
    /// One feature as an entry: its label and nominal through the id
    /// chains, location, normal, diameter and points; what could not be
    /// read noted in the inventory, and the first feature with a length
    /// kept in `unit_needed`.
    fn feature(
        &self,
        f: Node<'a, 'i>,
        inv: &mut Inventory,
        unit_needed: &mut Option<Node<'a, 'i>>,
    ) -> Result<(), SourceError> {
        let (ctx, mm) = (self.ctx, self.mm);
        let element = name(&f);
        let suffix = if element.ends_with("FeatureMeasurement") {
            "FeatureMeasurement"
        } else {
            "FeatureActual"
        };
        let item = deref(self.by_id, f, "FeatureItemId");
        let nominal = item.and_then(|i| deref(self.by_id, i, "FeatureNominalId"));
        let label = item
            .and_then(|i| child(i, "FeatureName"))
            .map(text_of)
            .unwrap_or_else(|| format!("#{}", f.attribute("id").unwrap_or("?")));
        let mut e = Entry::new(label, kind_of(element, suffix), ctx.line(f));
        e.run = self.index;
        let (loc, dir) = ctx.place(f)?;
        let (nloc, ndir) = match nominal {
            Some(n) => ctx.place(n)?,
            None => (None, None),
        };
        if loc.is_some() || nloc.is_some() {
            unit_needed.get_or_insert(f);
        }
        e.actual = loc.map(|p| p * mm);
        e.nominal = nloc.map(|p| p * mm);
        e.normal = dir.or(ndir);
        if let Some(d) = child(f, "Diameter") {
            e.value = ctx.numbers(d)?.first().map(|v| v * mm);
        }
        if let Some(list) = child(f, "PointList") {
            self.points(&mut e, list, inv)?;
        }
        self.warn_ball_centre(&e, inv);
        if e.actual.is_none() {
            inv.skipped.push(Unread {
                line: e.line,
                what: format!("{element} `{}`", e.label),
                why: "no measured location".into(),
            });
        }
        inv.entries.push(e);
        Ok(())
    }

    /// A feature's points from its `PointList`: probe-ball centres
    /// compensated along their normals, a point's Location given as its one
    /// uncompensated centre replaced by the compensated point, and a point
    /// without a Location placed at the mean of its points.
    fn points(
        &self,
        e: &mut Entry,
        list: Node<'_, '_>,
        inv: &mut Inventory,
    ) -> Result<(), SourceError> {
        let (ctx, mm) = (self.ctx, self.mm);
        let (refs, dangling) = point_refs(ctx, list, &self.sets)?;
        for why in dangling {
            inv.skipped.push(Unread {
                line: ctx.line(list),
                what: format!("the points of `{}`", e.label),
                why,
            });
        }
        // Probe-ball centres compensated here, with the surface
        // points they became.
        let mut centres: Vec<(Vector3<f64>, Vector3<f64>)> = Vec::new();
        for (what, set) in refs {
            for (k, &p) in set.points.iter().enumerate() {
                let p = p * mm;
                let surface = match (set.compensated, set.probe_radius) {
                    (true, _) | (false, None) => Some(p),
                    (false, Some(r)) => {
                        let n = set.normals.as_ref().map(|ns| ns[k]).or(e.normal);
                        let s = n.map(|n| p - n.normalize() * r * mm);
                        if let Some(s) = s {
                            centres.push((p, s));
                        }
                        s
                    }
                };
                match surface {
                    Some(s) => e.points.push(s),
                    None => {
                        inv.skipped.push(Unread {
                            line: e.line,
                            what: format!("point {} of {what} ({})", k + 1, e.label),
                            why: "a probe-ball centre without a normal to compensate it along"
                                .into(),
                        });
                    }
                }
            }
        }
        // Real writers (the QIF community's own PTS sample) give a
        // point's Location as the uncompensated ball centre of its
        // one point: a surface point a ball radius off the surface.
        // The compensated point is the measurement.
        if let (Some(a), [(centre, surface)]) = (e.actual, centres.as_slice())
            && e.kind == "point"
            && (a - centre).norm() <= 1e-9 * (1.0 + a.norm())
        {
            e.actual = Some(*surface);
            inv.warnings.push(format!(
                "line {}: `{}` gives its Location as the probe-ball centre of its uncompensated point set; the point compensated by the probe radius along the normal is used ({:.4} mm away)",
                e.line,
                e.label,
                (surface - centre).norm()
            ));
        }
        if e.actual.is_none() && e.kind == "point" && !e.points.is_empty() {
            let sum: Vector3<f64> = e.points.iter().sum();
            e.actual = Some(sum / e.points.len() as f64);
        }
        Ok(())
    }

    /// Warns of a point that may be an uncompensated ball centre.
    fn warn_ball_centre(&self, e: &Entry, inv: &mut Inventory) {
        // A point without raw points cannot be compensated; if it sits
        // a ball radius of this run off its nominal along the normal,
        // it is most likely a ball centre too, and the user is told.
        if let (Some(a), Some(nom), Some(n), true) =
            (e.actual, e.nominal, e.normal, e.points.is_empty())
            && e.kind == "point"
        {
            let off = (a - nom).dot(&n);
            if let Some(r) = self
                .sets
                .values()
                .filter(|s| !s.compensated)
                .filter_map(|s| s.probe_radius)
                .map(|r| r * self.mm)
                .find(|r| (off.abs() - r).abs() < 0.2 * r)
            {
                inv.warnings.push(format!(
                    "line {}: `{}` lies {off:.4} mm from its nominal along the normal, close to this run's probe radius {r:.4} mm, and has no raw points to compensate: it may be an uncompensated ball centre",
                    e.line, e.label
                ));
            }
        }
    }

    /// One characteristic as an entry: its name through the id chain and
    /// its value.
    fn characteristic(&self, c: Node<'a, 'i>) -> Result<Entry, SourceError> {
        let element = name(&c);
        let suffix = if element.ends_with("CharacteristicMeasurement") {
            "CharacteristicMeasurement"
        } else {
            "CharacteristicActual"
        };
        let item = deref(self.by_id, c, "CharacteristicItemId");
        let label = item
            .and_then(|i| child(i, "Name"))
            .map(text_of)
            .unwrap_or_else(|| format!("#{}", c.attribute("id").unwrap_or("?")));
        let mut e = Entry::new(
            label,
            format!("{} (characteristic)", kind_of(element, suffix)),
            self.ctx.line(c),
        );
        e.run = self.index;
        if let Some(v) = child(c, "Value") {
            e.value = self.ctx.numbers(v)?.first().copied();
        }
        Ok(e)
    }

    /// For a run without features whose features are defined in another
    /// QIF file: refused when the run has nothing else, else a warning that
    /// only its characteristics are reported.
    fn external_features(&self, inv: &mut Inventory) -> Result<(), SourceError> {
        let ri = self.index;
        if let Some(ext) = self
            .ctx
            .doc
            .descendants()
            .find(|n| name(n) == "ExternalQIFReferences")
        {
            let uri = ext
                .descendants()
                .find(|n| name(n) == "URI")
                .map(text_of)
                .unwrap_or_default();
            if !inv.entries.iter().any(|e| e.run == ri) {
                return Err(self.ctx.err(
                    ext,
                    format!("the results are kept in another QIF file ({uri}); give that file"),
                ));
            }
            inv.warnings.push(format!(
                "run {}: no feature measurements here; the features are defined in another QIF file ({uri}), only characteristic values are reported",
                ri + 1
            ));
        }
        Ok(())
    }
}
