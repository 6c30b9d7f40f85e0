//! LinuxCNC: the `(LOG,...)` file of a probing program using `G38.2`, and
//! the `(PROBEOPEN ...)` file as a fallback.
//!
//! # The log we read: `LOGOPEN`/`LOG` with labels
//! The program opens a log, writes a header, and after each `G38.2` writes
//! the touch's label with the probe position `#5061`-`#5063` (current work
//! coordinates: with the work offset on W, the ball centre in program
//! coordinates). LinuxCNC expands each `#nnnn` in a `LOG` comment with
//! `%lf`, six decimals:
//!
//! ```text
//! (LOGOPEN,probe-columns.log)
//! (LOG,FIVECAL probe-columns)
//! G38.2 X.. Y.. Z.. F100
//! (LOG,T A0C0_C1_xp X#5061 Y#5062 Z#5063)
//! (LOGCLOSE)
//! ```
//!
//! writes
//!
//! ```text
//! FIVECAL probe-columns
//! T A0C0_C1_xp X33.000000 Y-45.000000 Z135.002100
//! ```
//!
//! # Why not `PROBEOPEN` alone
//! `(PROBEOPEN file)` stores the nine numbers `X Y Z A B C U V W` of every
//! successful probe, `%f %f %f ...`, and nothing else (older versions only
//! `X Y Z`). Joining those lines to the plan by order is fragile: LinuxCNC
//! skips a result equal to the previous one, a `G38.3` that misses writes
//! nothing, and a run restarted half-way appends without a mark, and each
//! of these shifts every later point onto the wrong label without a trace.
//! A `LOG` line names its touch, so a missing, repeated or foreign line is
//! found at once. The program may open both files ([`open_lines`] with a
//! probe file): [`parse_probe_file`] reads the `PROBEOPEN` one by order,
//! checks its rotary columns against each touch's pose, and the joiner's
//! plausibility check rejects any line that lands off its touch's probing
//! line, which catches a shift.

use std::path::Path;

use nalgebra::Vector3;
use nom::Parser;

use super::{
    LogRecord, Logged, RawLog, TouchKey, blanks, blanks1, end_of_line, expect, is_empty_line,
    line_error, lines, number, parse_touch_lines, xyz,
};
use crate::formats::valid_label;
use crate::source::SourceError;

const TOUCH_LINE: &str = "T <label> X<x> Y<y> Z<z>";

/// The lines that open the log (and, when `probe_file` is given, the
/// `PROBEOPEN` file) and write the header.
pub fn open_lines(test: &str, log_file: &str, probe_file: Option<&str>) -> Vec<String> {
    let mut v = vec![
        format!("(LOGOPEN,{log_file})"),
        format!("(LOG,FIVECAL {test})"),
    ];
    if let Some(p) = probe_file {
        v.push(format!("(PROBEOPEN {p})"));
    }
    v
}

/// The line that logs the touch `label` right after its `G38.2` block.
pub fn touch_line(label: &str) -> String {
    format!("(LOG,T {label} X#5061 Y#5062 Z#5063)")
}

/// The lines that close what [`open_lines`] opened.
pub fn close_lines(probe_file: bool) -> Vec<String> {
    let mut v = Vec::new();
    if probe_file {
        v.push("(PROBECLOSE)".into());
    }
    v.push("(LOGCLOSE)".into());
    v
}

/// The log line LinuxCNC writes for [`touch_line`] (`%lf`, no `-0`).
pub fn log_line(label: &str, ball: &Vector3<f64>) -> String {
    let f = |v: f64| {
        let s = format!("{v:.6}");
        if s.starts_with('-') && s[1..].bytes().all(|b| b == b'0' || b == b'.') {
            s[1..].to_string()
        } else {
            s
        }
    };
    format!("T {label} X{} Y{} Z{}", f(ball.x), f(ball.y), f(ball.z))
}

/// Parses a `LOG` file.
pub fn parse_log(path: &Path, src: &str) -> Result<RawLog, SourceError> {
    parse_touch_lines(src, |no, line, body, _| {
        let label_of = |i| {
            nom::bytes::complete::take_while1(|c: char| {
                c.is_ascii_alphanumeric() || c == '_' || c == '.' || c == '-'
            })
            .parse(i)
        };
        let mut touch = (
            expect("`T`", nom::character::complete::char('T')),
            expect(
                "a space and the point label",
                nom::sequence::preceded(blanks1, label_of),
            ),
            xyz(false),
            end_of_line,
        );
        let (_, (_, label, p, ())) = touch
            .parse(body)
            .map_err(|e| line_error(path, no, line, e, TOUCH_LINE))?;
        debug_assert!(valid_label(label));
        // The record's column is the label's: errors about it point there.
        let column = line[..label.as_ptr() as usize - line.as_ptr() as usize]
            .chars()
            .count()
            + 1;
        Ok(LogRecord {
            key: TouchKey::Label(label.to_string()),
            position: p,
            logged: Logged::BallCentre,
            rotary: None,
            line: no,
            column,
        })
    })
}

/// Parses a `PROBEOPEN` file: per line three (`X Y Z`) or nine (`X Y Z A
/// B C U V W`) numbers, joined to the plan by order (the `n`-th line is
/// touch `n`). With nine, the tilt column (A, or B when `tilt_letter` is
/// `B`) and C are kept for the joiner to check against the pose. `#`
/// comment lines and blank lines are skipped.
pub fn parse_probe_file(path: &Path, src: &str, tilt_letter: char) -> Result<RawLog, SourceError> {
    let mut records = Vec::new();
    for (no, line) in lines(src) {
        if is_empty_line(line) || line.trim_start().starts_with('#') {
            continue;
        }
        let mut rest = line;
        let mut values = Vec::new();
        loop {
            let after = blanks(rest).map(|(r, _)| r).unwrap_or(rest);
            if after.is_empty() {
                break;
            }
            match number(false)(after) {
                Ok((r, v)) if r.is_empty() || r.starts_with(super::is_blank) => {
                    values.push(v);
                    rest = r;
                }
                _ => {
                    let e = nom::Err::Error(super::Expect {
                        at: after,
                        what: "a number",
                    });
                    return Err(line_error(path, no, line, e, "X Y Z [A B C U V W]"));
                }
            }
        }
        if values.len() != 3 && values.len() != 9 {
            return Err(SourceError::new(
                path,
                no,
                1,
                format!(
                    "expected 3 numbers (X Y Z) or 9 (X Y Z A B C U V W), found {}",
                    values.len()
                ),
            ));
        }
        let rotary = (values.len() == 9).then(|| {
            let t = if tilt_letter == 'B' {
                values[4]
            } else {
                values[3]
            };
            (t, values[5])
        });
        records.push(LogRecord {
            key: TouchKey::Index(records.len() + 1),
            position: Vector3::new(values[0], values[1], values[2]),
            logged: Logged::BallCentre,
            rotary,
            line: no,
            column: 1,
        });
    }
    Ok(RawLog {
        records,
        headers: Vec::new(),
    })
}
