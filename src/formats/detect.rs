//! Recognizes a measurement file from its content (never from its name) and
//! reads it into the canonical meaning of docs/formats.md.
//!
//! Every format is a [`Reader`] in one registry, [`readers`], tried in
//! order: the first whose `sniff` accepts the text reads it. Specific
//! formats come first, the plain point list (any three numbers per line)
//! last. Formats keyed to the plan (the probe logs of
//! [`super::probe_log`], whose lines name touches by index or label and
//! hold ball centres) read with a [`ReadContext`] that carries the plan,
//! the kinematics with the probe, the dialect and the probing options.

use std::path::Path;

use super::heights::{self, SectionHeight};
use super::inventory::{Entry, Inventory};
pub use super::inventory::{LengthUnit, MeasuredOptions, PointSet};
use super::measured;
use super::points::PlanPoints;
use super::{calypso, cloud, csv_lines, dmis, probe_log, qif, table};
use crate::kinematics::Kinematics;
use crate::machine::Dialect;
use crate::source::SourceError;

/// What a reader may need beyond the text: the plan and, for probe logs,
/// the machine's kinematics with the probe's gauge length, the dialect of
/// the program that wrote the log and the probing options.
#[derive(Clone, Copy, Default)]
pub struct ReadContext<'a> {
    /// The plan's points.
    pub plan: Option<&'a PlanPoints>,
    /// Kinematics with the probe's gauge length.
    pub kin: Option<&'a Kinematics>,
    /// Dialect of the plan's program.
    pub dialect: Option<Dialect>,
    /// Probe-log options (ball radius, probing window); set for probing
    /// plans only.
    pub probe: Option<&'a probe_log::ReadOptions>,
    /// What the user said about the files.
    pub options: MeasuredOptions,
}

/// What a measurement file holds.
#[derive(Clone, Debug, PartialEq)]
pub enum Measurement {
    /// Surface or contact points.
    Points(PointSet),
    /// Nine-section heights.
    Heights(Vec<SectionHeight>),
}

/// A measurement format.
pub trait Reader: Sync {
    /// Short name, shown in messages.
    fn name(&self) -> &'static str;
    /// One line on what the format is, for "expected ..." messages.
    fn describe(&self) -> &'static str;
    /// Whether the text is in this format (in this context).
    fn sniff(&self, src: &str, ctx: &ReadContext<'_>) -> bool;
    /// Reads it.
    fn read(
        &self,
        path: &Path,
        src: &str,
        ctx: &ReadContext<'_>,
    ) -> Result<Measurement, SourceError>;
    /// What the file holds, for `fivecal measured`: by default what
    /// [`Reader::read`] reads.
    fn inventory(
        &self,
        path: &Path,
        src: &str,
        ctx: &ReadContext<'_>,
    ) -> Result<Inventory, SourceError> {
        inventory_by_reading(self, path, src, ctx)
    }
}

/// What a file holds as `reader` reads it: the default of
/// [`Reader::inventory`], and what a reader with an inventory of its own
/// falls back to.
fn inventory_by_reading<R: Reader + ?Sized>(
    reader: &R,
    path: &Path,
    src: &str,
    ctx: &ReadContext<'_>,
) -> Result<Inventory, SourceError> {
    Ok(match reader.read(path, src, ctx)? {
        Measurement::Points(set) => Inventory::of_points(&set),
        Measurement::Heights(h) => {
            let mut inv = Inventory::new(reader.name());
            inv.units = "um (heights)".into();
            for s in h {
                let mut e = Entry::new(format!("section {}", s.section), "height", s.line);
                e.value = Some(s.height_um);
                inv.entries.push(e);
            }
            inv
        }
    })
}

/// The points of the run the options choose, from a file's inventory: a
/// file with several runs needs `--run`.
pub(crate) fn chosen_run(
    path: &Path,
    inv: &Inventory,
    options: &MeasuredOptions,
) -> Result<PointSet, SourceError> {
    let n = inv.runs.len();
    let run = match options.run {
        Some(r) if (1..=n).contains(&r) => r - 1,
        Some(r) => {
            return Err(SourceError::new(
                path,
                0,
                0,
                format!("--run {r}: the file holds {n} measurement run(s), expected 1 to {n}"),
            ));
        }
        None if n > 1 => {
            return Err(SourceError::new(
                path,
                0,
                0,
                format!(
                    "the file holds {n} measurement runs ({}): choose one with --run N (each run is one piece)",
                    inv.runs.join(", ")
                ),
            ));
        }
        None => 0,
    };
    let set = inv.point_set(run);
    if set.points.is_empty() {
        let why = if inv.entries.iter().any(|e| e.run == run) {
            format!(
                "no measured point in the file ({} features or characteristics without a measured point location; `fivecal measured {}` lists them)",
                inv.entries.iter().filter(|e| e.run == run).count(),
                crate::io::shell_word(&path.display().to_string())
            )
        } else {
            "nothing measured in the file".to_string()
        };
        let mut why = why;
        if let Some(w) = inv.warnings.first() {
            why.push_str(&format!("; {w}"));
        }
        if let Some(s) = inv.skipped.first() {
            why.push_str(&format!("; skipped: {} ({})", s.what, s.why));
        }
        return Err(SourceError::new(path, 0, 0, why));
    }
    Ok(set)
}

struct Dmis;
struct Qif;
struct Calypso;
struct Table;
struct Canonical;
struct Heights;
struct ProbeLog;
struct ProbeFile;
struct Plain;

/// The first lines with content (FANUC punch leaders, `%` tape marks and
/// blank lines skipped).
fn content_lines(src: &str) -> impl Iterator<Item = &str> {
    src.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && *l != "%" && !l.chars().all(|c| c.is_control()))
}

