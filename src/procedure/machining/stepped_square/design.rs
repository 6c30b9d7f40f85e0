//! The stepped-square test of Ibaraki & Ota 2014 (figs 2-4):
//! at every pose a square step is finished by a straight end mill moving
//! the linear axes only.
//!
//! Layout. The block (`stock.size` square, `stock.height` high, on a riser)
//! is cut on its top face by the poses whose tool axis is +Z of W (tilt 0):
//! a stepped pyramid of squares, the reference (tilt = C = 0, first in
//! execution) smallest and highest, each further one `size_increment`
//! wider and `step` lower, so every step keeps its four walls and a floor
//! band next to them. The poses whose tool axis is horizontal (tilt +-90)
//! cut the side face it points at, in the band below the pyramid: a square
//! boss centred on the face, each further pose on the same face wider and
//! deeper, above an uncut lip at the bottom. Each step is cut by concentric
//! rings around its boss from the outside in (climb milling), in layers no
//! deeper than `axial_depth`, then finished at zero allowance and, if asked,
//! finished again (the zero cut). A step's floor band next to its walls lies
//! inside the finishing ring's sweep, so walls (tool flank) and floor (flat
//! end) are both made by the finishing pass of their own pose.

use nalgebra::{Matrix3, Vector3};

use super::template::{SteppedSquareTemplate, TiltSet};
use crate::kinematics::Kinematics;
use crate::limits::{
    MAX_PLAN_MOVES, MAX_PLAN_POINT_MOVES, MAX_PLAN_POINTS, MAX_PLAN_POSES, MIN_PLAN_MM,
};
use crate::machine::{Tool, ToolKind};
use crate::mesh::{Cuboid, Solid};
use crate::procedure::bounds::{echo, total};
use crate::procedure::machining::Pass;
use crate::procedure::machining::cutter::ToolPart;
use crate::procedure::machining::design::{
    MachiningDesign, PointDesign, PoseDesign, Stroke, check_work_area, dir_code, dir_name, groups,
    pose_frame, pose_id, tool_of, within_limits,
};
use crate::procedure::{PlanConfig, PlanError, short};

/// Which face a pose cuts.
#[derive(Clone, Copy, Debug, PartialEq)]
enum FaceKind {
    Top,
    Side(Vector3<f64>),
}

/// One step: a square boss with its floor, in the boss frame (b1, b2, n)
/// with levels measured along n from the plane through the W origin.
#[derive(Clone, Debug)]
struct Step {
    center: Vector3<f64>,
    b1: Vector3<f64>,
    b2: Vector3<f64>,
    n: Vector3<f64>,
    half: f64,
    floor: f64,
    top: f64,
    /// Tool-centre limits along +b1, -b1, +b2, -b2 (beyond them the tool is
    /// clear of all material).
    limit: [f64; 4],
    /// Lowest tool-centre b2 coordinate (side faces: the lip).
    clamp: f64,
    /// Half size of the next step on the same face, if any.
    next_half: Option<f64>,
}

impl Step {
    fn at(&self, x: f64, y: f64, level: f64) -> Vector3<f64> {
        self.center + self.b1 * x + self.b2 * y + self.n * level
    }

    fn rect(&self, s: f64) -> (f64, f64, f64, f64) {
        let x_hi = s.min(self.limit[0]);
        let x_lo = -s.min(self.limit[1]);
        let y_hi = s.min(self.limit[2]);
        let y_lo = (-s.min(self.limit[3])).max(self.clamp);
        (x_lo, x_hi, y_lo, y_hi)
    }
}

/// One pose of the test: its angles, the frame of W it sees and the face it cuts.
struct Pose {
    tilt: f64,
    c: f64,
    frame: Matrix3<f64>,
    face: FaceKind,
}

/// Where the block and its two bands of steps lie, in W (mm).
struct Layout {
    /// Half the block's side.
    l: f64,
    /// Height of the block's bottom and top.
    zb: f64,
    zt: f64,
    /// Steps on the top face.
    n_top: usize,
    /// Most steps on any one side face.
    n_side_max: usize,
    /// Top of the side band, below the top steps.
    z_side_top: f64,
    /// Depth of the deepest side step.
    d_side: f64,
    /// Height of the side bosses' centres.
    zc: f64,
    /// Room kept between neighbouring steps.
    margin: f64,
}

