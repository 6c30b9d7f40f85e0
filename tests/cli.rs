//! The binary as a user runs it.

use assert_cmd::Command;

/// The binary, recording into a results store of this test run (never the
/// user's own): one SQLite file shared by every test, as several runs of a
/// shop share one.
pub fn fivecal() -> Command {
    let mut c = Command::cargo_bin("fivecal").unwrap();
    c.env("FIVECAL_DB", test_store());
    c
}

/// The results store the tests' runs record into.
pub fn test_store() -> std::path::PathBuf {
    static DIR: std::sync::OnceLock<tempfile::TempDir> = std::sync::OnceLock::new();
    DIR.get_or_init(|| tempfile::tempdir().unwrap())
        .path()
        .join("history.db")
}

/// `fivecal analyze --plan MANIFEST --measured FILE --out OUT`, to which a
/// test adds its own options.
pub fn analyze_cmd(
    manifest: &std::path::Path,
    measured: &std::path::Path,
    out: &std::path::Path,
) -> Command {
    let mut c = fivecal();
    c.args(["analyze", "--plan"])
        .arg(manifest)
        .arg("--measured")
        .arg(measured)
        .arg("--out")
        .arg(out);
    c
}

#[test]
fn help_lists_every_subcommand_with_what_it_does() {
    let out = fivecal()
        .arg("--help")
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let text = String::from_utf8(out).unwrap();
    for (cmd, what) in [
        ("plan", "NC program"),
        ("simulate", "virtual machine"),
        ("analyze", "uncertainty"),
        ("compensate", "NC programs"),
        ("discover", "missing"),
        ("machine", "machine files"),
    ] {
        let line = text
            .lines()
            .find(|l| l.trim_start().starts_with(cmd))
            .unwrap_or_else(|| panic!("no `{cmd}` in\n{text}"));
        assert!(line.contains(what), "`{cmd}` help line: {line}");
    }
}

#[test]
fn machine_show_prints_the_chain_and_symbols() {
    let out = fivecal()
        .args(["machine", "show", "bc-trunnion"])
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let text = String::from_utf8(out).unwrap();
    assert!(text.contains("rTw  = D(dx_BY, dy_BY, dz_BY, a_BY, b_BY, c_BY) * Db(-B) * D(dx_CB, dy_CB, dz_CB, a_CB, b_CB, c_CB) * Dc(-C)"), "{text}");
    assert!(text.contains("EB0B      = b_BY + b_CB"), "{text}");
    assert!(
        text.contains("EZ0C      dz_CB moves the C axis along its own direction"),
        "{text}"
    );
}

#[test]
fn machine_show_of_a_bad_file_names_file_line_and_key() {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/machines/reversed-limits.yaml");
    let out = fivecal()
        .args(["machine", "show"])
        .arg(&p)
        .assert()
        .code(2)
        .get_output()
        .stderr
        .clone();
    let text = String::from_utf8(out).unwrap();
    assert!(
        text.contains("reversed-limits.yaml:7:7: limits of B must be [min, max]"),
        "{text}"
    );
    assert!(!text.contains("panicked"), "{text}");
}

#[test]
fn completions_know_every_subcommand() {
    for shell in ["bash", "zsh", "fish", "powershell", "elvish"] {
        let out = fivecal()
            .args(["completions", shell])
            .assert()
            .success()
            .get_output()
            .stdout
            .clone();
        let text = String::from_utf8(out).unwrap();
        for sub in [
            "plan",
            "simulate",
            "analyze",
            "compensate",
            "discover",
            "machine",
        ] {
            assert!(text.contains(sub), "{shell} completions lack `{sub}`");
        }
    }
    fivecal().args(["completions", "tcsh"]).assert().failure();
}

/// Completions offer the test names after `plan` and the built-in
/// machines after `--machine`, while the commands still take a file.
#[test]
fn completions_offer_test_and_machine_names() {
    let text = |shell: &str| {
        String::from_utf8(
            fivecal()
                .args(["completions", shell])
                .assert()
                .success()
                .get_output()
                .stdout
                .clone(),
        )
        .unwrap()
    };
    let fish = text("fish");
    let plan_machine = fish
        .lines()
        .find(|l| l.contains("using_subcommand plan") && l.contains("-l machine"))
        .unwrap_or_else(|| panic!("{fish}"));
    let after: String = fish[fish.find(plan_machine).unwrap()..]
        .lines()
        .take(5)
        .collect();
    for m in ["bc-trunnion", "ac-trunnion", "head-table", "head-head"] {
        assert!(after.contains(m), "{after}");
    }
    let zsh = text("zsh");
    assert!(
        zsh.contains("(stepped-square nine-section probe-columns probe-sphere)"),
        "{zsh}"
    );
    // The parser itself is unchanged: a machine file is a path.
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("m.yaml");
    std::fs::write(
        &file,
        fivecal::Machine::builtin("head-head").unwrap().source,
    )
    .unwrap();
    fivecal()
        .args(["machine", "show"])
        .arg(&file)
        .assert()
        .success();
}

