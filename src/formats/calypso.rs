//! ZEISS CALYPSO table files: at the end of a run CALYPSO writes three
//! tab-separated tables beside each other, `<run>_hdr.txt` (the run: plan,
//! part number, date, CMM), `<run>_fet.txt` (the features: actual and
//! nominal position and direction) and `<run>_chr.txt` (the
//! characteristics: a measured value against its nominal and tolerances).
//!
//! The column set differs between installations (a `unit` column or not,
//! customer columns), so every column is found by its name in the header
//! line, case-insensitively, never by position. The `type` column is in the
//! operator's language (`Durchmesser`, `Rundheit`); the feature or
//! characteristic kind is taken from `idsymbol`, which is not. Rows may be
//! shorter than the header (empty trailing fields are left out), the
//! header ends in a tab, the `_chr` table ends with a line `END`, and lines
//! end in CRLF or LF.
//!
//! What is read:
//! - `_fet`: each feature by `id`, its kind (`idsymbol`; `spacePoint` and
//!   `point` are points `analyze` joins), its actual position `x y z` and
//!   direction `nx ny nz` (or `i j k`), its nominal position `x_nom y_nom
//!   z_nom` and direction `nx_nom ny_nom nz_nom` (or `i_nom j_nom k_nom`);
//!   the direction is the measured one where given, else the nominal's;
//! - `_chr`: each characteristic by `id` with its `actual` value, reported
//!   as the file states it; a feature (`featureid`) with `xValue`, `yValue`
//!   and `zValue` characteristics is also read as a point at those
//!   coordinates (their `nominal` values as its nominal point);
//! - `_hdr`: the run's name; it holds no measurement.
//!
//! Lengths are in the table's `unit` column (`mm` or `inch`); a table
//! without one is read in mm (CALYPSO's default), with a warning, unless
//! the user names the unit. Rows with another `planid` or `partnb` are
//! another measurement run (one piece each). Ignored: tolerances, the
//! localized `type`, `featurePosX/Y/Z` (where the characteristic is shown,
//! not a measured point), groups, datums, comments and every other column.

use std::collections::HashMap;
use std::path::Path;

use nalgebra::Vector3;

use super::inventory::{Entry, Inventory, LengthUnit, MeasuredOptions, Unread};
use crate::source::SourceError;

/// Which of the three tables a file is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum CalypsoTable {
    /// `_chr.txt`: characteristics.
    Characteristics,
    /// `_fet.txt`: features.
    Features,
    /// `_hdr.txt`: the run header.
    Header,
}

impl CalypsoTable {
    /// The file name suffix CALYPSO gives the table.
    pub(crate) fn suffix(self) -> &'static str {
        match self {
            CalypsoTable::Characteristics => "_chr",
            CalypsoTable::Features => "_fet",
            CalypsoTable::Header => "_hdr",
        }
    }
}

/// The header line: its 1-based line number and its column names
/// (lower-case) with their 1-based byte columns.
struct Header {
    line: usize,
    names: Vec<(usize, String)>,
}

impl Header {
    fn find(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|(_, n)| n == name)
    }

    /// The first of several accepted names.
    fn find_any(&self, names: &[&str]) -> Option<usize> {
        names.iter().find_map(|n| self.find(n))
    }

    /// Three columns, all or none.
    fn triple(&self, names: [&[&str]; 3]) -> Option<[usize; 3]> {
        Some([
            self.find_any(names[0])?,
            self.find_any(names[1])?,
            self.find_any(names[2])?,
        ])
    }

    fn table(&self) -> Option<CalypsoTable> {
        let has = |n: &str| self.find(n).is_some();
        if has("id") && has("idsymbol") && has("actual") {
            Some(CalypsoTable::Characteristics)
        } else if has("id") && has("x") && has("y") && has("z") {
            Some(CalypsoTable::Features)
        } else if has("planid") && has("partnb") {
            Some(CalypsoTable::Header)
        } else {
            None
        }
    }
}

/// Tab-separated fields of a line with their 1-based byte columns.
fn split(line: &str) -> Vec<(usize, &str)> {
    let mut out = Vec::new();
    let mut start = 0;
    for part in line.split('\t') {
        out.push((start + 1, part));
        start += part.len() + 1;
    }
    out
}

