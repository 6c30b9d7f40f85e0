//! Programs with macro logic: which blocks need it run
//! ([`needs_logic`]), the values a run gives a block's expression words
//! written into it for a correction in place ([`substitute`]), and
//! `--expand`: the program flattened as its macro logic runs. Every block
//! that runs is written once per run, in the order it runs, with each
//! expression word replaced by the literal value it had then (in the
//! dialect's own number format); labels, jumps, loops, branches and calls
//! are dropped; assignments are kept as they run (a cycle definition or a
//! call may still read a parameter; on LinuxCNC with the value they had
//! written in, since a subroutine's may read the arguments of a call that
//! is gone), as are the header, comments and
//! every block that is not macro logic. HEIDENHAIN blocks are numbered
//! again in order. Each written block keeps the line of the block it
//! comes from, so what the rewrite reports names the source line.

use super::edit::Edits;
use super::subroutines::Library;
use crate::machine::Dialect;
use crate::nc::exec::{Executed, Trace, WordValue};
use crate::nc::exec::{Known, KnownWords};
use crate::nc::lexeme::{self, NumStyle, WriteRules};
use crate::nc::{Block, BlockError, Entry, Flow, HhKind, Segment, Stmt, Syntax, TokenKind, Value};
use crate::source::SourceError;
use std::path::Path;

/// Decimals of an expanded literal: 1 nm (and 1 udeg), below any
/// control's resolution; the rewrite writes its own decimals over them.
const DECIMALS: u8 = 6;

/// Decimals of an expanded LinuxCNC literal: enough that the text gives
/// back the value the program computed to 1e-12 mm. LinuxCNC takes an arc
/// given by its radius only when half its chord is within a relative
/// 1e-12 of the radius (rs274ngc's `arc_data_r`, `TINY`): a half circle
/// (`G3 X[..] Y[..] R#<r>`, as LinuxCNC's ngcgui `slot.ngc` writes it)
/// whose ends were written with 6 decimals no longer reaches.
const LINUXCNC_DECIMALS: u8 = 12;

/// Decimals of an expanded literal in `dialect`.
fn decimals(dialect: Dialect) -> u8 {
    match dialect {
        Dialect::Linuxcnc => LINUXCNC_DECIMALS,
        _ => DECIMALS,
    }
}

/// Whether a statement is macro logic that an expanded program drops.
fn dropped(stmt: Stmt) -> bool {
    matches!(
        stmt,
        Stmt::Flow(_)
            | Stmt::Hh(
                HhKind::Lbl
                    | HhKind::CallLbl
                    | HhKind::Fn(9)
                    | HhKind::Fn(10)
                    | HhKind::Fn(11)
                    | HhKind::Fn(12)
            )
    )
}

/// Whether `trace` can be written flattened: it ran to the end of the
/// program, and every coordinate it needs has a value. An error in a
/// subroutine file of `lib` names that file.
pub(super) fn check(
    path: &Path,
    lib: &Library,
    blocks: &[Block],
    trace: &Trace,
) -> Result<(), SourceError> {
    let path_of = |b: usize| lib.file_of(b).map_or(path, |f| f.path.as_path());
    if let Some(h) = &trace.halt {
        return Err(SourceError::new(
            path_of(h.block),
            h.line,
            1,
            format!(
                "--expand cannot follow the program here: {} (run without --expand to correct what can be corrected in place)",
                h.why
            ),
        ));
    }
    for s in &trace.steps {
        let block = &blocks[s.block as usize];
        for wv in &trace.values[s.values.0 as usize..s.values.1 as usize] {
            let TokenKind::Word(w) = block.tokens[wv.token as usize].kind else {
                continue;
            };
            // A tool name, or a feed set outside the program, stays as
            // written: its parameter is still assigned where it was.
            let coordinate = w
                .addr
                .as_letter()
                .is_some_and(|c| b"XYZABCIJKR@^".contains(&c))
                || [
                    crate::nc::Addr::new("I1"),
                    crate::nc::Addr::new("J1"),
                    crate::nc::Addr::new("K1"),
                    crate::nc::Addr::new("CR"),
                ]
                .contains(&w.addr);
            if wv.value.is_none() && coordinate {
                let why = trace
                    .first_unknown
                    .as_ref()
                    .filter(|(l, _)| *l == block.line)
                    .map_or_else(String::new, |(_, w)| format!(": {w}"));
                let (line, column) = block.locate(w.value_span.start as usize);
                return Err(SourceError::new(
                    path_of(s.block as usize),
                    line,
                    column,
                    format!("--expand: the value of {} is not known here{why}", w.addr),
                ));
            }
        }
    }
    Ok(())
}

