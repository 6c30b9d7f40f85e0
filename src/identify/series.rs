//! Series of results (seed 001 section 4): several pieces of the same plan
//! machined one after the other, or a cold probing run against a machining
//! test. For every location symbol: its value on each piece, its change
//! from the first piece with the combined standard uncertainty, and the
//! straight-line trend per piece (weighted least squares) that shows a
//! thermal drift.

use indexmap::IndexMap;

use crate::errorfile::ErrorFile;

/// A value with its standard uncertainty, if known.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Value {
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
    pub values: Vec<Option<Value>>,
    /// Change from the first piece.
    pub change: Vec<Option<Value>>,
    /// Slope of a straight line through the values, per piece, when at
    /// least three pieces identify the symbol.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub trend_per_piece: Option<Value>,
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
            let values: Vec<Option<Value>> = pieces
                .iter()
                .map(|(_, f)| {
                    f.location_errors.get(&s).map(|q| Value {
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
                    Some(Value {
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

    /// Text table: one row per symbol, value (u) per piece, then the trend.
    pub fn render(&self) -> String {
        use std::fmt::Write as _;
        let mut s = format!("{:<10}", "symbol");
        for p in &self.pieces {
            let _ = write!(s, " {:>22}", p);
        }
        s.push_str("   trend/piece\n");
        for (name, ser) in &self.location_errors {
            let _ = write!(s, "{name:<10}");
            for v in &ser.values {
                match v {
                    Some(Value { value, u: Some(u) }) => {
                        let _ = write!(s, " {:>22}", format!("{value:.2} ({u:.2})"));
                    }
                    Some(Value { value, u: None }) => {
                        let _ = write!(s, " {:>22}", format!("{value:.2}"));
                    }
                    None => {
                        let _ = write!(s, " {:>22}", "-");
                    }
                }
            }
            match ser.trend_per_piece {
                Some(Value { value, u: Some(u) }) => {
                    let _ = writeln!(s, "   {value:+.2} ({u:.2})");
                }
                Some(Value { value, u: None }) => {
                    let _ = writeln!(s, "   {value:+.2}");
                }
                None => s.push('\n'),
            }
        }
        s
    }
}

/// Weighted straight line through (piece index, value): slope and its
/// standard uncertainty.
fn trend(values: &[Option<Value>]) -> Option<Value> {
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
    Some(Value {
        value: slope,
        u: weighted.then(|| (1.0 / sxx).sqrt()),
    })
}
