//! The `--report DIR` output of `analyze`: an HTML page with SVG plots (the
//! measured deviations of every pose magnified, the location errors and the
//! error maps against angle with their error bars, the residuals) and a
//! `.glb` of the measured points with the deviations magnified and
//! coloured. Every file is written atomically.

pub mod ball_bar;
pub(crate) mod glb;
pub mod laser;
pub mod nine_section;
pub mod plots;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use nalgebra::{Point3, Vector3};

use crate::analyze::IdentifiedPiece;
use crate::analyze::uncertainty::McResult;
use crate::errorfile::ErrorFile;
use crate::formats::manifest::TestKind;
use crate::identify::{Dataset, Identification};
use crate::io::{OutputError, StagedDir};
use crate::kinematics::symbols::Unit;
use crate::model::Effect;
use glb::ShownPoint;
use plots::ViewPoint;

/// What goes into a report.
pub struct ReportInput<'a> {
    /// Page title (test and piece).
    pub title: String,
    /// The measurements.
    pub data: &'a Dataset,
    /// The identification.
    pub est: &'a Identification,
    /// The uncertainties reported (Monte Carlo or covariance).
    pub u: Vec<Option<f64>>,
    /// The Monte-Carlo study, if run.
    pub mc: Option<&'a McResult>,
    /// The error file written.
    pub error_file: &'a ErrorFile,
    /// A sphere test: its few touches per pose are drawn as one plot of
    /// the sphere's centre per pose, not a plot per pose.
    pub sphere: bool,
    /// The `fivecal discover` command on the same plan and measurements,
    /// as `analyze` prints it under a misfit.
    pub discover: String,
}

impl<'a> ReportInput<'a> {
    /// The report of an analysed piece of test `test`, planned in the
    /// plan file `manifest`.
    pub fn for_piece(test: &str, piece: &'a IdentifiedPiece, manifest: &Path) -> ReportInput<'a> {
        ReportInput {
            title: format!("{test}: {}", piece.name()),
            sphere: test == "probe-sphere",
            data: &piece.data,
            est: &piece.est,
            u: piece.u.clone(),
            mc: piece.monte_carlo.as_ref().map(|s| &s.result),
            error_file: &piece.file,
            discover: crate::analyze::goodness::discover_command(manifest, &piece.data.files),
        }
    }
}

/// Why a report could not be written.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// Writing failed.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// A plot failed.
    #[error("plot {0}: {1}")]
    Plot(String, plots::DrawError),
}

/// Each observation's nominal point, normal and measured deviation along
/// the normal (um), in the frame the piece is drawn in: W for a machined
/// piece (through the identified placement), the machine frame for
/// probing.
pub fn deviations(data: &Dataset, est: &Identification) -> Vec<ShownPoint> {
    let kin = &est.model.kin;
    (0..data.obs.len())
        .map(|k| {
            let p = data.point(k);
            let m = data.obs[k].m;
            match data.kind {
                TestKind::Machining => {
                    let w = match &est.placement {
                        Some(pl) => (pl.inverse() * Point3::from(m)).coords,
                        None => m,
                    };
                    ShownPoint {
                        nominal: p.p,
                        normal: p.n,
                        deviation_um: p.n.dot(&(w - p.p)) * 1e3,
                    }
                }
                TestKind::Probing => {
                    let t = kin.nominal_table_transform(p.tilt, p.c);
                    let q = (t * Point3::from(p.p)).coords;
                    let n = t.rotation * p.n;
                    ShownPoint {
                        nominal: q,
                        normal: n,
                        deviation_um: n.dot(&(m - q)) * 1e3,
                    }
                }
            }
        })
        .collect()
}

