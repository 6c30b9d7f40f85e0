//! What the controller has in force at each block, and where each move
//! goes.
//!
//! [`Modal`] follows a program in file order: units (G20/G21, `BEGIN PGM ...
//! MM|INCH`), absolute or incremental distances (G90/G91, HEIDENHAIN's `I`
//! prefix), the motion mode (G0/G1/G2/G3, canned cycles, `L ... FMAX`), the
//! feed mode (G93 inverse time, G94, G95), the plane, the work offset
//! (G54..G59, G54.1 Pn, HEIDENHAIN presets), tool length compensation
//! (G43/G49), tool centre point control (G43.4, G43.5, M128, FUNCTION TCPM),
//! the tilted working plane (G68.2, PLANE, CYCL DEF 19), datum shifts (G52,
//! G92, CYCL DEF 7), transformations it does not model (G68 rotation, G51
//! scaling, mirroring, polar coordinates) and the last programmed position
//! of every axis.
//!
//! Each statement becomes an [`Event`]: no motion, a [`Move`] with its
//! start and end in program coordinates, or a motion that must be left as
//! written, with the reason ([`Skip`]). Positions are tracked in file order;
//! where control flow makes the position at runtime unknowable statically
//! (labels, loops, calls, jumps, probing, tool changes) the tracked position
//! is forgotten, so a move there is rewritten only when its own words fix
//! every axis.

use super::iso::g_code;
use super::{Addr, Block, HhKind, Segment, Stmt, TokenKind, Value, Word};
use crate::machine::Dialect;

/// Axis indices: X, Y, Z, A, B, C.
pub const AXES: [u8; 6] = *b"XYZABC";

/// Length units of the program.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Units {
    /// Millimetres.
    Mm,
    /// Inches.
    Inch,
}

impl Units {
    /// Millimetres per program unit.
    pub fn mm(self) -> f64 {
        match self {
            Units::Mm => 1.0,
            Units::Inch => 25.4,
        }
    }
}

/// Interpolation mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Motion {
    /// G0 / FMAX.
    Rapid,
    /// G1.
    Linear,
    /// G2.
    ArcCw,
    /// G3.
    ArcCcw,
    /// Anything else: canned cycles, splines, threading, probing.
    Other,
}

/// Feed mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FeedMode {
    /// G94: per minute.
    PerMinute,
    /// G93: inverse time (F = 1 / minutes for the block).
    InverseTime,
    /// G95: per revolution.
    PerRev,
}

/// Arc plane.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Plane {
    /// G17.
    Xy,
    /// G18.
    Zx,
    /// G19.
    Yz,
}

impl Plane {
    /// (first, second, normal) axis indices.
    pub fn axes(self) -> (usize, usize, usize) {
        match self {
            Plane::Xy => (0, 1, 2),
            Plane::Zx => (2, 0, 1),
            Plane::Yz => (1, 2, 0),
        }
    }
}

/// Tool centre point control.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Tcp {
    /// Off: coordinates are axis positions (post-side programs).
    Off,
    /// On, rotary axis positions programmed (G43.4, M128, FUNCTION TCPM AXIS POS).
    Axes,
    /// On, tool direction programmed as a vector (G43.5 I J K).
    Vector,
    /// On, spatial angles programmed (FUNCTION TCPM AXIS SPAT): not modelled.
    Spatial,
}

/// Why a move is left as written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Skip {
    /// A coordinate is an expression or a parameter.
    Expression,
    /// The block has a word this parser does not know.
    UnknownWord,
    /// An axis the machine does not have.
    UnknownAxis(u8),
    /// FANUC axis value without a decimal point (unit depends on parameter DPI).
    FanucInteger,
    /// The named axis' position is not known here.
    PositionUnknown(u8),
    /// A transformation that is not modelled is active.
    Transformed(&'static str),
    /// A tilted working plane is active.
    TiltedPlane,
    /// Tool centre point control with spatial angles.
    TcpSpatial,
    /// A macro call with axis arguments (G65/G66).
    MacroCall,
    /// Canned cycle positions.
    CannedCycle,
    /// A contour element that is not compensated (polar, tangential,
    /// approach/departure, vector blocks, splines).
    Element(&'static str),
    /// The datum shift is not known (datum table row).
    ShiftUnknown,
}

impl std::fmt::Display for Skip {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Skip::Expression => write!(f, "coordinates are expressions or variables"),
            Skip::UnknownWord => write!(f, "the block has a word fivecal does not know"),
            Skip::UnknownAxis(a) => write!(f, "axis {} is not an axis of this machine", *a as char),
            Skip::FanucInteger => write!(
                f,
                "axis value without a decimal point (FANUC reads it in mm or in least input increments by parameter 3401#0; pass --integer-unit)"
            ),
            Skip::PositionUnknown(a) => write!(
                f,
                "the position of {} is not known here (not yet programmed, or forgotten after a jump, call, probe or tool change)",
                *a as char
            ),
            Skip::Transformed(what) => write!(f, "{what} is active"),
            Skip::TiltedPlane => write!(
                f,
                "a tilted working plane is active (G68.2 / PLANE / CYCL DEF 19): the controller chooses the rotary positions"
            ),
            Skip::TcpSpatial => write!(f, "TCPM with spatial angles (AXIS SPAT) is not modelled"),
            Skip::MacroCall => write!(f, "macro call arguments (G65/G66)"),
            Skip::CannedCycle => write!(f, "canned cycle, spline or thread positions"),
            Skip::Element(what) => write!(f, "{what} elements are not compensated"),
            Skip::ShiftUnknown => write!(f, "the datum shift comes from a table (value unknown)"),
        }
    }
}

/// The arc of a move.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Arc {
    /// Plane.
    pub plane: Plane,
    /// Clockwise (G2, DR-).
    pub cw: bool,
    /// Centre, absolute program coordinates in the plane (first, second).
    pub center: [f64; 2],
    /// Extra full turns (LinuxCNC P word minus one).
    pub turns: u32,
    /// Token indices of I, J, K (centre words), if written.
    pub center_words: [Option<usize>; 3],
    /// Token index of the radius word (R), if the arc is given by radius.
    pub radius_word: Option<usize>,
}

/// What kind of move.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MoveKind {
    /// Rapid positioning.
    Rapid,
    /// Linear interpolation.
    Linear,
    /// Circular interpolation.
    Arc(Arc),
}

