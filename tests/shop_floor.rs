//! Files a shop floor uses as they are: SINUMERIK and HEIDENHAIN programs
//! that call the tool the control's tool list holds, setup sheets in the
//! control's own words, a probe log that fits the control's protocol
//! files, and the history commands taking the same `--machine` file as
//! every other command.

use std::path::{Path, PathBuf};

use crate::cli::fivecal;
use crate::util::tempdir;

/// `machine new NAME --from bc-trunnion`, with `edit` applied to its text.
fn machine_file(dir: &Path, name: &str, edit: impl Fn(String) -> String) -> PathBuf {
    let path = dir.join(format!("{name}.yaml"));
    fivecal()
        .args(["machine", "new", name, "-o"])
        .arg(&path)
        .assert()
        .success();
    let text = std::fs::read_to_string(&path).unwrap();
    std::fs::write(&path, edit(text)).unwrap();
    path
}

/// `plan TEST --machine M --dialect D -o DIR/OUT` with `extra`; the run's
/// output (stdout and stderr) and whether it succeeded.
fn plan(dir: &Path, test: &str, machine: &Path, dialect: &str, extra: &[&str]) -> (bool, String) {
    let out = fivecal()
        .args(["plan", test, "--machine"])
        .arg(machine)
        .args(["--dialect", dialect, "-o"])
        .arg(dir.join(format!("{test}-{dialect}")))
        .args(extra)
        .output()
        .unwrap();
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    (out.status.success(), text)
}

fn read(dir: &Path, test: &str, dialect: &str, ext: &str) -> String {
    std::fs::read_to_string(dir.join(format!("{test}-{dialect}/{test}.{ext}"))).unwrap()
}

/// A tool-list name given to the probe.
fn with_probe_id(text: String) -> String {
    text.replace(
        "  ball_diameter: 6.0\n",
        "  ball_diameter: 6.0\n  id: TS_PROBE_6\n",
    )
}

/// Issue 46 item 3: the SINUMERIK program called the tool by its
/// description cut to 32 characters (`T="strain-gauge touch probe, 6 mm b"`)
/// while its header said T99. With tool management the control finds a
/// tool by its name in the tool list, which the machine file now gives as
/// `id:`; without it the tool is called by number, as a control without
/// tool management expects. HEIDENHAIN's TOOL CALL follows the same rule.
#[test]
fn a_sinumerik_program_calls_the_tool_list_name_or_the_number_never_the_description() {
    let dir = tempdir();
    let d = dir.path();
    let plain = machine_file(d, "plain", |t| t);
    assert!(plan(d, "probe-columns", &plain, "sinumerik", &[]).0);
    let mpf = read(d, "probe-columns", "sinumerik", "mpf");
    assert!(mpf.contains(" T99 M6\n"), "{mpf}");
    assert!(!mpf.contains("T=\""), "{mpf}");

    let named = machine_file(d, "named", with_probe_id);
    let dn = d.join("named");
    std::fs::create_dir(&dn).unwrap();
    assert!(plan(&dn, "probe-columns", &named, "sinumerik", &[]).0);
    let mpf = read(&dn, "probe-columns", "sinumerik", "mpf");
    assert!(mpf.contains(" T=\"TS_PROBE_6\" M6\n"), "{mpf}");
    assert!(plan(&dn, "probe-columns", &named, "heidenhain", &[]).0);
    let h = read(&dn, "probe-columns", "heidenhain", "h");
    assert!(h.contains(" TOOL CALL \"TS_PROBE_6\" Z\n"), "{h}");
    // The setup sheet names both, so the operator loads the right tool.
    let sheet = read(&dn, "probe-columns", "heidenhain", "md");
    assert!(sheet.contains("- T99 \"TS_PROBE_6\": "), "{sheet}");
}

/// A name the control cannot hold is refused at the key that gives it.
#[test]
fn a_tool_list_name_with_a_quote_or_beyond_32_characters_is_refused_at_its_key() {
    let dir = tempdir();
    let d = dir.path();
    for (i, (id, expected)) in [
        ("'A\"B'", "`\"`"),
        (
            "ABCDEFGHIJKLMNOPQRSTUVWXYZ0123456",
            "1 to 32 characters, got 33",
        ),
    ]
    .into_iter()
    .enumerate()
    {
        let m = machine_file(d, &format!("bad{i}"), |t| {
            t.replace(
                "  ball_diameter: 6.0\n",
                &format!("  ball_diameter: 6.0\n  id: {id}\n"),
            )
        });
        let (ok, text) = plan(d, "probe-columns", &m, "sinumerik", &[]);
        assert!(!ok, "{text}");
        assert!(
            text.contains(&format!("bad{i}.yaml:"))
                && text.contains("tool-list name (id)")
                && text.contains(expected),
            "{text}"
        );
    }
}

