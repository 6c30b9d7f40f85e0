//! What only a probing plan writes (the rest is [`crate::procedure::Plan`]'s
//! writer): points.csv with its header and the setup sheet.

use std::fmt::Write as _;

use super::{ProbedGeometry, ProbingPlan, log_name};
use crate::procedure::{push_notes, round, short};

impl ProbingPlan {
    /// The points.csv text.
    pub(crate) fn points_csv(&self) -> String {
        let head = format!(
            "{} on {} (fivecal plan): nominal contact points in W, mm; n = outward unit normal; row i = touch i",
            self.test, self.machine.name
        );
        self.plan_points().to_csv(&[head.as_str()])
    }

    /// The setup sheet (Markdown).
    pub fn setup_sheet(&self, stem: &str) -> String {
        let m = &self.machine;
        let p = &self.probe;
        let s = &self.plan.settings;
        let letter = m.tilt_letter();
        let mut o = String::new();
        let _ = writeln!(o, "# {} on {}\n", self.test, m.name);
        let _ = writeln!(
            o,
            "{}\n",
            self.info.lines[0].trim_start_matches("fivecal plan: ")
        );
        let _ = writeln!(
            o,
            "Program `{stem}.{}` ({} dialect, postprocessor `{}`): {} poses, {} touches.\n",
            self.post.extension,
            self.dialect,
            self.post.name,
            self.plan.poses.len(),
            self.plan.touches.len()
        );
        let _ = writeln!(o, "## Setup\n");
        for l in self.setup.describe() {
            let _ = writeln!(o, "- {l}.");
        }
        let place = s.overtravel.min(s.safe_margin);
        match &self.setup {
            ProbedGeometry::Columns(_) => {
                let _ = writeln!(
                    o,
                    "- Fix each column to the {} table within {} mm of its nominal place and square to the table: the probing moves start {} mm from the nominal faces and run {} mm past them, and the moves between touches keep {} mm from them.",
                    m.name,
                    short(place),
                    short(s.clearance),
                    short(s.overtravel),
                    short(s.safe_margin)
                );
            }
            ProbedGeometry::Sphere(_) => {
                let _ = writeln!(
                    o,
                    "- Clamp the stem to the {} table so that the sphere's centre lies within {} mm of its nominal place; nothing else may stand on the table.",
                    m.name,
                    short(place)
                );
            }
        }
        let _ = writeln!(
            o,
            "- Nothing else may stand on the table within the probe's reach: the path is checked against these pieces and the table only.\n- 3-D model of the setup: `{stem}.obj`, `{stem}.glb` (one group per piece)."
        );
        let _ = writeln!(o, "\n## Probe\n");
        let _ = writeln!(
            o,
            "- {}: {}, calibrated ball D{}, gauge length {} mm (set its length offset; calibrate its radius and trigger points before the run).",
            p.label(),
            p.name,
            short(p.ball_diameter),
            short(p.length)
        );
        let _ = writeln!(
            o,
            "- Each touch starts {} mm from the nominal surface, approaches along the surface normal at {} mm/min and is programmed {} mm past it; positioning at {} mm/min below the clearance height, rapids above it.",
            short(s.clearance),
            short(s.feed),
            short(s.overtravel),
            short(s.positioning_feed)
        );
        let _ = writeln!(o, "\n## Zero point\n");
        let _ = writeln!(
            o,
            "- {} on the W origin at {letter} = C = 0: the machine file's pivot, spindle gauge point at machine X{} Y{} Z{}. No TCP, no tilted plane.",
            crate::procedure::capitalised(self.dialect.work_offset()),
            short(m.pivot.x),
            short(m.pivot.y),
            short(m.pivot.z)
        );
        let _ = writeln!(
            o,
            "- Safe height Z{} (program): {}. The rotary axes move only there.",
            short(round(self.plan.safe_z, 3)),
            self.safe_reason
        );
        let _ = writeln!(o, "\n## Log\n");
        let fmt = self.log_format();
        let example = self
            .plan
            .touches
            .first()
            .map(|t| fmt.touch_line(t, &t.contact.axes.xyz, self.plan.probe.ball_radius));
        let (where_, how) = match self.dialect {
            crate::machine::Dialect::Fanuc => (
                "the POPEN output channel (parameter No. 0020: RS-232C, memory card or data server)".to_string(),
                "DPRNT prints the touch index (row of points.csv) and the skip position #5061-#5063",
            ),
            crate::machine::Dialect::Heidenhain => (
                format!(
                    "TNC:\\fivecal\\{}.txt; copy the format files {} to TNC:\\fivecal\\ first",
                    log_name(self.test),
                    self.program
                        .aux
                        .iter()
                        .map(|a| format!("`{}`", a.name))
                        .collect::<Vec<_>>()
                        .join(" and ")
                ),
                "FN 16 prints the touch index and cycle 0's touch point (ID360 NR1)",
            ),
            crate::machine::Dialect::Linuxcnc => (
                format!(
                    "`{}.log` in LinuxCNC's working directory",
                    log_name(self.test)
                ),
                "LOG writes the touch label and the probe position #5061-#5063",
            ),
            crate::machine::Dialect::Sinumerik => (
                format!(
                    "the file `FIVECAL_{}` of the program's directory (copy it off the control; the program deletes the log of an earlier run first)",
                    log_name(self.test).to_ascii_uppercase()
                ),
                "WRITE appends the touch index and the latched position $AA_MW (rounded to 4 decimals by the program)",
            ),
        };
        let _ = writeln!(o, "- Written to {where_}: {how}.");
        if let Some(e) = example {
            let _ = writeln!(
                o,
                "- The first line after the header `FIVECAL {}` reads, for a touch right on the nominal surface: `{e}`.",
                self.test
            );
        }
        // The operator's next step is a command, not the library's reader.
        let _ = writeln!(
            o,
            "- Copy the log from the control and read it back with `fivecal analyze --plan {stem}.plan.yaml --measured LOG --out errors.yaml` (LOG the copied file): it joins each touch to its row of `{stem}.points.csv`."
        );
        let rt = &self.run_time;
        let _ = writeln!(o, "\n## Run\n");
        let _ = writeln!(
            o,
            "Estimated run time {} min for {} touches, {} s per touch (rapids {} min, positioning {} min, probing {} min, overheads {} min; no acceleration). Ibaraki, Iritani & Matsushita 2013 reports 219 points in about 28 min (7.7 s per touch).\n",
            short(round(rt.total_min, 1)),
            rt.touches,
            short(round(rt.per_touch_s(), 1)),
            short(round(rt.rapid_s / 60.0, 1)),
            short(round(rt.positioning_s / 60.0, 1)),
            short(round(rt.probing_s / 60.0, 1)),
            short(round(rt.overhead_s / 60.0, 1))
        );
        let _ = writeln!(
            o,
            "| seq | pose | {letter} | C | touches | start min | end min |"
        );
        let _ = writeln!(o, "|---|---|---|---|---|---|---|");
        for p in self.poses() {
            let _ = writeln!(
                o,
                "| {} | {} | {} | {} | {} | {} | {} |",
                p.seq,
                p.id,
                short(p.tilt),
                short(p.c),
                p.touches.len(),
                short(round(p.start_min, 1)),
                short(round(p.end_min, 1))
            );
        }
        push_notes(&mut o, &self.notes);
        o
    }
}
