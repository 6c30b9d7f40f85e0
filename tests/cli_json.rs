//! `--json` on every command that has a result: standard output is one
//! JSON document with stable keys, checked here against the files the run
//! wrote and the words it printed for its user (on standard error).

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use serde_json::Value;

use crate::cli::fivecal;

/// A run that must succeed: its standard output parsed as JSON, and its
/// standard error (what it said for its user).
fn json_run(c: &mut assert_cmd::Command) -> (Value, String) {
    let o = c.output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{err}");
    let v: Value = serde_json::from_slice(&o.stdout)
        .unwrap_or_else(|e| panic!("{e}:\n{}", String::from_utf8_lossy(&o.stdout)));
    (v, err)
}

/// One demo run for the tests that read its files (its plan, programs,
/// results and store), in a directory of its own.
fn demo() -> &'static Path {
    static DIR: OnceLock<tempfile::TempDir> = OnceLock::new();
    DIR.get_or_init(|| {
        let d = tempfile::tempdir().unwrap();
        fivecal()
            .args(["demo", "--out"])
            .arg(d.path().join("demo"))
            .assert()
            .success();
        d
    })
    .path()
}

fn demo_file(name: &str) -> PathBuf {
    demo().join("demo").join(name)
}

fn strings(v: &Value) -> Vec<String> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|s| s.as_str().unwrap().to_string())
        .collect()
}

/// `plan --json`: every file it names exists, and what it says the plan
/// identifies is the manifest's `identifies:`.
#[test]
fn plan_json_names_its_files_and_the_manifests_identifiability() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("ss");
    let (v, err) = json_run(
        fivecal()
            .args([
                "plan",
                "stepped-square",
                "--machine",
                "bc-trunnion",
                "--json",
            ])
            .arg("--out")
            .arg(&out),
    );
    assert_eq!(v["test"], "stepped-square");
    assert_eq!(v["machine"], "bc-trunnion");
    assert_eq!(v["dialect"], "fanuc");
    let human = format!(
        "stepped-square on bc-trunnion: {} poses, {} points",
        v["poses"], v["points"]
    );
    assert!(err.contains(&human), "{human}\n{err}");
    let files = strings(&v["files"]);
    assert!(files.len() >= 5, "{files:?}");
    for f in &files {
        assert!(Path::new(f).is_file(), "{f}");
        assert!(err.contains(&format!("wrote {f}")), "{f}");
    }
    let manifest: Value = serde_yaml::from_str::<Value>(
        &std::fs::read_to_string(out.join("stepped-square.plan.yaml")).unwrap(),
    )
    .unwrap();
    // The same entry, to the last digit the YAML file keeps.
    let (printed, kept) = (&v["identifies"], &manifest["identifies"]);
    for key in ["method", "noise_um", "rank", "parameters", "not_separable"] {
        assert_eq!(printed[key], kept[key], "{key}");
    }
    let symbols = printed["symbols"].as_object().unwrap();
    assert_eq!(symbols.len(), kept["symbols"].as_object().unwrap().len());
    for (sym, s) in symbols {
        let k = &kept["symbols"][sym];
        assert_eq!(s["unit"], k["unit"], "{sym}");
        match (s["u"].as_f64(), k["u"].as_f64()) {
            (Some(a), Some(b)) => assert!((a - b).abs() <= 1e-12 * b.abs(), "{sym}: {a} {b}"),
            (a, b) => assert_eq!(a, b, "{sym}"),
        }
    }
    let missing = strings(&v["missing"]);
    for (sym, s) in v["identifies"]["symbols"].as_object().unwrap() {
        assert_eq!(s.get("u").is_none(), missing.contains(sym), "{sym}");
    }
}

/// `simulate --json`: the file written and as many points as it holds.
#[test]
fn simulate_json_counts_the_points_of_the_file_it_wrote() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("cmm.csv");
    let (v, err) = json_run(
        fivecal()
            .args(["simulate", "--json", "--plan"])
            .arg(demo_file("plan/stepped-square.plan.yaml"))
            .arg("--errors")
            .arg(demo_file("truth.yaml"))
            .arg("-o")
            .arg(&csv),
    );
    assert_eq!(
        (v["kind"].as_str(), v["format"].as_str(), v["seed"].as_u64()),
        (Some("machining"), Some("csv"), Some(1))
    );
    assert_eq!(v["placement"], "random");
    assert_eq!(strings(&v["files"]), [csv.display().to_string()]);
    let rows = std::fs::read_to_string(&csv)
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty() && !l.starts_with("label"))
        .count();
    assert_eq!(v["points"].as_u64(), Some(rows as u64));
    assert!(
        err.contains(&format!("{rows} points of the machined piece")),
        "{err}"
    );
}

