//! Runs `compensate` over a local copy of the real-file corpus (the files
//! `tests/corpus/fetch.sh` brings; they are never committed, so the test
//! suite cannot run them): every NC program of `nc/fanuc`, `nc/heidenhain`,
//! `nc/linuxcnc` and `nc/sinumerik` under DIR, once at zero error, where
//! the rewrite must be byte-identical to the input, and once with location
//! errors of about 20 um and 20 urad, where the run must go through or stop
//! with a reason at a line.
//!
//! ```text
//! cargo run --release --example corpus -- tests/corpus
//! ```
//!
//! Prints one row per file and a total; exits non-zero on a panic, on a
//! zero-error rewrite that changed a byte, or on a refusal that does not
//! name a line (the issue's "unexplained refusal").
//!
//! Each file's dialect is also detected from its text as a run without
//! `--dialect` does, for a machine of each controller: a file detected as
//! another dialect than its directory's is a failure, except plain G-code
//! (no sign of FANUC or LinuxCNC) read by the ISO dialect of the machine,
//! which either controller runs; those are counted apart.
//!
//! Every measurement file under `cmm/` (the QIF schemas aside) is then read
//! as `fivecal measured` reads it: it must give its format and entries or be
//! refused with a message naming the file; a panic is a failure.

use std::io::BufReader;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};

use fivecal::compensate::{CompensateError, Compensator, Settings, Summary};
use fivecal::errorfile::{ErrorFile, LoadedErrors};
use fivecal::formats::detect::{self, ReadContext};
use fivecal::kinematics::Kinematics;
use fivecal::model::Model;
use fivecal::nc::dialect::{Detection, detect};
use fivecal::{Dialect, Machine};

/// One run's outcome.
enum Outcome {
    Done(Box<Summary>, bool),
    /// Stopped with a message that names the line.
    Refused(String),
    /// Stopped without a line.
    Unexplained(String),
    Panic(String),
}

fn main() {
    let dir = match std::env::args().nth(1) {
        Some(d) => PathBuf::from(d),
        None => {
            eprintln!(
                "usage: corpus DIR   (DIR holds nc/fanuc, nc/heidenhain, nc/linuxcnc, nc/sinumerik)"
            );
            std::process::exit(2);
        }
    };
    let mut files = Vec::new();
    for (sub, dialect) in [
        ("nc/fanuc", Dialect::Fanuc),
        ("nc/heidenhain", Dialect::Heidenhain),
        ("nc/linuxcnc", Dialect::Linuxcnc),
        ("nc/sinumerik", Dialect::Sinumerik),
    ] {
        let mut found = Vec::new();
        walk(&dir.join(sub), &mut found);
        found.sort();
        files.extend(found.into_iter().map(|p| (p, dialect)));
    }
    if files.is_empty() {
        eprintln!(
            "{}: no NC programs under nc/ (run tests/corpus/fetch.sh first)",
            dir.display()
        );
        std::process::exit(2);
    }
    // Silence the default panic message: the table reports it.
    std::panic::set_hook(Box::new(|_| {}));
    let mut failures = 0;
    let (mut identical, mut ran, mut refused, mut corrected) = (0, 0, 0, 0);
    let (mut moves, mut changed) = (0usize, 0usize);
    let (mut by_sign, mut by_hint, mut plain) = (0, 0, 0);
    println!("| file | dialect | detected | machine | zero error | with errors |");
    println!("|---|---|---|---|---|---|");
    for (path, dialect) in &files {
        let shown = path
            .strip_prefix(&dir)
            .unwrap_or(path)
            .display()
            .to_string();
        let bytes = match std::fs::read(path) {
            Ok(b) => b,
            Err(e) => {
                failures += 1;
                println!("| {shown} | {dialect} | - | cannot read: {e} | - |");
                continue;
            }
        };
        let detected = match detection(path, &bytes, *dialect) {
            Ok(d) => {
                if d.why.starts_with("from the text") {
                    by_sign += 1;
                } else if d.why.starts_with("plain G-code") {
                    plain += 1;
                } else {
                    by_hint += 1;
                }
                d.why
            }
            Err(m) => {
                failures += 1;
                m
            }
        };
        let detected = one_line(&detected);
        let machine_name = machine_for(&bytes);
        let machine = Machine::builtin(machine_name).expect("built-in machine");
        let zero = run(path, &bytes, &machine, *dialect, 0.0);
        let zero_cell = match &zero {
            Outcome::Done(_, true) => {
                identical += 1;
                "identical".to_string()
            }
            Outcome::Done(..) => {
                failures += 1;
                "CHANGED BYTES".to_string()
            }
            other => cell(other, &mut failures),
        };
        let with = run(path, &bytes, &machine, *dialect, 20.0);
        let with_cell = match &with {
            Outcome::Done(s, _) => {
                ran += 1;
                moves += s.moves;
                changed += s.changed;
                if s.changed > 0 {
                    corrected += 1;
                }
                format!(
                    "{} moves, {} blocks changed, {} left as written",
                    s.moves,
                    s.changed,
                    s.skipped_count()
                )
            }
            Outcome::Refused(m) => {
                refused += 1;
                format!("refused: {}", one_line(m))
            }
            other => cell(other, &mut failures),
        };
        println!(
            "| {shown} | {dialect} | {detected} | {machine_name} | {zero_cell} | {with_cell} |"
        );
    }
    let run_files = files.len();
    println!();
    println!(
        "dialect from the text, whatever the machine's controller: {by_sign} by a sign of their own, {by_hint} by extension or machine with no sign, {plain} plain G-code read by the machine's ISO dialect"
    );
    println!(
        "{} files: zero error {}/{} byte-identical; with errors {} ran through ({} with a block corrected; {} moves, {} blocks changed), {} refused at a named line; {} failures (panics, changed bytes at zero error, refusals without a line)",
        files.len(),
        identical,
        run_files,
        ran,
        corrected,
        moves,
        changed,
        refused,
        failures
    );
    failures += measurement_files(&dir);
    if failures > 0 {
        std::process::exit(1);
    }
}

