//! Turns the candidate touches of each pose into the plan: which touches
//! the probe can make, their waypoints, and the safe path through them.

use nalgebra::Vector3;

use super::collision::{Checker, Collision, Obstacle, ProbeShape};
use super::{
    ControlLimits, LeftOut, ProbingMove, ProbingMoveKind, ProbingSettings, Touch, TouchPlan,
    TouchPose, Waypoint,
};
use crate::kinematics::pose_frame::PoseFrame;
use crate::kinematics::{Axes, Kinematics};
use crate::machine::Structure;
use crate::procedure::{PlanError, Test};

/// A surface point that a pose may probe.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct SurfaceCandidate {
    /// The obstacle it lies on.
    pub piece: String,
    /// Its name within the pose (`C1_t1`, `xp`, ...), the label's suffix.
    pub feature: String,
    /// Nominal contact point in W.
    pub contact_w: Vector3<f64>,
    /// Outward unit normal in W.
    pub normal_w: Vector3<f64>,
}

/// A pose with its candidate touches in the order they are made.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct PoseSpec {
    /// TouchPose id.
    pub id: String,
    /// Tilt, deg.
    pub tilt: f64,
    /// C, deg.
    pub c: f64,
    /// The candidates.
    pub candidates: Vec<SurfaceCandidate>,
}

fn waypoint(frame: &PoseFrame, ball_w: Vector3<f64>) -> Waypoint {
    Waypoint {
        axes: frame.commanded(&ball_w),
        ball_w,
        ball_prog: frame.to_prog(&ball_w),
    }
}

/// The same X, Y (and angles) at commanded height `z`.
fn at_z(frame: &PoseFrame, w: &Waypoint, z: f64) -> Waypoint {
    let xyz = Vector3::new(w.axes.xyz.x, w.axes.xyz.y, z);
    let ball_prog = frame.ball_prog(&xyz);
    Waypoint {
        axes: Axes {
            xyz,
            tilt: frame.tilt,
            c: frame.c,
        },
        ball_w: frame.to_w(&ball_prog),
        ball_prog,
    }
}

/// Commanded Z at which the probe clears everything whatever the rotary
/// axes do (see [`TouchPlan::safe_z`]).
fn safe_z(kin: &Kinematics, obstacles: &[Obstacle], probe: &ProbeShape, margin: f64) -> f64 {
    let m = kin.machine();
    match m.structure {
        Structure::TableTable => {
            // Everything on the table turns about axes through the W origin
            // and stays inside this sphere; the probe hangs straight down.
            let r = obstacles
                .iter()
                .map(|o| o.solid.farthest_from(&Vector3::zeros()))
                .fold(0.0, f64::max);
            r + margin + probe.ball_radius
        }
        Structure::HeadTable | Structure::HeadHead => {
            // The table turns (if at all) about Z, so nothing rises above
            // its top; the probe swings about the head's pivot, `lh` above
            // the commanded point, and stays inside a ball of radius `reach`.
            let top = obstacles
                .iter()
                .map(|o| {
                    o.solid
                        .extent_along(&nalgebra::Isometry3::identity(), &Vector3::z())
                })
                .fold(f64::NEG_INFINITY, f64::max);
            let lh = m.pivot_length + kin.gauge_length();
            let ends = [
                (0.0, probe.ball_radius),
                (probe.stylus_length, probe.stylus_radius),
                (probe.stylus_length, probe.body_radius),
                (probe.stylus_length + probe.body_length, probe.body_radius),
                (
                    probe.stylus_length + probe.body_length,
                    probe.spindle_radius,
                ),
                (
                    probe.stylus_length + probe.body_length + probe.spindle_length,
                    probe.spindle_radius,
                ),
            ];
            let reach = ends
                .iter()
                .map(|&(s, r)| (lh - s).abs() + r)
                .fold(0.0, f64::max);
            top + margin + reach - lh
        }
    }
}

/// Commanded Z at a pose above which the probe clears every obstacle.
fn clear_z(frame: &PoseFrame, obstacles: &[Obstacle], probe: &ProbeShape, margin: f64) -> f64 {
    let top = obstacles
        .iter()
        .map(|o| o.solid.extent_along(&frame.w_to_prog(), &Vector3::z()))
        .fold(f64::NEG_INFINITY, f64::max);
    let caps = probe.capsules(&Vector3::zeros(), &frame.probe_axis_prog());
    let down = caps
        .iter()
        .map(|c| c.radius - c.a.z.min(c.b.z))
        .fold(0.0, f64::max);
    top + margin + down - frame.head_offset().z
}

