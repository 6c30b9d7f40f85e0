//! HEIDENHAIN TNC Klartext (conversational) blocks.
//!
//! A block is `[/][n] [/] <keyword> ...`: the number is optional, block
//! delete may stand before or after it (both occur in real files), and a
//! trailing `~` continues the block on the next line (cycle parameters
//! `Q200=+2 ;SET-UP CLEARANCE ~`). Blocks are classified by their keyword
//! and, for cycles, by the cycle number only: the cycle text is in the
//! operator's language. Path blocks (`L`, `C`, `CC`, `CR`, `CP`, `APPR`,
//! ...) are split into words (`X+10`, `IX-2`, `Y+Q1`, `PA+30`, `R0`, `RL`,
//! `DR-`, `F500`, `FMAX`, `F MAX`, `M128`); everything else into atoms that
//! are words where they look like one (`SPB+30`, `S4456`, `M3`) and text
//! otherwise.

use super::Syntax;
use crate::nc::{
    Addr, Block, BlockError, Entry, HhKind, Segment, Span, Stmt, TokenKind, Value, Word, is_space,
    lexeme, line_end_at,
};

/// Keywords in match order (longest first where one is a prefix of another).
const KEYWORDS: &[(&str, HhKind)] = &[
    ("BEGIN PGM", HhKind::BeginPgm),
    ("END PGM", HhKind::EndPgm),
    ("BLK FORM", HhKind::BlkForm),
    ("TOOL CALL", HhKind::ToolCall),
    ("TOOL DEF", HhKind::ToolDef),
    ("CYCL CALL", HhKind::CyclCall),
    ("TCH PROBE", HhKind::TchProbe),
    ("PLANE RESET", HhKind::PlaneReset),
    ("PLANE", HhKind::Plane),
    ("FUNCTION RESET TCPM", HhKind::FunctionResetTcpm),
    ("FUNCTION TCPM", HhKind::FunctionTcpm),
    ("FUNCTION", HhKind::Function),
    ("CALL LBL", HhKind::CallLbl),
    ("CALL PGM", HhKind::CallPgm),
    ("CALL SELECTED", HhKind::CallPgm),
    ("SEL PGM", HhKind::CallPgm),
    ("LBL", HhKind::Lbl),
    ("STOP", HhKind::Stop),
    ("APPR", HhKind::Appr),
    ("DEP", HhKind::Dep),
    ("LN", HhKind::Ln),
    ("LP", HhKind::Lp),
    ("L", HhKind::L),
    ("CC", HhKind::Cc),
    ("CP", HhKind::Cp),
    ("CR", HhKind::Cr),
    ("CT", HhKind::Ct),
    ("C", HhKind::C),
    ("RND", HhKind::Rnd),
    ("CHF", HhKind::Chf),
    ("PRESET", HhKind::Other),
    ("DECLARE", HhKind::Other),
    ("SEL TABLE", HhKind::Other),
    ("SEL CORR-TABLE", HhKind::Other),
    ("SEL CYCLE", HhKind::Other),
    ("CONTOUR DEF", HhKind::Other),
    ("SPEC FCT", HhKind::Other),
    ("SQL", HhKind::Other),
    ("PATTERN DEF", HhKind::Other),
    ("POLARKIN", HhKind::Other),
    ("FUNCTION", HhKind::Function),
    ("TRANS", HhKind::Other),
    ("OPEN CONTOUR", HhKind::Other),
    ("WAIT", HhKind::Other),
];

/// Sub-keywords of `APPR`/`DEP`.
const APPR_TYPES: [&str; 8] = ["PLCT", "PLT", "PLN", "PCT", "LCT", "LT", "LN", "CT"];

/// Path-block word addresses (longest first).
const PATH_ADDRS: [&str; 28] = [
    "FMAX", "FAUTO", "LEN", "CCA", "IPA", "IPR", "PA", "PR", "NX", "NY", "NZ", "TX", "TY", "TZ",
    "DR", "RL", "RR", "FU", "FZ", "X", "Y", "Z", "A", "B", "C", "U", "V", "W",
];

