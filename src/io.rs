//! Outputs that never leave a half-written file, never overwrite an input
//! and never destroy what they replace.
//!
//! Every output path is one of three kinds ([`OutputTarget`]):
//! - `-`, `/dev/stdout`: standard output, through [`stdout`], which ends
//!   quietly when the reader goes away (a broken pipe is recorded, not
//!   raised, so the run still writes its files);
//! - an existing device, FIFO or socket, or any path under `/dev/` or
//!   `/proc/`: written in place, never renamed over (`-o /dev/null` leaves
//!   `/dev/null` a device);
//! - anything else: a regular file, written to a temporary file beside it
//!   (`.NAME.*.fivecal-tmp`) and renamed into place once complete. A
//!   symbolic link to a file is followed (the link stays, its file is
//!   replaced); a dangling link or a directory is refused with the reason.
//!   A new file's mode follows the umask, a replaced file keeps its mode.
//!
//! A multi-file output (a plan, a report) is a [`StagedDir`]: every file is
//! written into a temporary directory, and only once all are complete do
//! they move into the target, which appears whole or not at all.
//!
//! Temporary files and directories are removed on every error (on drop) and,
//! through [`remove_temporaries`], by the binary's handler of SIGINT and
//! SIGTERM. [`check_outputs`] refuses, before any work, an output that names
//! an input of the same run or another output (paths compared after
//! resolving links), and an output of the wrong kind.
//!
//! Inputs read through other files (a plan's points, machine and template
//! copies, a glTF's buffers, the results store) are not on the command
//! line, so every reader of [`crate::input`] notes the file it opens
//! ([`note_input`]) once the binary has turned the guard on
//! ([`guard_inputs`]); every output ([`AtomicOutput`], [`StagedDir`]) is
//! then refused, before its first byte, when it is one of them: the same
//! path after resolving links and `..`, or the same device and inode (a
//! hard link). The message names both the output and the input.

use std::fs::{File, OpenOptions};
use std::io::{self, BufWriter, Write};
use std::path::{Component, Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// Errors of the output helpers.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// The output path names one of the inputs of the same run.
    #[error("refusing to overwrite input file {0}")]
    WouldOverwriteInput(PathBuf),
    /// An output option names one of the inputs of the same run.
    #[error("{flag} {}: refusing to overwrite input file {} (it is also an input of this run; write the output elsewhere)", path.display(), path.display())]
    OutputIsInput {
        /// The option.
        flag: String,
        /// The path given.
        path: PathBuf,
    },
    /// Two outputs of one run name the same file.
    #[error("{first} and {second} both name {path}: give each output its own path")]
    SameOutput {
        /// The path (as the first output named it).
        path: PathBuf,
        /// The first flag.
        first: String,
        /// The second flag.
        second: String,
    },
    /// The output cannot be written as the kind of output it is.
    #[error("{flag} {path}: {what}")]
    WrongKind {
        /// The flag (or `output`).
        flag: String,
        /// The path.
        path: PathBuf,
        /// What the path is and what was expected.
        what: String,
    },
    /// The output is a file this run reads (named directly or through
    /// another file).
    #[error("{}: refusing to overwrite input file {}, {what} this run reads (write the output elsewhere)", out.display(), input.display())]
    OutputIsRead {
        /// The output as named.
        out: PathBuf,
        /// The input as it was named when read.
        input: PathBuf,
        /// What the input is ("the plan's points file").
        what: String,
    },
    /// Any I/O failure, with the path.
    #[error("cannot write {path}: {cause}")]
    Io {
        /// The destination.
        path: PathBuf,
        /// The cause (in the message, not chained, so it prints once).
        cause: std::io::Error,
    },
}

impl OutputError {
    fn io(path: &Path) -> impl Fn(io::Error) -> OutputError + '_ {
        move |cause| OutputError::Io {
            path: path.to_path_buf(),
            cause,
        }
    }

    /// Whether the error is standard output's reader having gone away.
    pub fn is_broken_pipe(&self) -> bool {
        matches!(self, OutputError::Io { cause, .. } if cause.kind() == io::ErrorKind::BrokenPipe)
    }
}

// ---------------------------------------------------------------- stdout

static STDOUT_CLOSED: AtomicBool = AtomicBool::new(false);
static STDOUT_CLAIMED: AtomicBool = AtomicBool::new(false);

/// Standard output that ends quietly when its reader goes away: a broken
/// pipe is recorded ([`stdout_closed`]) and everything after it discarded,
/// so a run piped into `head` still writes its files.
#[derive(Clone, Copy, Debug, Default)]
pub struct Stdout;

