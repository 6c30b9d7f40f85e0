//! Property tests of every file reader: arbitrary bytes, and real files
//! with structured damage (a cut, a line repeated, a hostile token put in,
//! bytes deleted), never panic and either parse or fail with an error that
//! names the file and, where it gives a line, a line the text has. For the
//! NC programs of the three dialects, generated programs and damaged real
//! ones also print back as they were read: each block's tokens tile its
//! bytes and write them back, and `compensate` at zero error writes the
//! program out byte for byte.
//!
//! The case count and seed are fixed on CI. A longer run goes beyond it,
//! on every reader or on those whose name holds `FIVECAL_FUZZ_READER`
//! (`dmis`, `machine`, `fanuc program`, `program` for the three NC
//! dialects): `FIVECAL_FUZZ_CASES=200000 FIVECAL_FUZZ_SEED=7
//! FIVECAL_FUZZ_READER=dmis cargo test --release --test integration
//! fuzz_readers` (docs/input-and-output.md).

use std::path::{Path, PathBuf};

use fivecal::compensate::{Compensator, Settings};
use fivecal::errorfile::ErrorFile;
use fivecal::formats::manifest::Manifest;
use fivecal::formats::points::PlanPoints;
use fivecal::formats::probe_log::{fanuc, heidenhain, linuxcnc};
use fivecal::formats::{detect, dmis, heights, measured};
use fivecal::nc::{Blocks, Syntax};
use fivecal::post::PostDefinition;
use fivecal::source::SourceError;
use fivecal::{Dialect, Machine};
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
        ("laser run", |p, s| {
            fivecal::formats::laser::LaserRun::parse(p, s)
                .err()
                .and_then(located)
        }),
        ("laser plan", |p, s| {
            fivecal::formats::laser::LaserManifest::parse(p, s)
                .err()
                .and_then(located)
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
        "tests/fixtures/laser/worked-example.rtl",
        "tests/fixtures/laser/L4.txt",
        "tests/fixtures/laser/small.plan.yaml",
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
    // NC programs.
    "~",
    "%",
    "\u{1a}",
    "##",
    "#[",
    "X[",
    "G1 X",
    " GOTO",
    "DO1",
    "END1",
    "o100 endif",
    " FMAX",
    "Q",
    "1.2.3",
    "\r\r",
    "9999999999999999999999999999999999999999999999999999999999.5",
];

/// Whether the reader named `name` is fuzzed in this run: every one, or
/// those whose name holds `FIVECAL_FUZZ_READER`.
fn selected(name: &str) -> bool {
    std::env::var("FIVECAL_FUZZ_READER").map_or(true, |r| name.contains(r.as_str()))
}

/// The name an NC dialect's reader goes by in [`selected`].
fn nc_reader(d: Dialect) -> String {
    format!("{d} program")
}

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
    // A bare CR ends a line too (old Mac files; YAML says so as well).
    let lines = src.replace("\r\n", "\n").split(['\n', '\r']).count() + 1;
    for (name, read) in readers().into_iter().filter(|(n, _)| selected(n)) {
        if let Some((msg, line)) = read(&path, src) {
            prop_assert!(msg.contains(PATH), "{name}: error without the file: {msg}");
            prop_assert!(line <= lines, "{name}: line {line} of {lines}: {msg}");
        }
    }
    Ok(())
}

#[test]
fn arbitrary_bytes_never_panic_and_fail_located() {
    let mut runner = TestRunner::new(config(1000, 1));
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
    /// Any byte (the NC readers take bytes, not text).
    Byte(usize, u8),
}

fn damage() -> impl Strategy<Value = Damage> {
    prop_oneof![
        any::<usize>().prop_map(Damage::Cut),
        any::<usize>().prop_map(Damage::RepeatLine),
        (any::<usize>(), 0..HOSTILE.len()).prop_map(|(a, t)| Damage::Insert(a, t)),
        (any::<usize>(), 1usize..40).prop_map(|(a, n)| Damage::Delete(a, n)),
    ]
}

/// [`damage`], and any byte put in anywhere.
fn byte_damage() -> impl Strategy<Value = Damage> {
    prop_oneof![
        4 => damage(),
        1 => (any::<usize>(), any::<u8>()).prop_map(|(a, b)| Damage::Byte(a, b)),
    ]
}

/// `i` (any number) as an offset into `s` where `ok` holds (0 always does).
fn at(s: &[u8], i: usize, ok: &dyn Fn(usize) -> bool) -> usize {
    let mut i = i % (s.len() + 1);
    while !ok(i) {
        i -= 1;
    }
    i
}

