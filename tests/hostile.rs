//! Hostile input, as an unfriendly user would give it: every command ends
//! with a clear error or does its job, and never panics, hangs, grows
//! without bound, leaves a temporary file or destroys a file. Each test is
//! one class of the cases `docs/input-and-output.md` lists.

use std::path::{Path, PathBuf};
use std::process::{Command as StdCommand, Stdio};

use crate::cli::fivecal;
use crate::util::tempdir;

fn example(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples")
        .join(rel)
}

fn stderr_of(out: &std::process::Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Runs `fivecal ARGS` and expects a clear refusal (exit 2, no panic)
/// whose message contains every one of `expect`.
fn refused(args: &[&std::ffi::OsStr], expect: &[&str]) -> String {
    let out = fivecal().args(args).output().unwrap();
    let err = stderr_of(&out);
    assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
    assert!(!err.contains("panicked"), "{args:?}: {err}");
    for e in expect {
        assert!(err.contains(e), "{args:?}: expected `{e}` in: {err}");
    }
    err
}

macro_rules! args {
    ($($a:expr),* $(,)?) => { &[$(std::ffi::OsStr::new(&$a)),*] };
}

/// Files left in `dir` whose names mark them as temporaries.
fn temporaries(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains("fivecal-tmp") || n.starts_with(".tmp"))
        .collect()
}

/// A compensate run of the stepped-square example program with its truth.
fn compensate_args(out: &Path) -> Vec<std::ffi::OsString> {
    let d = example("analyze/stepped-square");
    vec![
        "compensate".into(),
        "--machine".into(),
        "bc-trunnion".into(),
        "--errors".into(),
        d.join("truth.yaml").into(),
        d.join("stepped-square.nc").into(),
        "-o".into(),
        out.into(),
    ]
}

