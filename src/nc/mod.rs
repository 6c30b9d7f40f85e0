//! NC programs as a lossless concrete syntax tree, for FANUC (ISO G-code
//! with Custom Macro B), LinuxCNC (rs274ngc), HEIDENHAIN Klartext and
//! SINUMERIK.
//!
//! A program is read one *block* at a time (a line; on HEIDENHAIN a line
//! plus the lines its `~` continues onto), so memory does not grow with the
//! file. Every byte of a block belongs to exactly one [`Token`]: spaces,
//! comments, line endings (LF, CRLF or a bare CR, or none at the end of a
//! file without a trailing newline), block numbers, block delete, `%`, FANUC's `;` end of
//! block, words with their value lexeme, macro and o-word statements,
//! expressions. Printing an unchanged block writes its tokens back, so the
//! text is reproduced byte for byte; a rewrite replaces only the value
//! lexemes it changes (see `lexeme` for how they keep their style).
//!
//! One file per dialect does the tokenizing (`lex`); [`interp`] is the
//! one interpreter `compensate` and `simulate nc` share: what the
//! controller has in force at each block (units, G90/G91, motion mode,
//! feed mode, work offset, tool length compensation, TCP, tilted working
//! plane, datum shifts) and where each move goes.

pub mod dialect;
pub(crate) mod exec;
pub(crate) mod expr;
mod g_codes;
pub mod interp;
pub(crate) mod lex;
pub(crate) mod lexeme;
mod reader;

use std::fmt;

pub use lex::Syntax;
pub use reader::{BlockReader, Blocks, ReadError};

/// A byte range inside a block's text.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Span {
    /// First byte.
    pub start: u32,
    /// One past the last byte.
    pub end: u32,
}

impl Span {
    /// The span `[start, end)`.
    pub fn new(start: usize, end: usize) -> Span {
        Span {
            start: start as u32,
            end: end as u32,
        }
    }

    /// As a range.
    pub fn range(self) -> std::ops::Range<usize> {
        self.start as usize..self.end as usize
    }

    /// Whether it is empty.
    pub fn is_empty(self) -> bool {
        self.start == self.end
    }
}

/// A word address of up to four letters (`X`, `G`, `PA`, `FMAX`, ...),
/// upper case, packed into an integer so comparisons are cheap.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub struct Addr(pub u32);

impl Addr {
    /// The address spelled by `s` (at most four ASCII letters).
    pub const fn new(s: &str) -> Addr {
        let b = s.as_bytes();
        let mut v = 0u32;
        let mut i = 0;
        while i < 4 {
            v <<= 8;
            if i < b.len() {
                v |= b[i].to_ascii_uppercase() as u32;
            }
            i += 1;
        }
        Addr(v)
    }

    /// A one-letter address.
    pub const fn letter(c: u8) -> Addr {
        Addr((c.to_ascii_uppercase() as u32) << 24)
    }

    /// The single letter of a one-letter address.
    pub(crate) fn as_letter(self) -> Option<u8> {
        (self.0 & 0x00ff_ffff == 0).then_some((self.0 >> 24) as u8)
    }
}

impl fmt::Display for Addr {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for k in (0..4).rev() {
            let c = ((self.0 >> (8 * k)) & 0xff) as u8;
            if c != 0 {
                write!(f, "{}", c as char)?;
            }
        }
        Ok(())
    }
}

/// The value of a word.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Value {
    /// A literal number.
    Num(f64),
    /// An expression or parameter (`[#1+2]`, `#5061`, `Q12`): not evaluated.
    Expr,
    /// No value (`FMAX`, `R0`, `DR+`, `RL`).
    None,
}

/// An address word.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Word {
    /// The address, upper case.
    pub addr: Addr,
    /// HEIDENHAIN's `I` prefix (`IX-2`): incremental.
    pub incremental: bool,
    /// The value.
    pub value: Value,
    /// Where the value's lexeme is (empty for [`Value::None`]).
    pub value_span: Span,
    /// How a literal value is written (default otherwise).
    pub style: lexeme::NumStyle,
}

