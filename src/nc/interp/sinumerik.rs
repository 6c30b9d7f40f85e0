//! SINUMERIK semantics: the G groups (motion, plane, units G70/G71/G700/
//! G710, G90/G91, feed mode, settable work offsets G54..G57 and
//! G505..G599, G500), per-word absolute and incremental values (`X=AC()`,
//! `X=IC()`), arcs with incremental or `=AC()` centres and `CR=` radii,
//! circles through an intermediate point in space (`CIP`),
//! tool offsets (`D0` off, `D1`.. on), TRAORI / TRAFOOF with rotary
//! positions or `A3= B3= C3=` tool vectors, CYCLE800 swivel planes,
//! programmable frames (`TRANS`/`ATRANS`, `ROT`/`AROT` with `X Y Z`
//! angles or `RPL=` in the working plane, `ROTS`/`AROTS` by solid angles,
//! composed into one frame `R p + t`, tool vectors turned with it;
//! `SCALE`, `MIRROR`, `CROTS`, `PAROT`, `TOROT` not modelled; a CYCLE800
//! on a programmable frame, a frame inside a swivel plane and TRAORI
//! inside one are left as written with the reason),
//! blocks in machine coordinates (`SUPA`, `G53`, `G153`), probing
//! (`MEAS=`, `MEAW=`), cycles and subprogram calls (the position is
//! unknown after them).

use super::ReasonKind;
use super::interpolation::CircleGeo;
use super::{
    AXES, Arc, ArcPlane, Event, FeedMode, Interpreter, Motion, Move, MoveKind, Skip, Tcp, Through,
    Units, Unmodelled, arc_runs, center_from_radius,
};
use crate::nc::interp::gcode::g_code;
use crate::nc::{Addr, Block, Flow, Segment, Stmt, TokenKind, Value, Word};

/// Programmable frame statements: their axis words are frame values.
const FRAMES: [&str; 12] = [
    "TRANS", "ATRANS", "ROT", "AROT", "ROTS", "AROTS", "CROTS", "SCALE", "ASCALE", "MIRROR",
    "AMIRROR", "RPL",
];

/// Programmable frames fivecal does not model, by why.
const FRAME_SCALING: &str = "a programmable frame scaling or mirroring (SCALE, MIRROR)";
const FRAME_SOLID: &str =
    "a frame rotation CROTS (it turns the frame in the data management: not modelled)";
const FRAME_ROTARY: &str = "a programmable frame on a rotary axis (TRANS/ROT with A, B or C)";
const FRAME_PARAMETER: &str = "a programmable frame rotation by a parameter or an expression";
const FRAME_RPL_AND_AXES: &str = "a programmable frame rotation with RPL= and axis angles together";
const FRAME_SOLID_RPL: &str = "a solid-angle frame rotation (ROTS/AROTS) with RPL=";
const FRAME_VECTOR_MKS: &str =
    "tool vectors (A3= B3= C3=) in the machine coordinate system (ORIMKS: not modelled)";
const UNMODELLED_FRAMES: [&str; 8] = [
    FRAME_SCALING,
    FRAME_SOLID,
    FRAME_ROTARY,
    FRAME_PARAMETER,
    FRAME_RPL_AND_AXES,
    FRAME_SOLID_RPL,
    super::plane::SOLID_THREE,
    super::plane::SOLID_STEEP,
];

/// The value of `RPL=` in a frame statement (`ROT RPL=30`: the turn in the
/// plane), `Some(None)` when it is not a number.
fn plane_rotation(block: &Block, seg: &Segment) -> Option<Option<f64>> {
    let toks = block.seg_tokens(seg);
    let at = toks.iter().position(|t| {
        t.kind == TokenKind::Param && block.bytes(t.span).eq_ignore_ascii_case(b"RPL")
    })?;
    let value = toks[at + 1..]
        .iter()
        .find(|t| t.kind == TokenKind::Expr)
        .map(|t| {
            String::from_utf8_lossy(block.bytes(t.span))
                .trim()
                .to_string()
        });
    Some(value.and_then(|v| v.parse::<f64>().ok().filter(|v| v.is_finite())))
}

/// Commands that move no axis and change nothing fivecal models.
const QUIET_COMMANDS: [&str; 50] = [
    "STOPRE", "FNORM", "FFWON", "FFWOF", "SOFT", "BRISK", "DRIVE", "COMPOF", "COMPON", "COMPCURV",
    "COMPCAD", "ORIAXES", "ORIVECT", "ORIPLANE", "ORICONO", "CFC", "CFTCP", "CFIN", "UPATH",
    "SPATH", "DISPLOF", "DISPLON", "SAVE", "MSG", "WRITE", "DELETE", "SETAL", "SETMS", "CYCLE832",
    "G642", "M17", "ENAT", "TNAT", "CUT2D", "CUT3DC", "CUT3DF", "CDON", "CDOF", "CDOF2", "DIAMOF",
    "WALIMON", "WALIMOF", "OFFN", "TRAILOF", "SPOS", "SPOSA", "GWPSON", "GWPSOF", "EXTCLOSE",
    "EXTOPEN",
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
        bool,
    ),
    nalgebra::Matrix3<f64>,
);

