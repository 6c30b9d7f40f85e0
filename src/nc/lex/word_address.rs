//! The two word-address dialects: FANUC (ISO G-code with Custom Macro B)
//! and LinuxCNC (rs274ngc with o-words and named parameters).
//!
//! They share words (`X-12.5`, `G43.4`, `X[#1+2]`, `X#5061`), parenthesized
//! comments, block delete and block numbers, and differ where it matters:
//! on FANUC `;` ends a block (so one line may hold several), `O1234` names
//! the program and `IF/GOTO/WHILE/DO/END/DPRNT/POPEN/PCLOS` and unbracketed
//! `#1=#1+1` are statements; on LinuxCNC `;` starts a comment, `o100 sub`
//! and friends are the control flow, parameters are assigned inside any
//! line (`#<x>=[..]`) and there is no `E` address.

use super::Syntax;
use crate::machine::Dialect;
use crate::nc::g_codes::{g_code, known_g};
use crate::nc::{
    Addr, Block, BlockError, Entry, Flow, Segment, Span, Stmt, TokenKind, Value, Word, expr,
    is_space, lexeme,
};

const OWORD_KEYWORDS: [(&str, Flow); 15] = [
    ("endsub", Flow::Return),
    ("sub", Flow::Label),
    ("call", Flow::Call),
    ("do", Flow::LoopStart),
    ("endwhile", Flow::LoopEnd),
    ("while", Flow::LoopStart),
    ("endif", Flow::Branch),
    ("elseif", Flow::Branch),
    ("else", Flow::Branch),
    ("if", Flow::Branch),
    ("endrepeat", Flow::LoopEnd),
    ("repeat", Flow::LoopStart),
    ("break", Flow::LoopEnd),
    ("continue", Flow::LoopEnd),
    ("return", Flow::Return),
];

fn starts_with_ci(s: &[u8], kw: &str) -> bool {
    s.len() >= kw.len() && s[..kw.len()].eq_ignore_ascii_case(kw.as_bytes())
}

struct Lexer<'a> {
    s: &'a [u8],
    /// End of the content (before the line ending).
    n: usize,
    fanuc: bool,
    syn: &'a Syntax,
}

impl<'a> Lexer<'a> {
    fn spaces(&self, mut i: usize) -> usize {
        while i < self.n && is_space(self.s[i]) {
            i += 1;
        }
        i
    }

    fn digits(&self, mut i: usize) -> usize {
        while i < self.n && self.s[i].is_ascii_digit() {
            i += 1;
        }
        i
    }

    fn comment(&self, i: usize) -> Result<usize, BlockError> {
        match self.s[i + 1..self.n].iter().position(|&c| c == b')') {
            Some(p) => Ok(i + 1 + p + 1),
            None => Err(BlockError::new(
                i,
                "unclosed comment: expected `)` before the end of the line",
            )),
        }
    }

    /// The value of a word starting at `i` (after the address and spaces).
    fn value(&self, i: usize, letter: u8) -> Result<(Value, lexeme::NumStyle, usize), BlockError> {
        let rest = &self.s[i..self.n];
        if let Some((lx, n)) = lexeme::scan(rest) {
            if rest
                .get(n)
                .is_some_and(|c| *c == b'.' || c.is_ascii_digit())
            {
                return Err(BlockError::new(
                    i,
                    format!(
                        "bad number `{}` after {}: expected digits with at most one decimal point",
                        String::from_utf8_lossy(&rest[..word_end(rest)]),
                        letter as char
                    ),
                ));
            }
            if !lx.value.is_finite() {
                return Err(super::too_large(i, &rest[..n]));
            }
            return Ok((Value::Num(lx.value), lx.style, i + n));
        }
        if let Some(n) = expr::real_value_len(rest).map_err(|e| too_deep(i, e))? {
            return Ok((Value::Expr, lexeme::NumStyle::default(), i + n));
        }
        let shown = &rest[..word_end(rest).max(rest.len().min(1))];
        Err(BlockError::new(
            i,
            format!(
                "bad number `{}` after {}: expected a number, a [ ] expression or a #parameter",
                String::from_utf8_lossy(shown),
                letter as char
            ),
        ))
    }
}

/// An expression starting at `start` nested too deep, located at the
/// level too many.
fn too_deep(start: usize, e: expr::TooDeep) -> BlockError {
    BlockError::new(start + e.offset, e.to_string())
}

