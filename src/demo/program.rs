//! The demo's example five-axis program: a FANUC finishing contour around a
//! frustum on a tilting-table machine, written with post-side kinematics
//! (the program holds X, Y, Z, tilt and C as the machine moves them, no
//! TCP), which is the kind of program `compensate` rewrites axis by axis.
//!
//! The tool's end face runs on three rings of a frustum standing on the
//! table at the W origin while the tool axis leans 35 to 45 deg from the
//! table normal, swinging with the position around the ring, so that the
//! tilt and C axes both move in every block: the program exercises every
//! location error of the machine, unlike a 3+2 program.

use std::f64::consts::PI;
use std::fmt::Write as _;

use nalgebra::Vector3;

use crate::kinematics::{Axes, IkError, Kinematics, ToolPose};

/// Height of the rings above the table, mm.
const RINGS: [f64; 3] = [4.0, 9.0, 14.0];
/// Radius of the frustum at the table, mm.
const BASE_RADIUS: f64 = 45.0;
/// The frustum's flanks lean this far from the table normal, deg.
const FLANK: f64 = 40.0;
/// Blocks per ring.
const STEPS: usize = 120;
/// Cutting feed, mm/min of tool tip.
const FEED: f64 = 1200.0;
/// Tip distance of the approach and departure points from the surface, mm.
const CLEAR: f64 = 10.0;
/// Program Z (tool tip, rotary axes at zero) at which rotary moves are safe.
const SAFE_Z: f64 = 120.0;

/// Why the program cannot be written for a machine.
#[derive(Debug, thiserror::Error)]
pub(crate) enum ProgramError {
    /// The machine is not a tilting-table machine.
    #[error("the example program is written for table-table machines, not {0}")]
    Structure(String),
    /// A pose of the contour is beyond the machine's reach.
    #[error("the contour point at ring {ring}, {angle:.0} deg is out of reach: {cause}")]
    Reach {
        /// Ring index from 1.
        ring: usize,
        /// Angle around the ring, deg.
        angle: f64,
        /// The kinematics' reason.
        cause: IkError,
    },
    /// A position needs a linear axis beyond its stroke.
    #[error("{what} needs {axis} = {value:.1} mm, beyond its stroke {lo}..{hi} mm")]
    Stroke {
        /// Which position.
        what: String,
        /// Axis letter.
        axis: char,
        /// Machine coordinate.
        value: f64,
        /// Stroke minimum.
        lo: f64,
        /// Stroke maximum.
        hi: f64,
    },
}

/// The tool pose at angle `phi` (rad) around ring `z`: the tip on the
/// frustum, the axis along the local flank normal, whose lean varies by
/// +-5 deg twice per turn.
fn pose(z: f64, phi: f64) -> ToolPose {
    let flank = FLANK.to_radians();
    let r = BASE_RADIUS - z * flank.tan();
    let lean = (FLANK + 5.0 * (2.0 * phi).sin()).to_radians();
    ToolPose {
        tip: Vector3::new(r * phi.cos(), r * phi.sin(), z),
        axis: Vector3::new(lean.sin() * phi.cos(), lean.sin() * phi.sin(), lean.cos()),
    }
}

fn num(v: f64) -> String {
    // FANUC: always a decimal point; 4 decimals keep 0.1 um, so that a
    // compensated program is not rounded back to the original.
    let s = format!("{v:.4}");
    let s = s.trim_end_matches('0');
    if s == "-0." {
        "0.".into()
    } else {
        s.to_string()
    }
}

fn block(a: &Axes, tilt: char) -> String {
    format!(
        "X{} Y{} Z{} {tilt}{} C{}",
        num(a.xyz.x),
        num(a.xyz.y),
        num(a.xyz.z),
        num(a.tilt),
        num(a.c)
    )
}

