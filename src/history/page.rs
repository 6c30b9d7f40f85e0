//! The history page: `index.html` with one plot per location error over
//! time (the u band shaded, each result marked by its fit verdict, the
//! exports as vertical lines, the acceptance limits, the current trend
//! dashed up to where it meets its limit) and the list of records, in the
//! style of the analysis report. Written atomically.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use jiff::Timestamp;

use super::trend::{self, Forecast, Outlook};
use super::{History, render_outlooks, short_time};
use crate::conformance::AcceptanceLimits;
use crate::io::write_atomic;
use crate::report::plots::{self, FitMark, TimePoint, TimeSeries};
use crate::report::{ReportError, esc, page_start};
use crate::store::FitVerdict;

/// Writes the page into `dir`; returns the files written.
pub fn write(
    dir: &Path,
    h: &History,
    limits: &AcceptanceLimits,
) -> Result<Vec<PathBuf>, ReportError> {
    let mut files = Vec::new();
    let origin: Option<Timestamp> = h.records.iter().map(|r| r.record.measured_at).min();
    let origin = origin.unwrap_or_else(Timestamp::now);
    let x = |t: Timestamp| trend::days_between(origin, t);
    // A series within a week gets the time on its axis: a date alone
    // labels every tick of one day's measurements the same.
    let span = h
        .records
        .iter()
        .map(|r| x(r.record.measured_at))
        .fold(0.0_f64, f64::max);
    let (format, x_desc) = if span <= 7.0 {
        ("%m-%d %H:%M", "date and time (UTC)")
    } else {
        ("%Y-%m-%d", "date (UTC)")
    };
    let label = |d: f64| {
        trend::add_days(origin, d).map_or(String::new(), |t| t.strftime(format).to_string())
    };
    let exports: Vec<f64> = h.exports.iter().map(|e| x(e.at)).collect();
    let outlooks = h.outlooks(limits);
    let mut figs = Vec::new();
    for (series, outlook) in &outlooks {
        // One run per interval between exports.
        let mut runs: Vec<Vec<TimePoint>> = vec![Vec::new()];
        let mut next_export = 0;
        for p in &series.points {
            while next_export < h.exports.len() && h.exports[next_export].at < p.at {
                next_export += 1;
                runs.push(Vec::new());
            }
            runs.last_mut().expect("one run at least").push(TimePoint {
                x: x(p.at),
                value: p.value,
                u: p.u,
                verdict: match p.fit {
                    Some(FitVerdict::Fits) => FitMark::Fits,
                    Some(FitVerdict::Misfit | FitVerdict::NotConverged) => FitMark::Misfit,
                    None => FitMark::Unknown,
                },
            });
        }
        runs.retain(|r| !r.is_empty());
        let trend = match outlook {
            Outlook::Drifting { line, forecast } => {
                let end = match forecast {
                    // Up to the crossing, unless that is far beyond the
                    // data (then as far again as the trend spans).
                    Forecast::Reaches { at, .. } => {
                        let span = x(line.at) - x(line.since);
                        let cross = x(*at);
                        cross.min(x(line.at) + span.max(1.0))
                    }
                    _ => x(line.at),
                };
                let y = |d: f64| line.value + line.slope * (d - x(line.at));
                let start = x(line.since);
                Some(((start, y(start)), (end, y(end))))
            }
            _ => None,
        };
        let file = format!(
            "history-{}.svg",
            series.symbol.replace(['(', ')', ','], "_")
        );
        let svg = plots::time_series(&TimeSeries {
            title: &format!("{} over time ({})", series.symbol, series.unit),
            unit: series.unit,
            runs,
            exports: exports.clone(),
            limit: limits.get(&series.symbol).map(|l| (l.lower, l.upper)),
            trend,
            x_label: &label,
            x_desc,
        })
        .map_err(|e| ReportError::Plot(file.clone(), e))?;
        let p = dir.join(&file);
        write_atomic(&p, svg.as_bytes())?;
        files.push(p);
        figs.push((file, series.symbol.clone()));
    }

    let mut page = page_start(&format!("History of {}", h.machine));
    let first = h.records.first().map(|r| short_time(r.record.measured_at));
    let last = h.records.last().map(|r| short_time(r.record.measured_at));
    let _ = writeln!(
        page,
        "<p>{} records from {} to {} (UTC), {} exports. Each plot shows one location error over time: the band is the standard uncertainty (k = 1) of each result; filled dots are results whose model fitted the measurement, red crosses results that did not, hollow dots results without a fit verdict; orange lines mark the exports (the control's parameters were changed there), red lines the acceptance limits, the dashed green line the current trend up to where it reaches its limit.</p>",
        h.records.len(),
        esc(first.as_deref().unwrap_or("-")),
        esc(last.as_deref().unwrap_or("-")),
        h.exports.len()
    );
    if !h.superseded.is_empty() {
        let _ = writeln!(
            page,
            "<p>{} {} measured the same files as a later record and {} not plotted: the later result of a measurement counts.</p>",
            if h.superseded.len() == 1 {
                "Record"
            } else {
                "Records"
            },
            h.superseded
                .iter()
                .map(|i| i.to_string())
                .collect::<Vec<_>>()
                .join(", "),
            if h.superseded.len() == 1 { "is" } else { "are" }
        );
    }
    let _ = writeln!(
        page,
        "<h2>Trends</h2>\n<pre>{}</pre>",
        esc(&render_outlooks(h, limits))
    );
    page.push_str("<div class=grid>\n");
    for (f, sym) in &figs {
        let _ = writeln!(
            page,
            "<figure><img src=\"{f}\" alt=\"{s} over time\"><figcaption>{s}</figcaption></figure>",
            s = esc(sym)
        );
    }
    page.push_str("</div>\n<h2>Records</h2>\n");
    page.push_str("<table><tr><th>id</th><th>measured (UTC)</th><th>kind</th><th>test or controller</th><th>fit</th><th>deg C</th><th class=l>note</th><th class=l>result</th></tr>\n");
    for r in &h.records {
        let c = &r.record;
        let _ = writeln!(
            page,
            "<tr><td>{}</td><td>{}</td><td class=l>{}</td><td class=l>{}</td><td class=l>{}</td><td>{}</td><td class=l>{}</td><td class=l>{}</td></tr>",
            r.id,
            short_time(c.measured_at),
            c.kind,
            esc(c.test.as_deref().or(c.controller.as_deref()).unwrap_or("")),
            c.fit.map_or("-", |f| f.name()),
            c.temperature.map_or(String::new(), |t| format!("{t:.1}")),
            esc(c.note.as_deref().unwrap_or("")),
            esc(&c.result_name)
        );
    }
    page.push_str("</table>\n");
    let _ = writeln!(page, "<h2>Next step</h2>\n<p>{}</p>", next_step(&outlooks));
    page.push_str("</body></html>\n");
    let p = dir.join("index.html");
    write_atomic(&p, page.as_bytes())?;
    files.push(p);
    Ok(files)
}