pub(crate) fn design(
    cfg: &PlanConfig,
    t: &SteppedSquareTemplate,
    raise: f64,
) -> Result<MachiningDesign, PlanError> {
    let riser = t.stock.fixture_height + raise;
    let m = &cfg.machine;
    let src = &t.source;
    let tool = tool_of(cfg, &t.tool);
    if tool.kind != ToolKind::Flat {
        return Err(PlanError::Impossible(format!(
            "the stepped-square test needs a straight (flat) end mill; tool T{} `{}` is {:?}",
            tool.number, tool.name, tool.kind
        )));
    }
    check_work_area(cfg, src, t.stock.size, &tool)?;
    let k = Kinematics::with_gauge_length(m, tool.length);
    let letter = m.tilt_letter();
    let r = tool.diameter / 2.0;
    let so = stepover(t, &tool)?;
    let mut notes = Vec::new();

    let order = tilt_order(&k, t, &mut notes)?;
    let poses = poses(&k, t, &order)?;
    let layout = layout(cfg, t, riser, &poses, &tool)?;
    check_fit(t, &poses, &layout, &tool)?;
    let (steps, features) = steps(t, &poses, &layout, r, letter)?;
    let allow = t.cutting.finish_allowance.unwrap_or(0.0);
    let pose_designs = toolpaths(t, &tool, &poses, &steps, features, so, allow, letter)?;
    let points = points(t, &steps, &pose_designs, r);
    let (stock, solid) = piece(t, &layout, &steps);

    let Layout {
        l,
        zb,
        n_top,
        n_side_max: _,
        ..
    } = layout;
    let size = t.stock.size;
    let ids: Vec<String> = pose_designs.iter().map(|p| p.id.clone()).collect();
    let csg = solid.to_csg();
    let groups = groups(&ids);
    let fixture = (riser > 0.0).then(|| {
        Cuboid::aligned(
            Vector3::new(-l, -l, m.table.surface),
            Vector3::new(l, l, zb),
            u32::MAX,
        )
    });
    Ok(MachiningDesign {
        title: "stepped-square machining test (Ibaraki & Ota 2014)".into(),
        description: format!(
            "{} poses; {n_top} steps on the top face, {} on the side faces; {} CMM points",
            poses.len(),
            poses.len() - n_top,
            points.len()
        ),
        program_number: 1001,
        tool,
        cutting: t.cutting.clone(),
        clearance: t.clearance.clone(),
        stock,
        fixture,
        solid,
        csg,
        groups,
        poses: pose_designs,
        points,
        notes,
        stock_text: format!(
            "block {} x {} x {} mm, centred on the W origin in X and Y, on a {} mm riser (bottom at Z{} in W)",
            short(size),
            short(size),
            short(t.stock.height),
            short(riser),
            short(zb)
        ),
    })
}

/// The distance between roughing rings, refused when a control could not resolve it.
fn stepover(t: &SteppedSquareTemplate, tool: &Tool) -> Result<f64, PlanError> {
    let so = t.cutting.stepover * tool.diameter;
    if so.is_nan() || so < MIN_PLAN_MM {
        return Err(t
            .source
            .error(
                &["cutting", "stepover"],
                format!(
                    "cutting.stepover {} of the D{} tool puts the rings {} mm apart, closer than the {MIN_PLAN_MM} mm a control resolves",
                    echo(t.cutting.stepover),
                    short(tool.diameter),
                    echo(so)
                ),
            )
            .into());
    }
    Ok(so)
}

/// The face a pose cuts (with the frame of W it sees), refused when its tool
/// axis is normal to no face of the block.
fn classify(
    k: &Kinematics,
    t: &SteppedSquareTemplate,
    tilt: f64,
    c: f64,
) -> Result<(Matrix3<f64>, FaceKind), PlanError> {
    let letter = k.machine().tilt_letter();
    let f = pose_frame(k, tilt, c);
    let u: Vector3<f64> = f.column(2).into_owned();
    if (u - Vector3::z()).norm() < 1e-9 {
        return Ok((f, FaceKind::Top));
    }
    if u.z.abs() < 1e-9 && dir_code(&u).is_some() {
        return Ok((f, FaceKind::Side(u)));
    }
    Err(t
        .source
        .error(
            &["angles"],
            format!(
                "at {letter} = {tilt}, C = {c} the tool axis in W is {}, normal to no face of the block: steps are cut on the top face (tool along +Z, {letter} = 0) or on a side face (tool along +-X or +-Y); use tilts 0 and +-90 with C at multiples of 90 there",
                dir_name(&u)
            ),
        )
        .into())
}

