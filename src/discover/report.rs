//! The `--report DIR` page of `discover`: the gap shrinking step by step
//! (RMS and maximum after each added effect), the residual patterns before
//! and after (by observation, grouped by pose, with the breakdowns by face,
//! direction and sequence), each step's effect with its values, and every
//! candidate's verdict. SVG plots through plotters, like `analyze`'s
//! report ([`crate::report::plots`]); every file is written atomically.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use plotters::prelude::*;

use super::Discovery;
use super::gap::{Gap, Group};
use super::story::{CandidateVerdict, Story};
use crate::identify::Dataset;
use crate::io::StagedDir;
use crate::report::ReportError;
use crate::report::plots::{self, PlotResult, TEXT, err, tick};

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The gap after each state (start, then each step): RMS and maximum, with
/// the final residual sigma as the floor it can reach.
pub(crate) fn gap_plot(labels: &[String], rms: &[f64], max: &[f64], sigma: f64) -> PlotResult {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (760, 400)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let n = labels.len().max(1);
        let top = max
            .iter()
            .chain(rms)
            .copied()
            .filter(|v| v.is_finite())
            .fold(0.0f64, f64::max)
            .max(if sigma.is_finite() { sigma } else { 0.0 })
            * 1.12
            + 1e-6;
        let mut chart = ChartBuilder::on(&root)
            .caption("the gap, step by step", ("sans-serif", TEXT + 4))
            .margin(12)
            .x_label_area_size(48)
            .y_label_area_size(60)
            .build_cartesian_2d(-0.5f64..(n as f64 - 0.5), 0f64..top)
            .map_err(err)?;
        let names = labels.to_vec();
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
            .label_style(("sans-serif", TEXT))
            .axis_desc_style(("sans-serif", TEXT))
            .y_label_formatter(&tick)
            .x_desc("after each step of the search")
            .y_desc("gap, um")
            .draw()
            .map_err(err)?;
        let series = |v: &[f64]| -> Vec<(f64, f64)> {
            v.iter().enumerate().map(|(i, y)| (i as f64, *y)).collect()
        };
        chart
            .draw_series(LineSeries::new(series(rms), BLUE.stroke_width(2)))
            .map_err(err)?
            .label("RMS")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], BLUE.stroke_width(2)));
        chart
            .draw_series(
                series(rms)
                    .into_iter()
                    .map(|p| Circle::new(p, 4, BLUE.filled())),
            )
            .map_err(err)?;
        chart
            .draw_series(LineSeries::new(series(max), RED.stroke_width(2)))
            .map_err(err)?
            .label("max")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], RED.stroke_width(2)));
        chart
            .draw_series(
                series(max)
                    .into_iter()
                    .map(|p| Circle::new(p, 4, RED.filled())),
            )
            .map_err(err)?;
        if sigma.is_finite() {
            chart
                .draw_series(std::iter::once(PathElement::new(
                    vec![(-0.5, sigma), (n as f64 - 0.5, sigma)],
                    BLACK.mix(0.5),
                )))
                .map_err(err)?
                .label("final residual standard deviation")
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], BLACK.mix(0.5)));
        }
        chart
            .configure_series_labels()
            .label_font(("sans-serif", TEXT))
            .border_style(BLACK.mix(0.3))
            .background_style(WHITE.mix(0.8))
            .draw()
            .map_err(err)?;
        root.present().map_err(err)?;
    }
    Ok(svg)
}

fn group_table(h: &mut String, title: &str, before: &[Group], after: &[Group]) {
    let _ = writeln!(
        h,
        "<table><tr><th>{}</th><th>points</th><th>RMS before</th><th>max before</th><th>RMS after</th><th>max after</th></tr>",
        esc(title)
    );
    for g in before {
        let a = after.iter().find(|x| x.name == g.name);
        let _ = writeln!(
            h,
            "<tr><td class=l>{}</td><td>{}</td><td>{:.3}</td><td>{:.3}</td><td>{}</td><td>{}</td></tr>",
            esc(&g.name),
            g.points,
            g.rms_um,
            g.max_um,
            a.map_or("-".into(), |a| format!("{:.3}", a.rms_um)),
            a.map_or("-".into(), |a| format!("{:.3}", a.max_um)),
        );
    }
    h.push_str("</table>\n");
}

