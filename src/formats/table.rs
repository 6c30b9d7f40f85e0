//! Point tables with a header naming their columns: what CMM software,
//! scanners and spreadsheets export when nobody asked for a standard. The
//! columns come in any order, separated by commas, semicolons, tabs or
//! runs of spaces (found from the header line); quoted fields are read by
//! the csv crate. A semicolon- or tab-separated table may write decimal
//! commas (`12,5`), as European spreadsheets do.
//!
//! Columns are recognized by name, case-insensitively, with the names CMM
//! exports use: a label (`label`, `name`, `id`, `point`, `feature`), the
//! actual position (`x`/`y`/`z`, `x_act`, `actual_x`, `meas_x`, ...), the
//! nominal position (`x_nom`, `nominal_x`, `nom_x`, ...), and a direction
//! (`i`/`j`/`k`, `nx`/`ny`/`nz`). Every other column is ignored and named
//! in the inventory.

use std::path::Path;

use nalgebra::Vector3;

use super::inventory::{Entry, Inventory, MeasuredOptions, Unread};
use crate::source::SourceError;

/// The roles a column can have.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Role {
    Label,
    Actual(usize),
    Nominal(usize),
    Dir(usize),
}

fn role(name: &str) -> Option<Role> {
    let n: String = name
        .trim()
        .trim_matches('"')
        .to_ascii_lowercase()
        .chars()
        .filter(|c| !matches!(c, ' ' | '.' | '(' | ')' | '[' | ']'))
        .collect();
    let n = n.trim_end_matches("mm").trim_end_matches('_');
    let axis = |c: &str| match c {
        "x" => Some(0),
        "y" => Some(1),
        "z" => Some(2),
        _ => None,
    };
    if matches!(
        n,
        "label" | "name" | "id" | "point" | "feature" | "pointname" | "featurename"
    ) {
        return Some(Role::Label);
    }
    if let Some(a) = axis(n) {
        return Some(Role::Actual(a));
    }
    match n {
        "i" | "nx" => return Some(Role::Dir(0)),
        "j" | "ny" => return Some(Role::Dir(1)),
        "k" | "nz" => return Some(Role::Dir(2)),
        _ => {}
    }
    for (prefix, suffix, nominal) in [
        ("actual_", "", false),
        ("act_", "", false),
        ("meas_", "", false),
        ("measured_", "", false),
        ("", "_act", false),
        ("", "_actual", false),
        ("", "_meas", false),
        ("", "act", false),
        ("nominal_", "", true),
        ("nom_", "", true),
        ("", "_nom", true),
        ("", "_nominal", true),
        ("", "nom", true),
    ] {
        if let Some(c) = n.strip_prefix(prefix).and_then(|r| r.strip_suffix(suffix))
            && let Some(a) = axis(c)
        {
            return Some(if nominal {
                Role::Nominal(a)
            } else {
                Role::Actual(a)
            });
        }
    }
    None
}

/// The separator of a header line: the one of `\t`, `;`, `,` it has most
/// of, else whitespace (`None`).
fn separator(header: &str) -> Option<u8> {
    [b'\t', b';', b',']
        .into_iter()
        .map(|s| (s, header.bytes().filter(|&b| b == s).count()))
        .filter(|x| x.1 > 0)
        .max_by_key(|x| x.1)
        .map(|x| x.0)
}

/// The first line with content that is not a `#` comment: (0-based index,
/// text).
fn header_line(src: &str) -> Option<(usize, &str)> {
    src.lines()
        .enumerate()
        .find(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'))
}

/// Fields of a line with their 1-based byte columns.
fn fields(line: &str, sep: Option<u8>) -> Vec<(usize, String)> {
    match sep {
        None => {
            let mut out = Vec::new();
            let mut start = None;
            for (i, ch) in line.char_indices() {
                match (ch.is_whitespace(), start) {
                    (true, Some(s)) => {
                        out.push((s + 1, line[s..i].to_string()));
                        start = None;
                    }
                    (false, None) => start = Some(i),
                    _ => {}
                }
            }
            if let Some(s) = start {
                out.push((s + 1, line[s..].to_string()));
            }
            out
        }
        Some(sep) => {
            let mut r = csv::ReaderBuilder::new()
                .delimiter(sep)
                .has_headers(false)
                .flexible(true)
                .from_reader(line.as_bytes());
            let mut rec = csv::StringRecord::new();
            if !matches!(r.read_record(&mut rec), Ok(true)) {
                return Vec::new();
            }
            // Byte columns of the fields: the csv crate gives each field's
            // end in the unquoted record, close enough for the raw line
            // when nothing is quoted; quoted lines fall back to searching.
            let mut out = Vec::new();
            let mut from = 0;
            for f in rec.iter() {
                let at = line[from..].find(f).map_or(from, |i| from + i);
                out.push((at + 1, f.trim().to_string()));
                from = (at + f.len()).min(line.len());
            }
            out
        }
    }
}

/// Whether a text is a table with a header naming x, y and z columns (and
/// not the canonical `label,x,y,z`, which its own reader takes).
pub(crate) fn looks_like_table(src: &str) -> bool {
    let Some((_, h)) = header_line(src) else {
        return false;
    };
    let roles: Vec<Option<Role>> = fields(h, separator(h)).iter().map(|f| role(&f.1)).collect();
    (0..3).all(|a| {
        roles
            .iter()
            .any(|r| matches!(r, Some(Role::Actual(b)) if *b == a))
    })
}

/// A number, with a decimal comma where the separator allows it.
fn number(s: &str, sep: Option<u8>) -> Result<f64, String> {
    let t = s.trim();
    let owned;
    let t = if sep != Some(b',') && t.contains(',') && !t.contains('.') {
        owned = t.replace(',', ".");
        owned.as_str()
    } else {
        t
    };
    match t.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(format!("expected a finite number, got `{}`", s.trim())),
        Err(_) => Err(format!("expected a number, got `{}`", s.trim())),
    }
}