#[test]
fn a_closed_standard_output_ends_each_printing_command_quietly_after_its_files_are_written() {
    let dir = tempdir();
    let result = dir.path().join("result.yaml");
    let program = dir.path().join("compensated.nc");
    let measured = dir.path().join("measured.dmo");
    let json = dir.path().join("result.json");
    let mc = dir.path().join("mc.yaml");
    let discovered = dir.path().join("discovered.yaml");
    let demo = dir.path().join("demo");
    let demo_result = demo.join("analyzed.yaml");
    let d = example("analyze/stepped-square");
    let analyze = |extra: &[&str], out: &Path| {
        let mut a: Vec<std::ffi::OsString> = vec![
            "analyze".into(),
            "--plan".into(),
            d.join("stepped-square.plan.yaml").into(),
            "--measured".into(),
            d.join("piece1.dmo").into(),
            "--out".into(),
            out.into(),
        ];
        a.extend(extra.iter().map(Into::into));
        a
    };
    let strings = |a: &[&str]| {
        a.iter()
            .map(Into::into)
            .collect::<Vec<std::ffi::OsString>>()
    };
    let runs: Vec<(Vec<std::ffi::OsString>, Option<&Path>)> = vec![
        (
            vec![
                "simulate".into(),
                "--plan".into(),
                d.join("stepped-square.plan.yaml").into(),
                "--errors".into(),
                d.join("truth.yaml").into(),
                "-o".into(),
                measured.clone().into(),
            ],
            Some(&measured),
        ),
        (
            vec![
                "simulate".into(),
                "nc".into(),
                "--machine".into(),
                "bc-trunnion".into(),
                "--errors".into(),
                d.join("truth.yaml").into(),
                d.join("stepped-square.nc").into(),
            ],
            None,
        ),
        (analyze(&["--json"], &json), Some(&json)),
        (analyze(&["--mc", "20"], &mc), Some(&mc)),
        (
            vec![
                "analyze".into(),
                "contour".into(),
                "--model".into(),
                example("contour/frustum.obj").into(),
                "--measured".into(),
                example("contour/cmm-points.csv").into(),
            ],
            None,
        ),
        (
            vec![
                "discover".into(),
                "--plan".into(),
                example("discover/stepped-square.plan.yaml").into(),
                "--measured".into(),
                example("discover/piece.dmo").into(),
                "--max-steps".into(),
                "1".into(),
                "--out".into(),
                discovered.clone().into(),
            ],
            Some(&discovered),
        ),
        (
            vec![
                "compensate".into(),
                "--machine".into(),
                "bc-trunnion".into(),
                "--errors".into(),
                d.join("truth.yaml").into(),
                "--export".into(),
                "fanuc".into(),
                "--no-record".into(),
            ],
            None,
        ),
        (
            vec!["demo".into(), "--out".into(), demo.clone().into()],
            Some(&demo_result),
        ),
        (vec!["measured".into(), d.join("piece1.dmo").into()], None),
        (strings(&["man"]), None),
        (vec!["machine".into(), "list".into()], None),
        (
            vec!["machine".into(), "show".into(), "bc-trunnion".into()],
            None,
        ),
        (vec!["simulate".into(), "--truth-example".into()], None),
        (vec!["completions".into(), "bash".into()], None),
        (analyze(&[], &result), Some(&result)),
        (compensate_args(&program), Some(&program)),
    ];
    for (args, file) in runs {
        // A pipe whose reader is gone: the first write fails at once.
        let (reader, writer) = std::io::pipe().unwrap();
        drop(reader);
        let out = StdCommand::new(assert_cmd::cargo::cargo_bin("fivecal"))
            .args(&args)
            .env("FIVECAL_DB", crate::cli::test_store())
            .stdout(Stdio::from(writer))
            .stderr(Stdio::piped())
            .output()
            .unwrap();
        let err = stderr_of(&out);
        assert_eq!(out.status.code(), Some(141), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
        if let Some(f) = file {
            assert!(std::fs::metadata(f).unwrap().len() > 0, "{args:?}: {f:?}");
        }
    }
}

#[test]
fn devices_are_written_in_place_and_dash_is_standard_output() {
    let dir = tempdir();
    let before = std::fs::metadata("/dev/null").unwrap();
    fivecal()
        .args(compensate_args(Path::new("/dev/null")))
        .assert()
        .success();
    use std::os::unix::fs::FileTypeExt;
    let after = std::fs::metadata("/dev/null").unwrap();
    assert!(after.file_type().is_char_device());
    assert_eq!(
        std::os::unix::fs::MetadataExt::rdev(&before),
        std::os::unix::fs::MetadataExt::rdev(&after)
    );
    let out = fivecal()
        .current_dir(dir.path())
        .args(compensate_args(Path::new("-")))
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", stderr_of(&out));
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("G1") || text.contains("G01"), "{text}");
    assert!(!dir.path().join("-").exists());
}

#[test]
fn new_files_follow_the_umask_and_replaced_files_keep_their_mode() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempdir();
    let out = dir.path().join("new.nc");
    fivecal().args(compensate_args(&out)).assert().success();
    let mode = std::fs::metadata(&out).unwrap().permissions().mode() & 0o777;
    // The test process's umask is the usual 022 or 002: group and others
    // read, never the 0600 of a temporary file.
    assert!(mode & 0o044 == 0o044, "{mode:o}");
    std::fs::set_permissions(&out, std::fs::Permissions::from_mode(0o640)).unwrap();
    fivecal().args(compensate_args(&out)).assert().success();
    let mode = std::fs::metadata(&out).unwrap().permissions().mode() & 0o777;
    assert_eq!(mode, 0o640);
}

#[test]
fn an_output_naming_an_input_or_another_output_is_refused_before_anything_is_written() {
    let dir = tempdir();
    let d = example("analyze/stepped-square");
    let prev = dir.path().join("prev.yaml");
    std::fs::copy(d.join("truth.yaml"), &prev).unwrap();
    let before = std::fs::read(&prev).unwrap();
    refused(
        args![
            "analyze",
            "--plan",
            d.join("stepped-square.plan.yaml"),
            "--measured",
            d.join("piece1.dmo"),
            "--out",
            prev,
            "--compare",
            prev
        ],
        &["--out", "prev.yaml"],
    );
    assert_eq!(std::fs::read(&prev).unwrap(), before);
    let x = dir.path().join("x.nc");
    let mut a = compensate_args(&x);
    a.extend([
        "--export".into(),
        "fanuc".into(),
        "--export-to".into(),
        x.clone().into(),
    ]);
    let out = fivecal().args(&a).output().unwrap();
    assert_eq!(out.status.code(), Some(2), "{}", stderr_of(&out));
    assert!(
        stderr_of(&out).contains("--export-to"),
        "{}",
        stderr_of(&out)
    );
    assert!(!x.exists());
    // A plan onto an existing file says what is wrong with it.
    let file = dir.path().join("a-file");
    std::fs::write(&file, "keep").unwrap();
    let err = refused(
        args![
            "plan",
            "stepped-square",
            "--machine",
            "bc-trunnion",
            "--out",
            file
        ],
        &["--out"],
    );
    assert!(!err.contains("os error 17"), "{err}");
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "keep");
}

