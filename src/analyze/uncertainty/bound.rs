//! The Cramér-Rao bound of a test's design: the smallest covariance any
//! unbiased estimator of the parameters can reach when every measured point
//! carries independent Gaussian noise of `sigma` along its surface normal.
//!
//! It is computed from the design alone (which points are measured at which
//! poses, and the machine they are measured on), at the true parameters,
//! with whatever forward model is given: the simulator's general model
//! ([`crate::simulate::forward`]) makes it independent of the rigid-pose
//! models the identification methods use, which is what lets the tests set
//! it beside the reported uncertainty and the spread of simulated runs. The
//! nuisance parameters of the test (the forward model's own, e.g. the setup
//! of each probed piece, and the CMM placement of a machined piece) are
//! estimated with the parameters, so the bound is their marginal: the
//! parameter block of `(J^T J)^+` on the constrained subspace, times
//! `sigma^2`.

use faer::Mat;
use nalgebra::DMatrix;

use crate::formats::manifest::TestKind;
use crate::identify::forward::ForwardModel;
use crate::identify::rigid::face_residual;
use crate::identify::{Dataset, Identifiability, IdentifyError, Setup, identifiability, lsq};

/// The bound of one design.
#[derive(Clone, Debug)]
pub struct Bound {
    /// Covariance bound of the model parameters (file units squared),
    /// restricted to the identifiable subspace.
    pub cov: DMatrix<f64>,
    /// What the design identifies (model parameters first, then the
    /// nuisance parameters).
    pub identifiability: Identifiability,
}

impl Bound {
    /// The bound on the standard uncertainty of parameter `i`, `None` where
    /// the design cannot identify it.
    pub fn u(&self, i: usize) -> Option<f64> {
        self.identifiability
            .is_identifiable(i)
            .then(|| self.cov[(i, i)].max(0.0).sqrt())
    }
}

/// The Cramér-Rao bound of the parameters of `setup` for the observations
/// of `data`, at the true values `theta` and the forward model's nuisance
/// `nuisance`, for noise `sigma_um` (um, standard deviation) per point
/// along its normal. A machined piece's CMM placement counts as six more
/// nuisance parameters, as in the global fit.
pub fn cramer_rao_bound(
    fm: &dyn ForwardModel,
    setup: &Setup,
    data: &Dataset,
    theta: &[f64],
    nuisance: &[f64],
    sigma_um: f64,
) -> Result<Bound, IdentifyError> {
    let n = setup.model.n_params();
    if fm.model().n_params() != n || theta.len() != n {
        return Err(IdentifyError::Data(
            "the forward model, the setup and the values differ in their parameters".into(),
        ));
    }
    let names_nuisance = fm.nuisance_names();
    let k = names_nuisance.len();
    if nuisance.len() != k {
        return Err(IdentifyError::Data(format!(
            "the forward model has {k} nuisance parameters, {} were given",
            nuisance.len()
        )));
    }
    let placement = data.kind == TestKind::Machining;
    let extra = k + if placement { 6 } else { 0 };
    let m = data.obs.len();
    let mut minutes = vec![0.0; m];
    for pose in &data.poses {
        for &o in &pose.obs {
            minutes[o] = pose.minutes;
        }
    }
    let jacobian = |theta: &[f64], nuisance: &[f64]| -> Result<Mat<f64>, IdentifyError> {
        let mut j = Mat::<f64>::zeros(m, n + extra);
        for (row, &t) in minutes.iter().enumerate() {
            let pred = fm.predict(theta, nuisance, data.point(row), t)?;
            // Noise-free: the measured point is the predicted one, so only
            // the derivatives of the point-to-face residual matter.
            let f = face_residual(&[0.0; 6], &pred.point, &pred.normal, &pred.point);
            for c in 0..n + k {
                let mut v = 0.0;
                for i in 0..3 {
                    v += f.d_q[i] * pred.d_point[(i, c)] + f.d_n[i] * pred.d_normal[(i, c)];
                }
                j[(row, c)] = v;
            }
            if placement {
                for i in 0..6 {
                    j[(row, n + k + i)] = f.d_rho[i];
                }
            }
        }
        Ok(j)
    };
    let basis = setup.basis(extra);
    let rtol = lsq::Options::default().rank_rtol;
    // What the design identifies is judged at the nominal machine, as the
    // methods judge it: at the true errors the exact model couples unseen
    // directions (a column's setup along its own faces) to seen ones by
    // terms of the order of the errors, which would count them as
    // identifiable with huge variances and inflate the bound.
    let nominal = lsq::design(&jacobian(&vec![0.0; n], &vec![0.0; k])?, Some(&basis), rtol);
    let design = lsq::design_ranked(
        &jacobian(theta, nuisance)?,
        Some(&basis),
        rtol,
        Some(nominal.rank),
    );
    let mut names = setup.model.param_names();
    names.extend(names_nuisance);
    if placement {
        names.extend(
            crate::identify::global::PLACEMENT_NAMES
                .iter()
                .map(|s| s.to_string()),
        );
    }
    let report = identifiability::report(&nominal, m, n, &names, &setup.constraint_names);
    Ok(Bound {
        cov: design.cov_unit.view((0, 0), (n, n)).into_owned() * (sigma_um * sigma_um),
        identifiability: report,
    })
}
