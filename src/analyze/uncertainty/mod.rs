//! Uncertainty of the identified parameters.
//!
//! Every method returns the covariance of its estimate, scaled by the
//! residuals (`Identification::cov`): what the measurement noise alone
//! allows. The systematic contributors of the papers (linear-axis errors,
//! squareness, setup) only show in a Monte-Carlo study: draw a machine that
//! has the identified errors plus random contributors ([`contributors`]),
//! simulate the test, identify again, and take the spread of the estimates
//! ([`montecarlo`]). [`simulated`] runs the plan again on the simulator
//! for that; [`synthetic_run`] (the foundation's rigid-pose model,
//! [`crate::identify::synthetic`]) remains for a points file whose plan
//! cannot be rebuilt. [`bound`] gives the Cramér-Rao bound of a test's
//! design, the floor under every method's uncertainty. [`study`] is the
//! entry `analyze --mc` takes: the simulator where the plan can be rebuilt,
//! the synthetic model otherwise.

pub mod bound;
pub mod budget;
pub mod contributors;
pub mod linear;
pub mod montecarlo;
pub mod simulated;

use std::collections::HashMap;

use nalgebra::{DMatrix, Isometry3, Vector3};
use rand::Rng;

use crate::formats::detect::PointSet;
use crate::formats::manifest::TestKind;
use crate::formats::points::PlanPoints;
use crate::identify::sphere::SphereOptions;
use crate::identify::{self, Dataset, Identification, Method, Setup, synthetic};
use crate::model::Model;

pub use bound::Bound;
pub use bound::cramer_rao_bound;
pub use budget::{Budget, Group};
pub use contributors::{Contributors, Disturbance};
pub use montecarlo::{McOptions, McResult};

use super::method::identify_for_study;
use crate::procedure::Plan;

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
    let r =
        identify_for_study(t.method, t.setup, &data, &t.sphere, None).map_err(|e| e.to_string())?;
    Ok(r.estimates_or_nan())
}

/// The method's own covariance for noise `sigma_um` per point,
/// `sigma^2 cov_unit`: the Cramér-Rao bound when the method is efficient
/// (the global fit), above it otherwise (Ibaraki, Iritani & Matsushita's (2013) two-stage form, the
/// sphere method). The bound of the design itself is
/// [`cramer_rao_bound`].
pub fn cramer_rao(est: &Identification, sigma_um: f64) -> DMatrix<f64> {
    &est.cov_unit * (sigma_um * sigma_um)
}

/// An identification with what produced it, as a Monte-Carlo study takes it.
#[derive(Clone, Copy, Debug)]
pub struct Estimate<'a> {
    /// The identification whose values are taken as the truth.
    pub est: &'a Identification,
    /// The parameterisation it identified.
    pub setup: &'a Setup,
    /// The measured dataset.
    pub data: &'a Dataset,
    /// Sphere-method options.
    pub sphere: SphereOptions,
}

/// One identifiable parameter's uncertainty by both routes.
#[derive(Clone, Debug, PartialEq)]
pub struct StudyRow {
    /// The parameter.
    pub name: String,
    /// From the method's covariance.
    pub covariance: Option<f64>,
    /// The spread of the Monte-Carlo runs (NaN where no run estimated it).
    pub monte_carlo: f64,
}

/// A Monte-Carlo study of one identification (`analyze --mc`).
#[derive(Clone, Debug)]
pub struct Study {
    /// The spread of the runs.
    pub result: McResult,
    /// The study's seed.
    pub seed: u64,
    /// How the runs were made: on the simulator, or with the synthetic
    /// model and why.
    pub how: String,
    /// Contributors the study leaves out.
    pub not_included: Vec<String>,
    /// The identifiable parameters: covariance and Monte-Carlo `u`.
    pub rows: Vec<StudyRow>,
    /// Runs that failed, if some did.
    pub warning: Option<String>,
    /// The Birge ratio the spread is widened by when the model does not
    /// fit: the runs draw the stated noise, the measurements show more.
    pub widened: Option<f64>,
}

impl Study {
    /// Widens the study's uncertainties by the Birge ratio `factor` of a
    /// fit that failed (nothing when it is 1 or less).
    pub fn widen(&mut self, factor: f64) {
        if factor > 1.0 {
            self.widened = Some(factor);
            for r in &mut self.rows {
                r.monte_carlo *= factor;
            }
        }
    }

    /// The uncertainties to report: the study's spread for every
    /// identifiable parameter (none where no run estimated it), the
    /// covariance's for the rest.
    pub fn u(&self, est: &Identification) -> Vec<Option<f64>> {
        let mut u = est.u();
        for (i, ui) in u.iter_mut().enumerate() {
            if est.identifiable(i) {
                let s = self.result.std[i] * self.widened.unwrap_or(1.0);
                *ui = s.is_finite().then_some(s);
            }
        }
        u
    }
}

/// The uncertainty budget of a global fit's estimate for `plan` (the plan
/// the measured points describe) with `contributors`, in closed form
/// ([`budget`]); the reason where there is none: a points file whose plan
/// cannot be rebuilt, a method whose response is not linear, a
/// contributor the closed form cannot take.
pub fn budget_of(
    e: &Estimate<'_>,
    plan: Result<&Plan, String>,
    contributors: Contributors,
) -> Result<Budget, String> {
    let plan = simulator_plan(plan, e.data)?;
    let study = linear::LinearStudy::new(plan, e, contributors).map_err(|e| e.to_string())?;
    let b = study.budget().map_err(|e| e.to_string())?;
    if b.variance.iter().all(|v| v.is_finite()) {
        Ok(b)
    } else {
        Err("the budget is not a finite number".into())
    }
}