/// The tilt angles in execution order: the top tilt first, then the others
/// in the listed order (the default set leaves out, with a note, a tilt
/// beyond the machine's limits).
fn tilt_order(
    k: &Kinematics,
    t: &SteppedSquareTemplate,
    notes: &mut Vec<String>,
) -> Result<Vec<f64>, PlanError> {
    let m = k.machine();
    let src = &t.source;
    let letter = m.tilt_letter();
    let tilts: Vec<f64> = match &t.angles.tilt {
        TiltSet::Auto => {
            let mut v = Vec::new();
            for a in [0.0, 90.0, -90.0] {
                match within_limits(m, letter, a) {
                    Ok(()) => v.push(a),
                    Err(e) => notes.push(format!(
                        "{letter} = {a} is left out of the default angle set: {e}; the side faces get one step each from the other tilt"
                    )),
                }
            }
            v
        }
        TiltSet::List(l) => {
            for &a in l {
                within_limits(m, letter, a).map_err(|e| src.error(&["angles", "tilt"], e))?;
            }
            l.clone()
        }
    };
    for &c in &t.angles.c {
        within_limits(m, 'C', c).map_err(|e| src.error(&["angles", "c"], e))?;
    }
    let mut order: Vec<f64> = tilts
        .iter()
        .copied()
        .filter(|&a| classify(k, t, a, t.angles.c[0]).is_ok_and(|(_, f)| f == FaceKind::Top))
        .collect();
    if order.is_empty() {
        return Err(src
            .error(
                &["angles", "tilt"],
                format!(
                    "the stepped-square test needs the reference step on top: include {letter} = 0 in the tilt angles"
                ),
            )
            .into());
    }
    let rest: Vec<f64> = tilts
        .iter()
        .copied()
        .filter(|a| !order.contains(a))
        .collect();
    order.extend(rest);
    Ok(order)
}

/// CMM points asked for at each pose (in floats: a template built in code
/// may ask for usize::MAX points).
fn points_per_pose(t: &SteppedSquareTemplate) -> f64 {
    4.0 * (t.points.per_wall as f64 + t.points.per_floor_side as f64)
}

/// Every pose (each tilt with each C), counted against the limits before
/// any is made: the checks after compare poses pairwise, and every pose
/// gets its points.
fn poses(k: &Kinematics, t: &SteppedSquareTemplate, order: &[f64]) -> Result<Vec<Pose>, PlanError> {
    let src = &t.source;
    let n_poses = order.len() * t.angles.c.len();
    total(
        src,
        &["angles"],
        n_poses as f64,
        MAX_PLAN_POSES,
        "poses",
        "list fewer angles",
    )?;
    let per_pose = points_per_pose(t);
    total(
        src,
        &["points"],
        n_poses as f64 * per_pose,
        MAX_PLAN_POINTS,
        "points",
        &format!(
            "{n_poses} poses with {} points each (points.per_wall and points.per_floor_side on each of 4 walls): ask for fewer",
            echo(per_pose)
        ),
    )?;
    let mut poses = Vec::new();
    for &tilt in order {
        for &c in &t.angles.c {
            let (frame, face) = classify(k, t, tilt, c)?;
            poses.push(Pose {
                tilt,
                c,
                frame,
                face,
            });
        }
    }
    Ok(poses)
}

/// The poses that cut the side face with outward normal `n`.
fn side_count(poses: &[Pose], n: &Vector3<f64>) -> usize {
    poses
        .iter()
        .filter(|p| matches!(p.face, FaceKind::Side(v) if (v - n).norm() < 1e-9))
        .count()
}

/// Half the size of the `i`-th top step.
fn top_half(t: &SteppedSquareTemplate, i: usize) -> f64 {
    t.top.first_size / 2.0 + i as f64 * t.top.size_increment / 2.0
}

