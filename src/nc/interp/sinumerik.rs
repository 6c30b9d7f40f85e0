//! SINUMERIK semantics: the G groups (motion, plane, units G70/G71/G700/
//! G710, G90/G91, feed mode, settable work offsets G54..G57 and
//! G505..G599, G500), per-word absolute and incremental values (`X=AC()`,
//! `X=IC()`), arcs with incremental or `=AC()` centres and `CR=` radii,
//! tool offsets (`D0` off, `D1`.. on), TRAORI / TRAFOOF with rotary
//! positions or `A3= B3= C3=` tool vectors, CYCLE800 swivel planes,
//! programmable frames (`TRANS`/`ATRANS` followed; `ROT`, `SCALE`,
//! `MIRROR`, `PAROT`, `TOROT` not modelled), blocks in machine coordinates
//! (`SUPA`, `G53`, `G153`), probing (`MEAS=`, `MEAW=`), cycles and
//! subprogram calls (the position is unknown after them).

use super::{
    AXES, Arc, Event, FeedMode, Interpreter, Motion, Move, MoveKind, Plane, Skip, Tcp, Units,
    arc_runs, center_from_radius,
};
use crate::nc::interp::gcode::g_code;
use crate::nc::{Addr, Block, Flow, Segment, Stmt, TokenKind, Value, Word};

/// Programmable frame statements: their axis words are frame values.
const FRAMES: [&str; 12] = [
    "TRANS", "ATRANS", "ROT", "AROT", "ROTS", "AROTS", "CROTS", "SCALE", "ASCALE", "MIRROR",
    "AMIRROR", "RPL",
];

/// Commands that move no axis and change nothing fivecal models.
const QUIET_COMMANDS: [&str; 52] = [
    "STOPRE", "FNORM", "FFWON", "FFWOF", "SOFT", "BRISK", "DRIVE", "COMPOF", "COMPON", "COMPCURV",
    "COMPCAD", "ORIWKS", "ORIMKS", "ORIAXES", "ORIVECT", "ORIPLANE", "ORICONO", "CFC", "CFTCP",
    "CFIN", "UPATH", "SPATH", "DISPLOF", "DISPLON", "SAVE", "MSG", "WRITE", "DELETE", "SETAL",
    "SETMS", "CYCLE832", "G642", "M17", "ENAT", "TNAT", "CUT2D", "CUT3DC", "CUT3DF", "CDON",
    "CDOF", "CDOF2", "DIAMOF", "WALIMON", "WALIMOF", "OFFN", "TRAILOF", "SPOS", "SPOSA", "GWPSON",
    "GWPSOF", "EXTCLOSE", "EXTOPEN",
];

/// `=AC()` (absolute) or `=IC()` (incremental) written around a word's
/// literal, read from the bytes before its lexeme; `None` for a bare value.
fn written_mode(block: &Block, w: &Word) -> Option<bool> {
    if w.incremental {
        return Some(true);
    }
    let before = &block.text[..w.value_span.start as usize];
    let upper: Vec<u8> = before
        .iter()
        .rev()
        .take(4)
        .map(u8::to_ascii_uppercase)
        .collect();
    let ends = |f: &[u8]| upper.len() >= f.len() && upper[..f.len()].iter().rev().eq(f.iter());
    (ends(b"AC(") || ends(b"DC(") || ends(b"ACP(") || ends(b"ACN(")).then_some(false)
}

/// What a block `IF` leaves known: the state it was entered with, and
/// where its `THEN` part ended once an `ELSE` follows.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Branch {
    entered: Known,
    then_end: Option<Known>,
}

/// The part of the state a branch may change: positions and the modal
/// state that says what they mean.
type Known = (
    [Option<f64>; 6],
    (
        bool,
        Units,
        u32,
        bool,
        Tcp,
        bool,
        [f64; 3],
        Option<&'static str>,
    ),
);

impl Interpreter {
    /// One SINUMERIK statement.
    pub(super) fn sinumerik(&mut self, block: &Block, seg: &Segment) -> Event {
        match seg.stmt {
            Stmt::Words => self.si_words(block, seg),
            Stmt::Flow(Flow::Branch) => {
                self.si_branch(block, seg);
                Event::None
            }
            Stmt::Flow(_) => {
                // Jumps, loops, calls: the state at run time is not known
                // statically, and an open IF cannot be followed through.
                self.branches.clear();
                self.forget();
                Event::None
            }
            _ => Event::None,
        }
    }