fn starts_kw(s: &[u8], kw: &str) -> bool {
    if s.len() < kw.len() || !s[..kw.len()].eq_ignore_ascii_case(kw.as_bytes()) {
        return false;
    }
    // A keyword ends at a space, a sign or digit for glued forms (`FN0:`,
    // `CYCL DEF9`), or the end.
    match s.get(kw.len()) {
        None => true,
        Some(&c) => is_space(c) || c == b'\r' || c == b'\n' || c == b';' || c == b'~',
    }
}

struct Lx<'a> {
    s: &'a [u8],
    strict: bool,
}

impl<'a> Lx<'a> {
    fn spaces(&self, mut i: usize) -> usize {
        while i < self.s.len() && is_space(self.s[i]) {
            i += 1;
        }
        i
    }

    /// End of the current physical line's content (before its ending: LF,
    /// CRLF or a bare CR).
    fn line_end(&self, i: usize) -> usize {
        let mut j = i;
        while j < self.s.len() && line_end_at(self.s, j) == 0 {
            j += 1;
        }
        j
    }

    /// Where a comment starting at `i` ends: the end of the line, or before
    /// a trailing `~` (and the spaces before it).
    fn comment_end(&self, i: usize) -> usize {
        let e = self.line_end(i);
        let mut k = e;
        while k > i && is_space(self.s[k - 1]) {
            k -= 1;
        }
        if k > i + 1 && self.s[k - 1] == b'~' {
            let mut m = k - 1;
            while m > i + 1 && is_space(self.s[m - 1]) {
                m -= 1;
            }
            return m;
        }
        e
    }
}

/// Tokenizes one Klartext block (with its continuation lines).
pub(super) fn parse_text(syn: &Syntax, s: &[u8], b: &mut Block) -> Result<(), BlockError> {
    let lx = Lx {
        s,
        strict: syn.strict,
    };
    let mut seg = Segment {
        first: 0,
        end: 0,
        stmt: Stmt::Blank,
        body: 0,
        unknown: None,
        entry: Entry::AsWritten,
    };
    let sp = |b: &mut Block, i: usize| {
        let j = lx.spaces(i);
        if j > i {
            b.push(TokenKind::Space, i, j);
        }
        j
    };
    let mut i = 0;
    if b.line == 1 && s.starts_with(super::BOM) {
        b.push(TokenKind::Text, 0, super::BOM.len());
        i = super::BOM.len();
    }
    i = sp(b, i);
    if i < s.len() && s[i] == super::DOS_EOF {
        // DOS's end-of-file mark: nothing after it is part of the program.
        b.push(TokenKind::Text, i, s.len());
        seg.end = b.tokens.len() as u32;
        b.segments.push(seg);
        return Ok(());
    }
    if i < s.len() && s[i] == b'/' {
        b.push(TokenKind::BlockDelete, i, i + 1);
        i = sp(b, i + 1);
    }
    if i < s.len() && s[i].is_ascii_digit() {
        let mut j = i;
        while j < s.len() && s[j].is_ascii_digit() {
            j += 1;
        }
        let num = s[i..j]
            .iter()
            .try_fold(0u32, |acc, &c| {
                acc.checked_mul(10)?.checked_add((c - b'0') as u32)
            })
            .unwrap_or(u32::MAX);
        b.push(TokenKind::BlockNumber(num), i, j);
        i = sp(b, j);
        if i < s.len() && s[i] == b'/' {
            b.push(TokenKind::BlockDelete, i, i + 1);
            i = sp(b, i + 1);
        }
    }
    seg.body = b.tokens.len() as u32;
    let rest = &s[i..];
    let eol = lx.line_end(i);
    if i >= eol {
        // Blank line.
    } else if rest[0] == b';' {
        let e = lx.comment_end(i);
        b.push(TokenKind::Comment, i, e);
        seg.stmt = Stmt::Hh(HhKind::Comment);
        i = e;
    } else if rest[0] == b'*' {
        let e = lx.comment_end(i);
        b.push(TokenKind::Text, i, e);
        seg.stmt = Stmt::Hh(HhKind::Structure);
        i = e;
    } else {
        let (kind, kw_end) = keyword(&lx, i)?;
        if kw_end > i {
            b.push(TokenKind::Keyword, i, kw_end);
        }
        seg.stmt = Stmt::Hh(kind);
        i = match kind {
            HhKind::L
            | HhKind::Ln
            | HhKind::Lp
            | HhKind::C
            | HhKind::Cc
            | HhKind::Cp
            | HhKind::Cr
            | HhKind::Ct
            | HhKind::Appr
            | HhKind::Dep
            | HhKind::M => path_words(&lx, b, kw_end, &mut seg)?,
            _ => atoms(&lx, b, kw_end)?,
        };
    }
    // The rest: continuation lines (cycle parameters) and the ending.
    let _ = atoms(&lx, b, i)?;
    seg.end = b.tokens.len() as u32;
    b.segments.push(seg);
    Ok(())
}

