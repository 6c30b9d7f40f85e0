//! The NC interpreter: what the controller has in force at each block, and
//! where each move goes.
//!
//! One [`Interpreter`] follows a program in file order for `compensate` and
//! for `simulate nc`: units (G20/G21, `BEGIN PGM ... MM|INCH`), absolute or
//! incremental distances (G90/G91, HEIDENHAIN's `I` prefix), the motion
//! mode (G0/G1/G2/G3, canned cycles, `L ... FMAX`), the feed mode (G93
//! inverse time, G94, G95), the plane, the work offset (G54..G59, G54.1 Pn,
//! HEIDENHAIN presets), tool length compensation (G43/G49), tool centre
//! point control (G43.4, G43.5, M128, FUNCTION TCPM, M-codes the machine
//! file names), the tilted working plane (G68.2, PLANE, CYCL DEF 19), datum
//! shifts (G52, G92, CYCL DEF 7), transformations it does not model (G68
//! rotation, G51 scaling, mirroring, polar coordinates) and the last
//! programmed position of every axis. It also turns program coordinates
//! into the model frame of the kinematics ([`Frame`]) and, under G43.5,
//! the programmed tool direction into the rotary positions the nominal
//! controller picks.
//!
//! The semantics of each dialect live in one file: [`gcode`] holds the
//! word-address G-code of FANUC and LinuxCNC, `heidenhain` Klartext,
//! `sinumerik` the SINUMERIK language;
//! another dialect is one more file and one more arm in
//! [`Interpreter::step`].
//!
//! Each statement becomes an [`Event`]: no motion, a [`Move`] with its
//! start and end in program coordinates, or a motion that must be left as
//! written, with the reason ([`Skip`]). Positions are tracked in file order;
//! where control flow makes the position at runtime unknowable statically
//! (labels, loops, calls, jumps, probing, tool changes) the tracked position
//! is forgotten, so a move there is rewritten only when its own words fix
//! every axis. The whole state is a plain value: it can be cloned and
//! handed from one stretch of a program to the next.

pub mod approach;
pub mod coordinates;
pub mod corner;
pub mod gcode;
mod heidenhain;
pub mod interpolation;
pub mod offsets;
pub mod plane;
mod sinumerik;
pub mod tangent;

use std::sync::Arc as Shared;

use nalgebra::{Matrix3, Vector3};

pub use coordinates::Frame;
pub use heidenhain::CycleDef;
pub use plane::{PlaneSkip, Tilt, WorkPlane};

use super::{Addr, Block, Entry, HhKind, Segment, Stmt, TokenKind, Value, Word};
use crate::kinematics::fast::FastChain;
use crate::kinematics::{Axes, Kinematics, ToolPose};
use crate::machine::Dialect;

/// Axis indices: X, Y, Z, A, B, C.
pub(crate) const AXES: [u8; 6] = *b"XYZABC";

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

impl Motion {
    /// The motion of G0, G1, G2 or G3, as [`gcode::g_code`] numbers them
    /// (ten times the code); `None` for any other code.
    pub(crate) fn of_g(g: u32) -> Option<Motion> {
        match g {
            0 => Some(Motion::Rapid),
            10 => Some(Motion::Linear),
            20 => Some(Motion::ArcCw),
            30 => Some(Motion::ArcCcw),
            _ => None,
        }
    }
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
pub enum ArcPlane {
    /// G17.
    Xy,
    /// G18.
    Zx,
    /// G19.
    Yz,
}

impl ArcPlane {
    /// (first, second, normal) axis indices.
    pub fn axes(self) -> (usize, usize, usize) {
        match self {
            ArcPlane::Xy => (0, 1, 2),
            ArcPlane::Zx => (2, 0, 1),
            ArcPlane::Yz => (1, 2, 0),
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

impl Tcp {
    /// What the program's coordinates are in this mode.
    pub fn meaning(self) -> &'static str {
        match self {
            Tcp::Off => "axis positions (no tool-centre-point control)",
            Tcp::Axes => "tool tip in the workpiece (TCP, rotary axis positions)",
            Tcp::Vector => "tool tip in the workpiece (TCP, tool direction vectors)",
            Tcp::Spatial => "tool tip with spatial angles (TCP, left as written)",
        }
    }
}

/// What last switched tool-centre-point control on or off.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TcpCause {
    /// 1-based line.
    pub line: usize,
    /// The statement, as written (cut to a few words).
    pub code: String,
    /// The machine file's `m_codes:` made it a TCP code.
    pub machine_file: bool,
}

/// A statement whose effect the interpreter does not model, noted so that
/// the run reports it (and `--strict` refuses it).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Unmodelled {
    /// Byte offset in the block.
    pub offset: usize,
    /// What it is and what fivecal does about it.
    pub what: String,
}

/// How the program's coordinates are meant.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Coordinates {
    /// As the program switches TCP on and off (G43.4/G43.5, M128/TCPM).
    Auto,
    /// Always axis positions (a post-side program), whatever TCP code it has.
    Axes,
    /// Always tool-tip coordinates in W (a controller whose kinematics
    /// always runs TCP, e.g. LinuxCNC with trt-kins).
    Tcp,
}

/// Which of three kinds a reason to leave a move as written is: what a
/// user can do about each differs. Where the file does not say, only the
/// user, the machine or the calling program knows (a flag may state it);
/// what is not implemented yet is fivecal's to add; a program for another
/// machine is the wrong program, or the wrong machine file.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum ReasonKind {
    /// The program leaves it open: a system variable, an operator's table
    /// value, the caller of a subroutine file, a rotary axis never set, a
    /// block the controller itself could read in more than one way.
    Unsaid,
    /// A construct fivecal does not follow yet.
    NotImplemented,
    /// Axes, kinematics or strokes that do not match the machine file.
    OtherMachine,
}

impl ReasonKind {
    /// Every kind, in the order a report lists them.
    pub const ALL: [ReasonKind; 3] = [
        ReasonKind::Unsaid,
        ReasonKind::NotImplemented,
        ReasonKind::OtherMachine,
    ];

    /// A stable name for machine-readable output.
    pub fn key(self) -> &'static str {
        match self {
            ReasonKind::Unsaid => "file_does_not_say",
            ReasonKind::NotImplemented => "not_implemented",
            ReasonKind::OtherMachine => "other_machine",
        }
    }

    /// What a user can do about it, said once under the heading of a report.
    pub fn advice(self) -> &'static str {
        match self {
            ReasonKind::Unsaid => {
                "only the machine, its operator or the calling program knows; state it where a flag is named"
            }
            ReasonKind::NotImplemented => "a construct fivecal does not follow yet",
            ReasonKind::OtherMachine => {
                "axes, kinematics or strokes that do not match the machine file"
            }
        }
    }
}

impl std::fmt::Display for ReasonKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            ReasonKind::Unsaid => "the file does not say",
            ReasonKind::NotImplemented => "not implemented yet",
            ReasonKind::OtherMachine => "a program for another machine",
        })
    }
}

