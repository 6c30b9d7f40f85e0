//! File output that never leaves a half-written file and never overwrites an
//! input: everything is written to a temporary file in the destination
//! directory and renamed into place once complete.

use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

/// Errors of the output helpers.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// The output path names one of the inputs of the same run.
    #[error("refusing to overwrite input file {0}")]
    WouldOverwriteInput(PathBuf),
    /// Any I/O failure, with the path.
    #[error("cannot write {path}: {cause}")]
    Io {
        /// The destination.
        path: PathBuf,
        /// The cause (in the message, not chained, so it prints once).
        cause: std::io::Error,
    },
}

fn same_file(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(x), Ok(y)) => x == y,
        _ => false,
    }
}

/// Fails when `out` is one of `inputs` (compared after resolving links).
pub fn ensure_not_input(out: &Path, inputs: &[&Path]) -> Result<(), OutputError> {
    if inputs.iter().any(|i| same_file(out, i)) {
        return Err(OutputError::WouldOverwriteInput(out.to_path_buf()));
    }
    Ok(())
}

/// Writes `bytes` to `path` atomically (temporary file + rename), creating
/// the parent directory when needed.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    let mut out = AtomicOutput::create(path)?;
    out.write_all(bytes).map_err(|cause| OutputError::Io {
        path: path.to_path_buf(),
        cause,
    })?;
    out.commit()
}

/// Streaming output that appears only when complete: written to a
/// temporary file next to the destination and renamed into place by
/// [`AtomicOutput::commit`]. Dropped without a commit (an error half-way
/// through a program), the temporary file is removed and nothing is left
/// at the destination: for output too large to hold in memory.
pub struct AtomicOutput {
    path: PathBuf,
    file: BufWriter<tempfile::NamedTempFile>,
}

impl AtomicOutput {
    /// Starts writing `path` (creating its directory when needed).
    pub fn create(path: &Path) -> Result<AtomicOutput, OutputError> {
        let io = |cause| OutputError::Io {
            path: path.to_path_buf(),
            cause,
        };
        let dir = match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        std::fs::create_dir_all(&dir).map_err(io)?;
        let tmp = tempfile::NamedTempFile::new_in(&dir).map_err(io)?;
        Ok(AtomicOutput {
            path: path.to_path_buf(),
            file: BufWriter::with_capacity(1 << 16, tmp),
        })
    }

    /// Moves the complete file into place.
    pub fn commit(self) -> Result<(), OutputError> {
        let io = |cause| OutputError::Io {
            path: self.path.clone(),
            cause,
        };
        let tmp = self.file.into_inner().map_err(|e| io(e.into_error()))?;
        tmp.as_file().sync_all().map_err(io)?;
        tmp.persist(&self.path).map_err(|e| io(e.error))?;
        Ok(())
    }
}

impl Write for AtomicOutput {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.file.write(buf)
    }

    fn write_all(&mut self, buf: &[u8]) -> io::Result<()> {
        self.file.write_all(buf)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.file.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
        let n = std::fs::read_dir(dir.path().join("sub")).unwrap().count();
        assert_eq!(n, 1);
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
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        let mut o = AtomicOutput::create(&p).unwrap();
        o.write_all(b"G0 X1.\n").unwrap();
        o.commit().unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"G0 X1.\n");
    }
}
