//! The ball bar under tool-centre-point control (the rotary-axis part of Jiang et
//! al. 2013): its plan file `ball-bar.plan.yaml` and its run files.
//!
//! The plan file records, per setup, everything a simulator or an analysis
//! needs without planning again: which axis is swept, where the spindle
//! ball M and the table ball N sit in W, the bar, the spindle ball's gauge
//! length, the angle the other rotary axis holds, the angles of the sweep
//! and the program's timing (feed and dwell), from which a sample-based
//! capture is matched to the angles.
//!
//! A run file is one setup's readings, plain text, `#` starting a comment:
//!
//! ```text
//! # fivecal ball-bar run
//! setup: C1-X
//! angle_deg,deviation_um
//! 0,0.000
//! 6,0.412
//! ```
//!
//! or, as an instrument captures them, samples at a fixed rate, with the
//! samples where the program's sweep started and stopped (the first and
//! last sample when not given):
//!
//! ```text
//! setup: C1-X
//! sample_rate_hz: 10
//! start_sample: 12
//! stop_sample: 2240
//! sample,deviation_um
//! 0,0.01
//! ```
//!
//! The deviation is the bar's length minus its calibrated length, um,
//! positive when the balls are farther apart.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::machine::Dialect;
use crate::source::SourceError;

/// Current version of the ball-bar plan file.
pub const BALL_BAR_VERSION: u32 = 1;

/// The plan file of a ball-bar test.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BallBarManifest {
    /// Format version ([`BALL_BAR_VERSION`]).
    pub fivecal_ball_bar: u32,
    /// Machine name.
    pub machine: String,
    /// Copy of the machine file, relative to the plan file.
    pub machine_file: PathBuf,
    /// Dialect of the programs.
    pub dialect: Dialect,
    /// Standard deviation of one reading (the bar's noise), um.
    pub noise_um: f64,
    /// Standard uncertainty of the bar's calibrated length, um.
    pub calibration_um: f64,
    /// The setups in the order they are run.
    pub setups: Vec<SetupEntry>,
}

/// One setup: one bar between one spindle-ball and one table-ball position,
/// one axis swept.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SetupEntry {
    /// Setup name (`C1-X`), as a run file names it.
    pub name: String,
    /// The axis swept (`A`, `B` or `C`).
    pub axis: char,
    /// Whether the swept axis turns the table (else the head).
    pub on_table: bool,
    /// The spindle ball M in W, mm (held there by TCP).
    pub spindle_ball: [f64; 3],
    /// The table ball N in W, mm.
    pub table_ball: [f64; 3],
    /// The bar's calibrated length, mm (|MN|).
    pub bar_mm: f64,
    /// Direction of the bar from N to M (`+X`, `-Y`, `+Z`, ...), in W.
    pub direction: String,
    /// Gauge length of the spindle ball (gauge line to ball centre), mm.
    pub gauge_mm: f64,
    /// The angle the other rotary axis holds, deg.
    pub held_deg: f64,
    /// The swept axis' angles, in the order run, deg.
    pub angles: Vec<f64>,
    /// Feed of the rotary steps, deg/min.
    pub feed_deg_min: f64,
    /// Dwell at each angle for a still reading, s.
    pub dwell_s: f64,
    /// The program, relative to the plan file.
    pub program: PathBuf,
    /// The setup sheet, relative to the plan file.
    pub sheet: PathBuf,
}

impl SetupEntry {
    /// Tilt and C angles (deg) at step `i` of the sweep.
    pub fn angles_at(&self, i: usize, tilt_letter: char) -> (f64, f64) {
        let a = self.angles[i];
        if self.axis == tilt_letter {
            (a, self.held_deg)
        } else {
            (self.held_deg, a)
        }
    }

    /// Seconds from the start of the sweep (the first angle reached) to
    /// the start of the dwell at step `i` and to its end.
    pub fn dwell_window(&self, i: usize) -> (f64, f64) {
        let mut t = 0.0;
        for k in 0..i {
            t += self.dwell_s;
            t += (self.angles[k + 1] - self.angles[k]).abs() / self.feed_deg_min * 60.0;
        }
        (t, t + self.dwell_s)
    }

    /// Seconds of the sweep from the first dwell's start to the last's end.
    pub fn sweep_seconds(&self) -> f64 {
        self.dwell_window(self.angles.len() - 1).1
    }
}

