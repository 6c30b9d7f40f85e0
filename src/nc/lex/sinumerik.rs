//! SINUMERIK 840D sl / ONE: DIN 66025 words with the Siemens high-level
//! language.
//!
//! A line is a block (there is no continuation character). `;` starts a
//! comment to the end of the line, except inside a string; `(` never starts
//! a comment, it opens a parameter list (`CYCLE800(...)`, `MSG("...")`) or
//! groups an expression. A word is an address and a value: a single letter
//! may take a number directly (`X10.5`, `G0X-170` without spaces, lower case
//! `g17`), every other address and every expression needs `=` (`X=R1+2`,
//! `CR=15`, `A3=0.5`, `X=AC(10)`, `X=IC(-2)`, `C=DC(42)`). A literal inside
//! `AC(..)`, `IC(..)`, `DC(..)`, `ACP(..)` and `ACN(..)` is the word's value
//! (`IC` marks it incremental), so a rewrite replaces just that lexeme.
//! Besides words a block holds assignments to R parameters, user and
//! system variables (`R1=12.5`, `_X_HOME=-365.`, `$TC_CARR44[1]=0.01`),
//! commands (`TRAORI`, `SUPA`, `STOPRE`, `TRANS`), calls with a parameter
//! list (`CYCLE800(...)`, `WRITE(...)`, `L140(2)`), and statements whose
//! rest of line is kept as one validated expression: `IF`, `GOTOF`,
//! `GOTOB`, `GOTO`, `WHILE`, `FOR`, `LOOP`, `REPEAT`, `UNTIL`, `CASE`,
//! `PROC`, `RET`, `DEF`. A label (`METKA_START:`) is a statement of its own;
//! a `%_N_NAME_MPF` line heads a file exchanged outside the control.

use super::Syntax;
use crate::limits::MAX_EXPR_DEPTH;
use crate::nc::{
    Addr, Block, BlockError, Entry, Flow, Segment, Span, Stmt, TokenKind, Value, Word, is_space,
    lexeme,
};

/// G codes the SINUMERIK 840D sl knows in Siemens mode (value x 10), from
/// the programming manual's list of G groups.
const SINUMERIK_G: &[u32] = &[
    0, 10, 20, 30, 40, 50, 70, 90, 170, 180, 190, 250, 260, 330, 340, 350, 400, 410, 420, 530, 540,
    550, 560, 570, 580, 590, 600, 620, 630, 640, 700, 710, 740, 750, 900, 910, 930, 940, 950, 960,
    970, 1100, 1110, 1120, 1400, 1410, 1420, 1430, 1470, 1480, 1530, 2470, 2480, 2900, 2910, 3310,
    3320, 3400, 3410, 3470, 3480, 4500, 4510, 4600, 4610, 4620, 5000, 5050, 5060, 5070, 5080, 5090,
    6010, 6020, 6030, 6210, 6410, 6420, 6430, 6440, 6450, 7000, 7100, 7510, 7530, 8100, 8110, 8120,
    8130, 8140, 8150, 8160, 8170, 8180, 8190, 8200, 8210, 8220, 8230, 8240, 8250, 8260, 8270, 8280,
    8290, 9310, 9420, 9520, 9610, 9620, 9710, 9720, 9730,
];

/// Whether SINUMERIK knows G code `g` (x 10): the list above and the
/// settable work offsets G505 to G599.
pub(crate) fn known_g(g: u32) -> bool {
    SINUMERIK_G.binary_search(&g).is_ok() || (5050..=5990).contains(&g) && g.is_multiple_of(10)
}

/// Addresses of more than one letter that take a value after `=` (the
/// rest of such names are variables or commands).
const LONG_ADDRESSES: [&str; 16] = [
    "CR", "AR", "RND", "RNDM", "CHF", "CHR", "MEAS", "MEAW", "SPOS", "SPOSA", "OFFN", "TURN",
    "ACC", "FA", "FL", "FB",
];