/// Why a move is left as written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Skip {
    /// A coordinate is an expression or a parameter.
    Expression,
    /// A block with axis words that the program's own logic never runs
    /// (a branch not taken, a subroutine this file defines but does not
    /// call): the controller's state does not pass through it.
    NeverRuns,
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
    /// A tilted working plane is active and the move cannot be corrected
    /// in it.
    TiltedPlane(PlaneSkip),
    /// Tool centre point control with spatial angles.
    TcpSpatial,
    /// A macro call with axis arguments (G65/G66).
    MacroCall,
    /// Canned cycle positions.
    CannedCycle,
    /// A HEIDENHAIN cycle call whose hole is not corrected: which kind of
    /// reason, and why.
    CycleCall(ReasonKind, &'static str),
    /// The move after a `RND`/`CHF` (at this line) whose corner fivecal
    /// does not follow, and why.
    AfterCorner(usize, &'static str),
    /// A HEIDENHAIN `APPR`/`DEP` whose path fivecal does not follow, and
    /// why.
    ApproachDeparture(&'static str),
    /// A HEIDENHAIN `CT` whose arc fivecal does not follow, and why.
    Tangential(&'static str),
    /// A contour element, or a form of one, that is not compensated: which
    /// kind of reason (a form fivecal does not follow, or one the block
    /// leaves open, such as an arc whose centre is not on its circle), and
    /// what it is.
    Element(ReasonKind, &'static str),
    /// The datum shift is not known (datum table row).
    ShiftUnknown,
    /// G43.5 without a tool direction in the block.
    NoToolVector,
    /// G43.5: no rotary positions of the nominal machine give the
    /// programmed tool direction.
    VectorOutOfReach,
    /// An axis, centre or radius value (this letter) beyond what a
    /// control takes ([`crate::limits::MAX_NC_VALUE`]).
    OutOfRange(u8),
    /// The work offset in force is not known relative to the one at the
    /// first move, and why.
    OffsetUnknown(&'static str),
    /// The block could not be read (kept byte for byte).
    Unreadable,
    /// An unreadable block at this line may have changed the modal state
    /// (a G or M code, a parameter, a cycle); nothing is corrected until a
    /// block sets it again (G90/G91; `BEGIN PGM`).
    StateUnknown(usize),
}

impl std::fmt::Display for Skip {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Skip::Expression => write!(f, "coordinates are expressions or variables"),
            Skip::UnknownWord => write!(f, "the block has a word fivecal does not know"),
            Skip::UnknownAxis(a) => write!(f, "axis {} is not an axis of this machine", *a as char),
            Skip::FanucInteger => write!(
                f,
                "axis value without a decimal point (FANUC reads it in mm or in least input increments by parameter 3401#0; pass --integer-unit or set integer_unit in the machine file)"
            ),
            // A rotary axis the program never sets stands where the
            // machine was left: only the user can say where.
            Skip::PositionUnknown(a @ (b'A' | b'B' | b'C')) => write!(
                f,
                "the position of {a} is not known here (not yet programmed: give its start with --rotary-start {a}=DEG; or forgotten after a jump, call, probe or tool change)",
                a = *a as char
            ),
            Skip::PositionUnknown(a) => write!(
                f,
                "the position of {} is not known here (not yet programmed, or forgotten after a jump, call, probe or tool change)",
                *a as char
            ),
            Skip::Transformed(what) => write!(f, "{what} is active"),
            Skip::TiltedPlane(why) => write!(f, "{why}"),
            Skip::TcpSpatial => write!(f, "TCPM with spatial angles (AXIS SPAT) is not modelled"),
            Skip::MacroCall => write!(f, "macro call arguments (G65/G66)"),
            Skip::CannedCycle => write!(f, "canned cycle, spline or thread positions"),
            Skip::AfterCorner(line, why) => write!(
                f,
                "the element after the rounding or chamfer at line {line}, which fivecal follows only between two straight lines: {why}"
            ),
            Skip::CycleCall(_, why) => write!(
                f,
                "cycle call position (CYCL CALL POS) left as written: {why}"
            ),
            Skip::ApproachDeparture(why) => {
                write!(f, "approach or departure (APPR/DEP) left as written: {why}")
            }
            Skip::Tangential(why) => write!(f, "tangential circle (CT) left as written: {why}"),
            Skip::Element(_, what) => write!(f, "not compensated: {what}"),
            Skip::ShiftUnknown => write!(f, "the datum shift comes from a table (value unknown)"),
            Skip::NoToolVector => write!(f, "tool direction (I J K) not programmed"),
            Skip::VectorOutOfReach => write!(
                f,
                "tool direction out of reach: no rotary positions of the nominal machine give it"
            ),
            Skip::OutOfRange(a) => write!(
                f,
                "{} value beyond what a control takes (five integer digits: at most {} mm, or deg for a rotary axis)",
                *a as char,
                crate::limits::MAX_NC_VALUE
            ),
            Skip::OffsetUnknown(why) => write!(f, "{why}"),
            Skip::Unreadable => write!(f, "the block could not be read"),
            Skip::NeverRuns => write!(
                f,
                "never runs in this program's own logic (a branch not taken, or a subroutine the file defines but does not call: its moves depend on its caller)"
            ),
            Skip::StateUnknown(line) => write!(
                f,
                "the controller state is unknown after the unreadable block at line {line} (until G90/G91 or BEGIN PGM sets it again)"
            ),
        }
    }
}

impl Skip {
    /// Which kind of reason this is (see [`ReasonKind`]), assigned case by
    /// case.
    pub fn kind(&self) -> ReasonKind {
        use ReasonKind::{NotImplemented, OtherMachine, Unsaid};
        match self {
            // A variable's value is in the file only where the macro logic
            // is followed; what is left is a system variable, a table value
            // or an argument from a caller.
            Skip::Expression => Unsaid,
            Skip::NeverRuns => Unsaid,
            Skip::UnknownWord => NotImplemented,
            Skip::UnknownAxis(_) => OtherMachine,
            // Parameter 3401#0 of the control, not a word of the program.
            Skip::FanucInteger => Unsaid,
            // Never programmed (`--rotary-start` states it) or forgotten
            // where the control's documented behaviour leaves it open.
            Skip::PositionUnknown(_) => Unsaid,
            Skip::Transformed(_) => NotImplemented,
            Skip::TiltedPlane(p) => p.kind(),
            Skip::TcpSpatial => NotImplemented,
            // The macro's body is a program in the control's memory, not
            // in this file.
            Skip::MacroCall => Unsaid,
            Skip::CannedCycle => NotImplemented,
            Skip::CycleCall(kind, _) | Skip::Element(kind, _) => *kind,
            Skip::AfterCorner(..) => NotImplemented,
            Skip::ApproachDeparture(why) | Skip::Tangential(why) => kind_of(why),
            // A datum table row: the operator's value.
            Skip::ShiftUnknown => Unsaid,
            Skip::NoToolVector => Unsaid,
            Skip::VectorOutOfReach => OtherMachine,
            // No machine's travel: a program written for other units or
            // another machine.
            Skip::OutOfRange(_) => OtherMachine,
            Skip::OffsetUnknown(why) => kind_of(why),
            // A block fivecal cannot read is one it does not implement (the
            // control may well run it); what follows it is unknown for the
            // same reason.
            Skip::Unreadable | Skip::StateUnknown(_) => NotImplemented,
        }
    }
}

/// The kind of a reason passed on as text from where it was found (an
/// approach's path, a tangential arc, a plane definition, a work offset):
/// those the block leaves open and those that do not fit the machine are
/// named here, every other one is a construct not implemented yet.
pub(crate) fn kind_of(why: &str) -> ReasonKind {
    match why {
        // What the block leaves open, or gives in a form the control
        // refuses or reads in no single way.
        "a polar approach without a known pole (CC)"
        | "X or Y in a polar approach (its first contour point is given by PR and PA around the pole CC)"
        | "its LEN is not a positive number"
        | "its end point is where it starts"
        | "its end point lies on the tangent of the element before it (no circle)"
        | "a parameter or an expression in G68.2"
        | "a parameter, an expression or a value without a decimal point in G68.2"
        | "a parameter or an unreadable value in the plane"
        | "a zero or unreadable vector"
        | "the base and normal vectors are not perpendicular"
        | "the three points lie on a line"
        | "G68.2 P3 with vectors that are not orthogonal"
        | "two rotary solutions are equally near the positions before the plane"
        | "G68.4 with no plane in force: FANUC then reads it as G68.2, LinuxCNC's remap stops with an error, so the file does not say which"
        | "CYCLE800 with fewer than 14 parameters"
        | offsets::UNRELATED => ReasonKind::Unsaid,
        "rotary positions of an axis this machine does not have"
        | "rotary positions without both of the machine's rotary axes"
        | "no rotary positions of the machine put the tool along it"
        | "no solution with the tilt of the requested sign (SEQ)" => ReasonKind::OtherMachine,
        // G10 sets an offset from what fivecal cannot relate to --origin:
        // the file does not say where it lies.
        w if w.starts_with("the external work offset (G10 L2 P0)")
            || w.starts_with("G10 L2/L20 changed a work offset") =>
        {
            ReasonKind::Unsaid
        }
        _ => ReasonKind::NotImplemented,
    }
}

/// The arc of a move.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Arc {
    /// Plane.
    pub plane: ArcPlane,
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

/// A SINUMERIK `CIP`: the circle from the move's start through an
/// intermediate point to its end.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Through {
    /// The intermediate point, absolute program coordinates (X, Y, Z).
    pub point: [f64; 3],
    /// The circle it makes with the move's start and end.
    pub geo: interpolation::CircleGeo,
    /// Token indices of `I1=`, `J1=`, `K1=`, if written.
    pub words: [Option<usize>; 3],
    /// Which of them count from the start (G91 or `=IC()`); an omitted
    /// one is the start's coordinate either way.
    pub incremental: [bool; 3],
    /// Token index of the `CIP` command, if the block has it (the mode is
    /// modal).
    pub keyword: Option<usize>,
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
    /// Circular interpolation through an intermediate point, in space.
    Through(Through),
}

/// One move, in program coordinates (program units, degrees, before the
/// datum shift).
#[derive(Clone, Debug, PartialEq)]
pub struct Move {
    /// Kind.
    pub kind: MoveKind,
    /// Position before the move (X Y Z A B C), where known.
    pub start: [Option<f64>; 6],
    /// Position after the move, where known (under G43.5 the rotary
    /// positions the nominal controller picks for the tool direction).
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
    /// G43.5: the programmed tool direction as a unit vector in W, once
    /// resolved into rotary positions.
    pub vector: Option<Vector3<f64>>,
    /// HEIDENHAIN LP/CP: the end point in the plane is written as polar
    /// radius and angle around the pole.
    pub polar: Option<Polar>,
    /// A canned drilling cycle: the move is the hole's bottom.
    pub drill: Option<Drill>,
    /// HEIDENHAIN `RND`/`CHF` before this line: the controller cuts the
    /// corner between the line before and this one.
    /// Boxed, as is `approach`: HEIDENHAIN's alone and rare, they would
    /// otherwise be a third of every move's bytes copied.
    pub corner: Option<Box<corner::Corner>>,
    /// HEIDENHAIN `CT`: the arc leaves its start in this unit direction
    /// (XY, program frame), the one the element before it ends in; its
    /// centre follows from it and the end point.
    pub tangential: Option<[f64; 2]>,
    /// HEIDENHAIN `APPR LT|LN`/`DEP LT|LN`: the move is one, its `LEN`
    /// and which.
    pub appr_dep: Option<approach::Tangential>,
    /// HEIDENHAIN `APPR LT|LN` before this move, the first contour element:
    /// the control's auxiliary point follows from the direction this move
    /// starts in.
    pub approach: Option<Box<approach::Approach>>,
}

/// The polar words of a HEIDENHAIN `LP`/`CP` block: token index and
/// whether it is incremental (`IPR`, `IPA`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Polar {
    /// `PR` / `IPR`.
    pub radius: Option<(usize, bool)>,
    /// `PA` / `IPA`.
    pub angle: Option<(usize, bool)>,
}

/// A hole of a canned drilling cycle (G73, G74, G76, G81-G89). Its
/// [`Move`] ends at the bottom of the hole; the cycle reaches it from
/// `r_level` along the drill axis, and leaves the tool at the R level
/// (G99) or back at the level it came from (G98).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Drill {
    /// The drill axis (index into X Y Z): the normal of the plane.
    pub axis: usize,
    /// The R level (program units, absolute).
    pub r_level: f64,
    /// G98: back to the initial level; G99: to the R level.
    pub to_initial: bool,
    /// A HEIDENHAIN `CYCL CALL POS`: its tool-axis word is the datum the
    /// cycle's own depth counts from, so the word holds the bottom minus
    /// this (`Q203 + Q201`), and where the cycle leaves the tool is not
    /// followed. `None` for the G-code cycles, whose word is the bottom.
    pub call_offset: Option<f64>,
}

