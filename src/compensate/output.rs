//! Streaming output that appears only when complete: the program is
//! written to a temporary file next to the destination and renamed into
//! place by [`AtomicOutput::commit`]. Dropped without a commit (an error
//! half-way through a program), the temporary file is removed and nothing
//! is left at the destination. This is `fivecal::io::write_atomic` for
//! output too large to hold in memory.

use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

use crate::io::OutputError;

/// A destination file being written.
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
