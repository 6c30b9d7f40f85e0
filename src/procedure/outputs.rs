//! The files a plan writes, for every test: the program (and its auxiliary
//! files, HEIDENHAIN's log format files), points.csv, the piece or setup as
//! `.obj` and `.glb`, the setup sheet, the postprocessor, a machining
//! test's DMIS program, copies of the machine file and the template (so a
//! plan directory is self-contained) and, last, the manifest. All of them
//! deterministic (no dates, no random ids), each written atomically, and
//! none over an input.

use std::path::{Path, PathBuf};

use indexmap::IndexMap;

use super::{MachiningPlan, Plan, ProbingPlan};
use crate::formats::manifest::{
    Identifies, KinematicsMode, MANIFEST_VERSION, Manifest, PoseEntry, SuggestedChange,
};
use crate::io::{OutputError, StagedDir, ensure_not_input};
use crate::mesh::Mesh;

/// `v` rounded to `d` decimals.
pub(crate) fn round(v: f64, d: i32) -> f64 {
    let f = 10f64.powi(d);
    (v * f).round() / f
}

/// A number without trailing zeros (`90`, `-22.5`).
pub(crate) fn short(v: f64) -> String {
    let s = crate::formats::points::fmt_num(v, 6);
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s.is_empty() || s == "-" {
        "0".into()
    } else {
        s.to_string()
    }
}

/// The setup sheet's closing `## Notes` list, if there are notes.
/// `s` with its first letter in upper case, to open a sentence.
pub(crate) fn capitalised(s: &str) -> String {
    let mut c = s.chars();
    match c.next() {
        Some(f) => f.to_uppercase().chain(c).collect(),
        None => String::new(),
    }
}

pub(crate) fn push_notes(s: &mut String, notes: &[String]) {
    use std::fmt::Write as _;
    if notes.is_empty() {
        return;
    }
    let _ = writeln!(s, "\n## Notes\n");
    for n in notes {
        let _ = writeln!(s, "- {n}");
    }
}

/// A pose as the manifest lists it, its minutes to the thousandth.
fn pose_entry(id: &str, seq: u32, tilt: f64, c: f64, start: f64, end: f64) -> PoseEntry {
    PoseEntry {
        pose: id.to_string(),
        seq,
        tilt,
        c,
        start_min: round(start, 3),
        end_min: round(end, 3),
    }
}

impl MachiningPlan {
    /// The poses as the manifest lists them (seq, angles, minutes).
    pub(crate) fn pose_entries(&self) -> Vec<PoseEntry> {
        self.poses
            .iter()
            .map(|p| pose_entry(&p.id, p.seq, p.tilt, p.c, p.start_min, p.end_min))
            .collect()
    }
}

impl ProbingPlan {
    /// The poses as the manifest lists them (seq, angles, minutes).
    pub(crate) fn pose_entries(&self) -> Vec<PoseEntry> {
        self.poses()
            .iter()
            .map(|p| pose_entry(&p.id, p.seq, p.tilt, p.c, p.start_min, p.end_min))
            .collect()
    }
}

/// Output file names by role, for a plan named `stem`.
pub(super) fn file_names(plan: &Plan, stem: &str) -> Vec<(&'static str, PathBuf)> {
    let mut v = vec![
        (
            "program",
            PathBuf::from(format!("{stem}.{}", plan.post().extension)),
        ),
        ("points", PathBuf::from(format!("{stem}.points.csv"))),
    ];
    if matches!(plan, Plan::Machining(_)) {
        v.push(("dmis", PathBuf::from(format!("{stem}.dmi"))));
        v.push(("qif", PathBuf::from(format!("{stem}.qif"))));
    }
    v.extend([
        ("glb", PathBuf::from(format!("{stem}.glb"))),
        ("obj", PathBuf::from(format!("{stem}.obj"))),
        ("setup", PathBuf::from(format!("{stem}.md"))),
        ("postprocessor", PathBuf::from(format!("{stem}.post.yaml"))),
    ]);
    for a in &plan.program().aux {
        v.push(("log_format", PathBuf::from(&a.name)));
    }
    v
}

impl Plan {
    /// The manifest of this plan written under the name `stem`.
    pub fn manifest(&self, stem: &str) -> Manifest {
        let files: IndexMap<String, PathBuf> = self
            .file_names(stem)
            .into_iter()
            .map(|(r, p)| (r.to_string(), p))
            .collect();
        let (kinematics, tool, probe, poses) = match self {
            Plan::Machining(t) => (t.kinematics, Some(t.tool.clone()), None, t.pose_entries()),
            Plan::Probing(p) => (
                KinematicsMode::Post,
                None,
                Some(p.probe.clone()),
                p.pose_entries(),
            ),
        };
        Manifest {
            fivecal_plan: MANIFEST_VERSION,
            test: self.test(),
            kind: self.kind(),
            machine: self.machine().name.clone(),
            machine_file: PathBuf::from(format!("{stem}.machine.yaml")),
            template_file: PathBuf::from(format!("{stem}.template.yaml")),
            dialect: self.dialect(),
            kinematics,
            tool,
            probe,
            files,
            poses,
            identifies: None,
            suggestions: Vec::new(),
        }
    }

