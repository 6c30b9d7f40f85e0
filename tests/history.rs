//! A machine's history as a user keeps it: the demo's runs in its store,
//! `fivecal history` listing, showing, exporting and plotting them,
//! `fivecal verify` before and after the demo's export, `analyze --limits`
//! deciding at the limits' edges, recording from `analyze`, `discover`
//! and `compensate --export`, and the trend forecast on a series of
//! simulated measurements of a machine whose EX0B drifts day by day.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use fivecal::analyze::{self, Found};
use fivecal::conformance::{AcceptanceLimits, Limit};
use fivecal::errorfile::ErrorFile;
use fivecal::history::History;
use fivecal::history::trend::{Forecast, Outlook, days_between};
use fivecal::store::runs::{self, RunNotes};
use fivecal::store::{Location, RecordKind, Store, parse_time};

use crate::cli::fivecal;

/// The demo, run once for every test here, in a directory of its own.
fn demo_dir() -> &'static Path {
    static DIR: OnceLock<tempfile::TempDir> = OnceLock::new();
    DIR.get_or_init(|| {
        let d = tempfile::tempdir().unwrap();
        fivecal::demo::run(
            &fivecal::demo::DemoConfig {
                out: d.path().join("fivecal-demo"),
                seed: 1,
            },
            &mut |_| {},
        )
        .unwrap();
        d
    })
    .path()
}

fn demo_out() -> PathBuf {
    demo_dir().join("fivecal-demo")
}

