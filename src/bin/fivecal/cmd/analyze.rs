//! `fivecal analyze`: identify location errors and error maps, with their
//! uncertainty, from CMM and probe files. The options are validated into
//! one configuration in `config/analyze.rs`, the library's
//! [`fivecal::analyze::run`] does the analysis, and this prints what it
//! found and writes the files. The `contour` mode lives in `contour.rs`.

use fivecal::analyze::{self, Found, Identified, IdentifiedPiece, NineSectionOutcome, Outcome};
use fivecal::conformance::ConformanceVerdict;
use fivecal::report::{self, ReportInput};
use fivecal::store::runs;

use crate::config::analyze::{AnalyzeCli, AnalyzeMode, Config, validate};

pub fn run(cli: AnalyzeCli) -> anyhow::Result<()> {
    match cli.mode {
        Some(AnalyzeMode::Contour(a)) => super::contour::run(a),
        None => {
            if let Some(l) = cli.args.laser_lines() {
                return super::laser::analyze(l?);
            }
            let c = validate(*cli.args)?;
            if c.json_stdout {
                // Standard output is the JSON's: what the run says goes
                // to standard error.
                crate::out::to_stderr();
            }
            if let Some(bb) = &c.ball_bar {
                return super::ball_bar::analyze(&c, bb);
            }
            let mut recorder = c.record.open()?;
            let outcome = analyze::run(&c.request)?;
            for w in &outcome.warnings {
                eprintln!("warning: {w}");
            }
            match &outcome.found {
                Found::Identified(id) => identified(&c, &outcome, id)?,
                Found::NineSection(n) => nine_section(&c, &outcome, n)?,
            }
            let written = analyze::result::files(&outcome, &c.out, c.json)?;
            if c.json_stdout {
                // The result file's content, in JSON whatever the file's
                // format (with --series, the table; the pieces are files).
                let files = analyze::result::files(&outcome, &c.out, true)?;
                if let Some((_, text)) = files.iter().find(|(p, _)| *p == c.out) {
                    crate::out::json(text)?;
                }
            }
            let records = runs::analysis(
                &outcome,
                &c.request.manifest,
                &c.request.measured,
                &written,
                &c.record.notes,
            )?;
            recorder.save(&records, &|s| outln!("{s}"))
        }
    }
}

fn identified(c: &Config, outcome: &Outcome, id: &Identified) -> anyhow::Result<()> {
    if let Some(l) = &c.limits {
        for piece in &id.pieces {
            l.check_result(&piece.file)?;
        }
    }
    for piece in &id.pieces {
        print_piece(c, piece);
        if let Some(l) = &c.limits {
            outln!("limits from {}:", l.path.display());
            out!(
                "{}",
                ConformanceVerdict::of(&piece.file, &l.limits).render()
            );
        }
        if let Some(dir) = &c.report {
            let dir = piece.report_dir(dir);
            let files = report::write(
                &dir,
                &ReportInput::for_piece(id.test.as_str(), piece, &c.request.manifest),
            )?;
            outln!(
                "report: {} ({} files)",
                dir.join("index.html").display(),
                files.len()
            );
        }
    }
    if let Some(series) = &id.series {
        out!(
            "\nseries of {} pieces:\n{}",
            id.pieces.len(),
            series.render()
        );
    }
    analyze::result::write(outcome, &c.out, c.json)?;
    if id.series.is_some() {
        outln!(
            "wrote {} and one error file per piece beside it",
            c.out.display()
        );
    } else {
        outln!("wrote {}", c.out.display());
    }
    if let Some(cmp) = &id.comparison {
        out!(
            "\ncomparison with {}: the value (u) in each result, then the change from it (combined u):\n{}",
            cmp.table.pieces[0],
            cmp.render()
        );
    }
    Ok(())
}

/// What the analysis of one piece found: identifiability and values, the
/// Monte-Carlo study, the residuals.
fn print_piece(c: &Config, p: &IdentifiedPiece) {
    for w in &p.data.warnings {
        eprintln!("warning: {w}");
    }
    if let Some(k) = p.number {
        outln!("== piece {k}: {}", p.name());
    }
    // The verdict first: it says whether anything below may be acted on.
    out!("{}", analyze::verdict::render(p.fit.as_ref()));
    if let Some(f) = p.misfit() {
        let next = analyze::goodness::discover_command(&c.request.manifest, &p.data.files);
        outln!("{}\n", analyze::goodness::banner(f, &next));
    }
    out!("{}", p.est.summary_with(&p.u));
    if let Some(u) = &p.file.uncertainty {
        out!("{}", analyze::result::render_uncertainty(u));
    }
    let symbols = &p.est.model.symbols;
    let units = |name: &str| {
        symbols
            .location_index(name)
            .map_or(String::new(), |k| symbols.location[k].unit.to_string())
    };
    out!(
        "{}",
        analyze::result::render_not_useful(&p.file.seen_not_usefully, &units)
    );
    if let Some(s) = &p.monte_carlo {
        if let Some(w) = &s.warning {
            eprintln!("warning: {w}");
        }
        outln!(
            "monte carlo: {} runs (seed {}) {}",
            s.result.runs,
            s.seed,
            s.how
        );
        if let Some(w) = s.widened {
            outln!(
                "  u widened by the Birge ratio {w:.2}: the model does not fit, the runs drew only the stated noise"
            );
        }
        for r in &s.rows {
            outln!(
                "  {:<24} u(covariance) {:>8.3}   u(monte carlo) {:>8.3}",
                r.name,
                r.covariance.unwrap_or(f64::NAN),
                r.monte_carlo
            );
        }
    }
    outln!("residuals by pose and face (um):");
    outln!(
        "  {:<12} {:<22} {:>6} {:>9} {:>9} {:>9}",
        "pose",
        "face",
        "points",
        "mean",
        "rms",
        "max"
    );
    for r in p.est.residual_table(&p.data) {
        outln!(
            "  {:<12} {:<22} {:>6} {:>9.3} {:>9.3} {:>9.3}",
            r.pose,
            r.face,
            r.points,
            r.mean_um,
            r.rms_um,
            r.max_um
        );
    }
}

/// The nine-section statistics of each piece, and what the test cannot
/// identify.
fn nine_section(c: &Config, outcome: &Outcome, n: &NineSectionOutcome) -> anyhow::Result<()> {
    for (p, s) in &n.stats {
        outln!("{}:\n{}", p.display(), s.render());
    }
    if let Some(r) = n.improvement {
        let rate =
            |r: Option<f64>| r.map_or("- (zero on the first)".into(), |r| format!("{r:.2} %"));
        outln!(
            "rate of improvement from the first to the last: AVG {}, MAX {}, RMS {}",
            rate(r[0]),
            rate(r[1]),
            rate(r[2])
        );
    }
    if let Some(first) = n.not_identifiable.first() {
        outln!(
            "not identifiable: {} ({})",
            n.not_identifiable
                .iter()
                .map(|n| n.symbol.as_str())
                .collect::<Vec<_>>()
                .join(", "),
            first.reason
        );
    }
    analyze::result::write(outcome, &c.out, c.json)?;
    outln!("wrote {}", c.out.display());
    if let Some(dir) = &c.report {
        let files = report::nine_section::write(dir, n)?;
        outln!(
            "report: {} ({} files)",
            dir.join("index.html").display(),
            files.len()
        );
    }
    Ok(())
}
