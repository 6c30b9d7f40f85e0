//! The setup sheets: one per line (where the reflector and the
//! interferometer go, how the offset is made, the program, the steps) and
//! the overview `laser-lines.md` (the ten lines in order, the time).

use std::fmt::Write as _;

use super::{AXES, LaserPlan, POINT_NAMES};
use crate::formats::laser::LineEntry;

fn xyz(v: &[f64; 3]) -> String {
    format!("X {:.3}, Y {:.3}, Z {:.3}", v[0], v[1], v[2])
}

/// Which point of the method the line traces: P, or the offset point.
pub(super) fn point_name(l: &LineEntry) -> &'static str {
    match l.offset.iter().position(|v| *v != 0.0) {
        Some(k) => POINT_NAMES[k],
        None => "P",
    }
}

/// The sheet of one line.
pub(super) fn setup_sheet(plan: &LaserPlan, l: &LineEntry) -> String {
    let req = &plan.request;
    let m = &req.machine;
    let n = l.targets.len();
    let end: [f64; 3] = std::array::from_fn(|k| l.start[k] + l.direction[k] * l.targets[n - 1]);
    let mut t = String::new();
    let _ = writeln!(t, "# Laser line {} on {} (fivecal)\n", l.name, m.name);
    let what = if l.axes == "XYZ" {
        "the volume's diagonal: X, Y and Z move together, so their squareness adds to the positioning".to_string()
    } else {
        format!(
            "the positioning of {} along the path of {}",
            l.axes,
            point_name(l)
        )
    };
    let _ = writeln!(t, "Measures {what} (ISO 230-2 standard test cycle).\n");
    let _ = writeln!(t, "| | |\n|---|---|");
    let _ = writeln!(
        t,
        "| program | `{}` ({}) |",
        l.program.display(),
        req.dialect
    );
    let _ = writeln!(
        t,
        "| line | from {} to {} mm, machine coordinates of the measured point |",
        xyz(&l.start),
        xyz(&end)
    );
    let _ = writeln!(
        t,
        "| direction | {:.6}, {:.6}, {:.6} |",
        l.direction[0], l.direction[1], l.direction[2]
    );
    let offset = match l.offset_by.as_str() {
        "axes" => {
            let k = l.offset.iter().position(|v| *v != 0.0).unwrap_or(0);
            format!(
                "{} = P + {:.3} mm along {}: made by {} holding that position while {} moves ({} lies between {} and the tool in the chain {})",
                point_name(l),
                l.offset[k],
                AXES[k],
                AXES[k],
                l.axes,
                AXES[k],
                l.axes,
                m.chain
            )
        }
        "bracket" => {
            let k = l.offset.iter().position(|v| *v != 0.0).unwrap_or(0);
            format!(
                "{} = P + {:.3} mm along {}: a reflector bracket on the spindle ({} lies on the table side of {} in the chain {}, so moving it would not carry the lever arm)",
                point_name(l),
                l.offset[k],
                AXES[k],
                AXES[k],
                l.axes,
                m.chain
            )
        }
        _ => "none: the reflector at the spindle gauge point P".to_string(),
    };
    let _ = writeln!(t, "| offset | {offset} |");
    let _ = writeln!(
        t,
        "| targets | {n}: 0 .. {} mm in equal steps of {} mm |",
        crate::numbers::echo(l.targets[n - 1]),
        crate::numbers::echo(l.targets[1] - l.targets[0])
    );
    let _ = writeln!(
        t,
        "| cycle | {} runs; each: every target from below (+), overrun {} mm, every target from above (-), overrun {} mm; {} s still at each target |",
        req.runs, req.overrun_mm, req.overrun_mm, req.dwell_s
    );
    let _ = writeln!(t, "| time | about {:.0} min |", plan.seconds(l) / 60.0);
    let _ = writeln!(t, "\n## Steps\n");
    let _ = writeln!(
        t,
        "1. Set the zero point ({}) on the volume's first corner X {}, Y {}, Z {} (machine coordinates), no tool length: the program moves the spindle gauge point.",
        req.dialect.work_offset(),
        plan.volume[0],
        plan.volume[1],
        plan.volume[2]
    );
    let reflector = if l.offset_by == "bracket" {
        "Clamp the reflector bracket in the spindle with the reflector's centre at the offset above"
    } else {
        "Clamp the linear reflector in the spindle with its centre at the gauge point"
    };
    let _ = writeln!(t, "2. {reflector}; lock the spindle.");
    let _ = writeln!(
        t,
        "3. Put the interferometer (beam splitter with its reflector) on the table on the line, before its start, and the laser head beyond it on a tripod, the beam along the direction above through the measured point. Align over the whole line (the reflector at both ends) until the signal stays full."
    );
    let _ = writeln!(
        t,
        "4. Put the air sensor near the beam and the material sensor on the table; turn on the environmental compensation and write down what the software states (it goes into the run file)."
    );
    let _ = writeln!(
        t,
        "5. Run the program. At the first stop the reflector is on target 0, approached from below: set the reading to zero and start the automatic capture (a reading when the machine is still for the dwell, {} targets each way in each of {} runs).",
        n, req.runs
    );
    let _ = writeln!(
        t,
        "6. Export the run (fivecal's plain format or the software's .rtl text) named `{}` and give it to `fivecal analyze`.",
        l.name
    );
    t
}

/// The overview of the ten lines.
pub(super) fn overview(plan: &LaserPlan) -> String {
    let req = &plan.request;
    let v = &plan.volume;
    let mut t = String::new();
    let _ = writeln!(
        t,
        "# Laser interferometer, ten lines on {} (fivecal)\n",
        req.machine.name
    );
    let _ = writeln!(
        t,
        "Measuring volume X {} .. {}, Y {} .. {}, Z {} .. {} mm (machine coordinates), {} equal divisions per line, {} runs each way (ISO 230-2), programs for {}.\n",
        v[0], v[3], v[1], v[4], v[2], v[5], req.divisions, req.runs, req.dialect
    );
    let _ = writeln!(
        t,
        "| line | moves | point | offset | made by | length, mm | program | min |"
    );
    let _ = writeln!(t, "|---|---|---|---|---|---|---|---|");
    let mut total = 0.0;
    for l in &plan.lines {
        let s = plan.seconds(l);
        total += s;
        let _ = writeln!(
            t,
            "| {} | {} | {} | {:.1}, {:.1}, {:.1} | {} | {} | `{}` | {:.0} |",
            l.name,
            l.axes,
            point_name(l),
            l.offset[0],
            l.offset[1],
            l.offset[2],
            l.offset_by,
            crate::numbers::echo(l.targets[l.targets.len() - 1]),
            l.program.display(),
            s / 60.0
        );
    }
    let _ = writeln!(
        t,
        "\nAbout {:.1} h of measuring, without the alignments.",
        total / 3600.0
    );
    for n in &plan.notes {
        let _ = writeln!(t, "\nNote: {n}");
    }
    t
}