impl BallBarManifest {
    /// Parses a plan file.
    pub fn parse(path: &Path, src: &str) -> Result<BallBarManifest, SourceError> {
        let m: BallBarManifest = crate::input::parse_yaml(path, src)?;
        if m.fivecal_ball_bar != BALL_BAR_VERSION {
            return Err(SourceError::at_key(
                path,
                src,
                &["fivecal_ball_bar"],
                format!(
                    "ball-bar plan version {} is not supported (expected {BALL_BAR_VERSION})",
                    m.fivecal_ball_bar
                ),
            ));
        }
        let positive = |v: f64| v.is_finite() && v > 0.0;
        for (i, s) in m.setups.iter().enumerate() {
            let at = |msg: String| {
                SourceError::at_key(path, src, &["setups"], format!("setup {}: {msg}", i + 1))
            };
            if s.angles.is_empty() {
                return Err(at(format!("{}: no angles", s.name)));
            }
            let fine = positive(s.bar_mm)
                && positive(s.feed_deg_min)
                && positive(s.gauge_mm)
                && s.dwell_s.is_finite()
                && s.dwell_s >= 0.0;
            if !fine {
                return Err(at(format!(
                    "{}: bar, feed and gauge length must be > 0 and the dwell >= 0",
                    s.name
                )));
            }
            let all = s
                .spindle_ball
                .iter()
                .chain(&s.table_ball)
                .chain(&s.angles)
                .chain([&s.held_deg]);
            if all.into_iter().any(|v| !v.is_finite()) {
                return Err(at(format!(
                    "{}: a position or angle is not a number",
                    s.name
                )));
            }
        }
        let fine = m.noise_um.is_finite()
            && m.noise_um >= 0.0
            && m.calibration_um.is_finite()
            && m.calibration_um >= 0.0;
        if !fine {
            return Err(SourceError::at_key(
                path,
                src,
                &["noise_um"],
                "noise_um and calibration_um must be >= 0",
            ));
        }
        Ok(m)
    }

    /// Reads a plan file.
    pub fn read(path: &Path) -> Result<BallBarManifest, SourceError> {
        let src = crate::input::read_text(path, "ball-bar plan", crate::limits::MAX_YAML_BYTES)?;
        BallBarManifest::parse(path, &src)
    }

    /// YAML text.
    pub fn to_yaml(&self) -> String {
        serde_yaml::to_string(self).expect("ball-bar plans serialize")
    }

    /// The setup named `name`.
    pub fn setup(&self, name: &str) -> Option<&SetupEntry> {
        self.setups.iter().find(|s| s.name == name)
    }

    /// Whether `src` is a ball-bar plan file (its first key).
    pub fn sniff(src: &str) -> bool {
        super::first_key_is(src, "fivecal_ball_bar:")
    }
}

/// The readings of one run.
#[derive(Clone, Debug, PartialEq)]
pub enum Readings {
    /// One deviation per angle, (deg, um).
    Angles(Vec<(f64, f64)>),
    /// Samples at a fixed rate.
    Samples {
        /// Samples per second.
        rate_hz: f64,
        /// The sample at which the sweep's first dwell began.
        start: Option<usize>,
        /// The sample at which the sweep's last dwell ended.
        stop: Option<usize>,
        /// The deviations, um, by sample index from 0.
        values: Vec<f64>,
    },
}

/// One run file.
#[derive(Clone, Debug, PartialEq)]
pub struct BallBarRun {
    /// The setup it measured.
    pub setup: String,
    /// Its readings.
    pub readings: Readings,
}

/// Largest run file, bytes (a day's capture at 1 kHz is far smaller).
const MAX_RUN_BYTES: u64 = 64 << 20;

impl BallBarRun {
    /// The plain text of a run by angle.
    pub fn to_text(&self) -> String {
        use std::fmt::Write as _;
        let mut s =
            String::from("# fivecal ball-bar run: bar length minus calibrated length, um\n");
        let _ = writeln!(s, "setup: {}", self.setup);
        match &self.readings {
            Readings::Angles(v) => {
                s.push_str("angle_deg,deviation_um\n");
                for (a, d) in v {
                    let _ = writeln!(s, "{},{:.4}", crate::numbers::echo(*a), d);
                }
            }
            Readings::Samples {
                rate_hz,
                start,
                stop,
                values,
            } => {
                let _ = writeln!(s, "sample_rate_hz: {}", crate::numbers::echo(*rate_hz));
                if let Some(v) = start {
                    let _ = writeln!(s, "start_sample: {v}");
                }
                if let Some(v) = stop {
                    let _ = writeln!(s, "stop_sample: {v}");
                }
                s.push_str("sample,deviation_um\n");
                for (i, d) in values.iter().enumerate() {
                    let _ = writeln!(s, "{i},{d:.4}");
                }
            }
        }
        s
    }

