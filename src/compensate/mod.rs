//! Rewriting NC programs so that the identified errors cancel.
//!
//! For every move the program asks for a tool pose through the nominal
//! kinematics: the tip and axis the nominal machine would reach at the
//! programmed axis values (post-side programs), or the programmed tip in W
//! with the tool axis of the programmed rotary positions (tool centre point
//! control: G43.4, M128, FUNCTION TCPM; G43.5 gives the axis as a vector).
//! [`Solver`] finds the axis values that reach that pose on the machine
//! with the identified errors; for TCP programs the rewritten coordinates
//! are the W coordinates the *nominal* controller kinematics turns into
//! those axis values, so the controller's own TCP does the rest.
//!
//! Between end points the controller interpolates the written values
//! linearly (axis values, or tip and rotary positions under TCP), so the
//! actual path bends away from the intended one where the rotary axes move.
//! A linear move is subdivided until every piece stays within the
//! tolerance of the intended path; an arc is kept when the rewritten arc
//! stays within it (rotary axes fixed: the correction is then a rigid
//! motion) and linearized otherwise. Inverse-time feeds are recomputed for
//! the pieces so that the block takes as long as before.
//!
//! Moves that cannot be rewritten (expression coordinates, unknown words,
//! positions that are not statically known, transformations that are not
//! modelled) are left exactly as written and reported with their line
//! numbers. A correction larger than the configured limit stops the run
//! with the line named, and nothing is written. The rewrite streams: one
//! block is in memory at a time.

pub mod against;
pub mod axis_tables;
mod compensator;
mod correction;
mod edit;
mod engine;
mod expand;
pub mod export;
pub mod report;
pub mod simulate;
mod solver;
mod subroutines;
pub mod tolerance;
mod writer;

use std::fmt;
use std::path::PathBuf;

use nalgebra::Vector3;

pub use crate::io::AtomicOutput;
pub use compensator::Compensator;
pub use report::{Rewrite, by_kind, reasons, rotary_start_note};
pub use solver::{Solution, Solver};

pub use crate::nc::interp::{Coordinates, ReasonKind};

use crate::kinematics::{Axes, ToolPose};
use crate::machine::Dialect;
use crate::nc::interp::Tcp;
use crate::source::SourceError;

/// Settings of a rewrite.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// The dialect.
    pub dialect: Dialect,
    /// Reject words and codes the parser does not know.
    pub strict: bool,
    /// Largest allowed distance of the actual tool-tip path from the
    /// intended one, mm.
    pub tolerance: f64,
    /// Largest allowed correction: um for X, Y, Z and urad for the change
    /// of tool orientation the rotary corrections make (1 urad = 1 um/m).
    pub max_correction: f64,
    /// Where the program zero lies in W at rotary zero, mm (0 for programs
    /// whose work offset is on the W origin, as `fivecal plan` writes them).
    pub origin: Vector3<f64>,
    /// Decimals written for linear axes (at least; more if the program
    /// already writes more).
    pub linear_decimals: u8,
    /// Decimals written for rotary axes and tool vectors (at least).
    pub rotary_decimals: u8,
    /// How coordinates are meant.
    pub coordinates: Coordinates,
    /// Largest C swing accepted for an exact correction next to the tilt
    /// singularity, deg; beyond it C is held (see [`Solver`]).
    pub max_c_swing: f64,
    /// FANUC axis values without a decimal point: mm per unit, or `None`
    /// to leave such moves as written.
    pub fanuc_integer_unit: Option<f64>,
    /// Write the program flattened as its macro logic runs (loops and
    /// calls unrolled, every move literal) and correct that.
    pub expand: bool,
    /// Positions of rotary axes before the first block, as the user
    /// states them (axis letter, deg); see
    /// [`crate::nc::interp::InterpreterSettings::rotary_start`].
    pub rotary_start: Vec<(char, f64)>,
    /// LinuxCNC: directories to look in, after the program's own, for
    /// the file `name.ngc` an `o<name> call` runs (its `SUBROUTINE_PATH`).
    pub subroutine_path: Vec<std::path::PathBuf>,
}

