//! The machine at one rotary pose as the program sees it: where a point of
//! W is in program coordinates, which commanded X, Y, Z put the probe-ball
//! centre on a given point, and which way the probe points.
//!
//! Program coordinates are the frame of the commanded X, Y, Z with the work
//! offset on the W origin at rotary zero (docs/model.md). A point `q` of W
//! is at `rTw*(t, c) q` in them (for a head machine `rTw*` holds the table
//! rotation only, or nothing). The probe-ball centre is the commanded X, Y,
//! Z plus the head's offset at the pose, which is zero on a table-table
//! machine and, on a head machine without TCP, the swing of the tool tip
//! about the head's pivot (the kinematic chain is affine in X, Y, Z, so this
//! offset does not depend on where the axes are). Kinematics must be built
//! with the probe's gauge length ([`Kinematics::with_gauge_length`]).
//!
//! `pose_frame()` is the same pose's nominal tool frame in W: the program
//! frame of a tilted working plane, which the machining designs write and
//! the NC interpreter reads back.

use nalgebra::{Isometry3, Matrix3, Point3, Vector3};

use crate::geom::{self, Axis3};
use crate::kinematics::{Axes, Kinematics};

/// One rotary pose of a machine, for probing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoseFrame {
    /// Tilt angle, deg.
    pub tilt: f64,
    /// C angle, deg.
    pub c: f64,
    w_to_prog: Isometry3<f64>,
    head_offset: Vector3<f64>,
    probe_axis_prog: Vector3<f64>,
}

impl PoseFrame {
    /// The pose `(tilt, c)` (deg) of the machine of `kin`.
    pub fn new(kin: &Kinematics, tilt: f64, c: f64) -> PoseFrame {
        let w_to_prog = kin.nominal_table_transform(tilt, c);
        let at_zero = kin.forward_nominal(&Axes::new(0.0, 0.0, 0.0, tilt, c));
        PoseFrame {
            tilt,
            c,
            w_to_prog,
            head_offset: (w_to_prog * Point3::from(at_zero.tip)).coords,
            probe_axis_prog: (w_to_prog.rotation * at_zero.axis).normalize(),
        }
    }

    /// A point of W in program coordinates.
    pub fn to_prog(&self, p_w: &Vector3<f64>) -> Vector3<f64> {
        (self.w_to_prog * Point3::from(*p_w)).coords
    }

    /// A point in program coordinates, in W.
    pub fn to_w(&self, p_prog: &Vector3<f64>) -> Vector3<f64> {
        (self.w_to_prog.inverse() * Point3::from(*p_prog)).coords
    }

    /// A direction of W in program coordinates.
    pub(crate) fn dir_to_prog(&self, d_w: &Vector3<f64>) -> Vector3<f64> {
        self.w_to_prog.rotation * d_w
    }

    /// A direction in program coordinates, in W.
    pub(crate) fn dir_to_w(&self, d_prog: &Vector3<f64>) -> Vector3<f64> {
        self.w_to_prog.rotation.inverse() * d_prog
    }

    /// The commanded axes that put the ball centre on `ball_w` (in W).
    pub fn commanded(&self, ball_w: &Vector3<f64>) -> Axes {
        Axes {
            xyz: self.to_prog(ball_w) - self.head_offset,
            tilt: self.tilt,
            c: self.c,
        }
    }

    /// The ball centre in program coordinates for commanded X, Y, Z (what
    /// a controller reports as the skip or probe position).
    pub fn ball_prog(&self, xyz: &Vector3<f64>) -> Vector3<f64> {
        xyz + self.head_offset
    }

    /// The ball centre in W for commanded X, Y, Z.
    pub fn ball_w(&self, xyz: &Vector3<f64>) -> Vector3<f64> {
        self.to_w(&self.ball_prog(xyz))
    }

    /// The probe's axis (from the ball towards the spindle) in program
    /// coordinates.
    pub(crate) fn probe_axis_prog(&self) -> Vector3<f64> {
        self.probe_axis_prog
    }

    /// The probe's axis in W.
    pub fn probe_axis_w(&self) -> Vector3<f64> {
        self.dir_to_w(&self.probe_axis_prog)
    }

    /// The rigid map from W to program coordinates (`rTw*`).
    pub(crate) fn w_to_prog(&self) -> Isometry3<f64> {
        self.w_to_prog
    }

    /// Ball centre in program coordinates minus commanded X, Y, Z: zero on
    /// a table-table machine.
    pub(crate) fn head_offset(&self) -> Vector3<f64> {
        self.head_offset
    }
}

/// The nominal tool frame in W at (tilt, c): columns are the machine's
/// X, Y and the tool axis as seen from the table. It is the program frame
/// of a tilted working plane at that pose.
pub(crate) fn pose_frame(k: &Kinematics, tilt: f64, c: f64) -> Matrix3<f64> {
    let m = k.machine();
    let table = k
        .nominal_table_transform(tilt, c)
        .rotation
        .to_rotation_matrix()
        .into_inner();
    let mut head = Matrix3::identity();
    if !m.c.on_table {
        head *= geom::rot(Axis3::Z, m.c.direction * geom::rad(c))
            .rotation
            .to_rotation_matrix()
            .into_inner();
    }
    if !m.tilt.on_table {
        head *= geom::rot(m.tilt.about, m.tilt.direction * geom::rad(tilt))
            .rotation
            .to_rotation_matrix()
            .into_inner();
    }
    clean(table.transpose() * head)
}

/// Rounds entries within 1e-12 of -1, 0, 1 so that right-angle poses
/// are exactly axis-aligned.
fn clean(mut m: Matrix3<f64>) -> Matrix3<f64> {
    for v in m.iter_mut() {
        for t in [-1.0, 0.0, 1.0] {
            if (*v - t).abs() < 1e-12 {
                *v = t;
            }
        }
    }
    m
}
