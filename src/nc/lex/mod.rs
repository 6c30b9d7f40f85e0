//! Tokenizing a block in its dialect: [`word_address`] for FANUC and
//! LinuxCNC (with their macro languages), [`klartext`] for HEIDENHAIN.

pub mod klartext;
pub mod word_address;

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
    /// Tokenizes `block.text` into `block.tokens` and `block.segments`.
    pub fn parse(&self, block: &mut Block) -> Result<(), BlockError> {
        block.tokens.clear();
        block.segments.clear();
        match self.dialect {
            Dialect::Fanuc | Dialect::Linuxcnc => word_address::parse(self, block),
            Dialect::Heidenhain => klartext::parse(self, block),
        }?;
        debug_assert!(covers(block), "tokens must cover the block exactly");
        Ok(())
    }
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
