//! Recognizes a measurement file from its content (never from its name) and
//! reads it into the canonical meaning of SPEC section 3.
//!
//! Every format is a [`Reader`] in one registry, [`readers`], tried in
//! order: the first whose `sniff` accepts the text reads it. Specific
//! formats come first, the plain point list (any three numbers per line)
//! last. The probe-log readers of `src/formats/probe_log/` plug in at the
//! marked place in [`readers`].

use std::path::Path;

use nalgebra::Vector3;

use super::heights::{self, SectionHeight};
use super::measured::{self, MeasuredPoint};
use super::{csv_lines, dmis, parse_finite};
use crate::source::SourceError;

/// Points read from one file.
#[derive(Clone, Debug, PartialEq)]
pub struct PointSet {
    /// The format's name (`dmis`, `csv`, `plain`, ...).
    pub format: &'static str,
    /// The points; labels are empty when the format has none.
    pub points: Vec<MeasuredPoint>,
    /// Whether the points carry labels.
    pub labeled: bool,
    /// Nominal positions the file itself states, by label (DMIS `F(..)`):
    /// used to check that the file belongs to the plan.
    pub nominals: Vec<dmis::Nominal>,
    /// Quirks met while reading.
    pub warnings: Vec<String>,
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
    /// Whether the text is in this format.
    fn sniff(&self, src: &str) -> bool;
    /// Reads it.
    fn read(&self, path: &Path, src: &str) -> Result<Measurement, SourceError>;
}

struct Dmis;
struct Canonical;
struct Heights;
struct Plain;

impl Reader for Dmis {
    fn name(&self) -> &'static str {
        "dmis"
    }
    fn describe(&self) -> &'static str {
        "DMIS output (F(..)/FA(..) statements)"
    }
    fn sniff(&self, src: &str) -> bool {
        dmis::looks_like_dmis(src)
    }
    fn read(&self, path: &Path, src: &str) -> Result<Measurement, SourceError> {
        let o = dmis::parse(path, src)?;
        let points = o.measured_points();
        if points.is_empty() {
            return Err(SourceError::new(
                path,
                0,
                0,
                "DMIS output without any measured point (FA(..)=FEAT/POINT,...)",
            ));
        }
        for p in &points {
            if !super::valid_label(&p.label) {
                return Err(SourceError::new(
                    path,
                    p.line,
                    1,
                    format!(
                        "label `{}` cannot name a plan point (letters, digits, `_`, `.`, `-`)",
                        p.label
                    ),
                ));
            }
        }
        Ok(Measurement::Points(PointSet {
            format: "dmis",
            points,
            labeled: true,
            nominals: o.nominal_points(),
            warnings: o.warnings,
        }))
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
    fn sniff(&self, src: &str) -> bool {
        header_fields(src).is_some_and(|h| {
            ["label", "x", "y", "z"]
                .iter()
                .all(|n| h.iter().any(|c| c == n))
        })
    }
    fn read(&self, path: &Path, src: &str) -> Result<Measurement, SourceError> {
        Ok(Measurement::Points(PointSet {
            format: "csv",
            points: measured::parse_csv(path, src)?,
            labeled: true,
            nominals: Vec::new(),
            warnings: Vec::new(),
        }))
    }
}

impl Reader for Heights {
    fn name(&self) -> &'static str {
        "heights"
    }
    fn describe(&self) -> &'static str {
        "nine-section heights (header section,height_um)"
    }
    fn sniff(&self, src: &str) -> bool {
        heights::looks_like_heights(src)
    }
    fn read(&self, path: &Path, src: &str) -> Result<Measurement, SourceError> {
        Ok(Measurement::Heights(heights::parse(path, src)?))
    }
}

/// Splits a plain data line at commas, semicolons, tabs or spaces, with
/// the 1-based column of each field.
fn plain_fields(line: &str) -> Vec<(usize, &str)> {
    let mut out = Vec::new();
    let mut start = None;
    for (i, ch) in line.char_indices() {
        let sep = ch == ',' || ch == ';' || ch == '\t' || ch == ' ';
        match (sep, start) {
            (true, Some(s)) => {
                out.push((s + 1, &line[s..i]));
                start = None;
            }
            (false, None) => start = Some(i),
            _ => {}
        }
    }
    if let Some(s) = start {
        out.push((s + 1, &line[s..]));
    }
    out
}

