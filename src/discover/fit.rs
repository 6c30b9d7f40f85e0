//! Fitting a model to a test's measurements, sized for the hundreds of
//! refits a discovery makes: the `global` identification (one nonlinear
//! least-squares fit of every point to the exact forward model, the CMM
//! placement of a machined piece and the forward model's own nuisance
//! estimated with the parameters; residuals in um along the predicted
//! normal) with the placement's starting point found once per dataset, the
//! design at the nominal machine kept for the identifiability analysis,
//! and no per-pose fits.
//!
//! The forward model is chosen in one place, [`forward_model`]: the
//! rigid-pose models of `identify::forward` until the simulator's general
//! model lands.

use std::cell::RefCell;
use std::ops::Range;

use faer::Mat;
use nalgebra::{DMatrix, Isometry3, Point3, Vector3};

use crate::formats::manifest::TestKind;
use crate::identify::forward::{ForwardError, ForwardModel, RigidPoseMachining, RigidPoseProbing};
use crate::identify::global::PLACEMENT_NAMES;
use crate::identify::identifiability::{self, Identifiability};
use crate::identify::lsq::{self, Design, Problem};
use crate::identify::rigid::{d6_um, face_residual};
use crate::identify::{Dataset, IdentifyError, Setup, initial_placement};
use crate::model::{Effect, Model};

/// The forward model `discover` fits with: the one seam to change when a
/// more general model is available.
pub fn forward_model(model: Model, data: &Dataset) -> Result<Box<dyn ForwardModel>, ForwardError> {
    match data.kind {
        TestKind::Machining => Ok(Box::new(RigidPoseMachining::new(model)?)),
        TestKind::Probing => {
            let piece_of = data
                .plan
                .points
                .iter()
                .zip(&data.piece_of)
                .map(|(p, &k)| (p.label.clone(), k))
                .collect();
            Ok(Box::new(RigidPoseProbing::with_pieces(
                model,
                data.pieces.clone(),
                piece_of,
            )?))
        }
    }
}

/// A model to fit: effects in order, each with its story name and its own
/// defining constraints.
#[derive(Clone, Debug)]
pub struct Spec {
    /// The model.
    pub model: Model,
    /// Story name of each effect (`location`, `drift.EZ0B/seq`, ...).
    pub names: Vec<String>,
    /// Per effect: constraint rows on its own parameters, with what each
    /// says.
    pub constraints: Vec<Vec<(Vec<f64>, String)>>,
}

impl Spec {
    /// An empty model of `model.kin`.
    pub fn empty(model: Model) -> Spec {
        Spec {
            model: Model::new(model.kin.clone(), Vec::new()),
            names: Vec::new(),
            constraints: Vec::new(),
        }
    }

    /// Appends an effect.
    pub fn push(&mut self, name: &str, effect: Effect, constraints: Vec<(Vec<f64>, String)>) {
        self.model.push(effect);
        self.names.push(name.to_string());
        self.constraints.push(constraints);
    }

    /// Index of the effect named `name`.
    pub fn find(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n == name)
    }

    /// The orthonormal basis of the parameter directions the constraints
    /// leave free, block by block (so that each free direction belongs to
    /// one effect), extended by `extra` unconstrained nuisance parameters;
    /// and the range of basis columns of each effect.
    pub fn basis(&self, extra: usize) -> (DMatrix<f64>, Vec<Range<usize>>) {
        let n = self.model.n_params();
        let mut blocks = Vec::new();
        let mut free = 0;
        for (ei, rows) in self.constraints.iter().enumerate() {
            let r = self.model.param_range(ei);
            let c = DMatrix::from_fn(rows.len(), r.len(), |i, j| rows[i].0[j]);
            let b = lsq::constraint_basis(&c);
            blocks.push((r, b));
        }
        let mut ranges = Vec::new();
        for (_, b) in &blocks {
            ranges.push(free..free + b.ncols());
            free += b.ncols();
        }
        let mut out = DMatrix::zeros(n + extra, free + extra);
        for ((r, b), zr) in blocks.iter().zip(&ranges) {
            out.view_mut((r.start, zr.start), (r.len(), zr.len()))
                .copy_from(b);
        }
        for i in 0..extra {
            out[(n + i, free + i)] = 1.0;
        }
        (out, ranges)
    }

    /// The same model as the identification's [`Setup`] (constraints
    /// stacked), for the reports built on it.
    pub fn setup(&self) -> Setup {
        let n = self.model.n_params();
        let rows: usize = self.constraints.iter().map(|c| c.len()).sum();
        let mut c = DMatrix::zeros(rows, n);
        let mut names = Vec::new();
        let mut k = 0;
        for (ei, rs) in self.constraints.iter().enumerate() {
            let o = self.model.param_range(ei).start;
            for (row, name) in rs {
                for (j, v) in row.iter().enumerate() {
                    c[(k, o + j)] = *v;
                }
                names.push(name.clone());
                k += 1;
            }
        }
        Setup {
            model: self.model.clone(),
            constraints: c,
            constraint_names: names,
        }
    }

    /// All constraint names, in order.
    pub fn constraint_names(&self) -> Vec<String> {
        self.constraints
            .iter()
            .flat_map(|c| c.iter().map(|x| x.1.clone()))
            .collect()
    }
}