/// `src` with `d` done to it, cutting only where `ok` says.
fn damaged(src: &[u8], d: &Damage, ok: &dyn Fn(usize) -> bool) -> Vec<u8> {
    let join = |a: &[u8], mid: &[u8], b: &[u8]| [a, mid, b].concat();
    match *d {
        Damage::Cut(i) => src[..at(src, i, ok)].to_vec(),
        Damage::RepeatLine(i) => {
            let lines: Vec<&[u8]> = src.split(|&c| c == b'\n').collect();
            let k = i % lines.len();
            let mut out = lines.clone();
            out.insert(k, lines[k]);
            out.join(&b'\n')
        }
        Damage::Insert(i, t) => {
            let i = at(src, i, ok);
            join(&src[..i], HOSTILE[t].as_bytes(), &src[i..])
        }
        Damage::Delete(i, n) => {
            let a = at(src, i, ok);
            let b = at(src, a + n, ok).max(a);
            join(&src[..a], &[], &src[b..])
        }
        Damage::Byte(i, b) => {
            let i = at(src, i, ok);
            join(&src[..i], &[b], &src[i..])
        }
    }
}

/// Text damaged at character boundaries (still text).
fn apply(src: &str, d: &Damage) -> String {
    let cut = damaged(src.as_bytes(), d, &|i| src.is_char_boundary(i));
    String::from_utf8_lossy(&cut).into_owned()
}

#[test]
fn damaged_real_files_never_panic_and_fail_located() {
    let seeds = seeds();
    let mut runner = TestRunner::new(config(2000, 2));
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

// ------------------------------------------------------------ NC programs

/// A number as NC programs write it: integers, decimals, a trailing or a
/// leading point, padded zeros, a sign.
fn nc_number(signed: bool) -> impl Strategy<Value = String> {
    (-99_999i32..99_999, 0usize..5, 0usize..4, prop::bool::ANY).prop_map(
        move |(v, decimals, style, plus)| {
            let x = v as f64 / 10f64.powi(decimals as i32);
            let mut t = match style {
                0 => format!("{x:.decimals$}"),
                1 => format!("{}.", v),
                2 => format!("{x:.decimals$}").replacen("0.", ".", 1),
                _ => format!("{:08.3}", x),
            };
            if signed && plus && !t.starts_with('-') {
                t.insert(0, '+');
            }
            t
        },
    )
}

/// Spaces between words as people and posts write them.
fn gap() -> impl Strategy<Value = &'static str> {
    prop::sample::select(vec![" ", " ", " ", "", "  ", "\t"])
}

/// A FANUC or LinuxCNC block (without its line ending).
fn word_address_block(linuxcnc: bool) -> impl Strategy<Value = String> {
    let word = prop_oneof![
        (prop::sample::select(vec![
            "G0", "G1", "G2", "G3", "G90", "G91", "G17", "G21", "G43 H1", "G54", "G43.4 H1", "G49",
            "M3", "M5", "M30", "T1 M6"
        ]))
        .prop_map(str::to_string),
        (
            prop::sample::select(vec![
                "X", "Y", "Z", "A", "B", "C", "I", "J", "K", "R", "F", "S", "x", "z"
            ]),
            nc_number(false)
        )
            .prop_map(|(a, n)| format!("{a}{n}")),
        (
            prop::sample::select(vec!["X", "Z", "B"]),
            prop::sample::select(vec![
                "[#1+2]",
                "#5",
                "-[#100*2]",
                "[#1/[#2]]",
                "#<_x>",
                "[SIN[#3]]"
            ])
        )
            .prop_map(|(a, e)| format!("{a}{e}")),
        prop::sample::select(vec!["(COMMENT)", "(MSG, hello)", "(a; b)"]).prop_map(str::to_string),
    ];
    let statement = prop_oneof![
        6 => (prop::collection::vec((word, gap()), 1..6)).prop_map(|ws| {
            ws.into_iter().map(|(w, g)| format!("{w}{g}")).collect::<String>()
        }),
        1 => prop::sample::select(if linuxcnc {
            vec!["#1 = [#2 + 1]", "#<depth> = 5", "o100 if [#1 GT 0]", "o100 endif", "o101 while [#1 LT 3]", "o101 endwhile", "o<s> call [1] [2]", "; a comment", "G1 @10 ^30", "%"]
        } else {
            vec!["#100=#100+1", "#[#2000+#13]=0", "IF [#1 GT 0] GOTO 10", "WHILE [#1 LT 3] DO1", "END1", "GOTO 999", "O1234 (TITLE)", "%", "IF[#32GT180]THEN #32=#32-360", "G65 P9810 X10. Y20."]
        })
        .prop_map(str::to_string),
    ];
    (
        prop::option::of(Just("/")),
        prop::option::of(1u32..99_999),
        statement,
        prop::option::of(if linuxcnc { Just("") } else { Just(" ;") }),
    )
        .prop_map(|(del, n, st, eob)| {
            let mut b = String::new();
            if let Some(d) = del {
                b.push_str(d);
            }
            if let Some(n) = n {
                b.push_str(&format!("N{n} "));
            }
            b.push_str(st.trim_end());
            b.push_str(eob.unwrap_or(""));
            b
        })
}

