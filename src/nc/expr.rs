//! Expressions of FANUC Custom Macro B and LinuxCNC rs274ngc: validated,
//! never evaluated.
//!
//! A block whose coordinates are expressions is left untouched by
//! `compensate`, so the parser only has to know where an expression ends and
//! that it is well formed: numbers, parameters (`#1`, `#<name>`, `#[#1+2]`,
//! `##1`), brackets, functions (`SIN[..]`, `ATAN[a]/[b]`, `EXISTS[#<x>]`),
//! the arithmetic, comparison and logic operators, and keywords glued to
//! their operands as real macro code writes them (`#4119GE2600`).
//!
//! The parser recurses once per bracket and once per chained `#` (`##1`),
//! so it follows at most [`MAX_EXPR_DEPTH`] levels of them together and
//! reports where the first level too deep starts ([`TooDeep`]): 200,000
//! nested brackets, or as many `#`, would otherwise overflow the stack.

use std::cell::Cell;

use nom::branch::alt;
use nom::bytes::complete::{tag, tag_no_case, take_while, take_while1};
use nom::character::complete::char;
use nom::combinator::{opt, recognize};
use nom::{IResult, Parser};

use super::lexeme;
pub(crate) use crate::limits::MAX_EXPR_DEPTH;

type Res<'a> = IResult<&'a [u8], &'a [u8]>;

/// An expression nested deeper than [`MAX_EXPR_DEPTH`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct TooDeep {
    /// Byte offset, in the text handed to the parser, of the bracket or
    /// `#` that opens the level too many.
    pub offset: usize,
}

impl std::fmt::Display for TooDeep {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "brackets and #parameter references nested deeper than {MAX_EXPR_DEPTH} levels: expected at most {MAX_EXPR_DEPTH} (controllers read a few)"
        )
    }
}

impl std::error::Error for TooDeep {}

thread_local! {
    /// Levels the parser is inside on this thread.
    static DEPTH: Cell<usize> = const { Cell::new(0) };
}

/// Runs `f` one level deeper, or fails for good (no other branch is
/// tried) at `i` when that is one level too many.
fn deeper<'a>(i: &'a [u8], f: impl FnOnce(&'a [u8]) -> Res<'a>) -> Res<'a> {
    let d = DEPTH.with(Cell::get);
    if d >= MAX_EXPR_DEPTH {
        return Err(nom::Err::Failure(nom::error::Error::new(
            i,
            nom::error::ErrorKind::TooLarge,
        )));
    }
    DEPTH.with(|c| c.set(d + 1));
    let r = f(i);
    DEPTH.with(|c| c.set(d));
    r
}

const FUNCS: [&str; 19] = [
    "ASIN", "ACOS", "ATAN", "ATN", "SIN", "COS", "TAN", "SQRT", "SQR", "ABS", "ROUND", "RND",
    "FIX", "FUP", "LN", "EXP", "BIN", "BCD", "POW",
];

const OPS: [&str; 10] = [
    "MOD", "EQ", "NE", "GT", "GE", "LT", "LE", "AND", "OR", "XOR",
];

fn ws(i: &[u8]) -> Res<'_> {
    take_while(|c: u8| c == b' ' || c == b'\t')(i)
}

fn number(i: &[u8]) -> Res<'_> {
    // Unsigned here: signs are unary operators.
    let n = if i.first().is_some_and(|c| *c == b'+' || *c == b'-') {
        0
    } else {
        lexeme::lex_len(i)
    };
    if n == 0 {
        return Err(nom::Err::Error(nom::error::Error::new(
            i,
            nom::error::ErrorKind::Float,
        )));
    }
    Ok((&i[n..], &i[..n]))
}

/// A parameter reference: `#12`, `#<name>`, `#[expr]`, `##3`.
fn param(i: &[u8]) -> Res<'_> {
    recognize((
        char('#'),
        ws,
        alt((
            take_while1(|c: u8| c.is_ascii_digit()),
            recognize((
                char('<'),
                take_while1(|c: u8| c != b'>' && c != b'\n'),
                char('>'),
            )),
            bracketed,
            |j| deeper(j, param),
        )),
    ))
    .parse(i)
}

/// `[ expr ]`.
fn bracketed(i: &[u8]) -> Res<'_> {
    deeper(i, |i| {
        recognize((char('['), ws, expr, ws, char(']'))).parse(i)
    })
}

fn func(i: &[u8]) -> Res<'_> {
    let (rest, name) = take_while1(|c: u8| c.is_ascii_alphabetic())(i)?;
    let upper: Vec<u8> = name.to_ascii_uppercase();
    let known = FUNCS.iter().any(|f| f.as_bytes() == upper.as_slice());
    if upper == b"EXISTS" {
        let (rest, _) = (ws, char('['), ws, param, ws, char(']')).parse(rest)?;
        return Ok((rest, &i[..i.len() - rest.len()]));
    }
    if !known {
        return Err(nom::Err::Error(nom::error::Error::new(
            i,
            nom::error::ErrorKind::Tag,
        )));
    }
    let (rest, _) = (ws, bracketed).parse(rest)?;
    // ATAN[y]/[x] takes a second bracketed argument after a slash.
    let (rest, _) = opt((ws, char('/'), ws, bracketed)).parse(rest)?;
    Ok((rest, &i[..i.len() - rest.len()]))
}

fn atom(i: &[u8]) -> Res<'_> {
    recognize((
        take_while(|c: u8| c == b'-' || c == b'+' || c == b' ' || c == b'\t'),
        alt((number, param, bracketed, func)),
    ))
    .parse(i)
}

