//! Probe logs: the files our probing programs make the controller write,
//! one module per dialect, and their conversion to measured contact points
//! (docs/formats.md: `label,x,y,z`, the contact point in W at rotary zero).
//!
//! Every log line of a touch carries the touch's key, its 1-based index
//! (row of `points.csv`) or its label, and the position the controller
//! recorded at the trigger, in program coordinates (work offset on the W
//! origin at rotary zero). Each dialect module documents its exact line
//! with an example and exposes the NC text that produces it, so that the
//! post-processor emits exactly that:
//!
//! | dialect | log line | NC that writes it |
//! |---|---|---|
//! | FANUC | `T    17 X   33.0000 Y-  45.0000 Z  135.0021` | [`fanuc::touch_blocks`]: `#199=17`, `DPRNT[T#199[50]*X#5061[44]*Y#5062[44]*Z#5063[44]]` |
//! | HEIDENHAIN | `K17 X33,0000 Y-45,0000 Z132,0021` (cycle 0's compensated touch point; `T` for ball centres) | [`heidenhain::cycle0_reads`], [`heidenhain::touch_format_file`] (`.A`) and [`heidenhain::touch_statements`] (`FN 16: F-PRINT`) |
//! | LinuxCNC | `T A0C0_C1_xp X33.000000 Y-45.000000 Z135.002100` | [`linuxcnc::touch_line`]: `(LOG,T A0C0_C1_xp X#5061 Y#5062 Z#5063)` |
//! | SINUMERIK | `T17 X33 Y-45 Z135.0021` | `R1=$AA_MW[X]` ..., `FCLINE="T17 X"<<ROUND(R1*10000)/10000<<...`, `WRITE(FCERR,"FIVECAL_COLUMNS",FCLINE)` ([`sinumerik`]) |
//!
//! and a header line `FIVECAL <test>` at the start of each run.
//! [`write::LogFormat`] writes these logs as the control would, for a
//! simulator.
//!
//! # From ball centre to contact point
//! The controller records the probe-ball centre `b` (in program
//! coordinates, with the rotary axes at the touch's pose). The touch's
//! nominal normal `n` (W, from `points.csv`) is `n' = rTw*(t, c) n` in
//! program coordinates, and the ball met the surface on its side facing
//! the approach `-n'`, so the contact point is `b - r n'` with `r` the
//! ball radius. (On a head machine the reported X, Y, Z are the commanded
//! ones and the ball sits off them by the head's swing; the reader adds
//! that offset, [`crate::kinematics::pose_frame::PoseFrame::ball_prog`].) A HEIDENHAIN
//! log may instead hold contact points already compensated by the
//! controller (line tag `K`); those are taken as they are.
//!
//! # Checks
//! Each touch's position must lie on its own probing line: at most
//! [`ReadOptions::lateral_tolerance`] off the line through the nominal
//! contact along `n'`, and along it between the overtravel end and the
//! start of the probing move ([`ReadOptions::window`]). That catches a log
//! of another plan, a work offset not on W, a DPRNT field too narrow for
//! the value (FANUC drops the high digits), and a probe that never
//! triggered (FANUC's skip position is then the programmed end point).
//!
//! # Blank and repeated lines
//! Blank lines, lines of spaces or control characters (a FANUC punch
//! leader), and `%` lines (FANUC's POPEN/PCLOS tape marks) are skipped.
//! A touch logged again with the same numbers (a log captured twice, a
//! resent block) counts once. A touch logged again with other numbers (the
//! program was restarted and the log appended) takes the later value and
//! the reader says so in [`ProbeLog::notes`], unless
//! [`Repeats::Reject`] asks for an error. Anything else is an error at
//! `file:line:column` saying what was expected there.

pub mod fanuc;
pub mod heidenhain;
pub mod linuxcnc;
pub mod sinumerik;
pub mod write;

use std::collections::HashMap;
use std::path::Path;

use nalgebra::Vector3;
use nom::error::{ErrorKind, ParseError};
use nom::{IResult, Parser};

use crate::formats::measured::MeasuredPoint;
use crate::formats::points::PlanPoints;
use crate::kinematics::Kinematics;
use crate::kinematics::pose_frame::PoseFrame;
use crate::machine::Dialect;
use crate::source::SourceError;

