//! Goodness of fit: a complete model fits every test on every machine with
//! every method that takes it, a model that misses an effect is flagged,
//! the flag travels with the result file, and `compensate` refuses it until
//! `discover` has found the effect.

use std::path::Path;

use fivecal::analyze::goodness::{self, ExpectedNoise};
use fivecal::errorfile::{ErrorFile, FitVerdict};

use fivecal::identify::{Method, Setup};
use fivecal::kinematics::Kinematics;
use fivecal::procedure::Test;

use crate::analyze_sim::{identify, measure};
use crate::cli::fivecal;
use crate::util::MACHINES;

/// The location errors of `fivecal simulate --truth-example` for a
/// machine, with the example's noise and nothing else (the machine line is
/// added by the loader): the model every method identifies is then
/// complete.
pub fn location_truth(kin: &Kinematics) -> String {
    let example = fivecal::simulate::truth::example(kin);
    let full: serde_yaml::Value = serde_yaml::from_str(&example).unwrap();
    let mut t = serde_yaml::Mapping::new();
    t.insert("location_errors".into(), full["location_errors"].clone());
    serde_yaml::to_string(&t).unwrap() + "effects: {noise: {cmm: 0.35, probe: 0.35}}\n"
}

/// Every test that identifies location errors, on every built-in machine,
/// with every method that accepts it, two seeds: each value reported is
/// within 4 u of the truth, every other is listed as not identifiable, and
/// the complete model fits
/// (a chi-square test at 0.1 % flags one clean run in a thousand, and the
/// cases here are fixed). Before the global method on the sphere test used
/// the exact sphere, seed 2 on the trunnions failed here: a sphere set up
/// 0.1 mm off its place moves each touch by d^2 / 2R off the tangent plane.
#[test]
fn every_test_machine_and_method_fits_and_reports_within_4u() {
    let mut judged = 0;
    for machine in MACHINES {
        for test in ["stepped-square", "probe-columns", "probe-sphere"] {
            let plan = crate::simulate::planned(machine, test);
            let kin = fivecal::simulate::plan_kinematics(&plan);
            let truth = crate::simulate::truth(&plan, &location_truth(&kin));
            let rigid = !fivecal::analyze::method::rigid_refuses(&truth.model);
            let mut methods = vec![Method::Global];
            if rigid && test != "probe-sphere" {
                methods.push(Method::TwoStage);
            }
            if test == "probe-sphere" {
                methods.push(Method::Sphere);
            }
            for seed in [1, 2] {
                let opts = fivecal::simulate::SimOptions {
                    seed,
                    ..Default::default()
                };
                let data = measure(&plan, &truth, &opts);
                let setup = Setup::new(&kin, &data.poses, &[]).unwrap();
                let expected = ExpectedNoise::new(None, data.kind, plan.test());
                for &method in &methods {
                    let est = identify(&plan, &setup, &data, method);
                    let f = goodness::of(&est, &expected).unwrap();
                    assert_eq!(
                        f.verdict,
                        FitVerdict::Fits,
                        "{test} on {machine}, {method}, seed {seed}: {f:?}"
                    );
                    // Residuals near the noise, not far below it either:
                    // a fit that absorbs the noise has too many freedoms.
                    assert!(
                        f.ratio > 0.75 && f.ratio < 1.3,
                        "{test} on {machine}, {method}, seed {seed}: ratio {}",
                        f.ratio
                    );
                    // The verdict on every point against the complete
                    // model at the method's estimate fits as well: the
                    // sphere and two-stage estimates are as good as the
                    // global one where the model is complete.
                    let v = fivecal::analyze::verdict::of(
                        &est,
                        &setup,
                        &data,
                        plan.test(),
                        Some(&plan),
                        &expected,
                    )
                    .unwrap()
                    .unwrap();
                    assert_eq!(
                        v.verdict,
                        FitVerdict::Fits,
                        "{test} on {machine}, {method}, seed {seed}: verdict {v:?}"
                    );
                    assert!(
                        v.ratio > 0.75 && v.ratio < 1.3 && v.ratio >= f.ratio * 0.9,
                        "{test} on {machine}, {method}, seed {seed}: verdict ratio {} against the method's {}",
                        v.ratio,
                        f.ratio
                    );
                    // And what it reports is right within 4 u; what it
                    // does not report, the result file lists with why.
                    let file = est.error_file(None);
                    for (i, name) in est.model.param_names().iter().enumerate() {
                        match est.get(name).unwrap() {
                            (v, Some(u)) => {
                                let z = (v - truth.theta[i]).abs() / u;
                                assert!(
                                    z < 4.0,
                                    "{test} on {machine}, {method}, seed {seed}: {name} off by {z:.1} u\n{}",
                                    est.summary()
                                );
                            }
                            (_, None) => assert!(
                                file.not_identifiable
                                    .iter()
                                    .any(|n| n.symbol.contains(name.as_str())),
                                "{test} on {machine}, {method}, seed {seed}: {name} neither reported nor listed"
                            ),
                        }
                    }
                    judged += 1;
                }
            }
        }
    }
    assert_eq!(judged, 2 * (2 * (2 + 2 + 2) + 2 * (1 + 1 + 2)));
}

/// The README demo's piece: the machine drifts in Z while the stepped
/// square is cut, which location errors cannot express.
const DRIFTING: &str = "machine: bc-trunnion
location_errors: {EX0B: 12.0, EZ0B: -25.0, EA0B: 60.0, EC0B: -45.0, EB0B: 110.0, EX(0B)C: 18.0, EY0C: -15.0, EA(0B)C: 35.0}
effects:
  thermal_drift: {EZ0B: {per: seq, rate: 1.5}}
  noise: {cmm: 0.35}
";

