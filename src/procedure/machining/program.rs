//! From a design in W to machine moves and a program: the safe height, the
//! approach and retract at every pose, inverse kinematics (or the tilted
//! frame of `--kinematics controller`), stroke and rapid-collision checks,
//! the neutral toolpath, the time estimate and the provenance of every
//! point.

use nalgebra::Vector3;
use rayon::prelude::*;

use super::cutter::{Cutter, ToolPart};
use super::design::{MachiningDesign, PoseDesign};
use super::{
    Face, Generator, MachiningPlan, Pass, PathMove, Piece, PlannedPoint, PlannedPose, Provenance,
};
use crate::formats::manifest::KinematicsMode;
use crate::formats::points::PlanPoint;
use crate::kinematics::{Axes, Kinematics, ToolPose};
use crate::machine::{Machine, Structure, ToolKind};
use crate::mesh::{Cuboid, Mesh};
use crate::post::{ControllerKinematics, Coolant, Op, ProgramInfo, Target};
use crate::procedure::short;
use crate::procedure::{PlanConfig, PlanError};

/// Tolerance of "the tool touches the point", mm.
const TOUCH: f64 = 1e-6;
/// No other pose's tool may pass closer than this above a point, mm.
const SEPARATION: f64 = 0.05;

/// The safe height (program Z) and why it is safe.
fn safe_height(m: &Machine, d: &MachiningDesign) -> (f64, String) {
    let mut corners = corners_of(&d.stock);
    if let Some(f) = &d.fixture {
        corners.extend(corners_of(f));
    }
    match m.structure {
        Structure::TableTable => {
            let rim = m.table.radius.hypot(m.table.surface);
            let r = corners.iter().map(|c| c.norm()).fold(rim, f64::max);
            (
                r + d.clearance.safe,
                format!(
                    "{} mm beyond the {} mm sphere the table, riser and block sweep when the rotary axes turn",
                    short(d.clearance.safe),
                    short((r * 1000.0).round() / 1000.0)
                ),
            )
        }
        _ => {
            let top = corners.iter().map(|c| c.z).fold(m.table.surface, f64::max);
            (
                top + d.clearance.safe,
                format!("{} mm above the block", short(d.clearance.safe)),
            )
        }
    }
}

fn corners_of(b: &Cuboid) -> Vec<Vector3<f64>> {
    (0..8)
        .map(|i| {
            let s = Vector3::new(
                if i & 1 == 0 { -1.0 } else { 1.0 },
                if i & 2 == 0 { -1.0 } else { 1.0 },
                if i & 4 == 0 { -1.0 } else { 1.0 },
            );
            b.center + b.axes * s.component_mul(&b.half)
        })
        .collect()
}

fn box_distance(b: &Cuboid, p: &Vector3<f64>) -> f64 {
    let u = b.local(p);
    Vector3::new(
        (u.x.abs() - b.half.x).max(0.0),
        (u.y.abs() - b.half.y).max(0.0),
        (u.z.abs() - b.half.z).max(0.0),
    )
    .norm()
}

/// Whether the tool moving from tip `a` to tip `b` with axis `u` comes
/// into the box. Exact when the whole move lies beyond the box along the
/// tool axis (the tool extends only that way from its tip); otherwise the
/// tool's surface is sampled (0.5 mm along the move and the axis, 24
/// points around) and must stay 0.05 mm clear.
fn rapid_hits(
    cutter: &Cutter,
    a: &Vector3<f64>,
    b: &Vector3<f64>,
    u: &Vector3<f64>,
    bx: &Cuboid,
) -> bool {
    let beyond = corners_of(bx)
        .iter()
        .map(|c| u.dot(c))
        .fold(f64::NEG_INFINITY, f64::max);
    if u.dot(a) >= beyond && u.dot(b) >= beyond {
        return false;
    }
    let (e1, e2) = crate::geom::tangent_basis(u);
    let n = ((b - a).norm() / 0.5).ceil().max(1.0) as usize;
    let m = (cutter.length / 0.5).ceil().max(1.0) as usize;
    for i in 0..=n {
        let tip = a + (b - a) * (i as f64 / n as f64);
        for j in 0..=m {
            let q = tip + u * (cutter.length * j as f64 / m as f64);
            if box_distance(bx, &q) < cutter.radius + 0.05 {
                // Only now look at the surface around this axis point.
                let hit = (0..24).any(|k| {
                    let ang = k as f64 * std::f64::consts::TAU / 24.0;
                    let p = q + (e1 * ang.cos() + e2 * ang.sin()) * cutter.radius;
                    box_distance(bx, &p) < 0.05
                }) || box_distance(bx, &q) < 0.05;
                if hit {
                    return true;
                }
            }
        }
    }
    false
}

