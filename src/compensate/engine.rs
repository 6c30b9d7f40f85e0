//! The streaming rewrite: read a block, let the interpreter say what each
//! statement does, plan the correction of its move, write the block back
//! with only the changed lexemes replaced.

use std::io::{BufRead, Write};
use std::path::Path;

use indexmap::IndexMap;

use super::correction::{Plan, Point, Refusal, size};
use super::expand;
use super::solver::Solver;
use super::writer::Writer;
use super::{CompensateError, CoordinateSection, Largest, Lines, Settings, Summary, Vertex};
use crate::model::{Effect, Model};
use crate::nc::exec;
use crate::nc::interp::coordinates::known;
use crate::nc::interp::{self, Event, Frame, Interpreter, Skip};
use crate::nc::{Block, Blocks, ReadError, Syntax};
use crate::source::SourceError;

/// A program rewriter for one machine and one set of errors.
#[derive(Clone, Debug)]
pub struct Compensator {
    pub(super) settings: Settings,
    pub(super) solver: Solver,
    not_compensated: Vec<String>,
}

impl Compensator {
    /// A rewriter for `model` with parameters `theta` (file units).
    pub fn new(model: &Model, theta: &[f64], settings: Settings) -> Compensator {
        let solver = Solver::new(model, theta, settings.max_c_swing);
        let mut not_compensated = Vec::new();
        for e in &model.effects {
            let id = e.id(&model.symbols);
            match e {
                Effect::Drift { .. } => not_compensated.push(format!(
                    "{id}: a thermal drift depends on when each block runs; compensated at its start value"
                )),
                Effect::ToolRadius => not_compensated.push(format!(
                    "{id}: a tool radius error does not move the tool pose; correct it in the tool table"
                )),
                Effect::ProbePretravel => {
                    not_compensated.push(format!("{id}: applies to probing only"))
                }
                _ => {}
            }
        }
        Compensator {
            settings,
            solver,
            not_compensated,
        }
    }

    /// The settings.
    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    /// The solver.
    pub fn solver(&self) -> &Solver {
        &self.solver
    }

    /// The interpreter for this machine and these settings, at power-on.
    pub fn interpreter(&self) -> Interpreter {
        let s = &self.settings;
        let settings = interp::Settings {
            dialect: s.dialect,
            coordinates: s.coordinates,
            origin: s.origin,
            integer_unit: s.fanuc_integer_unit,
        };
        Interpreter::new(&settings, self.solver.kinematics())
    }

    /// Rewrites the program read from `input` into `output`; `path` names
    /// it in errors.
    pub fn run<R: BufRead, W: Write>(
        &self,
        path: &Path,
        input: R,
        output: &mut W,
    ) -> Result<Summary, CompensateError> {
        self.run_inner(path, input, output, None)
    }

    /// As [`Compensator::run`], calling `observer` with every end point written.
    pub fn run_observed<R: BufRead, W: Write>(
        &self,
        path: &Path,
        input: R,
        output: &mut W,
        observer: &mut dyn FnMut(&Vertex),
    ) -> Result<Summary, CompensateError> {
        self.run_inner(path, input, output, Some(observer))
    }