/// The shared standard-output writer.
pub fn stdout() -> Stdout {
    Stdout
}

/// Whether a write to standard output found its reader gone.
pub fn stdout_closed() -> bool {
    STDOUT_CLOSED.load(Ordering::Relaxed)
}

/// Whether an output of this run is standard output (`-`): messages then
/// belong on standard error.
pub fn stdout_claimed() -> bool {
    STDOUT_CLAIMED.load(Ordering::Relaxed)
}

impl Write for Stdout {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        if stdout_closed() {
            return Ok(buf.len());
        }
        match io::stdout().lock().write(buf) {
            Err(e) if e.kind() == io::ErrorKind::BrokenPipe => {
                STDOUT_CLOSED.store(true, Ordering::Relaxed);
                Ok(buf.len())
            }
            r => r,
        }
    }

    fn write_all(&mut self, buf: &[u8]) -> io::Result<()> {
        if stdout_closed() {
            return Ok(());
        }
        match io::stdout().lock().write_all(buf) {
            Err(e) if e.kind() == io::ErrorKind::BrokenPipe => {
                STDOUT_CLOSED.store(true, Ordering::Relaxed);
                Ok(())
            }
            r => r,
        }
    }

    fn flush(&mut self) -> io::Result<()> {
        if stdout_closed() {
            return Ok(());
        }
        match io::stdout().lock().flush() {
            Err(e) if e.kind() == io::ErrorKind::BrokenPipe => {
                STDOUT_CLOSED.store(true, Ordering::Relaxed);
                Ok(())
            }
            r => r,
        }
    }
}

// ----------------------------------------------------------- inputs read

/// A file this run has read.
#[derive(Clone, Debug)]
struct ReadInput {
    /// As it was named.
    path: PathBuf,
    /// What it is, for messages.
    what: String,
    /// Where it resolves to (links and `..` resolved).
    real: PathBuf,
    /// Device and inode, when it exists.
    id: Option<(u64, u64)>,
}

static GUARD: AtomicBool = AtomicBool::new(false);
static INPUTS: Mutex<Vec<ReadInput>> = Mutex::new(Vec::new());

/// Turns on the guard of inputs for this process: from now on every file
/// read is noted and no output may land on one. The binary turns it on
/// once; a library user that reads and rewrites the same file in one
/// process (a test, an editor) leaves it off.
pub fn guard_inputs() {
    GUARD.store(true, Ordering::Relaxed);
}

#[cfg(unix)]
fn file_id(m: &std::fs::Metadata) -> Option<(u64, u64)> {
    use std::os::unix::fs::MetadataExt;
    Some((m.dev(), m.ino()))
}

#[cfg(not(unix))]
fn file_id(_: &std::fs::Metadata) -> Option<(u64, u64)> {
    None
}

/// Notes that this run reads `path` (`what` names it in messages, "the
/// plan's points file"); a file that does not exist yet (a new results
/// store) is noted by its resolved path. Does nothing unless
/// [`guard_inputs`] was called.
pub fn note_input(path: &Path, what: &str) {
    if !GUARD.load(Ordering::Relaxed) || path.as_os_str() == "-" {
        return;
    }
    let input = ReadInput {
        path: path.to_path_buf(),
        what: what.to_string(),
        real: resolved(path),
        id: std::fs::metadata(path).ok().as_ref().and_then(file_id),
    };
    if let Ok(mut v) = INPUTS.lock() {
        v.push(input);
    }
}

/// The input of `inputs` that `out` would write over, if any.
fn read_input_at(out: &Path, inputs: &[ReadInput]) -> Option<ReadInput> {
    let real = resolved(out);
    let id = std::fs::metadata(out).ok().as_ref().and_then(file_id);
    inputs
        .iter()
        .find(|i| i.real == real || (id.is_some() && i.id == id))
        .cloned()
}

/// Refuses an output that is a file this run has read (see
/// [`note_input`]).
pub fn ensure_not_read(out: &Path) -> Result<(), OutputError> {
    if !GUARD.load(Ordering::Relaxed) {
        return Ok(());
    }
    let inputs = match INPUTS.lock() {
        Ok(v) => v.clone(),
        Err(_) => return Ok(()),
    };
    match read_input_at(out, &inputs) {
        Some(i) => Err(OutputError::OutputIsRead {
            out: out.to_path_buf(),
            input: i.path,
            what: i.what,
        }),
        None => Ok(()),
    }
}

// ------------------------------------------------------------ temporaries

static TEMPORARIES: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());
static COUNTER: AtomicU64 = AtomicU64::new(0);