/// Hands `emit` the blocks of `blocks` as `trace` ran them, flattened, one
/// at a time (a long loop is never all in memory); [`check`] first. The
/// blocks of a subroutine file of `lib` are written where the program
/// calls it, with the line of the call.
pub(super) fn flatten<E: From<SourceError>>(
    path: &Path,
    lib: &Library,
    syntax: Syntax,
    blocks: &[Block],
    trace: &Trace,
    emit: &mut dyn FnMut(&Block) -> Result<(), E>,
) -> Result<(), E> {
    check(path, lib, blocks, trace)?;
    let profiles = match syntax.dialect {
        Dialect::Linuxcnc => profile_subs(blocks, lib.main, trace),
        _ => Vec::new(),
    };
    let steps = Steps {
        steps: &trace.steps,
        values: &trace.values,
        main: lib.main,
        own_lines: false,
        as_written: &profiles,
    };
    write_steps(path, syntax, blocks, &steps, true, emit)
}

/// LinuxCNC's lathe cycles G70, G71 and G72 take the contour they cut
/// from the subroutine their Q word numbers (`G71 Q100` reads `o100 sub`
/// ... `o100 endsub`; LinuxCNC's G-code reference, "G70 Finishing
/// Cycle", "G71 G72 Roughing Cycles"). The cycle reads that definition,
/// it never calls it, so the run has none of its blocks: the ranges of
/// blocks of the program's own definitions such a cycle that runs names,
/// for the flattened program to keep as written where they stand.
fn profile_subs(blocks: &[Block], main: usize, trace: &Trace) -> Vec<std::ops::Range<usize>> {
    use crate::nc::Addr;
    let mut named: Vec<String> = Vec::new();
    for s in &trace.steps {
        let Some(block) = blocks
            .get(s.block as usize)
            .filter(|_| (s.block as usize) < main)
        else {
            continue;
        };
        let Some(seg) = block.segments.get(s.seg as usize) else {
            continue;
        };
        let lathe_cycle = block.words(seg).any(|(_, w)| {
            w.addr == Addr::letter(b'G')
                && matches!(w.value, Value::Num(g) if [70.0, 71.0, 71.1, 71.2, 72.0, 72.1, 72.2].contains(&g))
        });
        if !lathe_cycle {
            continue;
        }
        // The Q word as the run had it (a literal, or an expression's value).
        for (ti, w) in block.words(seg) {
            if w.addr != Addr::letter(b'Q') {
                continue;
            }
            let v = match w.value {
                Value::Num(v) => Some(v),
                _ => trace.values[s.values.0 as usize..s.values.1 as usize]
                    .iter()
                    .find(|wv| wv.token as usize == ti)
                    .and_then(|wv| wv.value),
            };
            if let Some(v) = v.filter(|v| v.fract() == 0.0 && *v >= 0.0 && *v < 1e9) {
                let label = format!("o{}", v as u64);
                if !named.contains(&label) {
                    named.push(label);
                }
            }
        }
    }
    let mut out = Vec::new();
    for label in &named {
        let opens = |b: &Block| {
            b.segments
                .iter()
                .any(|seg| crate::nc::exec::sub_label(b, seg).as_deref() == Some(label))
        };
        let closes = |b: &Block| {
            b.segments
                .iter()
                .any(|seg| crate::nc::exec::endsub_label(b, seg).as_deref() == Some(label))
        };
        if let Some(start) = blocks[..main].iter().position(opens)
            && let Some(len) = blocks[start..main].iter().position(closes)
        {
            out.push(start..start + len + 1);
        }
    }
    out.sort_by_key(|r| r.start);
    out
}

/// Where [`write_steps`] hands a block's text: its source line, why it
/// could not be read (if so), and whether it runs.
type WriteBlock<'a, E> = dyn FnMut(Vec<u8>, usize, Option<&BlockError>, bool) -> Result<(), E> + 'a;