fn stdout(c: &mut assert_cmd::Command) -> String {
    let o = c.output().unwrap();
    assert!(
        o.status.success(),
        "{}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8(o.stdout).unwrap()
}

fn stderr_of_failure(c: &mut assert_cmd::Command) -> String {
    let o = c.output().unwrap();
    assert_eq!(
        o.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
    String::from_utf8(o.stderr).unwrap()
}

/// `fivecal history --db fivecal-demo/history.db` lists the demo's four
/// runs in order: the analysis, the discovered model, the export to the
/// FANUC control and the analysis after it; `show` prints one with the
/// hashes of the files it read, equal to the files' own.
#[test]
fn the_demo_records_its_runs_and_history_lists_them() {
    let db = demo_out().join("history.db");
    let text = stdout(fivecal().current_dir(demo_dir()).args([
        "history",
        "--db",
        "fivecal-demo/history.db",
    ]));
    let rows: Vec<Vec<&str>> = text
        .lines()
        .skip(1)
        .map(|l| l.split_whitespace().collect())
        .collect();
    assert_eq!(rows.len(), 4, "{text}");
    let kinds: Vec<&str> = rows.iter().map(|r| r[4]).collect();
    assert_eq!(
        kinds,
        ["analyze", "discover", "export", "analyze"],
        "{text}"
    );
    assert!(rows.iter().all(|r| r[3] == "bc-trunnion"), "{text}");
    assert_eq!(rows[2][5], "fanuc", "{text}");

    let mut store = Store::open(&Location::Sqlite(db.clone())).unwrap();
    let records = store.list(Some("bc-trunnion")).unwrap();
    let first = &records[0];
    let measured = std::fs::read(demo_out().join("measured.dmo")).unwrap();
    assert_eq!(
        first.record.files[0].sha256,
        fivecal::store::sha256_hex(&measured)
    );
    assert_eq!(
        first.record.content,
        std::fs::read_to_string(demo_out().join("analyzed.yaml")).unwrap()
    );
    let show = stdout(
        fivecal()
            .args(["history", "show"])
            .arg(first.id.to_string())
            .arg("--db")
            .arg(&db),
    );
    assert!(show.contains(&first.record.files[0].sha256), "{show}");
    assert!(show.contains("location_errors:"), "{show}");
    assert!(
        stderr_of_failure(
            fivecal()
                .args(["history", "show", "999"])
                .arg("--db")
                .arg(&db)
        )
        .contains("no record 999")
    );
}

/// The CSV export has a row per record and location symbol with value, u
/// and unit as in the result; the JSON export carries the same values.
#[test]
fn history_exports_csv_and_json_with_the_results_values() {
    let db = demo_out().join("history.db");
    let csv_text = stdout(
        fivecal()
            .args(["history", "export", "--format", "csv", "--db"])
            .arg(&db),
    );
    let mut r = csv::Reader::from_reader(csv_text.as_bytes());
    let head = r.headers().unwrap().clone();
    let col = |n: &str| head.iter().position(|h| h == n).unwrap();
    let rows: Vec<csv::StringRecord> = r.records().map(|x| x.unwrap()).collect();
    let (analyzed, _) = ErrorFile::read(&demo_out().join("analyzed.yaml")).unwrap();
    let ex = &analyzed.location_errors["EX0B"];
    let row = rows
        .iter()
        .find(|row| &row[col("id")] == "1" && &row[col("symbol")] == "EX0B")
        .expect("EX0B of record 1");
    // The same number, read by two parsers (the YAML one may differ in
    // the last bit).
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs();
    assert!(close(row[col("value")].parse().unwrap(), ex.value));
    assert!(close(row[col("u")].parse().unwrap(), ex.u.unwrap()));
    assert_eq!(&row[col("unit")], "um");
    let json = stdout(
        fivecal()
            .args(["history", "export", "--format", "json", "--db"])
            .arg(&db),
    );
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(v.as_array().unwrap().len(), 4);
    assert!(close(
        v[0]["location_errors"]["EX0B"]["value"].as_f64().unwrap(),
        ex.value
    ));
    assert_eq!(v[2]["kind"], "export");
    assert_eq!(v[2]["controller"], "fanuc");
}

/// `verify` on the demo's results. The first analysis is a misfit (the
/// drift the location errors cannot express), and so is the analysis of
/// the piece measured after the export (the drift is still there): verify
/// refuses both, from the files and from the store, naming the result and
/// its verdict; it once compared them without a word. Results of two tests
/// are refused too; two results of one test that fit are compared, with
/// the limits decided.
#[test]
fn verify_on_the_demo_refuses_misfits_and_other_tests() {
    let out = demo_out();
    let dir = tempfile::tempdir().unwrap();
    let limits = dir.path().join("limits.yaml");
    std::fs::write(
        &limits,
        "machine: bc-trunnion\nlimits:\n  EX0B: 10\n  EX(0B)C: 10\n",
    )
    .unwrap();
    let verify = |before: &str, after: &str| {
        stderr_of_failure(
            fivecal()
                .arg("verify")
                .arg("--before")
                .arg(out.join(before))
                .arg("--after")
                .arg(out.join(after)),
        )
    };
    let err = verify("analyzed.yaml", "analyzed.after.yaml");
    assert!(
        err.contains("analyzed.yaml: its verdict is misfit"),
        "{err}"
    );
    let err = verify("discovered.yaml", "analyzed.after.yaml");
    assert!(
        err.contains("analyzed.after.yaml: its verdict is misfit"),
        "{err}"
    );
    let err = stderr_of_failure(
        fivecal()
            .args(["verify", "--machine", "bc-trunnion", "--db"])
            .arg(out.join("history.db")),
    );
    assert!(err.contains("record 4") && err.contains("misfit"), "{err}");
    // The discovered model as if from two tests: refused; of one test:
    // compared.
    let discovered = std::fs::read_to_string(out.join("discovered.yaml")).unwrap();
    let as_test = |test: &str| {
        let p = dir.path().join(format!("{test}.yaml"));
        std::fs::write(
            &p,
            discovered.replacen(
                "machine: bc-trunnion\n",
                &format!("machine: bc-trunnion\ntest: {test}\n"),
                1,
            ),
        )
        .unwrap();
        p
    };
    let err = stderr_of_failure(
        fivecal()
            .arg("verify")
            .arg("--before")
            .arg(as_test("stepped-square"))
            .arg("--after")
            .arg(as_test("probe-sphere")),
    );
    assert!(
        err.contains("of the stepped-square test") && err.contains("of the probe-sphere test"),
        "{err}"
    );
    let text = stdout(
        fivecal()
            .arg("verify")
            .arg("--before")
            .arg(as_test("stepped-square"))
            .arg("--after")
            .arg(as_test("stepped-square"))
            .arg("--limits")
            .arg(&limits),
    );
    assert!(text.contains("EX0B"), "{text}");
    let other = stderr_of_failure(
        fivecal()
            .arg("verify")
            .arg("--before")
            .arg(out.join("discovered.yaml"))
            .arg("--after")
            .arg(out.join("truth.yaml"))
            .arg("--limits")
            .arg(dir.path().join("missing.yaml")),
    );
    assert!(other.contains("missing.yaml"), "{other}");
}

/// `history plot` writes the page and one SVG per location error, with
/// the export and the limit drawn.
#[test]
fn history_plot_writes_a_page_with_each_error_over_time() {
    let dir = tempfile::tempdir().unwrap();
    let limits = dir.path().join("limits.yaml");
    std::fs::write(&limits, "limits:\n  EX0B: 10\n").unwrap();
    let page = dir.path().join("hist");
    let text = stdout(
        fivecal()
            .args(["history", "plot", "--db"])
            .arg(demo_out().join("history.db"))
            .arg("--out")
            .arg(&page)
            .arg("--limits")
            .arg(&limits),
    );
    assert!(text.contains("history of bc-trunnion"), "{text}");
    let html = std::fs::read_to_string(page.join("index.html")).unwrap();
    assert!(html.contains("History of bc-trunnion") && html.contains("history-EX0B.svg"));
    let svg = std::fs::read_to_string(page.join("history-EX0B.svg")).unwrap();
    assert!(
        svg.contains("export (control changed)") && svg.contains("limit"),
        "{svg}"
    );
    assert!(!svg.contains("NaN"));
}

/// `history plot --out` naming an existing file is refused with the
/// option and the file, not with the OS's bare "Not a directory".
#[test]
fn history_plot_onto_an_existing_file_names_it() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("taken.txt");
    std::fs::write(&file, "mine").unwrap();
    let err = fivecal()
        .args(["history", "plot", "--db"])
        .arg(demo_out().join("history.db"))
        .arg("--out")
        .arg(&file)
        .assert()
        .failure()
        .get_output()
        .stderr
        .clone();
    let err = String::from_utf8_lossy(&err);
    assert!(err.contains("taken.txt") && err.contains("--out"), "{err}");
    assert!(!err.contains("os error"), "{err}");
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "mine");
}