fn register(p: &Path) {
    if let Ok(mut v) = TEMPORARIES.lock() {
        v.push(p.to_path_buf());
    }
}

fn unregister(p: &Path) {
    if let Ok(mut v) = TEMPORARIES.lock()
        && let Some(i) = v.iter().position(|x| x == p)
    {
        v.swap_remove(i);
    }
}

/// Removes every temporary file and directory still being written (for a
/// signal handler: the run is about to end without committing them).
pub fn remove_temporaries() {
    let list = match TEMPORARIES.lock() {
        Ok(mut v) => std::mem::take(&mut *v),
        Err(_) => return,
    };
    for p in list {
        let _ = if p.is_dir() {
            std::fs::remove_dir_all(&p)
        } else {
            std::fs::remove_file(&p)
        };
    }
}

/// The suffix of every temporary name.
const TEMP_SUFFIX: &str = ".fivecal-tmp";

/// Longest file name most file systems take, bytes.
const NAME_MAX: usize = 255;

/// Room a temporary name needs beside the output's name: the dot before
/// it, `.<pid>-<unique>` (hex, at most 8 + 1 + 16 + 1 + 1 bytes) and the
/// suffix.
const TEMP_EXTRA: usize = 1 + 1 + 8 + 1 + 16 + TEMP_SUFFIX.len();

/// The part of an output's name a temporary name keeps: all of it when it
/// fits, else its start (cut at a character boundary), so that a legal
/// output name of up to 255 bytes still has a legal temporary name.
fn temp_stem(name: &str) -> &str {
    let max = NAME_MAX - TEMP_EXTRA;
    if name.len() <= max {
        return name;
    }
    let mut end = max;
    while !name.is_char_boundary(end) {
        end -= 1;
    }
    &name[..end]
}

/// A fresh name `.<name>.<pid>-<unique>.fivecal-tmp` in `dir`, hidden and
/// naming what it will become (so a leftover after `kill -9` says what it
/// was, and the next run into the same place finds it by the pid of a run
/// that is gone); a long `name` is cut so the whole stays within 255 bytes.
fn temp_name(dir: &Path, name: &str) -> PathBuf {
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let t = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.subsec_nanos() as u64);
    dir.join(format!(
        ".{}.{:x}-{:x}{TEMP_SUFFIX}",
        temp_stem(name),
        std::process::id(),
        (t << 16) ^ n
    ))
}

static STALE_REMOVED: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// Whether process `pid` is running (Linux: `/proc/<pid>` exists; where
/// that cannot be told, every process counts as running).
fn running(pid: u32) -> bool {
    if !Path::new("/proc/self").exists() {
        return true;
    }
    Path::new(&format!("/proc/{pid}")).exists()
}

/// Removes the temporary files (and directories) that a killed run left
/// in `dir` while writing `name`: those of the same output whose run is no
/// longer running. Each removal is kept for [`stale_removed`].
fn remove_stale(dir: &Path, name: &str) {
    let prefix = format!(".{}.", temp_stem(name));
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let file = e.file_name();
        let Some(f) = file.to_str() else { continue };
        let Some(middle) = f
            .strip_prefix(&prefix)
            .and_then(|r| r.strip_suffix(TEMP_SUFFIX))
        else {
            continue;
        };
        let Some(pid) = middle
            .split_once('-')
            .and_then(|(p, _)| u32::from_str_radix(p, 16).ok())
        else {
            continue;
        };
        if pid == std::process::id() || running(pid) {
            continue;
        }
        let p = e.path();
        let gone = if p.is_dir() {
            std::fs::remove_dir_all(&p)
        } else {
            std::fs::remove_file(&p)
        };
        if gone.is_ok()
            && let Ok(mut v) = STALE_REMOVED.lock()
        {
            v.push(p);
        }
    }
}

/// The temporary files of killed runs removed so far (the binary names
/// them on standard error).
pub fn stale_removed() -> Vec<PathBuf> {
    STALE_REMOVED.lock().map(|v| v.clone()).unwrap_or_default()
}

/// Creates a new file that did not exist, mode 0666 less the umask.
fn create_new(path: &Path) -> io::Result<File> {
    let mut o = OpenOptions::new();
    o.write(true).create_new(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        o.mode(0o666);
    }
    o.open(path)
}

fn file_name_of(path: &Path) -> String {
    path.file_name()
        .map_or("output".into(), |n| n.to_string_lossy().into_owned())
}

// ---------------------------------------------------------------- targets

