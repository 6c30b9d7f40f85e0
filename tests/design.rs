//! `plan` says what a test will identify on a machine before anything is
//! cut or probed, and the uncertainties it predicts are the ones `analyze`
//! then reports.

use fivecal::analyze::design;
use fivecal::identify::Setup;

use crate::analyze_sim::{identify, measure};

use crate::cli::fivecal;

/// The prediction against an analysis of a simulated run of the same plan
/// (location errors of a few tens of micrometres, 0.35 um noise): the same
/// symbols identified, each u within 20 % (the reported u is scaled by the
/// residual sigma, which over 100 to 250 points is within about 10 % of
/// the noise; the covariance's u in turn agrees with the spread of
/// simulated runs, `analyze_sim`).
#[test]
fn plan_predicts_the_symbols_and_u_that_analyze_reports() {
    for (machine, test) in [
        ("bc-trunnion", "stepped-square"),
        ("ac-trunnion", "probe-columns"),
        ("head-table", "probe-sphere"),
    ] {
        let plan = crate::simulate::planned(machine, test);
        let predicted = design::predict(&plan, None, None).unwrap();
        let kin = fivecal::simulate::plan_kinematics(&plan);
        let truth = crate::simulate::truth(&plan, &crate::fit::location_truth(&kin));
        let data = measure(&plan, &truth, &Default::default());
        let setup = Setup::new(&kin, &data.poses, &[]).unwrap();
        let est = identify(&plan, &setup, &data, predicted.method);
        let mut compared = 0;
        for row in &predicted.rows {
            let (_, u) = est.get(&row.symbol).unwrap();
            match (row.u, u) {
                (Some(p), Some(r)) => {
                    assert!(
                        (p / r - 1.0).abs() < 0.2,
                        "{test} on {machine}: {} predicted u {p:.3}, analyze reports {r:.3}",
                        row.symbol
                    );
                    compared += 1;
                }
                (None, None) => {}
                (p, r) => panic!(
                    "{test} on {machine}: {} predicted {p:?}, analyze reports {r:?}",
                    row.symbol
                ),
            }
        }
        assert!(compared >= 2, "{test} on {machine}: {}", predicted.render());
    }
}

/// `--require all` on a design that leaves errors unseen stops before
/// anything is written and names them; a complete design is planned, and
/// its setup sheet carries the table.
#[test]
fn require_all_refuses_an_incomplete_design_and_the_sheet_shows_the_table() {
    let dir = crate::util::tempdir();
    let refused = dir.path().join("refused");
    let out = fivecal()
        .args([
            "plan",
            "probe-sphere",
            "--machine",
            "head-head",
            "--require",
            "all",
            "--out",
        ])
        .arg(&refused)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(
        err.contains("--require all")
            && err.contains("does not identify")
            && err.contains("EB(0A)S"),
        "{err}"
    );
    assert!(!refused.exists());

    let ok = dir.path().join("ss");
    let out = fivecal()
        .args([
            "plan",
            "stepped-square",
            "--machine",
            "bc-trunnion",
            "--require",
            "all",
            "--out",
        ])
        .arg(&ok)
        .output()
        .unwrap();
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("identifies 8 of 8 location errors"), "{text}");
    let sheet = std::fs::read_to_string(ok.join("stepped-square.md")).unwrap();
    let section = &sheet[sheet.find("## What this test identifies").unwrap()..];
    for s in [
        "EX0B", "EZ0B", "EA0B", "EC0B", "EB0B", "EX(0B)C", "EY0C", "EA(0B)C",
    ] {
        assert!(
            section.contains(&format!("  {s:<10} u =")),
            "{s}\n{section}"
        );
    }
    // The manifest carries the same table: every symbol with the u the
    // screen printed, read back through the manifest reader.
    let manifest =
        fivecal::formats::manifest::Manifest::read(&ok.join("stepped-square.plan.yaml")).unwrap();
    let id = manifest
        .identifies
        .expect("the manifest says what the test identifies");
    assert_eq!(
        (id.method.as_str(), id.rank, id.parameters),
        ("global", 14, 14)
    );
    assert_eq!(id.symbols.len(), 8);
    for (symbol, row) in &id.symbols {
        let u = row.u.unwrap_or_else(|| panic!("{symbol}: {row:?}"));
        let printed = text
            .lines()
            .find(|l| l.trim_start().starts_with(&format!("{symbol} ")))
            .unwrap_or_else(|| panic!("{symbol} not printed:\n{text}"));
        assert!(printed.contains(&format!("{u:.3}")), "{printed} vs {u}");
    }
}

/// The predicted u against the spread of the identified values over 200
/// simulated runs of the same piece or probing (each run its own noise,
/// placement and setups, the errors fixed): the standard deviation of 200
/// draws is within about 5 % of the true one (1/sqrt(2 x 200)), so 20 %
/// is four of its standard errors.
#[test]
fn predicted_u_matches_the_spread_of_200_simulated_runs() {
    use rayon::prelude::*;
    for (machine, test) in [
        ("bc-trunnion", "stepped-square"),
        ("head-table", "probe-columns"),
    ] {
        let plan = crate::simulate::planned(machine, test);
        let predicted = design::predict(&plan, None, None).unwrap();
        let kin = fivecal::simulate::plan_kinematics(&plan);
        let truth = crate::simulate::truth(&plan, &crate::fit::location_truth(&kin));
        let runs: Vec<Vec<(String, f64)>> = (0..200u64)
            .into_par_iter()
            .map(|seed| {
                let opts = fivecal::simulate::SimOptions {
                    seed: 1000 + seed,
                    ..Default::default()
                };
                let data = measure(&plan, &truth, &opts);
                let setup = Setup::new(&kin, &data.poses, &[]).unwrap();
                let est = identify(&plan, &setup, &data, predicted.method);
                predicted
                    .rows
                    .iter()
                    .filter(|r| r.u.is_some())
                    .map(|r| (r.symbol.clone(), est.get(&r.symbol).unwrap().0))
                    .collect()
            })
            .collect();
        let mut compared = 0;
        for (i, row) in predicted.rows.iter().filter(|r| r.u.is_some()).enumerate() {
            let v: Vec<f64> = runs.iter().map(|r| r[i].1).collect();
            let mean = v.iter().sum::<f64>() / v.len() as f64;
            let sd =
                (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (v.len() - 1) as f64).sqrt();
            let u = row.u.unwrap();
            assert!(
                (u / sd - 1.0).abs() < 0.2,
                "{test} on {machine}: {} predicted u {u:.4}, spread of 200 runs {sd:.4}",
                row.symbol
            );
            compared += 1;
        }
        assert!(compared >= 4, "{test} on {machine}");
    }
}
