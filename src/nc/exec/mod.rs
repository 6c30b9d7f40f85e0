//! Running a program's macro logic: parameters, jumps, loops and calls,
//! executed as the controller would, so that moves written with variables
//! get the values they have when they run.
//!
//! Each statement is decoded once into an `ExecOp` (one file per dialect:
//! `iso.rs` for FANUC Macro B and LinuxCNC o-words, `heidenhain.rs` for Q
//! parameters, FN and labels, `sinumerik.rs` for R parameters, `DEF`
//! variables and the structured statements); the loops and branches are
//! linked to their ends, and [`run_with`] steps through them from the first
//! statement. The result is a [`Trace`]: every statement executed, in
//! order, with the values its expression words had. A value the program
//! does not fix (a system variable, a parameter set elsewhere) is unknown,
//! never guessed; a condition or a jump that depends on one, or a call
//! out of the program, ends the trace there ([`Trace::halt`]).
//! Execution is bounded ([`MAX_EXEC_STATEMENTS`] statements,
//! [`MAX_CALL_DEPTH`] nested calls): a loop that does not end is an error
//! at its line, never a hang.

pub(crate) mod eval;
mod heidenhain;
mod iso;
mod sinumerik;

use std::collections::HashMap;

pub(crate) use crate::limits::{MAX_CALL_DEPTH, MAX_EXEC_STATEMENTS};
use crate::machine::Dialect;
use eval::{Key, Params, Stop};

use super::{Block, Entry, TokenKind, Value};

/// A condition.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Cond {
    /// Always true.
    Always,
    /// An expression: true when not zero.
    Expr(String),
    /// HEIDENHAIN FN 9-12: `a op b` with op one of `==`, `<>`, `>`, `<`.
    Cmp(String, &'static str, String),
}

/// What the statement does after its words (ISO M and G codes).
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum After {
    /// Nothing.
    Next,
    /// The program ends (M2, M30, END PGM, M99 in the main program).
    End,
    /// It goes where fivecal cannot follow (M98, G65, CALL PGM, ...).
    Halt(String),
    /// A probing move (G31, G38.x): the control writes where it touched,
    /// and whether it did, into #5061-#5070, values no program text fixes.
    Probe,
}

/// A decoded statement.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum ExecOp {
    /// Nothing to execute (blank, comment, program number, a label).
    Nop,
    /// Words: their expressions are evaluated, then any assignments in
    /// the statement (`Param = Expr` tokens) are made.
    Words(After),
    /// Assignments only (`Param = Expr` tokens).
    Assign,
    /// FANUC `IF [c] THEN #n = ...`.
    IfThen(Cond),
    /// `target = expression` decoded from the text (HEIDENHAIN FN, Q).
    Set(Key, String),
    /// `target = a op b` with a function of two values that the formula
    /// syntax has no spelling for (HEIDENHAIN FN 8 `LEN`, FN 13 `ANG`).
    SetPair(Key, Pair, String, String),
    /// The parameter becomes unknown (FN 18 SYSREAD), with why.
    Forget(Key, String),
    /// DEF: names set to the values.
    Define(Vec<(Key, String)>),
    /// A jump to a label, when the condition holds.
    Goto {
        cond: Cond,
        /// Label expression (`N` + number, or the name).
        target: JumpTarget,
        /// Search forward (`Some(true)`), backward, or everywhere.
        forward: Option<bool>,
    },
    /// Opens `if`: when false, go to `next` (elseif, else or endif).
    If { cond: Cond, next: usize },
    /// `elseif`: taken only when entered from a failed test.
    ElseIf { cond: Cond, next: usize, end: usize },
    /// `else`.
    Else { end: usize },
    /// Top of a loop tested first (WHILE, LinuxCNC while, FOR's test):
    /// when false, go past `end`.
    While { cond: Cond, end: usize },
    /// Bottom of a loop: go back to `start` (its test).
    Back { start: usize },
    /// Bottom of a do-loop: back to `start + 1` while the condition holds.
    BackIf { cond: Cond, start: usize },
    /// `repeat [n]` top: the count; `end` is its endrepeat.
    Repeat { count: String, end: usize },
    /// `endrepeat`.
    RepeatEnd { start: usize },
    /// FOR var = from TO to.
    For {
        var: Key,
        from: String,
        to: String,
        end: usize,
    },
    /// ENDFOR.
    ForEnd { start: usize, var: Key },
    /// `break` out of the loop ending at `end`.
    Break { end: usize },
    /// A subprogram body starts: skipped when reached without a call.
    Sub { end: usize },
    /// A subprogram returns (endsub, return, LBL 0 in a call).
    Return,
    /// A call with arguments (LinuxCNC `call`, HEIDENHAIN `CALL LBL`).
    Call {
        target: JumpTarget,
        args: Vec<String>,
        /// HEIDENHAIN `REP n` on a label before the call: the section is
        /// run again n times; n is an expression (`REP Q5`), read when the
        /// call is first reached.
        rep: Option<String>,
    },
    /// The program ends.
    End,
    /// Execution cannot go on (with why).
    Halt(String),
}

