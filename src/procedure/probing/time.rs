//! The expected run time of a probing plan, from its path: each rapid takes
//! its longest axis at the machine's rapid rate (linear and rotary rates
//! from the machine file), each positioning move and retract its length at
//! the positioning feed, each probing move the distance to the nominal
//! contact at the probing feed; every touch adds a fixed overhead (trigger,
//! reversal, writing the log line) and every pose another (clamping the
//! rotary axes, settling). Acceleration is not modelled: the overheads
//! absorb it, and they are the template's to tune against a real run.

use super::{ProbingMoveKind, TouchPlan};

/// Time split by activity.
#[derive(Clone, Debug, PartialEq)]
pub struct RunTime {
    /// Whole program, min.
    pub total_min: f64,
    /// Rapids (linear and rotary), s.
    pub rapid_s: f64,
    /// Positioning moves and retracts, s.
    pub positioning_s: f64,
    /// Probing moves up to the contact, s.
    pub probing_s: f64,
    /// Touch and pose overheads, s.
    pub overhead_s: f64,
    /// Per pose of the plan: minutes from the start when it begins and ends.
    pub poses: Vec<(f64, f64)>,
    /// Number of touches.
    pub touches: usize,
    /// Per touch of the plan: minutes from the start when the probe
    /// reaches its nominal contact (for effects that drift with time).
    pub touch_min: Vec<f64>,
}

impl RunTime {
    /// Mean time per touch, s.
    pub fn per_touch_s(&self) -> f64 {
        if self.touches == 0 {
            0.0
        } else {
            self.total_min * 60.0 / self.touches as f64
        }
    }
}

pub(crate) fn estimate(plan: &TouchPlan) -> RunTime {
    let rapid = &plan.kin.machine().rapid;
    let s = &plan.settings;
    let (mut rapid_s, mut positioning_s, mut probing_s, mut overhead_s) = (0.0, 0.0, 0.0, 0.0);
    let mut poses = vec![(f64::NAN, 0.0); plan.poses.len()];
    let mut touch_min = vec![0.0; plan.touches.len()];
    let mut t = 0.0;
    for mv in &plan.moves {
        let d = mv.to.axes.xyz - mv.from.axes.xyz;
        let dt = match mv.kind {
            ProbingMoveKind::Rapid => {
                let v = d.abs().max() / rapid.linear * 60.0;
                rapid_s += v;
                v
            }
            ProbingMoveKind::Rotary => {
                let a = (mv.to.axes.tilt - mv.from.axes.tilt)
                    .abs()
                    .max((mv.to.axes.c - mv.from.axes.c).abs());
                let v = a / rapid.rotary * 60.0 + s.pose_overhead;
                rapid_s += v - s.pose_overhead;
                overhead_s += s.pose_overhead;
                v
            }
            ProbingMoveKind::Position | ProbingMoveKind::Retract(_) => {
                let v = d.norm() / s.positioning_feed * 60.0;
                positioning_s += v;
                v
            }
            ProbingMoveKind::Probe(i) => {
                let touch = &plan.touches[i];
                let v = (touch.contact.axes.xyz - mv.from.axes.xyz).norm() / touch.feed * 60.0;
                probing_s += v;
                touch_min[i] = (t + v) / 60.0;
                overhead_s += s.touch_overhead;
                v + s.touch_overhead
            }
        };
        // A rotary move belongs to the pose it turns to.
        let p = &mut poses[mv.pose];
        if p.0.is_nan() {
            p.0 = t / 60.0;
        }
        t += dt;
        p.1 = t / 60.0;
    }
    RunTime {
        total_min: t / 60.0,
        rapid_s,
        positioning_s,
        probing_s,
        overhead_s,
        poses,
        touches: plan.touches.len(),
        touch_min,
    }
}