    fn run_inner<R: BufRead, W: Write>(
        &self,
        path: &Path,
        input: R,
        output: &mut W,
        mut observer: Option<&mut dyn FnMut(&Vertex)>,
    ) -> Result<Summary, CompensateError> {
        let mut interp = self.interpreter();
        let mut writer = Writer::new(&self.settings);
        let mut summary = Summary {
            fast_path: self.solver.is_fast(),
            not_compensated: self.not_compensated.clone(),
            ..Default::default()
        };
        let mut skipped: IndexMap<String, Lines> = IndexMap::new();
        let mut unmodelled: IndexMap<String, Lines> = IndexMap::new();
        // The last written end point had C held (the next move ramps C).
        let mut last_held = false;
        let syntax = Syntax {
            dialect: self.settings.dialect,
            strict: self.settings.strict,
        };
        let mut macro_note = None;
        let mut process = |block: &Block, why: Option<&str>| -> Result<(), CompensateError> {
            let line = block.line;
            writer.begin(block);
            summary.blocks += 1;
            for si in 0..block.segments.len() {
                let seg = block.segments[si];
                let before = interp.pos;
                let event = interp.step(block, &seg);
                super::take_unmodelled(
                    &mut interp,
                    block,
                    path,
                    self.settings.strict,
                    &mut unmodelled,
                )
                .map_err(CompensateError::Unmodelled)?;
                if matches!(event, Event::Move(_) | Event::Skip(_))
                    && !matches!(event, Event::Skip(Skip::Unreadable))
                {
                    section(&mut summary.coordinates, &interp, line);
                }
                let mut motion_done = false;
                match event {
                    Event::Move(mv) => {
                        summary.moves += 1;
                        let f = interp.frame();
                        match self.plan(&f, &mv, &writer.emit, last_held, line) {
                            Ok(plan) => {
                                for pt in plan_points(&plan) {
                                    record(&mut summary, pt, line);
                                }
                                match &plan {
                                    Plan::Pieces {
                                        linearize: true, ..
                                    } => summary.linearized.push(line),
                                    Plan::Pieces { .. } => summary.subdivided.push(line),
                                    _ => {}
                                }
                                let tool_axis = mv.vector.and_then(|_| match &plan {
                                    Plan::End(pt) => {
                                        Some(self.solver.nominal_pose(&pt.written).axis)
                                    }
                                    _ => None,
                                });
                                let vector = mv.vector.is_some();
                                let mut sink = |pt: &Point, emitted: &[Option<f64>; 6], ins| {
                                    last_held = pt.held.is_some();
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
                                motion_done = writer.write(
                                    block, &seg, &mv, &f, &interp, &plan, tool_axis, &mut sink,
                                );
                            }
                            Err(Refusal::Skip(reason)) => {
                                skipped.entry(reason).or_default().push(line);
                                writer.keep(block, &seg, &interp, &before);
                                last_held = false;
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
                            .entry(format!("{}{why}", Skip::Unreadable))
                            .or_default()
                            .push(line);
                        writer.keep(block, &seg, &interp, &before);
                        writer.emit = [None; 6];
                        last_held = false;
                    }
                    Event::Skip(s) => {
                        summary.moves += 1;
                        let reason = match (s, why) {
                            (Skip::Expression, Some(w)) => w.to_string(),
                            _ => s.to_string(),
                        };
                        skipped.entry(reason).or_default().push(line);
                        writer.keep(block, &seg, &interp, &before);
                        last_held = false;
                    }
                    Event::Quiet => {
                        writer.follow(block, &seg, &interp, &before, true);
                        last_held = false;
                    }
                    Event::None => writer.follow(block, &seg, &interp, &before, false),
                }
                writer.after_statement(block, &seg, &interp, motion_done);
            }
            if writer.end(block) {
                summary.changed += 1;
            }
            writer.edits.write_block(block, output)?;
            Ok(())
        };
        let mut blocks = Blocks::new(path, input, syntax);
        // Blocks stream through until the first one with macro logic; from
        // there the rest of the program is read and run first.
        let mut rest: Vec<Block> = Vec::new();
        loop {
            let block = match blocks.next_block() {
                Ok(Some(b)) => b,
                Ok(None) => break,
                Err(ReadError::Io(e)) => return Err(CompensateError::Io(e)),
                Err(ReadError::Syntax(e)) => return Err(CompensateError::Syntax(e)),
            };
            if rest.is_empty() && !expand::needs_logic(block) {
                process(block, None)?;
            } else {
                rest.push(block.clone());
            }
        }
        if !rest.is_empty() {
            let trace = exec::run(syntax.dialect, &rest).map_err(|e| {
                CompensateError::Syntax(SourceError::new(path, e.line, 1, e.message))
            })?;
            if self.settings.expand {
                expand::flatten(path, syntax, &rest, &trace, &mut |b| process(b, None))?;
            } else {
                let known = exec::known_words(&trace).unwrap_or_default();
                for (i, block) in rest.iter().enumerate() {
                    let (b, why) = expand::substitute(block, i as u32, syntax.dialect, &known);
                    process(&b, why.as_deref())?;
                }
                macro_note = trace.halt.map(|h| {
                    format!(
                        "the macro logic was followed up to line {}: {}; moves with variables are left as written",
                        h.line, h.why
                    )
                });
            }
        }
        blocks
            .finish(summary.moves)
            .map_err(CompensateError::Syntax)?;
        output.flush()?;
        summary.inserted = writer.inserted;
        summary.skipped = skipped.into_iter().collect();
        summary.unmodelled = unmodelled.into_iter().collect();
        summary.macro_logic = macro_note;
        Ok(summary)
    }
}

/// Extends the last section of `sections` to the move at `line`, or
/// starts one where the coordinates change meaning.
fn section(sections: &mut Vec<CoordinateSection>, interp: &Interpreter, line: usize) {
    let meaning = interp.coordinates_meaning();
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
fn plan_points(plan: &Plan) -> impl Iterator<Item = &Point> {
    let (one, many) = match plan {
        Plan::End(pt) | Plan::Arc { end: pt, .. } => (Some(pt), &[][..]),
        Plan::Pieces { pieces, .. } => (None, pieces.as_slice()),
    };
    one.into_iter().chain(many.iter().map(|(_, p)| p))
}

/// Adds a corrected point to the summary: the largest corrections and the
/// lines where an axis was held.
fn record(summary: &mut Summary, pt: &Point, line: usize) {
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
    pt: &Point,
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