/// `analyze --limits` decides each symbol with U = 2u: a bound 2u + 0.1
/// beyond |value| passes, a bound at |value| cannot decide, a bound 2u +
/// 0.1 inside |value| fails, and the machine fails. A limit on a name that
/// is no location symbol is refused with its line.
#[test]
fn analyze_decides_at_the_limits_edges() {
    let out = demo_out();
    let (a, _) = ErrorFile::read(&out.join("analyzed.yaml")).unwrap();
    let q = |s: &str| {
        let q = &a.location_errors[s];
        (q.value.abs(), 2.0 * q.u.unwrap())
    };
    let (ex, uex) = q("EX0B");
    let (ez, _) = q("EZ0B");
    let (eb, ueb) = q("EB0B");
    let dir = tempfile::tempdir().unwrap();
    let limits = dir.path().join("limits.yaml");
    std::fs::write(
        &limits,
        format!(
            "limits:\n  EX0B: {}\n  EZ0B: {}\n  EB0B: {}\n",
            ex + uex + 0.1,
            ez,
            eb - ueb - 0.1
        ),
    )
    .unwrap();
    let run = |limits: &Path| {
        let mut c = fivecal();
        c.args(["analyze", "--no-record", "--plan"])
            .arg(out.join("plan/stepped-square.plan.yaml"))
            .arg("--measured")
            .arg(out.join("measured.dmo"))
            .arg("--out")
            .arg(dir.path().join("r.yaml"))
            .arg("--limits")
            .arg(limits);
        c
    };
    let text = stdout(&mut run(&limits));
    // The acceptance block follows the identification's own listing.
    let block = &text[text
        .find("acceptance (ISO 14253-1")
        .expect("the acceptance block")..];
    let decision = |s: &str| {
        block
            .lines()
            .find(|l| l.split_whitespace().next() == Some(s))
            .unwrap_or_else(|| panic!("{s} in {block}"))
            .to_string()
    };
    assert!(decision("EX0B").contains("PASS"), "{text}");
    assert!(decision("EZ0B").contains("cannot decide"), "{text}");
    assert!(decision("EB0B").contains("FAIL"), "{text}");
    assert!(text.contains("machine: FAIL"), "{text}");

    std::fs::write(&limits, "limits:\n  EX0B: 10\n  EXX: 5\n").unwrap();
    let err = stderr_of_failure(&mut run(&limits));
    assert!(
        err.contains("limits.yaml") && err.contains(":3:") && err.contains("EXX"),
        "{err}"
    );
}