/// A touch line of one of our probe logs: `T` then a key, then X, Y, Z.
fn looks_like_touch(line: &str) -> bool {
    let Some(rest) = line.strip_prefix('T') else {
        return false;
    };
    let rest = rest.trim_start();
    let key_end = rest.find(char::is_whitespace).unwrap_or(rest.len());
    let after = rest[key_end..].trim_start();
    key_end > 0 && after.starts_with('X') && after.contains('Y') && after.contains('Z')
}

fn probe_context<'a>(
    path: &Path,
    ctx: &ReadContext<'a>,
    what: &str,
) -> Result<(&'a PlanPoints, &'a Kinematics, &'a probe_log::ReadOptions), SourceError> {
    match (ctx.plan, ctx.kin, ctx.probe) {
        (Some(p), Some(k), Some(o)) => Ok((p, k, o)),
        _ => Err(SourceError::new(
            path,
            0,
            0,
            format!(
                "this is {what}: it is read against its probing plan (the plan gives the probe, the dialect and the touches)"
            ),
        )),
    }
}

fn log_points(log: probe_log::ProbeLog, format: &'static str) -> Measurement {
    let mut warnings = log.notes;
    if !log.missing.is_empty() {
        warnings.push(format!(
            "{} planned touches are not in the log (first: `{}`)",
            log.missing.len(),
            log.missing[0]
        ));
    }
    Measurement::Points(PointSet {
        format,
        points: log.points,
        labeled: true,
        nominals: Vec::new(),
        warnings,
    })
}

