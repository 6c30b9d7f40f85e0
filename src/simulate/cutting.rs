//! The actual machine along a machining plan's toolpath: when each move
//! runs, where the commanded axes are at any instant of it, the context the
//! effects see there, the exact actual tool pose, and the actual cutter.
//!
//! This is the one code path both the exact simulator ([`super::machining`])
//! and the forward model ([`super::forward`]) go through, so they differ
//! only in how they find the surface, never in where the tool is.
//!
//! Time: a pose runs from its manifest `start_min` to `end_min`; its moves
//! take their length over their feed (rapids at the machine's rapid rate)
//! and end with the pose, the rotary index taking the time before the first
//! move. Drift per minute therefore changes continuously along a cut.
//!
//! Within a move the rotary axes stand still and X, Y, Z run linearly from
//! the move's start to its end. Every effect is affine in X, Y, Z except
//! straightness (piecewise linear between its nodes) and anything that
//! drifts with time, so without drift per minute the actual tool runs on a
//! straight line with a fixed axis between the instants where the moving
//! axis of a straightness error crosses one of its nodes.

use std::sync::Arc;

use nalgebra::Vector3;

use crate::geom::Axis3;
use crate::kinematics::{Axes, SLOT_TOOL_RADIUS, ToolPose};
use crate::model::{Context, DriftBasis, Effect, Model};
use crate::procedure::MachiningPlan;
use crate::procedure::machining::{Cutter, PlannedPose};

/// When each move of each pose runs.
#[derive(Clone, Debug)]
pub struct Timeline {
    /// Per pose, per move: minutes from the program start when it begins.
    start: Vec<Vec<f64>>,
    /// Per pose, per move: its duration, minutes.
    duration: Vec<Vec<f64>>,
    /// Per pose: the middle of its manifest interval (what `analyze`
    /// passes a forward model).
    mid: Vec<f64>,
}

impl Timeline {
    /// The timeline of a plan (pose intervals as its manifest lists them).
    pub fn new(plan: &MachiningPlan) -> Timeline {
        let entries = plan.pose_entries();
        let mut start = Vec::new();
        let mut duration = Vec::new();
        let mut mid = Vec::new();
        for (pose, e) in plan.poses.iter().zip(&entries) {
            let d: Vec<f64> = (0..pose.moves.len())
                .map(|i| {
                    let (a, b) = pose.segment(i);
                    let feed = pose.moves[i].feed;
                    if feed > 0.0 {
                        (b.xyz - a.xyz).norm() / feed
                    } else {
                        0.0
                    }
                })
                .collect();
            let total: f64 = d.iter().sum();
            // The moves end with the pose; what is left at its start is the
            // rotary index (never negative, whatever the rounding).
            let mut t = e.start_min.max(e.end_min - total);
            let mut s = Vec::with_capacity(d.len());
            for di in &d {
                s.push(t);
                t += di;
            }
            start.push(s);
            duration.push(d);
            mid.push(0.5 * (e.start_min + e.end_min));
        }
        Timeline {
            start,
            duration,
            mid,
        }
    }

    /// Minutes from the program start at parameter `t` of move `mv` of
    /// pose `pose`.
    pub fn at(&self, pose: usize, mv: usize, t: f64) -> f64 {
        self.start[pose][mv] + t * self.duration[pose][mv]
    }

    /// The middle of pose `pose`'s manifest interval, minutes.
    pub fn mid(&self, pose: usize) -> f64 {
        self.mid[pose]
    }
}

/// A machining plan on a machine with errors: the model (with the plan
/// tool's gauge length), the timeline and what makes a move non-affine.
#[derive(Clone, Debug)]
pub struct Cutting {
    /// The model.
    pub model: Model,
    /// The plan.
    pub plan: Arc<MachiningPlan>,
    /// When the moves run.
    pub timeline: Timeline,
    /// Whether an effect drifts with time (the actual path then bends
    /// within a move).
    pub drifts_in_time: bool,
    /// Maps along the linear axes (straightness, positioning, angular):
    /// the moving axis and its nodes (mm).
    breaks: Vec<(Axis3, Vec<f64>)>,
    /// Each move's nominal tip at its start and end and its tool axis, by
    /// pose: the forward model asks for them at every point of every fit.
    segments: Vec<Vec<Segment>>,
}

/// A move's nominal tip at its start and at its end, and its tool axis.
type Segment = (Vector3<f64>, Vector3<f64>, Vector3<f64>);