/// `analyze`, `discover --out` and `compensate --export` record into the
/// store `--db` names, with the note and temperature given; `--no-record`
/// adds nothing; a bad temperature is refused before anything runs.
#[test]
fn analyze_discover_and_export_record_into_the_store() {
    let out = demo_out();
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("shop.db");
    let manifest = out.join("plan/stepped-square.plan.yaml");
    let measured = out.join("measured.dmo");
    let analyze = |extra: &[&str], name: &str| {
        let mut c = fivecal();
        c.arg("analyze")
            .arg("--plan")
            .arg(&manifest)
            .arg("--measured")
            .arg(&measured)
            .arg("--out")
            .arg(dir.path().join(name))
            .args(extra);
        c
    };
    let text = stdout(&mut analyze(
        &[
            "--db",
            db.to_str().unwrap(),
            "--note",
            "weekly check",
            "--temperature",
            "21.5",
            "--measured-at",
            "2026-03-01T08:30:00+01:00",
        ],
        "a.yaml",
    ));
    assert!(text.contains("recorded as record 1 in"), "{text}");
    stdout(&mut analyze(&["--no-record"], "b.yaml"));
    let err = stderr_of_failure(&mut analyze(
        &["--db", db.to_str().unwrap(), "--temperature", "NaN"],
        "c.yaml",
    ));
    assert!(err.contains("--temperature"), "{err}");
    assert!(!dir.path().join("c.yaml").exists());
    let text = stdout(
        fivecal()
            .args(["discover", "--max-steps", "1", "--plan"])
            .arg(&manifest)
            .arg("--measured")
            .arg(&measured)
            .arg("--out")
            .arg(dir.path().join("model.yaml"))
            .arg("--db")
            .arg(&db),
    );
    assert!(text.contains("recorded as record 2"), "{text}");
    // --db without --entered: nothing to record it in.
    let err = stderr_of_failure(
        fivecal()
            .args(["compensate", "--machine", "bc-trunnion", "--errors"])
            .arg(dir.path().join("model.yaml"))
            .args(["--export", "fanuc", "--export-to"])
            .arg(dir.path().join("params.txt"))
            .arg("--db")
            .arg(&db),
    );
    assert!(
        err.contains("--db goes with a record") && err.contains("--entered"),
        "{err}"
    );
    // Without --entered the export is a preview: the control is not
    // changed, nothing is recorded (in the store FIVECAL_DB names), and
    // the history and its trends stay as they were.
    let trend = |db: &std::path::Path| {
        stdout(
            fivecal()
                .args(["history", "trend", "--machine", "bc-trunnion", "--db"])
                .arg(db),
        )
    };
    let trend_before = trend(&db);
    assert_eq!(
        Store::open(&Location::Sqlite(db.clone()))
            .unwrap()
            .list(None)
            .unwrap()
            .len(),
        2
    );
    let preview = fivecal()
        .env("FIVECAL_DB", &db)
        .args(["compensate", "--machine", "bc-trunnion", "--errors"])
        .arg(dir.path().join("model.yaml"))
        .args(["--export", "fanuc"])
        .output()
        .unwrap();
    assert!(preview.status.success());
    let said = String::from_utf8_lossy(&preview.stderr);
    assert!(said.contains("not recorded: a preview"), "{said}");
    assert_eq!(
        Store::open(&Location::Sqlite(db.clone()))
            .unwrap()
            .list(None)
            .unwrap()
            .len(),
        2
    );
    assert_eq!(trend(&db), trend_before);
    let text = stdout(
        fivecal()
            .args(["compensate", "--machine", "bc-trunnion", "--errors"])
            .arg(dir.path().join("model.yaml"))
            .args(["--export", "fanuc", "--entered", "--export-to"])
            .arg(dir.path().join("params.txt"))
            .arg("--db")
            .arg(&db),
    );
    assert!(text.contains("recorded as record 3"), "{text}");

    let mut store = Store::open(&Location::Sqlite(db)).unwrap();
    let all = store.list(None).unwrap();
    assert_eq!(all.len(), 3);
    let a = &all[0].record;
    assert_eq!(a.kind, RecordKind::Analyze);
    assert_eq!(a.note.as_deref(), Some("weekly check"));
    assert_eq!(a.temperature, Some(21.5));
    assert_eq!(a.measured_at, parse_time("2026-03-01T07:30:00Z").unwrap());
    assert_eq!(a.test.as_deref(), Some("stepped-square"));
    assert_eq!(all[1].record.kind, RecordKind::Discover);
    let x = &all[2].record;
    assert_eq!(
        (x.kind, x.controller.as_deref()),
        (RecordKind::Export, Some("fanuc"))
    );
    assert_eq!(
        x.exported.as_deref(),
        Some(
            std::fs::read_to_string(dir.path().join("params.txt"))
                .unwrap()
                .as_str()
        )
    );
}

