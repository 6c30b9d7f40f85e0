//! The streaming rewrite: read a block, let the interpreter say what each
//! statement does, plan the correction of its move, write the block back
//! with only the changed lexemes replaced.

use std::io::{BufRead, Write};
use std::path::Path;
use std::sync::mpsc;

use indexmap::IndexMap;

use super::compensator::Compensator;
use super::correction::{CorrectedPoint, Refusal, WritePlan, size};
use super::edit::Deferred;
use super::expand;
use super::subroutines::{self, Library};
use super::writer::Writer;
use super::{
    CompensateError, CoordinateSection, Largest, Lines, Reason, ReasonKind, Summary, Vertex,
};
use crate::nc::exec;
use crate::nc::interp::approach::{Approach, Leg, Tangential, approach_aux, arc_center};
use crate::nc::interp::coordinates::known;
use crate::nc::interp::{self, Event, Frame, Interpreter, Skip};
use crate::nc::{Block, Blocks, ReadError, Syntax};
use crate::source::SourceError;

impl Compensator {
    /// Rewrites the program read from `input` into `output`; `path` names
    /// it in errors.
    ///
    /// Two threads share the work: this one reads and tokenizes the blocks
    /// (in chunks of a thousand), notes which have macro logic, and writes
    /// the rewritten text from the edits handed back (numbers formatted
    /// here); the other follows the program in order (interpretation,
    /// correction, the edits each block needs) with the whole state handed
    /// from one chunk to the next, exactly as one thread would. A few chunks are in
    /// flight at a time, whatever the program's length; on an error
    /// nothing after the failing block is written (and the caller's
    /// [`AtomicOutput`](crate::io::AtomicOutput) writes nothing at all).
    pub fn run<R: BufRead, W: Write>(
        &self,
        path: &Path,
        input: R,
        output: &mut W,
    ) -> Result<Summary, CompensateError> {
        self.run_chunked(path, input, output, Some(CHUNK))
    }

    /// As [`Compensator::run`], calling `observer` with every end point
    /// written (in one thread).
    pub fn run_observed<R: BufRead, W: Write>(
        &self,
        path: &Path,
        input: R,
        output: &mut W,
        observer: &mut dyn FnMut(&Vertex),
    ) -> Result<Summary, CompensateError> {
        self.run_one(path, input, output, Some(observer))
    }

    /// The rewrite in this thread alone.
    fn run_one<'a, R: BufRead, W: Write>(
        &'a self,
        path: &'a Path,
        input: R,
        output: &mut W,
        observer: Option<&'a mut dyn FnMut(&Vertex)>,
    ) -> Result<Summary, CompensateError> {
        let mut blocks = Blocks::new(path, input, self.syntax());
        let mut pass = Pass::new(self, path, observer);
        let mut block = Block::default();
        loop {
            match blocks.next_into(&mut block) {
                Ok(true) => pass.feed(&block, output)?,
                Ok(false) => break,
                Err(e) => return Err(read_error(e)),
            }
        }
        let mut summary = pass.finish(output)?;
        summary.no_motion = blocks
            .finish(summary.moves)
            .map_err(CompensateError::Syntax)?;
        output.flush()?;
        Ok(summary)
    }

    /// [`Compensator::run`] with `chunk` blocks handed over at a time
    /// (`None`: all in this thread), so that tests can put a chunk boundary
    /// between any two blocks.
    #[doc(hidden)]
    pub fn run_chunked<R: BufRead, W: Write>(
        &self,
        path: &Path,
        input: R,
        output: &mut W,
        chunk: Option<usize>,
    ) -> Result<Summary, CompensateError> {
        let Some(chunk) = chunk.map(|c| c.max(1)) else {
            return self.run_one(path, input, output, None);
        };
        let mut blocks = Blocks::new(path, input, self.syntax());
        let (summary, read_err, write_err) = std::thread::scope(|scope| {
            let (chunk_tx, chunk_rx) = mpsc::sync_channel::<Chunk>(2);
            let (back_tx, back_rx) = mpsc::channel::<Back>();
            type Done = Result<Option<(Summary, Vec<u8>)>, CompensateError>;
            let worker = scope.spawn(move || -> Done {
                let mut pass = Pass::new(self, path, None);
                for msg in chunk_rx {
                    match msg {
                        Chunk::Blocks(chunk, logic, mut edits) => {
                            edits.clear();
                            for (b, &l) in chunk.iter().zip(&logic) {
                                pass.feed_known(
                                    b,
                                    l,
                                    &mut Out::<std::io::Sink>::Later(&mut edits),
                                )?;
                            }
                            // The reader may be gone (it stopped): fine.
                            let _ = back_tx.send((chunk, logic, edits));
                        }
                        Chunk::End => {
                            // What the macro logic's part writes comes after
                            // every chunk's blocks: the reading thread writes
                            // it last.
                            let mut tail = Vec::new();
                            let summary = pass.finish(&mut tail)?;
                            return Ok(Some((summary, tail)));
                        }
                    }
                }
                // The reader stopped short of the end (it failed).
                Ok(None)
            });
            let mut read_err = None;
            let mut write_err: Option<std::io::Error> = None;
            // A chunk back from the worker: its blocks written with their
            // edits, in order.
            let mut scratch = Vec::new();
            let mut put = |back: &Back, err: &mut Option<std::io::Error>| {
                if err.is_some() {
                    return;
                }
                for (k, b) in back.0.iter().enumerate() {
                    if let Err(e) = back.2.write_block(k, b, output, &mut scratch) {
                        *err = Some(e);
                        return;
                    }
                }
            };
            let mut made = 0;
            loop {
                // A fixed pool of chunks: the blocks' buffers are reused and
                // memory stays the same whatever the program's length.
                let back = match back_rx.try_recv() {
                    Ok(b) => Some(b),
                    Err(_) if made < POOL => {
                        made += 1;
                        None
                    }
                    Err(_) => match back_rx.recv() {
                        Ok(b) => Some(b),
                        // The worker stopped: its error says why.
                        Err(_) => break,
                    },
                };
                let (mut list, mut logic, edits) = match back {
                    Some(b) => {
                        put(&b, &mut write_err);
                        b
                    }
                    None => (
                        Vec::with_capacity(chunk),
                        Vec::with_capacity(chunk),
                        Deferred::default(),
                    ),
                };
                let mut n = 0;
                let mut end = false;
                while n < chunk {
                    if n == list.len() {
                        list.push(Block::default());
                    }
                    match blocks.next_into(&mut list[n]) {
                        Ok(true) => n += 1,
                        Ok(false) => {
                            end = true;
                            break;
                        }
                        Err(e) => {
                            read_err = Some(read_error(e));
                            break;
                        }
                    }
                }
                list.truncate(n);
                logic.clear();
                logic.extend(list.iter().map(expand::needs_logic));
                let stop = end || read_err.is_some();
                if (n > 0 && chunk_tx.send(Chunk::Blocks(list, logic, edits)).is_err())
                    || (end && chunk_tx.send(Chunk::End).is_err())
                {
                    // The worker stopped: its error says why.
                    break;
                }
                if stop || write_err.is_some() {
                    break;
                }
            }
            drop(chunk_tx);
            // The worker's sender goes when it stops: every chunk is back.
            for back in back_rx {
                put(&back, &mut write_err);
            }
            let summary = worker
                .join()
                .unwrap_or_else(|p| std::panic::resume_unwind(p));
            let summary = summary.map(|done| {
                done.map(|(summary, tail)| {
                    if write_err.is_none()
                        && let Err(e) = output.write_all(&tail)
                    {
                        write_err = Some(e);
                    }
                    summary
                })
            });
            (summary, read_err, write_err)
        });
        if let Some(e) = write_err {
            return Err(CompensateError::Io(e));
        }
        let summary = summary?;
        let mut summary = match (summary, read_err) {
            (_, Some(e)) => return Err(e),
            (Some(s), None) => s,
            (None, None) => unreachable!("the worker ends at the end of the input or on an error"),
        };
        summary.no_motion = blocks
            .finish(summary.moves)
            .map_err(CompensateError::Syntax)?;
        output.flush()?;
        Ok(summary)
    }

    fn syntax(&self) -> Syntax {
        Syntax {
            dialect: self.settings.dialect,
            strict: self.settings.strict,
        }
    }
}