fn gap_tables(h: &mut String, before: &Gap, after: &Gap) {
    h.push_str("<div class=grid>\n");
    group_table(h, "face", &before.by_face, &after.by_face);
    group_table(h, "direction", &before.by_direction, &after.by_direction);
    group_table(h, "sequence", &before.by_sequence, &after.by_sequence);
    h.push_str("</div>\n");
    group_table(h, "pose", &before.by_pose, &after.by_pose);
}

/// Writes the report of a discovery into `dir`; returns the files written.
pub fn write(dir: &Path, d: &Discovery, data: &Dataset) -> Result<Vec<PathBuf>, ReportError> {
    // Every file is staged: the report appears whole or not at all.
    let mut files = StagedDir::create(dir)?;
    let s: &Story = &d.story;
    gap_figure(&mut files, s)?;
    residual_figures(&mut files, d, data)?;
    let value_figs = step_figures(&mut files, s)?;
    let mut h = String::new();
    html_head(&mut h, s, data);
    gap_section(&mut h, s);
    ambiguity_section(&mut h, s);
    steps_section(&mut h, s, &value_figs);
    h.push_str("<h2>Residual patterns</h2>\n<div class=grid>\n<figure><img src=\"residuals-before.svg\" alt=\"before\"><figcaption>before: the starting model</figcaption></figure>\n<figure><img src=\"residuals-after.svg\" alt=\"after\"><figcaption>after: the final model</figcaption></figure>\n</div>\n");
    h.push_str(&crate::report::pose_key(data));
    gap_tables(&mut h, &s.start.gap, &s.end.gap);
    last_round_section(&mut h, s);
    notes_section(&mut h, s, data);
    let _ = writeln!(
        h,
        "<h2>The story as printed</h2>\n<pre>{}</pre>",
        esc(&s.render())
    );
    let next = if s.ambiguity.is_some() {
        "The search stopped at an ambiguity: plan the supplementary test it names (<code>fivecal plan --supplement</code>), run and measure it, and run <code>fivecal discover</code> on both runs' measurements.".to_string()
    } else {
        format!(
            "Compensate with the model found: its error file (<code>discover --out</code>) goes to <code>fivecal compensate --machine {m} --errors MODEL.yaml</code> (a part program, or <code>--export</code> to the control); after the change, run the test again and compare with <code>fivecal verify</code>.",
            m = esc(&s.machine)
        )
    };
    let _ = writeln!(h, "<h2>Next step</h2>\n<p>{next}</p>");
    h.push_str("</body></html>\n");
    put(&mut files, "index.html", h.as_bytes())?;
    Ok(files.commit()?)
}

/// Stages one file of the report.
fn put(files: &mut StagedDir, name: &str, bytes: &[u8]) -> Result<(), ReportError> {
    files.write(Path::new(name), bytes)?;
    Ok(())
}

/// Stages a drawn figure, or names it in the error if the drawing failed.
fn put_plot(files: &mut StagedDir, name: &str, res: PlotResult) -> Result<(), ReportError> {
    let svg = res.map_err(|e| ReportError::Plot(name.into(), e))?;
    put(files, name, svg.as_bytes())
}

/// `gap.svg`: the gap's RMS and maximum after each step.
fn gap_figure(files: &mut StagedDir, s: &Story) -> Result<(), ReportError> {
    let mut labels = vec!["start".to_string()];
    let mut rms = vec![s.start.gap.rms_um];
    let mut max = vec![s.start.gap.max_um];
    for st in &s.steps {
        labels.push(format!("+{}", st.name));
        rms.push(st.gap_after.rms_um);
        max.push(st.gap_after.max_um);
    }
    put_plot(
        files,
        "gap.svg",
        gap_plot(&labels, &rms, &max, s.end.sigma_um),
    )
}

/// `residuals-before.svg` and `residuals-after.svg`: the residuals of the
/// starting and the final model.
fn residual_figures(
    files: &mut StagedDir,
    d: &Discovery,
    data: &Dataset,
) -> Result<(), ReportError> {
    let start = d.start();
    let end = d.end();
    put_plot(
        files,
        "residuals-before.svg",
        plots::residual_plot(
            &crate::report::residual_groups(data, &start.residuals),
            start.sigma(),
        ),
    )?;
    put_plot(
        files,
        "residuals-after.svg",
        plots::residual_plot(
            &crate::report::residual_groups(data, &end.residuals),
            end.sigma(),
        ),
    )
}

