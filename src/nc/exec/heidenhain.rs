//! HEIDENHAIN Klartext parameters as [`ExecOp`]s: Q formulas (`Q1 = Q2 * 3`,
//! `QL`, `QR`), FN 0-FN 7 arithmetic, FN 9-FN 12 conditional jumps, FN 18
//! (the parameter becomes unknown), FN 14 (an error: execution stops),
//! `LBL n` / `LBL "name"`, `LBL 0` (end of a subprogram), `CALL LBL n`
//! (a subprogram call) and `CALL LBL n REP m` (the section since the label
//! run m more times), `END PGM`; `CALL PGM` leaves the file.

use super::eval::{self, NoParams};
use super::{After, Cond, ExecOp, JumpTarget, Program, RunawayError};
use crate::machine::Dialect;
use crate::nc::{Addr, HhKind, Stmt, TokenKind, Value};

pub(super) fn decode(p: &mut Program) -> Result<(), RunawayError> {
    let n = p.at.len();
    p.ops = vec![ExecOp::Nop; n];
    for i in 0..n {
        let seg = *p.seg(i);
        let code = p.code(i);
        let op = match seg.stmt {
            Stmt::Hh(HhKind::Q) => assignment(&code, |rhs| rhs.to_string()),
            Stmt::Hh(HhKind::Fn(f)) => fn_op(f, &code),
            Stmt::Hh(HhKind::Lbl) => {
                let name = label(after_word(&code, "LBL"));
                if name == "LBL 0" {
                    ExecOp::Return
                } else {
                    p.add_label(name, i);
                    ExecOp::Nop
                }
            }
            Stmt::Hh(HhKind::CallLbl) => call_lbl(after_word(&code, "LBL")),
            Stmt::Hh(HhKind::CallPgm) => ExecOp::Halt("CALL PGM runs another program".into()),
            Stmt::Hh(HhKind::EndPgm) => ExecOp::End,
            Stmt::Hh(_) => {
                let block = p.block(i);
                let mut after = After::Next;
                for (_, w) in block.words(&seg) {
                    if w.addr == Addr::letter(b'M')
                        && matches!(w.value, Value::Num(v) if v == 2.0 || v == 30.0)
                    {
                        after = After::End;
                    }
                }
                ExecOp::Words(after)
            }
            _ => ExecOp::Nop,
        };
        p.ops[i] = op;
    }
    Ok(())
}

/// `CALL LBL n [REP m]`: a subprogram call, or a section repeat.
fn call_lbl(rest: &str) -> ExecOp {
    // `REP` may be glued to its count, also when a real
    // program gives the count as a parameter (`REPQ13`).
    let rep_at = ["REP", "REPQ", "REPQL", "REPQR"]
        .iter()
        .find_map(|w| find_word(rest, w));
    let (lbl, rep) = match rep_at {
        Some(k) => {
            let r = rest[k + 3..]
                .trim()
                .split(|c: char| !c.is_ascii_digit())
                .next()
                .and_then(|d| d.parse::<u32>().ok());
            match r {
                Some(r) => (&rest[..k], Some(r)),
                None => {
                    return ExecOp::Halt(format!(
                        "CALL LBL with a repeat count that is not a number (`{}`): how the control reads it is not confirmed",
                        rest[k..].trim()
                    ));
                }
            }
        }
        None => (rest, None),
    };
    ExecOp::Call {
        target: JumpTarget::Label(label(lbl)),
        args: Vec::new(),
        rep,
    }
}

/// `Qn = rhs`: the parameter and the expression `f(rhs)`.
fn assignment(code: &str, f: impl Fn(&str) -> String) -> ExecOp {
    let Some(eq) = code.find('=') else {
        return ExecOp::Halt(format!("`{code}` has no `=`"));
    };
    let target = code[..eq].trim();
    if target.to_ascii_uppercase().starts_with("QS") {
        // Strings are not numbers any move uses.
        return ExecOp::Nop;
    }
    match eval::param_ref(Dialect::Heidenhain, target.as_bytes(), &NoParams) {
        Ok((key, _)) => ExecOp::Set(key, f(code[eq + 1..].trim())),
        Err(e) => ExecOp::Halt(e.to_string()),
    }
}

