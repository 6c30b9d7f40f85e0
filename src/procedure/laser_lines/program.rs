//! One line's NC program in each dialect: the ISO 230-2 standard test
//! cycle along the line. The program starts retracted (Z at the top of its
//! stroke less 5 mm), goes above the overrun position before the first
//! target and down onto it, approaches target 0 and stops for the optics
//! to be aligned and the reading set to zero there; then each run
//! approaches every target from below (+) with a dwell for the
//! interferometer's automatic capture, overruns the last target, approaches
//! every target from above (-) with a dwell, and overruns the first; at the
//! end it retracts. The rotary axes stay at zero throughout (a head
//! machine's spindle vertical). Coordinates are those of the zero point set on the
//! volume's first corner (X0, Y0, Z0), with no tool length: the spindle's
//! gauge point, where the reflector (or its bracket) is clamped.

use nalgebra::Vector3;

use super::LaserRequest;
use crate::formats::laser::LineEntry;
use crate::machine::Dialect;
use crate::procedure::instrument_nc::Out;

/// Machine Z of the retract: the top of the Z stroke less 5 mm.
pub fn safe_z(req: &LaserRequest) -> f64 {
    req.machine.strokes[2].1 - 5.0
}

/// The header lines: what the program is.
pub fn header(req: &LaserRequest, volume: &[f64; 6], l: &LineEntry) -> Vec<String> {
    let m = &req.machine;
    let n = l.targets.len();
    let mut v = vec![
        format!(
            "fivecal laser-lines {} on {}: ISO 230-2 positioning test along {}",
            l.name,
            m.name,
            if l.axes == "XYZ" {
                "the volume diagonal".to_string()
            } else {
                l.axes.clone()
            }
        ),
        format!(
            "{n} targets 0 .. {} mm, {} runs each way, overrun {} mm, dwell {} s per target",
            crate::numbers::echo(l.targets[n - 1]),
            req.runs,
            req.overrun_mm,
            req.dwell_s
        ),
        format!(
            "measured point at target 0: X{:.3} Y{:.3} Z{:.3} machine coordinates",
            l.start[0], l.start[1], l.start[2]
        ),
    ];
    match l.offset_by.as_str() {
        "axes" => v.push(format!(
            "offset from P {:.3} {:.3} {:.3} mm made by the axes' position",
            l.offset[0], l.offset[1], l.offset[2]
        )),
        "bracket" => v.push(format!(
            "reflector on a bracket {:.3} {:.3} {:.3} mm from the spindle gauge point",
            l.offset[0], l.offset[1], l.offset[2]
        )),
        _ => v.push("reflector at the spindle gauge point P".into()),
    }
    v.push(format!(
        "zero point {} on the volume corner X{} Y{} Z{} machine coordinates, no tool length, rotary axes at zero",
        req.dialect.work_offset(),
        volume[0],
        volume[1],
        volume[2]
    ));
    v
}

/// The program of line `l`.
pub fn write(req: &LaserRequest, volume: &[f64; 6], l: &LineEntry) -> String {
    let d = req.dialect;
    let v0 = Vector3::new(volume[0], volume[1], volume[2]);
    let dir = Vector3::from(l.direction);
    let at = |i: usize| Vector3::from(l.spindle_at(i)) - v0;
    let n = l.targets.len();
    let before = at(0) - dir * req.overrun_mm;
    let after = at(n - 1) + dir * req.overrun_mm;
    let safe = (safe_z(req) - v0.z).max(before.z).max(after.z);
    let mut o = Out::new(d);
    let number: u32 = l.name.trim_start_matches('L').parse().unwrap_or(0);
    let name = format!("LASER_{}", l.name);
    match d {
        Dialect::Fanuc => {
            o.block("%");
            o.block(format!("O{:04} ({name})", 2000 + number));
        }
        Dialect::Linuxcnc => o.block("%"),
        Dialect::Heidenhain => o.block(format!("BEGIN PGM {name} MM")),
        Dialect::Sinumerik => o.block(format!("; {name}")),
    }
    for h in header(req, volume, l) {
        o.comment(&h);
    }
    match d {
        Dialect::Fanuc => {
            o.block("G21 G90 G17 G40 G49 G80 G94");
            o.block("G54");
        }
        Dialect::Linuxcnc => {
            o.block("G21 G90 G17 G40 G49 G80 G94 G64 P0.001");
            o.block("G54");
        }
        Dialect::Sinumerik => {
            o.block("G71 G90 G17 G40 G94");
            o.block("TRAFOOF");
            o.block("G54");
            o.block("D0");
        }
        Dialect::Heidenhain => {
            o.block("CYCL DEF 247 DATUM SETTING ~");
            o.block("  Q339=+1 ;DATUM NUMBER");
            o.block("TOOL CALL 0 Z");
        }
    }
    o.comment("retract, the rotary axes to zero, then above the overrun before the first target");
    o.rapid(&o.words(&[('Z', safe)]));
    o.rapid(&o.words(&[(req.machine.tilt.letter, 0.0), ('C', 0.0)]));
    o.rapid(&o.words(&[('X', before.x), ('Y', before.y)]));
    o.feed(&o.xyz(&before), req.feed_mm_min);
    o.feed(&o.xyz(&at(0)), req.feed_mm_min);
    o.stop(&format!(
        "align the optics along {}, set the reading to zero here, start the automatic capture",
        l.name
    ));
    for run in 1..=req.runs {
        o.comment(&format!("run {run} of {}: + approach", req.runs));
        if run > 1 {
            o.feed(&o.xyz(&before), req.feed_mm_min);
        }
        for i in 0..n {
            if !(run == 1 && i == 0) {
                o.feed(&o.xyz(&at(i)), req.feed_mm_min);
            }
            o.dwell(req.dwell_s);
        }
        o.feed(&o.xyz(&after), req.feed_mm_min);
        o.comment(&format!("run {run} of {}: - approach", req.runs));
        for i in (0..n).rev() {
            o.feed(&o.xyz(&at(i)), req.feed_mm_min);
            o.dwell(req.dwell_s);
        }
    }
    o.feed(&o.xyz(&before), req.feed_mm_min);
    o.stop(&format!("{} done: stop the capture, save the run", l.name));
    o.comment("retract");
    o.rapid(&o.words(&[('Z', safe)]));
    o.finish(&name)
}