/// Statements whose rest of line is one expression, and what they do.
const STATEMENTS: [(&str, Flow); 15] = [
    ("GOTOF", Flow::Jump),
    ("GOTOB", Flow::Jump),
    ("GOTOC", Flow::Jump),
    ("GOTO", Flow::Jump),
    ("ENDIF", Flow::Branch),
    ("ELSE", Flow::Branch),
    ("ENDWHILE", Flow::LoopEnd),
    ("WHILE", Flow::LoopStart),
    ("ENDFOR", Flow::LoopEnd),
    ("FOR", Flow::LoopStart),
    ("ENDLOOP", Flow::LoopEnd),
    ("LOOP", Flow::LoopStart),
    ("UNTIL", Flow::LoopEnd),
    ("CASE", Flow::Jump),
    ("PROC", Flow::Label),
];

struct Lexer<'a> {
    s: &'a [u8],
    /// End of the content (before the line ending).
    n: usize,
    syn: &'a Syntax,
}

fn ident_start(c: u8) -> bool {
    c.is_ascii_alphabetic() || c == b'_' || c == b'$'
}

fn ident_char(c: u8) -> bool {
    c.is_ascii_alphanumeric() || c == b'_' || c == b'$'
}

impl<'a> Lexer<'a> {
    fn spaces(&self, mut i: usize) -> usize {
        while i < self.n && is_space(self.s[i]) {
            i += 1;
        }
        i
    }

    fn ident_end(&self, mut i: usize) -> usize {
        while i < self.n && ident_char(self.s[i]) {
            i += 1;
        }
        i
    }

    /// The end of a string starting at its quote `i`.
    fn string_end(&self, i: usize) -> Result<usize, BlockError> {
        let q = self.s[i];
        match self.s[i + 1..self.n].iter().position(|&c| c == q) {
            Some(p) => Ok(i + 1 + p + 1),
            None => Err(BlockError::new(
                i,
                if q == b'"' {
                    "unclosed string: expected `\"` before the end of the line"
                } else {
                    "unclosed literal: expected `'` before the end of the line ('H0F', 'B101')"
                },
            )),
        }
    }

    /// The end of an expression starting at `i`: up to a blank, `;`, `,`
    /// or `)` outside brackets and strings, going on over blanks next to
    /// an operator (`R1 + 2`). `stop_words` also ends it before one of
    /// those keywords (the `GOTOF` of an `IF`).
    fn expr_end(&self, i: usize, stop_words: &[&str]) -> Result<usize, BlockError> {
        let s = self.s;
        let mut depth: Vec<(u8, usize)> = Vec::new();
        let mut j = i;
        while j < self.n {
            let c = s[j];
            match c {
                b'"' | b'\'' => {
                    j = self.string_end(j)?;
                    continue;
                }
                b'(' | b'[' => {
                    if depth.len() >= MAX_EXPR_DEPTH {
                        return Err(BlockError::new(
                            j,
                            format!(
                                "brackets nested deeper than {MAX_EXPR_DEPTH} levels: expected at most {MAX_EXPR_DEPTH} (controllers read a few)"
                            ),
                        ));
                    }
                    depth.push((if c == b'(' { b')' } else { b']' }, j));
                }
                b')' | b']' => match depth.pop() {
                    Some((close, _)) if close == c => {}
                    Some((close, at)) => {
                        return Err(BlockError::new(
                            j,
                            format!(
                                "`{}` closes the bracket opened at column {}: expected `{}`",
                                c as char,
                                at + 1,
                                close as char
                            ),
                        ));
                    }
                    // Closes the list or index the expression is in.
                    None => return Ok(j),
                },
                b';' | b',' if depth.is_empty() => return Ok(j),
                _ if is_space(c) && depth.is_empty() => {
                    let k = self.spaces(j);
                    let before = s[..j].iter().rev().find(|c| !is_space(**c)).copied();
                    let after = s.get(k).copied().filter(|_| k < self.n);
                    let op = |c: Option<u8>| {
                        c.is_some_and(|c| {
                            matches!(c, b'+' | b'-' | b'*' | b'/' | b'<' | b'>' | b'=')
                        })
                    };
                    let stop = stop_words
                        .iter()
                        .any(|w| starts_with_word(&s[k..self.n], w));
                    if stop
                        || !(op(before)
                            || op(after)
                            || after.is_some_and(|c| word_op(&s[k..self.n], c)))
                    {
                        return Ok(j);
                    }
                    j = k;
                    continue;
                }
                _ => {}
            }
            j += 1;
        }
        if let Some((close, at)) = depth.last() {
            return Err(BlockError::new(
                *at,
                format!(
                    "bracket not closed: expected `{}` before the end of the line",
                    *close as char
                ),
            ));
        }
        Ok(j)
    }
}