/// What an output path is.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum OutputTarget {
    /// Standard output (`-`, `/dev/stdout`).
    Stdout,
    /// A device, FIFO, socket or a path under `/dev/` or `/proc/`: written
    /// in place.
    InPlace(PathBuf),
    /// A regular file (new or replaced), at this path (links resolved).
    File(PathBuf),
}

fn is_special_location(path: &Path) -> bool {
    let mut c = path.components();
    c.next() == Some(Component::RootDir)
        && matches!(c.next(), Some(Component::Normal(n)) if n == "dev" || n == "proc")
}

/// Classifies an output path for a file output named by `flag`.
pub(crate) fn classify(flag: &str, path: &Path) -> Result<OutputTarget, OutputError> {
    let wrong = |what: String| OutputError::WrongKind {
        flag: flag.to_string(),
        path: path.to_path_buf(),
        what,
    };
    let s = path.as_os_str();
    if s == "-" || s == "/dev/stdout" || s == "/proc/self/fd/1" || s == "/dev/fd/1" {
        return Ok(OutputTarget::Stdout);
    }
    if s.is_empty() {
        return Err(wrong("expected a file name".into()));
    }
    let link = match std::fs::symlink_metadata(path) {
        Ok(m) => m,
        Err(e) if e.kind() == io::ErrorKind::NotFound => {
            // Resolved first: `/proc/self/cwd/x` is a file of the working
            // directory, written through a temporary file like any other.
            let real = resolved(path);
            if is_special_location(&real) {
                return Err(wrong(
                    "does not exist, and fivecal creates no files under /dev or /proc".into(),
                ));
            }
            return Ok(OutputTarget::File(real));
        }
        Err(e) => return Err(OutputError::io(path)(e)),
    };
    let meta = if link.file_type().is_symlink() {
        match std::fs::metadata(path) {
            Ok(m) => m,
            Err(_) => {
                let to = std::fs::read_link(path).unwrap_or_default();
                return Err(wrong(format!(
                    "is a symbolic link to {}, which does not exist: remove the link or name another file",
                    to.display()
                )));
            }
        }
    } else {
        link
    };
    if meta.is_dir() {
        return Err(wrong("is a directory: expected a file name".into()));
    }
    if !meta.is_file() {
        return Ok(OutputTarget::InPlace(path.to_path_buf()));
    }
    // The real path decides: a regular file reached through `/proc/self/cwd`
    // is replaced whole, a file that really is under /proc or /dev is not.
    let real = std::fs::canonicalize(path).map_err(OutputError::io(path))?;
    if is_special_location(&real) {
        return Ok(OutputTarget::InPlace(path.to_path_buf()));
    }
    Ok(OutputTarget::File(real))
}

/// Classifies an output directory named by `flag`: it must be a directory
/// or not exist yet.
fn check_dir_target(flag: &str, path: &Path) -> Result<(), OutputError> {
    let wrong = |what: String| OutputError::WrongKind {
        flag: flag.to_string(),
        path: path.to_path_buf(),
        what,
    };
    if path.as_os_str() == "-" {
        return Err(wrong(
            "writes several files and needs a directory, not standard output".into(),
        ));
    }
    let link = match std::fs::symlink_metadata(path) {
        Ok(m) => m,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(OutputError::io(path)(e)),
    };
    let meta = if link.file_type().is_symlink() {
        match std::fs::metadata(path) {
            Ok(m) => m,
            Err(_) => {
                let to = std::fs::read_link(path).unwrap_or_default();
                return Err(wrong(format!(
                    "is a symbolic link to {}, which does not exist: remove the link or name another directory",
                    to.display()
                )));
            }
        }
    } else {
        link
    };
    if meta.is_dir() {
        return Ok(());
    }
    let what = if meta.is_file() {
        "is an existing file"
    } else {
        "is a device or special file"
    };
    Err(wrong(format!(
        "{what}; this output is several files and needs a directory (a new name, or an existing directory)"
    )))
}

/// Lexically normalized absolute path (for paths that do not exist yet).
fn absolute(path: &Path) -> PathBuf {
    let base = if path.is_absolute() {
        PathBuf::new()
    } else {
        std::env::current_dir().unwrap_or_default()
    };
    let mut out = PathBuf::new();
    for c in base.join(path).components() {
        match c {
            Component::ParentDir => {
                out.pop();
            }
            Component::CurDir => {}
            c => out.push(c),
        }
    }
    out
}

