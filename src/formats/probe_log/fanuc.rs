//! FANUC: the `POPEN`/`DPRNT`/`PCLOS` log of a probing program using `G31`.
//!
//! The program opens the output once, writes a header, and after every
//! `G31` probing move sets the touch index into `#199` and prints it with
//! the skip position `#5061`-`#5063` (workpiece coordinates, tool length
//! compensation applied: with the work offset on W, the ball centre in
//! program coordinates):
//!
//! ```text
//! POPEN
//! DPRNT[FIVECAL*PROBE-COLUMNS]
//! ...
//! G31 X.. Y.. Z.. F100.
//! #199=17
//! DPRNT[T#199[50]*X#5061[44]*Y#5062[44]*Z#5063[44]]
//! ...
//! PCLOS
//! ```
//!
//! which writes (`*` prints as a space; the exact padding depends on the
//! control's PRT setting, No. 6001#1):
//!
//! ```text
//! %
//! FIVECAL PROBE-COLUMNS
//! T   17 X  33.0000 Y -45.0000 Z 135.0021
//! T   18 X -.4187 Y 0. Z 20.0000
//! %
//! ```
//!
//! # Why `[44]`
//! A DPRNT field `[cd]` has `c` integer and `d` decimal digits with
//! `c + d <= 8`. FANUC pads a short integer part with spaces but drops the
//! high digits of a long one (the manual's `T#30[20]` of 123.456 prints
//! `T23`). The program sets the work offset on the W origin (the
//! intersection of the rotary axes), so every recorded ball centre lies
//! within the probe's reach of the table centre: a few hundred millimetres,
//! three integer digits (machine coordinates would be as large as the
//! strokes, and a work offset at a table corner would double them). `[44]`
//! keeps one spare integer digit, values up to 9999.9999 mm, and four
//! decimals, 0.1 um, the finest increment a FANUC records (IS-C); `[53]`
//! would round to 1 um. The index uses `[50]`: up to 99999 touches, no
//! decimal point. [`fits_field`] tells whether a value prints whole; the
//! planner's positions all do, and the reader's plausibility check catches
//! a value that lost its high digits anyway.
//!
//! `#199` is a common variable outside the range Renishaw's Inspection Plus
//! macros use for results (`#100`-`#149`).

use std::path::Path;

use nalgebra::Vector3;
use nom::Parser;

use super::{
    LogRecord, Logged, RawLog, TouchKey, blanks, end_of_line, expect, index, line_error,
    parse_touch_lines, xyz,
};
use crate::source::SourceError;

/// The macro variable holding the touch index.
pub(crate) const INDEX_VARIABLE: u32 = 199;
/// Integer digits of the coordinate fields.
pub(crate) const INT_DIGITS: usize = 4;
/// Decimal digits of the coordinate fields.
pub(crate) const DEC_DIGITS: usize = 4;

const TOUCH_LINE: &str = "T<index> X<x> Y<y> Z<z>";

/// The blocks that open the log and write its header (`test` in capitals,
/// DPRNT's literal text being letters, digits and `-`).
pub fn open_blocks(test: &str) -> Vec<String> {
    vec![
        "POPEN".into(),
        format!("DPRNT[FIVECAL*{}]", test.to_ascii_uppercase()),
    ]
}

/// The blocks that log touch `index` right after its `G31` block.
pub fn touch_blocks(index: usize) -> Vec<String> {
    let v = INDEX_VARIABLE;
    vec![
        format!("#{v}={index}"),
        format!(
            "DPRNT[T#{v}[50]*X#5061[{INT_DIGITS}{DEC_DIGITS}]*Y#5062[{INT_DIGITS}{DEC_DIGITS}]*Z#5063[{INT_DIGITS}{DEC_DIGITS}]]"
        ),
    ]
}

/// The block that closes the log.
pub fn close_blocks() -> Vec<String> {
    vec!["PCLOS".into()]
}

/// Whether `v` prints whole in a `[44]` field.
pub fn fits_field(v: f64) -> bool {
    let scale = 10f64.powi(DEC_DIGITS as i32);
    ((v.abs() * scale).round() / scale) < 10f64.powi(INT_DIGITS as i32)
}

