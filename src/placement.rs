//! Where the measured piece sits on the CMM: the rigid transform from the
//! table frame W (in which the plan gives every nominal point) to the CMM
//! frame, for any rotation and any offset.
//!
//! With labelled points the start is closed-form: the point-to-point
//! least-squares rotation of Kabsch (Horn's solution, via the SVD of the
//! 3 x 3 cross-covariance), exact when the measured points lie at the
//! nominal ones. It is then refined by least squares on the reference
//! features, point-to-plane along the nominal normals (the tangential
//! position of a probed point says nothing about the surface), iterating
//! the exact rigid update until it stops moving. Without labels, the start
//! is searched: the principal axes of both point sets, under the 24 proper
//! rotations that permute and flip them, each improved by point-to-plane
//! ICP against the nearest nominal points; the best fit wins, and a fit
//! that a symmetric piece makes ambiguous is reported.

use nalgebra::{
    DMatrix, DVector, Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3,
};

/// A measured point with the nominal surface point and normal it belongs to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlaneObservation {
    /// Nominal surface point in W, mm.
    pub p: Vector3<f64>,
    /// Unit outward normal in W.
    pub n: Vector3<f64>,
    /// Measured point in the CMM frame, mm.
    pub m: Vector3<f64>,
}

/// A placement and how well the features fix it.
#[derive(Clone, Debug, PartialEq)]
pub struct PlacementFit {
    /// W to CMM.
    pub iso: Isometry3<f64>,
    /// Root-mean-square point-to-plane residual of the points used, um.
    pub rms_um: f64,
    /// How many of the six rigid degrees of freedom the features fix.
    pub constrained: usize,
    /// Number of points used.
    pub points: usize,
}

/// Why no placement could be found.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PlacementError {
    /// Fewer points than a rigid placement needs.
    #[error("{got} points cannot place a piece: at least {need} are needed")]
    TooFewPoints {
        /// Points given.
        got: usize,
        /// Points needed.
        need: usize,
    },
    /// The points are collinear (or coincide), so the rotation is unknown.
    #[error("the points are collinear: the placement's rotation is undetermined")]
    Degenerate,
    /// The features leave some rigid motion free.
    #[error("the measured faces fix only {0} of the six degrees of freedom of the placement")]
    Underdetermined(usize),
}

/// The rigid transform `T` minimising `sum |T w_i - c_i|^2` (Kabsch/Horn):
/// from W points `w` to CMM points `c`.
pub(crate) fn kabsch(
    w: &[Vector3<f64>],
    c: &[Vector3<f64>],
) -> Result<Isometry3<f64>, PlacementError> {
    assert_eq!(w.len(), c.len());
    if w.len() < 3 {
        return Err(PlacementError::TooFewPoints {
            got: w.len(),
            need: 3,
        });
    }
    let n = w.len() as f64;
    let wc = w.iter().sum::<Vector3<f64>>() / n;
    let cc = c.iter().sum::<Vector3<f64>>() / n;
    let mut h = Matrix3::zeros();
    for (a, b) in w.iter().zip(c) {
        h += (a - wc) * (b - cc).transpose();
    }
    let svd = h.svd(true, true);
    let (u, vt) = (svd.u.unwrap(), svd.v_t.unwrap());
    let s = svd.singular_values;
    if s[1] <= 1e-9 * s[0].max(1e-300) {
        return Err(PlacementError::Degenerate);
    }
    let v = vt.transpose();
    let d = (v * u.transpose()).determinant().signum();
    let r = v * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * u.transpose();
    let rot = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r));
    let t = cc - rot * wc;
    Ok(Isometry3::from_parts(Translation3::from(t), rot))
}

/// Singular values of `a` after scaling its columns to unit length, and
/// the number above `rtol` times the largest.
fn scaled_rank(a: &DMatrix<f64>, rtol: f64) -> usize {
    let mut s = a.clone();
    for mut col in s.column_iter_mut() {
        let nrm = col.norm();
        if nrm > 0.0 {
            col /= nrm;
        }
    }
    let sv = s.svd(false, false).singular_values;
    let max = sv.max();
    sv.iter().filter(|&&x| x > rtol * max).count()
}