/// The drilling cycles that end on the hole's axis at their retraction
/// plane RTP, their first parameter: drilling/centring, drilling/counter-
/// boring and deep-hole drilling ("retraction to the retraction plane
/// with G0", SINUMERIK 840D cycles programming guide, CYCLE81-CYCLE83).
const DRILLING_CYCLES: [&[u8]; 3] = [b"CYCLE81", b"CYCLE82", b"CYCLE83"];

/// RTP, the first parameter of a drilling cycle's list `(RTP, RFP, ...)`,
/// when it is written as a number.
fn retraction_plane(args: &str) -> Option<f64> {
    let inner = args.trim().strip_prefix('(')?;
    let first = inner.split([',', ')']).next()?.trim();
    first.parse::<f64>().ok().filter(|v| v.is_finite())
}

/// What the commands and words of one block say, gathered before
/// anything moves.
#[derive(Default)]
struct SiScan {
    frame: Option<String>,
    machine: bool,
    probing: bool,
    call: bool,
    cycle: bool,
    g_nonmodal: Option<u32>,
    motion_word: Option<usize>,
    motion_here: Option<Motion>,
    /// The token of a `CIP` command.
    cip: Option<usize>,
    has_axis: bool,
    expr_g: bool,
    /// The block is an `MCALL`: the cycle named after it is defined for
    /// the blocks that follow, not run here.
    mcall: bool,
    /// A drilling cycle called in this block, with its retraction plane.
    drill_rtp: Option<f64>,
}

impl Interpreter {
    /// One SINUMERIK statement.
    pub(super) fn sinumerik(&mut self, block: &Block, seg: &Segment) -> Event {
        match seg.stmt {
            Stmt::Words => {
                self.si_frame_data(block, seg);
                self.si_words(block, seg)
            }
            Stmt::Assign => {
                self.si_frame_data(block, seg);
                Event::None
            }
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

    /// An assignment to a frame in the control's data: `$P_UIFR[n]`, the
    /// settable frame G54.., G505.. select, `$P_PFRAME` (the programmable
    /// frame), the base frames (`$P_CHBFR`, `$P_NCBFR`), ... The values a
    /// settable frame held before are not known, nor is which frame a
    /// changed one moves: from here on no work offset relates to the one
    /// of the first move, and nothing is corrected.
    fn si_frame_data(&mut self, block: &Block, seg: &Segment) {
        for t in block.seg_tokens(seg) {
            if t.kind != TokenKind::Param {
                continue;
            }
            let name = block.bytes(t.span).to_ascii_uppercase();
            if name.starts_with(b"$P_") && name.windows(2).any(|w| w == b"FR") {
                self.offsets.set = true;
                self.offsets.lost = Some(FRAME_DATA);
                self.pos[..3].fill(None);
                self.note(
                    t.span.start as usize,
                    format!(
                        "`{}`: {FRAME_DATA}: the moves after it are left as written",
                        String::from_utf8_lossy(&name)
                    ),
                );
            }
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
                self.ori_machine,
            ),
            self.frame_rot,
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
        let old = self.frame_key();
        let mut s = SiScan::default();
        // Commands first: they say what the block's words mean.
        self.si_commands(block, seg, &mut s);
        self.si_address_words(block, seg, &mut s);
        let now = self.frame_key();
        if now != old {
            // The same numbers mean another place now; the rotary axes
            // stay where they are (their positions are machine positions
            // whatever the frame: no work offset has a rotary part, each
            // lies on the W origin at rotary zero).
            let rotary = [self.pos[3], self.pos[4], self.pos[5]];
            self.forget();
            self.pos[3..].copy_from_slice(&rotary);
        }
        self.si_event(block, seg, &s)
    }

    /// The block's commands (TRAORI, CYCLE800, SUPA, frames, calls, ...).
    fn si_commands(&mut self, block: &Block, seg: &Segment, s: &mut SiScan) {
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
                "ORIMKS" => self.ori_machine = true,
                "ORIWKS" => self.ori_machine = false,
                "CYCLE800" => {
                    let text = args.map(|a| String::from_utf8_lossy(a).into_owned());
                    self.cycle800(block.line, offset, text.as_deref().unwrap_or(""));
                }
                "SUPA" => s.machine = true,
                "CIP" | "CT" | "POLY" | "ASPLINE" | "BSPLINE" | "CSPLINE" => {
                    self.motion = Some(Motion::Other);
                    self.cip = name == "CIP";
                    if self.cip {
                        s.cip = Some(seg.first as usize + k);
                    }
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
                    s.mcall = true;
                    self.cancel("a modal subprogram call (MCALL)");
                    self.si_mcall = None;
                    let called = toks[k + 1..]
                        .iter()
                        .position(|t| t.kind == TokenKind::Keyword)
                        .map(|j| k + 1 + j);
                    let cycle = called.and_then(|j| {
                        let name = block.bytes(toks[j].span).to_ascii_uppercase();
                        let args = toks
                            .get(j + 1)
                            .filter(|a| a.kind == TokenKind::Text)
                            .map(|a| String::from_utf8_lossy(block.bytes(a.span)).into_owned());
                        DRILLING_CYCLES
                            .contains(&name.as_slice())
                            .then(|| retraction_plane(args.as_deref().unwrap_or("")))
                    });
                    match cycle {
                        Some(rtp) => self.si_mcall = Some(rtp),
                        None if args.is_some() || called.is_some() => {
                            self.transformed = Some("a modal subprogram call (MCALL)");
                        }
                        // `MCALL` alone ends the modal call.
                        None => {}
                    }
                }
                // `RPL` belongs to the ROT/AROT before it.
                n if FRAMES.contains(&n) => {
                    if n != "RPL" || s.frame.is_none() {
                        s.frame = Some(n.to_string());
                    }
                }
                n if QUIET_COMMANDS.contains(&n) => {}
                n if n.starts_with("CYCLE") && !s.mcall => {
                    s.cycle = true;
                    if DRILLING_CYCLES.contains(&n.as_bytes()) {
                        let text = args.map(|a| String::from_utf8_lossy(a).into_owned());
                        s.drill_rtp = retraction_plane(text.as_deref().unwrap_or(""));
                    }
                }
                n if n.starts_with("CYCLE") => {}
                _ => {
                    // A subprogram (by name or with a parameter list) or a
                    // command fivecal does not know: where the axes are
                    // afterwards is not known.
                    s.call = true;
                    self.note(
                        offset,
                        format!(
                            "`{name}`: a subprogram call or a command fivecal does not model (the position is taken as unknown after it)"
                        ),
                    );
                }
            }
        }
    }

