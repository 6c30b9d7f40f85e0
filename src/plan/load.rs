//! Rebuilding a plan from its manifest: the copies of the machine file,
//! template and postprocessor next to `<test>.plan.yaml`, with the tool,
//! dialect and kinematics mode the manifest records, planned again. The
//! result is checked against the manifest's poses (and, for probing plans,
//! against the probe and the written points.csv), so a plan directory whose
//! files were edited after the fact is refused rather than silently
//! reinterpreted.
//!
//! [`load_any`] serves every manifest and says which kind it holds
//! ([`LoadedPlan`]); [`load`] and [`load_probing`] ask for one kind.
//!
//! ```no_run
//! use fivecal::plan::{LoadedPlan, load_any};
//! # fn main() -> Result<(), fivecal::plan::LoadError> {
//! match load_any(std::path::Path::new("plans/probe-sphere.plan.yaml"))? {
//!     LoadedPlan::Probing(p) => {
//!         // p.plan.touches, p.setup, p.probe, p.log_format(), ...
//!         println!("{} touches", p.plan.touches.len());
//!     }
//!     LoadedPlan::Machining(t) => println!("{} points", t.points.len()),
//! }
//! # Ok(())
//! # }
//! ```

use std::path::{Path, PathBuf};

use super::probing::{PlannedProbing, ProbingConfig, plan_probing};
use super::template::Template;
use super::{PlanConfig, PlanError, PlannedTest, plan};
use crate::formats::manifest::{Manifest, PoseEntry, TestKind};
use crate::formats::points::PlanPoints;
use crate::machine::{Dialect, Machine, MachineError};
use crate::post::PostDefinition;
use crate::probing::template::{ProbeTemplate, TemplateSource};
use crate::source::SourceError;

/// Why a plan could not be rebuilt from its manifest.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// A file of the plan is missing or malformed.
    #[error(transparent)]
    Source(#[from] SourceError),
    /// The machine copy is malformed.
    #[error(transparent)]
    Machine(#[from] MachineError),
    /// Planning again failed.
    #[error("{path}: cannot rebuild the plan: {source}")]
    Plan {
        /// The manifest.
        path: PathBuf,
        /// Cause.
        source: Box<PlanError>,
    },
    /// The rebuilt plan differs from what the manifest says.
    #[error(
        "{path}: the plan rebuilt from the copied machine, template and postprocessor differs from the manifest: {what}"
    )]
    Mismatch {
        /// The manifest.
        path: PathBuf,
        /// What differs.
        what: String,
    },
}

/// A plan of either kind, rebuilt from its manifest.
#[derive(Clone, Debug)]
pub enum LoadedPlan {
    /// A machining test (stepped-square, nine-section).
    Machining(Box<PlannedTest>),
    /// An on-machine probing test (probe-columns, probe-sphere).
    Probing(Box<PlannedProbing>),
}

impl LoadedPlan {
    /// The test name.
    pub fn test(&self) -> &str {
        match self {
            LoadedPlan::Machining(t) => &t.test,
            LoadedPlan::Probing(p) => &p.test,
        }
    }

    /// Machining or probing.
    pub fn kind(&self) -> TestKind {
        match self {
            LoadedPlan::Machining(_) => TestKind::Machining,
            LoadedPlan::Probing(_) => TestKind::Probing,
        }
    }

    /// The machine.
    pub fn machine(&self) -> &Machine {
        match self {
            LoadedPlan::Machining(t) => &t.machine,
            LoadedPlan::Probing(p) => &p.machine,
        }
    }

    /// The program's dialect.
    pub fn dialect(&self) -> Dialect {
        match self {
            LoadedPlan::Machining(t) => t.dialect,
            LoadedPlan::Probing(p) => p.dialect,
        }
    }

    /// The nominal points, as points.csv holds them.
    pub fn plan_points(&self) -> PlanPoints {
        match self {
            LoadedPlan::Machining(t) => t.plan_points(),
            LoadedPlan::Probing(p) => p.plan_points(),
        }
    }

    /// The poses as the manifest lists them (seq, angles, minutes).
    pub fn poses(&self) -> Vec<PoseEntry> {
        match self {
            LoadedPlan::Machining(t) => t.manifest(&t.test).poses,
            LoadedPlan::Probing(p) => p.manifest(&p.test).poses,
        }
    }

