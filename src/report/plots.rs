//! SVG plots (plotters, SVG backend): values with error bars, error maps
//! against angle, residuals, and the measured deviations of a pose
//! magnified (Ibaraki & Ota 2014, figs. 7-8, Ibaraki, Iritani & Matsushita 2013, fig. 5), and a value over time
//! with its u band (the machine's history).

use plotters::prelude::*;

/// A figure the drawing library could not draw, with its message.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct DrawError(String);

/// A drawn figure's SVG text.
pub(crate) type PlotResult = Result<String, DrawError>;

/// A node of an error map as plotted: angle (deg), value, standard
/// uncertainty.
pub type MapNode = (f64, f64, Option<f64>);

/// plotters' errors are generic over the backend; only their message
/// reaches the user.
pub(crate) fn err<E: std::fmt::Debug>(e: E) -> DrawError {
    DrawError(format!("{e:?}"))
}

const W: u32 = 720;
const H: u32 = 380;

fn range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |a, v| {
            (a.0.min(v), a.1.max(v))
        });
    if !lo.is_finite() {
        return (-1.0, 1.0);
    }
    let pad = ((hi - lo) * 0.12)
        .max(1e-3 * (lo.abs() + hi.abs()))
        .max(0.1);
    (lo - pad, hi + pad)
}

/// Values with error bars (k = 1), one per named item.
pub(crate) fn values_with_bars(
    title: &str,
    unit: &str,
    items: &[(String, f64, Option<f64>)],
) -> PlotResult {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (W, H)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let (y0, y1) = range(items.iter().flat_map(|(_, v, u)| {
            let u = u.unwrap_or(0.0);
            [v - u, v + u, 0.0]
        }));
        let n = items.len().max(1);
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(-0.5f64..(n as f64 - 0.5), y0..y1)
            .map_err(err)?;
        let names: Vec<String> = items.iter().map(|i| i.0.clone()).collect();
        chart
            .configure_mesh()
            .x_labels(n)
            .x_label_formatter(&|x| {
                let i = x.round();
                if (x - i).abs() < 0.01 && i >= 0.0 {
                    names.get(i as usize).cloned().unwrap_or_default()
                } else {
                    String::new()
                }
            })
            .y_desc(unit)
            .draw()
            .map_err(err)?;
        chart
            .draw_series(std::iter::once(PathElement::new(
                vec![(-0.5, 0.0), (n as f64 - 0.5, 0.0)],
                BLACK.mix(0.4),
            )))
            .map_err(err)?;
        for (i, (_, v, u)) in items.iter().enumerate() {
            let x = i as f64;
            if let Some(u) = u {
                chart
                    .draw_series([
                        PathElement::new(vec![(x, v - u), (x, v + u)], BLUE.stroke_width(2)),
                        PathElement::new(
                            vec![(x - 0.12, v - u), (x + 0.12, v - u)],
                            BLUE.stroke_width(2),
                        ),
                        PathElement::new(
                            vec![(x - 0.12, v + u), (x + 0.12, v + u)],
                            BLUE.stroke_width(2),
                        ),
                    ])
                    .map_err(err)?;
            }
            chart
                .draw_series(std::iter::once(Circle::new((x, *v), 4, BLUE.filled())))
                .map_err(err)?;
        }
        root.present().map_err(err)?;
    }
    Ok(svg)
}

