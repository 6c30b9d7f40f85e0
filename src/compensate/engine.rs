//! The streaming rewrite: read a block, track the modal state, correct its
//! moves, write it back with only the changed lexemes replaced.

use std::f64::consts::PI;
use std::io::{BufRead, Write};
use std::path::Path;

use indexmap::IndexMap;
use nalgebra::Vector3;

use super::edit::Edits;
use super::frame::{ArcGeo, Frame, Path2, known, lerp, round_to};
use super::solver::Solver;
use super::{CompensateError, Coordinates, Largest, Lines, Settings, Summary, Vertex};
use crate::kinematics::{Axes, ToolPose};
use crate::machine::Dialect;
use crate::model::{Effect, Model};
use crate::nc::modal::{AXES, Arc, Event, Modal, ModalSettings, Motion, Move, MoveKind, Skip, Tcp};
use crate::nc::number::{self, NumStyle, WriteRules};
use crate::nc::{Addr, Block, BlockReader, HhKind, Segment, Stmt, Syntax, TokenKind};
use crate::source::SourceError;

/// A program rewriter for one machine and one set of errors.
#[derive(Clone, Debug)]
pub struct Compensator {
    settings: Settings,
    solver: Solver,
    not_compensated: Vec<String>,
    tilt: usize,
    tool_length: f64,
}

/// A corrected point: what the program asked for and what to write.
#[derive(Clone, Copy, Debug)]
struct Point {
    nominal: Axes,
    target: ToolPose,
    /// Written values in the model frame (unrounded).
    written: Axes,
    /// Written values in program units and frame (unrounded).
    program: [f64; 6],
    held: Option<f64>,
    held_tilt: Option<f64>,
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
        let m = model.kin.machine();
        Compensator {
            tilt: if m.tilt.letter == 'A' { 3 } else { 4 },
            tool_length: model.kin.gauge_length(),
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
        observer: Option<&mut dyn FnMut(&Vertex)>,
    ) -> Result<Summary, CompensateError> {
        let m = self.solver.kinematics().machine();
        let mut run = Run {
            c: self,
            path,
            modal: Modal::new(ModalSettings {
                dialect: self.settings.dialect,
                rotary: [m.tilt.letter as u8, b'C'],
                fanuc_integer_unit: self.settings.fanuc_integer_unit,
            }),
            emit: [None; 6],
            emit_motion: None,
            emit_pole: None,
            vector_rot: None,
            last_held: false,
            eol: b"\n",
            eol_known: false,
            hh_offset: 0,
            before: 0,
            after: 0,
            edits: Edits::default(),
            summary: Summary {
                fast_path: self.solver.is_fast(),
                not_compensated: self.not_compensated.clone(),
                ..Default::default()
            },
            skipped: IndexMap::new(),
            observer,
        };
        let syntax = Syntax {
            dialect: self.settings.dialect,
            strict: self.settings.strict,
        };
        let mut reader = BlockReader::new(input, self.settings.dialect);
        let mut block = Block::default();
        while reader.read(&mut block)? {
            syntax.parse(&mut block).map_err(|e| {
                let (line, column) = block.locate(e.offset);
                CompensateError::Syntax(SourceError::new(path, line, column, e.message))
            })?;
            run.block(&block)?;
            run.edits.write_block(&block, output)?;
        }
        output.flush()?;
        run.summary.skipped = run.skipped.into_iter().collect();
        Ok(run.summary)
    }
}

struct Run<'a, 'o> {
    c: &'a Compensator,
    path: &'a Path,
    modal: Modal,
    /// What the controller has as the last position (program frame), given
    /// what was written so far.
    emit: [Option<f64>; 6],
    emit_motion: Option<Motion>,
    emit_pole: Option<[f64; 2]>,
    vector_rot: Option<(f64, f64)>,
    /// The last written end point had C held.
    last_held: bool,
    eol: &'static [u8],
    eol_known: bool,
    hh_offset: i64,
    before: i64,
    after: i64,
    edits: Edits,
    summary: Summary,
    skipped: IndexMap<String, Lines>,
    observer: Option<&'o mut dyn FnMut(&Vertex)>,
}

impl Run<'_, '_> {
    fn settings(&self) -> &Settings {
        &self.c.settings
    }

    fn solver(&self) -> &Solver {
        &self.c.solver
    }

    fn heidenhain(&self) -> bool {
        self.settings().dialect == Dialect::Heidenhain
    }

    fn rules(&self) -> WriteRules {
        WriteRules {
            force_point: self.settings().dialect == Dialect::Fanuc,
            force_plus: self.heidenhain(),
        }
    }

    fn block(&mut self, block: &Block) -> Result<(), CompensateError> {
        self.edits.clear();
        self.summary.blocks += 1;
        if !self.eol_known
            && let Some(e) = block.line_ending()
        {
            self.eol = e;
            self.eol_known = true;
        }
        self.before = 0;
        self.after = 0;
        for si in 0..block.segments.len() {
            let seg = block.segments[si];
            self.segment(block, &seg)?;
        }
        if self.heidenhain() {
            self.renumber(block);
        }
        if !self.edits.is_empty() {
            self.summary.changed += 1;
        }
        Ok(())
    }

    fn renumber(&mut self, block: &Block) {
        let shift = self.hh_offset + self.before;
        if shift != 0
            && let Some(t) = block
                .tokens
                .iter()
                .find(|t| matches!(t.kind, TokenKind::BlockNumber(_)))
        {
            let TokenKind::BlockNumber(n) = t.kind else {
                unreachable!()
            };
            let new = (n as i64 + shift).max(0) as u64;
            self.edits.replace(t.span, |b| number::push_u64(b, new));
        }
        self.hh_offset += self.before + self.after;
    }