/// The program text (FANUC, `%`-delimited, O2001) for `kin`'s machine.
pub(crate) fn frustum_program(kin: &Kinematics) -> Result<String, ProgramError> {
    let m = kin.machine();
    if m.structure != crate::machine::Structure::TableTable {
        return Err(ProgramError::Structure(m.structure.to_string()));
    }
    let tilt = m.tilt.letter;
    let stroke = |what: &str, a: &Axes| -> Result<(), ProgramError> {
        let axis_m = kin.nominal_tool_axis_machine(a.tilt, a.c);
        let gauge = a.xyz + axis_m * kin.gauge_length();
        m.check_strokes(&gauge)
            .map_err(|(axis, value, (lo, hi))| ProgramError::Stroke {
                what: what.to_string(),
                axis,
                value,
                lo,
                hi,
            })
    };
    let mut rings: Vec<Vec<Axes>> = Vec::new();
    let mut hint: Option<Axes> = None;
    for (k, &z) in RINGS.iter().enumerate() {
        let mut ring = Vec::with_capacity(STEPS + 1);
        for i in 0..=STEPS {
            let phi = 2.0 * PI * i as f64 / STEPS as f64;
            let a = kin
                .inverse_nominal(&pose(z, phi), hint.as_ref())
                .map_err(|cause| ProgramError::Reach {
                    ring: k + 1,
                    angle: phi.to_degrees(),
                    cause,
                })?;
            stroke(&format!("ring {}, {:.0} deg", k + 1, phi.to_degrees()), &a)?;
            hint = Some(a);
            ring.push(a);
        }
        rings.push(ring);
    }
    let mut s = String::new();
    let _ = writeln!(s, "%");
    let _ = writeln!(s, "O2001 (FIVECAL DEMO - FIVE-AXIS FRUSTUM FINISH)");
    for line in [
        format!(
            "MACHINE {} - POST-SIDE KINEMATICS, NO TCP",
            m.name.to_uppercase()
        ),
        "TOOL END FACE ON 3 RINGS OF A FRUSTUM ON THE TABLE".into(),
        format!(
            "BASE R{} MM AT W ORIGIN, FLANKS {} DEG, AXIS LEANS 35-45 DEG",
            BASE_RADIUS, FLANK
        ),
        format!(
            "T{} {} D{} L{}",
            m.tool.number,
            m.tool.name.to_uppercase(),
            m.tool.diameter,
            m.tool.length
        ),
        "G54 = W AT ROTARY ZERO, INVERSE-TIME FEED G93".into(),
        format!("ROTARY MOVES ONLY AT THE SAFE HEIGHT Z{}", num(SAFE_Z)),
        "WRITTEN BY FIVECAL DEMO".into(),
    ] {
        let _ = writeln!(s, "({line})");
    }
    let _ = writeln!(s, "G21 G17 G40 G49 G80 G90 G94");
    let _ = writeln!(s, "G54");
    let _ = writeln!(s, "T{} M06", m.tool.number);
    let _ = writeln!(s, "S9000 M03");
    // One block sets every axis, at the safe height, so that the position
    // is known from the start (as a compensator or simulator needs it).
    let first = &rings[0][0];
    let _ = writeln!(
        s,
        "G00 G43 H{} X{} Y{} Z{} {tilt}{} C{}",
        m.tool.number,
        num(first.xyz.x),
        num(first.xyz.y),
        num(SAFE_Z),
        num(first.tilt),
        num(first.c)
    );
    for (k, ring) in rings.iter().enumerate() {
        let first = &ring[0];
        let above = |a: &Axes| -> Axes {
            let axis_m = kin.nominal_tool_axis_machine(a.tilt, a.c);
            Axes {
                xyz: a.xyz + axis_m * CLEAR,
                ..*a
            }
        };
        let start = above(first);
        stroke(&format!("ring {} approach", k + 1), &start)?;
        let _ = writeln!(s, "(RING {} AT Z{})", k + 1, num(RINGS[k]));
        // Rotary axes turn with the tool at the safe height, then the tool
        // comes down in air above the ring, and feeds in along its axis.
        let _ = writeln!(s, "G00 Z{}", num(SAFE_Z));
        let _ = writeln!(s, "G00 {tilt}{} C{}", num(first.tilt), num(first.c));
        let _ = writeln!(s, "G00 X{} Y{}", num(start.xyz.x), num(start.xyz.y));
        let _ = writeln!(s, "G00 Z{}", num(start.xyz.z + CLEAR));
        let _ = writeln!(s, "G01 G94 Z{} F2000.", num(start.xyz.z));
        let _ = writeln!(s, "G01 {} F600.", block(first, tilt));
        let _ = writeln!(s, "G93");
        for w in ring.windows(2) {
            let (p0, p1) = (
                kin.forward_nominal(&w[0]).tip,
                kin.forward_nominal(&w[1]).tip,
            );
            let minutes = (p1 - p0).norm() / FEED;
            let _ = writeln!(s, "G01 {} F{}", block(&w[1], tilt), num(1.0 / minutes));
        }
        let last = ring.last().expect("rings have points");
        let _ = writeln!(s, "G94");
        let _ = writeln!(s, "G01 {} F2000.", block(&above(last), tilt));
    }
    let _ = writeln!(s, "G00 Z{}", num(SAFE_Z));
    let _ = writeln!(s, "G00 {tilt}0. C0.");
    let _ = writeln!(s, "M05");
    let _ = writeln!(s, "G49");
    let _ = writeln!(s, "M30");
    let _ = writeln!(s, "%");
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compensate::simulate::{SimSettings, Simulator};
    use crate::machine::{Dialect, Machine};
    use crate::model::Model;

    /// Run on the nominal machine, every cutting block's end point puts the
    /// tool where the contour asks, and the program stays inside the
    /// machine's limits and leaves the rotary axes alone below the safe
    /// height.
    #[test]
    fn the_frustum_program_runs_the_contour_on_the_nominal_machine() {
        let m = Machine::builtin("bc-trunnion").unwrap();
        let kin = Kinematics::new(&m);
        let text = frustum_program(&kin).unwrap();
        let model = Model::new(kin.clone(), Vec::new());
        let sim = Simulator::new(&model, &[], SimSettings::new(Dialect::Fanuc));
        let mut tips = Vec::new();
        let summary = sim
            .run(
                std::path::Path::new("frustum.nc"),
                text.as_bytes(),
                &mut |s| {
                    if s.feed {
                        tips.push(s.nominal);
                    }
                },
            )
            .unwrap();
        assert!(summary.skipped.is_empty(), "{:?}", summary.skipped);
        let on_ring: Vec<_> = tips
            .iter()
            .filter(|p| RINGS.iter().any(|z| (p.tip.z - z).abs() < 1e-3))
            .collect();
        assert_eq!(on_ring.len(), RINGS.len() * (STEPS + 1));
        for p in on_ring {
            let phi = p.tip.y.atan2(p.tip.x);
            let want = pose(p.tip.z, phi);
            // Four decimals of a degree move the tip by up to 0.1 um.
            assert!(
                (p.tip - want.tip).norm() < 2e-4,
                "{:?} vs {:?}",
                p.tip,
                want.tip
            );
            assert!((p.axis - want.axis).norm() < 4e-6);
        }
        // Rotary words only on G00 blocks at the safe height or in feed
        // moves along the contour (which start from a point above it).
        let mut z = f64::NAN;
        for l in text.lines().filter(|l| !l.starts_with('(')) {
            if let Some(v) = l.split_whitespace().find_map(|w| w.strip_prefix('Z')) {
                z = v.parse().unwrap();
            }
            if l.starts_with("G00") && (l.contains(" B") || l.contains(" C")) {
                assert_eq!(z, SAFE_Z, "rotary rapid below the safe height: {l}");
            }
        }
    }
}