    fn known(&self) -> Known {
        (
            self.pos,
            (
                self.absolute,
                self.units,
                self.work_offset,
                self.tool_length,
                self.tcp,
                self.tilted,
                self.local_shift,
                self.transformed,
            ),
        )
    }

    /// A block `IF`, `ELSE` or `ENDIF`: after `ENDIF` the position stays
    /// known when every way through the branch leaves the same state (the
    /// typical check of a measuring block, whose body only raises an
    /// alarm); otherwise it is forgotten.
    fn si_branch(&mut self, block: &Block, seg: &Segment) {
        let kw = block
            .seg_tokens(seg)
            .iter()
            .find(|t| t.kind == TokenKind::Keyword)
            .map(|t| block.bytes(t.span).to_ascii_uppercase())
            .unwrap_or_default();
        match kw.as_slice() {
            b"IF" => {
                let entered = self.known();
                self.branches.push(Branch {
                    entered,
                    then_end: None,
                });
            }
            b"ELSE" => {
                let now = self.known();
                match self.branches.last_mut() {
                    Some(b) if b.then_end.is_none() => {
                        b.then_end = Some(now);
                        self.pos = b.entered.0;
                    }
                    _ => {
                        self.branches.clear();
                        self.forget();
                    }
                }
            }
            _ => {
                let now = self.known();
                match self.branches.pop() {
                    Some(b) if b.then_end.as_ref().unwrap_or(&b.entered) == &now => {}
                    _ => {
                        self.branches.clear();
                        self.forget();
                    }
                }
            }
        }
    }

