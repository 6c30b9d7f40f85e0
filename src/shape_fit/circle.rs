//! Circles in space, as Cubas Brizuela & Yeh 2023, section 3.2 uses them: the centres of a
//! calibration sphere measured at several C (or tilt) positions lie on a
//! circle whose plane is perpendicular to the rotary axis and whose centre
//! lies on it. [`circle_through_three`] is the closed form the seed applies
//! to every combination of three positions (eq. 3.3: a plane from two base
//! vectors, then the circle in it); [`fit_circle`] uses all positions at
//! once: the least-squares plane, then the circle of the projected points,
//! algebraic (Kasa) first and geometric after. [`Circle3::axis_point_at_z`]
//! is eq. 4.1, where the axis crosses a horizontal plane, and
//! [`Circle3::axis_tilt`] eq. 3.4, the angle between the axis and Z.

use nalgebra::{Matrix3, Vector2, Vector3};

use super::plane::{canonical_sign, fit_plane};
use super::{ShapeFitError, check_points, rms_max};
use crate::geom::tangent_basis;

/// A circle in space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Circle3 {
    /// Centre, mm.
    pub centre: Vector3<f64>,
    /// Unit normal of its plane (the direction of the rotary axis), with
    /// the canonical sign of [`super::Plane::normal`].
    pub normal: Vector3<f64>,
    /// Radius, mm.
    pub radius: f64,
}

impl Circle3 {
    /// Where the circle's axis (the line through the centre along the
    /// normal) crosses the plane `Z = z` (Cubas Brizuela & Yeh 2023, eq. 4.1 with `z = 0`);
    /// `None` when the axis is parallel to that plane.
    pub fn axis_point_at_z(&self, z: f64) -> Option<Vector3<f64>> {
        if self.normal.z.abs() < 1e-12 {
            return None;
        }
        Some(self.centre + self.normal * ((z - self.centre.z) / self.normal.z))
    }

    /// Angle between the axis and the Z axis, rad (Cubas Brizuela & Yeh 2023, eq. 3.4).
    pub fn axis_tilt(&self) -> f64 {
        self.normal.z.abs().min(1.0).acos()
    }
}

/// A fitted circle with its residuals.
#[derive(Clone, Debug, PartialEq)]
pub struct CircleFit {
    /// The circle.
    pub circle: Circle3,
    /// In-plane radial residual of each point (distance of its projection
    /// from the centre minus the radius), mm.
    pub radial: Vec<f64>,
    /// Signed distance of each point from the circle's plane, mm.
    pub out_of_plane: Vec<f64>,
    /// Root mean square of the full distances of the points from the
    /// circle, mm.
    pub rms: f64,
    /// Largest distance of a point from the circle, mm.
    pub max_abs: f64,
}

/// The circle through three points (closed form).
pub fn circle_through_three(
    a: &Vector3<f64>,
    b: &Vector3<f64>,
    c: &Vector3<f64>,
) -> Result<Circle3, ShapeFitError> {
    check_points(&[*a, *b, *c], "circle", 3)?;
    let u = b - a;
    let v = c - a;
    let w = u.cross(&v);
    let w2 = w.norm_squared();
    let scale = u.norm_squared().max(v.norm_squared());
    if w2 <= 1e-18 * scale * scale || scale == 0.0 {
        return Err(ShapeFitError::Degenerate {
            shape: "circle",
            why: "the three points lie on one line (or coincide)".into(),
        });
    }
    let centre = a + (v.cross(&w) * u.norm_squared() + w.cross(&u) * v.norm_squared()) / (2.0 * w2);
    Ok(Circle3 {
        centre,
        normal: canonical_sign(w / w2.sqrt()),
        radius: (centre - a).norm(),
    })
}

/// Fits a circle to three or more points not on one line.
pub fn fit_circle(points: &[Vector3<f64>]) -> Result<CircleFit, ShapeFitError> {
    check_points(points, "circle", 3)?;
    let plane = fit_plane(points)
        .map_err(|_| ShapeFitError::Degenerate {
            shape: "circle",
            why: "the points lie on one line (or coincide)".into(),
        })?
        .plane;
    let (e1, e2) = tangent_basis(&plane.normal);
    let uv: Vec<Vector2<f64>> = points
        .iter()
        .map(|p| {
            let d = p - plane.point;
            Vector2::new(d.dot(&e1), d.dot(&e2))
        })
        .collect();
    // Kasa: u^2 + v^2 + D u + E v + F = 0, linear least squares.
    let mut ata = Matrix3::zeros();
    let mut atb = Vector3::zeros();
    for q in &uv {
        let row = Vector3::new(q.x, q.y, 1.0);
        ata += row * row.transpose();
        atb += row * -q.norm_squared();
    }
    let sol = ata
        .cholesky()
        .ok_or_else(|| ShapeFitError::Degenerate {
            shape: "circle",
            why: "the projected points do not determine a circle".into(),
        })?
        .solve(&atb);
    let mut c = Vector2::new(-sol[0] / 2.0, -sol[1] / 2.0);
    let r2 = c.norm_squared() - sol[2];
    if r2 <= 0.0 {
        return Err(ShapeFitError::Degenerate {
            shape: "circle",
            why: "the algebraic fit has no real radius".into(),
        });
    }
    let mut r = r2.sqrt();
    // Geometric refinement (Gauss-Newton with damping) on |q - c| - r.
    let cost = |c: &Vector2<f64>, r: f64| -> f64 {
        uv.iter()
            .map(|q| {
                let e = (q - c).norm() - r;
                e * e
            })
            .sum()
    };
    let mut f = cost(&c, r);
    let mut lambda = 1e-6;
    for _ in 0..200 {
        let mut jtj = Matrix3::zeros();
        let mut jtr = Vector3::zeros();
        for q in &uv {
            let d = q - c;
            let dist = d.norm();
            if dist < 1e-15 {
                continue;
            }
            let row = Vector3::new(-d.x / dist, -d.y / dist, -1.0);
            jtj += row * row.transpose();
            jtr += row * (dist - r);
        }
        let mut improved = false;
        for _ in 0..30 {
            let mut a = jtj;
            for i in 0..3 {
                a[(i, i)] += lambda * (jtj[(i, i)] + 1e-12);
            }
            let Some(ch) = a.cholesky() else {
                lambda *= 10.0;
                continue;
            };
            let step = ch.solve(&-jtr);
            let c_new = c + Vector2::new(step[0], step[1]);
            let r_new = r + step[2];
            let f_new = cost(&c_new, r_new);
            if f_new <= f {
                let small = step.norm() <= 1e-14 * (1.0 + r.abs());
                c = c_new;
                r = r_new;
                f = f_new;
                lambda = (lambda * 0.1).max(1e-15);
                improved = !small;
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    let centre = plane.point + e1 * c.x + e2 * c.y;
    let circle = Circle3 {
        centre,
        normal: plane.normal,
        radius: r,
    };
    let radial: Vec<f64> = uv.iter().map(|q| (q - c).norm() - r).collect();
    let out_of_plane: Vec<f64> = points.iter().map(|p| plane.distance(p)).collect();
    let full: Vec<f64> = radial
        .iter()
        .zip(&out_of_plane)
        .map(|(a, b)| a.hypot(*b))
        .collect();
    let (rms, max_abs) = rms_max(&full);
    Ok(CircleFit {
        circle,
        radial,
        out_of_plane,
        rms,
        max_abs,
    })
}
