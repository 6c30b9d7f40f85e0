//! The laser interferometer's ten lines (the linear-axis part of Jiang et
//! al. 2013): the plan file `laser-lines.plan.yaml` and the run files an
//! interferometer's software exports.
//!
//! The plan file records, per line, what the analysis needs without
//! planning again: the line's start in machine coordinates, its direction,
//! the offset of the measured point from the spindle point P (the lever
//! arm the line measures through), whether that offset is made by moving
//! an axis or by a bracket on the spindle, and the target positions along
//! the line.
//!
//! A run file holds the readings of one line, as ISO 230-2 names them: at
//! each target position, run and approach direction, the positioning
//! deviation (actual minus target, um). Two formats are read:
//!
//! - fivecal's plain format (`#` starts a comment; the environment keys are
//!   optional and kept as written):
//!
//!   ```text
//!   # fivecal laser-lines run
//!   line: L1
//!   air_temperature_c: 20.2
//!   air_pressure_hpa: 1013.1
//!   humidity_percent: 45
//!   material_temperature_c: 20.4
//!   expansion_coefficient_ppm_per_k: 11.7
//!   compensation: automatic
//!   target_mm,run,direction,deviation_um
//!   0,1,+,0.000
//!   20,1,+,1.250
//!   ```
//!
//! - the text export of Renishaw's laser software (`.rtl`): sections
//!   `HEADER::`, `TARGET DATA::` (`Target-count:`, `Targets :` the target
//!   positions in mm), `USER-TEXT::`, `RUNS::` (`Run-count:`, the passes in
//!   both directions), `DEVIATIONS::` (`Run Target Data:` rows `pass target
//!   deviation_um`) and `ENVIRONMENT::` (air and material temperatures,
//!   pressure, humidity, expansion coefficient as the software recorded
//!   them), ending `EOF::`. A pass whose target numbers rise approached
//!   in the + direction, one whose numbers fall in the - direction; pass k
//!   in a direction is run k of it.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::machine::Dialect;
use crate::source::SourceError;

/// Current version of the laser-lines plan file.
pub const LASER_VERSION: u32 = 1;

/// The plan file of the ten-line test.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LaserManifest {
    /// Format version ([`LASER_VERSION`]).
    pub fivecal_laser_lines: u32,
    /// Machine name.
    pub machine: String,
    /// Copy of the machine file, relative to the plan file.
    pub machine_file: PathBuf,
    /// Dialect of the programs.
    pub dialect: Dialect,
    /// The measuring volume, machine coordinates of the measured point,
    /// mm: X0, Y0, Z0, X1, Y1, Z1.
    pub volume: [f64; 6],
    /// Runs in each direction (ISO 230-2 asks five).
    pub runs: usize,
    /// Overrun beyond the end targets before each reversal, mm.
    pub overrun_mm: f64,
    /// Dwell at each target for the interferometer's capture, s.
    pub dwell_s: f64,
    /// Standard uncertainty of one reading of the interferometer, um
    /// (its resolution and the noise of a still capture).
    pub reading_u_um: f64,
    /// Standard uncertainty of the compensated length, ppm (the laser's
    /// wavelength with the environmental compensation).
    pub length_u_ppm: f64,
    /// The lines in the order they are run.
    pub lines: Vec<LineEntry>,
}

/// One line of the ten.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LineEntry {
    /// `L1` .. `L10`, as a run file names it.
    pub name: String,
    /// The axes that move: `X`, `Y`, `Z` or `XYZ` (the diagonal).
    pub axes: String,
    /// The measured point at target 0, machine coordinates, mm.
    pub start: [f64; 3],
    /// Unit direction of the line (of rising target positions).
    pub direction: [f64; 3],
    /// The measured point's offset from the spindle point P, mm.
    pub offset: [f64; 3],
    /// How the offset is made: `none`, `axes` (the other axes hold the
    /// offset position) or `bracket` (a reflector bracket on the spindle).
    pub offset_by: String,
    /// Target positions along the line from its start, mm, rising.
    pub targets: Vec<f64>,
    /// The program, relative to the plan file.
    pub program: PathBuf,
    /// The setup sheet, relative to the plan file.
    pub sheet: PathBuf,
}