/// Blocks per chunk handed from the reading thread to the rewriting one:
/// enough that handing over costs nothing per block, few enough that the
/// chunks in flight stay small.
const CHUNK: usize = 1024;

/// Chunks in circulation: one being read, two waiting, one being rewritten.
const POOL: usize = 4;

/// A chunk handed back by the rewriting thread: its blocks, whether each
/// has macro logic, and their edits.
type Back = (Vec<Block>, Vec<bool>, Deferred);

/// Where the rewrite of a block goes.
enum Out<'o, W> {
    /// Written at once.
    Now(&'o mut W),
    /// Its edits kept for the thread that writes the blocks.
    Later(&'o mut Deferred),
}

/// What the reading thread hands over.
enum Chunk {
    /// The next blocks (sent back for reuse), and whether each has macro
    /// logic.
    Blocks(Vec<Block>, Vec<bool>, Deferred),
    /// The input ended (after the last chunk).
    End,
}

fn read_error(e: ReadError) -> CompensateError {
    match e {
        ReadError::Io(e) => CompensateError::Io(e),
        ReadError::Syntax(e) => CompensateError::Syntax(e),
    }
}

/// One pass of the rewrite over a program: the controller's state, the
/// writer's, and what has been seen so far.
struct Pass<'a> {
    c: &'a Compensator,
    path: &'a Path,
    interp: Interpreter,
    writer: Writer,
    summary: Summary,
    skipped: IndexMap<Reason, Lines>,
    unmodelled: IndexMap<String, Lines>,
    /// Motion blocks not corrected, by the reason of their first move
    /// left as written.
    uncorrected: IndexMap<String, Lines>,
    /// The last written end point had C held (the next move ramps C).
    last_held: bool,
    /// The last move was left as written: the next line may start off
    /// its intended start.
    after_left: bool,
    /// From the first block with macro logic on: the rest of the program,
    /// read and run first.
    rest: Vec<Block>,
    /// The last stretch the written program moves along (start and end,
    /// program frame): where a HEIDENHAIN rounding or chamfer after it
    /// begins.
    last_piece: Option<Stretch>,
    /// The direction (XY, unit, program frame) the written program's last
    /// element ends in: where a HEIDENHAIN `CT` after it starts.
    last_tangent: Option<[f64; 2]>,
    /// A HEIDENHAIN `APPR LT`/`LN` written (its line) whose path through the
    /// auxiliary point waits for the first contour element after it.
    approach_open: Option<usize>,
    /// The interpreter's frame after the last statement.
    frame: Option<Frame>,
    observer: Option<&'a mut dyn FnMut(&Vertex)>,
}

