//! The options of `fivecal plan laser-lines` (the laser interferometer's
//! ten lines) and of `fivecal analyze` on a laser-lines plan, validated
//! into the library's request.

use std::path::PathBuf;

use anyhow::bail;
use clap::Args;
use fivecal::machine::{Machine, MachineOrigin};
use fivecal::procedure::laser_lines::LaserRequest;

use super::DialectArg;

/// `plan laser-lines` only.
#[derive(Args, Debug, Default)]
pub struct LaserArgs {
    /// laser-lines: the measuring volume, machine coordinates of the
    /// measured point, mm [default: the strokes less a margin].
    #[arg(long, value_name = "X0,Y0,Z0,X1,Y1,Z1")]
    pub volume: Option<String>,
    /// laser-lines: runs in each direction [default: 5, as ISO 230-2].
    #[arg(long, value_name = "N")]
    pub runs: Option<usize>,
    /// laser-lines: equal divisions of each line [default: 40].
    #[arg(long, value_name = "N")]
    pub divisions: Option<usize>,
    /// laser-lines: overrun beyond the end targets, mm [default: 5].
    #[arg(long, value_name = "MM")]
    pub overrun: Option<f64>,
    /// laser-lines: dwell at each target for the capture, s [default: 3].
    #[arg(long, value_name = "S")]
    pub dwell: Option<f64>,
    /// laser-lines: offset of a reflector on a spindle bracket, mm
    /// [default: 150].
    #[arg(long, value_name = "MM")]
    pub bracket: Option<f64>,
    /// laser-lines: the interferometer's standard uncertainty of one
    /// reading, um, and of a length, ppm [default: 0.1,0.5].
    #[arg(long, value_name = "UM,PPM")]
    pub laser_u: Option<String>,
}

impl LaserArgs {
    /// The options given, by flag, for refusing them on another test.
    pub fn given(&self) -> Vec<&'static str> {
        [
            ("--volume", self.volume.is_some()),
            ("--runs", self.runs.is_some()),
            ("--divisions", self.divisions.is_some()),
            ("--overrun", self.overrun.is_some()),
            ("--dwell", self.dwell.is_some()),
            ("--bracket", self.bracket.is_some()),
            ("--laser-u", self.laser_u.is_some()),
        ]
        .into_iter()
        .filter_map(|(f, g)| g.then_some(f))
        .collect()
    }
}

/// The validated `plan laser-lines`.
pub struct LaserPlanConfig {
    pub request: LaserRequest,
    pub out: PathBuf,
    pub inputs: Vec<PathBuf>,
    pub origin: String,
}

fn numbers(flag: &str, s: &str, n: usize, example: &str) -> anyhow::Result<Vec<f64>> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| anyhow::anyhow!("{flag} {s}: expected {n} numbers, e.g. {example}"))?;
    if v.len() != n || v.iter().any(|x| !x.is_finite()) {
        bail!("{flag} {s}: expected {n} numbers, e.g. {example}");
    }
    Ok(v)
}

/// Validates `plan laser-lines`' options.
pub fn config(
    machine: Option<&str>,
    dialect: Option<DialectArg>,
    out: Option<PathBuf>,
    a: LaserArgs,
) -> anyhow::Result<LaserPlanConfig> {
    let Some(spec) = machine else {
        bail!("plan laser-lines needs --machine: a machine file or a built-in machine");
    };
    let (machine, origin) =
        Machine::resolve(spec).map_err(|e| anyhow::anyhow!("cannot load machine `{spec}`: {e}"))?;
    let mut inputs = Vec::new();
    if let MachineOrigin::File(p) = &origin {
        inputs.push(p.clone());
    }
    let dialect = dialect.map_or(machine.dialect, Into::into);
    let mut r = LaserRequest::new(machine, dialect);
    if let Some(v) = &a.volume {
        let v = numbers("--volume", v, 6, "100,-650,-500,900,-50,-100")?;
        r.volume = Some([v[0], v[1], v[2], v[3], v[4], v[5]]);
    }
    r.runs = a.runs.unwrap_or(r.runs);
    r.divisions = a.divisions.unwrap_or(r.divisions);
    r.overrun_mm = a.overrun.unwrap_or(r.overrun_mm);
    r.dwell_s = a.dwell.unwrap_or(r.dwell_s);
    r.bracket_mm = a.bracket.unwrap_or(r.bracket_mm);
    if let Some(s) = &a.laser_u {
        let v = numbers("--laser-u", s, 2, "0.1,0.5")?;
        (r.reading_u_um, r.length_u_ppm) = (v[0], v[1]);
    }
    Ok(LaserPlanConfig {
        request: r,
        out: out.unwrap_or_else(|| PathBuf::from("laser-lines")),
        inputs,
        origin: origin.to_string(),
    })
}

/// The validated `analyze` of a laser-lines plan.
pub struct LaserAnalyzeConfig {
    pub plan: PathBuf,
    pub measured: Vec<PathBuf>,
    pub out: PathBuf,
    pub json: bool,
    pub report: Option<PathBuf>,
}
