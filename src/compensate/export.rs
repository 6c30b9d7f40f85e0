//! The identified location errors as the corrected pivot data of a
//! controller (`fivecal compensate --export fanuc|heidenhain|linuxcnc`),
//! with what the controller cannot hold.
//!
//! The erroneous machine's rotary axis lines are computed at rotary zero
//! from the chain (the same transforms the kinematics uses), in machine
//! coordinates: the machine file's `pivot` plus the errors. Each controller
//! holds some of this geometry:
//!
//! - FANUC 30i-class tool centre point control (parameters 19680-19714,
//!   manual A-79348E): the position of the first table axis (19700-19702),
//!   the offset from it to the second table axis (19703-19705), and for
//!   head axes the offsets between the tool axis and the tool rotary axes
//!   (19709-19711, 19712-19714). Positions only.
//! - HEIDENHAIN TNC kinematics description: a chain of transformations
//!   (`TRANS` rows along X, Y, Z, and fixed rotations about A, B, C) that
//!   can hold both positions and orientations; KinematicsOpt (cycle 452)
//!   adjusts only the translations, the rotations need the machine tool
//!   builder's access to the table.
//! - LinuxCNC `xyzbc-trt-kins` / `xyzac-trt-kins` (tilting tables): the C
//!   axis position (`x-rot-point`, `y-rot-point`, `z-rot-point`) and the
//!   offset of the tilt axis from it (`x-offset` / `y-offset`,
//!   `z-offset`). Positions only.
//!
//! Orientation errors, zero-point errors, error maps, drift and linear-axis
//! errors that a controller cannot hold are listed; the NC rewrite of this
//! module compensates all of them.

use std::fmt::Write as _;

use nalgebra::{Matrix3, Vector3};

use crate::geom::d6;
use crate::kinematics::{Kinematics, Perturbation};
use crate::machine::{Dialect, Structure};
use crate::model::{Context, Effect, Model};

/// Why an export is not possible.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ExportError {
    /// The controller has no kinematics for this structure.
    #[error("{0}")]
    Unsupported(String),
}

/// A line in machine coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxisLine {
    /// A point on it, mm.
    pub point: Vector3<f64>,
    /// Unit direction.
    pub dir: Vector3<f64>,
}

impl AxisLine {
    /// The point of the line nearest `q`.
    pub fn nearest(&self, q: &Vector3<f64>) -> Vector3<f64> {
        self.point + self.dir * (q - self.point).dot(&self.dir)
    }

    /// The feet of the common perpendicular of two lines (on self, on other).
    pub fn common_perpendicular(
        &self,
        other: &AxisLine,
        near: &Vector3<f64>,
    ) -> (Vector3<f64>, Vector3<f64>) {
        let (d1, d2) = (self.dir, other.dir);
        let r = self.point - other.point;
        let (a, b, c) = (d1.dot(&d1), d1.dot(&d2), d2.dot(&d2));
        let (d, e) = (d1.dot(&r), d2.dot(&r));
        let den = a * c - b * b;
        if den.abs() < 1e-14 {
            // Parallel: any pair; take the one near `near`.
            let p = self.nearest(near);
            return (p, other.nearest(&p));
        }
        let s = (b * e - c * d) / den;
        let t = (a * e - b * d) / den;
        (self.point + d1 * s, other.point + d2 * t)
    }
}

/// The machine's axis geometry at rotary zero, machine coordinates.
#[derive(Clone, Debug, PartialEq)]
pub struct Geometry {
    /// Tilt axis line.
    pub tilt: AxisLine,
    /// C axis line.
    pub c: AxisLine,
    /// Spindle axis (tool axis at rotary zero), through the tool tip of the
    /// W origin position (head machines; table machines: the machine Z axis
    /// through the pivot).
    pub spindle: AxisLine,
}

fn rigid(p: &Perturbation, l: usize) -> (Matrix3<f64>, Vector3<f64>) {
    let iso = d6(&p.link(l));
    (
        iso.rotation.to_rotation_matrix().into_inner(),
        iso.translation.vector,
    )
}