    fn segment(&mut self, block: &Block, seg: &Segment) -> Result<(), CompensateError> {
        let before = self.modal.pos;
        let event = self.modal.step(block, seg);
        let mut motion_done = false;
        match event {
            Event::Move(mv) => {
                self.summary.moves += 1;
                motion_done = self.handle_move(block, seg, &mv, &before)?;
            }
            Event::Skip(s) => {
                self.summary.moves += 1;
                self.skip(block, seg, s.to_string(), &before);
            }
            Event::Quiet => self.follow(block, seg, &before, true),
            Event::None => self.follow(block, seg, &before, false),
        }
        if self.heidenhain() {
            if let Stmt::Hh(HhKind::Cc) = seg.stmt {
                self.emit_pole = self.modal.pole;
            }
        } else if !motion_done {
            self.fix_motion_word(block, seg);
        }
        Ok(())
    }

    /// ISO: a block that relies on the modal motion mode gets the program's
    /// motion word back when a linearized arc changed the mode in force.
    fn fix_motion_word(&mut self, block: &Block, seg: &Segment) {
        if self.emit_motion == self.modal.motion {
            // Nothing to restore, and nothing changes by recording it.
            return;
        }
        let has_axis = block
            .words(seg)
            .any(|(_, w)| w.addr.as_letter().is_some_and(|l| AXES.contains(&l)));
        let has_motion = block.words(seg).any(|(_, w)| {
            w.addr == Addr::letter(b'G')
                && matches!(w.value, crate::nc::Value::Num(v) if [0.0, 1.0, 2.0, 3.0].contains(&v))
        });
        if has_axis
            && !has_motion
            && self.emit_motion != self.modal.motion
            && let Some(word) = motion_text(self.modal.motion)
        {
            let at = block.tokens[seg.body as usize..seg.end as usize]
                .iter()
                .find(|t| !matches!(t.kind, TokenKind::Space))
                .map_or(
                    block.tokens[seg.body.min(seg.end.saturating_sub(1)) as usize]
                        .span
                        .start,
                    |t| t.span.start,
                );
            self.edits.insert(at, |b| {
                b.extend_from_slice(word.as_bytes());
                b.push(b' ');
            });
        }
        if has_axis || has_motion {
            self.emit_motion = self.modal.motion;
        }
    }

    fn skip(&mut self, block: &Block, seg: &Segment, reason: String, before: &[Option<f64>; 6]) {
        self.skipped.entry(reason).or_default().push(block.line);
        if self.heidenhain()
            && matches!(seg.stmt, Stmt::Hh(HhKind::Lp | HhKind::Cp))
            && self.emit_pole != self.modal.pole
        {
            // A polar element left as written needs the program's own pole.
            if let Some(p) = self.modal.pole {
                self.insert_pole(block, p);
            }
        }
        self.follow(block, seg, before, true);
    }

    /// Follows a statement that is left as written: the controller moves
    /// where the words say, from wherever the previous blocks left it.
    fn follow(&mut self, block: &Block, seg: &Segment, before: &[Option<f64>; 6], moved: bool) {
        let after = self.modal.pos;
        if !moved {
            // No motion (a pole, a shift, a cycle definition): positions
            // change only where the frame changed.
            for i in 0..6 {
                self.emit[i] = match after[i] {
                    None => None,
                    Some(a) if before[i] != Some(a) => Some(a),
                    Some(_) => self.emit[i],
                };
            }
            return;
        }
        let mut named = [false; 6];
        let mut inc = [false; 6];
        for (_, w) in block.words(seg) {
            if let Some(l) = w.addr.as_letter()
                && let Some(i) = AXES.iter().position(|&a| a == l)
            {
                named[i] = true;
                inc[i] = w.incremental || !self.modal.absolute;
            }
        }
        for i in 0..6 {
            self.emit[i] = match after[i] {
                None => None,
                Some(a) if named[i] && inc[i] => match (before[i], self.emit[i]) {
                    (Some(b), Some(e)) => Some(e + (a - b)),
                    _ => None,
                },
                Some(a) if named[i] => Some(a),
                Some(a) => {
                    if before[i].is_none() {
                        // Newly known without being named (G92 and the like).
                        Some(a)
                    } else {
                        self.emit[i]
                    }
                }
            };
        }
        self.vector_rot = None;
        self.last_held = false;
    }

    fn frame(&self) -> Frame {
        let tcp = match self.settings().coordinates {
            Coordinates::Auto => self.modal.tcp,
            Coordinates::Axes => Tcp::Off,
            Coordinates::Tcp => {
                if self.modal.tcp == Tcp::Off {
                    Tcp::Axes
                } else {
                    self.modal.tcp
                }
            }
        };
        Frame {
            u: self.modal.units.mm(),
            shift: self.modal.total_shift(),
            origin: self.settings().origin,
            tlc: if tcp == Tcp::Off && !self.modal.tool_length {
                self.c.tool_length
            } else {
                0.0
            },
            tcp,
            tilt: self.c.tilt,
        }
    }

    fn target(&self, f: &Frame, n: &Axes, vector: Option<Vector3<f64>>) -> ToolPose {
        match f.tcp {
            Tcp::Off => self.solver().nominal_pose(n),
            _ => ToolPose {
                tip: n.xyz,
                axis: vector.unwrap_or_else(|| self.solver().nominal_pose(n).axis),
            },
        }
    }

    fn written_model(&self, f: &Frame, corrected: &Axes) -> Axes {
        match f.tcp {
            Tcp::Off => *corrected,
            _ => Axes {
                xyz: self.solver().nominal_pose(corrected).tip,
                ..*corrected
            },
        }
    }

