//! `probe-columns` (Ibaraki, Iritani & Matsushita 2013, section 3 and fig. 2): square columns on the
//! rotary table, probed on their top and side faces at every pose of a
//! tilt x C grid. The reference pose (the first, normally tilt = C = 0)
//! probes every reference point; the other poses re-probe the same points
//! wherever the probe reaches them, so that each point's displacement from
//! its reference measurement shows the table's pose error (Ibaraki, Iritani & Matsushita 2013, eq.
//! 7-8). With the default template that is 3 columns x 5 points = 15 at the
//! reference pose, as in the seed, and fewer where faces turn away from the
//! spindle or hide behind another column.

use nalgebra::{Matrix3, Rotation3, Vector3};

use super::template::{ColumnSpec, ColumnsTemplate, Side};
use crate::kinematics::Kinematics;
use crate::limits::{MAX_PLAN_POINTS, MAX_PLAN_POSES};
use crate::machine::Machine;
use crate::procedure::bounds::total;
use crate::procedure::probing::collision::{ConvexSolid, Obstacle, ProbeShape};
use crate::procedure::probing::path::{self, PoseSpec, SurfaceCandidate};
use crate::procedure::probing::template::StylusSpec;
use crate::procedure::probing::{ControlLimits, TouchPlan, pose_id};
use crate::procedure::{PlanError, Test};

/// Thickness of the table modelled below its surface, mm (the machine file
/// gives only its top and radius).
pub(crate) const TABLE_THICKNESS: f64 = 50.0;

/// The table as an obstacle: a disc of the machine's table radius from its
/// surface down by [`TABLE_THICKNESS`].
pub(crate) fn table_obstacle(m: &Machine) -> Obstacle {
    Obstacle {
        name: "table".into(),
        solid: ConvexSolid::Cylinder {
            a: Vector3::new(0.0, 0.0, m.table.surface - TABLE_THICKNESS),
            b: Vector3::new(0.0, 0.0, m.table.surface),
            radius: m.table.radius,
        },
    }
}

/// The probe of the machine file with the template's stylus and body.
pub(crate) fn probe_shape(
    m: &Machine,
    s: &StylusSpec,
    err: impl Fn(&[&str], String) -> crate::source::SourceError,
) -> Result<ProbeShape, PlanError> {
    let r = m.probe.ball_diameter / 2.0;
    if s.stylus_diameter >= m.probe.ball_diameter {
        return Err(err(
            &["probe", "stylus_diameter"],
            format!(
                "probe.stylus_diameter ({} mm) must be smaller than the ball of the machine's probe ({} mm)",
                s.stylus_diameter, m.probe.ball_diameter
            ),
        )
        .into());
    }
    let body_length = match s.body_length {
        Some(l) => l,
        None => {
            let l = m.probe.length - s.stylus_length;
            if l <= 0.0 {
                return Err(err(
                    &["probe", "stylus_length"],
                    format!(
                        "probe.stylus_length ({} mm) must be shorter than the probe's gauge length in the machine file ({} mm)",
                        s.stylus_length, m.probe.length
                    ),
                )
                .into());
            }
            l
        }
    };
    Ok(ProbeShape {
        ball_radius: r,
        stylus_length: s.stylus_length,
        stylus_radius: s.stylus_diameter / 2.0,
        body_length,
        body_radius: s.body_diameter / 2.0,
        spindle_length: s.spindle_length,
        spindle_radius: s.spindle_diameter / 2.0,
    })
}

/// A column as a box in W, standing on the table surface.
pub(crate) fn column_obstacle(m: &Machine, c: &ColumnSpec) -> Obstacle {
    let rot = Rotation3::from_axis_angle(&Vector3::z_axis(), c.yaw.to_radians());
    Obstacle {
        name: c.name.clone(),
        solid: ConvexSolid::Cuboid {
            centre: Vector3::new(c.centre.x, c.centre.y, m.table.surface + c.height / 2.0),
            axes: *rot.matrix(),
            half: Vector3::new(c.size.x / 2.0, c.size.y / 2.0, c.height / 2.0),
        },
    }
}

/// The reference points of every column, in probing order: the top points
/// (`t1`, `t2`, ...) then the sides in the template's order.
fn reference_points(m: &Machine, t: &ColumnsTemplate) -> Vec<SurfaceCandidate> {
    let mut out = Vec::new();
    for c in &t.columns {
        let rot: Matrix3<f64> =
            *Rotation3::from_axis_angle(&Vector3::z_axis(), c.yaw.to_radians()).matrix();
        let top = m.table.surface + c.height;
        let centre = Vector3::new(c.centre.x, c.centre.y, top);
        for (k, off) in t.top.iter().enumerate() {
            out.push(SurfaceCandidate {
                piece: c.name.clone(),
                feature: format!("{}_t{}", c.name, k + 1),
                contact_w: centre + rot * Vector3::new(off.x, off.y, 0.0),
                normal_w: Vector3::z(),
            });
        }
        for side in &t.sides {
            let (n, half) = match side {
                Side::XPlus => (Vector3::x(), c.size.x / 2.0),
                Side::XMinus => (-Vector3::x(), c.size.x / 2.0),
                Side::YPlus => (Vector3::y(), c.size.y / 2.0),
                Side::YMinus => (-Vector3::y(), c.size.y / 2.0),
            };
            let n_w = rot * n;
            out.push(SurfaceCandidate {
                piece: c.name.clone(),
                feature: format!("{}_{}", c.name, side.feature()),
                contact_w: centre + n_w * half - Vector3::z() * t.side_depth,
                normal_w: n_w,
            });
        }
    }
    out
}

