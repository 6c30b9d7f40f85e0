//! Reading a program one block at a time: the raw text of each block
//! ([`BlockReader`]) and the tokenized blocks with malformed ones reported
//! by file, line and column ([`Blocks`]), which also refuse a program whose
//! text shows another dialect than the one it is read in
//! ([`super::dialect`]).

use std::io::{self, BufRead};
use std::path::{Path, PathBuf};

#[cfg(doc)]
use super::Stmt;
use super::dialect::{Clue, Evidence};
use super::{Block, Syntax};
use crate::machine::Dialect;
use crate::source::SourceError;

/// Reads blocks from a buffered reader: a line with its line ending (LF,
/// CRLF, or a bare CR as old Mac files end their lines); on HEIDENHAIN also
/// the lines a trailing `~` continues onto. Memory use is one block,
/// whatever the file size.
pub struct BlockReader<R> {
    input: R,
    dialect: Dialect,
    next_line: usize,
}

impl<R: BufRead> BlockReader<R> {
    /// A reader of `dialect` blocks.
    pub fn new(input: R, dialect: Dialect) -> BlockReader<R> {
        BlockReader {
            input,
            dialect,
            next_line: 1,
        }
    }

    /// Reads the next block's text into `block` (tokens are left to the
    /// parser); `false` at the end of the input.
    pub fn read(&mut self, block: &mut Block) -> io::Result<bool> {
        block.text.clear();
        block.line = self.next_line;
        loop {
            let start = block.text.len();
            let n = read_line(&mut self.input, &mut block.text)?;
            if n == 0 {
                break;
            }
            self.next_line += 1;
            if self.dialect != Dialect::Heidenhain || !continues(&block.text[start..]) {
                break;
            }
        }
        Ok(!block.text.is_empty())
    }
}

/// Why the next block could not be had.
#[derive(Debug)]
pub enum ReadError {
    /// The input could not be read.
    Io(io::Error),
    /// A malformed block: file, line, column and what was expected.
    Syntax(SourceError),
}

/// A program as a stream of tokenized blocks (one in memory at a time).
pub struct Blocks<R> {
    reader: BlockReader<R>,
    syntax: Syntax,
    path: PathBuf,
    block: Block,
    evidence: Evidence,
    count: usize,
    /// Blocks that could not be read (outside `strict`), and the first
    /// of them: line, column, why.
    unreadable: usize,
    first_unreadable: Option<(usize, usize, String)>,
}

impl<R: BufRead> Blocks<R> {
    /// The blocks of `input` (named `path` in errors) in `syntax`.
    pub fn new(path: &Path, input: R, syntax: Syntax) -> Blocks<R> {
        Blocks {
            reader: BlockReader::new(input, syntax.dialect),
            syntax,
            path: path.to_path_buf(),
            block: Block::default(),
            evidence: Evidence::default(),
            count: 0,
            unreadable: 0,
            first_unreadable: None,
        }
    }

    /// Refused when the text read shows another dialect than the one it
    /// is read in (a sign of that one and none of its own), or when it
    /// had no move at all (`moves`, counted by the caller) and nothing
    /// shows its dialect: a program read in the wrong dialect is never
    /// passed through as a copy of itself. A program that shows its
    /// dialect and moves no axis itself (tool changes, calls of
    /// subprograms and macros) is no error: the note says so.
    pub fn finish(&self, moves: usize) -> Result<Option<String>, SourceError> {
        let d = self.syntax.dialect;
        if let Some(c) = self.evidence.other_than(d) {
            return Err(self.mismatch(c));
        }
        if moves == 0
            && d == Dialect::Heidenhain
            && let Some((line, word)) = self.evidence.iso()
        {
            // Plain G-code shows no one G-code dialect, but it is not Klartext.
            return Err(SourceError::new(
                &self.path,
                line,
                0,
                format!(
                    "this is a G-code program (`{word}`: FANUC or LinuxCNC), not heidenhain: no motion block of it is understood as heidenhain; read it as fanuc or linuxcnc (--dialect fanuc or --dialect linuxcnc)"
                ),
            ));
        }
        if moves == 0 {
            return Err(SourceError::new(
                &self.path,
                0,
                0,
                if self.count == 0 {
                    "the program is empty: no motion block to work on".to_string()
                } else if let Some((line, column, why)) = &self.first_unreadable {
                    format!(
                        "no motion block understood in its {} blocks read as {d}: {} could not be read (the first at line {line}, column {column}: {why}); nothing to compensate",
                        self.count, self.unreadable
                    )
                } else if let Some(own) = self.evidence.clue(d) {
                    // The right dialect: the program just makes no move
                    // itself (tool changes, macro or subprogram calls).
                    return Ok(Some(format!(
                        "no motion block in its {} blocks, which read as {d} (the text shows it: `{}` at line {}): it moves no axis itself; moves made by the subprograms or macros it calls are in those programs",
                        self.count, own.sign, own.line
                    )));
                } else {
                    format!(
                        "no motion block understood in its {} blocks read as {d}: a program for another controller? (--dialect fanuc, heidenhain, linuxcnc or sinumerik)",
                        self.count
                    )
                },
            ));
        }
        Ok(None)
    }