#[test]
fn temporary_files_go_after_an_error_and_after_sigterm() {
    let dir = tempdir();
    // An error midway: the program ends in a block the reader refuses.
    let bad = dir.path().join("bad.nc");
    let mut text =
        std::fs::read_to_string(example("analyze/stepped-square/stepped-square.nc")).unwrap();
    text.push_str("G1 X1 Y\n");
    std::fs::write(&bad, text).unwrap();
    let out = dir.path().join("out.nc");
    let mut a = compensate_args(&out);
    a[5] = bad.into();
    // Outside --strict an unreadable block is kept and reported, not an error.
    a.push("--strict".into());
    let o = fivecal().args(&a).output().unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", stderr_of(&o));
    assert!(!out.exists());
    assert_eq!(temporaries(dir.path()), Vec::<String>::new());

    // SIGTERM while a long program is being rewritten: the temporary
    // output exists, the run is still writing. (Inputs are regular files:
    // a FIFO is refused before it is opened, so a long file it is.)
    let long = dir.path().join("long.nc");
    let src = std::fs::read_to_string(example("analyze/stepped-square/stepped-square.nc")).unwrap();
    let lines: Vec<&str> = src.lines().collect();
    let (body, end) = lines.split_at(lines.len() - 2);
    let mut text: Vec<&str> = body.to_vec();
    for _ in 0..100 {
        text.extend_from_slice(&body[20..]);
    }
    text.extend_from_slice(end);
    std::fs::write(&long, text.join("\n") + "\n").unwrap();
    let mut a = compensate_args(&out);
    a[5] = long.into();
    let mut child = StdCommand::new(assert_cmd::cargo::cargo_bin("fivecal"))
        .args(&a)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // The temporary file appears as soon as the run starts writing; wait
    // for it by polling (never longer than a minute), then end the run.
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(60);
    while temporaries(dir.path()).is_empty() {
        if let Some(status) = child.try_wait().unwrap() {
            panic!("the run ended ({status}) before its temporary file was seen");
        }
        assert!(
            std::time::Instant::now() < deadline,
            "no temporary file within a minute"
        );
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    assert!(
        StdCommand::new("kill")
            .args(["-TERM", &child.id().to_string()])
            .status()
            .unwrap()
            .success()
    );
    let status = child.wait().unwrap();
    assert!(!status.success());
    assert!(!out.exists());
    assert_eq!(temporaries(dir.path()), Vec::<String>::new());
}

#[test]
fn endless_and_oversized_inputs_end_at_once_with_an_error() {
    let dir = tempdir();
    refused(
        args!["machine", "show", "/dev/zero"],
        &["/dev/zero", "device"],
    );
    let mut a = compensate_args(&dir.path().join("o.nc"));
    a[5] = "/dev/zero".into();
    let o = fivecal().args(&a).output().unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", stderr_of(&o));
    assert!(stderr_of(&o).contains("device"), "{}", stderr_of(&o));
    // YAML nested 200,000 brackets deep: refused by a linear scan before
    // the parser, whose time grows with the square of the depth.
    let deep = dir.path().join("deep.yaml");
    std::fs::write(&deep, "[".repeat(200_000)).unwrap();
    refused(
        args!["machine", "show", deep],
        &["deep.yaml:1:", "nested more than"],
    );
    // A sampling step finer than any machine resolves.
    let d = example("analyze/stepped-square");
    refused(
        args![
            "simulate",
            "nc",
            "--machine",
            "bc-trunnion",
            "--errors",
            d.join("truth.yaml"),
            "--step",
            "1e-9",
            d.join("stepped-square.nc")
        ],
        &["--step 0.000000001", "at least"],
    );
    refused(
        args![
            "simulate",
            "nc",
            "--machine",
            "bc-trunnion",
            "--errors",
            d.join("truth.yaml"),
            "--max-distance=-1",
            d.join("stepped-square.nc")
        ],
        &["--max-distance -1"],
    );
}

/// The fanuc postprocessor with one template replaced.
fn post_with(dir: &Path, name: &str, template: &str) -> PathBuf {
    let src = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("postprocessors/fanuc.yaml"),
    )
    .unwrap();
    let key = format!("  {name}: ");
    let line = src.lines().find(|l| l.starts_with(&key)).unwrap();
    let p = dir.join(format!("{name}.post.yaml"));
    std::fs::write(&p, src.replace(line, &format!("{key}{template}"))).unwrap();
    p
}

