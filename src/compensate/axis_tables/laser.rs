//! Axis tables from a laser-lines result (`fivecal analyze` of a ten-line
//! plan, docs/laser-lines.md): the base lines L1, L2 and L3 run along X, Y
//! and Z through the spindle point P, so their per-target mean deviations
//! in each approach direction are the axis's positioning error there.
//!
//! A line's target `t` (mm from its start) sits on the axis at `start + t
//! direction` in machine coordinates; a line that runs against the axis
//! (direction -1) has its approach directions and its deviations' sign
//! turned to the axis's. The deviation is the interferometer's, zero at
//! the line's first target (the reading is set to zero there): a table
//! built from it makes the axis right relative to that point, and the
//! constant left is what the work offsets absorb.
//!
//! The u of a mean deviation of n runs: the larger of the runs' standard
//! deviation and the instrument's reading u, over sqrt(n) (a scatter below
//! the instrument's own is the luck of few runs), combined in quadrature
//! with the laser's length uncertainty times the distance from the zero.
//!
//! The result is read by its own small schema here (the analysis stands
//! above compensation in the layers): the keys a table needs, the rest of
//! the file ignored.

use std::path::Path;

use serde::Deserialize;

use super::{AxisTable, TableError, TablePoint};
use crate::source::SourceError;

#[derive(Deserialize)]
struct ResultFile {
    fivecal_laser_result: u32,
    machine: String,
    reading_u_um: Option<f64>,
    length_u_ppm: Option<f64>,
    lines: Vec<Line>,
}

#[derive(Deserialize)]
struct Line {
    line: String,
    axes: String,
    start: Option<[f64; 3]>,
    direction: Option<[f64; 3]>,
    offset: Option<[f64; 3]>,
    runs: usize,
    targets: Vec<Target>,
}

#[derive(Deserialize)]
struct Target {
    position_mm: f64,
    up: Dir,
    down: Dir,
}

#[derive(Deserialize)]
struct Dir {
    mean_um: f64,
    s_um: f64,
    n: usize,
}

/// The tables a laser-lines result gives, and the machine it names.
#[derive(Clone, Debug, PartialEq)]
pub struct LaserTables {
    /// The machine the result names.
    pub machine: String,
    /// One table per base line found, in X, Y, Z order.
    pub tables: Vec<AxisTable>,
    /// The axes without a base line in the result, each with the line's
    /// name (`('Z', "L3")`).
    pub missing: Vec<(char, String)>,
}

/// Whether `src` is a laser-lines result (its first key).
pub fn sniff(src: &str) -> bool {
    crate::formats::first_key_is(src, "fivecal_laser_result:")
}

/// The base line of each axis: its name in the plan, and the axis.
const BASE: [(&str, char); 3] = [("L1", 'X'), ("L2", 'Y'), ("L3", 'Z')];

/// Reads the result `src` (from `path`) into one table per base line;
/// refused when it holds none of L1, L2, L3, naming them.
pub fn tables(path: &Path, src: &str) -> Result<LaserTables, TableError> {
    let r: ResultFile = crate::input::parse_yaml(path, src)?;
    let at = |keys: &[&str], m: String| SourceError::at_key(path, src, keys, m);
    if r.fivecal_laser_result != 1 {
        return Err(at(
            &["fivecal_laser_result"],
            format!(
                "laser-lines result version {} is not supported (expected 1)",
                r.fivecal_laser_result
            ),
        )
        .into());
    }
    let (Some(u_r), Some(ppm)) = (r.reading_u_um, r.length_u_ppm) else {
        return Err(at(
            &["fivecal_laser_result"],
            "the result holds no reading_u_um and length_u_ppm (written by an earlier fivecal): analyze the runs again".into(),
        )
        .into());
    };
    if !(u_r.is_finite() && u_r >= 0.0 && ppm.is_finite() && ppm >= 0.0) {
        return Err(at(
            &["reading_u_um"],
            "reading_u_um and length_u_ppm must be numbers >= 0".into(),
        )
        .into());
    }
    let mut tables = Vec::new();
    let mut missing = Vec::new();
    for (name, axis) in BASE {
        let Some(l) = r.lines.iter().find(|l| l.line == name) else {
            missing.push((axis, name.to_string()));
            continue;
        };
        let bad = |m: String| -> TableError {
            at(
                &["lines"],
                format!("line {name} ({axis} through the spindle point P): {m}"),
            )
            .into()
        };
        let (Some(start), Some(dir)) = (l.start, l.direction) else {
            return Err(bad(
                "no start and direction (a result written by an earlier fivecal): analyze the runs again".into(),
            ));
        };
        let k = super::axis_index(axis);
        let along = dir[k];
        let off_axis = (0..3)
            .filter(|&j| j != k)
            .map(|j| dir[j].abs())
            .fold(0.0, f64::max);
        if l.axes != axis.to_string() || (along.abs() - 1.0).abs() > 1e-9 || off_axis > 1e-9 {
            return Err(bad(format!(
                "it moves {} along ({}, {}, {}), not {axis} alone: not the base line of {axis}",
                l.axes, dir[0], dir[1], dir[2]
            )));
        }
        if l.offset.is_some_and(|o| o.iter().any(|v| v.abs() > 1e-9)) {
            return Err(bad(
                "its measured point is offset from P: the reading holds an angular error times the offset".into(),
            ));
        }
        if l.targets.len() < 2 || l.runs < 2 {
            return Err(bad("fewer than two targets or runs".into()));
        }
        let t0 = l.targets[0].position_mm;
        let mut points = Vec::with_capacity(l.targets.len());
        for t in &l.targets {
            let vals = [
                t.position_mm,
                t.up.mean_um,
                t.up.s_um,
                t.down.mean_um,
                t.down.s_um,
            ];
            if vals.iter().any(|v| !v.is_finite()) || t.up.n < 2 || t.down.n < 2 {
                return Err(bad(format!(
                    "target {} mm: a value is not a number, or fewer than two runs",
                    t.position_mm
                )));
            }
            let length = ppm * (t.position_mm - t0).abs() * 1e-3;
            let u = |d: &Dir| ((d.s_um.max(u_r)).powi(2) / d.n as f64 + length * length).sqrt();
            // The line's + approach is the axis's + approach when the line
            // runs along the axis, its - approach when it runs against.
            let (plus, minus) = if along > 0.0 {
                (&t.up, &t.down)
            } else {
                (&t.down, &t.up)
            };
            points.push(TablePoint {
                position_mm: start[k] + along * t.position_mm,
                plus_um: along * plus.mean_um,
                minus_um: along * minus.mean_um,
                u_plus_um: u(plus),
                u_minus_um: u(minus),
            });
        }
        if along < 0.0 {
            points.reverse();
        }
        let table = AxisTable {
            axis,
            from: format!("line {name} of {}", path.display()),
            points,
        };
        table.check()?;
        tables.push(table);
    }
    if tables.is_empty() {
        return Err(at(
            &["lines"],
            format!(
                "no base line in the result: an axis table is built from L1 (X), L2 (Y) or L3 (Z), the lines through the spindle point P; it holds {}",
                if r.lines.is_empty() {
                    "no line".to_string()
                } else {
                    r.lines.iter().map(|l| l.line.as_str()).collect::<Vec<_>>().join(", ")
                }
            ),
        )
        .into());
    }
    Ok(LaserTables {
        machine: r.machine,
        tables,
        missing,
    })
}
