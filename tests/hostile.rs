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
    let d = example("analyze/stepped-square");
    let runs: Vec<(Vec<std::ffi::OsString>, Option<&Path>)> = vec![
        (vec!["machine".into(), "list".into()], None),
        (
            vec!["machine".into(), "show".into(), "bc-trunnion".into()],
            None,
        ),
        (vec!["simulate".into(), "--truth-example".into()], None),
        (vec!["completions".into(), "bash".into()], None),
        (
            vec![
                "analyze".into(),
                "--plan".into(),
                d.join("stepped-square.plan.yaml").into(),
                "--measured".into(),
                d.join("piece1.dmo").into(),
                "--out".into(),
                result.clone().into(),
            ],
            Some(&result),
        ),
        (compensate_args(&program), Some(&program)),
    ];
    for (args, file) in runs {
        // A pipe whose reader is gone: the first write fails at once.
        let (reader, writer) = std::io::pipe().unwrap();
        drop(reader);
        let out = StdCommand::new(assert_cmd::cargo::cargo_bin("fivecal"))
            .args(&args)
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

    // SIGTERM while the program is still coming in through a FIFO: the
    // temporary output exists, the run is waiting for more input.
    let fifo = dir.path().join("in.nc");
    assert!(
        StdCommand::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap()
            .success()
    );
    let mut a = compensate_args(&out);
    a[5] = fifo.clone().into();
    let mut child = StdCommand::new(assert_cmd::cargo::cargo_bin("fivecal"))
        .args(&a)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut w = std::fs::OpenOptions::new().write(true).open(&fifo).unwrap();
    use std::io::Write as _;
    writeln!(w, "G0 X0 Y0 Z100").unwrap();
    w.flush().unwrap();
    // The temporary file appears as soon as the run starts writing; wait
    // for it by polling, then end the run.
    while temporaries(dir.path()).is_empty() {
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    assert!(
        StdCommand::new("kill")
            .args(["-TERM", &child.id().to_string()])
            .status()
            .unwrap()
            .success()
    );
    let status = child.wait().unwrap();
    drop(w);
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
            "--program",
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
            "--program",
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