#[test]
fn a_postprocessor_whose_motion_templates_break_the_safety_rules_is_refused() {
    let dir = tempdir();
    for (name, template, expect) in [
        ("retract", "\"G0 X0\"", "does not retract"),
        ("retract", "\"G0 {{ words }} X0\"", "also moves X or Y"),
        ("rapid", "\"\"", "every word"),
        ("rotary", "\"G0 {{ words }} Z5\"", "no X, Y or Z"),
    ] {
        let post = post_with(dir.path(), name, template);
        let out = dir.path().join(format!("plan-{name}"));
        refused(
            args![
                "plan",
                "stepped-square",
                "--machine",
                "bc-trunnion",
                "--postprocessor",
                post,
                "--out",
                out
            ],
            &[&format!("template `{name}`"), expect],
        );
        assert!(!out.exists());
    }
    // A template that loops without end runs out of its step budget.
    let post = post_with(
        dir.path(),
        "rapid",
        "\"{% for i in range(100000) %}{% for j in range(100000) %}{% endfor %}{% endfor %}G0 {{ words }}\"",
    );
    refused(
        args![
            "plan",
            "stepped-square",
            "--machine",
            "bc-trunnion",
            "--postprocessor",
            post,
            "--out",
            dir.path().join("loop")
        ],
        &["steps to render one block"],
    );
}

#[test]
fn duplicate_keys_are_refused_at_every_depth_and_implausible_values_name_their_unit() {
    let dir = tempdir();
    let truth = example("analyze/stepped-square/truth.yaml");
    let src = std::fs::read_to_string(&truth).unwrap();
    let dup = dir.path().join("dup.yaml");
    std::fs::write(
        &dup,
        src.replacen("  EZ0B: -40.0\n", "  EZ0B: -40.0\n  EX0B: 3.0\n", 1),
    )
    .unwrap();
    refused(
        args![
            "compensate",
            "--machine",
            "bc-trunnion",
            "--errors",
            dup,
            "--export",
            "fanuc"
        ],
        &["dup.yaml:5:3:", "duplicate key `EX0B`"],
    );
    let huge = dir.path().join("huge.yaml");
    std::fs::write(&huge, src.replacen("  EX0B: 12.0\n", "  EX0B: 1.0e6\n", 1)).unwrap();
    refused(
        args![
            "compensate",
            "--machine",
            "bc-trunnion",
            "--errors",
            huge,
            "--export",
            "fanuc"
        ],
        &["huge.yaml:3:", "EX0B", "um"],
    );
}

#[test]
fn a_built_in_machine_name_means_the_built_in_machine() {
    let dir = tempdir();
    std::fs::write(dir.path().join("bc-trunnion"), "name: impostor\n").unwrap();
    let out = fivecal()
        .current_dir(dir.path())
        .args(["machine", "show", "bc-trunnion"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", stderr_of(&out));
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("built in"), "{text}");
    assert!(!text.contains("impostor"), "{text}");
}

/// The built-in template of `test` with each `(from, to)` replaced,
/// written to `dir/name.yaml`; with its text.
fn template_with(dir: &Path, test: &str, name: &str, edits: &[(&str, &str)]) -> (PathBuf, String) {
    let mut text = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("templates/{test}.yaml")),
    )
    .unwrap();
    for (from, to) in edits {
        assert!(text.contains(from), "{test}: {from}");
        text = text.replacen(from, to, 1);
    }
    let p = dir.join(format!("{name}.yaml"));
    std::fs::write(&p, &text).unwrap();
    (p, text)
}

