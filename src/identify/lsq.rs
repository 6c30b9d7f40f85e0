//! The pure numerical core of every identification: nonlinear least
//! squares by Gauss-Newton with a Levenberg-Marquardt fallback, in the
//! basis of the singular value decomposition of the column-scaled Jacobian
//! (faer), optionally restricted to the subspace `x = x0 + N z` that linear
//! equality constraints leave free.
//!
//! Column scaling (each column of `J N` to unit length) makes the steps,
//! the rank decision and the condition number independent of units. A
//! direction whose scaled singular value falls below `rank_rtol` times the
//! largest is not identifiable: the step never moves along it (minimum-norm
//! steps), and the covariance and [`Design::null`] report it. So is a
//! direction below a gap of [`RANK_GAP`] in the spectrum, under
//! [`RANK_GAP_LEVEL`] of the largest ([`numerical_rank`]): a direction
//! that a linearized design does not see at all but the exact model sees
//! through its curvature (a probed column turned about the point between
//! its touches) comes out there, five orders of magnitude below the others,
//! and a fit that counted it would slide along it for a hundred steps.
//! Everything here works on plain slices and matrices; the callers in
//! `identify` give it meaning.

use faer::Mat;
use nalgebra::DMatrix;

/// A least-squares problem: residuals and their Jacobian at a point.
pub trait Problem {
    /// Number of residuals.
    fn n_residuals(&self) -> usize;
    /// Number of parameters.
    fn n_params(&self) -> usize;
    /// Writes the residuals at `x` into `r` and, when asked, the Jacobian
    /// `d r / d x` into `jac` (`n_residuals x n_params`).
    fn eval(&self, x: &[f64], r: &mut [f64], jac: Option<&mut Mat<f64>>);
}

/// Options of [`solve`].
#[derive(Clone, Copy, Debug)]
pub struct Options {
    /// Maximum number of accepted steps.
    pub max_iter: usize,
    /// Relative singular value below which a direction is not identifiable.
    pub rank_rtol: f64,
    /// Stop when the scaled step is below this (relative).
    pub xtol: f64,
    /// Stop when the cost decreases by less than this (relative).
    pub ftol: f64,
    /// Also stop, before evaluating it, when the linearized model says the
    /// Gauss-Newton step would gain less than `ftol`. A caller that
    /// differentiates the solution by re-solving from a warm start after a
    /// tiny change of the data must leave this off: the step it wants is
    /// exactly such a small one.
    pub stop_on_prediction: bool,
    /// Once a step has needed damping, adapt the damping to how well the
    /// linearized model predicted the last step (Nielsen's rule: shrink it
    /// by up to 3 where the prediction held, grow it where it did not)
    /// instead of trying a tenth of it before every step. Where the exact
    /// model curves along barely seen directions (a piece turned about its
    /// probed points), the tenth fails before nearly every step, so each
    /// step costs two evaluations, and the damping never settles where the
    /// curvature is; adapted, a step costs one and goes further. A run
    /// whose undamped steps all succeed is the same either way.
    pub adapt_damping: bool,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            max_iter: 50,
            rank_rtol: 1e-9,
            xtol: 1e-12,
            ftol: 1e-14,
            stop_on_prediction: false,
            adapt_damping: false,
        }
    }
}

/// The solution of [`solve`].
#[derive(Clone, Debug)]
pub struct LsqSolution {
    /// The parameters.
    pub x: Vec<f64>,
    /// Residuals at `x`.
    pub residuals: Vec<f64>,
    /// Jacobian at `x`.
    pub jacobian: Mat<f64>,
    /// Sum of squared residuals.
    pub cost: f64,
    /// Accepted steps.
    pub iterations: usize,
    /// Whether a stopping test (rather than `max_iter`) ended the run.
    pub converged: bool,
}

/// Ratio between consecutive scaled singular values from which the
/// smaller ones are taken as unseen (see [`numerical_rank`]).
pub const RANK_GAP: f64 = 1e4;

/// Largest scaled singular value, relative to the largest, that a gap of
/// [`RANK_GAP`] above it leaves unseen (see [`numerical_rank`]).
pub const RANK_GAP_LEVEL: f64 = 1e-5;

/// The number of directions a design sees, from its scaled singular values
/// `s` (largest first): those above `rtol` times the largest, less those
/// below the first gap of at least [`RANK_GAP`] between consecutive values
/// that lies under [`RANK_GAP_LEVEL`] of the largest.
///
/// The rounding floor (`rtol`) catches the directions no measurement sees.
/// The gap catches those the design sees only through the curvature of the
/// exact model: on probe-columns, each column turned about the point
/// between its top and side touches moves no touch to first order, and
/// the exact model's scaled singular values for those nine turns are
/// 5e-8 to 2e-7 of the largest on bc-trunnion, against 0.09 and more for
/// every other direction. Counted as seen they would be determined a million times
/// worse than the column's own offsets, the condition number would be
/// 2e7, and a fit would slide along them step after step. A design whose
/// weak directions thin out gradually (no gap) keeps them: whether their
/// uncertainty is useful is a question for the uncertainty, not the rank.
pub fn numerical_rank(s: &[f64], rtol: f64) -> usize {
    let smax = s.first().copied().unwrap_or(0.0);
    let above = s.iter().filter(|&&x| x > rtol * smax && x > 0.0).count();
    (1..above)
        .find(|&k| s[k] <= RANK_GAP_LEVEL * smax && s[k - 1] >= RANK_GAP * s[k])
        .unwrap_or(above)
}