impl<'a> Pass<'a> {
    fn new(
        c: &'a Compensator,
        path: &'a Path,
        observer: Option<&'a mut dyn FnMut(&Vertex)>,
    ) -> Pass<'a> {
        Pass {
            c,
            path,
            interp: c.interpreter(),
            writer: Writer::new(&c.settings),
            summary: Summary {
                fast_path: c.solver.is_fast(),
                not_compensated: c.not_compensated.clone(),
                ..Default::default()
            },
            skipped: IndexMap::new(),
            unmodelled: IndexMap::new(),
            uncorrected: IndexMap::new(),
            last_held: false,
            after_left: false,
            rest: Vec::new(),
            last_piece: None,
            last_tangent: None,
            approach_open: None,
            frame: None,
            observer,
        }
    }

    /// The next block of the program: rewritten, or kept for the macro
    /// logic.
    fn feed<W: Write>(&mut self, block: &Block, output: &mut W) -> Result<(), CompensateError> {
        self.feed_known(block, expand::needs_logic(block), &mut Out::Now(output))
    }

    /// [`Self::feed`] with [`expand::needs_logic`] of the block already
    /// known (the reading thread works it out, the rewriting one is the
    /// busier).
    fn feed_known<W: Write>(
        &mut self,
        block: &Block,
        logic: bool,
        output: &mut Out<'_, W>,
    ) -> Result<(), CompensateError> {
        // Blocks stream through until the first one with macro logic; from
        // there the rest of the program is read and run first.
        if self.rest.is_empty() && !logic {
            self.process(block, None, output)
        } else {
            if let Out::Later(d) = output {
                d.hold();
            }
            self.rest.push(block.clone());
            Ok(())
        }
    }

    /// After the last block: the macro logic's part, and the summary.
    fn finish<W: Write>(mut self, output: &mut W) -> Result<Summary, CompensateError> {
        let mut macro_note = None;
        if !self.rest.is_empty() {
            let mut rest = std::mem::take(&mut self.rest);
            let syntax = self.c.syntax();
            let path = self.path;
            let lib = subroutines::load(syntax, path, &self.c.settings.subroutine_path, &mut rest)?;
            let trace = exec::run_with(syntax.dialect, &rest, lib.main).map_err(|e| {
                CompensateError::Syntax(SourceError::new(path, e.line, 1, e.message))
            })?;
            if self.c.settings.expand {
                expand::flatten(path, &lib, syntax, &rest, &trace, &mut |b| {
                    self.process(b, None, &mut Out::Now(output))
                })?;
            } else {
                let known = exec::known_words_in(&trace, lib.main).unwrap_or_default();
                let calls = file_calls(&trace, &rest, &lib);
                for (i, block) in rest[..lib.main].iter().enumerate() {
                    let (b, why) = expand::substitute(block, i as u32, syntax.dialect, &known);
                    self.process(&b, why.as_deref(), &mut Out::Now(output))?;
                    for si in 0..block.segments.len() {
                        if let Some(call) = calls.get(&(i as u32, si as u32)) {
                            self.follow(block.line, call, &rest, &trace, &lib)?;
                        }
                    }
                }
                macro_note = trace.halt.map(|h| {
                    let place = match lib.file_of(h.block) {
                        Some(f) => format!("line {} of {}", h.line, f.path.display()),
                        None => format!("line {}", h.line),
                    };
                    format!(
                        "the macro logic was followed up to {place}: {}; moves with variables are left as written",
                        h.why
                    )
                });
            }
        }
        // An approach the program ends after: no element places its
        // auxiliary point.
        if let Some(at) = self.approach_open.take() {
            self.skipped
                .entry(approach_unchecked())
                .or_default()
                .push(at);
        }
        let mut summary = self.summary;
        summary.inserted = self.writer.inserted;
        summary.skipped = self.skipped.into_iter().collect();
        summary.unmodelled = self.unmodelled.into_iter().collect();
        summary.uncorrected_blocks = self.uncorrected.into_iter().collect();
        summary.macro_logic = macro_note;
        Ok(summary)
    }

    /// After the program's `o<name> call` at `line` into a subroutine
    /// file: the file's statements as the call ran them, followed by the
    /// interpreter (the caller's later moves start where they leave the
    /// tool, with the modal state they leave) but not written, since they
    /// are another file's; its moves are reported at the call.
    fn follow(
        &mut self,
        line: usize,
        call: &FileCall,
        blocks: &[Block],
        trace: &exec::Trace,
        lib: &Library,
    ) -> Result<(), CompensateError> {
        let file = lib
            .file_of(trace.steps[call.body.start].block as usize)
            .expect("a file call's body is in a file");
        let shown = file.path.display().to_string();
        let label = &file.label;
        if !call.once {
            // The call runs several times (a loop, or a subroutine of the
            // program's): the interpreter forgot the positions at it.
            // Another file's moves: rewriting them in place is not
            // implemented (--expand writes them into this one).
            let reason = Reason::new(
                ReasonKind::NotImplemented,
                format!(
                    "moves in the subroutine file {shown} ({label} call, run more than once here): that file's moves, not rewritten in this one (--expand writes them, corrected, into it)"
                ),
            );
            self.skipped.entry(reason.clone()).or_default().push(line);
            self.summary.motion_blocks += 1;
            self.uncorrected.entry(reason.text).or_default().push(line);
            return Ok(());
        }
        let before = self.interp.clone();
        let run = expand::Steps {
            steps: &trace.steps[call.body.clone()],
            values: &trace.values,
            main: lib.main,
            own_lines: true,
            as_written: &[],
        };
        let syntax = self.c.syntax();
        let strict = self.c.settings.strict;
        let mut moves = 0usize;
        let mut restores = false;
        let interp = &mut self.interp;
        let unmodelled = &mut self.unmodelled;
        expand::write_steps(&file.path, syntax, blocks, &run, false, &mut |b: &Block| {
            for seg in &b.segments {
                restores |= b.words(seg).any(|(_, w)| {
                    w.addr == crate::nc::Addr::letter(b'M')
                        && matches!(w.value, crate::nc::Value::Num(m) if m == 72.0 || m == 73.0)
                });
                let ev = interp.step(b, seg);
                let mut notes = IndexMap::new();
                super::take_unmodelled(interp, b, &file.path, strict, &mut notes)
                    .map_err(CompensateError::Unmodelled)?;
                for (what, _) in notes {
                    unmodelled
                        .entry(format!("{what} (in {shown})"))
                        .or_default()
                        .push(line);
                }
                if matches!(ev, Event::Move(_) | Event::Skip(_) | Event::Quiet)
                    && !matches!(ev, Event::Skip(Skip::NeverRuns))
                {
                    moves += 1;
                }
            }
            Ok::<(), CompensateError>(())
        })?;
        let mut after = String::new();
        if restores {
            // M73 (or M72) gives back the modal state the call found; what
            // LinuxCNC keeps of the rest is not followed: positions forgotten.
            *interp = before;
            interp.forget();
            after.push_str(
                "it restores the modal state on return (M72/M73): positions after the call are not known",
            );
        } else {
            let known: Vec<String> = interp::AXES
                .iter()
                .zip(&interp.pos)
                .filter(|(_, p)| p.is_some())
                .map(|(a, _)| (*a as char).to_string())
                .collect();
            after = if known.is_empty() {
                "no position is known after it".to_string()
            } else {
                format!(
                    "after it the program knows {} where the file leaves {}",
                    known.join(" "),
                    if known.len() == 1 { "it" } else { "them" }
                )
            };
        }
        // What the control is written to start from next: where the
        // file's moves, as written, leave the tool.
        self.writer.emit = self.interp.pos;
        self.after_left = true;
        self.last_held = false;
        self.last_piece = None;
        self.last_tangent = None;
        self.frame = None;
        if let Some(at) = self.approach_open.take() {
            self.skipped
                .entry(approach_unchecked())
                .or_default()
                .push(at);
        }
        let reason = format!(
            "moves in the subroutine file {shown} ({label} call): that file's moves, not rewritten in this one (--expand writes them, corrected, into it); {after}"
        );
        if moves > 0 {
            self.summary.moves += moves;
            self.skipped
                .entry(Reason::new(ReasonKind::NotImplemented, reason.clone()))
                .or_default()
                .push(line);
            self.summary.motion_blocks += 1;
            self.uncorrected.entry(reason).or_default().push(line);
        } else {
            self.unmodelled.entry(reason).or_default().push(line);
        }
        Ok(())
    }

    fn process<W: Write>(
        &mut self,
        block: &Block,
        why: Option<&str>,
        output: &mut Out<'_, W>,
    ) -> Result<(), CompensateError> {
        let c = self.c;
        let path = self.path;
        let line = block.line;
        let interp = &mut self.interp;
        let writer = &mut self.writer;
        let summary = &mut self.summary;
        let skipped = &mut self.skipped;
        let last_held = &mut self.last_held;
        let observer = &mut self.observer;
        writer.begin(block);
        summary.blocks += 1;
        // Whether the block moves an axis, and why it was not corrected
        // (the first move left as written).
        let mut moved = false;
        let mut left: Option<String> = None;
        // The first reason a block's move is left as written, for its count.
        let leave = |left: &mut Option<String>, r: &Reason| {
            left.get_or_insert_with(|| r.text.clone());
        };
        for si in 0..block.segments.len() {
            let seg = block.segments[si];
            let before = interp.pos;
            // The frame after the statement before (nothing else moves the
            // interpreter between statements): one frame per statement.
            let frame_before = self.frame.take().unwrap_or_else(|| interp.frame());
            let event = interp.step(block, &seg);
            let f = interp.frame();
            super::take_unmodelled(interp, block, path, c.settings.strict, &mut self.unmodelled)
                .map_err(CompensateError::Unmodelled)?;
            if matches!(event, Event::Move(_) | Event::Skip(_))
                && !matches!(event, Event::Skip(Skip::Unreadable | Skip::NeverRuns))
            {
                section(&mut summary.coordinates, interp, &f, line);
            }
            let mut motion_done = false;
            match &event {
                Event::Move(mv) => {
                    summary.moves += 1;
                    moved |= moves_an_axis(mv);
                    if let Some(at) = self.approach_open.take()
                        && mv.approach.is_none()
                    {
                        skipped.entry(approach_unchecked()).or_default().push(at);
                    }
                    if let Some(Tangential::Departure { len, leg }) = mv.appr_dep {
                        let from = writer.emit;
                        match c.plan_departure(&f, mv, &from, self.last_tangent, len, leg) {
                            Ok(end) => {
                                self.after_left = false;
                                // Nothing to write: the control's line from
                                // the corrected contour is the intended one.
                                for a in f.axes() {
                                    writer.emit[a] = Some(end[a]);
                                }
                            }
                            Err(reason) => {
                                self.after_left = true;
                                leave(&mut left, &reason);
                                skipped.entry(reason).or_default().push(line);
                                writer.keep(block, &seg, interp, &before);
                                self.last_tangent = None;
                            }
                        }
                        *last_held = false;
                        self.last_piece = Some((from, writer.emit));
                        writer.after_statement(block, &seg, interp, false);
                        self.frame = Some(f);
                        continue;
                    }
                    let appr = matches!(mv.appr_dep, Some(Tangential::Approach { .. }));
                    let planned = match mv.tangential {
                        _ if along_tool_axis_under_radius_comp(interp, mv) => {
                            // Not implemented: a correction there would
                            // need the control's offset path around it.
                            Err(Refusal::Skip(Reason::new(
                                ReasonKind::NotImplemented,
                                RADIUS_COMP_TOOL_AXIS,
                            )))
                        }
                        _ if appr => c.plan_approach(&f, mv, &writer.emit, *last_held, line),
                        Some(_) => c.plan_tangential(
                            &f,
                            mv,
                            &writer.emit,
                            self.last_tangent,
                            *last_held,
                            line,
                        ),
                        None => c.plan(&f, mv, &writer.emit, *last_held, line),
                    };
                    match planned {
                        Ok(plan) => {
                            // Checked only after a move left as written: a
                            // forward transform per block otherwise.
                            let off_start = std::mem::take(&mut self.after_left)
                                && !appr
                                && mv.tangential.is_none()
                                && matches!(mv.kind, interp::MoveKind::Linear)
                                && f.axes()
                                    .iter()
                                    .all(|&a| mv.start[a].is_some() && writer.emit[a].is_some())
                                && !c.starts_on(&f, &known(&mv.start), &known(&writer.emit));
                            if off_start {
                                // A path back from where the move before
                                // leaves the tool is not implemented.
                                let why = Reason::new(
                                    ReasonKind::NotImplemented,
                                    super::correction::OFF_START_LINE,
                                );
                                leave(&mut left, &why);
                                skipped.entry(why).or_default().push(line);
                            }
                            for pt in plan_points(&plan) {
                                record(summary, pt, line);
                            }
                            match &plan {
                                WritePlan::Pieces {
                                    linearize: true, ..
                                } => summary.linearized.push(line),
                                WritePlan::Pieces { .. } => summary.subdivided.push(line),
                                _ => {}
                            }
                            let tool_axis = mv.vector.and_then(|_| match &plan {
                                WritePlan::End(pt) => Some(c.solver.nominal_pose(&pt.written).axis),
                                _ => None,
                            });
                            let vector = mv.vector.is_some();
                            let mut piece_from = writer.emit;
                            let mut first_piece = None;
                            let mut last_piece = None;
                            let mut sink =
                                |pt: &CorrectedPoint, emitted: &[Option<f64>; 6], ins| {
                                    first_piece.get_or_insert((piece_from, *emitted));
                                    last_piece = Some((piece_from, *emitted));
                                    piece_from = *emitted;
                                    *last_held = pt.held.is_some();
                                    if let Some(o) = observer.as_mut() {
                                        let mut shown = *emitted;
                                        if vector {
                                            // No rotary word is written: the
                                            // control turns the written vector
                                            // into the rotary positions solved.
                                            let p = f.program(&pt.written);
                                            for a in 3..6 {
                                                if p[a].is_finite() {
                                                    shown[a] = Some(p[a]);
                                                }
                                            }
                                        }
                                        o(&vertex(line, &f, pt, &shown, ins));
                                    }
                                };
                            motion_done = writer
                                .write(block, &seg, mv, &f, interp, &plan, tool_axis, &mut sink);
                            if let Some(corner) = &mv.corner
                                && let Some(why) =
                                    check_corner(c, &f, corner, mv, self.last_piece, first_piece)
                            {
                                // The path around the corner misses: the
                                // line that carries it is not corrected.
                                leave(&mut left, &why);
                                skipped.entry(why).or_default().push(corner.line);
                            }
                            if let Some(a) = &mv.approach
                                && let Some(why) = check_approach(
                                    c,
                                    &f,
                                    a,
                                    mv,
                                    &plan,
                                    self.last_piece,
                                    first_piece,
                                )
                            {
                                skipped.entry(why).or_default().push(a.line);
                            }
                            if appr {
                                self.approach_open = Some(line);
                            }
                            self.last_tangent = written_direction(
                                &plan,
                                mv,
                                self.last_tangent,
                                first_piece.as_ref(),
                                last_piece.as_ref(),
                            );
                            self.last_piece = last_piece;
                        }
                        Err(Refusal::Skip(reason)) => {
                            self.after_left = true;
                            if moves_an_axis(mv) {
                                leave(&mut left, &reason);
                            }
                            skipped.entry(reason).or_default().push(line);
                            let from = writer.emit;
                            writer.keep(block, &seg, interp, &before);
                            *last_held = false;
                            if let Some(a) = &mv.approach {
                                skipped
                                    .entry(approach_unchecked())
                                    .or_default()
                                    .push(a.line);
                            }
                            if let Some(corner) = &mv.corner {
                                let why = "the line after it is left as written";
                                skipped
                                    .entry(Skip::AfterCorner(corner.line, why).into())
                                    .or_default()
                                    .push(corner.line);
                            }
                            self.last_piece = Some((from, writer.emit));
                            self.last_tangent = None;
                        }
                        Err(Refusal::Fatal(e)) => return Err(e.in_file(path)),
                    }
                }
                Event::Skip(Skip::Unreadable) => {
                    // Kept byte for byte; what the controller does
                    // after it is unknown (the interpreter forgot it).
                    let why = block.unreadable.as_ref().map_or_else(String::new, |e| {
                        let (_, column) = block.locate(e.offset);
                        format!(" (column {column}: {})", e.message)
                    });
                    summary.unreadable.push(line);
                    skipped
                        .entry(Reason::new(
                            Skip::Unreadable.kind(),
                            format!("{}{why}", Skip::Unreadable),
                        ))
                        .or_default()
                        .push(line);
                    writer.keep(block, &seg, interp, &before);
                    writer.emit = [None; 6];
                    self.last_tangent = None;
                    *last_held = false;
                }
                Event::Skip(Skip::NeverRuns) => {
                    // Kept as written and counted, but the controller
                    // never passes through it: what it knows is as before.
                    summary.moves += 1;
                    moved = true;
                    let reason = Reason::from(Skip::NeverRuns);
                    leave(&mut left, &reason);
                    skipped.entry(reason).or_default().push(line);
                }
                Event::Skip(s) => {
                    self.after_left = true;
                    if let Some(at) = self.approach_open.take() {
                        skipped.entry(approach_unchecked()).or_default().push(at);
                    }
                    self.last_piece = None;
                    self.last_tangent = None;
                    summary.moves += 1;
                    let reason = match (s, why) {
                        // Values that vary from run to run, or inside a
                        // call: written in place is not implemented
                        // (--expand writes each run).
                        (Skip::Expression, Some(w)) => Reason::new(ReasonKind::NotImplemented, w),
                        _ => Reason::from(*s),
                    };
                    moved = true;
                    leave(&mut left, &reason);
                    skipped.entry(reason).or_default().push(line);
                    writer.keep(block, &seg, interp, &before);
                    *last_held = false;
                }
                Event::Quiet => {
                    self.after_left = true;
                    if let Some(at) = self.approach_open.take() {
                        skipped.entry(approach_unchecked()).or_default().push(at);
                    }
                    self.last_tangent = None;
                    moved = true;
                    left.get_or_insert_with(|| super::LEFT_ON_PURPOSE.to_string());
                    writer.follow(block, &seg, interp, &before, true);
                    *last_held = false;
                }
                Event::None => {
                    if let Some(words) = interp.setting_words {
                        writer.move_setting(block, &words, interp, &before);
                    }
                    writer.reframe(block, &seg, interp, &f, (&before, &frame_before))
                }
            }
            writer.after_statement(block, &seg, interp, motion_done);
            self.frame = Some(f);
        }
        if writer.end(block) {
            summary.changed += 1;
        }
        if moved {
            summary.motion_blocks += 1;
            match left {
                Some(reason) => self.uncorrected.entry(reason).or_default().push(line),
                None => summary.corrected_blocks += 1,
            }
        }
        match output {
            Out::Now(w) => writer.edits.write_block(block, *w)?,
            Out::Later(d) => d.take(&mut writer.edits),
        }
        Ok(())
    }
}