impl Reader for ProbeLog {
    fn name(&self) -> &'static str {
        "probe-log"
    }
    fn describe(&self) -> &'static str {
        "a probe log of our probing programs (FIVECAL header, T lines)"
    }
    fn sniff(&self, src: &str, _: &ReadContext<'_>) -> bool {
        content_lines(src).take(5).any(|l| {
            l.get(..8)
                .is_some_and(|h| h.eq_ignore_ascii_case("FIVECAL "))
                || looks_like_touch(l)
        })
    }
    fn read(
        &self,
        path: &Path,
        src: &str,
        ctx: &ReadContext<'_>,
    ) -> Result<Measurement, SourceError> {
        let (plan, kin, opts) = probe_context(path, ctx, "a probe log")?;
        // The plan's dialect first; a log of another dialect is still read
        // when its lines say which it is.
        let mut order = Dialect::ALL.to_vec();
        if let Some(d) = ctx.dialect {
            order.retain(|x| *x != d);
            order.insert(0, d);
        }
        let mut first_error = None;
        for d in order {
            match probe_log::read(d, path, src, plan, kin, opts) {
                Ok(log) => return Ok(log_points(log, "probe-log")),
                Err(e) => {
                    first_error.get_or_insert(e);
                }
            }
        }
        Err(first_error.expect("every dialect was tried"))
    }
    /// Without its plan, the log as written: each touch line's key and
    /// logged position, in the first dialect whose reader takes every line.
    /// Which planned touch a key means, and where its contact point lies,
    /// only the plan says.
    fn inventory(
        &self,
        path: &Path,
        src: &str,
        ctx: &ReadContext<'_>,
    ) -> Result<Inventory, SourceError> {
        if probe_context(path, ctx, "a probe log").is_ok() {
            return inventory_by_reading(self, path, src, ctx);
        }
        let mut first_error = None;
        let mut read = Vec::new();
        for d in Dialect::ALL {
            match probe_log::parse(d, path, src) {
                Ok(r) if !r.records.is_empty() => read.push((d, r)),
                Ok(_) => {}
                Err(e) => {
                    first_error.get_or_insert(e);
                }
            }
        }
        let Some((_, raw)) = read.first() else {
            return Err(first_error.unwrap_or_else(|| {
                SourceError::new(path, 0, 0, "a probe log without a touch line".to_string())
            }));
        };
        let mut inv = Inventory::new("probe-log");
        for r in &raw.records {
            let label = match &r.key {
                probe_log::TouchKey::Index(i) => format!("T{i}"),
                probe_log::TouchKey::Label(l) => l.clone(),
            };
            let kind = match r.logged {
                probe_log::Logged::BallCentre => "ball centre",
                probe_log::Logged::Contact => "contact point",
            };
            let mut e = Entry::new(label, kind, r.line);
            e.actual = Some(r.position);
            inv.entries.push(e);
        }
        for (line, test) in &raw.headers {
            inv.warnings
                .push(format!("line {line}: a log of the {test} test"));
        }
        // Several dialects write the same touch lines: which control wrote
        // it, the plan says.
        let dialects: Vec<String> = read.iter().map(|(d, _)| d.to_string()).collect();
        inv.warnings.push(format!(
            "read as a log of {} (the plan's dialect decides); positions as the control logged them, in program coordinates: `fivecal analyze --plan` joins each with its planned touch and turns ball centres into contact points",
            dialects.join(" or ")
        ));
        Ok(inv)
    }
}

impl Reader for ProbeFile {
    fn name(&self) -> &'static str {
        "probe-file"
    }
    fn describe(&self) -> &'static str {
        "a LinuxCNC PROBEOPEN file (of a LinuxCNC probing plan)"
    }
    fn sniff(&self, src: &str, ctx: &ReadContext<'_>) -> bool {
        // Only a LinuxCNC probing plan makes numbers-only files mean ball
        // centres in touch order.
        ctx.probe.is_some()
            && ctx.dialect == Some(Dialect::Linuxcnc)
            && content_lines(src)
                .filter(|l| !l.starts_with('#'))
                .take(3)
                .all(|l| {
                    let f: Vec<&str> = l.split_whitespace().collect();
                    (f.len() == 3 || f.len() == 9) && f.iter().all(|x| x.parse::<f64>().is_ok())
                })
    }
    fn read(
        &self,
        path: &Path,
        src: &str,
        ctx: &ReadContext<'_>,
    ) -> Result<Measurement, SourceError> {
        let (plan, kin, opts) = probe_context(path, ctx, "a PROBEOPEN file")?;
        let raw = probe_log::linuxcnc::parse_probe_file(path, src, plan.tilt_letter)?;
        Ok(log_points(
            probe_log::join(path, &raw, plan, kin, opts)?,
            "probe-file",
        ))
    }
}

/// A DMIS program (what a CMM runs) given where its output is expected.
fn dmis_program_error(path: &Path, o: &dmis::DmisOutput) -> SourceError {
    SourceError::new(
        path,
        0,
        0,
        format!(
            "this is a DMIS program, not DMIS output: {} nominal features and {} MEAS/PTMEAS/GOTO statements but no actual FA(..) results; run it on the CMM and give the output file it writes (.dmo, .out)",
            o.features.len(),
            o.program_statements
        ),
    )
}