/// A HEIDENHAIN Klartext block after its number (without its line ending).
fn klartext_block() -> impl Strategy<Value = String> {
    let s = || {
        nc_number(true).prop_map(|n| {
            if n.starts_with(['-', '+']) {
                n
            } else {
                format!("+{n}")
            }
        })
    };
    prop_oneof![
        (
            s(),
            s(),
            s(),
            prop::sample::select(vec!["R0 FMAX", "RL F200", "R0 F MAX M3", "F600"])
        )
            .prop_map(|(x, y, z, t)| format!("L X{x} Y{y} Z{z} {t}")),
        (s(), s()).prop_map(|(x, y)| format!("CC X{x} Y{y}")),
        (s(), s()).prop_map(|(x, y)| format!("C X{x} Y{y} DR+")),
        (s(), s()).prop_map(|(x, y)| format!("CR X{x} Y{y} R+80 DR-")),
        s().prop_map(|x| format!("L IX{x} R0 F MAX")),
        s().prop_map(|x| format!("L X{} R0 FMAX", x.replace('.', ","))),
        s().prop_map(|b| format!("PLANE SPATIAL SPA+0 SPB{b} SPC+0 TURN MB MAX FMAX")),
        s().prop_map(|x| format!("FN 0: Q1 = {x}")),
        s().prop_map(|x| format!("CYCL DEF 7.1 X{x}")),
        prop::sample::select(vec![
            "TOOL CALL 1 Z S4000",
            "L Z+Q13 FMAX",
            "Q2 = Q1 * 2",
            "; a comment",
            "* - a structure block",
            "LBL 1",
            "CALL LBL 1 REP 2",
            "PLANE RESET STAY",
            "FUNCTION TCPM F TCP AXIS POS PATHCTRL AXIS",
            "FUNCTION RESET TCPM",
            "CYCL DEF 7.0 DATUM SHIFT",
            "BLK FORM 0.1 Z X+0 Y+0 Z-40",
            "CYCL DEF 200 DRILLING ~\n  Q200=+2 ;SET-UP CLEARANCE ~\n  Q201=-20 ;DEPTH",
            "M30",
        ])
        .prop_map(str::to_string),
    ]
}

/// A whole program of `dialect`: blocks with LF or CRLF endings, the last
/// one perhaps without.
fn nc_program(dialect: Dialect) -> BoxedStrategy<Vec<u8>> {
    let blocks = match dialect {
        Dialect::Heidenhain => prop::collection::vec(klartext_block(), 1..30)
            .prop_map(|bs| {
                let mut all = vec!["BEGIN PGM FUZZ MM".to_string()];
                all.extend(bs);
                all.push("END PGM FUZZ MM".into());
                all.into_iter()
                    .enumerate()
                    .map(|(i, b)| format!("{i} {b}"))
                    .collect::<Vec<_>>()
            })
            .boxed(),
        d => prop::collection::vec(word_address_block(d == Dialect::Linuxcnc), 1..30).boxed(),
    };
    (blocks, prop::bool::ANY, prop::bool::ANY)
        .prop_map(|(bs, crlf, last_ending)| {
            let end = if crlf { "\r\n" } else { "\n" };
            let mut t = bs.join(end);
            if last_ending {
                t.push_str(end);
            }
            t.into_bytes()
        })
        .boxed()
}