/// One error map against angle: a series per row (a C map has one row per
/// tilt angle), each node with its error bar.
pub(crate) fn map_plot(
    title: &str,
    x_desc: &str,
    unit: &str,
    rows: &[(String, Vec<MapNode>)],
) -> PlotResult {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (W, H)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let (x0, x1) = range(rows.iter().flat_map(|r| r.1.iter().map(|p| p.0)));
        let (y0, y1) = range(rows.iter().flat_map(|r| {
            r.1.iter().flat_map(|p| {
                let u = p.2.unwrap_or(0.0);
                [p.1 - u, p.1 + u]
            })
        }));
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc(x_desc)
            .y_desc(unit)
            .draw()
            .map_err(err)?;
        let dx = (x1 - x0) * 0.01;
        for (k, (label, pts)) in rows.iter().enumerate() {
            let colour = Palette99::pick(k).to_rgba();
            chart
                .draw_series(LineSeries::new(pts.iter().map(|p| (p.0, p.1)), colour))
                .map_err(err)?
                .label(label.clone())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], colour));
            for p in pts {
                if let Some(u) = p.2 {
                    chart
                        .draw_series([
                            PathElement::new(vec![(p.0, p.1 - u), (p.0, p.1 + u)], colour),
                            PathElement::new(
                                vec![(p.0 - dx, p.1 - u), (p.0 + dx, p.1 - u)],
                                colour,
                            ),
                            PathElement::new(
                                vec![(p.0 - dx, p.1 + u), (p.0 + dx, p.1 + u)],
                                colour,
                            ),
                        ])
                        .map_err(err)?;
                }
                chart
                    .draw_series(std::iter::once(Circle::new((p.0, p.1), 3, colour.filled())))
                    .map_err(err)?;
            }
        }
        if rows.len() > 1 {
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .draw()
                .map_err(err)?;
        }
        root.present().map_err(err)?;
    }
    Ok(svg)
}

/// Residuals by observation, coloured by pose, with the +-sigma band.
pub(crate) fn residual_plot(groups: &[(String, Vec<(usize, f64)>)], sigma: f64) -> PlotResult {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (W, H)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let n = groups.iter().map(|g| g.1.len()).sum::<usize>().max(1);
        let (y0, y1) = range(
            groups
                .iter()
                .flat_map(|g| g.1.iter().map(|p| p.1))
                .chain([sigma.abs(), -sigma.abs()]),
        );
        let mut chart = ChartBuilder::on(&root)
            .caption(
                "residuals (measured - model, along the normal)",
                ("sans-serif", 18),
            )
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(0f64..n as f64, y0..y1)
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc("point (grouped by pose)")
            .y_desc("um")
            .draw()
            .map_err(err)?;
        if sigma.is_finite() {
            for s in [sigma, -sigma] {
                chart
                    .draw_series(std::iter::once(PathElement::new(
                        vec![(0.0, s), (n as f64, s)],
                        BLACK.mix(0.4),
                    )))
                    .map_err(err)?;
            }
        }
        for (k, (_, pts)) in groups.iter().enumerate() {
            let colour = Palette99::pick(k).to_rgba();
            chart
                .draw_series(
                    pts.iter()
                        .map(|p| Circle::new((p.0 as f64 + 0.5, p.1), 2, colour.filled())),
                )
                .map_err(err)?;
        }
        root.present().map_err(err)?;
    }
    Ok(svg)
}

/// One point of a pose view: its nominal position in the view's two
/// coordinates and its displacement there (deviation along the normal,
/// magnified, projected).
#[derive(Clone, Copy, Debug)]
pub struct ViewPoint {
    /// Nominal, mm.
    pub nominal: (f64, f64),
    /// Magnified displacement, mm.
    pub shift: (f64, f64),
    /// Deviation, um (for the colour).
    pub deviation_um: f64,
}