    /// The actual tool pose for written values (model frame).
    fn actual(&self, f: &Frame, w: &Axes) -> ToolPose {
        match f.tcp {
            Tcp::Off => self.solver().actual_pose(w),
            _ => {
                let xyz = self
                    .solver()
                    .nominal()
                    .position(&w.xyz, w.tilt, w.c, &Vector3::zeros());
                self.solver().actual_pose(&Axes { xyz, ..*w })
            }
        }
    }

    fn correct(
        &self,
        f: &Frame,
        p: &[f64; 6],
        vector: Option<Vector3<f64>>,
        hold: Option<f64>,
    ) -> Result<Point, String> {
        let nominal = f.model(p);
        let target = self.target(f, &nominal, vector);
        let why = |e| format!("no axis values reach the intended tool pose on this machine ({e})");
        let sol = match hold {
            Some(dc) => self.solver().solve_held(
                &target,
                &Axes {
                    c: nominal.c + dc,
                    ..nominal
                },
            ),
            None => self.solver().solve(&target, &nominal),
        }
        .map_err(why)?;
        let mut pt = self.point(f, nominal, target, &sol);
        let (lin, rot) = Self::size(&pt);
        let limit = self.settings().max_correction;
        if sol.held_c.is_none() && lin > limit && rot <= limit {
            // A swing of C that drags X, Y, Z past the limit (the tool
            // turns little, the table a lot): hold C if that keeps the
            // correction inside.
            if let Ok(held) = self.solver().solve_held(&target, &nominal) {
                let alt = self.point(f, nominal, target, &held);
                if !self.exceeds(&alt) {
                    pt = alt;
                }
            }
        }
        Ok(pt)
    }

    fn point(&self, f: &Frame, nominal: Axes, target: ToolPose, sol: &super::Solution) -> Point {
        let written = self.written_model(f, &sol.axes);
        Point {
            nominal,
            target,
            written,
            program: f.program(&written),
            held: sol.held_c,
            held_tilt: sol.held_tilt,
        }
    }

    /// Size of a correction: X, Y, Z (um, length of the vector) and the
    /// change of tool orientation the rotary corrections make (urad; a C
    /// correction counts with the sine of the tilt, since next to the
    /// singular tilt turning C barely turns the tool).
    fn size(pt: &Point) -> (f64, f64) {
        let lin_um = (pt.written.xyz - pt.nominal.xyz).norm() * 1e3;
        let dt = (pt.written.tilt - pt.nominal.tilt).to_radians().abs();
        let dc = (pt.written.c - pt.nominal.c).to_radians().abs();
        // |dc sin t| cannot exceed dt when dc does not: skip the sine then.
        // |sin t| of the nominal tilt from the target's tool axis: every
        // nominal chain turns +Z by the tilt first (z component cos t).
        let dc = if dc <= dt {
            0.0
        } else {
            let uz = pt.target.axis.z / pt.target.axis.norm();
            dc * (1.0 - uz * uz).max(0.0).sqrt()
        };
        (lin_um, dt.max(dc) * 1e6)
    }

    fn exceeds(&self, pt: &Point) -> bool {
        let (l, r) = Self::size(pt);
        let limit = self.settings().max_correction;
        l > limit || r > limit
    }

    fn check_limit(&mut self, pt: &Point, line: usize) -> Result<(), CompensateError> {
        let (lin_um, rot_urad) = Self::size(pt);
        let limit = self.settings().max_correction;
        let m = self.solver().kinematics().machine();
        if lin_um > limit {
            return Err(CompensateError::TooLarge {
                path: self.path.to_path_buf(),
                line,
                what: format!(
                    "correction of {lin_um:.1} um in X, Y, Z exceeds --max-correction {limit} um; nothing written"
                ),
            });
        }
        if rot_urad > limit {
            return Err(CompensateError::TooLarge {
                path: self.path.to_path_buf(),
                line,
                what: format!(
                    "correction of the tool orientation by {rot_urad:.1} urad ({} and C) exceeds --max-correction {limit} urad; nothing written",
                    m.tilt.letter
                ),
            });
        }
        if self.summary.largest_linear.is_none_or(|l| lin_um > l.value) {
            self.summary.largest_linear = Some(Largest {
                value: lin_um,
                line,
            });
        }
        if self
            .summary
            .largest_rotary
            .is_none_or(|l| rot_urad > l.value)
        {
            self.summary.largest_rotary = Some(Largest {
                value: rot_urad,
                line,
            });
        }
        if let Some(h) = pt.held {
            self.summary.held_c.push(line);
            self.summary.held_c_axis_error = self.summary.held_c_axis_error.max(h * 1e6);
        }
        if let Some(h) = pt.held_tilt {
            self.summary.held_tilt.push(line);
            self.summary.held_tilt_axis_error = self.summary.held_tilt_axis_error.max(h * 1e6);
        }
        Ok(())
    }

    /// Tip distance between the actual path of written values interpolated
    /// from `w0` to `w1` and the intended path, at fraction `t` of a piece
    /// spanning `u0..u1` of the nominal path.
    #[allow(clippy::too_many_arguments)]
    fn deviation(
        &self,
        f: &Frame,
        path: &Path2,
        u0: f64,
        u1: f64,
        w0: &[f64; 6],
        w1: &[f64; 6],
        t: f64,
        vector: Option<Vector3<f64>>,
    ) -> f64 {
        let n = f.model(&path.at(u0 + t * (u1 - u0)));
        let target = self.target(f, &n, vector);
        let w = f.model(&lerp(w0, w1, t));
        (self.actual(f, &w).tip - target.tip).norm()
    }