/// Issue 46 item 3: the SINUMERIK setup sheet said "Work offset G54
/// (HEIDENHAIN preset 1)". Each dialect's sheet and header now name the
/// zero point its program selects.
#[test]
fn the_setup_sheet_names_the_zero_point_in_the_dialect_s_words() {
    let dir = tempdir();
    let d = dir.path();
    let m = machine_file(d, "m", |t| t);
    for (dialect, ext, sheet_says, header_says) in [
        (
            "sinumerik",
            "mpf",
            "- Work offset G54 on the W origin",
            "; zero point: work offset G54 on",
        ),
        (
            "fanuc",
            "nc",
            "- Work offset G54 on the W origin",
            "(ZERO POINT: WORK OFFSET G54 ON",
        ),
        (
            "heidenhain",
            "h",
            "- Preset 1 (preset table line 1, activated by CYCL DEF 247) on",
            "; zero point: preset 1 (preset table line 1",
        ),
    ] {
        assert!(plan(d, "stepped-square", &m, dialect, &[]).0);
        let sheet = read(d, "stepped-square", dialect, "md");
        assert!(sheet.contains(sheet_says), "{dialect}: {sheet}");
        assert!(!sheet.contains("HEIDENHAIN preset"), "{dialect}: {sheet}");
        let program = read(d, "stepped-square", dialect, ext);
        assert!(program.contains(header_says), "{dialect}: {program}");
    }
}

/// The probe log `simulate` writes to `log` for the plan `manifest` on
/// the machine file `m`, with the simulator's own truth example.
fn simulated_log(m: &Path, manifest: &Path, log: &Path) -> PathBuf {
    let truth = log.with_extension("truth.yaml");
    let t = fivecal()
        .args(["simulate", "--truth-example", "--machine"])
        .arg(m)
        .output()
        .unwrap();
    std::fs::write(&truth, &t.stdout).unwrap();
    fivecal()
        .args(["simulate", "--plan"])
        .arg(manifest)
        .arg("--errors")
        .arg(&truth)
        .arg("-o")
        .arg(log)
        .assert()
        .success();
    log.to_path_buf()
}

/// The kB of "the probe log FIVECAL_.. will hold about N kB".
fn stated_kb(text: &str) -> f64 {
    let at = text.find("will hold about ").expect(text) + "will hold about ".len();
    text[at..].split(' ').next().unwrap().parse().unwrap()
}

/// Issue 46 item 3: a probing log of 221-242 touches may pass the size
/// the control allows its protocol files (MD11420), where WRITE stops the
/// run with error 10. The plan states the log's size; with the control's
/// value in the postprocessor (`log_limit_kb`) it refuses a plan whose log
/// would not fit. The stated size is checked against the log the
/// simulator writes for the same plan, line for line what the program's
/// WRITE produces.
#[test]
fn the_probe_log_s_size_is_stated_and_a_log_beyond_the_control_s_limit_refused() {
    let dir = tempdir();
    let d = dir.path();
    let m = machine_file(d, "m", |t| t);
    let (ok, text) = plan(d, "probe-sphere", &m, "sinumerik", &[]);
    assert!(ok, "{text}");
    assert!(text.contains("MD11420 LEN_PROTOCOL_FILE"), "{text}");
    let kb = stated_kb(&text);
    // The same words on the setup sheet, for the operator.
    assert!(read(d, "probe-sphere", "sinumerik", "md").contains(&format!("about {kb} kB")));

    let log = simulated_log(
        &m,
        &d.join("probe-sphere-sinumerik/probe-sphere.plan.yaml"),
        &d.join("sphere.log"),
    );
    let bytes = std::fs::metadata(&log).unwrap().len() as f64;
    // An upper bound (every value with four decimals), not a wild one.
    assert!(kb * 1024.0 >= bytes, "{kb} kB for {bytes} bytes");
    assert!(
        kb <= (1.5 * bytes / 1024.0).ceil() + 1.0,
        "{kb} kB for {bytes} bytes"
    );

    // The control's limit in a copy of the postprocessor.
    let post = |limit: f64| {
        let p = d.join(format!("sinumerik-{limit}.yaml"));
        let src = std::fs::read_to_string(d.join("probe-sphere-sinumerik/probe-sphere.post.yaml"))
            .unwrap();
        std::fs::write(
            &p,
            src.replace("# log_limit_kb: 10", &format!("log_limit_kb: {limit}")),
        )
        .unwrap();
        p
    };
    let small = post(kb - 1.0);
    let (ok, text) = plan(
        d,
        "probe-sphere",
        &m,
        "sinumerik",
        &["--postprocessor", small.to_str().unwrap()],
    );
    assert!(!ok, "{text}");
    assert!(
        text.contains(&format!("about {kb} kB"))
            && text.contains("error 10")
            && text.contains(&format!("raise MD11420 to at least {kb} kB")),
        "{text}"
    );
    let large = post(kb);
    let (ok, text) = plan(
        d,
        "probe-sphere",
        &m,
        "sinumerik",
        &["--postprocessor", large.to_str().unwrap()],
    );
    assert!(ok, "{text}");
    assert!(!text.contains("will hold about"), "{text}");
}

