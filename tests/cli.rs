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

/// Completions offer the test names after `plan`, and files where a file
/// is meant: after every `--machine` (a file or a built-in name; clap's
/// completions offer names or files, not both, and a user's own machine is
/// a file), a postprocessor, a tool, the machine of `machine show`.
#[test]
fn completions_offer_test_names_and_machine_files() {
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
    let machine_lines: Vec<&str> = fish.lines().filter(|l| l.contains("-l machine ")).collect();
    // plan, simulate, simulate nc, compensate, verify, history and its
    // subcommands.
    assert!(machine_lines.len() >= 6, "{fish}");
    for l in &machine_lines {
        // `-F`: fish completes files; no list of names (`-a`) takes their
        // place.
        assert!(l.ends_with(" -r -F"), "{l}");
    }
    let plan_postprocessor = fish
        .lines()
        .find(|l| l.contains("using_subcommand plan") && l.contains("-l postprocessor"))
        .unwrap_or_else(|| panic!("{fish}"));
    assert!(plan_postprocessor.contains(" -F"), "{plan_postprocessor}");
    let zsh = text("zsh");
    assert!(
        zsh.contains("(stepped-square nine-section probe-columns probe-sphere)"),
        "{zsh}"
    );
    assert!(
        zsh.contains("--machine=[") && zsh.contains(":_files"),
        "{zsh}"
    );
    let bash = text("bash");
    assert!(bash.contains("compgen -f"), "{bash}");
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
    let copy = fivecal::Machine::from_file(&file, "machine file").unwrap();
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

/// What one command's `--help` shows of the one vocabulary.
struct Speaks {
    /// The subcommand path.
    path: &'static [&'static str],
    /// It writes a file or a directory, named `-o, --out`.
    out: bool,
    /// It takes a machine, `--machine <M.yaml|NAME>` (a file or a built-in
    /// name, resolved the same way everywhere).
    machine: bool,
    /// It prints a result that `--json` puts on standard output as JSON.
    json: bool,
    /// It takes a dialect, `--dialect` with the four values.
    dialect: bool,
}

const fn speaks(
    path: &'static [&'static str],
    out: bool,
    machine: bool,
    json: bool,
    dialect: bool,
) -> Speaks {
    Speaks {
        path,
        out,
        machine,
        json,
        dialect,
    }
}

/// Every subcommand, with what its options are about.
const VOCABULARY: &[Speaks] = &[
    speaks(&["plan"], true, true, true, true),
    speaks(&["simulate"], true, true, true, false),
    speaks(&["simulate", "nc"], true, true, true, true),
    speaks(&["analyze"], true, false, true, false),
    speaks(&["analyze", "contour"], true, false, false, false),
    speaks(&["compensate"], true, true, true, true),
    speaks(&["discover"], true, false, true, false),
    speaks(&["history"], false, true, true, false),
    speaks(&["history", "list"], false, true, true, false),
    speaks(&["history", "show"], false, true, true, false),
    speaks(&["history", "export"], true, true, true, false),
    speaks(&["history", "trend"], false, true, true, false),
    speaks(&["history", "plot"], true, true, true, false),
    speaks(&["verify"], true, true, true, false),
    speaks(&["demo"], true, false, false, false),
    speaks(&["measured"], false, false, true, false),
    speaks(&["machine"], false, false, false, false),
    speaks(&["machine", "list"], false, false, false, false),
    speaks(&["machine", "show"], false, false, false, false),
    speaks(&["machine", "new"], true, false, false, false),
    speaks(&["completions"], false, false, false, false),
    speaks(&["man"], false, false, false, false),
];

