//! The laser interferometer's ten lines (Jiang et al. 2013, its
//! linear-axis method): the positioning deviation measured along ten lines
//! of the measuring volume, traced by the spindle point P and by points
//! offset from it as the linear axes move.
//!
//! Per linear axis three lines: one traced by P, and two by points offset
//! from P across the axis (P' along Z, P'' along Y, P''' along X), whose
//! lever arms make the axis' pitch and yaw show in its positioning; the
//! tenth runs along the volume's diagonal, where all three axes move and
//! their squareness shows. An offset counts only if it sits on the tool
//! side of the measured axis: it is made by moving another axis when that
//! axis lies between the measured one and the tool in the machine's chain,
//! and otherwise by a reflector on a bracket fixed to the spindle.
//!
//! [`plan`] lays the lines in the measuring volume (the user's, or the
//! strokes less a margin), checks every position the programs command
//! against the strokes, and writes per line one program in the ISO 230-2
//! standard test cycle (each target approached from below, an overrun, each
//! target approached from above, an overrun, repeated for every run, with a
//! dwell at each target for the interferometer's automatic capture) and a
//! setup sheet placing the optics.

pub mod program;
mod sheet;

use std::path::{Path, PathBuf};

use nalgebra::Vector3;

use crate::formats::laser::{LASER_VERSION, LaserManifest, LineEntry};
use crate::io::{OutputError, write_dir};
use crate::machine::{Dialect, Machine};

/// What the user asks of a ten-line plan.
#[derive(Clone, Debug)]
pub struct LaserRequest {
    /// The machine.
    pub machine: Machine,
    /// The programs' dialect.
    pub dialect: Dialect,
    /// The measuring volume (machine coordinates of the measured point,
    /// mm: X0, Y0, Z0, X1, Y1, Z1); `None`: the strokes less a margin.
    pub volume: Option<[f64; 6]>,
    /// Runs in each direction.
    pub runs: usize,
    /// Equal divisions of each line (targets = divisions + 1).
    pub divisions: usize,
    /// Overrun beyond the end targets, mm.
    pub overrun_mm: f64,
    /// Dwell at each target, s.
    pub dwell_s: f64,
    /// Feed between targets, mm/min.
    pub feed_mm_min: f64,
    /// Offset of a reflector on a spindle bracket, mm.
    pub bracket_mm: f64,
    /// Standard uncertainty of one reading, um.
    pub reading_u_um: f64,
    /// Standard uncertainty of a compensated length, ppm.
    pub length_u_ppm: f64,
}

impl LaserRequest {
    /// The defaults: the seed's 40 equal divisions, ISO 230-2's five runs
    /// each way, a 5 mm overrun, 3 s dwell (a still capture), 150 mm
    /// bracket, an XL-80-class laser (0.1 um per reading, 0.5 ppm).
    pub fn new(machine: Machine, dialect: Dialect) -> LaserRequest {
        LaserRequest {
            machine,
            dialect,
            volume: None,
            runs: 5,
            divisions: 40,
            overrun_mm: 5.0,
            dwell_s: 3.0,
            feed_mm_min: 2000.0,
            bracket_mm: 150.0,
            reading_u_um: 0.1,
            length_u_ppm: 0.5,
        }
    }
}

/// Why a ten-line plan cannot be made.
#[derive(Debug, thiserror::Error)]
pub enum LaserError {
    /// A request value out of range.
    #[error("{0}")]
    Request(String),
    /// A line leaves the machine's strokes.
    #[error("{0}")]
    Limits(String),
}

/// A ten-line plan.
#[derive(Clone, Debug)]
pub struct LaserPlan {
    /// The request it answers.
    pub request: LaserRequest,
    /// The volume used, mm.
    pub volume: [f64; 6],
    /// The lines, L1 .. L10.
    pub lines: Vec<LineEntry>,
    /// The programs, one per line.
    pub programs: Vec<String>,
    /// What was chosen and why.
    pub notes: Vec<String>,
}

const AXES: [char; 3] = ['X', 'Y', 'Z'];

/// The point names of the offsets along X, Y, Z.
pub const POINT_NAMES: [&str; 3] = ["P'''", "P''", "P'"];

/// The default volume: each stroke less 5 % of it, at least the overrun
/// plus 5 mm, at both ends.
pub fn default_volume(machine: &Machine, overrun: f64) -> [f64; 6] {
    let mut v = [0.0; 6];
    for k in 0..3 {
        let (lo, hi) = machine.strokes[k];
        let m = (0.05 * (hi - lo)).max(overrun + 5.0);
        v[k] = lo + m;
        v[k + 3] = hi - m;
    }
    v
}

/// Whether an offset along `along` for a line of `axis` is made by moving
/// `along` (it lies on the tool side of `axis` in the chain).
pub fn offset_by_axes(machine: &Machine, axis: char, along: char) -> bool {
    let at = |c: char| machine.chain.find(c);
    matches!((at(axis), at(along)), (Some(a), Some(b)) if b > a)
}

