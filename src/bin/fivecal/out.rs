//! What a run prints for its user. Every command prints through [`out!`] and
//! [`outln!`]: to standard output, or to standard error when standard output
//! carries one of the run's outputs (`-o -`) or its `--json` output. A reader that goes away
//! (`fivecal analyze ... | head`) ends the printing quietly and the run goes
//! on to write its files (`fivecal::io::Stdout`); `main` then exits with
//! 141, the status of a process ended by SIGPIPE, as `yes | head` reports.

use std::fmt;
use std::io::Write as _;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};

/// The first failure to write standard output other than a closed pipe (a
/// full disk): reported when the run ends.
static FAILED: Mutex<Option<String>> = Mutex::new(None);

/// Whether standard output carries a command's `--json` output, so that
/// what it says for its user goes to standard error.
static JSON_ON_STDOUT: AtomicBool = AtomicBool::new(false);

/// From now on, [`print`] writes to standard error: standard output is
/// kept for the JSON that [`json`] writes.
pub fn to_stderr() {
    JSON_ON_STDOUT.store(true, Ordering::Relaxed);
}

/// Writes a command's `--json` output to standard output, ending with a
/// newline.
pub fn json(text: &str) -> std::io::Result<()> {
    let mut out = fivecal::io::stdout();
    out.write_all(text.as_bytes())?;
    if !text.ends_with('\n') {
        out.write_all(b"\n")?;
    }
    out.flush()
}

/// Prints formatted text (see the module documentation).
pub fn print(args: fmt::Arguments<'_>) {
    if fivecal::io::stdout_claimed() || JSON_ON_STDOUT.load(Ordering::Relaxed) {
        eprint!("{args}");
        return;
    }
    if let Err(e) = fivecal::io::stdout().write_fmt(args)
        && let Ok(mut f) = FAILED.lock()
        && f.is_none()
    {
        *f = Some(e.to_string());
    }
}

/// Why standard output could not be written, if it could not (a closed
/// pipe is not a failure).
pub fn failure() -> Option<String> {
    FAILED.lock().ok().and_then(|f| f.clone())
}

/// `print!` through [`print`].
macro_rules! out {
    ($($t:tt)*) => { $crate::out::print(format_args!($($t)*)) };
}

/// `println!` through [`print`].
macro_rules! outln {
    () => { $crate::out::print(format_args!("\n")) };
    ($($t:tt)*) => { $crate::out::print(format_args!("{}\n", format_args!($($t)*))) };
}

/// Writes `value` as a command's `--json` output (pretty JSON, one
/// newline) through [`json`].
pub fn json_of<T: serde::Serialize>(value: &T) -> anyhow::Result<()> {
    json(&serde_json::to_string_pretty(value)?)?;
    Ok(())
}

/// Lines of an NC program grouped under one reason (what was skipped,
/// left as written, not modelled), as `--json` prints them: the reason in
/// words, how many lines, and the first of them.
#[derive(serde::Serialize)]
pub struct ReasonLines {
    pub reason: String,
    pub count: usize,
    pub lines: Vec<usize>,
}

impl ReasonLines {
    /// Each reason with its lines.
    pub fn all<R: fmt::Display>(groups: &[(R, fivecal::compensate::Lines)]) -> Vec<ReasonLines> {
        groups
            .iter()
            .map(|(r, l)| ReasonLines {
                reason: r.to_string(),
                count: l.len(),
                lines: l.first.clone(),
            })
            .collect()
    }
}

/// A largest value and the program line it was met on.
#[derive(serde::Serialize)]
pub struct AtLine {
    pub value: f64,
    pub line: usize,
}

impl From<fivecal::compensate::Largest> for AtLine {
    fn from(l: fivecal::compensate::Largest) -> AtLine {
        AtLine {
            value: l.value,
            line: l.line,
        }
    }
}