impl LineEntry {
    /// The spindle point's machine coordinates at target `i` (the bracket's
    /// offset taken off when the reflector sits on one).
    pub fn spindle_at(&self, i: usize) -> [f64; 3] {
        let b = if self.offset_by == "bracket" {
            self.offset
        } else {
            [0.0; 3]
        };
        std::array::from_fn(|k| self.start[k] + self.direction[k] * self.targets[i] - b[k])
    }
}

impl LaserManifest {
    /// Parses a plan file.
    pub fn parse(path: &Path, src: &str) -> Result<LaserManifest, SourceError> {
        let m: LaserManifest = crate::input::parse_yaml(path, src)?;
        if m.fivecal_laser_lines != LASER_VERSION {
            return Err(SourceError::at_key(
                path,
                src,
                &["fivecal_laser_lines"],
                format!(
                    "laser-lines plan version {} is not supported (expected {LASER_VERSION})",
                    m.fivecal_laser_lines
                ),
            ));
        }
        let at = |key: &str, msg: String| SourceError::at_key(path, src, &[key], msg);
        if m.runs < 2 || m.runs > 100 {
            return Err(at("runs", format!("runs {}: expected 2 to 100", m.runs)));
        }
        let fine = |v: f64| v.is_finite() && v >= 0.0;
        if !(fine(m.overrun_mm) && fine(m.dwell_s) && fine(m.reading_u_um) && fine(m.length_u_ppm))
        {
            return Err(at(
                "overrun_mm",
                "overrun_mm, dwell_s, reading_u_um and length_u_ppm must be numbers >= 0".into(),
            ));
        }
        if m.volume.iter().any(|v| !v.is_finite()) {
            return Err(at("volume", "volume: expected six numbers, mm".into()));
        }
        for (i, l) in m.lines.iter().enumerate() {
            let bad = |msg: String| at("lines", format!("line {} ({}): {msg}", i + 1, l.name));
            if l.targets.len() < 2 {
                return Err(bad("expected at least two targets".into()));
            }
            if l.targets.iter().any(|t| !t.is_finite())
                || l.targets.windows(2).any(|w| w[1] <= w[0])
            {
                return Err(bad("targets must be finite and rising".into()));
            }
            let all = l.start.iter().chain(&l.direction).chain(&l.offset);
            if all.into_iter().any(|v| !v.is_finite()) {
                return Err(bad("a position or direction is not a number".into()));
            }
            let len = l.direction.iter().map(|v| v * v).sum::<f64>().sqrt();
            if (len - 1.0).abs() > 1e-6 {
                return Err(bad(format!("direction has length {len}, expected 1")));
            }
            if !matches!(l.offset_by.as_str(), "none" | "axes" | "bracket") {
                return Err(bad(format!(
                    "offset_by `{}`: expected none, axes or bracket",
                    l.offset_by
                )));
            }
        }
        Ok(m)
    }

    /// Reads a plan file.
    pub fn read(path: &Path) -> Result<LaserManifest, SourceError> {
        let src = crate::input::read_text(path, "laser-lines plan", crate::limits::MAX_YAML_BYTES)?;
        LaserManifest::parse(path, &src)
    }

    /// YAML text.
    pub fn to_yaml(&self) -> String {
        serde_yaml::to_string(self).expect("laser-lines plans serialize")
    }

    /// The line named `name`.
    pub fn line(&self, name: &str) -> Option<&LineEntry> {
        self.lines.iter().find(|l| l.name == name)
    }

    /// Whether `src` is a laser-lines plan file (its first key).
    pub fn sniff(src: &str) -> bool {
        super::first_key_is(src, "fivecal_laser_lines:")
    }
}

/// One reading: a target approached in one direction in one run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reading {
    /// Target position along the line, mm.
    pub target_mm: f64,
    /// Run number in its direction, from 1.
    pub run: usize,
    /// Approached in the + direction (rising positions).
    pub forward: bool,
    /// Positioning deviation, actual minus target, um.
    pub deviation_um: f64,
}

/// The readings of one line.
#[derive(Clone, Debug, PartialEq)]
pub struct LaserRun {
    /// The plan's line it measured.
    pub line: String,
    /// Which format it came from (`fivecal plain`, `Renishaw .rtl`).
    pub format: &'static str,
    /// The environment and its compensation, as the file states them
    /// (key, value).
    pub environment: Vec<(String, String)>,
    /// The readings in file order.
    pub readings: Vec<Reading>,
}

/// Largest run file, bytes.
const MAX_RUN_BYTES: u64 = 16 << 20;