    /// The block's address words: G and M codes, D, F, L and the axes.
    fn si_address_words(&mut self, block: &Block, seg: &Segment, s: &mut SiScan) {
        for (ti, w) in block.words(seg) {
            let a = w.addr;
            if a == Addr::new("MEAS") || a == Addr::new("MEAW") {
                s.probing = true;
                continue;
            }
            let Some(letter) = a.as_letter() else {
                continue;
            };
            match letter {
                b'G' => {
                    let Value::Num(v) = w.value else {
                        s.expr_g = true;
                        continue;
                    };
                    let Some(g) = g_code(v) else { continue };
                    match g {
                        0 | 10 | 20 | 30 => {
                            s.motion_here = Motion::of_g(g);
                            s.motion_word = Some(ti);
                        }
                        50 | 330 | 340 | 350 | 3310 | 3320 => {
                            s.motion_here = Some(Motion::Other);
                            s.motion_word = Some(ti);
                        }
                        // Dwell, working-area limits, reference and fixed points.
                        40 | 250 | 260 | 740 | 750 => s.g_nonmodal = Some(g),
                        530 | 1530 => s.machine = true,
                        170 => self.plane = ArcPlane::Xy,
                        180 => self.plane = ArcPlane::Zx,
                        190 => self.plane = ArcPlane::Yz,
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
                        400 => self.radius_comp = None,
                        410 => self.radius_comp = Some(super::approach::Side::Left),
                        420 => self.radius_comp = Some(super::approach::Side::Right),
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
                        self.m_function(m, block.tokens[ti].span.start as usize, block.line);
                        // M6 is the tool change (`m_function`: what the
                        // machine file says it moves); the subprogram and
                        // program ends leave the axes where the caller or
                        // the next program finds them.
                        if matches!(m, 17 | 2 | 30) {
                            s.call = true;
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
                b'L' => s.call = true,
                _ => {
                    if self.axis_index(a).is_some() {
                        s.has_axis = true;
                    }
                }
            }
        }
    }

    /// What the block does once its commands and words are read.
    fn si_event(&mut self, block: &Block, seg: &Segment, s: &SiScan) -> Event {
        if let Some(m) = s.motion_here {
            self.motion = Some(m);
            self.cip = false;
        }
        if let Some(f) = &s.frame {
            self.si_frame(block, seg, f);
            return Event::None;
        }
        if s.expr_g {
            self.forget();
            self.motion = None;
            return if s.has_axis {
                Event::Skip(Skip::Expression)
            } else {
                Event::None
            };
        }
        if s.machine || s.probing || s.g_nonmodal.is_some_and(|g| g == 740 || g == 750) {
            if s.machine && !s.probing && s.g_nonmodal.is_none() {
                let absolute = self.absolute;
                self.machine_move(block, seg, |b, w| {
                    written_mode(b, w).map_or(absolute, |inc| !inc)
                });
            } else {
                self.forget_named(block, seg);
            }
            if s.call || self.si_mcall.is_some() {
                // A modal cycle runs after the machine-coordinate move too.
                self.forget();
            }
            return if s.has_axis || s.probing {
                Event::Quiet
            } else {
                Event::None
            };
        }
        if s.g_nonmodal.is_some() {
            return Event::None;
        }
        if s.cycle {
            // A drilling cycle ends on the hole's axis at its retraction
            // plane; any other cycle where its own parameters put it.
            let xy = [self.pos[0], self.pos[1]];
            self.forget();
            if let Some(rtp) = s
                .drill_rtp
                .filter(|_| self.plane == ArcPlane::Xy && !self.tilted && !s.has_axis && !s.call)
            {
                self.pos[..3].copy_from_slice(&[xy[0], xy[1], Some(rtp)]);
            }
            return Event::Skip(Skip::CannedCycle);
        }
        if s.call {
            self.forget();
            return if s.has_axis {
                Event::Skip(Skip::MacroCall)
            } else {
                Event::None
            };
        }
        if !s.has_axis {
            if let Some(u) = seg.unknown {
                let word = String::from_utf8_lossy(block.bytes(u)).into_owned();
                self.note(
                    u.start as usize,
                    format!("`{word}`: a word fivecal does not know (taken to move no axis)"),
                );
            }
            return Event::None;
        }
        let ev = self.si_path_event(block, seg, s);
        if let Some(rtp) = self.si_mcall {
            // The modal drilling cycle drills a hole where this block
            // ends and goes back to its retraction plane RTP, on the
            // hole's axis (SINUMERIK cycles manual, CYCLE81-CYCLE83).
            if self.plane == ArcPlane::Xy && !self.tilted {
                self.pos[2] = rtp;
            } else {
                self.pos[..3].fill(None);
            }
            if matches!(ev, Event::Move(_)) {
                let at = block.tokens[seg.body as usize].span.start as usize;
                self.note(
                    at,
                    "MCALL: the drilling cycle called after this block drills to the depth its own parameters give, which no word of the block moves: the hole is left as the machine drills it",
                );
            }
        }
        ev
    }

    /// The event of a block that moves along a path in the motion mode in
    /// force.
    fn si_path_event(&mut self, block: &Block, seg: &Segment, s: &SiScan) -> Event {
        match self.motion {
            Some(m @ (Motion::Rapid | Motion::Linear | Motion::ArcCw | Motion::ArcCcw)) => {
                self.si_move(block, seg, m, s.motion_word, None)
            }
            Some(Motion::Other) if self.cip => {
                self.si_move(block, seg, Motion::Other, None, Some(s.cip))
            }
            Some(Motion::Other) => {
                self.track_words(block, seg);
                Event::Skip(Skip::Element(
                    ReasonKind::NotImplemented,
                    "a CT, POLY, spline, thread or tapping motion",
                ))
            }
            None => {
                self.track_words(block, seg);
                Event::Skip(Skip::Element(
                    ReasonKind::Unsaid,
                    "motion without a motion mode",
                ))
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
        if self.local_shift != [0.0; 3]
            || self.shift != [0.0; 3]
            || self.frame_rot != nalgebra::Matrix3::identity()
        {
            // The swivel acts on the frame chain, but which frame it turns
            // about when a programmable one is in force (its zero point
            // or the work offset's), and whether the programmable frame is
            // kept in it, is not read in a primary text.
            return self.plane_unmodelled(
                line,
                at,
                "CYCLE800 on a programmable frame (TRANS/ROT in force): which zero point the swivel turns about is not known",
            );
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
                // Haas's DWO (an ISO code) never reaches SINUMERIK; as a
                // plane it is the workpiece's own axes.
                None | Some(super::Tilt::Workpiece) => {}
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

    /// A programmable frame statement. SINUMERIK's programmable frame maps
    /// a point written at `p` to `R p + t` in the coordinates of the work
    /// offset (kept here as `frame_rot` and `local_shift`). Read in
    /// Siemens' programming manuals (SINUMERIK ONE NC programming 12/2019,
    /// 2.12, pp. 309-324; the 808D manual): `TRANS` is absolute and clears
    /// the previous offset, rotation, scale and mirror, `ATRANS` adds;
    /// `ROT X.. Y.. Z..` turns in the order Z, then the turned Y, then the
    /// twice-turned X (RPY, the default of the control; a control set to
    /// Euler angles reads the same words as Z, X', Z'', which the program
    /// does not show), `ROT RPL=` turns in the working plane G17/G18/G19,
    /// `AROT` adds; `TRANS`/`ROT` written alone clear; `ROTS`/`AROTS` turn
    /// by solid angles ([`super::plane::solid_angles`]) as `ROT`/`AROT` do.
    /// The sense of every turn is the right-hand rule about its axis (read:
    /// function manual K2, 2.4.2.3). The axis of `RPL=` is derived, not read
    /// on a page of its own: the turn "in the plane" is the one about the
    /// plane's normal, as the frame function `CRPL` puts it beside its turns
    /// about Z, Y and X (K2, 828D edition 09/2011, p. 728: "rotation in the
    /// active plane"), so Z in G17, Y in G18 and X in G19, positive from
    /// the plane's first axis towards its second (X to Y, Z to X, Y to Z,
    /// the axis order of the planes on p. 324), which is the right-hand
    /// rule about that normal. The general rule of the frame chain, not
    /// read on a page of its own (fivecal's reading, as every controller
    /// with frames composes them): `ROT` (like every absolute frame
    /// statement) replaces the whole programmable frame, and an additive
    /// statement acts in the frame in force, so `ATRANS v` adds `R v` and
    /// `AROT` composes `R R'` about the current zero point. What stays
    /// unmodelled is refused: scaling and mirroring, `CROTS` (it writes
    /// the frame in the data management), three solid angles (the control
    /// refuses them), frames on rotary axes, values in parameters, and any
    /// frame inside a CYCLE800 swivel plane.
    fn si_frame(&mut self, block: &Block, seg: &Segment, name: &str) {
        use nalgebra::{Matrix3, Vector3};
        let mut vals = [None::<f64>; 3];
        let mut any = false;
        let mut unknown = false;
        let mut nonzero = false;
        let mut rotary = false;
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
                    } else {
                        rotary |= v != 0.0;
                    }
                }
                Err(_) => {
                    unknown = true;
                    rotary |= i >= 3;
                }
            }
        }
        let rpl = plane_rotation(block, seg);
        if let Some(r) = rpl {
            any = true;
            match r {
                Some(v) => nonzero |= v != 0.0,
                None => unknown = true,
            }
        }
        if self.tilted && any {
            let at = block.tokens[seg.body as usize].span.start as usize;
            return self.plane_unmodelled(
                block.line,
                at,
                "a programmable frame inside the swivel plane",
            );
        }
        let absolute = !name.starts_with('A');
        let (old_rot, old_shift) = (self.frame_rot, Vector3::from(self.local_shift));
        if absolute {
            // An absolute frame statement replaces the whole programmable
            // frame.
            self.frame_rot = Matrix3::identity();
            self.local_shift = [0.0; 3];
            self.shift_known = true;
            for what in UNMODELLED_FRAMES {
                self.cancel(what);
            }
        }
        let given = Vector3::new(
            vals[0].unwrap_or(0.0),
            vals[1].unwrap_or(0.0),
            vals[2].unwrap_or(0.0),
        );
        match name {
            "TRANS" | "ATRANS" => {
                if self.transformed.is_some() && !absolute {
                    // Along axes scaled or mirrored: not a known shift.
                    self.forget();
                }
                let t = Vector3::from(self.local_shift) + self.frame_rot * given;
                self.local_shift = t.into();
                if unknown {
                    self.shift_known = false;
                }
            }
            "ROT" | "AROT" if any => {
                let turn = match rpl {
                    _ if rotary => Err(FRAME_ROTARY),
                    _ if unknown => Err(FRAME_PARAMETER),
                    Some(_) if vals.iter().any(Option::is_some) => Err(FRAME_RPL_AND_AXES),
                    // The turn in the plane is about its normal: Z in G17,
                    // Y in G18, X in G19 (see above).
                    Some(a) => {
                        let (_, _, normal) = self.plane.axes();
                        Ok(super::plane::about(b"XYZ"[normal], a.unwrap_or(0.0)))
                    }
                    None => Ok(super::plane::intrinsic(b"ZYX", [given.z, given.y, given.x])),
                };
                match turn {
                    Ok(r) => self.frame_rot *= r,
                    Err(why) => self.transformed = Some(why),
                }
            }
            "ROT" | "AROT" => {}
            "ROTS" | "AROTS" if any => {
                let turn = match rpl {
                    _ if rotary => Err(FRAME_ROTARY),
                    _ if unknown => Err(FRAME_PARAMETER),
                    Some(_) => Err(FRAME_SOLID_RPL),
                    None => super::plane::solid_angles(vals),
                };
                match turn {
                    Ok(r) => self.frame_rot *= r,
                    Err(why) => self.transformed = Some(why),
                }
            }
            "ROTS" | "AROTS" => {}
            "CROTS" => {
                if any {
                    self.transformed = Some(FRAME_SOLID);
                }
            }
            _ => {
                if any && (nonzero || unknown) {
                    self.transformed = Some(FRAME_SCALING);
                }
            }
        }
        if rotary {
            self.transformed.get_or_insert(FRAME_ROTARY);
            self.pos[3..].fill(None);
        }
        // The tracked positions, written in the new frame: the same points.
        let (rot, shift) = (self.frame_rot, Vector3::from(self.local_shift));
        let xyz = [self.pos[0], self.pos[1], self.pos[2]];
        if rot == old_rot {
            let d = rot.transpose() * (old_shift - shift);
            for (p, d) in self.pos.iter_mut().zip(d.iter()) {
                if let Some(v) = p {
                    *v += d;
                }
            }
        } else if let [Some(x), Some(y), Some(z)] = xyz {
            let p = rot.transpose() * (old_rot * Vector3::new(x, y, z) + old_shift - shift);
            self.pos[..3].copy_from_slice(&[Some(p.x), Some(p.y), Some(p.z)]);
        } else {
            self.pos[..3].fill(None);
        }
    }

    /// A move of the motion mode in force; `cip`: it is a `CIP` (with the
    /// token of its command, when this block has it).
    fn si_move(
        &mut self,
        block: &Block,
        seg: &Segment,
        motion: Motion,
        motion_word: Option<usize>,
        cip: Option<Option<usize>>,
    ) -> Event {
        let start = self.pos;
        let mut mv = Move::new(MoveKind::Rapid, start, !self.absolute);
        mv.motion_word = motion_word;
        let mut skip: Option<Skip> = seg.unknown.map(|_| Skip::UnknownWord);
        let mut ijk: [Option<(usize, f64, bool)>; 3] = [None; 3];
        // CIP's intermediate point: token, value, incremental.
        let mut ijk1: [Option<(usize, f64, bool)>; 3] = [None; 3];
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
            if let Some(k) = [Addr::new("I1"), Addr::new("J1"), Addr::new("K1")]
                .iter()
                .position(|x| *x == a)
            {
                match self.axis_value(&w) {
                    Ok(v) => ijk1[k] = Some((ti, v, mode.unwrap_or(!self.absolute))),
                    Err(s) => {
                        skip.get_or_insert(s);
                    }
                }
                continue;
            }
            if a == Addr::new("AR") {
                skip.get_or_insert(Skip::Element(
                    ReasonKind::NotImplemented,
                    "an arc by opening angle (AR=)",
                ));
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
            _ if cip.is_some() => {
                let keyword = cip.flatten();
                match self.cip_circle(block, seg, (&start, &mv.end), ijk1, keyword) {
                    Ok(t) => MoveKind::Through(t),
                    Err(why) => return Event::Skip(skip.unwrap_or(why)),
                }
            }
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
                                ReasonKind::Unsaid,
                                "an arc whose radius does not reach its end point",
                            )));
                        }
                    }
                } else {
                    let (ca, cb) = (ijk[a], ijk[b]);
                    let abs = [ca.is_some_and(|x| x.2), cb.is_some_and(|x| x.2)];
                    if abs[0] != abs[1] {
                        return Event::Skip(skip.unwrap_or(Skip::Element(
                            ReasonKind::NotImplemented,
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
                            ReasonKind::Unsaid,
                            "off-circle arc (its centre I, J, K not as far from the end as from the start)",
                       ) ));
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
            if self.tcp == Tcp::Off || matches!(mv.kind, MoveKind::Arc(_) | MoveKind::Through(_)) {
                return Event::Skip(Skip::Element(
                    ReasonKind::NotImplemented,
                    "a tool vector (A3= B3= C3=) outside TRAORI or on an arc",
                ));
            }
            if self.ori_machine {
                return Event::Skip(Skip::Transformed(FRAME_VECTOR_MKS));
            }
            // ORIWKS (the default): the vector is in the workpiece
            // coordinate system (JP-06 p. 245, read), the one the
            // programmable frame leads to from the settable zero system
            // (ONE manual 12/2019, 3.8, p. 631, read): turned into W by the
            // frame's rotation, as the rewriter turns it back.
            let v = self.frame_rot
                * nalgebra::Vector3::new(
                    vector[0].map_or(0.0, |x| x.1),
                    vector[1].map_or(0.0, |x| x.1),
                    vector[2].map_or(0.0, |x| x.1),
                );
            mv.tool_vector = Some((
                [v.x, v.y, v.z],
                [
                    vector[0].map(|x| x.0),
                    vector[1].map(|x| x.0),
                    vector[2].map(|x| x.0),
                ],
            ));
            if self.settings().coordinates != super::Coordinates::Axes
                && let Err(why) = self.resolve_vector(&mut mv)
            {
                return Event::Skip(why);
            }
        }
        Event::Move(mv)
    }
}