/// Rounds a height up to the next whole millimetre strictly above it, so
/// that a clearance never sits exactly at the margin.
fn round_up(z: f64) -> f64 {
    (z + 1e-6).ceil()
}

/// Whether a unit direction runs along X, Y or Z (as the post engine
/// decides it for a control that probes along one axis only).
pub(crate) fn axis_aligned(d: &Vector3<f64>) -> bool {
    let d = d.normalize();
    (0..3).any(|i| (d[i].abs() - 1.0).abs() < 1e-9)
}

/// Checks that the commanded point lies inside the strokes.
pub(crate) fn check_strokes(kin: &Kinematics, axes: &Axes) -> Result<(), String> {
    kin.check_strokes(axes)
}

struct Feasible {
    touch: Touch,
    above: Waypoint,
}

/// A pose with its frame and its clearance height (program Z).
struct FramedPose {
    spec: PoseSpec,
    frame: PoseFrame,
    clear: f64,
}

/// What every touch is checked against: the machine, the collision
/// checker, the probing settings and the control's limits.
struct Reach<'a> {
    kin: &'a Kinematics,
    checker: Checker<'a>,
    settings: &'a ProbingSettings,
    limits: &'a ControlLimits,
    /// Ball radius.
    r: f64,
    /// The safe height (program Z).
    safe: f64,
}

#[allow(clippy::too_many_arguments)]
pub(crate) fn build(
    test: Test,
    kin: Kinematics,
    obstacles: Vec<Obstacle>,
    probe: ProbeShape,
    settings: ProbingSettings,
    specs: Vec<PoseSpec>,
    limits: &ControlLimits,
) -> Result<TouchPlan, PlanError> {
    let margin = settings.safe_margin;
    let safe = round_up(safe_z(&kin, &obstacles, &probe, margin));
    let (framed, safe) = framed_poses(&kin, &obstacles, &probe, &settings, specs, safe)?;
    check_safe_height(&kin, safe)?;

    let reach = Reach {
        kin: &kin,
        checker: Checker::new(&kin, &obstacles, &probe),
        settings: &settings,
        limits,
        r: probe.ball_radius,
        safe,
    };
    let mut skipped = Vec::new();
    let mut planned: Vec<(FramedPose, Vec<Feasible>)> = Vec::new();
    for pose in framed {
        let ok = reach.feasible(&pose, &mut skipped);
        if ok.is_empty() {
            skipped.push(LeftOut {
                pose: pose.spec.id.clone(),
                label: pose.spec.id.clone(),
                reason: "no touch of this pose is reachable without collision".into(),
            });
            continue;
        }
        planned.push((pose, ok));
    }
    if planned.is_empty() {
        return Err(PlanError::Unreachable(format!(
            "no pose has a reachable touch (the first one left out: {}: {})",
            skipped.first().map_or("-", |s| s.label.as_str()),
            skipped.first().map_or("-", |s| s.reason.as_str())
        )));
    }
    let first = &planned[0];
    let start = at_z(&first.0.frame, &first.1[0].touch.start, safe);
    let mut path = PathBuilder {
        moves: Vec::new(),
        here: start.clone(),
        touches: Vec::new(),
    };
    let mut poses = Vec::new();
    for (k, (pose, feas)) in planned.into_iter().enumerate() {
        poses.push(path.pose(&reach, k, pose, &feas));
    }
    let PathBuilder { moves, touches, .. } = path;
    let plan = TouchPlan {
        test,
        kin,
        obstacles,
        probe,
        settings,
        safe_z: safe,
        start,
        poses,
        touches,
        moves,
        skipped,
        warnings: Vec::new(),
    };
    check_path(plan)
}

/// Each pose's frame and clearance height (above its setup and every start
/// point, so that each start is reached by a descent), refused beyond the
/// rotary limits; and the safe height, raised to at least every pose's
/// clearance height.
fn framed_poses(
    kin: &Kinematics,
    obstacles: &[Obstacle],
    probe: &ProbeShape,
    settings: &ProbingSettings,
    specs: Vec<PoseSpec>,
    safe: f64,
) -> Result<(Vec<FramedPose>, f64), PlanError> {
    let m = kin.machine();
    let r = probe.ball_radius;
    let mut framed = Vec::new();
    let mut safe = safe;
    for spec in specs {
        for (axis, v) in [(&m.tilt, spec.tilt), (&m.c, spec.c)] {
            if !axis.within(v, 1e-9) {
                return Err(PlanError::Unreachable(format!(
                    "pose {}: {} = {v} deg is outside the machine's limits {}",
                    spec.id,
                    axis.letter,
                    super::limits_text(axis)
                )));
            }
        }
        let frame = PoseFrame::new(kin, spec.tilt, spec.c);
        let mut clear = clear_z(&frame, obstacles, probe, settings.safe_margin);
        for cand in &spec.candidates {
            let start = cand.contact_w + cand.normal_w.normalize() * (r + settings.clearance);
            clear = clear.max(frame.commanded(&start).xyz.z);
        }
        let clear = round_up(clear);
        safe = safe.max(clear);
        framed.push(FramedPose { spec, frame, clear });
    }
    Ok((framed, safe))
}

