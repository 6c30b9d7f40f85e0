//! Choosing the setups: for each rotary axis, where the spindle ball M
//! sits, which bar goes which way to the table ball N, and the angles of
//! the sweep, all checked against the machine: the table ball on the table
//! and high enough for its post, the bar clear of the arbor, every angle
//! within the rotary limits and every commanded position within the
//! strokes (fivecal's inverse kinematics is what a TCP control commands).

use nalgebra::Vector3;

use super::{BallBarError, BallBarRequest, BarDirection, Setup, setup_kinematics};
use crate::kinematics::pose_frame::PoseFrame;
use crate::machine::{Machine, RotaryAxis};

/// Smallest angle between the bar and the arbor (tool axis) over a sweep,
/// deg: closer, the bar runs into the spindle-ball holder.
pub const MIN_BAR_ARBOR_DEG: f64 = 30.0;

/// Margin of the table ball from the table's edge, mm.
const EDGE_MARGIN: f64 = 25.0;

/// The angle the tilt axis holds while a C head is swept: the first of
/// 45, -45, 30, -30 deg within its limits (at zero the ball sits on the C
/// axis and the C rotation about it goes unseen).
pub fn head_angle_held(tilt: &RotaryAxis) -> Option<f64> {
    [45.0, -45.0, 30.0, -30.0]
        .into_iter()
        .find(|&a| tilt.within(a, 0.0))
}

/// The sweep of an axis: a continuous C a full turn (closing where it
/// began), a limited axis from 0 to its farther side, at most 90 deg (the
/// paper's B ran 0 to -90; one side only, so that a bar across the tilt
/// can lie on the side the arbor turns away from).
fn sweep(axis: &RotaryAxis, step: f64) -> Vec<f64> {
    let (lo, hi) = match axis.limits {
        None => (0.0, 360.0),
        Some((lo, hi)) if -lo >= hi => (0.0, lo.max(-90.0)),
        Some((_, hi)) => (0.0, hi.min(90.0)),
    };
    let n = ((hi - lo).abs() / step).round().max(1.0) as usize;
    let step = (hi - lo) / n as f64;
    (0..=n).map(|i| lo + step * i as f64).collect()
}

/// Where the table ball may sit: on the table, on a post at least
/// `min_height` high.
fn on_table(machine: &Machine, n: &Vector3<f64>, min_height: f64) -> bool {
    n.xy().norm() <= machine.table.radius - EDGE_MARGIN
        && n.z >= machine.table.surface + min_height - 1e-9
}

/// The angles of `sweep` at which M can be held: within the strokes,
/// the longest run of consecutive feasible angles. Returns the angles, the
/// commanded axes, and the smallest bar-to-arbor angle for `dir_nm` (the
/// unit vector from M to N).
struct Held {
    angles: Vec<f64>,
    axes: Vec<crate::kinematics::Axes>,
    reason: Option<String>,
}

fn hold(
    machine: &Machine,
    gauge: f64,
    m: &Vector3<f64>,
    axis: char,
    held: f64,
    sweep: &[f64],
) -> Held {
    let kin = setup_kinematics(machine, gauge);
    let mut ok: Vec<Option<crate::kinematics::Axes>> = Vec::new();
    let mut reason = None;
    for &a in sweep {
        let (t, c) = if axis == machine.tilt.letter {
            (a, held)
        } else {
            (held, a)
        };
        let axes = PoseFrame::new(&kin, t, c).commanded(m);
        match kin.check_strokes(&axes) {
            Ok(()) => ok.push(Some(axes)),
            Err(e) => {
                if reason.is_none() {
                    reason = Some(format!("at {axis} = {a}: {e}"));
                }
                ok.push(None);
            }
        }
    }
    // The longest run of consecutive feasible angles.
    let (mut best, mut cur) = ((0, 0), (0, 0));
    for (i, a) in ok.iter().enumerate() {
        if a.is_some() {
            if cur.1 == cur.0 {
                cur = (i, i);
            }
            cur.1 = i + 1;
            if cur.1 - cur.0 > best.1 - best.0 {
                best = cur;
            }
        } else {
            cur = (i + 1, i + 1);
        }
    }
    Held {
        angles: sweep[best.0..best.1].to_vec(),
        axes: ok[best.0..best.1].iter().map(|a| a.unwrap()).collect(),
        reason,
    }
}