/// The first line with content: (0-based index, text without CR).
fn first_line(src: &str) -> Option<(usize, &str)> {
    src.lines()
        .map(|l| l.strip_suffix('\r').unwrap_or(l))
        .enumerate()
        .find(|(_, l)| !l.trim().is_empty())
}

fn header(src: &str) -> Option<Header> {
    let (i, line) = first_line(src)?;
    if !line.contains('\t') {
        return None;
    }
    let names = split(line.trim_start_matches('\u{feff}'))
        .into_iter()
        .map(|(c, n)| (c, n.trim().to_ascii_lowercase()))
        .collect();
    Some(Header { line: i + 1, names })
}

/// Whether a text is a CALYPSO table, and which.
pub(crate) fn sniff(src: &str) -> Option<CalypsoTable> {
    let h = header(src)?;
    // `planid`/`partnb` or `idsymbol` mark CALYPSO; a plain table naming
    // x, y, z is the table reader's.
    if h.find("planid").is_none() && h.find("idsymbol").is_none() {
        return None;
    }
    h.table()
}

/// One data row.
struct Row<'a> {
    line: usize,
    fields: Vec<(usize, &'a str)>,
}

impl<'a> Row<'a> {
    /// The trimmed field of column `k`, `None` when empty or past the end
    /// of a short row.
    fn get(&self, k: Option<usize>) -> Option<(usize, &'a str)> {
        let (c, s) = *self.fields.get(k?)?;
        let s = s.trim();
        (!s.is_empty()).then_some((c, s))
    }
}

struct Reader<'a> {
    path: &'a Path,
    header: Header,
}

impl Reader<'_> {
    fn err(&self, line: usize, col: usize, msg: impl Into<String>) -> SourceError {
        SourceError::new(self.path, line, col, msg)
    }

    /// The name in column `id` of the row of a `what` (feature,
    /// characteristic), with its column.
    fn name<'a>(
        &self,
        row: &Row<'a>,
        id: Option<usize>,
        what: &str,
    ) -> Result<(usize, &'a str), SourceError> {
        row.get(id).ok_or_else(|| {
            self.err(
                row.line,
                row.fields.first().map_or(1, |f| f.0),
                format!("expected the {what}'s name in column `id`"),
            )
        })
    }

    /// A number in column `k` of a row (`None` when empty).
    fn number(&self, row: &Row<'_>, k: Option<usize>) -> Result<Option<f64>, SourceError> {
        let Some((c, s)) = row.get(k) else {
            return Ok(None);
        };
        let name = &self.header.names[k.expect("field found")].1;
        match s.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(Some(v)),
            Ok(_) => Err(self.err(
                row.line,
                c,
                format!("column `{name}`: expected a finite number, got `{s}`"),
            )),
            Err(_) => Err(self.err(
                row.line,
                c,
                format!("column `{name}`: expected a number with a decimal point, got `{s}`"),
            )),
        }
    }

    /// Three numbers, all or none.
    fn vector(
        &self,
        row: &Row<'_>,
        cols: Option<[usize; 3]>,
    ) -> Result<Option<Vector3<f64>>, SourceError> {
        let Some(cols) = cols else {
            return Ok(None);
        };
        let v = [
            self.number(row, Some(cols[0]))?,
            self.number(row, Some(cols[1]))?,
            self.number(row, Some(cols[2]))?,
        ];
        match v {
            [Some(a), Some(b), Some(c)] => Ok(Some(Vector3::new(a, b, c))),
            [None, None, None] => Ok(None),
            _ => {
                let k = v.iter().position(Option::is_none).expect("one is missing");
                let names: Vec<&str> = cols
                    .iter()
                    .map(|&c| self.header.names[c].1.as_str())
                    .collect();
                Err(self.err(
                    row.line,
                    row.fields
                        .get(cols[k])
                        .map_or(row.fields.last().map_or(1, |f| f.0), |f| f.0),
                    format!(
                        "expected all of {} or none, `{}` is empty",
                        names.join(", "),
                        names[k]
                    ),
                ))
            }
        }
    }

    /// A unit direction from three columns (renormalized), all or none.
    fn direction(
        &self,
        row: &Row<'_>,
        cols: Option<[usize; 3]>,
    ) -> Result<Option<Vector3<f64>>, SourceError> {
        match self.vector(row, cols)? {
            Some(v) => super::unit_direction(v, "the direction")
                .map(Some)
                .map_err(|m| self.err(row.line, row.get(cols.map(|c| c[0])).map_or(1, |f| f.0), m)),
            None => Ok(None),
        }
    }
}

