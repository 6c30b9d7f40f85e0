//! `fivecal discover` as a user runs it, on the worked example of
//! `examples/discover/` (a planned stepped square run on a virtual machine
//! that hides a tool radius error, a drift of EZ0B and a B-axis
//! positioning map; the truth is in `truth.yaml` beside it).

use std::path::{Path, PathBuf};

use fivecal::errorfile::ErrorFile;
use fivecal::kinematics::Kinematics;

use crate::cli::fivecal;
use crate::util::{machine, tempdir};

fn example(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples/discover")
        .join(name)
}

fn args(extra: &[&str]) -> Vec<String> {
    let mut v: Vec<String> = vec![
        "discover".into(),
        "--plan".into(),
        example("stepped-square.plan.yaml").display().to_string(),
        "--measured".into(),
        example("piece.dmo").display().to_string(),
    ];
    v.extend(extra.iter().map(|s| s.to_string()));
    v
}

#[test]
fn the_worked_example_tells_the_story_the_readme_shows() {
    let out = fivecal()
        .args(args(&[]))
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let text = String::from_utf8(out).unwrap();
    let story = std::fs::read_to_string(example("story.txt")).unwrap();
    assert_eq!(text, story, "examples/discover/story.txt is out of date");
    // The effects the truth hides, the larger first.
    let truth = std::fs::read_to_string(example("truth.yaml")).unwrap();
    assert!(
        truth.contains("thermal_drift")
            && truth.contains("tool_radius")
            && truth.contains("EBB(B)")
    );
    let s1 = text.find("step 1: add tool_radius").unwrap();
    let s2 = text.find("step 2: add drift.EZ0B/seq").unwrap();
    let s3 = text.find("step 3: add map.EBB(B)").unwrap();
    assert!(s1 < s2 && s2 < s3 && !text.contains("step 4"));
    // A step's values are provisional, each beside its final value: the
    // drift is refitted once the map joins the model.
    let step2 = &text[s2..s3];
    assert!(step2.contains("provisional values"), "{step2}");
    let line = step2
        .lines()
        .find(|l| l.trim_start().starts_with("drift.EZ0B/seq"))
        .unwrap();
    let final_drift = text[s3..]
        .lines()
        .find(|l| l.trim_start().starts_with("drift.EZ0B/seq"))
        .unwrap()
        .split_whitespace()
        .nth(1)
        .unwrap()
        .to_string();
    assert!(line.contains(&format!("final {final_drift}")), "{line}");
    assert!(text.contains("final model (the values to quote)"));
    // The rival that comes next is shown at step 1, and said to come next;
    // no rival is hidden behind a count or promised to come next.
    let step1 = &text[s1..s2];
    assert!(
        step1.contains("rival drift.EZ0B/seq (gap") && step1.contains("added at step 2"),
        "{step1}"
    );
    assert!(!text.contains("more rivals") && !text.contains("may come next"));
}