/// Statements run, to write flattened.
pub(super) struct Steps<'a> {
    /// The statements, in the order they ran.
    pub steps: &'a [Executed],
    /// Their words' values ([`Trace::values`]).
    pub values: &'a [WordValue],
    /// The program's own blocks; those after are subroutine files'.
    pub main: usize,
    /// A file's block keeps its own line (else it takes the line of the
    /// program's statement that ran last before it: the call).
    pub own_lines: bool,
    /// Ranges of the program's own blocks written as they stand, where
    /// they stand, though they never run (a lathe cycle's profile
    /// subroutine): marked so that what reads them back knows they do not
    /// run.
    pub as_written: &'a [std::ops::Range<usize>],
}

/// Hands `emit` the blocks of `blocks` as `run` ran them, flattened (each
/// word whose value is known written as that value, the others as
/// written); with `tail`, what follows the last block run (`%`, blank
/// lines) too.
pub(super) fn write_steps<E: From<SourceError>>(
    path: &Path,
    syntax: Syntax,
    blocks: &[Block],
    run: &Steps<'_>,
    tail: bool,
    emit: &mut dyn FnMut(&Block) -> Result<(), E>,
) -> Result<(), E> {
    let dialect = syntax.dialect;
    let eol: &[u8] = blocks.iter().find_map(Block::line_ending).unwrap_or(b"\n");
    let mut number = blocks.iter().find_map(|b| {
        b.tokens.iter().find_map(|t| match t.kind {
            TokenKind::BlockNumber(n) => Some(i64::from(n)),
            _ => None,
        })
    });
    // The last block is held back until the next: a block without a line
    // ending (the file's last) gets one when another follows it.
    let mut held: Option<Block> = None;
    // A block the source could not read stays unreadable as it runs: kept
    // as written, what the controller does after it unknown, as where the
    // program streams (it has no words the logic could fill in).
    let mut out =
        |text: Vec<u8>, line: usize, bad: Option<&BlockError>, runs: bool| -> Result<(), E> {
            if let Some(mut prev) = held.take() {
                if prev.line_ending().is_none() {
                    let mut t = std::mem::take(&mut prev.text);
                    t.extend_from_slice(eol);
                    let was = prev.unreadable.take();
                    let entries: Vec<Entry> = prev.segments.iter().map(|s| s.entry).collect();
                    prev = parse(path, syntax, t, prev.line, was.as_ref())?;
                    for (seg, e) in prev.segments.iter_mut().zip(entries) {
                        seg.entry = e;
                    }
                }
                emit(&prev)?;
            }
            let mut b = parse(path, syntax, text, line, bad)?;
            if !runs {
                for seg in &mut b.segments {
                    seg.entry = Entry::NotRun;
                }
            }
            held = Some(b);
            Ok(())
        };
    // The blocks written as they stand, each range once, before the first
    // block after it that runs.
    let mut as_written = run.as_written.iter().peekable();
    let mut write_as_written = |before: usize, out: &mut WriteBlock<'_, E>| -> Result<(), E> {
        while let Some(r) = as_written.next_if(|r| r.start < before) {
            for block in &blocks[r.clone()] {
                out(
                    block.text.clone(),
                    block.line,
                    block.unreadable.as_ref(),
                    false,
                )?;
            }
        }
        Ok(())
    };
    let mut edits = Edits::default();
    let mut k = 0;
    let steps = run.steps;
    let mut last_block = None;
    // The line of the program's statement that ran last (a call).
    let mut call_line = None;
    while k < steps.len() {
        // One run of a block: its consecutive statements.
        let b = steps[k].block;
        let mut j = k;
        while j < steps.len() && steps[j].block == b && (j == k || steps[j].seg > steps[j - 1].seg)
        {
            j += 1;
        }
        let block = &blocks[b as usize];
        let line = if (b as usize) < run.main || run.own_lines {
            if (b as usize) < run.main {
                call_line = Some(block.line);
            }
            block.line
        } else {
            call_line.unwrap_or(block.line)
        };
        if (b as usize) < run.main {
            last_block = Some(b as usize);
            write_as_written(b as usize, &mut out)?;
        }
        edits.clear();
        let mut kept = false;
        for (si, seg) in block.segments.iter().enumerate() {
            let Some(step) = steps[k..j].iter().find(|s| s.seg as usize == si) else {
                delete(&mut edits, block, seg);
                continue;
            };
            if seg.stmt == Stmt::Flow(Flow::Branch) && dialect == Dialect::Fanuc && step.taken {
                // IF [..] THEN #n = ..: the assignment stays.
                if let Some(p) = block
                    .seg_tokens(seg)
                    .iter()
                    .position(|t| t.kind == TokenKind::Param)
                {
                    let start = block.tokens[seg.body as usize].span.start;
                    let at = block.tokens[seg.first as usize + p].span.start;
                    edits.delete(crate::nc::Span { start, end: at });
                    kept = true;
                    continue;
                }
            }
            if dropped(seg.stmt) {
                delete(&mut edits, block, seg);
                continue;
            }
            if !matches!(seg.stmt, Stmt::Blank) {
                kept = true;
            }
            for wv in &run.values[step.values.0 as usize..step.values.1 as usize] {
                let tok = &block.tokens[wv.token as usize];
                // No control takes `X=inf`: a value the logic computes
                // beyond every number (R1=EXP(1000)) ends the run here,
                // with its line, before it is written.
                if let Some(v) = wv.value
                    && !v.is_finite()
                    && matches!(tok.kind, TokenKind::Word(_) | TokenKind::Expr)
                {
                    return Err(SourceError::new(
                        path,
                        line,
                        0,
                        format!(
                            "a word's value computes to {v}, which is not a number a control can take: nothing written"
                        ),
                    )
                    .into());
                }
                match (tok.kind, wv.value) {
                    (TokenKind::Word(w), Some(v)) => {
                        edits.replace(w.value_span, |o| literal(o, dialect, w.addr, v));
                    }
                    // A LinuxCNC assignment keeps the value it had: its
                    // right-hand side may read a call's arguments, which
                    // the flattened program no longer passes.
                    (TokenKind::Expr, Some(v)) => {
                        edits.replace(tok.span, |o| {
                            lexeme::write(
                                o,
                                v,
                                decimals(dialect),
                                &NumStyle {
                                    point: true,
                                    ..NumStyle::default()
                                },
                                WriteRules {
                                    force_point: true,
                                    force_plus: false,
                                },
                            )
                        });
                    }
                    _ => {}
                }
            }
        }
        let only_blank = block.segments.iter().all(|s| s.stmt == Stmt::Blank);
        if kept || only_blank {
            if dialect == Dialect::Heidenhain
                && let Some(n) = number.as_mut()
                && let Some(t) = block
                    .tokens
                    .iter()
                    .find(|t| matches!(t.kind, TokenKind::BlockNumber(_)))
            {
                let v = *n;
                edits.replace(t.span, |o| lexeme::push_u64(o, v.max(0) as u64));
                *n += 1;
            }
            let mut text = Vec::new();
            edits
                .write_block(block, &mut text)
                .expect("writing to memory");
            out(text, line, block.unreadable.as_ref(), true)?;
        }
        k = j;
    }
    write_as_written(run.main, &mut out)?;
    // What follows the end (`%`, blank lines, comments) is kept.
    if tail && let Some(last) = last_block {
        for block in &blocks[last + 1..run.main] {
            if block
                .segments
                .iter()
                .all(|s| matches!(s.stmt, Stmt::Blank | Stmt::Percent))
            {
                out(
                    block.text.clone(),
                    block.line,
                    block.unreadable.as_ref(),
                    true,
                )?;
            }
        }
    }
    if let Some(b) = held {
        emit(&b)?;
    }
    Ok(())
}

