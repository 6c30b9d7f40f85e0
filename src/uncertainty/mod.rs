//! Uncertainty of the identified parameters.
//!
//! Every method returns the covariance of its estimate, scaled by the
//! residuals (`Identification::cov`): what the measurement noise alone
//! allows. The systematic contributors of the seeds (linear-axis errors,
//! squareness, setup) only show in a Monte-Carlo study: draw a machine that
//! has the identified errors plus random contributors ([`contributors`]),
//! simulate the test, identify again, and take the spread of the estimates
//! ([`montecarlo`]). [`simulated`] runs the plan again on the simulator
//! for that; [`synthetic_run`] (the foundation's rigid-pose model,
//! [`crate::identify::synthetic`]) remains for a points file whose plan
//! cannot be rebuilt. [`bound`] gives the Cramér-Rao bound of a test's
//! design, the floor under every method's uncertainty.

pub mod bound;
pub mod contributors;
pub mod montecarlo;
pub mod simulated;

use std::collections::HashMap;

use nalgebra::{DMatrix, Isometry3, Vector3};
use rand::Rng;

use crate::formats::detect::PointSet;
use crate::formats::manifest::TestKind;
use crate::formats::points::PlanPoints;
use crate::identify::forward::RigidPoseMachining;
use crate::identify::sphere::SphereOptions;
use crate::identify::{
    self, Dataset, Identification, IdentifyError, Method, Setup, lsq, synthetic,
};
use crate::model::Model;

pub use bound::{Bound, cramer_rao_bound};
pub use contributors::{Contributors, Disturbance};
pub use montecarlo::{McOptions, McResult};

/// Runs one identification method on a dataset.
pub fn identify_with(
    method: Method,
    setup: &Setup,
    data: &Dataset,
    sphere: &SphereOptions,
) -> Result<Identification, IdentifyError> {
    let opts = lsq::Options::default();
    match method {
        Method::Global => {
            let fm = identify::forward::rigid_for(setup.model.clone(), data)?;
            identify::global::identify(fm.as_ref(), setup, data, &opts)
        }
        Method::TwoStage => identify::two_stage::identify(setup, data, &opts),
        Method::Sphere => identify::sphere::identify(setup, data, sphere),
    }
}

/// Whether the rigid-pose forward models refuse `model` (effects that vary
/// within a pose, head machines): the global method then needs the plan
/// for the simulator's general forward model.
pub fn rigid_refuses(model: &Model) -> bool {
    RigidPoseMachining::new(model.clone()).is_err()
}

/// [`identify_with`], with the plan at hand: where the rigid-pose models
/// refuse the model, the global method inverts the simulator's general
/// forward model ([`crate::simulate::forward`]) instead.
pub fn identify_with_plan(
    method: Method,
    setup: &Setup,
    data: &Dataset,
    sphere: &SphereOptions,
    plan: Option<&crate::plan::LoadedPlan>,
) -> Result<Identification, IdentifyError> {
    if let (Method::Global, Some(plan)) = (method, plan)
        && rigid_refuses(&setup.model)
    {
        let fm = crate::simulate::forward::for_plan(&setup.model, plan)?;
        return identify::global::identify(fm.as_ref(), setup, data, &lsq::Options::default());
    }
    identify_with(method, setup, data, sphere)
}

/// What a synthetic Monte-Carlo run needs to know about the test.
#[derive(Clone, Debug)]
pub struct SyntheticTest<'a> {
    /// The identification whose values are taken as the truth.
    pub estimate: &'a Identification,
    /// The parameterisation to identify again.
    pub setup: &'a Setup,
    /// The measured dataset (its observed points are simulated).
    pub data: &'a Dataset,
    /// The method.
    pub method: Method,
    /// Sphere-method options.
    pub sphere: SphereOptions,
    /// For a sphere test: the sphere's centre in W and its radius, mm.
    pub sphere_geometry: Option<(Vector3<f64>, f64)>,
    /// The contributors.
    pub contributors: Contributors,
}

