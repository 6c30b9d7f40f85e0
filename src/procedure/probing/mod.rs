//! The probing tests: pieces on the table touched by the machine's own
//! probe at a set of poses, the touches logged by the program. Each test
//! designs its touches and poses in its own folder ([`columns`], [`sphere`]:
//! the design and the template). What they share: what each touch is, the
//! safe path through the touches ([`TouchPlan`], dialect-free), a collision
//! checker for any path ([`collision`]: the probe's ball, stylus, body and
//! spindle nose as capsules against column boxes, the sphere, its stem and
//! the table), the expected run time ([`time`]); `program` renders a
//! [`TouchPlan`] into an NC program that logs its touches ([`ProbingPlan`]),
//! and the log readers of [`crate::formats::probe_log`] turn what that
//! program records back into contact points.
//!
//! # Frames
//! Nominal geometry is in W (docs/model.md). The program's coordinates
//! have the work offset on the W origin at rotary zero, so at a pose
//! `(t, c)` a W point `q` is at `rTw*(t, c) q` ([`PoseFrame`]). The probe
//! hangs along the spindle axis; on a head machine it tilts with the head
//! and its ball is not at the commanded X, Y, Z ([`PoseFrame::commanded`]
//! accounts for that). Every position of the plan is a [`Waypoint`]: the
//! commanded axes, and the ball centre in W and in program coordinates.
//!
//! # What a touch is
//! A [`Touch`] probes one nominal surface point `p` with outward unit
//! normal `n` (both in W, as in `points.csv`). With ball radius `r`:
//! - `start`: the ball centre at `p + (r + clearance) n`, reached by
//!   positioning moves;
//! - the probing move runs from `start` along `-n` (the approach) at the
//!   probing feed towards `end = p + (r - overtravel) n`, and the controller
//!   stops it at the contact, nominally the ball centre `contact = p + r n`;
//! - then the probe retracts to `start` at the positioning feed.
//!
//! The controller records the ball centre at the trigger in program
//! coordinates; the contact point is that minus `r` times `n` expressed in
//! program coordinates at the pose (what the log readers compute).
//!
//! # The safe path
//! [`TouchPlan::moves`] is the whole path in execution order, starting at
//! [`TouchPlan::start`]. The program reaches `start` by raising Z to
//! [`TouchPlan::safe_z`] first, then turning the rotary axes to the first
//! pose, then moving X, Y. Then, per pose:
//! - rapid in X, Y at `safe_z` above the first start point, rapid down to
//!   the pose's clearance height [`TouchPose::clear_z`] (above every obstacle at
//!   this pose with the margin, and above every start point), position
//!   down to the start;
//! - each touch: the probing move, the retract; then to the next start
//!   point directly when that straight move keeps the margin from every
//!   obstacle (around a column's corner, say), else up to `clear_z`,
//!   across, and down (over the pieces);
//! - after the last touch: up to `clear_z`, rapid up to `safe_z`, and a
//!   rotary move (rotary axes only) to the next pose.
//!
//! At `safe_z` nothing can be hit whatever the rotary axes do: on a
//! table-table machine the probe clears the ball about the W origin that
//! holds everything on the table; on a head machine the probe's reach about
//! the head pivot clears the top of the setup. Every move changes either
//! the rotary axes or the linear ones; rapids only ever run at `clear_z` or
//! `safe_z` or straight up and down, so the shape of a multi-axis rapid
//! (FANUC's non-linear positioning) cannot matter. [`TouchPlan::check`]
//! re-checks every move with the [`collision`] checker, and the planner
//! refuses to return a plan that fails it or leaves the strokes.
//!
//! Touches the probe cannot make at a pose (a face turned away from the
//! spindle, the stylus or body hitting a piece, the stem or the table on
//! the way, a point out of stroke) are left out of that pose and listed in
//! [`TouchPlan::skipped`] with the reason. A pose whose remaining touches
//! cannot fix on their own what the test measures there (the table's six
//! pose components for the columns, the sphere's centre) is kept, for a
//! joint identification, and named in [`TouchPlan::warnings`].
//!
//! # For the post-processor
//! `program` renders a plan through the post engine as
//! follows. Per [`ProbingMoveKind`]: `Rapid` is a G0 (or `L ... FMAX`) of X, Y, Z; `Rotary`
//! a G0 of the rotary axes alone, between the stored angles (at `safe_z`
//! any direction of rotation is safe, so a controller's shortest-path mode
//! does no harm); `Position` and `Retract` are linear moves at
//! [`ProbingSettings::positioning_feed`]; `Probe(i)` is the dialect's
//! probing move (`G31`, `G38.2`, `TCH PROBE`) to `to`, the touch's
//! overtravel end, at [`Touch::feed`], followed by the log statements of
//! [`crate::formats::probe_log`] for touch `i` (its [`Touch::index`] or
//! [`Touch::label`]). The program runs with the work offset on the W origin
//! at rotary zero and without TCP (the rotary axes stand still while
//! probing, and the logs are read as commanded positions); on FANUC every
//! commanded coordinate must pass
//! [`crate::formats::probe_log::fanuc::fits_field`].
//!
//! # Machines
//! The planner works in W through the machine's kinematics, so one code
//! serves every structure. On the table-table machines of the papers
//! (`ac-trunnion`, `bc-trunnion`) the rotary axes move the pieces and each
//! pose shows the table's pose error, as the papers intend. On `head-table`
//! the C table turns the pieces and the tilting head turns the probe; the
//! touches measure both. On `head-head` the pieces never move: every pose
//! probes the same points with the head turned, which measures the head's
//! location errors at one place. The sphere test is the natural test there
//! (as in head-calibration cycles); the column pattern plans and checks as
//! well, but its many faces add little over the sphere's five touches.
//!
//! # Labels and indices
//! Poses are executed in order; [`TouchPose::seq`] counts from 0 and the pose id
//! says where the machine is (`A-30C60`; `S07` for the the LAMDAMAP 2015 paper's spiral).
//! Touches are numbered in execution order: [`Touch::index`] counts from 1
//! and is the touch's row among the data rows of `points.csv`
//! ([`TouchPlan::points`]); [`Touch::label`] is `<pose>_<feature>`, e.g.
//! `A-30C60_C2_xp` (column C2, the face whose normal is +X in W) or
//! `A0C10_xm` (sphere, approach in -X). A label depends only on the pose
//! and the feature, never on which other touches were possible. FANUC and
//! HEIDENHAIN logs carry the index, LinuxCNC logs the label.

