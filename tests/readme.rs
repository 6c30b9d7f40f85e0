//! The README's two commands, run from the README's own text, so the
//! README cannot drift from what the tool does.

use std::path::Path;
use std::process::Command;

use assert_cmd::cargo::CommandCargoExt;
use fivecal::errorfile::ErrorFile;
use fivecal::{Kinematics, Machine};

/// The command on the first indented line after `<!-- marker -->`, read
/// the way `.ci/run` reads the test command.
fn command_after(marker: &str) -> Vec<String> {
    let readme = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("README.md"))
        .expect("README.md");
    let mut lines = readme
        .lines()
        .skip_while(|l| !l.contains(&format!("<!-- {marker} -->")));
    lines
        .next()
        .unwrap_or_else(|| panic!("README.md has no <!-- {marker} --> marker"));
    let line = lines
        .find(|l| !l.trim().is_empty() && !l.trim_start().starts_with("```"))
        .expect("a command after the marker");
    line.split_whitespace().map(str::to_string).collect()
}

/// `cargo run --release -- demo`, run as written (the built binary stands
/// for `cargo run --release`) in an empty directory: it finishes, leaves
/// its files in `fivecal-demo/`, and the errors it identifies are within
/// four standard uncertainties of the built-in truth.
#[test]
fn the_readme_demo_command_runs_the_whole_job() {
    let words = command_after("demo-command");
    assert_eq!(
        &words[..4],
        ["cargo", "run", "--release", "--"],
        "{words:?}"
    );
    let dir = tempfile::tempdir().unwrap();
    let out = Command::cargo_bin("fivecal")
        .unwrap()
        .args(&words[4..])
        .current_dir(dir.path())
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let demo = dir.path().join("fivecal-demo");
    for f in [
        "plan/stepped-square.nc",
        "plan/stepped-square.points.csv",
        "measured.dmo",
        "analyzed.yaml",
        "report/index.html",
        "discover.txt",
        "discovered.yaml",
        "frustum.nc",
        "frustum.compensated.nc",
    ] {
        assert!(demo.join(f).is_file(), "{f} missing; stdout:\n{stdout}");
    }
    let kin = Kinematics::new(&Machine::builtin("bc-trunnion").unwrap());
    let truth = ErrorFile::load(&demo.join("truth.yaml"), &kin).unwrap();
    let (found, _) = ErrorFile::read(&demo.join("discovered.yaml")).unwrap();
    let names = truth.model.param_names();
    for (sym, q) in &found.location_errors {
        let i = names.iter().position(|n| n == sym).unwrap();
        let u = q.u.expect("an uncertainty");
        assert!(
            (q.value - truth.theta[i]).abs() <= 4.0 * u,
            "{sym}: {} +- {u} against the truth {}\n{stdout}",
            q.value,
            truth.theta[i]
        );
    }
    assert_eq!(found.location_errors.len(), 8, "{stdout}");
    assert!(stdout.contains("discovered: drift.EZ0B"), "{stdout}");
}

/// The demo's `analyzed.yaml` is what `analyze` writes: beside the values,
/// the noise the fit found, as the CMM's (the demo measures a machined
/// piece). The demo's model lacks the drift hidden in the truth, so that
/// noise is the gap's RMS (corrected for the fitted parameters), not the
/// simulated CMM's 0.35 um.
#[test]
fn the_demo_result_file_carries_the_measured_noise() {
    let dir = tempfile::tempdir().unwrap();
    let d = fivecal::demo::run(
        &fivecal::demo::DemoConfig {
            out: dir.path().to_path_buf(),
            seed: 1,
        },
        &mut |_| {},
    )
    .unwrap();
    let (analyzed, _) = ErrorFile::read(&dir.path().join("analyzed.yaml")).unwrap();
    let noise = analyzed.effects.noise.expect("a noise entry");
    assert_eq!(noise.probe, None);
    let cmm = noise.cmm.expect("the CMM's noise");
    let gap = d.gap_before.rms_um;
    assert!(
        cmm >= gap && cmm < 1.15 * gap,
        "noise {cmm} um, gap RMS {gap} um"
    );
}