/// A function of two values.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Pair {
    /// HEIDENHAIN FN 8 `a LEN b`: the root of the sum of the squares.
    Len,
    /// HEIDENHAIN FN 13 `a ANG b`: the angle whose sine and cosine are
    /// in the ratio a : b (the arc tangent of a / b, any quadrant),
    /// degrees in [0, 360).
    Ang,
}

impl Pair {
    fn apply(self, a: f64, b: f64) -> Result<f64, Stop> {
        let v = match self {
            Pair::Len => a.hypot(b),
            // Both zero is no direction: no angle to give, never a guess.
            Pair::Ang if a == 0.0 && b == 0.0 => {
                return Err(Stop::Alarm("FN 13 ANG of two zero values".into()));
            }
            Pair::Ang => {
                let t = a.atan2(b).to_degrees();
                // A hair below zero would round to 360 itself.
                if t < 0.0 { (t + 360.0) % 360.0 } else { t }
            }
        };
        if v.is_finite() {
            Ok(v)
        } else {
            Err(Stop::Alarm(format!(
                "{self:?} of {a} and {b} is not a finite number"
            )))
        }
    }
}

/// A jump or call target.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum JumpTarget {
    /// A label known from the text.
    Label(String),
    /// FANUC `GOTO #1`: `N` and the value.
    Number(String),
}

/// One statement executed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Executed {
    /// Block index in the program.
    pub block: u32,
    /// Statement index in the block.
    pub seg: u32,
    /// Call depth (0: the main program).
    pub depth: u32,
    /// Its values in [`Trace::values`].
    pub values: (u32, u32),
    /// A conditional statement's action was taken (FANUC IF-THEN).
    pub taken: bool,
}

/// A word's value in one run of its statement.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct WordValue {
    /// Token index of the word in its block.
    pub token: u32,
    /// Its value, or `None` when unknown.
    pub value: Option<f64>,
}

/// Where execution stopped before the end, and why.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Halt {
    /// 1-based line.
    pub line: usize,
    /// Index of its block in the blocks run (a subroutine file's blocks
    /// follow the program's: [`run_with`]).
    pub block: usize,
    /// Why.
    pub why: String,
}

/// A program's execution.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct Trace {
    /// Statements executed, in order.
    pub steps: Vec<Executed>,
    /// Values of the expression words of the steps.
    pub values: Vec<WordValue>,
    /// Where execution could not go on, when it could not.
    pub halt: Option<Halt>,
    /// The first unknown word value: line and why.
    pub first_unknown: Option<(usize, String)>,
}

/// A program whose execution does not end within the bounds.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct RunawayError {
    /// 1-based line of the statement where the bound was reached.
    pub line: usize,
    /// What was exceeded.
    pub message: String,
}

/// The parameter store.
#[derive(Default)]
struct Vars {
    known: HashMap<Key, f64>,
    unknown: HashMap<Key, String>,
}

impl Vars {
    fn set(&mut self, k: Key, v: Result<f64, Stop>) {
        match v {
            Ok(v) => {
                self.unknown.remove(&k);
                self.known.insert(k, v);
            }
            Err(s) => {
                self.known.remove(&k);
                self.unknown.insert(k, s.to_string());
            }
        }
    }
}

struct Store<'a> {
    vars: &'a Vars,
    dialect: Dialect,
}

impl Params for Store<'_> {
    fn get(&self, key: &Key) -> Result<f64, Stop> {
        if let Some(v) = self.vars.known.get(key) {
            return Ok(*v);
        }
        if let Some(why) = self.vars.unknown.get(key) {
            return Err(Stop::Unknown(why.clone()));
        }
        let shown = match (self.dialect, key) {
            (Dialect::Fanuc | Dialect::Linuxcnc, Key::Num(n)) => format!("#{n}"),
            (Dialect::Fanuc | Dialect::Linuxcnc, Key::Name(s)) => format!("#<{s}>"),
            (Dialect::Heidenhain, Key::Num(n)) => format!("Q{n}"),
            (Dialect::Sinumerik, Key::Num(n)) => format!("R{n}"),
            (_, Key::Name(s)) => s.to_uppercase(),
        };
        Err(Stop::Unknown(format!(
            "{shown} is not set by the program (a system variable, or set by the operator or another program)"
        )))
    }
}