/// The NC programs of the test fixtures, with their dialect (byte strings:
/// some are Latin-1).
fn nc_seeds() -> Vec<(Dialect, Vec<u8>)> {
    let mut out = Vec::new();
    for (path, d, _) in crate::nc::corpus() {
        out.push((d, std::fs::read(path).unwrap()));
    }
    for (f, d) in [
        ("quirks/aptpost_spaced.h", Dialect::Heidenhain),
        ("quirks/latin1_typos.h", Dialect::Heidenhain),
        ("quirks/hal_polar.ngc", Dialect::Linuxcnc),
        ("quirks/macro_packed.nc", Dialect::Fanuc),
        ("quirks/sinumerik_frames.mpf", Dialect::Sinumerik),
    ] {
        out.push((d, std::fs::read(crate::nc::fixture(f)).unwrap()));
    }
    out
}

/// Zero-error compensators of every dialect, on the machines the
/// fixtures are written for.
fn zero_compensators() -> Vec<(Dialect, fivecal::model::Model, Vec<f64>)> {
    [
        (Dialect::Fanuc, "bc-trunnion"),
        (Dialect::Linuxcnc, "bc-trunnion"),
        (Dialect::Heidenhain, "head-table"),
        (Dialect::Sinumerik, "bc-trunnion"),
    ]
    .into_iter()
    .map(|(d, m)| {
        let (model, theta) = crate::nc::zero_model(m, false);
        (d, model, theta)
    })
    .collect()
}

/// The NC properties of one program: read block by block (strictly, then
/// not), every block's tokens tile its bytes and print them back, the
/// blocks together print the program back; a strict read either takes
/// every block or stops at a line and column of the text; and compensate
/// at zero error writes the program back byte for byte, or refuses it as
/// a whole (another dialect's, or without a motion block).
fn nc_round_trip(
    dialect: Dialect,
    compensator: &Compensator,
    bytes: &[u8],
) -> Result<(), TestCaseError> {
    let path = Path::new(PATH);
    // LF, CRLF and a bare CR each end a line.
    let lines = 1
        + (0..bytes.len())
            .filter(|&i| bytes[i] == b'\n' || bytes[i] == b'\r' && bytes.get(i + 1) != Some(&b'\n'))
            .count();
    for strict in [true, false] {
        let mut blocks = Blocks::new(path, bytes, Syntax { dialect, strict });
        let mut again = Vec::new();
        loop {
            let b = match blocks.next_block() {
                Ok(Some(b)) => b,
                Ok(None) => break,
                Err(fivecal::nc::ReadError::Syntax(e)) => {
                    prop_assert!(strict, "{dialect}: refused without --strict: {e}");
                    prop_assert!(e.to_string().starts_with(PATH), "{e}");
                    // A column, or none where the line shows another
                    // dialect's program.
                    prop_assert!(
                        e.line >= 1 && e.line <= lines,
                        "{dialect}: {e} of {lines} lines"
                    );
                    break;
                }
                Err(fivecal::nc::ReadError::Io(e)) => {
                    return Err(TestCaseError::fail(format!("{dialect}: {e}")));
                }
            };
            let mut end = 0;
            for t in &b.tokens {
                prop_assert_eq!(
                    t.span.start as usize,
                    end,
                    "{}: tokens of line {} leave a gap or overlap",
                    dialect,
                    b.line
                );
                prop_assert!(t.span.end >= t.span.start);
                end = t.span.end as usize;
            }
            prop_assert_eq!(
                end,
                b.text.len(),
                "{}: tokens of line {} stop short",
                dialect,
                b.line
            );
            let before = again.len();
            b.reprint(&mut again);
            prop_assert!(
                again[before..] == b.text[..],
                "{dialect}: line {} prints differently",
                b.line
            );
            if b.unreadable.is_some() {
                prop_assert!(!strict);
            }
        }
        if !strict {
            prop_assert!(
                again == bytes,
                "{dialect}: the blocks print a different program"
            );
        }
    }
    let mut out = Vec::new();
    match compensator.run(path, bytes, &mut out) {
        Ok(s) => {
            prop_assert!(
                out == bytes,
                "{dialect}: compensate at zero error changed the program:\n{}\n---\n{}",
                String::from_utf8_lossy(bytes),
                String::from_utf8_lossy(&out)
            );
            prop_assert_eq!(s.changed, 0);
            prop_assert_eq!(s.inserted, 0);
        }
        // Outside --strict a block that cannot be read is kept; what is
        // refused is the program as a whole (one of another dialect, one
        // without a motion block), named with a line it has, if any.
        Err(fivecal::compensate::CompensateError::Syntax(e)) => {
            prop_assert!(e.to_string().starts_with(PATH), "{e}");
            prop_assert!(e.line <= lines, "{dialect}: {e} of {lines} lines");
        }
        // A block the control cannot run (a SINUMERIK CIP whose points a
        // damage put on one line) stops the run at its line and column.
        Err(fivecal::compensate::CompensateError::Unmodelled(e))
            if e.message.ends_with("the control cannot run this block") =>
        {
            prop_assert!(e.to_string().starts_with(PATH), "{e}");
            prop_assert!(
                e.line >= 1 && e.line <= lines && e.column >= 1,
                "{dialect}: {e} of {lines} lines"
            );
        }
        Err(e) => {
            return Err(TestCaseError::fail(format!(
                "{dialect}: compensate at zero error refused: {e}\n{}",
                String::from_utf8_lossy(bytes)
            )));
        }
    }
    Ok(())
}

