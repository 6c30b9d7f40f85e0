//! The `--report DIR` of a nine-section analysis: the section heights of
//! each piece as a plot and a table, their AVG, MAX and RMS, the rate of
//! improvement from the first piece to the last, why the test identifies
//! no location error, and what to do next. The page is staged and appears
//! whole or not at all, as every report.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::{ReportError, esc, page_start, plot, plots, put};
use crate::analyze::NineSectionOutcome;
use crate::io::StagedDir;

/// Writes the nine-section report into `dir`; returns the files written.
pub fn write(dir: &Path, n: &NineSectionOutcome) -> Result<Vec<PathBuf>, ReportError> {
    let mut files = StagedDir::create(dir)?;
    let mut h = page_start(&format!("Nine-section test on {}", n.machine));
    let _ = writeln!(
        h,
        "<p>Machine <b>{}</b>, {} measured from {}.</p>",
        esc(&n.machine),
        if n.stats.len() == 1 {
            "one piece".to_string()
        } else {
            format!("{} pieces", n.stats.len())
        },
        esc(&n
            .stats
            .iter()
            .map(|(p, _)| p.display().to_string())
            .collect::<Vec<_>>()
            .join(", "))
    );
    // What the numbers are for comes first: they evaluate, they do not
    // calibrate.
    let reason = n
        .not_identifiable
        .first()
        .map(|r| r.reason.as_str())
        .unwrap_or_default();
    let _ = writeln!(h, "<h2>What the test tells</h2>\n<p>{}.</p>", esc(reason));
    if let Some([avg, max, rms]) = n.improvement {
        let rate = |r: Option<f64>| {
            r.map_or("- (zero on the first piece)".into(), |r| {
                format!("{r:.2} %")
            })
        };
        let _ = writeln!(
            h,
            "<h2>Rate of improvement, first piece to last</h2>\n<table><tr><th>AVG</th><th>MAX</th><th>RMS</th></tr><tr><td>{}</td><td>{}</td><td>{}</td></tr></table>\n<p>(|before| - |after|) / |before| of each statistic.</p>",
            rate(avg),
            rate(max),
            rate(rms)
        );
    }
    for (k, (path, s)) in n.stats.iter().enumerate() {
        let file = format!("heights-{}.svg", k + 1);
        let items: Vec<(String, f64, Option<f64>)> = s
            .sections
            .iter()
            .map(|&(section, height)| (section.to_string(), height, None))
            .collect();
        let title = format!("section heights, {}", path.display());
        put(
            &mut files,
            &file,
            plot(&file, plots::values_with_bars(&title, "um", &items))?.as_bytes(),
        )?;
        let _ = writeln!(
            h,
            "<h2>{}</h2>\n<img src=\"{file}\" alt=\"section heights of {}\">\n<table><tr><th>section</th><th>height um</th></tr>",
            esc(&path.display().to_string()),
            esc(&path.display().to_string())
        );
        for (section, height) in &s.sections {
            let _ = writeln!(h, "<tr><td>{section}</td><td>{height:.3}</td></tr>");
        }
        let _ = writeln!(
            h,
            "</table>\n<p>AVG <b>{:.4} um</b>, MAX <b>{:.4} um</b>, RMS <b>{:.4} um</b> (heights from section 1).</p>",
            s.avg_um, s.max_um, s.rms_um
        );
    }
    let next = if n.stats.len() == 1 {
        "Compensate the machine, cut a second piece from the same plan and analyze both together (<code>--measured BEFORE --measured AFTER</code>): the report then gives the rate of improvement. To identify the location errors themselves, plan the stepped-square, column or sphere test."
    } else {
        "A rate near 100 % means the compensation took the errors the heights see away; to identify the location errors themselves, plan the stepped-square, column or sphere test."
    };
    let _ = writeln!(h, "<h2>Next step</h2>\n<p>{next}</p>");
    h.push_str("</body></html>\n");
    put(&mut files, "index.html", h.as_bytes())?;
    Ok(files.commit()?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::errorfile::NotIdentified;
    use crate::identify::nine_section::NineSection;

    fn piece(heights: &[f64]) -> NineSection {
        let mut s = NineSection {
            sections: Vec::new(),
            avg_um: 0.0,
            max_um: 0.0,
            rms_um: 0.0,
        };
        for (k, h) in heights.iter().enumerate() {
            s.sections.push((k as u32 + 1, *h));
        }
        s
    }

    /// Two pieces: a plot and a table of each, the rates with a statistic
    /// that has none, and the reason the test identifies nothing.
    #[test]
    fn the_report_shows_each_piece_and_the_rates() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("report");
        let n = NineSectionOutcome {
            machine: "bc-trunnion".into(),
            stats: vec![
                ("before.csv".into(), piece(&[0.0, -5.0, -9.0])),
                ("after.csv".into(), piece(&[0.0, 2.0, 2.0])),
            ],
            improvement: Some([Some(98.88), None, Some(84.21)]),
            not_identifiable: vec![NotIdentified {
                symbol: "EX0B".into(),
                reason: "it evaluates a machine".into(),
            }],
        };
        let files = write(&out, &n).unwrap();
        assert_eq!(files.len(), 3, "{files:?}");
        let html = std::fs::read_to_string(out.join("index.html")).unwrap();
        for want in [
            "Nine-section test on bc-trunnion",
            "2 pieces",
            "it evaluates a machine",
            "98.88 %",
            "- (zero on the first piece)",
            "heights-1.svg",
            "heights-2.svg",
            "<td>-9.000</td>",
            "Next step",
        ] {
            assert!(html.contains(want), "{want} missing");
        }
        let svg = std::fs::read_to_string(out.join("heights-2.svg")).unwrap();
        assert!(svg.contains("after.csv") && svg.contains("um"));
    }
}
