//! The rotary axis lines of a machine at rotary zero, in machine
//! coordinates, from the kinematic chain with a set of constant errors:
//! what every controller export picks its points from.

use nalgebra::{Matrix3, Vector3};

use crate::geom::d6;
use crate::kinematics::{Kinematics, Perturbation};
use crate::machine::Structure;

/// A line in machine coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxisLine {
    /// A point on it, mm.
    pub point: Vector3<f64>,
    /// Unit direction.
    pub dir: Vector3<f64>,
}

impl AxisLine {
    /// The point of the line nearest `q`.
    pub fn nearest(&self, q: &Vector3<f64>) -> Vector3<f64> {
        self.point + self.dir * (q - self.point).dot(&self.dir)
    }

    /// The point of the line whose machine coordinate `i` (0, 1, 2 for X,
    /// Y, Z) is `value`; the line must not be perpendicular to that axis
    /// (it is used along the axis the line runs nearly parallel to).
    pub fn at(&self, i: usize, value: f64) -> Vector3<f64> {
        self.point + self.dir * ((value - self.point[i]) / self.dir[i])
    }

    /// The feet of the common perpendicular of two lines (on self, on other).
    pub(crate) fn common_perpendicular(
        &self,
        other: &AxisLine,
        near: &Vector3<f64>,
    ) -> (Vector3<f64>, Vector3<f64>) {
        let (d1, d2) = (self.dir, other.dir);
        let r = self.point - other.point;
        let (a, b, c) = (d1.dot(&d1), d1.dot(&d2), d2.dot(&d2));
        let (d, e) = (d1.dot(&r), d2.dot(&r));
        let den = a * c - b * b;
        if den.abs() < 1e-14 {
            // Parallel: any pair; take the one near `near`.
            let p = self.nearest(near);
            return (p, other.nearest(&p));
        }
        let s = (b * e - c * d) / den;
        let t = (a * e - b * d) / den;
        (self.point + d1 * s, other.point + d2 * t)
    }
}

/// The machine's axis geometry at rotary zero, machine coordinates.
#[derive(Clone, Debug, PartialEq)]
pub struct Geometry {
    /// Tilt axis line.
    pub tilt: AxisLine,
    /// C axis line.
    pub c: AxisLine,
    /// Spindle axis (tool axis at rotary zero) through the tool tip of the
    /// W origin position (head machines; table machines: the machine Z axis
    /// through the pivot).
    pub spindle: AxisLine,
    /// The spindle gauge point (the tool reference point: the tool tip
    /// plus the gauge length along the spindle axis), mm.
    pub gauge: Vector3<f64>,
}

fn rigid(p: &Perturbation, l: usize) -> (Matrix3<f64>, Vector3<f64>) {
    let iso = d6(&p.link(l));
    (
        iso.rotation.to_rotation_matrix().into_inner(),
        iso.translation.vector,
    )
}

/// The axis lines of `kin` with the constant errors `p`, at rotary zero.
pub fn geometry(kin: &Kinematics, p: &Perturbation) -> Geometry {
    let m = kin.machine();
    let pivot = m.pivot;
    let z = Vector3::z();
    let e_t = m.tilt.about.unit();
    let (r0, d0) = rigid(p, 0);
    let (r1, d1) = rigid(p, 1);
    let (r2, d2) = rigid(p, 2);
    let lg = kin.gauge_length();
    let lh = m.pivot_length + lg;
    let with_gauge = |tilt: AxisLine, c: AxisLine, spindle: AxisLine| Geometry {
        tilt,
        c,
        spindle,
        gauge: spindle.point + lg * spindle.dir,
    };
    match m.structure {
        Structure::TableTable => with_gauge(
            AxisLine {
                point: pivot + d0,
                dir: r0 * e_t,
            },
            AxisLine {
                point: pivot + d0 + r0 * d1,
                dir: r0 * r1 * z,
            },
            AxisLine {
                point: pivot,
                dir: z,
            },
        ),
        Structure::HeadTable => {
            // Tool side at X, Y, Z = 0 (the tip on the W origin when the
            // head is at zero): Tz(lh) E1 R_T E2 Tz(-lh).
            let head = pivot + lh * z + d1;
            let tip = head + r1 * (d2 + r2 * (-lh * z));
            with_gauge(
                AxisLine {
                    point: head,
                    dir: r1 * e_t,
                },
                AxisLine {
                    point: pivot + d0,
                    dir: r0 * z,
                },
                AxisLine {
                    point: tip,
                    dir: r1 * r2 * z,
                },
            )
        }
        Structure::HeadHead => {
            let c_point = pivot + lh * z + d0;
            let head = c_point + r0 * d1;
            let tip = head + r0 * r1 * (d2 + r2 * (-lh * z));
            with_gauge(
                AxisLine {
                    point: head,
                    dir: r0 * r1 * e_t,
                },
                AxisLine {
                    point: c_point,
                    dir: r0 * z,
                },
                AxisLine {
                    point: tip,
                    dir: r0 * r1 * r2 * z,
                },
            )
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Machine;

    #[test]
    fn nominal_geometry_intersects_at_the_pivot() {
        for name in ["bc-trunnion", "ac-trunnion", "head-table", "head-head"] {
            let m = Machine::builtin(name).unwrap();
            let k = Kinematics::new(&m);
            let g = geometry(&k, &Perturbation::zero());
            let (a, b) = g.tilt.common_perpendicular(&g.c, &m.pivot);
            assert!((a - b).norm() < 1e-9, "{name}: {a} {b}");
        }
    }

    #[test]
    fn the_gauge_point_of_a_head_does_not_depend_on_the_tool() {
        // Where the head's axis lies from the spindle gauge point is a
        // property of the machine: two tools give the same vector, errors
        // included (the slides stand elsewhere, by the difference in
        // length, to put each tool's tip on the W origin).
        let m = Machine::builtin("head-table").unwrap();
        let mut p = Perturbation::zero();
        p.0[6] = 0.012; // head X offset
        p.0[6 + 3] = 40e-6; // head tilt about X
        p.0[12 + 2] = -0.02; // spindle along its own axis
        p.0[12 + 4] = 30e-6; // spindle tilt about Y
        let a = geometry(&Kinematics::with_gauge_length(&m, 60.0), &p);
        let b = geometry(&Kinematics::with_gauge_length(&m, 140.0), &p);
        let from_gauge = |g: &Geometry| g.tilt.nearest(&g.gauge) - g.gauge;
        assert!(
            (from_gauge(&a) - from_gauge(&b)).norm() < 1e-12,
            "{} {}",
            from_gauge(&a),
            from_gauge(&b)
        );
        assert!((a.spindle.dir - b.spindle.dir).norm() < 1e-15);
        assert!(((b.gauge - a.gauge) - Vector3::new(0.0, 0.0, 80.0)).norm() < 1e-9);
    }
}
