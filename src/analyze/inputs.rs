//! Reading the measurements of a plan: every measurement file is read in
//! whatever format it is ([`crate::formats::detect`]) and its points are
//! joined to the plan's points ([`crate::identify::data::join`]). This is
//! the one place that does it, for `analyze`, `discover`, the demo and the
//! Monte-Carlo runs on the simulator.
//!
//! What the files are read against is a [`PlanContext`]: the plan's points,
//! pose times, kinematics (the tool's or the probe's gauge length), how its
//! probe logs read, and which probed piece each touch is on. It comes from
//! the files of a plan directory ([`PlanContext::from_manifest`]: the
//! written points and the copies beside the manifest, which is all
//! `analyze` needs, even for a points file edited by hand) or from a plan
//! rebuilt in memory ([`PlanContext::from_plan`]: its points at full
//! precision).

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use nalgebra::{Point3, Vector3};

use super::AnalyzeError;
use crate::formats::detect::{self, MeasuredOptions, Measurement, PointSet, ReadContext};
use crate::formats::heights::SectionHeight;
use crate::formats::manifest::{Manifest, TestKind};
use crate::formats::measured::MeasuredPoint;
use crate::formats::points::{PlanPoint, PlanPoints};
use crate::formats::probe_log;
use crate::identify::Dataset;
use crate::kinematics::Kinematics;
use crate::machine::{Dialect, Machine};
use crate::procedure::Plan;
use crate::procedure::probing::columns::ColumnsTemplate;
use crate::procedure::probing::sphere::SphereTemplate;
use crate::procedure::{TemplateSource, Test};
use crate::shape_fit::SphereCheck;

/// Which probed piece each touch is on, by label.
#[derive(Clone, Debug, PartialEq)]
pub enum Pieces {
    /// One piece (a machined piece, a sphere), or not known.
    One,
    /// From the plan in memory: every plan point has its piece.
    Planned(HashMap<String, String>),
    /// From the probing plan rebuilt out of the template copy: where it
    /// does not cover the points (a points file edited by hand), they are
    /// taken as one rigid setup, with a warning.
    Rebuilt(HashMap<String, String>),
}

/// What the measurements of one plan are read and joined against.
#[derive(Clone, Debug)]
pub struct PlanContext {
    /// The manifest, for messages.
    pub manifest: PathBuf,
    /// The test name.
    pub test: Test,
    /// Machining or probing.
    pub kind: TestKind,
    /// The dialect of the plan's program (its logs' format).
    pub dialect: Dialect,
    /// The plan's machine with the tool's (machining) or the probe's
    /// (probing) gauge length.
    pub kin: Kinematics,
    /// The plan's points; `None` for a nine-section plan without points
    /// (its heights are measured with a micrometer).
    pub points: Option<PlanPoints>,
    /// Each pose's (start, end) minutes from the program start.
    pub minutes: HashMap<String, (f64, f64)>,
    /// For a probing plan: how its logs are read.
    pub probe_log: Option<probe_log::ReadOptions>,
    /// For a sphere plan: the plausibility check of each pose's sphere
    /// (contact points lie on the sphere itself).
    pub sphere_check: Option<SphereCheck>,
    /// Which piece each touch is on.
    pub pieces: Pieces,
    /// What the reader should know (a probing plan that cannot be rebuilt).
    pub warnings: Vec<String>,
    /// What the user said about the measurement files (run, units,
    /// encoding).
    pub options: MeasuredOptions,
}

/// The files of a measurement, by what they hold.
#[derive(Clone, Debug, Default)]
pub struct Measurements {
    /// Point files (CMM output, probe logs, point lists), in the order given.
    pub points: Vec<(PathBuf, PointSet)>,
    /// Nine-section heights, in the order given.
    pub heights: Vec<(PathBuf, Vec<SectionHeight>)>,
}

/// Below this, a measured point is where the plan puts it, mm: the last
/// digit measurement files are written with (4 decimals in mm); a CMM's
/// noise alone is several times larger.
const COPY_MM: f64 = 1e-4;

/// When every point of file `file` lies where the plan puts it (on the
/// nominal point itself, or on the plan's point as written; for a machined
/// piece also after the best rigid placement, as a CMM's frame may have
/// it), the largest difference, mm: such a file is no measurement.
fn copy_of_nominal(
    data: &Dataset,
    file: usize,
    nominal: &dyn Fn(&PlanPoint) -> Vector3<f64>,
) -> Option<f64> {
    let obs: Vec<_> = data.obs.iter().filter(|o| o.file == file).collect();
    if obs.is_empty() {
        return None;
    }
    let largest = |target: &dyn Fn(&PlanPoint) -> Vector3<f64>| {
        obs.iter()
            .map(|o| (o.m - target(&data.plan.points[o.plan])).norm())
            .fold(0.0, f64::max)
    };
    let mut best = largest(nominal).min(largest(&|p: &PlanPoint| p.p));
    if data.kind == TestKind::Machining && obs.len() >= 3 {
        let w: Vec<Vector3<f64>> = obs.iter().map(|o| data.plan.points[o.plan].p).collect();
        let m: Vec<Vector3<f64>> = obs.iter().map(|o| o.m).collect();
        if let Ok(t) = crate::placement::kabsch(&w, &m) {
            best = best.min(largest(&|p: &PlanPoint| (t * Point3::from(p.p)).coords));
        }
    }
    (best < COPY_MM).then_some(best)
}

