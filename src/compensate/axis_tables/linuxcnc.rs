//! LinuxCNC's joint compensation file (`[JOINT_n]COMP_FILE`, with
//! `COMP_FILE_TYPE = 0`), from LinuxCNC's INI documentation
//! (docs/src/config/ini-config.adoc, `COMP_FILE`, `COMP_FILE_TYPE`) and its
//! source (src/emc/motion/usrmotintf.cc `usrmotLoadComp`, command.c
//! `EMCMOT_SET_JOINT_COMP`, control.c's screw compensation):
//!
//! - one line per point, three numbers separated by blanks: the nominal
//!   (commanded) joint position, the actual position reached moving in
//!   the positive direction, the actual position moving in the negative
//!   direction, all in machine units; nominals strictly rising; at most 256 lines;
//! - the loader converts a type-0 line into trims `nominal - actual` and
//!   the motion controller adds the trim of the direction of motion,
//!   interpolated linearly between the nominals and held at the end values
//!   beyond them, to the motor's commanded position: an axis that goes too
//!   far (actual > nominal) is commanded short by as much;
//! - the loader reads lines while each holds three numbers and stops at
//!   the first that does not, so the file holds no comment: what each
//!   value is, with its u, is in the listing written beside it.
//!
//! Type 0 is written because its columns are what the laser measured
//! (where the axis went), so no sign is left to the reader; type 1's
//! columns are the trims themselves (minus the error).

use std::path::PathBuf;

use super::{AxisTable, TableError, TablePoint};

/// The most points LinuxCNC's motion controller holds per joint
/// (`EMCMOT_COMP_SIZE` in src/emc/motion/motion.h; "256 triplets per
/// joint" in the INI documentation).
pub const MAX_POINTS: usize = 256;

/// The compensation file of `table`, machine units mm.
pub fn comp_file(table: &AxisTable) -> Result<String, TableError> {
    if table.points.len() > MAX_POINTS {
        return Err(TableError::Refused(format!(
            "linuxcnc: the {} table has {} points, and LinuxCNC holds at most {MAX_POINTS} per joint",
            table.axis,
            table.points.len()
        )));
    }
    Ok(table
        .points
        .iter()
        .map(|p| {
            let actual = |e_um: f64| p.position_mm + e_um * 1e-3;
            format!(
                "{:.6} {:.6} {:.6}\n",
                p.position_mm,
                actual(p.plus_um),
                actual(p.minus_um)
            )
        })
        .collect())
}

/// The file name of `axis`'s table.
pub fn file_name(axis: char) -> String {
    format!("{axis}.comp")
}

/// The files: one compensation file per axis and `axis-tables.txt`, the
/// listing with the INI lines that load them.
pub fn files(tables: &[AxisTable]) -> Result<Vec<(PathBuf, String)>, TableError> {
    let mut out = Vec::new();
    let mut listing = String::from(
        "LinuxCNC joint compensation files (COMP_FILE_TYPE = 0), written by fivecal compensate\n\
         Each file: nominal position, actual position moving +, actual position moving -, mm\n\
         (machine units: the INI's LINEAR_UNITS must be mm). LinuxCNC commands the motor at\n\
         nominal - (actual - nominal) in the direction of motion, interpolated between the lines\n\
         and held at the first and last beyond them. With a COMP_FILE the joint's BACKLASH is\n\
         not used: the two columns hold the reversal.\n\
         The axis was measured as it moved with whatever compensation was active then: measured\n\
         with a table already loaded, add these errors to that table's, do not replace it.\n\n\
         INI lines (JOINT_n is the joint that moves the axis; with trivkins and the 5-axis\n\
         kinematics X, Y, Z are joints 0, 1, 2):\n",
    );
    for t in tables {
        let name = file_name(t.axis);
        out.push((PathBuf::from(&name), comp_file(t)?));
        listing += &format!(
            "  [JOINT_{}]  COMP_FILE = {name}  COMP_FILE_TYPE = 0\n",
            super::axis_index(t.axis)
        );
    }
    listing.push('\n');
    for t in tables {
        let entered = |p: &TablePoint| {
            format!(
                "{:.6} {:.6}",
                p.position_mm + p.plus_um * 1e-3,
                p.position_mm + p.minus_um * 1e-3
            )
        };
        listing += &t.listing((
            &format!("in {}: actual +, actual - (mm)", file_name(t.axis)),
            &entered,
        ));
        listing.push('\n');
    }
    out.push((PathBuf::from("axis-tables.txt"), listing));
    Ok(out)
}
