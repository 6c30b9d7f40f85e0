//! Every `fivecal ...` command line README.md, docs/*.md and the man
//! page's EXAMPLES show, run as a reader would paste it, so that the text
//! cannot drift from the tool. A command line is one in a code block
//! (fenced, or indented by four spaces) that starts with `fivecal` (after
//! an optional `$ ` prompt) or `cargo run --release --`, which stands for
//! the built binary. Two kinds:
//!
//! - a synopsis, with placeholders (`[--seed N]`, `FILE...`,
//!   `DIR/<test>.plan.yaml`, `PATH|URL`, `R1.yaml`): each placeholder is
//!   given a value and the line must be accepted by the argument parser
//!   (it may then fail on the files it names: they are the reader's);
//! - a concrete line: it must exit 0. The lines of one source run in one
//!   directory, in order; a line that fails is tried again after the
//!   others, as a line may read what a later one writes. The reader's own
//!   files the text assumes (their machine file, their CMM output, their
//!   NC program) are made as the text describes them ([`provide`]).
//!
//! A line the text itself says is refused is listed in [`REFUSED`] with the
//! reason, and must be refused by the program, not by the parser. A
//! failure names the file and line of the command.

use std::path::{Path, PathBuf};

use crate::cli::fivecal;

/// One command line of the documentation.
#[derive(Debug)]
struct Shown {
    /// `README.md:69` or `fivecal man EXAMPLES:3`.
    at: String,
    /// The command as written (continuations joined, comment dropped),
    /// `fivecal` first.
    line: String,
}

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The command lines of one Markdown text.
fn command_lines(name: &str, text: &str) -> Vec<Shown> {
    let lines: Vec<&str> = text.lines().collect();
    let mut out = Vec::new();
    let mut fenced = false;
    let mut i = 0;
    while i < lines.len() {
        let raw = lines[i];
        let trimmed = raw.trim_start();
        if trimmed.starts_with("```") {
            fenced = !fenced;
            i += 1;
            continue;
        }
        let indented = raw.len() - trimmed.len() >= 4;
        let start = i;
        i += 1;
        if !(fenced || indented) {
            continue;
        }
        let body = trimmed.strip_prefix("$ ").unwrap_or(trimmed);
        let body = match body.strip_prefix("cargo run --release -- ") {
            Some(rest) => format!("fivecal {rest}"),
            None => body.to_string(),
        };
        let mut words = body.split_whitespace();
        // `fivecal plan: stepped-square on ...` is output, not a command.
        if words.next() != Some("fivecal") || words.next().is_none_or(|w| w.ends_with(':')) {
            continue;
        }
        let mut line = body;
        while line.trim_end().ends_with('\\') && i < lines.len() {
            line = format!(
                "{} {}",
                line.trim_end().trim_end_matches('\\').trim_end(),
                lines[i].trim()
            );
            i += 1;
        }
        out.push(Shown {
            at: format!("{name}:{}", start + 1),
            line: without_comment(&line).trim().to_string(),
        });
    }
    out
}

/// `line` without a `#` comment outside quotes.
fn without_comment(line: &str) -> String {
    let mut quote = None;
    let mut prev = ' ';
    for (i, c) in line.char_indices() {
        match (quote, c) {
            (None, '\'' | '"') => quote = Some(c),
            (Some(q), c) if c == q => quote = None,
            (None, '#') if prev.is_whitespace() => return line[..i].to_string(),
            _ => {}
        }
        prev = c;
    }
    line.to_string()
}

/// The words of `line` as a POSIX shell splits them (quotes removed), and
/// the file its standard output is redirected to.
fn shell_words(line: &str) -> (Vec<String>, Option<String>) {
    let mut words = Vec::new();
    let mut word = String::new();
    let mut in_word = false;
    let mut quote = None;
    for c in line.chars() {
        match (quote, c) {
            (None, '\'' | '"') => {
                quote = Some(c);
                in_word = true;
            }
            (Some(q), c) if c == q => quote = None,
            (None, c) if c.is_whitespace() => {
                if in_word {
                    words.push(std::mem::take(&mut word));
                    in_word = false;
                }
            }
            (_, c) => {
                word.push(c);
                in_word = true;
            }
        }
    }
    if in_word {
        words.push(word);
    }
    let redirect = words.iter().position(|w| w == ">").map(|i| {
        let file = words.get(i + 1).cloned().expect("a file after >");
        words.truncate(i);
        file
    });
    (words, redirect)
}