/// What a token is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TokenKind {
    /// Spaces and tabs.
    Space,
    /// `\n`, `\r\n` or a bare `\r`.
    LineEnd,
    /// `( ... )`, or `; ...` where `;` starts a comment (LinuxCNC, HEIDENHAIN).
    Comment,
    /// `/` (or FANUC `/1`..`/9`).
    BlockDelete,
    /// `N123` (ISO) or the leading number of a HEIDENHAIN block.
    BlockNumber(u32),
    /// `O1234`, `:1234`, or a LinuxCNC `o100` that names a program.
    ProgramNumber,
    /// A `%` line.
    Percent,
    /// FANUC's `;` end of block.
    Eob,
    /// HEIDENHAIN's `~`: the block continues on the next line.
    Continuation,
    /// An address word.
    Word(Word),
    /// A statement keyword (`IF`, `GOTO`, `WHILE`, `o100 sub`, `L`, `CYCL DEF`, ...).
    Keyword,
    /// A validated expression or condition.
    Expr,
    /// A parameter being assigned (`#100`, `#<x>`, `Q12`).
    Param,
    /// `=` of an assignment.
    Assign,
    /// Text kept verbatim (DPRNT arguments, cycle names, strings, paths).
    Text,
}

/// One token: what it is and where its bytes are.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Token {
    /// Kind.
    pub kind: TokenKind,
    /// Bytes.
    pub span: Span,
}

/// Control flow: where the statically tracked position stops being known.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Flow {
    /// A jump (`GOTO`, `IF ... GOTO`, `FN 9`).
    Jump,
    /// A conditional statement (`IF ... THEN`, o-word `if`/`elseif`/`else`/`endif`).
    Branch,
    /// Start of a loop (`WHILE ... DO`, o-word `while`/`do`/`repeat`).
    LoopStart,
    /// End of a loop (`END1`, `endwhile`, `endrepeat`, `break`, `continue`).
    LoopEnd,
    /// A label or subprogram start (`o100 sub`, `LBL 1`).
    Label,
    /// A call (`o100 call`, `M98`, `G65`, `CALL LBL`, `CALL PGM`).
    Call,
    /// A return (`endsub`, `return`, `M99`, `LBL 0`).
    Return,
}

/// What a HEIDENHAIN block is, keyed on its first word(s) (and, for
/// cycles, on the cycle number, never on the language-dependent text).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HhKind {
    /// `BEGIN PGM`.
    BeginPgm,
    /// `END PGM`.
    EndPgm,
    /// `BLK FORM`.
    BlkForm,
    /// `TOOL CALL`.
    ToolCall,
    /// `TOOL DEF`.
    ToolDef,
    /// `L`: straight line.
    L,
    /// `LN`: straight line with surface-normal and tool vectors.
    Ln,
    /// `LP`: straight line in polar coordinates.
    Lp,
    /// `C`: circle around the pole `CC`.
    C,
    /// `CC`: circle centre (pole).
    Cc,
    /// `CP`: circle in polar coordinates (helix).
    Cp,
    /// `CR`: circle with radius.
    Cr,
    /// `CT`: tangential circle.
    Ct,
    /// `RND`: rounding.
    Rnd,
    /// `CHF`: chamfer.
    Chf,
    /// `APPR ...`: approach.
    Appr,
    /// `DEP ...`: departure.
    Dep,
    /// `CYCL DEF n[.m]`.
    CyclDef {
        /// Cycle number.
        number: u32,
        /// Sub-block (`7.1` -> 1), if written.
        sub: Option<u32>,
    },
    /// `CYCL CALL`.
    CyclCall,
    /// `TCH PROBE n`.
    TchProbe,
    /// `PLANE ...` (any but `PLANE RESET`).
    Plane,
    /// `PLANE RESET`.
    PlaneReset,
    /// `FUNCTION TCPM ...`.
    FunctionTcpm,
    /// `FUNCTION RESET TCPM`.
    FunctionResetTcpm,
    /// Any other `FUNCTION ...`.
    Function,
    /// `FN n: ...`.
    Fn(u32),
    /// `Qn = ...` (also `QL`, `QR`, `QS`).
    Q,
    /// `LBL ...`.
    Lbl,
    /// `CALL LBL ...`.
    CallLbl,
    /// `CALL PGM ...` (and `SEL PGM`/`CALL SELECTED`).
    CallPgm,
    /// `STOP`.
    Stop,
    /// Only M functions.
    M,
    /// A `;` comment block.
    Comment,
    /// A `*` structure block.
    Structure,
    /// Any other known block (`PRESET`, `DECLARE`, `SEL TABLE`, ...).
    Other,
}