/// The statements of a program, decoded and linked.
pub(crate) struct Program<'a> {
    dialect: Dialect,
    blocks: &'a [Block],
    /// (block, segment) of each statement.
    at: Vec<(u32, u32)>,
    ops: Vec<ExecOp>,
    /// Label -> statement indices, in order.
    labels: HashMap<String, Vec<usize>>,
    /// Statements of the program itself; those after are subroutine
    /// files', reached only by a call.
    main: usize,
}

impl<'a> Program<'a> {
    fn new(
        dialect: Dialect,
        blocks: &'a [Block],
        main_blocks: usize,
    ) -> Result<Program<'a>, RunawayError> {
        let mut at = Vec::new();
        let mut main = 0;
        for (b, block) in blocks.iter().enumerate() {
            for s in 0..block.segments.len() {
                at.push((b as u32, s as u32));
            }
            if b < main_blocks {
                main = at.len();
            }
        }
        let mut p = Program {
            dialect,
            blocks,
            at,
            ops: Vec::new(),
            labels: HashMap::new(),
            main,
        };
        match dialect {
            Dialect::Fanuc | Dialect::Linuxcnc => iso::decode(&mut p)?,
            Dialect::Heidenhain => heidenhain::decode(&mut p)?,
            Dialect::Sinumerik => sinumerik::decode(&mut p)?,
        }
        Ok(p)
    }

    fn block(&self, i: usize) -> &Block {
        &self.blocks[self.at[i].0 as usize]
    }

    fn seg(&self, i: usize) -> &super::Segment {
        let (b, s) = self.at[i];
        &self.blocks[b as usize].segments[s as usize]
    }

    fn line(&self, i: usize) -> usize {
        self.at.get(i).map_or_else(
            || self.blocks.last().map_or(1, |b| b.line),
            |_| self.block(i).line,
        )
    }

    /// The text of token range `[a, b)` of statement `i`.
    fn text(&self, i: usize, span: super::Span) -> String {
        String::from_utf8_lossy(self.block(i).bytes(span)).into_owned()
    }

    fn add_label(&mut self, name: String, i: usize) {
        self.labels.entry(name).or_default().push(i);
    }

    /// The statement a jump from `from` to `label` lands on.
    fn find(&self, label: &str, from: usize, forward: Option<bool>) -> Option<usize> {
        let list = self.labels.get(label)?;
        match forward {
            Some(true) => list.iter().copied().find(|&i| i > from),
            Some(false) => list.iter().copied().rev().find(|&i| i < from),
            None => list
                .iter()
                .copied()
                .find(|&i| i > from)
                .or_else(|| list.first().copied()),
        }
    }
}

/// A call in progress.
struct Frame {
    ret: usize,
    saved: Vec<(Key, Option<Result<f64, String>>)>,
}

/// Runs the program made of the first `main_blocks` of `blocks`; the
/// blocks after them are subroutine files (LinuxCNC `name.ngc`), whose
/// `o<name> sub` the program's calls reach, but which never run on
/// their own: the program ends where its own blocks end.
pub(crate) fn run_with(
    dialect: Dialect,
    blocks: &[Block],
    main_blocks: usize,
) -> Result<Trace, RunawayError> {
    let p = Program::new(dialect, blocks, main_blocks)?;
    Runner {
        p: &p,
        vars: Vars::default(),
        trace: Trace::default(),
        frames: Vec::new(),
        counters: HashMap::new(),
        entering: false,
    }
    .run()
}

struct Runner<'p, 'a> {
    p: &'p Program<'a>,
    vars: Vars,
    trace: Trace,
    frames: Vec<Frame>,
    /// Loop counters by statement (repeat, REP).
    counters: HashMap<usize, u64>,
    /// The last jump was a failed branch test landing on the next test.
    entering: bool,
}

enum Flow {
    Next,
    Jump(usize),
    Stop,
}