    fn mismatch(&self, c: &Clue) -> SourceError {
        SourceError::new(
            &self.path,
            c.line,
            0,
            format!(
                "this is a {} program (`{}`), not {}: read it as {} (--dialect {})",
                c.dialect, c.sign, self.syntax.dialect, c.dialect, c.dialect
            ),
        )
    }

    /// As [`Blocks::next_block`], into `out`: `false` at the end of the
    /// input. The buffers `out` had are kept for a later block, so reading
    /// a program into a few recycled blocks allocates nothing per block.
    pub(crate) fn next_into(&mut self, out: &mut Block) -> Result<bool, ReadError> {
        let read = self.next_block()?.is_some();
        if read {
            std::mem::swap(&mut self.block, out);
        }
        Ok(read)
    }

    /// Reads and tokenizes the next block; `None` at the end of the input.
    /// A block that cannot be read is an error under `strict`; otherwise
    /// it comes back as one [`Stmt::Unreadable`] statement that keeps its
    /// text, with [`Block::unreadable`] saying why.
    pub fn next_block(&mut self) -> Result<Option<&Block>, ReadError> {
        self.block.unreadable = None;
        let read =
            self.reader.read(&mut self.block).map_err(
                |e| match crate::input::LineError::located(&self.path, &e) {
                    Some(located) => ReadError::Syntax(located),
                    None => ReadError::Io(e),
                },
            )?;
        if !read {
            return Ok(None);
        }
        self.count += 1;
        self.evidence.observe(&self.block.text, self.block.line);
        if let Err(e) = self.syntax.parse(&mut self.block) {
            if !self.syntax.strict {
                self.unreadable += 1;
                if self.first_unreadable.is_none() {
                    let (line, column) = self.block.locate(e.offset);
                    self.first_unreadable = Some((line, column, e.message.clone()));
                }
                self.block.make_unreadable(e);
                return Ok(Some(&self.block));
            }
            // A block of another dialect is that dialect's, not a typo.
            if let Some(c) = self.evidence.other_than(self.syntax.dialect) {
                return Err(ReadError::Syntax(self.mismatch(c)));
            }
            let (line, column) = self.block.locate(e.offset);
            return Err(ReadError::Syntax(SourceError::new(
                &self.path, line, column, e.message,
            )));
        }
        Ok(Some(&self.block))
    }
}

/// Appends one line of `input` with its ending (`\n`, `\r\n` or a bare
/// `\r`) to `out`; the number of bytes, 0 at the end of the input. A file
/// whose lines end in a bare CR is read line by line as well, not as one
/// block of the whole file.
fn read_line<R: BufRead>(input: &mut R, out: &mut Vec<u8>) -> io::Result<usize> {
    let mut n = 0;
    loop {
        let buf = match input.fill_buf() {
            Ok(b) => b,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        };
        if buf.is_empty() {
            return Ok(n);
        }
        let Some(i) = memchr::memchr2(b'\n', b'\r', buf) else {
            let len = buf.len();
            out.extend_from_slice(buf);
            input.consume(len);
            n += len;
            continue;
        };
        let cr = buf[i] == b'\r';
        out.extend_from_slice(&buf[..=i]);
        input.consume(i + 1);
        n += i + 1;
        if cr {
            // The LF of a CRLF may start the next buffer.
            let next = loop {
                match input.fill_buf() {
                    Ok(b) => break b,
                    Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                    Err(e) => return Err(e),
                }
            };
            if next.first() == Some(&b'\n') {
                out.push(b'\n');
                input.consume(1);
                n += 1;
            }
        }
        return Ok(n);
    }
}