/// Whether `s` starts with the operator words of the language (`AND`,
/// `OR`, `NOT`, `XOR`, `DIV`, `MOD`, `B_AND`, ...), which go on an
/// expression across blanks.
fn word_op(s: &[u8], c: u8) -> bool {
    if !c.is_ascii_alphabetic() {
        return false;
    }
    [
        "AND", "OR", "XOR", "NOT", "DIV", "MOD", "B_AND", "B_OR", "B_XOR", "B_NOT",
    ]
    .iter()
    .any(|w| starts_with_word(s, w))
}

/// `s` starts with the keyword `kw` (any case), not followed by more of a
/// name.
fn starts_with_word(s: &[u8], kw: &str) -> bool {
    s.len() >= kw.len()
        && s[..kw.len()].eq_ignore_ascii_case(kw.as_bytes())
        && !s.get(kw.len()).is_some_and(|c| ident_char(*c))
}

/// Tokenizes one SINUMERIK line.
pub(super) fn parse_text(syn: &Syntax, s: &[u8], b: &mut Block) -> Result<(), BlockError> {
    let (n, le) = super::split_line_end(s)?;
    let lx = Lexer { s, n, syn };
    let mut first = b.tokens.len();
    let mut i = 0;
    if b.line == 1 && s[..n].starts_with(super::BOM) {
        b.push(TokenKind::Text, 0, super::BOM.len());
        i = super::BOM.len();
    }
    i = space(&lx, b, i);
    if i < n && s[i] == super::DOS_EOF {
        b.push(TokenKind::Text, i, n);
        return finish_line(b, n, le, first, Stmt::Blank, None);
    }
    // `%_N_NAME_MPF`: the archive header of a file.
    if i < n && s[i] == b'%' {
        b.push(TokenKind::Percent, i, n);
        return finish_line(b, n, le, first, Stmt::Percent, None);
    }
    if i < n && s[i] == b'/' {
        let mut j = i + 1;
        if j < n && s[j].is_ascii_digit() {
            j += 1;
        }
        b.push(TokenKind::BlockDelete, i, j);
        i = space(&lx, b, j);
    }
    // `N10` (sub block) or `:10` (main block).
    if i + 1 < n && matches!(s[i], b'N' | b'n' | b':') && s[i + 1].is_ascii_digit() {
        let mut j = i + 1;
        while j < n && s[j].is_ascii_digit() {
            j += 1;
        }
        let num = s[i + 1..j]
            .iter()
            .try_fold(0u32, |acc, &c| {
                acc.checked_mul(10)?.checked_add((c - b'0') as u32)
            })
            .unwrap_or(u32::MAX);
        b.push(TokenKind::BlockNumber(num), i, j);
        i = space(&lx, b, j);
    }
    // A label ends with `:` right after its name.
    if i < n && ident_start(s[i]) && s[i] != b'$' {
        let e = lx.ident_end(i);
        if e < n
            && s[e] == b':'
            && e - i >= 2
            && s[i..i + 2]
                .iter()
                .all(|c| c.is_ascii_alphabetic() || *c == b'_')
        {
            b.push(TokenKind::Keyword, i, e + 1);
            let j = space(&lx, b, e + 1);
            if j >= n || s[j] == b';' {
                if j < n {
                    b.push(TokenKind::Comment, j, n);
                }
                return finish_line(b, n, le, first, Stmt::Flow(Flow::Label), None);
            }
            b.segments.push(Segment {
                first: first as u32,
                end: b.tokens.len() as u32,
                stmt: Stmt::Flow(Flow::Label),
                body: first as u32,
                unknown: None,
                entry: Entry::AsWritten,
            });
            first = b.tokens.len();
            i = j;
        }
    }
    let body = b.tokens.len();
    let (stmt, unknown) = if i < n {
        statement(&lx, b, i)?
    } else {
        (Stmt::Blank, None)
    };
    b.segments.push(Segment {
        first: first as u32,
        end: b.tokens.len() as u32,
        stmt,
        body: body as u32,
        unknown,
        entry: Entry::AsWritten,
    });
    if le > 0 {
        b.push(TokenKind::LineEnd, n, n + le);
    }
    Ok(())
}

