//! The `global` method: one nonlinear least-squares fit of every measured
//! point to the exact forward model, the CMM placement of a machined piece
//! estimated with the parameters as six nuisance parameters.
//!
//! Each residual is the signed distance of a measured point from its
//! predicted surface, along the predicted normal (um). The placement is
//! `P = P0 D(rho)`, with `P0` from the reference features
//! ([`super::initial_placement`]) and `rho` in um and urad; any motion of
//! every pose together is absorbed by `rho`, which is how the fit is
//! "relative to the reference pose".

use std::cell::RefCell;

use faer::Mat;
use nalgebra::{DMatrix, Isometry3, Point3, Vector3};

use super::forward::{ForwardError, ForwardModel};
use super::lsq::{self, Problem};
use super::rigid::{d6_um, face_residual};
use super::{Dataset, Identification, IdentifyError, Method, Setup, identifiability, two_stage};
use crate::formats::manifest::TestKind;

/// Names of the placement nuisance parameters.
pub(crate) const PLACEMENT_NAMES: [&str; 6] = [
    "placement.dx",
    "placement.dy",
    "placement.dz",
    "placement.a",
    "placement.b",
    "placement.c",
];

/// What a fit compares its predictions with: the starting CMM placement
/// `P0` of a machined piece (from the reference features), the observed
/// points taken back through it, and each observation's pose time.
pub struct Observed {
    /// `P0`, for a machined piece; `None` for on-machine probing.
    pub p0: Option<Isometry3<f64>>,
    /// Observed points, `P0^-1 m` (or `m`).
    pub u: Vec<Vector3<f64>>,
    /// Minutes from the program start at the middle of each observation's pose.
    pub minutes: Vec<f64>,
}

/// [`Observed`] for a dataset.
pub(crate) fn observed(data: &Dataset) -> Result<Observed, IdentifyError> {
    let p0 = match data.kind {
        TestKind::Machining => Some(super::initial_placement(data)?),
        TestKind::Probing => None,
    };
    let u = data
        .obs
        .iter()
        .map(|o| match &p0 {
            Some(p) => (p.inverse() * Point3::from(o.m)).coords,
            None => o.m,
        })
        .collect();
    let mut minutes = vec![0.0; data.obs.len()];
    for pose in &data.poses {
        for &k in &pose.obs {
            minutes[k] = pose.minutes;
        }
    }
    Ok(Observed { p0, u, minutes })
}

struct GlobalProblem<'a> {
    fm: &'a dyn ForwardModel,
    data: &'a Dataset,
    /// Observed points before the nuisance placement (`P0^-1 m`, or `m`).
    u: Vec<Vector3<f64>>,
    minutes: Vec<f64>,
    placement: bool,
    n: usize,
    /// Number of the forward model's own nuisance parameters.
    k: usize,
    error: RefCell<Option<ForwardError>>,
}

impl Problem for GlobalProblem<'_> {
    fn n_residuals(&self) -> usize {
        self.u.len()
    }

    fn n_params(&self) -> usize {
        self.n + self.k + if self.placement { 6 } else { 0 }
    }

    fn eval(&self, x: &[f64], r: &mut [f64], mut jac: Option<&mut Mat<f64>>) {
        let theta = &x[..self.n];
        let nuisance = &x[self.n..self.n + self.k];
        let o = self.n + self.k;
        let rho = if self.placement {
            [x[o], x[o + 1], x[o + 2], x[o + 3], x[o + 4], x[o + 5]]
        } else {
            [0.0; 6]
        };
        for k in 0..self.u.len() {
            let point = self.data.point(k);
            let pred = match self.fm.predict(theta, nuisance, point, self.minutes[k]) {
                Ok(p) => p,
                Err(e) => {
                    *self.error.borrow_mut() = Some(e);
                    r[k] = f64::NAN;
                    continue;
                }
            };
            let f = face_residual(&rho, &pred.point, &pred.normal, &self.u[k]);
            r[k] = f.r;
            if let Some(j) = jac.as_deref_mut() {
                for c in 0..o {
                    let mut v = 0.0;
                    for i in 0..3 {
                        v += f.d_q[i] * pred.d_point[(i, c)] + f.d_n[i] * pred.d_normal[(i, c)];
                    }
                    j[(k, c)] = v;
                }
                if self.placement {
                    for i in 0..6 {
                        j[(k, o + i)] = f.d_rho[i];
                    }
                }
            }
        }
    }
}