/// Why a fit cannot be made.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum FitError {
    /// The forward model cannot serve the model.
    #[error(transparent)]
    Forward(#[from] ForwardError),
    /// The identification cannot start (placement, data).
    #[error(transparent)]
    Identify(#[from] IdentifyError),
    /// The residuals are not finite.
    #[error("the fit failed: the residuals are not finite numbers")]
    NotFinite,
}

/// The dataset prepared once for every fit: the observed points before the
/// nuisance placement and each observation's time.
pub struct Fitter<'a> {
    /// The measurements.
    pub data: &'a Dataset,
    p0: Option<Isometry3<f64>>,
    u: Vec<Vector3<f64>>,
    minutes: Vec<f64>,
    /// Least-squares options.
    pub opts: lsq::Options,
}

struct FitProblem<'a> {
    fm: &'a dyn ForwardModel,
    f: &'a Fitter<'a>,
    n: usize,
    k: usize,
    error: RefCell<Option<ForwardError>>,
}

impl Problem for FitProblem<'_> {
    fn n_residuals(&self) -> usize {
        self.f.u.len()
    }

    fn n_params(&self) -> usize {
        self.n + self.k + if self.f.p0.is_some() { 6 } else { 0 }
    }

    fn eval(&self, x: &[f64], r: &mut [f64], mut jac: Option<&mut Mat<f64>>) {
        let theta = &x[..self.n];
        let nuisance = &x[self.n..self.n + self.k];
        let o = self.n + self.k;
        let placement = self.f.p0.is_some();
        let rho = if placement {
            [x[o], x[o + 1], x[o + 2], x[o + 3], x[o + 4], x[o + 5]]
        } else {
            [0.0; 6]
        };
        for k in 0..self.f.u.len() {
            let point = self.f.data.point(k);
            let pred = match self.fm.predict(theta, nuisance, point, self.f.minutes[k]) {
                Ok(p) => p,
                Err(e) => {
                    *self.error.borrow_mut() = Some(e);
                    r[k] = f64::NAN;
                    continue;
                }
            };
            let fr = face_residual(&rho, &pred.point, &pred.normal, &self.f.u[k]);
            r[k] = fr.r;
            if let Some(j) = jac.as_deref_mut() {
                for c in 0..o {
                    let mut v = 0.0;
                    for i in 0..3 {
                        v += fr.d_q[i] * pred.d_point[(i, c)] + fr.d_n[i] * pred.d_normal[(i, c)];
                    }
                    j[(k, c)] = v;
                }
                if placement {
                    for i in 0..6 {
                        j[(k, o + i)] = fr.d_rho[i];
                    }
                }
            }
        }
    }
}

/// A model ready to fit: its forward model and its design at the nominal
/// machine.
pub struct Prepared<'a> {
    fitter: &'a Fitter<'a>,
    /// The model.
    pub spec: Spec,
    fm: Box<dyn ForwardModel>,
    /// Names of every parameter: the model's, the forward model's
    /// nuisance, the placement.
    pub names: Vec<String>,
    /// Number of model parameters.
    pub n: usize,
    k: usize,
    /// Number of nuisance parameters (forward model's and placement).
    pub extra: usize,
    /// The Jacobian at the nominal machine (all parameters).
    pub j0: Mat<f64>,
}