impl Move {
    fn new(kind: MoveKind, start: [Option<f64>; 6], incremental: bool) -> Move {
        Move {
            kind,
            start,
            end: start,
            words: [None; 6],
            incremental: [incremental; 6],
            motion_word: None,
            feed: None,
            tool_vector: None,
            vector: None,
            polar: None,
            drill: None,
            corner: None,
            tangential: None,
            appr_dep: None,
            approach: None,
        }
    }
}

/// What a statement does.
// Events are returned by value once per statement and never stored in bulk:
// a box would be an allocation per statement. What costs is copying one,
// so the interpreter changes a move where it lies (see `step`).
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq)]
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

/// What the interpreter is told about the program and the machine.
#[derive(Clone, Debug, PartialEq)]
pub struct InterpreterSettings {
    /// The dialect.
    pub dialect: Dialect,
    /// How coordinates are meant.
    pub coordinates: Coordinates,
    /// Where the program zero lies in W at rotary zero, mm.
    pub origin: Vector3<f64>,
    /// FANUC axis values without a decimal point: mm per unit written
    /// (1 for calculator-type input, 0.001 or 0.0001 for least input
    /// increments), or `None` to leave such moves as written.
    pub integer_unit: Option<f64>,
    /// Positions of rotary axes before the program's first block, as the
    /// user states them (axis letter, deg): an axis the program never sets
    /// is otherwise unknown.
    pub rotary_start: Vec<(char, f64)>,
}

impl InterpreterSettings {
    /// Defaults for a dialect: TCP as the program switches it, program
    /// zero on the W origin, integer FANUC words left alone.
    pub fn new(dialect: Dialect) -> InterpreterSettings {
        InterpreterSettings {
            dialect,
            coordinates: Coordinates::Auto,
            origin: Vector3::zeros(),
            integer_unit: None,
            rotary_start: Vec::new(),
        }
    }
}

