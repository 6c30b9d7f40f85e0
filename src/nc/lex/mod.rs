//! Tokenizing a block in its dialect: [`word_address`] for FANUC and
//! LinuxCNC (with their macro languages), [`klartext`] for HEIDENHAIN,
//! [`sinumerik`] for SINUMERIK.

pub(crate) mod klartext;
pub(crate) mod sinumerik;
pub(crate) mod word_address;

use super::{Block, BlockError};
use crate::machine::Dialect;

/// Parser settings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Syntax {
    /// The dialect.
    pub dialect: Dialect,
    /// Reject words and codes this parser does not know instead of keeping
    /// them verbatim.
    pub strict: bool,
}

impl Syntax {
    /// The block of one line of text (line 1), tokenized: what the unit
    /// tests of the lexers and the writer start from.
    #[cfg(test)]
    pub(crate) fn block(&self, text: &str) -> Result<Block, BlockError> {
        let mut b = Block {
            text: text.as_bytes().to_vec(),
            line: 1,
            ..Default::default()
        };
        self.parse(&mut b)?;
        Ok(b)
    }

    /// Tokenizes `block.text` into `block.tokens` and `block.segments`.
    pub fn parse(&self, block: &mut Block) -> Result<(), BlockError> {
        block.tokens.clear();
        block.segments.clear();
        // The lexers read the text while they push tokens into the block.
        let text = std::mem::take(&mut block.text);
        let r = match self.dialect {
            Dialect::Fanuc | Dialect::Linuxcnc => word_address::parse_text(self, &text, block),
            Dialect::Heidenhain => klartext::parse_text(self, &text, block),
            Dialect::Sinumerik => sinumerik::parse_text(self, &text, block),
        };
        block.text = text;
        r?;
        debug_assert!(covers(block), "tokens must cover the block exactly");
        Ok(())
    }
}

/// The UTF-8 byte order mark some editors put at the start of a file.
pub(crate) const BOM: &[u8] = b"\xEF\xBB\xBF";

/// DOS's end-of-file mark.
pub(crate) const DOS_EOF: u8 = 0x1A;

/// A one-line block split into its body and line ending (`\r\n`, `\n`
/// or a bare `\r`): the body's length and the ending's. A line break
/// inside the body is an error.
pub(crate) fn split_line_end(s: &[u8]) -> Result<(usize, usize), BlockError> {
    let le = if s.ends_with(b"\r\n") {
        2
    } else if s.ends_with(b"\n") || s.ends_with(b"\r") {
        1
    } else {
        0
    };
    let n = s.len() - le;
    match memchr::memchr(b'\n', &s[..n]) {
        Some(p) => Err(BlockError::new(p, "unexpected line break")),
        None => Ok((n, le)),
    }
}

/// A number beyond the range of any controller (and of a 64-bit float).
pub(crate) fn too_large(offset: usize, lexeme: &[u8]) -> BlockError {
    let shown = if lexeme.len() > 24 {
        format!(
            "{}... ({} digits)",
            String::from_utf8_lossy(&lexeme[..20]),
            lexeme.len()
        )
    } else {
        String::from_utf8_lossy(lexeme).to_string()
    };
    BlockError::new(
        offset,
        format!("number `{shown}` is too large to be a coordinate, feed or parameter"),
    )
}

fn covers(block: &Block) -> bool {
    let mut at = 0u32;
    for t in &block.tokens {
        if t.span.start != at || t.span.end < t.span.start {
            return false;
        }
        at = t.span.end;
    }
    at as usize == block.text.len()
}
