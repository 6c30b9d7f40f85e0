//! Measured points in the canonical form of docs/formats.md: CSV
//! `label,x,y,z` (extra columns ignored). For a CMM, the surface point in
//! the CMM frame; for on-machine probing, the contact point (ball radius
//! applied) in W at rotary zero.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::Path;

use nalgebra::Vector3;

use super::points::fmt_num;
use super::{csv_lines, parse_finite, valid_label};
use crate::source::SourceError;

/// One measured point.
#[derive(Clone, Debug, PartialEq)]
pub struct MeasuredPoint {
    /// The plan point's label (empty when the source had none).
    pub label: String,
    /// Coordinates, mm.
    pub p: Vector3<f64>,
    /// Line of the source file it came from (1-based, 0 if generated).
    pub line: usize,
    /// Unit direction the file gives for it (the probing direction or the
    /// measured surface normal), if any; without one, the plan point's
    /// nominal normal is its direction.
    pub normal: Option<Vector3<f64>>,
}

/// Writes canonical CSV with a header and optional `#` comments.
pub fn to_csv(points: &[MeasuredPoint], comments: &[&str]) -> String {
    let mut s = String::new();
    for c in comments {
        let _ = writeln!(s, "# {c}");
    }
    s.push_str("label,x,y,z\n");
    for p in points {
        let _ = writeln!(
            s,
            "{},{},{},{}",
            p.label,
            fmt_num(p.p.x, 6),
            fmt_num(p.p.y, 6),
            fmt_num(p.p.z, 6)
        );
    }
    s
}

/// Parses canonical CSV: a header naming `label`, `x`, `y`, `z` (any order,
/// other columns ignored), `#` comments and blank lines allowed.
pub fn parse_csv(path: &Path, src: &str) -> Result<Vec<MeasuredPoint>, SourceError> {
    let mut cols: Option<[usize; 4]> = None;
    let mut out = Vec::new();
    let mut seen: HashMap<String, usize> = HashMap::new();
    for rec in csv_lines(src) {
        let line = rec.line;
        let Some(c) = cols else {
            let find = |name: &str| {
                rec.fields
                    .iter()
                    .position(|f| f.1.eq_ignore_ascii_case(name))
            };
            match (find("label"), find("x"), find("y"), find("z")) {
                (Some(l), Some(x), Some(y), Some(z)) => cols = Some([l, x, y, z]),
                _ => {
                    let got: Vec<&str> = rec.fields.iter().map(|f| f.1).collect();
                    return Err(SourceError::new(
                        path,
                        line,
                        1,
                        format!(
                            "expected a header with columns label,x,y,z, got `{}`",
                            got.join(",")
                        ),
                    ));
                }
            }
            continue;
        };
        let need = c.iter().max().unwrap() + 1;
        if rec.fields.len() < need {
            return Err(SourceError::new(
                path,
                line,
                1,
                format!("expected at least {need} fields, got {}", rec.fields.len()),
            ));
        }
        let at = |i: usize, m: String| SourceError::new(path, line, rec.col(i), m);
        let label = rec.get(c[0]).to_string();
        if !valid_label(&label) {
            return Err(at(
                c[0],
                format!("missing or invalid label `{label}` (letters, digits, `_`, `.`, `-`)"),
            ));
        }
        if let Some(first) = seen.insert(label.clone(), line) {
            return Err(at(
                c[0],
                format!("label `{label}` appears twice (first at line {first})"),
            ));
        }
        let num = |i: usize| parse_finite(rec.get(i)).map_err(|m| at(i, m));
        out.push(MeasuredPoint {
            label,
            p: Vector3::new(num(c[1])?, num(c[2])?, num(c[3])?),
            line,
            normal: None,
        });
    }
    if cols.is_none() {
        return Err(SourceError::new(
            path,
            0,
            0,
            "empty file: expected a header label,x,y,z and points",
        ));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_extra_columns_in_any_order() {
        let src = "# from the CMM\nx,y,z,label,dev\n1.5,2,-3,P1,0.001\n\n4,5,6,P2,0\n";
        let p = parse_csv(Path::new("m.csv"), src).unwrap();
        assert_eq!(p.len(), 2);
        assert_eq!(p[0].label, "P1");
        assert_eq!(p[0].p, Vector3::new(1.5, 2.0, -3.0));
        assert_eq!(p[1].line, 5);
        let back = parse_csv(Path::new("m.csv"), &to_csv(&p, &[])).unwrap();
        assert_eq!(
            back.iter().map(|q| (&q.label, q.p)).collect::<Vec<_>>(),
            p.iter().map(|q| (&q.label, q.p)).collect::<Vec<_>>()
        );
    }

    #[test]
    fn names_line_and_column_of_bad_values() {
        let e = parse_csv(Path::new("m.csv"), "label,x,y,z\nP1,1,NaN,3\n")
            .unwrap_err()
            .to_string();
        assert_eq!(e, "m.csv:2:6: expected a finite number, got `NaN`");
        let e = parse_csv(Path::new("m.csv"), "label,x,y,z\nP1,1,2,3\nP1,1,2,3\n")
            .unwrap_err()
            .to_string();
        assert_eq!(e, "m.csv:3:1: label `P1` appears twice (first at line 2)");
        let e = parse_csv(Path::new("m.csv"), "label,x,y,z\n,1,2,3\n")
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "m.csv:2:1: missing or invalid label `` (letters, digits, `_`, `.`, `-`)"
        );
    }
}