fn fn_op(f: u32, code: &str) -> ExecOp {
    // `FN 1: Q1 = +Q2 + +3`: the part after the colon.
    let body = code.split_once(':').map_or("", |(_, b)| b.trim());
    let strip = |rhs: &str, word: &str| {
        rhs.trim()
            .strip_prefix(word)
            .or_else(|| rhs.trim().strip_prefix(&word.to_ascii_lowercase()))
            .unwrap_or(rhs)
            .trim()
            .to_string()
    };
    match f {
        0..=3 => assignment(body, str::to_string),
        4 => assignment(body, |r| r.replace("DIV", "/").replace("div", "/")),
        5 => assignment(body, |r| format!("SQRT ( {} )", strip(r, "SQRT"))),
        6 => assignment(body, |r| format!("SIN ( {} )", strip(r, "SIN"))),
        7 => assignment(body, |r| format!("COS ( {} )", strip(r, "COS"))),
        9..=12 => {
            let op = ["==", "<>", ">", "<"][(f - 9) as usize];
            let word = ["EQU", "NE", "GT", "LT"][(f - 9) as usize];
            let rest = after_word(body, "IF");
            let (Some(k), Some(g)) = (find_word(rest, word), find_word(rest, "GOTO")) else {
                return ExecOp::Halt(format!("FN {f}: expected IF a {word} b GOTO LBL n"));
            };
            if g < k {
                return ExecOp::Halt(format!("FN {f}: expected IF a {word} b GOTO LBL n"));
            }
            ExecOp::Goto {
                cond: Cond::Cmp(
                    rest[..k].trim().to_string(),
                    op,
                    rest[k + word.len()..g].trim().to_string(),
                ),
                target: JumpTarget::Label(label(after_word(&rest[g..], "LBL"))),
                forward: None,
            }
        }
        14 => ExecOp::Halt("FN 14: ERROR stops the program here".into()),
        18 => match body
            .split_once('=')
            .map(|(t, _)| eval::param_ref(Dialect::Heidenhain, t.trim().as_bytes(), &NoParams))
        {
            Some(Ok((key, _))) => ExecOp::Forget(key, "FN 18 SYSREAD reads controller data".into()),
            _ => ExecOp::Nop,
        },
        8 | 13 => match body
            .split_once('=')
            .map(|(t, _)| eval::param_ref(Dialect::Heidenhain, t.trim().as_bytes(), &NoParams))
        {
            Some(Ok((key, _))) => {
                ExecOp::Forget(key, format!("FN {f} is not evaluated by fivecal"))
            }
            _ => ExecOp::Nop,
        },
        // Output, waits, PLC and system writes move nothing and set no Q.
        _ => ExecOp::Nop,
    }
}

/// The text after the first `word` (case-sensitive, as controls write it).
fn after_word<'s>(code: &'s str, word: &str) -> &'s str {
    find_word(code, word).map_or("", |k| &code[k + word.len()..])
}

/// Where `word` stands as a word of its own.
fn find_word(code: &str, word: &str) -> Option<usize> {
    let b = code.as_bytes();
    let mut from = 0;
    while let Some(k) = code[from..].find(word) {
        let at = from + k;
        let before = at == 0 || !b[at - 1].is_ascii_alphanumeric();
        let after = b
            .get(at + word.len())
            .is_none_or(|c| !c.is_ascii_alphabetic());
        if before && after {
            return Some(at);
        }
        from = at + word.len();
    }
    None
}

/// A label key: `LBL 1`, `LBL "name"`.
fn label(arg: &str) -> String {
    let arg = arg.trim();
    let arg = arg.split_whitespace().next().unwrap_or("");
    match arg.parse::<u64>() {
        Ok(n) => format!("LBL {n}"),
        Err(_) => format!("LBL {arg}"),
    }
}

impl Program<'_> {
    /// HEIDENHAIN: a statement's code: its text from the keyword on,
    /// without comments, continuation marks and line endings.
    pub(super) fn code(&self, i: usize) -> String {
        let block = self.block(i);
        let seg = self.seg(i);
        let mut s = String::new();
        for t in &block.tokens[seg.body as usize..seg.end as usize] {
            match t.kind {
                TokenKind::Comment => {}
                TokenKind::LineEnd | TokenKind::Continuation => s.push(' '),
                _ => s.push_str(&String::from_utf8_lossy(block.bytes(t.span))),
            }
        }
        s.trim().to_string()
    }
}