impl Runner<'_, '_> {
    fn store(&self) -> Store<'_> {
        Store {
            vars: &self.vars,
            dialect: self.p.dialect,
        }
    }

    fn eval(&self, text: &str) -> Result<f64, Stop> {
        eval::eval(self.p.dialect, text.as_bytes(), &self.store())
    }

    fn cond(&self, c: &Cond) -> Result<bool, Stop> {
        Ok(match c {
            Cond::Always => true,
            Cond::Expr(e) => self.eval(e)? != 0.0,
            Cond::Cmp(a, op, b) => {
                let (a, b) = (self.eval(a)?, self.eval(b)?);
                match *op {
                    "==" => (a - b).abs() < 1e-9,
                    "<>" => (a - b).abs() >= 1e-9,
                    ">" => a > b,
                    _ => a < b,
                }
            }
        })
    }

    fn halt(&mut self, i: usize, why: impl Into<String>) -> Flow {
        self.trace.halt = Some(Halt {
            line: self.p.line(i),
            block: self.p.at.get(i).map_or(0, |a| a.0 as usize),
            why: why.into(),
        });
        Flow::Stop
    }

    fn run(mut self) -> Result<Trace, RunawayError> {
        let mut pc = 0usize;
        let mut executed = 0usize;
        while pc < self.p.ops.len() {
            // Past the program's own end, only a call runs a file's blocks.
            if pc >= self.p.main && self.frames.is_empty() {
                break;
            }
            executed += 1;
            if executed > MAX_EXEC_STATEMENTS {
                return Err(RunawayError {
                    line: self.p.line(pc),
                    message: format!(
                        "more than {MAX_EXEC_STATEMENTS} statements executed without reaching the end of the program: a loop that does not end?"
                    ),
                });
            }
            let entering = std::mem::take(&mut self.entering);
            let (b, s) = self.p.at[pc];
            let first = self.trace.values.len() as u32;
            let mut taken = false;
            let flow = self.step(pc, entering, &mut taken);
            self.trace.steps.push(Executed {
                block: b,
                seg: s,
                depth: self.frames.len() as u32,
                values: (first, self.trace.values.len() as u32),
                taken,
            });
            match flow? {
                Flow::Next => pc += 1,
                Flow::Jump(t) => pc = t,
                Flow::Stop => break,
            }
        }
        Ok(self.trace)
    }

    /// Evaluates the statement's expression words and makes its
    /// assignments.
    fn words(&mut self, i: usize) {
        let block = self.p.block(i);
        let seg = *self.p.seg(i);
        for t in seg.first..seg.end {
            if let TokenKind::Word(w) = block.tokens[t as usize].kind
                && w.value == Value::Expr
            {
                let text = self.p.text(i, w.value_span);
                let v = self.eval(&text);
                if let Err(why) = &v
                    && self.trace.first_unknown.is_none()
                {
                    self.trace.first_unknown = Some((block.line, why.to_string()));
                }
                self.trace.values.push(WordValue {
                    token: t,
                    value: v.ok(),
                });
            }
        }
        self.assignments(i, seg.first as usize);
    }

    /// The `Param = Expr` assignments of statement `i` from token `from`.
    fn assignments(&mut self, i: usize, from: usize) {
        let block = self.p.block(i);
        let seg = self.p.seg(i);
        let toks = &block.tokens[from..seg.end as usize];
        // LinuxCNC reads every parameter of a line before it sets any.
        let mut sets = Vec::new();
        for (k, t) in toks.iter().enumerate() {
            if t.kind != TokenKind::Param {
                continue;
            }
            let Some(e) = toks[k..].iter().find(|t| t.kind == TokenKind::Expr) else {
                continue;
            };
            let target = eval::param_ref(self.p.dialect, block.bytes(t.span), &self.store());
            let value = self.eval(&self.p.text(i, e.span));
            if self.p.dialect == Dialect::Linuxcnc
                && let Some(at) = toks[k..].iter().position(|t| t.kind == TokenKind::Expr)
            {
                // The value the assignment gives, for `--expand` to write:
                // a flattened program has no call whose arguments (#1..)
                // the right-hand side may read.
                self.trace.values.push(WordValue {
                    token: (from + k + at) as u32,
                    value: value.as_ref().ok().copied(),
                });
            }
            if let Ok((key, _)) = target {
                sets.push((key, value));
            }
        }
        for (k, v) in sets {
            self.vars.set(k, v);
        }
    }

    /// Whether statement `i` (a FANUC `IF [..] THEN`) assigns the alarm
    /// variable #3000.
    fn raises_alarm(&self, i: usize) -> bool {
        if self.p.dialect != Dialect::Fanuc {
            return false;
        }
        let block = self.p.block(i);
        let seg = self.p.seg(i);
        block.tokens[seg.first as usize..seg.end as usize]
            .iter()
            .filter(|t| t.kind == TokenKind::Param)
            .any(|t| {
                matches!(
                    eval::param_ref(self.p.dialect, block.bytes(t.span), &self.store()),
                    Ok((Key::Num(3000), _))
                )
            })
    }

    fn step(&mut self, i: usize, entering: bool, taken: &mut bool) -> Result<Flow, RunawayError> {
        let op = &self.p.ops[i];
        Ok(match op {
            ExecOp::Nop => Flow::Next,
            ExecOp::Words(after) => {
                self.words(i);
                match after {
                    After::Next => Flow::Next,
                    After::Probe => {
                        let line = self.p.line(i);
                        for n in 5061..=5070 {
                            self.vars.set(
                                Key::Num(n),
                                Err(Stop::Unknown(format!(
                                    "#{n} is set by the probing move at line {line}"
                                ))),
                            );
                        }
                        Flow::Next
                    }
                    After::End => Flow::Stop,
                    After::Halt(why) => {
                        let why = why.clone();
                        self.halt(i, why)
                    }
                }
            }
            ExecOp::Assign => {
                self.assignments(i, self.p.seg(i).first as usize);
                Flow::Next
            }
            // `IF [..] THEN #3000 = n`: FANUC's macro alarm (Custom Macro
            // B, system variable #3000: the control stops in alarm state
            // with that number). It is a stop, not a jump: where the
            // condition holds nothing after it runs; where it does not,
            // the program goes on as if the IF were not there, so a
            // condition that is not known changes nothing that runs.
            ExecOp::IfThen(c) if self.raises_alarm(i) => match self.cond(c) {
                Ok(true) => {
                    *taken = true;
                    self.halt(i, "the program raises a macro alarm here (#3000)")
                }
                Ok(false) | Err(_) => Flow::Next,
            },
            ExecOp::IfThen(c) => match self.cond(c) {
                Ok(true) => {
                    *taken = true;
                    self.assignments(i, self.p.seg(i).first as usize);
                    Flow::Next
                }
                Ok(false) => Flow::Next,
                Err(e) => self.halt(i, format!("the condition is not known: {e}")),
            },
            ExecOp::Set(k, e) => {
                let v = self.eval(e);
                self.vars.set(k.clone(), v);
                Flow::Next
            }
            ExecOp::SetPair(k, f, a, b) => {
                let v = self.eval(a).and_then(|a| f.apply(a, self.eval(b)?));
                self.vars.set(k.clone(), v);
                Flow::Next
            }
            ExecOp::Forget(k, why) => {
                self.vars.set(k.clone(), Err(Stop::Unknown(why.clone())));
                Flow::Next
            }
            ExecOp::Define(list) => {
                for (k, e) in list {
                    let v = self.eval(e);
                    self.vars.set(k.clone(), v);
                }
                Flow::Next
            }
            ExecOp::Goto {
                cond,
                target,
                forward,
            } => match self.cond(cond) {
                Ok(false) => Flow::Next,
                Err(e) => self.halt(i, format!("the jump condition is not known: {e}")),
                Ok(true) => match self.label(target) {
                    Err(e) => self.halt(i, format!("the jump target is not known: {e}")),
                    Ok(l) => match self.p.find(&l, i, *forward) {
                        Some(t) => Flow::Jump(t),
                        None => self.halt(i, format!("jump to {l}, which is not in the program")),
                    },
                },
            },
            ExecOp::If { cond, next } => match self.cond(cond) {
                Ok(true) => Flow::Next,
                Ok(false) => {
                    self.entering = true;
                    Flow::Jump(*next)
                }
                Err(e) => self.halt(i, format!("the condition is not known: {e}")),
            },
            ExecOp::ElseIf { cond, next, end } => {
                if !entering {
                    Flow::Jump(*end)
                } else {
                    match self.cond(cond) {
                        Ok(true) => Flow::Next,
                        Ok(false) => {
                            self.entering = true;
                            Flow::Jump(*next)
                        }
                        Err(e) => self.halt(i, format!("the condition is not known: {e}")),
                    }
                }
            }
            ExecOp::Else { end } => {
                if entering {
                    Flow::Next
                } else {
                    Flow::Jump(*end)
                }
            }
            ExecOp::While { cond, end } => match self.cond(cond) {
                Ok(true) => Flow::Next,
                Ok(false) => Flow::Jump(end + 1),
                Err(e) => self.halt(i, format!("the loop condition is not known: {e}")),
            },
            ExecOp::Back { start } => Flow::Jump(*start),
            ExecOp::BackIf { cond, start } => match self.cond(cond) {
                Ok(true) => Flow::Jump(start + 1),
                Ok(false) => Flow::Next,
                Err(e) => self.halt(i, format!("the loop condition is not known: {e}")),
            },
            ExecOp::Repeat { count, end } => match self.eval(count) {
                Ok(n) => {
                    let n = n.max(0.0).round() as u64;
                    if n == 0 {
                        Flow::Jump(end + 1)
                    } else {
                        self.counters.insert(i, n - 1);
                        Flow::Next
                    }
                }
                Err(e) => self.halt(i, format!("the repeat count is not known: {e}")),
            },
            ExecOp::RepeatEnd { start } => match self.counters.get_mut(start) {
                Some(n) if *n > 0 => {
                    *n -= 1;
                    Flow::Jump(start + 1)
                }
                _ => {
                    self.counters.remove(start);
                    Flow::Next
                }
            },
            ExecOp::For { var, from, to, end } => {
                // Entered from above: set the variable; from ENDFOR: it
                // was incremented there.
                if !entering {
                    let v = self.eval(from);
                    self.vars.set(var.clone(), v);
                }
                let now = self.store().get(var);
                match (now, self.eval(to)) {
                    (Ok(v), Ok(t)) if v <= t + 1e-9 => Flow::Next,
                    (Ok(_), Ok(_)) => Flow::Jump(end + 1),
                    (Err(e), _) | (_, Err(e)) => {
                        self.halt(i, format!("the loop bounds are not known: {e}"))
                    }
                }
            }
            ExecOp::ForEnd { start, var } => match self.store().get(var) {
                Ok(v) => {
                    self.vars.set(var.clone(), Ok(v + 1.0));
                    self.entering = true;
                    Flow::Jump(*start)
                }
                Err(e) => self.halt(i, format!("the loop variable is not known: {e}")),
            },
            ExecOp::Break { end } => Flow::Jump(end + 1),
            ExecOp::Sub { end } => Flow::Jump(end + 1),
            ExecOp::Return => match self.frames.pop() {
                Some(f) => {
                    self.restore(f.saved);
                    Flow::Jump(f.ret)
                }
                // HEIDENHAIN: LBL 0 reached without a call does nothing.
                None if self.p.dialect == Dialect::Heidenhain => Flow::Next,
                None => Flow::Stop,
            },
            ExecOp::Call { target, args, rep } => {
                let target = target.clone();
                let args = args.clone();
                let rep = rep.clone();
                self.call(i, &target, &args, rep.as_deref())?
            }
            ExecOp::End => Flow::Stop,
            ExecOp::Halt(why) => {
                let why = why.clone();
                self.halt(i, why)
            }
        })
    }

    fn label(&self, t: &JumpTarget) -> Result<String, Stop> {
        match t {
            JumpTarget::Label(l) => Ok(l.clone()),
            JumpTarget::Number(e) => {
                let v = self.eval(e)?;
                Ok(format!("N{}", v.round() as i64))
            }
        }
    }

    fn call(
        &mut self,
        i: usize,
        target: &JumpTarget,
        args: &[String],
        rep: Option<&str>,
    ) -> Result<Flow, RunawayError> {
        let label = match self.label(target) {
            Ok(l) => l,
            Err(e) => return Ok(self.halt(i, format!("the call target is not known: {e}"))),
        };
        if let Some(n) = rep {
            // HEIDENHAIN program-section repeat: back to the label n times.
            if let Some(t) = self.p.find(&label, i, Some(false)) {
                if !self.counters.contains_key(&i) {
                    // The count is read once, when the call is first reached.
                    let count = match self.eval(n) {
                        Ok(v) if v >= 0.0 && v.fract() == 0.0 && v < 65536.0 => v as u64,
                        Ok(v) => {
                            return Ok(self.halt(
                                i,
                                format!(
                                    "the repeat count {v} is not a whole number from 0 to 65535"
                                ),
                            ));
                        }
                        Err(e) => {
                            return Ok(self.halt(i, format!("the repeat count is not known: {e}")));
                        }
                    };
                    self.counters.insert(i, count + 1);
                }
                let left = self.counters.get_mut(&i).expect("inserted above");
                *left -= 1;
                if *left == 0 {
                    self.counters.remove(&i);
                    return Ok(Flow::Next);
                }
                return Ok(Flow::Jump(t + 1));
            }
            return Ok(self.halt(
                i,
                format!("{label} is called with REP but not found before the call"),
            ));
        }
        let Some(t) = self.p.find(&label, i, None) else {
            let why = match subroutine_file(&label) {
                Some(file) if self.p.dialect == Dialect::Linuxcnc => format!(
                    "{label} is not a subroutine of this program, and its file {file} was not found beside the program or in a --subroutine-path directory (LinuxCNC runs it from its PROGRAM_PREFIX or SUBROUTINE_PATH): what it does is not in the files given"
                ),
                _ => format!("{label} is not in the program"),
            };
            return Ok(self.halt(i, why));
        };
        if self.frames.len() >= MAX_CALL_DEPTH {
            return Err(RunawayError {
                line: self.p.line(i),
                message: format!(
                    "calls nested deeper than {MAX_CALL_DEPTH} levels: a subprogram that calls itself without end?"
                ),
            });
        }
        let mut values = Vec::new();
        for a in args {
            values.push(self.eval(a));
        }
        let saved = self.save_locals();
        for (k, v) in values.into_iter().enumerate() {
            self.vars.set(Key::Num(k as i64 + 1), v);
        }
        self.frames.push(Frame { ret: i + 1, saved });
        // LinuxCNC lands on `sub` (skip it); HEIDENHAIN on `LBL n`.
        Ok(Flow::Jump(t + 1))
    }

    /// LinuxCNC: #1-#30 and named parameters without `_` are local to a
    /// call; the others are global (and all of HEIDENHAIN's).
    fn save_locals(&mut self) -> Vec<(Key, Option<Result<f64, String>>)> {
        if self.p.dialect != Dialect::Linuxcnc {
            return Vec::new();
        }
        let mut saved = Vec::new();
        let keys: Vec<Key> = self
            .vars
            .known
            .keys()
            .chain(self.vars.unknown.keys())
            .filter(|k| linuxcnc_local(k))
            .cloned()
            .collect();
        for k in keys {
            let v = match self.vars.known.remove(&k) {
                Some(v) => Some(Ok(v)),
                None => self.vars.unknown.remove(&k).map(Err),
            };
            saved.push((k, v));
        }
        // Keys set inside the call are removed on return.
        saved.push((Key::Name(String::new()), None));
        saved
    }

    fn restore(&mut self, saved: Vec<(Key, Option<Result<f64, String>>)>) {
        if saved.is_empty() {
            return;
        }
        self.vars.known.retain(|k, _| !linuxcnc_local(k));
        self.vars.unknown.retain(|k, _| !linuxcnc_local(k));
        for (k, v) in saved {
            match v {
                Some(Ok(v)) => {
                    self.vars.known.insert(k, v);
                }
                Some(Err(w)) => {
                    self.vars.unknown.insert(k, w);
                }
                None => {}
            }
        }
    }
}

