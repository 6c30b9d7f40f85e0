//! The options of `fivecal plan ball-bar` (the ball bar under TCP) and of
//! `fivecal simulate` on a ball-bar plan, validated into the library's
//! request.

use std::path::PathBuf;

use anyhow::{Context as _, bail};
use clap::Args;
use fivecal::machine::{Machine, MachineOrigin};
use fivecal::procedure::ball_bar::BallBarRequest;
use nalgebra::Vector3;

use super::DialectArg;

/// `plan ball-bar` only.
#[derive(Args, Debug, Default)]
pub struct BallBarArgs {
    /// ball-bar: the bar lengths you own, mm (calibrated lengths with
    /// their extensions), e.g. 100,150,300.
    #[arg(long, value_name = "MM,MM,..", value_delimiter = ',')]
    pub bar: Vec<f64>,
    /// ball-bar: a position (K, L, H) of the spindle ball in W for the
    /// table axes, mm; repeat for each (default: three chosen from the
    /// table, as the paper's (200,152,57), (310,152,57), (310,210,452)).
    #[arg(long, value_name = "K,L,H")]
    pub ball: Vec<String>,
    /// ball-bar: lengths S from the head's rotation centre to the spindle
    /// ball for the head axes, mm (default: the pivot length plus 100, 175
    /// and 250).
    #[arg(long, value_name = "MM,MM,..", value_delimiter = ',')]
    pub swing: Vec<f64>,
    /// ball-bar: standard deviation of one reading of the bar, um.
    #[arg(long, value_name = "UM", default_value_t = 0.5)]
    pub bar_noise: f64,
}

/// The validated `plan ball-bar`.
pub struct BallBarPlanConfig {
    pub request: BallBarRequest,
    pub out: PathBuf,
    pub inputs: Vec<PathBuf>,
    pub origin: String,
}

fn triple(s: &str) -> anyhow::Result<Vector3<f64>> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| anyhow::anyhow!("--ball {s}: expected K,L,H in mm, e.g. 200,152,57"))?;
    if v.len() != 3 || v.iter().any(|x| !x.is_finite()) {
        bail!("--ball {s}: expected three numbers K,L,H in mm, e.g. 200,152,57");
    }
    Ok(Vector3::new(v[0], v[1], v[2]))
}

/// Validates `plan ball-bar`'s options.
pub fn config(
    machine: Option<&str>,
    dialect: Option<DialectArg>,
    out: Option<PathBuf>,
    a: BallBarArgs,
) -> anyhow::Result<BallBarPlanConfig> {
    let Some(spec) = machine else {
        bail!("plan ball-bar needs --machine: a machine file or a built-in machine");
    };
    let (machine, origin) =
        Machine::resolve(spec).map_err(|e| anyhow::anyhow!("cannot load machine `{spec}`: {e}"))?;
    let mut inputs = Vec::new();
    if let MachineOrigin::File(p) = &origin {
        inputs.push(p.clone());
    }
    if a.bar.is_empty() {
        bail!("plan ball-bar needs --bar: the bar lengths you own, mm (e.g. --bar 100,150,300)");
    }
    let dialect = dialect.map_or(machine.dialect, Into::into);
    let mut request = BallBarRequest::new(machine, dialect, a.bar);
    request.balls = a
        .ball
        .iter()
        .map(|s| triple(s))
        .collect::<anyhow::Result<_>>()
        .context("bad --ball")?;
    request.swings = a.swing;
    request.noise_um = a.bar_noise;
    Ok(BallBarPlanConfig {
        request,
        out: out.unwrap_or_else(|| PathBuf::from("ball-bar")),
        inputs,
        origin: origin.to_string(),
    })
}