impl Settings {
    /// Defaults for a dialect: 1 um tolerance, 500 um / 500 urad limit,
    /// 4 decimals in mm and 6 in degrees (0.1 um and 0.02 urad, so rounding
    /// stays well inside 0.1 um and 0.1 urad), C held beyond a 1 deg swing.
    pub fn new(dialect: Dialect) -> Settings {
        Settings {
            dialect,
            strict: false,
            tolerance: 0.001,
            max_correction: 500.0,
            origin: Vector3::zeros(),
            linear_decimals: 4,
            rotary_decimals: 6,
            coordinates: Coordinates::Auto,
            max_c_swing: 1.0,
            fanuc_integer_unit: None,
            expand: false,
            rotary_start: Vec::new(),
            subroutine_path: Vec::new(),
        }
    }
}

/// One written end point, for callers that check or trace a rewrite.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Vertex {
    /// Line of the source block.
    pub line: usize,
    /// The nominal axes (or, under TCP, tip in W and rotary positions) the
    /// program asked for at this point, mm and deg.
    pub nominal: Axes,
    /// What was written, in the same frame, after rounding.
    pub written: Axes,
    /// The tool pose the point is meant to reach, in W.
    pub target: ToolPose,
    /// TCP mode of the point.
    pub tcp: Tcp,
    /// C was held next to the singularity.
    pub held_c: bool,
    /// 3+2 in a tilted working plane: the rotary positions are the
    /// controller's, only the tip is corrected (the tool axis keeps the
    /// machine's orientation error).
    pub tilted_plane: bool,
    /// An end point inside a move that was subdivided or linearized (the
    /// move's own end point is the last of its pieces and is not inserted).
    pub inserted: bool,
    /// The nominal point in program coordinates (X Y Z A B C, program
    /// units and frame; NaN for an axis the machine does not have).
    pub nominal_program: [f64; 6],
    /// What the controller has after this point, in program coordinates.
    pub program: [f64; 6],
}

/// Line numbers of a kind of event: how many there were and the first
/// `Lines::KEPT` of them (so a summary does not grow with the program).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Lines {
    /// How many.
    pub count: usize,
    /// The first ones, in order.
    pub first: Vec<usize>,
    last: Option<usize>,
}

impl Lines {
    /// How many line numbers are kept.
    pub(crate) const KEPT: usize = 200;

    /// Records `line` (a repeat of the last line is not counted again).
    pub fn push(&mut self, line: usize) {
        if self.last == Some(line) {
            return;
        }
        self.last = Some(line);
        self.count += 1;
        if self.first.len() < Self::KEPT {
            self.first.push(line);
        }
    }

    /// Number recorded.
    pub fn len(&self) -> usize {
        self.count
    }

    /// Whether none.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// Whether `line` is among the kept ones.
    pub fn contains(&self, line: &usize) -> bool {
        self.first.contains(line)
    }

    /// The first lines as text: `12, 14, 19` (at most 25, then `... (n more)`).
    pub fn list(&self) -> String {
        const SHOWN: usize = 25;
        let mut s: String = self
            .first
            .iter()
            .take(SHOWN)
            .map(|l| l.to_string())
            .collect::<Vec<_>>()
            .join(", ");
        let shown = self.first.len().min(SHOWN);
        if self.count > shown {
            s.push_str(&format!(" ... ({} more)", self.count - shown));
        }
        s
    }
}

impl PartialEq<Vec<usize>> for Lines {
    fn eq(&self, other: &Vec<usize>) -> bool {
        self.count == other.len() && self.first == *other
    }
}

/// Why moves are left as written: which of the three kinds of reason it
/// is (the file does not say, not implemented yet, a program for another
/// machine), and the reason in words.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Reason {
    /// Which kind.
    pub kind: ReasonKind,
    /// What and why, in words.
    pub text: String,
}

impl Reason {
    /// A reason of `kind`.
    pub fn new(kind: ReasonKind, text: impl Into<String>) -> Reason {
        Reason {
            kind,
            text: text.into(),
        }
    }
}

impl From<crate::nc::interp::Skip> for Reason {
    fn from(s: crate::nc::interp::Skip) -> Reason {
        Reason::new(s.kind(), s.to_string())
    }
}

