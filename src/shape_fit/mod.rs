//! Geometric fits of probed points: planes, circles in space and spheres,
//! each first in closed (algebraic) form and then refined by geometric
//! least squares, the distances of the points from the fitted shape being
//! what is minimized.
//!
//! They serve two users. On the machine, a calibration sphere is touched at
//! five points per pose (Cubas Brizuela & Yeh 2023, section 2): [`sphere::fit_sphere`] gives
//! the centre and radius and [`sphere::SphereCheck`] flags a set whose
//! radius or form is implausible, as a controller's sphere-radius check
//! would, before the centre is used. The sphere method of the analyzer
//! then fits circles through the centres of a C sweep ([`circle`]), whose
//! plane normal is the C axis direction and whose centre lies on it (seed
//! 004 section 3.2, eq. 3.3-4.1).
//!
//! All coordinates are in mm; the fits are invariant to where the points
//! are, because every fit works on coordinates taken relative to the
//! points' centroid.

pub mod circle;
pub mod plane;
pub mod sphere;

use nalgebra::Vector3;

pub use circle::{Circle3, CircleFit, circle_through_three, fit_circle};
pub use plane::{Plane, PlaneFit, fit_plane};
pub use sphere::{Sphere, SphereCheck, SphereFit, fit_sphere, fit_sphere_algebraic};

/// Why a fit has no answer.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ShapeFitError {
    /// Fewer points than the shape has parameters.
    #[error("a {shape} needs at least {need} points, got {got}")]
    TooFewPoints {
        /// `plane`, `circle` or `sphere`.
        shape: &'static str,
        /// Minimum number of points.
        need: usize,
        /// Points given.
        got: usize,
    },
    /// The points do not determine the shape (all on a line, or, for a
    /// sphere, all in one plane).
    #[error("the points do not determine a {shape}: {why}")]
    Degenerate {
        /// `plane`, `circle` or `sphere`.
        shape: &'static str,
        /// What is wrong with the points.
        why: String,
    },
    /// A coordinate is not finite.
    #[error("point {index} has a coordinate that is not a finite number")]
    NotFinite {
        /// 0-based index of the point.
        index: usize,
    },
}

/// The centroid of the points (which must not be empty).
pub(crate) fn centroid(points: &[Vector3<f64>]) -> Vector3<f64> {
    points.iter().sum::<Vector3<f64>>() / points.len() as f64
}

/// Checks the count and that every coordinate is finite.
pub(crate) fn check_points(
    points: &[Vector3<f64>],
    shape: &'static str,
    need: usize,
) -> Result<(), ShapeFitError> {
    if points.len() < need {
        return Err(ShapeFitError::TooFewPoints {
            shape,
            need,
            got: points.len(),
        });
    }
    if let Some(index) = points
        .iter()
        .position(|p| !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite()))
    {
        return Err(ShapeFitError::NotFinite { index });
    }
    Ok(())
}

/// Root mean square and largest magnitude of residuals.
pub(crate) fn rms_max(r: &[f64]) -> (f64, f64) {
    if r.is_empty() {
        return (0.0, 0.0);
    }
    let rms = (r.iter().map(|v| v * v).sum::<f64>() / r.len() as f64).sqrt();
    let max = r.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    (rms, max)
}