/// Whether labelled points join a plan by label: when no label of the
/// file is one of the plan's (a CMM program that renamed the features,
/// labels in another script), they join by nearest nominal instead, and a
/// warning says which.
pub(crate) fn label_policy(set: &mut PointSet, ctx: &ReadContext<'_>) {
    let Some(plan) = ctx.plan else {
        return;
    };
    if !set.labeled || set.points.is_empty() {
        return;
    }
    let known = set
        .points
        .iter()
        .filter(|p| plan.points.iter().any(|q| q.label == p.label))
        .count();
    if known == 0 {
        set.warnings.push(format!(
            "none of the file's {} labels (first: `{}`) is a label of the plan: the points are joined by nearest nominal",
            set.points.len(),
            set.points[0].label
        ));
        set.labeled = false;
        set.nominals.clear();
        for p in &mut set.points {
            p.label.clear();
        }
    } else if known < set.points.len() {
        // Every point joined by its label is the normal case, not news.
        set.warnings.push(format!(
            "{known} of the file's {} points joined by label",
            set.points.len()
        ));
    }
}

impl Reader for Dmis {
    fn name(&self) -> &'static str {
        "dmis"
    }
    fn describe(&self) -> &'static str {
        "DMIS output (F(..)/FA(..) statements)"
    }
    fn sniff(&self, src: &str, _: &ReadContext<'_>) -> bool {
        dmis::looks_like_dmis(src)
    }
    fn read(
        &self,
        path: &Path,
        src: &str,
        _: &ReadContext<'_>,
    ) -> Result<Measurement, SourceError> {
        let o = dmis::parse(path, src)?;
        let points = o.measured_points();
        if points.is_empty() {
            if o.features.iter().all(|f| f.actual.is_none()) && o.program_statements > 0 {
                return Err(dmis_program_error(path, &o));
            }
            return Err(SourceError::new(
                path,
                0,
                0,
                "DMIS output without any measured point (FA(..)=FEAT/POINT,...)",
            ));
        }
        // DMIS output keeps the CMM program's labels, which are the plan's:
        // unknown labels mean another plan's file and are refused at the join.
        Ok(Measurement::Points(PointSet {
            format: "dmis",
            points,
            labeled: true,
            nominals: o.nominal_points(),
            warnings: o.warnings,
        }))
    }
    fn inventory(
        &self,
        path: &Path,
        src: &str,
        _: &ReadContext<'_>,
    ) -> Result<Inventory, SourceError> {
        let o = dmis::parse(path, src)?;
        if o.features.iter().all(|f| f.actual.is_none()) && o.program_statements > 0 {
            return Err(dmis_program_error(path, &o));
        }
        Ok(o.inventory())
    }
}

/// The points of the chosen run of an inventory, labels judged against
/// the plan.
fn inventory_points(
    path: &Path,
    inv: &Inventory,
    ctx: &ReadContext<'_>,
) -> Result<Measurement, SourceError> {
    let mut set = chosen_run(path, inv, &ctx.options)?;
    label_policy(&mut set, ctx);
    Ok(Measurement::Points(set))
}

impl Reader for Qif {
    fn name(&self) -> &'static str {
        "qif"
    }
    fn describe(&self) -> &'static str {
        "QIF results (XML, <QIFDocument>)"
    }
    fn sniff(&self, src: &str, _: &ReadContext<'_>) -> bool {
        qif::looks_like_qif(src)
    }
    fn read(
        &self,
        path: &Path,
        src: &str,
        ctx: &ReadContext<'_>,
    ) -> Result<Measurement, SourceError> {
        inventory_points(path, &qif::parse(path, src, &ctx.options)?, ctx)
    }
    fn inventory(
        &self,
        path: &Path,
        src: &str,
        ctx: &ReadContext<'_>,
    ) -> Result<Inventory, SourceError> {
        qif::parse(path, src, &ctx.options)
    }
}