/// `log_limit_kb` is SINUMERIK's; in another dialect's postprocessor it
/// is refused at its key instead of being silently ignored.
#[test]
fn a_log_limit_in_a_postprocessor_of_another_dialect_is_refused() {
    let dir = tempdir();
    let d = dir.path();
    let m = machine_file(d, "m", |t| t);
    assert!(plan(d, "probe-columns", &m, "fanuc", &[]).0);
    let src =
        std::fs::read_to_string(d.join("probe-columns-fanuc/probe-columns.post.yaml")).unwrap();
    let p = d.join("fanuc-limit.yaml");
    std::fs::write(&p, format!("log_limit_kb: 10\n{src}")).unwrap();
    let (ok, text) = plan(
        d,
        "probe-columns",
        &m,
        "fanuc",
        &["--postprocessor", p.to_str().unwrap()],
    );
    assert!(!ok, "{text}");
    assert!(
        text.contains("fanuc-limit.yaml:1:") && text.contains("SINUMERIK's protocol files"),
        "{text}"
    );
}

/// Issue 46 item 2: `verify --machine my-mill.yaml` answered "no records
/// of machine `my-mill.yaml`": the store keys a machine by the name inside
/// its file, and `verify` and `history` took only that name. They now take
/// the file, as plan, simulate, analyze and compensate do.
#[test]
fn history_and_verify_take_the_machine_file_the_other_commands_take() {
    let dir = tempdir();
    let d = dir.path();
    let m = machine_file(d, "my-mill", |t| t);
    let db = d.join("h.db");
    assert!(plan(d, "probe-columns", &m, "fanuc", &[]).0);
    let manifest = d.join("probe-columns-fanuc/probe-columns.plan.yaml");
    let log = simulated_log(&m, &manifest, &d.join("pc.log"));
    fivecal()
        .args(["analyze", "--plan"])
        .arg(&manifest)
        .arg("--measured")
        .arg(&log)
        .arg("-o")
        .arg(d.join("res"))
        .arg("--db")
        .arg(&db)
        .assert()
        .success();
    let list = fivecal()
        .args(["history", "list", "--machine"])
        .arg(&m)
        .arg("--db")
        .arg(&db)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&list.stdout);
    assert!(list.status.success(), "{text}");
    assert!(
        text.contains("my-mill") && text.contains("probe-columns"),
        "{text}"
    );
    // By name, the same records.
    let by_name = fivecal()
        .args(["history", "list", "--machine", "my-mill", "--db"])
        .arg(&db)
        .output()
        .unwrap();
    assert_eq!(String::from_utf8_lossy(&by_name.stdout), text);
    // verify looks for the machine's records, not for a machine called
    // `my-mill.yaml`.
    let v = fivecal()
        .args(["verify", "--machine"])
        .arg(&m)
        .arg("--db")
        .arg(&db)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&v.stderr);
    assert!(!v.status.success());
    assert!(
        err.contains("machine `my-mill`") && !err.contains("my-mill.yaml`"),
        "{err}"
    );
    // The machine file is read: no output may land on it.
    let onto = fivecal()
        .args(["history", "export", "--machine"])
        .arg(&m)
        .arg("--db")
        .arg(&db)
        .arg("--out")
        .arg(&m)
        .output()
        .unwrap();
    assert!(!onto.status.success());
    assert!(
        std::fs::read_to_string(&m)
            .unwrap()
            .contains("name: my-mill")
    );
}

/// Issue 46 item 7: `fivecal measured` refused a probe log although the
/// README and `--help` say it shows what any measurement file holds.
/// Without its plan it shows the log as the control wrote it.
#[test]
fn measured_shows_a_probe_log_as_the_control_wrote_it() {
    let dir = tempdir();
    let log = dir.path().join("columns.log");
    std::fs::write(
        &log,
        "FIVECAL probe-columns\nT1 X10.5 Y0 Z5\nT2 X-10.25 Y1 Z5.0021\n",
    )
    .unwrap();
    let out = fivecal().arg("measured").arg(&log).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(text.contains("probe-log"), "{text}");
    assert!(text.contains("T2") && text.contains("-10.25"), "{text}");
    assert!(text.contains("ball centre"), "{text}");
    assert!(text.contains("a log of the probe-columns test"), "{text}");
}