/// LinuxCNC: the file an `o<name> call` (or `o123 call`) of a subroutine
/// the program does not define runs: `name.ngc`, the name in lower case
/// (LinuxCNC's o-code manual, "Calling Files"); `None` for a computed
/// label (`o[#1] call`).
pub(crate) fn subroutine_file(label: &str) -> Option<String> {
    let name = label.strip_prefix('o')?;
    let name = name
        .strip_prefix('<')
        .and_then(|n| n.strip_suffix('>'))
        .unwrap_or(name);
    let ok = !name.is_empty()
        && name
            .bytes()
            .all(|c| c.is_ascii_alphanumeric() || c == b'_' || c == b'-' || c == b'.');
    ok.then(|| format!("{}.ngc", name.to_ascii_lowercase()))
}

/// LinuxCNC: the o-label a statement calls (`o<name> call [..]`), as the
/// program's labels are kept (`o<name>`, lower case).
pub(crate) fn call_label(block: &Block, seg: &super::Segment) -> Option<String> {
    o_label(block, seg, super::Flow::Call, "call")
}

/// LinuxCNC: the o-label a statement opens a subroutine of (`o<name> sub`).
pub(crate) fn sub_label(block: &Block, seg: &super::Segment) -> Option<String> {
    o_label(block, seg, super::Flow::Label, "sub")
}