/// The axis lines of `kin` with the constant errors `p`, at rotary zero.
pub fn geometry(kin: &Kinematics, p: &Perturbation) -> Geometry {
    let m = kin.machine();
    let pivot = m.pivot;
    let z = Vector3::z();
    let e_t = m.tilt.about.unit();
    let (r0, d0) = rigid(p, 0);
    let (r1, d1) = rigid(p, 1);
    let (r2, d2) = rigid(p, 2);
    let lh = m.pivot_length + kin.gauge_length();
    match m.structure {
        Structure::TableTable => Geometry {
            tilt: AxisLine {
                point: pivot + d0,
                dir: r0 * e_t,
            },
            c: AxisLine {
                point: pivot + d0 + r0 * d1,
                dir: r0 * r1 * z,
            },
            spindle: AxisLine {
                point: pivot,
                dir: z,
            },
        },
        Structure::HeadTable => {
            // Tool side at X, Y, Z = 0 (the tip on the W origin when the
            // head is at zero): Tz(lh) E1 R_T E2 Tz(-lh).
            let head = pivot + lh * z + d1;
            let tip = head + r1 * (d2 + r2 * (-lh * z));
            Geometry {
                tilt: AxisLine {
                    point: head,
                    dir: r1 * e_t,
                },
                c: AxisLine {
                    point: pivot + d0,
                    dir: r0 * z,
                },
                spindle: AxisLine {
                    point: tip,
                    dir: r1 * r2 * z,
                },
            }
        }
        Structure::HeadHead => {
            let c_point = pivot + lh * z + d0;
            let head = c_point + r0 * d1;
            let tip = head + r0 * r1 * (d2 + r2 * (-lh * z));
            Geometry {
                tilt: AxisLine {
                    point: head,
                    dir: r0 * r1 * e_t,
                },
                c: AxisLine {
                    point: c_point,
                    dir: r0 * z,
                },
                spindle: AxisLine {
                    point: tip,
                    dir: r0 * r1 * r2 * z,
                },
            }
        }
    }
}

/// What the file holds that no pivot parameter can: orientation and zero
/// errors of the axes, maps, drift, linear-axis errors.
fn beyond_positions(model: &Model, theta: &[f64]) -> Vec<String> {
    let mut out = Vec::new();
    let sym = &model.symbols;
    for (i, e) in model.effects.iter().enumerate() {
        let r = model.param_range(i);
        match e {
            Effect::Location { symbols } => {
                for (k, &s) in symbols.iter().enumerate() {
                    let ls = &sym.location[s];
                    if ls.unit == crate::kinematics::symbols::Unit::Urad && theta[r.start + k] != 0.0 {
                        out.push(format!(
                            "{} = {:.2} urad ({})",
                            ls.name,
                            theta[r.start + k],
                            ls.description
                        ));
                    }
                }
            }
            other => out.push(format!(
                "{}: {}",
                other.id(sym),
                match other {
                    Effect::Map { .. } => "an error map over the rotary angles",
                    Effect::Drift { .. } => "a thermal drift",
                    Effect::Scale { .. } | Effect::Squareness { .. } | Effect::Straightness { .. } => {
                        "a linear-axis error (the controller's pitch and straightness compensation holds it, not the pivot data)"
                    }
                    Effect::ToolLength => "a tool length error (the tool table holds it)",
                    Effect::ToolRadius => "a tool radius error (the tool table holds it)",
                    _ => "a probing effect",
                }
            )),
        }
    }
    out
}

fn v3(v: &Vector3<f64>) -> String {
    format!("X {:+.4}  Y {:+.4}  Z {:+.4}", v.x, v.y, v.z)
}

