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
use crate::plan::LoadedPlan;

/// The method a test is analysed with unless asked otherwise: the sphere
/// method for the sphere test, the global fit for every other.
pub fn default_for(test: &str) -> Method {
    if test == "probe-sphere" {
        Method::Sphere
    } else {
        Method::Global
    }
}

/// Checks that `method` suits a test of `kind` and the maps asked for.
pub fn check(method: Method, test: &str, kind: TestKind, maps: &[String]) -> Result<(), String> {
    if method == Method::Sphere && kind != TestKind::Probing {
        return Err(format!(
            "--method sphere needs a probing plan (a calibration sphere); {test} is a machining test"
        ));
    }
    if method == Method::Sphere && !maps.is_empty() {
        return Err(
            "--maps needs the two-stage or global method; the sphere method identifies location errors only"
                .into(),
        );
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
    plan: Option<&LoadedPlan>,
) -> Result<Identification, IdentifyError> {
    if let (Method::Global, Some(plan)) = (method, plan)
        && rigid_refuses(&setup.model)
    {
        let fm = crate::simulate::forward::for_plan(&setup.model, plan)?;
        return identify::global::identify(fm.as_ref(), setup, data, &lsq::Options::default());
    }
    identify_with(method, setup, data, sphere)
}