fn check_request(req: &LaserRequest) -> Result<(), LaserError> {
    let bad = |m: String| Err(LaserError::Request(m));
    if !(2..=100).contains(&req.runs) {
        return bad(format!(
            "runs {}: expected 2 to 100 (ISO 230-2 asks 5)",
            req.runs
        ));
    }
    if !(1..=1000).contains(&req.divisions) {
        return bad(format!(
            "divisions {}: expected 1 to 1000 (the seed uses 40)",
            req.divisions
        ));
    }
    let checks = [
        ("overrun", req.overrun_mm, 0.0, 100.0, "mm"),
        ("dwell", req.dwell_s, 0.0, 60.0, "s"),
        ("feed", req.feed_mm_min, 1.0, 100_000.0, "mm/min"),
        ("bracket", req.bracket_mm, 10.0, 1000.0, "mm"),
        ("reading u", req.reading_u_um, 0.0, 100.0, "um"),
        ("length u", req.length_u_ppm, 0.0, 100.0, "ppm"),
    ];
    for (what, v, lo, hi, unit) in checks {
        if !(v.is_finite() && (lo..=hi).contains(&v)) {
            return bad(format!("{what} {v} {unit}: expected {lo} to {hi} {unit}"));
        }
    }
    if req.reading_u_um == 0.0 && req.length_u_ppm == 0.0 {
        return bad("an interferometer with neither reading nor length uncertainty gives u = 0: give its reading uncertainty".into());
    }
    if let Some(v) = req.volume {
        for k in 0..3 {
            if !(v[k].is_finite() && v[k + 3].is_finite() && v[k + 3] > v[k]) {
                return bad(format!(
                    "volume {}: expected X0,Y0,Z0,X1,Y1,Z1 with {}1 > {}0 (mm, machine coordinates)",
                    v.map(|x| x.to_string()).join(","),
                    AXES[k],
                    AXES[k]
                ));
            }
        }
    }
    Ok(())
}

/// Plans the ten lines on the machine.
pub fn plan(req: &LaserRequest) -> Result<LaserPlan, LaserError> {
    check_request(req)?;
    let m = &req.machine;
    let mut notes = Vec::new();
    let volume = match req.volume {
        Some(v) => v,
        None => {
            let v = default_volume(m, req.overrun_mm);
            notes.push(format!(
                "volume from the strokes less a margin: X {} .. {}, Y {} .. {}, Z {} .. {} mm (--volume to set it)",
                v[0], v[3], v[1], v[4], v[2], v[5]
            ));
            v
        }
    };
    let v0 = Vector3::new(volume[0], volume[1], volume[2]);
    let v1 = Vector3::new(volume[3], volume[4], volume[5]);
    let span = v1 - v0;
    for k in 0..3 {
        // Targets are kept to the micrometre: a step below 0.1 mm would be
        // rounded into unequal steps.
        if span[k] / (req.divisions as f64) < 0.1 {
            return Err(LaserError::Request(format!(
                "volume {} .. {} mm along {} in {} divisions: steps below 0.1 mm; a larger volume or fewer divisions",
                volume[k],
                volume[k + 3],
                AXES[k],
                req.divisions
            )));
        }
    }
    // (name, axis, offset axis)
    let layout: [(&str, usize, Option<usize>); 9] = [
        ("L1", 0, None),
        ("L2", 1, None),
        ("L3", 2, None),
        ("L4", 0, Some(1)),
        ("L5", 0, Some(2)),
        ("L6", 1, Some(0)),
        ("L7", 1, Some(2)),
        ("L8", 2, Some(0)),
        ("L9", 2, Some(1)),
    ];
    let mut lines = Vec::new();
    for (name, axis, off) in layout {
        let mut dir = Vector3::zeros();
        dir[axis] = 1.0;
        let mut offset = Vector3::zeros();
        let by = match off {
            None => "none",
            Some(j) if offset_by_axes(m, AXES[axis], AXES[j]) => {
                offset[j] = span[j];
                "axes"
            }
            Some(j) => {
                // A bracket reaches out across X or Y, and down along the
                // tool's side of Z (up would be inside the head).
                offset[j] = if j == 2 {
                    -req.bracket_mm
                } else {
                    req.bracket_mm
                };
                "bracket"
            }
        };
        lines.push(line(
            name,
            &AXES[axis].to_string(),
            v0 + offset,
            dir,
            offset,
            by,
            span[axis],
            req,
        ));
    }
    let diag = span.norm();
    lines.push(line(
        "L10",
        "XYZ",
        v0,
        span / diag,
        Vector3::zeros(),
        "none",
        diag,
        req,
    ));
    for l in &lines {
        check_limits(req, l, &volume)?;
    }
    let programs = lines
        .iter()
        .map(|l| program::write(req, &volume, l))
        .collect();
    Ok(LaserPlan {
        request: req.clone(),
        volume,
        lines,
        programs,
        notes,
    })
}

