//! The least-squares fit of the readings: Gauss-Newton on the exact
//! measurement model ([`super::design`]), within the parameters the
//! convention allows, columns scaled to unit norm.
//!
//! What the readings see is decided once, on the nominal machine: the
//! singular value decomposition of the design there gives its rank and its
//! null directions (combinations of the parameters no reading sees). A
//! parameter with a share in a null direction is unseen and gets no
//! value; every other one is an estimable function of the readings. The
//! iteration then moves only within the seen directions: at an estimate
//! away from zero a null direction of the nominal design is no longer
//! exactly null (its singular value grows with the errors, to second
//! order), and a step along it would fit noise with a lever of millions.

use nalgebra::{DMatrix, DVector};

use super::design::{Design, KnownLinear, RANK_TOL, Reading, Runout};

/// Largest number of Gauss-Newton steps.
const MAX_STEPS: usize = 30;

/// A step smaller than this fraction of every parameter's noise-only u
/// (at unit noise) ends the iteration.
const STEP_TOL: f64 = 1e-6;

/// The fit.
#[derive(Clone, Debug)]
pub struct Fit {
    /// The parameters, in the model's order (unseen ones at zero or
    /// wherever the seen directions carry them: meaningless).
    pub theta: Vec<f64>,
    /// Whether each parameter is seen (an estimable function).
    pub seen: Vec<bool>,
    /// The null directions over the parameters, each a combination no
    /// reading sees (in parameter units, largest entry 1).
    pub null: Vec<DVector<f64>>,
    /// The gain: d theta / d reading at the solution (parameters x
    /// readings).
    pub gain: DMatrix<f64>,
    /// The residuals, um, reading minus model.
    pub residuals: DVector<f64>,
    /// Rank of the design.
    pub rank: usize,
    /// Gauss-Newton steps taken.
    pub steps: usize,
    /// Whether the steps converged.
    pub converged: bool,
}

/// What the readings see, on the nominal machine.
struct Seen {
    /// The seen directions over the parameters (n x rank).
    basis: DMatrix<f64>,
    seen: Vec<bool>,
    null: Vec<DVector<f64>>,
}

impl Seen {
    fn new(j: &DMatrix<f64>, allowed: &DMatrix<f64>) -> Seen {
        let n = j.nrows().max(allowed.ncols());
        // theta = B S^-1 w: the allowed parameters, columns scaled.
        let a = j * allowed;
        let scale: Vec<f64> = (0..a.ncols()).map(|c| a.column(c).norm()).collect();
        let scale = super::design::scaled(&scale);
        // Rows of zeros where the readings are fewer than the parameters,
        // so that V holds every direction, the null ones too.
        let m = a.nrows();
        let a = DMatrix::from_fn(n, a.ncols(), |r, c| {
            if r < m && scale[c].is_finite() {
                a[(r, c)] / scale[c]
            } else {
                0.0
            }
        });
        let svd = a.svd(false, true);
        let vt = svd.v_t.expect("asked for V^T");
        let sv = &svd.singular_values;
        let smax = sv.max().max(f64::MIN_POSITIVE);
        let bs = DMatrix::from_fn(allowed.nrows(), allowed.ncols(), |r, c| {
            allowed[(r, c)] / super::design::unit(scale[c])
        });
        let keep: Vec<usize> = (0..sv.len()).filter(|&i| sv[i] > smax * RANK_TOL).collect();
        let null_w: Vec<DVector<f64>> = (0..sv.len())
            .filter(|&i| sv[i] <= smax * RANK_TOL)
            .map(|i| vt.row(i).transpose())
            .collect();
        let seen = (0..allowed.nrows())
            .map(|p| {
                let row = bs.row(p).transpose();
                let norm = row.norm();
                norm > 0.0 && null_w.iter().all(|v| v.dot(&row).abs() <= 1e-6 * norm)
            })
            .collect();
        let basis = DMatrix::from_fn(allowed.nrows(), keep.len(), |r, c| {
            (bs.row(r) * vt.row(keep[c]).transpose())[(0, 0)]
        });
        let null = null_w
            .iter()
            .map(|v| {
                let t = &bs * v;
                let big = t.amax();
                if big > 0.0 { t / big } else { t }
            })
            .collect();
        Seen { basis, seen, null }
    }
}

/// Fits `rows` (their `um` the readings).
pub fn fit(d: &Design, rows: &[Reading], known: Option<&KnownLinear>, runout: &Runout) -> Fit {
    let n = d.n_params();
    let y = DVector::from_iterator(rows.len(), rows.iter().map(|r| r.um));
    let mut theta = vec![0.0; n];
    let (_, j0) = d.jacobian(rows, &theta, None, &Runout::default());
    let mut seen = Seen::new(&j0, &d.allowed());
    // A pinned node is zero by the convention: known, as a reference is.
    for &k in &d.pinned {
        seen.seen[k] = true;
    }
    let rank = seen.basis.ncols();
    let mut steps = 0;
    let mut converged = false;
    loop {
        let (f, j) = d.jacobian(rows, &theta, known, runout);
        let r = &y - &f;
        // The step within the seen directions: full column rank there.
        let gain = if rank == 0 {
            DMatrix::zeros(n, rows.len())
        } else {
            let a = &j * &seen.basis;
            let svd = a.svd(true, true);
            let pinv = svd
                .pseudo_inverse(0.0)
                .unwrap_or_else(|_| DMatrix::zeros(rank, rows.len()));
            &seen.basis * pinv
        };
        if converged || steps == MAX_STEPS {
            return Fit {
                theta,
                seen: seen.seen,
                null: seen.null,
                gain,
                residuals: r,
                rank,
                steps,
                converged,
            };
        }
        let step = &gain * &r;

        // The step against each seen parameter's spread at unit noise:
        // small everywhere, the fit has converged.
        let small = (0..n)
            .all(|k| !seen.seen[k] || step[k].abs() <= STEP_TOL * gain.row(k).norm().max(1e-300));
        for (t, s) in theta.iter_mut().zip(step.iter()) {
            *t += s;
        }
        steps += 1;
        converged = small;
    }
}