/// A call of the program into a subroutine file: the statements of the
/// file's run (up to its return), and whether the call runs once (else
/// the caller does not follow it).
struct FileCall {
    body: std::ops::Range<usize>,
    once: bool,
}

/// The program's calls into subroutine files of `lib`, by statement
/// (block, statement index), as `trace` ran them: the first run of each.
fn file_calls(
    trace: &exec::Trace,
    blocks: &[Block],
    lib: &Library,
) -> std::collections::HashMap<(u32, u32), FileCall> {
    let mut out: std::collections::HashMap<(u32, u32), FileCall> = Default::default();
    if trace.halt.is_some() || lib.files.is_empty() {
        return out;
    }
    let steps = &trace.steps;
    for (k, s) in steps.iter().enumerate() {
        let own = (s.block as usize) < lib.main;
        let into_file = steps
            .get(k + 1)
            .is_some_and(|n| (n.block as usize) >= lib.main);
        if !own
            || !into_file
            || exec::call_label(
                &blocks[s.block as usize],
                &blocks[s.block as usize].segments[s.seg as usize],
            )
            .is_none()
        {
            continue;
        }
        // The return is the first statement after it back at the
        // caller's depth (recorded after each statement ran).
        let end = steps[k + 1..]
            .iter()
            .position(|n| n.depth < s.depth)
            .map_or(steps.len(), |p| k + 1 + p + 1);
        out.entry((s.block, s.seg))
            .and_modify(|c| c.once = false)
            .or_insert(FileCall {
                body: k + 1..end,
                once: true,
            });
    }
    out
}