fn finish_line(
    b: &mut Block,
    n: usize,
    le: usize,
    first: usize,
    stmt: Stmt,
    unknown: Option<Span>,
) -> Result<(), BlockError> {
    b.segments.push(Segment {
        first: first as u32,
        end: b.tokens.len() as u32,
        stmt,
        body: first as u32,
        unknown,
        entry: Entry::AsWritten,
    });
    if le > 0 {
        b.push(TokenKind::LineEnd, n, n + le);
    }
    Ok(())
}

fn space(lx: &Lexer, b: &mut Block, i: usize) -> usize {
    let j = lx.spaces(i);
    if j > i {
        b.push(TokenKind::Space, i, j);
    }
    j
}

/// A comment (or nothing) up to the end of the line after a statement.
fn tail(lx: &Lexer, b: &mut Block, i: usize, what: &str) -> Result<(), BlockError> {
    let i = space(lx, b, i);
    if i >= lx.n {
        return Ok(());
    }
    if lx.s[i] == b';' {
        b.push(TokenKind::Comment, i, lx.n);
        return Ok(());
    }
    Err(BlockError::new(
        i,
        format!(
            "unexpected `{}` after {what}: expected a comment or the end of the block",
            String::from_utf8_lossy(&lx.s[i..lx.n.min(i + 12)])
        ),
    ))
}

/// The statement from `i` to the end of the line.
fn statement(lx: &Lexer, b: &mut Block, i: usize) -> Result<(Stmt, Option<Span>), BlockError> {
    let s = lx.s;
    let n = lx.n;
    let rest = &s[i..n];
    if starts_with_word(rest, "IF") {
        b.push(TokenKind::Keyword, i, i + 2);
        let j = space(lx, b, i + 2);
        let jumps = ["GOTOF", "GOTOB", "GOTOC", "GOTO"];
        let e = lx.expr_end(j, &jumps)?;
        if e == j {
            return Err(BlockError::new(
                j,
                "IF needs a condition, e.g. IF R1>0 GOTOF END",
            ));
        }
        b.push(TokenKind::Expr, j, e);
        let k = space(lx, b, e);
        if let Some(kw) = jumps.iter().find(|w| starts_with_word(&s[k..n], w)) {
            b.push(TokenKind::Keyword, k, k + kw.len());
            let t = space(lx, b, k + kw.len());
            let te = lx.expr_end(t, &[])?;
            if te == t {
                return Err(BlockError::new(
                    t,
                    format!("{kw} needs a label or a block number"),
                ));
            }
            b.push(TokenKind::Text, t, te);
            tail(lx, b, te, "the jump target")?;
            return Ok((Stmt::Flow(Flow::Jump), None));
        }
        tail(lx, b, k, "the IF condition")?;
        return Ok((Stmt::Flow(Flow::Branch), None));
    }
    if starts_with_word(rest, "RET") {
        b.push(TokenKind::Keyword, i, i + 3);
        let j = rest_expr(lx, b, i + 3)?;
        tail(lx, b, j, "RET")?;
        return Ok((Stmt::Flow(Flow::Return), None));
    }
    if starts_with_word(rest, "REPEAT") {
        // `REPEAT` alone opens a loop up to `UNTIL`; with labels it runs a
        // stretch of the program again (a call).
        b.push(TokenKind::Keyword, i, i + 6);
        let j = space(lx, b, i + 6);
        if j >= n || s[j] == b';' {
            tail(lx, b, j, "REPEAT")?;
            return Ok((Stmt::Flow(Flow::LoopStart), None));
        }
        let e = rest_expr(lx, b, j)?;
        tail(lx, b, e, "REPEAT")?;
        return Ok((Stmt::Flow(Flow::Call), None));
    }
    for (kw, flow) in STATEMENTS {
        if starts_with_word(rest, kw) {
            b.push(TokenKind::Keyword, i, i + kw.len());
            let j = rest_expr(lx, b, i + kw.len())?;
            tail(lx, b, j, kw)?;
            return Ok((Stmt::Flow(flow), None));
        }
    }
    for kw in ["DEFINE", "DEF", "EXTERN"] {
        if starts_with_word(rest, kw) {
            b.push(TokenKind::Keyword, i, i + kw.len());
            let j = rest_expr(lx, b, i + kw.len())?;
            tail(lx, b, j, kw)?;
            return Ok((Stmt::Assign, None));
        }
    }
    words(lx, b, i)
}