    /// Reads a run file.
    pub fn read(path: &Path) -> Result<BallBarRun, SourceError> {
        let src = crate::input::read_text(path, "ball-bar run", MAX_RUN_BYTES)?;
        BallBarRun::parse(path, &src)
    }

    /// Parses a run file; errors name the line and column.
    pub fn parse(path: &Path, src: &str) -> Result<BallBarRun, SourceError> {
        let err = |line: usize, col: usize, msg: String| SourceError::new(path, line, col, msg);
        let mut setup: Option<String> = None;
        let mut rate: Option<f64> = None;
        let mut start: Option<usize> = None;
        let mut stop: Option<usize> = None;
        let mut columns: Option<bool> = None; // Some(true): by angle
        let mut angles: Vec<(f64, f64)> = Vec::new();
        let mut values: Vec<f64> = Vec::new();
        for (i, raw) in src.lines().enumerate() {
            let ln = i + 1;
            let text = raw.split('#').next().unwrap_or("");
            let indent = text.len() - text.trim_start().len();
            let line = text.trim();
            if line.is_empty() {
                continue;
            }
            let Some(by_angle) = columns else {
                if let Some((key, value)) = line.split_once(':') {
                    let vcol = indent + key.len() + 2 + (value.len() - value.trim_start().len());
                    let value = value.trim();
                    match key.trim() {
                        "setup" => {
                            if value.is_empty()
                                || !value.chars().all(|c| {
                                    c.is_ascii_alphanumeric() || matches!(c, '_' | '.' | '-')
                                })
                            {
                                return Err(err(
                                    ln,
                                    vcol,
                                    format!(
                                        "expected a setup name of the plan ([A-Za-z0-9_.-]+), got `{value}`"
                                    ),
                                ));
                            }
                            setup = Some(value.to_string());
                        }
                        "sample_rate_hz" => {
                            let r: f64 = value.parse().ok().filter(|r: &f64| {
                                r.is_finite() && *r > 0.0 && *r <= 1.0e6
                            }).ok_or_else(|| {
                                err(ln, vcol, format!("expected a sample rate in Hz (> 0, at most 1e6), got `{value}`"))
                            })?;
                            rate = Some(r);
                        }
                        "start_sample" | "stop_sample" => {
                            let v: usize = value.parse().map_err(|_| {
                                err(
                                    ln,
                                    vcol,
                                    format!(
                                        "expected a sample index (0, 1, 2, ...), got `{value}`"
                                    ),
                                )
                            })?;
                            if key.trim() == "start_sample" {
                                start = Some(v);
                            } else {
                                stop = Some(v);
                            }
                        }
                        other => {
                            return Err(err(
                                ln,
                                indent + 1,
                                format!(
                                    "unknown key `{other}`: expected setup, sample_rate_hz, start_sample or stop_sample, then the header angle_deg,deviation_um or sample,deviation_um"
                                ),
                            ));
                        }
                    }
                    continue;
                }
                let head: Vec<String> = line
                    .split(',')
                    .map(|s| s.trim().to_ascii_lowercase())
                    .collect();
                columns = Some(match head.as_slice() {
                    [a, d] if a == "angle_deg" && d == "deviation_um" => true,
                    [a, d] if a == "sample" && d == "deviation_um" => false,
                    _ => {
                        return Err(err(
                            ln,
                            indent + 1,
                            format!(
                                "expected the header `angle_deg,deviation_um` or `sample,deviation_um`, got `{line}`"
                            ),
                        ));
                    }
                });
                continue;
            };
            let fields: Vec<&str> = text.split(',').collect();
            if fields.len() != 2 {
                return Err(err(
                    ln,
                    indent + 1,
                    format!("expected two fields, got {}", fields.len()),
                ));
            }
            let col2 = fields[0].len() + 2;
            let dev: f64 = fields[1]
                .trim()
                .parse()
                .ok()
                .filter(|v: &f64| v.is_finite() && v.abs() <= crate::limits::MAX_ERROR_UM)
                .ok_or_else(|| {
                    err(
                        ln,
                        col2,
                        format!(
                            "expected a length deviation in um (a number within +-{}), got `{}`",
                            crate::limits::MAX_ERROR_UM,
                            fields[1].trim()
                        ),
                    )
                })?;
            if by_angle {
                let a: f64 = fields[0]
                    .trim()
                    .parse()
                    .ok()
                    .filter(|v: &f64| v.is_finite() && v.abs() <= 3600.0)
                    .ok_or_else(|| {
                        err(
                            ln,
                            indent + 1,
                            format!("expected an angle in degrees, got `{}`", fields[0].trim()),
                        )
                    })?;
                angles.push((a, dev));
            } else {
                let k: usize = fields[0].trim().parse().map_err(|_| {
                    err(
                        ln,
                        indent + 1,
                        format!("expected a sample index, got `{}`", fields[0].trim()),
                    )
                })?;
                if k != values.len() {
                    return Err(err(
                        ln,
                        indent + 1,
                        format!(
                            "expected sample {} (samples in order from 0), got {k}",
                            values.len()
                        ),
                    ));
                }
                values.push(dev);
            }
        }
        let end = src.lines().count().max(1);
        let Some(setup) = setup else {
            return Err(err(
                1,
                1,
                "missing `setup: NAME` (the plan's setup this run measured)".into(),
            ));
        };
        let readings = match columns {
            None => {
                return Err(err(
                    end,
                    1,
                    "no readings: expected the header angle_deg,deviation_um or sample,deviation_um and rows".into(),
                ));
            }
            Some(true) => {
                if rate.is_some() || start.is_some() || stop.is_some() {
                    return Err(err(1, 1, "sample_rate_hz, start_sample and stop_sample belong to a run by sample, not by angle".into()));
                }
                if angles.is_empty() {
                    return Err(err(end, 1, "no readings after the header".into()));
                }
                Readings::Angles(angles)
            }
            Some(false) => {
                let Some(rate_hz) = rate else {
                    return Err(err(1, 1, "a run by sample needs `sample_rate_hz:`".into()));
                };
                if values.is_empty() {
                    return Err(err(end, 1, "no samples after the header".into()));
                }
                for (what, v) in [("start_sample", start), ("stop_sample", stop)] {
                    if let Some(v) = v
                        && v >= values.len()
                    {
                        return Err(err(
                            1,
                            1,
                            format!("{what} {v} is beyond the last sample {}", values.len() - 1),
                        ));
                    }
                }
                if let (Some(a), Some(b)) = (start, stop)
                    && b <= a
                {
                    return Err(err(
                        1,
                        1,
                        format!("stop_sample {b} must come after start_sample {a}"),
                    ));
                }
                Readings::Samples {
                    rate_hz,
                    start,
                    stop,
                    values,
                }
            }
        };
        Ok(BallBarRun { setup, readings })
    }