/// Removes a statement (its line ending stays, so the line does).
fn delete(edits: &mut Edits, block: &Block, seg: &Segment) {
    let toks = block.seg_tokens(seg);
    let end = toks
        .iter()
        .rposition(|t| t.kind != TokenKind::LineEnd)
        .map(|p| toks[p].span.end);
    if let (Some(first), Some(end)) = (toks.first(), end) {
        // Block numbers and block delete stay with the block.
        let start = block.tokens[seg.body as usize..seg.end as usize]
            .first()
            .map_or(first.span.start, |t| t.span.start);
        if end > start {
            edits.delete(crate::nc::Span { start, end });
        }
    }
}

/// A value as a literal of the dialect: integers plain for codes (`G1`,
/// `M3`, `T2`), coordinates with a decimal point (FANUC reads `X1` in
/// least input increments) and HEIDENHAIN's sign.
fn literal(out: &mut Vec<u8>, dialect: Dialect, addr: crate::nc::Addr, v: f64) {
    let code = addr
        .as_letter()
        .is_some_and(|l| matches!(l, b'G' | b'M' | b'T' | b'D' | b'H' | b'S' | b'P' | b'L'));
    let integral = v.fract() == 0.0 && v.abs() < 1e9;
    let rules = WriteRules {
        force_point: dialect == Dialect::Fanuc && !(code && integral),
        force_plus: dialect == Dialect::Heidenhain,
    };
    let style = NumStyle {
        point: !(code && integral),
        ..NumStyle::default()
    };
    lexeme::write(out, v, decimals(dialect), &style, rules);
}

