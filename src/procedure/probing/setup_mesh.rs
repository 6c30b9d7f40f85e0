//! The probing setup as a triangle mesh for `.obj` and `.glb`: the column
//! boxes, the calibration sphere and its stem, and the top slab of the
//! table, one named group per obstacle, in W (mm).
//!
//! Boxes are exact. Round solids are inscribed polyhedra with vertices on
//! the true surface: [`SEGMENTS`] around, so a sphere or cylinder of
//! radius `r` deviates from its facets by at most `r (1 - cos(pi /
//! SEGMENTS))` (0.02 mm on a 15 mm sphere), plenty for a picture of the
//! setup and for checking that a plan's touches lie on it.

use std::collections::BTreeMap;
use std::f64::consts::PI;

use nalgebra::Vector3;

use super::collision::{ConvexSolid, Obstacle};
use crate::mesh::{Mesh, Triangle};

/// Facets around a round solid.
pub const SEGMENTS: usize = 64;

/// The mesh of a setup: one group per obstacle, named after it, tags from
/// 1 in the obstacles' order.
pub(crate) fn setup_mesh(obstacles: &[Obstacle]) -> Mesh {
    let mut triangles = Vec::new();
    let mut groups = BTreeMap::new();
    for (i, o) in obstacles.iter().enumerate() {
        let tag = i as u32 + 1;
        groups.insert(tag, o.name.clone());
        let mut push = |a: Vector3<f64>, b: Vector3<f64>, c: Vector3<f64>| {
            let n = (b - a).cross(&(c - a));
            let len = n.norm();
            if len > 1e-12 {
                triangles.push(Triangle {
                    v: [a, b, c],
                    n: n / len,
                    tag,
                });
            }
        };
        match &o.solid {
            ConvexSolid::Cuboid { centre, axes, half } => {
                let corner = |s: [f64; 3]| {
                    centre + axes * Vector3::new(s[0] * half.x, s[1] * half.y, s[2] * half.z)
                };
                // Each face: its normal axis and sign, corners counter-clockwise
                // seen from outside.
                for axis in 0..3 {
                    let (j, k) = ((axis + 1) % 3, (axis + 2) % 3);
                    for sign in [1.0, -1.0] {
                        let at = |u: f64, v: f64| {
                            let mut s = [0.0; 3];
                            s[axis] = sign;
                            s[j] = u;
                            s[k] = v;
                            corner(s)
                        };
                        let q = if sign > 0.0 {
                            [at(-1.0, -1.0), at(1.0, -1.0), at(1.0, 1.0), at(-1.0, 1.0)]
                        } else {
                            [at(-1.0, -1.0), at(-1.0, 1.0), at(1.0, 1.0), at(1.0, -1.0)]
                        };
                        push(q[0], q[1], q[2]);
                        push(q[0], q[2], q[3]);
                    }
                }
            }
            ConvexSolid::Ball { centre, radius } => {
                let (nu, nv) = (SEGMENTS, SEGMENTS / 2);
                let p = |i: usize, j: usize| {
                    let theta = PI * j as f64 / nv as f64; // from the north pole
                    let phi = 2.0 * PI * i as f64 / nu as f64;
                    centre
                        + Vector3::new(
                            theta.sin() * phi.cos(),
                            theta.sin() * phi.sin(),
                            theta.cos(),
                        ) * *radius
                };
                for j in 0..nv {
                    for i in 0..nu {
                        let (a, b, c, d) = (p(i, j), p(i, j + 1), p(i + 1, j + 1), p(i + 1, j));
                        if j > 0 {
                            push(a, b, d);
                        }
                        if j + 1 < nv {
                            push(b, c, d);
                        }
                    }
                }
            }
            ConvexSolid::Cylinder { a, b, radius } => {
                let ax = (b - a).normalize();
                let (e1, e2) = crate::geom::tangent_basis(&ax);
                let rim = |end: &Vector3<f64>, i: usize| {
                    let phi = 2.0 * PI * i as f64 / SEGMENTS as f64;
                    end + (e1 * phi.cos() + e2 * phi.sin()) * *radius
                };
                for i in 0..SEGMENTS {
                    let (a0, a1, b0, b1) = (rim(a, i), rim(a, i + 1), rim(b, i), rim(b, i + 1));
                    push(a0, a1, b1);
                    push(a0, b1, b0);
                    push(*b, b0, b1);
                    push(*a, a1, a0);
                }
            }
        }
    }
    Mesh { triangles, groups }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn meshes_close_around_the_volume_of_their_solids() {
        let shapes = [
            ConvexSolid::Cuboid {
                centre: Vector3::new(1.0, 2.0, 3.0),
                axes: *nalgebra::Rotation3::from_axis_angle(&Vector3::z_axis(), 0.3).matrix(),
                half: Vector3::new(10.0, 20.0, 30.0),
            },
            ConvexSolid::Ball {
                centre: Vector3::new(5.0, 0.0, 0.0),
                radius: 15.0,
            },
            ConvexSolid::Cylinder {
                a: Vector3::zeros(),
                b: Vector3::new(0.0, 0.0, 100.0),
                radius: 6.0,
            },
        ];
        let exact = [
            8.0 * 10.0 * 20.0 * 30.0,
            4.0 / 3.0 * PI * 15f64.powi(3),
            PI * 36.0 * 100.0,
        ];
        for (s, v) in shapes.iter().zip(exact) {
            let m = setup_mesh(&[Obstacle {
                name: "x".into(),
                solid: s.clone(),
            }]);
            // Positive volume: the facets face outwards; inscribed round
            // solids lose well under 1 % of their volume.
            let got = m.volume();
            assert!(got > 0.0 && got <= v * (1.0 + 1e-9), "{s:?}: {got} vs {v}");
            assert!(got > 0.99 * v, "{s:?}: {got} vs {v}");
        }
    }
}
