//! What a run prints for its user. Every command prints through [`out!`] and
//! [`outln!`]: to standard output, or to standard error when standard output
//! carries one of the run's outputs (`-o -`). A reader that goes away
//! (`fivecal analyze ... | head`) ends the printing quietly and the run goes
//! on to write its files (`fivecal::io::Stdout`); `main` then exits with
//! 141, the status of a process ended by SIGPIPE, as `yes | head` reports.

use std::fmt;
use std::io::Write as _;
use std::sync::Mutex;

/// The first failure to write standard output other than a closed pipe (a
/// full disk): reported when the run ends.
static FAILED: Mutex<Option<String>> = Mutex::new(None);

/// Prints formatted text (see the module documentation).
pub fn print(args: fmt::Arguments<'_>) {
    if fivecal::io::stdout_claimed() {
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