fn word_end(s: &[u8]) -> usize {
    s.iter()
        .position(|&c| is_space(c) || c == b'(' || c == b';' || c.is_ascii_alphabetic())
        .unwrap_or(s.len())
}

struct Seg {
    first: usize,
    body: usize,
    stmt: Stmt,
    unknown: Option<Span>,
}

/// Tokenizes one FANUC or LinuxCNC line.
pub(super) fn parse_text(syn: &Syntax, s: &[u8], b: &mut Block) -> Result<(), BlockError> {
    let (n, le) = super::split_line_end(s)?;
    let lx = Lexer {
        s,
        n,
        fanuc: syn.dialect == Dialect::Fanuc,
        syn,
    };
    let mut i = 0;
    let mut first_segment = true;
    loop {
        i = segment(&lx, b, i, first_segment)?;
        first_segment = false;
        if i >= n {
            break;
        }
    }
    if le > 0 {
        b.push(TokenKind::LineEnd, n, n + le);
    }
    Ok(())
}

/// Reads one statement from `i`; returns where the next one starts.
fn segment(lx: &Lexer, b: &mut Block, mut i: usize, first: bool) -> Result<usize, BlockError> {
    let s = lx.s;
    let n = lx.n;
    let mut seg = Seg {
        first: b.tokens.len(),
        body: b.tokens.len(),
        stmt: Stmt::Blank,
        unknown: None,
    };
    let sp = |b: &mut Block, i: usize| -> usize {
        let j = lx.spaces(i);
        if j > i {
            b.push(TokenKind::Space, i, j);
        }
        j
    };
    if first && b.line == 1 && s[..n].starts_with(super::BOM) {
        b.push(TokenKind::Text, 0, super::BOM.len());
        i = super::BOM.len();
    }
    i = sp(b, i);
    // DOS's end-of-file mark (after the closing `%` of files that went
    // through a DOS editor): nothing after it is part of the program.
    if i < n && s[i] == super::DOS_EOF {
        b.push(TokenKind::Text, i, n);
        finish(b, &seg);
        return Ok(n);
    }
    // `%` lines frame FANUC and LinuxCNC programs.
    if first && i < n && s[i] == b'%' {
        b.push(TokenKind::Percent, i, n);
        seg.stmt = Stmt::Percent;
        finish(b, &seg);
        return Ok(n);
    }
    if i < n && s[i] == b'/' {
        let mut j = i + 1;
        if lx.fanuc && j < n && (b'1'..=b'9').contains(&s[j]) {
            j += 1;
        }
        b.push(TokenKind::BlockDelete, i, j);
        i = sp(b, j);
    }
    if i < n && (s[i] == b'N' || s[i] == b'n') && i + 1 < n && s[i + 1].is_ascii_digit() {
        let j = lx.digits(i + 1);
        let num = s[i + 1..j]
            .iter()
            .try_fold(0u32, |acc, &c| {
                acc.checked_mul(10)?.checked_add((c - b'0') as u32)
            })
            .unwrap_or(u32::MAX);
        b.push(TokenKind::BlockNumber(num), i, j);
        i = sp(b, j);
    }
    seg.body = b.tokens.len();
    if i < n {
        i = if lx.fanuc {
            fanuc_body(lx, b, i, &mut seg)?
        } else {
            linuxcnc_body(lx, b, i, &mut seg)?
        };
    }
    finish(b, &seg);
    Ok(i)
}

fn finish(b: &mut Block, seg: &Seg) {
    b.segments.push(Segment {
        first: seg.first as u32,
        end: b.tokens.len() as u32,
        stmt: seg.stmt,
        body: seg.body as u32,
        unknown: seg.unknown,
        entry: Entry::AsWritten,
    });
}

/// Spaces and comments up to the end of the statement (FANUC: through its
/// `;`); anything else is an error.
fn tail(lx: &Lexer, b: &mut Block, mut i: usize, what: &str) -> Result<usize, BlockError> {
    let s = lx.s;
    while i < lx.n {
        let c = s[i];
        if is_space(c) {
            let j = lx.spaces(i);
            b.push(TokenKind::Space, i, j);
            i = j;
        } else if c == b'(' {
            let j = lx.comment(i)?;
            b.push(TokenKind::Comment, i, j);
            i = j;
        } else if c == b';' {
            if lx.fanuc {
                b.push(TokenKind::Eob, i, i + 1);
                return Ok(i + 1);
            }
            b.push(TokenKind::Comment, i, lx.n);
            return Ok(lx.n);
        } else {
            return Err(BlockError::new(
                i,
                format!(
                    "unexpected `{}` after {what}: expected a comment or the end of the block",
                    String::from_utf8_lossy(&s[i..i + word_end(&s[i..lx.n]).max(1)])
                ),
            ));
        }
    }
    Ok(i)
}