impl Interpreter {
    /// The circle of a `CIP` from the move's start through the
    /// intermediate point its `I1= J1= K1=` give to its end, or why it
    /// has none: a point not known, or (an alarm, noted at the block)
    /// three points no circle passes through.
    fn cip_circle(
        &mut self,
        block: &Block,
        seg: &Segment,
        (start, end): (&[Option<f64>; 6], &[Option<f64>; 6]),
        ijk1: [Option<(usize, f64, bool)>; 3],
        keyword: Option<usize>,
    ) -> Result<Through, Skip> {
        let mut s = [0.0; 3];
        let mut e = [0.0; 3];
        let mut m = [0.0; 3];
        for k in 0..3 {
            s[k] = start[k].ok_or(Skip::PositionUnknown(AXES[k]))?;
            e[k] = end[k].ok_or(Skip::PositionUnknown(AXES[k]))?;
            m[k] = match ijk1[k] {
                Some((_, v, true)) => s[k] + v,
                Some((_, v, false)) => v,
                // An interpolation parameter left out has the value 0
                // (SINUMERIK ONE NC programming 12/2019, p. 198): counted
                // from the start under G91, the start's coordinate; under
                // G90 the point 0 itself, which the same page leaves
                // unexplained where the start is elsewhere (a circle out
                // of the start's plane): followed only where both agree.
                None if !self.absolute || s[k] == 0.0 => s[k],
                None => return Err(Skip::Element(ReasonKind::Unsaid, CIP_OMITTED)),
            };
        }
        let geo = match CircleGeo::through(s, m, e, self.units.mm()) {
            Ok(g) => g,
            Err(why) => {
                let at = keyword
                    .or(ijk1.iter().flatten().map(|x| x.0).next())
                    .map_or(block.tokens[seg.body as usize].span.start, |t| {
                        block.tokens[t].span.start
                    });
                self.alarm = Some(Unmodelled {
                    offset: at as usize,
                    what: format!("CIP: {why}: the control cannot run this block"),
                });
                return Err(Skip::Element(ReasonKind::Unsaid, "a CIP without a circle"));
            }
        };
        Ok(Through {
            point: m,
            geo,
            words: ijk1.map(|x| x.map(|x| x.0)),
            incremental: ijk1.map(|x| x.is_some_and(|x| x.2)),
            keyword,
        })
    }
}