/// One move, in program coordinates (program units, degrees, before the
/// datum shift).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Move {
    /// Kind.
    pub kind: MoveKind,
    /// Position before the move (X Y Z A B C), where known.
    pub start: [Option<f64>; 6],
    /// Position after the move, where known.
    pub end: [Option<f64>; 6],
    /// Token index of each axis word in the block.
    pub words: [Option<usize>; 6],
    /// Which axis words are incremental.
    pub incremental: [bool; 6],
    /// The block's motion word (G0/G1/G2/G3), if written (ISO).
    pub motion_word: Option<usize>,
    /// The block's feed word and its value.
    pub feed: Option<(usize, f64)>,
    /// G43.5: the programmed tool direction (I, J, K) and its word indices.
    pub tool_vector: Option<([f64; 3], [Option<usize>; 3])>,
}

/// What a statement does.
// Events are returned by value once per statement and never stored in bulk,
// so the large `Move` variant costs nothing a box would save.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Event {
    /// No motion.
    None,
    /// A move to interpret.
    Move(Move),
    /// A motion left as written, and why.
    Skip(Skip),
    /// A motion left as written on purpose and not reported: machine
    /// coordinates (G53, M91, M92), reference return (G28, G30), probing
    /// (G31, G38.x, TCH PROBE).
    Quiet,
}

/// Settings of the tracker.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModalSettings {
    /// The dialect.
    pub dialect: Dialect,
    /// Letters of the machine's two rotary axes (tilt, then C).
    pub rotary: [u8; 2],
    /// FANUC axis values without a decimal point: mm per unit written
    /// (1 for calculator-type input, 0.001 or 0.0001 for least input
    /// increments), or `None` to leave such moves as written.
    pub fanuc_integer_unit: Option<f64>,
}

/// The modal state.
#[derive(Clone, Debug, PartialEq)]
pub struct Modal {
    /// Settings.
    pub settings: ModalSettings,
    /// Units.
    pub units: Units,
    /// G90 (ISO); HEIDENHAIN marks incremental words instead.
    pub absolute: bool,
    /// Arc centres absolute (LinuxCNC G90.1).
    pub arc_absolute: bool,
    /// Motion mode (ISO).
    pub motion: Option<Motion>,
    /// Feed mode.
    pub feed_mode: FeedMode,
    /// Last feed value.
    pub feed: Option<f64>,
    /// Plane.
    pub plane: Plane,
    /// Work offset in force: G code x 10 (540 = G54; 5410 + P for G54.1 P;
    /// 100000 + n for a HEIDENHAIN preset).
    pub work_offset: u32,
    /// Tool length compensation on (G43, G43.4, G43.5; always on HEIDENHAIN).
    pub tool_length: bool,
    /// Tool centre point control.
    pub tcp: Tcp,
    /// Tilted working plane on.
    pub tilted: bool,
    /// A transformation fivecal does not model, by name.
    pub transformed: Option<&'static str>,
    /// G92 / CYCL DEF 7 datum shift per linear axis, program units.
    pub shift: [f64; 3],
    /// G52 local shift per linear axis, program units.
    pub local_shift: [f64; 3],
    /// Whether the shifts are known.
    pub shift_known: bool,
    /// Cutter radius compensation on (G41/G42, RL/RR).
    pub radius_comp: bool,
    /// Last programmed absolute position per axis (X Y Z A B C).
    pub pos: [Option<f64>; 6],
    /// HEIDENHAIN pole (CC) in the XY plane.
    pub pole: Option<[f64; 2]>,
}

impl Modal {
    /// The power-on state of a controller of this dialect.
    pub fn new(settings: ModalSettings) -> Modal {
        Modal {
            settings,
            units: Units::Mm,
            absolute: true,
            arc_absolute: false,
            motion: None,
            feed_mode: FeedMode::PerMinute,
            feed: None,
            plane: Plane::Xy,
            work_offset: if settings.dialect == Dialect::Heidenhain {
                100_000
            } else {
                540
            },
            tool_length: settings.dialect == Dialect::Heidenhain,
            tcp: Tcp::Off,
            tilted: false,
            transformed: None,
            shift: [0.0; 3],
            local_shift: [0.0; 3],
            shift_known: true,
            radius_comp: false,
            pos: [None; 6],
            pole: None,
        }
    }

    /// Total datum shift per linear axis (program units).
    pub fn total_shift(&self) -> [f64; 3] {
        [
            self.shift[0] + self.local_shift[0],
            self.shift[1] + self.local_shift[1],
            self.shift[2] + self.local_shift[2],
        ]
    }

    /// Forgets every tracked position.
    pub fn forget(&mut self) {
        self.pos = [None; 6];
        self.pole = None;
    }

    fn axis_index(&self, addr: Addr) -> Option<usize> {
        match addr.as_letter()? {
            b'X' => Some(0),
            b'Y' => Some(1),
            b'Z' => Some(2),
            b'A' => Some(3),
            b'B' => Some(4),
            b'C' => Some(5),
            _ => None,
        }
    }

    /// Whether the axis letter is one the machine has.
    fn machine_axis(&self, i: usize) -> bool {
        i < 3 || self.settings.rotary.contains(&AXES[i])
    }

    /// The value of an axis word in program units (deg for rotary axes),
    /// or why it has none.
    fn axis_value(&self, w: &Word) -> Result<f64, Skip> {
        match w.value {
            Value::Num(v) => {
                if self.settings.dialect == Dialect::Fanuc && v != 0.0 && !w.style.point {
                    return match self.settings.fanuc_integer_unit {
                        Some(k) => Ok(v * k / self.units.mm()),
                        None => Err(Skip::FanucInteger),
                    };
                }
                Ok(v)
            }
            _ => Err(Skip::Expression),
        }
    }

    /// Applies one statement of `block` and says what it does.
    pub fn step(&mut self, block: &Block, seg: &Segment) -> Event {
        match seg.stmt {
            Stmt::Blank | Stmt::Percent | Stmt::ProgramNumber | Stmt::Output => Event::None,
            Stmt::Assign => Event::None,
            Stmt::Flow(_) => {
                self.forget();
                Event::None
            }
            Stmt::Words => self.iso(block, seg),
            Stmt::Hh(kind) => self.heidenhain(block, seg, kind),
        }
    }

    // ---------------------------------------------------------------- ISO