/// The environment keys of the plain format; the values are kept as text,
/// the numeric ones checked to be numbers.
const PLAIN_ENVIRONMENT: [(&str, bool); 6] = [
    ("air_temperature_c", true),
    ("air_pressure_hpa", true),
    ("humidity_percent", true),
    ("material_temperature_c", true),
    ("expansion_coefficient_ppm_per_k", true),
    ("compensation", false),
];

fn name_like(s: &str) -> bool {
    !s.is_empty()
        && s.len() <= 64
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '.' | '-'))
}

impl LaserRun {
    /// Reads a run file in either format (recognized from the content).
    pub fn read(path: &Path) -> Result<LaserRun, SourceError> {
        let src = crate::input::read_text(path, "laser run", MAX_RUN_BYTES)?;
        LaserRun::parse(path, &src)
    }

    /// Parses a run file in either format.
    pub fn parse(path: &Path, src: &str) -> Result<LaserRun, SourceError> {
        if src.lines().any(|l| l.trim() == "HEADER::") {
            parse_rtl(path, src)
        } else {
            parse_plain(path, src)
        }
    }

    /// Whether `src` looks like a run file of either format.
    pub fn sniff(src: &str) -> bool {
        let first = src
            .lines()
            .map(str::trim)
            .find(|l| !l.is_empty() && !l.starts_with('#'));
        first.is_some_and(|l| l == "HEADER::" || l.starts_with("line:"))
    }

    /// The plain text of the run.
    pub fn to_text(&self) -> String {
        use std::fmt::Write as _;
        let mut s = String::from(
            "# fivecal laser-lines run: positioning deviation (actual - target), um\n",
        );
        let _ = writeln!(s, "line: {}", self.line);
        for (k, v) in &self.environment {
            let _ = writeln!(s, "{k}: {v}");
        }
        s.push_str("target_mm,run,direction,deviation_um\n");
        for r in &self.readings {
            let _ = writeln!(
                s,
                "{},{},{},{:.4}",
                crate::numbers::echo(r.target_mm),
                r.run,
                if r.forward { '+' } else { '-' },
                r.deviation_um
            );
        }
        s
    }
}