/// Plans the column test on machine `m` for a control that probes in any
/// direction.
pub fn touch_plan(m: &Machine, t: &ColumnsTemplate) -> Result<TouchPlan, PlanError> {
    touch_plan_with(m, t, &ControlLimits::default())
}

/// Plans the column test on machine `m` for a control with `limits`
/// (touches it cannot make are left out, with the reason).
pub(crate) fn touch_plan_with(
    m: &Machine,
    t: &ColumnsTemplate,
    limits: &ControlLimits,
) -> Result<TouchPlan, PlanError> {
    let err = |k: &[&str], msg: String| t.source.error(k, msg);
    // Counted before any pose is planned.
    let n_poses = t.tilts.len() as f64 * t.cs.len() as f64;
    let per_pose = t.columns.len() as f64 * (t.top.len() + t.sides.len()) as f64;
    total(
        &t.source,
        &["poses"],
        n_poses,
        MAX_PLAN_POSES,
        "poses",
        "list fewer angles under poses.tilt and poses.c",
    )?;
    total(
        &t.source,
        &["poses"],
        n_poses * per_pose,
        MAX_PLAN_POINTS,
        "touches",
        &format!(
            "{n_poses} poses with up to {per_pose} touches each: list fewer angles, columns or points"
        ),
    )?;
    let probe = probe_shape(m, &t.probe, err)?;
    for (i, c) in t.columns.iter().enumerate() {
        let (sn, cs) = c.yaw.to_radians().sin_cos();
        let reach = [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)]
            .iter()
            .map(|(a, b)| {
                let (x, y) = (a * c.size.x / 2.0, b * c.size.y / 2.0);
                (c.centre.x + cs * x - sn * y).hypot(c.centre.y + sn * x + cs * y)
            })
            .fold(0.0, f64::max);
        if reach > m.table.radius + 1e-9 {
            return Err(t
                .source
                .error(
                    &[&format!("columns[{i}]"), "centre"],
                    format!(
                        "column {} reaches {reach:.1} mm from the C axis, beyond the table of {} (radius {} mm)",
                        c.name, m.name, m.table.radius
                    ),
                )
                .into());
        }
    }
    for (key, values, axis) in [("tilt", &t.tilts, &m.tilt), ("c", &t.cs, &m.c)] {
        if let Some(v) = values.iter().find(|v| !axis.within(**v, 1e-9)) {
            return Err(t
                .source
                .error(
                    &["poses", key],
                    format!(
                        "poses.{key}: {} = {v} deg is outside the limits of {} {}",
                        axis.letter,
                        m.name,
                        crate::procedure::probing::limits_text(axis)
                    ),
                )
                .into());
        }
    }
    let mut obstacles: Vec<Obstacle> = t.columns.iter().map(|c| column_obstacle(m, c)).collect();
    obstacles.push(table_obstacle(m));
    let refs = reference_points(m, t);
    let letter = m.tilt_letter();
    let mut specs = Vec::new();
    for &tilt in &t.tilts {
        for &c in &t.cs {
            specs.push(PoseSpec {
                id: pose_id(letter, tilt, c),
                tilt,
                c,
                candidates: refs.clone(),
            });
        }
    }
    crate::procedure::probing::uniquify_ids(&mut specs);
    let kin = Kinematics::with_gauge_length(m, m.probe.length);
    let mut plan = path::build(
        Test::ProbeColumns,
        kin,
        obstacles,
        probe,
        t.probing,
        specs,
        limits,
    )?;
    plan.warnings = weak_poses(&plan);
    Ok(plan)
}

/// Poses whose touches cannot fix the table's six-degree-of-freedom pose
/// on their own (Ibaraki, Iritani & Matsushita 2013, eq. 7-10): a touch senses a small displacement
/// `(d, theta)` of the table only through `n . (d + theta x p)`, so the
/// rows `[n, p x n]` of a pose's touches must have rank 6. Such a pose
/// still adds to a joint identification of the rotary axes' errors, but
/// not to a per-pose error map.
pub(crate) fn weak_poses(plan: &TouchPlan) -> Vec<String> {
    let mut out = Vec::new();
    for pose in &plan.poses {
        let touches = &plan.touches[pose.touches.clone()];
        let a = nalgebra::DMatrix::from_fn(touches.len().max(1), 6, |i, j| match touches.get(i) {
            None => 0.0,
            Some(t) => {
                let m = t.contact_w.cross(&t.normal_w);
                if j < 3 { t.normal_w[j] } else { m[j - 3] }
            }
        });
        let sv = a.singular_values();
        let top = sv.max();
        let rank = sv.iter().filter(|s| **s > 1e-9 * top.max(1e-300)).count();
        if rank < 6 {
            out.push(format!(
                "pose {}: its {} touches fix only {rank} of the table's 6 pose components",
                pose.id,
                touches.len()
            ));
        }
    }
    out
}
