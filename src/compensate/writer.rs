//! Writing corrected points into the program's own text: only the value
//! lexemes that change are replaced, in the style of the program (`X1.`,
//! `X+1`, `X.5`); an axis whose written value changes but that the block
//! does not name gets a word; pieces of subdivided moves and linearized
//! arcs follow as new blocks; an arc keeps its form with a corrected
//! centre or radius (HEIDENHAIN: a new pole `CC`); HEIDENHAIN blocks are
//! renumbered after inserted ones. The writer also follows what the
//! controller has as its position, given what was written so far, so an
//! incremental word or a new word is written against the right value.

use nalgebra::Vector3;

use super::Settings;
use super::correction::{CorrectedPoint, WritePlan};
use super::edit::Edits;
use crate::machine::Dialect;
use crate::nc::interp::gcode::linuxcnc_polar;
use crate::nc::interp::{
    AXES, Arc, FeedMode, Frame, Interpreter, Motion, Move, MoveKind, Polar, Through, Units,
};
use crate::nc::lexeme::{self, NumStyle, WriteRules, round_to};
use crate::nc::{Addr, Block, HhKind, Segment, Stmt, TokenKind, Value};

/// Most decimals a value is written or compared with: the finest control
/// increment is 1 nm (FANUC IS-E, 0.000001 mm); a thousand times finer
/// than that is still well above the floating-point noise of a coordinate
/// corrected through the model, which a program written with 26 decimals
/// would otherwise be rewritten for at zero error.
const MAX_DECIMALS: u8 = 9;

/// Where a written point goes: the point, what the controller has after
/// it (program frame), and whether it is a piece inside the move.
pub(super) type Sink<'s> = dyn FnMut(&CorrectedPoint, &[Option<f64>; 6], bool) + 's;

/// The writer's state along a program.
pub(super) struct Writer {
    dialect: Dialect,
    linear_decimals: u8,
    rotary_decimals: u8,
    /// What the controller has as the last position (program frame), given
    /// what was written so far.
    pub emit: [Option<f64>; 6],
    emit_motion: Option<Motion>,
    emit_pole: Option<[f64; 2]>,
    /// In a canned cycle: the level the tool came from and the hole bottom
    /// in force, as written.
    emit_drill: Option<[Option<f64>; 2]>,
    /// The current statement's hole was written.
    drill_written: bool,
    /// The current statement is an arc written as lines.
    linearizing: bool,
    eol: &'static [u8],
    eol_known: bool,
    /// HEIDENHAIN: blocks inserted so far (block numbers shift by it).
    hh_offset: i64,
    /// HEIDENHAIN: blocks inserted before / after the current block.
    before: i64,
    after: i64,
    /// The current block's edits.
    pub edits: Edits,
    /// Blocks inserted.
    pub inserted: usize,
}

impl Writer {
    pub(super) fn new(settings: &Settings) -> Writer {
        // Before the first block the controller has the stated rotary
        // positions (and, where the program corrects such an axis, the
        // word the rewrite adds moves it from there).
        let mut emit = [None; 6];
        for &(letter, v) in &settings.rotary_start {
            if let Some(i) = AXES.iter().position(|&a| a as char == letter) {
                emit[i] = Some(v);
            }
        }
        Writer {
            dialect: settings.dialect,
            linear_decimals: settings.linear_decimals,
            rotary_decimals: settings.rotary_decimals,
            emit,
            emit_motion: None,
            emit_pole: None,
            emit_drill: None,
            drill_written: false,
            linearizing: false,
            eol: b"\n",
            eol_known: false,
            hh_offset: 0,
            before: 0,
            after: 0,
            edits: Edits::default(),
            inserted: 0,
        }
    }

    fn heidenhain(&self) -> bool {
        self.dialect == Dialect::Heidenhain
    }

    fn rules(&self) -> WriteRules {
        WriteRules {
            force_point: self.dialect == Dialect::Fanuc,
            force_plus: self.heidenhain(),
        }
    }

    /// Starts a block: no edits yet.
    pub(crate) fn begin(&mut self, block: &Block) {
        self.edits.clear();
        if !self.eol_known
            && let Some(e) = block.line_ending()
        {
            self.eol = e;
            self.eol_known = true;
        }
        self.before = 0;
        self.after = 0;
    }

    /// Ends a block (renumbering HEIDENHAIN blocks); whether it changed.
    pub(super) fn end(&mut self, block: &Block) -> bool {
        if self.heidenhain() {
            self.renumber(block);
        }
        !self.edits.is_empty()
    }

    fn renumber(&mut self, block: &Block) {
        let shift = self.hh_offset + self.before;
        if shift != 0
            && let Some((n, span)) = block.tokens.iter().find_map(|t| match t.kind {
                TokenKind::BlockNumber(n) => Some((n, t.span)),
                _ => None,
            })
        {
            let new = (n as i64 + shift).max(0) as u64;
            self.edits.replace(span, |b| lexeme::push_u64(b, new));
        }
        self.hh_offset += self.before + self.after;
    }

    /// After a statement: HEIDENHAIN remembers the pole in force; ISO
    /// blocks that rely on a motion mode a linearized arc changed get their
    /// motion word back.
    pub(crate) fn after_statement(
        &mut self,
        block: &Block,
        seg: &Segment,
        interp: &Interpreter,
        motion_done: bool,
    ) {
        if self.heidenhain() {
            if let Stmt::Hh(HhKind::Cc) = seg.stmt {
                self.emit_pole = self.written_pole(block, seg, interp);
            }
        } else if !motion_done {
            self.fix_motion_word(block, seg, interp);
        }
        match (interp.cycle, self.emit_drill.as_mut()) {
            (None, _) => self.emit_drill = None,
            // A hole left as written: its depth is the program's.
            (Some(_), Some(d)) if !self.drill_written => d[1] = interp.cycle_depth,
            _ => {}
        }
        self.drill_written = false;
    }