/// Half the size of the `i`-th step on a side face.
fn side_half(t: &SteppedSquareTemplate, i: usize) -> f64 {
    t.side.first_size / 2.0 + i as f64 * t.side.size_increment / 2.0
}

/// The block's layout: the pyramid of top steps above the band of side
/// steps, refused when the floor bands, the tool or the block are too
/// small for it.
fn layout(
    cfg: &PlanConfig,
    t: &SteppedSquareTemplate,
    riser: f64,
    poses: &[Pose],
    tool: &Tool,
) -> Result<Layout, PlanError> {
    let m = &cfg.machine;
    let src = &t.source;
    let r = tool.diameter / 2.0;
    let size = t.stock.size;
    let l = size / 2.0;
    let zb = m.table.surface + riser;
    let zt = zb + t.stock.height;
    let n_top = poses.iter().filter(|p| p.face == FaceKind::Top).count();
    let n_side_max = poses
        .iter()
        .filter_map(|p| match p.face {
            FaceKind::Side(v) => Some(side_count(poses, &v)),
            FaceKind::Top => None,
        })
        .max()
        .unwrap_or(0);
    let z_side_top = zt - n_top as f64 * t.top.step;
    let d_side = n_side_max as f64 * t.side.step;

    let band_limit = 2.0 * r - 0.5;
    for (face, steps) in [("top", &t.top), ("side", &t.side)] {
        if steps.size_increment / 2.0 > band_limit {
            return Err(src
                .error(
                    &[face, "size_increment"],
                    format!(
                        "{face}.size_increment {} mm leaves a floor band of {} mm next to each wall, wider than the finishing pass of the D{} tool covers ({band_limit} mm): at most {} mm",
                        steps.size_increment,
                        steps.size_increment / 2.0,
                        tool.diameter,
                        2.0 * band_limit
                    ),
                )
                .into());
        }
    }
    let top_depth = n_top as f64 * t.top.step;
    if top_depth + t.clearance.rapid >= tool.length {
        return Err(PlanError::Impossible(format!(
            "tool length {} mm is too short for the {n_top} top steps, {top_depth} mm deep below the stock top (needs more than {} mm)",
            tool.length,
            top_depth + t.clearance.rapid
        )));
    }
    let margin = 1.0;
    let allow = t.cutting.finish_allowance.unwrap_or(0.0);
    let (zone_needed, zc) = if n_side_max > 0 {
        // Below the widest side boss the roughing rings need their full
        // band above the lip; above it the floor band and a margin.
        let half_needed = side_half(t, n_side_max - 1) + 2.0 * r + allow + 0.5;
        let needed = t.side.bottom_lip + 2.0 * half_needed + margin;
        let zc = 0.5 * (zb + t.side.bottom_lip + z_side_top);
        (needed, zc)
    } else {
        (1.0, 0.5 * (zb + z_side_top))
    };
    if z_side_top - zb < zone_needed {
        return Err(src
            .error(
                &["stock", "height"],
                format!(
                    "stock.height {} mm is too low: the {n_top} top steps take {top_depth} mm and the side steps need {zone_needed} mm below them (bottom lip, the widest side step and its floor band): at least {} mm",
                    t.stock.height,
                    top_depth + zone_needed
                ),
            )
            .into());
    }
    Ok(Layout {
        l,
        zb,
        zt,
        n_top,
        n_side_max,
        z_side_top,
        d_side,
        zc,
        margin,
    })
}

/// The turn of a top step's boss frame: the pose's machine X, reduced to
/// within an eighth turn (a square is symmetric under quarter turns).
fn top_angle(f: &Matrix3<f64>) -> f64 {
    let e1: Vector3<f64> = f.column(0).into_owned();
    let th = e1.y.atan2(e1.x);
    let q = std::f64::consts::FRAC_PI_2;
    let mut r = th.rem_euclid(q);
    if r > q / 2.0 {
        r -= q;
    }
    if r.abs() < 1e-12 { 0.0 } else { r }
}

