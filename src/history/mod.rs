//! A machine's history, read from the results store: every location error
//! as a series over time, the exports that changed the control between
//! them, the trend of each series against its acceptance limit
//! ([`trend`]), the HTML page that plots them ([`page`]), the listing and
//! export as CSV or JSON, and the comparison of a result before and after
//! compensation ([`compare`]).

pub mod compare;
mod json;
pub mod page;
pub mod trend;

use std::collections::HashSet;
use std::fmt::Write as _;

use indexmap::IndexMap;
use jiff::Timestamp;
use serde::{Deserialize, Serialize};

use crate::conformance::{AcceptanceLimits, unit_of};
use crate::errorfile::Quantity;
use crate::store::{FileRole, FitVerdict, RecordKind, Stored, format_time};
pub use json::trends_to_json;
use trend::{Outlook, TrendSample};

/// The location errors of a result file's text (YAML or JSON), or `None`
/// when it has none (nine-section statistics, a series table).
pub fn location_errors(content: &str) -> Option<IndexMap<String, Quantity>> {
    #[derive(Deserialize)]
    struct Values {
        #[serde(default)]
        location_errors: IndexMap<String, Quantity>,
    }
    serde_yaml::from_str::<Values>(content)
        .ok()
        .map(|v| v.location_errors)
        .filter(|v| !v.is_empty())
}

/// The run-to-run part of each value's `u` a result file states
/// (`uncertainty: values: SYMBOL: u_random`), by symbol; empty for a file
/// that does not split its `u` (then all of it is taken as varying from
/// run to run, which only makes a trend harder to show).
fn random_parts(content: &str) -> IndexMap<String, f64> {
    #[derive(Deserialize)]
    struct Part {
        #[serde(default)]
        u_random: Option<f64>,
    }
    #[derive(Deserialize)]
    struct Section {
        #[serde(default)]
        values: IndexMap<String, Part>,
    }
    #[derive(Deserialize)]
    struct File {
        #[serde(default)]
        uncertainty: Option<Section>,
    }
    serde_yaml::from_str::<File>(content)
        .ok()
        .and_then(|f| f.uncertainty)
        .map(|s| {
            s.values
                .into_iter()
                .filter_map(|(k, p)| p.u_random.filter(|u| u.is_finite()).map(|u| (k, u)))
                .collect()
        })
        .unwrap_or_default()
}

/// One value of a series.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SeriesPoint {
    /// The record it comes from.
    pub id: i64,
    /// When the machine was measured.
    #[serde(serialize_with = "ser_time")]
    pub at: Timestamp,
    /// analyze or discover.
    pub kind: RecordKind,
    /// The result's fit verdict.
    pub fit: Option<FitVerdict>,
    /// The test the result comes from, when recorded.
    pub test: Option<String>,
    /// The value.
    pub value: f64,
    /// Its standard uncertainty.
    pub u: Option<f64>,
    /// The part of `u` that varies from run to run, where the result
    /// states it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub u_random: Option<f64>,
}

fn ser_time<S: serde::Serializer>(t: &Timestamp, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(&format_time(*t))
}

/// One location error over time.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SymbolHistory {
    /// The symbol.
    pub symbol: String,
    /// um or urad.
    pub unit: &'static str,
    /// Oldest first.
    pub points: Vec<SeriesPoint>,
}

/// A change of the control (`compensate --export`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ExportRecord {
    /// The record.
    pub id: i64,
    /// When.
    #[serde(serialize_with = "ser_time")]
    pub at: Timestamp,
    /// Which controller's parameters.
    pub controller: Option<String>,
}

/// A machine's records as series.
#[derive(Clone, Debug)]
pub struct History {
    /// The machine.
    pub machine: String,
    /// Its records, oldest measurement first.
    pub records: Vec<Stored>,
    /// One series per location symbol, in the order they first appear.
    pub series: Vec<SymbolHistory>,
    /// The exports, oldest first.
    pub exports: Vec<ExportRecord>,
    /// Records that measured the same files as a later one and are left
    /// out of the series (the later result of a measurement counts).
    pub superseded: Vec<i64>,
}