#[test]
fn json_story_has_the_steps_with_values_uncertainties_and_gaps() {
    let out = fivecal()
        .args(args(&["--json"]))
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let j: serde_json::Value = serde_json::from_slice(&out).unwrap();
    let steps = j["steps"].as_array().unwrap();
    assert_eq!(steps.len(), 3);
    assert_eq!(steps[0]["name"], "tool_radius");
    assert_eq!(steps[1]["name"], "drift.EZ0B/seq");
    assert_eq!(steps[2]["name"], "map.EBB(B)");
    for st in steps {
        let values = st["provisional_values"].as_array().unwrap();
        assert!(!values.is_empty());
        for v in values {
            assert!(v["value"].is_f64() && v["u"].as_f64().unwrap() > 0.0, "{v}");
        }
        let (b, a) = (&st["gap_before"], &st["gap_after"]);
        assert!(a["rms_um"].as_f64().unwrap() < b["rms_um"].as_f64().unwrap());
        // The largest residual need not fall at every step (here the first
        // leaves it where it was); the RMS does.
        assert!(a["max_um"].as_f64().unwrap() >= a["rms_um"].as_f64().unwrap());
    }
    // One naming scheme: every value is a location symbol or named after
    // its effect, the candidate names of the story.
    let mut names: Vec<&str> = Vec::new();
    for st in steps {
        for v in st["provisional_values"].as_array().unwrap() {
            names.push(v["name"].as_str().unwrap());
        }
        for r in st["rivals"].as_array().unwrap() {
            assert!(r["exactly_indistinguishable"].is_boolean(), "{r}");
        }
        // The effect goes by one name: no second identifier beside it.
        assert!(st.get("effect").is_none(), "{st}");
    }
    for v in j["end"]["values"].as_array().unwrap() {
        names.push(v["name"].as_str().unwrap());
    }
    let effects: Vec<&str> = j["last_round"]
        .as_array()
        .unwrap()
        .iter()
        .chain(steps)
        .map(|t| t["name"].as_str().unwrap())
        .collect();
    let location = [
        "EX0B", "EZ0B", "EA0B", "EC0B", "EB0B", "EX(0B)C", "EY0C", "EA(0B)C",
    ];
    for n in &names {
        assert!(
            location.contains(n)
                || effects.iter().any(|e| n == e
                    || n.strip_prefix(e).is_some_and(|r| r.starts_with(['@', '.']))),
            "{n} is neither a location symbol nor named after one of {effects:?}"
        );
    }
    assert!(names.contains(&"map.EBB(B)@B=90") && names.contains(&"drift.EZ0B/seq"));
    // The gap of one step is the gap before the next.
    assert_eq!(steps[0]["gap_after"], steps[1]["gap_before"]);
    assert_eq!(steps[1]["gap_after"], steps[2]["gap_before"]);
    assert_eq!(steps[2]["gap_after"]["rms_um"], j["end"]["gap"]["rms_um"]);
}