fn fanuc_body(lx: &Lexer, b: &mut Block, i: usize, seg: &mut Seg) -> Result<usize, BlockError> {
    let s = lx.s;
    let n = lx.n;
    let rest = &s[i..n];
    // Program number: O1234 or :1234.
    if (rest[0] == b'O' || rest[0] == b'o' || rest[0] == b':')
        && rest.get(1).is_some_and(|c| c.is_ascii_digit())
    {
        let j = lx.digits(i + 1);
        b.push(TokenKind::ProgramNumber, i, j);
        seg.stmt = Stmt::ProgramNumber;
        return tail(lx, b, j, "the program number");
    }
    if rest[0] == b'#' {
        seg.stmt = Stmt::Assign;
        return fanuc_assign(lx, b, i);
    }
    // Statement keywords start with one of these letters; most blocks are
    // words and skip the comparisons.
    if !matches!(
        rest[0].to_ascii_uppercase(),
        b'I' | b'G' | b'W' | b'D' | b'E' | b'B' | b'P'
    ) {
        return words(lx, b, i, seg);
    }
    let kw = |k: &str| starts_with_ci(rest, k);
    if kw("IF") && !rest.get(2).is_some_and(|c| c.is_ascii_digit()) {
        b.push(TokenKind::Keyword, i, i + 2);
        let j = cond(lx, b, i + 2, "IF")?;
        let j = spaces_tok(lx, b, j);
        let r = &s[j..n];
        if starts_with_ci(r, "GOTO") {
            seg.stmt = Stmt::Flow(Flow::Jump);
            return goto(lx, b, j);
        }
        if starts_with_ci(r, "THEN") {
            b.push(TokenKind::Keyword, j, j + 4);
            seg.stmt = Stmt::Flow(Flow::Branch);
            let k = spaces_tok(lx, b, j + 4);
            if k < n && s[k] == b'#' {
                return fanuc_assign(lx, b, k);
            }
            return Err(BlockError::new(
                k,
                "IF [...] THEN needs an assignment (#n = ...) after THEN",
            ));
        }
        return Err(BlockError::new(
            j,
            "IF [...] must be followed by GOTO n or THEN #n = ...",
        ));
    }
    if kw("GOTO") {
        seg.stmt = Stmt::Flow(Flow::Jump);
        return goto(lx, b, i);
    }
    if kw("WHILE") {
        b.push(TokenKind::Keyword, i, i + 5);
        let j = cond(lx, b, i + 5, "WHILE")?;
        let j = spaces_tok(lx, b, j);
        if !starts_with_ci(&s[j..n], "DO") {
            return Err(BlockError::new(
                j,
                "WHILE [...] must be followed by DO1..DO3",
            ));
        }
        let k = loop_id(lx, b, j, 2)?;
        seg.stmt = Stmt::Flow(Flow::LoopStart);
        return tail(lx, b, k, "WHILE ... DO");
    }
    if kw("DO") && rest.get(2).is_some_and(|c| c.is_ascii_digit()) {
        let k = loop_id(lx, b, i, 2)?;
        seg.stmt = Stmt::Flow(Flow::LoopStart);
        return tail(lx, b, k, "DO");
    }
    if kw("END") && rest.get(3).is_some_and(|c| c.is_ascii_digit()) {
        let k = loop_id(lx, b, i, 3)?;
        seg.stmt = Stmt::Flow(Flow::LoopEnd);
        return tail(lx, b, k, "END");
    }
    for k in ["DPRNT", "BPRNT"] {
        if kw(k) {
            b.push(TokenKind::Keyword, i, i + 5);
            let j = i + 5;
            if j >= n || s[j] != b'[' {
                return Err(BlockError::new(
                    j,
                    format!("{k} needs its arguments in [ ]"),
                ));
            }
            let mut depth = 0i32;
            let mut e = j;
            while e < n {
                match s[e] {
                    b'[' => depth += 1,
                    b']' => {
                        depth -= 1;
                        if depth == 0 {
                            break;
                        }
                    }
                    _ => {}
                }
                e += 1;
            }
            if e >= n {
                return Err(BlockError::new(
                    j,
                    format!("{k}[ is not closed: expected `]`"),
                ));
            }
            b.push(TokenKind::Text, j, e + 1);
            seg.stmt = Stmt::Output;
            return tail(lx, b, e + 1, k);
        }
    }
    for k in ["POPEN", "PCLOS"] {
        if kw(k) {
            b.push(TokenKind::Keyword, i, i + 5);
            seg.stmt = Stmt::Output;
            return tail(lx, b, i + 5, k);
        }
    }
    words(lx, b, i, seg)
}