fn cost(r: &[f64]) -> f64 {
    r.iter().map(|v| v * v).sum()
}

/// `J N` (or `J` when there is no basis).
fn reduce(j: &Mat<f64>, basis: Option<&DMatrix<f64>>) -> Mat<f64> {
    match basis {
        None => j.clone(),
        Some(n) => {
            let (m, p) = (j.nrows(), n.ncols());
            let mut out = Mat::<f64>::zeros(m, p);
            // Column by column on contiguous slices (the sums in the same
            // order as element by element, so the same bits): a basis is
            // mostly the zeros between its effects' blocks, skipped.
            for c in 0..p {
                let oc = out.col_as_slice_mut(c);
                for k in 0..n.nrows() {
                    let w = n[(k, c)];
                    if w != 0.0 {
                        for (o, v) in oc.iter_mut().zip(j.col_as_slice(k)) {
                            *o += v * w;
                        }
                    }
                }
            }
            out
        }
    }
}

/// The scaled SVD of a (reduced) Jacobian.
struct ScaledSvd {
    scale: Vec<f64>,
    u: Mat<f64>,
    s: Vec<f64>,
    v: Mat<f64>,
    rank: usize,
}

/// The SVD of `jz` with its columns scaled to unit length; `want_u`: the
/// left singular vectors are needed (a wide design may leave them out).
fn scaled_svd(jz: &Mat<f64>, rtol: f64, want_u: bool) -> ScaledSvd {
    let (m, p) = (jz.nrows(), jz.ncols());
    let finite = (0..p).all(|c| (0..m).all(|r| jz[(r, c)].is_finite()));
    if !finite {
        // A Jacobian that overflowed (absurd input) identifies nothing.
        return ScaledSvd {
            scale: vec![1.0; p],
            u: Mat::zeros(m, p),
            s: vec![0.0; p],
            v: Mat::identity(p, p),
            rank: 0,
        };
    }
    let mut scale = vec![1.0; p];
    let mut js = jz.clone();
    let norms: Vec<f64> = (0..p)
        .map(|c| (0..m).map(|r| jz[(r, c)].powi(2)).sum::<f64>().sqrt())
        .collect();
    let max_norm = norms.iter().copied().fold(0.0, f64::max);
    for (c, sc) in scale.iter_mut().enumerate() {
        let nrm = norms[c];
        if nrm > 1e-12 * max_norm {
            *sc = nrm;
            for r in 0..m {
                js[(r, c)] /= nrm;
            }
        } else {
            // A column of round-off (a normal's 6e-17 component, say) is a
            // parameter nothing sees; scaled up it would pass for a strong
            // direction.
            for r in 0..m {
                js[(r, c)] = 0.0;
            }
        }
    }
    if m < p {
        return wide_svd(&js, scale, rtol, want_u);
    }
    let Ok(svd) = js.thin_svd() else {
        return ScaledSvd {
            scale,
            u: Mat::zeros(m, p),
            s: vec![0.0; p],
            v: Mat::identity(p, p),
            rank: 0,
        };
    };
    let sd = svd.S().column_vector();
    let s: Vec<f64> = (0..sd.nrows()).map(|i| sd[i]).collect();
    let rank = numerical_rank(&s, rtol);
    let u = svd.U().to_owned();
    let v = svd.V().to_owned();
    ScaledSvd {
        scale,
        u,
        s,
        v,
        rank,
    }
}