pub(crate) fn assemble(cfg: &PlanConfig, d: MachiningDesign) -> Result<MachiningPlan, PlanError> {
    let m = &cfg.machine;
    let post = &cfg.post;
    let tool = d.tool.clone();
    let k = Kinematics::with_gauge_length(m, tool.length);
    let cutter = Cutter::of(&tool);
    if cfg.kinematics == KinematicsMode::Controller && post.controller == ControllerKinematics::None
    {
        return Err(PlanError::Impossible(format!(
            "--kinematics controller: the {} postprocessor has no tilted-plane or TCP function (`controller: none`; stock LinuxCNC has neither G68.2 nor G43.4), so the program must position the axes itself: use --kinematics post",
            post.name
        )));
    }

    let (safe_z, safe_why) = safe_height(m, &d);
    check_room(m, tool.length, safe_z, &safe_why)?;

    let mut all_corners = corners_of(&d.stock);
    if let Some(f) = &d.fixture {
        all_corners.extend(corners_of(f));
    }
    let mut poses: Vec<PlannedPose> = Vec::new();
    let mut prev_xy: Option<(f64, f64)> = None;
    for (seq, pd) in d.poses.iter().enumerate() {
        let (start, moves) = pose_moves(cfg, &d, &k, pd, &all_corners, safe_z, prev_xy)?;
        let retract = moves.last().expect("moves").axes;
        prev_xy = Some((retract.xyz.x, retract.xyz.y));
        check_pose(m, &d, &k, &cutter, pd, &start, &moves)?;
        poses.push(PlannedPose {
            id: pd.id.clone(),
            seq: seq as u32,
            tilt: pd.tilt,
            c: pd.c,
            start_min: 0.0,
            end_min: 0.0,
            tool_axis: pd.axis,
            frame: pd.frame,
            feature: pd.feature.clone(),
            start,
            moves,
        });
    }

    let ops = toolpath(cfg, &d, safe_z, &poses);
    let run_minutes = estimate_times(m, &mut poses);

    // Provenance of every point, and its place on the piece: each on its
    // own (what `plan`, and every command that reads a plan, waits for),
    // the first failing point's error in the points' order.
    let points = d
        .points
        .par_iter()
        .map(|pt| provenance(&cutter, &k, &d.poses, &poses, pt, &d))
        .collect::<Vec<_>>()
        .into_iter()
        .collect::<Result<Vec<_>, _>>()?;
    let piece = piece(&d);

    let info = program_info(cfg, &d, safe_z, &safe_why, &poses, run_minutes);
    let program = post.render(&info, &ops)?;

    Ok(MachiningPlan {
        test: cfg.test(),
        machine: m.clone(),
        template: cfg.template.clone(),
        post: post.clone(),
        dialect: post.dialect,
        kinematics: cfg.kinematics,
        tool,
        cutter,
        cutting: d.cutting.clone(),
        safe_z,
        poses,
        piece,
        points,
        toolpath: ops,
        info,
        program,
        notes: d.notes,
        run_minutes,
        stock_text: d.stock_text,
        safe_reason: safe_why,
    })
}

