//! Rebuilding a plan from its manifest: the copies of the machine file,
//! template and postprocessor next to `<test>.plan.yaml`, with the tool,
//! dialect and kinematics mode the manifest records, planned again. The
//! result is checked against the manifest's poses, so a plan directory
//! whose files were edited after the fact is refused rather than silently
//! reinterpreted.

use std::path::{Path, PathBuf};

use super::template::Template;
use super::{PlanConfig, PlanError, PlannedTest, plan};
use crate::formats::manifest::{Manifest, TestKind};
use crate::machine::{Machine, MachineError};
use crate::post::PostDefinition;
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

fn read(path: &Path, what: &str) -> Result<String, SourceError> {
    std::fs::read_to_string(path)
        .map_err(|e| SourceError::new(path, 0, 0, format!("cannot read the plan's {what}: {e}")))
}

/// Rebuilds a planned test exactly from its manifest `<test>.plan.yaml`.
pub fn load(manifest_path: &Path) -> Result<PlannedTest, LoadError> {
    let man = Manifest::read(manifest_path)?;
    let at = |keys: &[&str], msg: String| {
        let src = std::fs::read_to_string(manifest_path).unwrap_or_default();
        SourceError::at_key(manifest_path, &src, keys, msg)
    };
    if man.kind != TestKind::Machining {
        return Err(at(
            &["kind"],
            format!(
                "test `{}` is a probing plan; this build rebuilds machining plans only",
                man.test
            ),
        )
        .into());
    }
    let machine_path = man.resolve(manifest_path, &man.machine_file);
    let machine = Machine::from_yaml(&machine_path, &read(&machine_path, "machine file")?)?;
    let template_path = man.resolve(manifest_path, &man.template_file);
    let template = Template::parse(&template_path, &read(&template_path, "template")?)?;
    let post = match man.file(manifest_path, "postprocessor") {
        Some(p) => PostDefinition::parse(&p, &read(&p, "postprocessor")?)?,
        None => PostDefinition::builtin(man.dialect),
    };
    if post.dialect != man.dialect {
        return Err(at(
            &["dialect"],
            format!(
                "dialect {} but the copied postprocessor writes {}",
                man.dialect, post.dialect
            ),
        )
        .into());
    }
    let Some(tool) = man.tool.clone() else {
        return Err(at(
            &["tool"],
            "a machining plan's manifest must name its tool".into(),
        )
        .into());
    };
    let cfg = PlanConfig {
        machine,
        template,
        post,
        kinematics: man.kinematics,
        tool: Some(tool),
    };
    let planned = plan(&cfg).map_err(|source| LoadError::Plan {
        path: manifest_path.to_path_buf(),
        source: Box::new(source),
    })?;
    let mismatch = |what: String| LoadError::Mismatch {
        path: manifest_path.to_path_buf(),
        what,
    };
    if planned.test != man.test {
        return Err(mismatch(format!(
            "test `{}` instead of `{}`",
            planned.test, man.test
        )));
    }
    if planned.poses.len() != man.poses.len() {
        return Err(mismatch(format!(
            "{} poses instead of {}",
            planned.poses.len(),
            man.poses.len()
        )));
    }
    for (p, e) in planned.poses.iter().zip(&man.poses) {
        let same = p.id == e.pose
            && p.seq == e.seq
            && (p.tilt - e.tilt).abs() < 1e-9
            && (p.c - e.c).abs() < 1e-9
            && (p.start_min - e.start_min).abs() < 1e-3
            && (p.end_min - e.end_min).abs() < 1e-3;
        if !same {
            return Err(mismatch(format!(
                "pose {} (seq {}, {}, {}, {:.3}..{:.3} min) instead of {} (seq {}, {}, {}, {:.3}..{:.3} min)",
                p.id,
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
    Ok(planned)
}
