//! HEIDENHAIN Klartext parameters as [`ExecOp`]s: Q formulas (`Q1 = Q2 * 3`,
//! `QL`, `QR`), FN 0-FN 8 and FN 13 arithmetic, FN 9-FN 12 conditional
//! jumps, FN 18 (the parameter becomes unknown), FN 14 (an error) and
//! FN 17 (a write to controller data), where execution stops; FN 15,
//! FN 16 and the FN above 18 move nothing and set no Q. `LBL n` /
//! `LBL "name"`, `LBL 0` (end of a subprogram), `CALL LBL n`
//! (a subprogram call) and `CALL LBL n REP m` (the section since the label
//! run m more times), `END PGM`; `CALL PGM` leaves the file.

use super::eval::{self, NoParams};
use super::{After, Cond, ExecOp, JumpTarget, Pair, Program, RunawayError};
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
            // The count: a number or a parameter (`REP 3`, `REP Q5`),
            // evaluated when the call is reached; what follows a `/` (the
            // count as the control displays it, `REP 2/2`) is not part of it.
            let count = rest[k + 3..].trim();
            let count = count.split('/').next().unwrap_or(count).trim();
            if count.is_empty() {
                return ExecOp::Halt(format!(
                    "CALL LBL with REP but no count (`{}`)",
                    rest[k..].trim()
                ));
            }
            (&rest[..k], Some(count.to_string()))
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
        8 => pair(body, "LEN", Pair::Len),
        13 => pair(body, "ANG", Pair::Ang),
        17 => ExecOp::Halt(
            "FN 17 SYSWRITE writes controller data (a datum, a tool or a machine parameter) fivecal does not model".into(),
        ),
        // Output, waits, PLC and system writes move nothing and set no Q.
        _ => ExecOp::Nop,
    }
}

/// `FN 8: Q1 = a LEN b`, `FN 13: Q1 = a ANG b`: the two values either
/// side of `word`.
fn pair(body: &str, word: &str, f: Pair) -> ExecOp {
    let Some(eq) = body.find('=') else {
        return ExecOp::Halt(format!("`{body}` has no `=`"));
    };
    let rhs = &body[eq + 1..];
    // A value may end in a digit glued to the word (`+Q1LEN+Q2`).
    let at = rhs.match_indices(word).map(|(k, _)| k).find(|&k| {
        let b = rhs.as_bytes();
        (k == 0 || !b[k - 1].is_ascii_alphabetic())
            && b.get(k + word.len())
                .is_none_or(|c| !c.is_ascii_alphabetic())
    });
    let Some(k) = at else {
        return ExecOp::Halt(format!("`{}`: expected a {word} b", body.trim()));
    };
    let (a, b) = (rhs[..k].trim(), rhs[k + word.len()..].trim());
    if a.is_empty() || b.is_empty() {
        return ExecOp::Halt(format!("`{}`: expected a {word} b", body.trim()));
    }
    match eval::param_ref(Dialect::Heidenhain, body[..eq].trim().as_bytes(), &NoParams) {
        Ok((key, _)) => ExecOp::SetPair(key, f, a.to_string(), b.to_string()),
        Err(e) => ExecOp::Halt(e.to_string()),
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