fn spaces_tok(lx: &Lexer, b: &mut Block, i: usize) -> usize {
    let j = lx.spaces(i);
    if j > i {
        b.push(TokenKind::Space, i, j);
    }
    j
}

fn cond(lx: &Lexer, b: &mut Block, i: usize, kw: &str) -> Result<usize, BlockError> {
    let j = spaces_tok(lx, b, i);
    match expr::bracketed_len(&lx.s[j..lx.n]).map_err(|e| too_deep(j, e))? {
        Some(len) => {
            b.push(TokenKind::Expr, j, j + len);
            Ok(j + len)
        }
        None => Err(BlockError::new(
            j,
            format!("{kw} needs a condition in [ ], e.g. {kw} [#1 GT 0]"),
        )),
    }
}

fn goto(lx: &Lexer, b: &mut Block, i: usize) -> Result<usize, BlockError> {
    b.push(TokenKind::Keyword, i, i + 4);
    let j = spaces_tok(lx, b, i + 4);
    let rest = &lx.s[j..lx.n];
    let len = if rest.first().is_some_and(|c| c.is_ascii_digit()) {
        lx.digits(j) - j
    } else {
        expr::real_value_len(rest)
            .map_err(|e| too_deep(j, e))?
            .unwrap_or(0)
    };
    if len == 0 {
        return Err(BlockError::new(
            j,
            "GOTO needs a block number, a #parameter or a [ ] expression",
        ));
    }
    b.push(TokenKind::Expr, j, j + len);
    tail(lx, b, j + len, "GOTO")
}

fn loop_id(lx: &Lexer, b: &mut Block, i: usize, kw_len: usize) -> Result<usize, BlockError> {
    let j = lx.digits(i + kw_len);
    if j == i + kw_len {
        return Err(BlockError::new(
            i + kw_len,
            "expected a loop number (1 to 3)",
        ));
    }
    b.push(TokenKind::Keyword, i, j);
    Ok(j)
}

/// `#target = expression` (FANUC: the right-hand side needs no brackets).
fn fanuc_assign(lx: &Lexer, b: &mut Block, i: usize) -> Result<usize, BlockError> {
    let s = lx.s;
    let n = lx.n;
    let Some(len) = expr::param_len(&s[i..n]).map_err(|e| too_deep(i, e))? else {
        return Err(BlockError::new(
            i,
            "expected a parameter (#1, #100, #[expression]) to assign",
        ));
    };
    b.push(TokenKind::Param, i, i + len);
    let j = spaces_tok(lx, b, i + len);
    if j >= n || s[j] != b'=' {
        return Err(BlockError::new(j, "expected `=` after the parameter"));
    }
    b.push(TokenKind::Assign, j, j + 1);
    let k = spaces_tok(lx, b, j + 1);
    let Some(len) = expr::expr_len(&s[k..n]).map_err(|e| too_deep(k, e))? else {
        return Err(BlockError::new(
            k,
            "expected an expression after `=` (number, #parameter, [ ], function)",
        ));
    };
    b.push(TokenKind::Expr, k, k + len);
    tail(lx, b, k + len, "the assignment")
}

