//! The records a run leaves in the store: what `analyze`, `discover` and
//! `compensate --export` produced, built from what the library returns
//! (the analysis' outcome, the result files' text) so the binary and the
//! demo record alike.
//!
//! An analysis of one piece is one record; a series is one record per
//! piece (each piece is its own measurement) with the piece's file hashed;
//! a nine-section evaluation is one record whose content is its
//! statistics (it has no location errors to plot). The fit verdict is
//! whatever the result file states in its `fit:` section.

use std::path::{Path, PathBuf};

use jiff::Timestamp;

use super::{FileHash, FileRole, Record, RecordKind, StoreError};
use crate::analyze::{Found, Outcome};

/// What the user adds to every record of a run.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RunNotes {
    /// `--note`.
    pub note: Option<String>,
    /// `--temperature`, deg C.
    pub temperature: Option<f64>,
    /// `--measured-at`: when the machine was measured, if not now.
    pub measured_at: Option<Timestamp>,
}

impl RunNotes {
    fn apply(&self, mut r: Record) -> Record {
        r.note.clone_from(&self.note);
        r.temperature = self.temperature;
        if let Some(t) = self.measured_at {
            r.measured_at = t;
        }
        r
    }
}

fn hashes(role: FileRole, paths: &[PathBuf]) -> Result<Vec<FileHash>, StoreError> {
    paths.iter().map(|p| FileHash::of(role, p)).collect()
}

/// The records of an analysis of the plan `manifest` from `measured`,
/// whose result files (path, text) are `files` as
/// [`crate::analyze::result::files`] made them.
pub fn analysis(
    outcome: &Outcome,
    manifest: &Path,
    measured: &[PathBuf],
    files: &[(PathBuf, String)],
    notes: &RunNotes,
) -> Result<Vec<Record>, StoreError> {
    let plan = FileHash::of(FileRole::Plan, manifest)?;
    let name = |p: &Path| p.display().to_string();
    match &outcome.found {
        Found::NineSection(_) => {
            let m = crate::formats::manifest::Manifest::read(manifest)
                .map_err(|e| StoreError::Invalid(e.to_string()))?;
            let (path, text) = files
                .last()
                .ok_or_else(|| StoreError::Invalid("the analysis wrote no result".into()))?;
            let mut r = Record::new(RecordKind::Analyze, &m.machine, &name(path), text.clone());
            r.test = Some(m.test.to_string());
            r.files = hashes(FileRole::Measured, measured)?;
            r.files.push(plan);
            Ok(vec![notes.apply(r)])
        }
        Found::Identified(id) => {
            let series = id.series.is_some();
            id.pieces
                .iter()
                .enumerate()
                .map(|(k, piece)| {
                    let (path, text) = files.get(k).ok_or_else(|| {
                        StoreError::Invalid(format!("no result file for piece {}", k + 1))
                    })?;
                    let mut r = Record::new(
                        RecordKind::Analyze,
                        &piece.file.machine,
                        &name(path),
                        text.clone(),
                    );
                    r.test = Some(id.test.to_string());
                    r.files = if series {
                        hashes(FileRole::Measured, &piece.data.files)?
                    } else {
                        hashes(FileRole::Measured, measured)?
                    };
                    r.files.push(plan.clone());
                    Ok(notes.apply(r))
                })
                .collect()
        }
    }
}

/// The record of a ball-bar analysis of the plan `manifest` from the runs
/// `measured`, whose result `file` was written to `result` as `text`.
pub fn ball_bar(
    file: &crate::errorfile::ErrorFile,
    manifest: &Path,
    measured: &[PathBuf],
    result: &Path,
    text: &str,
    notes: &RunNotes,
) -> Result<Vec<Record>, StoreError> {
    let mut r = Record::new(
        RecordKind::Analyze,
        &file.machine,
        &result.display().to_string(),
        text.to_string(),
    );
    r.test = file.test.clone();
    r.files = hashes(FileRole::Measured, measured)?;
    r.files.push(FileHash::of(FileRole::Plan, manifest)?);
    Ok(vec![notes.apply(r)])
}

/// The record of a `discover` run whose final model was written to
/// `result` with `text`, from the measured files of the tests whose plan
/// manifests are `manifests` (one, or several fitted together).
pub fn discovery(
    machine: &str,
    test: &str,
    manifests: &[PathBuf],
    measured: &[PathBuf],
    result: &Path,
    text: &str,
    notes: &RunNotes,
) -> Result<Record, StoreError> {
    let mut r = Record::new(
        RecordKind::Discover,
        machine,
        &result.display().to_string(),
        text.to_string(),
    );
    r.test = Some(test.to_string());
    r.files = hashes(FileRole::Measured, measured)?;
    for m in manifests {
        r.files.push(FileHash::of(FileRole::Plan, m)?);
    }
    Ok(notes.apply(r))
}

/// The record of `compensate --export`: the error file exported (`errors`,
/// its text `content`) and the parameter text written for `controller`.
pub fn export(
    machine: &str,
    errors: &Path,
    content: &str,
    controller: &str,
    exported: &str,
    notes: &RunNotes,
) -> Result<Record, StoreError> {
    let mut r = Record::new(
        RecordKind::Export,
        machine,
        &errors.display().to_string(),
        content.to_string(),
    );
    r.controller = Some(controller.to_string());
    r.exported = Some(exported.to_string());
    r.files = vec![FileHash::of(FileRole::Errors, errors)?];
    Ok(notes.apply(r))
}