/// Reads the block keyword at `i`; returns the kind and where it ends.
fn keyword(lx: &Lx, i: usize) -> Result<(HhKind, usize), BlockError> {
    let s = lx.s;
    let rest = &s[i..];
    if starts_kw(rest, "CYCL DEF") || rest.len() > 8 && rest[..8].eq_ignore_ascii_case(b"CYCL DEF")
    {
        let mut j = lx.spaces(i + 8);
        let d0 = j;
        while j < s.len() && s[j].is_ascii_digit() {
            j += 1;
        }
        if j == d0 {
            return Err(BlockError::new(j, "CYCL DEF needs a cycle number"));
        }
        let number = std::str::from_utf8(&s[d0..j]).unwrap().parse().unwrap_or(0);
        let k = lx.spaces(j);
        let mut sub = None;
        if k < s.len() && s[k] == b'.' {
            let mut m = k + 1;
            while m < s.len() && s[m].is_ascii_digit() {
                m += 1;
            }
            sub = std::str::from_utf8(&s[k + 1..m])
                .ok()
                .and_then(|t| t.parse().ok());
            j = m;
        }
        return Ok((HhKind::CyclDef { number, sub }, j));
    }
    if rest.len() >= 2 && rest[..2].eq_ignore_ascii_case(b"FN") {
        let mut j = lx.spaces(i + 2);
        let d0 = j;
        while j < s.len() && s[j].is_ascii_digit() {
            j += 1;
        }
        let k = lx.spaces(j);
        if j > d0 && k < s.len() && s[k] == b':' {
            let n = std::str::from_utf8(&s[d0..j]).unwrap().parse().unwrap_or(0);
            return Ok((HhKind::Fn(n), k + 1));
        }
    }
    // Q parameter formulas: Q1 = ..., QL2 = ..., QR3 = ..., QS4 = "...".
    if (rest[0] == b'Q' || rest[0] == b'q') && rest.len() > 1 {
        let mut j = 1;
        if rest[j].is_ascii_alphabetic()
            && matches!(rest[j].to_ascii_uppercase(), b'L' | b'R' | b'S')
        {
            j += 1;
        }
        let d0 = j;
        while j < rest.len() && rest[j].is_ascii_digit() {
            j += 1;
        }
        if j > d0 {
            let k = lx.spaces(i + j) - i;
            if rest.get(k) == Some(&b'=') {
                return Ok((HhKind::Q, i + j));
            }
        }
    }
    // A block of M functions only.
    if (rest[0] == b'M' || rest[0] == b'm') && rest.get(1).is_some_and(|c| c.is_ascii_digit()) {
        return Ok((HhKind::M, i));
    }
    for &(kw, kind) in KEYWORDS {
        if starts_kw(rest, kw) {
            let mut end = i + kw.len();
            if matches!(kind, HhKind::Appr | HhKind::Dep) {
                let j = lx.spaces(end);
                if let Some(t) = APPR_TYPES.iter().find(|t| starts_kw(&s[j..], t)) {
                    end = j + t.len();
                }
            }
            return Ok((kind, end));
        }
    }
    let w = rest
        .iter()
        .position(|&c| is_space(c) || c == b'\r' || c == b'\n')
        .unwrap_or(rest.len());
    if lx.strict {
        return Err(BlockError::new(
            i,
            format!(
                "unknown block `{}`: expected a Klartext block (L, C, CC, CR, CP, TOOL CALL, CYCL DEF, PLANE, FN, Q..., LBL, ...)",
                String::from_utf8_lossy(&rest[..w])
            ),
        ));
    }
    Ok((HhKind::Other, i))
}