fn binop(i: &[u8]) -> Res<'_> {
    if let Ok(r) = alt((
        tag::<_, _, nom::error::Error<&[u8]>>("**"),
        tag("+"),
        tag("-"),
        tag("*"),
        tag("/"),
    ))
    .parse(i)
    {
        return Ok(r);
    }
    for op in OPS {
        if let Ok(r) = tag_no_case::<_, _, nom::error::Error<&[u8]>>(op)(i) {
            return Ok(r);
        }
    }
    Err(nom::Err::Error(nom::error::Error::new(
        i,
        nom::error::ErrorKind::Tag,
    )))
}

/// An expression: atoms joined by binary operators.
fn expr(i: &[u8]) -> Res<'_> {
    let (mut rest, _) = atom(i)?;
    loop {
        match (ws, binop, ws, atom).parse(rest) {
            Ok((r, _)) => rest = r,
            // Too deep inside the next operand: the whole is refused.
            Err(e @ nom::Err::Failure(_)) => return Err(e),
            Err(_) => break,
        }
    }
    Ok((rest, &i[..i.len() - rest.len()]))
}

/// The length of what `parser` recognizes at the start of `s`: `Ok(None)`
/// when it is not there, `Err` when it nests too deep.
fn length(s: &[u8], parser: fn(&[u8]) -> Res<'_>) -> Result<Option<usize>, TooDeep> {
    match parser(s) {
        Ok((rest, _)) => Ok(Some(s.len() - rest.len())),
        Err(nom::Err::Failure(e)) if e.code == nom::error::ErrorKind::TooLarge => Err(TooDeep {
            offset: s.len() - e.input.len(),
        }),
        Err(_) => Ok(None),
    }
}

/// Length of the expression at the start of `s`, `None` if there is none.
pub(crate) fn expr_len(s: &[u8]) -> Result<Option<usize>, TooDeep> {
    length(s, expr)
}

/// Length of the bracketed expression at the start of `s`.
pub(crate) fn bracketed_len(s: &[u8]) -> Result<Option<usize>, TooDeep> {
    length(s, bracketed)
}

/// Length of a parameter reference (`#12`, `#<name>`, `#[expr]`, `##3`)
/// at the start of `s`.
pub(crate) fn param_len(s: &[u8]) -> Result<Option<usize>, TooDeep> {
    length(s, param)
}

/// Length of a LinuxCNC "real value" at the start of `s`: a number, a
/// parameter, a bracketed expression or a unary function, with optional
/// signs (no unbracketed binary operator).
pub(crate) fn real_value_len(s: &[u8]) -> Result<Option<usize>, TooDeep> {
    length(s, atom)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn full(s: &str) -> bool {
        expr_len(s.as_bytes()) == Ok(Some(s.len()))
    }

    #[test]
    fn accepts_macro_b_and_rs274ngc_expressions() {
        for s in [
            "#1+1",
            "#145*#30",
            "[#105+COS[#101]]",
            "#[#2000+#13]",
            "[#4119GE2600]",
            "#901200NE57",
            "[ABS[#1-#2] LT 0.1]",
            "[#1 LT 10] AND [#2 GT 0]",
            "ATAN[#1]/[#2]",
            "[EXISTS[#<_probe>]]",
            "-#5061+1.5",
            "##3",
            "[2 ** 3 MOD 5]",
            "#<_x> - .5",
        ] {
            assert!(full(s), "{s}");
        }
    }

    #[test]
    fn finds_where_an_expression_ends() {
        assert_eq!(expr_len(b"[#1+2] Y5"), Ok(Some(6)));
        assert_eq!(expr_len(b"#1 (comment)"), Ok(Some(2)));
        assert_eq!(bracketed_len(b"[#1 GT 0] GOTO 10"), Ok(Some(9)));
        assert_eq!(real_value_len(b"#1+#2"), Ok(Some(2)));
    }

    #[test]
    fn rejects_broken_expressions() {
        assert_eq!(bracketed_len(b"[#1+"), Ok(None));
        assert_eq!(bracketed_len(b"[#1+2"), Ok(None));
        assert_eq!(bracketed_len(b"[FOO[1]]"), Ok(None));
        assert_eq!(expr_len(b"#"), Ok(None));
    }

    #[test]
    fn nesting_is_followed_to_its_limit_and_refused_beyond_at_the_level_too_many() {
        let n = MAX_EXPR_DEPTH;
        let ok = format!("{}1{}", "[".repeat(n), "]".repeat(n));
        assert_eq!(expr_len(ok.as_bytes()), Ok(Some(ok.len())));
        // 200,000 brackets, or chained #, overflowed the stack.
        let deep = format!("{}1{}", "[".repeat(200_000), "]".repeat(200_000));
        assert_eq!(expr_len(deep.as_bytes()), Err(TooDeep { offset: n }));
        assert_eq!(bracketed_len(deep.as_bytes()), Err(TooDeep { offset: n }));
        // The first `#` is nested in nothing: the one at offset n + 1 is
        // level n + 1.
        let hashes = format!("{}1", "#".repeat(200_000));
        assert_eq!(param_len(hashes.as_bytes()), Err(TooDeep { offset: n + 1 }));
        assert_eq!(
            real_value_len(hashes.as_bytes()),
            Err(TooDeep { offset: n + 1 })
        );
        // Brackets and # count together; an operand after an operator too.
        let mixed = format!("1+{}", "#[".repeat(n + 1));
        assert!(expr_len(mixed.as_bytes()).is_err());
        // The depth is back to zero after a refusal.
        assert_eq!(expr_len(b"[[#1]]"), Ok(Some(6)));
    }
}