/// Issue 46 item 7: `machine show` accepted a pivot outside the machine's
/// own X stroke; every later message then blamed something else.
#[test]
fn a_pivot_outside_the_x_stroke_is_refused_at_the_pivot() {
    let dir = tempdir();
    let m = machine_file(dir.path(), "far", |t| {
        t.replace("pivot: [0.0, 0.0, -420.0]", "pivot: [400.0, 0.0, -420.0]")
    });
    let out = fivecal()
        .args(["machine", "show"])
        .arg(&m)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains("far.yaml:")
            && err.contains("pivot X 400 mm is outside the X stroke [-365, 365]"),
        "{err}"
    );
}

/// Issue 46 item 8: HEIDENHAIN comments may not hold `;`, and the header
/// dropped it: "(Ibaraki, Iritani & Matsushita 2013 Cubas Brizuela & Yeh
/// 2023)". A separator keeps its meaning as a comma.
#[test]
fn a_semicolon_a_comment_may_not_hold_becomes_a_comma() {
    let dir = tempdir();
    let d = dir.path();
    let m = machine_file(d, "m", |t| {
        t.replace(
            "\ndescription: m (copied",
            "\ndescription: m (Smith 2013; Jones 2023) (copied",
        )
    });
    assert!(plan(d, "probe-columns", &m, "heidenhain", &[]).0);
    let h = read(d, "probe-columns", "heidenhain", "h");
    assert!(h.contains("(Smith 2013, Jones 2023)"), "{h}");
}

/// The RMS and largest figure of one "tool tip from the path" line of
/// `simulate nc --against`, um.
fn against_figures(stdout: &str) -> (f64, f64) {
    let line = stdout
        .lines()
        .find(|l| l.contains("tool tip from the path"))
        .unwrap_or_else(|| panic!("no deviation line in {stdout}"));
    let after = |key: &str| -> f64 {
        let rest = &line[line.find(key).unwrap_or_else(|| panic!("{key} in {line}")) + key.len()..];
        rest.split_whitespace().next().unwrap().parse().unwrap()
    };
    (after("RMS "), after("max "))
}

/// Issue 46, item 5: the demo's "33.5 -> 0.1 um" is one command a user can
/// run. `simulate nc --against` the original measures the program, run on
/// the machine with the errors, against the path the original asks for on
/// the nominal machine: on the compensated program it gives the demo's
/// "compensated" figures, on the original itself its "as written" ones
/// (to the demo's printed decimal). Without errors the original lies on its
/// own path (0 um), and the sample CSV carries the deviation per sample.
#[test]
fn simulate_nc_against_the_original_gives_the_demo_s_before_and_after() {
    let dir = tempdir();
    let demo = dir.path().join("demo");
    let out = fivecal().args(["demo", "-o"]).arg(&demo).output().unwrap();
    assert!(out.status.success());
    let summary = String::from_utf8_lossy(&out.stdout).to_string();
    let line = summary
        .lines()
        .find(|l| l.starts_with("example program frustum.nc"))
        .unwrap();
    // "... 33.5 um RMS, 37.2 um max as written; 0.1 um RMS, 0.2 um max compensated"
    let numbers: Vec<f64> = line
        .split(|c: char| !(c.is_ascii_digit() || c == '.'))
        .filter_map(|w| w.parse().ok())
        .collect();
    let (before, after) = ((numbers[0], numbers[1]), (numbers[2], numbers[3]));
    assert!(summary.contains("fivecal simulate nc --machine bc-trunnion --errors"));
    let run = |program: &str, errors: &Path, csv: Option<&Path>| {
        let mut c = fivecal();
        c.args(["simulate", "nc", "--machine", "bc-trunnion", "--errors"])
            .arg(errors)
            .arg(demo.join(program))
            .arg("--against")
            .arg(demo.join("frustum.nc"))
            .args(["--step", "0.5"]);
        if let Some(csv) = csv {
            c.arg("-o").arg(csv);
        }
        let o = c.output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8_lossy(&o.stdout).to_string()
    };
    let truth = demo.join("truth.yaml");
    let close = |got: (f64, f64), want: (f64, f64)| {
        (got.0 - want.0).abs() <= 0.05 + 1e-9 && (got.1 - want.1).abs() <= 0.05 + 1e-9
    };
    let as_written = against_figures(&run("frustum.nc", &truth, None));
    assert!(
        close(as_written, before),
        "{as_written:?} against {before:?}"
    );
    let csv = dir.path().join("after.csv");
    let compensated = against_figures(&run("frustum.compensated.nc", &truth, Some(&csv)));
    assert!(
        close(compensated, after),
        "{compensated:?} against {after:?}"
    );
    assert!(compensated.0 < as_written.0 / 10.0);
    // The CSV's deviation column: its largest value is the largest printed.
    let text = std::fs::read_to_string(&csv).unwrap();
    let header = text.lines().find(|l| l.starts_with("line,")).unwrap();
    assert!(header.ends_with(",deviation"), "{header}");
    let largest = text
        .lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("line,"))
        .filter_map(|l| l.rsplit(',').next()?.parse::<f64>().ok())
        .fold(0.0, f64::max);
    assert!(
        (largest - compensated.1).abs() < 0.01,
        "{largest} against {compensated:?}"
    );
    // A machine without errors runs the original on its own path.
    let zero = dir.path().join("zero.yaml");
    std::fs::write(
        &zero,
        "machine: bc-trunnion\nlocation_errors:\n  EX0B: 0.0\n",
    )
    .unwrap();
    let nominal = against_figures(&run("frustum.nc", &zero, None));
    assert!(nominal.1 < 1e-3, "{nominal:?}");
}