/// The value of a path word at `i` (before `e`, the end of the line):
/// `(value, style, start, end)`. Spaces may stand between the address, a
/// sign and the value as older posts and hand-written programs put them
/// (`Z 25.000`, `Z + Q13`); the decimal separator is a point or, on older
/// controls, a comma (`X+32,000`); a Q parameter (`Q13`, `QL2`, `QR3`) is
/// an expression.
fn value_at(s: &[u8], i: usize, e: usize) -> Option<(Value, lexeme::NumStyle, usize, usize)> {
    let spaces = |mut k: usize| {
        while k < e && is_space(s[k]) {
            k += 1;
        }
        k
    };
    let start = spaces(i);
    let mut j = start;
    let mut neg = false;
    let mut plus = false;
    if j < e && (s[j] == b'+' || s[j] == b'-') {
        neg = s[j] == b'-';
        plus = !neg;
        j = spaces(j + 1);
    }
    let body = &s[j..e];
    let scanned = match lexeme::scan(body) {
        // `32,000`: the point scan stops at the comma.
        Some((_, n)) if body.get(n) == Some(&b',') => lexeme::scan_with(body, b','),
        Some(found) => Some(found),
        None => lexeme::scan_with(body, b','),
    };
    if let Some((lx, n)) = scanned {
        if body
            .get(n)
            .is_some_and(|&c| c == b'.' || c == b',' || c.is_ascii_digit())
        {
            return None;
        }
        if (neg || plus) && matches!(body[0], b'+' | b'-') {
            // Two signs.
            return None;
        }
        if !lx.value.is_finite() {
            return None;
        }
        let mut style = lx.style;
        style.plus |= plus;
        let v = if neg { -lx.value } else { lx.value };
        return Some((Value::Num(v), style, start, j + n));
    }
    // Q<n>, QL<n>, QR<n>
    let mut k = j;
    if k < e && (s[k] == b'Q' || s[k] == b'q') {
        k += 1;
        if k < e && matches!(s[k].to_ascii_uppercase(), b'L' | b'R') {
            k += 1;
        }
        let d0 = k;
        while k < e && s[k].is_ascii_digit() {
            k += 1;
        }
        if k > d0 {
            return Some((Value::Expr, lexeme::NumStyle::default(), start, k));
        }
    }
    None
}

fn at_boundary(s: &[u8], i: usize) -> bool {
    i >= s.len() || is_space(s[i]) || s[i] == b';' || s[i] == b'\r' || s[i] == b'\n' || s[i] == b'~'
}