/// Whether `line` is a synopsis: it shows placeholders rather than values.
fn is_synopsis(line: &str) -> bool {
    let (words, _) = shell_words(line);
    line.contains('[')
        || line.contains("...")
        || words.iter().any(|w| {
            w.contains('<') || w.contains('|') || is_placeholder(w.split('.').next().unwrap_or(w))
        })
}

/// `FILE`, `ID`, `R1`, `TRUTH`: a word in capitals standing for a value.
fn is_placeholder(w: &str) -> bool {
    w.len() >= 2
        && w.starts_with(|c: char| c.is_ascii_uppercase())
        && w.chars()
            .all(|c| c.is_ascii_uppercase() || c.is_ascii_digit() || c == '_')
}

/// A synopsis with each placeholder given a value: optional parts taken,
/// the first of alternatives, `<test>` a test, numbers for `N`, `UM`, `ID`.
fn filled_in(line: &str) -> Vec<String> {
    let plain = line.replace(['[', ']'], " ").replace("...", "");
    let (words, _) = shell_words(&plain);
    words
        .into_iter()
        .map(|w| {
            let w = w.split('|').next().unwrap_or("").to_string();
            let w = w.replace("<test>", "stepped-square");
            match w.as_str() {
                "N" | "UM" | "ID" | "DEG" | "MM" => "1".to_string(),
                _ => w,
            }
        })
        .filter(|w| !w.is_empty())
        .collect()
}

/// Lines the text says are refused: where, the command, and why.
const REFUSED: &[(&str, &str, &str)] = &[(
    "docs/history.md",
    "fivecal verify --machine bc-trunnion --db fivecal-demo/history.db",
    "the demo's last analysis is a misfit (the machine still drifts), and the text says verify refuses it, naming the record",
)];

/// The reader's own files a line assumes, made as the text describes
/// them, in `dir`, when a line names one that is not there yet.
fn provide(word: &str, dir: &Path) {
    let path = dir.join(word);
    if path.exists() {
        return;
    }
    let run = |args: &[&str]| {
        let o = fivecal().current_dir(dir).args(args).output().unwrap();
        assert!(
            o.status.success(),
            "making {word}: {args:?}\n{}",
            String::from_utf8_lossy(&o.stderr)
        );
    };
    match word {
        // "a machine file as in examples/machines/bc-trunnion.yaml"
        "my-machine.yaml" => run(&[
            "machine",
            "new",
            "my-machine",
            "--from",
            "bc-trunnion",
            "-o",
            word,
        ]),
        // The CMM's DMIS output of the planned piece, machined on a
        // machine with the demo's location errors.
        "piece.dmo" if dir.join("ss/stepped-square.plan.yaml").exists() => {
            let truth = std::fs::read_to_string(root().join("examples/demo/truth.yaml")).unwrap();
            let location = &truth[..truth.find("\neffects:").unwrap()];
            let machine = std::fs::read_to_string(dir.join("ss/stepped-square.plan.yaml"))
                .unwrap()
                .lines()
                .find_map(|l| l.strip_prefix("machine: ").map(str::to_string))
                .unwrap();
            std::fs::write(
                dir.join("my-truth.yaml"),
                location.replace("machine: bc-trunnion", &format!("machine: {machine}")),
            )
            .unwrap();
            run(&[
                "simulate",
                "--plan",
                "ss/stepped-square.plan.yaml",
                "--errors",
                "my-truth.yaml",
                "-o",
                word,
            ]);
        }
        // A production program for the B/C trunnion: the demo's.
        "part.nc" if dir.join("fivecal-demo/frustum.nc").exists() => {
            std::fs::copy(dir.join("fivecal-demo/frustum.nc"), &path).unwrap();
        }
        // "c: [0]": the columns template probed at one C angle.
        "my-columns.yaml" => {
            let t = std::fs::read_to_string(root().join("templates/probe-columns.yaml")).unwrap();
            let at = t.find("\n  c: [").expect("the template's C angles");
            let end = at + 1 + t[at + 1..].find('\n').unwrap();
            std::fs::write(&path, format!("{}\n  c: [0]{}", &t[..at], &t[end..])).unwrap();
        }
        // "copy first/probe-columns.machine.yaml ... and set probe.length:
        // 168 in it"
        "head-table-probe168.machine.yaml" if dir.join("first").exists() => {
            let m = std::fs::read_to_string(dir.join("first/probe-columns.machine.yaml")).unwrap();
            let probe = m.find("\nprobe:").expect("a probe");
            let at = probe + m[probe..].find("\n  length:").expect("its length");
            let end = at + 1 + m[at + 1..].find('\n').unwrap();
            std::fs::write(&path, format!("{}\n  length: 168.0{}", &m[..at], &m[end..])).unwrap();
        }
        // docs/ball-bar.md: "a machine of the paper's kind", the
        // built-in head-table with a DMU 100 monoBLOCK's table and strokes.
        "my-dmu.yaml" => {
            std::fs::write(&path, crate::ball_bar::paper_machine_yaml("my-dmu")).unwrap();
        }
        // docs/laser-lines.md: the paper's machine with machine
        // coordinates that hold its measuring volume.
        "my-dmu-laser.yaml" => {
            std::fs::write(&path, crate::laser_lines::seed_machine_yaml("my-dmu-laser")).unwrap();
        }
        // "a truth file": the commented example of the plan's machine.
        "truth.yaml"
            if dir.join("bb/ball-bar.plan.yaml").exists()
                || dir.join("laser/laser-lines.plan.yaml").exists() =>
        {
            let o = fivecal()
                .args(["simulate", "--truth-example", "--machine", "head-table"])
                .output()
                .unwrap();
            assert!(o.status.success());
            std::fs::write(&path, o.stdout).unwrap();
        }
        _ => {}
    }
}