/// Refuses a tool longer than the room between the safe height and the
/// spindle's highest position. Where the safe height is above that
/// position there is no room at all, whatever the tool: the message says
/// so instead of quoting a negative clearance.
fn check_room(m: &Machine, length: f64, safe_z: f64, safe_why: &str) -> Result<(), PlanError> {
    let z_top = m.strokes[2].1 - m.pivot.z;
    let room = z_top - safe_z;
    let mm = |v: f64| short((v * 1000.0).round() / 1000.0);
    let top = format!(
        "the spindle's highest position (gauge point at Z{} in program coordinates, machine Z {}) on {}",
        mm(z_top),
        short(m.strokes[2].1),
        m.name
    );
    if room <= 0.0 {
        return Err(PlanError::Impossible(format!(
            "the safe height Z{} ({safe_why}) is {} mm above {top}: no tool fits between them; the Z stroke [{}, {}] is too short for this piece on this table (a longer Z stroke or a smaller piece)",
            mm(safe_z),
            mm(-room),
            short(m.strokes[2].0),
            short(m.strokes[2].1),
        )));
    }
    if length > room {
        return Err(PlanError::Impossible(format!(
            "tool length {} mm is longer than the clearance of {} mm between the safe height Z{} ({safe_why}) and {top} (a shorter tool or a longer Z stroke)",
            short(length),
            mm(room),
            mm(safe_z),
        )));
    }
    Ok(())
}

/// One pose's position after the rotary index and its moves, in W and in
/// axes: down from the safe height to the approach above the stock, each
/// stroke entered and left at feed, back up to the safe height; in the
/// program coordinates of the kinematics mode.
fn pose_moves(
    cfg: &PlanConfig,
    d: &MachiningDesign,
    k: &Kinematics,
    pd: &PoseDesign,
    all_corners: &[Vector3<f64>],
    safe_z: f64,
    prev_xy: Option<(f64, f64)>,
) -> Result<(Axes, Vec<PathMove>), PlanError> {
    let m = &cfg.machine;
    let letter = m.tilt_letter();
    let u = pd.axis;
    let level = all_corners
        .iter()
        .map(|c| u.dot(c))
        .fold(f64::NEG_INFINITY, f64::max)
        + d.clearance.rapid;
    let lift = |p: &Vector3<f64>| p + u * (level - u.dot(p)).max(0.0);
    let mut hint = Axes {
        xyz: Vector3::zeros(),
        tilt: pd.tilt,
        c: pd.c,
    };
    let mut ik = |tip: &Vector3<f64>, what: &str| -> Result<Axes, PlanError> {
        let a = k
            .inverse_nominal(&ToolPose { tip: *tip, axis: u }, Some(&hint))
            .map_err(|source| PlanError::Kinematics {
                context: format!("pose {}: {what}", pd.id),
                source,
            })?;
        if (a.tilt - pd.tilt).abs() > 1e-7 || (a.c - pd.c).abs() > 1e-7 {
            return Err(PlanError::Impossible(format!(
                "pose {}: inverse kinematics reaches the tool axis at {letter} = {:.6}, C = {:.6} instead of the pose's {letter} = {}, C = {}",
                pd.id, a.tilt, a.c, pd.tilt, pd.c
            )));
        }
        let a = Axes {
            tilt: pd.tilt,
            c: pd.c,
            ..a
        };
        hint = a;
        Ok(a)
    };
    let first = pd
        .strokes
        .first()
        .ok_or_else(|| PlanError::Impossible(format!("pose {} has no cut", pd.id)))?;
    let approach = ik(&lift(&first.start), "approach")?;
    let safe_axes = Axes {
        xyz: Vector3::new(approach.xyz.x, approach.xyz.y, safe_z),
        ..approach
    };
    let (sx, sy) = prev_xy.unwrap_or((approach.xyz.x, approach.xyz.y));
    let start = Axes {
        xyz: Vector3::new(sx, sy, safe_z),
        tilt: pd.tilt,
        c: pd.c,
    };
    let mut moves: Vec<PathMove> = Vec::new();
    let mk = |axes: Axes, tip: Vector3<f64>, rapid: bool, feed: f64, pass: Pass| PathMove {
        rapid,
        feed,
        pass,
        axes,
        program: axes.xyz,
        tip,
    };
    let rapid = m.rapid.linear;
    moves.push(mk(
        safe_axes,
        k.forward_nominal(&safe_axes).tip,
        true,
        rapid,
        Pass::Air,
    ));
    moves.push(mk(approach, lift(&first.start), true, rapid, Pass::Air));
    for (j, s) in pd.strokes.iter().enumerate() {
        if j > 0 {
            let p = lift(&s.start);
            moves.push(mk(ik(&p, "move over")?, p, true, rapid, Pass::Air));
        }
        moves.push(mk(
            ik(&s.start, "entry")?,
            s.start,
            false,
            d.cutting.plunge_feed,
            Pass::Entry,
        ));
        for (p, pass) in &s.segs {
            moves.push(mk(ik(p, "cut")?, *p, false, d.cutting.feed, *pass));
        }
        // Out of the cut at feed: the tool may still rub material it
        // just cut around; rapids only start above the stock.
        let last = s.segs.last().map_or(s.start, |x| x.0);
        let p = lift(&last);
        moves.push(mk(
            ik(&p, "exit")?,
            p,
            false,
            d.cutting.plunge_feed,
            Pass::Exit,
        ));
    }
    let last = moves.last().expect("moves").axes;
    let retract = Axes {
        xyz: Vector3::new(last.xyz.x, last.xyz.y, safe_z),
        ..last
    };
    moves.push(mk(
        retract,
        k.forward_nominal(&retract).tip,
        true,
        rapid,
        Pass::Air,
    ));

    // Program coordinates of the mode (the retract is written untilted).
    let n = moves.len();
    if cfg.kinematics == KinematicsMode::Controller {
        for mv in moves.iter_mut().take(n - 1) {
            mv.program = match cfg.post.controller {
                ControllerKinematics::TiltedPlane => pd.frame.transpose() * mv.tip,
                _ => mv.tip,
            };
        }
    }
    Ok((start, moves))
}

