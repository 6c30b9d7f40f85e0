//! One setup's NC program in each dialect: the spindle-ball arbor called
//! and its spindle oriented (so the ball's run-out stays where the sheet
//! measured it), the axes retracted and the rotary axes on the sweep's
//! first angle, TCP on in the dialect's own way (FANUC `G43.4`, HEIDENHAIN
//! `FUNCTION TCPM`, SINUMERIK `TRAORI`), the spindle ball brought onto M,
//! a stop to mount the bar, the axis stepped through the sweep with the
//! tip held on M and a dwell at each angle for a still reading, a stop to
//! take the bar off, the ball lifted along the arbor, TCP off, retract and
//! the rotary axes back to zero: every program begins and ends retracted,
//! so a setup change never happens with the axes down.
//!
//! Stock LinuxCNC has no TCP G-code (its TCP kinematics are switched by
//! configuration-specific remaps), so the LinuxCNC program moves the joints
//! themselves: every X, Y, Z is fivecal's inverse kinematics of the machine
//! file holding the ball on M, and the program's header says so. It steps
//! in inverse-time feed (`G93`), each step taking the time the rotary feed
//! gives it.

use super::{BallBarRequest, Setup, setup_kinematics};
use crate::kinematics::pose_frame::PoseFrame;
use crate::machine::Dialect;
use crate::procedure::instrument_nc::{Out, num};

/// How far above M (along the arbor) the ball approaches and leaves, mm.
pub const APPROACH_MM: f64 = 30.0;

/// Feed of the approach onto M, mm/min.
pub const APPROACH_FEED: f64 = 500.0;

/// Program Z of the retract: the top of the Z stroke less 5 mm for the
/// arbor of this setup.
pub fn safe_z(req: &BallBarRequest, s: &Setup) -> f64 {
    req.machine.strokes[2].1 - req.machine.pivot.z - s.gauge - 5.0
}

/// The header lines: what the program is, where the balls go.
fn header(req: &BallBarRequest, s: &Setup) -> Vec<String> {
    let m = &req.machine;
    let mut v = vec![
        format!("fivecal ball-bar setup {} on {}", s.name, m.name),
        format!(
            "{} axis swept {} .. {} deg in {} steps, {} held at {} deg",
            s.axis,
            s.angles[0],
            s.angles[s.angles.len() - 1],
            s.angles.len() - 1,
            if s.axis == 'C' { m.tilt.letter } else { 'C' },
            s.held
        ),
        format!(
            "spindle ball M at X{:.3} Y{:.3} Z{:.3} in W, table ball N at X{:.3} Y{:.3} Z{:.3}",
            s.m.x, s.m.y, s.m.z, s.n.x, s.n.y, s.n.z
        ),
        format!(
            "bar {} mm along {} from N to M, arbor T{} gauge length {:.3} mm",
            s.bar,
            s.direction.label(),
            s.tool,
            s.gauge
        ),
        format!(
            "zero point {} on the W origin at rotary zero",
            req.dialect.work_offset()
        ),
    ];
    match req.dialect {
        Dialect::Linuxcnc => {
            v.push("no TCP: stock LinuxCNC has no TCP G-code, so every X Y Z below is".into());
            v.push("fivecal's inverse kinematics of the machine file holding the ball on M".into());
        }
        _ => {
            v.push("TCP on: X Y Z are the ball centre in W, which must turn with the table".into());
            v.push(format!(
                "dwell {} s at each angle for a still reading",
                req.dwell_s
            ));
        }
    }
    v
}