/// `machine new` writes a copy under the new name that reads back as the
/// same machine, never over an existing file. Its description is its own:
/// the old one is printed in every program header, and "FANUC 31i-like" or
/// another machine's paper would then label the new machine's programs.
#[test]
fn machine_new_writes_a_renamed_copy_that_reads_back() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("my.yaml");
    fivecal()
        .args(["machine", "new", "my-mill", "--from", "head-table", "-o"])
        .arg(&file)
        .assert()
        .success();
    let copy = fivecal::Machine::from_file(&file).unwrap();
    let original = fivecal::Machine::builtin("head-table").unwrap();
    assert_eq!(copy.name, "my-mill");
    assert_ne!(copy.description, original.description);
    assert!(
        copy.description
            .starts_with("my-mill (copied from head-table;"),
        "{}",
        copy.description
    );
    assert_eq!(
        (
            copy.strokes,
            copy.pivot,
            copy.chain.clone(),
            copy.tool.clone()
        ),
        (
            original.strokes,
            original.pivot,
            original.chain.clone(),
            original.tool.clone()
        )
    );
    let before = std::fs::read(&file).unwrap();
    let out = fivecal()
        .args(["machine", "new", "other", "-o"])
        .arg(&file)
        .assert()
        .failure()
        .get_output()
        .stderr
        .clone();
    assert!(String::from_utf8_lossy(&out).contains("exists"));
    assert_eq!(std::fs::read(&file).unwrap(), before);
    fivecal()
        .args(["machine", "new", "bad name", "-o", "-"])
        .assert()
        .failure();
}

/// The man page as `fivecal man` prints it.
fn man_page() -> String {
    let out = fivecal()
        .arg("man")
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    String::from_utf8(out).unwrap()
}

/// One vocabulary on every command: each command that writes a file or a
/// directory names it `-o/--out`; no command spells it `--output`; the NC
/// program is an argument, never `--program`; `--dialect` offers the four
/// dialects wherever it is taken.
#[test]
fn every_command_speaks_one_vocabulary() {
    let writes_output = [
        &["plan"][..],
        &["simulate"],
        &["simulate", "nc"],
        &["analyze"],
        &["analyze", "contour"],
        &["compensate"],
        &["discover"],
        &["verify"],
        &["history", "export"],
        &["history", "plot"],
        &["demo"],
        &["machine", "new"],
    ];
    for path in writes_output {
        let help = fivecal().args(path).arg("--help").output().unwrap();
        let help = String::from_utf8_lossy(&help.stdout);
        assert!(
            help.contains("-o, --out"),
            "{path:?} does not name its output -o/--out:\n{help}"
        );
        assert!(!help.contains("--output"), "{path:?} still says --output");
        assert!(!help.contains("--program"), "{path:?} takes --program");
        if help.contains("--dialect") {
            assert!(
                help.contains("fanuc")
                    && help.contains("heidenhain")
                    && help.contains("linuxcnc")
                    && help.contains("sinumerik"),
                "{path:?}: --dialect without its four values"
            );
        }
    }
}

/// The spellings of the last release still work, once more, with a note
/// saying what to write instead.
#[test]
fn the_old_output_spelling_still_works_with_a_note() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("old.yaml");
    let run = fivecal()
        .args(["machine", "new", "old-spelling", "--output"])
        .arg(&file)
        .assert()
        .success()
        .get_output()
        .clone();
    assert!(file.exists());
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(err.contains("`--output` is now `-o/--out`"), "{err}");
}

/// The man page's EXAMPLES are a calibration a user can paste, line by line,
/// into an empty directory: each line runs, in order, and leaves the files
/// the next one reads.
#[test]
fn man_page_examples_run_in_an_empty_directory() {
    let text = man_page();
    let examples = &text[text.find(".SH EXAMPLES").expect("an EXAMPLES section")..];
    let examples = &examples[..examples[4..].find(".SH ").map_or(examples.len(), |i| i + 4)];
    let lines: Vec<String> = examples
        .split(".RS 4\n")
        .skip(1)
        .map(|block| {
            block
                .lines()
                .next()
                .unwrap()
                .replace("\\-", "-")
                .replace("\\e", "\\")
        })
        .collect();
    assert!(lines.len() >= 5, "{examples}");
    let dir = tempfile::tempdir().unwrap();
    for line in &lines {
        let (command, redirect) = match line.split_once(" > ") {
            Some((c, file)) => (c, Some(file.trim())),
            None => (line.as_str(), None),
        };
        let words: Vec<&str> = command.split_whitespace().collect();
        assert_eq!(words[0], "fivecal", "{line}");
        let run = fivecal()
            .current_dir(dir.path())
            .args(&words[1..])
            .assert()
            .success()
            .get_output()
            .clone();
        if let Some(file) = redirect {
            std::fs::write(dir.path().join(file), &run.stdout).unwrap();
        }
    }
    assert!(dir.path().join("frustum-compensated.nc").exists());
}

/// Nested subcommands (`simulate nc`, `history plot`, `machine new`) have
/// their own sections, and every variable the program reads is listed.
#[test]
fn man_page_covers_nested_subcommands_and_the_environment() {
    let text = man_page();
    for sub in [
        "SIMULATE NC",
        "ANALYZE CONTOUR",
        "HISTORY PLOT",
        "HISTORY TREND",
        "MACHINE NEW",
    ] {
        assert!(
            text.contains(&format!(".SH \"FIVECAL {sub}\"")),
            "no section for {sub}"
        );
    }
    let env = &text[text
        .find(".SH ENVIRONMENT")
        .expect("an ENVIRONMENT section")..];
    assert!(env.contains("FIVECAL_DB"));
}

#[test]
fn man_page_has_a_section_per_subcommand() {
    let text = man_page();
    assert!(
        text.starts_with(".ie") && text.contains(".TH fivecal 1"),
        "{}",
        &text[..200.min(text.len())]
    );
    for sub in [
        "PLAN",
        "SIMULATE",
        "ANALYZE",
        "COMPENSATE",
        "DISCOVER",
        "MACHINE",
    ] {
        assert!(
            text.contains(&format!(".SH \"FIVECAL {sub}\"")),
            "no section for {sub}"
        );
    }
    // Only this one page is installed: it must not send the reader to
    // fivecal-plan(1) and the like, which do not exist.
    assert!(!text.contains("(1)"), "the man page cites other pages");
    assert!(text.contains(".SH NAME") && text.contains(".SH SYNOPSIS"));
}