/// `plan TEST --machine bc-trunnion -o PLAN` in `d`, and what the virtual
/// machine of `simulate --truth-example` makes of it in `d/MEASURED`.
fn planned_and_measured(d: &Path, test: &str, plan: &str, measured: &str) {
    fivecal()
        .current_dir(d)
        .args(["plan", test, "--machine", "bc-trunnion", "-o", plan])
        .assert()
        .success();
    let truth = fivecal()
        .args(["simulate", "--truth-example"])
        .output()
        .unwrap();
    std::fs::write(d.join("t.yaml"), &truth.stdout).unwrap();
    fivecal()
        .current_dir(d)
        .args(["simulate", "--plan"])
        .arg(format!("{plan}/{test}.plan.yaml"))
        .args(["--errors", "t.yaml", "-o", measured])
        .assert()
        .success();
}

/// Issue 46, item 7: `--method sphere` on a probe-columns plan is refused
/// for what it is (a column's touches lie on faces, not on a sphere),
/// naming the methods that work, before any fit; it used to stop in the
/// sphere fit with "four or more probed points ... (4 given)".
#[test]
fn the_sphere_method_on_a_column_plan_names_the_methods_that_work() {
    let dir = tempdir();
    let d = dir.path();
    planned_and_measured(d, "probe-columns", "pc", "pc.log");
    let out = fivecal()
        .current_dir(d)
        .args([
            "analyze",
            "--plan",
            "pc/probe-columns.plan.yaml",
            "--measured",
            "pc.log",
        ])
        .args(["--method", "sphere", "--no-record", "-o", "r.yaml"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("needs a probe-sphere plan"), "{err}");
    assert!(err.contains("global") && err.contains("two-stage"), "{err}");
    assert!(!err.contains("given"), "{err}");
    assert!(!d.join("r.yaml").exists());
}

/// Issue 46, item 7: a Z stroke shrunk to [-200, 0] leaves the safe height
/// above the spindle's highest position. The refusal says that no tool
/// fits and that the Z stroke is too short for the piece, not that a 60 mm
/// tool is longer than a clearance of -20.981 mm.
#[test]
fn a_z_stroke_too_short_for_the_piece_is_named_without_a_negative_clearance() {
    let dir = tempdir();
    let m = machine_file(dir.path(), "short-z", |t| {
        t.replace("  Z: [-510, 0]", "  Z: [-200, 0]")
    });
    let out = fivecal()
        .args(["plan", "stepped-square", "--machine"])
        .arg(&m)
        .arg("-o")
        .arg(dir.path().join("ss"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("no tool fits"), "{err}");
    assert!(err.contains("the Z stroke [-200, 0] is too short"), "{err}");
    assert!(!err.contains("clearance of -"), "{err}");
}

/// Issue 46, item 6: a nine-section analysis with `--report` writes its
/// report (it wrote none, silently), and its result file is flat: its test
/// and machine by name, each piece's sections as `section`/`height_um`
/// rows, no nested lists.
#[test]
fn a_nine_section_analysis_writes_its_report_and_a_flat_result_file() {
    let dir = tempdir();
    let d = dir.path();
    planned_and_measured(d, "nine-section", "ns", "ns.csv");
    let out = fivecal()
        .current_dir(d)
        .args([
            "analyze",
            "--plan",
            "ns/nine-section.plan.yaml",
            "--measured",
            "ns.csv",
        ])
        .args([
            "--measured",
            "ns.csv",
            "--no-record",
            "-o",
            "r.yaml",
            "--report",
            "rep",
        ])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("report: "), "{stdout}");
    let html = std::fs::read_to_string(d.join("rep/index.html")).unwrap();
    assert!(html.contains("Nine-section test on bc-trunnion"), "{html}");
    assert!(d.join("rep/heights-1.svg").is_file());
    let r: serde_yaml::Value =
        serde_yaml::from_str(&std::fs::read_to_string(d.join("r.yaml")).unwrap()).unwrap();
    assert_eq!(r["test"].as_str(), Some("nine-section"));
    assert_eq!(r["machine"].as_str(), Some("bc-trunnion"));
    let pieces = r["pieces"].as_sequence().unwrap();
    assert_eq!(pieces.len(), 2);
    assert_eq!(pieces[0]["measured"].as_str(), Some("ns.csv"));
    let sections = pieces[0]["sections"].as_sequence().unwrap();
    assert_eq!(sections.len(), 9);
    assert_eq!(sections[0]["section"].as_u64(), Some(1));
    assert!(sections[8]["height_um"].as_f64().unwrap().is_finite());
    // The same piece twice: no improvement, 0 % (not a division by zero).
    assert_eq!(r["improvement_percent"]["rms"].as_f64(), Some(0.0));
}

/// The built-in stepped-square template with `edit` applied, written to
/// `dir/NAME.yaml`.
fn stepped_square_template(dir: &Path, name: &str, edit: impl Fn(String) -> String) -> PathBuf {
    let text = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("templates/stepped-square.yaml"),
    )
    .unwrap();
    let path = dir.join(format!("{name}.yaml"));
    std::fs::write(&path, edit(text)).unwrap();
    path
}