/// Refuses a safe height beyond the Z stroke: without it the rotary axes
/// cannot turn safely anywhere.
fn check_safe_height(kin: &Kinematics, safe: f64) -> Result<(), PlanError> {
    let m = kin.machine();
    let gauge = safe + kin.gauge_length() + m.pivot.z;
    let (lo, hi) = m.strokes[2];
    if gauge > hi + 1e-9 || gauge < lo - 1e-9 {
        return Err(PlanError::Unreachable(format!(
            "the probe clears the setup at every rotary position only above Z{safe} (program \
             coordinates), where Z would be at {gauge:.3} in machine coordinates, outside its stroke [{lo}, {hi}]"
        )));
    }
    Ok(())
}

impl Reach<'_> {
    /// The touches of a pose that can be made, the others left out with the
    /// reason.
    fn feasible(&self, pose: &FramedPose, skipped: &mut Vec<LeftOut>) -> Vec<Feasible> {
        let mut ok = Vec::new();
        for cand in &pose.spec.candidates {
            let label = format!("{}_{}", pose.spec.id, cand.feature);
            match self.touch(pose, cand, label.clone()) {
                Ok(f) => ok.push(f),
                Err(reason) => skipped.push(LeftOut {
                    pose: pose.spec.id.clone(),
                    label,
                    reason,
                }),
            }
        }
        ok
    }

    /// One candidate as a touch with its waypoints, or why it cannot be
    /// made: an approach off the axes on a control that probes along them
    /// only, a waypoint beyond the strokes, or a collision on the way down
    /// or on the probing move.
    fn touch(
        &self,
        pose: &FramedPose,
        cand: &SurfaceCandidate,
        label: String,
    ) -> Result<Feasible, String> {
        let FramedPose { frame, clear, .. } = pose;
        let (settings, r) = (self.settings, self.r);
        let margin = settings.safe_margin;
        let n = cand.normal_w.normalize();
        let start = waypoint(frame, cand.contact_w + n * (r + settings.clearance));
        let contact = waypoint(frame, cand.contact_w + n * r);
        let end = waypoint(frame, cand.contact_w + n * (r - settings.overtravel));
        let above = at_z(frame, &start, *clear);
        let high = at_z(frame, &start, self.safe);
        let n_prog = frame.dir_to_prog(&n);
        if self.limits.axis_aligned_probing && !axis_aligned(&n_prog) {
            return Err(format!(
                "the control probes along X, Y or Z only, and this approach runs along \
                 ({:.4}, {:.4}, {:.4}) in program coordinates",
                -n_prog.x, -n_prog.y, -n_prog.z
            ));
        }
        for (what, w) in [
            ("start", &start),
            ("overtravel end", &end),
            ("clearance point", &above),
            ("safe point", &high),
        ] {
            if let Err(e) = check_strokes(self.kin, &w.axes) {
                return Err(format!("{what}: {e}"));
            }
        }
        if let Err(c) = self.checker.check_move(&above.axes, &start.axes, margin) {
            return Err(format!("going down to the start point, {c}"));
        } else if let Err(c) = self.checker.check_move(&start.axes, &contact.axes, -1e-6) {
            return Err(format!("on the probing move, {c}"));
        }
        Ok(Feasible {
            touch: Touch {
                index: 0,
                label,
                pose: 0,
                piece: cand.piece.clone(),
                feature: cand.feature.clone(),
                contact_w: cand.contact_w,
                normal_w: n,
                contact_prog: frame.to_prog(&cand.contact_w),
                normal_prog: frame.dir_to_prog(&n),
                start,
                contact,
                end,
                feed: settings.feed,
            },
            above,
        })
    }
}

/// The probe's path as it is laid: the moves so far, where the probe is,
/// and the touches made.
struct PathBuilder {
    moves: Vec<ProbingMove>,
    here: Waypoint,
    touches: Vec<Touch>,
}