fn parse_plain(path: &Path, src: &str) -> Result<LaserRun, SourceError> {
    let err = |line: usize, col: usize, msg: String| SourceError::new(path, line, col, msg);
    let mut line_name: Option<String> = None;
    let mut environment: Vec<(String, String)> = Vec::new();
    let mut header = false;
    let mut readings = Vec::new();
    for (i, raw) in src.lines().enumerate() {
        let ln = i + 1;
        let text = raw.split('#').next().unwrap_or("");
        let indent = text.len() - text.trim_start().len();
        let t = text.trim();
        if t.is_empty() {
            continue;
        }
        if !header {
            if let Some((key, value)) = t.split_once(':') {
                let vcol = indent + key.len() + 2 + (value.len() - value.trim_start().len());
                let (key, value) = (key.trim(), value.trim());
                if key == "line" {
                    if !name_like(value) {
                        return Err(err(
                            ln,
                            vcol,
                            format!("expected a line name of the plan (L1 .. L10), got `{value}`"),
                        ));
                    }
                    line_name = Some(value.to_string());
                } else if let Some((_, numeric)) = PLAIN_ENVIRONMENT.iter().find(|(k, _)| *k == key)
                {
                    let number = value.parse::<f64>().ok().filter(|v| v.is_finite());
                    if *numeric && number.is_none() {
                        return Err(err(
                            ln,
                            vcol,
                            format!("expected a number for {key}, got `{value}`"),
                        ));
                    }
                    if environment.iter().any(|(k, _)| k == key) {
                        return Err(err(ln, indent + 1, format!("{key} given twice")));
                    }
                    environment.push((key.to_string(), value.to_string()));
                } else {
                    let keys: Vec<&str> = PLAIN_ENVIRONMENT.iter().map(|(k, _)| *k).collect();
                    return Err(err(
                        ln,
                        indent + 1,
                        format!(
                            "unknown key `{key}`: expected line, {}, then the header target_mm,run,direction,deviation_um",
                            keys.join(", ")
                        ),
                    ));
                }
                continue;
            }
            let head: Vec<String> = t
                .split(',')
                .map(|s| s.trim().to_ascii_lowercase())
                .collect();
            if head != ["target_mm", "run", "direction", "deviation_um"] {
                return Err(err(
                    ln,
                    indent + 1,
                    format!(
                        "expected the header `target_mm,run,direction,deviation_um`, got `{t}`"
                    ),
                ));
            }
            header = true;
            continue;
        }
        let fields: Vec<&str> = text.split(',').collect();
        if fields.len() != 4 {
            return Err(err(
                ln,
                indent + 1,
                format!(
                    "expected four fields target_mm,run,direction,deviation_um, got {}",
                    fields.len()
                ),
            ));
        }
        let col = |k: usize| fields[..k].iter().map(|f| f.len() + 1).sum::<usize>() + 1;
        let target: f64 = fields[0]
            .trim()
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite() && v.abs() <= crate::limits::MAX_MACHINE_MM)
            .ok_or_else(|| {
                err(
                    ln,
                    col(0),
                    format!(
                        "expected a target position in mm, got `{}`",
                        fields[0].trim()
                    ),
                )
            })?;
        let run: usize = fields[1]
            .trim()
            .parse()
            .ok()
            .filter(|r| (1..=1000).contains(r))
            .ok_or_else(|| {
                err(
                    ln,
                    col(1),
                    format!(
                        "expected a run number 1, 2, ..., got `{}`",
                        fields[1].trim()
                    ),
                )
            })?;
        let forward = match fields[2].trim() {
            "+" => true,
            "-" => false,
            other => {
                return Err(err(
                    ln,
                    col(2),
                    format!("expected the approach direction + or -, got `{other}`"),
                ));
            }
        };
        let dev: f64 = fields[3]
            .trim()
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite() && v.abs() <= crate::limits::MAX_ERROR_UM)
            .ok_or_else(|| {
                err(
                    ln,
                    col(3),
                    format!(
                        "expected a deviation in um (a number within +-{}), got `{}`",
                        crate::limits::MAX_ERROR_UM,
                        fields[3].trim()
                    ),
                )
            })?;
        readings.push(Reading {
            target_mm: target,
            run,
            forward,
            deviation_um: dev,
        });
    }
    let end = src.lines().count().max(1);
    let Some(line) = line_name else {
        return Err(err(
            1,
            1,
            "missing `line: NAME` (the plan's line this run measured)".into(),
        ));
    };
    if readings.is_empty() {
        return Err(err(
            end,
            1,
            "no readings: expected the header target_mm,run,direction,deviation_um and rows".into(),
        ));
    }
    Ok(LaserRun {
        line,
        format: "fivecal plain",
        environment,
        readings,
    })
}