impl Reader for Calypso {
    fn name(&self) -> &'static str {
        "calypso"
    }
    fn describe(&self) -> &'static str {
        "a ZEISS CALYPSO table (_fet, _chr or _hdr, tab-separated)"
    }
    fn sniff(&self, src: &str, _: &ReadContext<'_>) -> bool {
        calypso::sniff(src).is_some()
    }
    fn read(
        &self,
        path: &Path,
        src: &str,
        ctx: &ReadContext<'_>,
    ) -> Result<Measurement, SourceError> {
        if calypso::sniff(src) == Some(calypso::CalypsoTable::Header) {
            return Err(SourceError::new(
                path,
                0,
                0,
                calypso::HEADER_HOLDS_NO_MEASUREMENT,
            ));
        }
        inventory_points(path, &calypso::parse(path, src, &ctx.options)?, ctx)
    }
    fn inventory(
        &self,
        path: &Path,
        src: &str,
        ctx: &ReadContext<'_>,
    ) -> Result<Inventory, SourceError> {
        calypso::parse(path, src, &ctx.options)
    }
}

fn header_fields(src: &str) -> Option<Vec<String>> {
    csv_lines(src)
        .next()
        .map(|h| h.fields.iter().map(|f| f.1.to_ascii_lowercase()).collect())
}

impl Reader for Canonical {
    fn name(&self) -> &'static str {
        "csv"
    }
    fn describe(&self) -> &'static str {
        "CSV with a header label,x,y,z"
    }
    fn sniff(&self, src: &str, _: &ReadContext<'_>) -> bool {
        header_fields(src).is_some_and(|h| {
            ["label", "x", "y", "z"]
                .iter()
                .all(|n| h.iter().any(|c| c == n))
        })
    }
    fn read(
        &self,
        path: &Path,
        src: &str,
        _: &ReadContext<'_>,
    ) -> Result<Measurement, SourceError> {
        Ok(Measurement::Points(PointSet {
            format: "csv",
            points: measured::parse_csv(path, src)?,
            labeled: true,
            nominals: Vec::new(),
            warnings: Vec::new(),
        }))
    }
}

impl Reader for Table {
    fn name(&self) -> &'static str {
        "table"
    }
    fn describe(&self) -> &'static str {
        "a point table with a header naming x, y, z (and label, nominal, i, j, k) columns"
    }
    fn sniff(&self, src: &str, _: &ReadContext<'_>) -> bool {
        table::looks_like_table(src)
    }
    fn read(
        &self,
        path: &Path,
        src: &str,
        ctx: &ReadContext<'_>,
    ) -> Result<Measurement, SourceError> {
        inventory_points(path, &table::parse(path, src, &ctx.options)?, ctx)
    }
    fn inventory(
        &self,
        path: &Path,
        src: &str,
        ctx: &ReadContext<'_>,
    ) -> Result<Inventory, SourceError> {
        table::parse(path, src, &ctx.options)
    }
}

impl Reader for Heights {
    fn name(&self) -> &'static str {
        "heights"
    }
    fn describe(&self) -> &'static str {
        "nine-section heights (header section,height_um)"
    }
    fn sniff(&self, src: &str, _: &ReadContext<'_>) -> bool {
        heights::looks_like_heights(src)
    }
    fn read(
        &self,
        path: &Path,
        src: &str,
        _: &ReadContext<'_>,
    ) -> Result<Measurement, SourceError> {
        Ok(Measurement::Heights(heights::parse(path, src)?))
    }
}

impl Reader for Plain {
    fn name(&self) -> &'static str {
        "plain"
    }
    fn describe(&self) -> &'static str {
        "a plain point list (x y z or x y z i j k per line, no labels)"
    }
    fn sniff(&self, src: &str, _: &ReadContext<'_>) -> bool {
        cloud::looks_like_cloud(src)
    }
    fn read(
        &self,
        path: &Path,
        src: &str,
        ctx: &ReadContext<'_>,
    ) -> Result<Measurement, SourceError> {
        inventory_points(path, &cloud::parse(path, src, &ctx.options)?, ctx)
    }
    fn inventory(
        &self,
        path: &Path,
        src: &str,
        ctx: &ReadContext<'_>,
    ) -> Result<Inventory, SourceError> {
        cloud::parse(path, src, &ctx.options)
    }
}

