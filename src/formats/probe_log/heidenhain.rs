//! HEIDENHAIN: the `FN 16: F-PRINT` log of a probing program.
//!
//! `FN 16` prints a format file (`.A`) with the values of Q parameters; the
//! plan writes two format files next to the program, one for the header
//! ([`header_format_file`]) and one for the touches
//! ([`touch_format_file`]), and after each touch the program puts the
//! touch index into `Q1900` and the recorded position into `Q1901`-`Q1903`
//! ([`touch_statements`]):
//!
//! ```text
//! Q1900 = 17
//! FN 16: F-PRINT TNC:\fivecal\probe-columns-touch.A / TNC:\fivecal\probe-columns.txt
//! ```
//!
//! with `probe-columns-touch.A`:
//!
//! ```text
//! M_APPEND;
//! "T%D X%.4LF Y%.4LF Z%.4LF",Q1900,Q1901,Q1902,Q1903;
//! ```
//!
//! The log then reads (a control set to a German or French user language
//! writes decimal commas, as the `FN 15` output `%FN15RUN.A` does):
//!
//! ```text
//! FIVECAL probe-columns
//! T17 X33,0000 Y-45,0000 Z135,0021
//! ```
//!
//! # Ball centres or contact points
//! The tag says what the numbers are. `T` lines hold probe-ball centres,
//! which the reader turns into contact points like the other dialects'.
//! `K` lines ([`touch_format_file`] with [`Logged::Contact`]) hold
//! contact points the control has already compensated: after `TCH PROBE 0`,
//! system datum `ID360 NR1` is "the last touch point of cycle 0 in the
//! workpiece coordinate system, with probe radius compensation, without
//! length compensation" (TNC 426/430 technical manual, system data 360;
//! [`cycle0_reads`] reads it), so a program built on cycle 0 writes `K`
//! lines. Cycle 0 probes along one axis only, which suits the sphere
//! test's axis-parallel touches; which cycle a post uses for oblique
//! approaches is the post's choice, and the tag keeps the log honest about
//! it. The separator between fields is a space, never a comma, so that
//! decimal commas stay unambiguous.
//!
//! The exact keywords of format files (`M_APPEND`, `%LF`) follow the TNC
//! manuals' examples; check them on the target control's user manual
//! ("FN 16: F-PRINT") before the first run.

use std::path::Path;

use nalgebra::Vector3;
use nom::Parser;

use super::{
    LogRecord, Logged, RawLog, TouchKey, blanks, end_of_line, expect, index, line_error,
    parse_touch_lines, xyz,
};
use crate::source::SourceError;

/// Q parameter holding the touch index.
pub(crate) const INDEX_Q: u32 = 1900;
/// Q parameters holding X, Y, Z of the recorded position: `X_Q`, +1, +2.
pub(crate) const X_Q: u32 = 1901;

const TOUCH_LINE: &str = "T<index> X<x> Y<y> Z<z> (or K<index> ...)";

/// The header format file: one line naming the test.
pub fn header_format_file(test: &str) -> String {
    format!("\"FIVECAL {test}\";\n")
}

/// The touch format file for positions of kind `logged`.
pub fn touch_format_file(logged: Logged) -> String {
    let tag = match logged {
        Logged::BallCentre => 'T',
        Logged::Contact => 'K',
    };
    format!(
        "M_APPEND;\n\"{tag}%D X%.4LF Y%.4LF Z%.4LF\",Q{INDEX_Q},Q{},Q{},Q{};\n",
        X_Q,
        X_Q + 1,
        X_Q + 2
    )
}

/// The `FN 16` block that prints `format_file` to `output_file`.
pub fn f_print(format_file: &str, output_file: &str) -> String {
    format!("FN 16: F-PRINT {format_file} / {output_file}")
}

/// The blocks that log touch `index` once `Q1901`-`Q1903` hold its
/// position.
pub fn touch_statements(index: usize, format_file: &str, output_file: &str) -> Vec<String> {
    vec![
        format!("Q{INDEX_Q} = {index}"),
        f_print(format_file, output_file),
    ]
}

/// The blocks that read the last touch point of `TCH PROBE 0` (radius
/// compensated: log it with [`Logged::Contact`]) into `Q1901`-`Q1903`.
pub fn cycle0_reads() -> Vec<String> {
    (0..3)
        .map(|k| format!("FN 18: SYSREAD Q{} = ID360 NR1 IDX{}", X_Q + k, k + 1))
        .collect()
}

/// A touch line as the format file prints it, with decimal commas when
/// `comma` (for writing logs as a control would, e.g. in simulation).
pub fn touch_line(index: usize, p: &Vector3<f64>, logged: Logged, comma: bool) -> String {
    let tag = match logged {
        Logged::BallCentre => 'T',
        Logged::Contact => 'K',
    };
    let f = |v: f64| {
        let s = crate::formats::points::fmt_num(v, 4);
        if comma { s.replace('.', ",") } else { s }
    };
    format!("{tag}{index} X{} Y{} Z{}", f(p.x), f(p.y), f(p.z))
}

/// Parses an `FN 16` log (decimal points or commas).
pub fn parse(path: &Path, src: &str) -> Result<RawLog, SourceError> {
    parse_touch_lines(src, |no, line, body, column| {
        let tag = nom::branch::alt((
            nom::combinator::value(Logged::BallCentre, nom::character::complete::char('T')),
            nom::combinator::value(Logged::Contact, nom::character::complete::char('K')),
        ));
        let mut touch = (
            expect(
                "`T` (ball centre) or `K` (contact) and the touch index",
                (tag, nom::sequence::preceded(blanks, index(true))),
            ),
            xyz(true),
            end_of_line,
        );
        let (_, ((logged, k), p, ())) = touch
            .parse(body)
            .map_err(|e| line_error(path, no, line, e, TOUCH_LINE))?;
        Ok(LogRecord {
            key: TouchKey::Index(k),
            position: p,
            logged,
            rotary: None,
            line: no,
            column,
        })
    })
}