impl History {
    /// The history of `machine` from its records (any order).
    pub fn new(machine: &str, mut records: Vec<Stored>) -> History {
        records.retain(|r| r.record.machine == machine);
        records.sort_by_key(|r| (r.record.measured_at, r.id));
        // analyze then discover on the same files: one measurement, the
        // last result counts.
        let mut seen: HashSet<Vec<String>> = HashSet::new();
        let mut superseded = Vec::new();
        let mut by_recorded: Vec<&Stored> = records.iter().collect();
        by_recorded.sort_by_key(|r| std::cmp::Reverse((r.record.recorded_at, r.id)));
        for r in by_recorded {
            if r.record.kind == RecordKind::Export {
                continue;
            }
            let mut key: Vec<String> = r
                .record
                .files
                .iter()
                .filter(|f| f.role == FileRole::Measured)
                .map(|f| f.sha256.clone())
                .collect();
            if key.is_empty() {
                continue;
            }
            key.sort();
            if !seen.insert(key) {
                superseded.push(r.id);
            }
        }
        let mut series: IndexMap<String, SymbolHistory> = IndexMap::new();
        let mut exports = Vec::new();
        for r in &records {
            if r.record.kind == RecordKind::Export {
                exports.push(ExportRecord {
                    id: r.id,
                    at: r.record.measured_at,
                    controller: r.record.controller.clone(),
                });
                continue;
            }
            if superseded.contains(&r.id) {
                continue;
            }
            let random = random_parts(&r.record.content);
            for (sym, q) in location_errors(&r.record.content).unwrap_or_default() {
                series
                    .entry(sym.clone())
                    .or_insert_with(|| SymbolHistory {
                        unit: unit_of(&sym),
                        symbol: sym.clone(),
                        points: Vec::new(),
                    })
                    .points
                    .push(SeriesPoint {
                        id: r.id,
                        at: r.record.measured_at,
                        kind: r.record.kind,
                        fit: r.record.fit,
                        test: r.record.test.clone(),
                        value: q.value,
                        u: q.u,
                        u_random: random.get(&sym).copied(),
                    });
            }
        }
        superseded.sort();
        History {
            machine: machine.to_string(),
            records,
            series: series.into_values().collect(),
            exports,
            superseded,
        }
    }

    /// The points of `s` since the last export (the control was changed
    /// there, so the values before it belong to another machine state),
    /// with an uncertainty.
    pub fn current(&self, s: &SymbolHistory) -> Vec<TrendSample> {
        self.basis(s).samples
    }

    /// What a trend of `s` is fitted to: the results since the last export
    /// with an uncertainty, that fit their measurements (a misfit's or a
    /// stopped fit's values are biased by more than their u), and of one
    /// test, the latest result's (another test sees the errors through
    /// another design, with other biases); and what was left out.
    pub fn basis(&self, s: &SymbolHistory) -> TrendBasis {
        let after = self.exports.last().map(|e| e.at);
        let since: Vec<&SeriesPoint> = s
            .points
            .iter()
            .filter(|p| after.is_none_or(|t| p.at > t))
            .filter(|p| p.u.is_some_and(|u| u > 0.0))
            .collect();
        let fitting: Vec<&SeriesPoint> = since
            .iter()
            .copied()
            .filter(|p| p.fit.is_none_or(FitVerdict::is_fit))
            .collect();
        let test = fitting.last().and_then(|p| p.test.clone());
        let samples: Vec<TrendSample> = fitting
            .iter()
            .filter(|p| p.test == test)
            .map(|p| {
                let u = p.u.unwrap_or(0.0);
                // The line is fitted against what varies from run to run;
                // the rest moves every value alike.
                let random = p.u_random.filter(|r| *r > 0.0 && *r <= u).unwrap_or(u);
                TrendSample {
                    at: p.at,
                    value: p.value,
                    u: random,
                    u_common: (u * u - random * random).max(0.0).sqrt(),
                }
            })
            .collect();
        TrendBasis {
            not_fits: since.len() - fitting.len(),
            other_tests: fitting.len() - samples.len(),
            samples,
            test,
        }
    }

    /// The outlook of every series against `limits`.
    pub fn outlooks(&self, limits: &AcceptanceLimits) -> Vec<(&SymbolHistory, Outlook)> {
        self.series
            .iter()
            .map(|s| (s, trend::outlook(&self.current(s), limits.get(&s.symbol))))
            .collect()
    }
}

/// The results a trend is fitted to ([`History::basis`]).
#[derive(Clone, Debug, PartialEq)]
pub struct TrendBasis {
    /// The samples, oldest first.
    pub samples: Vec<TrendSample>,
    /// Their test (the latest fitting result's), when recorded.
    pub test: Option<String>,
    /// Results left out because they did not fit (misfit, not converged).
    pub not_fits: usize,
    /// Fitting results left out because they are of another test.
    pub other_tests: usize,
}

/// A date-time as printed: minutes, UTC.
pub(crate) fn short_time(t: Timestamp) -> String {
    t.strftime("%Y-%m-%d %H:%M").to_string()
}