/// The words alone; a report names the kind in its heading.
impl fmt::Display for Reason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.text)
    }
}

/// The words, for callers that search them (`reason.contains(..)`).
impl std::ops::Deref for Reason {
    type Target = str;
    fn deref(&self) -> &str {
        &self.text
    }
}

/// The largest correction and where.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Largest {
    /// Value (um or urad).
    pub value: f64,
    /// Source line.
    pub line: usize,
}

/// What a rewrite did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Summary {
    /// Blocks read.
    pub blocks: usize,
    /// Moves found.
    pub moves: usize,
    /// Blocks rewritten.
    pub changed: usize,
    /// Blocks inserted (pieces of subdivided moves and linearized arcs,
    /// HEIDENHAIN circle centres).
    pub inserted: usize,
    /// Source lines of subdivided linear moves.
    pub subdivided: Lines,
    /// Source lines of linearized arcs.
    pub linearized: Lines,
    /// Largest correction of X, Y, Z (length of the correction vector), um.
    pub largest_linear: Option<Largest>,
    /// Largest correction of the tool orientation by the rotary axes, urad.
    pub largest_rotary: Option<Largest>,
    /// Moves left as written, grouped by reason (each of one of three
    /// kinds, [`ReasonKind`]), with their lines (blocks that could not be
    /// read among them, with the column and why).
    pub skipped: Vec<(Reason, Lines)>,
    /// Lines of blocks that could not be read and were kept as written
    /// (outside `--strict`).
    pub unreadable: Lines,
    /// Lines where C was held next to the tilt singularity.
    pub held_c: Lines,
    /// Largest remaining tool-axis error where C was held, urad.
    pub held_c_axis_error: f64,
    /// Lines where the tilt was held at its limit.
    pub held_tilt: Lines,
    /// Largest remaining tool-axis error there, urad.
    pub held_tilt_axis_error: f64,
    /// Lines corrected in a tilted working plane (3+2: X, Y, Z in the
    /// plane rewritten, the plane and its rotary positions as written).
    pub tilted_plane: Lines,
    /// Largest tool-axis error left there (a 3+2 section cannot correct
    /// the orientation by coordinates), urad.
    pub tilted_plane_axis_error: f64,
    /// Lines of canned-cycle holes corrected at their bottom (X, Y and the
    /// depth rewritten, the rotary positions as written).
    pub drilled: Lines,
    /// Largest angle left between the actual and the intended hole axis
    /// there, urad.
    pub drilled_axis_error: f64,
    /// Largest distance that angle puts the tip from the intended hole
    /// axis at the R level, um.
    pub drilled_residual: f64,
    /// Whether the closed-form fast path was used.
    pub fast_path: bool,
    /// Effects of the error file that a rewrite cannot cancel, with why.
    pub not_compensated: Vec<String>,
    /// Statements whose effect is not modelled (unknown M functions and
    /// words, G10), kept as written, by what they are.
    pub unmodelled: Vec<(String, Lines)>,
    /// How the moves' coordinates were read, section by section.
    pub coordinates: Vec<CoordinateSection>,
    /// Where following the macro logic stopped short of the end, and why.
    pub macro_logic: Option<String>,
    /// The program moves no axis itself (in its own dialect): why, said
    /// once; it is then written as it was.
    pub no_motion: Option<String>,
    /// Blocks that move an axis: a move whose end differs from its start
    /// (or starts where the position is unknown, or is an arc), or an
    /// axis word left as written (a skipped move, a move in machine
    /// coordinates, a reference return, a probing move). Unreadable blocks
    /// are not among them (whether they move is not known); see
    /// [`Summary::unreadable`].
    pub motion_blocks: usize,
    /// Of [`Summary::motion_blocks`], those whose every move was corrected.
    pub corrected_blocks: usize,
    /// The other motion blocks, grouped by why the first move of each
    /// was left as written.
    pub uncorrected_blocks: Vec<(String, Lines)>,
}