/// Refuses steps that do not fit: a top step (turned with its pose) that
/// reaches into the side steps or does not contain the one before, a side
/// step wider than its face leaves room for, or side steps deeper than the
/// tool reaches.
fn check_fit(
    t: &SteppedSquareTemplate,
    poses: &[Pose],
    layout: &Layout,
    tool: &Tool,
) -> Result<(), PlanError> {
    let src = &t.source;
    let r = tool.diameter / 2.0;
    let size = t.stock.size;
    let Layout {
        n_side_max,
        d_side,
        margin,
        ..
    } = *layout;
    let inside = size / 2.0 - d_side - margin;
    let mut prev_top: Option<(f64, f64)> = None;
    for (top_index, p) in poses.iter().filter(|p| p.face == FaceKind::Top).enumerate() {
        let th = top_angle(&p.frame);
        let half = top_half(t, top_index);
        let reach = (half + r + margin) * (th.cos().abs() + th.sin().abs());
        if reach > inside {
            return Err(src
                .error(
                    &["top", "first_size"],
                    format!(
                        "top step {} ({} mm square, C = {}) with its floor band reaches {:.3} mm from the centre, but the block ({size} mm) leaves {inside} mm inside the side steps ({d_side} mm deep): make the top steps smaller or the block larger",
                        top_index + 1,
                        2.0 * half,
                        p.c,
                        reach
                    ),
                )
                .into());
        }
        if let Some((ph, pth)) = prev_top {
            let rel = th - pth;
            let need = ph * (rel.cos().abs() + rel.sin().abs()) + 0.5;
            if need > half {
                return Err(src
                    .error(
                        &["top", "size_increment"],
                        format!(
                            "top step {} at C = {} is turned {:.3} deg against the one before: the {} mm square needs a next step at least {:.3} mm wide, got {} mm",
                            top_index + 1,
                            p.c,
                            rel.to_degrees(),
                            2.0 * ph,
                            2.0 * need,
                            2.0 * half
                        ),
                    )
                    .into());
            }
        }
        prev_top = Some((half, th));
    }
    if n_side_max > 0 {
        let reach = side_half(t, n_side_max - 1) + r + margin;
        let room = size / 2.0 - d_side - margin;
        if reach > room {
            return Err(src
                .error(
                    &["side", "first_size"],
                    format!(
                        "the widest side step ({} mm) with its floor band reaches {reach} mm from the face centre, but the face leaves {room} mm inside the neighbouring faces' steps: make the side steps smaller or the block larger",
                        2.0 * side_half(t, n_side_max - 1)
                    ),
                )
                .into());
        }
        if d_side >= tool.length - t.clearance.rapid {
            return Err(PlanError::Impossible(format!(
                "tool length {} mm is too short for side steps {d_side} mm deep",
                tool.length
            )));
        }
    }
    Ok(())
}

