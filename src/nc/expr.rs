//! Expressions of FANUC Custom Macro B and LinuxCNC rs274ngc: validated,
//! never evaluated.
//!
//! A block whose coordinates are expressions is left untouched by
//! `compensate`, so the parser only has to know where an expression ends and
//! that it is well formed: numbers, parameters (`#1`, `#<name>`, `#[#1+2]`,
//! `##1`), brackets, functions (`SIN[..]`, `ATAN[a]/[b]`, `EXISTS[#<x>]`),
//! the arithmetic, comparison and logic operators, and keywords glued to
//! their operands as real macro code writes them (`#4119GE2600`).

use nom::branch::alt;
use nom::bytes::complete::{tag, tag_no_case, take_while, take_while1};
use nom::character::complete::char;
use nom::combinator::{opt, recognize};
use nom::{IResult, Parser};

use super::lexeme;

type Res<'a> = IResult<&'a [u8], &'a [u8]>;

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
pub fn param(i: &[u8]) -> Res<'_> {
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
            param,
        )),
    ))
    .parse(i)
}

/// `[ expr ]`.
pub fn bracketed(i: &[u8]) -> Res<'_> {
    recognize((char('['), ws, expr, ws, char(']'))).parse(i)
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
pub fn expr(i: &[u8]) -> Res<'_> {
    let (mut rest, _) = atom(i)?;
    while let Ok((r, _)) = (ws, binop, ws, atom).parse(rest) {
        rest = r;
    }
    Ok((rest, &i[..i.len() - rest.len()]))
}

/// A LinuxCNC "real value": a number, a parameter, a bracketed expression
/// or a unary function, with optional signs (no unbracketed binary operator).
pub fn real_value(i: &[u8]) -> Res<'_> {
    atom(i)
}

/// Length of the expression at the start of `s`, or `None`.
pub fn expr_len(s: &[u8]) -> Option<usize> {
    expr(s).ok().map(|(rest, _)| s.len() - rest.len())
}

/// Length of the bracketed expression at the start of `s`, or `None`.
pub fn bracketed_len(s: &[u8]) -> Option<usize> {
    bracketed(s).ok().map(|(rest, _)| s.len() - rest.len())
}

/// Length of a parameter reference at the start of `s`, or `None`.
pub fn param_len(s: &[u8]) -> Option<usize> {
    param(s).ok().map(|(rest, _)| s.len() - rest.len())
}

/// Length of a real value (see [`real_value`]) at the start of `s`.
pub fn real_value_len(s: &[u8]) -> Option<usize> {
    real_value(s).ok().map(|(rest, _)| s.len() - rest.len())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn full(s: &str) -> bool {
        expr_len(s.as_bytes()) == Some(s.len())
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
        assert_eq!(expr_len(b"[#1+2] Y5"), Some(6));
        assert_eq!(expr_len(b"#1 (comment)"), Some(2));
        assert_eq!(bracketed_len(b"[#1 GT 0] GOTO 10"), Some(9));
        assert_eq!(real_value_len(b"#1+#2"), Some(2));
    }

    #[test]
    fn rejects_broken_expressions() {
        assert_eq!(bracketed_len(b"[#1+"), None);
        assert_eq!(bracketed_len(b"[#1+2"), None);
        assert_eq!(bracketed_len(b"[FOO[1]]"), None);
        assert_eq!(expr_len(b"#"), None);
    }
}