#[test]
fn template_values_that_would_plan_without_end_are_refused_before_any_work() {
    // Each of these made `plan` loop or grow to gigabytes; each now ends
    // at once with the template's file and line, the key and the range.
    let dir = tempdir();
    // (test, edits of its built-in template, what the error says)
    type Case<'a> = (&'a str, &'a [(&'a str, &'a str)], &'a [&'a str]);
    let cases: &[Case] = &[
        (
            "stepped-square",
            &[("axial_depth: 5 ", "axial_depth: 1e-9 ")],
            &[
                "cutting.axial_depth must be between 0.001 and 2000 mm",
                "got 1e-9",
            ],
        ),
        (
            "stepped-square",
            &[("stepover: 0.5 ", "stepover: 1e-9 ")],
            &["cutting.stepover 1e-9 of the D8 tool puts the rings 8e-9 mm apart"],
        ),
        (
            "stepped-square",
            &[("size: 100 ", "size: 1e300 ")],
            &["stock.size must be between 0.001 and 2000 mm", "got 1e300"],
        ),
        (
            "stepped-square",
            &[("size: 100 ", "size: 1000 ")],
            &["stock.size 1000 mm is wider than the Y stroke of bc-trunnion (530 mm)"],
        ),
        (
            "stepped-square",
            &[("per_wall: 2", "per_wall: 100000")],
            &["points.per_wall must be 1 to 10000, got 100000"],
        ),
        (
            "stepped-square",
            &[("per_wall: 2", "per_wall: 1000")],
            &["about 48048 points, more than the 10000 a plan may have"],
        ),
        (
            "stepped-square",
            &[("axial_depth: 5 ", "axial_depth: 0.001 ")],
            &[
                "moves, more than the 100000 a plan may have",
                "cutting.axial_depth",
            ],
        ),
        (
            "stepped-square",
            &[
                ("stepover: 0.5 ", "stepover: 0.003125 "),
                ("per_wall: 2", "per_wall: 200"),
            ],
            &["(point, move) pairs to trace, more than the 100000000"],
        ),
        (
            "nine-section",
            &[("stepover: 0.25 ", "stepover: 1e-9 ")],
            &[
                "cutting.stepover must be between 0.001 and 2000 mm",
                "got 1e-9",
            ],
        ),
        (
            "nine-section",
            &[("stepover: 0.25 ", "stepover: 0.001 ")],
            &["about 360018 moves, more than the 100000"],
        ),
        (
            "nine-section",
            &[("depth: 0.5 ", "depth: 1e-9 ")],
            &["depth must be between 0.001 and 2000 mm", "got 1e-9"],
        ),
        (
            "probe-sphere",
            &[("step: 10}}\n", "step: 1e-9}}\n")],
            &["a step of 1e-9 deg from 0 to 350 makes 350000000001 poses"],
        ),
        (
            "probe-sphere",
            &[
                ("pattern: seed-004", "pattern: seed-003"),
                ("poses: 50", "poses: 2001"),
            ],
            &["about 10005 touches, more than the 10000"],
        ),
        (
            "probe-columns",
            &[("spindle_length: 150", "spindle_length: 1e300")],
            &["probe.spindle_length must be between 0.001 and 2000 mm"],
        ),
        (
            "probe-columns",
            &[("feed: 100 ", "feed: 1e-300 ")],
            &["probing.feed must be between 1 and 1000000 mm/min, got 1e-300"],
        ),
        (
            "probe-columns",
            &[(
                "c: [0, 60, 120, 180, 240, 300]",
                "c: [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26, 27, 28, 29, 30, 31, 32, 33, 34, 35, 36, 37, 38, 39, 40, 41, 42, 43, 44, 45, 46, 47, 48, 49, 50, 51, 52, 53, 54, 55, 56, 57, 58, 59, 60, 61, 62, 63, 64, 65, 66, 67, 68, 69, 70, 71, 72, 73, 74, 75, 76, 77, 78, 79, 80, 81, 82, 83, 84, 85, 86, 87, 88, 89, 90, 91, 92, 93, 94, 95, 96, 97, 98, 99, 100, 101, 102, 103, 104, 105, 106, 107, 108, 109, 110, 111, 112, 113, 114, 115, 116, 117, 118, 119, 120, 121, 122, 123, 124, 125, 126, 127, 128, 129, 130, 131, 132, 133, 134, 135, 136, 137, 138, 139, 140, 141, 142, 143, 144, 145, 146, 147, 148, 149, 150, 151, 152, 153, 154, 155, 156, 157, 158, 159, 160, 161, 162, 163, 164, 165, 166, 167, 168, 169, 170, 171, 172, 173, 174, 175, 176, 177, 178, 179, 180]",
            )],
            &["about 10860 touches, more than the 10000 a plan may have"],
        ),
    ];
    for (k, (test, edits, expect)) in cases.iter().enumerate() {
        let (tpl, text) = template_with(dir.path(), test, &format!("t{k}"), edits);
        // The error points at the edited line, or at the section whose
        // counts multiply into too much work.
        let key = match expect[0] {
            e if e.contains("pairs") || e.contains("points,") => "points:",
            e if e.contains("moves,") && *test == "stepped-square" => "cutting:",
            e if e.contains("touches,") && *test == "probe-columns" => "poses:",
            e if e.contains("touches,") => "pattern:",
            _ => edits.last().unwrap().1.trim_end(),
        };
        let line = text
            .lines()
            .position(|l| l.starts_with(key) || l.contains(key))
            .unwrap()
            + 1;
        let out = dir.path().join(format!("plan-{k}"));
        let at = format!("t{k}.yaml:{line}:");
        let mut expect = expect.to_vec();
        expect.push(&at);
        refused(
            args![
                "plan",
                test,
                "--machine",
                "bc-trunnion",
                "--template",
                tpl,
                "--out",
                out
            ],
            &expect,
        );
        assert!(!out.exists(), "{test} {edits:?}");
    }
}

#[test]
fn a_template_or_tool_built_in_code_is_bounded_too() {
    // A library caller may fill a template's fields or hand over a tool
    // without the checks reading a file makes: the plan counts its work
    // before doing any, and refuses.
    use fivecal::formats::manifest::KinematicsMode;
    use fivecal::procedure::{PlanConfig, Template, Test};
    let config = |template: Template, tool: Option<fivecal::machine::Tool>| PlanConfig {
        machine: crate::util::machine("bc-trunnion"),
        template,
        post: fivecal::post::PostDefinition::builtin(fivecal::Dialect::Fanuc),
        kinematics: KinematicsMode::Post,
        tool,
    };
    let stepped = || match Template::builtin(Test::SteppedSquare) {
        Template::SteppedSquare(t) => t,
        _ => unreachable!(),
    };
    let err = |cfg: PlanConfig| fivecal::procedure::plan(&cfg).unwrap_err().to_string();

    let mut t = stepped();
    t.stock.size = 1e300;
    let e = err(config(Template::SteppedSquare(t), None));
    assert!(
        e.contains("stock.size 1e300 mm is wider than the Y stroke"),
        "{e}"
    );

    let mut t = stepped();
    t.cutting.axial_depth = Some(1e-12);
    let e = err(config(Template::SteppedSquare(t), None));
    assert!(e.contains("moves, more than the 100000"), "{e}");

    let mut t = stepped();
    t.points.per_wall = usize::MAX / 2;
    let e = err(config(Template::SteppedSquare(t), None));
    assert!(e.contains("points, more than the 10000"), "{e}");

    let mut tool = crate::util::machine("bc-trunnion").tool;
    tool.diameter = 1e-9;
    let e = err(config(Template::SteppedSquare(stepped()), Some(tool)));
    assert!(
        e.contains("tool diameter must be between 0.001 and 2000 mm, got 1e-9"),
        "{e}"
    );

    let mut t = match Template::builtin(Test::NineSection) {
        Template::NineSection(t) => t,
        _ => unreachable!(),
    };
    t.cutting.stepover = 0.0;
    let e = err(config(Template::NineSection(t), None));
    assert!(e.contains("countless moves"), "{e}");
}
