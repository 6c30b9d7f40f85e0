//! One test's measurements in a discovery, as the catalogue (which
//! candidates the parts can show) and the fitter both take them.

use crate::identify::Dataset;
use crate::kinematics::Kinematics;
use crate::procedure::Plan;

/// One test's measurements in a discovery: a discovery may fit the
/// measurements of several tests of one machine together (a test and the
/// supplementary test that separates what the first could not), each with
/// its own plan, gauge length (tool or probe), forward model and nuisance
/// (CMM placement, sphere position, setups), sharing the model's
/// parameters.
#[derive(Clone, Copy, Debug)]
pub struct Part<'a> {
    /// The plan's machine with its tool's or probe's gauge length.
    pub kin: &'a Kinematics,
    /// The measurements joined to the plan.
    pub data: &'a Dataset,
    /// The plan, when known (else the rigid-pose models serve).
    pub plan: Option<&'a Plan>,
    /// Its name in the nuisance names of several parts (the test's).
    pub label: &'a str,
}