/// Why nothing is corrected after a program writes a frame of the
/// control's data.
const FRAME_DATA: &str = "a frame written into the control's data ($P_UIFR, $P_PFRAME, ...), which fivecal does not model";

/// Why a `CIP` that leaves out an intermediate coordinate under G90 is
/// left as written.
const CIP_OMITTED: &str = "a CIP that leaves out I1=, J1= or K1= under G90 where the start is not at 0 on that axis (the programming manual gives an omitted interpolation parameter the value 0: the point 0, a circle out of the start's plane, or the start's coordinate, it does not say which)";

#[cfg(test)]
mod tests {
    use super::super::tests::run;
    use super::*;
    use crate::machine::Dialect;
    use nalgebra::{Matrix3, Rotation3, Vector3};

    fn close(a: &Matrix3<f64>, b: &Matrix3<f64>) -> bool {
        (a - b).abs().max() < 1e-12
    }

    #[test]
    fn frames_compose_as_a_hand_computation() {
        // TRANS X10 Y-5, turned 30 deg about Z there, moved 5 along the
        // turned X, turned 10 deg about the twice-turned X: R = Rz(30)
        // Rx(10), t = (10, -5, 0) + 5 (cos 30, sin 30, 0).
        let (_, m) = run(
            "G17 G90 G710 D1\nTRANS X10 Y-5\nAROT Z30\nATRANS X5\nAROT X10\n",
            Dialect::Sinumerik,
        );
        let (s, c) = (0.5, 0.75f64.sqrt());
        let x10 = 10f64.to_radians();
        let by_hand = Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
            * Matrix3::new(
                1.0,
                0.0,
                0.0,
                0.0,
                x10.cos(),
                -x10.sin(),
                0.0,
                x10.sin(),
                x10.cos(),
            );
        assert!(close(&m.frame_rot, &by_hand), "{}", m.frame_rot);
        let t = Vector3::from(m.local_shift);
        assert!((t - Vector3::new(10.0 + 5.0 * c, -2.5, 0.0)).norm() < 1e-12);
        // The frame puts a written point at R p + t.
        let f = m.frame();
        let p = Vector3::new(20.0, 10.0, 2.0);
        let a = f.model(&[p.x, p.y, p.z, 0.0, 20.0, 10.0]);
        assert!((a.xyz - (by_hand * p + t)).norm() < 1e-12);
        let back = f.program(&a);
        assert!((Vector3::new(back[0], back[1], back[2]) - p).norm() < 1e-12);

        // ROT X Y Z turns Z, then the turned Y, then the twice-turned X
        // (roll, pitch, yaw); an absolute ROT clears the translation.
        let (_, m) = run("TRANS X3\nROT X10 Y20 Z=30\n", Dialect::Sinumerik);
        let rpy = Rotation3::from_euler_angles(
            10f64.to_radians(),
            20f64.to_radians(),
            30f64.to_radians(),
        );
        assert!(close(&m.frame_rot, rpy.matrix()));
        assert_eq!(m.local_shift, [0.0; 3]);
        // RPL= in G17 is the turn about Z; ROT alone and TRANS clear.
        let (_, m) = run("ROT RPL=-45\n", Dialect::Sinumerik);
        assert!(close(
            &m.frame_rot,
            &super::super::plane::about(b'Z', -45.0)
        ));
        let (_, m) = run("AROT RPL=20\nATRANS Y2\nROT\n", Dialect::Sinumerik);
        assert!(m.frame_rot == Matrix3::identity() && m.local_shift == [0.0; 3]);
        assert!(m.transformed.is_none());
    }