/// What does not change along a program: the settings and the machine.
#[derive(Debug)]
struct Config {
    settings: InterpreterSettings,
    /// Letters of the machine's two rotary axes (tilt, then C).
    rotary: [u8; 2],
    /// Index of the tilt axis in [`AXES`] (3 for A, 4 for B).
    tilt: usize,
    /// Gauge length of the tool, mm.
    tool_length: f64,
    /// The nominal kinematics, as the controller has it.
    nominal: FastChain,
    /// The machine's kinematics (the frame of a plane given by rotary
    /// positions).
    kin: Kinematics,
    /// The machine's own M functions.
    m_codes: crate::machine::MCodes,
    /// The axes a tool change may move (X Y Z A B C).
    tool_change: [bool; 6],
}

/// The controller's state along a program.
#[derive(Clone, Debug)]
pub struct Interpreter {
    cfg: Shared<Config>,
    /// Units.
    pub units: Units,
    /// G90 (ISO); HEIDENHAIN marks incremental words instead.
    pub absolute: bool,
    /// Arc centres absolute (LinuxCNC G90.1).
    pub arc_absolute: bool,
    /// Motion mode (ISO).
    pub motion: Option<Motion>,
    /// SINUMERIK: the motion mode in force is `CIP` (`motion` is
    /// [`Motion::Other`] then).
    pub cip: bool,
    /// Feed mode.
    pub feed_mode: FeedMode,
    /// Last feed value.
    pub feed: Option<f64>,
    /// Plane.
    pub plane: ArcPlane,
    /// Work offset in force: G code x 10 (540 = G54; 5410 + P for G54.1 P;
    /// 100000 + n for a HEIDENHAIN preset).
    pub work_offset: u32,
    /// Tool length compensation on (G43, G43.4, G43.5; always on HEIDENHAIN).
    pub tool_length: bool,
    /// Tool centre point control.
    pub tcp: Tcp,
    /// Tilted working plane on.
    pub tilted: bool,
    /// The tilted working plane in force (`Some` exactly when `tilted`).
    pub working_plane: Option<Tilt>,
    /// What defined the tilted plane in force.
    pub plane_cause: Option<TcpCause>,
    /// A LinuxCNC G68.2 P2/P3 whose parts are still being given.
    pub plane_pending: Option<plane::Pending>,
    /// A transformation fivecal does not model, by name.
    pub transformed: Option<&'static str>,
    /// G92 / CYCL DEF 7 datum shift per linear axis, program units.
    pub shift: [f64; 3],
    /// G52 local shift per linear axis, program units (SINUMERIK: the
    /// translation of the programmable frame, `TRANS`/`ATRANS`).
    pub local_shift: [f64; 3],
    /// The rotation of SINUMERIK's programmable frame (`ROT`/`AROT`): a
    /// point written at `p` lies at `frame_rot * p + local_shift` in the
    /// work offset's coordinates; identity elsewhere.
    pub frame_rot: Matrix3<f64>,
    /// SINUMERIK `ORIMKS`: tool vectors in the machine coordinate system
    /// (`ORIWKS`, the default: in the workpiece's).
    pub ori_machine: bool,
    /// Whether the shifts are known.
    pub shift_known: bool,
    /// Cutter radius compensation in force (G41/G42, RL/RR): the side of
    /// the contour it puts the tool on (a HEIDENHAIN `APPR LN`/`DEP LN`'s
    /// point lies there); `None` when off (G40, R0).
    pub radius_comp: Option<approach::Side>,
    /// Last programmed absolute position per axis (X Y Z A B C).
    pub pos: [Option<f64>; 6],
    /// HEIDENHAIN pole (CC) in the XY plane.
    pub pole: Option<[f64; 2]>,
    /// HEIDENHAIN: the machining cycle the last `CYCL DEF` defined (what
    /// `CYCL CALL` and `M99` run).
    pub hh_cycle: Option<heidenhain::CycleDef>,
    /// SINUMERIK: a drilling cycle called modally (`MCALL CYCLE81(..)`)
    /// after every block that moves, with its retraction plane RTP where
    /// it is written as a number.
    pub si_mcall: Option<Option<f64>>,
    /// HEIDENHAIN: the last statement was a straight line with known ends
    /// (start, end), which a `RND`/`CHF` after it may cut.
    hh_line_before: Option<([f64; 6], [f64; 6])>,
    /// HEIDENHAIN: a `RND`/`CHF` waiting for the line after it.
    hh_corner: Option<heidenhain::PendingCorner>,
    /// HEIDENHAIN: the direction (XY, unit) the last contour element ends
    /// in, which a `CT` after it starts in.
    hh_tangent: Option<[f64; 2]>,
    /// HEIDENHAIN: an `APPR LT`/`LN` waiting for the first contour element.
    hh_approach: Option<heidenhain::PendingApproach>,
    /// The canned drilling cycle in force (G code x 10), if any.
    pub cycle: Option<u32>,
    /// Its modal hole bottom along the drill axis (program units).
    pub cycle_depth: Option<f64>,
    /// Its modal R level (program units).
    pub cycle_r: Option<f64>,
    /// G98 (back to the initial level) rather than G99 (to the R level).
    pub retract_initial: bool,
    /// The line of an unreadable block that may have changed the modal
    /// state; `None` when the state is known.
    pub state_unknown: Option<usize>,
    /// What last switched TCP on or off (`None`: nothing yet).
    pub tcp_cause: Option<TcpCause>,
    /// The work offset data the program sets (G10 L2/L20).
    pub offsets: offsets::WorkOffsets,
    /// A LinuxCNC G10 L20 in the last statement: the token index of each
    /// axis word. Its values count from the current position, so a rewrite
    /// that moved that position must move them with it.
    pub setting_words: Option<[Option<usize>; 6]>,
    /// The last statement's effect that is not modelled; the caller takes
    /// it after each [`Interpreter::step`].
    pub unmodelled: Option<Unmodelled>,
    /// The last statement is one the control cannot run (a `CIP` through
    /// three points on a line): what and where; the caller takes it after
    /// each [`Interpreter::step`] and stops there, since nothing after it
    /// runs.
    pub alarm: Option<Unmodelled>,
    /// A machine-file M function switched TCP in this statement.
    tcp_remapped: bool,
    /// A tool change (`M6`) in this statement: what it may move is
    /// forgotten again once the statement's own move is read, since the
    /// control may run it before or after that move.
    tool_changed: bool,
    /// HEIDENHAIN: the tool the last `TOOL CALL` put in the spindle (its
    /// number or name as written), `None` when not known.
    pub hh_tool: Option<String>,
    /// HEIDENHAIN: `M89` is in force (the cycle runs after every
    /// positioning block).
    pub hh_modal_call: bool,
    /// HEIDENHAIN: the SEQ+/SEQ- of the last PLANE block (`None`: none).
    pub hh_plane_seq: Option<f64>,
    /// Why the positions were last forgotten by a tool change: its line.
    pub tool_change_line: Option<usize>,
    /// SINUMERIK block `IF`s open here, innermost last.
    branches: Vec<sinumerik::Branch>,
}