/// The block `text` (from source line `line`) read back; `bad`: the
/// source block was unreadable, and this one is too, for the same reason.
fn parse(
    path: &Path,
    syntax: Syntax,
    text: Vec<u8>,
    line: usize,
    bad: Option<&BlockError>,
) -> Result<Block, SourceError> {
    let mut b = Block {
        text,
        line,
        ..Block::default()
    };
    if let Some(e) = bad {
        b.make_unreadable(e.clone());
        return Ok(b);
    }
    syntax.parse(&mut b).map_err(|e| {
        let (l, c) = b.locate(e.offset);
        SourceError::new(
            path,
            l,
            c,
            format!("the expanded block does not read back: {}", e.message),
        )
    })?;
    Ok(b)
}

/// Whether a block is macro logic or uses it: a parameter assignment,
/// control flow (labels, jumps, loops, calls) or an expression word.
pub(super) fn needs_logic(block: &Block) -> bool {
    block.segments.iter().any(|s| {
        matches!(
            s.stmt,
            Stmt::Assign
                | Stmt::Flow(_)
                | Stmt::Hh(HhKind::Q | HhKind::Fn(_) | HhKind::Lbl | HhKind::CallLbl)
        )
    }) || block
        .tokens
        .iter()
        .any(|t| matches!(t.kind, TokenKind::Word(w) if w.value == Value::Expr))
}

/// `block` (index `index` of the part that was run) with the value of
/// every expression word that has one value in every run written in as a
/// number (its text is only replaced if the correction changes it), how
/// each of its statements is reached when the program runs, and why its
/// other expression words cannot be corrected in place.
pub(super) fn substitute(
    block: &Block,
    index: u32,
    dialect: Dialect,
    known: &KnownWords,
) -> (Block, Option<String>) {
    let mut b = block.clone();
    // SINUMERIK's interpreter follows IF/ELSE blocks of its own.
    if dialect != Dialect::Sinumerik && !known.entries.is_empty() {
        for (si, seg) in b.segments.iter_mut().enumerate() {
            seg.entry = known
                .entries
                .get(&(index, si as u32))
                .copied()
                .unwrap_or(Entry::NotRun);
        }
    }
    let mut why = None;
    for (ti, t) in b.tokens.iter_mut().enumerate() {
        let TokenKind::Word(w) = &mut t.kind else {
            continue;
        };
        if w.value != Value::Expr {
            continue;
        }
        match known.words.get(&(index, ti as u32)) {
            Some(Known::Value(v)) => {
                w.value = Value::Num(*v);
                // A computed value is in mm (or deg), never in increments.
                w.style = NumStyle {
                    point: dialect == Dialect::Fanuc,
                    ..NumStyle::default()
                };
            }
            Some(Known::Varies(n)) => {
                why = Some(format!(
                    "the block runs {n} times with different values (a macro loop or repeated call); use --expand"
                ))
            }
            Some(Known::InCall) if why.is_none() => {
                why = Some("the block runs inside a subprogram call; use --expand".to_string())
            }
            _ => {}
        }
    }
    (b, why)
}