fn linuxcnc_body(lx: &Lexer, b: &mut Block, i: usize, seg: &mut Seg) -> Result<usize, BlockError> {
    let s = lx.s;
    let n = lx.n;
    if s[i] == b'o' || s[i] == b'O' {
        let mut j = i + 1;
        if j < n && s[j] == b'<' {
            match s[j..n].iter().position(|&c| c == b'>') {
                Some(p) => j += p + 1,
                None => return Err(BlockError::new(j, "o<name is not closed: expected `>`")),
            }
        } else if j < n && s[j].is_ascii_digit() {
            j = lx.digits(j);
        } else {
            return Err(BlockError::new(
                j,
                "an o-word needs a number or a <name> (o100, o<probe>)",
            ));
        }
        let k = lx.spaces(j);
        let rest = &s[k..n];
        let found = OWORD_KEYWORDS.iter().find(|(kw, _)| {
            starts_with_ci(rest, kw)
                && !rest
                    .get(kw.len())
                    .is_some_and(|c| c.is_ascii_alphanumeric())
        });
        let Some(&(kw, flow)) = found else {
            // `O1234 (title)`: a FANUC-style program number.
            b.push(TokenKind::ProgramNumber, i, j);
            seg.stmt = Stmt::ProgramNumber;
            return tail(lx, b, j, "the program number");
        };
        b.push(TokenKind::Keyword, i, j);
        let mut at = spaces_tok(lx, b, j);
        b.push(TokenKind::Keyword, at, at + kw.len());
        at += kw.len();
        seg.stmt = Stmt::Flow(flow);
        loop {
            let k = spaces_tok(lx, b, at);
            if k < n && s[k] == b'[' {
                let Some(len) = expr::bracketed_len(&s[k..n]).map_err(|e| too_deep(k, e))? else {
                    return Err(BlockError::new(k, "malformed [ ] expression"));
                };
                b.push(TokenKind::Expr, k, k + len);
                at = k + len;
            } else {
                return tail(lx, b, k, "the o-word");
            }
        }
    }
    words(lx, b, i, seg)
}