/// The step each pose cuts, in execution order, with the line describing it.
fn steps(
    t: &SteppedSquareTemplate,
    poses: &[Pose],
    layout: &Layout,
    r: f64,
    letter: char,
) -> Result<(Vec<Step>, Vec<String>), PlanError> {
    let Layout {
        l,
        zb,
        zt,
        n_top,
        z_side_top,
        zc,
        ..
    } = *layout;
    let air = t.clearance.rapid.max(1.0);
    let block_corners: Vec<Vector3<f64>> = (0..8)
        .map(|i| {
            Vector3::new(
                if i & 1 == 0 { -l } else { l },
                if i & 2 == 0 { -l } else { l },
                if i & 4 == 0 { zb } else { zt },
            )
        })
        .collect();
    let mut steps: Vec<Step> = Vec::new();
    let mut features = Vec::new();
    let mut top_i = 0;
    let mut side_i: Vec<(Vector3<f64>, usize)> = Vec::new();
    for p in poses {
        match p.face {
            FaceKind::Top => {
                let th = top_angle(&p.frame);
                let (b1, b2) = (
                    Vector3::new(th.cos(), th.sin(), 0.0),
                    Vector3::new(-th.sin(), th.cos(), 0.0),
                );
                let mut limit = [0.0f64; 4];
                for c in &block_corners {
                    let (x, y) = (b1.dot(c), b2.dot(c));
                    limit[0] = limit[0].max(x);
                    limit[1] = limit[1].max(-x);
                    limit[2] = limit[2].max(y);
                    limit[3] = limit[3].max(-y);
                }
                let half = top_half(t, top_i);
                let floor = zt - (top_i + 1) as f64 * t.top.step;
                let top = zt - top_i as f64 * t.top.step;
                let next_half = (top_i + 1 < n_top).then(|| top_half(t, top_i + 1));
                features.push(format!(
                    "top step {} of {n_top}{}: {} x {} mm square, floor at Z{} in W",
                    top_i + 1,
                    if top_i == 0 { " (reference)" } else { "" },
                    short(2.0 * half),
                    short(2.0 * half),
                    short(floor)
                ));
                steps.push(Step {
                    center: Vector3::zeros(),
                    b1,
                    b2,
                    n: Vector3::z(),
                    half,
                    floor,
                    top,
                    limit: limit.map(|e| e + r + air),
                    clamp: f64::NEG_INFINITY,
                    next_half,
                });
                top_i += 1;
            }
            FaceKind::Side(n) => {
                let j = match side_i.iter_mut().find(|(v, _)| (*v - n).norm() < 1e-9) {
                    Some((_, j)) => {
                        *j += 1;
                        *j
                    }
                    None => {
                        side_i.push((n, 0));
                        0
                    }
                };
                let count = side_count(poses, &n);
                let q = Vector3::z();
                let pdir = q.cross(&n);
                let half = side_half(t, j);
                let floor = l - (j + 1) as f64 * t.side.step;
                let top = l - j as f64 * t.side.step;
                let th = {
                    let e1: Vector3<f64> = p.frame.column(0).into_owned();
                    e1.dot(&q).atan2(e1.dot(&pdir))
                };
                let q4 = std::f64::consts::FRAC_PI_2;
                if (th / q4 - (th / q4).round()).abs() > 1e-9 {
                    return Err(PlanError::Impossible(format!(
                        "at {letter} = {}, C = {} the machine's X is not along an edge of the {} face; side steps need it to be",
                        p.tilt,
                        p.c,
                        dir_name(&n)
                    )));
                }
                features.push(format!(
                    "side step {} of {count} on the {} face: {} x {} mm square, {} mm deep",
                    j + 1,
                    dir_name(&n),
                    short(2.0 * half),
                    short(2.0 * half),
                    short(l - floor)
                ));
                steps.push(Step {
                    center: q * zc,
                    b1: pdir,
                    b2: q,
                    n,
                    half,
                    floor,
                    top,
                    limit: [
                        l + r + air,
                        l + r + air,
                        (z_side_top - zc) + r + air,
                        f64::INFINITY,
                    ],
                    clamp: (zb + t.side.bottom_lip + r) - zc,
                    next_half: (j + 1 < count).then(|| side_half(t, j + 1)),
                });
            }
        }
    }
    Ok((steps, features))
}

/// Each pose's toolpath, its moves counted against the limits (alone and
/// times the points traced back through them) before any is made.
#[allow(clippy::too_many_arguments)]
fn toolpaths(
    t: &SteppedSquareTemplate,
    tool: &Tool,
    poses: &[Pose],
    steps: &[Step],
    features: Vec<String>,
    so: f64,
    allow: f64,
    letter: char,
) -> Result<Vec<PoseDesign>, PlanError> {
    let src = &t.source;
    let r = tool.diameter / 2.0;
    let n_poses = poses.len();
    let per_pose = points_per_pose(t);
    let axial = t.cutting.axial_depth.unwrap_or(f64::INFINITY);
    let moves: f64 = steps
        .iter()
        .map(|s| step_moves(s, r, so, allow, axial))
        .sum();
    total(
        src,
        &["cutting"],
        moves,
        MAX_PLAN_MOVES,
        "moves",
        &format!(
            "rings {} mm apart (cutting.stepover {} of the D{} tool) in layers of at most {} mm (cutting.axial_depth): raise them or cut fewer, smaller steps",
            echo(so),
            echo(t.cutting.stepover),
            short(tool.diameter),
            echo(axial)
        ),
    )?;
    total(
        src,
        &["points"],
        moves * n_poses as f64 * per_pose,
        MAX_PLAN_POINT_MOVES,
        "(point, move) pairs to trace",
        &format!(
            "{} points, each traced back through about {} moves: ask for fewer points or fewer moves (a larger cutting.stepover or cutting.axial_depth)",
            n_poses as f64 * per_pose,
            moves.ceil()
        ),
    )?;
    let mut pose_designs = Vec::new();
    for (i, (p, s)) in poses.iter().zip(steps).enumerate() {
        let strokes = step_strokes(s, r, so, allow, axial, t.cutting.zero_cut);
        pose_designs.push(PoseDesign {
            id: pose_id(letter, p.tilt, p.c),
            tilt: p.tilt,
            c: p.c,
            axis: s.n,
            frame: p.frame,
            feature: features[i].clone(),
            strokes,
        });
    }
    Ok(pose_designs)
}

