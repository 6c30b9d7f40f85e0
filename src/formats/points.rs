//! Plan points, `<name>.points.csv` (docs/formats.md): the nominal surface
//! points of a test in W with the pose that produced or observes them and
//! the outward normal.
//!
//! ```text
//! # stepped-square on bc-trunnion
//! label,pose,seq,B,C,x,y,z,nx,ny,nz
//! P0001,B0C0,0,0,0,-20.000000,-30.000000,45.000000,0.000000000,-1.000000000,0.000000000
//! ```

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::Path;

use nalgebra::Vector3;

use super::{csv_lines, parse_finite, valid_label};
pub(crate) use crate::numbers::fmt_num;
use crate::source::SourceError;

/// One planned point.
#[derive(Clone, Debug, PartialEq)]
pub struct PlanPoint {
    /// Unique id.
    pub label: String,
    /// Id of the pose (cut or station).
    pub pose: String,
    /// Execution order of the pose, from 0.
    pub seq: u32,
    /// Tilt angle of the pose, deg.
    pub tilt: f64,
    /// C angle of the pose, deg.
    pub c: f64,
    /// Nominal surface point in W, mm.
    pub p: Vector3<f64>,
    /// Unit outward normal in W (material to air).
    pub n: Vector3<f64>,
}

/// The points of a plan, with the tilt axis letter of its header.
#[derive(Clone, Debug, PartialEq)]
pub struct PlanPoints {
    /// `A` or `B`.
    pub tilt_letter: char,
    /// The points, in file order.
    pub points: Vec<PlanPoint>,
}

fn fmt_angle(v: f64) -> String {
    let s = fmt_num(v, 6);
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s.is_empty() || s == "-" {
        "0".into()
    } else {
        s.to_string()
    }
}

impl PlanPoints {
    /// The CSV text, with optional `#` comment lines first.
    pub fn to_csv(&self, comments: &[&str]) -> String {
        let mut s = String::new();
        for c in comments {
            let _ = writeln!(s, "# {c}");
        }
        let _ = writeln!(s, "label,pose,seq,{},C,x,y,z,nx,ny,nz", self.tilt_letter);
        for p in &self.points {
            let _ = writeln!(
                s,
                "{},{},{},{},{},{},{},{},{},{},{}",
                p.label,
                p.pose,
                p.seq,
                fmt_angle(p.tilt),
                fmt_angle(p.c),
                fmt_num(p.p.x, 6),
                fmt_num(p.p.y, 6),
                fmt_num(p.p.z, 6),
                fmt_num(p.n.x, 9),
                fmt_num(p.n.y, 9),
                fmt_num(p.n.z, 9)
            );
        }
        s
    }