impl Reader for Plain {
    fn name(&self) -> &'static str {
        "plain"
    }
    fn describe(&self) -> &'static str {
        "a plain point list (x y z per line, no labels)"
    }
    fn sniff(&self, src: &str) -> bool {
        let mut data = src
            .lines()
            .map(str::trim)
            .filter(|l| !l.is_empty() && !l.starts_with('#'));
        let Some(first) = data.next() else {
            return false;
        };
        let numeric = |l: &str| {
            let f = plain_fields(l);
            f.len() >= 3 && f.iter().take(3).all(|x| x.1.parse::<f64>().is_ok())
        };
        let header = {
            let f: Vec<String> = plain_fields(first)
                .iter()
                .map(|x| x.1.to_ascii_lowercase())
                .collect();
            f.len() >= 3 && f[..3] == ["x", "y", "z"]
        };
        (header || numeric(first)) && data.next().is_some_and(numeric)
    }
    fn read(&self, path: &Path, src: &str) -> Result<Measurement, SourceError> {
        let mut points = Vec::new();
        let mut first = true;
        for (i, raw) in src.lines().enumerate() {
            let line = i + 1;
            let t = raw.trim();
            if t.is_empty() || t.starts_with('#') {
                continue;
            }
            let f = plain_fields(raw);
            if first {
                first = false;
                if f.first().is_some_and(|x| x.1.eq_ignore_ascii_case("x")) {
                    continue;
                }
            }
            if f.len() < 3 {
                return Err(SourceError::new(
                    path,
                    line,
                    1,
                    format!("expected three numbers x y z, got {} fields", f.len()),
                ));
            }
            let num = |k: usize| {
                parse_finite(f[k].1).map_err(|m| SourceError::new(path, line, f[k].0, m))
            };
            points.push(MeasuredPoint {
                label: String::new(),
                p: Vector3::new(num(0)?, num(1)?, num(2)?),
                line,
            });
        }
        Ok(Measurement::Points(PointSet {
            format: "plain",
            points,
            labeled: false,
            nominals: Vec::new(),
            warnings: Vec::new(),
        }))
    }
}

/// Every reader, in the order they are tried.
pub fn readers() -> Vec<&'static dyn Reader> {
    vec![
        &Dmis, &Heights, &Canonical,
        // Issue 4: the probe-log readers of `src/formats/probe_log/`
        // (FANUC/Haas DPRNT, LinuxCNC PROBEOPEN, HEIDENHAIN FN 16) go here,
        // before the plain point list, which accepts any three numbers per
        // line. Each returns `Measurement::Points` with labels (contact
        // points in W at rotary zero, SPEC section 3).
        &Plain,
    ]
}

/// The reader that accepts `src`, if any.
pub fn detect(src: &str) -> Option<&'static dyn Reader> {
    readers().into_iter().find(|r| r.sniff(src))
}

/// Reads a measurement file in whatever format it is.
pub fn read_measurement(path: &Path) -> Result<Measurement, SourceError> {
    let src = std::fs::read_to_string(path)
        .map_err(|e| SourceError::new(path, 0, 0, format!("cannot read: {e}")))?;
    parse_measurement(path, &src)
}

/// Reads measurement text in whatever format it is.
pub fn parse_measurement(path: &Path, src: &str) -> Result<Measurement, SourceError> {
    match detect(src) {
        Some(r) => r.read(path, src),
        None => {
            let expected: Vec<&str> = readers().iter().map(|r| r.describe()).collect();
            Err(SourceError::new(
                path,
                0,
                0,
                format!(
                    "unrecognized measurement format: expected {}",
                    expected.join(", or ")
                ),
            ))
        }
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
            ("x;y;z\n1;2;3\n", "plain"),
        ];
        for (src, name) in cases {
            assert_eq!(detect(src).map(|r| r.name()), Some(name), "{src}");
        }
        let e = parse_measurement(Path::new("q.txt"), "hello\nworld\n")
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("q.txt: unrecognized measurement format: expected DMIS"),
            "{e}"
        );
    }
}