/// The scaled SVD of a wide design (fewer residuals `m` than directions
/// `p`: a map with more nodes than the test has points), already scaled.
/// It has `m` singular values; the other `p - m` are zero, and `V` is made
/// full so that their directions, the ones no measurement sees, are there.
/// Padding the design square with zero rows gives the same, at the price of
/// the SVD of a `p x p` matrix, three times the work for a map's design.
/// `U` (left singular vectors, at most `m` of them seen) is computed only
/// when asked for, and padded with zero columns to `p`.
fn wide_svd(js: &Mat<f64>, scale: Vec<f64>, rtol: f64, want_u: bool) -> ScaledSvd {
    use faer::dyn_stack::{MemBuffer, MemStack};
    use faer::linalg::svd::{self, ComputeSvdVectors};
    let (m, p) = (js.nrows(), js.ncols());
    let failed = |scale: Vec<f64>| ScaledSvd {
        scale,
        u: Mat::zeros(m, p),
        s: vec![0.0; p],
        v: Mat::identity(p, p),
        rank: 0,
    };
    let par = faer::get_global_parallelism();
    let vectors_u = if want_u {
        ComputeSvdVectors::Thin
    } else {
        ComputeSvdVectors::No
    };
    let req = svd::svd_scratch::<f64>(
        m,
        p,
        vectors_u,
        ComputeSvdVectors::Full,
        par,
        Default::default(),
    );
    let mut buf = MemBuffer::new(req);
    let mut sd = faer::diag::Diag::<f64>::zeros(m);
    let mut um = Mat::<f64>::zeros(m, if want_u { m } else { 0 });
    let mut v = Mat::<f64>::zeros(p, p);
    let done = svd::svd(
        js.as_ref(),
        sd.as_mut(),
        want_u.then(|| um.as_mut()),
        Some(v.as_mut()),
        par,
        MemStack::new(&mut buf),
        Default::default(),
    );
    if done.is_err() {
        return failed(scale);
    }
    let sc = sd.column_vector();
    let s: Vec<f64> = (0..p).map(|i| if i < m { sc[i] } else { 0.0 }).collect();
    let rank = numerical_rank(&s, rtol);
    let u = Mat::from_fn(m, p, |r, c| if c < um.ncols() { um[(r, c)] } else { 0.0 });
    ScaledSvd {
        scale,
        u,
        s,
        v,
        rank,
    }
}

/// The step `dz` minimising `|r + J N dz|^2 + lambda |D dz|^2` within the
/// identifiable subspace.
fn step(sv: &ScaledSvd, r: &[f64], lambda: f64) -> Vec<f64> {
    let p = sv.scale.len();
    let mut ds = vec![0.0; p];
    for k in 0..sv.rank {
        let utr: f64 = (0..r.len()).map(|i| sv.u[(i, k)] * r[i]).sum();
        let s = sv.s[k];
        let f = s / (s * s + lambda);
        for (j, d) in ds.iter_mut().enumerate() {
            *d -= sv.v[(j, k)] * f * utr;
        }
    }
    ds.iter().zip(&sv.scale).map(|(d, s)| d / s).collect()
}

/// The decrease of the sum of squares the linearized model predicts for
/// the step of [`step`] with damping `lambda`.
fn predicted_gain(sv: &ScaledSvd, r: &[f64], lambda: f64) -> f64 {
    (0..sv.rank)
        .map(|k| {
            let utr: f64 = (0..r.len()).map(|i| sv.u[(i, k)] * r[i]).sum();
            let s2 = sv.s[k] * sv.s[k];
            let phi = s2 / (s2 + lambda);
            utr * utr * phi * (2.0 - phi)
        })
        .sum()
}

fn expand(x0: &[f64], dz: &[f64], basis: Option<&DMatrix<f64>>) -> Vec<f64> {
    match basis {
        None => x0.iter().zip(dz).map(|(a, b)| a + b).collect(),
        Some(n) => {
            let mut x = x0.to_vec();
            for (c, d) in dz.iter().enumerate() {
                for (k, xk) in x.iter_mut().enumerate() {
                    *xk += n[(k, c)] * d;
                }
            }
            x
        }
    }
}

/// Minimises the sum of squared residuals from `x0`, moving only within
/// `x0 + span(basis)` when a basis is given (columns: free directions).
pub fn solve<P: Problem + ?Sized>(
    problem: &P,
    x0: &[f64],
    basis: Option<&DMatrix<f64>>,
    opts: &Options,
) -> LsqSolution {
    solve_ranked(problem, x0, basis, opts, None)
}