/// A stretch the written program moves along: start and end, program
/// frame, where known.
type Stretch = ([Option<f64>; 6], [Option<f64>; 6]);

/// Whether the controller's rounding or chamfer `corner` between the
/// written line before it (`before`: its last piece) and the written
/// line after it (`after`: its first piece, ending `mv`) stays on the
/// intended one within the tolerance; the reason to report it otherwise.
fn check_corner(
    c: &Compensator,
    f: &Frame,
    corner: &interp::corner::Corner,
    mv: &interp::Move,
    before: Option<Stretch>,
    after: Option<Stretch>,
) -> Option<Reason> {
    let fill = |p: &[Option<f64>; 6]| -> Option<[f64; 6]> {
        let mut out = [0.0; 6];
        for i in f.axes() {
            out[i] = p[i]?;
        }
        Some(out)
    };
    let mut end = fill(&mv.end)?;
    // The axis the machine does not have, as the interpreter has it.
    for (i, e) in end.iter_mut().enumerate() {
        if !f.axes().contains(&i) {
            *e = corner.at[i];
        }
    }
    let written = match (before, after) {
        (Some((a, p)), Some((p2, b))) if p == p2 => fill(&a).zip(fill(&p)).zip(fill(&b)),
        _ => None,
    };
    let Some(((a, p), b)) = written else {
        return Some(
            Skip::AfterCorner(corner.line, "the written lines around it are not known").into(),
        );
    };
    // The lines around the corner are checked as written (rounded): the
    // whole tolerance holds for them.
    let tol = c.settings.tolerance;
    match c.corner_deviation(f, corner, &end, [&a, &p, &b]) {
        Ok(d) if d <= tol => None,
        // Following the element the controller builds from the corrected
        // lines (moving them so that it lands) is not implemented.
        Ok(d) => Some(Reason::new(
            ReasonKind::NotImplemented,
            format!(
                "rounding or chamfer: the controller's element between the corrected lines leaves the intended one by up to {:.2} um, more than --tolerance {} um",
                d * 1e3,
                tol * 1e3
            ),
        )),
        Err(why) => Some(Reason::new(
            ReasonKind::NotImplemented,
            format!(
                "rounding or chamfer: the controller cannot cut it between the corrected lines ({why})"
            ),
        )),
    }
}