/// Reads a table with a header into an inventory.
pub(crate) fn parse(
    path: &Path,
    src: &str,
    options: &MeasuredOptions,
) -> Result<Inventory, SourceError> {
    let Some((hi, header)) = header_line(src) else {
        return Err(SourceError::new(
            path,
            0,
            0,
            "empty file: expected a header and points",
        ));
    };
    let sep = separator(header);
    let cols = fields(header, sep);
    let mut roles: Vec<Option<Role>> = Vec::new();
    for (col, name) in &cols {
        let r = role(name);
        if let Some(r) = r
            && roles.contains(&Some(r))
        {
            return Err(SourceError::new(
                path,
                hi + 1,
                *col,
                format!("column `{name}` repeats a column before it"),
            ));
        }
        roles.push(r);
    }
    let find = |r: Role| roles.iter().position(|x| *x == Some(r));
    let actual = [0, 1, 2].map(|a| find(Role::Actual(a)));
    let nominal = [0, 1, 2].map(|a| find(Role::Nominal(a)));
    let dir = [0, 1, 2].map(|a| find(Role::Dir(a)));
    let label = find(Role::Label);
    if actual.iter().any(Option::is_none) {
        return Err(SourceError::new(
            path,
            hi + 1,
            1,
            "expected a header naming x, y and z columns",
        ));
    }
    let mut inv = Inventory::new("table");
    let mm = options.unstated_unit_mm(&mut inv);
    let ignored: Vec<&str> = cols
        .iter()
        .zip(&roles)
        .filter(|(_, r)| r.is_none())
        .map(|(c, _)| c.1.as_str())
        .collect();
    if !ignored.is_empty() {
        inv.skipped.push(Unread {
            line: hi + 1,
            what: format!("columns {}", ignored.join(", ")),
            why: "not a label, position, nominal or direction".into(),
        });
    }
    let mut seen = std::collections::HashMap::new();
    for (i, raw) in src.lines().enumerate().skip(hi + 1) {
        let line = i + 1;
        let raw = raw.strip_suffix('\r').unwrap_or(raw);
        if raw.trim().is_empty() || raw.trim_start().starts_with('#') {
            continue;
        }
        let f = fields(raw, sep);
        let get = |k: usize| -> Result<(usize, &str), SourceError> {
            f.get(k).map(|x| (x.0, x.1.as_str())).ok_or_else(|| {
                SourceError::new(
                    path,
                    line,
                    raw.len() + 1,
                    format!(
                        "expected a value for column `{}`, the line has {} fields",
                        cols[k].1,
                        f.len()
                    ),
                )
            })
        };
        let num = |k: usize| -> Result<f64, SourceError> {
            let (c, s) = get(k)?;
            number(s, sep).map_err(|m| SourceError::new(path, line, c, m))
        };
        let v3 = |c: [Option<usize>; 3]| -> Result<Option<Vector3<f64>>, SourceError> {
            match c {
                [Some(a), Some(b), Some(d)] => Ok(Some(Vector3::new(num(a)?, num(b)?, num(d)?))),
                _ => Ok(None),
            }
        };
        let name = match label {
            Some(k) => get(k)?.1.trim_matches('"').to_string(),
            None => String::new(),
        };
        if !name.is_empty()
            && let Some(first) = seen.insert(name.clone(), line)
        {
            return Err(SourceError::new(
                path,
                line,
                get(label.unwrap_or(0))?.0,
                format!("label `{name}` appears twice (first at line {first})"),
            ));
        }
        let mut e = Entry::new(name, "point", line);
        e.actual = v3(actual)?.map(|v| v * mm);
        e.nominal = v3(nominal)?.map(|v| v * mm);
        if let Some(d) = v3(dir)? {
            let col = get(dir[0].unwrap_or(0))?.0;
            e.normal = Some(
                super::unit_direction(d, "the direction i,j,k")
                    .map_err(|m| SourceError::new(path, line, col, m))?,
            );
        }
        inv.entries.push(e);
    }
    if inv.entries.is_empty() {
        return Err(SourceError::new(path, hi + 1, 1, "a header but no points"));
    }
    let labelled = inv.entries.iter().filter(|e| !e.label.is_empty()).count();
    if labelled > 0 && labelled < inv.entries.len() {
        let e = inv
            .entries
            .iter()
            .find(|e| e.label.is_empty())
            .expect("some");
        return Err(SourceError::new(
            path,
            e.line,
            1,
            "a point without a label in a table whose other points have one",
        ));
    }
    Ok(inv)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn columns_by_name_in_any_order_and_separator() {
        let src = "Name;Z;Y;X;X_nom;Y_nom;Z_nom;Dev\nP1;3,5;2;1;1;2;3,4;0,1\n";
        assert!(looks_like_table(src));
        let inv = parse(Path::new("t.csv"), src, &MeasuredOptions::default()).unwrap();
        let e = &inv.entries[0];
        assert_eq!(e.label, "P1");
        assert_eq!(e.actual, Some(Vector3::new(1.0, 2.0, 3.5)));
        assert_eq!(e.nominal, Some(Vector3::new(1.0, 2.0, 3.4)));
        assert_eq!(inv.skipped[0].what, "columns Dev");
        let e = parse(
            Path::new("t.csv"),
            "x\ty\tz\n1\t2\tq\n",
            &MeasuredOptions::default(),
        )
        .unwrap_err()
        .to_string();
        assert_eq!(e, "t.csv:2:5: expected a number, got `q`");
    }
}