/// What to do after reading the page: measure again before the first
/// trend reaches its limit, else keep the interval.
fn next_step(outlooks: &[(&super::SymbolHistory, Outlook)]) -> String {
    let first = outlooks
        .iter()
        .filter_map(|(s, o)| match o {
            Outlook::Drifting {
                forecast: Forecast::Reaches { at, .. },
                ..
            } => Some((*at, &s.symbol)),
            _ => None,
        })
        .min_by_key(|(at, _)| *at);
    if let Some((s, _)) = outlooks.iter().find(|(_, o)| {
        matches!(
            o,
            Outlook::Drifting {
                forecast: Forecast::Beyond { .. },
                ..
            }
        )
    }) {
        return format!(
            "{}'s trend is already beyond its acceptance limit: run the test now, export the new result to the control (<code>fivecal compensate --export</code>) and compare before and after with <code>fivecal verify</code>.",
            esc(&s.symbol)
        );
    }
    match first {
        Some((at, symbol)) => format!(
            "{} reaches its acceptance limit about {} (UTC): run the test again before then and export the new result to the control (<code>fivecal compensate --export</code>), then compare before and after with <code>fivecal verify</code>.",
            esc(symbol),
            esc(&short_time(at))
        ),
        None => "No trend reaches its limit: keep the measurement interval, and record the next result with <code>fivecal analyze</code> (each analysis is recorded unless <code>--no-record</code>); <code>fivecal history trend</code> prints the trends in numbers.".to_string(),
    }
}
