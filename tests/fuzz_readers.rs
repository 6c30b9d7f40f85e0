//! Property tests of every file reader outside the NC programs: arbitrary
//! bytes, and real files with structured damage (a cut, a line repeated, a
//! hostile token put in, bytes deleted), never panic and either parse or
//! fail with an error that names the file and, where it gives a line, a
//! line the text has.
//!
//! The case count and seed are fixed on CI. A longer run goes beyond it:
//! `FIVECAL_FUZZ_CASES=200000 FIVECAL_FUZZ_SEED=7 cargo test --release
//! --test integration fuzz_readers`.

use std::path::{Path, PathBuf};

use fivecal::Machine;
use fivecal::errorfile::ErrorFile;
use fivecal::formats::manifest::Manifest;
use fivecal::formats::points::PlanPoints;
use fivecal::formats::probe_log::{fanuc, heidenhain, linuxcnc};
use fivecal::formats::{detect, dmis, heights, measured};
use fivecal::post::PostDefinition;
use fivecal::source::SourceError;
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed, TestRunner};

const PATH: &str = "fuzzed.input";

/// A reader under test: its name and a parse that gives the error text and
/// line (0 when the error is about the whole file), or `None` on success.
type Reader = (&'static str, fn(&Path, &str) -> Option<(String, usize)>);

fn located(e: SourceError) -> Option<(String, usize)> {
    Some((e.to_string(), e.line))
}

fn readers() -> Vec<Reader> {
    vec![
        ("detect", |p, s| {
            detect::parse_measurement(p, s).err().and_then(located)
        }),
        ("dmis", |p, s| dmis::parse(p, s).err().and_then(located)),
        ("csv", |p, s| {
            measured::parse_csv(p, s).err().and_then(located)
        }),
        ("points", |p, s| {
            PlanPoints::parse(p, s).err().and_then(located)
        }),
        ("heights", |p, s| {
            heights::parse(p, s).err().and_then(located)
        }),
        ("fanuc log", |p, s| {
            fanuc::parse(p, s).err().and_then(located)
        }),
        ("heidenhain log", |p, s| {
            heidenhain::parse(p, s).err().and_then(located)
        }),
        ("linuxcnc log", |p, s| {
            linuxcnc::parse_log(p, s).err().and_then(located)
        }),
        ("linuxcnc probe file", |p, s| {
            linuxcnc::parse_probe_file(p, s, 'B')
                .err()
                .and_then(located)
        }),
        ("machine", |p, s| {
            Machine::from_yaml(p, s).err().map(|e| match e {
                fivecal::machine::MachineError::Invalid(e) => (e.to_string(), e.line),
                other => (other.to_string(), 0),
            })
        }),
        ("error file", |p, s| {
            ErrorFile::parse(p, s).err().and_then(located)
        }),
        ("postprocessor", |p, s| {
            PostDefinition::parse(p, s).err().and_then(located)
        }),
        ("manifest", |p, s| {
            Manifest::parse(p, s).err().and_then(located)
        }),
        ("yaml checks", |p, s| {
            fivecal::input::check_yaml(p, s).err().and_then(located)
        }),
    ]
}

/// Real files of every kind the readers take.
fn seeds() -> Vec<String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let files = [
        "tests/fixtures/cmm/quirks.dmo",
        "tests/fixtures/cmm/missing-label.csv",
        "tests/fixtures/probe/fanuc-dprnt.log",
        "tests/fixtures/probe/heidenhain-fn16-comma.txt",
        "tests/fixtures/probe/linuxcnc-log.txt",
        "tests/fixtures/probe/linuxcnc-probeopen.txt",
        "tests/fixtures/probe/seed004-table1.csv",
        "tests/fixtures/probe/small.points.csv",
        "examples/analyze/stepped-square/piece1.dmo",
        "examples/analyze/stepped-square/stepped-square.points.csv",
        "examples/analyze/stepped-square/stepped-square.plan.yaml",
        "examples/analyze/stepped-square/truth.yaml",
        "examples/analyze/probe-sphere/PROBE.TXT",
        "examples/machines/bc-trunnion.yaml",
        "postprocessors/heidenhain.yaml",
    ];
    files
        .iter()
        .map(|f| {
            let t = std::fs::read_to_string(root.join(f)).unwrap();
            // Keep each seed short so that a case stays fast.
            t.lines().take(80).collect::<Vec<_>>().join("\n") + "\n"
        })
        .collect()
}