/// Why a move in machine coordinates, a reference return or a probing
/// move is left as written: it is not a position of the tool on the part.
pub const LEFT_ON_PURPOSE: &str = "machine coordinates (G53, SUPA, M91, M92), reference return or probing: left as written on purpose";

/// Takes what the last statement did that the interpreter does not model
/// (shared by the rewrite and `simulate nc`): refused under `--strict` at
/// its line and column, else listed by what it is. A statement the control
/// cannot run is an error at its line and column, `--strict` or not.
pub(crate) fn take_unmodelled(
    interp: &mut crate::nc::interp::Interpreter,
    block: &crate::nc::Block,
    path: &std::path::Path,
    strict: bool,
    list: &mut indexmap::IndexMap<String, Lines>,
) -> Result<(), SourceError> {
    if let Some(a) = interp.alarm.take() {
        let (line, column) = block.locate(a.offset);
        return Err(SourceError::new(path, line, column, a.what));
    }
    let Some(u) = interp.unmodelled.take() else {
        return Ok(());
    };
    if strict {
        let (line, column) = block.locate(u.offset);
        return Err(SourceError::new(
            path,
            line,
            column,
            format!("{} (--strict refuses what it does not model)", u.what),
        ));
    }
    list.entry(u.what).or_default().push(block.line);
    Ok(())
}

/// A stretch of the program whose moves are read one way.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CoordinateSection {
    /// First and last line with a move.
    pub lines: (usize, usize),
    /// What the coordinates are ([`crate::nc::interp::Tcp::meaning`]).
    pub meaning: &'static str,
    /// Why: the flag or the code that set it, and its line.
    pub why: String,
}

impl Summary {
    /// Number of moves (and unreadable blocks) left as written.
    pub fn skipped_count(&self) -> usize {
        self.skipped.iter().map(|(_, l)| l.count).sum()
    }
}

/// Why a rewrite failed.
#[derive(Debug)]
pub enum CompensateError {
    /// A malformed program (file:line:column: what was expected).
    Syntax(SourceError),
    /// A correction above the limit.
    TooLarge {
        /// The program.
        path: PathBuf,
        /// Its line.
        line: usize,
        /// What and how much.
        what: String,
    },
    /// `--strict`: a statement whose effect is not modelled; `--strict`
    /// or not, a block the control cannot run (a `CIP` without a circle).
    Unmodelled(SourceError),
    /// A move that cannot be followed within the tolerance.
    Tolerance {
        /// The program.
        path: PathBuf,
        /// Its line.
        line: usize,
        /// Why.
        what: String,
    },
    /// Reading or writing failed.
    Io(std::io::Error),
}

impl fmt::Display for CompensateError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CompensateError::Syntax(e) | CompensateError::Unmodelled(e) => write!(f, "{e}"),
            CompensateError::TooLarge { path, line, what }
            | CompensateError::Tolerance { path, line, what } => {
                write!(f, "{}:{line}: {what}", path.display())
            }
            CompensateError::Io(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for CompensateError {}

impl CompensateError {
    /// The error with its program named.
    pub(crate) fn in_file(self, file: &std::path::Path) -> Self {
        match self {
            CompensateError::TooLarge { line, what, .. } => CompensateError::TooLarge {
                path: file.to_path_buf(),
                line,
                what,
            },
            CompensateError::Tolerance { line, what, .. } => CompensateError::Tolerance {
                path: file.to_path_buf(),
                line,
                what,
            },
            other => other,
        }
    }
}

impl From<SourceError> for CompensateError {
    fn from(e: SourceError) -> Self {
        CompensateError::Syntax(e)
    }
}

impl From<std::io::Error> for CompensateError {
    fn from(e: std::io::Error) -> Self {
        CompensateError::Io(e)
    }
}

/// The largest turn of a rotary axis between two program points, deg
/// (shared by the rewrite's path check and `simulate nc`'s sampling, which
/// both must follow a long turn more closely than its ends show).
pub(crate) fn largest_turn(p0: &[f64; 6], p1: &[f64; 6]) -> f64 {
    (3..6)
        .map(|i| (p1[i] - p0[i]).abs())
        .filter(|d| d.is_finite())
        .fold(0.0, f64::max)
}
