//! The machining tests: a piece cut at a set of poses and measured on a
//! CMM. Each test designs its piece, poses, cuts and points in its own
//! folder ([`stepped_square`], [`nine_section`]: the design and the
//! template); `design` holds what the designs share, `program` turns a
//! design into machine moves and an NC program with every point's
//! provenance, [`cutter`] is the tool's exact solid and `outputs` the
//! files only a machining plan writes (the DMIS program, the setup sheet).
//!
//! # For the simulator and the analyzer: what a `MachiningPlan` holds
//!
//! Frames and units follow docs/model.md: W is the table frame (origin at the
//! nominal intersection of the rotary axes, Z along C, parallel to the
//! machine frame at rotary zero); lengths mm, angles deg.
//!
//! * `machine`, `tool` ([`crate::machine::Tool`], its gauge length is the
//!   one the kinematics must use: `Kinematics::with_gauge_length(&machine,
//!   tool.length)`), `cutter` (the tool's exact solid, [`Cutter`]).
//! * `poses`: [`PlannedPose`] in execution order, each with `seq`, `tilt`,
//!   `c`, estimated `start_min`/`end_min` from program start, the nominal
//!   tool axis in W (`tool_axis`), the program frame of `--kinematics
//!   controller` (`frame`), and its `moves`: the commanded path at that
//!   pose, from the position after the rotary index (`start`) to the retract
//!   to the safe height. Each [`PathMove`] gives the end point as machine
//!   axis values (`axes`: X, Y, Z in program coordinates with the work
//!   offset on the W origin at rotary zero, what the axes really execute in
//!   both kinematics modes), as written in the program (`program`), and as
//!   the nominal tool tip in W (`tip`); `rapid` or `feed`; and the `pass`
//!   (air, entry, rough, finish, zero cut). A move goes in a straight line
//!   in axis space from the previous move's `axes` (or `start`); the rotary
//!   axes do not move within a pose. To machine with an erroneous machine,
//!   run each cutting move's end points through `Kinematics::forward` with
//!   the errors (at the pose's `seq`/minutes for drift): the actual tool
//!   sweeps the segment between them with a fixed axis.
//! * `piece`: the nominal finished piece ([`Piece`]): the `stock` and
//!   `fixture` boxes, an exact point-membership `solid`, the boundary
//!   `faces` (planar convex patches with their plane, outline in W and the
//!   tag of the pose that cut them, 0 for uncut stock) and the `mesh`
//!   written to `.obj`/`.glb`.
//! * `points`: [`PlannedPoint`] in points.csv order: the plan point of docs/formats.md
//!   (label, pose, seq, angles, nominal point and outward normal in W) and
//!   its [`Provenance`]: the pose index that cut it, the tool part that made
//!   the surface there ([`ToolPart`]: flank, flat end, ball, torus), and
//!   every generating move ([`Generator`]: the move index in that pose's
//!   `moves`, the parameter `t` along it, the nominal tool tip and axis in W
//!   and the axis values at that instant, and the pass). Several
//!   generators mean several passes touched the point (roughing at the same
//!   floor level, finishing, the zero cut); the surface left is the envelope
//!   of all of them. For an erroneous machine: for each generator take its
//!   move's end points (`pose.segment(move_index)`), run both through
//!   `Kinematics::forward` with the errors to get the actual tips `a`, `b`
//!   and axis, and find where the actual sweep meets the nominal normal line
//!   with `cutter.entry_along(&a, &b, &axis, &(p - n), &n, 0.0, 2.0)` (the
//!   line starts 1 mm inside the material); the least result minus 1 over
//!   all generators is the actual surface's offset along `n` (negative: cut
//!   deeper). See [`Cutter::entry_along`] and the test
//!   `provenance_gives_the_simulator_the_exact_surface_of_an_erroneous_machine`.
//!   No other pose's tool comes within 0.05 mm of a plan point (checked at
//!   planning), so errors below that size cannot hand a point to another
//!   pose.
//! * `toolpath`: the whole program as neutral [`crate::post::Op`]s and
//!   `program`: its rendered text.
//!
//! The nominal points lie on the piece exactly (1e-9 mm): each is checked
//! against the solid (material below, air above along the normal), against
//! the generating tool (zero distance) and against the mesh in the tests.

pub mod assembly;
pub mod cutter;
pub(crate) mod design;
pub mod nine_section;
mod outputs;
mod program;
pub mod stepped_square;
pub mod template;

use nalgebra::{Matrix3, Vector3};

use super::{PlanConfig, PlanError, Template, Test};
use crate::formats::manifest::KinematicsMode;
use crate::formats::points::{PlanPoint, PlanPoints};
use crate::kinematics::Axes;
use crate::machine::{Dialect, Machine, Tool};
use crate::mesh::{Cuboid, Mesh, Solid};
use crate::post::{Op, PostDefinition, ProgramInfo, RenderedProgram};