/// The plan restricted to the points that were measured, so a synthetic
/// run measures what the real one did.
fn measured_plan(data: &Dataset) -> PlanPoints {
    PlanPoints {
        tilt_letter: data.plan.tilt_letter,
        points: data
            .obs
            .iter()
            .map(|o| data.plan.points[o.plan].clone())
            .collect(),
    }
}

/// One synthetic run: the identified values (non-identifiable ones at
/// zero) plus one draw of the contributors, simulated with the foundation
/// model, identified again; returns the estimate (NaN where not
/// identifiable).
pub fn synthetic_run<R: Rng + ?Sized>(
    t: &SyntheticTest<'_>,
    rng: &mut R,
) -> Result<Vec<f64>, String> {
    let est = t.estimate;
    let kin = &est.model.kin;
    let d = t.contributors.sample(kin, rng);
    let mut effects = est.model.effects.clone();
    effects.extend(d.effects.iter().cloned());
    let truth = Model::new(kin.clone(), effects);
    let mut theta: Vec<f64> = est
        .theta
        .iter()
        .enumerate()
        .map(|(i, v)| if est.identifiable(i) { *v } else { 0.0 })
        .collect();
    theta.extend_from_slice(&d.theta);
    let plan = measured_plan(t.data);
    let minutes: HashMap<String, f64> = t
        .data
        .poses
        .iter()
        .map(|p| (p.id.clone(), p.minutes))
        .collect();
    let points = match (t.data.kind, t.method) {
        (TestKind::Probing, Method::Sphere) => {
            let (c, r) = t
                .sphere_geometry
                .ok_or("a sphere run needs the sphere's position and radius")?;
            synthetic::probed_sphere(&truth, &theta, &plan, &c, r, d.noise_um, rng)
        }
        (TestKind::Probing, _) => {
            // Each separately clamped piece sits where its own clamping put it.
            let mut setups = vec![d.setup];
            for _ in 1..t.data.pieces.len() {
                setups.push(t.contributors.sample_setup(rng));
            }
            let piece_of: HashMap<&str, usize> = t
                .data
                .plan
                .points
                .iter()
                .zip(&t.data.piece_of)
                .map(|(p, &k)| (p.label.as_str(), k))
                .collect();
            let setup = |p: &crate::formats::points::PlanPoint| {
                setups[piece_of.get(p.label.as_str()).copied().unwrap_or(0)]
            };
            synthetic::probed_with(&truth, &theta, &plan, &minutes, d.noise_um, &setup, rng)
        }
        (TestKind::Machining, _) => {
            let placement = est.placement.unwrap_or_else(Isometry3::identity);
            synthetic::machined(&truth, &theta, &plan, &minutes, d.noise_um, &placement, rng)
        }
    };
    let set = PointSet {
        format: "synthetic",
        points,
        labeled: true,
        nominals: Vec::new(),
        warnings: Vec::new(),
    };
    let mins: HashMap<String, (f64, f64)> =
        minutes.iter().map(|(k, v)| (k.clone(), (*v, *v))).collect();
    let data = identify::data::join(
        &t.data.plan,
        t.data.kind,
        &mins,
        &[("synthetic".into(), set)],
        &|p| p.p,
    )
    .map_err(|e| e.to_string())?;
    let mut data = data;
    data.pieces = t.data.pieces.clone();
    data.piece_of = t.data.piece_of.clone();
    let r = identify_with(t.method, t.setup, &data, &t.sphere).map_err(|e| e.to_string())?;
    Ok(r.estimates_or_nan())
}

/// The method's own covariance for noise `sigma_um` per point,
/// `sigma^2 cov_unit`: the Cramér-Rao bound when the method is efficient
/// (the global fit), above it otherwise (seed 000's two-stage form, the
/// sphere method). The bound of the design itself is
/// [`cramer_rao_bound`].
pub fn cramer_rao(est: &Identification, sigma_um: f64) -> DMatrix<f64> {
    &est.cov_unit * (sigma_um * sigma_um)
}