/// The words of a path block.
fn path_words(
    lx: &Lx,
    b: &mut Block,
    mut i: usize,
    seg: &mut Segment,
) -> Result<usize, BlockError> {
    let s = lx.s;
    let e = lx.line_end(i);
    while i < e {
        let c = s[i];
        if is_space(c) {
            let j = lx.spaces(i);
            b.push(TokenKind::Space, i, j);
            i = j;
            continue;
        }
        if c == b';' || c == b'~' {
            break;
        }
        let start = i;
        let mut incremental = false;
        let mut j = i;
        let upper = |k: usize| s.get(k).map(|c| c.to_ascii_uppercase());
        if upper(j) == Some(b'I')
            && matches!(
                upper(j + 1),
                Some(b'X' | b'Y' | b'Z' | b'A' | b'B' | b'C' | b'U' | b'V' | b'W' | b'P')
            )
        {
            incremental = true;
            j += 1;
        }
        // R0 / RL / RR radius compensation, DR+ / DR- direction.
        let word = |addr: &str, vend: usize, b: &mut Block| {
            b.push(
                TokenKind::Word(Word {
                    addr: Addr::new(addr),
                    incremental,
                    value: Value::None,
                    value_span: Span::new(vend, vend),
                    style: lexeme::NumStyle::default(),
                }),
                start,
                vend,
            );
        };
        let rest = &s[j..e];
        if !incremental
            && rest.len() >= 2
            && rest[..2].eq_ignore_ascii_case(b"R0")
            && at_boundary(s, j + 2)
        {
            word("R0", j + 2, b);
            i = j + 2;
            continue;
        }
        if !incremental
            && rest.len() >= 3
            && rest[..2].eq_ignore_ascii_case(b"DR")
            && (rest[2] == b'+' || rest[2] == b'-')
            && at_boundary(s, j + 3)
        {
            word("DR", j + 3, b);
            i = j + 3;
            continue;
        }
        if !incremental && rest.len() >= 5 && rest[..1].eq_ignore_ascii_case(b"F") {
            // `F MAX` and `F AUTO`, written with a space.
            let k = lx.spaces(j + 1);
            let kw = [("MAX", "FMAX"), ("AUTO", "FAUTO")]
                .into_iter()
                .find(|(kw, _)| {
                    s.len() >= k + kw.len()
                        && s[k..k + kw.len()].eq_ignore_ascii_case(kw.as_bytes())
                        && at_boundary(s, k + kw.len())
                });
            if k > j + 1
                && let Some((kw, addr)) = kw
            {
                word(addr, k + kw.len(), b);
                i = k + kw.len();
                continue;
            }
        }
        let addr = PATH_ADDRS
            .iter()
            .find(|a| rest.len() >= a.len() && rest[..a.len()].eq_ignore_ascii_case(a.as_bytes()));
        let (addr, k) = match addr {
            Some(a) => (*a, j + a.len()),
            None => {
                let single = upper(j).filter(|c| matches!(c, b'R' | b'F' | b'M' | b'S' | b'T'));
                match single {
                    Some(c) => (
                        match c {
                            b'R' => "R",
                            b'F' => "F",
                            b'M' => "M",
                            b'S' => "S",
                            _ => "T",
                        },
                        j + 1,
                    ),
                    None => {
                        return unknown_word(lx, b, start, e, seg);
                    }
                }
            }
        };
        if matches!(addr, "FMAX" | "FAUTO" | "RL" | "RR") && at_boundary(s, k) {
            word(addr, k, b);
            i = k;
            continue;
        }
        match value_at(s, k, e) {
            Some((value, style, vstart, vend)) if at_boundary(s, vend) => {
                b.push(
                    TokenKind::Word(Word {
                        addr: Addr::new(addr),
                        incremental,
                        value,
                        value_span: Span::new(vstart, vend),
                        style,
                    }),
                    start,
                    vend,
                );
                i = vend;
            }
            // Older TNCs print a dialog field left without an entry as
            // its bare letter (`L X+12,500 R F M`): the radius
            // compensation, the feed and the M function as they were.
            _ if matches!(addr, "R" | "F" | "M") && at_boundary(s, k) => {
                word(addr, k, b);
                i = k;
            }
            _ => {
                let w = s[start..e]
                    .iter()
                    .position(|&c| is_space(c) || c == b';')
                    .unwrap_or(e - start);
                if matches!(
                    addr,
                    "X" | "Y" | "Z" | "A" | "B" | "C" | "PA" | "PR" | "IPA" | "IPR" | "F" | "R"
                ) {
                    return Err(BlockError::new(
                        k,
                        format!(
                            "bad number in `{}`: expected a signed number or a Q parameter after {}{addr}",
                            String::from_utf8_lossy(&s[start..start + w]),
                            if incremental { "I" } else { "" }
                        ),
                    ));
                }
                return unknown_word(lx, b, start, e, seg);
            }
        }
    }
    Ok(i)
}