/// The test command is what `.ci/run` runs; here it must at least be a
/// cargo test command that builds as written.
#[test]
fn the_readme_test_command_builds_the_tests() {
    let words = command_after("test-command");
    assert_eq!(&words[..2], ["cargo", "test"], "{words:?}");
    let status = Command::new(env!("CARGO"))
        .args(&words[1..])
        .arg("--no-run")
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .status()
        .unwrap();
    assert!(status.success());
}

/// Users see the repository only: no README line, doc comment, template,
/// postprocessor, example or `--help` text may send them to the team's
/// working documents ("SPEC section 3", "seed 002", `../shared/`), which
/// are not part of it. The citations point into `docs/` instead.
#[test]
fn no_text_cites_documents_outside_the_repository() {
    let root = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let pattern = |line: &str| {
        line.contains("SPEC section")
            || line.contains("SPEC §")
            || line.contains("../shared")
            || line.contains("shared/seeds")
            || line.contains("shared/notes")
            || (0..10).any(|d| {
                line.contains(&format!("seed 00{d}")) || line.contains(&format!("Seed 00{d}"))
            })
    };
    let hits = lines_matching(
        &root,
        &[
            "README.md",
            "src",
            "docs",
            "templates",
            "postprocessors",
            "examples",
            "benches",
        ],
        pattern,
    );
    assert!(hits.is_empty(), "{}", hits.join("\n"));
    // The help text as users see it.
    let help = Command::cargo_bin("fivecal")
        .unwrap()
        .arg("--help")
        .output()
        .unwrap();
    let help = String::from_utf8_lossy(&help.stdout);
    assert!(help.lines().all(|l| !pattern(l)), "{help}");
}

/// A citation reads as a citation ("Ibaraki & Ota 2014"), never with a file
/// path pasted after it as literal text: "(docs/references.md)" leaked into
/// the README, `--help`, `machine list` and from the machine descriptions
/// into every NC program header. Links in markdown stay allowed.
#[test]
fn no_user_facing_text_pastes_a_docs_path_after_a_citation() {
    let root = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let leak =
        |text: &str| text.contains(" (docs/references.md") || text.contains("(docs/references.md,");
    let hits = lines_matching(
        &root,
        &[
            "README.md",
            "src",
            "templates",
            "postprocessors",
            "examples",
        ],
        leak,
    );
    assert!(hits.is_empty(), "{}", hits.join("\n"));
    for args in [&["plan", "--help"][..], &["machine", "list"], &["--help"]] {
        let out = Command::cargo_bin("fivecal")
            .unwrap()
            .args(args)
            .output()
            .unwrap();
        let out = String::from_utf8_lossy(&out.stdout);
        assert!(
            !leak(&out) && !out.contains("docs/references.md"),
            "{args:?}: {out}"
        );
    }
}

/// Every line of the text files under `dirs` (relative to `root`) that
/// `pattern` matches, as `path:line: text`.
fn lines_matching(
    root: &std::path::Path,
    dirs: &[&str],
    pattern: impl Fn(&str) -> bool,
) -> Vec<String> {
    let mut hits = Vec::new();
    let mut stack: Vec<std::path::PathBuf> = dirs.iter().map(|p| root.join(p)).collect();
    while let Some(p) = stack.pop() {
        if p.is_dir() {
            for e in std::fs::read_dir(&p).unwrap() {
                stack.push(e.unwrap().path());
            }
        } else if let Ok(text) = std::fs::read_to_string(&p) {
            for (i, line) in text.lines().enumerate().filter(|(_, l)| pattern(l)) {
                hits.push(format!("{}:{}: {}", p.display(), i + 1, line.trim()));
            }
        }
    }
    hits
}

/// The README's install command is `cargo install --path .` run from the
/// repository root, and that root's package has the `fivecal` binary it
/// promises to put on the PATH.
#[test]
fn the_readme_install_command_installs_the_fivecal_binary() {
    let words = command_after("install-command");
    assert_eq!(words, ["cargo", "install", "--path", "."]);
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let manifest = std::fs::read_to_string(root.join("Cargo.toml")).unwrap();
    assert!(manifest.contains("name = \"fivecal\""));
    assert!(root.join("src/bin/fivecal/main.rs").exists());
}