#[test]
fn generated_nc_programs_print_back_as_read_and_compensate_to_themselves_at_zero_error() {
    for (k, (dialect, model, theta)) in zero_compensators().into_iter().enumerate() {
        if !selected(&nc_reader(dialect)) {
            continue;
        }
        let c = Compensator::new(&model, &theta, Settings::new(dialect));
        let mut runner = TestRunner::new(config(1000, 10 + k as u64));
        runner
            .run(
                &(
                    nc_program(dialect),
                    prop::collection::vec(byte_damage(), 0..3),
                ),
                |(program, damages)| {
                    let mut bytes = program;
                    for d in &damages {
                        bytes = damaged(&bytes, d, &|_| true);
                    }
                    nc_round_trip(dialect, &c, &bytes)
                },
            )
            .unwrap();
    }
}

#[test]
fn damaged_real_nc_programs_print_back_as_read_and_compensate_to_themselves() {
    let seeds: Vec<(Dialect, Vec<u8>)> = nc_seeds()
        .into_iter()
        .filter(|(d, _)| selected(&nc_reader(*d)))
        .collect();
    if seeds.is_empty() {
        return;
    }
    let compensators: Vec<(Dialect, Compensator)> = zero_compensators()
        .iter()
        .map(|(d, m, t)| (*d, Compensator::new(m, t, Settings::new(*d))))
        .collect();
    let expanders: Vec<(Dialect, Compensator)> = zero_compensators()
        .iter()
        .map(|(d, m, t)| {
            let mut s = Settings::new(*d);
            s.expand = true;
            (*d, Compensator::new(m, t, s))
        })
        .collect();
    let mut runner = TestRunner::new(config(2000, 20));
    runner
        .run(
            &(0..seeds.len(), prop::collection::vec(byte_damage(), 1..5)),
            |(k, damages)| {
                let (dialect, src) = &seeds[k];
                let mut bytes = src.clone();
                for d in &damages {
                    bytes = damaged(&bytes, d, &|_| true);
                }
                let c = &compensators.iter().find(|(d, _)| d == dialect).unwrap().1;
                nc_round_trip(*dialect, c, &bytes)?;
                // --expand runs the damaged macro logic: it writes a
                // program, or refuses with a line of the input.
                let e = &expanders.iter().find(|(d, _)| d == dialect).unwrap().1;
                match e.run(Path::new(PATH), bytes.as_slice(), &mut Vec::new()) {
                    Ok(_) => Ok(()),
                    // Outside --strict the only other refusal is a block
                    // the control cannot run, at its line.
                    Err(
                        fivecal::compensate::CompensateError::Syntax(e)
                        | fivecal::compensate::CompensateError::Unmodelled(e),
                    ) => {
                        prop_assert!(e.to_string().starts_with(PATH), "{e}");
                        Ok(())
                    }
                    Err(e) => Err(TestCaseError::fail(format!("{dialect}: --expand: {e}"))),
                }
            },
        )
        .unwrap();
}

#[test]
fn arbitrary_bytes_as_nc_programs_print_back_as_read() {
    for (k, (dialect, model, theta)) in zero_compensators().into_iter().enumerate() {
        if !selected(&nc_reader(dialect)) {
            continue;
        }
        let c = Compensator::new(&model, &theta, Settings::new(dialect));
        let mut runner = TestRunner::new(config(1000, 30 + k as u64));
        runner
            .run(&proptest::collection::vec(any::<u8>(), 0..300), |bytes| {
                nc_round_trip(dialect, &c, &bytes)
            })
            .unwrap();
    }
}