/// Why an `APPR LT`/`LN` written with its end point corrected is reported:
/// the statement after it, which fixes its auxiliary point, is not a
/// contour element fivecal corrects.
fn approach_unchecked() -> Reason {
    Reason::new(
        ReasonKind::NotImplemented,
        "approach (APPR LT, LN, CT): its end point is corrected, but its path through the auxiliary point is not checked: the first contour element after it is left as written or not a line or circle in the XY plane",
    )
}

/// Whether the control's `APPR LT`/`LN` path, built from the written blocks
/// (`before`: the approach as written; `first`: the first piece of the
/// element after it, planned as `plan`), stays within the tolerance of
/// the intended one; the reason to report it otherwise.
fn check_approach(
    c: &Compensator,
    f: &Frame,
    a: &Approach,
    mv: &interp::Move,
    plan: &WritePlan,
    before: Option<Stretch>,
    first: Option<Stretch>,
) -> Option<Reason> {
    use interp::tangent::{arc_end_direction, direction};
    let want = match a.path {
        Ok(p) => p,
        Err(why) => {
            return Some(Reason::new(
                crate::nc::interp::kind_of(why),
                format!(
                    "approach (APPR {}): its end point is corrected, but its path through the auxiliary point is not checked: {why}",
                    a.leg.name()
                ),
            ));
        }
    };
    let xy = |p: &[Option<f64>; 6]| Some([p[0]?, p[1]?]);
    let written = (|| {
        let ((ps, pa), (s, e)) = (before?, first?);
        if pa != s || f.axes().iter().any(|&i| ps[i].is_none() || pa[i].is_none()) {
            return None;
        }
        let d = match (plan, mv.kind) {
            (WritePlan::Arc { center, .. }, interp::MoveKind::Arc(arc)) => {
                arc_end_direction(*center, xy(&s)?, arc.cw)?
            }
            (WritePlan::Arc { .. }, _) | (WritePlan::End(_), interp::MoveKind::Arc(_)) => {
                return None;
            }
            _ => direction(xy(&s)?, xy(&e)?)?,
        };
        let (ps, pa) = (known(&ps), known(&pa));
        let arc = arc_center([pa[0], pa[1]], d, a.leg);
        Some(([ps, approach_aux(&pa, d, a.len, a.leg), pa], arc))
    })();
    let Some((written, written_arc)) = written else {
        return Some(Reason::new(
            ReasonKind::NotImplemented,
            format!(
                "approach (APPR {}): its end point is corrected, but its path through the auxiliary point is not checked: the written blocks around it are not known",
                a.leg.name()
            ),
        ));
    };
    // The micrometres of tool axis an approach taken as flat moves (a
    // correction's tilt), which the control moves by the auxiliary point:
    // with the line to it (TNC7) or after it (TNC 640), paths that differ
    // by at most that much from the straight one followed here.
    let tool_axis = ((written[2][2] - written[0][2]).abs() + (want[2][2] - want[0][2]).abs()) * f.u;
    // The blocks are checked as written (rounded): the whole tolerance
    // holds for them.
    let tol = c.settings.tolerance;
    // A CT's arc leg: the intended centre and the one the control
    // places from the written blocks.
    let arc = match (a.leg, a.arc, written_arc) {
        (Leg::Arc { cw, .. }, Some(i), Some(w)) => Some((cw, i, w)),
        _ => None,
    };
    let d = c.approach_deviation(f, &want, &written, arc) + tool_axis;
    (d > tol).then(|| {
        Reason::new(
            ReasonKind::NotImplemented,
            format!(
                "approach (APPR {}): the control's path through its auxiliary point from the corrected blocks leaves the intended one by up to {:.2} um, more than --tolerance {} um",
                a.leg.name(),
                d * 1e3,
                tol * 1e3
            ),
        )
    })
}

