//! `history trend --json`: each location error's outlook as JSON, with
//! stable keys (docs/input-and-output.md): the same facts `history trend`
//! prints, as numbers.

use serde::Serialize;

use super::History;
use super::trend::{Forecast, Outlook};
use crate::conformance::AcceptanceLimits;
use crate::store::format_time;

/// The trends of a machine's history.
#[derive(Serialize)]
struct Trends<'a> {
    machine: &'a str,
    /// The last export the trends start after, if any.
    since_export: Option<SinceExport>,
    symbols: Vec<SymbolTrend<'a>>,
}

#[derive(Serialize)]
struct SinceExport {
    record: i64,
    at: String,
}

#[derive(Serialize)]
struct SymbolTrend<'a> {
    symbol: &'a str,
    unit: &'a str,
    limit: Option<[f64; 2]>,
    /// `too-few`, `too-short`, `no-trend` or `drifting`.
    outlook: &'static str,
    /// Results the outlook rests on.
    results: usize,
    /// Days from the first to the last of them (too-short).
    days: Option<f64>,
    /// The fitted line (no-trend, drifting): unit per day.
    slope_per_day: Option<f64>,
    u_slope_per_day: Option<f64>,
    since: Option<String>,
    value: Option<f64>,
    u_value: Option<f64>,
    /// Drifting: `no-limit`, `beyond` or `reaches`.
    forecast: Option<&'static str>,
    /// Reaches: the limit it moves toward, when, and that date's u.
    reaches_limit: Option<f64>,
    reaches_at: Option<String>,
    reaches_u_days: Option<f64>,
}

/// The outlooks of `h` against `limits` as pretty JSON (a trailing newline).
pub fn trends_to_json(h: &History, limits: &AcceptanceLimits) -> String {
    let symbols = h
        .outlooks(limits)
        .into_iter()
        .map(|(s, o)| {
            let mut t = SymbolTrend {
                symbol: &s.symbol,
                unit: s.unit,
                limit: limits.get(&s.symbol).map(|l| [l.lower, l.upper]),
                outlook: "",
                results: 0,
                days: None,
                slope_per_day: None,
                u_slope_per_day: None,
                since: None,
                value: None,
                u_value: None,
                forecast: None,
                reaches_limit: None,
                reaches_at: None,
                reaches_u_days: None,
            };
            let line = match o {
                Outlook::TooFew { n } => {
                    (t.outlook, t.results) = ("too-few", n);
                    None
                }
                Outlook::TooShort { n, days } => {
                    (t.outlook, t.results, t.days) = ("too-short", n, Some(days));
                    None
                }
                Outlook::NoTrend { line } => {
                    t.outlook = "no-trend";
                    Some(line)
                }
                Outlook::Drifting { line, forecast } => {
                    t.outlook = "drifting";
                    t.forecast = Some(match forecast {
                        Forecast::NoLimit => "no-limit",
                        Forecast::Beyond { limit } => {
                            t.reaches_limit = Some(limit);
                            "beyond"
                        }
                        Forecast::Reaches { limit, at, u_days } => {
                            t.reaches_limit = Some(limit);
                            t.reaches_at = Some(format_time(at));
                            t.reaches_u_days = Some(u_days);
                            "reaches"
                        }
                    });
                    Some(line)
                }
            };
            if let Some(l) = line {
                t.results = l.n;
                t.slope_per_day = Some(l.slope);
                t.u_slope_per_day = Some(l.u_slope);
                t.since = Some(format_time(l.since));
                t.value = Some(l.value);
                t.u_value = Some(l.u_value);
            }
            t
        })
        .collect();
    let out = Trends {
        machine: &h.machine,
        since_export: h.exports.last().map(|e| SinceExport {
            record: e.id,
            at: format_time(e.at),
        }),
        symbols,
    };
    serde_json::to_string_pretty(&out).expect("trends serialize") + "\n"
}