/// Where a plan point is measured without any error, in the frame of the
/// measured points before placement: the point itself in W for a CMM, the
/// point carried by the nominal rotary axes for on-machine probing.
fn nominal(kin: &Kinematics, kind: TestKind, p: &PlanPoint) -> Vector3<f64> {
    match kind {
        TestKind::Machining => p.p,
        TestKind::Probing => (kin.nominal_table_transform(p.tilt, p.c) * Point3::from(p.p)).coords,
    }
}

/// Each touch's piece, by label, from a probing plan's touches.
fn touch_pieces<'a>(touches: impl Iterator<Item = (&'a str, &'a str)>) -> HashMap<String, String> {
    touches
        .map(|(label, piece)| (label.to_string(), piece.to_string()))
        .collect()
}

/// The sphere check of a sphere template for contact points, which lie on
/// the sphere itself (no stylus ball radius added).
fn contact_check(t: &SphereTemplate) -> SphereCheck {
    t.sphere_check(0.0)
}

impl PlanContext {
    /// The context of a plan directory: the manifest, the points it wrote,
    /// and the copies of the machine file and template beside it.
    pub fn from_manifest(manifest_path: &Path) -> Result<PlanContext, AnalyzeError> {
        let manifest = Manifest::read(manifest_path)?;
        let machine_path = manifest.resolve(manifest_path, &manifest.machine_file);
        if !machine_path.exists() {
            return Err(AnalyzeError::Plan(format!(
                "{}: the plan's copy of the machine file, {}, is missing",
                manifest_path.display(),
                machine_path.display()
            )));
        }
        let machine =
            Machine::from_file(&machine_path, "the plan's machine copy").map_err(|source| {
                AnalyzeError::Machine {
                    path: machine_path.clone(),
                    source,
                }
            })?;
        let gauge = match manifest.kind {
            TestKind::Machining => manifest
                .tool
                .as_ref()
                .map_or(machine.tool.length, |t| t.length),
            TestKind::Probing => manifest
                .probe
                .as_ref()
                .map_or(machine.probe.length, |p| p.length),
        };
        let kin = Kinematics::with_gauge_length(&machine, gauge);
        let points = match manifest.file(manifest_path, "points") {
            None if manifest.test == Test::NineSection => None,
            None => {
                return Err(AnalyzeError::Plan(format!(
                    "{}: the manifest lists no `points` file",
                    manifest_path.display()
                )));
            }
            Some(p) => {
                let points = PlanPoints::read(&p)?;
                if points.tilt_letter != machine.tilt.letter {
                    return Err(AnalyzeError::Plan(format!(
                        "{}: the points are for a machine with a {} axis, the plan's machine has {}",
                        p.display(),
                        points.tilt_letter,
                        machine.tilt.letter
                    )));
                }
                Some(points)
            }
        };
        let mut ctx = PlanContext {
            manifest: manifest_path.to_path_buf(),
            test: manifest.test,
            kind: manifest.kind,
            dialect: manifest.dialect,
            kin,
            points,
            minutes: manifest
                .poses
                .iter()
                .map(|p| (p.pose.clone(), (p.start_min, p.end_min)))
                .collect(),
            probe_log: None,
            sphere_check: None,
            pieces: Pieces::One,
            warnings: Vec::new(),
            options: MeasuredOptions::default(),
        };
        if manifest.kind == TestKind::Probing {
            ctx.read_probing_template(&manifest, &machine)?;
        }
        Ok(ctx)
    }

    /// A probing plan's template copy gives the probing window its logs
    /// are checked against, the sphere's size, and the columns' pieces.
    fn read_probing_template(
        &mut self,
        manifest: &Manifest,
        machine: &Machine,
    ) -> Result<(), AnalyzeError> {
        let ball = manifest
            .probe
            .as_ref()
            .map_or(machine.probe.ball_diameter, |p| p.ball_diameter)
            / 2.0;
        let path = manifest.resolve(&self.manifest, &manifest.template_file);
        let text =
            crate::input::read_text(&path, "plan's template copy", crate::limits::MAX_YAML_BYTES)?;
        let source = TemplateSource { path, text };
        let settings = match manifest.test {
            Test::ProbeSphere => {
                let t = SphereTemplate::parse(source)?;
                self.sphere_check = Some(contact_check(&t));
                t.probing
            }
            Test::ProbeColumns => {
                let t = ColumnsTemplate::parse(source)?;
                // The columns are clamped one by one: each has its own
                // setup. The plan rebuilt from the copies says which touch
                // is on which.
                match crate::procedure::probing::columns::touch_plan(machine, &t) {
                    Ok(p) => {
                        self.pieces = Pieces::Rebuilt(touch_pieces(
                            p.touches
                                .iter()
                                .map(|t| (t.label.as_str(), t.piece.as_str())),
                        ))
                    }
                    Err(e) => self.warnings.push(format!(
                        "cannot rebuild the probing plan ({e}); the columns are taken as one rigid setup"
                    )),
                }
                t.probing
            }
            other @ (Test::SteppedSquare | Test::NineSection) => {
                return Err(AnalyzeError::Plan(format!(
                    "{}: `{other}` is not a probing test",
                    self.manifest.display()
                )));
            }
        };
        let mut o = probe_log::ReadOptions::for_plan(&settings, ball);
        o.test = Some(manifest.test);
        self.probe_log = Some(o);
        Ok(())
    }