/// Reads every measurement file under `cmm/` as `fivecal measured` does;
/// returns the failures (panics, refusals that do not name the file).
fn measurement_files(dir: &Path) -> usize {
    let mut found = Vec::new();
    walk(&dir.join("cmm"), &mut found);
    found.retain(|p| !p.components().any(|c| c.as_os_str() == "xsd"));
    found.sort();
    let (mut read, mut refused, mut failures) = (0, 0, 0);
    println!();
    println!("| measurement file | read as |");
    println!("|---|---|");
    for path in &found {
        let shown = path.strip_prefix(dir).unwrap_or(path).display().to_string();
        let outcome = catch_unwind(AssertUnwindSafe(|| {
            detect::inventory(path, &ReadContext::default())
        }));
        let cell = match outcome {
            Ok(Ok(inv)) => {
                read += 1;
                format!(
                    "{} {}, {} entries, {} warnings",
                    inv.format,
                    inv.version.as_deref().unwrap_or(""),
                    inv.entries.len(),
                    inv.warnings.len()
                )
            }
            Ok(Err(e)) => {
                let m = e.to_string();
                if m.contains(&path.display().to_string()) {
                    refused += 1;
                    format!("refused: {}", one_line(&m))
                } else {
                    failures += 1;
                    format!("REFUSED WITHOUT THE FILE: {}", one_line(&m))
                }
            }
            Err(_) => {
                failures += 1;
                "PANIC".to_string()
            }
        };
        println!("| {shown} | {cell} |");
    }
    println!();
    println!(
        "{} measurement files: {read} read, {refused} refused naming the file; {failures} failures",
        found.len()
    );
    failures
}

