//! Sphere fits and the plausibility check of a probed sphere.
//!
//! The closed form is Cubas Brizuela & Yeh's (2023) eq. 3.2: every point on a sphere satisfies
//! `x^2 + y^2 + z^2 + A x + B y + C z + D = 0`, which is linear in
//! `(A, B, C, D)`; the centre is `-(A, B, C) / 2` and the radius
//! `sqrt(|centre|^2 - D)`. With four points it is the exact circumsphere;
//! with more it is a least-squares fit of the *algebraic* distance, which
//! weights points unevenly when the set covers only part of the sphere (the
//! five touches of a calibration sphere cover its upper half). So it only
//! starts the geometric fit, Gauss-Newton with Levenberg-Marquardt damping
//! on the true distances `|p - c| - r`.
//!
//! [`SphereCheck`] then does what a controller's sphere-radius check does
//! after probing a calibration sphere (HEIDENHAIN KinematicsOpt rejects a
//! measurement whose radius is off by more than 0.02 mm by default): a set
//! of touches whose fitted radius is off the expected one, or whose points
//! do not lie on a sphere, names its pose and is not used.

use std::fmt;

use nalgebra::{Matrix4, Vector3, Vector4};

use super::{ShapeFitError, centroid, check_points, rms_max};

/// A sphere.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    /// Centre, mm.
    pub centre: Vector3<f64>,
    /// Radius, mm.
    pub radius: f64,
}

/// A fitted sphere with its residuals.
#[derive(Clone, Debug, PartialEq)]
pub struct SphereFit {
    /// The sphere.
    pub sphere: Sphere,
    /// Signed distance of each point from the sphere (`|p - c| - r`), mm.
    pub residuals: Vec<f64>,
    /// Root mean square of the residuals, mm.
    pub rms: f64,
    /// Largest residual magnitude, mm.
    pub max_abs: f64,
}