/// How DPRNT prints leading zeros and the plus sign (parameter PRT).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Prt {
    /// PRT = 0: as spaces (fixed-width fields).
    Spaces,
    /// PRT = 1: suppressed.
    Suppressed,
}

/// `v` as DPRNT prints it in a `[c d]` field: rounded to `d` decimals,
/// the integer part cut to its lowest `c` digits, padded or not by `prt`.
/// (For writing logs as a control would, e.g. in simulation.)
pub fn dprnt(v: f64, c: usize, d: usize, prt: Prt) -> String {
    let scale = 10u128.pow(d as u32);
    let units = (v.abs() * scale as f64).round() as u128;
    let (int, frac) = (units / scale, units % scale);
    let int = int % 10u128.pow(c as u32);
    let neg = v < 0.0 && units != 0;
    let digits = if int == 0 {
        String::new()
    } else {
        int.to_string()
    };
    let mut s = String::new();
    match prt {
        Prt::Spaces => {
            s.push(if neg { '-' } else { ' ' });
            s.push_str(&" ".repeat(c - digits.len()));
            s.push_str(&digits);
        }
        Prt::Suppressed => {
            if neg {
                s.push('-');
            }
            s.push_str(if digits.is_empty() && d == 0 {
                "0"
            } else {
                &digits
            });
        }
    }
    if d > 0 {
        s.push('.');
        s.push_str(&format!("{frac:0d$}"));
    }
    s
}

/// The line `DPRNT[T#199[50]*X#5061[44]*Y#5062[44]*Z#5063[44]]` prints.
pub fn touch_line(index: usize, ball: &Vector3<f64>, prt: Prt) -> String {
    format!(
        "T{} X{} Y{} Z{}",
        dprnt(index as f64, 5, 0, prt),
        dprnt(ball.x, INT_DIGITS, DEC_DIGITS, prt),
        dprnt(ball.y, INT_DIGITS, DEC_DIGITS, prt),
        dprnt(ball.z, INT_DIGITS, DEC_DIGITS, prt)
    )
}

/// Parses a DPRNT log.
pub fn parse(path: &Path, src: &str) -> Result<RawLog, SourceError> {
    parse_touch_lines(src, |no, line, body, column| {
        let mut touch = (
            expect(
                "`T` and the touch index",
                nom::sequence::preceded(
                    (nom::character::complete::char('T'), blanks),
                    index(false),
                ),
            ),
            xyz(false),
            end_of_line,
        );
        let (_, (k, p, ())) = touch
            .parse(body)
            .map_err(|e| line_error(path, no, line, e, TOUCH_LINE))?;
        Ok(LogRecord {
            key: TouchKey::Index(k),
            position: p,
            logged: Logged::BallCentre,
            rotary: None,
            line: no,
            column,
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dprnt_pads_rounds_and_cuts_like_the_manuals() {
        // FANUC: #2 = 128.47398, #5 = -91.2, #30 = 123.456,
        // DPRNT[X#2[53]Y#5[53]T#30[20]] -> X128.474Y-91.200T23 (PRT = 1).
        assert_eq!(dprnt(128.47398, 5, 3, Prt::Suppressed), "128.474");
        assert_eq!(dprnt(-91.2, 5, 3, Prt::Suppressed), "-91.200");
        assert_eq!(dprnt(123.456, 2, 0, Prt::Suppressed), "23");
        assert_eq!(dprnt(-0.4187, 4, 4, Prt::Suppressed), "-.4187");
        assert_eq!(dprnt(12.345, 4, 4, Prt::Spaces), "   12.3450");
        assert_eq!(dprnt(-12.345, 4, 4, Prt::Spaces), "-  12.3450");
    }

    #[test]
    fn field_fits_below_ten_thousand() {
        assert!(fits_field(-549.3474));
        assert!(fits_field(9999.99994));
        assert!(!fits_field(9999.99995));
        assert!(!fits_field(-12345.0));
    }
}