/// `simulate nc --json --against`: the tool tip of the compensated program
/// against the original's path, as the human line rounds it, and one CSV
/// row per sample.
#[test]
fn simulate_nc_json_gives_the_deviation_the_text_rounds() {
    let dir = tempfile::tempdir().unwrap();
    let samples = dir.path().join("samples.csv");
    let (v, err) = json_run(
        fivecal()
            .args(["simulate", "nc", "--machine", "bc-trunnion", "--json"])
            .arg("--errors")
            .arg(demo_file("truth.yaml"))
            .arg(demo_file("frustum.compensated.nc"))
            .arg("--against")
            .arg(demo_file("frustum.nc"))
            .arg("-o")
            .arg(&samples),
    );
    assert_eq!(v["dialect"], "fanuc");
    let a = &v["against"];
    let line = format!(
        "RMS {:.2} um, max {:.2} um (line {})",
        a["rms_um"].as_f64().unwrap(),
        a["max_um"]["value"].as_f64().unwrap(),
        a["max_um"]["line"]
    );
    assert!(err.contains(&line), "{line}\n{err}");
    assert_eq!(strings(&v["files"]), [samples.display().to_string()]);
    let rows = std::fs::read_to_string(&samples)
        .unwrap()
        .lines()
        .filter(|l| l.starts_with(|c: char| c.is_ascii_digit()))
        .count();
    assert_eq!(v["samples"].as_u64(), Some(rows as u64));
    assert!(v["skipped"].as_array().unwrap().is_empty(), "{v}");
}

/// `compensate --json`: the counts the summary prints, the program and
/// the export written, and each exported parameter as the file holds it.
#[test]
fn compensate_json_gives_the_counts_and_the_parameters_written() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("comp.nc");
    let (v, err) = json_run(
        fivecal()
            .args(["compensate", "--machine", "bc-trunnion", "--json"])
            .arg("--errors")
            .arg(demo_file("discovered.yaml"))
            .arg(demo_file("frustum.nc"))
            .arg("-o")
            .arg(&out)
            .args(["--export", "fanuc"]),
    );
    let r = &v["rewrite"];
    let counts = format!(
        "{} blocks, {} moves: {} blocks changed",
        r["blocks"], r["moves"], r["corrected"]
    );
    assert!(err.contains(&counts), "{counts}\n{err}");
    assert!(r["skipped"].as_array().unwrap().is_empty());
    let export = v["export"]["file"].as_str().unwrap().to_string();
    assert_eq!(
        strings(&v["files"]),
        [out.display().to_string(), export.clone()]
    );
    assert!(out.is_file());
    let text = std::fs::read_to_string(&export).unwrap();
    let params = v["export"]["parameters"].as_array().unwrap();
    assert!(!params.is_empty());
    for p in params {
        let name = p["name"].as_str().unwrap();
        assert!(text.contains(name), "{name} not in {export}");
    }
    // Nothing on standard output but the JSON, even with a note to say.
    assert!(v.get("unchanged").is_none(), "{v}");
}

/// `verify --json` prints what `-o FILE.json` writes.
#[test]
fn verify_json_is_the_comparison_file() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("cmp.json");
    let (v, _) = json_run(
        fivecal()
            .args(["verify", "--json", "--before"])
            .arg(demo_file("discovered.yaml"))
            .arg("--after")
            .arg(demo_file("discovered.yaml"))
            .arg("-o")
            .arg(&file),
    );
    let written: Value = serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    assert_eq!(v, written);
    assert!(!v["changes"].as_array().unwrap().is_empty(), "{v}");
}

/// `history --json` (the list) and `history list --json` print the
/// records as the export writes them; `history show ID --json` the one
/// record.
#[test]
fn history_list_and_show_json_are_the_exports_records() {
    let db = demo_file("history.db");
    let (export, _) = json_run(
        fivecal()
            .args(["history", "export", "--json", "--db"])
            .arg(&db),
    );
    let (list, _) = json_run(
        fivecal()
            .args(["history", "list", "--json", "--db"])
            .arg(&db),
    );
    let (default, _) = json_run(fivecal().args(["history", "--json", "--db"]).arg(&db));
    assert_eq!(list, export);
    assert_eq!(default, export);
    let records = export.as_array().unwrap();
    assert!(records.len() >= 2, "{export}");
    let second = &records[1];
    let id = second["id"].to_string();
    let (show, _) = json_run(
        fivecal()
            .args(["history", "show", &id, "--json", "--db"])
            .arg(&db),
    );
    assert_eq!(&show, second);
    // export has its own --json: the global one before it is refused,
    // not ignored.
    fivecal()
        .args(["history", "--json", "export", "--db"])
        .arg(&db)
        .assert()
        .failure();
}