/// The outcome of one run: `Ok` or what went wrong.
fn run_line(shown: &Shown, dir: &Path, refused: Option<&str>) -> Result<(), String> {
    let synopsis = is_synopsis(&shown.line);
    let (words, redirect) = if synopsis {
        (filled_in(&shown.line), None)
    } else {
        shell_words(&shown.line)
    };
    if !synopsis {
        for w in &words {
            provide(w, dir);
        }
    }
    let o = fivecal()
        .current_dir(dir)
        .args(&words[1..])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    // clap's own refusals, and only they, end with the usage.
    if err.contains("\nUsage: ") {
        return Err(format!("not accepted by the argument parser:\n{err}"));
    }
    if synopsis {
        return Ok(());
    }
    if let Some(file) = redirect {
        std::fs::write(dir.join(file), &o.stdout).unwrap();
    }
    match (o.status.success(), refused) {
        (true, None) => Ok(()),
        (false, None) => Err(format!("exit {:?}:\n{err}", o.status.code())),
        (true, Some(why)) => Err(format!("ran, though the text says it is refused ({why})")),
        (false, Some(_)) => Ok(()),
    }
}

/// Runs `lines` in `dir` in order, a failed one once more after the
/// others; the failures, each naming where the line is shown.
fn run_all(source: &str, lines: &[Shown], dir: &Path) -> Vec<String> {
    let refused = |s: &Shown| {
        REFUSED
            .iter()
            .find(|(file, line, _)| *file == source && *line == s.line)
            .map(|(_, _, why)| *why)
    };
    let mut later = Vec::new();
    for s in lines {
        if run_line(s, dir, refused(s)).is_err() {
            later.push(s);
        }
    }
    later
        .into_iter()
        .filter_map(|s| {
            run_line(s, dir, refused(s))
                .err()
                .map(|e| format!("{}: `{}`: {e}", s.at, s.line))
        })
        .collect()
}

/// The man page's EXAMPLES, as `fivecal man` prints them.
fn man_examples() -> Vec<Shown> {
    let out = fivecal().arg("man").output().unwrap();
    let text = String::from_utf8(out.stdout).unwrap();
    let examples = &text[text.find(".SH EXAMPLES").expect("an EXAMPLES section")..];
    let examples = &examples[..examples[4..].find(".SH ").map_or(examples.len(), |i| i + 4)];
    examples
        .split(".RS 4\n")
        .skip(1)
        .enumerate()
        .map(|(i, block)| Shown {
            at: format!("fivecal man, EXAMPLES, example {}", i + 1),
            line: block
                .lines()
                .next()
                .unwrap()
                .replace("\\-", "-")
                .replace("\\e", "\\"),
        })
        .collect()
}