/// Issue 46 item 4: the stepped square noted "at B = +-90 the tool axis
/// runs 37 mm above the table top ... the spindle nose must be narrower
/// than twice that" and wrote the program anyway. On bc-trunnion with the
/// template's 30 mm riser the side steps' lowest tool axis runs at the
/// riser plus the 3 mm lip plus the D8 tool's radius, 30 + 3 + 4 = 37 mm
/// above the table top (radius 125 mm, reaching under the nose, which
/// starts 60 mm out from the side face): a 200 mm nose reaches
/// 100 - 37 = 63 mm into the table. With the riser left as written the
/// plan is refused naming the pose and that clearance; with `raise: true`
/// the riser goes up until the nose keeps its 2 mm: 37 + raise >= 102.
#[test]
fn a_wide_spindle_nose_is_refused_naming_the_pose_and_the_clearance() {
    let dir = tempdir();
    let wide = |t: String| {
        t.replace(
            "spindle_nose:          # spindle beyond the gauge line (the probing templates' spindle); holder and\n  diameter: 120",
            "spindle_nose:\n  diameter: 200",
        )
    };
    let fixed = stepped_square_template(dir.path(), "fixed", |t| {
        wide(t).replace("raise: true", "raise: false")
    });
    let out = fivecal()
        .args([
            "plan",
            "stepped-square",
            "--machine",
            "bc-trunnion",
            "--template",
        ])
        .arg(&fixed)
        .arg("-o")
        .arg(dir.path().join("fixed"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("the spindle nose (diameter 200 mm) reaches 63 mm into the table"),
        "{err}"
    );
    assert!(
        err.contains("clearance -63 mm, at least 2 mm needed"),
        "{err}"
    );
    let pose = err.split("pose ").nth(1).unwrap_or_default();
    assert!(
        pose.starts_with("B90C") || pose.starts_with("B-90C"),
        "{err}"
    );
    assert!(
        err.contains("(B = 90, C = ") || err.contains("(B = -90, C = "),
        "{err}"
    );
    assert!(
        !dir.path().join("fixed").exists(),
        "a refused plan writes nothing"
    );

    let raised = stepped_square_template(dir.path(), "raised", wide);
    let out = fivecal()
        .args([
            "plan",
            "stepped-square",
            "--machine",
            "bc-trunnion",
            "--template",
        ])
        .arg(&raised)
        .arg("-o")
        .arg(dir.path().join("raised"))
        .output()
        .unwrap();
    let text =
        String::from_utf8_lossy(&out.stderr).to_string() + &String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}");
    let riser: f64 = text
        .split("the riser is ")
        .nth(1)
        .and_then(|s| s.split(" mm").next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("no riser note: {text}"));
    assert!(37.0 + (riser - 30.0) >= 102.0, "riser {riser}: {text}");
    assert!(
        (riser - 30.0) <= 65.0 + 5.0,
        "raised more than needed: {riser}"
    );
    assert!(
        text.contains("so that the spindle nose (diameter 200 mm) clears the table at B = "),
        "{text}"
    );
}

