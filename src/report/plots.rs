//! SVG plots (plotters, SVG backend): values with error bars, error maps
//! against angle, residuals, and the measured deviations of a pose
//! magnified (Ibaraki & Ota 2014, figs. 7-8, Ibaraki, Iritani & Matsushita 2013, fig. 5), and a value over time
//! with its u band (the machine's history).

use plotters::prelude::*;

/// A figure the drawing library could not draw, with its message.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct DrawError(String);

/// The mesh's tick labels and axis descriptions at the pages' text size.
pub(crate) trait Legible {
    /// Sets both text styles.
    fn legible(&mut self) -> &mut Self;
}

impl<X: plotters::coord::ranged1d::Ranged, Y: plotters::coord::ranged1d::Ranged, DB: DrawingBackend>
    Legible for plotters::chart::MeshStyle<'_, '_, X, Y, DB>
{
    fn legible(&mut self) -> &mut Self {
        self.label_style(("sans-serif", TEXT))
            .axis_desc_style(("sans-serif", TEXT))
    }
}

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

/// The width the report pages show a plot at, px: two side by side on a
/// 1100 px page (the report pages' style).
pub const SHOWN_WIDTH: u32 = 540;

/// Font sizes as plotters takes them: it writes `size / 1.24` px into the
/// SVG (points to pixels), and the pages show a plot at [`SHOWN_WIDTH`] of
/// its [`W`], so a size `s` reads `s / 1.24 * 540 / 720` px at 100 %
/// zoom: 20 gives 12.1 px of axis text (11 px at least, checked in
/// headless Chromium by the screenshot test), 24 the caption's 14.5 px.
pub(crate) const TEXT: u32 = 20;
const CAPTION: u32 = 24;

/// A tick label with no spurious decimals: `10`, `2.5`, `-0.04`, never
/// `10.0` or `-0`.
pub(crate) fn tick(v: &f64) -> String {
    if !v.is_finite() {
        return String::new();
    }
    // Ticks are round numbers; six decimals hold any step plotters picks
    // for the ranges drawn here (um, urad, mm, deg, days), and trimming
    // the zeros leaves only the digits that carry the step.
    let s = format!("{:.6}", v);
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".into() } else { s.to_string() }
}

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
            .caption(title, ("sans-serif", CAPTION))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(-0.5f64..(n as f64 - 0.5), y0..y1)
            .map_err(err)?;
        let names: Vec<String> = items.iter().map(|i| i.0.clone()).collect();
        chart
            .configure_mesh()
            .legible()
            .x_labels(n)
            .x_label_formatter(&|x| {
                let i = x.round();
                if (x - i).abs() < 0.01 && i >= 0.0 {
                    names.get(i as usize).cloned().unwrap_or_default()
                } else {
                    String::new()
                }
            })
            .y_label_formatter(&tick)
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
            .caption(title, ("sans-serif", CAPTION))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(err)?;
        chart
            .configure_mesh()
            .legible()
            .x_desc(x_desc)
            .y_label_formatter(&tick)
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
                .label_font(("sans-serif", TEXT))
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .draw()
                .map_err(err)?;
        }
        root.present().map_err(err)?;
    }
    Ok(svg)
}

/// Residuals by observation, coloured by pose (the page's key names the
/// poses), with the lines at plus and minus the residual standard
/// deviation, labelled.
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
                .chain([sigma.abs() * 1.6, -sigma.abs()]),
        );
        let mut chart = ChartBuilder::on(&root)
            .caption(
                "residuals (measured - model, along the normal)",
                ("sans-serif", CAPTION),
            )
            .margin(12)
            .margin_right(24)
            .x_label_area_size(44)
            .y_label_area_size(64)
            .build_cartesian_2d(0f64..n as f64, y0..y1)
            .map_err(err)?;
        chart
            .configure_mesh()
            .legible()
            .x_label_formatter(&tick)
            .y_label_formatter(&tick)
            .x_desc("point number, grouped by pose (colours: the key below)")
            .y_desc("residual, um")
            .draw()
            .map_err(err)?;
        if sigma.is_finite() {
            let grey = BLACK.mix(0.5);
            for (k, s) in [sigma, -sigma].into_iter().enumerate() {
                let series = chart
                    .draw_series(DashedLineSeries::new(
                        vec![(0.0, s), (n as f64, s)],
                        6,
                        4,
                        grey.stroke_width(1),
                    ))
                    .map_err(err)?;
                if k == 0 {
                    series
                        .label(format!(
                            "+-{} um: the residual standard deviation",
                            tick(&((sigma * 1e3).round() / 1e3))
                        ))
                        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], grey));
                }
            }
        }
        for (k, (_, pts)) in groups.iter().enumerate() {
            let (r, g, b) = super::pose_colour(k);
            let colour = RGBColor(r, g, b);
            chart
                .draw_series(
                    pts.iter()
                        .map(|p| Circle::new((p.0 as f64 + 0.5, p.1), 3, colour.filled())),
                )
                .map_err(err)?;
        }
        if sigma.is_finite() {
            chart
                .configure_series_labels()
                .label_font(("sans-serif", TEXT))
                .position(SeriesLabelPosition::UpperRight)
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .draw()
                .map_err(err)?;
        }
        root.present().map_err(err)?;
    }
    Ok(svg)
}

