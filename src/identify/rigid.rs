//! Small rigid motions shared by the identification methods: the six
//! numbers `(dx, dy, dz, a, b, c)` of `D(...)` (docs/model.md) and back,
//! and the exact point-to-plane residual of a rigidly moved face with its
//! derivatives.

use nalgebra::{Isometry3, Matrix3, Vector3};

use crate::geom::{self, Axis3};

/// The six numbers of `D(dx, dy, dz, a, b, c)` (mm, rad) of an isometry:
/// the inverse of [`geom::d6`] (exact for |b| < 90 deg).
pub(crate) fn d6_inverse(iso: &Isometry3<f64>) -> [f64; 6] {
    let r = iso.rotation.to_rotation_matrix().into_inner();
    let t = iso.translation.vector;
    let b = r[(0, 2)].clamp(-1.0, 1.0).asin();
    let a = (-r[(1, 2)]).atan2(r[(2, 2)]);
    let c = (-r[(0, 1)]).atan2(r[(0, 0)]);
    [t.x, t.y, t.z, a, b, c]
}

/// `D` from six numbers in um and urad.
pub(crate) fn d6_um(x: &[f64]) -> Isometry3<f64> {
    geom::d6(&[
        x[0] * 1e-3,
        x[1] * 1e-3,
        x[2] * 1e-3,
        x[3] * 1e-6,
        x[4] * 1e-6,
        x[5] * 1e-6,
    ])
}

/// The six numbers of an isometry in um and urad.
pub(crate) fn d6_inverse_um(iso: &Isometry3<f64>) -> [f64; 6] {
    let v = d6_inverse(iso);
    [
        v[0] * 1e3,
        v[1] * 1e3,
        v[2] * 1e3,
        v[3] * 1e6,
        v[4] * 1e6,
        v[5] * 1e6,
    ]
}

/// `D(x) q` (x in um and urad, q in mm) and its derivative with respect to
/// the six numbers (mm per um or urad), 3 x 6.
pub(crate) fn d6_apply(x: &[f64], q: &Vector3<f64>) -> (Vector3<f64>, nalgebra::Matrix3x6<f64>) {
    let (a, b, c) = (x[3] * 1e-6, x[4] * 1e-6, x[5] * 1e-6);
    let ra = geom::rot(Axis3::X, a)
        .rotation
        .to_rotation_matrix()
        .into_inner();
    let rb = geom::rot(Axis3::Y, b)
        .rotation
        .to_rotation_matrix()
        .into_inner();
    let rc = geom::rot(Axis3::Z, c)
        .rotation
        .to_rotation_matrix()
        .into_inner();
    let t = Vector3::new(x[0], x[1], x[2]) * 1e-3;
    let mut j = nalgebra::Matrix3x6::zeros();
    for i in 0..3 {
        j[(i, i)] = 1e-3;
    }
    let cols = [
        skew(&Vector3::x()) * ra * rb * rc * q,
        ra * skew(&Vector3::y()) * rb * rc * q,
        ra * rb * skew(&Vector3::z()) * rc * q,
    ];
    for (k, col) in cols.iter().enumerate() {
        j.set_column(3 + k, &(col * 1e-6));
    }
    (t + ra * rb * rc * q, j)
}

fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// The signed distance (um) of an observed point `u` from the face through
/// `q` with normal `n` after the face is moved by `D(rho)` (`rho` in um and
/// urad): `r = (R n) . (u - t - R q) * 1e3`, with `d r / d rho` (per um and
/// urad), `d r / d q` and `d r / d n` (per mm and per unit).
pub(crate) struct FaceResidual {
    /// The residual, um.
    pub r: f64,
    /// Derivative with respect to the six motion numbers.
    pub d_rho: [f64; 6],
    /// Derivative with respect to the face point (um per mm).
    pub d_q: Vector3<f64>,
    /// Derivative with respect to the face normal (um per unit).
    pub d_n: Vector3<f64>,
}