/// Formats a number with 4 decimals (and a sign for HEIDENHAIN).
/// The program of setup `s`.
pub fn write(req: &BallBarRequest, s: &Setup) -> String {
    let d = req.dialect;
    let m = &req.machine;
    let tl = m.tilt.letter;
    let kin = setup_kinematics(m, s.gauge);
    let mut o = Out::new(d);
    let name = format!("BALL_BAR_{}", s.name.replace('-', "_"));
    match d {
        Dialect::Fanuc => {
            o.block("%");
            o.block(format!(
                "O{:04} ({name})",
                1000 + s.group * 10 + s.direction.axis
            ));
        }
        Dialect::Linuxcnc => o.block("%"),
        Dialect::Heidenhain => o.block(format!("BEGIN PGM {name} MM")),
        Dialect::Sinumerik => o.block(format!("; {name}")),
    }
    for h in header(req, s) {
        o.comment(&h);
    }
    let safe = safe_z(req, s);
    let (t0, c0) = s.angles_at(0, tl);
    let last = s.angles.len() - 1;
    let (t1, c1) = s.angles_at(last, tl);
    let arbor0 = PoseFrame::new(&kin, t0, c0).probe_axis_w();
    let arbor1 = PoseFrame::new(&kin, t1, c1).probe_axis_w();
    let above0 = s.m + arbor0 * APPROACH_MM;
    let above1 = s.m + arbor1 * APPROACH_MM;
    // Preamble, arbor, spindle orientation.
    match d {
        Dialect::Fanuc => {
            o.block("G21 G90 G17 G40 G49 G80 G94");
            o.block("G54");
            o.block(format!("T{} M6", s.tool));
            o.block(format!("G43 H{}", s.tool));
            o.block("M19");
        }
        Dialect::Linuxcnc => {
            o.block("G21 G90 G17 G40 G49 G80 G94 G64 P0.001");
            o.block("G54");
            o.block(format!("T{} M6", s.tool));
            o.block(format!("G43 H{}", s.tool));
            o.block("M19 R0");
        }
        Dialect::Sinumerik => {
            o.block("G71 G90 G17 G40 G94");
            o.block("TRAFOOF");
            o.block("G54");
            o.block(format!("T{} M6", s.tool));
            o.block("D1");
            o.block("SPOS=0");
        }
        Dialect::Heidenhain => {
            o.block("CYCL DEF 247 DATUM SETTING ~");
            o.block("  Q339=+1 ;DATUM NUMBER");
            o.block(format!("TOOL CALL {} Z", s.tool));
            o.block("CYCL DEF 13.0 ORIENTATION");
            o.block("CYCL DEF 13.1 ANGLE0");
        }
    }
    o.comment("retract, then the rotary axes to the first angle");
    o.rapid(&format!("Z{}", num(d, safe)));
    o.rapid(&o.rot(tl, t0, c0));
    if d == Dialect::Linuxcnc {
        let pf = PoseFrame::new(&kin, t0, c0);
        let a = pf.commanded(&above0);
        o.rapid(&o.xyz(&a.xyz));
        o.feed(&o.xyz(&s.axes[0].xyz), APPROACH_FEED);
    } else {
        match d {
            Dialect::Fanuc => o.block(format!("G43.4 H{}", s.tool)),
            Dialect::Heidenhain => o.block("FUNCTION TCPM F CONT AXIS POS PATHCTRL AXIS"),
            _ => o.block("TRAORI"),
        }
        o.rapid(&o.xyz(&above0));
        o.feed(&o.xyz(&s.m), APPROACH_FEED);
    }
    o.stop(&format!(
        "mount the {} mm bar between the spindle ball and the table ball, then start",
        s.bar
    ));
    o.comment(&format!("sweep of {}: one still reading per angle", s.axis));
    if d == Dialect::Linuxcnc {
        o.block("G93");
    }
    for i in 0..s.angles.len() {
        if i > 0 {
            let (t, c) = s.angles_at(i, tl);
            let step = (s.angles[i] - s.angles[i - 1]).abs();
            if d == Dialect::Linuxcnc {
                // Inverse time: F is 1 / minutes of the step.
                let words = format!("{} {}", o.xyz(&s.axes[i].xyz), o.rot(tl, t, c));
                o.block(format!("G1 {words} F{:.4}", req.feed_deg_min / step));
            } else {
                let words = format!("{} {}", o.xyz(&s.m), o.rot(tl, t, c));
                o.feed(&words, req.feed_deg_min);
            }
        }
        if req.dwell_s > 0.0 {
            o.dwell(req.dwell_s);
        }
    }
    if d == Dialect::Linuxcnc {
        o.block("G94");
    }
    o.stop("take the bar off, then start");
    if d == Dialect::Linuxcnc {
        let a = PoseFrame::new(&kin, t1, c1).commanded(&above1);
        o.feed(&o.xyz(&a.xyz), APPROACH_FEED);
    } else {
        o.feed(&o.xyz(&above1), APPROACH_FEED);
        match d {
            Dialect::Fanuc => o.block(format!("G43 H{}", s.tool)),
            Dialect::Heidenhain => o.block("FUNCTION RESET TCPM"),
            _ => o.block("TRAFOOF"),
        }
    }
    o.comment("retract before the next setup");
    o.rapid(&format!("Z{}", num(d, safe)));
    o.rapid(&o.rot(tl, 0.0, 0.0));
    o.finish(&name)
}