/// The plan the simulator runs again, if it is the plan the measured
/// points describe (same labels at the same places).
fn simulator_plan<'p>(plan: Result<&'p Plan, String>, data: &Dataset) -> Result<&'p Plan, String> {
    let plan = plan?;
    let rebuilt = plan.plan_points();
    let same = rebuilt.points.len() == data.plan.points.len()
        && rebuilt
            .points
            .iter()
            .zip(&data.plan.points)
            .all(|(a, b)| a.label == b.label && (a.p - b.p).norm() < 1e-5);
    if !same {
        return Err(
            "the points file is not the one the plan's template gives (edited by hand?)".into(),
        );
    }
    Ok(plan)
}

/// The sphere's centre in W and its radius, from the reference pose's
/// contact points.
fn sphere_geometry(est: &Identification, data: &Dataset) -> Option<(Vector3<f64>, f64)> {
    let pose = &data.poses[0];
    let pts: Vec<Vector3<f64>> = pose.obs.iter().map(|&k| data.obs[k].m).collect();
    let s = identify::sphere::fit_centre(&pts)?;
    let t = est.model.kin.nominal_table_transform(pose.tilt, pose.c);
    Some((
        (t.inverse() * nalgebra::Point3::from(s.centre)).coords,
        s.radius,
    ))
}

/// Runs the Monte-Carlo study of an identification: on the simulator with
/// `plan` (rebuilt from the manifest) when it is the plan the points
/// describe, linearized ([`linear`]) unless `exact` or the contributors hold
/// what a linear study cannot draw (then every run is simulated again,
/// [`simulated`]), else with the synthetic rigid-pose model, saying why.
/// Fails when fewer than two runs return estimates.
pub fn study(
    opts: &McOptions,
    contributors: Contributors,
    e: &Estimate<'_>,
    plan: Result<&Plan, String>,
    exact: bool,
) -> Result<Study, String> {
    let est = e.est;
    let rebuilt = simulator_plan(plan, e.data);
    let (result, how) = match &rebuilt {
        Ok(plan) => {
            let linear = if exact {
                Err(None)
            } else {
                linear::LinearStudy::new(plan, e, contributors.clone()).map_err(Some)
            };
            match linear {
                Ok(lin) => (
                    montecarlo::run(opts, est.theta.len(), |_, r| lin.run(r)),
                    "on the simulator, linearized (each draw mapped to the measurements by the forward model's Jacobians at the estimate and re-identified by the fit's own response; --mc-exact simulates and fits every run)"
                        .to_string(),
                ),
                Err(why) => {
                    let t = simulated::SimulatedTest::from_estimate(
                        plan,
                        est,
                        e.setup,
                        e.data,
                        e.sphere,
                        contributors,
                    );
                    let mut how = "on the simulator (the plan run again with the estimate and the contributors)"
                        .to_string();
                    if let Some(why) = why {
                        how += &format!(", every run simulated: {why}");
                    }
                    (
                        montecarlo::run(opts, est.theta.len(), |_, r| {
                            simulated::simulated_run(&t, r)
                        }),
                        how,
                    )
                }
            }
        }
        Err(why) => {
            let sphere_geometry = (est.method == Method::Sphere)
                .then(|| sphere_geometry(est, e.data))
                .flatten();
            let t = SyntheticTest {
                estimate: est,
                setup: e.setup,
                data: e.data,
                method: est.method,
                sphere: e.sphere,
                sphere_geometry,
                contributors,
            };
            (
                montecarlo::run(opts, est.theta.len(), |_, r| synthetic_run(&t, r)),
                format!(
                    "with synthetic measurements from the rigid-pose model, not the simulator: the plan cannot be rebuilt from its manifest ({why})"
                ),
            )
        }
    };
    if let Some(s) = result.stopped {
        return Err(format!(
            "the Monte-Carlo study of {} runs stopped at --max-seconds {} with {} runs done ({:.0} s): a u from fewer runs than asked is not reported; give fewer runs with --mc or more time",
            opts.runs,
            opts.max_seconds.unwrap_or(s.seconds),
            s.done,
            s.seconds
        ));
    }
    if result.runs < 2 {
        return Err(result
            .failed
            .1
            .clone()
            .unwrap_or_else(|| "no run returned estimates".into()));
    }
    let warning = (result.failed.0 > 0).then(|| {
        format!(
            "{} of {} Monte-Carlo runs failed (first: {})",
            result.failed.0,
            opts.runs,
            result.failed.1.clone().unwrap_or_default()
        )
    });
    let mut not_included = Vec::new();
    if rebuilt.is_err() {
        for s in ["directional pre-travel", "the sphere's form error"] {
            not_included.push(format!("{s} (only the simulator applies it)"));
        }
    }
    not_included.extend(Contributors::unmapped().iter().map(|s| s.to_string()));
    let names = est.model.param_names();
    let u = est.u();
    let rows = (0..u.len())
        .filter(|&i| est.identifiable(i))
        .map(|i| StudyRow {
            name: names[i].clone(),
            covariance: u[i],
            monte_carlo: result.std[i],
        })
        .collect();
    Ok(Study {
        result,
        seed: opts.seed,
        how,
        not_included,
        rows,
        warning,
        widened: None,
    })
}
