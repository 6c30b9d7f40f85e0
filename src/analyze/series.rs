//! Results side by side. A series: several pieces of the same plan
//! machined one after the other (as in Ibaraki & Ota 2014), with, for
//! every location symbol, its value on each piece, its
//! change from the first piece with the combined standard uncertainty, and
//! the straight-line trend per piece (weighted least squares) that shows a
//! thermal drift. A comparison: an earlier result (a cold probing run, the
//! machine before compensation) beside the new ones, with the change of
//! each from it.

use indexmap::IndexMap;

use crate::errorfile::ErrorFile;

/// A value with its standard uncertainty, if known.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct SeriesValue {
    /// The value.
    pub value: f64,
    /// Standard uncertainty (k = 1).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub u: Option<f64>,
}

/// One symbol across the series.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct SymbolSeries {
    /// Values per piece (`None` where that piece does not identify it).
    pub values: Vec<Option<SeriesValue>>,
    /// Change from the first piece.
    pub change: Vec<Option<SeriesValue>>,
    /// Slope of a straight line through the values, per piece, when at
    /// least three pieces identify the symbol.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub trend_per_piece: Option<SeriesValue>,
}

/// A series of results.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Series {
    /// Piece names, in order.
    pub pieces: Vec<String>,
    /// Location symbols.
    pub location_errors: IndexMap<String, SymbolSeries>,
}

fn combine(a: Option<f64>, b: Option<f64>) -> Option<f64> {
    Some((a?.powi(2) + b?.powi(2)).sqrt())
}

impl Series {
    /// Builds the series from results in order.
    pub fn new(pieces: &[(String, ErrorFile)]) -> Series {
        let mut symbols: Vec<String> = Vec::new();
        for (_, f) in pieces {
            for k in f.location_errors.keys() {
                if !symbols.contains(k) {
                    symbols.push(k.clone());
                }
            }
        }
        let mut out = IndexMap::new();
        for s in symbols {
            let values: Vec<Option<SeriesValue>> = pieces
                .iter()
                .map(|(_, f)| {
                    f.location_errors.get(&s).map(|q| SeriesValue {
                        value: q.value,
                        u: q.u,
                    })
                })
                .collect();
            let first = values[0];
            let change = values
                .iter()
                .map(|v| {
                    let (v, f) = ((*v)?, first?);
                    Some(SeriesValue {
                        value: v.value - f.value,
                        u: combine(v.u, f.u),
                    })
                })
                .collect();
            out.insert(
                s,
                SymbolSeries {
                    trend_per_piece: trend(&values),
                    values,
                    change,
                },
            );
        }
        Series {
            pieces: pieces.iter().map(|p| p.0.clone()).collect(),
            location_errors: out,
        }
    }

    /// Text table: one row per symbol, value (u) per piece, then the trend
    /// where any symbol has one (a trend needs three pieces, so a series of
    /// two has no trend column rather than an empty one).
    pub fn render(&self) -> String {
        use std::fmt::Write as _;
        let trends = self
            .location_errors
            .values()
            .any(|ser| ser.trend_per_piece.is_some());
        let mut s = format!("{:<10}", "symbol");
        for p in &self.pieces {
            let _ = write!(s, " {:>22}", p);
        }
        if trends {
            s.push_str("   trend/piece");
        }
        s.push('\n');
        for (name, ser) in &self.location_errors {
            let _ = write!(s, "{name:<10}");
            for v in &ser.values {
                let _ = write!(s, " {:>22}", cell(v, false));
            }
            if trends {
                let _ = write!(s, "   {}", cell(&ser.trend_per_piece, true));
            }
            s.push('\n');
        }
        s
    }
}

/// Weighted straight line through (piece index, value): slope and its
/// standard uncertainty.
fn trend(values: &[Option<SeriesValue>]) -> Option<SeriesValue> {
    let pts: Vec<(f64, f64, f64)> = values
        .iter()
        .enumerate()
        .filter_map(|(i, v)| {
            let v = (*v)?;
            let w = v.u.filter(|u| *u > 0.0).map_or(1.0, |u| 1.0 / (u * u));
            Some((i as f64, v.value, w))
        })
        .collect();
    if pts.len() < 3 {
        return None;
    }
    let sw: f64 = pts.iter().map(|p| p.2).sum();
    let xm = pts.iter().map(|p| p.0 * p.2).sum::<f64>() / sw;
    let ym = pts.iter().map(|p| p.1 * p.2).sum::<f64>() / sw;
    let sxx: f64 = pts.iter().map(|p| p.2 * (p.0 - xm).powi(2)).sum();
    let sxy: f64 = pts.iter().map(|p| p.2 * (p.0 - xm) * (p.1 - ym)).sum();
    let slope = sxy / sxx;
    let weighted = values
        .iter()
        .flatten()
        .all(|v| v.u.is_some_and(|u| u > 0.0));
    Some(SeriesValue {
        value: slope,
        u: weighted.then(|| (1.0 / sxx).sqrt()),
    })
}

/// An earlier result beside new ones.
#[derive(Clone, Debug, PartialEq)]
pub struct EarlierComparison {
    /// The earlier result first, then the new ones; `change` is from the
    /// earlier one.
    pub table: Series,
}