/// Every reader, in the order they are tried.
pub fn readers() -> Vec<&'static dyn Reader> {
    vec![
        &Qif, &Dmis, &Calypso, &Heights, &Canonical,
        // The probe logs of `src/formats/probe_log/` (FANUC DPRNT,
        // HEIDENHAIN FN 16, LinuxCNC LOG and PROBEOPEN), before the plain
        // point list, which accepts any three numbers per line. They return
        // labelled contact points in W at rotary zero (docs/formats.md).
        &ProbeLog, &ProbeFile, &Table, &Plain,
    ]
}

/// The reader that accepts `src`, if any.
pub fn detect(src: &str) -> Option<&'static dyn Reader> {
    detect_in(src, &ReadContext::default())
}

/// The reader that accepts `src` in a context.
pub(crate) fn detect_in(src: &str, ctx: &ReadContext<'_>) -> Option<&'static dyn Reader> {
    readers().into_iter().find(|r| r.sniff(src, ctx))
}

/// Reads a measurement file in whatever format it is.
pub fn read_measurement(path: &Path) -> Result<Measurement, SourceError> {
    read_measurement_in(path, &ReadContext::default())
}

/// Reads a measurement file in whatever format it is, in a context.
pub fn read_measurement_in(path: &Path, ctx: &ReadContext<'_>) -> Result<Measurement, SourceError> {
    let (src, notes) = read_text(path, ctx)?;
    let mut m = parse_measurement_in(path, &src, ctx)?;
    if let Measurement::Points(set) = &mut m {
        set.warnings.extend(notes);
    }
    Ok(m)
}

/// The text of a measurement file (UTF-8, or the encoding the options
/// name) and notes on what was mended.
fn read_text(path: &Path, ctx: &ReadContext<'_>) -> Result<(String, Vec<String>), SourceError> {
    let bytes = crate::input::read_bytes(
        path,
        "measurement file",
        crate::limits::MAX_MEASUREMENT_BYTES,
    )?;
    let (text, notes) = super::encoding::decode(path, &bytes, ctx.options.encoding)?;
    Ok((crate::input::with_lf_lines(text), notes))
}

/// What a measurement file holds, before any plan is involved.
pub fn inventory(path: &Path, ctx: &ReadContext<'_>) -> Result<Inventory, SourceError> {
    let (src, notes) = read_text(path, ctx)?;
    let mut inv = parse_inventory(path, &src, ctx)?;
    inv.warnings.extend(notes);
    Ok(inv)
}

/// What measurement text holds.
pub(crate) fn parse_inventory(
    path: &Path,
    src: &str,
    ctx: &ReadContext<'_>,
) -> Result<Inventory, SourceError> {
    match detect_in(src, ctx) {
        Some(r) => r.inventory(path, src, ctx),
        None => Err(unrecognized(path)),
    }
}

fn unrecognized(path: &Path) -> SourceError {
    let expected: Vec<&str> = readers().iter().map(|r| r.describe()).collect();
    SourceError::new(
        path,
        0,
        0,
        format!(
            "unrecognized measurement format: expected {}",
            expected.join(", or ")
        ),
    )
}

/// Reads measurement text in whatever format it is.
pub fn parse_measurement(path: &Path, src: &str) -> Result<Measurement, SourceError> {
    parse_measurement_in(path, src, &ReadContext::default())
}

/// Reads measurement text in whatever format it is, in a context.
pub(crate) fn parse_measurement_in(
    path: &Path,
    src: &str,
    ctx: &ReadContext<'_>,
) -> Result<Measurement, SourceError> {
    match detect_in(src, ctx) {
        Some(r) => r.read(path, src, ctx),
        None => Err(unrecognized(path)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recognizes_each_format_from_its_content() {
        let cases = [
            ("DMISMN/'x',04.0\nFA(P1)=FEAT/POINT,CART,1,2,3\n", "dmis"),
            ("label,x,y,z\nP1,1,2,3\n", "csv"),
            ("section,height_um\n1,0\n", "heights"),
            ("1.0 2.0 3.0\n4 5 6\n", "plain"),
            ("x;y;z\n1;2;3\n", "table"),
        ];
        for (src, name) in cases {
            assert_eq!(detect(src).map(|r| r.name()), Some(name), "{src}");
        }
        let e = parse_measurement(Path::new("q.txt"), "hello\nworld\n")
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("q.txt: unrecognized measurement format: expected QIF"),
            "{e}"
        );
    }
}