/// Refuses a pose whose moves leave an axis stroke (at the gauge point) or
/// whose rapids run into the stock or riser.
fn check_pose(
    m: &Machine,
    d: &MachiningDesign,
    k: &Kinematics,
    cutter: &Cutter,
    pd: &PoseDesign,
    start: &Axes,
    moves: &[PathMove],
) -> Result<(), PlanError> {
    let gauge = |a: &Axes| a.xyz + Vector3::z() * d.tool.length;
    let check_strokes = |pose: &str, what: &str, a: &Axes| -> Result<(), PlanError> {
        m.check_strokes(&gauge(a))
            .map_err(|(axis, value, (lo, hi))| PlanError::Stroke {
                pose: pose.to_string(),
                what: what.to_string(),
                axis,
                value,
                lo,
                hi,
                machine: m.name.clone(),
            })
    };
    check_strokes(&pd.id, "the position after the rotary index", start)?;
    let mut prev_tip = k.forward_nominal(start).tip;
    for (i, mv) in moves.iter().enumerate() {
        check_strokes(&pd.id, &format!("move {}", i + 1), &mv.axes)?;
        if mv.rapid {
            let mut boxes = vec![&d.stock];
            boxes.extend(d.fixture.as_ref());
            for bx in boxes {
                if rapid_hits(cutter, &prev_tip, &mv.tip, &pd.axis, bx) {
                    return Err(PlanError::Impossible(format!(
                        "pose {}: rapid move {} from ({:.3}, {:.3}, {:.3}) to ({:.3}, {:.3}, {:.3}) in W would run the tool into the stock or riser",
                        pd.id,
                        i + 1,
                        prev_tip.x,
                        prev_tip.y,
                        prev_tip.z,
                        mv.tip.x,
                        mv.tip.y,
                        mv.tip.z
                    )));
                }
            }
        }
        prev_tip = mv.tip;
    }
    Ok(())
}