/// The CMM points of every step: spread along each wall at mid height, and
/// on the floor band next to each wall.
fn points(
    t: &SteppedSquareTemplate,
    steps: &[Step],
    pose_designs: &[PoseDesign],
    r: f64,
) -> Vec<PointDesign> {
    let mut points = Vec::new();
    for (i, s) in steps.iter().enumerate() {
        let id = &pose_designs[i].id;
        let dirs = [(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)];
        let mid = 0.5 * (s.floor + s.top);
        let code = |n: &Vector3<f64>, k: usize, floor: bool| match dir_code(n) {
            Some(c) => c.to_string(),
            None if floor => "F".to_string(),
            None => format!("W{}", k + 1),
        };
        let mut counts: std::collections::BTreeMap<String, usize> = Default::default();
        let mut label = |c: String| {
            let e = counts.entry(c.clone()).or_insert(0);
            *e += 1;
            format!("{id}-{c}{}", *e)
        };
        for (k, &(dx, dy)) in dirs.iter().enumerate() {
            let nrm = s.b1 * dx + s.b2 * dy;
            let mw = t.points.per_wall;
            for q in 0..mw {
                let along = -s.half + (2 * q + 1) as f64 * s.half / mw as f64;
                let (x, y) = (dx * s.half - dy * along, dy * s.half + dx * along);
                points.push(PointDesign {
                    label: label(code(&nrm, k, false)),
                    pose: i,
                    p: s.at(x, y, mid),
                    n: nrm,
                    surface: format!("wall {}", dir_name(&nrm)),
                    part: ToolPart::Flank,
                });
            }
        }
        let delta = match s.next_half {
            Some(h) => 0.5 * (h - s.half),
            None => r,
        };
        for (k, &(dx, dy)) in dirs.iter().enumerate() {
            let mf = t.points.per_floor_side;
            for q in 0..mf {
                let along = -s.half + (2 * q + 1) as f64 * s.half / mf as f64;
                let off = s.half + delta;
                let (x, y) = (dx * off - dy * along, dy * off + dx * along);
                points.push(PointDesign {
                    label: label(code(&s.n, k, true)),
                    pose: i,
                    p: s.at(x, y, s.floor),
                    n: s.n,
                    surface: "floor".into(),
                    part: ToolPart::FlatEnd,
                });
            }
        }
    }
    points
}

/// The stock block and the finished piece: the block minus every pose's cut
/// (a slab down to the step's floor, less its boss).
fn piece(t: &SteppedSquareTemplate, layout: &Layout, steps: &[Step]) -> (Cuboid, Solid) {
    let Layout { l, zb, zt, .. } = *layout;
    let size = t.stock.size;
    let stock = Cuboid::aligned(Vector3::new(-l, -l, zb), Vector3::new(l, l, zt), 0);
    let big = size + 20.0;
    let mut cuts = Vec::new();
    for (i, s) in steps.iter().enumerate() {
        let tag = i as u32 + 1;
        let axes = Matrix3::from_columns(&[s.b1, s.b2, s.n]);
        let (cut_box, boss) = if s.n == Vector3::z() {
            let (lo, hi) = (s.floor, zt + 10.0);
            (
                Cuboid {
                    center: s.center + s.n * (0.5 * (lo + hi)),
                    axes,
                    half: Vector3::new(big, big, 0.5 * (hi - lo)),
                    tag,
                },
                Cuboid {
                    center: s.center + s.n * (0.5 * (lo + hi)),
                    axes,
                    half: Vector3::new(s.half, s.half, 0.5 * (hi - lo) + 5.0),
                    tag,
                },
            )
        } else {
            let (nlo, nhi) = (s.floor, l + 10.0);
            let (qlo, qhi) = (zb + t.side.bottom_lip, zt + 10.0);
            (
                Cuboid {
                    center: s.b2 * (0.5 * (qlo + qhi)) + s.n * (0.5 * (nlo + nhi)),
                    axes,
                    half: Vector3::new(big, 0.5 * (qhi - qlo), 0.5 * (nhi - nlo)),
                    tag,
                },
                Cuboid {
                    center: s.center + s.n * (0.5 * (nlo + nhi)),
                    axes,
                    half: Vector3::new(s.half, s.half, 0.5 * (nhi - nlo) + 5.0),
                    tag,
                },
            )
        };
        cuts.push(Solid::Difference(
            Box::new(Solid::Cuboid(cut_box)),
            vec![Solid::Cuboid(boss)],
        ));
    }
    let solid = Solid::Difference(Box::new(Solid::Cuboid(stock.clone())), cuts);
    (stock, solid)
}