/// The path an output or input resolves to: canonical where it (or its
/// nearest existing ancestor) exists.
fn resolved(path: &Path) -> PathBuf {
    if let Ok(p) = path.canonicalize() {
        return p;
    }
    let abs = absolute(path);
    let mut tail = Vec::new();
    let mut cur = abs.as_path();
    while let Some(parent) = cur.parent() {
        if let Some(n) = cur.file_name() {
            tail.push(n.to_os_string());
        }
        if let Ok(p) = parent.canonicalize() {
            let mut r = p;
            for n in tail.iter().rev() {
                r.push(n);
            }
            return r;
        }
        cur = parent;
    }
    abs
}

fn same_file(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(x), Ok(y)) => x == y,
        _ => false,
    }
}

/// Writes `files` (names inside `dir`, with their bytes) into `dir` all or
/// nothing ([`StagedDir`]), refusing before anything is written when one
/// would land on one of `inputs`.
pub fn write_dir(
    dir: &Path,
    files: &[(PathBuf, Vec<u8>)],
    inputs: &[&Path],
) -> Result<Vec<PathBuf>, OutputError> {
    for (name, _) in files {
        ensure_not_input(&dir.join(name), inputs)?;
    }
    let mut stage = StagedDir::create(dir)?;
    for (name, bytes) in files {
        stage.write(name, bytes)?;
    }
    stage.commit()
}

/// Fails when `out` is one of `inputs` (compared after resolving links).
pub fn ensure_not_input(out: &Path, inputs: &[&Path]) -> Result<(), OutputError> {
    if inputs.iter().any(|i| same_file(out, i)) {
        return Err(OutputError::WouldOverwriteInput(out.to_path_buf()));
    }
    Ok(())
}

/// Whether an output is one file or a directory of files.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shape {
    /// One file (or standard output, or a device).
    File,
    /// A directory of files (a plan, a report).
    Dir,
}

/// Checks the outputs of one run before anything is done: each is of a kind
/// it can be written as (a file output is not a directory or a dangling
/// link; a directory output is not a file or a device), none names an input
/// or another output (after resolving links; a file inside a directory
/// output counts as the same), and at most one is standard output. Claims
/// standard output when an output is `-`.
pub fn check_outputs(
    inputs: &[&Path],
    outputs: &[(&str, &Path, Shape)],
) -> Result<(), OutputError> {
    let mut seen: Vec<(&str, PathBuf, Shape, bool)> = Vec::new();
    for &(flag, path, shape) in outputs {
        let stdout = match shape {
            Shape::File => classify(flag, path)? == OutputTarget::Stdout,
            Shape::Dir => {
                check_dir_target(flag, path)?;
                false
            }
        };
        if stdout {
            if let Some((first, ..)) = seen.iter().find(|s| s.3) {
                return Err(OutputError::SameOutput {
                    path: path.to_path_buf(),
                    first: first.to_string(),
                    second: flag.to_string(),
                });
            }
            seen.push((flag, PathBuf::new(), shape, true));
            continue;
        }
        if shape == Shape::File {
            ensure_not_read(path)?;
        }
        let r = resolved(path);
        for i in inputs {
            let ri = resolved(i);
            if ri == r {
                return Err(OutputError::OutputIsInput {
                    flag: flag.to_string(),
                    path: path.to_path_buf(),
                });
            }
        }
        for (first, other, oshape, is_stdout) in &seen {
            if *is_stdout {
                continue;
            }
            let clash = other == &r
                || (*oshape == Shape::Dir && r.starts_with(other))
                || (shape == Shape::Dir && other.starts_with(&r));
            if clash {
                return Err(OutputError::SameOutput {
                    path: path.to_path_buf(),
                    first: first.to_string(),
                    second: flag.to_string(),
                });
            }
        }
        seen.push((flag, r, shape, false));
    }
    if seen.iter().any(|s| s.3) {
        STDOUT_CLAIMED.store(true, Ordering::Relaxed);
    }
    Ok(())
}

// ------------------------------------------------------------ one file

/// Writes `bytes` to `path` as [`AtomicOutput`] does.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    let mut out = AtomicOutput::create(path)?;
    out.write_all(bytes).map_err(OutputError::io(path))?;
    out.commit()
}

enum Sink {
    Stdout(BufWriter<Stdout>),
    InPlace(BufWriter<File>),
    Temp {
        file: BufWriter<File>,
        tmp: PathBuf,
        target: PathBuf,
        mode: Option<std::fs::Permissions>,
    },
}

/// Streaming output that appears only when complete: a regular file is
/// written to a temporary file next to it and renamed into place by
/// [`AtomicOutput::commit`]; dropped without a commit (an error half-way
/// through a program), the temporary file is removed and the destination
/// is untouched. Standard output and special files are written as the
/// data comes (see the module documentation).
pub struct AtomicOutput {
    path: PathBuf,
    sink: Option<Sink>,
}

