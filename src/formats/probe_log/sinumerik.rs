//! SINUMERIK: the file a probing program appends to with `WRITE`.
//!
//! # The log we read
//! The program deletes the log of an earlier run, writes a header, and
//! after each measuring block (`MEAS=1 G1 X.. Y.. Z.. F..`, `STOPRE`, an
//! alarm when `$AC_MEA[1]` says the probe never switched) copies the
//! latched position in the workpiece system, `$AA_MW[X]`..`$AA_MW[Z]` (with
//! the work offset on W and the probe's length offset active: the ball
//! centre in program coordinates), into R parameters and appends one line
//! with the touch index. `<<` turns a REAL into text in the control's own
//! format, so the program rounds each value to four decimals itself:
//!
//! ```text
//! WRITE(FCERR,"FIVECAL_COLUMNS","FIVECAL probe-columns")
//! MEAS=1 G1 X33 Y-38 Z135 F100
//! STOPRE
//! R1=$AA_MW[X]
//! R2=$AA_MW[Y]
//! R3=$AA_MW[Z]
//! FCLINE="T17 X"<<ROUND(R1*10000)/10000<<" Y"<<ROUND(R2*10000)/10000<<" Z"<<ROUND(R3*10000)/10000
//! WRITE(FCERR,"FIVECAL_COLUMNS",FCLINE)
//! ```
//!
//! writes (`WRITE` ends each line with LF)
//!
//! ```text
//! FIVECAL probe-columns
//! T17 X33 Y-45 Z135.0021
//! ```
//!
//! How many digits `<<` prints for a rounded value is not documented in
//! the sources consulted: the reader takes any decimal number (`33`,
//! `33.0000`, `-.5`), and [`touch_line`] writes the shortest form.

use std::path::Path;

use nalgebra::Vector3;

use super::RawLog;
use crate::source::SourceError;

/// Decimals the program rounds each value to.
pub(crate) const DECIMALS: i32 = 4;

/// A value as the program writes it: rounded to [`DECIMALS`], without
/// trailing zeros, never `-0`.
fn text(v: f64) -> String {
    let k = 10f64.powi(DECIMALS);
    let r = (v * k).round() / k;
    let s = format!("{:.*}", DECIMALS as usize, r);
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".to_string()
    } else {
        s.to_string()
    }
}

/// The line the program appends for touch `index` with the latched ball
/// centre `ball` (program coordinates, mm).
pub fn touch_line(index: usize, ball: &Vector3<f64>) -> String {
    format!(
        "T{index} X{} Y{} Z{}",
        text(ball.x),
        text(ball.y),
        text(ball.z)
    )
}

/// Parses a log written by `WRITE`: its lines are those of FANUC's DPRNT
/// log (`T<index> X<x> Y<y> Z<z>`, any decimal spelling), read by one
/// reader.
pub fn parse(path: &Path, src: &str) -> Result<RawLog, SourceError> {
    super::fanuc::parse(path, src)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_read_back_what_the_program_writes() {
        let ball = Vector3::new(33.0, -45.00004, 135.00214);
        let l = touch_line(17, &ball);
        assert_eq!(l, "T17 X33 Y-45 Z135.0021");
        let src = format!("FIVECAL probe-columns\n{l}\nT18 X33.0000 Y-.5 Z0\n");
        let raw = parse(Path::new("log"), &src).unwrap();
        assert_eq!(raw.headers, vec![(1, "probe-columns".to_string())]);
        assert_eq!(raw.records[0].key, super::super::TouchKey::Index(17));
        assert!((raw.records[0].position - ball).norm() < 0.6e-4);
        assert_eq!(raw.records[1].position, Vector3::new(33.0, -0.5, 0.0));
        assert_eq!(
            touch_line(1, &Vector3::new(-0.00001, 0.0, 1.5)),
            "T1 X0 Y0 Z1.5"
        );
    }

    #[test]
    fn a_line_of_something_else_is_an_error_at_its_column() {
        let e = parse(Path::new("log"), "FIVECAL probe-sphere\nT3 X1 Y2\n").unwrap_err();
        assert_eq!(e.line, 2);
        assert!(e.message.contains("`Z` and a number"), "{}", e.message);
    }
}