/// A round length (1, 2 or 5 times a power of ten) near `v`, at most `v`.
fn round_down(v: f64) -> f64 {
    if v.is_nan() || v <= 0.0 {
        return 0.0;
    }
    let p = 10f64.powf(v.log10().floor());
    let m = v / p;
    p * if m >= 5.0 {
        5.0
    } else if m >= 2.0 {
        2.0
    } else {
        1.0
    }
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
///
/// Each panel carries a scale bar: the length a deviation of a round
/// number of um is drawn at, `mag` times magnified.
pub(crate) fn pose_plot(
    title: &str,
    views: &[(String, Vec<ViewPoint>)],
    max_dev: f64,
    mag: f64,
) -> PlotResult {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (W, H)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let root = root.titled(title, ("sans-serif", CAPTION)).map_err(err)?;
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
                .caption(name, ("sans-serif", TEXT))
                .margin(8)
                .margin_right(20)
                .x_label_area_size(44)
                .y_label_area_size(56)
                .build_cartesian_2d(x0..x1, y0..y1)
                .map_err(err)?;
            chart
                .configure_mesh()
                .legible()
                .x_label_formatter(&tick)
                .y_label_formatter(&tick)
                .x_desc("mm")
                .y_desc("mm")
                .draw()
                .map_err(err)?;
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
            // The scale bar, bottom left: about a fifth of the panel.
            let bar_um = round_down(0.2 * (x1 - x0) / (mag.max(1.0) * 1e-3));
            if bar_um > 0.0 {
                let len = bar_um * 1e-3 * mag.max(1.0);
                let (bx, by) = (x0 + 0.05 * (x1 - x0), y0 + 0.06 * (y1 - y0));
                chart
                    .draw_series([
                        PathElement::new(vec![(bx, by), (bx + len, by)], BLACK.stroke_width(3)),
                        PathElement::new(
                            vec![(bx, by - 0.015 * (y1 - y0)), (bx, by + 0.015 * (y1 - y0))],
                            BLACK.stroke_width(2),
                        ),
                        PathElement::new(
                            vec![
                                (bx + len, by - 0.015 * (y1 - y0)),
                                (bx + len, by + 0.015 * (y1 - y0)),
                            ],
                            BLACK.stroke_width(2),
                        ),
                    ])
                    .map_err(err)?;
                chart
                    .draw_series([Text::new(
                        format!("{} um (x{})", tick(&bar_um), tick(&mag)),
                        (bx, by + 0.03 * (y1 - y0)),
                        TextStyle::from(("sans-serif", TEXT).into_font()).pos(
                            plotters::style::text_anchor::Pos::new(
                                plotters::style::text_anchor::HPos::Left,
                                plotters::style::text_anchor::VPos::Bottom,
                            ),
                        ),
                    )])
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
    /// The label of an x value (a date, with the time when the series
    /// spans a few days).
    pub x_label: &'a dyn Fn(f64) -> String,
    /// What the x axis shows (`date and time (UTC)`).
    pub x_desc: &'a str,
}

/// Points measured at the same time (within 0.3 % of the plot's span) set
/// side by side, 1.2 % of the span apart, so that none hides another.
fn side_by_side(runs: &[Vec<TimePoint>], span: f64) -> Vec<Vec<TimePoint>> {
    let mut xs: Vec<f64> = runs.iter().flatten().map(|q| q.x).collect();
    xs.sort_by(f64::total_cmp);
    let near = 0.003 * span;
    let step = 0.012 * span;
    // The k-th of n points sharing a time goes (k - (n - 1) / 2) steps off.
    let mut seen: Vec<(f64, usize)> = Vec::new();
    runs.iter()
        .map(|run| {
            run.iter()
                .map(|q| {
                    let n = xs.iter().filter(|x| (*x - q.x).abs() <= near).count();
                    let k = match seen.iter_mut().find(|(x, _)| (x - q.x).abs() <= near) {
                        Some(e) => {
                            e.1 += 1;
                            e.1 - 1
                        }
                        None => {
                            seen.push((q.x, 1));
                            0
                        }
                    };
                    TimePoint {
                        x: q.x + (k as f64 - (n as f64 - 1.0) / 2.0) * step,
                        ..*q
                    }
                })
                .collect()
        })
        .collect()
}

/// A time series: the u band shaded around the line through the values,
/// dots by fit verdict, exports as vertical lines, limits as red lines,
/// the trend dashed.
pub(crate) fn time_series(p: &TimeSeries<'_>) -> PlotResult {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (W, H)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let span = {
            let xs = p.runs.iter().flatten().map(|q| q.x);
            let (lo, hi) = range(xs);
            hi - lo
        };
        let runs = side_by_side(&p.runs, span);
        let points = || runs.iter().flatten();
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
            .caption(p.title, ("sans-serif", CAPTION))
            .margin(12)
            // Room for half of the last tick label beyond the plot.
            .margin_right(64)
            .x_label_area_size(48)
            .y_label_area_size(64)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(err)?;
        chart
            .configure_mesh()
            .legible()
            .x_labels(5)
            .x_label_formatter(&|x| (p.x_label)(*x))
            .y_label_formatter(&tick)
            .x_desc(p.x_desc)
            .y_desc(p.unit)
            .draw()
            .map_err(err)?;
        let band = BLUE.mix(0.15);
        for run in &runs {
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
            .label_font(("sans-serif", TEXT))
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
    fn ticks_carry_no_spurious_decimals() {
        assert_eq!(tick(&10.0), "10");
        assert_eq!(tick(&2.5), "2.5");
        assert_eq!(tick(&-0.04), "-0.04");
        assert_eq!(tick(&-0.0), "0");
        assert_eq!(tick(&(0.1 + 0.2)), "0.3");
        assert_eq!(tick(&-1e-9), "0");
        assert_eq!(tick(&f64::NAN), "");
    }

    #[test]
    fn points_at_one_time_are_set_side_by_side_and_others_stay() {
        let p = |x| TimePoint {
            x,
            value: 1.0,
            u: None,
            verdict: FitMark::Fits,
        };
        // Span 10 days: step 0.12 days; the two at day 0 go to -0.06 and
        // +0.06, the one at day 10 stays.
        let runs = vec![vec![p(0.0), p(10.0)], vec![p(0.0)]];
        let out = side_by_side(&runs, 10.0);
        assert!((out[0][0].x + 0.06).abs() < 1e-12, "{:?}", out);
        assert_eq!(out[0][1].x, 10.0);
        assert!((out[1][0].x - 0.06).abs() < 1e-12, "{:?}", out);
    }

    #[test]
    fn the_pose_plot_has_a_scale_bar_in_um_and_text_of_the_legible_size() {
        let pts = vec![
            ViewPoint {
                nominal: (0.0, 0.0),
                shift: (1.0, 0.0),
                deviation_um: 5.0,
            },
            ViewPoint {
                nominal: (50.0, 50.0),
                shift: (0.0, -1.0),
                deviation_um: -5.0,
            },
        ];
        let s = pose_plot("pose", &[("top".into(), pts)], 5.0, 200.0).unwrap();
        // The panel spans about 64 mm: a fifth is 12.8 mm, 64 um at x200,
        // rounded down to 50 um.
        // (plotters writes a text's content on a line of its own)
        assert!(s.contains("\n50 um (x200)\n"), "{s}");
        // plotters writes size / 1.24 px.
        assert!(s.contains(&format!("font-size=\"{}\"", f64::from(TEXT) / 1.24)));
        assert!(!s.contains("\n10.0\n") && s.contains("\n10\n"), "{s}");
    }

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