/// How a log line names its touch.
#[derive(Clone, Debug, PartialEq)]
pub enum TouchKey {
    /// 1-based index: row among the data rows of `points.csv`.
    Index(usize),
    /// The point's label.
    Label(String),
}

/// What a logged position is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Logged {
    /// The probe-ball centre at the trigger (the reader applies the radius).
    BallCentre,
    /// The contact point, radius already applied by the controller.
    Contact,
}

/// One touch line of a log.
#[derive(Clone, Debug, PartialEq)]
pub struct LogRecord {
    /// Which touch.
    pub key: TouchKey,
    /// The recorded X, Y, Z, mm.
    pub position: Vector3<f64>,
    /// What they are.
    pub logged: Logged,
    /// Rotary axes (tilt, C) at the trigger, deg, when the log has them.
    pub rotary: Option<(f64, f64)>,
    /// 1-based line in the log.
    pub line: usize,
    /// 1-based column of the key.
    pub column: usize,
}

/// A parsed log, before joining with the plan.
#[derive(Clone, Debug, PartialEq)]
pub struct RawLog {
    /// Touch lines in file order.
    pub records: Vec<LogRecord>,
    /// Header lines: (line, test name as written).
    pub headers: Vec<(usize, String)>,
}

/// What to do with a touch logged twice with different numbers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Repeats {
    /// Keep the later value and note it.
    KeepLast,
    /// Refuse the log.
    Reject,
}

/// How to turn a log into contact points.
#[derive(Clone, Debug, PartialEq)]
pub struct ReadOptions {
    /// Probe-ball radius, mm.
    pub ball_radius: f64,
    /// How far (mm) the logged contact may lie inside the nominal surface
    /// (the overtravel: at it, the probe did not trigger) and outside it
    /// (the clearance: beyond it, the probing move had not begun).
    pub window: (f64, f64),
    /// How far (mm) a logged position may lie off its probing line.
    pub lateral_tolerance: f64,
    /// Policy for repeated touches.
    pub repeats: Repeats,
    /// The test the log must belong to (its header), if known.
    pub test: Option<crate::formats::manifest::Test>,
}

/// A log turned into contact points.
#[derive(Clone, Debug, PartialEq)]
pub struct ProbeLog {
    /// Contact points in W at rotary zero, in plan order, with the log's
    /// line numbers.
    pub points: Vec<MeasuredPoint>,
    /// Labels of planned touches the log does not have.
    pub missing: Vec<String>,
    /// What the reader did beyond the obvious (repeats, several runs).
    pub notes: Vec<String>,
}

/// Reads a log of `dialect` (for LinuxCNC, the `LOG` file) and joins it
/// with the plan's points. `kin` must have the probe's gauge length.
pub fn read(
    dialect: Dialect,
    path: &Path,
    src: &str,
    plan: &PlanPoints,
    kin: &Kinematics,
    opts: &ReadOptions,
) -> Result<ProbeLog, SourceError> {
    join(path, &parse(dialect, path, src)?, plan, kin, opts)
}

/// Parses a log of `dialect` (for LinuxCNC, the `LOG` file) as written,
/// before it is joined with a plan.
pub fn parse(dialect: Dialect, path: &Path, src: &str) -> Result<RawLog, SourceError> {
    match dialect {
        Dialect::Fanuc => fanuc::parse(path, src),
        Dialect::Heidenhain => heidenhain::parse(path, src),
        Dialect::Linuxcnc => linuxcnc::parse_log(path, src),
        Dialect::Sinumerik => sinumerik::parse(path, src),
    }
}