fn yaml(path: &Path) -> ErrorFile {
    ErrorFile::parse(path, &std::fs::read_to_string(path).unwrap()).unwrap()
}

/// From the drifting piece to an accepted compensation: `analyze` flags the
/// misfit on screen with the command to run next and in the result file,
/// widens a Monte-Carlo u by the Birge ratio, `compensate` refuses the
/// result until `--accept-misfit`; `discover` finds the drift and its model
/// fits and is accepted; the results store keeps both verdicts.
#[test]
fn a_drifting_piece_is_flagged_refused_then_discovered_and_accepted() {
    let dir = crate::util::tempdir();
    let d = dir.path();
    let p = |s: &str| d.join(s).display().to_string();
    std::fs::write(d.join("truth.yaml"), DRIFTING).unwrap();
    fivecal()
        .args([
            "plan",
            "stepped-square",
            "--machine",
            "bc-trunnion",
            "--out",
        ])
        .arg(p("ss"))
        .assert()
        .success();
    let plan = p("ss/stepped-square.plan.yaml");
    fivecal()
        .args(["simulate", "--plan", &plan, "--errors", &p("truth.yaml")])
        .args(["--out", &p("piece.dmo")])
        .assert()
        .success();
    let db = p("history.db");
    let out = fivecal()
        .args(["analyze", "--plan", &plan, "--measured", &p("piece.dmo")])
        .args(["--out", &p("r.yaml"), "--mc", "20", "--db", &db])
        .output()
        .unwrap();
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("THE MODEL DOES NOT FIT"), "{text}");
    assert!(
        text.contains(&format!(
            "fivecal discover --plan {plan} --measured {}",
            p("piece.dmo")
        )),
        "{text}"
    );
    assert!(text.contains("u widened by the Birge ratio"), "{text}");
    let r = yaml(&d.join("r.yaml"));
    let f = r.fit.as_ref().unwrap();
    assert_eq!(f.verdict, FitVerdict::Misfit);
    assert!(f.ratio > 4.0, "{f:?}");
    assert_eq!(f.expected_um, 0.35);

    // compensate refuses it, names the file and the way out.
    let refused = fivecal()
        .args(["compensate", "--machine", "bc-trunnion", "--errors"])
        .arg(p("r.yaml"))
        .args(["--export", "fanuc", "--no-record"])
        .output()
        .unwrap();
    assert!(!refused.status.success());
    let err = String::from_utf8(refused.stderr).unwrap();
    assert!(
        err.contains("r.yaml") && err.contains("does not fit") && err.contains("--accept-misfit"),
        "{err}"
    );
    assert!(refused.stdout.is_empty());
    // Accepted anyway: the values whose u (the noise taken at the
    // residuals', 7 times the stated) is above the usefulness threshold
    // are not among the result's values, so the export leaves them at
    // what the control holds and changes only what is known well enough.
    let r = yaml(&d.join("r.yaml"));
    assert!(!r.seen_not_usefully.is_empty(), "{r:?}");
    let taken = fivecal()
        .args(["compensate", "--machine", "bc-trunnion", "--errors"])
        .arg(p("r.yaml"))
        .args(["--export", "fanuc", "--no-record", "--accept-misfit"])
        .output()
        .unwrap();
    let err = String::from_utf8(taken.stderr).unwrap();
    assert!(taken.status.success(), "{err}");
    fivecal()
        .args(["compensate", "--machine", "bc-trunnion", "--errors"])
        .arg(p("r.yaml"))
        .args(["--export", "fanuc", "--no-record", "--accept-misfit"])
        .args(["--max-u", "0.05"])
        .assert()
        .success();

    // discover finds the drift; its model fits and compensate takes it.
    let out = fivecal()
        .args(["discover", "--plan", &plan, "--measured", &p("piece.dmo")])
        .args(["--out", &p("model.yaml"), "--db", &db])
        .output()
        .unwrap();
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("fit of the final model: fits"), "{text}");
    let m = yaml(&d.join("model.yaml"));
    assert_eq!(m.fit.as_ref().unwrap().verdict, FitVerdict::Fits);
    assert!(m.effects.thermal_drift.contains_key("EZ0B"));
    fivecal()
        .args(["compensate", "--machine", "bc-trunnion", "--errors"])
        .arg(p("model.yaml"))
        .args(["--export", "fanuc", "--no-record"])
        .assert()
        .success();

    // The store keeps each result's verdict.
    let out = fivecal()
        .args(["history", "--db", &db, "--machine", "bc-trunnion"])
        .output()
        .unwrap();
    let list = String::from_utf8(out.stdout).unwrap();
    let verdicts: Vec<&str> = list
        .lines()
        .filter_map(|l| {
            ["analyze", "discover"]
                .iter()
                .find(|k| l.contains(&format!(" {k} ")))
                .map(|_| {
                    if l.contains("misfit") {
                        "misfit"
                    } else {
                        "fits"
                    }
                })
        })
        .collect();
    assert_eq!(verdicts, ["misfit", "fits"], "{list}");
}

/// `--noise` states the instrument's noise: the same residuals against a
/// noisier CMM fit, and the result file says where the figure came from.
#[test]
fn a_stated_noise_judges_the_fit() {
    let r = goodness::judge(
        2.5,
        130,
        &ExpectedNoise::new(
            Some(2.4),
            fivecal::formats::manifest::TestKind::Machining,
            Test::SteppedSquare,
        ),
    )
    .unwrap();
    assert_eq!(r.verdict, FitVerdict::Fits);
    assert_eq!(r.expected_from, "stated with --noise");
    let out = fivecal()
        .args(["analyze", "--plan", "x.plan.yaml", "--measured", "m.csv"])
        .args(["--out", "r.yaml", "--noise", "0"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(err.contains("--noise 0"), "{err}");
}