    #[test]
    fn plane_rotations_and_solid_angles_compose_into_the_frame() {
        use super::super::plane::about;
        // RPL= turns about the working plane's normal: Z in G17, Y in
        // G18 (Z towards X), X in G19 (Y towards Z).
        for (g, axis, to) in [
            ("G17", b'Z', Vector3::y()),
            ("G18", b'Y', Vector3::x()),
            ("G19", b'X', Vector3::z()),
        ] {
            let (_, m) = run(&format!("{g}\nROT RPL=90\n"), Dialect::Sinumerik);
            assert!(close(&m.frame_rot, &about(axis, 90.0)), "{g}");
            assert!(m.transformed.is_none());
            // The plane's first axis turns onto its second.
            let (first, _, _) = m.plane.axes();
            let e = Vector3::ith(first, 1.0);
            assert!((m.frame_rot * e - to).norm() < 1e-12, "{g}");
        }
        // ROTS replaces the frame, AROTS adds to it in the turned axes.
        let (_, m) = run(
            "TRANS X5\nROTS X10 Y20\nAROTS Z=-30\nAROTS Y15 Z5\n",
            Dialect::Sinumerik,
        );
        let solid = |v: [Option<f64>; 3]| super::super::plane::solid_angles(v).unwrap();
        let by_hand = solid([Some(10.0), Some(20.0), None])
            * about(b'Z', -30.0)
            * solid([None, Some(15.0), Some(5.0)]);
        assert!(close(&m.frame_rot, &by_hand), "{}", m.frame_rot);
        assert_eq!(m.local_shift, [0.0; 3]);
        assert!(m.transformed.is_none());
    }