/// README.md and every docs/*.md, README first: docs/history.md reads
/// the files the README's demo leaves.
fn markdown_sources() -> Vec<(String, String)> {
    let mut docs: Vec<PathBuf> = std::fs::read_dir(root().join("docs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    docs.sort();
    std::iter::once(root().join("README.md"))
        .chain(docs)
        .map(|p| {
            let name = p.strip_prefix(root()).unwrap().display().to_string();
            (name, std::fs::read_to_string(&p).unwrap())
        })
        .collect()
}

/// Every command line of README.md and docs/: synopses accepted by the
/// parser, the rest run, in order, in one directory holding the
/// repository's examples.
#[test]
fn every_command_line_the_documentation_shows_runs() {
    let dir = tempfile::tempdir().unwrap();
    std::os::unix::fs::symlink(root().join("examples"), dir.path().join("examples")).unwrap();
    let mut failures = Vec::new();
    let mut count = 0;
    for (name, text) in markdown_sources() {
        let lines = command_lines(&name, &text);
        count += lines.len();
        failures.extend(run_all(&name, &lines, dir.path()));
    }
    assert!(count >= 20, "only {count} command lines found");
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

/// The man page's EXAMPLES are a calibration a user can paste, line by
/// line, into an empty directory: each line runs, in order, and leaves the
/// files the next one reads.
#[test]
fn man_page_examples_run_in_an_empty_directory() {
    let lines = man_examples();
    assert!(lines.len() >= 5, "{lines:?}");
    let dir = tempfile::tempdir().unwrap();
    let failures = run_all("fivecal man", &lines, dir.path());
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
    assert!(dir.path().join("frustum-compensated.nc").exists());
}

/// The reading of the text itself, on lines of this project's docs.
mod reading {
    use super::*;

    #[test]
    fn a_continued_line_with_a_comment_is_one_command() {
        let text = "Intro\n\n    $ fivecal plan x --out ss \\\n        --dialect fanuc   # a note\n    fivecal plan: output\n\n```\ncargo run --release -- demo\n```\n";
        let lines = command_lines("T.md", text);
        assert_eq!(lines.len(), 2, "{lines:?}");
        assert_eq!(lines[0].at, "T.md:3");
        assert_eq!(lines[0].line, "fivecal plan x --out ss --dialect fanuc");
        assert_eq!(lines[1].line, "fivecal demo");
    }

    #[test]
    fn a_line_the_parser_refuses_or_that_fails_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let shown = |line: &str| Shown {
            at: "T.md:1".into(),
            line: line.into(),
        };
        let e = run_line(&shown("fivecal plan --no-such-option"), dir.path(), None).unwrap_err();
        assert!(e.contains("not accepted by the argument parser"), "{e}");
        // A synopsis with an option that does not exist is refused too.
        let e = run_line(&shown("fivecal history [--no-such FILE]"), dir.path(), None).unwrap_err();
        assert!(e.contains("not accepted"), "{e}");
        let e = run_line(
            &shown("fivecal machine show no-such.yaml"),
            dir.path(),
            None,
        )
        .unwrap_err();
        assert!(e.starts_with("exit Some(2)"), "{e}");
        let lines = [shown("fivecal machine show no-such.yaml")];
        let failures = run_all("T.md", &lines, dir.path());
        assert!(
            failures[0].starts_with("T.md:1: `fivecal machine show no-such.yaml`"),
            "{failures:?}"
        );
        // A line the text says is refused must be refused.
        let e = run_line(&shown("fivecal machine list"), dir.path(), Some("why")).unwrap_err();
        assert!(e.contains("though the text says it is refused"), "{e}");
    }

    #[test]
    fn synopses_are_told_from_commands_and_filled_in() {
        assert!(is_synopsis(
            "fivecal history [--db PATH|URL] [--machine NAME]"
        ));
        assert!(is_synopsis("fivecal history show ID"));
        assert!(is_synopsis(
            "fivecal verify --before R1.yaml --after R2.yaml"
        ));
        assert!(!is_synopsis(
            "fivecal analyze --plan p.yaml --maps 'EBB(B)' --out result.yaml"
        ));
        assert_eq!(
            filled_in("fivecal analyze --plan DIR/<test>.plan.yaml --measured FILE... [--mc N]"),
            [
                "fivecal",
                "analyze",
                "--plan",
                "DIR/stepped-square.plan.yaml",
                "--measured",
                "FILE",
                "--mc",
                "1"
            ]
        );
        assert_eq!(
            shell_words("fivecal simulate --truth-example > truth.yaml"),
            (
                vec![
                    "fivecal".to_string(),
                    "simulate".into(),
                    "--truth-example".into()
                ],
                Some("truth.yaml".to_string())
            )
        );
    }
}