/// The smallest angle (deg) between the bar (from M towards N) and the
/// arbor (from M towards the spindle) over the sweep.
fn clearance(
    machine: &Machine,
    gauge: f64,
    setup_axes: &[(f64, f64)],
    m_to_n: &Vector3<f64>,
) -> f64 {
    let kin = setup_kinematics(machine, gauge);
    setup_axes
        .iter()
        .map(|&(t, c)| {
            let arbor = PoseFrame::new(&kin, t, c).probe_axis_w();
            arbor.dot(m_to_n).clamp(-1.0, 1.0).acos().to_degrees()
        })
        .fold(f64::INFINITY, f64::min)
}

/// The designed positions (K, L, H) of M for a table axis: two at the same
/// height and the same L with different K (they separate the rotation
/// about Z), a third with another L and high enough for the longest bar
/// under it (it separates the rotations about X and Y and carries the Z
/// bar) — the pattern of the paper's (200, 152, 57), (310, 152, 57),
/// (310, 210, 452).
fn table_positions(req: &BallBarRequest) -> Vec<Vector3<f64>> {
    let r = req.machine.table.radius;
    let s = req.machine.table.surface;
    let h0 = s + req.min_ball_height;
    // The highest the ball can be held at rotary zero: the top of the Z
    // stroke less the arbor, its approach and 5 mm.
    let top = req.machine.strokes[2].1
        - req.machine.pivot.z
        - req.gauge_mm
        - super::program::APPROACH_MM
        - 5.0;
    // The longest bar that fits under it on a post.
    let under = req
        .bars
        .iter()
        .cloned()
        .filter(|b| h0 + b <= top)
        .fold(0.0, f64::max);
    vec![
        Vector3::new(0.35 * r, 0.25 * r, h0),
        Vector3::new(0.55 * r, 0.25 * r, h0),
        Vector3::new(0.55 * r, 0.35 * r, h0 + under),
    ]
}

/// The designed lengths S for a head axis: the pivot length plus arbors of
/// 100, 175 and 250 mm.
fn head_swings(req: &BallBarRequest) -> Vec<f64> {
    [100.0, 175.0, 250.0]
        .iter()
        .map(|g| req.machine.pivot_length + g)
        .collect()
}