    fn iso(&mut self, block: &Block, seg: &Segment) -> Event {
        let mut g_nonmodal: Option<u32> = None;
        let mut motion_word = None;
        let mut motion_here: Option<Motion> = None;
        let mut m_codes: [Option<u32>; 4] = [None; 4];
        let mut nm = 0;
        let mut p_word: Option<f64> = None;
        let mut has_axis = false;
        let old_frame = (
            self.work_offset,
            self.tool_length,
            self.tcp,
            self.tilted,
            self.units,
        );
        let mut expr_g = false;
        for (ti, w) in block.words(seg) {
            let Some(letter) = w.addr.as_letter() else {
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
                        50 | 51 | 52 | 53 | 330 | 331 | 760 | 730 | 740 | 810..=890 => {
                            motion_here = Some(Motion::Other);
                            motion_word = Some(ti);
                        }
                        800 => {
                            self.motion = None;
                        }
                        40
                        | 100
                        | 280
                        | 281
                        | 300
                        | 301
                        | 310..=314
                        | 382..=385
                        | 520
                        | 530
                        | 650
                        | 660
                        | 531
                        | 920 => g_nonmodal = Some(g),
                        670 => {}
                        170 => self.plane = Plane::Xy,
                        180 => self.plane = Plane::Zx,
                        190 => self.plane = Plane::Yz,
                        200 => self.units = Units::Inch,
                        210 => self.units = Units::Mm,
                        900 => self.absolute = true,
                        910 => self.absolute = false,
                        901 => self.arc_absolute = true,
                        911 => self.arc_absolute = false,
                        921 | 922 => {
                            self.shift = [0.0; 3];
                        }
                        930 => self.feed_mode = FeedMode::InverseTime,
                        940 => self.feed_mode = FeedMode::PerMinute,
                        950 => self.feed_mode = FeedMode::PerRev,
                        400 => self.radius_comp = false,
                        410 | 420 | 411 | 421 | 412 | 422 => self.radius_comp = true,
                        430 | 431 | 432 | 440 => {
                            self.tool_length = true;
                            self.tcp = Tcp::Off;
                        }
                        434 => {
                            self.tool_length = true;
                            self.tcp = Tcp::Axes;
                        }
                        435 => {
                            self.tool_length = true;
                            self.tcp = Tcp::Vector;
                        }
                        490 => {
                            self.tool_length = false;
                            self.tcp = Tcp::Off;
                        }
                        541 => self.work_offset = 5410,
                        540 | 550 | 560 | 570 | 580 | 590 | 591 | 592 | 593 => self.work_offset = g,
                        682..=684 => self.tilted = true,
                        680 => self.transformed = Some("coordinate rotation (G68)"),
                        690 => {
                            self.tilted = false;
                            self.cancel("coordinate rotation (G68)");
                        }
                        510 => self.transformed = Some("scaling (G51)"),
                        500 => self.cancel("scaling (G51)"),
                        511 => self.transformed = Some("programmable mirror image (G51.1)"),
                        501 => self.cancel("programmable mirror image (G51.1)"),
                        160 => self.transformed = Some("polar coordinate command (G16)"),
                        150 => self.cancel("polar coordinate command (G16)"),
                        121 => self.transformed = Some("polar coordinate interpolation (G12.1)"),
                        131 => self.cancel("polar coordinate interpolation (G12.1)"),
                        71 => {
                            self.transformed = if self.transformed.is_none() {
                                Some("cylindrical interpolation (G7.1)")
                            } else {
                                None
                            }
                        }
                        _ => {}
                    }
                }
                b'M' => {
                    if let (Value::Num(v), true) = (w.value, nm < 4) {
                        m_codes[nm] = Some(v.round() as u32);
                        nm += 1;
                    }
                }
                b'P' => {
                    if let Value::Num(v) = w.value {
                        p_word = Some(v);
                    }
                }
                b'F' => {
                    if let Value::Num(v) = w.value {
                        self.feed = Some(v);
                    }
                }
                _ => {
                    if self.axis_index(w.addr).is_some() {
                        has_axis = true;
                    }
                }
            }
        }
        // G54.1 P n selects an additional work offset.
        if self.work_offset == 5410
            && let Some(p) = p_word
        {
            self.work_offset = 5410 + p.round() as u32;
        }
        let frame_now = (
            self.work_offset,
            self.tool_length,
            self.tcp,
            self.tilted,
            self.units,
        );
        if frame_now != old_frame {
            // The same numbers mean another place now.
            self.forget();
        }
        let calls = m_codes.iter().flatten().any(|&m| m == 98 || m == 99);
        if let Some(m) = motion_here {
            self.motion = Some(m);
        }
        if expr_g {
            // A G code from a variable: nothing below can be trusted.
            self.forget();
            self.motion = None;
            return if has_axis {
                Event::Skip(Skip::Expression)
            } else {
                Event::None
            };
        }
        if let Some(g) = g_nonmodal {
            let ev = self.nonmodal(block, seg, g, has_axis);
            if calls {
                self.forget();
            }
            return ev;
        }
        if calls {
            self.forget();
            return if has_axis {
                Event::Skip(Skip::MacroCall)
            } else {
                Event::None
            };
        }
        if !has_axis {
            return Event::None;
        }
        let motion = self.motion;
        match motion {
            Some(Motion::Rapid) | Some(Motion::Linear) | Some(Motion::ArcCw)
            | Some(Motion::ArcCcw) => self.iso_move(block, seg, motion.unwrap(), motion_word),
            Some(Motion::Other) => {
                self.track_words(block, seg);
                Event::Skip(Skip::CannedCycle)
            }
            None => {
                self.track_words(block, seg);
                Event::Skip(Skip::Element("motion without a motion mode"))
            }
        }
    }

    /// A block whose axis words belong to a non-modal G code.
    fn nonmodal(&mut self, block: &Block, seg: &Segment, g: u32, has_axis: bool) -> Event {
        match g {
            // Dwell: the axis words are not positions.
            40 => Event::None,
            // Data setting (work offsets, tool offsets): the offsets in use
            // may have changed.
            100 => {
                self.forget();
                Event::None
            }
            // Reference return and machine coordinates.
            280 | 281 | 300 | 301 | 530 => {
                for (_, w) in block.words(seg) {
                    if let Some(i) = self.axis_index(w.addr) {
                        self.pos[i] = None;
                    }
                }
                if has_axis { Event::Quiet } else { Event::None }
            }
            // Probing: the machine stops somewhere along the move.
            310..=314 | 382..=385 => {
                for (_, w) in block.words(seg) {
                    if let Some(i) = self.axis_index(w.addr) {
                        self.pos[i] = None;
                    }
                }
                Event::Quiet
            }
            // G53.1 turns the rotary axes to the tilted plane.
            531 => {
                self.pos[3] = None;
                self.pos[4] = None;
                self.pos[5] = None;
                Event::Quiet
            }
            650 | 660 => {
                self.forget();
                if has_axis {
                    Event::Skip(Skip::MacroCall)
                } else {
                    Event::None
                }
            }
            520 => {
                // G52: local coordinate system (absolute values; X0 cancels).
                for (_, w) in block.words(seg) {
                    if let Some(i) = self.axis_index(w.addr).filter(|&i| i < 3) {
                        match self.axis_value(&w) {
                            Ok(v) => {
                                if let Some(p) = self.pos[i] {
                                    self.pos[i] = Some(p + self.local_shift[i] - v);
                                }
                                self.local_shift[i] = v;
                            }
                            Err(_) => {
                                self.shift_known = false;
                            }
                        }
                    }
                }
                Event::None
            }
            920 => {
                // G92: the current position becomes the value given.
                for (_, w) in block.words(seg) {
                    if let Some(i) = self.axis_index(w.addr) {
                        match (self.axis_value(&w), self.pos[i]) {
                            (Ok(v), Some(p)) if i < 3 => {
                                self.shift[i] += p - v;
                                self.pos[i] = Some(v);
                            }
                            (Ok(v), _) if i >= 3 => {
                                // A rotary G92 shifts the rotary zero: unknown.
                                let _ = v;
                                self.pos[i] = None;
                                self.transformed = Some("a rotary-axis G92 shift");
                            }
                            _ => {
                                self.shift_known = false;
                                self.pos[i] = None;
                            }
                        }
                    }
                }
                Event::None
            }
            _ => Event::None,
        }
    }

    /// Updates tracked positions from the axis words (for moves left as
    /// written): literal values are followed, expressions forget.
    fn track_words(&mut self, block: &Block, seg: &Segment) {
        for (_, w) in block.words(seg) {
            let Some(i) = self.axis_index(w.addr) else {
                continue;
            };
            let inc = w.incremental || !self.absolute;
            self.pos[i] = match (self.axis_value(&w), self.pos[i]) {
                (Ok(v), Some(p)) if inc => Some(p + v),
                (Ok(v), _) if !inc => Some(v),
                _ => None,
            };
        }
    }

    /// The reason a move in the current state cannot be rewritten, if any
    /// (checked after the positions are updated).
    fn frame_skip(&self) -> Option<Skip> {
        if let Some(t) = self.transformed {
            return Some(Skip::Transformed(t));
        }
        if self.tilted {
            return Some(Skip::TiltedPlane);
        }
        if self.tcp == Tcp::Spatial {
            return Some(Skip::TcpSpatial);
        }
        if !self.shift_known {
            return Some(Skip::ShiftUnknown);
        }
        None
    }

    fn iso_move(
        &mut self,
        block: &Block,
        seg: &Segment,
        motion: Motion,
        motion_word: Option<usize>,
    ) -> Event {
        let start = self.pos;
        let mut mv = Move {
            kind: MoveKind::Rapid,
            start,
            end: start,
            words: [None; 6],
            incremental: [!self.absolute; 6],
            motion_word,
            feed: None,
            tool_vector: None,
        };
        let mut skip: Option<Skip> = seg.unknown.map(|_| Skip::UnknownWord);
        let mut ijk: [Option<(usize, f64)>; 3] = [None; 3];
        let mut r_word: Option<(usize, f64)> = None;
        let mut p_turns: Option<f64> = None;
        for (ti, w) in block.words(seg) {
            let letter = w.addr.as_letter().unwrap_or(0);
            if let Some(i) = self.axis_index(w.addr) {
                mv.words[i] = Some(ti);
                if !self.machine_axis(i) {
                    skip.get_or_insert(Skip::UnknownAxis(AXES[i]));
                }
                match self.axis_value(&w) {
                    Ok(v) => {
                        mv.end[i] = if self.absolute {
                            Some(v)
                        } else {
                            start[i].map(|p| p + v)
                        };
                    }
                    Err(s) => {
                        mv.end[i] = None;
                        skip.get_or_insert(s);
                    }
                }
                continue;
            }
            match letter {
                b'I' | b'J' | b'K' => {
                    let k = (letter - b'I') as usize;
                    match self.axis_value(&w) {
                        Ok(v) => ijk[k] = Some((ti, v)),
                        Err(s) => {
                            skip.get_or_insert(s);
                        }
                    }
                }
                b'R' => match self.axis_value(&w) {
                    Ok(v) => r_word = Some((ti, v)),
                    Err(s) => {
                        skip.get_or_insert(s);
                    }
                },
                b'P' => {
                    if let Value::Num(v) = w.value {
                        p_turns = Some(v);
                    }
                }
                b'F' => {
                    if let Value::Num(v) = w.value {
                        mv.feed = Some((ti, v));
                    } else {
                        skip.get_or_insert(Skip::Expression);
                    }
                }
                b'U' | b'V' | b'W' => {
                    skip.get_or_insert(Skip::UnknownAxis(letter));
                }
                _ => {}
            }
        }
        self.pos = mv.end;
        mv.kind = match motion {
            Motion::Rapid => MoveKind::Rapid,
            Motion::Linear => MoveKind::Linear,
            Motion::ArcCw | Motion::ArcCcw => {
                let cw = motion == Motion::ArcCw;
                let (a, b, _) = self.plane.axes();
                let (s0, s1, e0, e1) = (start[a], start[b], mv.end[a], mv.end[b]);
                let (Some(s0), Some(s1), Some(e0), Some(e1)) = (s0, s1, e0, e1) else {
                    return Event::Skip(skip.unwrap_or(Skip::PositionUnknown(
                        AXES[if start[a].is_none() || mv.end[a].is_none() {
                            a
                        } else {
                            b
                        }],
                    )));
                };
                let center = if let Some((_, r)) = r_word {
                    match center_from_radius([s0, s1], [e0, e1], r, cw) {
                        Some(c) => c,
                        None => {
                            return Event::Skip(skip.unwrap_or(Skip::Element(
                                "an arc whose radius does not reach its end point",
                            )));
                        }
                    }
                } else {
                    let off = |axis: usize| ijk[axis].map(|(_, v)| v).unwrap_or(0.0);
                    if self.arc_absolute {
                        [
                            ijk[a].map(|(_, v)| v).unwrap_or(s0),
                            ijk[b].map(|(_, v)| v).unwrap_or(s1),
                        ]
                    } else {
                        [s0 + off(a), s1 + off(b)]
                    }
                };
                MoveKind::Arc(Arc {
                    plane: self.plane,
                    cw,
                    center,
                    turns: p_turns.map_or(0, |p| (p.round() as u32).saturating_sub(1)),
                    center_words: [
                        ijk[0].map(|x| x.0),
                        ijk[1].map(|x| x.0),
                        ijk[2].map(|x| x.0),
                    ],
                    radius_word: r_word.map(|x| x.0),
                })
            }
            Motion::Other => unreachable!(),
        };
        if self.tcp == Tcp::Vector && !matches!(mv.kind, MoveKind::Arc(_)) {
            // G43.5: I J K are the tool direction; omitted ones are zero.
            if ijk.iter().any(|x| x.is_some()) {
                let v = [
                    ijk[0].map_or(0.0, |x| x.1),
                    ijk[1].map_or(0.0, |x| x.1),
                    ijk[2].map_or(0.0, |x| x.1),
                ];
                mv.tool_vector = Some((
                    v,
                    [
                        ijk[0].map(|x| x.0),
                        ijk[1].map(|x| x.0),
                        ijk[2].map(|x| x.0),
                    ],
                ));
            }
        }
        if let Some(s) = skip.or_else(|| self.frame_skip()) {
            return Event::Skip(s);
        }
        Event::Move(mv)
    }

    // ---------------------------------------------------------- HEIDENHAIN

    fn heidenhain(&mut self, block: &Block, seg: &Segment, kind: HhKind) -> Event {
        // M functions may appear in any block.
        let mut m91 = false;
        for (_, w) in block.words(seg) {
            if w.addr == Addr::letter(b'M')
                && let Value::Num(v) = w.value
            {
                match v.round() as u32 {
                    128 => self.set_tcp(Tcp::Axes),
                    129 => self.set_tcp(Tcp::Off),
                    91 | 92 => m91 = true,
                    _ => {}
                }
            }
        }
        let text_has = |needle: &str| {
            block.seg_tokens(seg).iter().any(|t| {
                matches!(t.kind, TokenKind::Text | TokenKind::Keyword)
                    && block.bytes(t.span).eq_ignore_ascii_case(needle.as_bytes())
            })
        };
        match kind {
            HhKind::BeginPgm => {
                if text_has("INCH") {
                    self.units = Units::Inch;
                } else {
                    self.units = Units::Mm;
                }
                Event::None
            }
            HhKind::L => self.hh_line(block, seg, m91),
            HhKind::C | HhKind::Cr => self.hh_arc(block, seg, kind, m91),
            HhKind::Cc => {
                let mut p = [self.pos[0], self.pos[1]];
                let mut expr = false;
                let mut any = false;
                for (_, w) in block.words(seg) {
                    let Some(i) = self.axis_index(w.addr).filter(|&i| i < 2) else {
                        continue;
                    };
                    any = true;
                    match self.axis_value(&w) {
                        Ok(v) => {
                            p[i] = if w.incremental {
                                self.pos[i].map(|q| q + v)
                            } else {
                                Some(v)
                            };
                        }
                        Err(_) => expr = true,
                    }
                }
                let _ = any;
                self.pole = match (p[0], p[1], expr) {
                    (Some(x), Some(y), false) => Some([x, y]),
                    _ => None,
                };
                Event::None
            }
            HhKind::Lp | HhKind::Cp | HhKind::Ct | HhKind::Appr | HhKind::Dep | HhKind::Ln => {
                // Moves that are not rewritten: follow the Cartesian words,
                // forget the plane position when polar.
                let polar = matches!(kind, HhKind::Lp | HhKind::Cp);
                self.track_words(block, seg);
                if polar || matches!(kind, HhKind::Appr | HhKind::Dep) {
                    let given: Vec<usize> = block
                        .words(seg)
                        .filter_map(|(_, w)| self.axis_index(w.addr))
                        .collect();
                    for i in 0..2 {
                        if !given.contains(&i) {
                            self.pos[i] = None;
                        }
                    }
                }
                Event::Skip(Skip::Element(match kind {
                    HhKind::Lp => "polar line (LP)",
                    HhKind::Cp => "polar circle (CP)",
                    HhKind::Ct => "tangential circle (CT)",
                    HhKind::Appr => "approach (APPR)",
                    HhKind::Dep => "departure (DEP)",
                    _ => "vector line (LN)",
                }))
            }
            HhKind::Rnd | HhKind::Chf | HhKind::M => Event::None,
            HhKind::CyclDef { number, sub } => {
                self.hh_cycle(block, seg, number, sub);
                Event::None
            }
            HhKind::Plane => {
                self.tilted = true;
                self.forget();
                Event::None
            }
            HhKind::PlaneReset => {
                self.tilted = false;
                self.forget();
                Event::None
            }
            HhKind::FunctionTcpm => {
                let spatial = text_has("SPAT");
                self.set_tcp(if spatial { Tcp::Spatial } else { Tcp::Axes });
                Event::None
            }
            HhKind::FunctionResetTcpm => {
                self.set_tcp(Tcp::Off);
                Event::None
            }
            HhKind::TchProbe => {
                // Touch probe cycles 0 (reference plane) and 1 (polar
                // datum plane) move the linear axes only; the others may
                // turn a rotary axis (403, 405) or move anywhere.
                if matches!(tch_probe_number(&block.text), Some(0 | 1)) {
                    self.pos[0] = None;
                    self.pos[1] = None;
                    self.pos[2] = None;
                } else {
                    self.forget();
                }
                Event::Quiet
            }
            HhKind::ToolCall | HhKind::CyclCall => {
                self.forget();
                Event::None
            }
            HhKind::Lbl | HhKind::CallLbl | HhKind::CallPgm | HhKind::Stop => {
                self.forget();
                Event::None
            }
            HhKind::Fn(9) | HhKind::Fn(10) | HhKind::Fn(11) | HhKind::Fn(12) => {
                self.forget();
                Event::None
            }
            _ => Event::None,
        }
    }

    fn cancel(&mut self, what: &str) {
        if self.transformed == Some(what) {
            self.transformed = None;
        }
    }

    fn set_tcp(&mut self, t: Tcp) {
        if self.tcp != t {
            self.tcp = t;
            self.forget();
        }
    }

    fn hh_cycle(&mut self, block: &Block, seg: &Segment, number: u32, sub: Option<u32>) {
        let sub = sub.unwrap_or(0);
        let words: Vec<Word> = block.words(seg).map(|(_, w)| w).collect();
        let hash = block
            .seg_tokens(seg)
            .iter()
            .any(|t| t.kind == TokenKind::Text && block.bytes(t.span).starts_with(b"#"));
        match (number, sub) {
            (7, s) if s >= 1 => {
                if hash {
                    self.shift_known = false;
                }
                for w in &words {
                    if let Some(i) = self.axis_index(w.addr).filter(|&i| i < 3)
                        && let Value::Num(v) = w.value
                    {
                        self.shift[i] = v;
                    }
                }
                // Values written with a space between letter and sign
                // (`X + 0`) come as text: read them from the raw block.
                if words.is_empty() && !hash {
                    let txt = String::from_utf8_lossy(&block.text).to_string();
                    let body = txt.split("7.").nth(1).unwrap_or("");
                    let compact: String = body.chars().filter(|c| !c.is_whitespace()).collect();
                    for (i, l) in ['X', 'Y', 'Z'].iter().enumerate() {
                        if let Some(p) = compact.find(*l) {
                            let rest = &compact[p + 1..];
                            let n = super::number::lex_len(rest.as_bytes());
                            if n > 0 {
                                self.shift[i] = super::number::read(&rest.as_bytes()[..n]).value;
                            }
                        }
                    }
                }
                self.forget();
            }
            (19, s) if s >= 1 => {
                let any = words.iter().any(|w| {
                    matches!(w.value, Value::Num(v) if v != 0.0) || w.value == Value::Expr
                });
                self.tilted = any;
                self.forget();
            }
            (10, s) if s >= 1 => {
                let rot = words.iter().any(|w| {
                    matches!(w.value, Value::Num(v) if v != 0.0) || w.value == Value::Expr
                });
                self.transformed = rot.then_some("coordinate rotation (CYCL DEF 10)");
            }
            (8, s) if s >= 1 => {
                let any = block.seg_tokens(seg).iter().any(|t| {
                    t.kind == TokenKind::Text && matches!(block.bytes(t.span), b"X" | b"Y" | b"Z")
                });
                self.transformed = any.then_some("mirror image (CYCL DEF 8)");
            }
            (11, s) | (26, s) if s >= 1 => {
                let unity = words
                    .iter()
                    .all(|w| matches!(w.value, Value::Num(v) if (v - 1.0).abs() < 1e-12));
                self.transformed = (!unity).then_some("scaling (CYCL DEF 11/26)");
            }
            (247, _) => {
                self.work_offset = 100_000 + 247;
                self.forget();
            }
            _ => {}
        }
    }

    fn hh_targets(&mut self, block: &Block, seg: &Segment, mv: &mut Move, skip: &mut Option<Skip>) {
        for (ti, w) in block.words(seg) {
            if let Some(i) = self.axis_index(w.addr) {
                mv.words[i] = Some(ti);
                mv.incremental[i] = w.incremental;
                if !self.machine_axis(i) {
                    skip.get_or_insert(Skip::UnknownAxis(AXES[i]));
                }
                match self.axis_value(&w) {
                    Ok(v) => {
                        mv.end[i] = if w.incremental {
                            mv.start[i].map(|p| p + v)
                        } else {
                            Some(v)
                        };
                    }
                    Err(s) => {
                        mv.end[i] = None;
                        skip.get_or_insert(s);
                    }
                }
            } else if w.addr == Addr::letter(b'F') {
                match w.value {
                    Value::Num(v) => {
                        mv.feed = Some((ti, v));
                        self.feed = Some(v);
                    }
                    _ => {
                        skip.get_or_insert(Skip::Expression);
                    }
                }
            } else if w.addr == Addr::new("RL") || w.addr == Addr::new("RR") {
                self.radius_comp = true;
            } else if w.addr == Addr::new("R0") {
                self.radius_comp = false;
            } else if matches!(w.addr.as_letter(), Some(b'U' | b'V' | b'W')) {
                skip.get_or_insert(Skip::UnknownAxis(w.addr.as_letter().unwrap()));
            }
        }
    }

    fn hh_line(&mut self, block: &Block, seg: &Segment, m91: bool) -> Event {
        let rapid = block.words(seg).any(|(_, w)| w.addr == Addr::new("FMAX"));
        let mut mv = Move {
            kind: if rapid {
                MoveKind::Rapid
            } else {
                MoveKind::Linear
            },
            start: self.pos,
            end: self.pos,
            words: [None; 6],
            incremental: [false; 6],
            motion_word: None,
            feed: None,
            tool_vector: None,
        };
        let mut skip = seg.unknown.map(|_| Skip::UnknownWord);
        self.hh_targets(block, seg, &mut mv, &mut skip);
        if m91 {
            for i in 0..6 {
                if mv.words[i].is_some() {
                    self.pos[i] = None;
                }
            }
            return if mv.words.iter().any(|w| w.is_some()) {
                Event::Quiet
            } else {
                Event::None
            };
        }
        self.pos = mv.end;
        if mv.words.iter().all(|w| w.is_none()) {
            return Event::None;
        }
        if let Some(s) = skip.or_else(|| self.frame_skip()) {
            return Event::Skip(s);
        }
        Event::Move(mv)
    }

    fn hh_arc(&mut self, block: &Block, seg: &Segment, kind: HhKind, m91: bool) -> Event {
        let mut mv = Move {
            kind: MoveKind::Linear,
            start: self.pos,
            end: self.pos,
            words: [None; 6],
            incremental: [false; 6],
            motion_word: None,
            feed: None,
            tool_vector: None,
        };
        let mut skip = seg.unknown.map(|_| Skip::UnknownWord);
        self.hh_targets(block, seg, &mut mv, &mut skip);
        let mut cw = None;
        let mut radius: Option<(usize, f64)> = None;
        for (ti, w) in block.words(seg) {
            if w.addr == Addr::new("DR") {
                cw = Some(
                    block.bytes(w.value_span).is_empty()
                        && block.text[w.value_span.start as usize - 1] == b'-',
                );
            } else if w.addr == Addr::letter(b'R') {
                match w.value {
                    Value::Num(v) => radius = Some((ti, v)),
                    _ => {
                        skip.get_or_insert(Skip::Expression);
                    }
                }
            }
        }
        self.pos = mv.end;
        if m91 {
            return Event::Quiet;
        }
        // HEIDENHAIN circles are in the working plane; only XY is modelled.
        let (s0, s1, e0, e1) = (mv.start[0], mv.start[1], mv.end[0], mv.end[1]);
        let (Some(s0), Some(s1), Some(e0), Some(e1)) = (s0, s1, e0, e1) else {
            return Event::Skip(skip.unwrap_or(Skip::PositionUnknown(
                if mv.start[0].is_none() || mv.end[0].is_none() {
                    b'X'
                } else {
                    b'Y'
                },
            )));
        };
        if mv.words[2].is_some() && self.plane != Plane::Xy {
            return Event::Skip(Skip::Element("circle outside the XY plane"));
        }
        let cw = cw.unwrap_or(false);
        let center = match kind {
            HhKind::C => match self.pole {
                Some(p) => p,
                None => {
                    return Event::Skip(
                        skip.unwrap_or(Skip::Element("circle without a known pole (CC)")),
                    );
                }
            },
            _ => match radius {
                Some((_, r)) => match center_from_radius([s0, s1], [e0, e1], r, cw) {
                    Some(c) => c,
                    None => {
                        return Event::Skip(skip.unwrap_or(Skip::Element(
                            "circle whose radius does not reach its end point",
                        )));
                    }
                },
                None => return Event::Skip(skip.unwrap_or(Skip::Element("CR without a radius"))),
            },
        };
        mv.kind = MoveKind::Arc(Arc {
            plane: Plane::Xy,
            cw,
            center,
            turns: 0,
            center_words: [None; 3],
            radius_word: radius.map(|r| r.0),
        });
        if let Some(s) = skip.or_else(|| self.frame_skip()) {
            return Event::Skip(s);
        }
        Event::Move(mv)
    }
}