    /// The machining plan, if it is one.
    pub fn machining(&self) -> Option<&PlannedTest> {
        match self {
            LoadedPlan::Machining(t) => Some(t),
            LoadedPlan::Probing(_) => None,
        }
    }

    /// The probing plan, if it is one.
    pub fn probing(&self) -> Option<&PlannedProbing> {
        match self {
            LoadedPlan::Probing(p) => Some(p),
            LoadedPlan::Machining(_) => None,
        }
    }
}

fn read(path: &Path, what: &str) -> Result<String, SourceError> {
    crate::input::read_text(
        path,
        &format!("plan's {what}"),
        crate::limits::MAX_YAML_BYTES,
    )
}

/// What both kinds read from a plan directory.
struct Copies {
    man: Manifest,
    machine: Machine,
    template_path: PathBuf,
    template_text: String,
    post: PostDefinition,
}

fn at(manifest_path: &Path, keys: &[&str], msg: String) -> LoadError {
    let src = std::fs::read_to_string(manifest_path).unwrap_or_default();
    SourceError::at_key(manifest_path, &src, keys, msg).into()
}

fn copies(manifest_path: &Path, man: Manifest) -> Result<Copies, LoadError> {
    let machine_path = man.resolve(manifest_path, &man.machine_file);
    let machine = Machine::from_yaml(&machine_path, &read(&machine_path, "machine file")?)?;
    let template_path = man.resolve(manifest_path, &man.template_file);
    let template_text = read(&template_path, "template")?;
    let post = match man.file(manifest_path, "postprocessor") {
        Some(p) => PostDefinition::parse(&p, &read(&p, "postprocessor")?)?,
        None => PostDefinition::builtin(man.dialect),
    };
    if post.dialect != man.dialect {
        return Err(at(
            manifest_path,
            &["dialect"],
            format!(
                "dialect {} but the copied postprocessor writes {}",
                man.dialect, post.dialect
            ),
        ));
    }
    Ok(Copies {
        man,
        machine,
        template_path,
        template_text,
        post,
    })
}

/// Compares rebuilt poses (id, seq, tilt, C, start and end minutes) with
/// the manifest's.
fn check_poses(
    manifest_path: &Path,
    test: &str,
    poses: &[PoseEntry],
    man: &Manifest,
) -> Result<(), LoadError> {
    let mismatch = |what: String| LoadError::Mismatch {
        path: manifest_path.to_path_buf(),
        what,
    };
    if test != man.test {
        return Err(mismatch(format!("test `{test}` instead of `{}`", man.test)));
    }
    if poses.len() != man.poses.len() {
        return Err(mismatch(format!(
            "{} poses instead of {}",
            poses.len(),
            man.poses.len()
        )));
    }
    for (p, e) in poses.iter().zip(&man.poses) {
        let same = p.pose == e.pose
            && p.seq == e.seq
            && (p.tilt - e.tilt).abs() < 1e-9
            && (p.c - e.c).abs() < 1e-9
            && (p.start_min - e.start_min).abs() < 1e-3
            && (p.end_min - e.end_min).abs() < 1e-3;
        if !same {
            return Err(mismatch(format!(
                "pose {} (seq {}, {}, {}, {:.3}..{:.3} min) instead of {} (seq {}, {}, {}, {:.3}..{:.3} min)",
                p.pose,
                p.seq,
                p.tilt,
                p.c,
                p.start_min,
                p.end_min,
                e.pose,
                e.seq,
                e.tilt,
                e.c,
                e.start_min,
                e.end_min
            )));
        }
    }
    Ok(())
}

/// Rebuilds a plan of either kind exactly from its manifest
/// `<test>.plan.yaml`.
pub fn load_any(manifest_path: &Path) -> Result<LoadedPlan, LoadError> {
    let man = Manifest::read(manifest_path)?;
    Ok(match man.kind {
        TestKind::Machining => LoadedPlan::Machining(Box::new(machining(manifest_path, man)?)),
        TestKind::Probing => LoadedPlan::Probing(Box::new(probing(manifest_path, man)?)),
    })
}

/// Rebuilds a machining plan exactly from its manifest `<test>.plan.yaml`
/// (a probing manifest is refused: use [`load_any`] or [`load_probing`]).
pub fn load(manifest_path: &Path) -> Result<PlannedTest, LoadError> {
    let man = Manifest::read(manifest_path)?;
    if man.kind != TestKind::Machining {
        return Err(at(
            manifest_path,
            &["kind"],
            format!(
                "test `{}` is a probing plan, not a machining plan (load it with plan::load_any or plan::load_probing)",
                man.test
            ),
        ));
    }
    machining(manifest_path, man)
}