/// A round magnification (1, 2 or 5 times a power of ten) that shows the
/// largest deviation at about `fraction` of `extent_mm`.
pub(crate) fn magnification(max_dev_um: f64, extent_mm: f64, fraction: f64) -> f64 {
    if max_dev_um <= 0.0 || extent_mm <= 0.0 {
        return 1.0;
    }
    let raw = fraction * extent_mm / (max_dev_um * 1e-3);
    let p = 10f64.powf(raw.log10().floor());
    let m = raw / p;
    let step = if m >= 5.0 {
        5.0
    } else if m >= 2.0 {
        2.0
    } else {
        1.0
    };
    (step * p).max(1.0)
}

/// The opening of a report page in the reports' style, up to its `<h1>`.
pub(crate) fn page_start(title: &str) -> String {
    format!(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{t}</title>\n<style>body{{font-family:sans-serif;max-width:1100px;margin:2em auto;color:#222}}table{{border-collapse:collapse}}td,th{{border:1px solid #ccc;padding:2px 8px;text-align:right}}th{{background:#eee}}td.l{{text-align:left}}pre{{background:#f6f6f6;padding:8px;white-space:pre-wrap;overflow-wrap:anywhere}}.grid{{display:flex;flex-wrap:wrap}}.grid img{{width:540px}}figure{{margin:0 8px 8px 0}}.key span{{white-space:nowrap;margin-right:8px}}</style></head><body>\n<h1>{t}</h1>\n",
        t = esc(title)
    )
}

/// Text escaped for HTML.
pub(crate) fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn fmt_opt(u: Option<f64>) -> String {
    u.map_or("-".into(), |u| format!("{u:.3}"))
}

/// Writes the report into `dir`; returns the files written.
pub fn write(dir: &Path, r: &ReportInput<'_>) -> Result<Vec<PathBuf>, ReportError> {
    // Every file is staged: the report appears whole or not at all.
    let mut files = StagedDir::create(dir)?;
    let mut figs = location_figures(r, &mut files)?;
    figs.extend(map_figures(r, &mut files)?);
    let shown = deviations(r.data, r.est);
    let (max_dev, mag) = shown_magnification(&shown);
    let (pose_figs, unfixed) = if r.sphere {
        centre_figure(r.data, &shown, &mut files)?
    } else {
        (
            pose_figures(r, &shown, max_dev, mag, &mut files)?,
            Vec::new(),
        )
    };
    let groups = residual_groups(r.data, &r.est.residuals);
    put(
        &mut files,
        "residuals.svg",
        plot(
            "residuals.svg",
            plots::residual_plot(&groups, r.est.sigma_um),
        )?
        .as_bytes(),
    )?;
    let poses: Vec<(String, Vec<usize>)> = r
        .data
        .poses
        .iter()
        .map(|p| (p.id.clone(), p.obs.clone()))
        .collect();
    put(&mut files, "piece.glb", &glb::glb(&shown, mag, &poses))?;
    let h = page(r, &figs, &pose_figs, &unfixed, mag);
    put(&mut files, "index.html", h.as_bytes())?;
    Ok(files.commit()?)
}

/// Stages one file of the report.
fn put(files: &mut StagedDir, name: &str, bytes: &[u8]) -> Result<(), ReportError> {
    files.write(Path::new(name), bytes)?;
    Ok(())
}

/// A plot's text, or the error naming its file.
fn plot(name: &str, res: plots::PlotResult) -> Result<String, ReportError> {
    res.map_err(|e| ReportError::Plot(name.into(), e))
}

/// The plots of the identifiable location errors with their error bars,
/// lengths and angles apart: (file, caption) of each.
fn location_figures(
    r: &ReportInput<'_>,
    files: &mut StagedDir,
) -> Result<Vec<(String, String)>, ReportError> {
    let est = r.est;
    let mut figs: Vec<(String, String)> = Vec::new();
    if let Some(e) = est.model.find("location") {
        let range = est.model.param_range(e);
        if let Effect::Location { symbols } = &est.model.effects[e] {
            for (unit, title) in [
                (Unit::Um, "location errors: positions"),
                (Unit::Urad, "location errors: orientations"),
            ] {
                let items: Vec<(String, f64, Option<f64>)> = symbols
                    .iter()
                    .enumerate()
                    .filter(|(_, s)| est.model.symbols.location[**s].unit == unit)
                    .filter(|(k, _)| est.identifiable(range.start + k))
                    .map(|(k, s)| {
                        let i = range.start + k;
                        (
                            est.model.symbols.location[*s].name.clone(),
                            est.theta[i],
                            r.u[i],
                        )
                    })
                    .collect();
                if !items.is_empty() {
                    let file = format!("location-{unit}.svg");
                    put(
                        files,
                        &file,
                        plot(
                            &file,
                            plots::values_with_bars(title, &unit.to_string(), &items),
                        )?
                        .as_bytes(),
                    )?;
                    figs.push((
                        file,
                        format!("{title} (error bars: standard uncertainty, k = 1)"),
                    ));
                }
            }
        }
    }
    Ok(figs)
}

/// The plot of each error map against angle (one line per tilt node for
/// a map over both axes): (file, caption) of each.
fn map_figures(
    r: &ReportInput<'_>,
    files: &mut StagedDir,
) -> Result<Vec<(String, String)>, ReportError> {
    let est = r.est;
    let mut figs = Vec::new();
    for (ei, e) in est.model.effects.iter().enumerate() {
        let Effect::Map { symbol, grid } = e else {
            continue;
        };
        let ms = &est.model.symbols.maps[*symbol];
        let range = est.model.param_range(ei);
        let tilt = est.model.symbols.tilt;
        let node = |i: usize| -> Option<plots::MapNode> {
            let k = range.start + i;
            est.identifiable(k).then(|| {
                let a = grid.node_angles(i);
                (a.last().map_or(0.0, |x| x.1), est.theta[k], r.u[k])
            })
        };
        let rows: Vec<(String, Vec<plots::MapNode>)> = if grid.dims.len() == 1 {
            vec![(String::new(), (0..grid.len()).filter_map(node).collect())]
        } else {
            let nc = grid.dims[1].nodes.len();
            grid.dims[0]
                .nodes
                .iter()
                .enumerate()
                .map(|(row, t)| {
                    (
                        format!("{tilt} = {t}"),
                        (0..nc).filter_map(|c| node(row * nc + c)).collect(),
                    )
                })
                .collect()
        };
        if rows.iter().all(|r| r.1.is_empty()) {
            continue;
        }
        let x_desc = if grid.dims.len() == 1 {
            format!("{tilt}, deg")
        } else {
            "C, deg".into()
        };
        let file = format!("map-{}.svg", ms.name.replace(['(', ')', ','], "_"));
        put(
            files,
            &file,
            plot(
                &file,
                plots::map_plot(&ms.name, &x_desc, &ms.unit.to_string(), &rows),
            )?
            .as_bytes(),
        )?;
        figs.push((
            file,
            format!(
                "{} against angle (added to the location error; error bars k = 1)",
                ms.name
            ),
        ));
    }
    Ok(figs)
}

/// The largest deviation (um) and the magnification that shows it at 8 %
/// of the piece's extent.
fn shown_magnification(shown: &[ShownPoint]) -> (f64, f64) {
    let max_dev = shown
        .iter()
        .fold(0.0f64, |a, p| a.max(p.deviation_um.abs()));
    let extent = {
        let (lo, hi) = shown.iter().fold(
            (
                Vector3::repeat(f64::INFINITY),
                Vector3::repeat(f64::NEG_INFINITY),
            ),
            |(lo, hi), p| (lo.inf(&p.nominal), hi.sup(&p.nominal)),
        );
        (hi - lo).max()
    };
    (max_dev, magnification(max_dev, extent.max(1.0), 0.08))
}

/// The plot of each pose's deviations, magnified, seen along the tool axis
/// and from the side: the file of each.
fn pose_figures(
    r: &ReportInput<'_>,
    shown: &[ShownPoint],
    max_dev: f64,
    mag: f64,
    files: &mut StagedDir,
) -> Result<Vec<String>, ReportError> {
    let data = r.data;
    let kin = &r.est.model.kin;
    let mut pose_figs = Vec::new();
    for pose in &data.poses {
        let inv = kin.nominal_table_transform(pose.tilt, pose.c).inverse();
        let (e1, e2, u) = match data.kind {
            TestKind::Machining => (
                inv.rotation * Vector3::x(),
                inv.rotation * Vector3::y(),
                inv.rotation * Vector3::z(),
            ),
            TestKind::Probing => (Vector3::x(), Vector3::y(), Vector3::z()),
        };
        let view = |a: &Vector3<f64>, b: &Vector3<f64>| -> Vec<ViewPoint> {
            pose.obs
                .iter()
                .map(|&k| {
                    let s = &shown[k];
                    let d = s.normal * (s.deviation_um * 1e-3 * mag);
                    ViewPoint {
                        nominal: (s.nominal.dot(a), s.nominal.dot(b)),
                        shift: (d.dot(a), d.dot(b)),
                        deviation_um: s.deviation_um,
                    }
                })
                .collect()
        };
        let title = format!(
            "pose {} ({} = {}, C = {}): deviations x{mag}",
            pose.id, data.plan.tilt_letter, pose.tilt, pose.c
        );
        let views = vec![
            ("along the tool axis (X, Y)".to_string(), view(&e1, &e2)),
            ("side (X, Z)".to_string(), view(&e1, &u)),
        ];
        let file = format!("pose-{}.svg", pose.id);
        put(
            files,
            &file,
            plot(&file, plots::pose_plot(&title, &views, max_dev, mag))?.as_bytes(),
        )?;
        pose_figs.push(file);
    }
    Ok(pose_figs)
}

/// The sphere's centre at each pose, measured less nominal (um, machine
/// frame), from its touches' deviations along their normals, or `None`
/// where the touches do not fix it (fewer than three independent
/// directions). A touch on a sphere whose centre is off by t deviates by
/// n . t along its normal n, so t is the least-squares solution of those
/// equations.
pub(crate) fn centre_shift(points: &[&ShownPoint]) -> Option<Vector3<f64>> {
    let mut a = nalgebra::Matrix3::<f64>::zeros();
    let mut b = Vector3::zeros();
    for p in points {
        a += p.normal * p.normal.transpose();
        b += p.normal * p.deviation_um;
    }
    // Every direction seen by a tenth of the touches' weight at least:
    // a pose probed from one side only leaves the centre open along it.
    let eig = a.symmetric_eigenvalues();
    if points.len() < 3 || eig.min() < 0.1 * eig.sum() / 3.0 {
        return None;
    }
    a.cholesky().map(|c| c.solve(&b))
}

/// The sphere test's deviations: the plot of its centre per pose, and the
/// poses whose touches do not fix it (`unfixed`).
fn sphere_section(h: &mut String, r: &ReportInput<'_>, figs: &[String], unfixed: &[String]) {
    let first = r.data.poses.first().map_or("", |p| p.id.as_str());
    let _ = writeln!(
        h,
        "<h2>The sphere's centre per pose</h2>\n<p>Each pose's touches on the sphere give where its centre was: measured less nominal, um, along the machine's X, Y and Z, the poses in measuring order (pose 1 is {}). An axis' location error draws the centre round a circle as the axis turns; drift draws it away over time. The touches in 3-D, one colour per pose: <a href=\"piece.glb\">piece.glb</a>.</p>\n<div class=grid>",
        esc(first)
    );
    for f in figs {
        let _ = writeln!(h, "<img src=\"{f}\" alt=\"{f}\">");
    }
    if !unfixed.is_empty() {
        let _ = writeln!(
            h,
            "</div>\n<p>Not drawn: {} (their touches do not fix the centre in every direction).</p>\n<div>",
            esc(&unfixed.join(", "))
        );
    }
}

/// The sphere test's one plot of the sphere's centre per pose (X, Y and Z
/// of its shift, in measuring order): a sphere's four or five touches per
/// pose, drawn pose by pose, would be fifty plots of a few dots, while the
/// centre's path over the poses is what shows an axis' error. Poses whose
/// touches do not fix the centre are named below the plot.
fn centre_figure(
    data: &Dataset,
    shown: &[ShownPoint],
    files: &mut StagedDir,
) -> Result<(Vec<String>, Vec<String>), ReportError> {
    let mut unfixed = Vec::new();
    let mut rows: Vec<(String, Vec<plots::MapNode>)> = ["X", "Y", "Z"]
        .iter()
        .map(|a| (a.to_string(), Vec::new()))
        .collect();
    for (k, pose) in data.poses.iter().enumerate() {
        let pts: Vec<&ShownPoint> = pose.obs.iter().map(|&i| &shown[i]).collect();
        match centre_shift(&pts) {
            Some(t) => {
                for (row, v) in rows.iter_mut().zip(t.iter()) {
                    row.1.push((k as f64 + 1.0, *v, None));
                }
            }
            None => unfixed.push(pose.id.clone()),
        }
    }
    if rows[0].1.is_empty() {
        return Ok((Vec::new(), unfixed));
    }
    let file = "sphere-centres.svg";
    put(
        files,
        file,
        plot(
            file,
            plots::map_plot(
                "sphere centre per pose, measured - nominal",
                "pose, in measuring order",
                "um",
                &rows,
            ),
        )?
        .as_bytes(),
    )?;
    Ok((vec![file.to_string()], unfixed))
}

/// The report page: what was measured, the fit verdict, what the test
/// identifies, the results table and plots, the deviations, the residuals
/// and the notes.
fn page(
    r: &ReportInput<'_>,
    figs: &[(String, String)],
    pose_figs: &[String],
    unfixed: &[String],
    mag: f64,
) -> String {
    let (est, data) = (r.est, r.data);
    let kin = &est.model.kin;
    let mut h = page_start(&r.title);
    // The page opens with the verdict: whether anything below may be
    // acted on.
    fit_section(&mut h, r);
    let _ = writeln!(
        h,
        "<p>Machine <b>{}</b>, method <b>{}</b>, {} points in {} poses from {}.</p>",
        esc(&kin.machine().name),
        est.method,
        data.obs.len(),
        data.poses.len(),
        esc(&data
            .files
            .iter()
            .map(|f| f.display().to_string())
            .collect::<Vec<_>>()
            .join(", "))
    );
    let _ = writeln!(
        h,
        "<h2>What the test identifies</h2>\n<pre>{}</pre>",
        esc(&est.identifiability.render())
    );
    results_section(&mut h, r, figs);
    if r.sphere {
        sphere_section(&mut h, r, pose_figs, unfixed);
    } else {
        let _ = writeln!(
            h,
            "<h2>Measured deviations, magnified x{mag}</h2>\n<p>Dots: nominal points; circles: measured points, their deviation along the surface normal magnified {mag} times (the bar in each plot: that many um, drawn magnified); blue: measured inside the nominal surface, red: outside it. The same in 3-D, one colour per pose: <a href=\"piece.glb\">piece.glb</a>.</p>\n<div class=grid>"
        );
        for f in pose_figs {
            let _ = writeln!(h, "<img src=\"{f}\" alt=\"{f}\">");
        }
    }
    h.push_str("</div>\n<h2>Residuals</h2>\n<img src=\"residuals.svg\" alt=\"residuals\">\n");
    h.push_str(&pose_key(data));
    h.push_str("<table><tr><th>pose</th><th>face</th><th>points</th><th>mean um</th><th>rms um</th><th>max um</th></tr>\n");
    for row in est.residual_table(data) {
        let _ = writeln!(
            h,
            "<tr><td class=l>{}</td><td class=l>{}</td><td>{}</td><td>{:.3}</td><td>{:.3}</td><td>{:.3}</td></tr>",
            esc(&row.pose),
            esc(&row.face),
            row.points,
            row.mean_um,
            row.rms_um,
            row.max_um
        );
    }
    h.push_str("</table>\n");
    let notes: Vec<&String> = data.warnings.iter().chain(&est.notes).collect();
    if !notes.is_empty() {
        h.push_str("<h2>Notes</h2><ul>\n");
        for n in notes {
            let _ = writeln!(h, "<li>{}</li>", esc(n));
        }
        h.push_str("</ul>\n");
    }
    let _ = writeln!(h, "<h2>Next step</h2>\n<p>{}</p>", next_step(r));
    h.push_str("</body></html>\n");
    h
}

/// The colour of the `k`-th pose: its dots in the residual plot (the
/// page's key lists the poses in these colours) and its segments in the
/// `.glb`.
pub(crate) fn pose_colour(k: usize) -> (u8, u8, u8) {
    use plotters::style::{Color as _, Palette as _};
    let c = plotters::style::Palette99::pick(k).to_rgba();
    (c.0, c.1, c.2)
}

/// The residual plot's key: each pose in the colour the plot gives it.
pub(crate) fn pose_key(data: &Dataset) -> String {
    let mut h = String::from("<p class=key>Poses: ");
    for (k, p) in data.poses.iter().enumerate() {
        let (r, g, b) = pose_colour(k);
        let _ = write!(
            h,
            "<span><b style=\"color:#{r:02x}{g:02x}{b:02x}\">&#9679;</b> {}</span> ",
            esc(&p.id)
        );
    }
    h.push_str("</p>\n");
    h
}

/// What to do with this result, by its fit verdict.
fn next_step(r: &ReportInput<'_>) -> String {
    use crate::errorfile::FitVerdict;
    match r.error_file.fit.as_ref().map(|f| f.verdict) {
        Some(FitVerdict::NotConverged) => "The values are no estimate. Look at the residual table for a pose or face far off the rest (a mislabelled point, a wrong plan or measurement file), correct it and run <code>fivecal analyze</code> again; if nothing stands out, try another <code>--method</code>.".to_string(),
        Some(FitVerdict::Misfit) => format!(
            "Find the effect the model lacks, on the same plan and measurements:<pre>{}</pre>then compensate with the model it finds.",
            esc(&r.discover)
        ),
        _ => format!(
            "Export the result to the control (<code>fivecal compensate --machine {m} --errors RESULT --export CONTROLLER</code>, RESULT the result file analyze wrote) or compensate part programs with it (<code>fivecal compensate --machine {m} --errors RESULT PART.nc -o PART-comp.nc</code>); after the change, run the test again and compare the two results with <code>fivecal verify</code>.",
            m = esc(&r.est.model.kin.machine().name)
        ),
    }
}

/// The page's fit verdict, if the result file has one: a warning box when
/// the model does not fit.
fn fit_section(h: &mut String, r: &ReportInput<'_>) {
    if let Some(f) = &r.error_file.fit {
        let line = format!(
            "Residuals {:.3} um against {:.3} um expected ({}): ratio {:.2}, p {} over {} degrees of freedom.",
            f.sigma_um,
            f.expected_um,
            f.expected_from,
            f.ratio,
            crate::numbers::p_value(f.p_value),
            f.dof
        );
        let mut line = line;
        if let Some(on) = &f.on {
            line.push_str(&format!(" Judged on {on}."));
        }
        for a in &f.set_aside {
            line.push_str(&format!(
                " Set aside from the estimate and judged here with the rest: {a}."
            ));
        }
        if f.verdict == crate::errorfile::FitVerdict::NotConverged {
            let _ = writeln!(
                h,
                "<div style=\"border:3px solid #c00;background:#fee;padding:8px\"><b>Verdict: the fit did not converge.</b> {} Its values are no estimate: <code>fivecal compensate</code>, its export and <code>fivecal verify</code> refuse this result.</div>",
                esc(f.stopped.as_deref().unwrap_or("The fit stopped."))
            );
        } else if f.verdict == crate::errorfile::FitVerdict::Misfit {
            let _ = writeln!(
                h,
                "<div style=\"border:3px solid #c00;background:#fee;padding:8px\"><b>Verdict: the model does not fit.</b> {} The values are biased by an effect the model lacks (or the stated noise is too small); their u is widened by the ratio, and <code>fivecal compensate</code> refuses this result without <code>--accept-misfit</code>. Find the missing effect with:<pre>{}</pre></div>",
                esc(&line),
                esc(&r.discover)
            );
        } else {
            let _ = writeln!(h, "<p><b>Verdict: the model fits.</b> {}</p>", esc(&line));
        }
    }
}

/// The page's results: every parameter with its value and u (or "not
/// identifiable"), the reasons for those not identifiable, and the plots of
/// the values.
fn results_section(h: &mut String, r: &ReportInput<'_>, figs: &[(String, String)]) {
    let est = r.est;
    let names = est.model.param_names();
    let units = est.model.param_units();
    let explained = r.error_file.uncertainty.as_ref();
    let _ = writeln!(
        h,
        "<h2>Results</h2>\n<p>Residual standard deviation {:.3} um ({} degrees of freedom). Uncertainties are standard uncertainties (k = 1); u holds {}.{}</p>",
        est.sigma_um,
        est.dof,
        match (explained, r.mc) {
            (Some(x), _) => esc(&x.basis),
            (None, Some(mc)) => format!("a Monte-Carlo study of {} runs", mc.runs),
            (None, None) => "the measurement noise only (the residual-scaled covariance)".into(),
        },
        match explained.and_then(|x| x.widened_by) {
            Some(w) => format!(" Every u is widened by the ratio {w:.2}: the model does not fit."),
            None => String::new(),
        }
    );
    h.push_str("<table><tr><th>parameter</th><th>value</th><th>u</th><th>u noise only</th><th>unit</th><th class=l>largest contributors (share of u&sup2;)</th></tr>\n");
    for i in 0..est.theta.len() {
        if est.identifiable(i) {
            let x = explained.and_then(|x| x.values.get(&names[i]));
            let largest = x.map_or(String::new(), |x| {
                x.largest
                    .iter()
                    .map(|s| format!("{} {:.0} %", esc(&s.contributor), s.share * 100.0))
                    .collect::<Vec<_>>()
                    .join(", ")
            });
            let _ = writeln!(
                h,
                "<tr><td class=l>{}</td><td>{:.3}</td><td>{}</td><td>{}</td><td class=l>{}</td><td class=l>{}</td></tr>",
                esc(&names[i]),
                est.theta[i],
                fmt_opt(r.u[i]),
                fmt_opt(x.and_then(|x| x.u_noise)),
                units[i],
                largest
            );
        } else {
            let _ = writeln!(
                h,
                "<tr><td class=l>{}</td><td>not identifiable</td><td></td><td></td><td class=l>{}</td><td></td></tr>",
                esc(&names[i]),
                units[i]
            );
        }
    }
    h.push_str("</table>\n");
    if let Some(x) = explained
        && !x.not_included.is_empty()
    {
        h.push_str("<p>Not included in any u (the model has no effect for them):</p><ul>\n");
        for n in &x.not_included {
            let _ = writeln!(h, "<li>{}</li>", esc(n));
        }
        h.push_str("</ul>\n");
    }
    if !r.error_file.seen_not_usefully.is_empty() {
        h.push_str("<h3>Seen, but not usefully</h3><p>Their u is above the threshold: not counted as identified, not exported, not compensated.</p><ul>\n");
        for n in &r.error_file.seen_not_usefully {
            let _ = writeln!(
                h,
                "<li><b>{}</b> = {:.3}, u = {:.3} &gt; {:.3} ({})</li>",
                esc(&n.symbol),
                n.value,
                n.u,
                n.threshold,
                esc(&n.from)
            );
        }
        h.push_str("</ul>\n");
    }
    if !r.error_file.not_identifiable.is_empty() {
        h.push_str("<h3>Not identifiable</h3><ul>\n");
        for n in &r.error_file.not_identifiable {
            let _ = writeln!(h, "<li><b>{}</b>: {}</li>", esc(&n.symbol), esc(&n.reason));
        }
        h.push_str("</ul>\n");
    }
    h.push_str("<div class=grid>\n");
    for (f, cap) in figs {
        let _ = writeln!(
            h,
            "<figure><img src=\"{f}\" alt=\"{c}\"><figcaption>{c}</figcaption></figure>",
            c = esc(cap)
        );
    }
    h.push_str("</div>\n");
}

/// Residuals grouped by pose for the residual plot: (pose id, (running
/// index, residual um)), in pose order.
pub(crate) fn residual_groups(data: &Dataset, r: &[f64]) -> Vec<(String, Vec<(usize, f64)>)> {
    let mut i = 0;
    data.poses
        .iter()
        .map(|p| {
            let v = p
                .obs
                .iter()
                .map(|&k| {
                    i += 1;
                    (i - 1, r.get(k).copied().unwrap_or(f64::NAN))
                })
                .collect();
            (p.id.clone(), v)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn touch(normal: Vector3<f64>, t: &Vector3<f64>) -> ShownPoint {
        let n = normal.normalize();
        ShownPoint {
            nominal: 25.0 * n,
            normal: n,
            deviation_um: n.dot(t),
        }
    }

    /// A sphere probed at its pole and at four points round its equator,
    /// 45 deg down, and shifted by t: the touches' deviations along their
    /// normals give t back. Touches in one plane leave the centre open
    /// across it, and the pose is not drawn.
    #[test]
    fn the_sphere_centre_of_a_pose_is_its_touches_shift() {
        let t = Vector3::new(3.0, -7.5, 12.0);
        let normals = [
            Vector3::new(0.0, 0.0, 1.0),
            Vector3::new(1.0, 0.0, 1.0),
            Vector3::new(-1.0, 0.0, 1.0),
            Vector3::new(0.0, 1.0, 1.0),
            Vector3::new(0.0, -1.0, 1.0),
        ];
        let pts: Vec<ShownPoint> = normals.iter().map(|n| touch(*n, &t)).collect();
        let refs: Vec<&ShownPoint> = pts.iter().collect();
        let got = centre_shift(&refs).unwrap();
        assert!((got - t).norm() < 1e-9, "{got}");
        let flat: Vec<ShownPoint> = [
            Vector3::new(1.0, 0.0, 0.0),
            Vector3::new(0.0, 1.0, 0.0),
            Vector3::new(-1.0, 0.0, 0.0),
            Vector3::new(0.0, -1.0, 0.0),
        ]
        .iter()
        .map(|n| touch(*n, &t))
        .collect();
        assert!(centre_shift(&flat.iter().collect::<Vec<_>>()).is_none());
        assert!(centre_shift(&refs[..1]).is_none());
    }

    #[test]
    fn magnification_is_round_and_shows_the_deviation_at_the_fraction() {
        // 10 um on a 100 mm piece at 8 %: 800 -> 500.
        assert_eq!(magnification(10.0, 100.0, 0.08), 500.0);
        assert_eq!(magnification(40.0, 100.0, 0.08), 200.0);
        assert_eq!(magnification(0.0, 100.0, 0.08), 1.0);
    }
}