impl Cutting {
    /// The plan on the machine of `model`.
    pub fn new(model: Model, plan: Arc<MachiningPlan>) -> Cutting {
        let mut breaks = Vec::new();
        let mut drifts_in_time = false;
        for e in &model.effects {
            match e {
                Effect::Straightness { moving, nodes, .. }
                | Effect::Positioning {
                    axis: moving,
                    nodes,
                }
                | Effect::Angular { moving, nodes, .. } => breaks.push((*moving, nodes.clone())),
                Effect::Drift {
                    basis: DriftBasis::Minute,
                    ..
                } => drifts_in_time = true,
                _ => {}
            }
        }
        let timeline = Timeline::new(&plan);
        let k = &model.kin;
        let segments = plan
            .poses
            .iter()
            .map(|pose| {
                (0..pose.moves.len())
                    .map(|mv| {
                        let (a, b) = pose.segment(mv);
                        let fa = k.forward_nominal(&a);
                        let fb = k.forward_nominal(&b);
                        (fa.tip, fb.tip, fa.axis)
                    })
                    .collect()
            })
            .collect();
        Cutting {
            model,
            plan,
            timeline,
            drifts_in_time,
            breaks,
            segments,
        }
    }

    /// The commanded axes at parameter `t` of move `mv` of pose `pose`.
    pub fn axes(&self, pose: usize, mv: usize, t: f64) -> Axes {
        let (a, b) = self.plan.poses[pose].segment(mv);
        Axes {
            xyz: a.xyz + (b.xyz - a.xyz) * t,
            ..b
        }
    }

    /// The context of the effects at parameter `t` of a move; `offset`
    /// (minutes) shifts the clock.
    pub fn context(&self, pose: usize, mv: usize, t: f64, offset: f64) -> Context {
        let p: &PlannedPose = &self.plan.poses[pose];
        Context {
            axes: self.axes(pose, mv, t),
            seq: p.seq as f64,
            minutes: self.timeline.at(pose, mv, t) + offset,
            approach: None,
            ..Default::default()
        }
    }

    /// The actual tool pose in W at parameter `t` of a move.
    pub fn pose(&self, theta: &[f64], pose: usize, mv: usize, t: f64, offset: f64) -> ToolPose {
        self.model.pose(theta, &self.context(pose, mv, t, offset))
    }

    /// The parameters in (0, 1) where the actual path of a move bends: the
    /// moving axis of a straightness error crossing one of its nodes.
    /// Between them (and without drift in time) the actual tool moves on a
    /// straight line with a fixed axis.
    pub fn bends(&self, pose: usize, mv: usize) -> Vec<f64> {
        let (a, b) = self.plan.poses[pose].segment(mv);
        let mut out = Vec::new();
        for (axis, nodes) in &self.breaks {
            let (x0, x1) = (a.xyz[axis.index()], b.xyz[axis.index()]);
            if (x1 - x0).abs() < 1e-12 {
                continue;
            }
            for &n in nodes {
                let t = (n - x0) / (x1 - x0);
                if t > 1e-12 && t < 1.0 - 1e-12 {
                    out.push(t);
                }
            }
        }
        out.sort_by(f64::total_cmp);
        out.dedup_by(|x, y| (*x - *y).abs() < 1e-12);
        out
    }

    /// The affine piece of a move that holds parameter `t`: `(lo, hi)`.
    pub fn piece(&self, pose: usize, mv: usize, t: f64) -> (f64, f64) {
        let mut lo = 0.0;
        for b in self.bends(pose, mv) {
            if b <= t {
                lo = b;
            } else {
                return (lo, b);
            }
        }
        (lo, 1.0)
    }

    /// The tool-radius error, mm (it does not depend on where the tool is).
    pub(crate) fn radius_error(&self, theta: &[f64]) -> f64 {
        self.model.perturbation(theta, &Context::default()).0[SLOT_TOOL_RADIUS]
    }

    /// `d radius_error / d theta`, mm per parameter unit.
    pub(crate) fn radius_gradient(&self) -> Vec<f64> {
        let mut g = vec![0.0; self.model.n_params()];
        for (slot, k, c) in self.model.slot_coefficients(&Context::default()) {
            if slot == SLOT_TOOL_RADIUS {
                g[k] += c;
            }
        }
        g
    }

    /// The nominal tool tip at a move's ends, and its axis.
    pub(crate) fn nominal_segment(
        &self,
        pose: usize,
        mv: usize,
    ) -> (Vector3<f64>, Vector3<f64>, Vector3<f64>) {
        self.segments[pose][mv]
    }
}

/// The actual cutter: the plan's tool with its radius off by `dr` mm (a
/// ball grows as a ball; a bull-nose or flat end keeps its corner).
pub(crate) fn actual_cutter(nominal: &Cutter, dr: f64) -> Cutter {
    let ball = (nominal.corner - nominal.radius).abs() < 1e-12;
    Cutter {
        radius: nominal.radius + dr,
        corner: if ball {
            nominal.corner + dr
        } else {
            nominal.corner
        },
        length: nominal.length,
    }
}