/// Every setup of every rotary axis, with notes on what was adapted or
/// left out.
pub fn choose_setups(req: &BallBarRequest) -> Result<(Vec<Setup>, Vec<String>), BallBarError> {
    let m = &req.machine;
    let mut setups = Vec::new();
    let mut notes = Vec::new();
    let mut bars = req.bars.clone();
    bars.sort_by(f64::total_cmp);
    bars.dedup();
    // The C axis first (as the paper), then the tilt axis.
    for axis in [&m.c, &m.tilt] {
        let other = if axis.letter == 'C' { &m.tilt } else { &m.c };
        let held = if axis.on_table || axis.letter != 'C' {
            0.0
        } else {
            match head_angle_held(other) {
                Some(a) => a,
                None => {
                    notes.push(format!(
                        "{}: not planned: the C head needs the {} axis held at 30 or 45 deg, outside its limits",
                        axis.letter, other.letter
                    ));
                    continue;
                }
            }
        };
        if !other.within(held, 0.0) {
            notes.push(format!(
                "{}: not planned: {} = {held} is outside its limits",
                axis.letter, other.letter
            ));
            continue;
        }
        let step = if axis.letter == 'C' {
            req.step_c_deg
        } else {
            req.step_tilt_deg
        };
        let angles = sweep(axis, step);
        // (group, M, gauge, S)
        let groups: Vec<(Vector3<f64>, f64, Option<f64>)> = if axis.on_table {
            let balls = if req.balls.is_empty() {
                table_positions(req)
            } else {
                req.balls.clone()
            };
            balls.into_iter().map(|b| (b, req.gauge_mm, None)).collect()
        } else {
            let swings = if req.swings.is_empty() {
                head_swings(req)
            } else {
                req.swings.clone()
            };
            // M above the table centre, high enough for the head to swing
            // and for the shortest bar under it on a post.
            let z = m.table.surface + (req.min_ball_height + bars[0]).max(150.0);
            swings
                .into_iter()
                .map(|s| (Vector3::new(0.0, 0.0, z), s - m.pivot_length, Some(s)))
                .collect()
        };
        let before = setups.len();
        for (gi, (mpos, gauge, swing)) in groups.iter().enumerate() {
            let held_run = hold(m, *gauge, mpos, axis.letter, held, &angles);
            let group_name = match swing {
                Some(s) => format!("S = {s} mm"),
                None => format!("(K, L, H) = ({}, {}, {}) mm", mpos.x, mpos.y, mpos.z),
            };
            if held_run.angles.len() < 3 {
                notes.push(format!(
                    "{}{}: {group_name}: not planned: the spindle ball cannot be held there over the sweep ({})",
                    axis.letter,
                    gi + 1,
                    held_run.reason.unwrap_or_default()
                ));
                continue;
            }
            if held_run.angles.len() < angles.len() {
                notes.push(format!(
                    "{}{}: {group_name}: the sweep is shortened to {} .. {} deg ({})",
                    axis.letter,
                    gi + 1,
                    held_run.angles[0],
                    held_run.angles[held_run.angles.len() - 1],
                    held_run.reason.clone().unwrap_or_default()
                ));
            }
            // The approach onto M and the lift off it, along the arbor at
            // the first and the last angle, must be within the strokes too.
            let kin = setup_kinematics(m, *gauge);
            let ends = [0, held_run.angles.len() - 1].map(|i| {
                let a = held_run.angles[i];
                let (t, c) = if axis.letter == m.tilt.letter {
                    (a, held)
                } else {
                    (held, a)
                };
                let pf = PoseFrame::new(&kin, t, c);
                let above = mpos + pf.probe_axis_w() * super::program::APPROACH_MM;
                kin.check_strokes(&pf.commanded(&above))
                    .map_err(|e| format!("the approach at {} = {a}: {e}", axis.letter))
            });
            if let Some(Err(e)) = ends.iter().find(|r| r.is_err()) {
                notes.push(format!(
                    "{}{}: {group_name}: not planned: {e}",
                    axis.letter,
                    gi + 1
                ));
                continue;
            }
            let poses: Vec<(f64, f64)> = held_run
                .angles
                .iter()
                .map(|&a| {
                    if axis.letter == m.tilt.letter {
                        (a, held)
                    } else {
                        (held, a)
                    }
                })
                .collect();
            for dir_axis in 0..3 {
                // Candidates: each bar, each side; the first that puts N on
                // the table clear of the arbor, preferring the shortest bar
                // across (X, Y) and the longest under M (Z, a short post).
                let mut order: Vec<f64> = bars.clone();
                if dir_axis == 2 {
                    order.reverse();
                }
                let mut found = None;
                let mut why: Vec<String> = Vec::new();
                'search: for &bar in &order {
                    for sign in [1.0, -1.0] {
                        let d = BarDirection {
                            axis: dir_axis,
                            sign,
                        };
                        let n = mpos - d.unit() * bar;
                        if !on_table(m, &n, req.min_ball_height) {
                            let w = format!(
                                "N off the table or under {} mm high on the {} side",
                                req.min_ball_height,
                                if sign > 0.0 { '-' } else { '+' }
                            );
                            if !why.contains(&w) {
                                why.push(w);
                            }
                            continue;
                        }
                        let cl = clearance(m, *gauge, &poses, &(-d.unit()));
                        if cl < MIN_BAR_ARBOR_DEG {
                            let w = format!(
                                "on the {} side the bar comes within {cl:.0} deg of the arbor (at least {MIN_BAR_ARBOR_DEG} deg needed)",
                                if sign > 0.0 { '-' } else { '+' }
                            );
                            if !why.contains(&w) {
                                why.push(w);
                            }
                            continue;
                        }
                        found = Some((bar, d, n, cl));
                        break 'search;
                    }
                }
                let label = ['X', 'Y', 'Z'][dir_axis];
                let Some((bar, d, n, cl)) = found else {
                    notes.push(format!(
                        "{}{}-{label}: {group_name}: no bar along {label} of {} mm: {}",
                        axis.letter,
                        gi + 1,
                        bars.iter()
                            .map(|b| crate::numbers::echo(*b))
                            .collect::<Vec<_>>()
                            .join(", "),
                        why.join("; ")
                    ));
                    continue;
                };
                setups.push(Setup {
                    name: format!("{}{}-{label}", axis.letter, gi + 1),
                    axis: axis.letter,
                    on_table: axis.on_table,
                    group: gi + 1,
                    swing: *swing,
                    m: *mpos,
                    n,
                    bar,
                    direction: d,
                    gauge: *gauge,
                    held,
                    angles: held_run.angles.clone(),
                    axes: held_run.axes.clone(),
                    tool: req.tool_number + if swing.is_some() { gi as u32 } else { 0 },
                    clearance_deg: cl,
                });
            }
        }
        if setups.len() == before {
            return Err(BallBarError::Impossible(format!(
                "no setup of the {} axis can be carried out on {}:\n  {}",
                axis.letter,
                m.name,
                notes.join("\n  ")
            )));
        }
    }
    Ok((setups, notes))
}
