//! `probe-sphere`: a calibration sphere on a stem on the rotary table,
//! touched five times per pose, along the program's axes: in +X, -X, +Y,
//! -Y at the height of the sphere's centre and in -Z from above (Cubas Brizuela & Yeh's (2023)
//! Xc+, Xc-, Yc+, Yc-, Zc-). The touches are defined in program
//! coordinates because that is how a controller probes a sphere wherever
//! the rotary axes have put it; in W their normals change with the pose.
//!
//! Two pose patterns:
//! - Cubas Brizuela & Yeh 2023 (section 2): a C sweep at tilt 0 (C = 0..350 step 10, 36
//!   poses) then a tilt sweep at C = 0 (-90..+30 step 10, 13 poses); the
//!   pose tilt = C = 0 is measured in both, as in the seed's 49 positions
//!   (the second one is named `A0C0.2`);
//! - the LAMDAMAP 2015 paper (section 3.2): 50 poses `S00`..`S49` with the tilt evenly
//!   spread over its range while C advances nine turns. C is stored
//!   modulo 360 (within the C limits), so the table does not really turn
//!   nine times: it is the spread of C angles that matters for a static
//!   measurement.
//!
//! A touch that would hit the stem (the approach from the stem's side when
//! the table is tilted) or leave the strokes is left out of its pose; four
//! touches, one of them off the equator, still determine the sphere.

use nalgebra::Vector3;

use super::template::{SpherePattern, SphereTemplate};
use crate::kinematics::Kinematics;
use crate::kinematics::pose_frame::PoseFrame;
use crate::limits::{MAX_PLAN_POINTS, MAX_PLAN_POSES};
use crate::machine::Machine;
use crate::procedure::bounds::total;
use crate::procedure::probing::collision::{ConvexSolid, Obstacle};
use crate::procedure::probing::columns::design::{probe_shape, table_obstacle};
use crate::procedure::probing::path::{self, PoseSpec, SurfaceCandidate};
use crate::procedure::probing::{ControlLimits, TouchPlan, pose_id};
use crate::procedure::{PlanError, Test};

/// The sphere's centre in W on machine `m`.
pub fn sphere_centre(m: &Machine, t: &SphereTemplate) -> Vector3<f64> {
    Vector3::new(t.position.x, t.position.y, m.table.surface + t.height)
}

/// The sphere and its stem as obstacles.
pub(crate) fn sphere_obstacles(m: &Machine, t: &SphereTemplate) -> [Obstacle; 2] {
    let c = sphere_centre(m, t);
    [
        Obstacle {
            name: "sphere".into(),
            solid: ConvexSolid::Ball {
                centre: c,
                radius: t.diameter / 2.0,
            },
        },
        Obstacle {
            name: "stem".into(),
            solid: ConvexSolid::Cylinder {
                a: Vector3::new(c.x, c.y, m.table.surface),
                b: c,
                radius: t.stem_diameter / 2.0,
            },
        },
    ]
}

/// The (tilt, C) of every pose with its id, in execution order.
pub fn poses(m: &Machine, t: &SphereTemplate) -> Vec<(String, f64, f64)> {
    let letter = m.tilt_letter();
    match &t.pattern {
        SpherePattern::Seed004 {
            c_sweep_tilt,
            c_sweep,
            tilt_sweep_c,
            tilt_sweep,
        } => c_sweep
            .iter()
            .map(|&c| (*c_sweep_tilt, c))
            .chain(tilt_sweep.iter().map(|&a| (a, *tilt_sweep_c)))
            .map(|(a, c)| (pose_id(letter, a, c), a, c))
            .collect(),
        SpherePattern::Grid { tilt, c } => tilt
            .iter()
            .flat_map(|&a| c.iter().map(move |&c| (a, c)))
            .map(|(a, c)| (pose_id(letter, a, c), a, c))
            .collect(),
        SpherePattern::Seed003 { poses, tilt, turns } => {
            let n = *poses;
            let width = (n - 1).to_string().len().max(2);
            (0..n)
                .map(|k| {
                    let s = k as f64 / (n - 1) as f64;
                    let a = tilt.0 + (tilt.1 - tilt.0) * s;
                    let mut c = (turns * 360.0 * s).rem_euclid(360.0);
                    // Round away float noise so that ids and files stay clean.
                    c = (c * 1e6).round() / 1e6;
                    if c >= 360.0 {
                        c -= 360.0;
                    }
                    if let Some((lo, _)) = m.c.limits {
                        while c - 360.0 >= lo && !m.c.within(c, 1e-9) {
                            c -= 360.0;
                        }
                    }
                    (format!("S{k:0width$}"), (a * 1e6).round() / 1e6, c)
                })
                .collect()
        }
    }
}