    fn si_words(&mut self, block: &Block, seg: &Segment) -> Event {
        // Commands first: they say what the block's words mean.
        let mut frame: Option<String> = None;
        let mut machine = false;
        let mut probing = false;
        let mut call = false;
        let mut cycle = false;
        let old = (
            self.work_offset,
            self.tool_length,
            self.tcp,
            self.tilted,
            self.units,
        );
        let toks = block.seg_tokens(seg);
        for (k, t) in toks.iter().enumerate() {
            if t.kind != TokenKind::Keyword {
                continue;
            }
            let name = String::from_utf8_lossy(block.bytes(t.span)).to_ascii_uppercase();
            let args = toks
                .get(k + 1)
                .filter(|a| a.kind == TokenKind::Text)
                .map(|a| block.bytes(a.span));
            let offset = t.span.start as usize;
            match name.as_str() {
                "TRAORI" => {
                    self.tool_length = true;
                    self.tcp = Tcp::Axes;
                }
                "TRAFOOF" => self.tcp = Tcp::Off,
                "CYCLE800" => {
                    let text = args.map(|a| String::from_utf8_lossy(a).into_owned());
                    self.cycle800(block.line, offset, text.as_deref().unwrap_or(""));
                }
                "SUPA" => machine = true,
                "CIP" | "CT" | "POLY" | "ASPLINE" | "BSPLINE" | "CSPLINE" => {
                    self.motion = Some(Motion::Other)
                }
                "PAROT" | "TOROT" | "TOFRAME" | "TOROTX" | "TOROTY" | "TOROTZ" => {
                    self.transformed =
                        Some("a frame turned with the table or tool (PAROT/TOROT/TOFRAME)");
                    self.forget();
                }
                "PAROTOF" | "TOROTOF" => {
                    self.cancel("a frame turned with the table or tool (PAROT/TOROT/TOFRAME)");
                    self.forget();
                }
                "MCALL" => {
                    if args.is_some() || toks[k + 1..].iter().any(|t| t.kind == TokenKind::Keyword)
                    {
                        self.transformed = Some("a modal subprogram call (MCALL)");
                    } else {
                        self.cancel("a modal subprogram call (MCALL)");
                    }
                }
                n if FRAMES.contains(&n) => frame = Some(n.to_string()),
                n if QUIET_COMMANDS.contains(&n) => {}
                n if n.starts_with("CYCLE") => cycle = true,
                _ => {
                    // A subprogram (by name or with a parameter list) or a
                    // command fivecal does not know: where the axes are
                    // afterwards is not known.
                    call = true;
                    self.note(
                        offset,
                        format!(
                            "`{name}`: a subprogram call or a command fivecal does not model (the position is taken as unknown after it)"
                        ),
                    );
                }
            }
        }
        let mut g_nonmodal: Option<u32> = None;
        let mut motion_word = None;
        let mut motion_here: Option<Motion> = None;
        let mut has_axis = false;
        let mut expr_g = false;
        for (ti, w) in block.words(seg) {
            let a = w.addr;
            if a == Addr::new("MEAS") || a == Addr::new("MEAW") {
                probing = true;
                continue;
            }
            let Some(letter) = a.as_letter() else {
                continue;
            };
            match letter {
                b'G' => {
                    let Value::Num(v) = w.value else {
                        expr_g = true;
                        continue;
                    };
                    let Some(g) = g_code(v) else { continue };
                    match g {
                        0 | 10 | 20 | 30 => {
                            motion_here = Some(match g {
                                0 => Motion::Rapid,
                                10 => Motion::Linear,
                                20 => Motion::ArcCw,
                                _ => Motion::ArcCcw,
                            });
                            motion_word = Some(ti);
                        }
                        50 | 330 | 340 | 350 | 3310 | 3320 => {
                            motion_here = Some(Motion::Other);
                            motion_word = Some(ti);
                        }
                        // Dwell, working-area limits, reference and fixed points.
                        40 | 250 | 260 | 740 | 750 => g_nonmodal = Some(g),
                        530 | 1530 => machine = true,
                        170 => self.plane = Plane::Xy,
                        180 => self.plane = Plane::Zx,
                        190 => self.plane = Plane::Yz,
                        700 | 7000 => self.units = Units::Inch,
                        710 | 7100 => self.units = Units::Mm,
                        900 => {
                            self.absolute = true;
                            self.state_unknown = None;
                        }
                        910 => {
                            self.absolute = false;
                            self.state_unknown = None;
                        }
                        930 => self.feed_mode = FeedMode::InverseTime,
                        940 => self.feed_mode = FeedMode::PerMinute,
                        950 => self.feed_mode = FeedMode::PerRev,
                        400 => self.radius_comp = false,
                        410 | 420 => self.radius_comp = true,
                        5000 => self.work_offset = 5000,
                        540 | 550 | 560 | 570 => self.work_offset = g,
                        5050..=5990 => self.work_offset = g,
                        1100..=1120 => {
                            self.transformed = Some("polar coordinates (G110-G112, AP=, RP=)")
                        }
                        _ => {}
                    }
                }
                b'M' => {
                    if let Value::Num(v) = w.value {
                        let m = v.round() as u32;
                        self.m_function(m, block.tokens[ti].span.start as usize);
                        if matches!(m, 6 | 17 | 2 | 30) {
                            // A tool change moves the axes where the machine
                            // has its change position.
                            call = true;
                        }
                    }
                }
                b'D' => {
                    if let Value::Num(v) = w.value {
                        self.tool_length = v != 0.0;
                    }
                }
                b'F' => {
                    if let Value::Num(v) = w.value {
                        self.feed = Some(v);
                    }
                }
                b'L' => call = true,
                _ => {
                    if self.axis_index(a).is_some() {
                        has_axis = true;
                    }
                }
            }
        }
        let now = (
            self.work_offset,
            self.tool_length,
            self.tcp,
            self.tilted,
            self.units,
        );
        if now != old {
            // The same numbers mean another place now; the rotary axes
            // stay where they are (their positions are machine positions
            // whatever the frame: no work offset has a rotary part, each
            // lies on the W origin at rotary zero).
            let rotary = [self.pos[3], self.pos[4], self.pos[5]];
            self.forget();
            self.pos[3..].copy_from_slice(&rotary);
        }
        if let Some(m) = motion_here {
            self.motion = Some(m);
        }
        if let Some(f) = frame {
            self.si_frame(block, seg, &f);
            return Event::None;
        }
        if expr_g {
            self.forget();
            self.motion = None;
            return if has_axis {
                Event::Skip(Skip::Expression)
            } else {
                Event::None
            };
        }
        if machine || probing || g_nonmodal.is_some_and(|g| g == 740 || g == 750) {
            if machine && !probing && g_nonmodal.is_none() {
                let absolute = self.absolute;
                self.machine_move(block, seg, |b, w| {
                    written_mode(b, w).map_or(absolute, |inc| !inc)
                });
            } else {
                self.forget_named(block, seg);
            }
            if call {
                self.forget();
            }
            return if has_axis || probing {
                Event::Quiet
            } else {
                Event::None
            };
        }
        if g_nonmodal.is_some() {
            return Event::None;
        }
        if cycle {
            self.forget();
            return Event::Skip(Skip::CannedCycle);
        }
        if call {
            self.forget();
            return if has_axis {
                Event::Skip(Skip::MacroCall)
            } else {
                Event::None
            };
        }
        if !has_axis {
            if let Some(u) = seg.unknown {
                let word = String::from_utf8_lossy(block.bytes(u)).into_owned();
                self.note(
                    u.start as usize,
                    format!("`{word}`: a word fivecal does not know (taken to move no axis)"),
                );
            }
            return Event::None;
        }
        match self.motion {
            Some(m @ (Motion::Rapid | Motion::Linear | Motion::ArcCw | Motion::ArcCcw)) => {
                self.si_move(block, seg, m, motion_word)
            }
            Some(Motion::Other) => {
                self.track_words(block, seg);
                Event::Skip(Skip::Element(
                    "a CIP, CT, POLY, spline, thread or tapping motion",
                ))
            }
            None => {
                self.track_words(block, seg);
                Event::Skip(Skip::Element("motion without a motion mode"))
            }
        }
    }