/// The rest of a statement's line up to a comment, as one token (text
/// kept, brackets and strings checked); returns where it ends.
fn rest_expr(lx: &Lexer, b: &mut Block, i: usize) -> Result<usize, BlockError> {
    let j = space(lx, b, i);
    let mut e = j;
    // Blanks separate the parts of a statement (`GOTOF END`, `FOR R1=0
    // TO 5`): go on over them up to a comment.
    while e < lx.n && lx.s[e] != b';' {
        let k = lx.expr_end(e, &[])?;
        if k < lx.n && matches!(lx.s[k], b',' | b')') {
            e = k + 1;
            continue;
        }
        e = lx.spaces(k);
        if k == e && k < lx.n && lx.s[k] != b';' {
            e = k + 1;
        }
    }
    // Trailing blanks before a comment stay spaces.
    let mut end = e;
    while end > j && is_space(lx.s[end - 1]) {
        end -= 1;
    }
    if end > j {
        b.push(TokenKind::Expr, j, end);
    }
    Ok(end)
}

/// A value after `=` starting at `i`: its end, and the word value with
/// its lexeme span when it is a literal (bare or in `AC()`, `IC()`,
/// `DC()`, `ACP()`, `ACN()`).
fn value(lx: &Lexer, i: usize) -> Result<(usize, Value, Span, lexeme::NumStyle, bool), BlockError> {
    let e = lx.expr_end(i, &[])?;
    if e == i {
        return Err(BlockError::new(
            i,
            "expected a value after `=`: a number, a parameter or an expression",
        ));
    }
    let v = &lx.s[i..e];
    let literal = |at: usize, len: usize| -> Option<(Value, Span, lexeme::NumStyle)> {
        let (lx_, n) = lexeme::scan(&lx.s[at..at + len])?;
        (n == len && lx_.value.is_finite())
            .then(|| (Value::Num(lx_.value), Span::new(at, at + len), lx_.style))
    };
    if let Some((val, span, style)) = literal(i, v.len()) {
        return Ok((e, val, span, style, false));
    }
    for (f, inc) in [
        ("AC(", false),
        ("IC(", true),
        ("DC(", false),
        ("ACP(", false),
        ("ACN(", false),
    ] {
        if v.len() > f.len() + 1
            && v[..f.len()].eq_ignore_ascii_case(f.as_bytes())
            && v[v.len() - 1] == b')'
            && let Some((val, span, style)) = literal(i + f.len(), v.len() - f.len() - 1)
        {
            return Ok((e, val, span, style, inc));
        }
    }
    Ok((
        e,
        Value::Expr,
        Span::new(i, e),
        lexeme::NumStyle::default(),
        false,
    ))
}

/// Whether a name taking `=` is a word address: a single letter, a letter
/// with a numeric extension (`A3`, `X1`, `I1`; `R1` is a parameter), or
/// one of [`LONG_ADDRESSES`].
fn is_address(name: &[u8]) -> bool {
    let Some((&first, ext)) = name.split_first() else {
        return false;
    };
    if !first.is_ascii_alphabetic() {
        return false;
    }
    if ext.iter().all(u8::is_ascii_digit) {
        return !first.eq_ignore_ascii_case(&b'R') || ext.is_empty();
    }
    LONG_ADDRESSES
        .iter()
        .any(|a| name.eq_ignore_ascii_case(a.as_bytes()))
}

