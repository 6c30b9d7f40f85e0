//! The `--report DIR` of a ten-line analysis: per line the standard plot
//! of ISO 230-2 (the mean positioning deviation of each approach direction
//! against the target position, with its band of plus and minus two
//! standard deviations of the runs), the figures with their u and the
//! environment the run file states.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use plotters::prelude::*;

use super::plots::{Legible as _, PlotResult, err};
use super::{ReportError, esc, page_start, plot, put};
use crate::analyze::iso230_2::{Direction, LineFigures, Target};
use crate::analyze::laser::LaserResult;
use crate::io::StagedDir;

/// The ISO 230-2 plot of one line.
pub fn line_plot(f: &LineFigures) -> PlotResult {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (760, 400)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let xs: Vec<f64> = f.targets.iter().map(|t| t.position_mm).collect();
        let (x0, x1) = (xs[0], xs[xs.len() - 1]);
        let ys = f.targets.iter().flat_map(|t| {
            [
                t.up.mean_um - 2.0 * t.up.s_um,
                t.up.mean_um + 2.0 * t.up.s_um,
                t.down.mean_um - 2.0 * t.down.s_um,
                t.down.mean_um + 2.0 * t.down.s_um,
            ]
        });
        let (lo, hi) = ys.fold((0.0f64, 0.0f64), |a, v| (a.0.min(v), a.1.max(v)));
        let pad = ((hi - lo) * 0.1).max(0.1);
        let pad_x = ((x1 - x0) * 0.02).max(1e-3);
        let mut chart = ChartBuilder::on(&root)
            .caption(
                format!("line {}: mean deviation +-2s per direction", f.line),
                ("sans-serif", 18),
            )
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d((x0 - pad_x)..(x1 + pad_x), (lo - pad)..(hi + pad))
            .map_err(err)?;
        chart
            .configure_mesh()
            .legible()
            .x_desc("target position, mm")
            .y_desc("deviation, um")
            .draw()
            .map_err(err)?;
        type Pick = fn(&Target) -> Direction;
        let series: [(&RGBColor, &str, Pick); 2] = [
            (&RED, "+ approach", |t| t.up),
            (&BLUE, "- approach", |t| t.down),
        ];
        for (color, label, d) in series {
            let band: Vec<(f64, f64)> = f
                .targets
                .iter()
                .map(|t| (t.position_mm, d(t).mean_um + 2.0 * d(t).s_um))
                .chain(
                    f.targets
                        .iter()
                        .rev()
                        .map(|t| (t.position_mm, d(t).mean_um - 2.0 * d(t).s_um)),
                )
                .collect();
            chart
                .draw_series(std::iter::once(Polygon::new(band, color.mix(0.15))))
                .map_err(err)?;
            chart
                .draw_series(LineSeries::new(
                    f.targets.iter().map(|t| (t.position_mm, d(t).mean_um)),
                    color.stroke_width(2),
                ))
                .map_err(err)?
                .label(label)
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2))
                });
        }
        chart
            .configure_series_labels()
            .border_style(BLACK)
            .background_style(WHITE.mix(0.8))
            .draw()
            .map_err(err)?;
        root.present().map_err(err)?;
    }
    Ok(svg)
}

/// Writes the report into `dir`; returns the files written.
pub fn write(dir: &Path, r: &LaserResult) -> Result<Vec<PathBuf>, ReportError> {
    let mut files = StagedDir::create(dir)?;
    let mut h = page_start(&format!("Laser lines on {} (ISO 230-2)", r.machine));
    let _ = writeln!(h, "<p>{}.</p>", esc(&r.uncertainty));
    if !r.not_measured.is_empty() {
        let _ = writeln!(
            h,
            "<p>Not measured: {}.</p>",
            esc(&r.not_measured.join(", "))
        );
    }
    for l in &r.lines {
        let f = &l.figures;
        let file = format!("line-{}.svg", f.line);
        put(&mut files, &file, plot(&file, line_plot(f))?.as_bytes())?;
        let _ = writeln!(
            h,
            "<h2>Line {} ({})</h2>\n<p>{} ({}), {} runs each way.</p>\n<img src=\"{file}\" alt=\"ISO 230-2 plot of line {}\">\n<table><tr><th>figure</th><th>value um</th><th>u um</th></tr>",
            esc(&f.line),
            esc(&l.axes),
            esc(&l.file.display().to_string()),
            esc(&l.format),
            f.runs,
            esc(&f.line)
        );
        let rows = [
            ("A", &f.a),
            ("A+", &f.a_up),
            ("A-", &f.a_down),
            ("R", &f.r),
            ("R+", &f.r_up),
            ("R-", &f.r_down),
            ("B", &f.b),
            ("mean reversal", &f.b_mean),
            ("E", &f.e),
            ("E+", &f.e_up),
            ("E-", &f.e_down),
            ("M", &f.m),
        ];
        for (name, x) in rows {
            let _ = writeln!(
                h,
                "<tr><td class=\"l\">{}</td><td>{:.3}</td><td>{:.3}</td></tr>",
                esc(name),
                x.value_um,
                x.u_um
            );
        }
        h.push_str("</table>\n");
        if !l.environment.is_empty() {
            h.push_str("<p>Environment as the file states it: ");
            let parts: Vec<String> = l
                .environment
                .iter()
                .map(|(k, v)| format!("{} = {}", esc(k), esc(v)))
                .collect();
            let _ = writeln!(h, "{}.</p>", parts.join("; "));
        }
    }
    h.push_str("</body></html>\n");
    put(&mut files, "index.html", h.as_bytes())?;
    Ok(files.commit()?)
}