/// Refines a placement by point-to-plane least squares. Returns the fit
/// (with `constrained < 6` when the faces leave some motion free; the free
/// motion then stays where `init` put it).
pub(crate) fn refine(obs: &[PlaneObservation], init: &Isometry3<f64>) -> PlacementFit {
    // Work with Q = P^-1 (CMM to W); residual r = n . (Q m - p).
    let mut q = init.inverse();
    let rows = obs.len();
    let mut constrained = 0;
    for _ in 0..100 {
        let mut a = DMatrix::zeros(rows, 6);
        let mut b = DVector::zeros(rows);
        for (k, o) in obs.iter().enumerate() {
            let w = q * nalgebra::Point3::from(o.m);
            let r = o.n.dot(&(w.coords - o.p));
            let c = w.coords.cross(&o.n);
            for j in 0..3 {
                a[(k, j)] = o.n[j];
                a[(k, 3 + j)] = c[j];
            }
            b[k] = -r;
        }
        constrained = scaled_rank(&a, 1e-9);
        // Column scaling keeps the rotation and translation columns
        // comparable for the truncated solve.
        let mut scale = [1.0; 6];
        for (j, s) in scale.iter_mut().enumerate() {
            let nrm = a.column(j).norm();
            if nrm > 0.0 {
                *s = nrm;
            }
        }
        let mut as_ = a.clone();
        for (j, s) in scale.iter().enumerate() {
            as_.column_mut(j).scale_mut(1.0 / s);
        }
        let svd = as_.svd(true, true);
        let tol = 1e-9 * svd.singular_values.max();
        let Ok(x) = svd.solve(&b, tol) else {
            break;
        };
        let d: Vec<f64> = (0..6).map(|j| x[j] / scale[j]).collect();
        let dt = Vector3::new(d[0], d[1], d[2]);
        let dr = Vector3::new(d[3], d[4], d[5]);
        let step =
            Isometry3::from_parts(Translation3::from(dt), UnitQuaternion::from_scaled_axis(dr));
        q = step * q;
        if dt.norm() < 1e-13 && dr.norm() < 1e-15 {
            break;
        }
    }
    let iso = q.inverse();
    let ss: f64 = obs
        .iter()
        .map(|o| {
            let w = q * nalgebra::Point3::from(o.m);
            o.n.dot(&(w.coords - o.p)).powi(2)
        })
        .sum();
    PlacementFit {
        iso,
        rms_um: (ss / obs.len().max(1) as f64).sqrt() * 1e3,
        constrained,
        points: obs.len(),
    }
}

/// Places a piece from labelled points: Kabsch on all points, then
/// point-to-plane on the reference features (`reference`: indices into
/// `obs`), or on all points when the reference features alone leave some
/// motion free.
pub fn place_labeled(
    obs: &[PlaneObservation],
    reference: &[usize],
) -> Result<PlacementFit, PlacementError> {
    let w: Vec<Vector3<f64>> = obs.iter().map(|o| o.p).collect();
    let c: Vec<Vector3<f64>> = obs.iter().map(|o| o.m).collect();
    let start = kabsch(&w, &c)?;
    let refs: Vec<PlaneObservation> = reference.iter().map(|&i| obs[i]).collect();
    if refs.len() >= 6 {
        let fit = refine(&refs, &start);
        if fit.constrained == 6 {
            return Ok(fit);
        }
    }
    let fit = refine(obs, &start);
    if fit.constrained < 6 {
        return Err(PlacementError::Underdetermined(fit.constrained));
    }
    Ok(fit)
}

/// The 24 proper rotations that map the coordinate axes onto themselves.
fn cube_rotations() -> Vec<Matrix3<f64>> {
    let mut out = Vec::new();
    let perms = [
        [0, 1, 2],
        [0, 2, 1],
        [1, 0, 2],
        [1, 2, 0],
        [2, 0, 1],
        [2, 1, 0],
    ];
    for p in perms {
        for signs in 0..8 {
            let mut m = Matrix3::zeros();
            for (row, &col) in p.iter().enumerate() {
                m[(row, col)] = if signs >> row & 1 == 1 { -1.0 } else { 1.0 };
            }
            if m.determinant() > 0.0 {
                out.push(m);
            }
        }
    }
    out
}

fn principal_axes(pts: &[Vector3<f64>]) -> (Vector3<f64>, Matrix3<f64>) {
    let n = pts.len() as f64;
    let c = pts.iter().sum::<Vector3<f64>>() / n;
    let mut cov = Matrix3::zeros();
    for p in pts {
        cov += (p - c) * (p - c).transpose();
    }
    let e = cov.symmetric_eigen();
    let mut v = e.eigenvectors;
    if v.determinant() < 0.0 {
        v.column_mut(2).neg_mut();
    }
    (c, v)
}

/// A placement found without labels, with the plan point each measured
/// point was matched to.
#[derive(Clone, Debug, PartialEq)]
pub struct UnlabeledFit {
    /// The placement.
    pub fit: PlacementFit,
    /// For each measured point, the index of its nearest nominal point.
    pub matches: Vec<usize>,
    /// Distance between each measured point (in W) and its match, mm.
    pub distances: Vec<f64>,
    /// The largest of them, mm.
    pub max_distance: f64,
    /// Set when another, clearly different placement fits almost as well
    /// (a symmetric piece): its rms, um.
    pub ambiguous_with: Option<f64>,
}

fn nearest(p: &Vector3<f64>, nominal: &[(Vector3<f64>, Vector3<f64>)]) -> (usize, f64) {
    let mut best = (0, f64::INFINITY);
    for (i, (q, _)) in nominal.iter().enumerate() {
        let d = (q - p).norm_squared();
        if d < best.1 {
            best = (i, d);
        }
    }
    (best.0, best.1.sqrt())
}

