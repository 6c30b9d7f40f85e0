//! FANUC Custom Macro B and LinuxCNC o-words as [`ExecOp`]s: `GOTO n` and
//! `IF [..] GOTO n` to sequence numbers, `IF [..] THEN`, `WHILE [..] DOm`
//! / `ENDm`; LinuxCNC `if`/`elseif`/`else`/`endif`, `while`/`endwhile`,
//! `do`/`while`, `repeat`/`endrepeat`, `break`/`continue`,
//! `sub`/`endsub`/`return`/`call` with arguments, linked by their o-label.
//! M2/M30 (and M99 in the main program) end the program; M98 and G65/G66
//! call programs outside the file and end what can be followed.

use super::{After, Cond, ExecOp, JumpTarget, Program, RunawayError};
use crate::machine::Dialect;
use crate::nc::{Addr, Flow, Stmt, TokenKind, Value};

pub(super) fn decode(p: &mut Program) -> Result<(), RunawayError> {
    let fanuc = p.dialect == Dialect::Fanuc;
    let n = p.at.len();
    p.ops = vec![ExecOp::Nop; n];
    // Open structures: (o-label or DO number, kind, statement).
    let mut open: Vec<(String, &'static str, usize)> = Vec::new();
    // if-chains: statements of the if/elseif/else of each open `if`.
    let mut chains: Vec<Vec<usize>> = Vec::new();
    for i in 0..n {
        if p.at[i].1 == 0
            && let Some(num) = p.block(i).tokens.iter().find_map(|t| match t.kind {
                TokenKind::BlockNumber(k) => Some(k),
                _ => None,
            })
        {
            p.add_label(format!("N{num}"), i);
        }
        let block = p.block(i);
        let seg = *p.seg(i);
        let toks = block.seg_tokens(&seg);
        let exprs: Vec<String> = toks
            .iter()
            .filter(|t| t.kind == TokenKind::Expr)
            .map(|t| String::from_utf8_lossy(block.bytes(t.span)).into_owned())
            .collect();
        let keywords: Vec<String> = toks
            .iter()
            .filter(|t| t.kind == TokenKind::Keyword)
            .map(|t| String::from_utf8_lossy(block.bytes(t.span)).to_ascii_lowercase())
            .collect();
        let op = match seg.stmt {
            Stmt::Words => words_op(block, &seg),
            Stmt::Assign => ExecOp::Assign,
            Stmt::Flow(flow) if fanuc => fanuc_flow(p, flow, &exprs, &keywords, &mut open, i),
            Stmt::Flow(flow) => oword_flow(p, flow, &exprs, &keywords, &mut open, &mut chains, i),
            _ => ExecOp::Nop,
        };
        p.ops[i] = op;
    }
    link_breaks(p);
    for (label, kind, i) in open {
        p.ops[i] = ExecOp::Halt(format!("{label} {kind} is never closed"));
    }
    Ok(())
}

/// A FANUC Macro B statement: GOTO, IF [..] GOTO / THEN, WHILE [..] DOm and
/// ENDm (a `WHILE` opens in `open`, its `END` closes it).
fn fanuc_flow(
    p: &mut Program,
    flow: Flow,
    exprs: &[String],
    keywords: &[String],
    open: &mut Vec<(String, &'static str, usize)>,
    i: usize,
) -> ExecOp {
    let cond = |k: usize| exprs.get(k).map_or(Cond::Always, |e| Cond::Expr(e.clone()));
    match flow {
        Flow::Jump => {
            let has_if = keywords.first().is_some_and(|k| k == "if");
            let target = exprs.last().cloned().unwrap_or_default();
            ExecOp::Goto {
                cond: if has_if { cond(0) } else { Cond::Always },
                target: if !target.is_empty() && target.bytes().all(|c| c.is_ascii_digit()) {
                    JumpTarget::Label(format!("N{}", target.parse::<u64>().unwrap_or(0)))
                } else {
                    JumpTarget::Number(target)
                },
                forward: None,
            }
        }
        Flow::Branch => ExecOp::IfThen(cond(0)),
        Flow::LoopStart => {
            let id = keywords.last().cloned().unwrap_or_default();
            let id = id.trim_start_matches("do").to_string();
            open.push((id, "while", i));
            ExecOp::While {
                cond: cond(0),
                end: i,
            }
        }
        Flow::LoopEnd => {
            let id = keywords.last().cloned().unwrap_or_default();
            let id = id.trim_start_matches("end").to_string();
            match open.pop() {
                Some((o, _, start)) if o == id => {
                    if let ExecOp::While { end, .. } = &mut p.ops[start] {
                        *end = i;
                    }
                    ExecOp::Back { start }
                }
                _ => ExecOp::Halt(format!("END{id} without its WHILE ... DO{id}")),
            }
        }
        _ => ExecOp::Nop,
    }
}

/// A LinuxCNC o-word statement, linked to its opening statement by its
/// o-label (`open`), with the if/elseif/else chains in `chains`; `break`
/// and `continue` are resolved by [`link_breaks`] once every loop's end is
/// known.
fn oword_flow(
    p: &mut Program,
    flow: Flow,
    exprs: &[String],
    keywords: &[String],
    open: &mut Vec<(String, &'static str, usize)>,
    chains: &mut Vec<Vec<usize>>,
    i: usize,
) -> ExecOp {
    let cond = |k: usize| exprs.get(k).map_or(Cond::Always, |e| Cond::Expr(e.clone()));
    let label = oword_label(keywords.first().map_or("", |s| s.as_str()));
    let kw = keywords.get(1).cloned().unwrap_or_default();
    let find_loop = |open: &[(String, &'static str, usize)]| {
        open.iter()
            .rev()
            .any(|(l, k, _)| *l == label && matches!(*k, "while" | "do" | "repeat"))
    };
    match (flow, kw.as_str()) {
        (_, "sub") => {
            p.add_label(label.clone(), i);
            open.push((label, "sub", i));
            ExecOp::Sub { end: i }
        }
        (_, "endsub") => {
            close(p, open, &label, "sub", i);
            ExecOp::Return
        }
        (_, "return") => ExecOp::Return,
        (_, "call") => ExecOp::Call {
            target: JumpTarget::Label(label),
            args: exprs.iter().map(|e| e.to_string()).collect(),
            rep: None,
        },
        (_, "if") => {
            open.push((label, "if", i));
            chains.push(vec![i]);
            ExecOp::If {
                cond: cond(0),
                next: i,
            }
        }
        (_, "elseif") | (_, "else") => {
            if let Some(c) = chains.last_mut() {
                c.push(i);
            }
            if kw == "else" {
                ExecOp::Else { end: i }
            } else {
                ExecOp::ElseIf {
                    cond: cond(0),
                    next: i,
                    end: i,
                }
            }
        }
        (_, "endif") => {
            let chain = chains.pop().unwrap_or_default();
            link_chain(p, &chain, i);
            close(p, open, &label, "if", i);
            ExecOp::Nop
        }
        (_, "do") => {
            open.push((label, "do", i));
            ExecOp::Nop
        }
        (_, "while") => match open.last() {
            Some((l, "do", s)) if *l == label => {
                let start = *s;
                open.pop();
                ExecOp::BackIf {
                    cond: cond(0),
                    start,
                }
            }
            _ => {
                open.push((label, "while", i));
                ExecOp::While {
                    cond: cond(0),
                    end: i,
                }
            }
        },
        (_, "endwhile") => match close(p, open, &label, "while", i) {
            Some(start) => ExecOp::Back { start },
            None => ExecOp::Halt(format!("{label} endwhile without its while")),
        },
        (_, "repeat") => {
            open.push((label, "repeat", i));
            ExecOp::Repeat {
                count: exprs.first().cloned().unwrap_or_default(),
                end: i,
            }
        }
        (_, "endrepeat") => match close(p, open, &label, "repeat", i) {
            Some(start) => ExecOp::RepeatEnd { start },
            None => ExecOp::Halt(format!("{label} endrepeat without its repeat")),
        },
        // Resolved below, once the loop's end is known.
        (_, "break") | (_, "continue") if find_loop(open) => ExecOp::Break { end: usize::MAX },
        (_, "break") | (_, "continue") => ExecOp::Halt(format!("{label} {kw} outside its loop")),
        _ => ExecOp::Halt(format!("{label} {kw} is not followed")),
    }
}

/// `break` and `continue`: to the end of their loop (continue runs the
/// end's test, break goes past it).
fn link_breaks(p: &mut Program) {
    let n = p.at.len();
    for i in 0..n {
        if !matches!(p.ops[i], ExecOp::Break { end: usize::MAX }) {
            continue;
        }
        let block = p.block(i);
        let seg = *p.seg(i);
        let kws: Vec<String> = block
            .seg_tokens(&seg)
            .iter()
            .filter(|t| t.kind == TokenKind::Keyword)
            .map(|t| String::from_utf8_lossy(block.bytes(t.span)).to_ascii_lowercase())
            .collect();
        let label = oword_label(kws.first().map_or("", |s| s.as_str()));
        let end = (i + 1..n).find(|&j| {
            matches!(
                p.ops[j],
                ExecOp::Back { .. } | ExecOp::BackIf { .. } | ExecOp::RepeatEnd { .. }
            ) && {
                let b = p.block(j);
                let s = p.seg(j);
                b.seg_tokens(s)
                    .iter()
                    .find(|t| t.kind == TokenKind::Keyword)
                    .is_some_and(|t| {
                        oword_label(&String::from_utf8_lossy(b.bytes(t.span)).to_ascii_lowercase())
                            == label
                    })
            }
        });
        let continue_ = kws.get(1).is_some_and(|k| k == "continue");
        p.ops[i] = match end {
            Some(e) if continue_ => ExecOp::Back { start: e },
            Some(e) => ExecOp::Break { end: e },
            None => ExecOp::Halt(format!("{label} break without its loop end")),
        };
    }
}

/// Closes the innermost open `kind` named `label`: its start, with its end
/// recorded.
fn close(
    p: &mut Program,
    open: &mut Vec<(String, &'static str, usize)>,
    label: &str,
    kind: &str,
    i: usize,
) -> Option<usize> {
    let at = open
        .iter()
        .rposition(|(l, k, _)| l == label && *k == kind)?;
    let (_, _, start) = open.remove(at);
    match &mut p.ops[start] {
        ExecOp::While { end, .. } | ExecOp::Repeat { end, .. } | ExecOp::Sub { end } => *end = i,
        _ => {}
    }
    Some(start)
}

/// Links `if`/`elseif`/`else` statements to the next test and the end.
fn link_chain(p: &mut Program, chain: &[usize], endif: usize) {
    for (k, &s) in chain.iter().enumerate() {
        let next = chain.get(k + 1).copied().unwrap_or(endif);
        match &mut p.ops[s] {
            ExecOp::If { next: n, .. } => *n = next,
            ExecOp::ElseIf { next: n, end, .. } => {
                *n = next;
                *end = endif;
            }
            ExecOp::Else { end } => *end = endif,
            _ => {}
        }
    }
}

/// `o100`, `O0100` -> `o100`; `o<Name >` -> `o<name>`.
pub(super) fn oword_label(s: &str) -> String {
    let s = s.to_ascii_lowercase();
    if let Some(rest) = s.strip_prefix('o') {
        if rest.starts_with('<') {
            return format!("o{}", rest.replace([' ', '\t'], ""));
        }
        if let Ok(n) = rest.parse::<u64>() {
            return format!("o{n}");
        }
    }
    s
}

/// A words statement: how it ends the program or leaves it.
fn words_op(block: &crate::nc::Block, seg: &crate::nc::Segment) -> ExecOp {
    let mut after = After::Next;
    for (_, w) in block.words(seg) {
        let Value::Num(v) = w.value else { continue };
        if w.addr == Addr::letter(b'M') {
            match v as i64 {
                2 | 30 | 99 if v.fract() == 0.0 => after = After::End,
                98 if v.fract() == 0.0 => {
                    after =
                        After::Halt("M98 calls a subprogram outside what fivecal follows".into())
                }
                _ => {}
            }
        } else if w.addr == Addr::letter(b'G') && matches!(v, 65.0 | 66.0 | 66.1) {
            after = After::Halt(format!("G{v} calls a macro program outside the file"));
        } else if w.addr == Addr::letter(b'G')
            && ((31.0..32.0).contains(&v) || (38.0..39.0).contains(&v))
            && after == After::Next
        {
            after = After::Probe;
        }
    }
    ExecOp::Words(after)
}
