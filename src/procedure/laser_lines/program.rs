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

use std::fmt::Write as _;

use nalgebra::Vector3;

use super::LaserRequest;
use crate::formats::laser::LineEntry;
use crate::machine::Dialect;

/// Machine Z of the retract: the top of the Z stroke less 5 mm.
pub fn safe_z(req: &LaserRequest) -> f64 {
    req.machine.strokes[2].1 - 5.0
}

fn num(d: Dialect, v: f64) -> String {
    let v = if v.abs() < 5e-5 { 0.0 } else { v };
    match d {
        Dialect::Heidenhain => format!("{v:+.4}"),
        _ => format!("{v:.4}"),
    }
}

struct Out {
    d: Dialect,
    lines: Vec<String>,
}

impl Out {
    fn block(&mut self, s: impl Into<String>) {
        self.lines.push(s.into());
    }

    fn comment(&mut self, text: &str) {
        let t: String = text
            .chars()
            .map(|c| if "()\";".contains(c) { ' ' } else { c })
            .collect();
        let line = match self.d {
            Dialect::Fanuc => format!("({})", t.to_uppercase()),
            Dialect::Linuxcnc => format!("({t})"),
            Dialect::Heidenhain | Dialect::Sinumerik => format!("; {t}"),
        };
        self.lines.push(line);
    }

    fn words(&self, axes: &[(char, f64)]) -> String {
        axes.iter()
            .map(|(a, v)| format!("{a}{}", num(self.d, *v)))
            .collect::<Vec<_>>()
            .join(" ")
    }

    fn rapid(&mut self, axes: &[(char, f64)]) {
        let w = self.words(axes);
        let b = match self.d {
            Dialect::Heidenhain => format!("L {w} R0 FMAX"),
            _ => format!("G0 {w}"),
        };
        self.block(b);
    }

    fn feed(&mut self, p: &Vector3<f64>, f: f64) {
        let w = self.words(&[('X', p.x), ('Y', p.y), ('Z', p.z)]);
        let b = match self.d {
            Dialect::Heidenhain => format!("L {w} R0 F{f:.0}"),
            _ => format!("G1 {w} F{f:.1}"),
        };
        self.block(b);
    }

    fn dwell(&mut self, s: f64) {
        match self.d {
            Dialect::Fanuc => self.block(format!("G4 X{s:.3}")),
            Dialect::Linuxcnc => self.block(format!("G4 P{s:.3}")),
            Dialect::Sinumerik => self.block(format!("G4 F{s:.3}")),
            Dialect::Heidenhain => {
                self.block("CYCL DEF 9.0 DWELL TIME");
                self.block(format!("CYCL DEF 9.1 DWELL {s:.3}"));
            }
        }
    }

    fn stop(&mut self, text: &str) {
        match self.d {
            Dialect::Fanuc | Dialect::Heidenhain => {
                self.comment(text);
                self.block(if self.d == Dialect::Fanuc {
                    "M0"
                } else {
                    "STOP"
                });
            }
            Dialect::Linuxcnc => {
                let t: String = text.chars().filter(|c| !"()".contains(*c)).collect();
                self.block(format!("(MSG,{t})"));
                self.block("M0");
            }
            Dialect::Sinumerik => {
                let t: String = text.chars().filter(|c| *c != '"').collect();
                self.block(format!("MSG(\"{t}\")"));
                self.block("M0");
            }
        }
    }
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
    let mut o = Out {
        d,
        lines: Vec::new(),
    };
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
    o.rapid(&[('Z', safe)]);
    o.rapid(&[(req.machine.tilt.letter, 0.0), ('C', 0.0)]);
    o.rapid(&[('X', before.x), ('Y', before.y)]);
    o.feed(&before, req.feed_mm_min);
    o.feed(&at(0), req.feed_mm_min);
    o.stop(&format!(
        "align the optics along {}, set the reading to zero here, start the automatic capture",
        l.name
    ));
    for run in 1..=req.runs {
        o.comment(&format!("run {run} of {}: + approach", req.runs));
        if run > 1 {
            o.feed(&before, req.feed_mm_min);
        }
        for i in 0..n {
            if !(run == 1 && i == 0) {
                o.feed(&at(i), req.feed_mm_min);
            }
            o.dwell(req.dwell_s);
        }
        o.feed(&after, req.feed_mm_min);
        o.comment(&format!("run {run} of {}: - approach", req.runs));
        for i in (0..n).rev() {
            o.feed(&at(i), req.feed_mm_min);
            o.dwell(req.dwell_s);
        }
    }
    o.feed(&before, req.feed_mm_min);
    o.stop(&format!("{} done: stop the capture, save the run", l.name));
    o.comment("retract");
    o.rapid(&[('Z', safe)]);
    match d {
        Dialect::Fanuc => {
            o.block("M30");
            o.block("%");
        }
        Dialect::Linuxcnc => {
            o.block("M2");
            o.block("%");
        }
        Dialect::Sinumerik => o.block("M30"),
        Dialect::Heidenhain => {
            o.block("M30");
            o.block(format!("END PGM {name} MM"));
        }
    }
    let mut text = String::new();
    if d == Dialect::Heidenhain {
        let mut k = 0;
        for l in &o.lines {
            if l.starts_with("  ") {
                let _ = writeln!(text, "{l}");
            } else {
                let _ = writeln!(text, "{k} {l}");
                k += 1;
            }
        }
    } else {
        for l in &o.lines {
            let _ = writeln!(text, "{l}");
        }
    }
    text
}
