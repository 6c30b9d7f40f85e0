//! Reads every file under a directory of real CMM output (the fetched
//! corpus of `tests/corpus/`, whose files are never committed) the way
//! `fivecal measured` does, and prints one row per file: the format
//! recognized, runs, entries and measured points, or why it was refused.
//! Exits non-zero on a panic or on a refusal that is not one of the
//! intended kinds (a file with nothing measured, a format fivecal does not
//! read, results kept in another file, coordinates without units).
//!
//! ```text
//! cargo run --release --example measured_corpus -- tests/corpus/cmm
//! ```

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use fivecal::formats::detect::{self, ReadContext};

/// Refusals that are the reader doing its job.
const EXPLAINED: [&str; 4] = [
    "nothing measured",
    "unrecognized measurement format",
    "kept in another QIF file",
    "states no length unit",
];

fn files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return;
    };
    let mut entries: Vec<PathBuf> = rd.filter_map(|e| e.ok().map(|e| e.path())).collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            files(&p, out);
        } else if !p.extension().is_some_and(|e| e.eq_ignore_ascii_case("xsd")) {
            out.push(p);
        }
    }
}

fn main() -> ExitCode {
    let Some(dir) = std::env::args().nth(1) else {
        eprintln!("usage: measured_corpus DIR");
        return ExitCode::from(2);
    };
    let mut list = Vec::new();
    files(Path::new(&dir), &mut list);
    let mut bad = 0;
    println!("| file | format | runs | entries | points | result |");
    println!("|---|---|---|---|---|---|");
    for f in &list {
        let name = f.strip_prefix(&dir).unwrap_or(f).display().to_string();
        let r = std::panic::catch_unwind(|| detect::inventory(f, &ReadContext::default()));
        match r {
            Err(_) => {
                bad += 1;
                println!("| {name} | | | | | PANIC |");
            }
            Ok(Ok(inv)) => {
                let points = inv.entries.iter().filter(|e| e.is_point()).count();
                println!(
                    "| {name} | {} {} | {} | {} | {points} | read ({} skipped) |",
                    inv.format,
                    inv.version.as_deref().unwrap_or(""),
                    inv.runs.len(),
                    inv.entries.len(),
                    inv.skipped.len()
                );
            }
            Ok(Err(e)) => {
                let msg = e.message.clone();
                let explained = EXPLAINED.iter().any(|k| msg.contains(k));
                if !explained {
                    bad += 1;
                }
                let short: String = msg.chars().take(90).collect();
                println!(
                    "| {name} | | | | | {}: {short} |",
                    if explained { "refused" } else { "UNEXPLAINED" }
                );
            }
        }
    }
    println!(
        "\n{} files, {bad} panics or unexplained refusals",
        list.len()
    );
    if bad > 0 {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}
