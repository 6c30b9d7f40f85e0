//! The tool assembly against the setup: the holder (a cylinder from the
//! spindle gauge line towards the tip) and the spindle nose (a cylinder
//! beyond the gauge line) swept along every cutting move of every pose,
//! against the table (a disc of the machine's table radius), the riser and
//! the stock block.
//!
//! Within a pose the rotary axes stand still and the tool only translates,
//! so the volume a part sweeps along a straight move is exactly a
//! parallelogram grown by the part's radius; its distance to each solid
//! comes from the probing tests' GJK ([`crate::procedure::probing::collision`]).
//! A plan whose assembly comes closer than [`ASSEMBLY_MARGIN`] to any of
//! them is refused with the pose, the part, what it meets and the
//! clearance (negative: how far it reaches into it). The cut itself (the
//! tool below the holder, inside the material it removes) is not checked
//! against the block: that is what it is there for.

use std::fmt;

use nalgebra::Vector3;

use super::design::MachiningDesign;
use super::template::{Holder, SpindleNose};
use crate::machine::Machine;
use crate::procedure::probing::ConvexSolid;
use crate::procedure::probing::collision::{swept_distance, swept_within};
use crate::procedure::{PlanError, short};

/// The gap the holder and spindle nose keep from the setup, mm (the
/// probing tests' `safe_margin` default).
pub const ASSEMBLY_MARGIN: f64 = 2.0;

/// Thickness of the table modelled below its surface, mm (enough for the
/// nose to be refused rather than pass under a thin disc).
const TABLE_THICKNESS: f64 = 50.0;

/// A part of the tool assembly meeting the setup.
#[derive(Clone, Debug, PartialEq)]
pub struct AssemblyCollision {
    /// Pose id.
    pub pose: String,
    /// Letter of the tilt axis.
    pub letter: char,
    /// Tilt, deg.
    pub tilt: f64,
    /// C, deg.
    pub c: f64,
    /// `tool holder` or `spindle nose`.
    pub part: &'static str,
    /// The part's diameter, mm.
    pub diameter: f64,
    /// `table`, `riser` or `stock block`.
    pub obstacle: &'static str,
    /// Smallest distance between the part and the obstacle along the
    /// pose's cutting moves, mm (negative: the part reaches that far into it).
    pub clearance: f64,
    /// The cutting move where it is smallest: tool-tip start and end in W, mm.
    pub from: Vector3<f64>,
    /// See `from`.
    pub to: Vector3<f64>,
}

impl AssemblyCollision {
    /// How much higher the piece would have to stand for the part to
    /// keep [`ASSEMBLY_MARGIN`] from the table, mm (an upper bound when
    /// the part meets the table's rim rather than its top).
    pub fn shortfall(&self) -> f64 {
        ASSEMBLY_MARGIN - self.clearance
    }
}

impl fmt::Display for AssemblyCollision {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let how = if self.clearance < 0.0 {
            format!(
                "reaches {} mm into the {}",
                short_1(-self.clearance),
                self.obstacle
            )
        } else {
            format!(
                "passes {} mm from the {}",
                short_1(self.clearance),
                self.obstacle
            )
        };
        let key = if self.part == "tool holder" {
            "holder.diameter"
        } else {
            "spindle_nose.diameter"
        };
        let what_to_do = if self.obstacle == "table" {
            "put the piece on a higher riser (stock.fixture_height, or stock.raise: true to let the plan raise it) or, if this machine's is narrower, give its"
        } else {
            "use a tool that sticks out further (the holder reaches holder.length below the gauge line) or, if yours is narrower, give its"
        };
        write!(
            f,
            "pose {} ({} = {}, C = {}): the {} (diameter {} mm) {} on the cut from X{:.3} Y{:.3} Z{:.3} to X{:.3} Y{:.3} Z{:.3} (tool tip in W): clearance {} mm, at least {} mm needed; {what_to_do} {key} in the template",
            self.pose,
            self.letter,
            short(self.tilt),
            short(self.c),
            self.part,
            short(self.diameter),
            how,
            self.from.x,
            self.from.y,
            self.from.z,
            self.to.x,
            self.to.y,
            self.to.z,
            short_1(self.clearance),
            short(ASSEMBLY_MARGIN),
        )
    }
}

/// A clearance to 0.1 mm, without a trailing `.0`.
fn short_1(v: f64) -> String {
    short((v * 10.0).round() / 10.0)
}