/// The direction (XY, unit) the written move ends in, as the control
/// has it from the written text: a line's (the last piece's), an arc's
/// around its written centre, a `CT` kept as written from the direction
/// `before` the written element before it ends in.
fn written_direction(
    plan: &WritePlan,
    mv: &interp::Move,
    before: Option<[f64; 2]>,
    first: Option<&Stretch>,
    last: Option<&Stretch>,
) -> Option<[f64; 2]> {
    use interp::tangent::{arc_end_direction, direction, tangent_arc};
    let xy = |p: &[Option<f64>; 6]| Some([p[0]?, p[1]?]);
    let (from, to) = last?;
    let end = xy(to)?;
    match (plan, mv.kind) {
        (WritePlan::Arc { center, .. }, interp::MoveKind::Arc(arc))
            if arc.plane == interp::ArcPlane::Xy =>
        {
            arc_end_direction(*center, end, arc.cw)
        }
        (WritePlan::Arc { .. }, _) => None,
        (WritePlan::End(_), interp::MoveKind::Arc(_)) if mv.tangential.is_some() => {
            let (c, cw) = tangent_arc(xy(&first?.0)?, before?, end, 1.0).ok()?;
            arc_end_direction(c, end, cw)
        }
        (WritePlan::End(_), interp::MoveKind::Arc(_)) => None,
        _ => direction(xy(from)?, end),
    }
}