#[allow(clippy::too_many_arguments)]
fn line(
    name: &str,
    axes: &str,
    start: Vector3<f64>,
    dir: Vector3<f64>,
    offset: Vector3<f64>,
    by: &str,
    length: f64,
    req: &LaserRequest,
) -> LineEntry {
    let n = req.divisions;
    let ext = extension(req.dialect);
    // Rounded to the micrometre, so that the plan file and the programs
    // carry the same numbers.
    let r = |v: f64| (v * 1000.0).round() / 1000.0;
    LineEntry {
        name: name.to_string(),
        axes: axes.to_string(),
        start: [r(start.x), r(start.y), r(start.z)],
        direction: [dir.x, dir.y, dir.z],
        offset: [r(offset.x), r(offset.y), r(offset.z)],
        offset_by: by.to_string(),
        targets: (0..=n).map(|k| r(length * k as f64 / n as f64)).collect(),
        program: PathBuf::from(format!("laser-{name}.{ext}")),
        sheet: PathBuf::from(format!("laser-{name}.md")),
    }
}

/// The file extension of a dialect's programs.
pub fn extension(d: Dialect) -> &'static str {
    match d {
        Dialect::Fanuc => "nc",
        Dialect::Heidenhain => "h",
        Dialect::Linuxcnc => "ngc",
        Dialect::Sinumerik => "mpf",
    }
}

/// Every spindle position a line's program commands, machine coordinates:
/// the overrun before the first target and after the last, and the safe
/// height above the line's ends.
pub fn commanded_positions(req: &LaserRequest, l: &LineEntry) -> Vec<(String, Vector3<f64>)> {
    let dir = Vector3::from(l.direction);
    let first = Vector3::from(l.spindle_at(0));
    let last = Vector3::from(l.spindle_at(l.targets.len() - 1));
    let before = first - dir * req.overrun_mm;
    let after = last + dir * req.overrun_mm;
    let safe = program::safe_z(req).max(before.z).max(after.z);
    let mut v = vec![
        ("the overrun before the first target".to_string(), before),
        ("the overrun after the last target".to_string(), after),
    ];
    for (what, p) in [("start", before), ("end", after)] {
        v.push((
            format!("the retract above the {what}"),
            Vector3::new(p.x, p.y, safe),
        ));
    }
    v
}

fn check_limits(req: &LaserRequest, l: &LineEntry, volume: &[f64; 6]) -> Result<(), LaserError> {
    let m = &req.machine;
    for (what, p) in commanded_positions(req, l) {
        for k in 0..3 {
            let (lo, hi) = m.strokes[k];
            if p[k] < lo - 1e-9 || p[k] > hi + 1e-9 {
                return Err(LaserError::Limits(format!(
                    "line {} ({} axis{}): {what} puts {} at {:.3} mm, outside its stroke [{lo}, {hi}] (volume {}; a smaller --volume, overrun or bracket fits it)",
                    l.name,
                    l.axes,
                    match l.offset_by.as_str() {
                        "bracket" => ", reflector on a bracket",
                        "axes" => ", offset by the axes",
                        _ => "",
                    },
                    AXES[k],
                    p[k],
                    volume.map(|x| x.to_string()).join(",")
                )));
            }
        }
    }
    Ok(())
}

impl LaserPlan {
    /// The plan file.
    pub fn manifest(&self) -> LaserManifest {
        LaserManifest {
            fivecal_laser_lines: LASER_VERSION,
            machine: self.request.machine.name.clone(),
            machine_file: PathBuf::from("laser-lines.machine.yaml"),
            dialect: self.request.dialect,
            volume: self.volume,
            runs: self.request.runs,
            overrun_mm: self.request.overrun_mm,
            dwell_s: self.request.dwell_s,
            reading_u_um: self.request.reading_u_um,
            length_u_ppm: self.request.length_u_ppm,
            lines: self.lines.clone(),
        }
    }

    /// Seconds one line's program takes (moves at the feed, dwells).
    pub fn seconds(&self, l: &LineEntry) -> f64 {
        let r = &self.request;
        let len = l.targets[l.targets.len() - 1] + 2.0 * r.overrun_mm;
        let moves = 2.0 * len * r.runs as f64 / r.feed_mm_min * 60.0;
        let dwells = 2.0 * (l.targets.len() * r.runs) as f64 * r.dwell_s;
        moves + dwells
    }

    /// Every output: (name in the plan directory, bytes), the plan file
    /// last.
    pub fn outputs(&self) -> Vec<(PathBuf, Vec<u8>)> {
        let mut v = Vec::new();
        for (l, p) in self.lines.iter().zip(&self.programs) {
            v.push((l.program.clone(), p.clone().into_bytes()));
            v.push((l.sheet.clone(), sheet::setup_sheet(self, l).into_bytes()));
        }
        v.push((
            PathBuf::from("laser-lines.md"),
            sheet::overview(self).into_bytes(),
        ));
        v.push((
            PathBuf::from("laser-lines.machine.yaml"),
            self.request.machine.source.as_bytes().to_vec(),
        ));
        v.push((
            PathBuf::from("laser-lines.plan.yaml"),
            self.manifest().to_yaml().into_bytes(),
        ));
        v
    }

    /// Writes every output into `dir` (staged: all or nothing), refusing
    /// to overwrite any of `inputs`.
    pub fn write(&self, dir: &Path, inputs: &[&Path]) -> Result<Vec<PathBuf>, OutputError> {
        write_dir(dir, &self.outputs(), inputs)
    }
}