/// Runs the global fit with the forward model `fm` (whose model must be
/// `setup.model`).
pub fn identify(
    fm: &dyn ForwardModel,
    setup: &Setup,
    data: &Dataset,
    opts: &lsq::Options,
) -> Result<Identification, IdentifyError> {
    fit(fm, setup, data, opts).map(|(id, _)| id)
}

/// The global fit's first-order response to its data: `gain[(i, k)]` is
/// how far parameter `i` of the estimate moves when measured point `k` moves
/// by 1 um along `dirs[k]`, a unit direction in the frame the fit compares
/// in (W for a machined piece once its CMM placement is taken off, the
/// probing frame for on-machine probing). It is the step the fit would take
/// from its own solution, `-J^+ dr`, with the Jacobian at the solution and
/// the rank of the design at the nominal machine, as the covariance is
/// taken: at the micrometre errors of a machine, a fit of slightly
/// different data lands there to first order (what lets a Monte-Carlo
/// study re-identify a draw without fitting it again).
pub fn response(
    fm: &dyn ForwardModel,
    setup: &Setup,
    data: &Dataset,
    dirs: &[Vector3<f64>],
    opts: &lsq::Options,
) -> Result<(Identification, DMatrix<f64>), IdentifyError> {
    let m = data.obs.len();
    if dirs.len() != m {
        return Err(IdentifyError::Data(format!(
            "{} directions for {m} measured points",
            dirs.len()
        )));
    }
    let (id, f) = fit(fm, setup, data, opts)?;
    let design = lsq::design_ranked(&f.jacobian, Some(&f.basis), opts.rank_rtol, Some(f.rank));
    let n = setup.model.n_params();
    let p = f.x.len();
    let theta = &f.x[..n];
    let nuisance = &f.x[n..n + f.k];
    let rho = if f.placement {
        f.x[n + f.k..n + f.k + 6].to_vec()
    } else {
        vec![0.0; 6]
    };
    // The residual is linear in the observed point: its change for a
    // 1 um move along the direction is exact as a difference.
    let mut dr = vec![0.0; m];
    for (k, d) in dr.iter_mut().enumerate() {
        let pred = fm.predict(theta, nuisance, data.point(k), f.minutes[k])?;
        let r0 = face_residual(&rho, &pred.point, &pred.normal, &f.u[k]).r;
        let r1 = face_residual(&rho, &pred.point, &pred.normal, &(f.u[k] + dirs[k] * 1e-3)).r;
        *d = r1 - r0;
    }
    // -J^+ = -(J^T J)^+ J^T on the identified subspace, parameter rows only.
    let cov = design.cov_unit.view((0, 0), (n, p)).into_owned();
    let mut gain = DMatrix::zeros(n, m);
    for k in 0..m {
        for c in 0..p {
            let j = f.jacobian[(k, c)];
            if j != 0.0 {
                for i in 0..n {
                    gain[(i, k)] -= cov[(i, c)] * j * dr[k];
                }
            }
        }
    }
    Ok((id, gain))
}

/// What [`fit`] leaves besides the identification: the solution and its
/// Jacobian, the constraint basis, the rank of the design at the nominal
/// machine and what the residuals compare with.
struct Fitted {
    x: Vec<f64>,
    jacobian: Mat<f64>,
    basis: DMatrix<f64>,
    rank: usize,
    k: usize,
    placement: bool,
    u: Vec<Vector3<f64>>,
    minutes: Vec<f64>,
}

