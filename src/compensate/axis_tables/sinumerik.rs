//! SINUMERIK's leadscrew error and measuring system error compensation
//! (LEC), from the function manual "Extended Functions", K3
//! Compensation, "Interpolatory compensation" (6FC5397-1BP40-3BA1, 03/2013,
//! sections 4.4.1-4.4.2; the 808D function manual states the same
//! principle):
//!
//! - the table of machine axis `AXIS` on measuring system 0 is the system
//!   variables `$AA_ENC_COMP[0,N,AXIS]` (the compensation value at
//!   interpolation point N, mm), `$AA_ENC_COMP_STEP[0,AXIS]` (the distance
//!   between points), `$AA_ENC_COMP_MIN` and `_MAX` (the positions of the
//!   first and last point) and `$AA_ENC_COMP_IS_MODULO` (0 for a linear
//!   axis), loaded as an INI part program `%_N_AX_EEC_INI` ... `M17`, with
//!   the compensation off (MD32700 `$MA_ENC_COMP_ENABLE[0] = 0`) while it
//!   loads;
//! - the control modifies the axis's actual position value by the value
//!   interpolated linearly between the points, the first and last value
//!   acting beyond the ends; a positive value moves the axis in the
//!   negative direction: the value to enter is the error itself (actual
//!   minus commanded);
//! - the table has one value per point, for both directions: the
//!   bidirectional mean is entered, and half the reversal is left in each
//!   direction (the control's backlash compensation, MD32450, is the place
//!   for the mean reversal; the listing prints it);
//! - points are equally spaced; N runs to MD38000
//!   `$MA_MM_ENC_COMP_MAX_POINTS` - 1, a machine datum configured on the
//!   control, which the file names as a requirement.
//!
//! Machine axis names are MD10000's; the default X1, Y1, Z1 are written.

use std::path::PathBuf;

use super::{AxisTable, TableError, TablePoint};

/// The machine axis name written for `axis`.
pub fn machine_axis(axis: char) -> String {
    format!("{axis}1")
}

/// The INI part program with every table.
pub fn ini(tables: &[AxisTable]) -> Result<String, TableError> {
    let mut s = String::from("%_N_AX_EEC_INI\n");
    s += "; leadscrew error compensation (LEC), written by fivecal compensate\n";
    s += "; value = positioning error, actual minus commanded, mean of both directions, mm\n";
    s +=
        "; load with MD32700 $MA_ENC_COMP_ENABLE[0] = 0, then set it to 1 and reference the axis\n";
    s += "; machine axis names X1, Y1, Z1: change them where MD10000 names the axes otherwise\n";
    for t in tables {
        if t.equal_step().is_none() {
            return Err(TableError::Refused(format!(
                "sinumerik: the {} table's points are not equally spaced, and the LEC table's are",
                t.axis
            )));
        }
        s += &format!(
            "; {}: {} points from {}, needs MD38000 $MA_MM_ENC_COMP_MAX_POINTS >= {}\n",
            machine_axis(t.axis),
            t.points.len(),
            t.from,
            t.points.len()
        );
    }
    s += "CHANDATA(1)\n";
    for t in tables {
        let a = machine_axis(t.axis);
        let step = t.equal_step().expect("checked above");
        for (n, p) in t.points.iter().enumerate() {
            s += &format!(
                "$AA_ENC_COMP[0,{n},{a}]={:.6} ; {:.4} mm: {:+.3} um u {:.3} um (+ {:+.3}, - {:+.3}, reversal {:+.3})\n",
                p.mean_um() * 1e-3,
                p.position_mm,
                p.mean_um(),
                p.u_mean_um(),
                p.plus_um,
                p.minus_um,
                p.reversal_um()
            );
        }
        s += &format!("$AA_ENC_COMP_STEP[0,{a}]={step:.6}\n");
        s += &format!("$AA_ENC_COMP_MIN[0,{a}]={:.6}\n", t.points[0].position_mm);
        s += &format!(
            "$AA_ENC_COMP_MAX[0,{a}]={:.6}\n",
            t.points[t.points.len() - 1].position_mm
        );
        s += &format!("$AA_ENC_COMP_IS_MODULO[0,{a}]=0\n");
    }
    s += "M17\n";
    Ok(s)
}

/// The files: `AX_EEC.INI` and `axis-tables.txt`, the listing.
pub fn files(tables: &[AxisTable]) -> Result<Vec<(PathBuf, String)>, TableError> {
    let ini = ini(tables)?;
    let mut listing = String::from(
        "SINUMERIK leadscrew error compensation (LEC) in AX_EEC.INI, written by fivecal compensate\n\
         One value per point for both directions: the mean of the two, mm; the control takes it off\n\
         the measured position (a positive value moves the axis negative), interpolated between\n\
         the points and held at the first and last beyond them. Half the reversal B stays in each\n\
         direction; its mean is what the backlash compensation (MD32450) would take.\n\
         The axis was measured as it moved with whatever compensation was active then: measured\n\
         with a table already loaded, add these values to that table's, do not replace it.\n\n",
    );
    for t in tables {
        let mean_b =
            t.points.iter().map(TablePoint::reversal_um).sum::<f64>() / t.points.len() as f64;
        let entered = |p: &TablePoint| format!("{:+.6} mm", p.mean_um() * 1e-3);
        listing += &t.listing((
            &format!("$AA_ENC_COMP[0,N,{}]", machine_axis(t.axis)),
            &entered,
        ));
        listing += &format!("  mean reversal {mean_b:+.3} um, not in the table\n\n");
    }
    Ok(vec![
        (PathBuf::from("AX_EEC.INI"), ini),
        (PathBuf::from("axis-tables.txt"), listing),
    ])
}