/// The corrected pivot data of `dialect`'s controller, as text.
pub fn export(
    model: &Model,
    theta: &[f64],
    dialect: Dialect,
    source: &str,
) -> Result<String, ExportError> {
    let kin = &model.kin;
    let m = kin.machine();
    let p = model.perturbation(theta, &Context::default());
    let g = geometry(kin, &p);
    let nominal = geometry(kin, &Perturbation::zero());
    let beyond = beyond_positions(model, theta);
    let mut s = String::new();
    let c = match dialect {
        Dialect::Fanuc | Dialect::Linuxcnc => "(",
        Dialect::Heidenhain => ";",
    };
    let _ = c;
    let header = |s: &mut String, title: &str, comment: &str| {
        let _ = writeln!(s, "{comment} {title}");
        let _ = writeln!(
            s,
            "{comment} machine {} ({}), errors from {source}",
            m.name, m.structure
        );
        let _ = writeln!(
            s,
            "{comment} values in mm, machine coordinates; nominal pivot (machine file): {}",
            v3(&m.pivot)
        );
    };
    match dialect {
        Dialect::Fanuc => {
            header(
                &mut s,
                "fivecal: FANUC tool centre point control parameters (30i-class, A-79348E)",
                "#",
            );
            let (a, b) = g.tilt.common_perpendicular(&g.c, &m.pivot);
            let _ = writeln!(s, "#");
            match m.structure {
                Structure::TableTable => {
                    let _ = writeln!(
                        s,
                        "19680 = 12            # mechanical unit: two table rotary axes ({} master, C slave)",
                        m.tilt.letter
                    );
                    let (an, bn) = nominal.tilt.common_perpendicular(&nominal.c, &m.pivot);
                    for (k, (v, vn)) in [(a, an), (b - a, bn - an)].iter().enumerate() {
                        for i in 0..3 {
                            let no = 19700 + 3 * k + i;
                            let what = if k == 0 {
                                format!(
                                    "rotary table position ({}-axis line, point nearest the C axis)",
                                    m.tilt.letter
                                )
                            } else {
                                format!("intersection offset {} axis -> C axis", m.tilt.letter)
                            };
                            let _ = writeln!(
                                s,
                                "{no} = {:+.4}   # {} {}; nominal {:+.4}, correction {:+.4} um",
                                v[i],
                                what,
                                ['X', 'Y', 'Z'][i],
                                vn[i],
                                (v[i] - vn[i]) * 1e3
                            );
                        }
                    }
                }
                Structure::HeadTable => {
                    let _ = writeln!(
                        s,
                        "19680 = 21            # mechanical unit: mixed ({} head master, C table slave)",
                        m.tilt.letter
                    );
                    let c_pt = g.c.nearest(&m.pivot);
                    let cn = nominal.c.nearest(&m.pivot);
                    for i in 0..3 {
                        let _ = writeln!(
                            s,
                            "{} = {:+.4}   # rotary table position (C axis) {}; nominal {:+.4}, correction {:+.4} um",
                            19700 + i,
                            c_pt[i],
                            ['X', 'Y', 'Z'][i],
                            cn[i],
                            (c_pt[i] - cn[i]) * 1e3
                        );
                    }
                    let (d, e) = g.spindle.common_perpendicular(&g.tilt, &m.pivot);
                    let off = e - d;
                    for i in 0..3 {
                        let _ = writeln!(
                            s,
                            "{} = {:+.4}   # intersection offset tool axis -> {} axis {} (nominal 0)",
                            19709 + i,
                            off[i],
                            m.tilt.letter,
                            ['X', 'Y', 'Z'][i]
                        );
                    }
                }
                Structure::HeadHead => {
                    let _ = writeln!(
                        s,
                        "19680 = 2             # mechanical unit: two tool rotary axes (C master, {} slave)",
                        m.tilt.letter
                    );
                    let (d, e) = g.spindle.common_perpendicular(&g.tilt, &m.pivot);
                    let (e2, f) = g.tilt.common_perpendicular(&g.c, &m.pivot);
                    let _ = e2;
                    for i in 0..3 {
                        let _ = writeln!(
                            s,
                            "{} = {:+.4}   # intersection offset tool axis -> {} axis {} (nominal 0)",
                            19709 + i,
                            (e - d)[i],
                            m.tilt.letter,
                            ['X', 'Y', 'Z'][i]
                        );
                    }
                    for i in 0..3 {
                        let _ = writeln!(
                            s,
                            "{} = {:+.4}   # intersection offset {} axis -> C axis {} (nominal 0)",
                            19712 + i,
                            (f - e)[i],
                            m.tilt.letter,
                            ['X', 'Y', 'Z'][i]
                        );
                    }
                }
            }
            let _ = writeln!(s, "#");
            let _ = writeln!(
                s,
                "# Not held by these parameters (positions only): the rotary axes' orientations and zero"
            );
            let _ = writeln!(
                s,
                "# points, and everything below; rewrite programs with `fivecal compensate` for them."
            );
            for b in &beyond {
                let _ = writeln!(s, "#   {b}");
            }
        }
        Dialect::Heidenhain => {
            header(
                &mut s,
                "fivecal: HEIDENHAIN kinematics description, corrected rotary-axis transformations",
                ";",
            );
            let _ = writeln!(s, ";");
            let _ = writeln!(
                s,
                "; Chain from the machine base: each rotary axis is preceded by its position (TRANS X/Y/Z,"
            );
            let _ = writeln!(
                s,
                "; mm) and its orientation (TRANS A/B/C, deg), as in the kinematics table (KEY TRANS)."
            );
            let rows =
                |s: &mut String, name: &str, line: &AxisLine, nom: &AxisLine, about_tilt: bool| {
                    let q = line.nearest(&nom.point);
                    for (i, l) in ['X', 'Y', 'Z'].iter().enumerate() {
                        let _ = writeln!(
                            s,
                            "TRANS  {l}  {:+.4}    ; {name} axis position, correction {:+.4} um",
                            q[i],
                            (q[i] - nom.point[i]) * 1e3
                        );
                    }
                    // Orientation: the rotation taking the nominal direction to the actual.
                    let axis = nom.dir.cross(&line.dir);
                    for (i, l) in ['A', 'B', 'C'].iter().enumerate() {
                        if about_tilt && i == m.tilt.about.index() {
                            continue;
                        }
                        let _ = writeln!(
                            s,
                            "TRANS  {l}  {:+.6}  ; {name} axis orientation, {:+.2} urad",
                            axis[i].to_degrees(),
                            axis[i] * 1e6
                        );
                    }
                };
            let _ = writeln!(s, ";");
            match m.structure {
                Structure::TableTable => {
                    rows(
                        &mut s,
                        &m.tilt.letter.to_string(),
                        &g.tilt,
                        &nominal.tilt,
                        true,
                    );
                    rows(&mut s, "C", &g.c, &nominal.c, false);
                }
                Structure::HeadTable => {
                    rows(&mut s, "C", &g.c, &nominal.c, false);
                    rows(
                        &mut s,
                        &m.tilt.letter.to_string(),
                        &g.tilt,
                        &nominal.tilt,
                        true,
                    );
                }
                Structure::HeadHead => {
                    rows(&mut s, "C", &g.c, &nominal.c, false);
                    rows(
                        &mut s,
                        &m.tilt.letter.to_string(),
                        &g.tilt,
                        &nominal.tilt,
                        true,
                    );
                }
            }
            let _ = writeln!(s, ";");
            let _ = writeln!(
                s,
                "; KinematicsOpt (cycle 452) adjusts only the TRANS X/Y/Z entries; the orientation rows and"
            );
            let _ = writeln!(
                s,
                "; the axes' zero points need the machine tool builder (protected table). Not held at all:"
            );
            for b in beyond.iter().filter(|b| !b.contains("urad")) {
                let _ = writeln!(s, ";   {b}");
            }
            if beyond.iter().all(|b| b.contains("urad")) {
                let _ = writeln!(s, ";   (nothing else)");
            }
        }
        Dialect::Linuxcnc => {
            if m.structure != Structure::TableTable {
                return Err(ExportError::Unsupported(format!(
                    "LinuxCNC's stock kinematics with pivot offsets (xyzac-trt-kins, xyzbc-trt-kins) are for tilting-table machines; {} is {}: rewrite its programs with `fivecal compensate` instead",
                    m.name, m.structure
                )));
            }
            let kins = match m.tilt.letter {
                'A' => "xyzac-trt-kins",
                _ => "xyzbc-trt-kins",
            };
            header(
                &mut s,
                &format!("fivecal: LinuxCNC {kins} pivot offsets (HAL)"),
                "#",
            );
            // C rotates about (x-rot-point, y-rot-point); the tilt axis runs
            // through (rot-point + offset) along its own direction.
            let ct = g.c.nearest(&g.tilt.nearest(&m.pivot));
            let tilt_pt = g.tilt.nearest(&ct);
            let cn = nominal.c.nearest(&m.pivot);
            let _ = writeln!(
                s,
                "setp {kins}.x-rot-point {:+.4}   # C axis X (nominal {:+.4})",
                ct.x, cn.x
            );
            let _ = writeln!(
                s,
                "setp {kins}.y-rot-point {:+.4}   # C axis Y (nominal {:+.4})",
                ct.y, cn.y
            );
            let _ = writeln!(
                s,
                "setp {kins}.z-rot-point {:+.4}   # Z where the {} axis crosses (nominal {:+.4})",
                tilt_pt.z, m.tilt.letter, cn.z
            );
            match m.tilt.letter {
                'A' => {
                    let _ = writeln!(
                        s,
                        "setp {kins}.y-offset {:+.4}   # A axis Y minus C axis Y",
                        tilt_pt.y - ct.y
                    );
                }
                _ => {
                    let _ = writeln!(
                        s,
                        "setp {kins}.x-offset {:+.4}   # B axis X minus C axis X",
                        tilt_pt.x - ct.x
                    );
                }
            }
            let _ = writeln!(s, "setp {kins}.z-offset {:+.4}", 0.0);
            let _ = writeln!(s, "#");
            let _ = writeln!(
                s,
                "# trt-kins takes no orientation errors and no zero-point errors of the rotary axes; not held:"
            );
            for b in &beyond {
                let _ = writeln!(s, "#   {b}");
            }
        }
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Machine;

    #[test]
    fn nominal_geometry_intersects_at_the_pivot() {
        for name in ["bc-trunnion", "ac-trunnion", "head-table", "head-head"] {
            let m = Machine::builtin(name).unwrap();
            let k = Kinematics::new(&m);
            let g = geometry(&k, &Perturbation::zero());
            let (a, b) = g.tilt.common_perpendicular(&g.c, &m.pivot);
            assert!((a - b).norm() < 1e-9, "{name}: {a} {b}");
        }
    }
}