impl Interpreter {
    /// The power-on state of a controller of this dialect on this machine.
    pub fn new(settings: &InterpreterSettings, kin: &Kinematics) -> Interpreter {
        let m = kin.machine();
        let dialect = settings.dialect;
        let cfg = Config {
            settings: settings.clone(),
            rotary: [m.tilt.letter as u8, b'C'],
            tilt: if m.tilt.letter == 'A' { 3 } else { 4 },
            tool_length: kin.gauge_length(),
            nominal: FastChain::nominal(kin),
            kin: kin.clone(),
            m_codes: m.m_codes.clone(),
            tool_change: std::array::from_fn(|i| m.tool_change.moves(AXES[i] as char)),
        };
        // A stated start position is where the axis is until the program
        // moves it or forgets it, like any tracked position.
        let mut pos = [None; 6];
        for &(letter, v) in &settings.rotary_start {
            if let Some(i) = AXES.iter().position(|&a| a as char == letter) {
                pos[i] = Some(v);
            }
        }
        Interpreter {
            cfg: Shared::new(cfg),
            units: Units::Mm,
            absolute: true,
            arc_absolute: false,
            motion: None,
            cip: false,
            feed_mode: FeedMode::PerMinute,
            feed: None,
            plane: ArcPlane::Xy,
            work_offset: match dialect {
                Dialect::Heidenhain => 100_000,
                // G500: no settable offset until the program selects one.
                Dialect::Sinumerik => 5000,
                Dialect::Fanuc | Dialect::Linuxcnc => 540,
            },
            tool_length: dialect == Dialect::Heidenhain,
            tcp: Tcp::Off,
            tilted: false,
            working_plane: None,
            plane_cause: None,
            plane_pending: None,
            transformed: None,
            shift: [0.0; 3],
            local_shift: [0.0; 3],
            frame_rot: Matrix3::identity(),
            ori_machine: false,
            shift_known: true,
            radius_comp: None,
            pos,
            pole: None,
            hh_cycle: None,
            si_mcall: None,
            hh_line_before: None,
            hh_corner: None,
            hh_tangent: None,
            hh_approach: None,
            cycle: None,
            cycle_depth: None,
            cycle_r: None,
            // FANUC powers on in G98; LinuxCNC's interpreter starts in
            // G99 (R plane).
            retract_initial: dialect != Dialect::Linuxcnc,
            state_unknown: None,
            tcp_cause: None,
            offsets: offsets::WorkOffsets::default(),
            setting_words: None,
            unmodelled: None,
            alarm: None,
            tcp_remapped: false,
            tool_changed: false,
            hh_tool: None,
            hh_modal_call: false,
            hh_plane_seq: None,
            tool_change_line: None,
            branches: Vec::new(),
        }
    }

    /// The settings.
    pub fn settings(&self) -> &InterpreterSettings {
        &self.cfg.settings
    }

    /// Applies one statement of `block` and says what it does.
    pub fn step(&mut self, block: &Block, seg: &Segment) -> Event {
        if seg.stmt == Stmt::Unreadable {
            // The axes it names are somewhere unknown after it; when it
            // may have set modal state, everything is.
            let code = code_of(self.cfg.settings.dialect, &block.text);
            if may_change_state(self.cfg.settings.dialect, &code) {
                self.forget();
                self.state_unknown = Some(block.line);
            } else {
                // Any axis letter that starts a word (`Xnan` too).
                for (i, &a) in AXES.iter().enumerate() {
                    if code
                        .iter()
                        .enumerate()
                        .any(|(k, &c)| c == a && (k == 0 || !code[k - 1].is_ascii_alphabetic()))
                    {
                        self.pos[i] = None;
                    }
                }
                self.pole = None;
            }
            return Event::Skip(Skip::Unreadable);
        }
        match seg.entry {
            // It never runs: the controller's state does not pass through it.
            Entry::NotRun => {
                let moves = block
                    .words(seg)
                    .any(|(_, w)| self.axis_index(w.addr).is_some());
                return if moves {
                    Event::Skip(Skip::NeverRuns)
                } else {
                    Event::None
                };
            }
            Entry::Jumped => self.forget(),
            // A jump, branch or label the run passes straight through: the
            // state is the one before it (the statement that follows is
            // marked jumped where it is not).
            Entry::Straight
                if matches!(
                    seg.stmt,
                    Stmt::Flow(_)
                        | Stmt::Hh(
                            HhKind::Lbl
                                | HhKind::Fn(9)
                                | HhKind::Fn(10)
                                | HhKind::Fn(11)
                                | HhKind::Fn(12)
                        )
                ) =>
            {
                return Event::None;
            }
            _ => {}
        }
        self.setting_words = None;
        let tcp_before = self.tcp;
        let plane_before = self.working_plane;
        self.tcp_remapped = false;
        self.tool_changed = false;
        // The move is changed where it lies below: an event is a kilobyte,
        // and moving it through each step was a quarter of compensate's
        // copying.
        let mut ev = match self.cfg.settings.dialect {
            Dialect::Fanuc | Dialect::Linuxcnc => self.gcode(block, seg),
            Dialect::Heidenhain => self.heidenhain(block, seg),
            Dialect::Sinumerik => self.sinumerik(block, seg),
        };
        if std::mem::take(&mut self.tool_changed) {
            self.tool_change(block.line);
        }
        if self.tcp != tcp_before {
            self.tcp_cause = Some(TcpCause {
                line: block.line,
                code: statement_text(block, seg),
                machine_file: self.tcp_remapped,
            });
        }
        if self.working_plane != plane_before {
            self.plane_cause = self.working_plane.map(|_| TcpCause {
                line: block.line,
                code: statement_text(block, seg),
                machine_file: false,
            });
        }
        // The offset in force at the first move in work coordinates is
        // the one `--origin` places.
        if matches!(ev, Event::Move(_) | Event::Skip(_)) {
            self.offsets.first_move(self.work_offset);
        }
        if self.tilted
            && let Event::Move(mv) = &ev
            && let Some(why) = self.plane_skip(mv)
        {
            ev = Event::Skip(Skip::TiltedPlane(why));
        }
        if self.tcp == Tcp::Vector
            && self.cfg.settings.coordinates != Coordinates::Axes
            && let Event::Move(mv) = &mut ev
            && let Err(why) = self.resolve_vector(mv)
        {
            ev = Event::Skip(why);
        }
        ev
    }

    /// The frame the current state puts program coordinates in.
    pub fn frame(&self) -> Frame {
        let tcp = match self.cfg.settings.coordinates {
            Coordinates::Auto => self.tcp,
            Coordinates::Axes => Tcp::Off,
            Coordinates::Tcp if self.tcp == Tcp::Off => Tcp::Axes,
            Coordinates::Tcp => self.tcp,
        };
        // In a tilted plane the controller turns the plane's coordinates
        // into axis values with its kinematics at the rotary positions in
        // force, as under TCP (tool length along the tool).
        let plane = match self.working_plane {
            Some(Tilt::Plane(w)) if self.tcp == Tcp::Off => Some(w),
            Some(Tilt::Workpiece) if self.tcp == Tcp::Off => {
                Some(WorkPlane::new(Matrix3::identity()))
            }
            _ => None,
        };
        let tcp = if plane.is_some() { Tcp::Axes } else { tcp };
        let u = self.units.mm();
        // Moves in an offset whose relation is not known are left as
        // written ([`Self::frame_skip`]): no shift is as good as any there.
        let o = self.offset_shift().unwrap_or([0.0; 6]);
        let shift = self.total_shift();
        Frame {
            u,
            shift: [
                shift[0] + o[0] / u,
                shift[1] + o[1] / u,
                shift[2] + o[2] / u,
            ],
            rotary: [o[self.cfg.tilt], o[5]],
            origin: self.cfg.settings.origin,
            tlc: if tcp == Tcp::Off && !self.tool_length {
                self.cfg.tool_length
            } else {
                0.0
            },
            tcp,
            tilt: self.cfg.tilt,
            plane,
            rot: self.frame_rot,
        }
    }