/// A command's `--help`, its lines joined and its runs of blanks made one,
/// so that a list of values wrapped over two lines reads as one.
fn help_of(path: &[&str]) -> String {
    let out = fivecal().args(path).arg("--help").assert().success();
    let text = String::from_utf8_lossy(&out.get_output().stdout).into_owned();
    text.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// One vocabulary on every command, read from each subcommand's `--help`:
/// every output is `-o/--out` (never `--output`), the NC program an
/// argument (never `--program`), every machine `--machine <M.yaml|NAME>`,
/// `--json` the one switch for machine-readable output (no `--format`
/// offers JSON), and `--dialect` the same four values wherever it is taken.
#[test]
fn every_command_speaks_one_vocabulary() {
    for s in VOCABULARY {
        let help = help_of(s.path);
        let path = s.path;
        assert_eq!(
            help.contains("-o, --out"),
            s.out,
            "{path:?}: -o/--out expected {}:\n{help}",
            s.out
        );
        assert!(!help.contains("--output"), "{path:?} still says --output");
        assert!(!help.contains("--program"), "{path:?} takes --program");
        assert_eq!(
            help.contains("--machine"),
            s.machine,
            "{path:?}: --machine expected {}",
            s.machine
        );
        if s.machine {
            assert!(
                help.contains("--machine <M.yaml|NAME>"),
                "{path:?}: --machine names its value otherwise:\n{help}"
            );
        }
        assert_eq!(
            help.contains("--json"),
            s.json,
            "{path:?}: --json expected {}",
            s.json
        );
        // What `--format` says, up to the next option.
        if let Some(i) = help.find("--format <") {
            let rest = &help[i + 2..];
            let format = &rest[..rest.find(" --").unwrap_or(rest.len())];
            assert!(
                !format.to_ascii_lowercase().contains("json"),
                "{path:?}: a --format offers JSON: {format}"
            );
        }
        assert_eq!(
            help.contains("--dialect"),
            s.dialect,
            "{path:?}: --dialect expected {}",
            s.dialect
        );
        if s.dialect {
            assert!(
                help.contains("[possible values: fanuc, heidenhain, linuxcnc, sinumerik]"),
                "{path:?}: --dialect without its four values:\n{help}"
            );
        }
    }
}

/// The table above names every subcommand `fivecal --help` and each
/// command's own `--help` list, so a new command cannot skip the check.
#[test]
fn the_vocabulary_table_names_every_subcommand() {
    fn commands(help: &str) -> Vec<String> {
        let Some(i) = help.find("Commands:") else {
            return Vec::new();
        };
        help[i..]
            .lines()
            .skip(1)
            .take_while(|l| l.starts_with("  "))
            // A description wrapped onto the next line is indented further.
            .filter(|l| !l.starts_with("   "))
            .filter_map(|l| l.split_whitespace().next())
            .filter(|c| *c != "help")
            .map(str::to_string)
            .collect()
    }
    let raw = |path: &[&str]| {
        let out = fivecal().args(path).arg("--help").assert().success();
        String::from_utf8_lossy(&out.get_output().stdout).into_owned()
    };
    let mut seen = Vec::new();
    for top in commands(&raw(&[])) {
        seen.push(vec![top.clone()]);
        for sub in commands(&raw(&[top.as_str()])) {
            seen.push(vec![top.clone(), sub]);
        }
    }
    assert!(seen.len() > 15, "{seen:?}");
    for path in &seen {
        assert!(
            VOCABULARY.iter().any(|s| s.path == path.as_slice()),
            "{path:?} is not in the vocabulary table"
        );
    }
}

/// Where `--json` is the switch, standard output is JSON and nothing else:
/// what the run says for its user goes to standard error.
#[test]
fn json_on_standard_output_is_json_alone() {
    let dir = tempfile::tempdir().unwrap();
    let d =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/analyze/stepped-square");
    let out = dir.path().join("result.yaml");
    let run = fivecal()
        .args(["analyze", "--no-record", "--json", "--plan"])
        .arg(d.join("stepped-square.plan.yaml"))
        .arg("--measured")
        .arg(d.join("piece1.dmo"))
        .arg("--out")
        .arg(&out)
        .assert()
        .success()
        .get_output()
        .clone();
    let printed: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
    assert!(printed["location_errors"].is_object(), "{printed}");
    // The old meaning kept one release: the file is JSON too, with a note.
    let file: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(file, printed);
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(
        err.contains("the result file's format follows its name"),
        "{err}"
    );
    assert!(err.contains("wrote "), "{err}");
}

/// `history export --format json`, the spelling of the last release, is
/// `--json` now; it still works, with a note.
#[test]
fn history_export_format_json_still_works_with_a_note() {
    let dir = tempfile::tempdir().unwrap();
    // The demo records its analyses in a store of its own.
    fivecal()
        .args(["demo", "--out"])
        .arg(dir.path())
        .assert()
        .success();
    let db = dir.path().join("history.db");
    let new = fivecal()
        .args(["history", "export", "--json", "--db"])
        .arg(&db)
        .output()
        .unwrap();
    let old = fivecal()
        .args(["history", "export", "--format", "json", "--db"])
        .arg(&db)
        .output()
        .unwrap();
    assert!(new.status.success() && old.status.success());
    let records: serde_json::Value = serde_json::from_slice(&new.stdout).unwrap();
    assert!(!records.as_array().unwrap().is_empty(), "{records}");
    assert_eq!(old.stdout, new.stdout);
    let err = String::from_utf8_lossy(&old.stderr);
    assert!(err.contains("`--format json` is now `--json`"), "{err}");
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
    let read = variables_read(&std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src"));
    assert!(read.contains(&"FIVECAL_DB".to_string()), "{read:?}");
    for name in &read {
        assert!(
            env.contains(&format!("\\fB{name}\\fR")),
            "{name} is read but not in ENVIRONMENT"
        );
    }
}

/// Every environment variable the source reads with `env::var` or
/// `env::var_os`: a literal name, or a `const` of the same file.
fn variables_read(dir: &std::path::Path) -> Vec<String> {
    let mut names = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            names.extend(variables_read(&path));
            continue;
        }
        if path.extension().is_none_or(|e| e != "rs") {
            continue;
        }
        let text = std::fs::read_to_string(&path).unwrap();
        for call in ["env::var(", "env::var_os("] {
            for (i, _) in text.match_indices(call) {
                let arg = text[i + call.len()..].split(')').next().unwrap().trim();
                let name = match arg.strip_prefix('"') {
                    Some(lit) => lit.trim_end_matches('"').to_string(),
                    None => {
                        let decl = format!("const {arg}: &str = \"");
                        let at = text.find(&decl).unwrap_or_else(|| {
                            panic!("{}: env var {arg} not a literal or const", path.display())
                        }) + decl.len();
                        text[at..].split('"').next().unwrap().to_string()
                    }
                };
                if !names.contains(&name) {
                    names.push(name);
                }
            }
        }
    }
    names
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

/// `plan` takes the options of every kind of test on one command line, so
/// an option of another kind is refused by name, never dropped: a stepped
/// square planned with `--bar` would not be what the command says.
#[test]
fn plan_refuses_the_options_of_another_kind_of_test() {
    let dir = tempfile::tempdir().unwrap();
    for (args, flag, owner) in [
        (
            vec!["stepped-square", "--bar", "100"],
            "--bar",
            "`plan ball-bar`",
        ),
        (
            vec!["probe-sphere", "--volume", "0,0,0,1,1,1"],
            "--volume",
            "`plan laser-lines`",
        ),
        (
            vec!["ball-bar", "--bar", "100", "--tool", "machine"],
            "--tool",
            "the template tests",
        ),
        (
            vec!["ball-bar", "--bar", "100", "--divisions", "4"],
            "--divisions",
            "`plan laser-lines`",
        ),
        (
            vec!["laser-lines", "--require", "all"],
            "--require",
            "the template tests",
        ),
        (
            vec!["laser-lines", "--bar-noise", "0.3"],
            "--bar-noise",
            "`plan ball-bar`",
        ),
    ] {
        let out = dir.path().join("never");
        let o = fivecal()
            .arg("plan")
            .args(&args)
            .args(["--machine", "bc-trunnion", "-o"])
            .arg(&out)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{args:?}");
        assert!(
            err.contains(&format!("{flag} does not apply to `plan {}`", args[0]))
                && err.contains(owner),
            "{args:?}: {err}"
        );
        assert!(!out.exists(), "{args:?} wrote {}", out.display());
    }
}