    /// Parses and validates a points file.
    pub fn parse(path: &Path, src: &str) -> Result<PlanPoints, SourceError> {
        let mut header: Option<(char, usize)> = None;
        let mut points = Vec::new();
        let mut labels: HashMap<String, usize> = HashMap::new();
        let mut poses: HashMap<String, (u32, f64, f64, usize)> = HashMap::new();
        for rec in csv_lines(src) {
            let line = rec.line;
            let at = |i: usize, msg: String| SourceError::new(path, line, rec.col(i), msg);
            let Some((tilt_letter, _)) = header else {
                let cols: Vec<&str> = rec.fields.iter().map(|f| f.1).collect();
                let t = cols.get(3).copied().unwrap_or("");
                let expected = [
                    "label", "pose", "seq", t, "C", "x", "y", "z", "nx", "ny", "nz",
                ];
                if (t != "A" && t != "B") || cols != expected {
                    return Err(SourceError::new(
                        path,
                        line,
                        1,
                        format!(
                            "expected the header `label,pose,seq,B,C,x,y,z,nx,ny,nz` (or A for B), got `{}`",
                            cols.join(",")
                        ),
                    ));
                }
                header = Some((t.chars().next().unwrap(), line));
                continue;
            };
            if rec.fields.len() != 11 {
                return Err(at(
                    0,
                    format!(
                        "expected 11 fields (label,pose,seq,{tilt_letter},C,x,y,z,nx,ny,nz), got {}",
                        rec.fields.len()
                    ),
                ));
            }
            let label = rec.get(0).to_string();
            if !valid_label(&label) {
                return Err(at(
                    0,
                    format!("label `{label}` must be made of letters, digits, `_`, `.` and `-`"),
                ));
            }
            if let Some(first) = labels.insert(label.clone(), line) {
                return Err(at(
                    0,
                    format!("label `{label}` appears twice (first at line {first})"),
                ));
            }
            let pose = rec.get(1).to_string();
            if !valid_label(&pose) {
                return Err(at(
                    1,
                    format!("pose `{pose}` must be made of letters, digits, `_`, `.` and `-`"),
                ));
            }
            let seq: u32 = rec.get(2).parse().map_err(|_| {
                at(
                    2,
                    format!("expected seq as an integer >= 0, got `{}`", rec.get(2)),
                )
            })?;
            let num = |i: usize| parse_finite(rec.get(i)).map_err(|m| at(i, m));
            let (tilt, c) = (num(3)?, num(4)?);
            let p = Vector3::new(num(5)?, num(6)?, num(7)?);
            let n = Vector3::new(num(8)?, num(9)?, num(10)?);
            if (n.norm() - 1.0).abs() > 1e-6 {
                return Err(at(
                    8,
                    format!(
                        "normal ({}, {}, {}) is not a unit vector (length {:.9})",
                        n.x,
                        n.y,
                        n.z,
                        n.norm()
                    ),
                ));
            }
            match poses.get(&pose) {
                Some(&(s, t, cc, first)) if (s, t, cc) != (seq, tilt, c) => {
                    return Err(at(
                        2,
                        format!(
                            "pose `{pose}` has seq {seq}, {tilt_letter} {tilt}, C {c} here but seq {s}, {tilt_letter} {t}, C {cc} at line {first}"
                        ),
                    ));
                }
                Some(_) => {}
                None => {
                    let _ = poses.insert(pose.clone(), (seq, tilt, c, line));
                }
            }
            points.push(PlanPoint {
                label,
                pose,
                seq,
                tilt,
                c,
                p,
                n: n.normalize(),
            });
        }
        let Some((tilt_letter, _)) = header else {
            return Err(SourceError::new(
                path,
                0,
                0,
                "no header: expected `label,pose,seq,B,C,x,y,z,nx,ny,nz`",
            ));
        };
        Ok(PlanPoints {
            tilt_letter,
            points,
        })
    }

    /// Reads a file.
    pub fn read(path: &Path) -> Result<PlanPoints, SourceError> {
        let src =
            crate::input::read_text(path, "points file", crate::limits::MAX_MEASUREMENT_BYTES)?;
        PlanPoints::parse(path, &src)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const FILE: &str = "# stepped-square on bc-trunnion\nlabel,pose,seq,B,C,x,y,z,nx,ny,nz\nP1,B0C0,0,0,0,-20,-30,45,0,-1,0\nP2,B0C0,0,0,0,20,-30,45,0,-1,0\n\nP3,B90C0,4,90,0,50,0,20,1,0,0\n";

    #[test]
    fn parses_and_writes_back() {
        let p = PlanPoints::parse(Path::new("t.points.csv"), FILE).unwrap();
        assert_eq!(p.tilt_letter, 'B');
        assert_eq!(p.points.len(), 3);
        assert_eq!(p.points[2].seq, 4);
        let again = PlanPoints::parse(Path::new("x"), &p.to_csv(&["again"])).unwrap();
        assert_eq!(again, p);
    }

    #[test]
    fn reports_bad_fields_with_line_and_column() {
        let bad = FILE.replace("P2,B0C0,0,0,0,20,", "P2,B0C0,0,0,0,2O,");
        let e = PlanPoints::parse(Path::new("t.csv"), &bad)
            .unwrap_err()
            .to_string();
        assert_eq!(e, "t.csv:4:15: expected a number, got `2O`");
        let dup = FILE.replace("P2,", "P1,");
        let e = PlanPoints::parse(Path::new("t.csv"), &dup)
            .unwrap_err()
            .to_string();
        assert_eq!(e, "t.csv:4:1: label `P1` appears twice (first at line 3)");
        let nonunit = FILE.replace("0,-1,0\nP2", "0,-2,0\nP2");
        let e = PlanPoints::parse(Path::new("t.csv"), &nonunit)
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("t.csv:3:") && e.contains("not a unit vector"),
            "{e}"
        );
        let seq = FILE.replace("P2,B0C0,0,", "P2,B0C0,1,");
        let e = PlanPoints::parse(Path::new("t.csv"), &seq)
            .unwrap_err()
            .to_string();
        assert!(e.contains("pose `B0C0` has seq 1"), "{e}");
    }
}