    /// The poses as the manifest lists them (seq, angles, minutes).
    pub fn poses(&self) -> Vec<PoseEntry> {
        match self {
            Plan::Machining(t) => t.pose_entries(),
            Plan::Probing(p) => p.pose_entries(),
        }
    }

    /// The points.csv text.
    pub(crate) fn points_csv(&self) -> String {
        match self {
            Plan::Machining(t) => t.points_csv(),
            Plan::Probing(p) => p.points_csv(),
        }
    }

    /// The setup sheet (Markdown) of the plan written under the name
    /// `stem`.
    pub fn setup_sheet(&self, stem: &str) -> String {
        match self {
            Plan::Machining(t) => t.setup_sheet(stem),
            Plan::Probing(p) => p.setup_sheet(stem),
        }
    }

    /// The nominal piece or setup as a mesh.
    pub fn mesh(&self) -> &Mesh {
        match self {
            Plan::Machining(t) => &t.piece.mesh,
            Plan::Probing(p) => &p.mesh,
        }
    }

    /// Every output file: (name relative to the plan directory, bytes),
    /// the manifest last.
    pub fn outputs(&self, stem: &str) -> Vec<(PathBuf, Vec<u8>)> {
        self.outputs_with(stem, "", None, &[])
    }

    /// [`Plan::outputs`], with `appendix` (Markdown) closing the setup
    /// sheet and `identifies` and `suggestions` in the manifest: what `plan`
    /// found out about the design beyond the plan itself.
    pub fn outputs_with(
        &self,
        stem: &str,
        appendix: &str,
        identifies: Option<&Identifies>,
        suggestions: &[SuggestedChange],
    ) -> Vec<(PathBuf, Vec<u8>)> {
        let title = format!("{} on {} (fivecal)", self.test(), self.machine().name);
        let mut manifest = self.manifest(stem);
        manifest.identifies = identifies.cloned();
        manifest.suggestions = suggestions.to_vec();
        let program = self.program();
        let mut v: Vec<(PathBuf, Vec<u8>)> = Vec::new();
        for (role, path) in self.file_names(stem) {
            let bytes = match (role, self) {
                ("program", _) => program.text.clone().into_bytes(),
                ("points", _) => self.points_csv().into_bytes(),
                ("dmis", Plan::Machining(t)) => t.dmis_program(stem).into_bytes(),
                ("qif", Plan::Machining(t)) => t.qif_plan().into_bytes(),
                ("glb", _) => self.mesh().to_glb(&title),
                ("obj", _) => self.mesh().to_obj(&title).into_bytes(),
                ("setup", _) => (self.setup_sheet(stem) + appendix).into_bytes(),
                ("postprocessor", _) => self.post().source.clone().into_bytes(),
                _ => continue,
            };
            v.push((path, bytes));
        }
        for a in &program.aux {
            v.push((PathBuf::from(&a.name), a.text.clone().into_bytes()));
        }
        v.push((
            manifest.machine_file.clone(),
            self.machine().source.as_bytes().to_vec(),
        ));
        v.push((
            manifest.template_file.clone(),
            self.template().source().text.as_bytes().to_vec(),
        ));
        v.push((
            PathBuf::from(format!("{stem}.plan.yaml")),
            manifest.to_yaml().into_bytes(),
        ));
        v
    }

    /// Writes every output into `dir`, refusing to overwrite any of
    /// `inputs` (checked before anything is written, so a refusal writes
    /// nothing) and staged, so that a plan failing partway leaves the
    /// directory as it was; the manifest comes last. Returns the paths
    /// written.
    pub fn write(
        &self,
        dir: &Path,
        stem: &str,
        inputs: &[&Path],
    ) -> Result<Vec<PathBuf>, OutputError> {
        self.write_with(dir, stem, inputs, "", None, &[])
    }

    /// [`Plan::write`], with `appendix` closing the setup sheet and
    /// `identifies` and `suggestions` in the manifest
    /// ([`Plan::outputs_with`]).
    pub fn write_with(
        &self,
        dir: &Path,
        stem: &str,
        inputs: &[&Path],
        appendix: &str,
        identifies: Option<&Identifies>,
        suggestions: &[SuggestedChange],
    ) -> Result<Vec<PathBuf>, OutputError> {
        let outs = self.outputs_with(stem, appendix, identifies, suggestions);
        let paths: Vec<PathBuf> = outs.iter().map(|(p, _)| dir.join(p)).collect();
        for p in &paths {
            ensure_not_input(p, inputs)?;
        }
        // Staged: a plan that fails partway leaves the directory as it was.
        let mut stage = StagedDir::create(dir)?;
        for (name, bytes) in &outs {
            stage.write(name, bytes)?;
        }
        stage.commit()
    }
}