/// The neutral toolpath the postprocessor renders: tool call, then per
/// pose its section, the rotary index, the tilted plane or TCP of the
/// controller mode, its moves and the retract.
fn toolpath(cfg: &PlanConfig, d: &MachiningDesign, safe_z: f64, poses: &[PlannedPose]) -> Vec<Op> {
    let post = &cfg.post;
    let tool = &d.tool;
    let letter = cfg.machine.tilt_letter();
    let mut ops = vec![
        Op::ToolCall {
            number: tool.number,
            name: tool.name.clone(),
            id: tool.id.clone(),
            rpm: Some(d.cutting.spindle),
        },
        Op::SpindleOn {
            rpm: d.cutting.spindle,
        },
    ];
    if d.cutting.coolant != Coolant::Off {
        ops.push(Op::Coolant(d.cutting.coolant));
    }
    ops.push(Op::Retract { z: safe_z });
    for p in poses {
        ops.push(Op::Section(format!(
            "pose {} (seq {}): {letter} = {}, C = {}: {}",
            p.id,
            p.seq,
            short(p.tilt),
            short(p.c),
            p.feature
        )));
        ops.push(Op::Rotary {
            tilt: p.tilt,
            c: p.c,
        });
        let controller = cfg.kinematics == KinematicsMode::Controller;
        if controller {
            ops.push(match post.controller {
                ControllerKinematics::TiltedPlane => Op::TiltedPlane {
                    rotation: p.frame,
                    origin: Vector3::zeros(),
                    tilt: p.tilt,
                    c: p.c,
                },
                _ => Op::TcpOn,
            });
        }
        let n = p.moves.len();
        for mv in &p.moves[..n - 1] {
            let to = Target::xyz(mv.program);
            ops.push(if mv.rapid {
                Op::Rapid(to)
            } else {
                Op::Feed { to, feed: mv.feed }
            });
        }
        if controller {
            ops.push(match post.controller {
                ControllerKinematics::TiltedPlane => Op::TiltedPlaneOff,
                _ => Op::TcpOff,
            });
        }
        ops.push(Op::Retract { z: safe_z });
    }
    ops
}

/// The run time in minutes (tool change, rotary indexes, every move at its
/// feed), with each pose's start and end written into it.
fn estimate_times(m: &Machine, poses: &mut [PlannedPose]) -> f64 {
    let mut minutes = 0.1; // tool change
    let mut at = Axes::default();
    let mut first = true;
    for p in poses {
        p.start_min = minutes;
        let (dt, dc) = ((p.tilt - at.tilt).abs(), (p.c - at.c).abs());
        minutes += dt.max(dc) / m.rapid.rotary;
        let mut cur = if first {
            p.start
        } else {
            Axes {
                tilt: p.tilt,
                c: p.c,
                ..at
            }
        };
        first = false;
        for mv in &p.moves {
            minutes += (mv.axes.xyz - cur.xyz).norm() / mv.feed;
            cur = mv.axes;
        }
        at = cur;
        p.end_min = minutes;
    }
    minutes
}

/// The finished piece: its solid, mesh and faces.
fn piece(d: &MachiningDesign) -> Piece {
    let mesh = Mesh::from_csg(&d.csg, d.groups.clone());
    let faces = d
        .csg
        .polygons
        .iter()
        .filter(|p| p.area() > 1e-10)
        .map(|p| Face {
            tag: p.tag,
            normal: p.plane.n,
            offset: p.plane.w,
            outline: p.vertices.clone(),
        })
        .collect();
    Piece {
        stock: d.stock.clone(),
        fixture: d.fixture.clone(),
        solid: d.solid.clone(),
        faces,
        mesh,
    }
}