pub mod collision;
pub mod columns;
mod log_format;
mod outputs;
mod path;
mod program;
pub mod setup_mesh;
pub mod sphere;
pub mod template;
pub mod time;

use std::ops::Range;

use nalgebra::Vector3;

use super::{PlanError, Template};
use crate::formats::points::{PlanPoint, PlanPoints};
use crate::kinematics::{Axes, Kinematics};

pub use crate::kinematics::pose_frame::PoseFrame;
pub use collision::{Checker, Collision, ConvexSolid, Obstacle, ProbePart, ProbeShape};
pub use program::{
    ProbedColumn, ProbedGeometry, ProbedSphere, ProbingPlan, ProbingPose, log_name, plan,
};
pub use time::RunTime;

/// How touches are made (the template's `probing:` section).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProbingSettings {
    /// Gap between ball and surface at the start of a probing move, mm.
    pub clearance: f64,
    /// How far past the nominal surface the probing move is programmed, mm.
    pub overtravel: f64,
    /// Probing feed, mm/min.
    pub feed: f64,
    /// Feed of positioning moves below the clearance height, mm/min.
    pub positioning_feed: f64,
    /// Smallest gap every positioning move keeps from the setup, mm.
    pub safe_margin: f64,
    /// Time per touch beyond its moves (trigger, reversal, log write), s.
    pub touch_overhead: f64,
    /// Time per pose beyond its moves (rotary clamping, settling), s.
    pub pose_overhead: f64,
}

/// What the control can and cannot do, as far as the plan is concerned.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ControlLimits {
    /// The control probes along one program axis only (HEIDENHAIN's touch
    /// probe cycle 0, [`crate::post::PostDefinition::probe_axis_aligned`]):
    /// a touch whose approach is oblique in program coordinates is left
    /// out of its pose and listed in [`TouchPlan::skipped`].
    pub axis_aligned_probing: bool,
}