/// What a statement does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stmt {
    /// Nothing but spaces, comments and block numbers.
    Blank,
    /// Address words (ISO): motion, modal codes, M/S/T/F.
    Words,
    /// A `%` line.
    Percent,
    /// A program number or name (`O1234`, `BEGIN PGM` is [`Stmt::Hh`]).
    ProgramNumber,
    /// A parameter assignment.
    Assign,
    /// Control flow.
    Flow(Flow),
    /// External output (`DPRNT`, `POPEN`, `PCLOS`, `BPRNT`).
    Output,
    /// A HEIDENHAIN block.
    Hh(HhKind),
    /// A block that could not be read (kept byte for byte outside
    /// `--strict`; [`Block::unreadable`] says why).
    Unreadable,
}

/// A statement: a token range of a block (FANUC can put several on one line
/// with `;`) and what it does.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    /// First token.
    pub first: u32,
    /// One past the last token.
    pub end: u32,
    /// What it is.
    pub stmt: Stmt,
    /// First token of the statement proper (after block delete and number).
    pub body: u32,
    /// A word this parser does not know (accepted outside `--strict`):
    /// the block must not be rewritten.
    pub unknown: Option<Span>,
    /// How the statement is reached when the program runs, where its
    /// macro logic was followed to the end (the lexers give
    /// [`Entry::AsWritten`]).
    pub entry: Entry,
}

/// How a statement is reached when the program runs. A correction in
/// place reads the program in the order written; its macro logic, run
/// first, says where that order is the one the controller runs it in.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Entry {
    /// Not known: read in the order written, a jump, loop or call
    /// statement making the position unknown after it.
    #[default]
    AsWritten,
    /// Never runs (a branch not taken, a block jumped over).
    NotRun,
    /// Runs once, straight after the statement that runs last before it
    /// in the text: the state the order written gives it is the one it
    /// runs with.
    Straight,
    /// Reached by a jump, a loop or a return, or run several times: the
    /// position when it runs is not the one the order written gives.
    Jumped,
}

/// One block: its raw text (with its line ending), tokens and statements.
#[derive(Clone, Debug, Default)]
pub struct Block {
    /// The raw bytes, exactly as read.
    pub text: Vec<u8>,
    /// The tokens; their spans cover `text` exactly, in order.
    pub tokens: Vec<Token>,
    /// The statements.
    pub segments: Vec<Segment>,
    /// 1-based line number of the first line.
    pub line: usize,
    /// Why the block could not be read, when it could not (outside
    /// `--strict` it is then one [`Stmt::Unreadable`] statement of text).
    pub unreadable: Option<BlockError>,
}

impl Block {
    /// The bytes of a span.
    pub fn bytes(&self, span: Span) -> &[u8] {
        &self.text[span.range()]
    }

    /// The tokens of a segment.
    pub(crate) fn seg_tokens(&self, seg: &Segment) -> &[Token] {
        &self.tokens[seg.first as usize..seg.end as usize]
    }