fn fit(
    fm: &dyn ForwardModel,
    setup: &Setup,
    data: &Dataset,
    opts: &lsq::Options,
) -> Result<(Identification, Fitted), IdentifyError> {
    super::check_data(data, Method::Global)?;
    let n = setup.model.n_params();
    if fm.model().n_params() != n {
        return Err(IdentifyError::Data(
            "the forward model's parameters differ from the setup's".into(),
        ));
    }
    let Observed { p0, u, minutes } = observed(data)?;
    let placement = p0.is_some();
    let nuisance_names = fm.nuisance_names();
    let k = nuisance_names.len();
    let problem = GlobalProblem {
        fm,
        data,
        u: u.clone(),
        minutes: minutes.clone(),
        placement,
        n,
        k,
        error: RefCell::new(None),
    };
    let extra = k + if placement { 6 } else { 0 };
    let basis = setup.basis(extra);
    let x0 = vec![0.0; n + extra];
    let sol = lsq::solve(&problem, &x0, Some(&basis), opts);
    if !sol.cost.is_finite() {
        return Err(match problem.error.borrow_mut().take() {
            Some(e) => e.into(),
            None => {
                IdentifyError::Data("the fit failed: the residuals are not finite numbers".into())
            }
        });
    }
    // What the test can identify is a property of its design, judged at
    // the nominal machine: at the estimate, the exact model couples unseen
    // directions to seen ones by terms of the order of the errors (1e-4),
    // which says nothing about the test. The covariance is taken at the
    // estimate with that rank.
    let mut r0 = vec![0.0; data.obs.len()];
    let mut j0 = Mat::<f64>::zeros(data.obs.len(), n + extra);
    problem.eval(&x0, &mut r0, Some(&mut j0));
    let nominal = lsq::design(&j0, Some(&basis), opts.rank_rtol);
    let design = lsq::design_ranked(
        &sol.jacobian,
        Some(&basis),
        opts.rank_rtol,
        Some(nominal.rank),
    );
    let m = data.obs.len();
    let dof = m.saturating_sub(design.rank);
    let mut notes = Vec::new();
    let s2 = if dof > 0 {
        sol.cost / dof as f64
    } else {
        notes.push(
            "as many unknowns as measurements: the residuals cannot scale the covariance".into(),
        );
        f64::NAN
    };
    let mut names = setup.model.param_names();
    names.extend(nuisance_names);
    if placement {
        names.extend(PLACEMENT_NAMES.iter().map(|s| s.to_string()));
    }
    let report = identifiability::report(&nominal, m, n, &names, &setup.constraint_names);
    let cov = design.cov_unit.view((0, 0), (n, n)).into_owned() * s2;
    let placement_iso: Option<Isometry3<f64>> = p0.map(|p| p * d6_um(&sol.x[n + k..n + k + 6]));
    if !sol.converged {
        notes.push(format!(
            "the fit stopped after {} steps without converging",
            sol.iterations
        ));
    }
    let poses = two_stage::pose_fits(data, &setup.model.kin, placement_iso.as_ref());
    let id = Identification {
        method: Method::Global,
        model: setup.model.clone(),
        theta: sol.x[..n].to_vec(),
        cov,
        cov_unit: design.cov_unit.view((0, 0), (n, n)).into_owned(),
        identifiability: report,
        sigma_um: s2.sqrt(),
        dof,
        residuals: sol.residuals.clone(),
        poses,
        placement: placement_iso,
        notes,
        converged: sol.converged,
        set_aside: Vec::new(),
    };
    let fitted = Fitted {
        x: sol.x,
        jacobian: sol.jacobian,
        basis,
        rank: nominal.rank,
        k,
        placement,
        u,
        minutes,
    };
    Ok((id, fitted))
}

/// The residuals of every measured point against the complete measurement
/// model `fm` at an estimate another method made: what the verdict of
/// that method is computed from ([`crate::analyze::verdict`]).
#[derive(Clone, Debug)]
pub struct Judged {
    /// Residual of each observation, um (the dataset's order).
    pub residuals: Vec<f64>,
    /// Their sum of squares, um^2.
    pub cost: f64,
    /// Degrees of freedom: measured points less the directions the
    /// complete design sees (as [`identify`] counts them).
    pub dof: usize,
    /// Whether the fit of what is not held (nuisance, setup, placement,
    /// what the method does not report) converged.
    pub converged: bool,
    /// What the points say about the held parameters once everything free
    /// is fitted: `J_h^T (I - P_f) J_h` (um^2 per unit^2, held parameters
    /// in model order), the information a least-squares fit of them would
    /// have. A method's estimate off the least-squares one by `d` adds
    /// `d^T I d` to the squared residuals.
    pub information: DMatrix<f64>,
}