/// Tokens that have broken readers, or could.
const HOSTILE: &[&str] = &[
    "NaN",
    "inf",
    "-inf",
    "1e308",
    "1e-320",
    "1e999",
    "-0",
    "",
    ",",
    ",,",
    ";",
    ":",
    "::",
    "[",
    "]",
    "{",
    "}",
    "[[[[",
    "{{{{",
    "\"",
    "'",
    "(",
    ")",
    "#",
    "\t",
    "\r",
    "\r\n",
    "\u{feff}",
    "\u{0}",
    "é",
    "99999999999999999999999",
    "- ",
    "? ",
    "&a",
    "*a",
    "!!binary",
    "|",
    ">",
    "$",
    "$$",
    "/",
    "=",
    "T(",
    "F(",
    "\n\n\n",
];

fn config(cases: u32, salt: u64) -> Config {
    let var = |k: &str| std::env::var(k).ok().and_then(|v| v.parse::<u64>().ok());
    Config {
        cases: var("FIVECAL_FUZZ_CASES").map_or(cases, |c| c as u32),
        rng_seed: RngSeed::Fixed(var("FIVECAL_FUZZ_SEED").unwrap_or(15) ^ salt),
        failure_persistence: None,
        ..Config::default()
    }
}

/// The property: every reader returns (no panic), and an error names the
/// file and a line within the text.
fn check_all(src: &str) -> Result<(), TestCaseError> {
    let path = PathBuf::from(PATH);
    let lines = src.split('\n').count() + 1;
    for (name, read) in readers() {
        if let Some((msg, line)) = read(&path, src) {
            prop_assert!(msg.contains(PATH), "{name}: error without the file: {msg}");
            prop_assert!(line <= lines, "{name}: line {line} of {lines}: {msg}");
        }
    }
    Ok(())
}

#[test]
fn arbitrary_bytes_never_panic_and_fail_located() {
    let mut runner = TestRunner::new(config(64, 1));
    runner
        .run(&proptest::collection::vec(any::<u8>(), 0..400), |bytes| {
            // As every reader gets its text: decoded, BOM dropped, CR lines.
            match fivecal::input::text_of(Path::new(PATH), "file", bytes) {
                Ok(text) => check_all(&text),
                Err(e) => {
                    prop_assert!(e.to_string().contains(PATH));
                    Ok(())
                }
            }
        })
        .unwrap();
}

#[derive(Clone, Debug)]
enum Damage {
    Cut(usize),
    RepeatLine(usize),
    Insert(usize, usize),
    Delete(usize, usize),
}

fn damage() -> impl Strategy<Value = Damage> {
    prop_oneof![
        any::<usize>().prop_map(Damage::Cut),
        any::<usize>().prop_map(Damage::RepeatLine),
        (any::<usize>(), 0..HOSTILE.len()).prop_map(|(a, t)| Damage::Insert(a, t)),
        (any::<usize>(), 1usize..40).prop_map(|(a, n)| Damage::Delete(a, n)),
    ]
}

fn at_char(s: &str, i: usize) -> usize {
    let mut i = i % (s.len() + 1);
    while !s.is_char_boundary(i) {
        i -= 1;
    }
    i
}

fn apply(src: &str, d: &Damage) -> String {
    match *d {
        Damage::Cut(i) => src[..at_char(src, i)].to_string(),
        Damage::RepeatLine(i) => {
            let lines: Vec<&str> = src.split('\n').collect();
            let k = i % lines.len();
            let mut out = lines.clone();
            out.insert(k, lines[k]);
            out.join("\n")
        }
        Damage::Insert(i, t) => {
            let i = at_char(src, i);
            format!("{}{}{}", &src[..i], HOSTILE[t], &src[i..])
        }
        Damage::Delete(i, n) => {
            let a = at_char(src, i);
            let b = at_char(src, a + n).max(a);
            format!("{}{}", &src[..a], &src[b..])
        }
    }
}

#[test]
fn damaged_real_files_never_panic_and_fail_located() {
    let seeds = seeds();
    let mut runner = TestRunner::new(config(96, 2));
    runner
        .run(
            &(0..seeds.len(), proptest::collection::vec(damage(), 1..6)),
            |(k, damages)| {
                let mut text = seeds[k].clone();
                for d in &damages {
                    text = apply(&text, d);
                }
                check_all(&text)
            },
        )
        .unwrap();
}

#[test]
fn the_real_files_themselves_read() {
    // The damage above starts from files each reader accepts as they are:
    // at least one reader takes every seed.
    let path = PathBuf::from(PATH);
    for (k, s) in seeds().iter().enumerate() {
        assert!(
            readers().iter().any(|(_, read)| read(&path, s).is_none()),
            "seed {k} is read by no reader"
        );
    }
}