impl AtomicOutput {
    /// Starts writing `path` (creating its directory when needed).
    pub fn create(path: &Path) -> Result<AtomicOutput, OutputError> {
        let io = OutputError::io(path);
        let sink = match classify("output", path)? {
            OutputTarget::Stdout => Sink::Stdout(BufWriter::with_capacity(1 << 16, stdout())),
            OutputTarget::InPlace(p) => {
                let f = OpenOptions::new().append(true).open(&p).map_err(&io)?;
                Sink::InPlace(BufWriter::with_capacity(1 << 16, f))
            }
            OutputTarget::File(target) => {
                ensure_not_read(path)?;
                let dir = match target.parent() {
                    Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
                    _ => PathBuf::from("."),
                };
                std::fs::create_dir_all(&dir).map_err(&io)?;
                let mode = std::fs::metadata(&target).ok().map(|m| m.permissions());
                let name = file_name_of(&target);
                remove_stale(&dir, &name);
                let (tmp, file) = loop {
                    let tmp = temp_name(&dir, &name);
                    match create_new(&tmp) {
                        Ok(f) => break (tmp, f),
                        Err(e) if e.kind() == io::ErrorKind::AlreadyExists => continue,
                        Err(e) => return Err(io(e)),
                    }
                };
                register(&tmp);
                Sink::Temp {
                    file: BufWriter::with_capacity(1 << 16, file),
                    tmp,
                    target,
                    mode,
                }
            }
        };
        Ok(AtomicOutput {
            path: path.to_path_buf(),
            sink: Some(sink),
        })
    }

    /// Completes the output: moves a regular file into place (with the mode
    /// of the file it replaces), flushes standard output or a device.
    pub fn commit(mut self) -> Result<(), OutputError> {
        let io = OutputError::io(&self.path);
        match self.sink.take().expect("committed once") {
            Sink::Stdout(mut w) => w.flush().map_err(io),
            Sink::InPlace(mut w) => w.flush().map_err(io),
            Sink::Temp {
                file,
                tmp,
                target,
                mode,
            } => {
                let done = (|| {
                    let f = file.into_inner().map_err(|e| e.into_error())?;
                    f.sync_all()?;
                    if let Some(m) = mode {
                        std::fs::set_permissions(&tmp, m)?;
                    }
                    std::fs::rename(&tmp, &target)
                })();
                if done.is_err() {
                    let _ = std::fs::remove_file(&tmp);
                }
                unregister(&tmp);
                done.map_err(io)
            }
        }
    }

    fn writer(&mut self) -> &mut dyn Write {
        match self.sink.as_mut().expect("not committed") {
            Sink::Stdout(w) => w,
            Sink::InPlace(w) => w,
            Sink::Temp { file, .. } => file,
        }
    }
}

impl Drop for AtomicOutput {
    fn drop(&mut self) {
        if let Some(Sink::Temp { tmp, .. }) = &self.sink {
            let _ = std::fs::remove_file(tmp);
            unregister(tmp);
        }
    }
}

/// A write error with what was being written and where: `-o /dev/full`
/// says more than "No space left on device".
fn writing(path: &Path, e: io::Error) -> io::Error {
    io::Error::new(
        e.kind(),
        format!("cannot write the output {}: {e}", path.display()),
    )
}

impl Write for AtomicOutput {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let r = self.writer().write(buf);
        r.map_err(|e| writing(&self.path, e))
    }

    fn write_all(&mut self, buf: &[u8]) -> io::Result<()> {
        let r = self.writer().write_all(buf);
        r.map_err(|e| writing(&self.path, e))
    }

    fn flush(&mut self) -> io::Result<()> {
        let r = self.writer().flush();
        r.map_err(|e| writing(&self.path, e))
    }
}

// ------------------------------------------------------- many files

/// A directory of outputs that appears whole or not at all: every file is
/// written into a temporary directory; [`StagedDir::commit`] then renames
/// it into place when the target does not exist yet, or moves the files
/// into the existing directory (other files there are left alone).
/// Dropped without a commit, the temporary directory is removed.
pub struct StagedDir {
    target: PathBuf,
    stage: PathBuf,
    exists: bool,
    files: Vec<PathBuf>,
    committed: bool,
}