/// The text export of Renishaw's laser software.
fn parse_rtl(path: &Path, src: &str) -> Result<LaserRun, SourceError> {
    let err = |line: usize, col: usize, msg: String| SourceError::new(path, line, col, msg);
    let mut section = String::new();
    let mut target_count: Option<(usize, usize)> = None;
    let mut targets: Vec<f64> = Vec::new();
    let mut in_targets = false;
    let mut in_rows = false;
    let mut run_count: Option<(usize, usize)> = None;
    let mut axis: Option<String> = None;
    let mut environment = Vec::new();
    // (line, pass, target number, deviation)
    let mut rows: Vec<(usize, usize, usize, f64)> = Vec::new();
    for (i, raw) in src.lines().enumerate() {
        let ln = i + 1;
        let indent = raw.len() - raw.trim_start().len();
        let t = raw.trim();
        if t.is_empty() {
            continue;
        }
        if let Some(name) = t.strip_suffix("::")
            && !name.is_empty()
            && name
                .chars()
                .all(|c| c.is_ascii_uppercase() || c == ' ' || c == '-')
        {
            section = name.trim().to_string();
            in_targets = false;
            in_rows = false;
            continue;
        }
        let kv = t.split_once(':').map(|(k, v)| (k.trim(), v.trim()));
        match section.as_str() {
            "TARGET DATA" => {
                if let Some((k, v)) = kv {
                    in_targets = k.eq_ignore_ascii_case("targets");
                    if k.eq_ignore_ascii_case("target-count") {
                        let n = v
                            .parse::<usize>()
                            .ok()
                            .filter(|n| (2..=100_000).contains(n));
                        target_count = Some((
                            n.ok_or_else(|| {
                                err(
                                    ln,
                                    indent + 1,
                                    format!("expected a target count (2 or more), got `{v}`"),
                                )
                            })?,
                            ln,
                        ));
                    }
                    if in_targets {
                        push_numbers(v, &mut targets).map_err(|w| {
                            err(
                                ln,
                                indent + 1,
                                format!("expected target positions in mm, got `{w}`"),
                            )
                        })?;
                    }
                } else if in_targets {
                    push_numbers(t, &mut targets).map_err(|w| {
                        err(
                            ln,
                            indent + 1,
                            format!("expected target positions in mm, got `{w}`"),
                        )
                    })?;
                } else {
                    return Err(err(
                        ln,
                        indent + 1,
                        format!("unexpected `{t}` in TARGET DATA"),
                    ));
                }
            }
            "USER-TEXT" => {
                if let Some(("Axis", v)) = kv
                    && !v.is_empty()
                {
                    axis = Some(v.to_string());
                }
            }
            "RUNS" => {
                if let Some((k, v)) = kv
                    && k.eq_ignore_ascii_case("run-count")
                {
                    let n = v.parse::<usize>().ok().filter(|n| (1..=2000).contains(n));
                    run_count = Some((
                        n.ok_or_else(|| {
                            err(
                                ln,
                                indent + 1,
                                format!("expected a run count (1 or more), got `{v}`"),
                            )
                        })?,
                        ln,
                    ));
                }
            }
            "DEVIATIONS" => {
                if let Some((k, _)) = kv {
                    in_rows = k.eq_ignore_ascii_case("run target data");
                    continue;
                }
                if !in_rows {
                    return Err(err(
                        ln,
                        indent + 1,
                        "expected `Run Target Data:` before the rows".into(),
                    ));
                }
                let f: Vec<&str> = t.split_whitespace().collect();
                if f.len() != 3 {
                    return Err(err(
                        ln,
                        indent + 1,
                        format!("expected three fields `pass target deviation_um`, got `{t}`"),
                    ));
                }
                let pass = f[0].parse::<usize>().ok().filter(|p| *p >= 1);
                let target = f[1].parse::<usize>().ok().filter(|p| *p >= 1);
                let dev = f[2]
                    .parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite() && v.abs() <= crate::limits::MAX_ERROR_UM);
                let col2 = raw.find(f[1]).unwrap_or(indent) + 1;
                let col3 = raw.rfind(f[2]).unwrap_or(indent) + 1;
                match (pass, target, dev) {
                    (None, _, _) => {
                        return Err(err(
                            ln,
                            indent + 1,
                            format!("expected a pass number 1, 2, ..., got `{}`", f[0]),
                        ));
                    }
                    (_, None, _) => {
                        return Err(err(
                            ln,
                            col2,
                            format!("expected a target number 1, 2, ..., got `{}`", f[1]),
                        ));
                    }
                    (_, _, None) => {
                        return Err(err(
                            ln,
                            col3,
                            format!(
                                "expected a deviation in um (within +-{}), got `{}`",
                                crate::limits::MAX_ERROR_UM,
                                f[2]
                            ),
                        ));
                    }
                    (Some(p), Some(k), Some(d)) => rows.push((ln, p, k, d)),
                }
            }
            "ENVIRONMENT" => {
                if let Some((k, v)) = kv
                    && !k.is_empty()
                {
                    environment.push((k.to_string(), v.to_string()));
                }
            }
            // HEADER, EQUIPMENT, EOF and what later versions add: not needed.
            _ => {}
        }
    }
    let end = src.lines().count().max(1);
    let Some((count, count_line)) = target_count else {
        return Err(err(1, 1, "missing `Target-count:` in TARGET DATA::".into()));
    };
    if targets.len() != count {
        return Err(err(
            count_line,
            1,
            format!(
                "Target-count: {count}, but `Targets :` lists {}",
                targets.len()
            ),
        ));
    }
    if targets.windows(2).any(|w| w[1] <= w[0]) {
        return Err(err(count_line, 1, "the targets must rise".into()));
    }
    let Some((passes, passes_line)) = run_count else {
        return Err(err(1, 1, "missing `Run-count:` in RUNS::".into()));
    };
    if rows.is_empty() {
        return Err(err(end, 1, "no rows after `Run Target Data:`".into()));
    }
    // Each pass: its rows' target numbers rise (+) or fall (-).
    let mut readings = Vec::new();
    let mut runs_in = [0usize; 2];
    for p in 1..=passes {
        let of: Vec<&(usize, usize, usize, f64)> = rows.iter().filter(|r| r.1 == p).collect();
        let Some(first) = of.first() else {
            return Err(err(
                passes_line,
                1,
                format!("Run-count: {passes}, but pass {p} has no rows"),
            ));
        };
        let rising = of.windows(2).all(|w| w[1].2 > w[0].2);
        let falling = of.windows(2).all(|w| w[1].2 < w[0].2);
        if of.len() < 2 || !(rising || falling) {
            return Err(err(
                first.0,
                1,
                format!(
                    "pass {p}: expected its target numbers in order, rising or falling (one direction per pass)"
                ),
            ));
        }
        let forward = rising;
        runs_in[usize::from(!forward)] += 1;
        let run = runs_in[usize::from(!forward)];
        for &&(ln, _, k, d) in &of {
            let Some(&t) = targets.get(k - 1) else {
                return Err(err(
                    ln,
                    1,
                    format!("target {k}: the file lists {count} targets"),
                ));
            };
            readings.push(Reading {
                target_mm: t,
                run,
                forward,
                deviation_um: d,
            });
        }
    }
    if let Some(r) = rows.iter().find(|r| r.1 > passes) {
        return Err(err(
            r.0,
            1,
            format!("pass {} beyond Run-count: {passes}", r.1),
        ));
    }
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let line = axis.filter(|a| name_like(a)).unwrap_or(stem);
    if !name_like(&line) {
        return Err(err(
            1,
            1,
            "no line name: expected `Axis:` in USER-TEXT:: naming the plan's line (L1 .. L10), or a file named after it".into(),
        ));
    }
    Ok(LaserRun {
        line,
        format: "Renishaw .rtl",
        environment,
        readings,
    })
}