/// [`solve`] moving along at most `max_rank` directions: those a design
/// decided elsewhere (e.g. at the nominal machine) sees, when the start
/// is an estimate where the exact model couples unseen directions to seen
/// ones.
pub fn solve_ranked<P: Problem + ?Sized>(
    problem: &P,
    x0: &[f64],
    basis: Option<&DMatrix<f64>>,
    opts: &Options,
    max_rank: Option<usize>,
) -> LsqSolution {
    let (m, n) = (problem.n_residuals(), problem.n_params());
    assert_eq!(x0.len(), n);
    let mut x = x0.to_vec();
    let mut r = vec![0.0; m];
    let mut jac = Mat::<f64>::zeros(m, n);
    problem.eval(&x, &mut r, Some(&mut jac));
    let mut c = cost(&r);
    let mut lambda = 0.0;
    let mut iterations = 0;
    let mut converged = false;
    let mut trial_r = vec![0.0; m];
    let mut start_rank: Option<usize> = None;
    // Growth factor of the damping after a failed step (adapted damping).
    let mut nu = 2.0;
    'outer: while iterations < opts.max_iter {
        let mut sv = scaled_svd(&reduce(&jac, basis), opts.rank_rtol, true);
        // The rank is decided once, at the start: away from it, the exact
        // model couples unseen directions to seen ones by terms of the
        // order of the parameters, which would otherwise turn a null
        // direction into a barely-seen one and send the step far along it.
        if let Some(r) = start_rank.or(max_rank) {
            sv.rank = sv.rank.min(r);
        }
        start_rank.get_or_insert(sv.rank);
        // What the full Gauss-Newton step would gain on the linearized
        // model: when that is already below the tolerance, this is the
        // minimum, and evaluating the step would only meet round-off.
        if opts.stop_on_prediction && lambda == 0.0 {
            let predicted: f64 = (0..sv.rank)
                .map(|k| (0..m).map(|i| sv.u[(i, k)] * r[i]).sum::<f64>().powi(2))
                .sum();
            if predicted <= opts.ftol * c.max(1e-300) {
                converged = true;
                break 'outer;
            }
        }
        let mut tries = 0;
        loop {
            let dz = step(&sv, &r, lambda);
            let scaled_norm: f64 = dz
                .iter()
                .zip(&sv.scale)
                .map(|(d, s)| (d * s).powi(2))
                .sum::<f64>()
                .sqrt();
            let xn = expand(&x, &dz, basis);
            problem.eval(&xn, &mut trial_r, None);
            let cn = cost(&trial_r);
            if cn.is_finite() && cn <= c {
                let reduction = c - cn;
                if opts.adapt_damping && lambda > 0.0 {
                    let rho = reduction / predicted_gain(&sv, &r, lambda).max(1e-300);
                    lambda *= (1.0 - (2.0 * rho - 1.0).powi(3)).max(1.0 / 3.0);
                    nu = 2.0;
                } else if lambda > 0.0 {
                    lambda *= 0.1;
                }
                x = xn;
                std::mem::swap(&mut r, &mut trial_r);
                c = cn;
                iterations += 1;
                problem.eval(&x, &mut r, Some(&mut jac));
                let xnorm: f64 = x.iter().map(|v| v * v).sum::<f64>().sqrt();
                if scaled_norm <= opts.xtol * (1.0 + xnorm)
                    || reduction <= opts.ftol * c.max(1e-300)
                {
                    converged = true;
                    break 'outer;
                }
                break;
            }
            // The Gauss-Newton step failed: damp (Levenberg-Marquardt).
            tries += 1;
            if tries > 40 {
                converged = true;
                break 'outer;
            }
            let smax = sv.s.first().copied().unwrap_or(1.0);
            lambda = if lambda == 0.0 {
                1e-6 * smax * smax
            } else if opts.adapt_damping {
                nu *= 2.0;
                lambda * nu / 2.0
            } else {
                lambda * 10.0
            };
        }
    }
    LsqSolution {
        x,
        residuals: r,
        jacobian: jac,
        cost: c,
        iterations,
        converged,
    }
}

/// What the Jacobian says about the parameters: rank, conditioning, the
/// unit-noise covariance in the identifiable subspace and the directions
/// no measurement sees.
#[derive(Clone, Debug)]
pub struct Design {
    /// Singular values of the column-scaled (and constraint-reduced)
    /// design, largest first.
    pub singular_values: Vec<f64>,
    /// Number of identifiable directions.
    pub rank: usize,
    /// Number of free directions (parameters minus constraints).
    pub free: usize,
    /// Largest over smallest kept singular value.
    pub condition: f64,
    /// `(J^T J)^+` in parameter space, restricted to the identifiable
    /// subspace (multiply by the residual variance).
    pub cov_unit: DMatrix<f64>,
    /// Orthonormal basis (columns) of the parameter directions that change
    /// no residual and respect the constraints.
    pub null: DMatrix<f64>,
}

/// Analyses a Jacobian (with optional constraint basis).
pub fn design(jac: &Mat<f64>, basis: Option<&DMatrix<f64>>, rtol: f64) -> Design {
    design_ranked(jac, basis, rtol, None)
}

/// [`design`] keeping at most `max_rank` directions: the covariance at an
/// estimate, with the rank of the design at the nominal machine (see
/// [`solve`]).
pub(crate) fn design_ranked(
    jac: &Mat<f64>,
    basis: Option<&DMatrix<f64>>,
    rtol: f64,
    max_rank: Option<usize>,
) -> Design {
    design_of(jac, basis, rtol, max_rank, true)
}

/// The unit-noise covariance of [`design_ranked`] alone, for a caller
/// that has the rest: the null directions' orthonormalisation (a QR of
/// hundreds of columns for a large map) is left out.
pub(crate) fn covariance_ranked(
    jac: &Mat<f64>,
    basis: Option<&DMatrix<f64>>,
    rtol: f64,
    max_rank: Option<usize>,
) -> DMatrix<f64> {
    design_of(jac, basis, rtol, max_rank, false).cov_unit
}