    /// Sets the tilted working plane in force (`None`: none). The linear
    /// positions are in another frame afterwards; the rotary positions
    /// are machine positions and stay.
    pub(super) fn set_plane(&mut self, t: Option<Tilt>) {
        self.tilted = t.is_some();
        self.working_plane = t;
        self.pos[0] = None;
        self.pos[1] = None;
        self.pos[2] = None;
        self.pole = None;
    }

    /// A plane definition at `line` that is not modelled: noted at its
    /// offset, and the moves in it are left as written.
    pub(super) fn plane_unmodelled(&mut self, line: usize, offset: usize, why: &'static str) {
        self.note(
            offset,
            format!("a tilted working plane fivecal does not model ({why}): the moves in it are left as written"),
        );
        self.set_plane(Some(Tilt::Unmodelled { line, why }));
    }

    /// Turns the rotary axes to the plane in force as the controller
    /// does (`choice`), or leaves their positions unknown with the reason
    /// noted at `offset`.
    pub(super) fn position_for_plane(&mut self, line: usize, offset: usize, choice: plane::Choice) {
        let t = self.cfg.tilt;
        match self.working_plane {
            Some(Tilt::Plane(w)) => {
                let before = (self.pos[t], self.pos[5]);
                match plane::rotary_for(&self.cfg.nominal, &w.normal(), before, choice) {
                    Ok((tilt, c)) => {
                        self.pos[t] = Some(tilt);
                        self.pos[5] = Some(c);
                    }
                    Err(why) => {
                        self.pos[t] = None;
                        self.pos[5] = None;
                        self.note(
                            offset,
                            format!("the rotary positions for the tilted plane of line {line} are not known ({why}): the moves in it are left as written"),
                        );
                    }
                }
            }
            _ => {
                self.pos[t] = None;
                self.pos[5] = None;
            }
        }
    }

    /// Why a move in the tilted plane in force cannot be corrected, if so.
    fn plane_skip(&self, mv: &Move) -> Option<PlaneSkip> {
        let w = match self.working_plane? {
            Tilt::Unmodelled { line, why } => return Some(PlaneSkip::Unmodelled(line, why)),
            Tilt::Plane(w) => Some(w),
            Tilt::Workpiece => None,
        };
        if self.tcp != Tcp::Off {
            return Some(PlaneSkip::Tcp);
        }
        if !self.tool_length {
            return Some(PlaneSkip::NoToolLength);
        }
        if mv.words[3..].iter().any(Option::is_some) {
            return Some(PlaneSkip::RotaryMove);
        }
        let t = self.cfg.tilt;
        let (Some(tilt), Some(c)) = (mv.end[t], mv.end[5]) else {
            return Some(PlaneSkip::RotaryUnknown);
        };
        // A dynamic work offset turns the workpiece's own coordinates
        // with the table: the tool points wherever the axes put it.
        let w = w?;
        let axis = self
            .cfg
            .nominal
            .forward(&crate::kinematics::Axes::new(0.0, 0.0, 0.0, tilt, c))
            .axis;
        // Rotary positions written with a few decimals put the tool along
        // the plane's Z within about 1e-6 rad; another orientation is a
        // program this model does not describe.
        if (axis.normalize() - w.normal()).norm() > 1e-4 {
            return Some(PlaneSkip::NotAlong);
        }
        None
    }

    /// Why the program's coordinates mean what [`Frame::meaning`] says
    /// here: the flag that forces it, or the code that switched it.
    pub(crate) fn coordinates_why(&self) -> String {
        if let (Some(_), Some(c)) = (self.frame().plane, &self.plane_cause) {
            return format!("`{}` at line {}", c.code, c.line);
        }
        match (self.cfg.settings.coordinates, &self.tcp_cause) {
            (Coordinates::Axes, _) => "--coordinates axes".into(),
            (Coordinates::Tcp, _) if self.tcp == Tcp::Off => "--coordinates tcp".into(),
            (_, None) => "no TCP code before these moves".into(),
            (_, Some(c)) => format!(
                "`{}` at line {}{}",
                c.code,
                c.line,
                if c.machine_file {
                    ", a TCP code by the machine file's m_codes"
                } else {
                    ""
                }
            ),
        }
    }

    /// An M function: the machine file's TCP codes switch TCP; one that
    /// neither the dialect nor the machine file knows is noted.
    fn m_function(&mut self, m: u32, offset: usize, line: usize) {
        let codes = &self.cfg.m_codes;
        if m == 6 && !codes.tcp_on.contains(&6) && !codes.tcp_off.contains(&6) {
            // M6 is the tool change in every dialect (HEIDENHAIN's TNC
            // too, where TOOL CALL is the usual way).
            self.tool_change(line);
            self.tool_changed = true;
        } else if codes.tcp_on.contains(&m) {
            self.tool_length = true;
            self.set_tcp(Tcp::Axes);
            self.tcp_remapped = true;
        } else if codes.tcp_off.contains(&m) {
            self.set_tcp(Tcp::Off);
            self.tcp_remapped = true;
        } else if !(known_m(self.cfg.settings.dialect, m) || codes.known.contains(&m)) {
            let d = self.cfg.settings.dialect;
            self.note(
                offset,
                format!(
                    "M{m}: an M function that {d} does not define and the machine file's m_codes do not list (taken to move no axis; if it switches TCP, list it under m_codes: tcp_on)"
                ),
            );
        }
    }

    /// Notes a statement whose effect is not modelled.
    fn note(&mut self, offset: usize, what: impl Into<String>) {
        self.unmodelled.get_or_insert(Unmodelled {
            offset,
            what: what.into(),
        });
    }

    /// What the work offset in force adds to the one in force at the
    /// first move ([`offsets::WorkOffsets::shift`]): X, Y, Z in mm, the
    /// rotary zero shifts in deg; `None` where that is not known.
    pub fn offset_shift(&self) -> Option<[f64; 6]> {
        self.offsets.shift(self.work_offset, [self.cfg.tilt, 5])
    }

    /// Program positions after the work offset's values changed from
    /// `before` (machine positions stay): shifted by the difference where
    /// both are known, else forgotten.
    fn reoffset(&mut self, before: Option<[f64; 6]>) {
        let after = self.offset_shift();
        if after == before {
            return;
        }
        let u = self.units.mm();
        match (before, after) {
            (Some(b), Some(a)) => {
                for (i, p) in self.pos.iter_mut().enumerate() {
                    let k = if i < 3 { 1.0 / u } else { 1.0 };
                    *p = p.map(|v| v + (b[i] - a[i]) * k);
                }
                self.pole = None;
            }
            _ => self.forget(),
        }
    }