/// The algebraic (closed-form, Cubas Brizuela & Yeh 2023, eq. 3.2) sphere through four or
/// more points that are not all in one plane.
pub fn fit_sphere_algebraic(points: &[Vector3<f64>]) -> Result<Sphere, ShapeFitError> {
    check_points(points, "sphere", 4)?;
    // Work relative to the centroid and in units of the spread, so that the
    // columns of the linear system are of comparable size.
    let m = centroid(points);
    let spread =
        (points.iter().map(|p| (p - m).norm_squared()).sum::<f64>() / points.len() as f64).sqrt();
    if spread < 1e-12 {
        return Err(ShapeFitError::Degenerate {
            shape: "sphere",
            why: "all points coincide".into(),
        });
    }
    let mut ata = Matrix4::zeros();
    let mut atb = Vector4::zeros();
    for p in points {
        let q = (p - m) / spread;
        let row = Vector4::new(q.x, q.y, q.z, 1.0);
        ata += row * row.transpose();
        atb += row * -q.norm_squared();
    }
    let eig = ata.symmetric_eigen();
    let (lo, hi) = eig
        .eigenvalues
        .iter()
        .fold((f64::INFINITY, 0.0_f64), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    if lo <= 1e-12 * hi {
        return Err(ShapeFitError::Degenerate {
            shape: "sphere",
            why: "the points lie in one plane (a sphere needs a point off it, such as the touch from above)"
                .into(),
        });
    }
    let sol = ata
        .cholesky()
        .ok_or_else(|| ShapeFitError::Degenerate {
            shape: "sphere",
            why: "the normal equations are singular".into(),
        })?
        .solve(&atb);
    let c = Vector3::new(-sol[0] / 2.0, -sol[1] / 2.0, -sol[2] / 2.0);
    let r2 = c.norm_squared() - sol[3];
    if r2 <= 0.0 {
        return Err(ShapeFitError::Degenerate {
            shape: "sphere",
            why: "the algebraic fit has no real radius".into(),
        });
    }
    Ok(Sphere {
        centre: m + c * spread,
        radius: r2.sqrt() * spread,
    })
}

/// The geometric least-squares sphere: minimizes the sum of squared
/// distances `|p - c| - r`, starting from [`fit_sphere_algebraic`].
pub fn fit_sphere(points: &[Vector3<f64>]) -> Result<SphereFit, ShapeFitError> {
    let start = fit_sphere_algebraic(points)?;
    let m = centroid(points);
    let q: Vec<Vector3<f64>> = points.iter().map(|p| p - m).collect();
    let mut c = start.centre - m;
    let mut r = start.radius;
    let cost = |c: &Vector3<f64>, r: f64| -> f64 {
        q.iter()
            .map(|p| {
                let e = (p - c).norm() - r;
                e * e
            })
            .sum()
    };
    let mut f = cost(&c, r);
    let mut lambda = 1e-6;
    for _ in 0..200 {
        let mut jtj = Matrix4::zeros();
        let mut jtr = Vector4::zeros();
        for p in &q {
            let d = p - c;
            let dist = d.norm();
            if dist < 1e-15 {
                continue;
            }
            let e = dist - r;
            let row = Vector4::new(-d.x / dist, -d.y / dist, -d.z / dist, -1.0);
            jtj += row * row.transpose();
            jtr += row * e;
        }
        let mut improved = false;
        for _ in 0..30 {
            let mut a = jtj;
            for i in 0..4 {
                a[(i, i)] += lambda * (jtj[(i, i)] + 1e-12);
            }
            let Some(ch) = a.cholesky() else {
                lambda *= 10.0;
                continue;
            };
            let step = ch.solve(&-jtr);
            let c_new = c + Vector3::new(step[0], step[1], step[2]);
            let r_new = r + step[3];
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
    let sphere = Sphere {
        centre: c + m,
        radius: r,
    };
    let residuals: Vec<f64> = points
        .iter()
        .map(|p| (p - sphere.centre).norm() - sphere.radius)
        .collect();
    let (rms, max_abs) = rms_max(&residuals);
    Ok(SphereFit {
        sphere,
        residuals,
        rms,
        max_abs,
    })
}

/// Plausibility limits for a probed sphere.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphereCheck {
    /// The radius the points should lie on, mm: the calibration sphere's
    /// radius plus the stylus ball radius when the points are ball centres
    /// (as logged by the controller), the sphere's radius alone when they
    /// are contact points.
    pub expected_radius: f64,
    /// Largest accepted difference between fitted and expected radius, mm
    /// (HEIDENHAIN's default: 0.02 mm).
    pub radius_tolerance: f64,
    /// Largest accepted distance of a point from the fitted sphere, mm.
    pub form_tolerance: f64,
}

impl SphereCheck {
    /// A check against `expected_radius` with the 0.02 mm limits of a
    /// controller's default sphere check.
    pub fn new(expected_radius: f64) -> SphereCheck {
        SphereCheck {
            expected_radius,
            radius_tolerance: 0.02,
            form_tolerance: 0.02,
        }
    }

    /// Fits the touches of one pose and accepts or rejects them.
    pub fn check(
        &self,
        pose: &str,
        points: &[Vector3<f64>],
    ) -> Result<SphereFit, ImplausibleSphere> {
        let fit = fit_sphere(points).map_err(|e| ImplausibleSphere {
            pose: pose.to_string(),
            fit: None,
            expected_radius: self.expected_radius,
            reason: e.to_string(),
        })?;
        let off = fit.sphere.radius - self.expected_radius;
        let mut why = Vec::new();
        if off.abs() > self.radius_tolerance {
            why.push(format!(
                "radius {:.4} mm is {:+.4} mm off the expected {:.4} mm (limit {} mm)",
                fit.sphere.radius, off, self.expected_radius, self.radius_tolerance
            ));
        }
        if fit.max_abs > self.form_tolerance {
            why.push(format!(
                "the touches lie up to {:.4} mm off the fitted sphere (limit {} mm)",
                fit.max_abs, self.form_tolerance
            ));
        }
        if why.is_empty() {
            Ok(fit)
        } else {
            Err(ImplausibleSphere {
                pose: pose.to_string(),
                expected_radius: self.expected_radius,
                reason: why.join("; "),
                fit: Some(Box::new(fit)),
            })
        }
    }
}

/// A pose whose touches fail the sphere check.
#[derive(Clone, Debug, PartialEq)]
pub struct ImplausibleSphere {
    /// The pose id.
    pub pose: String,
    /// The fit, when there was one.
    pub fit: Option<Box<SphereFit>>,
    /// The radius expected, mm.
    pub expected_radius: f64,
    /// What is wrong.
    pub reason: String,
}

impl fmt::Display for ImplausibleSphere {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "pose {}: implausible sphere, not used: {}",
            self.pose, self.reason
        )
    }
}

impl std::error::Error for ImplausibleSphere {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_points_give_the_sphere_back() {
        let c = Vector3::new(12.0, -40.0, 7.5);
        let r = 15.0;
        let dirs = [
            Vector3::new(1.0, 0.0, 0.0),
            Vector3::new(-1.0, 0.0, 0.0),
            Vector3::new(0.0, 1.0, 0.0),
            Vector3::new(0.0, -1.0, 0.0),
            Vector3::new(0.0, 0.0, 1.0),
        ];
        let p: Vec<_> = dirs.iter().map(|d| c + d * r).collect();
        let a = fit_sphere_algebraic(&p).unwrap();
        assert!((a.centre - c).norm() < 1e-10 && (a.radius - r).abs() < 1e-10);
        let g = fit_sphere(&p).unwrap();
        assert!(g.max_abs < 1e-10, "{:?}", g.residuals);
    }

    #[test]
    fn coplanar_points_are_refused() {
        let p: Vec<_> = (0..6)
            .map(|i| {
                let a = i as f64;
                Vector3::new(a.cos() * 10.0, a.sin() * 10.0, 3.0)
            })
            .collect();
        assert!(matches!(
            fit_sphere(&p),
            Err(ShapeFitError::Degenerate { .. })
        ));
    }
}