    #[test]
    fn tool_vectors_are_turned_out_of_the_programmable_frame() {
        // Under ROT X90 (ORIWKS) the written C3=1 (the frame's Z) is the
        // workpiece's -Y: R (0, 0, 1) = (0, -sin 90, cos 90).
        let (ev, _) = run(
            "G17 G90 G710 D1\nG0 X0 Y0 Z50 B0 C0\nTRAORI\nROT X90\nG1 X10 Y0 Z0 A3=0 B3=0 C3=1 F100\n",
            Dialect::Sinumerik,
        );
        let Some(Event::Move(mv)) = ev.last() else {
            panic!("{:?}", ev.last())
        };
        let (v, _) = mv.tool_vector.unwrap();
        assert!((Vector3::from(v) - Vector3::new(0.0, -1.0, 0.0)).norm() < 1e-12);
    }

    #[test]
    fn tracked_positions_stay_the_same_points_when_the_frame_turns() {
        // X1 Y2 Z3 seen from a frame turned 90 deg about Z: (2, -1, 3).
        let (_, m) = run("G90 G0 X1 Y2 Z3 B0 C0\nAROT Z90\n", Dialect::Sinumerik);
        let p = [m.pos[0].unwrap(), m.pos[1].unwrap(), m.pos[2].unwrap()];
        assert!(
            (p[0] - 2.0).abs() < 1e-12 && (p[1] + 1.0).abs() < 1e-12,
            "{p:?}"
        );
        assert_eq!((p[2], m.pos[4], m.pos[5]), (3.0, Some(0.0), Some(0.0)));
        // Then ATRANS X1 (along the turned X, the old Y): (1, -1, 3).
        let (_, m) = run(
            "G90 G0 X1 Y2 Z3 B0 C0\nAROT Z90\nATRANS X1\n",
            Dialect::Sinumerik,
        );
        assert!((m.pos[0].unwrap() - 1.0).abs() < 1e-12);
        assert!((m.pos[1].unwrap() + 1.0).abs() < 1e-12);
    }