/// LinuxCNC: the o-label a statement ends a subroutine of (`o<name> endsub`).
pub(crate) fn endsub_label(block: &Block, seg: &super::Segment) -> Option<String> {
    o_label(block, seg, super::Flow::Return, "endsub")
}

/// The o-label of a statement of kind `flow` whose second keyword is
/// `keyword` (`o<name> call`, `o<name> sub`).
fn o_label(
    block: &Block,
    seg: &super::Segment,
    flow: super::Flow,
    keyword: &str,
) -> Option<String> {
    if seg.stmt != super::Stmt::Flow(flow) {
        return None;
    }
    let mut kw = block
        .seg_tokens(seg)
        .iter()
        .filter(|t| t.kind == TokenKind::Keyword)
        .map(|t| String::from_utf8_lossy(block.bytes(t.span)).to_ascii_lowercase());
    let label = kw.next()?;
    (kw.next()? == keyword).then(|| iso::oword_label(&label))
}

/// LinuxCNC: whether a parameter is local to a subroutine call.
fn linuxcnc_local(k: &Key) -> bool {
    match k {
        Key::Num(n) => (1..=30).contains(n),
        Key::Name(s) => !s.starts_with('_'),
    }
}

/// What the execution says about one expression word, over all its runs.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Known {
    /// One value in every run (at least one run, all in the main program).
    Value(f64),
    /// Several runs with different values.
    Varies(usize),
    /// Its runs are inside subprogram calls.
    InCall,
    /// Its value is not known (or the statement never ran).
    Unknown,
}