pub use cutter::{Cutter, ToolPart};
pub use template::CuttingData;

/// What a move is for. Rapids run only above the stock's extent along the
/// tool axis (the clearance plane) or at the safe height.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Pass {
    /// Positioning, not cutting (rapids, retracts).
    Air,
    /// Feed from the clearance plane to the start of a stroke.
    Entry,
    /// Feed from the end of a stroke back to the clearance plane.
    Exit,
    /// Roughing.
    Rough,
    /// Finishing.
    Finish,
    /// The finishing pass repeated with zero radial depth.
    ZeroCut,
}

/// One commanded move at a pose.
#[derive(Clone, Debug, PartialEq)]
pub struct PathMove {
    /// Rapid (true) or feed.
    pub rapid: bool,
    /// Feed, mm/min (the machine's linear rapid rate for rapids).
    pub feed: f64,
    /// What it is for.
    pub pass: Pass,
    /// End point as machine axis values.
    pub axes: Axes,
    /// End point as written in the program (program frame of the mode).
    pub program: Vector3<f64>,
    /// End point as the nominal tool tip in W.
    pub tip: Vector3<f64>,
}

/// One rotary pose (a cut) in execution order.
#[derive(Clone, Debug, PartialEq)]
pub struct PlannedPose {
    /// Pose id, as in points.csv.
    pub id: String,
    /// Execution order from 0.
    pub seq: u32,
    /// Tilt, deg.
    pub tilt: f64,
    /// C, deg.
    pub c: f64,
    /// Estimated minutes from program start when the pose begins (rotary index).
    pub start_min: f64,
    /// ... and ends (after the retract).
    pub end_min: f64,
    /// Nominal tool axis in W (tip towards spindle).
    pub tool_axis: Vector3<f64>,
    /// Program frame of `--kinematics controller` (columns: its X, Y, Z in W).
    pub frame: Matrix3<f64>,
    /// What the pose cuts.
    pub feature: String,
    /// Position after the rotary index, at the safe height.
    pub start: Axes,
    /// The moves, ending with the retract.
    pub moves: Vec<PathMove>,
}

impl PlannedPose {
    /// Start and end axis values of move `i`.
    pub fn segment(&self, i: usize) -> (Axes, Axes) {
        let a = if i == 0 {
            self.start
        } else {
            self.moves[i - 1].axes
        };
        (a, self.moves[i].axes)
    }
}

/// A nominal tool position that generated a surface point.
#[derive(Clone, Debug, PartialEq)]
pub struct Generator {
    /// Index of the move in the pose's `moves`.
    pub move_index: usize,
    /// Parameter along the move, 0 at its start, 1 at its end.
    pub t: f64,
    /// Nominal tool tip in W at that instant.
    pub tip: Vector3<f64>,
    /// Nominal tool axis in W.
    pub axis: Vector3<f64>,
    /// Axis values at that instant.
    pub axes: Axes,
    /// The pass of the move.
    pub pass: Pass,
}

/// Which pose and which part of the tool made a surface point.
#[derive(Clone, Debug, PartialEq)]
pub struct Provenance {
    /// Index into `MachiningPlan::poses`.
    pub pose: usize,
    /// The tool part that made the surface.
    pub part: ToolPart,
    /// Every move of that pose that touches the point, in execution order.
    pub generators: Vec<Generator>,
}

/// A plan point with its provenance.
#[derive(Clone, Debug, PartialEq)]
pub struct PlannedPoint {
    /// The plan point of docs/formats.md.
    pub point: PlanPoint,
    /// The surface it lies on (`wall +X`, `floor`, `section 3`, ...).
    pub surface: String,
    /// Who made it.
    pub provenance: Provenance,
}

/// A planar face patch of the nominal piece.
#[derive(Clone, Debug, PartialEq)]
pub struct Face {
    /// Tag: 0 for uncut stock, else 1 + the index of the pose that cut it.
    pub tag: u32,
    /// Outward unit normal in W.
    pub normal: Vector3<f64>,
    /// Plane offset: `normal . x = offset` on the face, mm.
    pub offset: f64,
    /// Convex outline in W, counter-clockwise seen from outside.
    pub outline: Vec<Vector3<f64>>,
}

/// The nominal finished piece.
#[derive(Clone, Debug, PartialEq)]
pub struct Piece {
    /// The stock block.
    pub stock: Cuboid,
    /// The riser under it, if any.
    pub fixture: Option<Cuboid>,
    /// Exact point membership.
    pub solid: Solid,
    /// Boundary patches.
    pub faces: Vec<Face>,
    /// Triangle mesh (what `.obj` and `.glb` hold).
    pub mesh: Mesh,
}