/// The data rows: after the header, up to an `END` line, blank lines left
/// out; a row longer than the header is an error unless its extra fields
/// are empty (a trailing tab).
fn rows<'a>(r: &Reader<'_>, src: &'a str) -> Result<Vec<Row<'a>>, SourceError> {
    let width = r.header.names.len();
    let mut out = Vec::new();
    let mut end: Option<usize> = None;
    for (i, raw) in src.lines().enumerate().skip(r.header.line) {
        let line = i + 1;
        let raw = raw.strip_suffix('\r').unwrap_or(raw);
        if raw.trim().is_empty() {
            continue;
        }
        if let Some(e) = end {
            return Err(r.err(
                line,
                1,
                format!("expected nothing after the `END` line at line {e}"),
            ));
        }
        if raw.trim() == "END" {
            end = Some(line);
            continue;
        }
        let fields = split(raw);
        if let Some((c, s)) = fields.iter().skip(width).find(|f| !f.1.trim().is_empty()) {
            return Err(r.err(
                line,
                *c,
                format!(
                    "expected at most {width} fields (the header's columns), got `{}` beyond them",
                    s.trim()
                ),
            ));
        }
        out.push(Row { line, fields });
    }
    Ok(out)
}

/// The table's length unit from its `unit` column (rows with other units,
/// degrees, are left out), else the user's, else mm with a warning.
fn length_unit(
    r: &Reader<'_>,
    rows: &[Row<'_>],
    options: &MeasuredOptions,
    inv: &mut Inventory,
) -> Result<LengthUnit, SourceError> {
    let col = r.header.find("unit");
    let mut found: Option<(LengthUnit, usize, String)> = None;
    for row in rows {
        let Some((c, s)) = row.get(col) else {
            continue;
        };
        let Some(u) = LengthUnit::parse(s) else {
            continue;
        };
        match &found {
            None => found = Some((u, row.line, s.to_string())),
            Some((f, l, name)) if *f != u => {
                return Err(r.err(
                    row.line,
                    c,
                    format!(
                        "unit `{s}` here but `{name}` at line {l}: expected one length unit in a table"
                    ),
                ));
            }
            Some(_) => {}
        }
    }
    Ok(match (found, options.units) {
        (Some((u, _, _)), _) => {
            inv.units = u.name().into();
            u
        }
        (None, Some(u)) => {
            inv.units = format!("{} (given with --units; the file states none)", u.name());
            u
        }
        (None, None) => {
            inv.units = "mm (not stated)".into();
            inv.warnings.push(
                "the table has no `unit` column: its lengths are read as mm, CALYPSO's default (give --units inch for an inch program)".into(),
            );
            LengthUnit::Mm
        }
    })
}

/// The measurement runs: one per (`planid`, `partnb`) pair, in file order;
/// the run index of each row.
fn runs(r: &Reader<'_>, rows: &[Row<'_>], inv: &mut Inventory) -> Vec<usize> {
    let plan = r.header.find("planid");
    let part = r.header.find("partnb");
    let mut names: Vec<String> = Vec::new();
    let mut of = Vec::with_capacity(rows.len());
    for row in rows {
        let p = row.get(plan).map_or("", |f| f.1);
        let n = row.get(part).map_or("", |f| f.1);
        let name = match (p.is_empty(), n.is_empty()) {
            (true, true) => String::new(),
            (false, true) => p.to_string(),
            (true, false) => format!("part {n}"),
            (false, false) => format!("{p} part {n}"),
        };
        let i = match names.iter().position(|x| *x == name) {
            Some(i) => i,
            None => {
                names.push(name);
                names.len() - 1
            }
        };
        of.push(i);
    }
    if !names.is_empty() {
        inv.runs = names;
    }
    of
}