/// The measured deviations of one pose, magnified, in two views side by
/// side (Ibaraki & Ota 2014, figs. 7-8): dots at the nominal points, circles at the
/// measured ones, a segment along the normal between them.
pub(crate) fn pose_plot(
    title: &str,
    views: &[(String, Vec<ViewPoint>)],
    max_dev: f64,
) -> PlotResult {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (W, H)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let root = root.titled(title, ("sans-serif", 18)).map_err(err)?;
        let panels = root.split_evenly((1, views.len().max(1)));
        for (panel, (name, pts)) in panels.iter().zip(views) {
            let xs = pts
                .iter()
                .flat_map(|p| [p.nominal.0, p.nominal.0 + p.shift.0]);
            let ys = pts
                .iter()
                .flat_map(|p| [p.nominal.1, p.nominal.1 + p.shift.1]);
            let (mut x0, mut x1) = range(xs);
            let (mut y0, mut y1) = range(ys);
            // Equal scales on both axes.
            let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
            let half = 0.5 * (x1 - x0).max(y1 - y0);
            (x0, x1, y0, y1) = (cx - half, cx + half, cy - half, cy + half);
            let mut chart = ChartBuilder::on(panel)
                .caption(name, ("sans-serif", 14))
                .margin(8)
                .x_label_area_size(28)
                .y_label_area_size(44)
                .build_cartesian_2d(x0..x1, y0..y1)
                .map_err(err)?;
            chart.configure_mesh().x_desc("mm").draw().map_err(err)?;
            for p in pts {
                let t = if max_dev > 0.0 {
                    p.deviation_um / max_dev
                } else {
                    0.0
                };
                let c = super::glb::diverging(t);
                let colour = RGBColor(
                    (c[0] * 200.0) as u8,
                    (c[1] * 200.0) as u8,
                    (c[2] * 200.0) as u8,
                );
                let m = (p.nominal.0 + p.shift.0, p.nominal.1 + p.shift.1);
                chart
                    .draw_series([PathElement::new(vec![p.nominal, m], BLACK.mix(0.5))])
                    .map_err(err)?;
                chart
                    .draw_series([Circle::new(p.nominal, 2, BLACK.filled())])
                    .map_err(err)?;
                chart
                    .draw_series([Circle::new(m, 4, colour.stroke_width(2))])
                    .map_err(err)?;
            }
        }
        root.present().map_err(err)?;
    }
    Ok(svg)
}

/// How a point of a time series is drawn: by its result's fit verdict.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FitMark {
    /// The model fitted the measurement: a filled dot.
    Fits,
    /// It did not: a red cross.
    Misfit,
    /// No verdict recorded: a hollow dot.
    Unknown,
}

/// One value over time: x in days, the value, its standard uncertainty.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TimePoint {
    /// Days from the plot's origin.
    pub x: f64,
    /// The value.
    pub value: f64,
    /// Standard uncertainty (k = 1).
    pub u: Option<f64>,
    /// How it is drawn.
    pub verdict: FitMark,
}

/// A value over time with its u band, the moments the control was changed,
/// the acceptance limits and a trend line.
pub struct TimeSeries<'a> {
    /// Caption.
    pub title: &'a str,
    /// Unit of the values.
    pub unit: &'a str,
    /// Runs of points not separated by a change of the control; each run
    /// gets its own band.
    pub runs: Vec<Vec<TimePoint>>,
    /// When the control was changed (days).
    pub exports: Vec<f64>,
    /// Lower and upper acceptance limit.
    pub limit: Option<(f64, f64)>,
    /// A trend line from one (x, value) to another.
    pub trend: Option<((f64, f64), (f64, f64))>,
    /// The label of an x value (a date).
    pub x_label: &'a dyn Fn(f64) -> String,
}