    /// CYCLE800: the swivel plane, and the rotary positions the cycle
    /// turns to (its `_DIR` names the preferred sign of the tilt; the
    /// other solution when that one is out of the stroke; 0 leaves the
    /// axes where they are). An additive swivel is built in the axes of
    /// the plane in force, as a further frame on top of it: reference
    /// point, rotation about the turned axes and zero point after it.
    fn cycle800(&mut self, line: usize, at: usize, args: &str) {
        use super::plane::Swivel;
        let (rot, abc, before, after, dir, additive) = match super::plane::cycle800(args) {
            Ok(Swivel::Reset) => {
                if self.tilted {
                    self.set_plane(None);
                }
                return;
            }
            Ok(Swivel::Plane {
                rot,
                abc,
                before,
                after,
                dir,
                additive,
            }) => (rot, abc, before, after, dir, additive),
            Err(why) => return self.plane_unmodelled(line, at, why),
        };
        if self.local_shift != [0.0; 3] || self.shift != [0.0; 3] {
            // fivecal follows TRANS as a shift added after the plane.
            return self.plane_unmodelled(line, at, "CYCLE800 on a programmable frame (TRANS)");
        }
        let t = self.cfg.tilt;
        let direct = rot.is_none();
        let rot = match rot {
            Some(r) => r,
            None => match super::plane::axial(&self.cfg.kin, t, abc.map(Some)) {
                Ok(r) => r,
                Err(why) => return self.plane_unmodelled(line, at, why),
            },
        };
        let mut plane = super::WorkPlane {
            rot,
            origin: before + rot * after,
        };
        if additive {
            match self.working_plane {
                Some(super::Tilt::Plane(w)) => {
                    plane = super::WorkPlane {
                        rot: w.rot * plane.rot,
                        origin: w.to_workpiece(&plane.origin),
                    };
                }
                Some(super::Tilt::Unmodelled { .. }) => {
                    return self.plane_unmodelled(
                        line,
                        at,
                        "an additive CYCLE800 on a plane fivecal does not model",
                    );
                }
                None => {}
            }
        }
        self.set_plane(Some(super::Tilt::Plane(plane)));
        if direct && dir != 0.0 {
            self.pos[t] = Some(abc[t - 3]);
            self.pos[5] = Some(abc[2]);
        } else if dir != 0.0 {
            let choice = super::plane::Choice::Sign {
                sign: dir.signum(),
                strict: false,
            };
            self.position_for_plane(line, at, choice);
        }
    }