/// One line of the listing per record.
pub fn render_list(records: &[Stored]) -> String {
    let header = [
        "id",
        "measured (UTC)",
        "machine",
        "kind",
        "test",
        "fit",
        "deg C",
        "note",
    ];
    let rows: Vec<[String; 8]> = records
        .iter()
        .map(|r| {
            let c = &r.record;
            [
                r.id.to_string(),
                short_time(c.measured_at),
                c.machine.clone(),
                c.kind.to_string(),
                c.test
                    .as_deref()
                    .or(c.controller.as_deref())
                    .unwrap_or("-")
                    .to_string(),
                c.fit.map_or("-", |f| f.name()).to_string(),
                c.temperature.map_or("-".into(), |t| format!("{t:.1}")),
                c.note.as_deref().unwrap_or("").to_string(),
            ]
        })
        .collect();
    // Each column as wide as its widest entry, so a long machine name or
    // `not-converged` never pushes the later columns out from under their
    // headings; numbers right-aligned.
    let mut width = header.map(|h| h.chars().count());
    for row in &rows {
        for (w, v) in width.iter_mut().zip(row) {
            *w = (*w).max(v.chars().count());
        }
    }
    let line = |cells: [&str; 8]| {
        let mut l = String::new();
        for (k, (v, w)) in cells.iter().zip(width).enumerate() {
            let pad = w - v.chars().count();
            match k {
                0 | 6 => l.push_str(&format!("{}{v}", " ".repeat(pad))),
                7 => l.push_str(v),
                _ => l.push_str(&format!("{v}{}", " ".repeat(pad))),
            }
            if k < 7 {
                l.push_str("  ");
            }
        }
        l.trim_end().to_string()
    };
    let mut s = line(header) + "\n";
    for row in &rows {
        s += &line(row.each_ref().map(|v| v.as_str()));
        s.push('\n');
    }
    s
}

/// Everything about one record.
pub fn render_record(r: &Stored) -> String {
    let c = &r.record;
    let mut s = String::new();
    let _ = writeln!(s, "record {} ({}) of machine {}", r.id, c.kind, c.machine);
    if let Some(t) = &c.test {
        let _ = writeln!(s, "  test:         {t}");
    }
    let _ = writeln!(s, "  measured at:  {}", format_time(c.measured_at));
    let _ = writeln!(s, "  recorded at:  {}", format_time(c.recorded_at));
    let _ = writeln!(s, "  fivecal:      {}", c.tool_version);
    let _ = writeln!(s, "  result:       {}", c.result_name);
    let _ = writeln!(
        s,
        "  fit:          {}",
        c.fit
            .map_or("unknown (the result states no fit verdict)", |f| f.name())
    );
    if let Some(t) = c.temperature {
        let _ = writeln!(s, "  temperature:  {t} deg C");
    }
    if let Some(n) = &c.note {
        let _ = writeln!(s, "  note:         {n}");
    }
    if let Some(ctl) = &c.controller {
        let _ = writeln!(s, "  exported to:  {ctl}");
    }
    for f in &c.files {
        let role = match f.role {
            FileRole::Measured => "measured",
            FileRole::Plan => "plan",
            FileRole::Errors => "errors",
        };
        let _ = writeln!(s, "  {role:<9} {}  sha256 {}", f.path, f.sha256);
    }
    let _ = writeln!(s, "--- {}", c.result_name);
    s.push_str(&c.content);
    if !c.content.ends_with('\n') {
        s.push('\n');
    }
    if let Some(x) = &c.exported {
        let _ = writeln!(
            s,
            "--- parameters written for {}",
            c.controller.as_deref().unwrap_or("the control")
        );
        s.push_str(x);
        if !x.ends_with('\n') {
            s.push('\n');
        }
    }
    s
}