/// A planned machining test.
#[derive(Clone, Debug)]
pub struct MachiningPlan {
    /// The test.
    pub test: Test,
    /// The machine.
    pub machine: Machine,
    /// The template.
    pub template: Template,
    /// The postprocessor.
    pub post: PostDefinition,
    /// The dialect.
    pub dialect: Dialect,
    /// How 3+2 positions are written.
    pub kinematics: KinematicsMode,
    /// The tool.
    pub tool: Tool,
    /// The tool's solid.
    pub cutter: Cutter,
    /// Spindle speed, feeds and coolant.
    pub cutting: CuttingData,
    /// Program Z of the safe height.
    pub safe_z: f64,
    /// Poses in execution order.
    pub poses: Vec<PlannedPose>,
    /// The nominal piece.
    pub piece: Piece,
    /// Plan points with provenance.
    pub points: Vec<PlannedPoint>,
    /// The neutral toolpath of the whole program.
    pub toolpath: Vec<Op>,
    /// What the program header says.
    pub info: ProgramInfo,
    /// The rendered program.
    pub program: RenderedProgram,
    /// Notes for the setup sheet (adaptations to the machine, warnings).
    pub notes: Vec<String>,
    /// Estimated run time, min.
    pub run_minutes: f64,
    /// The stock and its fixturing, in words.
    pub stock_text: String,
    /// Why the safe height is safe, in words.
    pub safe_reason: String,
}

impl MachiningPlan {
    /// The plan points as points.csv (docs/formats.md).
    pub fn plan_points(&self) -> PlanPoints {
        PlanPoints {
            tilt_letter: self.machine.tilt_letter(),
            points: self.points.iter().map(|p| p.point.clone()).collect(),
        }
    }

    /// The pose with id `id`.
    pub fn pose(&self, id: &str) -> Option<&PlannedPose> {
        self.poses.iter().find(|p| p.id == id)
    }
}

/// Plans a machining test. With `stock.raise` in the template, a piece the
/// spindle cannot reach low enough within the Z stroke, or whose spindle
/// nose or holder would meet the table, is put on a higher riser.
pub fn plan(cfg: &PlanConfig) -> Result<MachiningPlan, PlanError> {
    let (raise_allowed, base, assembly) = match &cfg.template {
        Template::SteppedSquare(t) => (t.stock.raise, t.stock.fixture_height, &t.assembly),
        Template::NineSection(t) => (t.stock.raise, t.stock.fixture_height, &t.assembly),
        Template::Columns(_) | Template::Sphere(_) => {
            return Err(PlanError::Impossible(format!(
                "{} is a probing test, not a machining test",
                cfg.template.test()
            )));
        }
    };
    let mut raise = 0.0;
    // Why the riser went up: the Z stroke, the spindle nose over the table.
    let mut why: Vec<String> = Vec::new();
    let attempt = |raise: f64| -> Result<MachiningPlan, PlanError> {
        let mut design = design(cfg, raise)?;
        match assembly {
            Some((holder, nose)) => assembly::check(&cfg.machine, &design, holder, nose)?,
            // A template from before the keys existed plans as it did
            // then, and says what it leaves unchecked.
            None => design.notes.push(
                "the template gives no holder: or spindle_nose:, so the tool assembly is not checked against the table, the riser and the block: add them (the built-in template's show the keys) to have it checked".to_string(),
            ),
        }
        program::assemble(cfg, design)
    };
    for _ in 0..8 {
        match attempt(raise) {
            Err(PlanError::Stroke {
                axis: 'Z',
                value,
                lo,
                ..
            }) if raise_allowed && value < lo => {
                raise += ((lo - value) / 5.0).ceil() * 5.0 + 5.0;
                let r = "the spindle reaches every pose within the Z stroke".to_string();
                if !why.contains(&r) {
                    why.push(r);
                }
            }
            Err(PlanError::Assembly(c)) if raise_allowed && c.obstacle == "table" => {
                raise += (c.shortfall() / 5.0).ceil() * 5.0;
                let r = format!(
                    "the {} (diameter {} mm) clears the table at {} = {}",
                    c.part,
                    super::short(c.diameter),
                    c.letter,
                    super::short(c.tilt)
                );
                if !why.contains(&r) {
                    why.push(r);
                }
            }
            Ok(mut p) if raise > 0.0 => {
                p.notes.push(format!(
                    "the riser is {} mm instead of {} mm, so that {}",
                    super::short(base + raise),
                    super::short(base),
                    why.join(" and ")
                ));
                return Ok(p);
            }
            other => return other,
        }
    }
    attempt(raise)
}

/// Dispatches to the test's designer.
fn design(cfg: &PlanConfig, raise: f64) -> Result<design::MachiningDesign, PlanError> {
    match &cfg.template {
        Template::SteppedSquare(t) => stepped_square::design::design(cfg, t, raise),
        Template::NineSection(t) => nine_section::design::design(cfg, t, raise),
        Template::Columns(_) | Template::Sphere(_) => Err(PlanError::Impossible(format!(
            "{} is a probing test, not a machining test",
            cfg.test()
        ))),
    }
}