#[test]
fn out_writes_the_final_model_as_an_error_file_and_report_draws_the_gap() {
    let dir = tempdir();
    let out = dir.path().join("discovered.yaml");
    let report = dir.path().join("report");
    fivecal()
        .args(args(&[
            "--out",
            out.to_str().unwrap(),
            "--report",
            report.to_str().unwrap(),
        ]))
        .assert()
        .success();
    // The error file reads back with the effects found, values within
    // four u of the truth.
    let m = machine("bc-trunnion");
    let kin = Kinematics::with_gauge_length(&m, 60.0);
    let found = ErrorFile::load(&out, &kin).unwrap();
    let truth = ErrorFile::load(&example("truth.yaml"), &kin).unwrap();
    let names = found.model.param_names();
    for name in [
        "drift.EZ0B/seq",
        "map.EBB(B)@B=-90",
        "map.EBB(B)@B=0",
        "map.EBB(B)@B=90",
        "EZ0B",
    ] {
        let i = names.iter().position(|n| n == name).unwrap();
        let t = truth
            .model
            .param_names()
            .iter()
            .position(|n| n == name)
            .unwrap();
        let u = found.u[i].unwrap();
        assert!(
            (found.theta[i] - truth.theta[t]).abs() < 4.0 * u,
            "{name}: {} +- {u} against {}",
            found.theta[i],
            truth.theta[t]
        );
    }
    let html = std::fs::read_to_string(report.join("index.html")).unwrap();
    for s in [
        "gap.svg",
        "residuals-before.svg",
        "residuals-after.svg",
        "drift.EZ0B/seq",
        "map.EBB(B)",
    ] {
        assert!(html.contains(s), "{s}");
    }
    let svg = std::fs::read_to_string(report.join("gap.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("+map.EBB(B)"));
}

#[test]
fn candidates_and_start_steer_the_search() {
    // Only maps: the radius and the drift are not tried, so the gap stays
    // above the noise.
    let out = fivecal()
        .args(args(&["--candidates", "map", "--json"]))
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let j: serde_json::Value = serde_json::from_slice(&out).unwrap();
    let names: Vec<&str> = j["steps"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["name"].as_str().unwrap())
        .collect();
    assert!(names.iter().all(|n| n.starts_with("map.")), "{names:?}");
    assert!(j["end"]["gap"]["rms_um"].as_f64().unwrap() > 0.5);
    // Starting from the radius and the drift, the map is what is left to
    // find.
    let out = fivecal()
        .args(args(&[
            "--start",
            "location,tool_radius,drift.EZ0B/seq",
            "--json",
        ]))
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let j: serde_json::Value = serde_json::from_slice(&out).unwrap();
    assert_eq!(j["start"]["model"][2], "drift.EZ0B/seq");
    assert_eq!(j["steps"][0]["name"], "map.EBB(B)");
    assert_eq!(j["steps"].as_array().unwrap().len(), 1);
}

#[test]
fn bad_requests_fail_with_the_reason_and_write_nothing() {
    let dir = tempdir();
    let out = dir.path().join("r.yaml");
    let o = out.to_str().unwrap();
    for (extra, expected) in [
        (
            vec!["--alpha", "1.5"],
            "--alpha 1.5: expected a significance level between 0 and 1",
        ),
        (
            vec!["--candidates", "spindle_growth"],
            "`spindle_growth` names no candidate of this test",
        ),
        (
            vec!["--start", "location,map.EQQ(B)"],
            "`map.EQQ(B)` is not a candidate of this test",
        ),
    ] {
        let mut a: Vec<&str> = extra.clone();
        a.extend(["--out", o]);
        let err = fivecal()
            .args(args(&a))
            .assert()
            .code(2)
            .get_output()
            .stderr
            .clone();
        let err = String::from_utf8(err).unwrap();
        assert!(err.contains(expected), "{extra:?}: {err}");
        assert!(!out.exists());
    }
    // The input is never overwritten.
    let piece = example("piece.dmo");
    let err = fivecal()
        .args(args(&["--out", piece.to_str().unwrap()]))
        .assert()
        .code(2)
        .get_output()
        .stderr
        .clone();
    assert!(String::from_utf8(err).unwrap().contains("input"));
    // A measurement of another plan is refused, naming the file and line.
    let other =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/analyze/probe-sphere/PROBE.TXT");
    let err = fivecal()
        .args([
            "discover",
            "--plan",
            example("stepped-square.plan.yaml").to_str().unwrap(),
            "--measured",
            other.to_str().unwrap(),
        ])
        .assert()
        .code(2)
        .get_output()
        .stderr
        .clone();
    let err = String::from_utf8(err).unwrap();
    assert!(err.contains("PROBE.TXT:"), "{err}");
}

/// What a successful run printed.
fn stdout_of(args: &[&str]) -> String {
    let out = fivecal().args(args).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{args:?}: {err}");
    String::from_utf8(out.stdout).unwrap()
}

/// The stepped square cannot tell a B axis line wandering in X from one
/// wandering in Z (EXB(B) against EZB(B)): discover says so, writes the
/// ambiguity and the supplementary test that separates them into its
/// result, `plan --supplement` writes that test for the same machine, and
/// the next discover, given both tests' measurements, names EXB(B) with
/// values within 4 u of the truth and a model that fits.
#[test]
fn an_ambiguity_is_resolved_by_the_supplementary_test_discover_asked_for() {
    let dir = tempdir();
    let d = dir.path();
    let p = |s: &str| d.join(s).display().to_string();
    // The truth's map is linear in B, so that on the finer nodes of the
    // two tests together it still averages to zero (as identified maps do).
    std::fs::write(
        d.join("truth.yaml"),
        "machine: bc-trunnion
location_errors: {EX0B: 12.0, EZ0B: -25.0, EA0B: 60.0, EC0B: -45.0, EB0B: 110.0, EX(0B)C: 18.0, EY0C: -15.0, EA(0B)C: 35.0}
position_dependent:
  EXB(B): {B: [-90, 0, 90], values: [4.0, 0.0, -4.0]}
effects:
  noise: {cmm: 0.35, probe: 0.35}
",
    )
    .unwrap();
    fivecal()
        .args([
            "plan",
            "stepped-square",
            "--machine",
            "bc-trunnion",
            "--out",
            &p("ss"),
        ])
        .assert()
        .success();
    let ss = p("ss/stepped-square.plan.yaml");
    fivecal()
        .args(["simulate", "--plan", &ss, "--errors", &p("truth.yaml")])
        .args(["--out", &p("piece.dmo")])
        .assert()
        .success();
    let text = stdout_of(&[
        "discover",
        "--plan",
        &ss,
        "--measured",
        &p("piece.dmo"),
        "--out",
        &p("first.yaml"),
        "--no-record",
    ]);
    assert!(
        text.contains("exactly indistinguishable on this test"),
        "{text}"
    );
    assert!(text.contains("fivecal plan --supplement"), "{text}");
    let first = ErrorFile::read(&d.join("first.yaml")).unwrap().0;
    let a = first.ambiguity.as_ref().unwrap();
    let s = a.supplement.as_ref().unwrap();
    assert_eq!(s.plan.as_deref(), Some(ss.as_str()));
    // The first test's noise, not its gap.
    assert_eq!(first.effects.noise.as_ref().unwrap().cmm, Some(0.35));

    // The supplementary test, for the machine and dialect of the first.
    let text = stdout_of(&[
        "plan",
        "--supplement",
        &p("first.yaml"),
        "--out",
        &p("supp"),
    ]);
    assert!(
        text.starts_with(&format!(
            "probe-sphere on bc-trunnion: {} poses, {} touches",
            s.poses, s.touches
        )),
        "{text}"
    );
    let template = std::fs::read_to_string(d.join("supp/probe-sphere.template.yaml")).unwrap();
    assert!(template.contains("pattern: grid") && template.contains("tilt: [-90, -45, 0, 45, 90]"));
    let supp = p("supp/probe-sphere.plan.yaml");
    fivecal()
        .args(["simulate", "--plan", &supp, "--errors", &p("truth.yaml")])
        .args(["--out", &p("supp/PROBE.TXT")])
        .assert()
        .success();

    // Both tests together decide.
    let text = stdout_of(&[
        "discover",
        "--plan",
        &ss,
        "--measured",
        &p("piece.dmo"),
        "--plan",
        &supp,
        "--measured",
        &p("supp/PROBE.TXT"),
        "--out",
        &p("both.yaml"),
        "--db",
        &p("history.db"),
    ]);
    assert!(text.contains("step 1: add map.EXB(B)"), "{text}");
    assert!(
        !text.contains("step 2") && !text.contains("ambiguous"),
        "{text}"
    );
    assert!(text.contains("fit of the final model: fits"), "{text}");
    let m = machine("bc-trunnion");
    let kin = Kinematics::with_gauge_length(&m, 60.0);
    let both = ErrorFile::load(&d.join("both.yaml"), &kin).unwrap();
    assert!(
        both.not_identifiable
            .iter()
            .all(|n| !n.symbol.contains("EXB"))
    );
    let names = both.model.param_names();
    // The truth at the joint nodes: linear in B.
    for (name, t) in [
        ("map.EXB(B)@B=-90", 4.0),
        ("map.EXB(B)@B=-45", 2.0),
        ("map.EXB(B)@B=0", 0.0),
        ("map.EXB(B)@B=45", -2.0),
        ("map.EXB(B)@B=90", -4.0),
        ("EX0B", 12.0),
        ("EZ0B", -25.0),
    ] {
        let i = names.iter().position(|n| n == name).unwrap();
        let u = both.u[i].unwrap();
        assert!(
            (both.theta[i] - t).abs() < 4.0 * u,
            "{name}: {} +- {u} against {t}",
            both.theta[i]
        );
    }
    // The store keeps the result with both tests' plans and files.
    let list = stdout_of(&[
        "history",
        "--db",
        &p("history.db"),
        "--machine",
        "bc-trunnion",
    ]);
    assert!(list.contains("stepped-square + probe-sphere"), "{list}");
    // A result without an ambiguity asks for no supplement; the tests and
    // their files must pair up.
    let out = fivecal()
        .args(["plan", "--supplement", &p("both.yaml"), "--out", &p("x")])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("states no ambiguity"));
    let out = fivecal()
        .args(["discover", "--plan", &ss, "--plan", &supp])
        .args(["--measured", &p("piece.dmo")])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("each --plan takes its own --measured"));
}
