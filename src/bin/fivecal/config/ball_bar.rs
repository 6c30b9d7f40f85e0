//! The options of `fivecal plan ball-bar` (the ball bar under TCP), of
//! `fivecal simulate` on a ball-bar plan and of `fivecal analyze` on its
//! runs, validated into the library's requests.

use std::path::{Path, PathBuf};

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
    /// ball-bar: standard deviation of one reading of the bar, um
    /// [default: 0.5].
    #[arg(long, value_name = "UM")]
    pub bar_noise: Option<f64>,
}

impl BallBarArgs {
    /// The options given, by flag, for refusing them on another test.
    pub fn given(&self) -> Vec<&'static str> {
        [
            ("--bar", !self.bar.is_empty()),
            ("--ball", !self.ball.is_empty()),
            ("--swing", !self.swing.is_empty()),
            ("--bar-noise", self.bar_noise.is_some()),
        ]
        .into_iter()
        .filter_map(|(f, g)| g.then_some(f))
        .collect()
    }
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
    if let Some(n) = a.bar_noise {
        request.noise_um = n;
    }
    Ok(BallBarPlanConfig {
        request,
        out: out.unwrap_or_else(|| PathBuf::from("ball-bar")),
        inputs,
        origin: origin.to_string(),
    })
}

/// `--runout UM[,DEG]`: the spindle ball's run-out and the spindle angle
/// of its maximum (0 when not given).
pub fn runout(r: &str) -> anyhow::Result<(f64, f64)> {
    let v: Vec<f64> = r
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| anyhow::anyhow!("--runout {r}: expected UM or UM,DEG"))?;
    match v.as_slice() {
        [u] => Ok((*u, 0.0)),
        [u, p] => Ok((*u, *p)),
        _ => bail!("--runout {r}: expected UM or UM,DEG"),
    }
}

/// `analyze`'s options that apply to a ball-bar plan only.
pub struct BallBarAnalyzeArgs {
    pub runout: Option<String>,
    pub placement_u: Option<f64>,
    pub linear_errors: Option<PathBuf>,
}

/// `analyze` on the plan `plan`: the ball-bar request when it is a
/// ball-bar plan (refusing the options that do not apply to one, named in
/// `others` with whether each was given), else `None` (refusing the
/// ball-bar options).
pub fn analysis(
    plan: &Path,
    runs: &[PathBuf],
    a: BallBarAnalyzeArgs,
    noise: Option<f64>,
    usefulness: fivecal::analyze::usefulness::Usefulness,
    others: &[(&str, bool)],
) -> anyhow::Result<Option<fivecal::analyze::ball_bar::Request>> {
    use fivecal::analyze::ball_bar::{Options, Request, Runout};
    let is_plan =
        std::fs::read_to_string(plan).is_ok_and(|s| fivecal::analyze::ball_bar::is_plan(&s));
    if !is_plan {
        if a.runout.is_some() || a.placement_u.is_some() || a.linear_errors.is_some() {
            bail!(
                "--runout, --placement-u and --linear-errors apply to a ball-bar plan (`fivecal plan ball-bar`); {} is not one",
                plan.display()
            );
        }
        return Ok(None);
    }
    if let Some((name, _)) = others.iter().find(|(_, given)| *given) {
        bail!(
            "{name} does not apply to a ball-bar plan: its runs are identified by one fit of every reading, with u in closed form"
        );
    }
    let (um, phase_deg) = a
        .runout
        .as_deref()
        .map(runout)
        .transpose()?
        .unwrap_or((0.0, 0.0));
    let mut options = Options {
        runout: Runout { um, phase_deg },
        noise_um: noise,
        usefulness,
        ..Options::default()
    };
    if let Some(p) = a.placement_u {
        options.placement_um = p;
    }
    Ok(Some(Request {
        plan: plan.to_path_buf(),
        runs: runs.to_vec(),
        linear_errors: a.linear_errors,
        options,
    }))
}