/// The program's header: what it is, for which machine, dialect and
/// kinematics mode, the tool, zero point, stock, safe height and run time.
fn program_info(
    cfg: &PlanConfig,
    d: &MachiningDesign,
    safe_z: f64,
    safe_why: &str,
    poses: &[PlannedPose],
    run_minutes: f64,
) -> ProgramInfo {
    let m = &cfg.machine;
    let post = &cfg.post;
    let tool = &d.tool;
    let letter = m.tilt_letter();
    let kin_text = match cfg.kinematics {
        KinematicsMode::Post => format!(
            "kinematics post: X Y Z {letter} C computed by fivecal from the machine file (inverse kinematics); no TCP, no tilted plane"
        ),
        KinematicsMode::Controller => match post.controller {
            ControllerKinematics::TiltedPlane => "kinematics controller: rotary axes indexed, then the control's tilted working plane; X Y Z in the plane frame".to_string(),
            _ => "kinematics controller: rotary axes indexed, then the control's TCP; X Y Z in the work frame".into(),
        },
    };
    let kind = match tool.kind {
        ToolKind::Flat => "flat end mill".to_string(),
        ToolKind::Ball => "ball end mill".to_string(),
        ToolKind::Bull => format!(
            "bull-nose end mill R{}",
            short(tool.corner_radius.unwrap_or(0.0))
        ),
    };
    let ids: Vec<&str> = poses.iter().map(|p| p.id.as_str()).collect();
    let stem = cfg.test().to_string();
    ProgramInfo {
        name: stem.clone(),
        number: d.program_number,
        title: format!("{} {}", cfg.test(), m.name),
        lines: vec![
            format!("fivecal plan: {}", d.title),
            d.description.clone(),
            format!("machine {}: {}", m.name, m.description),
            format!("dialect {}, postprocessor {}", post.dialect, post.name),
            kin_text,
            format!(
                "tool {}: {}, {kind} D{} gauge length {} mm, {} rpm, feed {} mm/min",
                tool.label(),
                tool.name,
                short(tool.diameter),
                short(tool.length),
                short(d.cutting.spindle),
                short(d.cutting.feed)
            ),
            format!(
                "zero point: {} on the W origin at {letter} = C = 0, pivot of the machine file X{} Y{} Z{} (gauge point)",
                post.dialect.work_offset(),
                short(m.pivot.x),
                short(m.pivot.y),
                short(m.pivot.z)
            ),
            format!("stock: {}", d.stock_text),
            format!(
                "safe height Z{}: {}",
                short((safe_z * 1000.0).round() / 1000.0),
                safe_why
            ),
            format!(
                "{} poses {}, estimated run time {} min",
                poses.len(),
                ids.join(" "),
                short(run_minutes.round())
            ),
        ],
        stock_min: d.stock.center - d.stock.half,
        stock_max: d.stock.center + d.stock.half,
        tilt_letter: letter,
    }
}

/// The move parameter where the tool axis passes closest to `p`, or
/// `None` for a move along the axis.
fn closest_axis_t(
    a: &Vector3<f64>,
    b: &Vector3<f64>,
    u: &Vector3<f64>,
    p: &Vector3<f64>,
) -> Option<f64> {
    let perp = |v: Vector3<f64>| v - u * u.dot(&v);
    let (pa, ba) = (perp(p - a), perp(b - a));
    let bb = ba.norm_squared();
    (bb > 1e-18).then(|| (pa.dot(&ba) / bb).clamp(0.0, 1.0))
}