    /// The pole a `CC` block sets in the written program: its absolute
    /// words as written, an incremental word or an omitted one (`CC`
    /// alone: the pole where the tool is) from the position as written.
    fn written_pole(&self, block: &Block, seg: &Segment, interp: &Interpreter) -> Option<[f64; 2]> {
        let program = interp.pole?;
        let mut p = [self.emit[0], self.emit[1]];
        for (_, w) in block.words(seg) {
            let i = match w.addr.as_letter() {
                Some(b'X') => 0,
                Some(b'Y') => 1,
                _ => continue,
            };
            p[i] = match w.value {
                Value::Num(v) if w.incremental => p[i].map(|e| e + v),
                Value::Num(_) => Some(program[i]),
                _ => None,
            };
        }
        Some([p[0]?, p[1]?])
    }

    /// ISO: a block that relies on the modal motion mode gets the program's
    /// motion word back when a linearized arc changed the mode in force.
    fn fix_motion_word(&mut self, block: &Block, seg: &Segment, interp: &Interpreter) {
        let motion = interp.motion;
        if self.emit_motion == motion {
            // Nothing to restore, and nothing changes by recording it.
            return;
        }
        let has_axis = block
            .words(seg)
            .any(|(_, w)| w.addr.as_letter().is_some_and(|l| AXES.contains(&l)));
        let has_motion = block.words(seg).any(|(_, w)| {
            w.addr == Addr::letter(b'G')
                && matches!(w.value, Value::Num(v) if [0.0, 1.0, 2.0, 3.0].contains(&v))
        });
        // A SINUMERIK CIP is a command, not a G word.
        let word = match motion {
            Some(Motion::Other) if interp.cip => Some("CIP"),
            m => motion_text(m),
        };
        let has_motion = has_motion
            || interp.cip
                && block.seg_tokens(seg).iter().any(|t| {
                    t.kind == TokenKind::Keyword && block.bytes(t.span).eq_ignore_ascii_case(b"CIP")
                });
        if has_axis
            && !has_motion
            && let Some(word) = word
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
            self.emit_motion = motion;
        }
    }

    /// A move left as written: a polar element needs the program's own
    /// pole; the controller then moves where the words say.
    pub(super) fn keep(
        &mut self,
        block: &Block,
        seg: &Segment,
        interp: &Interpreter,
        before: &[Option<f64>; 6],
    ) {
        if self.heidenhain()
            && matches!(seg.stmt, Stmt::Hh(HhKind::Lp | HhKind::Cp))
            && self.emit_pole != interp.pole
            && let Some(p) = interp.pole
        {
            self.insert_pole(block, p, interp.units);
        }
        self.follow(block, seg, interp, before, true);
    }

    /// A statement that moved nothing but changed the frame (a datum
    /// shift, a programmable frame): the written position is the same
    /// place, now written in the new frame. When it is known on every axis
    /// it is mapped exactly (a corrected point keeps its correction, turned
    /// with the frame); otherwise it follows as any other statement.
    pub(super) fn reframe(
        &mut self,
        block: &Block,
        seg: &Segment,
        interp: &Interpreter,
        to: &Frame,
        before: (&[Option<f64>; 6], &Frame),
    ) {
        let axes = to.axes();
        let known = |p: &[Option<f64>; 6]| axes.iter().all(|&a| p[a].is_some());
        if to == before.1 || !known(&self.emit) || !known(before.0) || !known(&interp.pos) {
            return self.follow(block, seg, interp, before.0, false);
        }
        let p = to.program(
            &before
                .1
                .model(&crate::nc::interp::coordinates::known(&self.emit)),
        );
        for a in axes {
            self.emit[a] = Some(p[a]);
        }
    }

    /// A LinuxCNC G10 L20 (`words`: its axis words' tokens) sets an offset
    /// from the current position. Where the rewrite put the controller
    /// elsewhere than the program (`before`), each value moves by the same
    /// amount, so that the offset stored is the one the program meant.
    pub(super) fn move_setting(
        &mut self,
        block: &Block,
        words: &[Option<usize>; 6],
        interp: &Interpreter,
        before: &[Option<f64>; 6],
    ) {
        let rules = self.rules();
        for (a, ti) in words.iter().enumerate() {
            let (Some(ti), Some(p), Some(e)) = (*ti, before[a], self.emit[a]) else {
                continue;
            };
            let TokenKind::Word(w) = block.tokens[ti].kind else {
                continue;
            };
            let Value::Num(x) = w.value else { continue };
            let d = self.decimals(a, Some(&w.style), interp.units);
            if (e - p).abs() < lexeme::half_unit(d) {
                continue;
            }
            let new = round_to(x + (e - p), d);
            let style = w.style;
            self.edits
                .replace_number(w.value_span, new, d, style, rules);
        }
    }

    /// Follows a statement that is left as written: the controller moves
    /// where the words say, from wherever the previous blocks left it.
    pub(super) fn follow(
        &mut self,
        block: &Block,
        seg: &Segment,
        interp: &Interpreter,
        before: &[Option<f64>; 6],
        moved: bool,
    ) {
        let after = interp.pos;
        if !moved {
            // No motion (a pole, a shift, a cycle definition): positions
            // change only where the frame changed.
            for i in 0..6 {
                self.emit[i] = match after[i] {
                    None => None,
                    Some(a) if before[i] != Some(a) => match (before[i], self.emit[i]) {
                        // Newly known, or the rewrite has the tool where
                        // the program has it: the same value.
                        (None, _) => Some(a),
                        (Some(b), Some(e)) if e == b => Some(a),
                        // The rewrite has the tool elsewhere (a correction)
                        // and the change of frame could not be followed
                        // exactly ([`Self::reframe`]): where that puts the
                        // tool in the new coordinates is not known here, and
                        // taking the program's value would drop the
                        // correction from the next incremental or omitted
                        // word.
                        _ => None,
                    },
                    Some(_) => self.emit[i],
                };
            }
            return;
        }
        let start = self.emit;
        let mut named = [false; 6];
        let mut inc = [false; 6];
        for (_, w) in block.words(seg) {
            if let Some(l) = w.addr.as_letter()
                && let Some(i) = AXES.iter().position(|&a| a == l)
            {
                named[i] = true;
                inc[i] = w.incremental || !interp.absolute;
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
                Some(a) => match before[i] {
                    // Newly known without being named (G92 and the like).
                    None => Some(a),
                    Some(b) if b == a => self.emit[i],
                    // Moved without being named (a HEIDENHAIN polar
                    // element, a cycle's return level): the control went
                    // somewhere the words left as written do not say in
                    // the rewrite's coordinates, so it is unknown there
                    // until a word sets it (keeping the old value put an
                    // incremental move after a polar circle 10 mm off).
                    Some(_) => None,
                },
            };
        }
        if self.dialect == Dialect::Linuxcnc {
            self.follow_polar(block, seg, interp, start);
        }
    }

    /// LinuxCNC polar words left as written: the controller computes X and
    /// Y from them and from where the written program has the tool.
    fn follow_polar(
        &mut self,
        block: &Block,
        seg: &Segment,
        interp: &Interpreter,
        start: [Option<f64>; 6],
    ) {
        let (mut radius, mut angle) = (None, None);
        for (_, w) in block.words(seg) {
            let v = match w.value {
                Value::Num(v) => Some(v),
                _ => None,
            };
            match w.addr.as_letter() {
                Some(b'@') => radius = Some(v),
                Some(b'^') => angle = Some(v),
                _ => {}
            }
        }
        if radius.is_none() && angle.is_none() {
            return;
        }
        let cycle = interp.cycle.is_some();
        // Incremental cycles step their holes by the words: not followed.
        let p = (!cycle || interp.absolute)
            .then(|| {
                linuxcnc_polar([start[0], start[1]], radius, angle, !interp.absolute, cycle).ok()
            })
            .flatten();
        self.emit[0] = p.map(|p| p[0]);
        self.emit[1] = p.map(|p| p[1]);
    }

    /// Writes a planned move; returns whether the motion-word bookkeeping
    /// was done here (a linearized arc).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn write(
        &mut self,
        block: &Block,
        seg: &Segment,
        mv: &Move,
        f: &Frame,
        interp: &Interpreter,
        plan: &WritePlan,
        tool_axis: Option<Vector3<f64>>,
        sink: &mut Sink,
    ) -> bool {
        match plan {
            WritePlan::End(pt) => {
                self.write_end(block, seg, mv, f, interp, pt, sink);
                if let (Some((_, idx)), Some(axis)) = (mv.tool_vector, tool_axis) {
                    // Written in the programmable frame (SINUMERIK ROT).
                    self.write_vector(block, seg, f.rot.transpose() * axis, &idx);
                }
                false
            }
            WritePlan::Arc {
                end,
                through: Some(point),
                ..
            } => {
                let MoveKind::Through(t) = mv.kind else {
                    unreachable!("an intermediate point for a CIP")
                };
                self.write_through(block, seg, &t, point, interp);
                self.write_end(block, seg, mv, f, interp, end, sink);
                false
            }
            WritePlan::Arc { end, center, .. } => {
                let MoveKind::Arc(arc) = mv.kind else {
                    unreachable!("an arc plan for an arc move")
                };
                self.write_arc(block, seg, mv, f, interp, &arc, end, *center, sink);
                false
            }
            WritePlan::Pieces { pieces, linearize } => {
                self.write_pieces(block, seg, mv, f, interp, pieces, *linearize, sink);
                *linearize
            }
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn write_end(
        &mut self,
        block: &Block,
        seg: &Segment,
        mv: &Move,
        f: &Frame,
        interp: &Interpreter,
        pt: &CorrectedPoint,
        sink: &mut Sink,
    ) {
        let emitted = self.write_words(block, seg, mv, f, interp, &pt.program);
        self.emit = emitted;
        sink(pt, &emitted, false);
    }

    /// G43.5: the tool direction `axis` (the one the nominal controller
    /// turns into the corrected rotary positions) into the I J K words.
    /// Writes the corrected tool direction `axis` into the block's vector
    /// words; a component the block leaves out (zero) that the correction
    /// makes nonzero is added after them (`I`/`J`/`K` of G43.5, `A3=`
    /// `B3=` `C3=` of SINUMERIK), in the style of the first one.
    fn write_vector(
        &mut self,
        block: &Block,
        seg: &Segment,
        axis: Vector3<f64>,
        idx: &[Option<usize>; 3],
    ) {
        let rules = self.rules();
        // Keep the program's vector length (it need not be a unit vector).
        let mut norm2 = 0.0;
        let mut first_style = None;
        for ti in idx.iter().flatten() {
            if let TokenKind::Word(w) = block.tokens[*ti].kind
                && let Value::Num(x) = w.value
            {
                norm2 += x * x;
                first_style.get_or_insert(w.style);
            }
        }
        let v = axis * norm2.sqrt();
        let mut inserts = Vec::new();
        for (k, ti) in idx.iter().enumerate() {
            let Some(ti) = *ti else {
                if let Some(style) = first_style {
                    let d = style
                        .decimals
                        .max(self.rotary_decimals + 2)
                        .min(MAX_DECIMALS);
                    if v[k].abs() >= lexeme::half_unit(d) {
                        inserts.push((k, v[k], d, style));
                    }
                }
                continue;
            };
            let TokenKind::Word(w) = block.tokens[ti].kind else {
                continue;
            };
            let style = w.style;
            let d = style
                .decimals
                .max(self.rotary_decimals + 2)
                .min(MAX_DECIMALS);
            let Value::Num(orig) = w.value else {
                continue;
            };
            if (v[k] - orig).abs() >= lexeme::half_unit(d) {
                self.edits
                    .replace_number(w.value_span, v[k], d, style, rules);
            }
        }
        if inserts.is_empty() {
            return;
        }
        let names: [&[u8]; 3] = if self.dialect == Dialect::Sinumerik {
            [b"A3=", b"B3=", b"C3="]
        } else {
            [b"I", b"J", b"K"]
        };
        let lower = lower(block, seg);
        let last = idx
            .iter()
            .flatten()
            .map(|&ti| block.tokens[ti].span.end)
            .max()
            .unwrap_or(0);
        self.edits.insert(last, |b| {
            for (k, val, d, style) in &inserts {
                b.push(b' ');
                for &c in names[*k] {
                    b.push(if lower { c.to_ascii_lowercase() } else { c });
                }
                lexeme::write(b, *val, *d, style, rules);
            }
        });
    }

    #[allow(clippy::too_many_arguments)]
    fn write_arc(
        &mut self,
        block: &Block,
        seg: &Segment,
        mv: &Move,
        f: &Frame,
        interp: &Interpreter,
        arc: &Arc,
        pt: &CorrectedPoint,
        cstar: [f64; 2],
        sink: &mut Sink,
    ) {
        let rules = self.rules();
        let (a0, a1, _) = arc.plane.axes();
        let w0 = crate::nc::interp::coordinates::known(&self.emit);
        if self.heidenhain() && arc.radius_word.is_none() {
            // C around the pole: the pole itself moves.
            let d = self.decimals(0, None, interp.units);
            let half = lexeme::half_unit(d);
            let c = [round_to(cstar[0], d), round_to(cstar[1], d)];
            let differs = self
                .emit_pole
                .is_none_or(|p| (p[0] - cstar[0]).abs() >= half || (p[1] - cstar[1]).abs() >= half);
            if differs {
                self.insert_pole(block, c, interp.units);
            }
        }
        if let Some(ri) = arc.radius_word {
            let TokenKind::Word(w) = block.tokens[ri].kind else {
                return;
            };
            let d = self.decimals(0, Some(&w.style), interp.units);
            let Value::Num(orig) = w.value else {
                return;
            };
            let r = (w0[a0] - cstar[0]).hypot(w0[a1] - cstar[1]) * orig.signum();
            let new = round_to(r, d);
            if (r - orig).abs() >= lexeme::half_unit(d) {
                let style = w.style;
                self.edits
                    .replace_number(w.value_span, new, d, style, rules);
            }
        } else if !self.heidenhain() {
            let letters = [b'I', b'J', b'K'];
            let mut inserts = Vec::new();
            for (k, &axis) in [a0, a1].iter().enumerate() {
                let new_v = if interp.arc_absolute {
                    cstar[k]
                } else {
                    cstar[k] - w0[axis]
                };
                match arc.center_words[axis] {
                    Some(ti) => {
                        let TokenKind::Word(w) = block.tokens[ti].kind else {
                            continue;
                        };
                        let d = self.decimals(0, Some(&w.style), interp.units);
                        let Value::Num(orig) = w.value else {
                            continue;
                        };
                        let new = round_to(new_v, d);
                        if (new_v - orig).abs() >= lexeme::half_unit(d) {
                            let style = w.style;
                            self.edits
                                .replace_number(w.value_span, new, d, style, rules);
                        }
                    }
                    None => {
                        let d = self.decimals(0, None, interp.units);
                        let new = round_to(new_v, d);
                        if new_v.abs() >= lexeme::half_unit(d) || interp.arc_absolute {
                            inserts.push((axis, new, d, self.style_of(block, mv, axis)));
                        }
                    }
                }
            }
            let named: Vec<_> = inserts
                .into_iter()
                .map(|(l, v, d, style)| (std::slice::from_ref(&letters[l]), v, d, style))
                .collect();
            self.append_words(block, seg, &named);
        }
        self.write_end(block, seg, mv, f, interp, pt, sink);
    }

    /// A `CIP`'s corrected intermediate point into its `I1= J1= K1=`
    /// words, absolute or counted from the written start as each is; one
    /// the block leaves out (the start's coordinate) is added where the
    /// corrected point leaves that, in the mode G90/G91 gives it.
    fn write_through(
        &mut self,
        block: &Block,
        seg: &Segment,
        t: &Through,
        point: &[f64; 3],
        interp: &Interpreter,
    ) {
        let units = interp.units;
        let rules = self.rules();
        let w0 = crate::nc::interp::coordinates::known(&self.emit);
        let mut inserts = Vec::new();
        for k in 0..3 {
            match t.words[k] {
                Some(ti) => {
                    let TokenKind::Word(w) = block.tokens[ti].kind else {
                        continue;
                    };
                    let Value::Num(orig) = w.value else { continue };
                    let new_v = if t.incremental[k] {
                        point[k] - w0[k]
                    } else {
                        point[k]
                    };
                    let d = self.decimals(k, Some(&w.style), units);
                    if (new_v - orig).abs() >= lexeme::half_unit(d) {
                        let style = w.style;
                        let new = round_to(new_v, d);
                        self.edits
                            .replace_number(w.value_span, new, d, style, rules);
                    }
                }
                None => {
                    let d = self.decimals(k, None, units);
                    let from_start = point[k] - w0[k];
                    // Left out, it is the start's coordinate only where
                    // the manual's value 0 is one (G91, or a start at 0):
                    // anywhere else the word is written.
                    let reads_as_start = !interp.absolute || w0[k] == 0.0;
                    if from_start.abs() >= lexeme::half_unit(d) || !reads_as_start {
                        // Written as the block's own words are: the first
                        // one's style, else the dialect's default.
                        let style = t
                            .words
                            .iter()
                            .flatten()
                            .find_map(|&ti| match block.tokens[ti].kind {
                                TokenKind::Word(w) => Some(w.style),
                                _ => None,
                            })
                            .unwrap_or(NumStyle {
                                point: true,
                                decimals: 3,
                                ..NumStyle::default()
                            });
                        let v = if interp.absolute {
                            point[k]
                        } else {
                            from_start
                        };
                        inserts.push((k, round_to(v, d), d, style));
                    }
                }
            }
        }
        let names: [&[u8]; 3] = [b"I1=", b"J1=", b"K1="];
        let named: Vec<_> = inserts
            .into_iter()
            .map(|(k, v, d, style)| (names[k], v, d, style))
            .collect();
        self.append_words(block, seg, &named);
    }

    /// Appends words (address as written, value, decimals, style) after
    /// the last word of the statement, in its case.
    fn append_words(&mut self, block: &Block, seg: &Segment, words: &[(&[u8], f64, u8, NumStyle)]) {
        if words.is_empty() {
            return;
        }
        let rules = self.rules();
        let lower = lower(block, seg);
        let last = block
            .words(seg)
            .map(|(ti, _)| block.tokens[ti].span.end)
            .max()
            .unwrap_or(0);
        self.edits.insert(last, |b| {
            for (name, v, d, style) in words {
                b.push(b' ');
                for &c in *name {
                    b.push(if lower { c.to_ascii_lowercase() } else { c });
                }
                lexeme::write(b, *v, *d, style, rules);
            }
        });
    }

    /// HEIDENHAIN `LP`/`CP`: the corrected end point in the plane written
    /// as polar radius and angle around the pole the written program has
    /// in force (a corrected one, or the program's, which is inserted when
    /// none is known), as absolute or incremental words the way the block
    /// has them. A `CP` writes its angle only: its radius is where it
    /// starts. Returns the end point the controller computes from them.
    #[allow(clippy::too_many_arguments)]
    fn write_polar(
        &mut self,
        block: &Block,
        seg: &Segment,
        mv: &Move,
        interp: &Interpreter,
        pol: &Polar,
        values: &[f64; 6],
        prev: &[Option<f64>; 6],
    ) -> [Option<f64>; 2] {
        let units = interp.units;
        // LinuxCNC's polar words count from the origin of the XY plane.
        let linuxcnc = self.dialect == Dialect::Linuxcnc;
        let pole = match (self.emit_pole, interp.pole) {
            _ if linuxcnc => [0.0, 0.0],
            (Some(p), _) => p,
            (None, Some(p)) => {
                self.insert_pole(block, p, units);
                p
            }
            (None, None) => return [None, None],
        };
        let polar = |x: f64, y: f64| {
            (
                (x - pole[0]).hypot(y - pole[1]),
                (y - pole[1]).atan2(x - pole[0]).to_degrees(),
            )
        };
        let (r, a) = polar(values[0], values[1]);
        let here = match (prev[0], prev[1]) {
            (Some(x), Some(y)) => Some(polar(x, y)),
            _ => None,
        };
        // A CP keeps the radius it starts at; a LinuxCNC arc ends where
        // its words say.
        let circle = !linuxcnc && matches!(mv.kind, MoveKind::Arc(_)) && !self.linearizing;
        let word = |ti: usize| match block.tokens[ti].kind {
            TokenKind::Word(w) => match w.value {
                Value::Num(v) => Some((w, v)),
                _ => None,
            },
            _ => None,
        };
        let rules = self.rules();
        let own_style =
            |p: Option<(usize, bool)>| p.and_then(|(ti, _)| word(ti)).map(|(w, _)| w.style);
        // A word the block leaves out is written as its other polar word
        // is (HEIDENHAIN: with a sign and a point), after it (after the
        // LP or CP).
        let style = match (linuxcnc, own_style(pol.angle).or(own_style(pol.radius))) {
            (true, Some(st)) => st,
            _ => NumStyle {
                plus: true,
                point: true,
                ..NumStyle::default()
            },
        };
        let keyword = if linuxcnc {
            [pol.angle, pol.radius]
                .iter()
                .flatten()
                .map(|&(ti, _)| block.tokens[ti].span.end)
                .max()
                .unwrap_or(0)
        } else {
            block
                .seg_tokens(seg)
                .iter()
                .find(|t| t.kind == TokenKind::Keyword)
                .map_or(0, |t| t.span.end)
        };
        let (radius_word, angle_word_name): (&[u8], &[u8]) = if linuxcnc {
            (b" @", b" ^")
        } else {
            (b" PR", b" PA")
        };
        // LinuxCNC's G91 makes a word it adds incremental too.
        let added_inc = linuxcnc && !interp.absolute;
        // The radius: a CP keeps the one it starts at.
        let mut radius = here.map(|h| h.0);
        let mut after_radius = keyword;
        if !circle {
            let own = pol
                .radius
                .and_then(|(ti, _)| word(ti))
                .map(|(w, _)| w.style);
            let d = self.decimals(0, own.as_ref(), units);
            let half = lexeme::half_unit(d);
            match pol.radius {
                Some((ti, inc)) => {
                    let (w, orig) = match word(ti) {
                        Some(x) => x,
                        None => return [None, None],
                    };
                    after_radius = block.tokens[ti].span.end;
                    let base = if inc { here.map(|h| h.0) } else { Some(0.0) };
                    let Some(base) = base else {
                        return [None, None];
                    };
                    let new = r - base;
                    if (new - orig).abs() < half {
                        radius = Some(base + orig);
                    } else {
                        let v = round_to(new, d);
                        let st = w.style;
                        self.edits.replace_number(w.value_span, v, d, st, rules);
                        radius = Some(base + v);
                    }
                }
                None if here.is_none_or(|h| (r - h.0).abs() >= half) => {
                    let base = match here {
                        Some(h) if added_inc => h.0,
                        None if added_inc => return [None, None],
                        _ => 0.0,
                    };
                    let v = round_to(r - base, d);
                    self.edits
                        .insert(keyword, |b| polar_word(b, radius_word, v, d, style, rules));
                    radius = Some(base + v);
                }
                None => {}
            }
        }
        let Some(radius) = radius else {
            return [None, None];
        };
        // Enough decimals of a degree that half of the last one moves the
        // point by no more than half a unit of a coordinate.
        let d_lin = self.decimals(0, None, units);
        let reach = (radius * units.mm() * std::f64::consts::PI / 180.0).max(1e-9);
        let extra = reach.log10().ceil().max(0.0) as u8;
        let angle_word = pol.angle.and_then(|(ti, _)| word(ti));
        let d = angle_word
            .map_or(0, |(w, _)| w.style.decimals)
            .max(d_lin.saturating_add(extra))
            .min(MAX_DECIMALS);
        let half = lexeme::half_unit(d);
        let angle = match pol.angle {
            Some((_, inc)) => {
                let Some((w, orig)) = angle_word else {
                    return [None, None];
                };
                let base = if inc { here.map(|h| h.1) } else { Some(0.0) };
                let Some(base) = base else {
                    return [None, None];
                };
                // The same way round as written, whole turns and all.
                let mut new = a - base;
                new += 360.0 * ((orig - new) / 360.0).round();
                if (new - orig).abs() < half {
                    base + orig
                } else {
                    let v = round_to(new, d);
                    let st = w.style;
                    self.edits.replace_number(w.value_span, v, d, st, rules);
                    base + v
                }
            }
            None => {
                let Some((_, a0)) = here else {
                    return [None, None];
                };
                let mut new = a;
                new += 360.0 * ((a0 - new) / 360.0).round();
                if (new - a0).abs() < half {
                    a0
                } else {
                    let base = if added_inc { a0 } else { 0.0 };
                    let v = round_to(new - base, d);
                    self.edits.insert(after_radius, |b| {
                        polar_word(b, angle_word_name, v, d, style, rules)
                    });
                    base + v
                }
            }
        };
        let (s, c) = angle.to_radians().sin_cos();
        [Some(pole[0] + radius * c), Some(pole[1] + radius * s)]
    }

    /// HEIDENHAIN: inserts `CC X.. Y..` before the block.
    fn insert_pole(&mut self, block: &Block, c: [f64; 2], units: Units) {
        let d = self.decimals(0, None, units);
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
            ..NumStyle::default()
        };
        self.edits.insert(0, |b| {
            if let Some(n) = number {
                lexeme::push_u64(b, n.max(0) as u64);
                b.push(b' ');
            }
            b.extend_from_slice(b"CC X");
            lexeme::write(b, c[0], d, &style, rules);
            b.extend_from_slice(b" Y");
            lexeme::write(b, c[1], d, &style, rules);
            b.extend_from_slice(eol);
        });
        self.before += 1;
        self.inserted += 1;
        self.emit_pole = Some(c);
    }

    /// Writes a move as pieces: the block itself carries the first piece,
    /// the others follow as new blocks.
    #[allow(clippy::too_many_arguments)]
    fn write_pieces(
        &mut self,
        block: &Block,
        seg: &Segment,
        mv: &Move,
        f: &Frame,
        interp: &Interpreter,
        pieces: &[(f64, CorrectedPoint)],
        linearize: bool,
        sink: &mut Sink,
    ) {
        let rules = self.rules();
        let hh = self.heidenhain();
        // Turn the arc into a line.
        if linearize {
            let mut first_axis = None;
            // SINUMERIK's arc words of more than one letter: the radius
            // and a CIP's intermediate point.
            let long: &[Addr] = if self.dialect == Dialect::Sinumerik {
                &[
                    Addr::new("CR"),
                    Addr::new("I1"),
                    Addr::new("J1"),
                    Addr::new("K1"),
                ]
            } else {
                &[]
            };
            for (ti, w) in block.words(seg) {
                let l = w.addr.as_letter();
                let kill = if hh {
                    w.addr == Addr::new("DR") || w.addr == Addr::letter(b'R')
                } else {
                    matches!(l, Some(b'I' | b'J' | b'K' | b'R' | b'P')) || long.contains(&w.addr)
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
                    // A polar circle becomes a polar line: its first piece
                    // is written in its own polar words.
                    let kw: &[u8] = if mv.polar.is_some() { b"LP" } else { b"L" };
                    self.edits.replace(k.span, |b| b.extend_from_slice(kw));
                }
            } else if let Some(ti) = mv.motion_word {
                let TokenKind::Word(w) = block.tokens[ti].kind else {
                    return;
                };
                self.edits.replace(w.value_span, |b| b.push(b'1'));
            } else if let MoveKind::Through(Through {
                keyword: Some(ti), ..
            }) = mv.kind
            {
                let g: &[u8] = if lower(block, seg) { b"g1" } else { b"G1" };
                self.edits
                    .replace(block.tokens[ti].span, |b| b.extend_from_slice(g));
            } else {
                let at = first_axis.map_or(block.tokens[seg.body as usize].span.start, |ti| {
                    block.tokens[ti].span.start
                });
                let g = if lower(block, seg) { "g1 " } else { "G1 " };
                self.edits.insert(at, |b| b.extend_from_slice(g.as_bytes()));
            }
        }
        // The feed of each piece in inverse time: the block keeps its time.
        let inverse_time = !hh && interp.feed_mode == FeedMode::InverseTime;
        let feed = mv.feed;
        let mut u_prev = 0.0;
        let mut feed_for = |u: f64| -> Option<f64> {
            let r = feed.map(|(_, fv)| fv / (u - u_prev));
            u_prev = u;
            r
        };
        let (u_first, first) = pieces[0];
        let f_first = feed_for(u_first);
        self.linearizing = linearize;
        let emitted = self.write_words(block, seg, mv, f, interp, &first.program);
        self.linearizing = false;
        if inverse_time && let (Some((ti, _)), Some(fv)) = (feed, f_first) {
            let TokenKind::Word(w) = block.tokens[ti].kind else {
                return;
            };
            let style = w.style;
            let d = style.decimals.max(3);
            self.edits.replace_number(w.value_span, fv, d, style, rules);
        }
        self.emit = emitted;
        sink(&first, &emitted, pieces.len() > 1);
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
        let lower = lower(block, seg);
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
                lexeme::push_u64(&mut text, (n + 1 + self.after).max(0) as u64);
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
                    interp.units,
                );
                let half = lexeme::half_unit(d);
                let nv = round_to(p.program[a], d);
                let Some(pv) = prev[a] else { continue };
                if (p.program[a] - pv).abs() < half {
                    continue;
                }
                let inc = !hh && !interp.absolute;
                let val = if inc { round_to(nv - pv, d) } else { nv };
                if !first_word {
                    text.push(b' ');
                }
                first_word = false;
                let l = AXES[a];
                text.push(if lower { l.to_ascii_lowercase() } else { l });
                lexeme::write(&mut text, val, d, &self.style_of(block, mv, a), rules);
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
                lexeme::write(&mut text, fv, style.decimals.max(3), &style, rules);
            }
            if eob {
                if space_eob {
                    text.push(b' ');
                }
                text.push(b';');
            }
            self.emit = emitted;
            sink(p, &emitted, i != last);
            if hh {
                self.after += 1;
            }
            self.inserted += 1;
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
        if let Some(t) = toks.last().filter(|t| t.kind == TokenKind::Eob) {
            return t.span.end;
        }
        if self.heidenhain() {
            let n = block.text.len() - block.line_ending().map_or(0, |e| e.len());
            return n as u32;
        }
        toks.last().map_or(0, |t| t.span.end)
    }

    /// Decimals written for an axis: the settings' (two more in inches),
    /// or the lexeme's when it has more, up to [`MAX_DECIMALS`].
    fn decimals(&self, axis: usize, lexeme: Option<&NumStyle>, units: Units) -> u8 {
        let base = if axis < 3 {
            self.linear_decimals + if units == Units::Inch { 2 } else { 0 }
        } else {
            self.rotary_decimals
        };
        lexeme
            .map(|l| l.decimals)
            .unwrap_or(0)
            .max(base)
            .min(MAX_DECIMALS)
    }

    /// The style of a new word for `axis`: its own word's, another axis
    /// word's of the same kind, or the dialect's default.
    fn style_of(&self, block: &Block, mv: &Move, axis: usize) -> NumStyle {
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
                return s;
            }
        }
        // A word of the other kind still says how the control writes a
        // number: its decimal comma (older TNCs) and its sign.
        let other = (0..6).find_map(|a| mv.words[a].and_then(from));
        NumStyle {
            plus: other.map_or(self.heidenhain(), |o| o.plus),
            point: true,
            decimals: 3,
            comma: other.is_some_and(|o| o.comma),
            ..NumStyle::default()
        }
    }

    /// Writes an end point into the statement's own words (replacing
    /// values, adding words for axes whose written value changes); returns
    /// the position in force afterwards.
    fn write_words(
        &mut self,
        block: &Block,
        seg: &Segment,
        mv: &Move,
        f: &Frame,
        interp: &Interpreter,
        values: &[f64; 6],
    ) -> [Option<f64>; 6] {
        let prev = self.emit;
        let mut emitted = prev;
        let rules = self.rules();
        let lower = lower(block, seg);
        let mut inserts: [Option<(usize, f64, u8, NumStyle)>; 6] = [None; 6];
        // A hole: the bottom in force, and the level the cycle came from.
        let drill = mv.drill.map(|d| {
            let state = *self.emit_drill.get_or_insert([prev[d.axis], None]);
            (d, state)
        });
        if let Some((d, [_, depth])) = drill {
            emitted[d.axis] = depth;
        }
        for a in f.axes() {
            if a >= 3 && mv.vector.is_some() {
                // G43.5 programs the direction, not the rotary positions:
                // the controller turns the axes to the ones it solves for
                // the written direction, the written point's.
                emitted[a] = Some(values[a]);
                continue;
            }
            if a < 2 && mv.polar.is_some() {
                continue;
            }
            // A HEIDENHAIN cycle call's tool-axis word is the datum its
            // depth counts from: the word moves with the bottom.
            let offset = match drill {
                Some((d, _)) if d.axis == a => d.call_offset.unwrap_or(0.0),
                _ => 0.0,
            };
            let v = values[a] - offset;
            // A cycle block without the depth word drills to the depth in
            // force, not from where the tool is.
            let prev_a = match drill {
                Some((d, [_, depth])) if d.axis == a => depth,
                _ => prev[a],
            };
            match mv.words[a] {
                Some(ti) => {
                    let TokenKind::Word(w) = block.tokens[ti].kind else {
                        continue;
                    };
                    let d = self.decimals(a, Some(&w.style), interp.units);
                    let half = lexeme::half_unit(d);
                    let inc = mv.incremental[a];
                    let (Some(e_end), Some(s)) = (mv.end[a], mv.start[a].or(Some(0.0))) else {
                        continue;
                    };
                    let e_end = e_end - offset;
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
                            .replace_number(w.value_span, new, d, style, rules);
                        emitted[a] = Some(base + new);
                    }
                }
                None => {
                    let d = self.decimals(a, None, interp.units);
                    let half = lexeme::half_unit(d);
                    let Some(pv) = prev_a else { continue };
                    let nv = round_to(v, d);
                    if (v - pv).abs() >= half {
                        let inc = !self.heidenhain() && !interp.absolute;
                        let val = if inc { round_to(nv - pv, d) } else { nv };
                        inserts[a] = Some((a, val, d, self.style_of(block, mv, a)));
                        emitted[a] = Some(if inc { pv + val } else { nv });
                    }
                }
            }
        }
        if let Some(pol) = &mv.polar {
            let [x, y] = self.write_polar(block, seg, mv, interp, pol, values, &prev);
            emitted[0] = x;
            emitted[1] = y;
        }
        if let Some((d, [initial, _])) = drill {
            // The depth now in force, and where the cycle leaves the tool.
            self.emit_drill = Some([initial, emitted[d.axis]]);
            self.drill_written = true;
            emitted[d.axis] = match initial {
                // The cycle's own clearance: not followed.
                _ if d.call_offset.is_some() => None,
                Some(z) if d.to_initial => Some(z.max(d.r_level)),
                _ if d.to_initial => None,
                _ => Some(d.r_level),
            };
        }
        if inserts.iter().any(|i| i.is_some()) {
            let polar = mv
                .polar
                .iter()
                .flat_map(|p| [p.radius, p.angle])
                .flatten()
                .map(|(ti, _)| ti);
            let last = (0..6)
                .filter_map(|a| mv.words[a])
                .chain(polar)
                .map(|ti| block.tokens[ti].span.end)
                .max()
                .unwrap_or(block.tokens[seg.body as usize].span.start);
            self.edits.insert(last, |b| {
                for (a, val, d, style) in inserts.iter().flatten() {
                    b.push(b' ');
                    let l = AXES[*a];
                    b.push(if lower { l.to_ascii_lowercase() } else { l });
                    lexeme::write(b, *val, *d, style, rules);
                }
            });
        }
        emitted
    }
}