/// The columns of the header no reader role uses, for the inventory.
fn ignored(r: &Reader<'_>, used: &[Option<usize>], inv: &mut Inventory) {
    let names: Vec<&str> = r
        .header
        .names
        .iter()
        .enumerate()
        .filter(|(k, (_, n))| !n.is_empty() && !used.contains(&Some(*k)))
        .map(|(_, (_, n))| n.as_str())
        .collect();
    if !names.is_empty() {
        inv.skipped.push(Unread {
            line: r.header.line,
            what: format!("columns {}", names.join(", ")),
            why: "not read (tolerances, groups, display positions, the localized type, ...)".into(),
        });
    }
}

/// Why a `_hdr` table gives no points.
pub(crate) const HEADER_HOLDS_NO_MEASUREMENT: &str = "a CALYPSO run header (_hdr) holds no measurement: the features and their positions are in the run's _fet table, the characteristics in its _chr table";

/// Reads a CALYPSO table (any of the three) into an inventory.
pub(crate) fn parse(
    path: &Path,
    src: &str,
    options: &MeasuredOptions,
) -> Result<Inventory, SourceError> {
    let Some(h) = header(src) else {
        return Err(SourceError::new(
            path,
            0,
            0,
            "empty file: expected a CALYPSO table (a tab-separated header line and rows)",
        ));
    };
    let r = Reader { path, header: h };
    let mut seen = HashMap::new();
    for (c, n) in &r.header.names {
        if n.is_empty() {
            continue;
        }
        if let Some(first) = seen.insert(n.clone(), *c) {
            return Err(r.err(
                r.header.line,
                *c,
                format!("column `{n}` repeats the column at column {first}"),
            ));
        }
    }
    let Some(table) = r.header.table() else {
        return Err(r.err(
            r.header.line,
            1,
            "expected a CALYPSO table header: `id`, `idsymbol` and `actual` (_chr), `id`, `x`, `y`, `z` (_fet) or `planid`, `partnb` (_hdr)",
        ));
    };
    let rows = rows(&r, src)?;
    let mut inv = Inventory::new("calypso");
    inv.version = Some(table.suffix().trim_start_matches('_').to_string());
    let run_of = runs(&r, &rows, &mut inv);
    match table {
        CalypsoTable::Header => {
            inv.skipped.push(Unread {
                line: r.header.line,
                what: "the run header (plan, part, date, operator, CMM, temperatures)".into(),
                why: HEADER_HOLDS_NO_MEASUREMENT.into(),
            });
            return Ok(inv);
        }
        CalypsoTable::Features => {
            let unit = length_unit(&r, &rows, options, &mut inv)?;
            features(&r, &rows, &run_of, unit.mm(), &mut inv)?;
        }
        CalypsoTable::Characteristics => {
            let unit = length_unit(&r, &rows, options, &mut inv)?;
            characteristics(&r, &rows, &run_of, unit.mm(), &mut inv)?;
        }
    }
    if rows.is_empty() {
        inv.warnings.push(format!(
            "the {} table has a header but no rows",
            table.suffix()
        ));
    }
    Ok(inv)
}

/// The `idsymbol` values of point features.
fn is_point_symbol(s: &str) -> bool {
    matches!(s.to_ascii_lowercase().as_str(), "spacepoint" | "point")
}

