//! What a discovery reads: the plan rebuilt from its manifest
//! ([`crate::plan::load_any`]) and the measurement files of one test, read
//! in whatever format they are ([`crate::formats::detect`]) and joined to
//! the plan's points ([`crate::identify::data::join`]), as `analyze` reads
//! them; or measured points already in memory (from the simulator).

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use nalgebra::{Point3, Vector3};

use crate::formats::detect::{self, Measurement, PointSet, ReadContext};
use crate::formats::manifest::TestKind;
use crate::formats::measured::MeasuredPoint;
use crate::formats::points::PlanPoint;
use crate::formats::probe_log::ReadOptions;
use crate::identify::Dataset;
use crate::identify::data::join;
use crate::kinematics::Kinematics;
use crate::plan::{LoadError, LoadedPlan};
use crate::source::SourceError;

/// Why the inputs cannot be read.
#[derive(Debug, thiserror::Error)]
pub enum InputError {
    /// The plan cannot be rebuilt.
    #[error(transparent)]
    Plan(#[from] LoadError),
    /// A measurement file is unreadable or belongs to another plan.
    #[error(transparent)]
    Source(#[from] SourceError),
    /// The files do not suit a discovery.
    #[error("{0}")]
    Unsuitable(String),
}

/// The measurements of one test with the plan they measure.
#[derive(Clone, Debug)]
pub struct Inputs {
    /// The plan.
    pub plan: LoadedPlan,
    /// Kinematics with the plan's tool (or probe) as gauge length.
    pub kin: Kinematics,
    /// The measured points joined to the plan.
    pub data: Dataset,
}

pub use crate::simulate::plan_kinematics;

/// How the probe logs of a probing plan are read.
fn probe_options(plan: &LoadedPlan) -> Option<ReadOptions> {
    let p = plan.probing()?;
    let mut o = ReadOptions::for_plan(p.template.probing(), p.probe.ball_diameter / 2.0);
    o.test = Some(p.test.clone());
    Some(o)
}

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

    /// Reads the plan of `manifest` and the measurement files.
    pub fn load(manifest: &Path, measured: &[PathBuf]) -> Result<Inputs, InputError> {
        let plan = crate::plan::load_any(manifest)?;
        let kin = plan_kinematics(&plan);
        let points = plan.plan_points();
        let probe = probe_options(&plan);
        let ctx = ReadContext {
            plan: Some(&points),
            kin: Some(&kin),
            dialect: Some(plan.dialect()),
            probe: probe.as_ref(),
        };
        let mut sets = Vec::new();
        for f in measured {
            match detect::read_measurement_in(f, &ctx)? {
                Measurement::Points(s) => sets.push((f.clone(), s)),
                Measurement::Heights(_) => {
                    return Err(InputError::Unsuitable(format!(
                        "{}: section heights say nothing about where the model and the piece disagree point by point: discover needs measured points",
                        f.display()
                    )));
                }
            }
        }
        Inputs::join(plan, kin, &sets)
    }

    /// The plan with measured points in memory (labelled, in the meaning
    /// of SPEC section 3), named `source` in messages.
    pub fn from_points(
        plan: LoadedPlan,
        points: Vec<MeasuredPoint>,
        source: &Path,
    ) -> Result<Inputs, InputError> {
        let kin = plan_kinematics(&plan);
        let set = PointSet {
            format: "csv",
            points,
            labeled: true,
            nominals: Vec::new(),
            warnings: Vec::new(),
        };
        Inputs::join(plan, kin, &[(source.to_path_buf(), set)])
    }

    fn join(
        plan: LoadedPlan,
        kin: Kinematics,
        sets: &[(PathBuf, PointSet)],
    ) -> Result<Inputs, InputError> {
        if plan.test() == "nine-section" {
            return Err(InputError::Unsuitable(
                "the nine-section test is evaluated from its section heights by `analyze`; discover works on the stepped-square and the probing tests".into(),
            ));
        }
        let points = plan.plan_points();
        let minutes: HashMap<String, (f64, f64)> = plan
            .poses()
            .iter()
            .map(|p| (p.pose.clone(), (p.start_min, p.end_min)))
            .collect();
        let kind = plan.kind();
        let nominal = |p: &PlanPoint| -> Vector3<f64> {
            match kind {
                TestKind::Machining => p.p,
                TestKind::Probing => {
                    (kin.nominal_table_transform(p.tilt, p.c) * Point3::from(p.p)).coords
                }
            }
        };
        let mut data = join(&points, kind, &minutes, sets, &nominal)?;
        if let Some(p) = plan.probing() {
            let piece: HashMap<String, String> = p
                .plan
                .touches
                .iter()
                .map(|t| (t.label.clone(), t.piece.clone()))
                .collect();
            data.set_pieces(&piece).map_err(InputError::Unsuitable)?;
        }
        Ok(Inputs { plan, kin, data })
    }
}