/// The default holder (a 63 mm wide, 35 mm long HSK-A63 / SK40 chuck)
/// and spindle nose (120 mm) keep both machining tests plannable on every
/// built-in machine, the riser raised where the nose needs it.
#[test]
fn the_default_tool_assembly_plans_both_machining_tests_on_every_built_in_machine() {
    let dir = tempdir();
    for test in ["stepped-square", "nine-section"] {
        for machine in ["bc-trunnion", "ac-trunnion", "head-table", "head-head"] {
            let out = fivecal()
                .args(["plan", test, "--machine", machine, "-o"])
                .arg(dir.path().join(format!("{test}-{machine}")))
                .output()
                .unwrap();
            let err = String::from_utf8_lossy(&out.stderr);
            assert!(out.status.success(), "{test} on {machine}: {err}");
            assert!(!err.contains("narrower than twice"), "{err}");
        }
    }
}

/// Headless Chromium for the screenshot test: `FIVECAL_CHROMIUM`, else
/// `chromium` or `chromium-browser` on the PATH. Missing, the test is
/// skipped on a developer's machine and fails on CI (`CI` set), where
/// `.ci/run` installs Debian's `chromium`.
fn chromium() -> Option<String> {
    let names: Vec<String> = match std::env::var("FIVECAL_CHROMIUM") {
        Ok(c) => vec![c],
        Err(_) => vec!["chromium".into(), "chromium-browser".into()],
    };
    let found = names.into_iter().find(|c| {
        std::process::Command::new(c)
            .arg("--version")
            .output()
            .is_ok_and(|o| o.status.success())
    });
    if found.is_none() {
        assert!(
            std::env::var_os("CI").is_none(),
            "chromium is not installed: on CI the screenshot test must run (.ci/run installs it)"
        );
        eprintln!(
            "note: screenshot test skipped: no chromium (apt-get install chromium, or set FIVECAL_CHROMIUM)"
        );
    }
    found
}

/// `chromium --headless` with the flags a test run needs (no sandbox as
/// root, no GPU, file pages reading their neighbours), a 1200 px window.
fn headless(chromium: &str) -> std::process::Command {
    let mut c = std::process::Command::new(chromium);
    c.args([
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--hide-scrollbars",
        "--allow-file-access-from-files",
        "--window-size=1200,1600",
    ]);
    c
}