/// `history trend --json` holds what `history trend` prints, one entry per
/// location error in its order, the outlook in the words of the text;
/// `history plot --json` names the page and every file it wrote.
#[test]
fn history_trend_and_plot_json_say_what_the_text_and_the_page_hold() {
    let db = demo_file("history.db");
    let (trend, stderr) = json_run(
        fivecal()
            .args(["history", "trend", "--json", "--db"])
            .arg(&db),
    );
    assert!(stderr.is_empty() || !stderr.contains("trends"), "{stderr}");
    let text = fivecal()
        .args(["history", "trend", "--db"])
        .arg(&db)
        .output()
        .unwrap();
    let text = String::from_utf8(text.stdout).unwrap();
    let symbols = trend["symbols"].as_array().unwrap();
    assert!(!symbols.is_empty(), "{trend}");
    let lines: Vec<&str> = text
        .lines()
        .skip(1)
        .filter(|l| !l.contains("left out:"))
        .collect();
    assert_eq!(lines.len(), symbols.len(), "{text}\n{trend}");
    for (s, line) in symbols.iter().zip(&lines) {
        let name = s["symbol"].as_str().unwrap();
        assert_eq!(line.split_whitespace().next(), Some(name), "{line}");
        let words = match s["outlook"].as_str().unwrap() {
            "too-few" => "too few",
            "too-short" => "too short",
            "no-trend" => "no trend",
            "drifting" => "drift",
            o => panic!("outlook {o}"),
        };
        assert!(line.contains(words), "{line} against {s}");
        assert!(s["results"].as_u64().is_some(), "{s}");
    }
    assert_eq!(trend["machine"], "bc-trunnion", "{trend}");

    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("page");
    let (plot, _) = json_run(
        fivecal()
            .args(["history", "plot", "--json", "--db"])
            .arg(&db)
            .arg("-o")
            .arg(&page),
    );
    assert_eq!(plot["page"], page.join("index.html").display().to_string());
    let files = strings(&plot["files"]);
    assert_eq!(files.len(), symbols.len() + 1, "{plot}");
    for f in files {
        assert!(Path::new(&f).is_file(), "{f}");
    }
}

/// `plan ball-bar --json`: the setups and readings it printed, every file
/// it wrote, and per axis what the runs will identify: each of the six
/// terms with its predicted u, or none where no setup sees it.
#[test]
fn plan_ball_bar_json_names_its_files_and_what_each_axis_identifies() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("bb");
    let (v, err) = json_run(
        fivecal()
            .args(["plan", "ball-bar", "--machine", "bc-trunnion"])
            .args(["--bar", "100,150,300", "--json", "-o"])
            .arg(&out),
    );
    assert_eq!(v["test"], "ball-bar");
    assert_eq!(v["machine"], "bc-trunnion");
    let human = format!(
        "ball-bar on bc-trunnion: {} setups, {} readings",
        v["setups"], v["readings"]
    );
    assert!(err.contains(&human), "{human}\n{err}");
    for f in strings(&v["files"]) {
        assert!(Path::new(&f).is_file(), "{f}");
    }
    let axes = v["axes"].as_array().unwrap();
    let mut letters: Vec<&str> = axes.iter().map(|a| a["axis"].as_str().unwrap()).collect();
    letters.sort();
    assert_eq!(letters, ["B", "C"]);
    for a in axes {
        let terms = a["terms"].as_array().unwrap();
        assert_eq!(terms.len(), 6);
        for t in terms {
            // A number where every angle sees the term, else the angles
            // where none does: never both, never neither.
            let unseen = t["unseen_at_deg"].as_array().unwrap();
            assert_eq!(t["u_max"].is_null(), !unseen.is_empty(), "{t}");
            if let Some(u) = t["u_max"].as_f64() {
                assert!(u > 0.0 && u.is_finite(), "{t}");
            }
        }
    }
}

/// `plan laser-lines --json`: ten lines, each with where it starts and how
/// its offset is made, the files it wrote, and standard output left to the
/// JSON.
#[test]
fn plan_laser_lines_json_lists_the_ten_lines_and_their_files() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("laser");
    let (v, err) = json_run(
        fivecal()
            .args(["plan", "laser-lines", "--machine", "head-table"])
            .args(["--divisions", "4", "--runs", "2", "--json", "-o"])
            .arg(&out),
    );
    assert_eq!(v["test"], "laser-lines");
    assert_eq!(v["targets"], 5);
    assert_eq!(v["runs"], 2);
    let lines = v["lines"].as_array().unwrap();
    let names: Vec<&str> = lines.iter().map(|l| l["name"].as_str().unwrap()).collect();
    assert_eq!(
        names,
        ["L1", "L2", "L3", "L4", "L5", "L6", "L7", "L8", "L9", "L10"]
    );
    for l in lines {
        let by = l["offset_by"].as_str().unwrap();
        assert!(["none", "axes", "bracket"].contains(&by), "{l}");
        assert!(l["length_mm"].as_f64().unwrap() > 0.0, "{l}");
    }
    assert!(err.contains("laser-lines on head-table: 10 lines"), "{err}");
    let files = strings(&v["files"]);
    assert!(files.iter().any(|f| f.ends_with("laser-lines.plan.yaml")));
    for f in &files {
        assert!(Path::new(f).is_file(), "{f}");
    }
}