    /// The deviation at each of the setup's angles, um: read directly from
    /// a run by angle (every planned angle must be there, within 1e-6 deg),
    /// or matched from samples as the instrument software does, by the
    /// program's timing between the sweep's start and stop: the planned
    /// timeline (dwells and steps at the planned feed) is scaled onto the
    /// samples from start to stop, which absorbs a feed override or a
    /// clock off by a little, and each angle's reading is the mean of the
    /// middle half of its dwell.
    pub fn at_angles(&self, setup: &SetupEntry) -> Result<Vec<f64>, String> {
        match &self.readings {
            Readings::Angles(v) => setup
                .angles
                .iter()
                .enumerate()
                .map(|(i, a)| {
                    // Readings repeat an angle only at the closing step of a
                    // full turn: take them in order.
                    v.get(i)
                        .filter(|(got, _)| (got - a).abs() < 1e-6)
                        .map(|(_, d)| *d)
                        .ok_or_else(|| {
                            format!(
                                "reading {} should be at {} deg, the setup's angle {}; got {}",
                                i + 1,
                                a,
                                i + 1,
                                v.get(i)
                                    .map_or("no reading".to_string(), |(g, _)| format!("{g} deg"))
                            )
                        })
                })
                .collect(),
            Readings::Samples {
                rate_hz,
                start,
                stop,
                values,
            } => {
                let s0 = start.unwrap_or(0) as f64;
                let s1 = stop.unwrap_or(values.len() - 1) as f64;
                let planned = setup.sweep_seconds();
                let measured = (s1 - s0) / rate_hz;
                if planned <= 0.0 || measured <= 0.0 {
                    return Err("the sweep has no duration to match samples on".into());
                }
                let ratio = measured / planned;
                if !(0.8..=1.25).contains(&ratio) {
                    return Err(format!(
                        "the capture from start to stop lasts {measured:.1} s, the program's sweep {planned:.1} s: more than 20 % apart, so the samples cannot be matched to the angles (wrong start/stop, sample rate or feed override?)"
                    ));
                }
                let mut out = Vec::with_capacity(setup.angles.len());
                for i in 0..setup.angles.len() {
                    let (a, b) = setup.dwell_window(i);
                    let q = (b - a) / 4.0;
                    let from = s0 + (a + q) * ratio * rate_hz;
                    let to = s0 + (b - q) * ratio * rate_hz;
                    let lo = from.ceil().max(0.0) as usize;
                    let hi = (to.floor() as usize).min(values.len() - 1);
                    if hi < lo {
                        return Err(format!(
                            "the dwell at {} deg holds no sample at {rate_hz} Hz (dwell {} s): capture faster or dwell longer",
                            setup.angles[i], setup.dwell_s
                        ));
                    }
                    let w = &values[lo..=hi];
                    out.push(w.iter().sum::<f64>() / w.len() as f64);
                }
                Ok(out)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn setup() -> SetupEntry {
        SetupEntry {
            name: "C1-X".into(),
            axis: 'C',
            on_table: true,
            spindle_ball: [200.0, 152.0, 57.0],
            table_ball: [100.0, 152.0, 57.0],
            bar_mm: 100.0,
            direction: "+X".into(),
            gauge_mm: 100.0,
            held_deg: 0.0,
            angles: vec![0.0, 90.0, 180.0],
            feed_deg_min: 900.0,
            dwell_s: 2.0,
            program: "a.nc".into(),
            sheet: "a.md".into(),
        }
    }

    #[test]
    fn a_run_by_angle_reads_back_what_was_written() {
        let run = BallBarRun {
            setup: "C1-X".into(),
            readings: Readings::Angles(vec![(0.0, 0.5), (90.0, -1.25), (180.0, 2.0)]),
        };
        let back = BallBarRun::parse(Path::new("r.txt"), &run.to_text()).unwrap();
        assert_eq!(back, run);
        assert_eq!(back.at_angles(&setup()).unwrap(), vec![0.5, -1.25, 2.0]);
    }

    #[test]
    fn bad_input_names_line_and_column() {
        let e = BallBarRun::parse(
            Path::new("r.txt"),
            "setup: C1-X\nangle_deg,deviation_um\n0,0.5\n90,abc\n",
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.starts_with("r.txt:4:4: expected a length deviation"),
            "{e}"
        );
        let e = BallBarRun::parse(Path::new("r.txt"), "setup: C1 X\n")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("r.txt:1:8: expected a setup name"), "{e}");
        let e = BallBarRun::parse(Path::new("r.txt"), "setup: a\nangle,dev\n")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("r.txt:2:1: expected the header"), "{e}");
    }

    #[test]
    fn samples_are_matched_to_angles_by_the_programs_timing() {
        // 2 s dwells, 90 deg steps at 900 deg/min (6 s): the dwells are at
        // 0-2, 8-10 and 16-18 s. At 10 Hz with the start at sample 30 and
        // a clock 2 % fast, each dwell's middle holds its own level.
        let s = setup();
        let rate = 10.0;
        let scale = 1.02;
        let level = [1.0, -2.0, 3.0];
        let mut values = vec![9.0; 30 + (18.0 * scale * rate) as usize + 20];
        for (i, l) in level.iter().enumerate() {
            let (a, b) = s.dwell_window(i);
            for (k, v) in values.iter_mut().enumerate() {
                let t = (k as f64 - 30.0) / rate / scale;
                if t >= a && t <= b {
                    *v = *l;
                }
            }
        }
        let stop = 30 + (18.0 * scale * rate).round() as usize;
        let run = BallBarRun {
            setup: "C1-X".into(),
            readings: Readings::Samples {
                rate_hz: rate,
                start: Some(30),
                stop: Some(stop),
                values,
            },
        };
        let back = BallBarRun::parse(Path::new("r.txt"), &run.to_text()).unwrap();
        let got = back.at_angles(&s).unwrap();
        for (g, l) in got.iter().zip(level) {
            assert!((g - l).abs() < 1e-3, "{got:?}");
        }
        // A stop far off the program's duration is refused, not guessed.
        let Readings::Samples { values, .. } = back.readings.clone() else {
            unreachable!()
        };
        let off = BallBarRun {
            setup: "C1-X".into(),
            readings: Readings::Samples {
                rate_hz: rate,
                start: Some(30),
                stop: Some(30 + 100),
                values,
            },
        };
        assert!(off.at_angles(&s).unwrap_err().contains("more than 20 %"));
    }
}