/// Whether a HEIDENHAIN line ends with `~` (before spaces and its ending).
fn continues(line: &[u8]) -> bool {
    let mut end = line.len();
    while end > 0 && matches!(line[end - 1], b'\n' | b'\r' | b' ' | b'\t') {
        end -= 1;
    }
    end > 0 && line[end - 1] == b'~' && matches!(line.last(), Some(b'\n' | b'\r'))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn blocks(src: &str, d: Dialect) -> Vec<(usize, String)> {
        let mut r = BlockReader::new(src.as_bytes(), d);
        let mut b = Block::default();
        let mut out = Vec::new();
        while r.read(&mut b).unwrap() {
            out.push((b.line, String::from_utf8(b.text.clone()).unwrap()));
        }
        out
    }

    #[test]
    fn lines_keep_their_endings_and_the_last_may_have_none() {
        let got = blocks("G0 X1\r\nG1 X2\nM30", Dialect::Fanuc);
        assert_eq!(
            got,
            vec![
                (1, "G0 X1\r\n".to_string()),
                (2, "G1 X2\n".to_string()),
                (3, "M30".to_string())
            ]
        );
    }

    #[test]
    fn a_bare_cr_ends_a_line_as_old_mac_files_write_them() {
        // Read as one block of the whole file before: nothing moved.
        let got = blocks("%\rG0 X1.\rG1 X2.\r\nM30\r", Dialect::Fanuc);
        assert_eq!(
            got,
            vec![
                (1, "%\r".to_string()),
                (2, "G0 X1.\r".to_string()),
                (3, "G1 X2.\r\n".to_string()),
                (4, "M30\r".to_string())
            ]
        );
        // A CRLF whose LF starts the reader's next buffer is one ending.
        let src = b"G0 X1.\r\nG1 X2.\r";
        let mut r = BlockReader::new(io::BufReader::with_capacity(7, &src[..]), Dialect::Fanuc);
        let mut b = Block::default();
        let mut got = Vec::new();
        while r.read(&mut b).unwrap() {
            got.push((b.line, b.text.clone(), b.line_ending()));
        }
        assert_eq!(
            got,
            vec![
                (1, b"G0 X1.\r\n".to_vec(), Some(&b"\r\n"[..])),
                (2, b"G1 X2.\r".to_vec(), Some(&b"\r"[..]))
            ]
        );
        // HEIDENHAIN continuation lines in a CR file, located by line.
        let src = "5 CYCL DEF 200 DRILLING ~\r  Q200=+2 ~\r  Q201=-20\r6 L Z+100 R0 FMAX\r";
        let got = blocks(src, Dialect::Heidenhain);
        assert_eq!(got.len(), 2);
        assert_eq!((got[0].0, got[1].0), (1, 4));
        let mut b = Block {
            text: got[0].1.as_bytes().to_vec(),
            line: 1,
            ..Block::default()
        };
        let at = got[0].1.find("Q201").unwrap();
        assert_eq!(b.locate(at), (3, 3));
        b.text = b"G1 X1.\r\nX2.".to_vec();
        assert_eq!(b.locate(8), (2, 1));
    }

    #[test]
    fn heidenhain_continuation_lines_join_their_block() {
        let src = "5 CYCL DEF 200 DRILLING ~\n  Q200=+2 ;SET-UP CLEARANCE ~\n  Q201=-20 ;DEPTH\n6 L Z+100 R0 FMAX\n";
        let got = blocks(src, Dialect::Heidenhain);
        assert_eq!(got.len(), 2);
        assert_eq!(got[0].0, 1);
        assert_eq!(got[1].0, 4);
        assert!(got[0].1.ends_with("DEPTH\n"));
    }
}