/// `step-N.svg`: the provisional values of each step; returns their names.
fn step_figures(files: &mut StagedDir, s: &Story) -> Result<Vec<String>, ReportError> {
    let mut value_figs = Vec::new();
    for st in &s.steps {
        let items: Vec<(String, f64, Option<f64>)> = st
            .provisional_values
            .iter()
            .map(|v| (v.name.clone(), v.value, v.u))
            .collect();
        let unit = st
            .provisional_values
            .first()
            .map_or(String::new(), |v| v.unit.clone());
        let file = format!("step-{}.svg", st.step);
        put_plot(
            files,
            &file,
            plots::values_with_bars(&format!("step {}: {}", st.step, st.name), &unit, &items),
        )?;
        value_figs.push(file);
    }
    Ok(value_figs)
}

/// The page's head, title and what was measured.
fn html_head(h: &mut String, s: &Story, data: &Dataset) {
    let title = format!("discover: {} on {}", s.test, s.machine);
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{t}</title>\n<style>body{{font-family:sans-serif;max-width:1100px;margin:2em auto;color:#222}}table{{border-collapse:collapse;margin:0 1em 1em 0}}td,th{{border:1px solid #ccc;padding:2px 8px;text-align:right}}th{{background:#eee}}td.l{{text-align:left}}pre{{background:#f6f6f6;padding:8px;white-space:pre-wrap;overflow-wrap:anywhere}}figure{{margin:0 8px 8px 0}}.key span{{white-space:nowrap;margin-right:8px}}.grid{{display:flex;flex-wrap:wrap;align-items:flex-start}}.grid img{{width:540px}}</style></head><body>\n<h1>{t}</h1>\n",
        t = esc(&title)
    );
    let _ = writeln!(
        h,
        "<p>{} points in {} poses from {}. Significance level {} per step, after Bonferroni's adjustment for the number of candidates tried; a candidate must also lower the BIC.</p>",
        s.points,
        s.poses,
        esc(&data
            .files
            .iter()
            .map(|f| f.display().to_string())
            .collect::<Vec<_>>()
            .join(", ")),
        s.alpha
    );
}

/// "The gap shrinking": its figure, the table of the models and the stop.
fn gap_section(h: &mut String, s: &Story) {
    h.push_str("<h2>The gap shrinking</h2>\n<img src=\"gap.svg\" alt=\"gap per step\">\n");
    h.push_str("<table><tr><th>model</th><th>RMS um</th><th>max um</th><th>where it was concentrated</th></tr>\n");
    let _ = writeln!(
        h,
        "<tr><td class=l>{}</td><td>{:.3}</td><td>{:.3}</td><td class=l>{}</td></tr>",
        esc(&s.start.model.join(" + ")),
        s.start.gap.rms_um,
        s.start.gap.max_um,
        esc(&s.start.gap.summary)
    );
    for st in &s.steps {
        let _ = writeln!(
            h,
            "<tr><td class=l>+ {}</td><td>{:.3}</td><td>{:.3}</td><td class=l>{}</td></tr>",
            esc(&st.name),
            st.gap_after.rms_um,
            st.gap_after.max_um,
            esc(&st.concentrated)
        );
    }
    h.push_str("</table>\n");
    let _ = writeln!(h, "<p><b>Stop:</b> {}</p>", esc(&s.stop));
}

/// The ambiguity that stopped the search, if any, with the supplementary
/// test that would separate its candidates.
fn ambiguity_section(h: &mut String, s: &Story) {
    let Some(a) = &s.ambiguity else {
        return;
    };
    let _ = writeln!(h, "<p><b>Ambiguous:</b> {}</p>", esc(&a.reason));
    if let Some(p) = &a.supplement {
        let list = |v: &[f64]| {
            v.iter()
                .map(|x| crate::procedure::short(*x))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let _ = writeln!(
            h,
            "<p><b>To separate them:</b> a {} run at the tilt angles {} with C = {} ({} poses, {} touches; new poses {}).</p>\n<table><tr><th>effect</th><th>told from</th><th>directions</th><th>power</th></tr>",
            esc(&p.test),
            list(&p.tilt),
            list(&p.c),
            p.poses,
            p.touches,
            esc(&p.new_poses.join(", "))
        );
        for q in &p.power {
            let _ = writeln!(
                h,
                "<tr><td class=l>{}</td><td class=l>{}</td><td>{}</td><td>{:.3}</td></tr>",
                esc(&q.effect),
                esc(&q.against),
                q.directions,
                q.power
            );
        }
        h.push_str("</table>\n");
    }
    if let Some(why) = &a.no_supplement {
        let _ = writeln!(h, "<p>No supplementary test proposed: {}</p>", esc(why));
    }
}

/// "Steps": each step's test, values (provisional and final) and rivals.
fn steps_section(h: &mut String, s: &Story, value_figs: &[String]) {
    h.push_str("<h2>Steps</h2>\n");
    for (st, fig) in s.steps.iter().zip(value_figs) {
        let _ = writeln!(
            h,
            "<h3>Step {}: {}</h3>\n<p>{}. Gap {:.3} &rarr; {:.3} um RMS, {:.3} &rarr; {:.3} um max ({:.1} % of the squared gap). F = {:.4} ({}, {}), p = {:.3e}, {:.3e} after {} candidates; BIC {:+.1}. Alongside the model: +{} direction(s), canonical correlation {:.3}.</p>",
            st.step,
            esc(&st.name),
            esc(&st.description),
            st.gap_before.rms_um,
            st.gap_after.rms_um,
            st.gap_before.max_um,
            st.gap_after.max_um,
            100.0 * st.test.explained,
            st.test.f,
            st.test.df1,
            st.test.df2,
            st.test.p,
            st.p_adjusted,
            st.tested,
            st.test.delta_bic,
            st.alongside.rank_increase,
            st.alongside.canonical_correlation
        );
        h.push_str("<div class=grid>\n");
        let _ = writeln!(h, "<img src=\"{fig}\" alt=\"values of step {}\">", st.step);
        h.push_str("<table><tr><th>parameter</th><th>provisional value</th><th>u</th><th>final value</th><th>u</th><th>unit</th></tr>\n");
        let u3 = |u: Option<f64>| u.map_or("-".into(), |u| format!("{u:.3}"));
        for v in &st.provisional_values {
            let fin = s.end.values.iter().find(|e| e.name == v.name);
            let _ = writeln!(
                h,
                "<tr><td class=l>{}</td><td>{:.3}</td><td>{}</td><td>{}</td><td>{}</td><td class=l>{}</td></tr>",
                esc(&v.name),
                v.value,
                u3(v.u),
                fin.map_or("-".into(), |e| format!("{:.3}", e.value)),
                u3(fin.and_then(|e| e.u)),
                esc(&v.unit)
            );
        }
        h.push_str("</table></div>\n");
        if !st.rivals.is_empty() {
            h.push_str("<p>Significant rivals:</p><ul>\n");
            // Those that matter first: a later step added them, or the
            // data cannot tell them from this step's effect.
            let mut order: Vec<_> = st.rivals.iter().collect();
            order.sort_by_key(|r| !r.matters());
            for r in order {
                let _ = writeln!(
                    h,
                    "<li>{} (gap {:.3} um RMS): {}</li>",
                    esc(&r.name),
                    r.gap_after.rms_um,
                    esc(&r.verdict)
                );
            }
            h.push_str("</ul>\n");
        }
    }
}

/// "The last round": every candidate of the round that added nothing.
fn last_round_section(h: &mut String, s: &Story) {
    h.push_str("<h2>The last round</h2>\n<table><tr><th>candidate</th><th>verdict</th><th>RMS after</th><th>p adjusted</th><th>BIC change</th><th>why refused</th></tr>\n");
    for t in &s.last_round {
        let _ = writeln!(
            h,
            "<tr><td class=l>{}</td><td class=l>{}</td><td>{}</td><td>{}</td><td>{}</td><td class=l>{}</td></tr>",
            esc(&t.name),
            match t.verdict {
                CandidateVerdict::Significant => "significant",
                CandidateVerdict::NotSignificant => "not significant",
                CandidateVerdict::Refused => "refused",
            },
            t.gap_after
                .map_or("-".into(), |g| format!("{:.3}", g.rms_um)),
            t.p_adjusted.map_or("-".into(), |p| format!("{p:.3}")),
            t.test
                .map_or("-".into(), |c| format!("{:+.1}", c.delta_bic)),
            esc(t.reason.as_deref().unwrap_or(""))
        );
    }
    h.push_str("</table>\n");
}

/// "Notes": the discovery's notes and the data's warnings, if any.
fn notes_section(h: &mut String, s: &Story, data: &Dataset) {
    if !s.notes.is_empty() || !data.warnings.is_empty() {
        h.push_str("<h2>Notes</h2><ul>\n");
        for n in s.notes.iter().chain(&data.warnings) {
            let _ = writeln!(h, "<li>{}</li>", esc(n));
        }
        h.push_str("</ul>\n");
    }
}