    /// The words of a segment.
    pub fn words<'a>(&'a self, seg: &Segment) -> impl Iterator<Item = (usize, Word)> + 'a {
        (seg.first as usize..seg.end as usize).filter_map(|i| match self.tokens[i].kind {
            TokenKind::Word(w) => Some((i, w)),
            _ => None,
        })
    }

    /// The 1-based (line, column) of a byte offset (columns count characters).
    pub fn locate(&self, offset: usize) -> (usize, usize) {
        let offset = offset.min(self.text.len());
        let before = &self.text[..offset];
        // A bare CR ends a line as LF and CRLF do.
        let ends = |i: usize| match before[i] {
            b'\n' => true,
            b'\r' => self.text.get(i + 1) != Some(&b'\n'),
            _ => false,
        };
        let lines = (0..before.len()).filter(|&i| ends(i)).count();
        let line_start = (0..before.len())
            .rev()
            .find(|&i| ends(i))
            .map_or(0, |p| p + 1);
        let col = String::from_utf8_lossy(&before[line_start..])
            .chars()
            .count()
            + 1;
        (self.line + lines, col)
    }

    /// The line ending this block uses (`\r\n`, `\n` or `\r`), if it has
    /// one.
    pub(crate) fn line_ending(&self) -> Option<&'static [u8]> {
        if self.text.ends_with(b"\r\n") {
            Some(b"\r\n")
        } else if self.text.ends_with(b"\n") {
            Some(b"\n")
        } else if self.text.ends_with(b"\r") {
            Some(b"\r")
        } else {
            None
        }
    }

    /// Writes the block back from its tokens (byte-identical to `text`).
    pub fn reprint(&self, out: &mut Vec<u8>) {
        for t in &self.tokens {
            out.extend_from_slice(self.bytes(t.span));
        }
    }

    /// Makes the block one unreadable statement: its text kept as it is,
    /// `error` saying why.
    pub(crate) fn make_unreadable(&mut self, error: BlockError) {
        self.tokens.clear();
        self.segments.clear();
        let end = self.text.len() - self.line_ending().map_or(0, <[u8]>::len);
        if end > 0 {
            self.push(TokenKind::Text, 0, end);
        }
        if end < self.text.len() {
            self.push(TokenKind::LineEnd, end, self.text.len());
        }
        self.segments.push(Segment {
            first: 0,
            end: self.tokens.len() as u32,
            stmt: Stmt::Unreadable,
            body: 0,
            unknown: Some(Span::new(0, end)),
            entry: Entry::AsWritten,
        });
        self.unreadable = Some(error);
    }

    pub(crate) fn push(&mut self, kind: TokenKind, start: usize, end: usize) {
        self.tokens.push(Token {
            kind,
            span: Span::new(start, end),
        });
    }
}

/// A malformed block: where (byte offset in the block) and what was
/// expected.
#[derive(Clone, Debug, PartialEq)]
pub struct BlockError {
    /// Byte offset inside the block's text.
    pub offset: usize,
    /// What is wrong and what was expected.
    pub message: String,
}

impl BlockError {
    pub(crate) fn new(offset: usize, message: impl Into<String>) -> BlockError {
        BlockError {
            offset,
            message: message.into(),
        }
    }
}

pub(crate) fn is_space(c: u8) -> bool {
    c == b' ' || c == b'\t'
}

/// Length of the line ending at `i` (`\n`, `\r\n` or a bare `\r`), 0 if
/// none.
pub(crate) fn line_end_at(s: &[u8], i: usize) -> usize {
    match s.get(i) {
        Some(b'\n') => 1,
        Some(b'\r') if s.get(i + 1) == Some(&b'\n') => 2,
        Some(b'\r') => 1,
        _ => 0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn addresses_pack_and_print() {
        assert_eq!(Addr::new("x"), Addr::letter(b'X'));
        assert_eq!(Addr::new("FMAX").to_string(), "FMAX");
        assert_eq!(Addr::letter(b'G').as_letter(), Some(b'G'));
        assert_eq!(Addr::new("PA").as_letter(), None);
    }
}
