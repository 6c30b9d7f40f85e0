//! The files a plan writes, all deterministic (no dates, no random ids) and
//! each written atomically: the program, points.csv, the manifest with the
//! copies of machine, template and postprocessor, the DMIS program, the
//! piece as `.obj` and `.glb`, and the setup sheet.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use indexmap::IndexMap;

use super::design::{push_notes, round, short};
use super::{PlannedTest, RenderedProgram};
use crate::formats::dmis_program::{self, DmisMoves, Probing};
use crate::formats::manifest::{MANIFEST_VERSION, Manifest, PoseEntry};
use crate::io::{OutputError, StagedDir, ensure_not_input};

pub(crate) fn file_names(t: &PlannedTest, stem: &str) -> Vec<(&'static str, PathBuf)> {
    let mut v = vec![
        (
            "program",
            PathBuf::from(format!("{stem}.{}", t.post.extension)),
        ),
        ("points", PathBuf::from(format!("{stem}.points.csv"))),
        ("dmis", PathBuf::from(format!("{stem}.dmi"))),
        ("glb", PathBuf::from(format!("{stem}.glb"))),
        ("obj", PathBuf::from(format!("{stem}.obj"))),
        ("setup", PathBuf::from(format!("{stem}.md"))),
        ("postprocessor", PathBuf::from(format!("{stem}.post.yaml"))),
    ];
    for a in &t.program.aux {
        v.push(("log_format", PathBuf::from(&a.name)));
    }
    v
}

impl PlannedTest {
    /// The manifest of this plan written under the name `stem`.
    pub fn manifest(&self, stem: &str) -> Manifest {
        let files: IndexMap<String, PathBuf> = self
            .file_names(stem)
            .into_iter()
            .map(|(r, p)| (r.to_string(), p))
            .collect();
        Manifest {
            fivecal_plan: MANIFEST_VERSION,
            test: self.test.clone(),
            kind: self.kind,
            machine: self.machine.name.clone(),
            machine_file: PathBuf::from(format!("{stem}.machine.yaml")),
            template_file: PathBuf::from(format!("{stem}.template.yaml")),
            dialect: self.dialect,
            kinematics: self.kinematics,
            tool: Some(self.tool.clone()),
            probe: None,
            files,
            poses: self
                .poses
                .iter()
                .map(|p| PoseEntry {
                    pose: p.id.clone(),
                    seq: p.seq,
                    tilt: p.tilt,
                    c: p.c,
                    start_min: round(p.start_min, 3),
                    end_min: round(p.end_min, 3),
                })
                .collect(),
        }
    }

    /// The DMIS program measuring every plan point. Each point is reached
    /// from above along the way its pose's tool came in (its tool axis).
    pub fn dmis_program(&self, stem: &str) -> String {
        let approach = 5.0;
        let mut corners = Vec::new();
        for b in std::iter::once(&self.piece.stock).chain(self.piece.fixture.as_ref()) {
            for i in 0..8 {
                let s = nalgebra::Vector3::new(
                    if i & 1 == 0 { -1.0 } else { 1.0 },
                    if i & 2 == 0 { -1.0 } else { 1.0 },
                    if i & 4 == 0 { -1.0 } else { 1.0 },
                );
                corners.push(b.center + b.axes * s.component_mul(&b.half));
            }
        }
        let top = corners
            .iter()
            .map(|c| c.z)
            .fold(f64::NEG_INFINITY, f64::max);
        let items: Vec<Probing> = self
            .points
            .iter()
            .map(|p| {
                let u = self.poses[p.provenance.pose].tool_axis;
                let start = p.point.p + p.point.n * approach;
                let level = corners
                    .iter()
                    .map(|c| u.dot(c))
                    .fold(f64::NEG_INFINITY, f64::max)
                    + 10.0;
                Probing {
                    point: p.point.clone(),
                    free: start + u * (level - u.dot(&start)).max(0.0),
                }
            })
            .collect();
        let comments = vec![
            format!("fivecal plan: {} on {}: {} points", self.test, self.machine.name, self.points.len()),
            "nominal points in W (mm): align the part frame to W before running (origin on the C axis, Z along C)".to_string(),
            "each point is probed once along its outward normal; report FA(label) for fivecal analyze".to_string(),
        ];
        dmis_program::program(
            stem,
            &comments,
            &items,
            DmisMoves {
                approach,
                clear_z: top + 20.0,
            },
        )
    }