/// A time series: the u band shaded around the line through the values,
/// dots by fit verdict, exports as vertical lines, limits as red lines,
/// the trend dashed.
pub(crate) fn time_series(p: &TimeSeries<'_>) -> PlotResult {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (W, H)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let points = || p.runs.iter().flatten();
        let xs = points()
            .map(|q| q.x)
            .chain(p.exports.iter().copied())
            .chain(p.trend.iter().flat_map(|t| [t.0.0, t.1.0]));
        let (x0, x1) = range(xs);
        let ys = points()
            .flat_map(|q| {
                let u = q.u.unwrap_or(0.0);
                [q.value - u, q.value + u]
            })
            .chain(p.limit.iter().flat_map(|l| [l.0, l.1]))
            .chain(p.trend.iter().flat_map(|t| [t.0.1, t.1.1]));
        let (y0, y1) = range(ys);
        let mut chart = ChartBuilder::on(&root)
            .caption(p.title, ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_labels(6)
            .x_label_formatter(&|x| (p.x_label)(*x))
            .y_desc(p.unit)
            .draw()
            .map_err(err)?;
        let band = BLUE.mix(0.15);
        for run in &p.runs {
            let with_u: Vec<&TimePoint> = run.iter().filter(|q| q.u.is_some()).collect();
            if with_u.len() > 1 {
                let mut poly: Vec<(f64, f64)> = with_u
                    .iter()
                    .map(|q| (q.x, q.value + q.u.unwrap_or(0.0)))
                    .collect();
                poly.extend(
                    with_u
                        .iter()
                        .rev()
                        .map(|q| (q.x, q.value - q.u.unwrap_or(0.0))),
                );
                chart
                    .draw_series(std::iter::once(Polygon::new(poly, band.filled())))
                    .map_err(err)?;
            }
            for q in &with_u {
                let u = q.u.unwrap_or(0.0);
                chart
                    .draw_series(std::iter::once(PathElement::new(
                        vec![(q.x, q.value - u), (q.x, q.value + u)],
                        BLUE.mix(0.5),
                    )))
                    .map_err(err)?;
            }
            chart
                .draw_series(LineSeries::new(run.iter().map(|q| (q.x, q.value)), BLUE))
                .map_err(err)?;
        }
        if let Some((lo, hi)) = p.limit {
            for (k, y) in [lo, hi].into_iter().enumerate() {
                let s = chart
                    .draw_series(std::iter::once(PathElement::new(
                        vec![(x0, y), (x1, y)],
                        RED.stroke_width(2),
                    )))
                    .map_err(err)?;
                if k == 0 {
                    s.label("limit")
                        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], RED));
                }
            }
        }
        let orange = RGBColor(230, 140, 0);
        for (k, &x) in p.exports.iter().enumerate() {
            let s = chart
                .draw_series(std::iter::once(PathElement::new(
                    vec![(x, y0), (x, y1)],
                    orange.stroke_width(2),
                )))
                .map_err(err)?;
            if k == 0 {
                s.label("export (control changed)")
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], orange));
            }
        }
        if let Some((a, b)) = p.trend {
            let green = RGBColor(0, 140, 60);
            chart
                .draw_series(DashedLineSeries::new(
                    vec![a, b],
                    8,
                    5,
                    green.stroke_width(2),
                ))
                .map_err(err)?
                .label("trend")
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], green));
        }
        let mut first = [true; 3];
        for q in points() {
            let (k, label) = match q.verdict {
                FitMark::Fits => (0, "fits"),
                FitMark::Misfit => (1, "misfit"),
                FitMark::Unknown => (2, "no fit verdict"),
            };
            let s = match q.verdict {
                FitMark::Fits => chart
                    .draw_series(std::iter::once(Circle::new(
                        (q.x, q.value),
                        4,
                        BLUE.filled(),
                    )))
                    .map_err(err)?,
                FitMark::Misfit => chart
                    .draw_series(std::iter::once(Cross::new(
                        (q.x, q.value),
                        5,
                        RED.stroke_width(2),
                    )))
                    .map_err(err)?,
                FitMark::Unknown => chart
                    .draw_series(std::iter::once(Circle::new(
                        (q.x, q.value),
                        4,
                        BLUE.stroke_width(2),
                    )))
                    .map_err(err)?,
            };
            if std::mem::take(&mut first[k]) {
                s.label(label).legend(move |(x, y)| match k {
                    0 => Circle::new((x + 8, y), 4, BLUE.filled()).into_dyn(),
                    1 => Cross::new((x + 8, y), 5, RED.stroke_width(2)).into_dyn(),
                    _ => Circle::new((x + 8, y), 4, BLUE.stroke_width(2)).into_dyn(),
                });
            }
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(err)?;
        root.present().map_err(err)?;
    }
    Ok(svg)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plots_are_svg_with_their_labels() {
        let s = values_with_bars(
            "location errors",
            "um",
            &[
                ("EX0B".into(), 12.0, Some(0.4)),
                ("EZ0B".into(), -5.0, None),
            ],
        )
        .unwrap();
        assert!(s.starts_with("<svg") && s.contains("EX0B") && s.contains("location errors"));
        let m = map_plot(
            "EBB(B)",
            "B, deg",
            "urad",
            &[(
                "".into(),
                vec![
                    (-90.0, 30.0, Some(2.0)),
                    (0.0, 0.0, Some(1.0)),
                    (90.0, -30.0, Some(2.0)),
                ],
            )],
        )
        .unwrap();
        assert!(m.contains("EBB(B)"));
    }
}