impl PathBuilder {
    /// A move of pose `pose` to `to`; a rapid or positioning move that goes
    /// nowhere is left out.
    fn push(&mut self, kind: ProbingMoveKind, to: Waypoint, pose: usize) {
        let here = &self.here;
        let still = (to.axes.xyz - here.axes.xyz).norm() < 1e-9
            && (to.axes.tilt - here.axes.tilt).abs() < 1e-12
            && (to.axes.c - here.axes.c).abs() < 1e-12;
        if still && matches!(kind, ProbingMoveKind::Rapid | ProbingMoveKind::Position) {
            return;
        }
        self.moves.push(ProbingMove {
            kind,
            from: here.clone(),
            to: to.clone(),
            pose,
        });
        self.here = to;
    }

    /// The `k`-th pose's part of the path: turn at the safe height, go down
    /// to the first start point, probe each touch in turn (going round by
    /// the clearance height where the direct way collides), and back up.
    fn pose(
        &mut self,
        reach: &Reach<'_>,
        k: usize,
        pose: FramedPose,
        feas: &[Feasible],
    ) -> TouchPose {
        let FramedPose { spec, frame, clear } = pose;
        let safe = reach.safe;
        if k > 0 {
            let turned = at_z(&frame, &self.here, safe);
            self.push(ProbingMoveKind::Rotary, turned, k);
        }
        let first_start = &feas[0].touch.start;
        self.push(ProbingMoveKind::Rapid, at_z(&frame, first_start, safe), k);
        self.push(ProbingMoveKind::Rapid, feas[0].above.clone(), k);
        self.push(ProbingMoveKind::Position, first_start.clone(), k);
        let t0 = self.touches.len();
        let count = feas.len();
        for (i, f) in feas.iter().enumerate() {
            let ti = self.touches.len();
            let mut touch = f.touch.clone();
            touch.index = ti + 1;
            touch.pose = k;
            self.push(ProbingMoveKind::Probe(ti), touch.end.clone(), k);
            // The controller stops at the contact; retract from there.
            self.here = touch.contact.clone();
            self.push(ProbingMoveKind::Retract(ti), touch.start.clone(), k);
            self.touches.push(touch);
            if i + 1 < count {
                let next = &feas[i + 1];
                if reach
                    .checker
                    .check_move(
                        &self.here.axes,
                        &next.touch.start.axes,
                        reach.settings.safe_margin,
                    )
                    .is_ok()
                {
                    self.push(ProbingMoveKind::Position, next.touch.start.clone(), k);
                } else {
                    self.push(ProbingMoveKind::Position, f.above.clone(), k);
                    self.push(ProbingMoveKind::Rapid, next.above.clone(), k);
                    self.push(ProbingMoveKind::Position, next.touch.start.clone(), k);
                }
            } else {
                self.push(ProbingMoveKind::Position, f.above.clone(), k);
                let up = at_z(&frame, &self.here, safe);
                self.push(ProbingMoveKind::Rapid, up, k);
            }
        }
        TouchPose {
            id: spec.id,
            seq: k as u32,
            tilt: spec.tilt,
            c: spec.c,
            touches: t0..self.touches.len(),
            clear_z: clear,
        }
    }
}

/// The plan, refused if a move leaves the machine's travel or collides.
fn check_path(plan: TouchPlan) -> Result<TouchPlan, PlanError> {
    if let Some((i, e)) = plan.check_limits().into_iter().next() {
        return Err(PlanError::Unreachable(format!(
            "move {i} of the path ({:?}) leaves the machine's travel: {e}",
            plan.moves[i].kind
        )));
    }
    if let Some((i, c)) = plan.check().into_iter().next() {
        return Err(PlanError::Collision {
            move_index: i,
            kind: plan.moves[i].kind,
            collision: Box::new(c),
        });
    }
    Ok(plan)
}

/// Checks every move of a plan: probing moves up to the contact (the ball
/// may touch), retracts likewise, everything else with the plan's margin.
pub(crate) fn check_moves(plan: &TouchPlan) -> Vec<(usize, Collision)> {
    let checker = Checker::new(&plan.kin, &plan.obstacles, &plan.probe);
    let mut out = Vec::new();
    for (i, mv) in plan.moves.iter().enumerate() {
        let r = match mv.kind {
            ProbingMoveKind::Probe(t) => {
                checker.check_move(&mv.from.axes, &plan.touches[t].contact.axes, -1e-6)
            }
            ProbingMoveKind::Retract(_) => checker.check_move(&mv.from.axes, &mv.to.axes, -1e-6),
            _ => checker.check_move(&mv.from.axes, &mv.to.axes, plan.settings.safe_margin),
        };
        if let Err(c) = r {
            out.push((i, c));
        }
    }
    out
}