/// Whether a move moves an axis: an axis ends elsewhere than it started
/// or where it was not known, or it is an arc (a full circle ends where
/// it starts).
fn moves_an_axis(mv: &interp::Move) -> bool {
    matches!(mv.kind, interp::MoveKind::Arc(_))
        || mv
            .start
            .iter()
            .zip(&mv.end)
            .any(|(s, e)| e.is_some() && s != e)
}

/// Extends the last section of `sections` to the move at `line` (`f`: the
/// frame after it), or starts one where the coordinates change meaning.
fn section(sections: &mut Vec<CoordinateSection>, interp: &Interpreter, f: &Frame, line: usize) {
    let meaning = f.meaning();
    match sections.last_mut() {
        Some(s) if s.meaning == meaning => s.lines.1 = line,
        _ => sections.push(CoordinateSection {
            lines: (line, line),
            meaning,
            why: interp.coordinates_why(),
        }),
    }
}

/// Every point a plan writes.
fn plan_points(plan: &WritePlan) -> impl Iterator<Item = &CorrectedPoint> {
    let (one, many) = match plan {
        WritePlan::End(pt) | WritePlan::Arc { end: pt, .. } => (Some(pt), &[][..]),
        WritePlan::Pieces { pieces, .. } => (None, pieces.as_slice()),
    };
    one.into_iter().chain(many.iter().map(|(_, p)| p))
}

/// Adds a corrected point to the summary: the largest corrections and the
/// lines where an axis was held.
fn record(summary: &mut Summary, pt: &CorrectedPoint, line: usize) {
    let (lin_um, rot_urad) = size(pt);
    if summary.largest_linear.is_none_or(|l| lin_um > l.value) {
        summary.largest_linear = Some(Largest {
            value: lin_um,
            line,
        });
    }
    if summary.largest_rotary.is_none_or(|l| rot_urad > l.value) {
        summary.largest_rotary = Some(Largest {
            value: rot_urad,
            line,
        });
    }
    if let Some(h) = pt.held {
        summary.held_c.push(line);
        summary.held_c_axis_error = summary.held_c_axis_error.max(h * 1e6);
    }
    if let Some(h) = pt.plane_axis {
        summary.tilted_plane.push(line);
        summary.tilted_plane_axis_error = summary.tilted_plane_axis_error.max(h * 1e6);
    }
    if let Some((angle, residual)) = pt.drill {
        summary.drilled.push(line);
        summary.drilled_axis_error = summary.drilled_axis_error.max(angle * 1e6);
        summary.drilled_residual = summary.drilled_residual.max(residual * 1e3);
    }
    if let Some(h) = pt.held_tilt {
        summary.held_tilt.push(line);
        summary.held_tilt_axis_error = summary.held_tilt_axis_error.max(h * 1e6);
    }
}

/// A written point as callers that check a rewrite see it.
fn vertex(
    line: usize,
    f: &Frame,
    pt: &CorrectedPoint,
    written: &[Option<f64>; 6],
    inserted: bool,
) -> Vertex {
    let program = known(written);
    Vertex {
        line,
        nominal: pt.nominal,
        written: f.model(&program),
        target: pt.target,
        tcp: f.tcp,
        held_c: pt.held.is_some(),
        tilted_plane: pt.plane_axis.is_some(),
        inserted,
        nominal_program: f.program(&pt.nominal),
        program,
    }
}

/// Why a move along the tool axis under cutter radius compensation is
/// left as written.
const RADIUS_COMP_TOOL_AXIS: &str = "a move along the tool axis under cutter radius compensation (G41/G42, RL/RR): a correction across it would be a contour segment of a few micrometres the control offsets by the tool radius (LinuxCNC stops at it with a gouging error)";

/// Whether `mv` moves along the tool axis only (no word of the working
/// plane's axes) while cutter radius compensation is on: the control
/// offsets every segment of the plane sideways by the tool radius, so a
/// correction that adds a few micrometres across the tool axis makes a
/// contour segment of its own, one the control cannot offset without
/// gouging when it turns back (a concave corner).
fn along_tool_axis_under_radius_comp(interp: &Interpreter, mv: &interp::Move) -> bool {
    interp.radius_comp.is_some()
        && interp.plane == interp::ArcPlane::Xy
        && matches!(mv.kind, interp::MoveKind::Rapid | interp::MoveKind::Linear)
        && mv.words[0].is_none()
        && mv.words[1].is_none()
        && mv.words[2].is_some()
}