/// A fitted model.
#[derive(Clone, Debug)]
pub struct Fit {
    /// The model.
    pub spec: Spec,
    /// Every parameter: the model's, then nuisance and placement.
    pub x: Vec<f64>,
    /// Number of model parameters.
    pub n: usize,
    /// Names of every parameter.
    pub names: Vec<String>,
    /// Residual of each observation, um (measured minus predicted along
    /// the predicted normal).
    pub residuals: Vec<f64>,
    /// Sum of squared residuals, um^2.
    pub rss: f64,
    /// Rank of the design at the nominal machine (free directions seen).
    pub rank: usize,
    /// `(J^T J)^+` at the estimate, every parameter (per um^2 of noise).
    pub cov_unit: DMatrix<f64>,
    /// What the test identifies of this model.
    pub identifiability: Identifiability,
    /// The CMM placement (W to CMM) of a machined piece.
    pub placement: Option<Isometry3<f64>>,
    /// Whether a stopping test ended the fit.
    pub converged: bool,
}

impl Fit {
    /// The model parameters.
    pub fn theta(&self) -> &[f64] {
        &self.x[..self.n]
    }

    /// Degrees of freedom of the residuals.
    pub fn dof(&self) -> usize {
        self.residuals.len().saturating_sub(self.rank)
    }

    /// Residual standard deviation, um (NaN without degrees of freedom).
    pub fn sigma(&self) -> f64 {
        match self.dof() {
            0 => f64::NAN,
            d => (self.rss / d as f64).sqrt(),
        }
    }

    /// Standard uncertainty of model parameter `i` (residual-scaled),
    /// `None` where the test does not identify it.
    pub fn u(&self, i: usize) -> Option<f64> {
        self.identifiability
            .is_identifiable(i)
            .then(|| (self.cov_unit[(i, i)].max(0.0)).sqrt() * self.sigma())
    }

    /// Covariance of the model parameters, residual-scaled.
    pub fn cov(&self) -> DMatrix<f64> {
        let s2 = self.sigma().powi(2);
        self.cov_unit.view((0, 0), (self.n, self.n)).into_owned() * s2
    }
}

impl<'a> Fitter<'a> {
    /// Prepares `data`: the placement's starting point of a machined piece
    /// from its reference features.
    pub fn new(data: &'a Dataset) -> Result<Fitter<'a>, FitError> {
        let p0 = match data.kind {
            TestKind::Machining => Some(initial_placement(data)?),
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
        Ok(Fitter {
            data,
            p0,
            u,
            minutes,
            opts: lsq::Options::default(),
        })
    }

    /// Number of observations.
    pub fn len(&self) -> usize {
        self.u.len()
    }

    /// Whether there are no observations.
    pub fn is_empty(&self) -> bool {
        self.u.is_empty()
    }

    /// Builds the forward model of `spec` and its design at the nominal
    /// machine.
    pub fn prepare(&self, spec: Spec) -> Result<Prepared<'_>, FitError> {
        let fm = forward_model(spec.model.clone(), self.data)?;
        let n = spec.model.n_params();
        let nuisance = fm.nuisance_names();
        let k = nuisance.len();
        let mut names = spec.model.param_names();
        // A drift's parameter is named with its clock: the same symbol may
        // drift per pose and per minute.
        for (ei, e) in spec.model.effects.iter().enumerate() {
            if let Effect::Drift { basis, .. } = e {
                let i = spec.model.param_range(ei).start;
                names[i] = format!("{}/{}", names[i], basis.name());
            }
        }
        names.extend(nuisance);
        if self.p0.is_some() {
            names.extend(PLACEMENT_NAMES.iter().map(|s| s.to_string()));
        }
        let extra = names.len() - n;
        let problem = FitProblem {
            fm: fm.as_ref(),
            f: self,
            n,
            k,
            error: RefCell::new(None),
        };
        let m = self.u.len();
        let mut r = vec![0.0; m];
        let mut j0 = Mat::<f64>::zeros(m, n + extra);
        problem.eval(&vec![0.0; n + extra], &mut r, Some(&mut j0));
        if let Some(e) = problem.error.into_inner() {
            return Err(e.into());
        }
        if r.iter().any(|v| !v.is_finite()) {
            return Err(FitError::NotFinite);
        }
        Ok(Prepared {
            fitter: self,
            spec,
            fm,
            names,
            n,
            k,
            extra,
            j0,
        })
    }
}

impl Prepared<'_> {
    /// The design at the nominal machine with the model's constraints, and
    /// the basis columns of each effect.
    pub fn design(&self) -> (Design, DMatrix<f64>, Vec<Range<usize>>) {
        let (basis, ranges) = self.spec.basis(self.extra);
        let d = lsq::design(&self.j0, Some(&basis), self.fitter.opts.rank_rtol);
        (d, basis, ranges)
    }