    /// `TRANS`/`ATRANS` shift the zero point by the block's axis values
    /// (followed); the other frame statements turn, scale or mirror it
    /// (not modelled) or, written alone, cancel their part.
    fn si_frame(&mut self, block: &Block, seg: &Segment, name: &str) {
        const ROTATION: &str =
            "a programmable frame rotation, scaling or mirroring (ROT, SCALE, MIRROR)";
        let mut vals = [None::<f64>; 3];
        let mut any = false;
        let mut unknown = false;
        let mut nonzero = false;
        for (_, w) in block.words(seg) {
            let Some(i) = self.axis_index(w.addr) else {
                continue;
            };
            any = true;
            match self.axis_value(&w) {
                Ok(v) => {
                    nonzero |= v != 0.0;
                    if i < 3 {
                        vals[i] = Some(v);
                    }
                }
                Err(_) => unknown = true,
            }
        }
        let absolute = !name.starts_with('A');
        let old = self.local_shift;
        if self.tilted && any {
            let at = block.tokens[seg.body as usize].span.start as usize;
            return self.plane_unmodelled(
                block.line,
                at,
                "a programmable frame inside the swivel plane",
            );
        }
        match name {
            "TRANS" | "ATRANS" => {
                if absolute {
                    // An absolute frame statement replaces the whole
                    // programmable frame.
                    self.cancel(ROTATION);
                    self.local_shift = [0.0; 3];
                }
                if self.transformed.is_some() && !absolute {
                    // Along turned axes: the shift is not along X, Y, Z.
                    self.forget();
                }
                for (shift, v) in self.local_shift.iter_mut().zip(vals) {
                    if let Some(v) = v {
                        *shift += v;
                    }
                }
                if unknown {
                    self.shift_known = false;
                } else if absolute {
                    self.shift_known = true;
                }
            }
            _ => {
                if absolute {
                    self.local_shift = [0.0; 3];
                    self.cancel(ROTATION);
                }
                if any && (nonzero || unknown) || name == "RPL" {
                    self.transformed = Some(ROTATION);
                }
                self.forget();
            }
        }
        for ((p, o), n) in self.pos.iter_mut().zip(old).zip(self.local_shift) {
            if let Some(v) = p {
                *v += o - n;
            }
        }
    }