/// The rings of one step: the finishing ring, the first (innermost)
/// roughing ring and the outermost tool-centre offset to cover.
fn ring_span(s: &Step, r: f64, so: f64, allow: f64) -> (f64, f64, f64) {
    let s_fin = s.half + r;
    let first = if allow > 0.0 {
        s_fin + allow
    } else {
        s_fin + so
    };
    let s_max = s
        .limit
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max);
    (s_fin, first, s_max)
}

/// Roughing layers of a step no deeper than `axial`.
fn layer_count(s: &Step, axial: f64) -> f64 {
    ((s.top - s.floor) / axial - 1e-9).ceil().max(1.0)
}

/// The moves [`step_strokes`] makes for one step, counted without making
/// them: per layer the roughing rings (a step-in and four sides each),
/// on the last the finishing ring and the zero cut.
fn step_moves(s: &Step, r: f64, so: f64, allow: f64, axial: f64) -> f64 {
    let (_, first, s_max) = ring_span(s, r, so, allow);
    let rings = ((s_max - first) / so).ceil().max(0.0) + 1.0;
    layer_count(s, axial) * (rings + 2.0) * 5.0
}

/// The strokes of one step: per layer, rings from the outside in; on the
/// last layer the finishing ring and the zero cut.
fn step_strokes(s: &Step, r: f64, so: f64, allow: f64, axial: f64, zero_cut: bool) -> Vec<Stroke> {
    let (s_fin, first, s_max) = ring_span(s, r, so, allow);
    let mut rings = vec![first];
    while *rings.last().unwrap() < s_max {
        let next = rings.last().unwrap() + so;
        rings.push(next);
    }
    rings.reverse();
    let depth = s.top - s.floor;
    let layers = layer_count(s, axial) as usize;
    let mut strokes = Vec::new();
    for li in 0..layers {
        let level = s.top - depth * (li + 1) as f64 / layers as f64;
        let last_layer = li + 1 == layers;
        let mut ring_list: Vec<(f64, Pass)> = rings.iter().map(|&x| (x, Pass::Rough)).collect();
        if last_layer {
            ring_list.push((s_fin, Pass::Finish));
            if zero_cut {
                ring_list.push((s_fin, Pass::ZeroCut));
            }
        }
        let (x_lo, x_hi, y_lo, y_hi) = s.rect(ring_list[0].0);
        let start = s.at(x_hi, y_hi, level);
        let mut segs: Vec<(Vector3<f64>, Pass)> = Vec::new();
        let mut cur = start;
        for (k, &(sv, pass)) in ring_list.iter().enumerate() {
            let (x_lo2, x_hi2, y_lo2, y_hi2) = if k == 0 {
                (x_lo, x_hi, y_lo, y_hi)
            } else {
                s.rect(sv)
            };
            let corners = [
                s.at(x_hi2, y_lo2, level),
                s.at(x_lo2, y_lo2, level),
                s.at(x_lo2, y_hi2, level),
                s.at(x_hi2, y_hi2, level),
            ];
            // Step in to this ring's first corner (nothing to do when the
            // ring starts where the previous one ended, as the zero cut does).
            let first = s.at(x_hi2, y_hi2, level);
            if (first - cur).norm() > 1e-9 {
                segs.push((first, pass));
            }
            for p in corners {
                segs.push((p, pass));
            }
            cur = first;
        }
        strokes.push(Stroke { start, segs });
    }
    strokes
}
