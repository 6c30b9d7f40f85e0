//! Which identification runs: the method a test takes by default, what each
//! method accepts, and the forward model behind the global method (the
//! rigid-pose models where they serve the model, the simulator's general
//! forward model of the plan where they refuse it: effects that vary within
//! a pose, head machines).

use crate::formats::manifest::TestKind;
use crate::identify::forward::RigidPoseMachining;
use crate::identify::sphere::SphereOptions;
use crate::identify::{self, Dataset, Identification, IdentifyError, Method, Setup, lsq};
use crate::model::Model;
use crate::procedure::{Plan, Test};

/// The method a test is analysed with unless asked otherwise: the sphere
/// method for the sphere test on a table-table machine (the method of
/// Cubas Brizuela & Yeh 2023, made for a trunnion whose two axes carry the sphere), the
/// global fit for every other test and for the sphere test on a machine
/// with a head: there the sphere does not move on the tilt axis, a pose
/// the head turns away from it may keep fewer than the four touches a
/// per-pose sphere needs, and the fit of every touch against the full
/// model identifies what the per-pose centres cannot.
pub fn default_for(test: Test, structure: crate::machine::Structure) -> Method {
    if test == Test::ProbeSphere && structure == crate::machine::Structure::TableTable {
        Method::Sphere
    } else {
        Method::Global
    }
}

/// Why a method does not suit a test.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum MethodError {
    /// The sphere method on a machining test.
    #[error("--method sphere needs a probing plan (a calibration sphere); {0} is a machining test")]
    SphereNeedsProbing(Test),
    /// The sphere method on another probing test.
    #[error(
        "--method sphere fits a sphere's centre at each pose and needs a probe-sphere plan; {0} probes planar faces: use the global (default) or two-stage method"
    )]
    SphereNeedsSpherePlan(Test),
    /// The two-stage method on the sphere test.
    #[error(
        "--method two-stage fits planar faces at each station; the sphere test's touches lie on a sphere: use the sphere or global method"
    )]
    TwoStageOnSphere,
    /// Maps with the sphere method.
    #[error(
        "--maps needs the two-stage or global method; the sphere method identifies location errors only"
    )]
    MapsNeedAnotherMethod,
}

/// Checks that `method` suits a test of `kind` and the maps asked for.
pub fn check(
    method: Method,
    test: Test,
    kind: TestKind,
    maps: &[String],
) -> Result<(), MethodError> {
    if method == Method::Sphere && kind != TestKind::Probing {
        return Err(MethodError::SphereNeedsProbing(test));
    }
    if method == Method::Sphere && test != Test::ProbeSphere {
        // A column's touches at one pose lie on its faces, not on a
        // sphere: a sphere fitted to them says nothing, and the fit's own
        // refusal ("four or more points ... 4 given") would blame the data.
        return Err(MethodError::SphereNeedsSpherePlan(test));
    }
    if method == Method::TwoStage && test == Test::ProbeSphere {
        // Its first stage fits each station's touches as points on planar
        // faces; a sphere set up a tenth of a millimetre off its place
        // leaves residuals as large as the probe's noise (the fit test
        // flags it), and the values follow them.
        return Err(MethodError::TwoStageOnSphere);
    }
    if method == Method::Sphere && !maps.is_empty() {
        return Err(MethodError::MapsNeedAnotherMethod);
    }
    Ok(())
}

/// Runs one identification method on a dataset, with the rigid-pose
/// forward models.
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
        Method::Sphere => match identify::forward::rigid_for(setup.model.clone(), data) {
            Ok(fm) => identify::sphere::identify_judged(setup, data, sphere, Some(fm.as_ref())),
            // A head machine: the complete model of the points needs the
            // plan ([`identify_with_plan`]); without it every symbol the
            // centres alone cannot vouch for is refused.
            Err(_) => {
                let mut est = identify::sphere::identify(setup, data, sphere)?;
                refuse_all(
                    &mut est,
                    "the sphere method on a head machine needs the plan to judge what the centres' lines see",
                );
                Ok(est)
            }
        },
    }
}

/// The identification a Monte-Carlo run repeats: the same estimator, the
/// reporting (what is identifiable) taken from the study's first fit, so
/// the sphere method's judge is not run again.
pub(crate) fn identify_for_study(
    method: Method,
    setup: &Setup,
    data: &Dataset,
    sphere: &SphereOptions,
    plan: Option<&Plan>,
) -> Result<Identification, IdentifyError> {
    match method {
        Method::Sphere => identify::sphere::identify(setup, data, sphere),
        _ => identify_with_plan(method, setup, data, sphere, plan),
    }
}

/// Marks every model parameter of `est` not identifiable, with `reason`.
fn refuse_all(est: &mut Identification, reason: &str) {
    for i in 0..est.theta.len() {
        let p = &mut est.identifiability.params[i];
        if p.identifiable {
            p.identifiable = false;
            p.aliased_with.clear();
        }
    }
    est.notes.push(reason.to_string());
}

/// Whether the rigid-pose forward models refuse `model` (effects that vary
/// within a pose, head machines): the global method then needs the plan
/// for the simulator's general forward model.
pub fn rigid_refuses(model: &Model) -> bool {
    RigidPoseMachining::new(model.clone()).is_err()
}

/// Whether the global method on `test` needs the plan for the simulator's
/// general forward model: where the rigid-pose models refuse the model, and
/// on the sphere test, whose touches the rigid-pose probing model takes on
/// tangent planes. A sphere set up 0.1 mm off its nominal place moves a
/// touch along its fixed approach by d^2 / 2R from that plane, about
/// 0.4 um on a 12.7 mm ball: as large as the probe's noise, so the
/// tangent-plane fit fails its goodness-of-fit test where the exact
/// intersection does not.
pub fn needs_plan(model: &Model, test: Test) -> bool {
    rigid_refuses(model) || test == Test::ProbeSphere
}

/// [`identify_with`], with the plan at hand: where [`needs_plan`], the
/// global method inverts the simulator's general forward model
/// ([`crate::simulate::forward`]) instead.
pub fn identify_with_plan(
    method: Method,
    setup: &Setup,
    data: &Dataset,
    sphere: &SphereOptions,
    plan: Option<&Plan>,
) -> Result<Identification, IdentifyError> {
    if let (Method::Global, Some(plan)) = (method, plan)
        && needs_plan(&setup.model, plan.test())
    {
        let fm = crate::simulate::forward::for_plan(&setup.model, plan)?;
        return identify::global::identify(fm.as_ref(), setup, data, &lsq::Options::default());
    }
    if let (Method::Sphere, Some(plan)) = (method, plan)
        && rigid_refuses(&setup.model)
    {
        let fm = crate::simulate::forward::for_plan(&setup.model, plan)?;
        return identify::sphere::identify_judged(setup, data, sphere, Some(fm.as_ref()));
    }
    identify_with(method, setup, data, sphere)
}