/// Plans the sphere test on machine `m` for a control that probes in any
/// direction.
pub fn touch_plan(m: &Machine, t: &SphereTemplate) -> Result<TouchPlan, PlanError> {
    touch_plan_with(m, t, &ControlLimits::default())
}

/// Plans the sphere test on machine `m` for a control with `limits`.
pub(crate) fn touch_plan_with(
    m: &Machine,
    t: &SphereTemplate,
    limits: &ControlLimits,
) -> Result<TouchPlan, PlanError> {
    let err = |k: &[&str], msg: String| t.source.error(k, msg);
    // Counted before any pose is made.
    let n_poses = match &t.pattern {
        SpherePattern::Seed004 {
            c_sweep,
            tilt_sweep,
            ..
        } => (c_sweep.len() + tilt_sweep.len()) as f64,
        SpherePattern::Seed003 { poses, .. } => *poses as f64,
        // A product: counted in f64 so that two long lists cannot overflow.
        SpherePattern::Grid { tilt, c } => tilt.len() as f64 * c.len() as f64,
    };
    total(
        &t.source,
        &["pattern"],
        n_poses,
        MAX_PLAN_POSES,
        "poses",
        "make fewer poses",
    )?;
    total(
        &t.source,
        &["pattern"],
        n_poses * t.touches.len() as f64,
        MAX_PLAN_POINTS,
        "touches",
        &format!(
            "{n_poses} poses with {} touches each: make fewer poses",
            t.touches.len()
        ),
    )?;
    let probe = probe_shape(m, &t.probe, err)?;
    let centre = sphere_centre(m, t);
    if centre.xy().norm() + t.stem_diameter / 2.0 > m.table.radius {
        return Err(t
            .source
            .error(
                &["sphere", "position"],
                format!(
                    "the sphere's stem stands {:.1} mm from the C axis, beyond the table of {} (radius {} mm)",
                    centre.xy().norm(),
                    m.name,
                    m.table.radius
                ),
            )
            .into());
    }
    let poses = poses(m, t);
    for (id, a, c) in &poses {
        for (v, axis) in [(*a, &m.tilt), (*c, &m.c)] {
            if !axis.within(v, 1e-9) {
                let key: &[&str] = match (&t.pattern, axis.letter == 'C') {
                    (SpherePattern::Seed004 { .. }, true) => &["seed-004", "c_sweep"],
                    (SpherePattern::Seed004 { .. }, false) => &["seed-004", "tilt_sweep"],
                    (SpherePattern::Seed003 { .. }, _) => &["seed-003", "tilt"],
                    (SpherePattern::Grid { .. }, true) => &["grid", "c"],
                    (SpherePattern::Grid { .. }, false) => &["grid", "tilt"],
                };
                return Err(t
                    .source
                    .error(
                        key,
                        format!(
                            "pose {id}: {} = {v} deg is outside the limits of {} {}",
                            axis.letter,
                            m.name,
                            crate::procedure::probing::limits_text(axis)
                        ),
                    )
                    .into());
            }
        }
    }
    let kin = Kinematics::with_gauge_length(m, m.probe.length);
    let radius = t.diameter / 2.0;
    let mut specs: Vec<PoseSpec> = poses
        .into_iter()
        .map(|(id, tilt, c)| {
            let frame = PoseFrame::new(&kin, tilt, c);
            let centre_prog = frame.to_prog(&centre);
            let candidates = t
                .touches
                .iter()
                .map(|(approach, name)| {
                    let n_prog = -approach;
                    SurfaceCandidate {
                        piece: "sphere".into(),
                        feature: (*name).to_string(),
                        contact_w: frame.to_w(&(centre_prog + n_prog * radius)),
                        normal_w: frame.dir_to_w(&n_prog),
                    }
                })
                .collect();
            PoseSpec {
                id,
                tilt,
                c,
                candidates,
            }
        })
        .collect();
    crate::procedure::probing::uniquify_ids(&mut specs);
    let mut obstacles: Vec<Obstacle> = sphere_obstacles(m, t).into();
    obstacles.push(table_obstacle(m));
    let mut plan = path::build(
        Test::ProbeSphere,
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

/// Poses whose touches do not determine the sphere's centre: fewer than
/// four, or all on one plane.
pub(crate) fn weak_poses(plan: &TouchPlan) -> Vec<String> {
    plan.poses
        .iter()
        .filter_map(|pose| {
            let pts: Vec<Vector3<f64>> = plan.touches[pose.touches.clone()]
                .iter()
                .map(|t| t.contact_w)
                .collect();
            crate::shape_fit::fit_sphere_algebraic(&pts).err().map(|e| {
                format!(
                    "pose {}: its {} touches do not fix the sphere: {e}",
                    pose.id,
                    pts.len()
                )
            })
        })
        .collect()
}