    #[allow(clippy::too_many_arguments)]
    fn piece_deviation(
        &self,
        f: &Frame,
        path: &Path2,
        u0: f64,
        u1: f64,
        w0: &[f64; 6],
        w1: &[f64; 6],
        vector: Option<Vector3<f64>>,
    ) -> f64 {
        let tol = self.settings().tolerance;
        let mid = self.deviation(f, path, u0, u1, w0, w1, 0.5, vector);
        if mid > tol / 8.0 {
            mid.max(self.deviation(f, path, u0, u1, w0, w1, 0.25, vector))
                .max(self.deviation(f, path, u0, u1, w0, w1, 0.75, vector))
        } else {
            mid
        }
    }

    /// Whether a line needs no subdivision by the cheap bound of
    /// [`Solver::deviation_bound`] (post-side, constant errors): most blocks
    /// of a real program are short and are settled here without evaluating
    /// the path.
    fn short_enough(&self, f: &Frame, p0: &[f64; 6], w0: &[f64; 6], end: &Point) -> bool {
        if f.tcp != Tcp::Off || !self.solver().is_fast() {
            return false;
        }
        let (n0, w0m) = (f.model(p0), f.model(w0));
        // The written start may be off by the rounding of its lexemes.
        let ends = 1e-4;
        self.solver()
            .deviation_bound(&n0, &end.nominal, &w0m, &end.written, ends)
            <= self.settings().tolerance / 2.0
    }

    /// Pieces (end points) along `path` from the written start `w0` so that
    /// each stays within the tolerance; the last is `end`.
    #[allow(clippy::too_many_arguments)]
    fn pieces(
        &self,
        f: &Frame,
        path: &Path2,
        w0: &[f64; 6],
        end: &Point,
        n0: usize,
        vector: Option<Vector3<f64>>,
        line: usize,
    ) -> Result<Vec<(f64, Point)>, CompensateError> {
        let tol = self.settings().tolerance;
        let mut n = n0.max(1);
        // Where C is held at either end, the pieces do not switch between
        // held and exact solutions (which would jump): the correction of C
        // ramps from its value at the start to its value at the end, the
        // tilt is the best for that C and the tip stays exact.
        let ramp = end.held.is_some() || self.last_held;
        let dc0 = w0[5] - path.at(0.0)[5];
        let dc1 = end.written.c - end.nominal.c;
        loop {
            let mut pts = Vec::with_capacity(n);
            for k in 1..=n {
                let u = k as f64 / n as f64;
                if k == n {
                    pts.push((1.0, *end));
                } else {
                    let hold = ramp.then_some(dc0 + u * (dc1 - dc0));
                    let p = self.correct(f, &path.at(u), vector, hold).map_err(|what| {
                        CompensateError::Tolerance {
                            path: self.path.to_path_buf(),
                            line,
                            what: format!("a point along the move cannot be corrected: {what}"),
                        }
                    })?;
                    pts.push((u, p));
                }
            }
            let mut worst: f64 = 0.0;
            let mut prev = (0.0, *w0);
            for (u, p) in &pts {
                worst = worst
                    .max(self.piece_deviation(f, path, prev.0, *u, &prev.1, &p.program, vector));
                prev = (*u, p.program);
            }
            if worst <= tol {
                return Ok(pts);
            }
            n = if n == 1 {
                (((worst / tol).sqrt() * 1.25).ceil() as usize).max(2)
            } else {
                n * 2
            };
            if n > 1 << 16 {
                return Err(CompensateError::Tolerance {
                    path: self.path.to_path_buf(),
                    line,
                    what: format!(
                        "the move cannot be followed within --tolerance {} um even in {} pieces",
                        tol * 1e3,
                        1 << 16
                    ),
                });
            }
        }
    }