/// [`design_ranked`], with the null directions only when `null` says so
/// (an empty `null` otherwise).
fn design_of(
    jac: &Mat<f64>,
    basis: Option<&DMatrix<f64>>,
    rtol: f64,
    max_rank: Option<usize>,
    null: bool,
) -> Design {
    let n = jac.ncols();
    let jz = reduce(jac, basis);
    let p = jz.ncols();
    let mut sv = scaled_svd(&jz, rtol, false);
    if let Some(r) = max_rank {
        sv.rank = sv.rank.min(r);
    }
    let nb = match basis {
        Some(b) => b.clone(),
        None => DMatrix::identity(n, n),
    };
    // (J^T J)^+ = W W^T with W = N D^-1 V_r S_r^-1: one product.
    let vz = DMatrix::from_fn(p, sv.rank, |j, k| sv.v[(j, k)] / sv.scale[j] / sv.s[k]);
    let w = &nb * vz;
    let cov = &w * w.transpose();
    // The null directions in x-space, N D^-1 v for the unseen v,
    // orthonormalised (a QR: hundreds of them for a large map). They are
    // independent, as N has orthonormal columns and D is invertible; a
    // direction that round-off made dependent is dropped.
    let nz = if null { p - sv.rank } else { 0 };
    let null = if nz == 0 {
        DMatrix::zeros(n, 0)
    } else {
        let nbf = Mat::from_fn(n, p, |r, c| nb[(r, c)]);
        let vn = Mat::from_fn(p, nz, |j, k| sv.v[(j, sv.rank + k)] / sv.scale[j]);
        let x = &nbf * &vn;
        let qr = x.qr();
        let q = qr.compute_thin_Q();
        let r = qr.thin_R();
        let scale = (0..nz).fold(0.0f64, |a, k| a.max(x.col(k).norm_l2()));
        let keep: Vec<usize> = (0..nz.min(n))
            .filter(|&k| r[(k, k)].abs() > 1e-12 * scale.max(1e-300))
            .collect();
        DMatrix::from_fn(n, keep.len(), |i, k| q[(i, keep[k])])
    };
    let smax = sv.s.first().copied().unwrap_or(0.0);
    let smin = if sv.rank > 0 { sv.s[sv.rank - 1] } else { 0.0 };
    Design {
        singular_values: sv.s.clone(),
        rank: sv.rank,
        free: p,
        condition: if smin > 0.0 {
            smax / smin
        } else {
            f64::INFINITY
        },
        cov_unit: cov,
        null,
    }
}

/// Orthonormal basis (columns) of the column space of `J N` (of `J` when
/// there is no basis): the left singular vectors of the column-scaled
/// design that [`design`] keeps, at most `max_rank` of them.
pub(crate) fn column_basis(
    jac: &Mat<f64>,
    basis: Option<&DMatrix<f64>>,
    rtol: f64,
    max_rank: Option<usize>,
) -> DMatrix<f64> {
    let sv = scaled_svd(&reduce(jac, basis), rtol, true);
    let rank = max_rank.map_or(sv.rank, |r| sv.rank.min(r));
    DMatrix::from_fn(jac.nrows(), rank, |r, c| sv.u[(r, c)])
}

/// Orthonormal basis (columns) of `{x : C x = 0}` for a constraint matrix
/// `C` (rows: constraints).
pub(crate) fn constraint_basis(c: &DMatrix<f64>) -> DMatrix<f64> {
    let n = c.ncols();
    if c.nrows() == 0 {
        return DMatrix::identity(n, n);
    }
    // Null space of C from the eigenvectors of C^T C (n x n, small), with
    // faer: a map's constraints make n several hundred, where nalgebra's
    // eigensolver is what a discovery waits for.
    let cf = Mat::from_fn(c.nrows(), n, |r, k| c[(r, k)]);
    let ctc = cf.transpose() * &cf;
    let Ok(e) = ctc.self_adjoint_eigen(faer::Side::Lower) else {
        // Non-finite constraint rows leave no direction trustworthy.
        return DMatrix::zeros(n, 0);
    };
    let vals = e.S().column_vector();
    let vecs = e.U();
    let max = (0..n).fold(0.0f64, |a, k| a.max(vals[k].abs()));
    let keep: Vec<usize> = (0..n)
        .filter(|&k| vals[k].abs() <= 1e-10 * max.max(1e-300))
        .collect();
    DMatrix::from_fn(n, keep.len(), |r, k| vecs[(r, keep[k])])
}

