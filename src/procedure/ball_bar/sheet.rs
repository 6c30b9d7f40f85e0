//! The setup sheets: one per setup (where the table ball goes, which bar,
//! which way, the run-out check of the spindle ball, the program) and the
//! overview `ball-bar.md` (every setup in order, what was adapted or left
//! out, and what the runs will identify).

use std::fmt::Write as _;
use std::path::Path;

use super::{BallBarPlan, Setup};

/// The sheet of one setup.
pub(super) fn setup_sheet(plan: &BallBarPlan, s: &Setup, program: &Path) -> String {
    let req = &plan.request;
    let m = &req.machine;
    let mut t = String::new();
    let _ = writeln!(t, "# Ball bar, setup {} on {} (fivecal)\n", s.name, m.name);
    let what = match s.swing {
        Some(sw) => format!(
            "the {} head, with the spindle ball {sw} mm from its rotation centre (S)",
            s.axis
        ),
        None => format!(
            "the {} table, with the spindle ball at (K, L, H) = ({}, {}, {}) mm",
            s.axis, s.m.x, s.m.y, s.m.z
        ),
    };
    let _ = writeln!(t, "Measures {what}.\n");
    let _ = writeln!(t, "| | |\n|---|---|");
    let _ = writeln!(t, "| program | `{}` ({}) |", program.display(), req.dialect);
    let _ = writeln!(
        t,
        "| spindle ball M (in W) | X {:.3}, Y {:.3}, Z {:.3} mm |",
        s.m.x, s.m.y, s.m.z
    );
    let _ = writeln!(
        t,
        "| table ball N (in W) | X {:.3}, Y {:.3}, Z {:.3} mm: a post {:.1} mm above the table top |",
        s.n.x,
        s.n.y,
        s.n.z,
        s.n.z - m.table.surface
    );
    let _ = writeln!(
        t,
        "| bar | {} mm, along {} from N to M |",
        s.bar,
        s.direction.label()
    );
    let _ = writeln!(
        t,
        "| arbor | T{}, gauge line to ball centre {:.3} mm |",
        s.tool, s.gauge
    );
    let other = if s.axis == 'C' { m.tilt.letter } else { 'C' };
    let _ = writeln!(
        t,
        "| sweep | {} from {} to {} deg, {} angles, {} held at {} deg; {} s still at each, steps at {} deg/min |",
        s.axis,
        s.angles[0],
        s.angles[s.angles.len() - 1],
        s.angles.len(),
        other,
        s.held,
        req.dwell_s,
        req.feed_deg_min
    );
    let _ = writeln!(
        t,
        "| clearance | the bar stays at least {:.0} deg off the arbor |",
        s.clearance_deg
    );
    let _ = writeln!(t, "\n## Steps\n");
    let _ = writeln!(
        t,
        "1. Set the zero point ({}) on the W origin at rotary zero: the C axis at the table top.",
        req.dialect.work_offset()
    );
    let _ = writeln!(
        t,
        "2. Run-out of the spindle ball: put a dial indicator on the ball's equator and turn the \
         spindle slowly by hand through a full turn. Half the indicator's range is the run-out r; \
         note it and the spindle angle of its maximum. The program orients the spindle (angle 0) \
         before the sweep, so the ball's offset stays where it is and the bar reads it as \
         r cos(angle - phase) over a turn of the table (the paper's eqs. 10 and 15). Re-seat the \
         arbor if r exceeds {:.1} um (twice the bar's noise).",
        2.0 * req.noise_um
    );
    let _ = writeln!(
        t,
        "3. Fix the table ball's post so the ball's centre is at N (the bar's setting fixture, or \
         the spindle ball brought to N and the post set under it)."
    );
    let _ = writeln!(
        t,
        "4. Check that TCP on this control carries the table rotation (X, Y, Z of the program move \
         with the table), then start the program: it retracts, turns to the first angle, switches \
         TCP on, brings the spindle ball onto M and stops."
    );
    let _ = writeln!(
        t,
        "5. Mount the {} mm bar between the balls, start the capture in the instrument's software, \
         and restart the program: it steps through the sweep with a dwell at each angle.",
        s.bar
    );
    let _ = writeln!(
        t,
        "6. At the next stop, end the capture, take the bar off and restart: the program lifts the \
         ball, switches TCP off, retracts and turns the rotary axes to zero."
    );
    let _ = writeln!(
        t,
        "7. Save the run as `{}.txt` in the plain format (docs/ball-bar.md): `setup: {}`, then \
         the deviation per angle, or the samples with the capture's rate and the samples where \
         the sweep began and ended.",
        s.name, s.name
    );
    t
}

/// The overview sheet.
pub(super) fn overview(plan: &BallBarPlan) -> String {
    let req = &plan.request;
    let mut t = String::new();
    let _ = writeln!(
        t,
        "# Ball bar under TCP on {} (fivecal)\n",
        req.machine.name
    );
    let _ = writeln!(
        t,
        "Every rotary axis stepped through its range while the control holds the spindle ball \
         still on the table (TCP on); a ball bar between it and a ball on the table reads how far \
         it strays. Bars: {} mm. Bar noise {} um, calibration {} um.\n",
        req.bars
            .iter()
            .map(|b| crate::numbers::echo(*b))
            .collect::<Vec<_>>()
            .join(", "),
        req.noise_um,
        req.calibration_um
    );
    let _ = writeln!(t, "| setup | axis | M (mm, W) | N (mm, W) | bar | angles |");
    let _ = writeln!(t, "|---|---|---|---|---|---|");
    for s in &plan.setups {
        let _ = writeln!(
            t,
            "| {} | {} | {:.1}, {:.1}, {:.1} | {:.1}, {:.1}, {:.1} | {} mm {} | {} .. {} ({}) |",
            s.name,
            s.axis,
            s.m.x,
            s.m.y,
            s.m.z,
            s.n.x,
            s.n.y,
            s.n.z,
            s.bar,
            s.direction.label(),
            s.angles[0],
            s.angles[s.angles.len() - 1],
            s.angles.len()
        );
    }
    let _ = writeln!(t, "\n## What the runs identify\n");
    let _ = writeln!(t, "```\n{}```", plan.prediction.render());
    crate::procedure::push_notes(&mut t, &plan.notes);
    t
}