fn icp(
    nominal: &[(Vector3<f64>, Vector3<f64>)],
    measured: &[Vector3<f64>],
    start: Isometry3<f64>,
) -> (Isometry3<f64>, Vec<usize>, f64) {
    let mut iso = start;
    let mut matches = vec![usize::MAX; measured.len()];
    for _ in 0..60 {
        let inv = iso.inverse();
        let new: Vec<usize> = measured
            .iter()
            .map(|m| nearest(&(inv * nalgebra::Point3::from(*m)).coords, nominal).0)
            .collect();
        let obs: Vec<PlaneObservation> = new
            .iter()
            .zip(measured)
            .map(|(&i, m)| PlaneObservation {
                p: nominal[i].0,
                n: nominal[i].1,
                m: *m,
            })
            .collect();
        // Point-to-point first while the matches still move: it pulls the
        // piece along faces, which point-to-plane alone cannot.
        let w: Vec<Vector3<f64>> = obs.iter().map(|o| o.p).collect();
        let stable = new == matches;
        matches = new;
        iso = if stable {
            refine(&obs, &iso).iso
        } else {
            kabsch(&w, measured).unwrap_or(iso)
        };
        if stable {
            break;
        }
    }
    let inv = iso.inverse();
    let ms: f64 = measured
        .iter()
        .map(|m| {
            nearest(&(inv * nalgebra::Point3::from(*m)).coords, nominal)
                .1
                .powi(2)
        })
        .sum::<f64>()
        / measured.len() as f64;
    (iso, matches, ms.sqrt())
}

/// Places a piece from unlabelled points: each measured point is matched
/// to its nearest nominal point once the placement is found.
pub fn place_unlabeled(
    nominal: &[(Vector3<f64>, Vector3<f64>)],
    measured: &[Vector3<f64>],
) -> Result<UnlabeledFit, PlacementError> {
    if measured.len() < 6 {
        return Err(PlacementError::TooFewPoints {
            got: measured.len(),
            need: 6,
        });
    }
    let noms: Vec<Vector3<f64>> = nominal.iter().map(|x| x.0).collect();
    let (cw, ew) = principal_axes(&noms);
    let (cc, ec) = principal_axes(measured);
    let mut starts = Vec::new();
    for s in cube_rotations() {
        let r = ec * s * ew.transpose();
        let rot = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r));
        starts.push(Isometry3::from_parts(
            Translation3::from(cc - rot * cw),
            rot,
        ));
    }
    // The CMM's own alignment, when the operator set it up on W.
    starts.push(Isometry3::from_parts(
        Translation3::from(cc - cw),
        UnitQuaternion::identity(),
    ));
    let mut results: Vec<(Isometry3<f64>, Vec<usize>, f64)> = starts
        .into_iter()
        .map(|s| icp(nominal, measured, s))
        .collect();
    results.sort_by(|a, b| a.2.total_cmp(&b.2));
    let (iso, matches, rms) = results.swap_remove(0);
    let ambiguous_with = results
        .iter()
        .find(|(o, _, r)| *r < 1.5 * rms.max(1e-6) && (o.rotation.angle_to(&iso.rotation) > 1e-2))
        .map(|x| x.2 * 1e3);
    let obs: Vec<PlaneObservation> = matches
        .iter()
        .zip(measured)
        .map(|(&i, m)| PlaneObservation {
            p: nominal[i].0,
            n: nominal[i].1,
            m: *m,
        })
        .collect();
    let fit = refine(&obs, &iso);
    if fit.constrained < 6 {
        return Err(PlacementError::Underdetermined(fit.constrained));
    }
    let inv = fit.iso.inverse();
    let distances: Vec<f64> = measured
        .iter()
        .zip(&matches)
        .map(|(m, &i)| ((inv * nalgebra::Point3::from(*m)).coords - nominal[i].0).norm())
        .collect();
    let max_distance = distances.iter().copied().fold(0.0, f64::max);
    Ok(UnlabeledFit {
        fit,
        matches,
        distances,
        max_distance,
        ambiguous_with,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kabsch_recovers_a_known_transform_exactly() {
        let w = [
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(50.0, 0.0, 10.0),
            Vector3::new(0.0, 40.0, -5.0),
            Vector3::new(20.0, 20.0, 30.0),
        ];
        let t = Isometry3::new(
            Vector3::new(1000.0, -250.0, 30.0),
            Vector3::new(2.0, -1.0, 0.5),
        );
        let c: Vec<Vector3<f64>> = w
            .iter()
            .map(|p| (t * nalgebra::Point3::from(*p)).coords)
            .collect();
        let got = kabsch(&w, &c).unwrap();
        assert!((got.translation.vector - t.translation.vector).norm() < 1e-9);
        assert!(got.rotation.angle_to(&t.rotation) < 1e-12);
    }
}
