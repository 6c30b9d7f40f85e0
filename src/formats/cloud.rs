//! Point clouds without labels: one point per line, `x y z` or `x y z i j
//! k` (a direction: the probing direction or the measured surface normal),
//! separated by spaces, tabs, commas or semicolons, `#` comments and blank
//! lines allowed; what many CMM and scanner exports are when nobody asked
//! for a format. A table whose first line names its columns is the table
//! reader's ([`super::table`]).
//!
//! The points carry no labels: `analyze` joins each to its nearest nominal
//! point once the piece is placed, and a point whose direction disagrees
//! with the normal of the plan point it lands on is refused there
//! ([`crate::identify::data`]). A point without a direction takes its plan
//! point's nominal normal. Every line has the layout of the first: three
//! numbers, or six with a direction; other counts (a LinuxCNC `PROBEOPEN`
//! line holds nine: x y z and the axes) are read as x y z with the rest
//! ignored, and said. Lengths are in mm unless the user names the unit.

use std::path::Path;

use nalgebra::Vector3;

use super::inventory::{Entry, Inventory, MeasuredOptions};
use super::parse_finite;
use crate::source::SourceError;

/// Splits a line at commas, semicolons, tabs or spaces, with the 1-based
/// column of each field.
pub(crate) fn fields(line: &str) -> Vec<(usize, &str)> {
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

/// Whether a text is a point cloud: its first two data lines start with
/// three numbers.
pub(crate) fn looks_like_cloud(src: &str) -> bool {
    let mut data = src
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'));
    let numeric = |l: &str| {
        let f = fields(l);
        f.len() >= 3 && f.iter().take(3).all(|x| x.1.parse::<f64>().is_ok())
    };
    data.next().is_some_and(numeric) && data.next().is_some_and(numeric)
}

/// Reads a point cloud into an inventory (lengths in mm).
pub(crate) fn parse(
    path: &Path,
    src: &str,
    options: &MeasuredOptions,
) -> Result<Inventory, SourceError> {
    let mut inv = Inventory::new("plain");
    let mm = options.unstated_unit_mm(&mut inv);
    // (fields per line, line that set it)
    let mut layout: Option<(usize, usize)> = None;
    for (i, raw) in src.lines().enumerate() {
        let line = i + 1;
        let t = raw.trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        let f = fields(raw);
        if f.len() < 3 {
            return Err(SourceError::new(
                path,
                line,
                f.last().map_or(1, |x| x.0),
                format!("expected three numbers x y z, got {} fields", f.len()),
            ));
        }
        match layout {
            None => layout = Some((f.len(), line)),
            Some((n, first)) if (n == 6) != (f.len() == 6) => {
                let what = if n == 6 {
                    "six numbers x y z i j k"
                } else {
                    "x y z without a direction"
                };
                return Err(SourceError::new(
                    path,
                    line,
                    f.last().map_or(1, |x| x.0),
                    format!(
                        "expected {what} as on line {first}, got {} numbers",
                        f.len()
                    ),
                ));
            }
            Some(_) => {}
        }
        let num =
            |k: usize| parse_finite(f[k].1).map_err(|m| SourceError::new(path, line, f[k].0, m));
        let mut e = Entry::new("", "point", line);
        e.actual = Some(Vector3::new(num(0)?, num(1)?, num(2)?) * mm);
        if f.len() == 6 {
            let d = Vector3::new(num(3)?, num(4)?, num(5)?);
            e.normal = Some(
                super::unit_direction(d, "the direction i j k")
                    .map_err(|m| SourceError::new(path, line, f[3].0, m))?,
            );
        }
        inv.entries.push(e);
    }
    if let Some((n, first)) = layout
        && n != 3
        && n != 6
    {
        inv.warnings.push(format!(
            "{n} numbers per line (line {first}): read as x y z, the other {} ignored (a direction is the 4th to 6th of exactly six)",
            n - 3
        ));
    }
    Ok(inv)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn directions_are_read_renormalized_and_every_line_keeps_the_layout() {
        let src = "# x y z i j k\n1 2 3 0 0 1.0001\n4;5;6;0.6;0.8;0\n";
        assert!(looks_like_cloud(src));
        let inv = parse(Path::new("c.txt"), src, &MeasuredOptions::default()).unwrap();
        assert_eq!(inv.entries[0].normal, Some(Vector3::new(0.0, 0.0, 1.0)));
        assert_eq!(inv.entries[1].actual, Some(Vector3::new(4.0, 5.0, 6.0)));
        let e = parse(
            Path::new("c.txt"),
            "1 2 3 0 0 1\n4 5 6\n",
            &MeasuredOptions::default(),
        )
        .unwrap_err()
        .to_string();
        assert_eq!(
            e,
            "c.txt:2:5: expected six numbers x y z i j k as on line 1, got 3 numbers"
        );
        let e = parse(
            Path::new("c.txt"),
            "1 2 3 0 0 0\n",
            &MeasuredOptions::default(),
        )
        .unwrap_err()
        .to_string();
        assert_eq!(e, "c.txt:1:7: the direction i j k must not be zero");
        // Not a rounded unit vector: refused, not stretched into one.
        let e = parse(
            Path::new("c.txt"),
            "1 2 3 0 0 2\n",
            &MeasuredOptions::default(),
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.starts_with("c.txt:1:7: the direction i j k has length 2.000000"),
            "{e}"
        );
    }
}