fn features(
    r: &Reader<'_>,
    rows: &[Row<'_>],
    run_of: &[usize],
    mm: f64,
    inv: &mut Inventory,
) -> Result<(), SourceError> {
    let h = &r.header;
    let id = h.find("id");
    let symbol = h.find("idsymbol");
    let actual = h.triple([&["x"], &["y"], &["z"]]);
    let dir = h.triple([&["nx", "i"], &["ny", "j"], &["nz", "k"]]);
    let nominal = h.triple([
        &["x_nom", "xnom", "nomx", "x_nominal"],
        &["y_nom", "ynom", "nomy", "y_nominal"],
        &["z_nom", "znom", "nomz", "z_nominal"],
    ]);
    let nominal_dir = h.triple([
        &["nx_nom", "i_nom", "nomi"],
        &["ny_nom", "j_nom", "nomj"],
        &["nz_nom", "k_nom", "nomk"],
    ]);
    let mut used = vec![
        id,
        symbol,
        h.find("planid"),
        h.find("partnb"),
        h.find("unit"),
    ];
    for t in [actual, dir, nominal, nominal_dir].into_iter().flatten() {
        used.extend(t.map(Some));
    }
    ignored(r, &used, inv);
    let mut labels: HashMap<(usize, String), usize> = HashMap::new();
    for (row, &run) in rows.iter().zip(run_of) {
        let (c, label) = r.name(row, id, "feature")?;
        if let Some(first) = labels.insert((run, label.to_string()), row.line) {
            return Err(r.err(
                row.line,
                c,
                format!("feature `{label}` appears twice in one run (first at line {first})"),
            ));
        }
        let sym = row.get(symbol).map_or("feature", |f| f.1);
        let kind = if is_point_symbol(sym) {
            "point".to_string()
        } else {
            sym.to_string()
        };
        let mut e = Entry::new(label, kind, row.line);
        e.run = run;
        e.actual = r.vector(row, actual)?.map(|v| v * mm);
        e.nominal = r.vector(row, nominal)?.map(|v| v * mm);
        let measured_dir = r.direction(row, dir)?;
        let nominal_dir = r.direction(row, nominal_dir)?;
        e.normal = measured_dir.or(nominal_dir);
        if e.actual.is_none() {
            inv.skipped.push(Unread {
                line: row.line,
                what: format!("feature `{label}`"),
                why: "no actual position (x, y, z empty): not measured".into(),
            });
        }
        inv.entries.push(e);
    }
    Ok(())
}

/// The axis of a coordinate characteristic (`xValue`, `yValue`, `zValue`).
fn coordinate_axis(symbol: &str) -> Option<usize> {
    match symbol.to_ascii_lowercase().as_str() {
        "xvalue" => Some(0),
        "yvalue" => Some(1),
        "zvalue" => Some(2),
        _ => None,
    }
}

/// The coordinate characteristics of one feature: per axis (actual,
/// nominal, line).
type Coordinates = [Option<(f64, Option<f64>, usize)>; 3];

fn characteristics(
    r: &Reader<'_>,
    rows: &[Row<'_>],
    run_of: &[usize],
    mm: f64,
    inv: &mut Inventory,
) -> Result<(), SourceError> {
    let h = &r.header;
    let id = h.find("id");
    let symbol = h.find("idsymbol");
    let actual = h.find("actual");
    let nominal = h.find("nominal");
    let feature = h.find("featureid");
    ignored(
        r,
        &[
            id,
            symbol,
            actual,
            nominal,
            feature,
            h.find("planid"),
            h.find("partnb"),
            h.find("unit"),
        ],
        inv,
    );
    // Features with coordinate characteristics, in order of first mention.
    let mut coords: Vec<((usize, String), Coordinates)> = Vec::new();
    let mut ambiguous: Vec<(usize, String)> = Vec::new();
    for (row, &run) in rows.iter().zip(run_of) {
        let (_, label) = r.name(row, id, "characteristic")?;
        let Some((_, sym)) = row.get(symbol) else {
            return Err(r.err(
                row.line,
                row.fields.get(symbol.unwrap_or(0)).map_or(1, |f| f.0),
                format!("characteristic `{label}`: expected its kind in column `idsymbol`"),
            ));
        };
        let value = r.number(row, actual)?;
        let nom = r.number(row, nominal)?;
        let mut e = Entry::new(label, sym, row.line);
        e.run = run;
        e.value = value;
        inv.entries.push(e);
        let Some(v) = value else {
            inv.skipped.push(Unread {
                line: row.line,
                what: format!("characteristic `{label}`"),
                why: "no actual value: not measured".into(),
            });
            continue;
        };
        if let (Some(axis), Some((_, f))) = (coordinate_axis(sym), row.get(feature)) {
            let key = (run, f.to_string());
            let k = match coords.iter().position(|c| c.0 == key) {
                Some(k) => k,
                None => {
                    coords.push((key.clone(), [None; 3]));
                    coords.len() - 1
                }
            };
            if let Some((_, _, first)) = coords[k].1[axis] {
                if !ambiguous.contains(&key) {
                    inv.skipped.push(Unread {
                        line: row.line,
                        what: format!("the position of feature `{f}`"),
                        why: format!(
                            "two `{sym}` characteristics (lines {first} and {}): which one is its position is not known",
                            row.line
                        ),
                    });
                    ambiguous.push(key);
                }
            } else {
                coords[k].1[axis] = Some((v, nom, row.line));
            }
        }
    }
    for ((run, label), c) in coords {
        if ambiguous.contains(&(run, label.clone())) {
            continue;
        }
        let [Some(x), Some(y), Some(z)] = c else {
            continue;
        };
        let mut e = Entry::new(label, "point", x.2.min(y.2).min(z.2));
        e.run = run;
        e.actual = Some(Vector3::new(x.0, y.0, z.0) * mm);
        if let (Some(a), Some(b), Some(d)) = (x.1, y.1, z.1) {
            e.nominal = Some(Vector3::new(a, b, d) * mm);
        }
        inv.entries.push(e);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const CHR: &str = "planid\tpartnb\tid\ttype\tidsymbol\tactual\tnominal\tuppertol\tlowertol\tfeatureid\t\r\n\
        PLAN\t7\tP1_X\tX-Wert\txValue\t10.0010000\t10.0000000\t0.01\t-0.01\tP1\r\n\
        PLAN\t7\tP1_Y\tY-Wert\tyValue\t-4.9990000\t-5.0000000\t0.01\t-0.01\tP1\r\n\
        PLAN\t7\tD1\tDurchmesser\tdiameter\t23.4009393\t23.4\r\n\
        PLAN\t7\tP1_Z\tZ-Wert\tzValue\t2.5000000\t2.5000000\t0.01\t-0.01\tP1\r\n\
        END\r\n";

    #[test]
    fn characteristics_by_name_with_coordinate_triples_as_points() {
        assert_eq!(sniff(CHR), Some(CalypsoTable::Characteristics));
        let inv = parse(Path::new("r_chr.txt"), CHR, &MeasuredOptions::default()).unwrap();
        assert_eq!(inv.runs, ["PLAN part 7"]);
        assert_eq!(inv.entries.len(), 5);
        // A row shorter than the header still reads.
        assert_eq!(inv.entries[2].kind, "diameter");
        assert_eq!(inv.entries[2].value, Some(23.4009393));
        let p = &inv.entries[4];
        assert_eq!(
            (p.label.as_str(), p.kind.as_str(), p.line),
            ("P1", "point", 2)
        );
        assert_eq!(p.actual, Some(Vector3::new(10.001, -4.999, 2.5)));
        assert_eq!(p.nominal, Some(Vector3::new(10.0, -5.0, 2.5)));
        assert!(inv.warnings[0].contains("no `unit` column"));
    }

    #[test]
    fn malformed_tables_name_line_column_and_what_was_expected() {
        let bad = CHR.replace("-4.9990000", "-4,999");
        let e = parse(Path::new("r_chr.txt"), &bad, &MeasuredOptions::default())
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "r_chr.txt:3:27: column `actual`: expected a number with a decimal point, got `-4,999`"
        );
        let after = format!("{CHR}PLAN\t7\tX\n");
        let e = parse(Path::new("r_chr.txt"), &after, &MeasuredOptions::default())
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "r_chr.txt:7:1: expected nothing after the `END` line at line 6"
        );
        let long = CHR.replace("23.4\r\n", "23.4\t\t\t\t\t\t\t\t\textra\r\n");
        let e = parse(Path::new("r_chr.txt"), &long, &MeasuredOptions::default())
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("r_chr.txt:4:"), "{e}");
        assert!(e.contains("expected at most 11 fields"), "{e}");
    }
}