fn provenance(
    cutter: &Cutter,
    k: &Kinematics,
    designs: &[PoseDesign],
    poses: &[PlannedPose],
    pt: &super::design::PointDesign,
    d: &MachiningDesign,
) -> Result<PlannedPoint, PlanError> {
    let bug = |msg: String| PlanError::Impossible(format!("point {}: {msg}", pt.label));
    // Material below, air above.
    let eps = 1e-4;
    if !d.solid.contains(&(pt.p - pt.n * eps)) || d.solid.contains(&(pt.p + pt.n * eps)) {
        return Err(bug(format!(
            "({:.4}, {:.4}, {:.4}) with normal {:?} is not on the piece's surface",
            pt.p.x, pt.p.y, pt.p.z, pt.n
        )));
    }
    let reach = 1.0;
    let mut generators = Vec::new();
    for (pi, pose) in poses.iter().enumerate() {
        let u = pose.tool_axis;
        let mut prev = k.forward_nominal(&pose.start).tip;
        let mut prev_axes = pose.start;
        for (mi, mv) in pose.moves.iter().enumerate() {
            let (a, b) = (prev, mv.tip);
            let (a_axes, b_axes) = (prev_axes, mv.axes);
            prev = mv.tip;
            prev_axes = mv.axes;
            if mv.rapid {
                continue;
            }
            if !cutter.may_reach(&a, &b, &u, &pt.p, reach) {
                continue;
            }
            let (dist, t) = cutter.swept_distance(&a, &b, &u, &pt.p);
            if dist > reach {
                continue;
            }
            if pi != pt.pose && dist < SEPARATION {
                return Err(bug(format!(
                    "move {} of pose {} passes {:.6} mm from it, so the point would not tell pose {} from pose {}",
                    mi + 1,
                    pose.id,
                    dist,
                    designs[pt.pose].id,
                    pose.id
                )));
            }
            // Only compared with TOUCH and SEPARATION below: a thousandth
            // of TOUCH is precision enough.
            let Some(s) =
                cutter.entry_within(&a, &b, &u, &pt.p, &pt.n, -reach, reach, 1e-3 * TOUCH)
            else {
                continue;
            };
            if s < -TOUCH {
                return Err(bug(format!(
                    "move {} of pose {} cuts {:.6} mm below it",
                    mi + 1,
                    pose.id,
                    -s
                )));
            }
            if pi != pt.pose && s < SEPARATION {
                return Err(bug(format!(
                    "move {} of pose {} passes {:.6} mm above it, so the point would not tell pose {} from pose {}",
                    mi + 1,
                    pose.id,
                    s,
                    designs[pt.pose].id,
                    pose.id
                )));
            }
            if pi == pt.pose && s <= TOUCH {
                // Where the tool axis passes closest: on a flat end the
                // touch spans an interval, and its middle is the position
                // that made the point (the rim touches at its ends).
                let t = closest_axis_t(&a, &b, &u, &pt.p)
                    .filter(|&tc| {
                        cutter.signed_distance(&(a + (b - a) * tc), &u, &pt.p).abs() <= TOUCH
                    })
                    .unwrap_or(t);
                let tip = a + (b - a) * t;
                let axes = Axes {
                    xyz: a_axes.xyz + (b_axes.xyz - a_axes.xyz) * t,
                    ..b_axes
                };
                generators.push(Generator {
                    move_index: mi,
                    t,
                    tip,
                    axis: u,
                    axes,
                    pass: mv.pass,
                });
            }
        }
    }
    let Some(last) = generators.last() else {
        return Err(bug(format!(
            "no move of pose {} touches it",
            designs[pt.pose].id
        )));
    };
    // The part that touches the point in most generating positions: a flat
    // end sweeping over a floor also touches it with its rim once, at the
    // edge of its sweep, and that does not make the rim the maker.
    let order = [
        ToolPart::FlatEnd,
        ToolPart::Ball,
        ToolPart::Torus,
        ToolPart::Flank,
        ToolPart::Corner,
    ];
    let counts = order.map(|part| {
        generators
            .iter()
            .filter(|g| cutter.part_at(&g.tip, &g.axis, &pt.p) == part)
            .count()
    });
    let best = (0..order.len()).fold(0, |b, i| if counts[i] > counts[b] { i } else { b });
    let part = order[best];
    let _ = last;
    if part != pt.part {
        return Err(bug(format!(
            "it was meant to be made by the tool's {} but the {} touches it",
            pt.part.name(),
            part.name()
        )));
    }
    let pose = &poses[pt.pose];
    Ok(PlannedPoint {
        point: PlanPoint {
            label: pt.label.clone(),
            pose: pose.id.clone(),
            seq: pose.seq,
            tilt: pose.tilt,
            c: pose.c,
            p: pt.p,
            n: pt.n,
        },
        surface: pt.surface.clone(),
        provenance: Provenance {
            pose: pt.pose,
            part,
            generators,
        },
    })
}