    /// The points.csv text.
    pub fn points_csv(&self) -> String {
        let head = format!(
            "{} on {} (fivecal plan): nominal points in W, mm; n = outward unit normal",
            self.test, self.machine.name
        );
        self.plan_points().to_csv(&[head.as_str()])
    }

    /// The setup sheet (Markdown).
    pub fn setup_sheet(&self, stem: &str) -> String {
        let m = &self.machine;
        let t = &self.tool;
        let letter = m.tilt_letter();
        let mut s = String::new();
        let _ = writeln!(s, "# {} on {}\n", self.test, m.name);
        let _ = writeln!(
            s,
            "{}\n",
            self.info.lines[0].trim_start_matches("fivecal plan: ")
        );
        let _ = writeln!(
            s,
            "Program `{stem}.{}` ({} dialect, postprocessor `{}`, kinematics {}).\n",
            self.post.extension,
            self.dialect,
            self.post.name,
            match self.kinematics {
                crate::formats::manifest::KinematicsMode::Post => "post",
                crate::formats::manifest::KinematicsMode::Controller => "controller",
            }
        );
        let _ = writeln!(s, "## Stock and fixturing\n");
        let _ = writeln!(s, "- {}.", self.stock_text);
        let _ = writeln!(
            s,
            "- Clamp the riser to the {} table and the block to the riser so that the block's top and four sides are free; nothing may stand higher than the block.",
            m.name
        );
        let _ = writeln!(s, "\n## Tool\n");
        let _ = writeln!(
            s,
            "- T{}: {} ({:?}, D{}{}, gauge length {} mm; set its length offset).",
            t.number,
            t.name,
            t.kind,
            short(t.diameter),
            t.corner_radius
                .map(|r| format!(" R{}", short(r)))
                .unwrap_or_default(),
            short(t.length)
        );
        let cut = match &self.template.kind {
            super::template::TemplateKind::SteppedSquare(t) => &t.cutting,
            super::template::TemplateKind::NineSection(t) => &t.cutting,
        };
        let _ = writeln!(
            s,
            "- {} rpm, feed {} mm/min, plunge {} mm/min, coolant {}.",
            short(cut.spindle),
            short(cut.feed),
            short(cut.plunge_feed),
            cut.coolant.name()
        );
        let _ = writeln!(s, "\n## Zero point\n");
        let _ = writeln!(
            s,
            "- Work offset G54 (HEIDENHAIN preset 1) on the W origin at {letter} = C = 0: the machine file's pivot, spindle gauge point at machine X{} Y{} Z{}. W's axes are parallel to the machine's at rotary zero; Z runs along C.",
            short(m.pivot.x),
            short(m.pivot.y),
            short(m.pivot.z)
        );
        let _ = writeln!(
            s,
            "- Safe height Z{} (program): {}.",
            short(round(self.safe_z, 3)),
            self.safe_reason
        );
        let _ = writeln!(s, "\n## Run\n");
        let _ = writeln!(
            s,
            "Estimated run time {} min (feeds and rapids at their nominal rates, no acceleration).\n",
            short(round(self.run_minutes, 1))
        );
        let _ = writeln!(
            s,
            "| seq | pose | {letter} | C | start min | end min | cut |"
        );
        let _ = writeln!(s, "|---|---|---|---|---|---|---|");
        for p in &self.poses {
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | {} | {} |",
                p.seq,
                p.id,
                short(p.tilt),
                short(p.c),
                short(round(p.start_min, 1)),
                short(round(p.end_min, 1)),
                p.feature
            );
        }
        let _ = writeln!(s, "\n## Measuring\n");
        let _ = writeln!(
            s,
            "- {} points in `{stem}.points.csv` (nominal, in W, with outward normals); `{stem}.dmi` probes each once along its normal.",
            self.points.len()
        );
        let _ = writeln!(
            s,
            "- The CMM frame may be placed anywhere: `fivecal analyze` finds the placement itself. Align roughly to W so the probing moves start in air."
        );
        let _ = writeln!(
            s,
            "- Nominal piece: `{stem}.obj`, `{stem}.glb` (one group per pose, `stock` for uncut faces)."
        );
        push_notes(&mut s, &self.notes);
        s
    }

    /// Every output file: (name relative to the plan directory, bytes).
    pub fn outputs(&self, stem: &str) -> Vec<(PathBuf, Vec<u8>)> {
        let title = format!("{} on {} (fivecal)", self.test, self.machine.name);
        let manifest = self.manifest(stem);
        let mut v: Vec<(PathBuf, Vec<u8>)> = Vec::new();
        for (role, path) in self.file_names(stem) {
            let bytes = match role {
                "program" => self.program.text.clone().into_bytes(),
                "points" => self.points_csv().into_bytes(),
                "dmis" => self.dmis_program(stem).into_bytes(),
                "glb" => self.piece.mesh.to_glb(&title),
                "obj" => self.piece.mesh.to_obj(&title).into_bytes(),
                "setup" => self.setup_sheet(stem).into_bytes(),
                "postprocessor" => self.post.source.clone().into_bytes(),
                _ => continue,
            };
            v.push((path, bytes));
        }
        push_common(
            &mut v,
            &self.program,
            &manifest,
            &self.machine.source,
            &self.template.source.text,
            stem,
        );
        v
    }

    /// Writes every output into `dir`, refusing to overwrite any of
    /// `inputs`; the manifest is written last. Returns the paths written.
    pub fn write(
        &self,
        dir: &Path,
        stem: &str,
        inputs: &[&Path],
    ) -> Result<Vec<PathBuf>, OutputError> {
        write_all(dir, &self.outputs(stem), inputs)
    }
}