/// The centre of an arc from `s` to `e` with radius `r` (positive: at most
/// half a circle; negative: more), turning clockwise or not.
pub fn center_from_radius(s: [f64; 2], e: [f64; 2], r: f64, cw: bool) -> Option<[f64; 2]> {
    let (dx, dy) = (e[0] - s[0], e[1] - s[1]);
    let d = dx.hypot(dy);
    if d == 0.0 || d > 2.0 * r.abs() * (1.0 + 1e-9) {
        return None;
    }
    let h = (r * r - d * d / 4.0).max(0.0).sqrt();
    let (mx, my) = ((s[0] + e[0]) / 2.0, (s[1] + e[1]) / 2.0);
    let (ux, uy) = (-dy / d, dx / d); // left normal of the chord
    // Counter-clockwise minor arcs have their centre on the left.
    let left = cw != (r > 0.0);
    let sgn = if left { 1.0 } else { -1.0 };
    Some([mx + sgn * h * ux, my + sgn * h * uy])
}

/// The cycle number of a `TCH PROBE n.m` block.
fn tch_probe_number(text: &[u8]) -> Option<u32> {
    let up = text.to_ascii_uppercase();
    let at = up.windows(9).position(|w| w == b"TCH PROBE")? + 9;
    let rest = &up[at..];
    let start = rest.iter().position(|b| !b.is_ascii_whitespace())?;
    let digits: Vec<u8> = rest[start..]
        .iter()
        .take_while(|b| b.is_ascii_digit())
        .copied()
        .collect();
    std::str::from_utf8(&digits).ok()?.parse().ok()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nc::Syntax;

    fn run(src: &str, d: Dialect) -> (Vec<Event>, Modal) {
        let mut m = Modal::new(ModalSettings {
            dialect: d,
            rotary: [b'B', b'C'],
            fanuc_integer_unit: None,
        });
        let syn = Syntax {
            dialect: d,
            strict: false,
        };
        let mut out = Vec::new();
        let mut r = crate::nc::BlockReader::new(src.as_bytes(), d);
        let mut b = Block::default();
        while r.read(&mut b).unwrap() {
            syn.parse(&mut b).unwrap();
            for seg in b.segments.clone() {
                out.push(m.step(&b, &seg));
            }
        }
        (out, m)
    }

    fn mv(e: &Event) -> &Move {
        match e {
            Event::Move(m) => m,
            other => panic!("not a move: {other:?}"),
        }
    }

    #[test]
    fn tracks_units_distance_motion_feed_and_offsets() {
        let (ev, m) = run(
            "G20 G91 G93 G55 G18\nG0 X1. Y2. Z3. B0 C0\nG1 X1. F2.\n",
            Dialect::Fanuc,
        );
        assert_eq!(m.units, Units::Inch);
        assert!(!m.absolute);
        assert_eq!(m.feed_mode, FeedMode::InverseTime);
        assert_eq!(m.work_offset, 550);
        assert_eq!(m.plane, Plane::Zx);
        assert_eq!(m.motion, Some(Motion::Linear));
        // Incremental from unknown positions: nothing known yet.
        assert_eq!(mv(&ev[1]).end, [None; 6]);
        assert_eq!(mv(&ev[2]).end, [None; 6]);
    }

    #[test]
    fn absolute_moves_fill_modal_axes() {
        let (ev, _) = run(
            "G90 G0 X1. Y2. Z3. B10. C20.\nG1 X5. F100.\n",
            Dialect::Fanuc,
        );
        let m = mv(&ev[1]);
        assert_eq!(
            m.start,
            [
                Some(1.0),
                Some(2.0),
                Some(3.0),
                None,
                Some(10.0),
                Some(20.0)
            ]
        );
        assert_eq!(m.end[0], Some(5.0));
        assert_eq!(m.end[4], Some(10.0));
        assert_eq!(m.feed.map(|f| f.1), Some(100.0));
    }

    #[test]
    fn tcp_and_tilted_plane_and_machine_coordinates() {
        let (ev, m) = run(
            "G43.4 H1\nG0 X0 Y0 Z10. B0 C0\nG53 Z0\nG68.2 X0 Y0 Z0 I0 J30. K0\nG53.1\nG1 X1. Y1. Z1.\nG69\n",
            Dialect::Fanuc,
        );
        assert_eq!(m.tcp, Tcp::Axes);
        assert!(matches!(ev[1], Event::Move(_)));
        assert_eq!(ev[2], Event::Quiet);
        assert_eq!(ev[5], Event::Skip(Skip::TiltedPlane));
        assert!(!m.tilted);
    }

    #[test]
    fn expressions_are_skipped_and_forget_the_axis() {
        let (ev, m) = run("G0 X1. Y2. Z3. B0 C0\nG1 X[#1+2.] F100.\n", Dialect::Fanuc);
        assert_eq!(ev[1], Event::Skip(Skip::Expression));
        assert_eq!(m.pos[0], None);
    }

    #[test]
    fn fanuc_integers_are_ambiguous_unless_told() {
        let (ev, _) = run("G0 X10 Y2. Z3. B0 C0\n", Dialect::Fanuc);
        assert_eq!(ev[0], Event::Skip(Skip::FanucInteger));
        let (ev, _) = run("G0 X10 Y2 Z3 B0 C0\n", Dialect::Linuxcnc);
        assert!(matches!(ev[0], Event::Move(_)));
    }

    #[test]
    fn arcs_by_centre_and_by_radius() {
        let (ev, _) = run(
            "G17 G0 X10. Y0 Z0 B0 C0\nG3 X0 Y10. I-10. J0 F100.\nG2 X10. Y0 R10.\n",
            Dialect::Fanuc,
        );
        let MoveKind::Arc(a) = mv(&ev[1]).kind else {
            panic!()
        };
        assert_eq!(a.center, [0.0, 0.0]);
        assert!(!a.cw);
        let MoveKind::Arc(a) = mv(&ev[2]).kind else {
            panic!()
        };
        assert!(a.cw);
        assert!(
            (a.center[0]).abs() < 1e-12 && a.center[1].abs() < 1e-12,
            "{:?}",
            a.center
        );
    }

    #[test]
    fn control_flow_forgets_positions() {
        let (ev, _) = run(
            "G0 X1. Y2. Z3. B0 C0\nWHILE [#1 LT 3] DO1\nG1 X5. F100.\nEND1\n",
            Dialect::Fanuc,
        );
        let m = mv(&ev[2]);
        assert_eq!(m.start, [None; 6]);
        assert_eq!(m.end[0], Some(5.0));
        assert_eq!(m.end[1], None);
    }

    #[test]
    fn probing_forgets_only_what_the_probe_moves() {
        // TCH PROBE 0 moves the linear axes only: B and C stay known.
        let (ev, _) = run(
            "0 BEGIN PGM T MM\n1 L X+10 Y+0 Z+5 B+0 C+30 R0 FMAX\n2 TCH PROBE 0.0 REF. PLANE Q1 X+\n3 TCH PROBE 0.1 X+0 Y+0 Z+5\n4 L X+1 Y+2 Z+3 R0 F100\n5 TCH PROBE 403 ROT IN ROTARY AXIS ~\n  Q263=+0 ;1ST POINT 1ST AXIS\n6 L X+1 Y+2 Z+3 R0 F100\n7 END PGM T MM\n",
            Dialect::Heidenhain,
        );
        assert_eq!(ev[2], Event::Quiet);
        let m = mv(&ev[4]);
        assert_eq!(&m.start[..3], &[None; 3]);
        assert_eq!(m.start[4], Some(0.0));
        assert_eq!(m.start[5], Some(30.0));
        // Cycle 403 may turn the table: everything is forgotten.
        assert_eq!(mv(&ev[6]).start, [None; 6]);
        assert_eq!(
            tch_probe_number(b"12 TCH PROBE 1.0 POLAR DATUM PLANE"),
            Some(1)
        );
        assert_eq!(
            tch_probe_number(b"TCH PROBE 412 DATUM CIRC. CENTER"),
            Some(412)
        );
        // G31 forgets the axes it names.
        let (ev, _) = run(
            "G0 X1. Y2. Z3. B0 C0\nG31 Z-10. F100.\nG1 X2.\n",
            Dialect::Fanuc,
        );
        let m = mv(&ev[2]);
        assert_eq!(m.start[0], Some(1.0));
        assert_eq!(m.start[2], None);
        assert_eq!(m.start[5], Some(0.0));
    }

    #[test]
    fn heidenhain_blocks() {
        let (ev, m) = run(
            "0 BEGIN PGM T MM\n1 L X+10 Y+0 Z+5 B+0 C+0 R0 FMAX\n2 CC X+0 Y+0\n3 C X+0 Y+10 DR+ F500\n4 CR X+10 Y+0 R+10 DR- F500\n5 L IX+1 F500\n6 M128\n7 CYCL DEF 7.0 DATUM SHIFT\n8 CYCL DEF 7.1 X+100\n9 PLANE SPATIAL SPA+0 SPB+30 SPC+0 TURN FMAX\n10 L X+1 Y+1 Z+1 B+0 C+0 F100\n11 PLANE RESET STAY\n12 END PGM T MM\n",
            Dialect::Heidenhain,
        );
        assert_eq!(mv(&ev[1]).kind, MoveKind::Rapid);
        let MoveKind::Arc(a) = mv(&ev[3]).kind else {
            panic!()
        };
        assert_eq!(a.center, [0.0, 0.0]);
        assert!(!a.cw);
        let MoveKind::Arc(a) = mv(&ev[4]).kind else {
            panic!()
        };
        assert!(a.cw);
        assert_eq!(mv(&ev[5]).end[0], Some(11.0));
        assert_eq!(m.tcp, Tcp::Axes);
        assert_eq!(m.shift[0], 100.0);
        assert_eq!(ev[10], Event::Skip(Skip::TiltedPlane));
        assert!(!m.tilted);
    }

    #[test]
    fn radius_centres_are_on_the_right_side() {
        // Quarter circle from (10,0) to (0,10) counter-clockwise about 0.
        let c = center_from_radius([10.0, 0.0], [0.0, 10.0], 10.0, false).unwrap();
        assert!(c[0].abs() < 1e-12 && c[1].abs() < 1e-12);
        // Clockwise, same chord: centre at (10, 10).
        let c = center_from_radius([10.0, 0.0], [0.0, 10.0], 10.0, true).unwrap();
        assert!((c[0] - 10.0).abs() < 1e-12 && (c[1] - 10.0).abs() < 1e-12);
        // Negative radius: the major arc, centre on the other side.
        let c = center_from_radius([10.0, 0.0], [0.0, 10.0], -10.0, false).unwrap();
        assert!((c[0] - 10.0).abs() < 1e-12 && (c[1] - 10.0).abs() < 1e-12);
    }
}