/// A series of weekly checks on the virtual machine: EX0B holds at 12 um
/// for three checks, then drifts 1.5 um a day. Each day's piece is
/// simulated (with its own noise) and analysed, and recorded with the day
/// it was measured. The trend is dated from the last steady day, its
/// slope is within 3u of 1.5 um/day, and the forecast of reaching the
/// 20 um limit is within 3u (plus a tenth of a day) of the true day.
#[test]
fn the_trend_forecast_on_a_simulated_drift_finds_the_day_the_limit_is_reached() {
    let out = demo_out();
    let manifest = out.join("plan/stepped-square.plan.yaml");
    let plan = fivecal::procedure::load(&manifest).unwrap();
    let kin = fivecal::simulate::plan_kinematics(&plan);
    let dir = tempfile::tempdir().unwrap();
    let mut store = Store::open(&Location::Sqlite(dir.path().join("h.db"))).unwrap();
    let start = parse_time("2026-03-02T07:00:00Z").unwrap();
    let days = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
    let truth_at = |d: f64| 12.0 + 1.5 * (d - 2.0).max(0.0);
    for (k, &d) in days.iter().enumerate() {
        let truth = dir.path().join(format!("truth{k}.yaml"));
        std::fs::write(
            &truth,
            format!(
                "machine: bc-trunnion\nlocation_errors:\n  EX0B: {}\n  EZ0B: -25.0\n  EB0B: 110.0\n",
                truth_at(d)
            ),
        )
        .unwrap();
        let errors = ErrorFile::load(&truth, &kin).unwrap();
        let sim = fivecal::simulate::run(
            &plan,
            &errors,
            &fivecal::simulate::SimOptions {
                seed: 100 + k as u64,
                ..Default::default()
            },
        )
        .unwrap();
        let measured = dir.path().join(format!("day{k}.dmo"));
        sim.write(fivecal::simulate::Format::Dmis, &measured)
            .unwrap();
        // One machine measured day after day: its linear axes' errors are
        // the same every day, so only the noise scatters the series about
        // the drift. Each record's u holds the test's contributors too
        // (as analyze prints by default, several micrometres for EX0B);
        // the trend judges the slope against the part that varies from day
        // to day (`u_random`), or the drift would drown in a bias common
        // to every day.
        let outcome = analyze::run(&analyze::Request {
            rebuilt: Some(plan.clone()),
            ..analyze::Request::new(&manifest, vec![measured.clone()])
        })
        .unwrap();
        assert!(matches!(outcome.found, Found::Identified(_)));
        let result = dir.path().join(format!("day{k}.yaml"));
        let files = analyze::result::files(&outcome, &result, false).unwrap();
        let notes = RunNotes {
            measured_at: fivecal::history::trend::add_days(start, d),
            ..RunNotes::default()
        };
        for r in runs::analysis(&outcome, &manifest, &[measured], &files, &notes).unwrap() {
            store.record(&r).unwrap();
        }
    }
    let h = History::new("bc-trunnion", store.list(Some("bc-trunnion")).unwrap());
    let mut limits = AcceptanceLimits::default();
    limits.0.insert("EX0B".into(), Limit::symmetric(20.0));
    let (_, outlook) = h
        .outlooks(&limits)
        .into_iter()
        .find(|(s, _)| s.symbol == "EX0B")
        .unwrap();
    let Outlook::Drifting { line, forecast } = outlook else {
        panic!("{outlook:?}")
    };
    assert_eq!(days_between(start, line.since).round(), 2.0, "{line:?}");
    assert!((line.slope - 1.5).abs() < 3.0 * line.u_slope, "{line:?}");
    let Forecast::Reaches { limit, at, u_days } = forecast else {
        panic!("{forecast:?}")
    };
    assert_eq!(limit, 20.0);
    // 12 + 1.5 (d - 2) = 20 on day 2 + 8/1.5.
    let truth_day = 2.0 + 8.0 / 1.5;
    let day = days_between(start, at);
    assert!(
        (day - truth_day).abs() < 3.0 * u_days + 0.1,
        "day {day} (u {u_days}), truth {truth_day}"
    );
    let text = fivecal::history::render_outlooks(&h, &limits);
    assert!(
        text.contains("EX0B")
            && text.contains("drifting since 2026-03-04")
            && text.contains("reaches its limit 20 um"),
        "{text}"
    );
}
