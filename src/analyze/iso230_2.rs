//! ISO 230-2 figures of one line measured by a laser interferometer: at
//! every target the mean unidirectional deviations and their estimators
//! of the standard uncertainty (the runs' standard deviation), and over the
//! line the positioning accuracy A, the repeatability R (bidirectional and
//! per direction), the reversal value B and the mean reversal, the
//! systematic positioning deviation E and the mean bidirectional
//! positioning deviation M, each with the standard uncertainty of the
//! figure itself (docs/laser-lines.md, "Figures").
//!
//! The uncertainty of a figure comes from two sources. The instrument:
//! every reading carries a random part of standard uncertainty `u_r` (the
//! plan's `reading_u_um`), which the runs' mean reduces by sqrt(n), and a
//! length part proportional to the distance between the two targets a
//! figure takes the difference of (`length_u_ppm`; it cancels at one
//! target, so it enters E, M and A but not B or R). The sampling: a
//! standard deviation s from n runs is itself uncertain by s /
//! sqrt(2 (n - 1)) (normal readings), which enters R and A. The terms are
//! combined in quadrature at the targets that give the figure its value.

use serde::Serialize;

use crate::formats::laser::LaserRun;

/// The figures of one direction at one target.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Direction {
    /// Mean unidirectional positioning deviation, um.
    pub mean_um: f64,
    /// Estimator of the unidirectional standard uncertainty (the runs'
    /// standard deviation), um.
    pub s_um: f64,
    /// Runs.
    pub n: usize,
}

/// One target position.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Target {
    /// Position along the line, mm.
    pub position_mm: f64,
    /// Approached in the + direction.
    pub up: Direction,
    /// Approached in the - direction.
    pub down: Direction,
}

impl Target {
    /// Reversal value B_i = mean(+) - mean(-), um.
    pub fn reversal(&self) -> f64 {
        self.up.mean_um - self.down.mean_um
    }
    /// Mean bidirectional positioning deviation, um.
    pub fn mean(&self) -> f64 {
        (self.up.mean_um + self.down.mean_um) / 2.0
    }
    /// Bidirectional repeatability R_i, um.
    pub fn repeatability(&self) -> f64 {
        (2.0 * self.up.s_um + 2.0 * self.down.s_um + self.reversal().abs())
            .max(4.0 * self.up.s_um)
            .max(4.0 * self.down.s_um)
    }
}

/// A figure and its standard uncertainty, um.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Figure {
    /// The value, um.
    pub value_um: f64,
    /// Its standard uncertainty, um.
    pub u_um: f64,
}

/// The ISO 230-2 figures of one line.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LineFigures {
    /// The line's name.
    pub line: String,
    /// Runs in each direction.
    pub runs: usize,
    /// Per target.
    pub targets: Vec<Target>,
    /// Bidirectional accuracy of positioning A.
    pub a: Figure,
    /// Unidirectional accuracy A+ and A-.
    pub a_up: Figure,
    /// See `a_up`.
    pub a_down: Figure,
    /// Bidirectional repeatability of positioning R.
    pub r: Figure,
    /// Unidirectional repeatability R+.
    pub r_up: Figure,
    /// Unidirectional repeatability R-.
    pub r_down: Figure,
    /// Reversal value B (largest |B_i|).
    pub b: Figure,
    /// Mean reversal value (mean of B_i, signed).
    pub b_mean: Figure,
    /// Bidirectional systematic positioning deviation E.
    pub e: Figure,
    /// Unidirectional systematic positioning deviation E+.
    pub e_up: Figure,
    /// Unidirectional systematic positioning deviation E-.
    pub e_down: Figure,
    /// Range of the mean bidirectional positioning deviation M.
    pub m: Figure,
}

/// What the figures are computed with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Instrument {
    /// Standard uncertainty of one reading, um.
    pub reading_u_um: f64,
    /// Standard uncertainty of a length, ppm.
    pub length_u_ppm: f64,
}

/// Why the figures cannot be computed.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum FiguresError {
    /// Too few runs or targets, or readings missing.
    #[error("{0}")]
    Incomplete(String),
}