/// A position of the path.
#[derive(Clone, Debug, PartialEq)]
pub struct Waypoint {
    /// Commanded axes (program coordinates, deg).
    pub axes: Axes,
    /// Ball centre in W, mm.
    pub ball_w: Vector3<f64>,
    /// Ball centre in program coordinates, mm.
    pub ball_prog: Vector3<f64>,
}

/// One touch (see the module documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct Touch {
    /// 1-based execution order: the row in `points.csv`, the index logs carry.
    pub index: usize,
    /// Stable label `<pose>_<feature>`.
    pub label: String,
    /// Index of its pose in [`TouchPlan::poses`].
    pub pose: usize,
    /// The obstacle touched.
    pub piece: String,
    /// Feature name within the pose.
    pub feature: String,
    /// Nominal contact point in W, mm.
    pub contact_w: Vector3<f64>,
    /// Outward unit normal in W.
    pub normal_w: Vector3<f64>,
    /// Nominal contact point in program coordinates at the pose, mm.
    pub contact_prog: Vector3<f64>,
    /// Outward normal in program coordinates at the pose (the approach is
    /// its opposite).
    pub normal_prog: Vector3<f64>,
    /// Ball at the clearance distance: where the probing move starts.
    pub start: Waypoint,
    /// Ball touching the nominal surface.
    pub contact: Waypoint,
    /// Ball at the overtravel: the probing move's programmed end.
    pub end: Waypoint,
    /// Probing feed, mm/min.
    pub feed: f64,
}

/// A pose of the plan.
#[derive(Clone, Debug, PartialEq)]
pub struct TouchPose {
    /// Id (`A-30C60`, `S07`, ...).
    pub id: String,
    /// Execution order, from 0.
    pub seq: u32,
    /// Tilt, deg.
    pub tilt: f64,
    /// C, deg.
    pub c: f64,
    /// Its touches in [`TouchPlan::touches`].
    pub touches: Range<usize>,
    /// Commanded Z of the clearance height at this pose, mm.
    pub clear_z: f64,
}

/// What a move is, for the post-processor.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProbingMoveKind {
    /// Rapid (G0) of the linear axes: straight up or down, or X, Y at a
    /// clearance or safe height.
    Rapid,
    /// Rapid of the rotary axes only, at the safe height.
    Rotary,
    /// Linear move at the positioning feed (below the clearance height).
    Position,
    /// Probing move of touch `n` (index into [`TouchPlan::touches`]),
    /// programmed to its `end`; the controller stops at the contact.
    Probe(usize),
    /// Back from the contact of touch `n` to its start, at the positioning
    /// feed.
    Retract(usize),
}

/// A move of the path.
#[derive(Clone, Debug, PartialEq)]
pub struct ProbingMove {
    /// What it is.
    pub kind: ProbingMoveKind,
    /// Where it starts (for a retract, the nominal contact).
    pub from: Waypoint,
    /// Where it is programmed to end.
    pub to: Waypoint,
    /// Index of its pose in [`TouchPlan::poses`].
    pub pose: usize,
}

/// A touch (or a whole pose) the plan leaves out, and why.
#[derive(Clone, Debug, PartialEq)]
pub struct LeftOut {
    /// The pose id.
    pub pose: String,
    /// The label the touch would have had (the pose id for a whole pose).
    pub label: String,
    /// Why.
    pub reason: String,
}

/// The touches of a probing test and the safe path through them, before
/// any NC dialect.
#[derive(Clone, Debug)]
pub struct TouchPlan {
    /// The test.
    pub test: super::Test,
    /// The machine's kinematics with the probe's gauge length.
    pub kin: Kinematics,
    /// The setup in W: pieces, sphere and stem, table.
    pub obstacles: Vec<Obstacle>,
    /// The probe's shape.
    pub probe: ProbeShape,
    /// Distances, feeds and margins.
    pub settings: ProbingSettings,
    /// Commanded Z at which the rotary axes may move freely, mm.
    pub safe_z: f64,
    /// Where the path starts: above the first touch at `safe_z`, rotary
    /// axes at the first pose.
    pub start: Waypoint,
    /// Poses in execution order.
    pub poses: Vec<TouchPose>,
    /// Touches in execution order.
    pub touches: Vec<Touch>,
    /// The path.
    pub moves: Vec<ProbingMove>,
    /// What was left out.
    pub skipped: Vec<LeftOut>,
    /// Poses whose touches do not determine what the test measures there
    /// on their own (see `columns::design::weak_poses`, `sphere::design::weak_poses`).
    pub warnings: Vec<String>,
}