/// See [`FaceResidual`].
pub(crate) fn face_residual(
    rho: &[f64],
    q: &Vector3<f64>,
    n: &Vector3<f64>,
    u: &Vector3<f64>,
) -> FaceResidual {
    let t = Vector3::new(rho[0], rho[1], rho[2]) * 1e-3;
    let (a, b, c) = (rho[3] * 1e-6, rho[4] * 1e-6, rho[5] * 1e-6);
    let ra = geom::rot(Axis3::X, a)
        .rotation
        .to_rotation_matrix()
        .into_inner();
    let rb = geom::rot(Axis3::Y, b)
        .rotation
        .to_rotation_matrix()
        .into_inner();
    let rc = geom::rot(Axis3::Z, c)
        .rotation
        .to_rotation_matrix()
        .into_inner();
    let r = ra * rb * rc;
    let rn = r * n;
    let gap = u - t - r * q;
    let res = rn.dot(&gap);
    let dr = [
        skew(&Vector3::x()) * r,
        ra * skew(&Vector3::y()) * rb * rc,
        ra * rb * skew(&Vector3::z()) * rc,
    ];
    let mut d_rho = [0.0; 6];
    for i in 0..3 {
        d_rho[i] = -rn[i] * 1e-3 * 1e3;
        d_rho[3 + i] = ((dr[i] * n).dot(&gap) - rn.dot(&(dr[i] * q))) * 1e-6 * 1e3;
    }
    FaceResidual {
        r: res * 1e3,
        d_rho,
        d_q: -n * 1e3,
        d_n: (r.transpose() * (u - t) - q) * 1e3,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn d6_inverse_inverts_d6() {
        let x = [0.3, -1.2, 2.0, 0.01, -0.4, 1.2];
        let back = d6_inverse(&geom::d6(&x));
        for i in 0..6 {
            assert!((back[i] - x[i]).abs() < 1e-14, "{i}: {back:?}");
        }
    }

    #[test]
    fn d6_apply_is_d6_and_its_derivative() {
        let x = [5.0, -3.0, 2.0, 300.0, -200.0, 700.0];
        let q = Vector3::new(40.0, -10.0, 25.0);
        let (v, j) = d6_apply(&x, &q);
        assert!((v - (d6_um(&x) * nalgebra::Point3::from(q)).coords).norm() < 1e-12);
        for k in 0..6 {
            let (mut p, mut m) = (x, x);
            p[k] += 1e-2;
            m[k] -= 1e-2;
            let fd = (d6_apply(&p, &q).0 - d6_apply(&m, &q).0) / 2e-2;
            assert!((fd - j.column(k)).norm() < 1e-12, "{k}");
        }
    }

    #[test]
    fn face_residual_derivatives_match_finite_differences() {
        let rho = [3.0, -2.0, 5.0, 40.0, -25.0, 60.0];
        let q = Vector3::new(30.0, -20.0, 15.0);
        let n = Vector3::new(0.6, 0.0, 0.8);
        let u = Vector3::new(30.01, -19.99, 15.004);
        let f = face_residual(&rho, &q, &n, &u);
        for k in 0..6 {
            let h = 1e-3;
            let mut p = rho;
            let mut m = rho;
            p[k] += h;
            m[k] -= h;
            let fd =
                (face_residual(&p, &q, &n, &u).r - face_residual(&m, &q, &n, &u).r) / (2.0 * h);
            assert!(
                (fd - f.d_rho[k]).abs() < 1e-7 * (1.0 + fd.abs()),
                "rho {k}: {fd} vs {}",
                f.d_rho[k]
            );
        }
        for k in 0..3 {
            let h = 1e-6;
            let mut e = Vector3::zeros();
            e[k] = h;
            let fq = (face_residual(&rho, &(q + e), &n, &u).r
                - face_residual(&rho, &(q - e), &n, &u).r)
                / (2.0 * h);
            let fnn = (face_residual(&rho, &q, &(n + e), &u).r
                - face_residual(&rho, &q, &(n - e), &u).r)
                / (2.0 * h);
            assert!((fq - f.d_q[k]).abs() < 1e-5, "q {k}");
            assert!((fnn - f.d_n[k]).abs() < 1e-5, "n {k}");
        }
    }
}