/// Collects the run's readings at the plan's targets: every target in both
/// directions in every run `1..=runs`, each once.
pub fn tabulate(
    run: &LaserRun,
    targets: &[f64],
    runs: usize,
) -> Result<Vec<[Vec<f64>; 2]>, FiguresError> {
    let mut table: Vec<[Vec<Option<f64>>; 2]> = targets
        .iter()
        .map(|_| [vec![None; runs], vec![None; runs]])
        .collect();
    for r in &run.readings {
        let Some(i) = targets.iter().position(|t| (t - r.target_mm).abs() < 1e-3) else {
            return Err(FiguresError::Incomplete(format!(
                "line {}: a reading at {} mm, which is no target of the plan's line (targets {} .. {} mm)",
                run.line,
                r.target_mm,
                targets[0],
                targets[targets.len() - 1]
            )));
        };
        if r.run > runs {
            return Err(FiguresError::Incomplete(format!(
                "line {}: run {} at {} mm, but {runs} runs are expected",
                run.line, r.run, r.target_mm
            )));
        }
        let cell = &mut table[i][usize::from(!r.forward)][r.run - 1];
        if cell.is_some() {
            return Err(FiguresError::Incomplete(format!(
                "line {}: two readings at {} mm, run {}, direction {}",
                run.line,
                r.target_mm,
                r.run,
                if r.forward { '+' } else { '-' }
            )));
        }
        *cell = Some(r.deviation_um);
    }
    table
        .into_iter()
        .zip(targets)
        .map(|(dirs, t)| {
            let mut out: [Vec<f64>; 2] = [Vec::new(), Vec::new()];
            for (d, cells) in dirs.iter().enumerate() {
                for (j, c) in cells.iter().enumerate() {
                    let Some(v) = c else {
                        return Err(FiguresError::Incomplete(format!(
                            "line {}: no reading at {t} mm, run {}, direction {} (ISO 230-2 needs every target in both directions in every run)",
                            run.line,
                            j + 1,
                            if d == 0 { '+' } else { '-' }
                        )));
                    };
                    out[d].push(*v);
                }
            }
            Ok(out)
        })
        .collect()
}

fn direction(v: &[f64]) -> Direction {
    let n = v.len();
    let mean = v.iter().sum::<f64>() / n as f64;
    let ss = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>();
    Direction {
        mean_um: mean,
        s_um: (ss / (n as f64 - 1.0)).sqrt(),
        n,
    }
}