/// Address words (and, on LinuxCNC, parameter assignments and `;`
/// comments) up to the end of the statement.
fn words(lx: &Lexer, b: &mut Block, mut i: usize, seg: &mut Seg) -> Result<usize, BlockError> {
    let s = lx.s;
    let n = lx.n;
    while i < n {
        let c = s[i];
        if is_space(c) {
            let j = lx.spaces(i);
            b.push(TokenKind::Space, i, j);
            i = j;
        } else if c == b'(' {
            let j = lx.comment(i)?;
            b.push(TokenKind::Comment, i, j);
            i = j;
        } else if c == b';' {
            if lx.fanuc {
                b.push(TokenKind::Eob, i, i + 1);
                return Ok(i + 1);
            }
            b.push(TokenKind::Comment, i, n);
            i = n;
        } else if c == b'#' && !lx.fanuc {
            let Some(len) = expr::param_len(&s[i..n]).map_err(|e| too_deep(i, e))? else {
                return Err(BlockError::new(i, "expected a parameter (#1, #<name>)"));
            };
            b.push(TokenKind::Param, i, i + len);
            let j = spaces_tok(lx, b, i + len);
            if j >= n || s[j] != b'=' {
                return Err(BlockError::new(
                    j,
                    "expected `=` after the parameter (a parameter alone is not a word)",
                ));
            }
            b.push(TokenKind::Assign, j, j + 1);
            let k = spaces_tok(lx, b, j + 1);
            let Some(len) = expr::real_value_len(&s[k..n]).map_err(|e| too_deep(k, e))? else {
                return Err(BlockError::new(
                    k,
                    "expected a value after `=`: a number, a #parameter or a [ ] expression",
                ));
            };
            b.push(TokenKind::Expr, k, k + len);
            if seg.stmt == Stmt::Blank {
                seg.stmt = Stmt::Assign;
            }
            i = k + len;
        } else if c.is_ascii_alphabetic() || (!lx.fanuc && matches!(c, b'@' | b'^' | b'$')) {
            // LinuxCNC's `@` and `^` are the polar distance and angle,
            // `$` selects the spindle an M3/M4/M5/S word is for (LinuxCNC
            // 2.8 and later, G-code reference "Spindle Control"; no axis).
            let letter = c.to_ascii_uppercase();
            let j = lx.spaces(i + 1);
            let (value, style, end) = lx.value(j, letter)?;
            let w = Word {
                addr: Addr::letter(letter),
                incremental: false,
                value,
                value_span: Span::new(j, end),
                style,
            };
            let unknown = if letter == b'O' {
                Some("an O word inside a block (program numbers and o-words start a line)")
            } else if !lx.fanuc && letter == b'E' {
                Some("LinuxCNC has no E address")
            } else if letter == b'G' {
                match value {
                    Value::Num(v) => match g_code(v) {
                        Some(g) if known_g(lx.syn.dialect, g) => None,
                        _ => Some("an unknown G code"),
                    },
                    _ => None,
                }
            } else {
                None
            };
            if let Some(why) = unknown {
                if lx.syn.strict || letter == b'O' {
                    return Err(BlockError::new(
                        i,
                        format!(
                            "unknown word `{}`: {why} for {}",
                            String::from_utf8_lossy(&s[i..end]),
                            lx.syn.dialect
                        ),
                    ));
                }
                seg.unknown.get_or_insert(Span::new(i, end));
            }
            b.push(TokenKind::Word(w), i, end);
            if seg.stmt == Stmt::Blank || seg.stmt == Stmt::Assign {
                seg.stmt = Stmt::Words;
            }
            i = end;
        } else {
            return Err(BlockError::new(
                i,
                format!(
                    "unexpected character `{}`: expected a word (letter and number), a comment or the end of the block",
                    String::from_utf8_lossy(&s[i..(i + utf8_len(c)).min(n)])
                ),
            ));
        }
    }
    Ok(i)
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

    fn parse_str(src: &str, d: Dialect, strict: bool) -> Result<Block, BlockError> {
        Syntax { dialect: d, strict }.block(src)
    }

    fn kinds(b: &Block) -> Vec<String> {
        b.tokens
            .iter()
            .map(|t| {
                let txt = String::from_utf8_lossy(b.bytes(t.span)).to_string();
                match t.kind {
                    TokenKind::Word(_) => format!("W:{txt}"),
                    TokenKind::Space => "_".into(),
                    k => format!("{k:?}:{txt}"),
                }
            })
            .collect()
    }

    #[test]
    fn fanuc_words_keep_their_lexemes() {
        let b = parse_str("N10 G01 X1. Y-.5 Z10(c)F1500.;\n", Dialect::Fanuc, true).unwrap();
        let words: Vec<(String, Value)> = b
            .words(&b.segments[0])
            .map(|(_, w)| (w.addr.to_string(), w.value))
            .collect();
        assert_eq!(
            words,
            vec![
                ("G".into(), Value::Num(1.0)),
                ("X".into(), Value::Num(1.0)),
                ("Y".into(), Value::Num(-0.5)),
                ("Z".into(), Value::Num(10.0)),
                ("F".into(), Value::Num(1500.0)),
            ]
        );
        assert!(matches!(b.tokens[0].kind, TokenKind::BlockNumber(10)));
        assert_eq!(b.tokens.last().unwrap().kind, TokenKind::LineEnd);
        assert!(kinds(&b).contains(&"Eob:;".to_string()));
    }

    #[test]
    fn fanuc_semicolon_separates_blocks_on_one_line() {
        let b = parse_str("G0 X1;G1 X2 F100.;\n", Dialect::Fanuc, true).unwrap();
        assert_eq!(b.segments.len(), 2);
        assert_eq!(b.segments[1].stmt, Stmt::Words);
    }

    #[test]
    fn macro_b_statements() {
        for (src, stmt) in [
            ("#101=#5061+1.5\n", Stmt::Assign),
            ("#[#2000+#13]=0\n", Stmt::Assign),
            ("N1 IF [#2 NE #0] GOTO2\n", Stmt::Flow(Flow::Jump)),
            ("IF[#4119GE2600]GOTO002\n", Stmt::Flow(Flow::Jump)),
            ("IF[#32GT180]THEN #32=#32-360\n", Stmt::Flow(Flow::Branch)),
            ("N3 WHILE [#19 GT 0] DO1\n", Stmt::Flow(Flow::LoopStart)),
            ("END1\n", Stmt::Flow(Flow::LoopEnd)),
            ("GOTO999\n", Stmt::Flow(Flow::Jump)),
            ("DPRNT[X#5061[44]*Z#5063[53]]\n", Stmt::Output),
            ("POPEN\n", Stmt::Output),
            ("O1234 (TITLE)\n", Stmt::ProgramNumber),
            ("%\n", Stmt::Percent),
        ] {
            let b = parse_str(src, Dialect::Fanuc, true).unwrap_or_else(|e| panic!("{src}: {e:?}"));
            assert_eq!(b.segments[0].stmt, stmt, "{src}");
        }
    }

    #[test]
    fn expressions_as_word_values() {
        let b = parse_str("G90 X[#1+2.] Y#5062 Z-#3\n", Dialect::Fanuc, true).unwrap();
        let vals: Vec<Value> = b.words(&b.segments[0]).map(|(_, w)| w.value).collect();
        assert_eq!(
            vals,
            vec![Value::Num(90.0), Value::Expr, Value::Expr, Value::Expr]
        );
    }

    #[test]
    fn linuxcnc_owords_parameters_and_comments() {
        for (src, stmt) in [
            ("o100 sub\n", Stmt::Flow(Flow::Label)),
            ("o<probe> call [1.5] [#<x>]\n", Stmt::Flow(Flow::Call)),
            ("O101 while [#1 LT 10]\n", Stmt::Flow(Flow::LoopStart)),
            ("o101 endwhile\n", Stmt::Flow(Flow::LoopEnd)),
            ("o100 endsub [#1]\n", Stmt::Flow(Flow::Return)),
            ("#<zmachine> = [#5063 + #5023 - #5422]\n", Stmt::Assign),
            ("g1 x1 #1=2 ; a comment\n", Stmt::Words),
            ("O1234 (T)\n", Stmt::ProgramNumber),
            ("(PROBEOPEN results.txt)\n", Stmt::Blank),
        ] {
            let b =
                parse_str(src, Dialect::Linuxcnc, true).unwrap_or_else(|e| panic!("{src}: {e:?}"));
            assert_eq!(b.segments[0].stmt, stmt, "{src}");
        }
    }

    #[test]
    fn linuxcnc_polar_words_bom_dos_end_of_file_and_nesting() {
        let b = parse_str("G81 R2 Z-5 @10 ^60\n", Dialect::Linuxcnc, true).unwrap();
        let addrs: Vec<String> = b
            .words(&b.segments[0])
            .map(|(_, w)| w.addr.to_string())
            .collect();
        assert_eq!(addrs, ["G", "R", "Z", "@", "^"]);
        let b = parse_str("\u{FEFF}%\n", Dialect::Fanuc, true).unwrap();
        assert_eq!(b.tokens[0].kind, TokenKind::Text);
        assert!(b.tokens.iter().any(|t| t.kind == TokenKind::Percent));
        let b = parse_str("\u{1A}\n", Dialect::Fanuc, true).unwrap();
        assert!(
            !b.tokens
                .iter()
                .any(|t| matches!(t.kind, TokenKind::Word(_)))
        );
        let deep = format!("X{}1{}\n", "[".repeat(200_000), "]".repeat(200_000));
        let e = parse_str(&deep, Dialect::Fanuc, false).unwrap_err();
        assert!(e.message.contains("nested deeper"), "{}", e.message);
        assert_eq!(e.offset, 1 + crate::limits::MAX_EXPR_DEPTH);
        let chain = format!("#1={}2\n", "#".repeat(200_000));
        let e = parse_str(&chain, Dialect::Linuxcnc, false).unwrap_err();
        assert!(e.message.contains("nested deeper"), "{}", e.message);
        assert_eq!(e.offset, 3 + crate::limits::MAX_EXPR_DEPTH + 1);
        let huge = format!("G1 X1{}\n", "0".repeat(400));
        let e = parse_str(&huge, Dialect::Fanuc, false).unwrap_err();
        assert!(e.message.contains("too large"), "{}", e.message);
    }

    #[test]
    fn malformed_lines_name_the_column_and_what_was_expected() {
        let e = parse_str("G0 X1 Y2 (a\n", Dialect::Linuxcnc, false).unwrap_err();
        assert_eq!(e.offset, 9);
        assert!(e.message.contains("unclosed comment"), "{}", e.message);
        let e = parse_str("G1 X1.2.3\n", Dialect::Fanuc, false).unwrap_err();
        assert_eq!(e.offset, 4);
        assert!(e.message.contains("bad number `1.2.3`"), "{}", e.message);
        let e = parse_str("G1 X\n", Dialect::Fanuc, false).unwrap_err();
        assert!(e.message.contains("bad number"), "{}", e.message);
        let e = parse_str("G1 E5\n", Dialect::Linuxcnc, true).unwrap_err();
        assert!(e.message.contains("unknown word `E5`"), "{}", e.message);
        let b = parse_str("G1 E5\n", Dialect::Linuxcnc, false).unwrap();
        assert!(b.segments[0].unknown.is_some());
        let e = parse_str("G12.7 X1\n", Dialect::Fanuc, true).unwrap_err();
        assert!(e.message.contains("unknown G code"), "{}", e.message);
    }
}