fn unknown_word(
    lx: &Lx,
    b: &mut Block,
    start: usize,
    e: usize,
    seg: &mut Segment,
) -> Result<usize, BlockError> {
    let s = lx.s;
    let w = s[start..e]
        .iter()
        .position(|&c| is_space(c) || c == b';')
        .unwrap_or(e - start)
        .max(1);
    if lx.strict {
        return Err(BlockError::new(
            start,
            format!(
                "unknown word `{}` in a path block: expected X Y Z A B C (with I for incremental), PA, PR, R0, RL, RR, R, DR+, DR-, F, FMAX or M",
                String::from_utf8_lossy(&s[start..start + w])
            ),
        ));
    }
    seg.unknown.get_or_insert(Span::new(start, start + w));
    b.push(TokenKind::Text, start, start + w);
    path_words(lx, b, start + w, seg)
}

/// Atoms up to the end of the block: words where they look like one
/// (`S4456`, `SPB+30`, `M3`, `X+100`), quoted strings, `;` comments, `~`,
/// line endings of continuation lines, and text otherwise.
fn atoms(lx: &Lx, b: &mut Block, mut i: usize) -> Result<usize, BlockError> {
    let s = lx.s;
    while i < s.len() {
        let c = s[i];
        let le = line_end_at(s, i);
        if le > 0 {
            b.push(TokenKind::LineEnd, i, i + le);
            i += le;
            continue;
        }
        if is_space(c) {
            let j = lx.spaces(i);
            b.push(TokenKind::Space, i, j);
            i = j;
            continue;
        }
        if c == b';' {
            let e = lx.comment_end(i);
            b.push(TokenKind::Comment, i, e);
            i = e;
            continue;
        }
        if c == b'~' {
            b.push(TokenKind::Continuation, i, i + 1);
            i += 1;
            continue;
        }
        if c == b'"' {
            let e = lx.line_end(i);
            match s[i + 1..e].iter().position(|&q| q == b'"') {
                Some(p) => {
                    b.push(TokenKind::Text, i, i + p + 2);
                    i += p + 2;
                }
                None => {
                    return Err(BlockError::new(
                        i,
                        "unclosed string: expected `\"` before the end of the line",
                    ));
                }
            }
            continue;
        }
        let mut j = i;
        while j < s.len()
            && !is_space(s[j])
            && s[j] != b'\n'
            && s[j] != b'\r'
            && s[j] != b';'
            && s[j] != b'"'
        {
            j += 1;
        }
        // A trailing `~` glued to an atom is still the continuation mark.
        if j == i {
            // A lone carriage return or other control byte: keep it verbatim.
            b.push(TokenKind::Text, i, i + 1);
            i += 1;
            continue;
        }
        let mut atom_end = j;
        if atom_end > i + 1 && s[atom_end - 1] == b'~' && at_line_tail(lx, atom_end) {
            atom_end -= 1;
        }
        push_atom(b, s, i, atom_end)?;
        i = atom_end;
    }
    Ok(i)
}

fn at_line_tail(lx: &Lx, i: usize) -> bool {
    let e = lx.line_end(i);
    lx.s[i..e].iter().all(|&c| is_space(c))
}