/// Whether the statement writes its words in lower case.
fn lower(block: &Block, seg: &Segment) -> bool {
    block.words(seg).next().is_some_and(|(ti, _)| {
        block.text[block.tokens[ti].span.start as usize].is_ascii_lowercase()
    })
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

/// A polar word the block did not have (` PR..`, ` PA..`), written with
/// `d` decimals in the style of the block's other numbers.
fn polar_word(b: &mut Vec<u8>, word: &[u8], v: f64, d: u8, style: NumStyle, rules: WriteRules) {
    b.extend_from_slice(word);
    lexeme::write(
        b,
        v,
        d,
        &NumStyle {
            decimals: d,
            ..style
        },
        rules,
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compensate::Compensator;
    use crate::kinematics::Kinematics;
    use crate::machine::Machine;
    use crate::model::Model;
    use crate::nc::Syntax;

    fn block(text: &str) -> Block {
        Syntax {
            dialect: Dialect::Fanuc,
            strict: false,
        }
        .block(text)
        .unwrap()
    }

    /// A change of frame the writer cannot map exactly (one axis of the
    /// rewrite's position unknown) must not hand a corrected axis the
    /// program's value: the next incremental word would be written from
    /// there, off by the correction.
    #[test]
    fn a_frame_change_not_followed_exactly_forgets_a_corrected_axis_it_moves() {
        let kin = Kinematics::new(&Machine::builtin("bc-trunnion").unwrap());
        let model = Model::new(kin, vec![]);
        let settings = Settings::new(Dialect::Fanuc);
        let c = Compensator::new(&model, &[], settings.clone());
        let mut interp = c.interpreter();
        let mut w = Writer::new(&settings);
        let first = block("G90 G54 G0 X10. Y5. Z50. B0. C0.\n");
        for seg in &first.segments {
            interp.step(&first, seg);
        }
        assert_eq!(interp.pos[0], Some(10.0));
        // Where the rewrite put the tool: X and Z corrected, Y unknown.
        w.emit = [
            Some(10.02),
            None,
            Some(49.99),
            Some(0.0),
            Some(0.0),
            Some(0.0),
        ];
        let shift = block("G52 X5.\n");
        let before = interp.pos;
        let frame_before = interp.frame();
        for seg in &shift.segments {
            interp.step(&shift, seg);
            let to = interp.frame();
            w.reframe(&shift, seg, &interp, &to, (&before, &frame_before));
        }
        assert_eq!(interp.pos[0], Some(5.0), "G52 X5. shifts the program's X");
        assert_eq!(
            w.emit[0], None,
            "X: the program's 5 would drop the 0.02 correction"
        );
        assert_eq!(
            w.emit[2],
            Some(49.99),
            "Z is not shifted: its correction stays"
        );
    }
}