    /// Returns whether the motion-word bookkeeping was done here.
    fn handle_move(
        &mut self,
        block: &Block,
        seg: &Segment,
        mv: &Move,
        before: &[Option<f64>; 6],
    ) -> Result<bool, CompensateError> {
        let line = block.line;
        let f = self.frame();
        let mut end = mv.end;
        let mut vector = None;
        if f.tcp == Tcp::Vector {
            // G43.5: the controller picks the rotary positions for the
            // programmed tool direction, nearest where they were.
            let v = mv
                .tool_vector
                .map(|(v, _)| Vector3::new(v[0], v[1], v[2]).normalize());
            let Some(v) = v else {
                self.skip(
                    block,
                    seg,
                    "tool direction (I J K) not programmed".into(),
                    before,
                );
                return Ok(false);
            };
            let (t0, c0) = self.vector_rot.unwrap_or((0.0, 0.0));
            let reference = Axes::new(0.0, 0.0, 0.0, t0, c0);
            match self.solver().nominal().inverse(
                &ToolPose {
                    tip: Vector3::zeros(),
                    axis: v,
                },
                &reference,
            ) {
                Ok(a) => {
                    end[f.tilt] = Some(a.tilt);
                    end[5] = Some(a.c);
                }
                Err(e) => {
                    self.skip(
                        block,
                        seg,
                        format!("tool direction out of reach: {e}"),
                        before,
                    );
                    return Ok(false);
                }
            }
            vector = Some(v);
        }
        for a in f.axes() {
            if end[a].is_none() {
                self.skip(
                    block,
                    seg,
                    Skip::PositionUnknown(AXES[a]).to_string(),
                    before,
                );
                return Ok(false);
            }
        }
        let p1 = known(&end);
        let pt = match self.correct(&f, &p1, vector, None) {
            Ok(p) => p,
            Err(reason) => {
                self.skip(block, seg, reason, before);
                return Ok(false);
            }
        };
        self.check_limit(&pt, line)?;
        let start_known = f
            .axes()
            .iter()
            .all(|&a| mv.start[a].is_some() && self.emit[a].is_some());
        let p0 = known(&mv.start);
        let w0 = known(&self.emit);
        match mv.kind {
            MoveKind::Rapid => {
                self.write_end(block, seg, mv, &f, &pt, false);
                Ok(false)
            }
            MoveKind::Linear if !start_known || vector.is_some() => {
                self.write_end(block, seg, mv, &f, &pt, false);
                Ok(false)
            }
            MoveKind::Linear => {
                let path = Path2::Line { p0, p1 };
                if self.short_enough(&f, &p0, &w0, &pt) {
                    self.write_end(block, seg, mv, &f, &pt, false);
                    return Ok(false);
                }
                let pieces = self.pieces(&f, &path, &w0, &pt, 1, vector, line)?;
                for (_, p) in &pieces[..pieces.len() - 1] {
                    self.check_limit(p, line)?;
                }
                if pieces.len() == 1 {
                    self.write_end(block, seg, mv, &f, &pt, false);
                    return Ok(false);
                }
                self.summary.subdivided.push(line);
                self.write_pieces(block, seg, mv, &f, &pieces, false);
                Ok(false)
            }
            MoveKind::Arc(arc) => {
                if !start_known {
                    self.skip(block, seg, Skip::PositionUnknown(b'X').to_string(), before);
                    return Ok(false);
                }
                self.arc(block, seg, mv, &f, &arc, &p0, &w0, &p1, &pt)
            }
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn arc(
        &mut self,
        block: &Block,
        seg: &Segment,
        mv: &Move,
        f: &Frame,
        arc: &Arc,
        p0: &[f64; 6],
        w0: &[f64; 6],
        p1: &[f64; 6],
        pt: &Point,
    ) -> Result<bool, CompensateError> {
        let line = block.line;
        let tol = self.settings().tolerance;
        let axes = arc.plane.axes();
        let geo = ArcGeo::new(axes, arc.center, p0, p1, arc.cw, arc.turns);
        let path = Path2::Arc {
            p0: *p0,
            p1: *p1,
            geo,
        };
        let rotary_fixed = p0[f.tilt] == p1[f.tilt] && p0[5] == p1[5];
        // The corrected centre, with the rotary axes where the arc runs.
        let (a0, a1, _) = axes;
        let mut pc = *p0;
        pc[a0] = arc.center[0];
        pc[a1] = arc.center[1];
        let nc = f.model(&pc);
        let tip = self.target(f, &nc, None).tip;
        // The machine axes that put the actual tip on the centre with the
        // corrected rotary positions; under TCP, written as the W point the
        // nominal controller turns into them.
        let m = Axes {
            xyz: self
                .solver()
                .position_at(&tip, pt.written.tilt, pt.written.c),
            tilt: pt.written.tilt,
            c: pt.written.c,
        };
        let cprog = f.program(&self.written_model(f, &m));
        let cstar = [cprog[a0], cprog[a1]];
        let mut keep = rotary_fixed;
        if keep {
            let wg = ArcGeo::new(axes, cstar, w0, &pt.program, arc.cw, arc.turns);
            keep = (wg.rs - wg.re).abs() <= tol && (wg.sweep - geo.sweep).abs() < 0.5;
            if keep {
                for k in 1..16 {
                    let u = k as f64 / 16.0;
                    let n = f.model(&geo.at(p0, p1, u));
                    let target = self.target(f, &n, None);
                    let w = f.model(&wg.at(w0, &pt.program, u));
                    if (self.actual(f, &w).tip - target.tip).norm() > tol {
                        keep = false;
                        break;
                    }
                }
            }
        }
        if keep {
            self.write_arc(block, seg, mv, f, arc, pt, cstar, w0);
            return Ok(false);
        }
        let r = geo.rs.max(geo.re) * f.u;
        let step = if r > tol / 2.0 {
            2.0 * (1.0 - tol / 2.0 / r).clamp(-1.0, 1.0).acos()
        } else {
            PI / 2.0
        };
        let n0 = ((geo.sweep.abs() / step.max(1e-4)).ceil() as usize).max(2);
        let pieces = self.pieces(f, &path, w0, pt, n0, None, line)?;
        for (_, p) in &pieces[..pieces.len() - 1] {
            self.check_limit(p, line)?;
        }
        self.summary.linearized.push(line);
        self.write_pieces(block, seg, mv, f, &pieces, true);
        Ok(true)
    }

    fn decimals(&self, axis: usize, lexeme: Option<&NumStyle>) -> u8 {
        let base = if axis < 3 {
            self.settings().linear_decimals
                + if self.modal.units == crate::nc::modal::Units::Inch {
                    2
                } else {
                    0
                }
        } else {
            self.settings().rotary_decimals
        };
        lexeme.map(|l| l.decimals).unwrap_or(0).max(base)
    }

    fn style_of(&self, block: &Block, seg: &Segment, mv: &Move, axis: usize) -> NumStyle {
        let from = |ti: usize| match block.tokens[ti].kind {
            TokenKind::Word(w) => Some(w.style),
            _ => None,
        };
        if let Some(s) = mv.words[axis].and_then(from) {
            return s;
        }
        // Another word of the same kind (linear or rotary) in the block.
        let same = |a: usize| (a < 3) == (axis < 3);
        for a in 0..6 {
            if same(a)
                && let Some(s) = mv.words[a].and_then(from)
            {
                return NumStyle {
                    trailing_zeros: s.trailing_zeros,
                    ..s
                };
            }
        }
        let _ = seg;
        NumStyle {
            plus: self.heidenhain(),
            point: true,
            decimals: 3,
            no_leading_zero: false,
            trailing_zeros: false,
        }
    }

    fn lower(&self, block: &Block, seg: &Segment) -> bool {
        block.words(seg).next().is_some_and(|(ti, _)| {
            block.text[block.tokens[ti].span.start as usize].is_ascii_lowercase()
        })
    }

    /// Writes an end point into the segment's own words (replacing values,
    /// adding words for axes whose written value changes); returns the
    /// position in force afterwards.
    fn write_words(
        &mut self,
        block: &Block,
        seg: &Segment,
        mv: &Move,
        f: &Frame,
        values: &[f64; 6],
    ) -> [Option<f64>; 6] {
        let prev = self.emit;
        let mut emitted = prev;
        let rules = self.rules();
        let lower = self.lower(block, seg);
        let mut inserts: Vec<(usize, f64, u8, NumStyle)> = Vec::new();
        for a in f.axes() {
            if a >= 3 && f.tcp == Tcp::Vector {
                // G43.5 programs the direction, not the rotary positions.
                continue;
            }
            let v = values[a];
            match mv.words[a] {
                Some(ti) => {
                    let TokenKind::Word(w) = block.tokens[ti].kind else {
                        continue;
                    };
                    let d = self.decimals(a, Some(&w.style));
                    let half = number::half_unit(d);
                    let inc = mv.incremental[a];
                    let (Some(e_end), Some(s)) = (mv.end[a], mv.start[a].or(Some(0.0))) else {
                        continue;
                    };
                    let orig = if inc { e_end - s } else { e_end };
                    let base = if inc { prev[a] } else { Some(0.0) };
                    let Some(base) = base else { continue };
                    // Compare unrounded: a value that only rounds differently
                    // (zero errors) must keep its lexeme.
                    if (v - base - orig).abs() < half {
                        emitted[a] = Some(base + orig);
                    } else {
                        let new = round_to(v - base, d);
                        let style = w.style;
                        self.edits
                            .replace(w.value_span, |b| number::write(b, new, d, &style, rules));
                        emitted[a] = Some(base + new);
                    }
                }
                None => {
                    let d = self.decimals(a, None);
                    let half = number::half_unit(d);
                    let Some(pv) = prev[a] else { continue };
                    let nv = round_to(v, d);
                    if (v - pv).abs() >= half {
                        let inc = !self.heidenhain() && !self.modal.absolute;
                        let val = if inc { round_to(nv - pv, d) } else { nv };
                        inserts.push((a, val, d, self.style_of(block, seg, mv, a)));
                        emitted[a] = Some(if inc { pv + val } else { nv });
                    }
                }
            }
        }
        if !inserts.is_empty() {
            let last = (0..6)
                .filter_map(|a| mv.words[a])
                .map(|ti| block.tokens[ti].span.end)
                .max()
                .unwrap_or(block.tokens[seg.body as usize].span.start);
            self.edits.insert(last, |b| {
                for (a, val, d, style) in &inserts {
                    b.push(b' ');
                    let l = AXES[*a];
                    b.push(if lower { l.to_ascii_lowercase() } else { l });
                    number::write(b, *val, *d, style, rules);
                }
            });
        }
        emitted
    }

    fn observe(
        &mut self,
        line: usize,
        f: &Frame,
        pt: &Point,
        written: &[Option<f64>; 6],
        inserted: bool,
    ) {
        self.last_held = pt.held.is_some();
        let Some(observer) = self.observer.as_mut() else {
            return;
        };
        let program = known(written);
        let w = f.model(&program);
        let v = Vertex {
            line,
            nominal: pt.nominal,
            written: w,
            target: pt.target,
            tcp: f.tcp,
            held_c: pt.held.is_some(),
            inserted,
            nominal_program: f.program(&pt.nominal),
            program,
        };
        observer(&v);
    }

    fn write_end(
        &mut self,
        block: &Block,
        seg: &Segment,
        mv: &Move,
        f: &Frame,
        pt: &Point,
        _arc: bool,
    ) {
        let emitted = self.write_words(block, seg, mv, f, &pt.program);
        if let Some((_, idx)) = mv.tool_vector {
            self.write_vector(block, pt, &idx);
        }
        self.emit = emitted;
        self.observe(block.line, f, pt, &emitted, false);
    }

    /// G43.5: the tool direction the nominal controller turns into the
    /// corrected rotary positions.
    fn write_vector(&mut self, block: &Block, pt: &Point, idx: &[Option<usize>; 3]) {
        let rules = self.rules();
        // Keep the program's vector length (it need not be a unit vector).
        let mut norm2 = 0.0;
        for ti in idx.iter().flatten() {
            if let TokenKind::Word(w) = block.tokens[*ti].kind
                && let crate::nc::Value::Num(x) = w.value
            {
                norm2 += x * x;
            }
        }
        let v = self.solver().nominal_pose(&pt.written).axis * norm2.sqrt();
        for k in 0..3 {
            let Some(ti) = idx[k] else { continue };
            let TokenKind::Word(w) = block.tokens[ti].kind else {
                continue;
            };
            let style = w.style;
            let d = style.decimals.max(self.settings().rotary_decimals + 2);
            let crate::nc::Value::Num(orig) = w.value else {
                continue;
            };
            if (v[k] - orig).abs() >= number::half_unit(d) {
                self.edits
                    .replace(w.value_span, |b| number::write(b, v[k], d, &style, rules));
            }
        }
        self.vector_rot = Some((pt.written.tilt, pt.written.c));
    }

    #[allow(clippy::too_many_arguments)]
    fn write_arc(
        &mut self,
        block: &Block,
        seg: &Segment,
        mv: &Move,
        f: &Frame,
        arc: &Arc,
        pt: &Point,
        cstar: [f64; 2],
        w0: &[f64; 6],
    ) {
        let rules = self.rules();
        let (a0, a1, _) = arc.plane.axes();
        if self.heidenhain() && arc.radius_word.is_none() {
            // C around the pole: the pole itself moves.
            let d = self.decimals(0, None);
            let half = number::half_unit(d);
            let c = [round_to(cstar[0], d), round_to(cstar[1], d)];
            let differs = self
                .emit_pole
                .is_none_or(|p| (p[0] - cstar[0]).abs() >= half || (p[1] - cstar[1]).abs() >= half);
            if differs {
                self.insert_pole(block, c);
            }
        }
        if let Some(ri) = arc.radius_word {
            let TokenKind::Word(w) = block.tokens[ri].kind else {
                return;
            };
            let d = self.decimals(0, Some(&w.style));
            let crate::nc::Value::Num(orig) = w.value else {
                return;
            };
            let r = (w0[a0] - cstar[0]).hypot(w0[a1] - cstar[1]) * orig.signum();
            let new = round_to(r, d);
            if (r - orig).abs() >= number::half_unit(d) {
                let style = w.style;
                self.edits
                    .replace(w.value_span, |b| number::write(b, new, d, &style, rules));
            }
        } else if !self.heidenhain() {
            let letters = [b'I', b'J', b'K'];
            let mut inserts = Vec::new();
            for (k, &axis) in [a0, a1].iter().enumerate() {
                let new_v = if self.modal.arc_absolute {
                    cstar[k]
                } else {
                    cstar[k] - w0[axis]
                };
                match arc.center_words[axis] {
                    Some(ti) => {
                        let TokenKind::Word(w) = block.tokens[ti].kind else {
                            continue;
                        };
                        let d = self.decimals(0, Some(&w.style));
                        let crate::nc::Value::Num(orig) = w.value else {
                            continue;
                        };
                        let new = round_to(new_v, d);
                        if (new_v - orig).abs() >= number::half_unit(d) {
                            let style = w.style;
                            self.edits
                                .replace(w.value_span, |b| number::write(b, new, d, &style, rules));
                        }
                    }
                    None => {
                        let d = self.decimals(0, None);
                        let new = round_to(new_v, d);
                        if new_v.abs() >= number::half_unit(d) || self.modal.arc_absolute {
                            inserts.push((
                                letters[axis],
                                new,
                                d,
                                self.style_of(block, seg, mv, axis),
                            ));
                        }
                    }
                }
            }
            if !inserts.is_empty() {
                let lower = self.lower(block, seg);
                let last = block
                    .words(seg)
                    .map(|(ti, _)| block.tokens[ti].span.end)
                    .max()
                    .unwrap_or(0);
                self.edits.insert(last, |b| {
                    for (l, v, d, style) in &inserts {
                        b.push(b' ');
                        b.push(if lower { l.to_ascii_lowercase() } else { *l });
                        number::write(b, *v, *d, style, rules);
                    }
                });
            }
        }
        self.write_end(block, seg, mv, f, pt, true);
    }

    /// HEIDENHAIN: inserts `CC X.. Y..` before the block.
    fn insert_pole(&mut self, block: &Block, c: [f64; 2]) {
        let d = self.decimals(0, None);
        let number = block.tokens.iter().find_map(|t| match t.kind {
            TokenKind::BlockNumber(n) => Some(n as i64 + self.hh_offset + self.before),
            _ => None,
        });
        let eol = self.eol;
        let rules = self.rules();
        let style = NumStyle {
            plus: true,
            point: true,
            decimals: d,
            no_leading_zero: false,
            trailing_zeros: false,
        };
        self.edits.insert(0, |b| {
            if let Some(n) = number {
                number::push_u64(b, n.max(0) as u64);
                b.push(b' ');
            }
            b.extend_from_slice(b"CC X");
            number::write(b, c[0], d, &style, rules);
            b.extend_from_slice(b" Y");
            number::write(b, c[1], d, &style, rules);
            b.extend_from_slice(eol);
        });
        self.before += 1;
        self.summary.inserted += 1;
        self.emit_pole = Some(c);
    }

    /// Writes a move as pieces: the block itself carries the first piece,
    /// the others follow as new blocks.
    fn write_pieces(
        &mut self,
        block: &Block,
        seg: &Segment,
        mv: &Move,
        f: &Frame,
        pieces: &[(f64, Point)],
        linearize: bool,
    ) {
        let rules = self.rules();
        let hh = self.heidenhain();
        // Turn the arc into a line.
        if linearize {
            let mut first_axis = None;
            for (ti, w) in block.words(seg) {
                let l = w.addr.as_letter();
                let kill = if hh {
                    w.addr == Addr::new("DR") || w.addr == Addr::letter(b'R')
                } else {
                    matches!(l, Some(b'I' | b'J' | b'K' | b'R' | b'P'))
                };
                if kill {
                    self.delete_with_space(block, ti);
                }
                if first_axis.is_none() && l.is_some_and(|l| AXES.contains(&l)) {
                    first_axis = Some(ti);
                }
            }
            if hh {
                if let Some(k) = block
                    .seg_tokens(seg)
                    .iter()
                    .find(|t| t.kind == TokenKind::Keyword)
                {
                    self.edits.replace(k.span, |b| b.push(b'L'));
                }
            } else if let Some(ti) = mv.motion_word {
                let TokenKind::Word(w) = block.tokens[ti].kind else {
                    return;
                };
                self.edits.replace(w.value_span, |b| b.push(b'1'));
            } else {
                let at = first_axis.map_or(block.tokens[seg.body as usize].span.start, |ti| {
                    block.tokens[ti].span.start
                });
                let g = if self.lower(block, seg) { "g1 " } else { "G1 " };
                self.edits.insert(at, |b| b.extend_from_slice(g.as_bytes()));
            }
        }
        // The feed of each piece in inverse time: the block keeps its time.
        let inverse_time = !hh && self.modal.feed_mode == crate::nc::modal::FeedMode::InverseTime;
        let feed = mv.feed;
        let mut u_prev = 0.0;
        let mut feed_for = |u: f64| -> Option<f64> {
            let r = feed.map(|(_, fv)| fv / (u - u_prev));
            u_prev = u;
            r
        };
        let (u_first, first) = pieces[0];
        let f_first = feed_for(u_first);
        let emitted = self.write_words(block, seg, mv, f, &first.program);
        if inverse_time && let (Some((ti, _)), Some(fv)) = (feed, f_first) {
            let TokenKind::Word(w) = block.tokens[ti].kind else {
                return;
            };
            let style = w.style;
            let d = style.decimals.max(3);
            self.edits
                .replace(w.value_span, |b| number::write(b, fv, d, &style, rules));
        }
        self.emit = emitted;
        self.observe(block.line, f, &first, &emitted, pieces.len() > 1);
        // The following pieces, as new blocks after this statement.
        let at = self.insert_point(block, seg);
        let eob = block
            .seg_tokens(seg)
            .last()
            .is_some_and(|t| t.kind == TokenKind::Eob);
        let space_eob = eob
            && block
                .seg_tokens(seg)
                .iter()
                .rev()
                .nth(1)
                .is_some_and(|t| t.kind == TokenKind::Space);
        let delete = block
            .seg_tokens(seg)
            .iter()
            .find(|t| t.kind == TokenKind::BlockDelete)
            .map(|t| block.bytes(t.span).to_vec());
        let number_base = if hh {
            block.tokens.iter().find_map(|t| match t.kind {
                TokenKind::BlockNumber(n) => Some(n as i64 + self.hh_offset + self.before),
                _ => None,
            })
        } else {
            None
        };
        let lower = self.lower(block, seg);
        let rapid = matches!(mv.kind, MoveKind::Rapid);
        let mut text = Vec::new();
        let last = pieces.len() - 1;
        for (i, (u, p)) in pieces.iter().enumerate().skip(1) {
            let fv = feed_for(*u);
            let prev = self.emit;
            text.extend_from_slice(self.eol);
            if let Some(d) = &delete {
                text.extend_from_slice(d);
                if hh {
                    text.push(b' ');
                }
            }
            if let Some(n) = number_base {
                number::push_u64(&mut text, (n + 1 + self.after).max(0) as u64);
                text.push(b' ');
            }
            if hh {
                text.extend_from_slice(b"L");
            }
            let mut first_word = !hh;
            let mut emitted = prev;
            for a in f.axes() {
                let d = self.decimals(
                    a,
                    mv.words[a].and_then(|ti| match &block.tokens[ti].kind {
                        TokenKind::Word(w) => Some(&w.style),
                        _ => None,
                    }),
                );
                let half = number::half_unit(d);
                let nv = round_to(p.program[a], d);
                let Some(pv) = prev[a] else { continue };
                if (p.program[a] - pv).abs() < half {
                    continue;
                }
                let inc = !hh && !self.modal.absolute;
                let val = if inc { round_to(nv - pv, d) } else { nv };
                if !first_word {
                    text.push(b' ');
                }
                first_word = false;
                let l = AXES[a];
                text.push(if lower { l.to_ascii_lowercase() } else { l });
                number::write(&mut text, val, d, &self.style_of(block, seg, mv, a), rules);
                emitted[a] = Some(if inc { pv + val } else { nv });
            }
            if hh && rapid {
                text.extend_from_slice(b" FMAX");
            }
            if inverse_time && let (Some(fv), Some((ti, _))) = (fv, feed) {
                let TokenKind::Word(w) = block.tokens[ti].kind else {
                    continue;
                };
                let style = w.style;
                text.push(b' ');
                text.push(if lower { b'f' } else { b'F' });
                number::write(&mut text, fv, style.decimals.max(3), &style, rules);
            }
            if eob {
                if space_eob {
                    text.push(b' ');
                }
                text.push(b';');
            }
            self.emit = emitted;
            self.observe(block.line, f, p, &emitted, i != last);
            if hh {
                self.after += 1;
            }
            self.summary.inserted += 1;
        }
        self.edits.insert(at, |b| b.extend_from_slice(&text));
        if linearize {
            self.emit_motion = Some(Motion::Linear);
        }
    }

    fn delete_with_space(&mut self, block: &Block, ti: usize) {
        let mut span = block.tokens[ti].span;
        if ti > 0 && block.tokens[ti - 1].kind == TokenKind::Space {
            span.start = block.tokens[ti - 1].span.start;
        }
        self.edits.delete(span);
    }

    /// Where blocks following a statement are inserted: after its `;`, or
    /// before the block's final line ending.
    fn insert_point(&self, block: &Block, seg: &Segment) -> u32 {
        let toks = block.seg_tokens(seg);
        if toks.last().is_some_and(|t| t.kind == TokenKind::Eob) {
            return toks.last().unwrap().span.end;
        }
        if self.heidenhain() {
            let n = block.text.len() - block.line_ending().map_or(0, |e| e.len());
            return n as u32;
        }
        toks.last().map_or(0, |t| t.span.end)
    }
}

fn motion_text(m: Option<Motion>) -> Option<&'static str> {
    match m? {
        Motion::Rapid => Some("G0"),
        Motion::Linear => Some("G1"),
        Motion::ArcCw => Some("G2"),
        Motion::ArcCcw => Some("G3"),
        Motion::Other => None,
    }
}