impl EarlierComparison {
    /// Sets `results` beside `earlier`.
    pub fn new(earlier: (String, ErrorFile), results: &[(String, ErrorFile)]) -> EarlierComparison {
        let mut rows = vec![earlier];
        rows.extend(results.iter().cloned());
        EarlierComparison {
            table: Series::new(&rows),
        }
    }

    /// Text table: one row per symbol, the value (u) of the earlier result
    /// and of each new one, then each new one's change from the earlier
    /// result with the combined u (`-` where either does not identify the
    /// symbol).
    pub fn render(&self) -> String {
        use std::fmt::Write as _;
        let t = &self.table;
        let new = t.pieces.len() - 1;
        let change_head = |k: usize| {
            if new == 1 {
                "change".to_string()
            } else {
                format!("change {k}")
            }
        };
        let mut s = format!("{:<10}", "symbol");
        for p in &t.pieces {
            let _ = write!(s, " {p:>22}");
        }
        for k in 1..=new {
            let _ = write!(s, " {:>22}", change_head(k));
        }
        s.push('\n');
        for (name, ser) in &t.location_errors {
            let _ = write!(s, "{name:<10}");
            for v in &ser.values {
                let _ = write!(s, " {:>22}", cell(v, false));
            }
            for c in &ser.change[1..] {
                let _ = write!(s, " {:>22}", cell(c, true));
            }
            s.push('\n');
        }
        s
    }
}

/// A value with its u, signed when it is a change; `-` when absent.
fn cell(v: &Option<SeriesValue>, signed: bool) -> String {
    match (v, signed) {
        (Some(SeriesValue { value, u: Some(u) }), false) => format!("{value:.2} ({u:.2})"),
        (Some(SeriesValue { value, u: None }), false) => format!("{value:.2}"),
        (Some(SeriesValue { value, u: Some(u) }), true) => format!("{value:+.2} ({u:.2})"),
        (Some(SeriesValue { value, u: None }), true) => format!("{value:+.2}"),
        (None, _) => "-".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::errorfile::Quantity;

    fn result(values: &[(&str, f64, Option<f64>)]) -> ErrorFile {
        let mut f: ErrorFile = serde_yaml::from_str("machine: bc-trunnion\n").unwrap();
        for (s, value, u) in values {
            f.location_errors.insert(
                s.to_string(),
                Quantity {
                    value: *value,
                    u: *u,
                },
            );
        }
        f
    }

    /// The change is the new value minus the earlier one, its u the two
    /// u combined in quadrature (0.3 and 0.4 make 0.5); a symbol one of
    /// them lacks has no change.
    #[test]
    fn comparison_shows_values_and_the_change_from_the_earlier_result() {
        let before = result(&[("EX0B", 10.0, Some(0.3)), ("EZ0B", -5.0, None)]);
        let after = result(&[("EX0B", 11.0, Some(0.4)), ("EC0B", 3.0, Some(1.0))]);
        let c = EarlierComparison::new(("cold.yaml".into(), before), &[("warm.dmo".into(), after)]);
        let text = c.render();
        let lines: Vec<&str> = text.lines().collect();
        let cells = |l: &str| l.split_whitespace().map(String::from).collect::<Vec<_>>();
        assert_eq!(
            cells(lines[0]),
            ["symbol", "cold.yaml", "warm.dmo", "change"]
        );
        assert_eq!(
            cells(lines[1]),
            [
                "EX0B", "10.00", "(0.30)", "11.00", "(0.40)", "+1.00", "(0.50)"
            ]
        );
        assert_eq!(cells(lines[2]), ["EZ0B", "-5.00", "-", "-"]);
        assert_eq!(cells(lines[3]), ["EC0B", "-", "3.00", "(1.00)", "-"]);
    }

    /// Two pieces have no trend (it needs three): the table has no trend
    /// column at all, not a heading over empty cells.
    #[test]
    fn a_series_of_two_has_no_trend_column() {
        let a = result(&[("EX0B", 10.0, Some(0.3))]);
        let b = result(&[("EX0B", 11.0, Some(0.3))]);
        let text = Series::new(&[("a.dmo".into(), a), ("b.dmo".into(), b)]).render();
        assert!(!text.contains("trend"), "{text}");
        let head: Vec<&str> = text.lines().next().unwrap().split_whitespace().collect();
        assert_eq!(head, ["symbol", "a.dmo", "b.dmo"]);
    }

    /// Three pieces rising by 1 um each with equal u: the trend column
    /// shows the slope +1.00 um per piece, its u 0.3/sqrt(2) = 0.21 (the
    /// weighted least-squares slope's u over x = 0, 1, 2).
    #[test]
    fn a_series_of_three_shows_the_trend_per_piece() {
        let rows: Vec<(String, ErrorFile)> = (0..3)
            .map(|i| {
                (
                    format!("p{i}.dmo"),
                    result(&[("EX0B", 10.0 + i as f64, Some(0.3))]),
                )
            })
            .collect();
        let text = Series::new(&rows).render();
        let lines: Vec<Vec<&str>> = text
            .lines()
            .map(|l| l.split_whitespace().collect())
            .collect();
        assert_eq!(
            lines[0],
            ["symbol", "p0.dmo", "p1.dmo", "p2.dmo", "trend/piece"]
        );
        assert_eq!(lines[1][7..], ["+1.00", "(0.21)"]);
    }
}
