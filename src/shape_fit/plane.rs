//! Least-squares plane: the plane through the centroid whose normal is the
//! direction of least spread (smallest eigenvalue of the scatter matrix).
//! This minimizes the sum of squared orthogonal distances exactly, so there
//! is no separate algebraic start and refinement.

use nalgebra::{Matrix3, Vector3};

use super::{ShapeFitError, centroid, check_points, rms_max};

/// A plane through `point` with unit `normal`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    /// A point on the plane (the centroid of the fitted points), mm.
    pub point: Vector3<f64>,
    /// Unit normal. Its sign is chosen so that it points along +Z when it
    /// is not perpendicular to Z (else along +Y, else +X), so that fits of
    /// similar point sets give comparable normals.
    pub normal: Vector3<f64>,
}

impl Plane {
    /// Signed distance of `p` from the plane, positive on the normal's side.
    pub fn distance(&self, p: &Vector3<f64>) -> f64 {
        (p - self.point).dot(&self.normal)
    }

    /// The orthogonal projection of `p` on the plane.
    pub fn project(&self, p: &Vector3<f64>) -> Vector3<f64> {
        p - self.normal * self.distance(p)
    }
}

/// A fitted plane with its residuals.
#[derive(Clone, Debug, PartialEq)]
pub struct PlaneFit {
    /// The plane.
    pub plane: Plane,
    /// Signed distance of each point from the plane, mm.
    pub residuals: Vec<f64>,
    /// Root mean square of the residuals, mm.
    pub rms: f64,
    /// Largest residual magnitude, mm.
    pub max_abs: f64,
}

/// Flips `n` to the canonical sign of [`Plane::normal`].
pub(crate) fn canonical_sign(n: Vector3<f64>) -> Vector3<f64> {
    const EPS: f64 = 1e-12;
    let key = if n.z.abs() > EPS {
        n.z
    } else if n.y.abs() > EPS {
        n.y
    } else {
        n.x
    };
    if key < 0.0 { -n } else { n }
}

/// Fits a plane to three or more points that are not all on one line.
pub fn fit_plane(points: &[Vector3<f64>]) -> Result<PlaneFit, ShapeFitError> {
    check_points(points, "plane", 3)?;
    let c = centroid(points);
    let mut s = Matrix3::zeros();
    for p in points {
        let d = p - c;
        s += d * d.transpose();
    }
    let eig = s.symmetric_eigen();
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
    let (l_mid, l_max) = (
        eig.eigenvalues[order[1]].max(0.0),
        eig.eigenvalues[order[2]].max(0.0),
    );
    if l_max.sqrt() < 1e-12 || l_mid.sqrt() <= 1e-9 * l_max.sqrt() {
        return Err(ShapeFitError::Degenerate {
            shape: "plane",
            why: "the points lie on one line (or coincide)".into(),
        });
    }
    let normal = canonical_sign(eig.eigenvectors.column(order[0]).normalize());
    let plane = Plane { point: c, normal };
    let residuals: Vec<f64> = points.iter().map(|p| plane.distance(p)).collect();
    let (rms, max_abs) = rms_max(&residuals);
    Ok(PlaneFit {
        plane,
        residuals,
        rms,
        max_abs,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn three_points_give_the_cross_product_normal() {
        let a = Vector3::new(1.0, 2.0, 3.0);
        let b = Vector3::new(4.0, -1.0, 2.5);
        let c = Vector3::new(-2.0, 0.5, 7.0);
        let f = fit_plane(&[a, b, c]).unwrap();
        let n = canonical_sign((b - a).cross(&(c - a)).normalize());
        assert!(
            (f.plane.normal - n).norm() < 1e-12,
            "{:?} vs {n:?}",
            f.plane.normal
        );
        assert!(f.max_abs < 1e-12);
    }

    #[test]
    fn collinear_points_are_refused() {
        let p: Vec<_> = (0..4)
            .map(|i| Vector3::new(i as f64, 2.0 * i as f64, 1.0))
            .collect();
        assert!(matches!(
            fit_plane(&p),
            Err(ShapeFitError::Degenerate { .. })
        ));
    }
}
