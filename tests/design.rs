//! `plan` says what a test will identify on a machine before anything is
//! cut or probed, and the uncertainties it predicts are the ones `analyze`
//! then reports.

use fivecal::analyze::design;
use fivecal::identify::Setup;
use fivecal::identify::sphere::{CircleMethod, SphereOptions};

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
        let out = fivecal::simulate::run(&plan, &truth, &Default::default()).unwrap();
        let data =
            fivecal::analyze::uncertainty::simulated::plan_dataset(&plan, "measured", out.points)
                .unwrap();
        let setup = Setup::new(&kin, &data.poses, &[]).unwrap();
        let est = fivecal::analyze::method::identify_with_plan(
            predicted.method,
            &setup,
            &data,
            &SphereOptions {
                circle: CircleMethod::Robust,
                check: None,
            },
            Some(&plan),
        )
        .unwrap();
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
}