    #[test]
    fn cip_intermediate_points_follow_g90_g91_ac_and_ic_and_the_mode_is_modal() {
        let (ev, m) = run(
            "G17 G90 G710 D1\nG0 X30 Y40 Z0 B0 C0\nCIP X50 Y40 I1=40 J1=45\n\
             X60 Y30 Z-5 I1=IC(8) J1=IC(-3) K1=IC(-2)\n\
             G91 X-10 Y-10 I1=AC(58) J1=-8\nG90 G1 X0\n",
            Dialect::Sinumerik,
        );
        let through = |e: &Event| match e {
            Event::Move(Move {
                kind: MoveKind::Through(t),
                ..
            }) => *t,
            other => panic!("not a CIP: {other:?}"),
        };
        // K1 left out at a start on Z0: Z0 either way.
        let t = through(&ev[2]);
        assert_eq!(t.point, [40.0, 45.0, 0.0]);
        assert!(t.keyword.is_some() && t.words[2].is_none());
        // IC counts from the start (50, 40, 0), in a block with no CIP of
        // its own.
        let t = through(&ev[3]);
        assert_eq!(t.point, [58.0, 37.0, -2.0]);
        assert_eq!((t.incremental, t.keyword), ([true; 3], None));
        // G91: J1 from the start (60, 30, -5), I1 absolute by AC, K1 left
        // out the start's Z.
        let t = through(&ev[4]);
        assert_eq!(t.point, [58.0, 22.0, -5.0]);
        assert_eq!(t.incremental, [false, true, false]);
        let Event::Move(end) = &ev[4] else { panic!() };
        assert_eq!(&end.end[..3], &[Some(50.0), Some(20.0), Some(-5.0)]);
        // G1 ends the mode.
        assert!(matches!(
            ev[5],
            Event::Move(Move {
                kind: MoveKind::Linear,
                ..
            })
        ));
        assert!(!m.cip);
    }

    #[test]
    fn frames_fivecal_does_not_model_are_refused_with_the_reason() {
        let why = |src: &str| {
            let (ev, _) = run(src, Dialect::Sinumerik);
            match ev.last() {
                Some(Event::Skip(s)) => s.to_string(),
                other => panic!("{src}: {other:?}"),
            }
        };
        let head = "G17 G90 G710 D1\nG0 X0 Y0 Z50 B0 C0\n";
        for (frame, reason) in [
            ("AROTS X10 Y20 Z5", "three solid angles"),
            ("ROTS X95 Y10", "within +-90"),
            ("CROTS X10 Y20", "CROTS"),
            ("SCALE X2", "scaling"),
            ("ROT Z=R1", "parameter"),
            ("ROT X10 RPL=5", "RPL= and axis angles"),
            ("TRANS C10", "rotary axis"),
        ] {
            let got = why(&format!("{head}{frame}\nG1 X10 Y0 Z0 F100\n"));
            assert!(got.contains(reason), "{frame}: {got}");
        }
        let got = why(&format!(
            "{head}TRAORI\nORIMKS\nG1 X10 Y0 Z0 A3=0 B3=0 C3=1 F100\n"
        ));
        assert!(got.contains("ORIMKS"), "{got}");
        // CYCLE800 on a turned programmable frame, and a frame inside the
        // swivel plane.
        let swivel = "CYCLE800(1,\"TC1\",0,57,0,0,0,0,30,0,0,0,0,-1,100,1)";
        for src in [
            format!("{head}ROT Z30\n{swivel}\nG1 X10 Y0 Z0 F100\n"),
            format!("{head}{swivel}\nAROT Z30\nG1 X10 Y0 Z0 F100\n"),
        ] {
            let got = why(&src);
            assert!(got.contains("does not model"), "{src}: {got}");
        }
    }
}