/// Joins parsed records with the plan and converts them to contact points.
pub fn join(
    path: &Path,
    raw: &RawLog,
    plan: &PlanPoints,
    kin: &Kinematics,
    opts: &ReadOptions,
) -> Result<ProbeLog, SourceError> {
    let mut notes = Vec::new();
    if let Some(want) = &opts.test {
        for (line, got) in &raw.headers {
            if !got.eq_ignore_ascii_case(want.as_str()) {
                return Err(SourceError::new(
                    path,
                    *line,
                    1,
                    format!("this log is of `{got}`, but the plan is `{want}`"),
                ));
            }
        }
    }
    if raw.headers.len() > 1 {
        notes.push(format!(
            "the log holds {} runs (headers at lines {}); a touch logged in several keeps its last value",
            raw.headers.len(),
            raw.headers
                .iter()
                .map(|h| h.0.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    let by_label: HashMap<&str, usize> = plan
        .points
        .iter()
        .enumerate()
        .map(|(i, p)| (p.label.as_str(), i))
        .collect();
    let mut by_lower: HashMap<String, Option<usize>> = HashMap::new();
    for (i, p) in plan.points.iter().enumerate() {
        by_lower
            .entry(p.label.to_ascii_lowercase())
            .and_modify(|e| *e = None)
            .or_insert(Some(i));
    }
    let mut got: Vec<Option<(Vector3<f64>, &LogRecord)>> = vec![None; plan.points.len()];
    let r = opts.ball_radius;
    for rec in &raw.records {
        let at = |msg: String| SourceError::new(path, rec.line, rec.column, msg);
        let i = match &rec.key {
            TouchKey::Index(k) => {
                if *k == 0 || *k > plan.points.len() {
                    return Err(at(format!(
                        "touch index {k}: the plan has touches 1 to {}",
                        plan.points.len()
                    )));
                }
                k - 1
            }
            TouchKey::Label(l) => match by_label.get(l.as_str()) {
                Some(&i) => i,
                None => match by_lower.get(&l.to_ascii_lowercase()) {
                    Some(Some(i)) => *i,
                    _ => return Err(at(format!("label `{l}` is not a point of the plan"))),
                },
            },
        };
        let p = &plan.points[i];
        let frame = PoseFrame::new(kin, p.tilt, p.c);
        if let Some((t, c)) = rec.rotary {
            let dc = (c - p.c).rem_euclid(360.0);
            if (t - p.tilt).abs() > 1e-3 || dc.min(360.0 - dc) > 1e-3 {
                return Err(at(format!(
                    "touch {} ({}) was logged at {} = {t}, C = {c}, but its pose {} is at {} = {}, C = {}",
                    i + 1,
                    p.label,
                    plan.tilt_letter,
                    p.pose,
                    plan.tilt_letter,
                    p.tilt,
                    p.c
                )));
            }
        }
        let n = frame.dir_to_prog(&p.n);
        let logged = frame.ball_prog(&rec.position);
        let contact = match rec.logged {
            Logged::BallCentre => logged - n * r,
            Logged::Contact => logged,
        };
        let d = contact - frame.to_prog(&p.p);
        let along = d.dot(&n);
        let lateral = (d - n * along).norm();
        if lateral > opts.lateral_tolerance {
            return Err(at(format!(
                "touch {} ({}): the logged position lies {lateral:.3} mm off its probing line (limit {} mm): \
                 not a touch of this plan, or the work offset is not on the W origin",
                i + 1,
                p.label,
                opts.lateral_tolerance
            )));
        }
        if along <= -opts.window.0 + 1e-3 {
            return Err(at(format!(
                "touch {} ({}): the contact lies {:.3} mm inside the nominal surface, at or past the {} mm overtravel: \
                 the probe did not trigger",
                i + 1,
                p.label,
                -along,
                opts.window.0
            )));
        }
        if along > opts.window.1 + 1e-3 {
            return Err(at(format!(
                "touch {} ({}): the contact lies {along:.3} mm outside the nominal surface, before its probing move \
                 began ({} mm clearance)",
                i + 1,
                p.label,
                opts.window.1
            )));
        }
        if let Some((prev, first)) = got[i] {
            if (prev - contact).norm() <= 1e-9 {
                notes.push(format!(
                    "line {}: touch {} ({}) repeats line {} with the same numbers; counted once",
                    rec.line,
                    i + 1,
                    p.label,
                    first.line
                ));
                continue;
            }
            if opts.repeats == Repeats::Reject {
                return Err(at(format!(
                    "touch {} ({}) is logged again with other numbers (first at line {})",
                    i + 1,
                    p.label,
                    first.line
                )));
            }
            notes.push(format!(
                "line {}: touch {} ({}) logged again (first at line {}); the later value is used",
                rec.line,
                i + 1,
                p.label,
                first.line
            ));
        }
        got[i] = Some((contact, rec));
    }
    let mut points = Vec::new();
    let mut missing = Vec::new();
    for (p, g) in plan.points.iter().zip(&got) {
        match g {
            Some((c, rec)) => points.push(MeasuredPoint {
                label: p.label.clone(),
                p: *c,
                line: rec.line,
                normal: None,
            }),
            None => missing.push(p.label.clone()),
        }
    }
    if !missing.is_empty() {
        notes.push(format!(
            "{} of {} planned touches are not in the log (first: {})",
            missing.len(),
            plan.points.len(),
            missing[0]
        ));
    }
    Ok(ProbeLog {
        points,
        missing,
        notes,
    })
}

// ---------------------------------------------------------------- line parsing

/// A parse failure inside a line: where, and what was expected there.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Expect<'a> {
    pub at: &'a str,
    pub what: &'static str,
}

impl<'a> ParseError<&'a str> for Expect<'a> {
    fn from_error_kind(input: &'a str, _kind: ErrorKind) -> Self {
        Expect {
            at: input,
            what: "",
        }
    }

    fn append(_input: &'a str, _kind: ErrorKind, other: Self) -> Self {
        other
    }
}

pub(crate) type PResult<'a, O> = IResult<&'a str, O, Expect<'a>>;

/// Labels a parser: on failure, the error points at where it started and
/// says what was expected.
pub(crate) fn expect<'a, O, P>(
    what: &'static str,
    mut p: P,
) -> impl Parser<&'a str, Output = O, Error = Expect<'a>>
where
    P: Parser<&'a str, Output = O, Error = Expect<'a>>,
{
    move |i: &'a str| p.parse(i).map_err(|e| e.map(|_| Expect { at: i, what }))
}

/// Spaces, tabs and control characters (a DPRNT punch leader, DC2/DC4).
pub(crate) fn is_blank(c: char) -> bool {
    c == ' ' || c == '\t' || (c.is_ascii_control() && c != '\n')
}

pub(crate) fn blanks(i: &str) -> PResult<'_, &str> {
    nom::bytes::complete::take_while(is_blank).parse(i)
}