/// The setup's solids the assembly must keep clear of.
fn obstacles(m: &Machine, design: &MachiningDesign) -> Vec<(&'static str, ConvexSolid)> {
    let cuboid = |c: &crate::mesh::Cuboid| ConvexSolid::Cuboid {
        centre: c.center,
        axes: c.axes,
        half: c.half,
    };
    let mut v = vec![(
        "table",
        ConvexSolid::Cylinder {
            a: Vector3::new(0.0, 0.0, m.table.surface - TABLE_THICKNESS),
            b: Vector3::new(0.0, 0.0, m.table.surface),
            radius: m.table.radius,
        },
    )];
    if let Some(f) = &design.fixture {
        v.push(("riser", cuboid(f)));
    }
    v.push(("stock block", cuboid(&design.stock)));
    v
}

/// Checks the holder and spindle nose along every cutting move of the
/// design; the first pose (in execution order) where a part comes closer
/// than [`ASSEMBLY_MARGIN`] is refused with its smallest clearance.
pub(crate) fn check(
    m: &Machine,
    design: &MachiningDesign,
    holder: &Holder,
    nose: &SpindleNose,
) -> Result<(), PlanError> {
    let tool = &design.tool;
    if holder.length >= tool.length {
        return Err(PlanError::Impossible(format!(
            "holder.length {} mm reaches the tip of tool T{} `{}` (gauge length {} mm): the tool must stick out of its holder; give the holder's length below the gauge line",
            short(holder.length),
            tool.number,
            tool.name,
            short(tool.length)
        )));
    }
    let obstacles = obstacles(m, design);
    let parts = [
        (
            "tool holder",
            holder.diameter,
            tool.length - holder.length,
            holder.length,
        ),
        ("spindle nose", nose.diameter, tool.length, nose.length),
    ];
    let letter = m.tilt_letter();
    for pose in &design.poses {
        let axis = pose.axis.normalize();
        let mut worst: Option<AssemblyCollision> = None;
        for stroke in &pose.strokes {
            let mut prev = stroke.start;
            for (p, _) in &stroke.segs {
                for &(part, diameter, offset, length) in &parts {
                    let r = diameter / 2.0;
                    let a = prev + axis * offset;
                    let e1 = axis * length;
                    let e2 = p - prev;
                    let reach = 0.5 * (e1.norm() + e2.norm()) + r;
                    let mid = a + 0.5 * (e1 + e2);
                    for (name, solid) in &obstacles {
                        let (oc, or) = solid.bounding_ball();
                        if (mid - oc).norm() > reach + or + ASSEMBLY_MARGIN
                            || !swept_within(a, e1, e2, r, solid, ASSEMBLY_MARGIN)
                        {
                            continue;
                        }
                        let clearance = clearance(a, e1, e2, r, solid);
                        if worst.as_ref().is_none_or(|w| clearance < w.clearance) {
                            worst = Some(AssemblyCollision {
                                pose: pose.id.clone(),
                                letter,
                                tilt: pose.tilt,
                                c: pose.c,
                                part,
                                diameter,
                                obstacle: name,
                                clearance,
                                from: prev,
                                to: *p,
                            });
                        }
                    }
                }
                prev = *p;
            }
        }
        if let Some(w) = worst {
            return Err(PlanError::Assembly(Box::new(w)));
        }
    }
    Ok(())
}

/// The distance between a part of `radius` swept along a move and a
/// solid, mm; where they meet, minus the amount its radius would have to
/// shrink for them to part (how far a nose over the table reaches into
/// it), or minus the radius when even its axis meets the solid.
fn clearance(
    a: Vector3<f64>,
    e1: Vector3<f64>,
    e2: Vector3<f64>,
    r: f64,
    solid: &ConvexSolid,
) -> f64 {
    let d = swept_distance(a, e1, e2, r, solid, 0.01);
    if d > 0.0 {
        return d;
    }
    if swept_within(a, e1, e2, 0.0, solid, 0.0) {
        return -r;
    }
    let (mut lo, mut hi) = (0.0, r);
    while hi - lo > 0.01 {
        let mid = 0.5 * (lo + hi);
        if swept_within(a, e1, e2, mid, solid, 0.0) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    -(r - lo)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_message_names_the_pose_the_part_and_the_clearance() {
        let c = AssemblyCollision {
            pose: "B90C0".into(),
            letter: 'B',
            tilt: 90.0,
            c: 0.0,
            part: "spindle nose",
            diameter: 160.0,
            obstacle: "table",
            clearance: -43.04,
            from: Vector3::new(47.0, -20.0, 37.0),
            to: Vector3::new(47.0, 20.0, 37.0),
        };
        let text = c.to_string();
        assert!(text.starts_with("pose B90C0 (B = 90, C = 0): the spindle nose (diameter 160 mm) reaches 43 mm into the table"), "{text}");
        assert!(
            text.contains("clearance -43 mm, at least 2 mm needed"),
            "{text}"
        );
        assert!(text.contains("spindle_nose.diameter"), "{text}");
        assert!((c.shortfall() - 45.04).abs() < 1e-12);
    }
}