/// The figures of line `name` from its readings (`readings[i]` = the runs
/// at target `positions[i]`, + then -, as [`tabulate`] gives them).
pub fn figures(
    name: &str,
    positions: &[f64],
    readings: &[[Vec<f64>; 2]],
    inst: Instrument,
) -> Result<LineFigures, FiguresError> {
    if positions.len() < 2 || positions.len() != readings.len() {
        return Err(FiguresError::Incomplete(format!(
            "line {name}: expected two or more targets with their readings"
        )));
    }
    let n = readings[0][0].len();
    if n < 2 || readings.iter().any(|r| r[0].len() != n || r[1].len() != n) {
        return Err(FiguresError::Incomplete(format!(
            "line {name}: expected the same number of runs, two or more, at every target in both directions"
        )));
    }
    let targets: Vec<Target> = positions
        .iter()
        .zip(readings)
        .map(|(p, r)| Target {
            position_mm: *p,
            up: direction(&r[0]),
            down: direction(&r[1]),
        })
        .collect();
    let nf = n as f64;
    let ur = inst.reading_u_um;
    // u of a mean of n readings, of s from n runs, of a length between
    // targets i and k.
    let u_mean = ur / nf.sqrt();
    let u_s = |s: f64| s / (2.0 * (nf - 1.0)).sqrt();
    let u_len = |i: usize, k: usize| {
        inst.length_u_ppm * 1e-3 * (targets[i].position_mm - targets[k].position_mm).abs()
    };
    let q = |terms: &[f64]| terms.iter().map(|t| t * t).sum::<f64>().sqrt();
    let argmax = |f: &dyn Fn(&Target) -> f64| {
        (0..targets.len())
            .max_by(|&a, &b| f(&targets[a]).total_cmp(&f(&targets[b])))
            .expect("two or more targets")
    };
    let argmin = |f: &dyn Fn(&Target) -> f64| {
        (0..targets.len())
            .min_by(|&a, &b| f(&targets[a]).total_cmp(&f(&targets[b])))
            .expect("two or more targets")
    };
    // E per direction: range of the means.
    let e_dir = |d: fn(&Target) -> Direction| {
        let hi = argmax(&|t| d(t).mean_um);
        let lo = argmin(&|t| d(t).mean_um);
        Figure {
            value_um: d(&targets[hi]).mean_um - d(&targets[lo]).mean_um,
            u_um: q(&[u_mean, u_mean, u_len(hi, lo)]),
        }
    };
    let up = |t: &Target| t.up;
    let down = |t: &Target| t.down;
    // Extremes over both directions: (value, target, direction).
    let both = |f: &dyn Fn(&Direction) -> f64, max: bool| {
        let mut best: Option<(f64, usize, Direction)> = None;
        for (i, t) in targets.iter().enumerate() {
            for d in [t.up, t.down] {
                let v = f(&d);
                let better = best.is_none_or(|(b, _, _)| if max { v > b } else { v < b });
                if better {
                    best = Some((v, i, d));
                }
            }
        }
        best.expect("two or more targets")
    };
    let (ehi, ehi_i, _) = both(&|d| d.mean_um, true);
    let (elo, elo_i, _) = both(&|d| d.mean_um, false);
    let e = Figure {
        value_um: ehi - elo,
        u_um: q(&[u_mean, u_mean, u_len(ehi_i, elo_i)]),
    };
    // A from its two ends: the highest mean + 2 s (direction h at target
    // hi) and the lowest mean - 2 s (l at lo), each end's mean and s
    // uncertain, and the laser's length between them.
    let accuracy = |h: Direction, hi: usize, l: Direction, lo: usize| Figure {
        value_um: (h.mean_um + 2.0 * h.s_um) - (l.mean_um - 2.0 * l.s_um),
        u_um: q(&[
            u_mean,
            2.0 * u_s(h.s_um),
            u_mean,
            2.0 * u_s(l.s_um),
            u_len(hi, lo),
        ]),
    };
    let a_dir = |d: fn(&Target) -> Direction| {
        let hi = argmax(&|t| d(t).mean_um + 2.0 * d(t).s_um);
        let lo = argmin(&|t| d(t).mean_um - 2.0 * d(t).s_um);
        accuracy(d(&targets[hi]), hi, d(&targets[lo]), lo)
    };
    let (_, ahi_i, ahd) = both(&|d| d.mean_um + 2.0 * d.s_um, true);
    let (_, alo_i, ald) = both(&|d| d.mean_um - 2.0 * d.s_um, false);
    let a = accuracy(ahd, ahi_i, ald, alo_i);
    let r_dir = |d: fn(&Target) -> Direction| {
        let i = argmax(&|t| d(t).s_um);
        let s = d(&targets[i]).s_um;
        Figure {
            value_um: 4.0 * s,
            u_um: 4.0 * u_s(s),
        }
    };
    let u_b = ur * (2.0 / nf).sqrt();
    let ri = argmax(&|t| t.repeatability());
    let rt = &targets[ri];
    let r = {
        let v = rt.repeatability();
        // The term that gives R_i its value.
        let u = if (v - 4.0 * rt.up.s_um).abs() < 1e-12 && 4.0 * rt.up.s_um >= 4.0 * rt.down.s_um {
            4.0 * u_s(rt.up.s_um)
        } else if (v - 4.0 * rt.down.s_um).abs() < 1e-12 {
            4.0 * u_s(rt.down.s_um)
        } else {
            q(&[2.0 * u_s(rt.up.s_um), 2.0 * u_s(rt.down.s_um), u_b])
        };
        Figure {
            value_um: v,
            u_um: u,
        }
    };
    let bi = argmax(&|t| t.reversal().abs());
    let b = Figure {
        value_um: targets[bi].reversal().abs(),
        u_um: u_b,
    };
    let mf = targets.len() as f64;
    let b_mean = Figure {
        value_um: targets.iter().map(Target::reversal).sum::<f64>() / mf,
        u_um: u_b / mf.sqrt(),
    };
    let mhi = argmax(&|t| t.mean());
    let mlo = argmin(&|t| t.mean());
    // A bidirectional mean is a mean of 2n readings.
    let u_bi = ur / (2.0 * nf).sqrt();
    let m = Figure {
        value_um: targets[mhi].mean() - targets[mlo].mean(),
        u_um: q(&[u_bi, u_bi, u_len(mhi, mlo)]),
    };
    Ok(LineFigures {
        line: name.to_string(),
        runs: n,
        a,
        a_up: a_dir(up),
        a_down: a_dir(down),
        r,
        r_up: r_dir(up),
        r_down: r_dir(down),
        b,
        b_mean,
        e,
        e_up: e_dir(up),
        e_down: e_dir(down),
        m,
        targets,
    })
}

impl LineFigures {
    /// The figures as an engineer reads them: one line each, value and u.
    pub fn render(&self) -> String {
        use std::fmt::Write as _;
        let mut s = String::new();
        let f = |x: &Figure| format!("{:>8.3} um  (u {:.3} um)", x.value_um, x.u_um);
        let _ = writeln!(
            s,
            "line {}: ISO 230-2, {} targets {} .. {} mm, {} runs each way",
            self.line,
            self.targets.len(),
            crate::numbers::echo(self.targets[0].position_mm),
            crate::numbers::echo(self.targets[self.targets.len() - 1].position_mm),
            self.runs
        );
        let rows = [
            ("A   accuracy, bidirectional", &self.a),
            ("A+  accuracy, + approach", &self.a_up),
            ("A-  accuracy, - approach", &self.a_down),
            ("R   repeatability, bidirectional", &self.r),
            ("R+  repeatability, + approach", &self.r_up),
            ("R-  repeatability, - approach", &self.r_down),
            ("B   reversal value", &self.b),
            ("B~  mean reversal value", &self.b_mean),
            ("E   systematic deviation, bidir.", &self.e),
            ("E+  systematic deviation, +", &self.e_up),
            ("E-  systematic deviation, -", &self.e_down),
            ("M   mean bidirectional deviation", &self.m),
        ];
        for (name, x) in rows {
            let _ = writeln!(s, "  {name:<34} {}", f(x));
        }
        s
    }
}
