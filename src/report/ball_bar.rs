//! The `--report DIR` of a ball-bar analysis: each run's circularity
//! figure first (what an acceptance engineer reads), the verdict, what the
//! runs do not see, the location errors, and each error motion of the
//! rotary axes as a plot over the angle with its u band. The page is
//! staged and appears whole or not at all, as every report.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::{ReportError, esc, page_start, plot, plots, put};
use crate::errorfile::{ErrorFile, Values};
use crate::io::StagedDir;

/// Writes the report of the ball-bar result `file` into `dir`; returns
/// the files written.
pub fn write(dir: &Path, file: &ErrorFile) -> Result<Vec<PathBuf>, ReportError> {
    let mut files = StagedDir::create(dir)?;
    let mut h = page_start(&format!("Ball bar under TCP on {}", file.machine));
    let _ = writeln!(
        h,
        "<h2>Circularity per run</h2>\n<p>ISO 230-4 / ISO 10791-6 style: the bar's length deviation over the sweep, largest minus smallest, um. Nothing is removed: a fixed-length bar under TCP has no centre to fit, its pivot is the table ball.</p>\n<table><tr><th>run</th><th>range</th><th>max</th><th>min</th><th>range without the stated run-out</th></tr>"
    );
    for c in &file.circularity {
        let _ = writeln!(
            h,
            "<tr><td class=\"l\">{}</td><td>{:.3}</td><td>{:.3}</td><td>{:.3}</td><td>{}</td></tr>",
            esc(&c.setup),
            c.range_um,
            c.max_um,
            c.min_um,
            c.range_without_runout_um
                .map_or("-".to_string(), |v| format!("{v:.3}"))
        );
    }
    h.push_str("</table>\n");
    let _ = writeln!(
        h,
        "<h2>Verdict</h2>\n<pre>{}</pre>",
        esc(&crate::analyze::verdict::render(file.fit.as_ref()))
    );
    if !file.not_identifiable.is_empty() {
        h.push_str("<h2>Not seen by the runs</h2>\n<table><tr><th>symbol</th><th>why</th></tr>\n");
        for n in &file.not_identifiable {
            let _ = writeln!(
                h,
                "<tr><td class=\"l\">{}</td><td class=\"l\">{}</td></tr>",
                esc(&n.symbol),
                esc(&n.reason)
            );
        }
        h.push_str("</table>\n");
    }
    if !file.location_errors.is_empty() {
        h.push_str(
            "<h2>Location errors</h2>\n<table><tr><th>symbol</th><th>value</th><th>u</th></tr>\n",
        );
        for (name, q) in &file.location_errors {
            let _ = writeln!(
                h,
                "<tr><td class=\"l\">{}</td><td>{:.3}</td><td>{}</td></tr>",
                esc(name),
                q.value,
                q.u.map_or("-".to_string(), |u| format!("{u:.3}"))
            );
        }
        h.push_str("</table>\n");
    }
    if !file.position_dependent.is_empty() {
        h.push_str(
            "<h2>Error motions over the angle (u as error bars)</h2>\n<div class=\"grid\">\n",
        );
    }
    for (k, (name, m)) in file.position_dependent.iter().enumerate() {
        let dims: Vec<(&String, &Vec<f64>)> = m.nodes.iter().collect();
        let Some((x_letter, xs)) = dims.last() else {
            continue;
        };
        let rows_v = rows(&m.values);
        let rows_u = m.u.as_ref().map(rows);
        let series: Vec<(String, Vec<plots::MapNode>)> = rows_v
            .iter()
            .enumerate()
            .map(|(r, vals)| {
                let label = match dims.first() {
                    Some((l, n)) if dims.len() > 1 => format!("{l} = {}", n[r]),
                    _ => name.clone(),
                };
                let pts = xs
                    .iter()
                    .zip(vals)
                    .enumerate()
                    .map(|(i, (&x, &v))| (x, v, rows_u.as_ref().map(|u| u[r][i])))
                    .collect();
                (label, pts)
            })
            .collect();
        let unit = if name.starts_with("EA") || name.starts_with("EB") || name.starts_with("EC") {
            "urad"
        } else {
            "um"
        };
        let f = format!("map-{}.svg", k + 1);
        put(
            &mut files,
            &f,
            plot(
                &f,
                plots::map_plot(name, &format!("{x_letter}, deg"), unit, &series),
            )?
            .as_bytes(),
        )?;
        let _ = writeln!(h, "<img src=\"{f}\" alt=\"{}\">", esc(name));
    }
    if !file.position_dependent.is_empty() {
        h.push_str("</div>\n");
    }
    if let Some(u) = &file.uncertainty {
        let _ = writeln!(h, "<p>u (k = 1) holds {}.</p>", esc(&u.basis));
    }
    h.push_str("</body></html>\n");
    put(&mut files, "index.html", h.as_bytes())?;
    Ok(files.commit()?)
}

fn rows(v: &Values) -> Vec<Vec<f64>> {
    match v {
        Values::Flat(x) => vec![x.clone()],
        Values::Rows(r) => r.clone(),
    }
}