impl StagedDir {
    /// Starts a directory output at `target`: a new directory (its parents
    /// created) or an existing one. A file, a dangling link or a device at
    /// `target` is refused with the reason.
    pub fn create(target: &Path) -> Result<StagedDir, OutputError> {
        check_dir_target("output directory", target)?;
        let io = OutputError::io(target);
        let exists = target.is_dir();
        let stage_in = if exists {
            target.to_path_buf()
        } else {
            let parent = match target.parent() {
                Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
                _ => PathBuf::from("."),
            };
            std::fs::create_dir_all(&parent).map_err(&io)?;
            parent
        };
        let name = file_name_of(target);
        remove_stale(&stage_in, &name);
        let stage = loop {
            let s = temp_name(&stage_in, &name);
            match std::fs::create_dir(&s) {
                Ok(()) => break s,
                Err(e) if e.kind() == io::ErrorKind::AlreadyExists => continue,
                Err(e) => return Err(io(e)),
            }
        };
        register(&stage);
        Ok(StagedDir {
            target: target.to_path_buf(),
            stage,
            exists,
            files: Vec::new(),
            committed: false,
        })
    }

    /// The directory the files will be in.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// Writes the file `name` (relative, no directories) of the output;
    /// returns its final path.
    pub fn write(&mut self, name: &Path, bytes: &[u8]) -> Result<PathBuf, OutputError> {
        let fin = self.target.join(name);
        if name.components().count() != 1
            || !matches!(name.components().next(), Some(Component::Normal(_)))
        {
            return Err(OutputError::WrongKind {
                flag: "output".into(),
                path: fin,
                what: "expected a plain file name inside the output directory".into(),
            });
        }
        if self.files.iter().any(|f| f == name) {
            return Err(OutputError::SameOutput {
                path: fin,
                first: "one file of the output".into(),
                second: "another".into(),
            });
        }
        ensure_not_read(&fin)?;
        let p = self.stage.join(name);
        let io = OutputError::io(&fin);
        let mut f = create_new(&p).map_err(&io)?;
        f.write_all(bytes).map_err(&io)?;
        f.sync_all().map_err(&io)?;
        if self.exists
            && let Ok(m) = std::fs::metadata(&fin)
            && m.is_file()
        {
            std::fs::set_permissions(&p, m.permissions()).map_err(&io)?;
        }
        drop(io);
        self.files.push(name.to_path_buf());
        Ok(fin)
    }

    /// Moves the complete output into place; returns the files' paths in
    /// the order they were written.
    pub fn commit(mut self) -> Result<Vec<PathBuf>, OutputError> {
        let io = OutputError::io(&self.target);
        if self.exists {
            self.move_files()?;
        } else {
            match std::fs::rename(&self.stage, &self.target) {
                Ok(()) => {}
                // Another run made the directory meanwhile (two runs into
                // one directory at once): this run's files join it, as
                // they would had it been there first.
                Err(_) if self.target.is_dir() => self.move_files()?,
                Err(e) => return Err(io(e)),
            }
        }
        unregister(&self.stage);
        self.committed = true;
        Ok(self.files.iter().map(|f| self.target.join(f)).collect())
    }
}

impl StagedDir {
    /// Moves the staged files into the existing target directory and
    /// removes the stage. Every file is complete: only renames remain.
    fn move_files(&self) -> Result<(), OutputError> {
        let io = OutputError::io(&self.target);
        for f in &self.files {
            let fin = self.target.join(f);
            if fin.is_dir() {
                return Err(OutputError::WrongKind {
                    flag: "output".into(),
                    path: fin,
                    what: "is a directory where the output has a file".into(),
                });
            }
        }
        for f in &self.files {
            std::fs::rename(self.stage.join(f), self.target.join(f)).map_err(&io)?;
        }
        std::fs::remove_dir(&self.stage).map_err(&io)
    }
}

impl Drop for StagedDir {
    fn drop(&mut self) {
        if !self.committed {
            let _ = std::fs::remove_dir_all(&self.stage);
            unregister(&self.stage);
        }
    }
}