/// `fivecal ARGS` in `dir`, which must succeed.
fn run_in(dir: &Path, args: &[&str]) {
    let out = fivecal().current_dir(dir).args(args).output().unwrap();
    assert!(
        out.status.success(),
        "fivecal {}: {}",
        args.join(" "),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Issue 46 item 6: the reports' plots were drawn at 540 px with axis text
/// of about 8 px, and long lines ran off the page. The analysis (a misfit,
/// with its banner), discover, column, sphere and history pages are
/// written and laid out by headless Chromium, which takes a screenshot of
/// each (kept in the target directory's tmp/report-screenshots) and, with
/// tests/fixtures/report/check.js injected, measures every text of the
/// page and of every plot at the size the page shows it: none is below
/// 11 px, no element runs beyond the page or its own box, and no plot
/// label is drawn beyond its plot.
#[test]
fn report_pages_read_at_11_px_or_more_and_nothing_overflows_in_chromium() {
    let Some(chromium) = chromium() else {
        return;
    };
    let dir = tempdir();
    let d = dir.path();
    let examples = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/discover");
    let plan = examples.join("stepped-square.plan.yaml");
    let piece = examples.join("piece.dmo");
    let (plan, piece) = (plan.to_str().unwrap(), piece.to_str().unwrap());
    let db: &[&str] = &["--db", "h.db"];
    run_in(
        d,
        &[
            &[
                "analyze",
                "--plan",
                plan,
                "--measured",
                piece,
                "-o",
                "a.yaml",
                "--report",
                "analysis",
                "--measured-at",
                "2026-03-01T08:30:00Z",
            ][..],
            db,
        ]
        .concat(),
    );
    run_in(
        d,
        &[
            "discover",
            "--plan",
            plan,
            "--measured",
            piece,
            "--out",
            "d.yaml",
            "--report",
            "discover",
            "--db",
            "h.db",
        ],
    );
    let truth = fivecal()
        .args(["simulate", "--truth-example"])
        .output()
        .unwrap();
    std::fs::write(d.join("t.yaml"), &truth.stdout).unwrap();
    // The column and the sphere test on the same machine, the column
    // recorded at the same time as the analysis (two points at one time
    // on the history's axis), the sphere a day later.
    for (test, page, at) in [
        ("probe-columns", "column", "2026-03-01T08:30:00Z"),
        ("probe-sphere", "sphere", "2026-03-02T14:00:00Z"),
    ] {
        run_in(d, &["plan", test, "--machine", "bc-trunnion", "-o", test]);
        let manifest = format!("{test}/{test}.plan.yaml");
        let measured = format!("{test}.csv");
        run_in(
            d,
            &[
                "simulate", "--plan", &manifest, "--errors", "t.yaml", "-o", &measured,
            ],
        );
        let result = format!("{page}.yaml");
        run_in(
            d,
            &[
                &[
                    "analyze",
                    "--plan",
                    &manifest,
                    "--measured",
                    &measured,
                    "-o",
                    &result,
                    "--report",
                    page,
                    "--measured-at",
                    at,
                ][..],
                db,
            ]
            .concat(),
        );
    }
    run_in(
        d,
        &[
            &[
                "history",
                "plot",
                "--machine",
                "bc-trunnion",
                "-o",
                "history",
            ][..],
            db,
        ]
        .concat(),
    );

    let check = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/report/check.js");
    let shots = Path::new(env!("CARGO_TARGET_TMPDIR")).join("report-screenshots");
    std::fs::create_dir_all(&shots).unwrap();
    let pages = ["analysis", "discover", "column", "sphere", "history"];
    // Every page's measurement and screenshot at once: Chromium spends
    // most of a run starting up.
    let mut runs = Vec::new();
    for page in pages {
        let index = d.join(page).join("index.html");
        let html = std::fs::read_to_string(&index).unwrap();
        assert!(html.contains("<h2>Next step</h2>"), "{page}: no next step");
        // The page as written, with the measuring script added.
        let checked = d.join(page).join("check.html");
        std::fs::write(
            &checked,
            html.replace(
                "</body>",
                &format!(
                    "<script src=\"file://{}\"></script></body>",
                    check.display()
                ),
            ),
        )
        .unwrap();
        let shot = shots.join(format!("{page}.png"));
        let _ = std::fs::remove_file(&shot);
        let spawn = |c: &mut std::process::Command| {
            c.stdout(std::process::Stdio::piped())
                .stderr(std::process::Stdio::piped())
                .spawn()
                .unwrap()
        };
        let dump = spawn(
            headless(&chromium)
                .arg("--dump-dom")
                .arg(format!("file://{}", checked.display())),
        );
        let screenshot = spawn(
            headless(&chromium)
                .arg(format!("--screenshot={}", shot.display()))
                .arg(format!("file://{}", index.display())),
        );
        runs.push((page, dump, screenshot, shot));
    }
    let mut problems = Vec::new();
    for (page, dump, screenshot, shot) in runs {
        let out = dump.wait_with_output().unwrap();
        let dom = String::from_utf8_lossy(&out.stdout);
        let json = dom
            .split("<pre id=\"fivecal-check\">")
            .nth(1)
            .and_then(|s| s.split("</pre>").next())
            .unwrap_or_else(|| {
                panic!(
                    "{page}: the check wrote nothing: {}",
                    String::from_utf8_lossy(&out.stderr)
                )
            })
            .replace("&lt;", "<")
            .replace("&gt;", ">")
            .replace("&amp;", "&");
        let r: serde_json::Value = serde_json::from_str(&json).unwrap();
        for (font, at) in [("html_font", "html_where"), ("svg_font", "svg_where")] {
            let px = r[font].as_f64().unwrap();
            if px < 11.0 {
                problems.push(format!("{page}: {px:.1} px text ({})", r[at]));
            }
        }
        assert!(r["svgs"].as_u64().unwrap() >= 1, "{page}: no plot measured");
        for o in r["overflow"].as_array().unwrap() {
            problems.push(format!("{page}: {}", o.as_str().unwrap()));
        }
        let out = screenshot.wait_with_output().unwrap();
        let png = std::fs::read(&shot).unwrap_or_else(|_| {
            panic!(
                "{page}: no screenshot: {}",
                String::from_utf8_lossy(&out.stderr)
            )
        });
        assert!(
            png.starts_with(b"\x89PNG") && png.len() > 10_000,
            "{page}: {} bytes",
            png.len()
        );
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}