    /// The context of a plan rebuilt in memory from `manifest` (or planned
    /// there): its points at full precision, its pose times, its probe and
    /// its touches' pieces.
    pub fn from_plan(plan: &Plan, manifest: &Path) -> PlanContext {
        let mut ctx = PlanContext {
            manifest: manifest.to_path_buf(),
            test: plan.test(),
            kind: plan.kind(),
            dialect: plan.dialect(),
            kin: crate::simulate::plan_kinematics(plan),
            points: Some(plan.plan_points()),
            minutes: plan
                .poses()
                .into_iter()
                .map(|p| (p.pose, (p.start_min, p.end_min)))
                .collect(),
            probe_log: None,
            sphere_check: None,
            pieces: Pieces::One,
            warnings: Vec::new(),
            options: MeasuredOptions::default(),
        };
        if let Some(p) = plan.probing() {
            ctx.probe_log = Some(p.read_options());
            if let crate::procedure::Template::Sphere(t) = &p.template {
                ctx.sphere_check = Some(contact_check(t));
            }
            ctx.pieces = Pieces::Planned(touch_pieces(
                p.plan
                    .touches
                    .iter()
                    .map(|t| (t.label.as_str(), t.piece.as_str())),
            ));
        }
        ctx
    }

    /// Reads measurement files in whatever format each is.
    pub fn read(&self, files: &[PathBuf]) -> Result<Measurements, AnalyzeError> {
        let ctx = ReadContext {
            plan: self.points.as_ref(),
            kin: Some(&self.kin),
            dialect: Some(self.dialect),
            probe: self.probe_log.as_ref(),
            options: self.options,
        };
        let mut m = Measurements::default();
        for f in files {
            match detect::read_measurement_in(f, &ctx)? {
                Measurement::Points(s) => m.points.push((f.clone(), s)),
                Measurement::Heights(h) => m.heights.push((f.clone(), h)),
            }
        }
        Ok(m)
    }

    /// Joins point sets (one piece, several files) to the plan's points,
    /// each probed piece on its own setup; a file that holds the plan's
    /// nominal points instead of a measurement is refused.
    pub fn join(&self, sets: &[(PathBuf, PointSet)]) -> Result<Dataset, AnalyzeError> {
        let data = self.join_sets(sets)?;
        let nominal = |p: &PlanPoint| nominal(&self.kin, self.kind, p);
        for (fi, (path, _)) in sets.iter().enumerate() {
            if let Some(largest) = copy_of_nominal(&data, fi, &nominal) {
                return Err(AnalyzeError::Plan(format!(
                    "{}: its {} points are the plan's nominal points (largest difference {:.3} um, below the {} um a measurement resolves): the plan's own points file, or a simulation without errors and noise, not a measurement; nothing to identify",
                    path.display(),
                    data.obs.iter().filter(|o| o.file == fi).count(),
                    largest * 1e3,
                    COPY_MM * 1e3
                )));
            }
        }
        Ok(data)
    }

    fn join_sets(&self, sets: &[(PathBuf, PointSet)]) -> Result<Dataset, AnalyzeError> {
        let Some(points) = &self.points else {
            return Err(AnalyzeError::Plan(format!(
                "{}: a nine-section plan takes section heights (section,height_um), not points",
                self.manifest.display()
            )));
        };
        let nominal = |p: &PlanPoint| nominal(&self.kin, self.kind, p);
        let mut data =
            crate::identify::data::join(points, self.kind, &self.minutes, sets, &nominal)?;
        match &self.pieces {
            Pieces::One => {}
            Pieces::Planned(map) => data
                .set_pieces(map)
                .map_err(|e| AnalyzeError::Plan(e.to_string()))?,
            Pieces::Rebuilt(map) => {
                if let Err(e) = data.set_pieces(map) {
                    data.warnings
                        .push(format!("{e}: the points are taken as one rigid setup"));
                }
            }
        }
        Ok(data)
    }

    /// Joins labelled points already in memory (simulated ones), named
    /// `source` in messages. Not checked against the nominal points: a
    /// simulation without errors and noise is how `plan` predicts what its
    /// test identifies.
    pub(crate) fn join_points(
        &self,
        points: Vec<MeasuredPoint>,
        format: &'static str,
        source: &Path,
    ) -> Result<Dataset, AnalyzeError> {
        let set = PointSet {
            format,
            points,
            labeled: true,
            nominals: Vec::new(),
            warnings: Vec::new(),
        };
        self.join_sets(&[(source.to_path_buf(), set)])
    }
}
