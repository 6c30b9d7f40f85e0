//! SINUMERIK as [`ExecOp`]s: R parameters and `DEF REAL|INT|BOOL` variables
//! (assignments in any block), labels and block numbers as jump targets,
//! `GOTOF`/`GOTOB`/`GOTO`/`GOTOC` with or without `IF`,
//! `IF`/`ELSE`/`ENDIF`, `LOOP`/`ENDLOOP`, `WHILE`/`ENDWHILE`,
//! `FOR var = a TO b`/`ENDFOR`, `REPEAT`/`UNTIL`; M2/M30/M17/RET end the
//! program; `CASE` and `REPEAT` over labels are not followed.

use super::eval::{self, Key};
use super::{After, Cond, ExecOp, JumpTarget, Program, RunawayError};
use crate::machine::Dialect;
use crate::nc::{Addr, Flow, Stmt, TokenKind, Value};

pub(super) fn decode(p: &mut Program) -> Result<(), RunawayError> {
    let n = p.at.len();
    p.ops = vec![ExecOp::Nop; n];
    let mut open: Vec<(&'static str, usize)> = Vec::new();
    let mut chains: Vec<Vec<usize>> = Vec::new();
    for i in 0..n {
        let block = p.block(i);
        let seg = *p.seg(i);
        let mut labels = Vec::new();
        if p.at[i].1 == 0
            && let Some(num) = block.tokens.iter().find_map(|t| match t.kind {
                TokenKind::BlockNumber(k) => Some(k),
                _ => None,
            })
        {
            labels.push(format!("N{num}"));
        }
        let toks = block.seg_tokens(&seg);
        let text_of = |k: TokenKind| -> Vec<String> {
            toks.iter()
                .filter(|t| t.kind == k)
                .map(|t| String::from_utf8_lossy(block.bytes(t.span)).into_owned())
                .collect()
        };
        let kws: Vec<String> = text_of(TokenKind::Keyword)
            .into_iter()
            .map(|k| k.to_ascii_uppercase())
            .collect();
        let exprs = text_of(TokenKind::Expr);
        let texts = text_of(TokenKind::Text);
        let kw = kws.first().map_or("", String::as_str);
        let cond = || {
            exprs
                .first()
                .map_or(Cond::Always, |e| Cond::Expr(e.clone()))
        };
        let op = match seg.stmt {
            Stmt::Flow(Flow::Label) => {
                if let Some(name) = kw.strip_suffix(':') {
                    labels.push(name.to_string());
                }
                ExecOp::Nop
            }
            Stmt::Flow(Flow::Jump) if kw == "CASE" => {
                ExecOp::Halt("CASE is not followed by fivecal".into())
            }
            Stmt::Flow(Flow::Jump) => {
                let (cond, jump, target) = if kw == "IF" {
                    (
                        cond(),
                        kws.get(1).cloned().unwrap_or_default(),
                        texts.first().cloned().unwrap_or_default(),
                    )
                } else {
                    (
                        Cond::Always,
                        kw.to_string(),
                        exprs.first().cloned().unwrap_or_default(),
                    )
                };
                ExecOp::Goto {
                    cond,
                    target: JumpTarget::Label(target.trim().to_ascii_uppercase()),
                    forward: match jump.as_str() {
                        "GOTOF" => Some(true),
                        "GOTOB" => Some(false),
                        _ => None,
                    },
                }
            }
            Stmt::Flow(Flow::Branch) => match kw {
                "IF" => {
                    open.push(("IF", i));
                    chains.push(vec![i]);
                    ExecOp::If {
                        cond: cond(),
                        next: i,
                    }
                }
                "ELSE" => {
                    if let Some(c) = chains.last_mut() {
                        c.push(i);
                    }
                    ExecOp::Else { end: i }
                }
                _ => match close(&mut open, "IF") {
                    Some(_) => {
                        let chain = chains.pop().unwrap_or_default();
                        for (k, &s) in chain.iter().enumerate() {
                            let next = chain.get(k + 1).copied().unwrap_or(i);
                            match &mut p.ops[s] {
                                ExecOp::If { next: nx, .. } => *nx = next,
                                ExecOp::Else { end } => *end = i,
                                _ => {}
                            }
                        }
                        ExecOp::Nop
                    }
                    None => ExecOp::Halt("ENDIF without its IF".into()),
                },
            },
            Stmt::Flow(Flow::LoopStart) => match kw {
                "WHILE" => {
                    open.push(("WHILE", i));
                    ExecOp::While {
                        cond: cond(),
                        end: i,
                    }
                }
                "FOR" => {
                    open.push(("FOR", i));
                    for_op(exprs.first().map_or("", String::as_str), i)
                }
                "LOOP" => {
                    open.push(("LOOP", i));
                    ExecOp::Nop
                }
                _ => {
                    open.push(("REPEAT", i));
                    ExecOp::Nop
                }
            },
            Stmt::Flow(Flow::LoopEnd) => {
                let kind = match kw {
                    "ENDWHILE" => "WHILE",
                    "ENDFOR" => "FOR",
                    "ENDLOOP" => "LOOP",
                    _ => "REPEAT",
                };
                match close(&mut open, kind) {
                    None => ExecOp::Halt(format!("{kw} without its {kind}")),
                    Some(start) => match kind {
                        "WHILE" => {
                            if let ExecOp::While { end, .. } = &mut p.ops[start] {
                                *end = i;
                            }
                            ExecOp::Back { start }
                        }
                        "FOR" => match &mut p.ops[start] {
                            ExecOp::For { end, var, .. } => {
                                *end = i;
                                ExecOp::ForEnd {
                                    start,
                                    var: var.clone(),
                                }
                            }
                            _ => ExecOp::Halt("ENDFOR of a FOR fivecal does not follow".into()),
                        },
                        "LOOP" => ExecOp::Back { start },
                        _ => ExecOp::BackIf {
                            cond: match cond() {
                                Cond::Expr(e) => Cond::Expr(format!("NOT ({e})")),
                                c => c,
                            },
                            start,
                        },
                    },
                }
            }
            Stmt::Flow(Flow::Call) => ExecOp::Halt("REPEAT over labels is not followed".into()),
            Stmt::Flow(Flow::Return) => ExecOp::End,
            Stmt::Assign if kw == "DEF" => define(exprs.first().map_or("", String::as_str)),
            Stmt::Assign if !kw.is_empty() => ExecOp::Nop,
            Stmt::Assign => ExecOp::Assign,
            Stmt::Words => {
                let mut after = After::Next;
                for (_, w) in block.words(&seg) {
                    if w.addr == Addr::letter(b'M')
                        && matches!(w.value, Value::Num(v) if [2.0, 17.0, 30.0].contains(&v))
                    {
                        after = After::End;
                    }
                }
                ExecOp::Words(after)
            }
            _ => ExecOp::Nop,
        };
        p.ops[i] = op;
        for l in labels {
            p.add_label(l, i);
        }
    }
    for (kind, i) in open {
        p.ops[i] = ExecOp::Halt(format!("{kind} is never closed"));
    }
    Ok(())
}

fn close(open: &mut Vec<(&'static str, usize)>, kind: &str) -> Option<usize> {
    match open.last() {
        Some((k, s)) if *k == kind => {
            let s = *s;
            open.pop();
            Some(s)
        }
        _ => None,
    }
}

fn key(name: &str) -> Option<Key> {
    eval::param_ref(Dialect::Sinumerik, name.trim().as_bytes(), &eval::NoParams)
        .ok()
        .filter(|(_, n)| *n == name.trim().len())
        .map(|(k, _)| k)
}

/// `FOR R1=0 TO 5`.
fn for_op(text: &str, i: usize) -> ExecOp {
    let upper = text.to_ascii_uppercase();
    let (Some(eq), Some(to)) = (text.find('='), upper.find(" TO ")) else {
        return ExecOp::Halt("FOR: expected FOR var=a TO b".into());
    };
    match key(&text[..eq]) {
        Some(var) if eq < to => ExecOp::For {
            var,
            from: text[eq + 1..to].trim().to_string(),
            to: text[to + 4..].trim().to_string(),
            end: i,
        },
        _ => ExecOp::Halt("FOR: expected FOR var=a TO b".into()),
    }
}

/// `DEF REAL A=1, B`: numeric variables, 0 unless given a value.
fn define(text: &str) -> ExecOp {
    let mut words = text.trim().splitn(2, [' ', '\t']);
    let ty = words.next().unwrap_or("").to_ascii_uppercase();
    if !matches!(ty.as_str(), "REAL" | "INT" | "BOOL") {
        return ExecOp::Nop;
    }
    let mut list = Vec::new();
    for part in words.next().unwrap_or("").split(',') {
        let (name, value) = match part.split_once('=') {
            Some((n, v)) => (n, v.trim().to_string()),
            None => (part, "0".to_string()),
        };
        // Arrays (`_A[3]`) are not followed.
        if let Some(k) = key(name) {
            list.push((k, value));
        }
    }
    ExecOp::Define(list)
}