/// The dialect a run without `--dialect` reads `bytes` in, on a machine
/// of each controller: the detection on a machine of another controller
/// than `dialect` (the hard case), or why a detection went wrong.
fn detection(path: &Path, bytes: &[u8], dialect: Dialect) -> Result<Detection, String> {
    let mut shown = None;
    for machine in [Dialect::Fanuc, Dialect::Heidenhain, Dialect::Linuxcnc] {
        let d = detect(path, bytes, machine);
        let iso = |x: Dialect| x != Dialect::Heidenhain;
        let either = d.why.starts_with("plain G-code") && iso(dialect) && iso(d.dialect);
        if d.dialect != dialect && !either {
            return Err(format!(
                "WRONG on a {machine} machine: read as {} ({})",
                d.dialect, d.why
            ));
        }
        if machine != dialect && shown.is_none() {
            shown = Some(d);
        }
    }
    Ok(shown.expect("three controllers, one the file's"))
}

/// The table cell of a run that did not finish.
fn cell(o: &Outcome, failures: &mut usize) -> String {
    match o {
        Outcome::Done(..) => unreachable!("finished runs are shown by the caller"),
        Outcome::Refused(m) => format!("refused: {}", one_line(m)),
        Outcome::Unexplained(m) => {
            *failures += 1;
            format!("UNEXPLAINED: {}", one_line(m))
        }
        Outcome::Panic(m) => {
            *failures += 1;
            format!("PANIC: {}", one_line(m))
        }
    }
}

fn one_line(m: &str) -> String {
    let first = m.lines().next().unwrap_or("").replace('|', "/");
    let mut s: String = first.chars().take(140).collect();
    if first.chars().count() > 140 {
        s.push_str("...");
    }
    s
}

/// Files under `dir`, depth first.
fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return;
    };
    for e in rd.flatten() {
        let p = e.path();
        if p.is_dir() {
            walk(&p, out);
        } else {
            out.push(p);
        }
    }
}

/// A built-in machine with the rotary axes the program uses: B and C
/// (bc-trunnion) when it writes B words and no A, else A and C.
fn machine_for(bytes: &[u8]) -> &'static str {
    let word = |letter: u8| {
        bytes.windows(2).enumerate().any(|(i, w)| {
            w[0].eq_ignore_ascii_case(&letter)
                && (w[1].is_ascii_digit() || matches!(w[1], b'-' | b'+' | b'.'))
                && (i == 0 || !bytes[i - 1].is_ascii_alphabetic())
        })
    };
    if word(b'B') && !word(b'A') {
        "bc-trunnion"
    } else {
        "ac-trunnion"
    }
}

/// Location errors of `size` um / urad on every symbol (fixed pattern),
/// or all zero.
fn errors(machine: &Machine, size: f64) -> LoadedErrors {
    let k = Kinematics::new(machine);
    let model = Model::new(k.clone(), vec![]);
    let mut src = format!("machine: {}\nlocation_errors:\n", machine.name);
    for (i, s) in model.symbols.location.iter().enumerate() {
        // A fixed spread of signs and sizes, no randomness needed.
        let v = size * ((i as f64 * 2.399).sin());
        src.push_str(&format!("  {}: {v:.3}\n", s.name));
    }
    ErrorFile::parse(Path::new("corpus-errors.yaml"), &src)
        .and_then(|f| f.to_model(&k, Path::new("corpus-errors.yaml"), &src))
        .expect("generated error file reads")
}

fn run(path: &Path, bytes: &[u8], machine: &Machine, dialect: Dialect, size: f64) -> Outcome {
    let e = errors(machine, size);
    let c = Compensator::new(&e.model, &e.theta, Settings::new(dialect));
    let mut out = Vec::with_capacity(bytes.len() + 1024);
    let r = catch_unwind(AssertUnwindSafe(|| {
        c.run(path, BufReader::new(bytes), &mut out)
    }));
    match r {
        Ok(Ok(s)) => {
            let same = out == bytes;
            Outcome::Done(Box::new(s), same)
        }
        Ok(Err(err)) => {
            let m = err.to_string();
            match err {
                CompensateError::Syntax(_)
                | CompensateError::Unmodelled(_)
                | CompensateError::TooLarge { .. }
                | CompensateError::Tolerance { .. } => Outcome::Refused(m),
                CompensateError::Io(_) => Outcome::Unexplained(m),
            }
        }
        Err(p) => Outcome::Panic(
            p.downcast_ref::<String>()
                .cloned()
                .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_else(|| "panic".into()),
        ),
    }
}
