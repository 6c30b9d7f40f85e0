//! LinuxCNC subroutine files. `o<name> call` of a subroutine the program
//! does not define runs the file `name.ngc` (its `o<name> sub` ..
//! `o<name> endsub`), which LinuxCNC looks for in its `PROGRAM_PREFIX`
//! directory and then in each `SUBROUTINE_PATH` directory, in order
//! (LinuxCNC's o-code manual, "Calling Files"; rs274ngc's
//! `find_ngc_file`). fivecal looks beside the program it is given (the
//! place of `PROGRAM_PREFIX`), then in each `--subroutine-path`
//! directory, in order, and appends the files found to the program's
//! blocks, so that the macro logic runs the calls with their arguments
//! bound and the state they leave ([`crate::nc::exec::run_with`]). A
//! file called from a file found is looked for the same way.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use crate::machine::Dialect;
use crate::nc::exec::{call_label, sub_label, subroutine_file};
use crate::nc::{Block, Blocks, ReadError, Syntax};
use crate::source::SourceError;

/// At most this many subroutine files are read for one program: a
/// library larger than this is not something a run should pull in
/// unasked.
const MAX_FILES: usize = 256;

/// A subroutine file appended to the program's blocks.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct File {
    /// The label its calls name (`o<name>`).
    pub label: String,
    /// Where it was found.
    pub path: PathBuf,
    /// Its first block among the blocks run.
    pub first: usize,
}

/// The subroutine files of a program.
#[derive(Clone, Debug, Default, PartialEq)]
pub(super) struct Library {
    /// Blocks of the program itself; the files' follow.
    pub main: usize,
    /// The files, in the order their blocks are appended.
    pub files: Vec<File>,
}

impl Library {
    /// The file block `b` belongs to (`None`: the program's own).
    pub(super) fn file_of(&self, b: usize) -> Option<&File> {
        if b < self.main {
            return None;
        }
        self.files.iter().rev().find(|f| f.first <= b)
    }
}

/// Appends to `blocks` (the program named `caller`, read in `syntax`)
/// the subroutine file of every call whose subroutine it does not
/// define, found beside it or in `dirs`; a call whose file is not found
/// is left to the macro logic, which stops there and names the file.
pub(super) fn load(
    syntax: Syntax,
    caller: &Path,
    dirs: &[PathBuf],
    blocks: &mut Vec<Block>,
) -> Result<Library, SourceError> {
    let mut lib = Library {
        main: blocks.len(),
        files: Vec::new(),
    };
    if syntax.dialect != Dialect::Linuxcnc {
        return Ok(lib);
    }
    let beside = match caller.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let mut places = vec![beside];
    places.extend(dirs.iter().cloned());
    let mut defined: HashSet<String> = HashSet::new();
    let mut tried: HashSet<String> = HashSet::new();
    let mut scanned = 0;
    loop {
        let mut wanted = Vec::new();
        for block in &blocks[scanned..] {
            for seg in &block.segments {
                if let Some(l) = sub_label(block, seg) {
                    defined.insert(l);
                } else if let Some(l) = call_label(block, seg) {
                    wanted.push(l);
                }
            }
        }
        scanned = blocks.len();
        let mut added = false;
        for label in wanted {
            if defined.contains(&label) || !tried.insert(label.clone()) {
                continue;
            }
            let Some(name) = subroutine_file(&label) else {
                continue;
            };
            // Whatever stands at the name is what LinuxCNC would open: a
            // FIFO, device or directory there is refused by its type
            // (`read`), not passed over as missing.
            let Some(path) = places.iter().map(|d| d.join(&name)).find(|p| p.exists()) else {
                continue;
            };
            if lib.files.len() >= MAX_FILES {
                return Err(SourceError::new(
                    &path,
                    0,
                    0,
                    format!("more than {MAX_FILES} subroutine files called: not followed"),
                ));
            }
            let first = blocks.len();
            read(syntax, &path, blocks)?;
            let defines = blocks[first..].iter().any(|b| {
                b.segments
                    .iter()
                    .any(|s| sub_label(b, s).as_deref() == Some(&label))
            });
            if !defines {
                // LinuxCNC stops here too: the file it opened has no sub.
                return Err(SourceError::new(
                    &path,
                    0,
                    0,
                    format!(
                        "the program calls {label}, and this file, which LinuxCNC would run for it, defines no `{label} sub`"
                    ),
                ));
            }
            lib.files.push(File { label, path, first });
            added = true;
        }
        if !added {
            return Ok(lib);
        }
    }
}

/// The largest subroutine file read, bytes: its blocks are held in
/// memory with the program's, unlike the program itself, which streams.
const MAX_FILE_BYTES: u64 = 16 << 20;

/// Reads the blocks of the file `path` onto `blocks`. As every input: a
/// FIFO or device is refused by its type before it is opened (a FIFO
/// without a writer would block the open for ever), a file beyond
/// [`MAX_FILE_BYTES`] by its size, a line without end at its line.
fn read(syntax: Syntax, path: &Path, blocks: &mut Vec<Block>) -> Result<(), SourceError> {
    let what = "LinuxCNC subroutine file";
    let input = crate::input::open_stream(path, what)?;
    let size = std::fs::metadata(path).map_or(0, |m| m.len());
    if size > MAX_FILE_BYTES {
        return Err(SourceError::new(
            path,
            0,
            0,
            format!(
                "{size} bytes, more than the {} MiB read for a {what}",
                MAX_FILE_BYTES >> 20
            ),
        ));
    }
    let mut reader = Blocks::new(path, input, syntax);
    let mut block = Block::default();
    loop {
        match reader.next_into(&mut block) {
            Ok(true) => blocks.push(block.clone()),
            Ok(false) => return Ok(()),
            Err(ReadError::Io(e)) => {
                return Err(crate::input::LineError::located(path, &e)
                    .unwrap_or_else(|| SourceError::new(path, 0, 0, format!("cannot read: {e}"))));
            }
            Err(ReadError::Syntax(e)) => return Err(e),
        }
    }
}