    /// The fit: from the nominal machine (so that the rank decided at the
    /// start is the design's; see [`lsq::solve`]), the covariance at the
    /// estimate with that rank.
    pub fn fit(&self) -> Result<Fit, FitError> {
        let (d0, basis, _) = self.design();
        let f = self.fitter;
        let problem = FitProblem {
            fm: self.fm.as_ref(),
            f,
            n: self.n,
            k: self.k,
            error: RefCell::new(None),
        };
        let x0 = vec![0.0; self.n + self.extra];
        let sol = lsq::solve(&problem, &x0, Some(&basis), &f.opts);
        if !sol.cost.is_finite() {
            return Err(match problem.error.into_inner() {
                Some(e) => e.into(),
                None => FitError::NotFinite,
            });
        }
        let design =
            lsq::design_ranked(&sol.jacobian, Some(&basis), f.opts.rank_rtol, Some(d0.rank));
        let setup = self.spec.setup();
        let report = identifiability::report(
            &d0,
            f.u.len(),
            self.n,
            &self.names,
            &setup.constraint_names,
            &setup.quality_axes(),
        );
        let o = self.n + self.k;
        let placement = f.p0.map(|p| p * d6_um(&sol.x[o..o + 6]));
        Ok(Fit {
            spec: self.spec.clone(),
            x: sol.x.clone(),
            n: self.n,
            names: self.names.clone(),
            residuals: sol.residuals,
            rss: sol.cost,
            rank: d0.rank,
            cov_unit: design.cov_unit,
            identifiability: report,
            placement,
            converged: sol.converged,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Machine;
    use crate::kinematics::Kinematics;

    #[test]
    fn basis_is_block_diagonal_and_respects_each_effects_constraints() {
        let kin = Kinematics::new(&Machine::builtin("bc-trunnion").unwrap());
        let mut spec = Spec::empty(Model::new(kin, Vec::new()));
        spec.push(
            "location",
            Effect::Location {
                symbols: vec![0, 1],
            },
            Vec::new(),
        );
        let grid = crate::kinematics::maps::MapGrid {
            dims: vec![
                crate::kinematics::maps::MapDim::new(0, &[-90.0, 0.0, 90.0], false).unwrap(),
            ],
        };
        spec.push(
            "map.EBB(B)",
            Effect::Map { symbol: 4, grid },
            vec![(vec![1.0, 1.0, 1.0], "averages to zero".into())],
        );
        let (b, ranges) = spec.basis(6);
        assert_eq!(b.shape(), (2 + 3 + 6, 2 + 2 + 6));
        assert_eq!(ranges, vec![0..2, 2..4]);
        // Orthonormal columns; the map's span its own rows and sum to zero.
        assert!((b.transpose() * &b - DMatrix::identity(10, 10)).norm() < 1e-12);
        for c in 2..4 {
            let col = b.column(c);
            assert!(col.rows(0, 2).norm() < 1e-15 && col.rows(5, 6).norm() < 1e-15);
            assert!(col.rows(2, 3).sum().abs() < 1e-12);
        }
        assert_eq!(spec.setup().constraints.shape(), (1, 5));
    }
}
