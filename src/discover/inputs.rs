//! What a discovery reads: the plan rebuilt from its manifest
//! ([`crate::procedure::load`]) and the measurements of one test, read and
//! joined to the plan as `analyze` reads them ([`crate::analyze::inputs`]);
//! or measured points already in memory (from the simulator).

use std::path::{Path, PathBuf};

use crate::analyze::{AnalyzeError, PlanContext};
use crate::formats::detect::MeasuredOptions;
use crate::formats::measured::MeasuredPoint;
use crate::identify::Dataset;
use crate::kinematics::Kinematics;
use crate::procedure::{LoadError, Plan, Test};

/// Why the inputs cannot be read.
#[derive(Debug, thiserror::Error)]
pub enum InputError {
    /// The plan cannot be rebuilt.
    #[error(transparent)]
    Plan(#[from] LoadError),
    /// A measurement file is unreadable or belongs to another plan.
    #[error(transparent)]
    Measurement(#[from] AnalyzeError),
    /// The files do not suit a discovery.
    #[error("{0}")]
    Unsuitable(String),
}

/// The measurements of one test with the plan they measure.
#[derive(Clone, Debug)]
pub struct Inputs {
    /// The plan.
    pub plan: Plan,
    /// Kinematics with the plan's tool (or probe) as gauge length.
    pub kin: Kinematics,
    /// The measured points joined to the plan.
    pub data: Dataset,
}

pub use crate::simulate::plan_kinematics;

impl Inputs {
    /// Runs a discovery on these inputs (the story's test named after the
    /// plan).
    pub fn discover(
        &self,
        opts: &super::DiscoverOptions,
    ) -> Result<super::Discovery, super::DiscoverError> {
        let opts = super::DiscoverOptions {
            test: self.plan.test().to_string(),
            ..opts.clone()
        };
        super::run(&self.kin, &self.data, Some(&self.plan), &opts)
    }

    /// Reads the plan of `manifest` and the measurement files, with what
    /// the user said about them.
    pub fn load(
        manifest: &Path,
        measured: &[PathBuf],
        options: &MeasuredOptions,
    ) -> Result<Inputs, InputError> {
        let plan = crate::procedure::load(manifest)?;
        let mut ctx = PlanContext::from_plan(&plan, manifest);
        ctx.options = *options;
        let read = ctx.read(measured)?;
        if let Some((f, _)) = read.heights.first() {
            return Err(InputError::Unsuitable(format!(
                "{}: section heights say nothing about where the model and the piece disagree point by point: discover needs measured points",
                f.display()
            )));
        }
        suitable(&plan)?;
        let data = ctx.join(&read.points)?;
        Ok(Inputs {
            kin: ctx.kin,
            plan,
            data,
        })
    }

    /// The plan with measured points in memory (labelled, as a CSV file
    /// `label,x,y,z` holds them), named `source` in messages.
    pub fn from_points(
        plan: Plan,
        points: Vec<MeasuredPoint>,
        source: &Path,
    ) -> Result<Inputs, InputError> {
        suitable(&plan)?;
        let ctx = PlanContext::from_plan(&plan, source);
        let data = ctx.join_points(points, "csv", source)?;
        Ok(Inputs {
            kin: ctx.kin,
            plan,
            data,
        })
    }
}

/// Whether a discovery can work on the measurements of `plan`.
fn suitable(plan: &Plan) -> Result<(), InputError> {
    if plan.test() == Test::NineSection {
        return Err(InputError::Unsuitable(
            "the nine-section test is evaluated from its section heights by `analyze`; discover works on the stepped-square and the probing tests".into(),
        ));
    }
    Ok(())
}