pub(crate) fn blanks1(i: &str) -> PResult<'_, &str> {
    nom::bytes::complete::take_while1(is_blank).parse(i)
}

/// A decimal number as controllers print it: optional sign, optional
/// spaces after it (padded DPRNT fields), digits with an optional
/// fraction, or a bare fraction: `12.3450`, `-.4187`, `0.`, `- 12.5`,
/// `17`; with `comma`, `,` is the decimal separator as well. No exponent,
/// no `inf`/`nan`.
pub(crate) fn number(comma: bool) -> impl Fn(&str) -> PResult<'_, f64> {
    move |i: &str| {
        let start = i;
        let (mut rest, sign) =
            nom::combinator::opt(nom::character::complete::one_of("+-")).parse(i)?;
        if sign.is_some() {
            rest = blanks(rest)?.0;
        }
        let is_sep = |c: char| c == '.' || (comma && c == ',');
        let int_len = rest.bytes().take_while(u8::is_ascii_digit).count();
        let mut frac_len = 0;
        let mut sep = false;
        if rest[int_len..].starts_with(is_sep) {
            sep = true;
            frac_len = rest[int_len + 1..]
                .bytes()
                .take_while(u8::is_ascii_digit)
                .count();
        }
        if int_len == 0 && frac_len == 0 {
            return Err(nom::Err::Error(Expect {
                at: start,
                what: "",
            }));
        }
        let used = int_len + if sep { 1 + frac_len } else { 0 };
        let text = format!(
            "{}{}.{}",
            if sign == Some('-') { "-" } else { "" },
            if int_len == 0 { "0" } else { &rest[..int_len] },
            if sep && frac_len > 0 {
                &rest[int_len + 1..used]
            } else {
                "0"
            }
        );
        let v: f64 = text.parse().map_err(|_| {
            nom::Err::Error(Expect {
                at: start,
                what: "",
            })
        })?;
        Ok((&rest[used..], v))
    }
}