    /// G43.5: the controller picks the rotary positions for the programmed
    /// tool direction, nearest where they were (written into `mv`), or
    /// the move is left as written for the reason returned.
    fn resolve_vector(&mut self, mv: &mut Move) -> Result<(), Skip> {
        let Some((v, _)) = mv.tool_vector else {
            return Err(Skip::NoToolVector);
        };
        let v = Vector3::new(v[0], v[1], v[2]);
        if !(v.norm() > 0.0 && v.iter().all(|x| x.is_finite())) {
            return Err(Skip::VectorOutOfReach);
        }
        let v = v.normalize();
        let t = self.cfg.tilt;
        let reference = Axes::new(
            0.0,
            0.0,
            0.0,
            mv.start[t].unwrap_or(0.0),
            mv.start[5].unwrap_or(0.0),
        );
        let pose = ToolPose {
            tip: Vector3::zeros(),
            axis: v,
        };
        match self.cfg.nominal.inverse(&pose, &reference) {
            Ok(a) => {
                mv.end[t] = Some(a.tilt);
                mv.end[5] = Some(a.c);
                self.pos[t] = Some(a.tilt);
                self.pos[5] = Some(a.c);
                mv.vector = Some(v);
                Ok(())
            }
            Err(_) => {
                self.pos[t] = None;
                self.pos[5] = None;
                Err(Skip::VectorOutOfReach)
            }
        }
    }

    /// Total datum shift per linear axis (program units).
    pub(crate) fn total_shift(&self) -> [f64; 3] {
        [
            self.shift[0] + self.local_shift[0],
            self.shift[1] + self.local_shift[1],
            self.shift[2] + self.local_shift[2],
        ]
    }

    /// A tool change at `line`: the axes the machine file says it may move
    /// ([`crate::machine::ToolChange`]) are somewhere the program does not
    /// say afterwards; the others keep their positions.
    pub(super) fn tool_change(&mut self, line: usize) {
        for (i, p) in self.pos.iter_mut().enumerate() {
            if self.cfg.tool_change[i] {
                *p = None;
            }
        }
        if self.cfg.tool_change[0] || self.cfg.tool_change[1] {
            self.pole = None;
        }
        self.tool_change_line = Some(line);
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
        i < 3 || self.cfg.rotary.contains(&AXES[i])
    }

    /// The value of an axis word in program units (deg for rotary axes),
    /// or why it has none.
    /// A value beyond a control's five integer digits is its alarm, and
    /// would make every position after it meaningless in floating point.
    fn axis_value(&self, w: &Word) -> Result<f64, Skip> {
        let Value::Num(mut v) = w.value else {
            return Err(Skip::Expression);
        };
        if self.cfg.settings.dialect == Dialect::Fanuc && v != 0.0 && !w.style.point {
            match self.cfg.settings.integer_unit {
                Some(k) => v = v * k / self.units.mm(),
                None => return Err(Skip::FanucInteger),
            }
        }
        let rotary = self.axis_index(w.addr).is_some_and(|i| i >= 3);
        let unit = if rotary { 1.0 } else { self.units.mm() };
        if (v * unit).abs() > crate::limits::MAX_NC_VALUE {
            return Err(Skip::OutOfRange(w.addr.as_letter().unwrap_or(b'?')));
        }
        Ok(v)
    }