    fn si_move(
        &mut self,
        block: &Block,
        seg: &Segment,
        motion: Motion,
        motion_word: Option<usize>,
    ) -> Event {
        let start = self.pos;
        let mut mv = Move::new(MoveKind::Rapid, start, !self.absolute);
        mv.motion_word = motion_word;
        let mut skip: Option<Skip> = seg.unknown.map(|_| Skip::UnknownWord);
        let mut ijk: [Option<(usize, f64, bool)>; 3] = [None; 3];
        let mut vector: [Option<(usize, f64)>; 3] = [None; 3];
        let mut cr: Option<(usize, f64)> = None;
        for (ti, w) in block.words(seg) {
            let mode = written_mode(block, &w);
            if let Some(i) = self.axis_index(w.addr) {
                mv.words[i] = Some(ti);
                if !self.machine_axis(i) {
                    skip.get_or_insert(Skip::UnknownAxis(AXES[i]));
                }
                let inc = mode.unwrap_or(!self.absolute);
                mv.incremental[i] = inc;
                match self.axis_value(&w) {
                    Ok(v) => {
                        mv.end[i] = if inc {
                            start[i].map(|p| p + v)
                        } else {
                            Some(v)
                        }
                    }
                    Err(s) => {
                        mv.end[i] = None;
                        skip.get_or_insert(s);
                    }
                }
                continue;
            }
            let a = w.addr;
            if let Some(k) = [Addr::new("A3"), Addr::new("B3"), Addr::new("C3")]
                .iter()
                .position(|x| *x == a)
            {
                match w.value {
                    Value::Num(v) => vector[k] = Some((ti, v)),
                    _ => {
                        skip.get_or_insert(Skip::Expression);
                    }
                }
                continue;
            }
            if a == Addr::new("CR") {
                match self.axis_value(&w) {
                    Ok(v) => cr = Some((ti, v)),
                    Err(s) => {
                        skip.get_or_insert(s);
                    }
                }
                continue;
            }
            if a == Addr::new("AR") {
                skip.get_or_insert(Skip::Element("an arc by opening angle (AR=)"));
                continue;
            }
            match a.as_letter() {
                Some(l @ (b'I' | b'J' | b'K')) => {
                    let k = (l - b'I') as usize;
                    match self.axis_value(&w) {
                        Ok(v) => ijk[k] = Some((ti, v, mode == Some(false))),
                        Err(s) => {
                            skip.get_or_insert(s);
                        }
                    }
                }
                Some(b'F') => {
                    if let Value::Num(v) = w.value {
                        mv.feed = Some((ti, v));
                    } else if self.feed_mode == FeedMode::InverseTime {
                        skip.get_or_insert(Skip::Expression);
                    }
                }
                Some(l @ (b'U' | b'V' | b'W')) => {
                    skip.get_or_insert(Skip::UnknownAxis(l));
                }
                _ => {}
            }
        }
        self.pos = mv.end;
        // The writer writes centres as the block has them.
        self.arc_absolute = false;
        mv.kind = match motion {
            Motion::Rapid => MoveKind::Rapid,
            Motion::Linear => MoveKind::Linear,
            _ => {
                let cw = motion == Motion::ArcCw;
                let (a, b, _) = self.plane.axes();
                let (Some(s0), Some(s1), Some(e0), Some(e1)) =
                    (start[a], start[b], mv.end[a], mv.end[b])
                else {
                    return Event::Skip(skip.unwrap_or(Skip::PositionUnknown(
                        AXES[if start[a].is_none() || mv.end[a].is_none() {
                            a
                        } else {
                            b
                        }],
                    )));
                };
                let center = if let Some((_, r)) = cr {
                    match center_from_radius([s0, s1], [e0, e1], r, cw) {
                        Some(c) => c,
                        None => {
                            return Event::Skip(skip.unwrap_or(Skip::Element(
                                "an arc whose radius does not reach its end point",
                            )));
                        }
                    }
                } else {
                    let (ca, cb) = (ijk[a], ijk[b]);
                    let abs = [ca.is_some_and(|x| x.2), cb.is_some_and(|x| x.2)];
                    if abs[0] != abs[1] {
                        return Event::Skip(skip.unwrap_or(Skip::Element(
                            "an arc centre given partly =AC() and partly incremental",
                        )));
                    }
                    let c = if abs[0] {
                        self.arc_absolute = true;
                        [ca.map_or(s0, |x| x.1), cb.map_or(s1, |x| x.1)]
                    } else {
                        [s0 + ca.map_or(0.0, |x| x.1), s1 + cb.map_or(0.0, |x| x.1)]
                    };
                    if !arc_runs([s0, s1], [e0, e1], c, self.units.mm()) {
                        return Event::Skip(skip.unwrap_or(Skip::Element(
                            "off-circle arc (its centre I, J, K not as far from the end as from the start)",
                        )));
                    }
                    c
                };
                MoveKind::Arc(Arc {
                    plane: self.plane,
                    cw,
                    center,
                    turns: 0,
                    center_words: [
                        ijk[0].map(|x| x.0),
                        ijk[1].map(|x| x.0),
                        ijk[2].map(|x| x.0),
                    ],
                    radius_word: cr.map(|x| x.0),
                })
            }
        };
        if let Some(s) = skip.or_else(|| self.frame_skip()) {
            return Event::Skip(s);
        }
        if vector.iter().any(Option::is_some) {
            // TRAORI with the tool direction: missing components are zero.
            if self.tcp == Tcp::Off || matches!(mv.kind, MoveKind::Arc(_)) {
                return Event::Skip(Skip::Element(
                    "a tool vector (A3= B3= C3=) outside TRAORI or on an arc",
                ));
            }
            mv.tool_vector = Some((
                [
                    vector[0].map_or(0.0, |x| x.1),
                    vector[1].map_or(0.0, |x| x.1),
                    vector[2].map_or(0.0, |x| x.1),
                ],
                [
                    vector[0].map(|x| x.0),
                    vector[1].map(|x| x.0),
                    vector[2].map(|x| x.0),
                ],
            ));
            if self.settings().coordinates != super::Coordinates::Axes {
                return self.resolve_vector(mv);
            }
        }
        Event::Move(mv)
    }
}
