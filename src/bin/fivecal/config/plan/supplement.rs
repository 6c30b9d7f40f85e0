//! `plan --supplement DISCOVER.yaml`: the supplementary test a `discover`
//! result asks for, and the machine and dialect of the first test's plan
//! where that plan is found.

use std::path::{Path, PathBuf};

use anyhow::bail;

/// What `--supplement DISCOVER.yaml` asks for: the supplementary test, and
/// the first test's machine (a file) and dialect where its plan is found.
pub(super) struct Supplementary {
    pub file: PathBuf,
    pub machine_name: String,
    pub supplement: fivecal::errorfile::Supplement,
    pub machine_file: Option<PathBuf>,
    pub dialect: Option<fivecal::Dialect>,
}

pub(super) fn supplementary(path: &Path) -> anyhow::Result<Supplementary> {
    let (f, _) = fivecal::errorfile::ErrorFile::read(path)?;
    let Some(a) = f.ambiguity else {
        bail!(
            "{}: states no ambiguity, so there is no supplementary test to plan (expected the result of a `discover --out` that stopped on one)",
            path.display()
        );
    };
    let Some(supplement) = a.supplement else {
        bail!(
            "{}: proposes no supplementary test{}",
            path.display(),
            a.no_supplement
                .map(|w| format!(" ({w})"))
                .unwrap_or_default()
        );
    };
    // The first test's plan, as discover was given it: relative to where
    // discover ran, or to the result file.
    let mut machine_file = None;
    let mut dialect = None;
    if let Some(plan) = &supplement.plan {
        let candidates = [
            PathBuf::from(plan),
            path.parent().unwrap_or(Path::new(".")).join(plan),
        ];
        if let Some(m) = candidates.iter().find(|p| p.exists()) {
            let manifest = fivecal::formats::manifest::Manifest::read(m)?;
            machine_file = Some(manifest.resolve(m, &manifest.machine_file));
            dialect = Some(manifest.dialect);
        }
    }
    Ok(Supplementary {
        file: path.to_path_buf(),
        machine_name: f.machine,
        supplement,
        machine_file,
        dialect,
    })
}