/// Rebuilds a probing plan exactly from its manifest `<test>.plan.yaml`
/// (a machining manifest is refused: use [`load_any`] or [`load`]).
pub fn load_probing(manifest_path: &Path) -> Result<PlannedProbing, LoadError> {
    let man = Manifest::read(manifest_path)?;
    if man.kind != TestKind::Probing {
        return Err(at(
            manifest_path,
            &["kind"],
            format!(
                "test `{}` is a machining plan, not a probing plan (load it with plan::load_any or plan::load)",
                man.test
            ),
        ));
    }
    probing(manifest_path, man)
}

fn machining(manifest_path: &Path, man: Manifest) -> Result<PlannedTest, LoadError> {
    let c = copies(manifest_path, man)?;
    let template = Template::parse(&c.template_path, &c.template_text)?;
    let Some(tool) = c.man.tool.clone() else {
        return Err(at(
            manifest_path,
            &["tool"],
            "a machining plan's manifest must name its tool".into(),
        ));
    };
    let cfg = PlanConfig {
        machine: c.machine,
        template,
        post: c.post,
        kinematics: c.man.kinematics,
        tool: Some(tool),
    };
    let planned = plan(&cfg).map_err(|source| LoadError::Plan {
        path: manifest_path.to_path_buf(),
        source: Box::new(source),
    })?;
    check_poses(
        manifest_path,
        &planned.test,
        &planned.manifest(&planned.test).poses,
        &c.man,
    )?;
    Ok(planned)
}

fn probing(manifest_path: &Path, man: Manifest) -> Result<PlannedProbing, LoadError> {
    let c = copies(manifest_path, man)?;
    let template = ProbeTemplate::parse(TemplateSource {
        path: c.template_path.clone(),
        text: c.template_text.clone(),
    })?;
    let mismatch = |what: String| LoadError::Mismatch {
        path: manifest_path.to_path_buf(),
        what,
    };
    match &c.man.probe {
        None => {
            return Err(at(
                manifest_path,
                &["probe"],
                "a probing plan's manifest must name its probe".into(),
            ));
        }
        Some(p) if *p != c.machine.probe => {
            return Err(mismatch(format!(
                "the manifest's probe ({}, ball D{}, length {}) is not the copied machine file's ({}, ball D{}, length {})",
                p.name,
                p.ball_diameter,
                p.length,
                c.machine.probe.name,
                c.machine.probe.ball_diameter,
                c.machine.probe.length
            )));
        }
        Some(_) => {}
    }
    let cfg = ProbingConfig {
        machine: c.machine,
        template,
        post: c.post,
    };
    let planned = plan_probing(&cfg).map_err(|source| LoadError::Plan {
        path: manifest_path.to_path_buf(),
        source: Box::new(source),
    })?;
    check_poses(
        manifest_path,
        &planned.test,
        &planned.manifest(&planned.test).poses,
        &c.man,
    )?;
    // The touches must be the rows of the written points.csv (to its six
    // decimals), so that a log's indices and labels mean what they meant.
    if let Some(p) = c.man.file(manifest_path, "points")
        && p.exists()
    {
        let written = PlanPoints::read(&p)?;
        let rebuilt = planned.plan_points();
        if written.points.len() != rebuilt.points.len() {
            return Err(mismatch(format!(
                "{} holds {} points, the rebuilt plan {} touches",
                p.display(),
                written.points.len(),
                rebuilt.points.len()
            )));
        }
        for (i, (w, r)) in written.points.iter().zip(&rebuilt.points).enumerate() {
            let same = w.label == r.label
                && w.pose == r.pose
                && w.seq == r.seq
                && (w.tilt - r.tilt).abs() < 1e-6
                && (w.c - r.c).abs() < 1e-6
                && (w.p - r.p).norm() < 1e-5
                && (w.n - r.n).norm() < 1e-8;
            if !same {
                return Err(mismatch(format!(
                    "row {} of {} is {} at ({:.6}, {:.6}, {:.6}), the rebuilt touch {} at ({:.6}, {:.6}, {:.6})",
                    i + 1,
                    p.display(),
                    w.label,
                    w.p.x,
                    w.p.y,
                    w.p.z,
                    r.label,
                    r.p.x,
                    r.p.y,
                    r.p.z
                )));
            }
        }
    }
    Ok(planned)
}
