//! Edits to one block: replaced byte ranges and inserted text, applied in
//! one pass when the block is written. Everything not edited is copied
//! byte for byte.

use std::io::{self, Write};

use crate::nc::lexeme::{self, NumStyle, WriteRules};
use crate::nc::{Block, Span};

#[derive(Clone, Copy, Debug)]
struct Edit {
    start: u32,
    end: u32,
    text: (u32, u32),
    seq: u32,
    /// A number written in place of `text` when the block is written
    /// (by the thread that writes it: formatting is a good part of the
    /// rewrite's cost).
    num: Option<Number>,
}

/// A number to write: value, decimals and style.
#[derive(Clone, Copy, Debug)]
struct Number {
    value: f64,
    decimals: u8,
    style: NumStyle,
    rules: WriteRules,
}

/// The edits of one block (buffers are reused from block to block).
#[derive(Default, Debug)]
pub(super) struct Edits {
    items: Vec<Edit>,
    buf: Vec<u8>,
    /// Where numbers are formatted when the block is written.
    scratch: Vec<u8>,
}

impl Edits {
    /// Forgets all edits.
    pub(super) fn clear(&mut self) {
        self.items.clear();
        self.buf.clear();
    }

    /// Whether there are none.
    pub(super) fn is_empty(&self) -> bool {
        self.items.is_empty()
    }

    /// Replaces `span` with what `f` writes.
    pub(super) fn replace(&mut self, span: Span, f: impl FnOnce(&mut Vec<u8>)) {
        let a = self.buf.len() as u32;
        f(&mut self.buf);
        let b = self.buf.len() as u32;
        let seq = self.items.len() as u32;
        self.items.push(Edit {
            start: span.start,
            end: span.end,
            text: (a, b),
            seq,
            num: None,
        });
    }

    /// Replaces `span` with `value` as [`lexeme::write`] writes it.
    pub(super) fn replace_number(
        &mut self,
        span: Span,
        value: f64,
        decimals: u8,
        style: NumStyle,
        rules: WriteRules,
    ) {
        let seq = self.items.len() as u32;
        self.items.push(Edit {
            start: span.start,
            end: span.end,
            text: (0, 0),
            seq,
            num: Some(Number {
                value,
                decimals,
                style,
                rules,
            }),
        });
    }

    /// Inserts what `f` writes at byte `at` (after earlier insertions at the
    /// same place).
    pub(super) fn insert(&mut self, at: u32, f: impl FnOnce(&mut Vec<u8>)) {
        self.replace(Span { start: at, end: at }, f);
    }

    /// Deletes `span`.
    pub(crate) fn delete(&mut self, span: Span) {
        self.replace(span, |_| {});
    }

    /// Writes the block with the edits applied.
    pub(crate) fn write_block<W: Write>(&mut self, block: &Block, out: &mut W) -> io::Result<()> {
        self.sort();
        apply(&self.items, &self.buf, block, out, &mut self.scratch)
    }

    fn sort(&mut self) {
        self.items
            .sort_unstable_by_key(|e| (e.start, e.end != e.start, e.seq));
    }
}

/// `block` with `items` (sorted, their text in `buf`) applied; numbers
/// are formatted in `scratch`.
fn apply<W: Write>(
    items: &[Edit],
    buf: &[u8],
    block: &Block,
    out: &mut W,
    scratch: &mut Vec<u8>,
) -> io::Result<()> {
    if items.is_empty() {
        return out.write_all(&block.text);
    }
    let mut at = 0usize;
    for e in items {
        let (s, t) = (e.start as usize, e.end as usize);
        if s < at {
            // Overlapping edits would be a bug upstream; never lose text.
            continue;
        }
        out.write_all(&block.text[at..s])?;
        match e.num {
            Some(n) => {
                scratch.clear();
                lexeme::write(scratch, n.value, n.decimals, &n.style, n.rules);
                out.write_all(scratch)?;
            }
            None => out.write_all(&buf[e.text.0 as usize..e.text.1 as usize])?,
        }
        at = t;
    }
    out.write_all(&block.text[at..])
}