/// Words, assignments, commands and calls up to the end of the line.
fn words(lx: &Lexer, b: &mut Block, mut i: usize) -> Result<(Stmt, Option<Span>), BlockError> {
    let s = lx.s;
    let n = lx.n;
    let mut stmt = Stmt::Blank;
    let mut unknown: Option<Span> = None;
    while i < n {
        let c = s[i];
        if is_space(c) {
            i = space(lx, b, i);
            continue;
        }
        if c == b';' {
            b.push(TokenKind::Comment, i, n);
            break;
        }
        if !ident_start(c) {
            return Err(BlockError::new(
                i,
                format!(
                    "unexpected character `{}`: expected a word (X10, X=R1), an assignment, a command or a comment",
                    String::from_utf8_lossy(&s[i..(i + utf8_len(c)).min(n)])
                ),
            ));
        }
        let after_letter = s.get(i + 1).copied().filter(|_| i + 1 < n);
        // A single letter with a number right after it: `X10`, `G0X1`,
        // `X-.5`; unless the digits are an address extension before `=`
        // (`A3=0.5`, `R1=2`).
        if c.is_ascii_alphabetic()
            && after_letter.is_some_and(|d| d.is_ascii_digit() || matches!(d, b'.' | b'-' | b'+'))
        {
            let mut k = i + 1;
            while k < n && s[k].is_ascii_digit() {
                k += 1;
            }
            let eq = lx.spaces(k);
            let extension = k > i + 1 && eq < n && s[eq] == b'=' && s.get(eq + 1) != Some(&b'=');
            if !extension {
                let Some((lx_, len)) = lexeme::scan(&s[i + 1..n]) else {
                    return Err(BlockError::new(
                        i + 1,
                        format!("bad number after {}: expected digits", c as char),
                    ));
                };
                let end = i + 1 + len;
                if s.get(end)
                    .is_some_and(|d| *d == b'.' || (d.is_ascii_digit() && end < n))
                {
                    return Err(BlockError::new(
                        i + 1,
                        format!(
                            "bad number `{}` after {}: expected digits with at most one decimal point",
                            String::from_utf8_lossy(
                                &s[i + 1..lx.ident_end(end).max(end + 1).min(n)]
                            ),
                            c as char
                        ),
                    ));
                }
                if !lx_.value.is_finite() {
                    return Err(super::too_large(i + 1, &s[i + 1..end]));
                }
                let letter = c.to_ascii_uppercase();
                if letter == b'G' && !crate::nc::g_codes::g_code(lx_.value).is_some_and(known_g) {
                    if lx.syn.strict {
                        return Err(BlockError::new(
                            i,
                            format!(
                                "unknown word `{}`: an unknown G code for sinumerik",
                                String::from_utf8_lossy(&s[i..end])
                            ),
                        ));
                    }
                    unknown.get_or_insert(Span::new(i, end));
                }
                b.push(
                    TokenKind::Word(Word {
                        addr: Addr::letter(letter),
                        incremental: false,
                        value: Value::Num(lx_.value),
                        value_span: Span::new(i + 1, end),
                        style: lx_.style,
                    }),
                    i,
                    end,
                );
                stmt = Stmt::Words;
                i = end;
                continue;
            }
        }
        let e = lx.ident_end(i);
        let name = &s[i..e];
        let mut k = e;
        // An indexed name: `$AA_MW[X]`, `_ARR[1,2]`, `AX[_XX]`.
        if k < n && s[k] == b'[' {
            let close = lx.expr_end(k + 1, &[])?;
            if close >= n || s[close] != b']' {
                return Err(BlockError::new(e, "`[` not closed: expected `]`"));
            }
            k = close + 1;
        }
        let eq = lx.spaces(k);
        if eq < n && s[eq] == b'=' && s.get(eq + 1) != Some(&b'=') {
            let vstart = lx.spaces(eq + 1);
            let (end, val, span, style, inc) = value(lx, vstart)?;
            if k == e && is_address(name) && name.len() <= 4 {
                b.push(
                    TokenKind::Word(Word {
                        addr: Addr::new(&String::from_utf8_lossy(name)),
                        incremental: inc,
                        value: val,
                        value_span: span,
                        style,
                    }),
                    i,
                    end,
                );
                stmt = Stmt::Words;
            } else {
                b.push(TokenKind::Param, i, k);
                if eq > k {
                    b.push(TokenKind::Space, k, eq);
                }
                b.push(TokenKind::Assign, eq, eq + 1);
                if vstart > eq + 1 {
                    b.push(TokenKind::Space, eq + 1, vstart);
                }
                b.push(TokenKind::Expr, vstart, end);
                if stmt == Stmt::Blank {
                    stmt = Stmt::Assign;
                }
            }
            i = end;
            continue;
        }
        if k > e {
            return Err(BlockError::new(
                k,
                format!(
                    "expected `=` after `{}`: an indexed variable alone is not a statement",
                    String::from_utf8_lossy(&s[i..k])
                ),
            ));
        }
        b.push(TokenKind::Keyword, i, e);
        if e < n && s[e] == b'(' {
            // A parameter list: `CYCLE800(...)`, `MSG("...")`, `L140(2)`.
            let close = lx.expr_end(e + 1, &[])?;
            let mut end = close;
            loop {
                if end < n && s[end] == b',' {
                    end = lx.expr_end(end + 1, &[])?;
                    continue;
                }
                break;
            }
            if end >= n || s[end] != b')' {
                return Err(BlockError::new(e, "`(` not closed: expected `)`"));
            }
            b.push(TokenKind::Text, e, end + 1);
            i = end + 1;
        } else {
            i = e;
        }
        stmt = Stmt::Words;
    }
    Ok((stmt, unknown))
}