/// What a run of the macro logic says for a correction in place.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct KnownWords {
    /// Per block and word token, for blocks with expression words.
    pub words: HashMap<(u32, u32), Known>,
    /// Per block and statement: how it is reached ([`entries`]).
    pub entries: HashMap<(u32, u32), Entry>,
}

/// Per block and word token: what the trace says, for blocks with
/// expression words, and how each statement is reached. `None` when
/// execution did not reach the end (a later run of any statement could
/// not be ruled out).
/// Of a program whose first `main_blocks` blocks are its own and the
/// rest subroutine files ([`run_with`]): a call into a file
/// is passed straight through, the statement after it reached as if the
/// call were one statement (the caller follows the file's statements
/// itself).
pub(crate) fn known_words_in(trace: &Trace, main_blocks: usize) -> Option<KnownWords> {
    if trace.halt.is_some() {
        return None;
    }
    // Runs, first value, values differ, a run unknown, a run in a call.
    type Runs = (usize, Option<f64>, bool, bool, bool);
    let mut out: HashMap<(u32, u32), Runs> = HashMap::new();
    for s in &trace.steps {
        for wv in &trace.values[s.values.0 as usize..s.values.1 as usize] {
            let e = out
                .entry((s.block, wv.token))
                .or_insert((0, wv.value, false, false, false));
            e.0 += 1;
            match (e.1, wv.value) {
                (Some(a), Some(b)) => e.2 |= a != b,
                _ => e.3 = true,
            }
            e.4 |= s.depth > 0;
        }
    }
    let words = out
        .into_iter()
        .map(|(k, (n, v, differs, unknown, in_call))| {
            let known = match v {
                _ if unknown => Known::Unknown,
                Some(_) if differs => Known::Varies(n),
                Some(_) if in_call => Known::InCall,
                Some(v) => Known::Value(v),
                None => Known::Unknown,
            };
            (k, known)
        })
        .collect();
    Some(KnownWords {
        words,
        entries: entries(trace, main_blocks),
    })
}