/// The trends as printed, one paragraph per symbol.
pub fn render_outlooks(h: &History, limits: &AcceptanceLimits) -> String {
    use trend::{Forecast, Outlook as O};
    let mut s = String::new();
    if let Some(e) = h.exports.last() {
        let _ = writeln!(
            s,
            "trends since the last export ({}, record {}):",
            short_time(e.at),
            e.id
        );
    } else {
        let _ = writeln!(s, "trends:");
    }
    for (series, o) in h.outlooks(limits) {
        let u = series.unit;
        let sym = &series.symbol;
        let lim = limits
            .get(sym)
            .map_or(String::new(), |l| format!(" (limit {l} {u})"));
        let basis = h.basis(series);
        let mut left = Vec::new();
        if basis.not_fits > 0 {
            left.push(format!(
                "{} that do not fit (misfit or not converged)",
                basis.not_fits
            ));
        }
        if basis.other_tests > 0 {
            left.push(format!("{} of other tests", basis.other_tests));
        }
        if !left.is_empty() {
            let _ = writeln!(
                s,
                "  {sym:<10} left out: {}{}",
                left.join(", "),
                basis
                    .test
                    .as_ref()
                    .map_or(String::new(), |t| format!(" (trend of the {t} results)"))
            );
        }
        let _ = match o {
            O::TooFew { n } => writeln!(
                s,
                "  {sym:<10} {n} result(s) with u: too few for a trend (3 needed){lim}"
            ),
            O::TooShort { n, days } => writeln!(
                s,
                "  {sym:<10} {n} results over {:.2} days: too short for a trend ({} day(s) needed){lim}",
                days,
                trend::MIN_SPAN_DAYS
            ),
            O::NoTrend { line } => writeln!(
                s,
                "  {sym:<10} no trend: {:+.4} {u}/day (u {:.4}) over {} results since {}{lim}",
                line.slope,
                line.u_slope,
                line.n,
                short_time(line.since)
            ),
            O::Drifting { line, forecast } => {
                let head = format!(
                    "  {sym:<10} drifting since {}: {:+.4} {u}/day (u {:.4}) over {} results, now {:.3} {u} (u {:.3})",
                    short_time(line.since),
                    line.slope,
                    line.u_slope,
                    line.n,
                    line.value,
                    line.u_value
                );
                let widened = if line.birge > 1.0 {
                    format!(
                        "; the results scatter {:.1} times their u, the trend's u is widened by that",
                        line.birge
                    )
                } else {
                    String::new()
                };
                match forecast {
                    Forecast::NoLimit => writeln!(s, "{head}{widened}; no limit set"),
                    Forecast::Beyond { limit } => {
                        writeln!(s, "{head}{widened}; already beyond its limit {limit} {u}")
                    }
                    Forecast::Reaches { limit, at, u_days } => writeln!(
                        s,
                        "{head}{widened}; reaches its limit {limit} {u} around {} (u {:.1} days)",
                        short_time(at),
                        u_days
                    ),
                }
            }
        };
    }
    s
}

/// The records as CSV, one row per record and location symbol (records
/// without location errors get one row with empty symbol columns).
pub fn to_csv(records: &[Stored]) -> Result<String, csv::Error> {
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record([
        "id",
        "machine",
        "kind",
        "test",
        "measured_at",
        "recorded_at",
        "fit",
        "temperature_c",
        "note",
        "symbol",
        "value",
        "u",
        "unit",
    ])?;
    for r in records {
        let c = &r.record;
        let head = [
            r.id.to_string(),
            c.machine.clone(),
            c.kind.to_string(),
            c.test.clone().unwrap_or_default(),
            format_time(c.measured_at),
            format_time(c.recorded_at),
            c.fit.map_or(String::new(), |f| f.to_string()),
            c.temperature.map_or(String::new(), |t| t.to_string()),
            c.note.clone().unwrap_or_default(),
        ];
        let values = location_errors(&c.content).unwrap_or_default();
        if values.is_empty() {
            w.write_record(head.iter().cloned().chain([
                "".into(),
                "".into(),
                "".into(),
                "".into(),
            ]))?;
        }
        for (sym, q) in values {
            w.write_record(head.iter().cloned().chain([
                sym.clone(),
                q.value.to_string(),
                q.u.map_or(String::new(), |u| u.to_string()),
                unit_of(&sym).to_string(),
            ]))?;
        }
    }
    let bytes = w.into_inner().map_err(|e| e.into_error())?;
    Ok(String::from_utf8(bytes).expect("CSV of UTF-8 fields"))
}

/// The records as JSON: every field, the files with their hashes, and the
/// location errors read from the content.
pub fn to_json(records: &[Stored]) -> String {
    let out: Vec<JsonRecord> = records.iter().map(JsonRecord::of).collect();
    serde_json::to_string_pretty(&out).expect("records serialize") + "\n"
}

/// One record as [`to_json`] writes each (`history show --json`).
pub fn record_to_json(record: &Stored) -> String {
    serde_json::to_string_pretty(&JsonRecord::of(record)).expect("records serialize") + "\n"
}

/// A record with its location errors read out of its content.
#[derive(Serialize)]
struct JsonRecord<'a> {
    #[serde(flatten)]
    stored: &'a Stored,
    location_errors: IndexMap<String, Quantity>,
}

impl JsonRecord<'_> {
    fn of(r: &Stored) -> JsonRecord<'_> {
        JsonRecord {
            stored: r,
            location_errors: location_errors(&r.record.content).unwrap_or_default(),
        }
    }
}