fn utf8_len(c: u8) -> usize {
    match c {
        0xc0..=0xdf => 2,
        0xe0..=0xef => 3,
        0xf0..=0xf7 => 4,
        _ => 1,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::machine::Dialect;

    fn parse_str(src: &str, strict: bool) -> Result<Block, BlockError> {
        Syntax {
            dialect: Dialect::Sinumerik,
            strict,
        }
        .block(src)
    }

    fn words(b: &Block) -> Vec<(String, Value, String, bool)> {
        b.segments
            .iter()
            .flat_map(|seg| b.words(seg).collect::<Vec<_>>())
            .map(|(_, w)| {
                (
                    w.addr.to_string(),
                    w.value,
                    String::from_utf8_lossy(b.bytes(w.value_span)).to_string(),
                    w.incremental,
                )
            })
            .collect()
    }

    #[test]
    fn words_in_every_form_the_manuals_and_real_programs_write() {
        let b = parse_str(
            "N10 G0X-170 y=AC(12.5) Z=IC(-2) C=DC(42.) CR=27.5 A3=.5 X=R1+2 ;c\n",
            true,
        )
        .unwrap();
        let w = words(&b);
        assert_eq!(w[0], ("G".into(), Value::Num(0.0), "0".into(), false));
        assert_eq!(w[1], ("X".into(), Value::Num(-170.0), "-170".into(), false));
        assert_eq!(w[2], ("Y".into(), Value::Num(12.5), "12.5".into(), false));
        assert_eq!(w[3], ("Z".into(), Value::Num(-2.0), "-2".into(), true));
        assert_eq!(w[4], ("C".into(), Value::Num(42.0), "42.".into(), false));
        assert_eq!(w[5], ("CR".into(), Value::Num(27.5), "27.5".into(), false));
        assert_eq!(w[6], ("A3".into(), Value::Num(0.5), ".5".into(), false));
        assert_eq!(w[7], ("X".into(), Value::Expr, "R1+2".into(), false));
        assert_eq!(b.segments[0].stmt, Stmt::Words);
        assert!(matches!(b.tokens[0].kind, TokenKind::BlockNumber(10)));
        let mut out = Vec::new();
        b.reprint(&mut out);
        assert_eq!(out, b.text);
    }

    #[test]
    fn statements_labels_and_assignments() {
        for (src, stmts) in [
            ("N51 METKA_START:\n", vec![Stmt::Flow(Flow::Label)]),
            ("LBL1: G1 X1\n", vec![Stmt::Flow(Flow::Label), Stmt::Words]),
            ("IF R6<R3 GOTOF END ; done\n", vec![Stmt::Flow(Flow::Jump)]),
            ("IF $AC_MEA[1]==0\n", vec![Stmt::Flow(Flow::Branch)]),
            ("ENDIF\n", vec![Stmt::Flow(Flow::Branch)]),
            ("GOTOB METKA_START\n", vec![Stmt::Flow(Flow::Jump)]),
            (
                "WHILE R1 < 10 AND R2>0\n",
                vec![Stmt::Flow(Flow::LoopStart)],
            ),
            ("FOR R1=0 TO 5\n", vec![Stmt::Flow(Flow::LoopStart)]),
            ("REPEAT\n", vec![Stmt::Flow(Flow::LoopStart)]),
            ("REPEAT LBL1 LBL2 P=3\n", vec![Stmt::Flow(Flow::Call)]),
            ("UNTIL R1>5\n", vec![Stmt::Flow(Flow::LoopEnd)]),
            ("DEF STRING[10] S=\"a;b\" ; c\n", vec![Stmt::Assign]),
            (
                "PROC HOLES1(REAL A, INT B) SAVE DISPLOF\n",
                vec![Stmt::Flow(Flow::Label)],
            ),
            ("R1=12.5;glued\n", vec![Stmt::Assign]),
            ("_X_HOME=-365. _Y_HOME=224.\n", vec![Stmt::Assign]),
            ("$TC_CARR44[1]=0.01\n", vec![Stmt::Assign]),
            ("%_N_SHAFT123_MPF\n", vec![Stmt::Percent]),
            ("; only a comment\n", vec![Stmt::Blank]),
            ("TRAORI\n", vec![Stmt::Words]),
            (
                "CYCLE800(0,\"TC1\",0,192,0,0,0,0,30,45,0,0,0,1)\n",
                vec![Stmt::Words],
            ),
            (
                "FCLINE=\"T1 X\"<<ROUND(R1*10000)/10000<<\" Y\"\n",
                vec![Stmt::Assign],
            ),
            ("MEAS=1 G1 X10 Y0 Z5 F100\n", vec![Stmt::Words]),
        ] {
            let b = parse_str(src, true).unwrap_or_else(|e| panic!("{src}: {e:?}"));
            let got: Vec<Stmt> = b.segments.iter().map(|s| s.stmt).collect();
            assert_eq!(got, stmts, "{src}");
            let mut out = Vec::new();
            b.reprint(&mut out);
            assert_eq!(out, b.text, "{src}");
        }
    }

    #[test]
    fn malformed_lines_name_the_column_and_what_was_expected() {
        let e = parse_str("G1 X1.2.3\n", false).unwrap_err();
        assert_eq!(e.offset, 4);
        assert!(e.message.contains("bad number"), "{}", e.message);
        let e = parse_str("MSG(\"open\n", false).unwrap_err();
        assert!(e.message.contains("unclosed string"), "{}", e.message);
        let e = parse_str("X=(R1+2\n", false).unwrap_err();
        assert!(e.message.contains("not closed"), "{}", e.message);
        let e = parse_str("G1 X=\n", false).unwrap_err();
        assert!(e.message.contains("expected a value"), "{}", e.message);
        let e = parse_str("G12.7 X1\n", true).unwrap_err();
        assert!(e.message.contains("unknown G code"), "{}", e.message);
        let b = parse_str("G12.7 X1\n", false).unwrap();
        assert!(b.segments[0].unknown.is_some());
        let deep = format!("X={}1{}\n", "(".repeat(200), ")".repeat(200));
        let e = parse_str(&deep, false).unwrap_err();
        assert!(e.message.contains("nested deeper"), "{}", e.message);
    }
}