/// The files every plan writes after its own: the program's auxiliary
/// files, copies of the machine and template (so the plan directory is
/// self-contained) and, last, the manifest.
pub(super) fn push_common(
    v: &mut Vec<(PathBuf, Vec<u8>)>,
    program: &RenderedProgram,
    manifest: &Manifest,
    machine_source: &str,
    template_source: &str,
    stem: &str,
) {
    for a in &program.aux {
        v.push((PathBuf::from(&a.name), a.text.clone().into_bytes()));
    }
    v.push((
        manifest.machine_file.clone(),
        machine_source.as_bytes().to_vec(),
    ));
    v.push((
        manifest.template_file.clone(),
        template_source.as_bytes().to_vec(),
    ));
    v.push((
        PathBuf::from(format!("{stem}.plan.yaml")),
        manifest.to_yaml().into_bytes(),
    ));
}

/// Writes `outs` into `dir` in order, after checking that none of them
/// would overwrite one of `inputs`, so a refusal writes nothing.
pub(super) fn write_all(
    dir: &Path,
    outs: &[(PathBuf, Vec<u8>)],
    inputs: &[&Path],
) -> Result<Vec<PathBuf>, OutputError> {
    let paths: Vec<PathBuf> = outs.iter().map(|(p, _)| dir.join(p)).collect();
    for p in &paths {
        ensure_not_input(p, inputs)?;
    }
    // Staged: a plan that fails partway leaves the directory as it was.
    let mut stage = StagedDir::create(dir)?;
    for (name, bytes) in outs {
        stage.write(name, bytes)?;
    }
    stage.commit()
}
