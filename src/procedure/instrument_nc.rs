//! The NC words of the instrument tests' programs (the ball bar under TCP,
//! the laser interferometer's lines): numbers, comments, moves, the dwell
//! an instrument's capture needs, a stop with a message for the operator,
//! and the end of the program with HEIDENHAIN's block numbers, in each
//! dialect's own spelling. These programs are written directly rather than
//! through the machining post-processors: they hold a point still while an
//! axis turns, or step along a line, and need none of a cutting program's
//! tool, spindle or coolant handling.

use std::fmt::Write as _;

use nalgebra::Vector3;

use crate::machine::Dialect;

/// A coordinate as written: four decimals, a sign on HEIDENHAIN's, no
/// negative zero.
pub(crate) fn num(d: Dialect, v: f64) -> String {
    let v = if v.abs() < 5e-5 { 0.0 } else { v };
    match d {
        Dialect::Heidenhain => format!("{v:+.4}"),
        _ => format!("{v:.4}"),
    }
}

/// A program's blocks as they are written, in one dialect.
pub(crate) struct Out {
    /// The dialect.
    pub(crate) d: Dialect,
    /// The blocks, without HEIDENHAIN's numbers (added by [`Out::finish`]);
    /// a line starting with two spaces continues the block before it.
    pub(crate) lines: Vec<String>,
}

impl Out {
    /// An empty program in `d`.
    pub(crate) fn new(d: Dialect) -> Out {
        Out {
            d,
            lines: Vec::new(),
        }
    }

    /// A block as given.
    pub(crate) fn block(&mut self, s: impl Into<String>) {
        self.lines.push(s.into());
    }

    /// A comment, stripped of what would end it early.
    pub(crate) fn comment(&mut self, text: &str) {
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

    /// Axis words, `X.. Y..`.
    pub(crate) fn words(&self, axes: &[(char, f64)]) -> String {
        axes.iter()
            .map(|(a, v)| format!("{a}{}", num(self.d, *v)))
            .collect::<Vec<_>>()
            .join(" ")
    }

    /// `X.. Y.. Z..` of a point.
    pub(crate) fn xyz(&self, p: &Vector3<f64>) -> String {
        self.words(&[('X', p.x), ('Y', p.y), ('Z', p.z)])
    }

    /// The rotary axes' words: the tilt axis by its letter, then C.
    pub(crate) fn rot(&self, tilt_letter: char, t: f64, c: f64) -> String {
        self.words(&[(tilt_letter, t), ('C', c)])
    }

    /// A rapid move to `words`.
    pub(crate) fn rapid(&mut self, words: &str) {
        let b = match self.d {
            Dialect::Heidenhain => format!("L {words} R0 FMAX"),
            _ => format!("G0 {words}"),
        };
        self.block(b);
    }

    /// A feed move to `words` at `f`.
    pub(crate) fn feed(&mut self, words: &str, f: f64) {
        let b = match self.d {
            Dialect::Heidenhain => format!("L {words} R0 F{f:.0}"),
            _ => format!("G1 {words} F{f:.1}"),
        };
        self.block(b);
    }

    /// A dwell of `s` seconds, for a still reading.
    pub(crate) fn dwell(&mut self, s: f64) {
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

    /// A programmed stop with `text` shown to the operator.
    pub(crate) fn stop(&mut self, text: &str) {
        match self.d {
            Dialect::Fanuc => {
                self.comment(text);
                self.block("M0");
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
            Dialect::Heidenhain => {
                self.comment(text);
                self.block("STOP");
            }
        }
    }

    /// The program's end (HEIDENHAIN's naming program `name`) and its
    /// text, HEIDENHAIN's blocks numbered in order.
    pub(crate) fn finish(mut self, name: &str) -> String {
        match self.d {
            Dialect::Fanuc => {
                self.block("M30");
                self.block("%");
            }
            Dialect::Linuxcnc => {
                self.block("M2");
                self.block("%");
            }
            Dialect::Sinumerik => self.block("M30"),
            Dialect::Heidenhain => {
                self.block("M30");
                self.block(format!("END PGM {name} MM"));
            }
        }
        let mut text = String::new();
        let mut n = 0;
        for l in &self.lines {
            // A cycle's continuation line has no number of its own.
            if self.d == Dialect::Heidenhain && !l.starts_with("  ") {
                let _ = writeln!(text, "{n} {l}");
                n += 1;
            } else {
                let _ = writeln!(text, "{l}");
            }
        }
        text
    }
}