/// A touch index: a positive whole number, possibly printed with a zero
/// fraction (`17`, `17.`, `17,0000`).
pub(crate) fn index(comma: bool) -> impl Fn(&str) -> PResult<'_, usize> {
    move |i: &str| {
        let (rest, v) = number(comma)(i)?;
        if v >= 1.0 && v.fract() == 0.0 && v < 1e9 {
            Ok((rest, v as usize))
        } else {
            Err(nom::Err::Error(Expect { at: i, what: "" }))
        }
    }
}

/// One of the coordinate fields ` X<n> Y<n> Z<n>`, with any blanks.
pub(crate) fn xyz(comma: bool) -> impl Fn(&str) -> PResult<'_, Vector3<f64>> {
    move |i: &str| {
        let field = |letter: char, what: &'static str| {
            nom::sequence::preceded(
                blanks,
                expect(
                    what,
                    nom::sequence::preceded(
                        (nom::character::complete::char(letter), blanks),
                        number(comma),
                    ),
                ),
            )
        };
        let (i, x) = field('X', "`X` and a number").parse(i)?;
        let (i, y) = field('Y', "`Y` and a number").parse(i)?;
        let (i, z) = field('Z', "`Z` and a number").parse(i)?;
        Ok((i, Vector3::new(x, y, z)))
    }
}

/// The end of a line (blanks only).
pub(crate) fn end_of_line(i: &str) -> PResult<'_, ()> {
    let (rest, _) = blanks(i)?;
    if rest.is_empty() {
        Ok((rest, ()))
    } else {
        Err(nom::Err::Error(Expect {
            at: rest,
            what: "the end of the line",
        }))
    }
}

/// The lines of a log with their numbers, the line ending removed.
pub(crate) fn lines(src: &str) -> impl Iterator<Item = (usize, &str)> {
    src.split('\n')
        .enumerate()
        .map(|(i, l)| (i + 1, l.strip_suffix('\r').unwrap_or(l)))
}

/// Walks a log the way every dialect's log is laid out: blank lines and
/// tape marks skipped, `FIVECAL <test>` header lines kept, and every other
/// line handed to `touch` with its number, the whole line, the line after
/// its leading blanks, and that body's 1-based column.
pub(crate) fn parse_touch_lines(
    src: &str,
    mut touch: impl FnMut(usize, &str, &str, usize) -> Result<LogRecord, SourceError>,
) -> Result<RawLog, SourceError> {
    let mut records = Vec::new();
    let mut headers = Vec::new();
    for (no, line) in lines(src) {
        if is_empty_line(line) {
            continue;
        }
        if let Some(name) = header(line) {
            headers.push((no, name));
            continue;
        }
        let body = blanks(line).map(|(r, _)| r).unwrap_or(line);
        let column = line[..line.len() - body.len()].chars().count() + 1;
        records.push(touch(no, line, body, column)?);
    }
    Ok(RawLog { records, headers })
}

/// Whether a line carries nothing (blanks, control characters, or a
/// FANUC tape mark `%`).
pub(crate) fn is_empty_line(l: &str) -> bool {
    let t = l.trim_matches(is_blank);
    t.is_empty() || t == "%"
}

/// A header line `FIVECAL <test>`: the test name, if it is one.
pub(crate) fn header(l: &str) -> Option<String> {
    let t = l.trim_matches(is_blank);
    let rest = t.strip_prefix("FIVECAL")?;
    let name = rest.trim_matches(is_blank);
    if name.is_empty() || !rest.starts_with(is_blank) {
        return None;
    }
    Some(name.to_string())
}

/// Turns a parse failure into a `file:line:column` error.
pub(crate) fn line_error(
    path: &Path,
    line_no: usize,
    line: &str,
    e: nom::Err<Expect<'_>>,
    whole: &'static str,
) -> SourceError {
    let (at, what) = match e {
        nom::Err::Error(x) | nom::Err::Failure(x) => (x.at, x.what),
        nom::Err::Incomplete(_) => ("", ""),
    };
    let offset = line.len() - at.len();
    let column = line[..offset].chars().count() + 1;
    let found = at.trim_matches(is_blank);
    let found = if found.is_empty() {
        "the end of the line".to_string()
    } else {
        format!("`{}`", found.chars().take(24).collect::<String>())
    };
    let what = if what.is_empty() { whole } else { what };
    SourceError::new(
        path,
        line_no,
        column,
        format!("expected {what}, found {found} (a touch line is `{whole}`)"),
    )
}