/// How each statement that ran is reached ([`Entry`]; one that is not in
/// the map never ran): straight when each of its runs comes right after
/// the statement that runs last before it in the text, both running once
/// (the statements between, never run, change nothing), otherwise
/// jumped. Read in the order written with the statements that never run
/// passed over, a straight statement then has the state it runs with.
fn entries(trace: &Trace, main_blocks: usize) -> HashMap<(u32, u32), Entry> {
    let key = |s: &Executed| (s.block, s.seg);
    let own: Vec<Executed> = trace
        .steps
        .iter()
        .filter(|s| (s.block as usize) < main_blocks)
        .copied()
        .collect();
    let mut runs: std::collections::BTreeMap<(u32, u32), usize> = Default::default();
    for s in &own {
        *runs.entry(key(s)).or_default() += 1;
    }
    // The statement that ran next after each one, in text order.
    let order: Vec<(u32, u32)> = runs.keys().copied().collect();
    let next: HashMap<(u32, u32), (u32, u32)> = order.windows(2).map(|w| (w[0], w[1])).collect();
    let mut out: HashMap<(u32, u32), Entry> = HashMap::new();
    for (k, s) in own.iter().enumerate() {
        let here = key(s);
        let straight = runs[&here] == 1
            && (k == 0 || {
                let prev = key(&own[k - 1]);
                runs[&prev] == 1 && next.get(&prev) == Some(&here)
            });
        let e = out.entry(here).or_insert(Entry::Straight);
        if !straight {
            *e = Entry::Jumped;
        }
    }
    out
}