/// `s` as one word of a POSIX shell command line, quoted only when it
/// must be: the commands fivecal suggests are pasted into a shell, and a
/// directory name with a space must stay one word.
pub fn shell_word(s: &str) -> String {
    if !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || "._-/+:=,@".contains(c))
    {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', "'\\''"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn count(dir: &Path) -> usize {
        std::fs::read_dir(dir).unwrap().count()
    }

    #[test]
    fn writes_and_refuses_inputs() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("sub/out.txt");
        write_atomic(&p, b"hello").unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "hello");
        assert!(matches!(
            ensure_not_input(&p, &[p.as_path()]),
            Err(OutputError::WouldOverwriteInput(_))
        ));
        let other = dir.path().join("other.txt");
        assert!(ensure_not_input(&other, &[p.as_path()]).is_ok());
        // No temporary files left behind.
        assert_eq!(count(&dir.path().join("sub")), 1);
    }

    #[test]
    fn nothing_appears_until_commit_and_nothing_stays_on_drop() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("out.nc");
        let mut o = AtomicOutput::create(&p).unwrap();
        o.write_all(b"G0 X1.\n").unwrap();
        assert!(!p.exists());
        drop(o);
        assert!(!p.exists());
        assert_eq!(count(dir.path()), 0);
        let mut o = AtomicOutput::create(&p).unwrap();
        o.write_all(b"G0 X1.\n").unwrap();
        o.commit().unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"G0 X1.\n");
    }

    #[cfg(unix)]
    #[test]
    fn a_replaced_file_keeps_its_mode_and_a_link_stays_a_link() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let real = dir.path().join("real.yaml");
        std::fs::write(&real, "old").unwrap();
        std::fs::set_permissions(&real, std::fs::Permissions::from_mode(0o640)).unwrap();
        let link = dir.path().join("link.yaml");
        std::os::unix::fs::symlink(&real, &link).unwrap();
        write_atomic(&link, b"new").unwrap();
        assert!(
            std::fs::symlink_metadata(&link)
                .unwrap()
                .file_type()
                .is_symlink()
        );
        assert_eq!(std::fs::read_to_string(&real).unwrap(), "new");
        let mode = std::fs::metadata(&real).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o640);
    }

    #[cfg(unix)]
    #[test]
    fn devices_are_written_in_place() {
        write_atomic(Path::new("/dev/null"), b"discarded").unwrap();
        let m = std::fs::metadata("/dev/null").unwrap();
        assert!(!m.is_file());
    }

    #[cfg(unix)]
    #[test]
    fn wrong_kinds_are_named() {
        let dir = tempfile::tempdir().unwrap();
        let e = classify("--out", dir.path()).unwrap_err().to_string();
        assert!(e.contains("is a directory"), "{e}");
        let dangling = dir.path().join("gone");
        std::os::unix::fs::symlink(dir.path().join("nowhere"), &dangling).unwrap();
        let e = classify("--out", &dangling).unwrap_err().to_string();
        assert!(e.contains("which does not exist"), "{e}");
        let file = dir.path().join("f.txt");
        std::fs::write(&file, "x").unwrap();
        let e = StagedDir::create(&file).err().unwrap().to_string();
        assert!(e.contains("is an existing file"), "{e}");
        let e = StagedDir::create(Path::new("/dev/null"))
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("device"), "{e}");
    }

    #[test]
    fn outputs_that_collide_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a.yaml");
        std::fs::write(&a, "x").unwrap();
        let b = dir.path().join("sub/../a.yaml");
        let e = check_outputs(
            &[],
            &[("--out", &a, Shape::File), ("--export-to", &b, Shape::File)],
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("--out and --export-to both name"), "{e}");
        let e = check_outputs(&[&a], &[("--out", &b, Shape::File)])
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("--out ") && e.contains("refusing to overwrite input file"),
            "{e}"
        );
        let rep = dir.path().join("rep");
        let inside = rep.join("index.html");
        assert!(
            check_outputs(
                &[],
                &[
                    ("--report", &rep, Shape::Dir),
                    ("--out", &inside, Shape::File)
                ]
            )
            .is_err()
        );
    }

    #[test]
    fn a_staged_directory_appears_whole_or_not_at_all() {
        let dir = tempfile::tempdir().unwrap();
        let t = dir.path().join("plan");
        let mut s = StagedDir::create(&t).unwrap();
        s.write(Path::new("a.txt"), b"a").unwrap();
        assert!(!t.exists());
        drop(s);
        assert!(!t.exists());
        assert_eq!(count(dir.path()), 0);
        let mut s = StagedDir::create(&t).unwrap();
        s.write(Path::new("a.txt"), b"a").unwrap();
        s.write(Path::new("b.txt"), b"b").unwrap();
        let files = s.commit().unwrap();
        assert_eq!(files.len(), 2);
        assert_eq!(count(&t), 2);
        // Into an existing directory: its other files stay.
        std::fs::write(t.join("mine.txt"), "keep").unwrap();
        let mut s = StagedDir::create(&t).unwrap();
        s.write(Path::new("a.txt"), b"A").unwrap();
        assert_eq!(std::fs::read_to_string(t.join("a.txt")).unwrap(), "a");
        s.commit().unwrap();
        assert_eq!(std::fs::read_to_string(t.join("a.txt")).unwrap(), "A");
        assert_eq!(std::fs::read_to_string(t.join("mine.txt")).unwrap(), "keep");
        assert_eq!(count(&t), 3);
    }
}