/// Fits every measured point to the complete model `fm`, the model
/// parameters marked `held` kept at `theta` (the values a method
/// reports), everything else free from there: the nuisance of the forward
/// model (the sphere's or the pieces' setups), a machined piece's CMM
/// placement, and the parameters the method does not report. The residuals
/// left are those of the method's estimate, whatever it did inside; for
/// the global method itself (nothing held that it did not fit) they are
/// its own.
pub fn judge_at(
    fm: &dyn ForwardModel,
    setup: &Setup,
    data: &Dataset,
    theta: &[f64],
    held: &[bool],
    opts: &lsq::Options,
) -> Result<Judged, IdentifyError> {
    let n = setup.model.n_params();
    if fm.model().n_params() != n || theta.len() != n || held.len() != n {
        return Err(IdentifyError::Data(
            "the estimate's parameters differ from the forward model's".into(),
        ));
    }
    let Observed { p0, u, minutes } = observed(data)?;
    let placement = p0.is_some();
    let k = fm.nuisance_names().len();
    let problem = GlobalProblem {
        fm,
        data,
        u,
        minutes,
        placement,
        n,
        k,
        error: RefCell::new(None),
    };
    let extra = k + if placement { 6 } else { 0 };
    let basis = setup.basis(extra);
    // The degrees of freedom of the complete design, judged at the nominal
    // machine as the global fit judges them.
    let zeros = vec![0.0; n + extra];
    let mut r0 = vec![0.0; data.obs.len()];
    let mut j0 = Mat::<f64>::zeros(data.obs.len(), n + extra);
    problem.eval(&zeros, &mut r0, Some(&mut j0));
    if let Some(e) = problem.error.borrow_mut().take() {
        return Err(e.into());
    }
    let nominal = lsq::design(&j0, Some(&basis), opts.rank_rtol);
    let dof = data.obs.len().saturating_sub(nominal.rank);
    // The free directions: those of the constraint basis that leave every
    // held parameter where it is (the null space of the basis' held rows).
    let free = held_fixed(&basis, held);
    let mut x0 = theta.to_vec();
    x0.extend(std::iter::repeat_n(0.0, extra));
    let sol = if free.ncols() == 0 {
        let mut r = vec![0.0; data.obs.len()];
        problem.eval(&x0, &mut r, None);
        let cost = r.iter().map(|v| v * v).sum();
        lsq::LsqSolution {
            x: x0,
            residuals: r,
            jacobian: Mat::zeros(0, 0),
            cost,
            iterations: 0,
            converged: true,
        }
    } else {
        // Along the directions the free parameters' own design sees at the
        // nominal machine: the setups of probed pieces have combinations
        // no touch sees, which a fit would otherwise wander along.
        let seen = lsq::design(&j0, Some(&free), opts.rank_rtol).rank;
        lsq::solve_ranked(&problem, &x0, Some(&free), opts, Some(seen))
    };
    if !sol.cost.is_finite() {
        return Err(match problem.error.borrow_mut().take() {
            Some(e) => e.into(),
            None => {
                IdentifyError::Data("the residuals at the estimate are not finite numbers".into())
            }
        });
    }
    // The Jacobian at the solution, split into held and free columns.
    let mut r = vec![0.0; data.obs.len()];
    let mut j = Mat::<f64>::zeros(data.obs.len(), n + extra);
    problem.eval(&sol.x, &mut r, Some(&mut j));
    let j = lsq::to_nalgebra(&j);
    let held_cols: Vec<usize> = (0..n).filter(|&i| held[i]).collect();
    let free_cols: Vec<usize> = (0..n + extra).filter(|&i| i >= n || !held[i]).collect();
    let jh = j.select_columns(&held_cols);
    let jh_perp = if free_cols.is_empty() {
        jh
    } else {
        let jf = j.select_columns(&free_cols);
        let svd = jf.svd(true, false);
        let smax = svd.singular_values.iter().fold(0.0f64, |a, &v| a.max(v));
        let u = svd.u.expect("U asked for");
        let keep: Vec<usize> = (0..svd.singular_values.len())
            .filter(|&k| svd.singular_values[k] > opts.rank_rtol * smax)
            .collect();
        let ur = u.select_columns(&keep);
        let proj = &ur * (ur.transpose() * &jh);
        jh - proj
    };
    Ok(Judged {
        residuals: sol.residuals,
        cost: sol.cost,
        dof,
        converged: sol.converged,
        information: jh_perp.transpose() * &jh_perp,
    })
}

/// The columns of `basis` (orthonormal) combined so that every row marked
/// `held` is zero: the directions that move no held parameter.
fn held_fixed(basis: &DMatrix<f64>, held: &[bool]) -> DMatrix<f64> {
    let rows: Vec<usize> = (0..held.len()).filter(|&i| held[i]).collect();
    if rows.is_empty() {
        return basis.clone();
    }
    let h = basis.select_rows(&rows);
    let q = basis.ncols();
    let eig = nalgebra::SymmetricEigen::new(h.transpose() * &h);
    let scale = eig.eigenvalues.iter().fold(1.0f64, |a, &v| a.max(v.abs()));
    let keep: Vec<usize> = (0..q)
        .filter(|&c| eig.eigenvalues[c].abs() <= 1e-10 * scale)
        .collect();
    let null = eig.eigenvectors.select_columns(&keep);
    basis * null
}
