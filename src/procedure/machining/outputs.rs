//! What only a machining plan writes (the rest is [`crate::procedure::Plan`]'s
//! writer): points.csv with its header, the DMIS program that measures the
//! piece and the setup sheet.

use std::fmt::Write as _;

use super::MachiningPlan;
use crate::formats::dmis_program::{self, DmisMoves, ProbeTarget};
use crate::formats::qif_write;
use crate::procedure::{capitalised, push_notes, round, short};

impl MachiningPlan {
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
        let items: Vec<ProbeTarget> = self
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
                ProbeTarget {
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

    /// The QIF 3 measurement plan: the points to probe, with their
    /// nominals and normals, as features a CMM importing QIF plans measures
    /// and names in its QIF results.
    pub(crate) fn qif_plan(&self) -> String {
        let comments = vec![
            format!(
                "fivecal plan: {} on {}: {} points, QIF 3 measurement plan",
                self.test,
                self.machine.name,
                self.points.len()
            ),
            "nominal points in W (mm): align the part frame to W before measuring (origin on the C axis, Z along C)".to_string(),
            "each point is probed once along its outward normal; write the results as QIF (they keep these feature ids and names) for fivecal analyze".to_string(),
        ];
        qif_write::plan(&comments, &self.plan_points().points)
    }

    /// The points.csv text.
    pub(crate) fn points_csv(&self) -> String {
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
            "- {}: {} ({:?}, D{}{}, gauge length {} mm; set its length offset).",
            t.label(),
            t.name,
            t.kind,
            short(t.diameter),
            t.corner_radius
                .map(|r| format!(" R{}", short(r)))
                .unwrap_or_default(),
            short(t.length)
        );
        let cut = &self.cutting;
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
            "- {} on the W origin at {letter} = C = 0: the machine file's pivot, spindle gauge point at machine X{} Y{} Z{}. W's axes are parallel to the machine's at rotary zero; Z runs along C.",
            capitalised(self.dialect.work_offset()),
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
            "- {} points in `{stem}.points.csv` (nominal, in W, with outward normals); `{stem}.dmi` (a DMIS program) and `{stem}.qif` (a QIF 3 measurement plan) probe each once along its normal.",
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
}