/// Converts a faer matrix into nalgebra's.
pub(crate) fn to_nalgebra(m: &Mat<f64>) -> DMatrix<f64> {
    DMatrix::from_fn(m.nrows(), m.ncols(), |r, c| m[(r, c)])
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DVector;

    /// Fits y = a * exp(b t) (nonlinear) and checks against the known answer.
    struct Exp {
        t: Vec<f64>,
        y: Vec<f64>,
    }

    impl Problem for Exp {
        fn n_residuals(&self) -> usize {
            self.t.len()
        }
        fn n_params(&self) -> usize {
            2
        }
        fn eval(&self, x: &[f64], r: &mut [f64], jac: Option<&mut Mat<f64>>) {
            for (i, (&t, &y)) in self.t.iter().zip(&self.y).enumerate() {
                r[i] = x[0] * (x[1] * t).exp() - y;
            }
            if let Some(j) = jac {
                for (i, &t) in self.t.iter().enumerate() {
                    j[(i, 0)] = (x[1] * t).exp();
                    j[(i, 1)] = x[0] * t * (x[1] * t).exp();
                }
            }
        }
    }

    #[test]
    fn converges_from_far_on_a_nonlinear_fit() {
        let t: Vec<f64> = (0..20).map(|i| i as f64 * 0.1).collect();
        let y = t.iter().map(|t| 2.5 * (-1.3 * t).exp()).collect();
        let p = Exp { t, y };
        let s = solve(&p, &[1.0, 0.5], None, &Options::default());
        assert!(s.converged);
        assert!(
            (s.x[0] - 2.5).abs() < 1e-10 && (s.x[1] + 1.3).abs() < 1e-10,
            "{:?}",
            s.x
        );
    }

    /// Rosenbrock's valley as least squares: `r = (10 (y - x^2), 1 - x)`.
    struct Valley {
        evaluations: std::cell::Cell<usize>,
    }

    impl Problem for Valley {
        fn n_residuals(&self) -> usize {
            2
        }
        fn n_params(&self) -> usize {
            2
        }
        fn eval(&self, x: &[f64], r: &mut [f64], jac: Option<&mut Mat<f64>>) {
            self.evaluations.set(self.evaluations.get() + 1);
            r[0] = 10.0 * (x[1] - x[0] * x[0]);
            r[1] = 1.0 - x[0];
            if let Some(j) = jac {
                j[(0, 0)] = -20.0 * x[0];
                j[(0, 1)] = 10.0;
                j[(1, 0)] = -1.0;
                j[(1, 1)] = 0.0;
            }
        }
    }

    /// Down a curved valley whose undamped steps fail, the adapted damping
    /// reaches the same minimum as the tenfold one, with no more
    /// evaluations.
    #[test]
    fn adapted_damping_reaches_the_minimum_of_a_curved_valley() {
        let run = |adapt_damping: bool| {
            let p = Valley {
                evaluations: std::cell::Cell::new(0),
            };
            let opts = Options {
                max_iter: 200,
                adapt_damping,
                ..Options::default()
            };
            let s = solve(&p, &[-1.2, 1.0], None, &opts);
            (s, p.evaluations.get())
        };
        let (fixed, n_fixed) = run(false);
        let (adapted, n_adapted) = run(true);
        for s in [&fixed, &adapted] {
            assert!(s.converged && s.cost < 1e-20, "{:?}", s.x);
            assert!((s.x[0] - 1.0).abs() < 1e-9 && (s.x[1] - 1.0).abs() < 1e-9);
        }
        assert!(n_adapted <= n_fixed, "{n_adapted} > {n_fixed}");
    }

    /// r = A x - b with a column that duplicates another: one direction is
    /// not identifiable and the step leaves it alone.
    struct Lin {
        a: DMatrix<f64>,
        b: DVector<f64>,
    }

    impl Problem for Lin {
        fn n_residuals(&self) -> usize {
            self.a.nrows()
        }
        fn n_params(&self) -> usize {
            self.a.ncols()
        }
        fn eval(&self, x: &[f64], r: &mut [f64], jac: Option<&mut Mat<f64>>) {
            let rv = &self.a * DVector::from_column_slice(x) - &self.b;
            r.copy_from_slice(rv.as_slice());
            if let Some(j) = jac {
                for i in 0..self.a.nrows() {
                    for k in 0..self.a.ncols() {
                        j[(i, k)] = self.a[(i, k)];
                    }
                }
            }
        }
    }

    /// A rotated normal's 6e-17 component once made a column of round-off
    /// pass for a strong direction, and the step went 1e10 along it.
    #[test]
    fn a_column_of_round_off_is_not_a_direction() {
        let a = DMatrix::from_row_slice(3, 2, &[1.0, 6e-17, 2.0, -3e-17, 0.5, 1e-17]);
        let b = DVector::from_column_slice(&[1.0, 2.0, 0.5]);
        let s = solve(&Lin { a, b }, &[0.0; 2], None, &Options::default());
        assert!((s.x[0] - 1.0).abs() < 1e-12 && s.x[1] == 0.0, "{:?}", s.x);
        let d = design(&s.jacobian, None, 1e-9);
        assert_eq!(d.rank, 1);
    }

    #[test]
    fn rank_deficient_directions_are_reported_and_left_alone() {
        let a = DMatrix::from_row_slice(4, 3, &[1., 1., 0., 2., 2., 1., 0., 0., 1., 1., 1., 3.]);
        let b = DVector::from_column_slice(&[2., 5., 1., 5.]);
        let p = Lin { a: a.clone(), b };
        let s = solve(&p, &[0.0; 3], None, &Options::default());
        // x0 + x1 is determined (= 2), x0 - x1 is not and stays at 0.
        assert!((s.x[0] + s.x[1] - 2.0).abs() < 1e-12 && (s.x[0] - s.x[1]).abs() < 1e-12);
        let d = design(&s.jacobian, None, 1e-9);
        assert_eq!((d.rank, d.free), (2, 3));
        let v = d.null.column(0);
        assert!((v[0] + v[1]).abs() < 1e-12 && v[2].abs() < 1e-12);
        // With the constraint x0 = x1 the problem becomes fully determined.
        let c = DMatrix::from_row_slice(1, 3, &[1.0, -1.0, 0.0]);
        let nb = constraint_basis(&c);
        let d = design(&s.jacobian, Some(&nb), 1e-9);
        assert_eq!((d.rank, d.free), (2, 2));
        // Covariance against the closed form (A^T A)^-1 on the subspace.
        let an = &a * &nb;
        let closed = &nb * (an.transpose() * &an).try_inverse().unwrap() * nb.transpose();
        assert!((d.cov_unit - closed).norm() < 1e-10);
    }

    /// The rank rule on spectra whose answer is plain: a gap of six orders
    /// of magnitude far below the largest cuts (the nine turns of
    /// probe-columns' columns); a spectrum that thins out by a thousand
    /// per step has no gap and keeps everything above the rounding floor;
    /// a gap whose lower side is not weak (1e-4 of the largest) does not
    /// cut; a gap above an even larger one cuts at the first one.
    #[test]
    fn the_rank_stops_at_a_gap_far_below_the_largest_value_and_nowhere_else() {
        let columns = [1.0, 0.6, 0.3, 0.1, 4e-7, 2e-7, 9e-8];
        assert_eq!(numerical_rank(&columns, 1e-9), 4);
        let thinning = [1.0, 1e-3, 1e-6, 1e-9 * 0.5];
        assert_eq!(numerical_rank(&thinning, 1e-9), 3);
        let strong = [1.0, 1e-4, 5e-5];
        assert_eq!(numerical_rank(&strong, 1e-9), 3);
        let two_gaps = [1.0, 0.5, 1e-6, 1e-6, 1e-11, 0.0];
        assert_eq!(numerical_rank(&two_gaps, 1e-12), 2);
        assert_eq!(numerical_rank(&[], 1e-9), 0);
        assert_eq!(numerical_rank(&[0.0, 0.0], 1e-9), 0);
    }

    /// A third column equal to the first but for a 1e-7 touch of its own:
    /// the linearized design all but repeats the first column, as a probed
    /// column turned about the point between its touches repeats its
    /// offsets. Counted as seen, that direction would take the fit to
    /// `x0 - x2` of the order of 1e6; it is not identifiable, the fit
    /// leaves it alone (the minimum-norm answer, the first and third
    /// columns sharing what they see) and converges, and the design
    /// names it as unseen.
    #[test]
    fn a_direction_seen_a_million_times_more_weakly_than_the_rest_is_left_alone() {
        let a = DMatrix::from_row_slice(
            5,
            3,
            &[
                1.0, 0.0, 1.0, //
                0.0, 1.0, 0.0, //
                1.0, 1.0, 1.0, //
                2.0, 0.0, 2.0, //
                0.0, 0.0, 1e-7,
            ],
        );
        let b = DVector::from_column_slice(&[1.0, 2.0, 3.5, 2.0, 0.3]);
        let s = solve(
            &Lin { a: a.clone(), b },
            &[0.0; 3],
            None,
            &Options::default(),
        );
        assert!(s.converged);
        assert!(s.x.iter().all(|v| v.abs() < 10.0), "{:?}", s.x);
        assert!((s.x[0] - s.x[2]).abs() < 1e-6, "{:?}", s.x);
        // What the two strong directions see: x0 + x2 and x1, as the least
        // squares of the rows without the weak one give them.
        let a2 = DMatrix::from_row_slice(4, 2, &[1.0, 0.0, 0.0, 1.0, 1.0, 1.0, 2.0, 0.0]);
        let b2 = DVector::from_column_slice(&[1.0, 2.0, 3.5, 2.0]);
        let ls = (a2.transpose() * &a2).try_inverse().unwrap() * (a2.transpose() * b2);
        assert!((s.x[0] + s.x[2] - ls[0]).abs() < 1e-6, "{:?} {ls}", s.x);
        assert!((s.x[1] - ls[1]).abs() < 1e-6, "{:?} {ls}", s.x);
        let jf = Mat::from_fn(5, 3, |r, c| a[(r, c)]);
        let d = design(&jf, None, 1e-9);
        assert_eq!((d.rank, d.null.ncols()), (2, 1));
        let v = d.null.column(0);
        assert!((v[0] + v[2]).abs() < 1e-6 && v[1].abs() < 1e-6, "{v}");
    }

    /// At the size of a discovery's C-axis map (hundreds of parameters,
    /// most of them fixed by constraints or unseen): the free directions
    /// and the design's null directions are orthonormal and exact, checked
    /// against the definitions (C N = 0, J null = 0) and the rank.
    #[test]
    fn free_and_null_directions_of_a_map_sized_problem_are_orthonormal_and_exact() {
        use rand::SeedableRng;
        use rand_distr::{Distribution, Uniform};
        let mut rng = rand::rngs::StdRng::seed_from_u64(17);
        let u = Uniform::new(-1.0, 1.0).unwrap();
        let n = 240;
        // 180 random constraints, then 20 repeated as sums of others: rank 180.
        let mut c = DMatrix::from_fn(200, n, |_, _| u.sample(&mut rng));
        for k in 180..200 {
            let row = c.row(k - 180) + c.row(k - 179) * 0.5;
            c.set_row(k, &row);
        }
        let nb = constraint_basis(&c);
        assert_eq!(nb.ncols(), n - 180);
        assert!((&c * &nb).amax() < 1e-10);
        let gram = nb.transpose() * &nb;
        assert!((gram - DMatrix::identity(n - 180, n - 180)).amax() < 1e-10);
        // A design that sees only 25 combinations of the 60 free ones.
        let seen = DMatrix::from_fn(300, 25, |_, _| u.sample(&mut rng));
        let mix = DMatrix::from_fn(25, n, |_, _| u.sample(&mut rng));
        let j = &seen * &mix;
        let jf = Mat::from_fn(j.nrows(), n, |r, k| j[(r, k)]);
        let d = design(&jf, Some(&nb), 1e-9);
        assert_eq!((d.rank, d.free, d.null.ncols()), (25, 60, 35));
        assert!((&j * &d.null).amax() < 1e-9 * j.amax());
        assert!((&c * &d.null).amax() < 1e-10);
        let gram = d.null.transpose() * &d.null;
        assert!((gram - DMatrix::identity(35, 35)).amax() < 1e-10);
    }

    /// A wide design (fewer residuals than parameters, as a map with more
    /// nodes than the test has points) and rank-deficient below that: the
    /// covariance is the pseudo-inverse of J^T J, the null directions are
    /// exact, and a linear fit from zero lands on the minimum-norm
    /// solution; each against nalgebra's own SVD of the unpadded matrix.
    #[test]
    fn a_wide_rank_deficient_design_gives_the_pseudo_inverse_and_the_minimum_norm_fit() {
        use rand::SeedableRng;
        use rand_distr::{Distribution, Uniform};
        let mut rng = rand::rngs::StdRng::seed_from_u64(23);
        let u = Uniform::new(-1.0, 1.0).unwrap();
        let (m, n, seen) = (20, 50, 12);
        let a = DMatrix::from_fn(m, seen, |_, _| u.sample(&mut rng));
        let b = DMatrix::from_fn(seen, n, |_, _| u.sample(&mut rng));
        // Columns of very different size, as micrometres beside microradians.
        let scale = DMatrix::from_fn(n, n, |i, k| {
            if i == k {
                10f64.powi((i % 5) as i32 - 2)
            } else {
                0.0
            }
        });
        let j = &a * &b * &scale;
        let jf = Mat::from_fn(m, n, |r, k| j[(r, k)]);
        let d = design(&jf, None, 1e-9);
        assert_eq!((d.rank, d.free, d.null.ncols()), (seen, n, n - seen));
        // The covariance alone is the design's, to the bit.
        let bits = |m: &DMatrix<f64>| m.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(
            bits(&covariance_ranked(&jf, None, 1e-9, None)),
            bits(&d.cov_unit)
        );
        assert!((&j * &d.null).amax() < 1e-9 * j.amax());
        let gram = d.null.transpose() * &d.null;
        assert!((gram - DMatrix::identity(n - seen, n - seen)).amax() < 1e-10);
        let pinv = (j.transpose() * &j)
            .pseudo_inverse(1e-9 * (j.transpose() * &j).amax())
            .unwrap();
        // Only the seen subspace is compared: the scaled and unscaled
        // pseudo-inverses differ on the directions the design cannot see.
        let proj = DMatrix::identity(n, n) - &d.null * d.null.transpose();
        let (x, y) = (&proj * &d.cov_unit * &proj, &proj * &pinv * &proj);
        assert!((&x - &y).amax() < 1e-6 * y.amax(), "{}", (&x - &y).amax());
        let y = DVector::from_fn(m, |_, _| u.sample(&mut rng));
        let problem = Lin {
            a: j.clone(),
            b: y.clone(),
        };
        let sol = solve(&problem, &vec![0.0; n], None, &Options::default());
        let x = DVector::from_column_slice(&sol.x);
        // The minimum-norm solution in the column-scaled parameters (every
        // column to unit length), which is what the fit moves along.
        let norms: Vec<f64> = (0..n).map(|k| j.column(k).norm()).collect();
        let js = DMatrix::from_fn(m, n, |r, k| j[(r, k)] / norms[k]);
        let z = js.pseudo_inverse(1e-12).unwrap() * &y;
        let reference = DVector::from_fn(n, |k, _| z[k] / norms[k]);
        assert!(
            (&x - &reference).amax() < 1e-8 * reference.amax(),
            "{}",
            (&x - &reference).amax()
        );
    }
}