    /// Updates tracked positions from the axis words (for moves left as
    /// written): literal values are followed, expressions forget.
    fn track_words(&mut self, block: &Block, seg: &Segment) {
        for (_, w) in block.words(seg) {
            if matches!(w.addr.as_letter(), Some(b'@' | b'^')) {
                // LinuxCNC's polar words move X and Y.
                self.pos[0] = None;
                self.pos[1] = None;
                continue;
            }
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

    /// A move in machine coordinates (G53, SUPA): the linear axes it names
    /// end where the program's frame does not say, a rotary axis at the
    /// angle written, which is its program position less the rotary part
    /// of the work offset (none unless the program sets one with G10: each
    /// lies on the W origin at rotary zero, docs/model.md). `absolute` says
    /// whether a word is an absolute position.
    fn machine_move(
        &mut self,
        block: &Block,
        seg: &Segment,
        absolute: impl Fn(&Block, &Word) -> bool,
    ) {
        // A rotary zero shift the program set (G10) puts the programmed
        // angle that much below the machine's.
        let rotary_zero = self.offset_shift();
        for (_, w) in block.words(seg) {
            let Some(i) = self.axis_index(w.addr) else {
                continue;
            };
            self.pos[i] = match (self.axis_value(&w), rotary_zero) {
                (Ok(v), Some(o)) if i >= 3 && absolute(block, &w) => Some(v - o[i]),
                _ => None,
            };
        }
    }

    /// Forgets the axes the block names (a move that ends somewhere the
    /// program does not say: probing, reference return).
    fn forget_named(&mut self, block: &Block, seg: &Segment) {
        for (_, w) in block.words(seg) {
            if let Some(i) = self.axis_index(w.addr) {
                self.pos[i] = None;
            }
        }
    }

    /// The reason a move in the current state cannot be rewritten, if any
    /// (checked after the positions are updated).
    fn frame_skip(&self) -> Option<Skip> {
        if let Some(line) = self.state_unknown {
            return Some(Skip::StateUnknown(line));
        }
        if let Some(t) = self.transformed {
            return Some(Skip::Transformed(t));
        }
        if self.tcp == Tcp::Spatial {
            return Some(Skip::TcpSpatial);
        }
        if !self.shift_known {
            return Some(Skip::ShiftUnknown);
        }
        match self.offset_shift() {
            None => Some(Skip::OffsetUnknown(
                self.offsets.lost.unwrap_or(offsets::UNRELATED),
            )),
            // The rotary positions a tilted plane or a tool direction
            // gives are machine positions: with a rotary work offset they
            // are not modelled.
            Some(o)
                if (o[self.cfg.tilt] != 0.0 || o[5] != 0.0)
                    && (self.tilted || self.tcp == Tcp::Vector) =>
            {
                Some(Skip::OffsetUnknown(offsets::ROTARY_IN_PLANE))
            }
            Some(_) => None,
        }
    }

    fn cancel(&mut self, what: &str) {
        if self.transformed == Some(what) {
            self.transformed = None;
        }
    }

    /// Switches tool-centre-point control. The linear words mean another
    /// place now and are forgotten; the rotary positions are machine
    /// positions with TCP on (`M128`, `FUNCTION TCPM .. AXIS POS`, a
    /// machine file's remapped code) or off, and switching turns no axis,
    /// so they stay known (as under G43.4). Only spatial angles
    /// (`AXIS SPAT`) give the rotary words another meaning.
    fn set_tcp(&mut self, t: Tcp) {
        if self.tcp != t {
            let spatial = self.tcp == Tcp::Spatial || t == Tcp::Spatial;
            self.tcp = t;
            let kept = [self.pos[3], self.pos[4], self.pos[5]];
            self.forget();
            if !spatial {
                self.pos[3..].copy_from_slice(&kept);
            }
        }
    }
}

/// M functions each dialect defines (the machine builder's own come from
/// the machine file). FANUC: program stop and end, spindle, tool change,
/// coolant, orientation, rigid tapping, subprograms. LinuxCNC 2.9: the M
/// codes of its G-code reference (M100-M199 are the user's and M200 and
/// up exist only as remaps, so neither is known without the machine
/// file). HEIDENHAIN TNC: the M functions of the Klartext manuals, and M7
/// (mist coolant on most machines, as the bundled postprocessor writes it).
pub(crate) fn known_m(dialect: Dialect, m: u32) -> bool {
    const FANUC: &[u32] = &[0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 19, 29, 30, 98, 99, 198];
    const LINUXCNC: &[u32] = &[
        0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 19, 30, 48, 49, 50, 51, 52, 53, 60, 61, 62, 63, 64, 65, 66,
        67, 68, 70, 71, 72, 73, 98, 99,
    ];
    const HEIDENHAIN: &[u32] = &[
        0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 13, 14, 30, 89, 90, 91, 92, 94, 97, 98, 99, 101, 102, 103,
        104, 105, 106, 107, 108, 109, 110, 111, 114, 115, 116, 117, 118, 120, 124, 126, 127, 128,
        129, 130, 134, 135, 136, 137, 138, 140, 141, 142, 143, 144, 145, 148, 149, 150, 197,
    ];
    // SINUMERIK: stop, end, spindle, tool change, coolant, subprogram end,
    // spindle positioning and gear stages (M40-M45), M70 (spindle as axis).
    const SINUMERIK: &[u32] = &[
        0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 17, 19, 30, 40, 41, 42, 43, 44, 45, 70,
    ];
    let list = match dialect {
        Dialect::Fanuc => FANUC,
        Dialect::Linuxcnc => LINUXCNC,
        Dialect::Heidenhain => HEIDENHAIN,
        Dialect::Sinumerik => SINUMERIK,
    };
    list.binary_search(&m).is_ok()
}

/// A statement's text for a message: its first words, trimmed.
fn statement_text(block: &Block, seg: &Segment) -> String {
    // The code alone: a comment beside it (`G43.4 H1 (TCP ON)`) is the
    // programmer's, not what switched the mode.
    let mut text = String::new();
    for t in block.seg_tokens(seg) {
        match t.kind {
            TokenKind::Comment | TokenKind::LineEnd | TokenKind::Eob | TokenKind::Continuation => {}
            TokenKind::Space => {
                if !text.is_empty() && !text.ends_with(' ') {
                    text.push(' ');
                }
            }
            _ => text.push_str(&String::from_utf8_lossy(
                &block.text[t.span.start as usize..t.span.end as usize],
            )),
        }
    }
    let text = text.trim();
    if text.chars().count() > 40 {
        format!("{}...", text.chars().take(40).collect::<String>())
    } else {
        text.to_string()
    }
}

/// Whether an unreadable block may have changed the modal state: outside
/// its comments it has a G or M code, a parameter or an assignment, a
/// program-flow word (ISO), or it is not a plain Klartext path block, or a
/// path block with an M function (HEIDENHAIN). Only axis words and feeds
/// are left: those move the tool and are forgotten with the position.
fn may_change_state(dialect: Dialect, code: &[u8]) -> bool {
    match dialect {
        Dialect::Fanuc | Dialect::Linuxcnc => {
            letter_word(code, b"GMO") || code.iter().any(|c| matches!(c, b'#' | b'=' | b'<'))
        }
        // Any G, M or D word, assignment, command or call (a name of two
        // letters or more): only plain axis and feed words are left.
        Dialect::Sinumerik => {
            letter_word(code, b"GMD")
                || code.contains(&b'=')
                || code.windows(2).any(|w| {
                    w[0].is_ascii_alphabetic() && (w[1].is_ascii_alphabetic() || w[1] == b'_')
                })
        }
        Dialect::Heidenhain => {
            let body: Vec<u8> = code
                .iter()
                .copied()
                .skip_while(|c| c.is_ascii_digit() || matches!(c, b' ' | b'\t' | b'/'))
                .collect();
            let path = [
                &b"L "[..],
                b"LP ",
                b"C ",
                b"CC ",
                b"CR ",
                b"CT ",
                b"CP ",
                b"RND ",
                b"CHF ",
            ]
            .iter()
            .any(|k| body.starts_with(k));
            !path || letter_word(code, b"M")
        }
    }
}

/// A block's text outside its comments, upper case.
fn code_of(dialect: Dialect, text: &[u8]) -> Vec<u8> {
    let mut code = Vec::with_capacity(text.len());
    let mut depth = 0usize;
    for &c in text {
        match c {
            b';' if dialect != Dialect::Fanuc => break,
            // SINUMERIK's `(` opens a parameter list, not a comment.
            b'(' if matches!(dialect, Dialect::Fanuc | Dialect::Linuxcnc) => depth += 1,
            b')' if depth > 0 => depth -= 1,
            _ if depth == 0 => code.push(c.to_ascii_uppercase()),
            _ => {}
        }
    }
    code
}

/// Whether `code` has one of `letters` as a word address: not inside a
/// longer name, followed by a number, a parameter or an expression.
fn letter_word(code: &[u8], letters: &[u8]) -> bool {
    code.iter().enumerate().any(|(i, c)| {
        letters.contains(c)
            && (i == 0 || !code[i - 1].is_ascii_alphabetic())
            && code[i + 1..]
                .iter()
                .find(|b| !matches!(b, b' ' | b'\t'))
                .is_some_and(|b| {
                    b.is_ascii_digit() || matches!(b, b'#' | b'[' | b'+' | b'-' | b'.')
                })
    })
}

/// Whether a controller runs the arc from `s` to `e` about `c` (program
/// units, `mm` millimetres each): neither radius is zero, and the radius
/// at the end differs from the one at the start by at most LinuxCNC's
/// default spiral tolerance (0.02 x sqrt 2 mm), or by at most 0.1 % of
/// the radius and 100 times that (its rs274ngc rule). A centre that is
/// nowhere near the circle through both ends is a controller's alarm
/// (FANUC PS0020, LinuxCNC "radius to end of arc differs from radius to
/// start"), not a path to follow.
pub(crate) fn arc_runs(s: [f64; 2], e: [f64; 2], c: [f64; 2], mm: f64) -> bool {
    const ZERO_RADIUS_MM: f64 = 0.00127;
    const SPIRAL_MM: f64 = 0.02 * std::f64::consts::SQRT_2;
    const SPIRAL_RELATIVE: f64 = 0.001;
    let rs = (s[0] - c[0]).hypot(s[1] - c[1]) * mm;
    let re = (e[0] - c[0]).hypot(e[1] - c[1]) * mm;
    if !(rs >= ZERO_RADIUS_MM && re >= ZERO_RADIUS_MM) {
        return false;
    }
    let diff = (rs - re).abs();
    diff <= SPIRAL_MM || (diff <= 100.0 * SPIRAL_MM && diff / rs.max(re) <= SPIRAL_RELATIVE)
}

/// The centre of an arc from `s` to `e` with radius `r` (positive: at most
/// half a circle; negative: more), turning clockwise or not.
pub(crate) fn center_from_radius(s: [f64; 2], e: [f64; 2], r: f64, cw: bool) -> Option<[f64; 2]> {
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

#[cfg(test)]
mod tests;