impl TouchPlan {
    /// The nominal points (docs/formats.md), one row per touch in execution
    /// order: row `i` (from 1) is the touch with index `i`.
    pub fn points(&self) -> PlanPoints {
        PlanPoints {
            tilt_letter: self.kin.machine().tilt_letter(),
            points: self
                .touches
                .iter()
                .map(|t| {
                    let pose = &self.poses[t.pose];
                    PlanPoint {
                        label: t.label.clone(),
                        pose: pose.id.clone(),
                        seq: pose.seq,
                        tilt: pose.tilt,
                        c: pose.c,
                        p: t.contact_w,
                        n: t.normal_w,
                    }
                })
                .collect(),
        }
    }

    /// Re-checks every move against the setup; empty for a plan the planner
    /// returned.
    pub fn check(&self) -> Vec<(usize, Collision)> {
        path::check_moves(self)
    }

    /// Every waypoint outside the strokes or rotary limits, by move index.
    pub fn check_limits(&self) -> Vec<(usize, String)> {
        let m = self.kin.machine();
        let mut out = Vec::new();
        for (i, mv) in self.moves.iter().enumerate() {
            for w in [&mv.from, &mv.to] {
                if let Err(e) = path::check_strokes(&self.kin, &w.axes) {
                    out.push((i, e));
                }
                for (axis, v) in [(&m.tilt, w.axes.tilt), (&m.c, w.axes.c)] {
                    if !axis.within(v, 1e-9) {
                        out.push((i, format!("{} = {v} is outside its limits", axis.letter)));
                    }
                }
            }
        }
        out
    }

    /// The expected run time from feeds, rapids and distances.
    pub fn run_time(&self) -> RunTime {
        time::estimate(self)
    }

    /// The pose frame of pose `i`.
    pub fn frame(&self, i: usize) -> PoseFrame {
        PoseFrame::new(&self.kin, self.poses[i].tilt, self.poses[i].c)
    }
}

/// The touches and path of either probing test on machine `m` for a
/// control with `limits`.
pub fn touch_plan(
    m: &crate::machine::Machine,
    t: &Template,
    limits: &ControlLimits,
) -> Result<TouchPlan, PlanError> {
    match t {
        Template::Columns(t) => columns::touch_plan_with(m, t, limits),
        Template::Sphere(t) => sphere::touch_plan_with(m, t, limits),
        Template::SteppedSquare(_) | Template::NineSection(_) => Err(PlanError::Impossible(
            format!("{} is a machining test, not a probing test", t.test()),
        )),
    }
}

/// Makes pose ids unique by suffixing repeats with `.2`, `.3`, ...
fn uniquify_ids(specs: &mut [path::PoseSpec]) {
    let mut seen: std::collections::HashMap<String, usize> = std::collections::HashMap::new();
    for s in specs.iter_mut() {
        let n = seen.entry(s.id.clone()).or_insert(0);
        *n += 1;
        if *n > 1 {
            s.id = format!("{}.{}", s.id, n);
        }
    }
}

/// A rotary axis's limits as a person writes them: `[-120, 30]`, or
/// `continuous`.
pub(crate) fn limits_text(axis: &crate::machine::RotaryAxis) -> String {
    match axis.limits {
        Some((lo, hi)) => format!("[{lo}, {hi}]"),
        None => "continuous".into(),
    }
}

/// A pose id from its angles: `A-30C60`, `B0C0`, at most three decimals.
pub(crate) fn pose_id(tilt_letter: char, tilt: f64, c: f64) -> String {
    format!("{tilt_letter}{}C{}", short(tilt), short(c))
}

fn short(v: f64) -> String {
    let s = format!("{v:.3}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".into() } else { s.to_string() }
}