fn push_numbers<'a>(s: &'a str, out: &mut Vec<f64>) -> Result<(), &'a str> {
    for w in s.split_whitespace() {
        let v: f64 = w
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite() && v.abs() <= crate::limits::MAX_MACHINE_MM)
            .ok_or(w)?;
        if out.len() >= 100_000 {
            return Err(w);
        }
        out.push(v);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_plain_run_reads_back_what_was_written() {
        let run = LaserRun {
            line: "L4".into(),
            format: "fivecal plain",
            environment: vec![("air_temperature_c".into(), "20.3".into())],
            readings: vec![
                Reading {
                    target_mm: 0.0,
                    run: 1,
                    forward: true,
                    deviation_um: 0.5,
                },
                Reading {
                    target_mm: 20.0,
                    run: 1,
                    forward: false,
                    deviation_um: -1.25,
                },
            ],
        };
        let back = LaserRun::parse(Path::new("r.txt"), &run.to_text()).unwrap();
        assert_eq!(back, run);
    }

    #[test]
    fn bad_plain_input_names_line_and_column() {
        let e = LaserRun::parse(
            Path::new("r.txt"),
            "line: L1\ntarget_mm,run,direction,deviation_um\n0,1,+,0.5\n20,1,x,1\n",
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.starts_with("r.txt:4:6: expected the approach direction"),
            "{e}"
        );
        let e = LaserRun::parse(Path::new("r.txt"), "line: L1\nair_pressure_hpa: high\n")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("r.txt:2:19: expected a number"), "{e}");
    }

    #[test]
    fn an_rtl_pass_direction_follows_its_target_order() {
        let src = "HEADER::\nFile type : rtl\n\nTARGET DATA::\nFiletype : ISO\nTarget-count: 3\nTargets :\n0 10 20\nFlags: 0 0 2 0\n\nUSER-TEXT::\nAxis: L2\n\nRUNS::\nRun-count: 2\n\nDEVIATIONS::\nRun Target Data:\n1 1 0.0\n1 2 1.5\n1 3 2.5\n2 3 3.0\n2 2 2.0\n2 1 0.5\n\nENVIRONMENT::\nAir temp : 20.10\n\nEOF::\n";
        let r = LaserRun::parse(Path::new("x.rtl"), src).unwrap();
        assert_eq!(r.line, "L2");
        assert_eq!(r.readings.len(), 6);
        assert_eq!(
            r.readings[3],
            Reading {
                target_mm: 20.0,
                run: 1,
                forward: false,
                deviation_um: 3.0
            }
        );
        assert_eq!(
            r.environment,
            vec![("Air temp".to_string(), "20.10".to_string())]
        );
        let bad = src.replace("2 2 2.0", "2 2 two");
        let e = LaserRun::parse(Path::new("x.rtl"), &bad)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("x.rtl:23:5: expected a deviation"), "{e}");
    }
}