/// An atom: a word if it is letters then a signed number (`SPB+30`,
/// `Q339=+1` is text), else text.
fn push_atom(b: &mut Block, s: &[u8], i: usize, e: usize) -> Result<(), BlockError> {
    let a = &s[i..e];
    let letters = a.iter().take_while(|c| c.is_ascii_uppercase()).count();
    if (1..=4).contains(&letters) {
        let v = &a[letters..];
        let n = lexeme::lex_len(v);
        if n > 0 && n == v.len() {
            let name = std::str::from_utf8(&a[..letters]).unwrap_or("");
            let lx = lexeme::read(v);
            if !lx.value.is_finite() {
                return Err(super::too_large(i + letters, v));
            }
            b.push(
                TokenKind::Word(Word {
                    addr: Addr::new(name),
                    incremental: false,
                    value: Value::Num(lx.value),
                    value_span: Span::new(i + letters, e),
                    style: lx.style,
                }),
                i,
                e,
            );
            return Ok(());
        }
    }
    b.push(TokenKind::Text, i, e);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::machine::Dialect;

    fn parse_str(src: &str, strict: bool) -> Result<Block, BlockError> {
        Syntax {
            dialect: Dialect::Heidenhain,
            strict,
        }
        .block(src)
    }

    fn words(b: &Block) -> Vec<String> {
        b.words(&b.segments[0])
            .map(|(_, w)| {
                format!(
                    "{}{}={}",
                    if w.incremental { "I" } else { "" },
                    w.addr,
                    String::from_utf8_lossy(b.bytes(w.value_span))
                )
            })
            .collect()
    }

    #[test]
    fn path_blocks_split_into_words() {
        let b = parse_str("12 L X+10.5 IY-2 Z+Q1 R0 FMAX M3\n", true).unwrap();
        assert_eq!(b.segments[0].stmt, Stmt::Hh(HhKind::L));
        assert_eq!(
            words(&b),
            ["X=+10.5", "IY=-2", "Z=+Q1", "R0=", "FMAX=", "M=3"]
        );
        let b = parse_str("L X-174.5 Y7 R0 F MAX M3\n", true).unwrap();
        assert_eq!(words(&b), ["X=-174.5", "Y=7", "R0=", "FMAX=", "M=3"]);
        let b = parse_str("CR X+10 Y+10 R+10 DR- RL F600\n", true).unwrap();
        assert_eq!(
            words(&b),
            ["X=+10", "Y=+10", "R=+10", "DR=", "RL=", "F=600"]
        );
        let b = parse_str("CP IPA+360 IZ-2 DR+ R0 F600\n", true).unwrap();
        assert_eq!(words(&b), ["IPA=+360", "IZ=-2", "DR=", "R0=", "F=600"]);
    }

    #[test]
    fn block_numbers_and_every_block_delete_placement() {
        for src in [
            "/12 L X+1 R0 FMAX\n",
            "12 / L X+1 R0 FMAX\n",
            "/ L X+1 R0 FMAX\n",
        ] {
            let b = parse_str(src, true).unwrap();
            assert!(
                b.tokens.iter().any(|t| t.kind == TokenKind::BlockDelete),
                "{src}"
            );
            assert_eq!(b.segments[0].stmt, Stmt::Hh(HhKind::L), "{src}");
        }
    }

    #[test]
    fn cycles_are_keyed_on_their_number() {
        for (src, number, sub) in [
            ("5 CYCL DEF 7.0 DATUM SHIFT\n", 7, Some(0)),
            ("6 CYCL DEF 7.1  X + 0\n", 7, Some(1)),
            ("7 CYCL DEF 7.1 #5\n", 7, Some(1)),
            ("8 CYCL DEF 9 .0 VARAKOZASI IDO\n", 9, Some(0)),
            (
                "9 CYCL DEF 200 DRILLING ~\n  Q200=+2 ;SET-UP CLEARANCE ~\n  Q201=-20 ;DEPTH\n",
                200,
                None,
            ),
        ] {
            let b = parse_str(src, true).unwrap();
            assert_eq!(
                b.segments[0].stmt,
                Stmt::Hh(HhKind::CyclDef { number, sub }),
                "{src}"
            );
        }
    }

    #[test]
    fn other_blocks() {
        for (src, kind) in [
            ("0 BEGIN PGM TEST MM\n", HhKind::BeginPgm),
            ("1 BLK FORM 0.1 Z X-187 Y-55.5 Z-50.6\n", HhKind::BlkForm),
            ("3 TOOL CALL \"AF08\" Z S50 DL+0 DR+0\n", HhKind::ToolCall),
            (
                "4 PLANE SPATIAL SPA+0 SPB+30 SPC+0 TURN MB MAX FMAX\n",
                HhKind::Plane,
            ),
            ("5 PLANE RESET STAY\n", HhKind::PlaneReset),
            ("6 M128\n", HhKind::M),
            (
                "7 FUNCTION TCPM F TCP AXIS POS PATHCTRL AXIS\n",
                HhKind::FunctionTcpm,
            ),
            ("8 FUNCTION RESET TCPM\n", HhKind::FunctionResetTcpm),
            ("9 FN 0: Q1 =+5\n", HhKind::Fn(0)),
            ("10 FN18: SYSREAD Q12 = ID270 NR1 IDX3\n", HhKind::Fn(18)),
            ("11 FN0 : Q1 = -200.66\n", HhKind::Fn(0)),
            ("12 QR7 = SQRT ( ( QR4 ^ 2 ) + ( QR3 ^ 2 ) )\n", HhKind::Q),
            ("13 QS1 = \"PART\"\n", HhKind::Q),
            ("14 FN 9: IF +Q4 EQU +Q5 GOTO LBL 1\n", HhKind::Fn(9)),
            ("15 LBL \"CuttingEdges1\"\n", HhKind::Lbl),
            ("16 CALL LBL 1 REP 3\n", HhKind::CallLbl),
            (
                "17 FN 16: F-PRINT TNC:\\MASKE.A / TNC:\\PROT.TXT\n",
                HhKind::Fn(16),
            ),
            ("18 ; hello there\n", HhKind::Comment),
            ("19 * - TOOL: D10\n", HhKind::Structure),
            ("20 TCH PROBE 0.0 REF. PLANE Q5 X-\n", HhKind::TchProbe),
            ("21 END PGM TEST MM\n", HhKind::EndPgm),
        ] {
            let b = parse_str(src, true).unwrap_or_else(|e| panic!("{src}: {e:?}"));
            assert_eq!(b.segments[0].stmt, Stmt::Hh(kind), "{src}");
        }
    }

    #[test]
    fn malformed_blocks() {
        let e = parse_str("5 L X+1.2.3 R0\n", false).unwrap_err();
        assert!(e.message.contains("bad number"), "{}", e.message);
        let e = parse_str("5 FOO X+1\n", true).unwrap_err();
        assert!(e.message.contains("unknown block `FOO`"), "{}", e.message);
        assert!(parse_str("5 FOO X+1\n", false).is_ok());
        let e = parse_str("5 L X+1 QQ7 R0\n", true).unwrap_err();
        assert!(e.message.contains("unknown word `QQ7`"), "{}", e.message);
        let b = parse_str("5 L X+1 QQ7 R0\n", false).unwrap();
        assert!(b.segments[0].unknown.is_some());
    }

    #[test]
    fn values_apart_from_their_address_decimal_commas_and_feed_keywords() {
        // As older posts and hand-written programs write them.
        let b = parse_str("15 L Z 25.000 FMAX\n", true).unwrap();
        assert_eq!(words(&b), ["Z=25.000", "FMAX="]);
        let b = parse_str("16 L Z + Q13 FMAX\n", true).unwrap();
        assert_eq!(words(&b), ["Z=+ Q13", "FMAX="]);
        let b = parse_str("17 L X+32,000 Y-7,5 R0 F AUTO\n", true).unwrap();
        // Addresses pack four letters: `F AUTO` is the word FAUT.
        assert_eq!(words(&b), ["X=+32,000", "Y=-7,5", "R0=", "FAUT="]);
        let (_, w) = b.words(&b.segments[0]).next().unwrap();
        assert!(w.style.comma);
        assert!(matches!(w.value, Value::Num(v) if v == 32.0));
        // Two signs are not a number.
        assert!(parse_str("18 L X+ -3 R0\n", true).is_err());
    }

    #[test]
    fn byte_order_mark_dos_end_of_file_and_numbers_beyond_a_float() {
        let b = parse_str("\u{FEFF}0 BEGIN PGM A MM\n", true).unwrap();
        assert_eq!(b.tokens[0].kind, TokenKind::Text);
        assert_eq!(b.segments[0].stmt, Stmt::Hh(HhKind::BeginPgm));
        let b = parse_str("\u{1A}\n", true).unwrap();
        assert!(b.tokens.iter().all(|t| matches!(
            t.kind,
            TokenKind::Text | TokenKind::Space | TokenKind::LineEnd
        )));
        let huge = format!("5 L X+1{} R0 FMAX\n", "0".repeat(400));
        assert!(parse_str(&huge, false).is_err());
    }
}