/// The edits of a run of blocks, kept to be applied by whoever writes the
/// blocks: the thread that reads them has the time, the one that rewrites
/// them has not.
#[derive(Default, Debug)]
pub(super) struct Deferred {
    items: Vec<Edit>,
    buf: Vec<u8>,
    /// Per block, in order: its items, or `None` when it is not written
    /// here (kept for the macro logic, written after the last block).
    blocks: Vec<Option<(u32, u32)>>,
}

impl Deferred {
    /// Forgets everything.
    pub(super) fn clear(&mut self) {
        self.items.clear();
        self.buf.clear();
        self.blocks.clear();
    }

    /// The next block is written with `e` (which is cleared).
    pub(super) fn take(&mut self, e: &mut Edits) {
        e.sort();
        let first = self.items.len() as u32;
        let base = self.buf.len() as u32;
        self.buf.extend_from_slice(&e.buf);
        self.items.extend(e.items.iter().map(|x| Edit {
            text: (x.text.0 + base, x.text.1 + base),
            ..*x
        }));
        self.blocks.push(Some((first, self.items.len() as u32)));
        e.clear();
    }

    /// The next block is not written here.
    pub(super) fn hold(&mut self) {
        self.blocks.push(None);
    }

    /// Writes block `k` (the `k`-th given to [`Self::take`] or
    /// [`Self::hold`]), which is `block`, unless it was held.
    pub(super) fn write_block<W: Write>(
        &self,
        k: usize,
        block: &Block,
        out: &mut W,
        scratch: &mut Vec<u8>,
    ) -> io::Result<()> {
        match self.blocks.get(k) {
            Some(Some((a, b))) => apply(
                &self.items[*a as usize..*b as usize],
                &self.buf,
                block,
                out,
                scratch,
            ),
            _ => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn replaces_inserts_and_deletes_in_order() {
        let block = Block {
            text: b"G1 X1. Y2.\n".to_vec(),
            ..Default::default()
        };
        let mut e = Edits::default();
        e.replace(Span { start: 4, end: 6 }, |b| b.extend_from_slice(b"1.5"));
        e.insert(10, |b| b.extend_from_slice(b" Z3."));
        e.insert(10, |b| b.extend_from_slice(b" C4."));
        e.delete(Span { start: 0, end: 3 });
        let mut out = Vec::new();
        e.write_block(&block, &mut out).unwrap();
        assert_eq!(String::from_utf8(out).unwrap(), "X1.5 Y2. Z3. C4.\n");
    }

    /// Deferred, the same edits give the same text, each block its own.
    #[test]
    fn deferred_edits_write_each_block_as_at_once() {
        let blocks = ["G1 X1. Y2.\n", "M5\n", "#1=2\n", "G0 Z5.\n"].map(|t| Block {
            text: t.as_bytes().to_vec(),
            ..Default::default()
        });
        let mut d = Deferred::default();
        let mut e = Edits::default();
        e.insert(10, |b| b.extend_from_slice(b" C4."));
        e.replace(Span { start: 4, end: 6 }, |b| b.extend_from_slice(b"1.5"));
        d.take(&mut e);
        assert!(e.is_empty());
        d.take(&mut e);
        d.hold();
        let style = lexeme::read(b"5.").style;
        let rules = WriteRules {
            force_point: true,
            force_plus: false,
        };
        e.replace_number(Span { start: 4, end: 6 }, 4.25, 3, style, rules);
        d.take(&mut e);
        let mut out = Vec::new();
        for (k, b) in blocks.iter().enumerate() {
            d.write_block(k, b, &mut out, &mut Vec::new()).unwrap();
        }
        assert_eq!(
            String::from_utf8(out).unwrap(),
            "G1 X1.5 Y2. C4.\nM5\nG0 Z4.25\n"
        );
    }
}
