//! `fivecal plan`'s options, and the [`Route`] they validate into: a
//! template test's [`Config`] (`plan/template.rs`: the machine, the
//! template, dialect and postprocessor, kinematics and tool, the output
//! directory, and the command line `plan` quotes when it suggests a
//! change), or the ball bar's or the laser lines' own configuration. An
//! option of another kind of test is refused here, by name.

use std::path::PathBuf;

use anyhow::bail;
use clap::{Args, ValueEnum};

use super::DialectArg;

mod recipe;
mod supplement;
mod template;
mod tool;

pub use recipe::recipe;
pub use template::Config;

use template::config;

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum KinematicsArg {
    /// fivecal computes X, Y, Z and the rotary axes from the machine file.
    Post,
    /// The controller's tilted plane (G68.2 / PLANE SPATIAL) or TCP does it.
    Controller,
}

#[derive(Args, Debug)]
pub struct PlanArgs {
    /// The test: stepped-square (Ibaraki & Ota 2014), nine-section (Cubas Brizuela & Yeh 2023),
    /// probe-columns (Ibaraki, Iritani & Matsushita 2013), probe-sphere (the LAMDAMAP 2015 paper; Cubas Brizuela & Yeh 2023)
    /// ball-bar (the ball bar under TCP, Jiang et al.; with --bar) or laser-lines (the laser
    /// interferometer's ten lines, ISO 230-2 cycles; Jiang et al.).
    /// Not needed with --supplement.
    #[arg(required_unless_present = "supplement")]
    test: Option<String>,
    /// Machine file, or a built-in machine (bc-trunnion, ac-trunnion,
    /// head-table, head-head). Required: a plan is for one machine [with
    /// --supplement: the machine of the first test's plan].
    #[arg(long, value_name = "M.yaml|NAME")]
    machine: Option<String>,
    /// Write the supplementary test a `discover` result asks for (its
    /// `ambiguity.supplement`): the probing run whose poses separate the
    /// effects the first test could not tell apart, for the same machine.
    /// Measure it and give both tests to the next `discover`.
    #[arg(long, value_name = "DISCOVER.yaml", conflicts_with = "template")]
    supplement: Option<PathBuf>,
    /// Controller dialect: fanuc, heidenhain, linuxcnc or sinumerik [default: the
    /// machine file's controller].
    #[arg(long, value_enum)]
    dialect: Option<DialectArg>,
    /// Output directory [default: a directory named after the test, such
    /// as `stepped-square/`].
    #[arg(short, long)]
    out: Option<PathBuf>,
    /// How 3+2 positions are written (machining tests; probing programs
    /// always position the axes themselves) [default: post].
    #[arg(long, value_enum)]
    kinematics: Option<KinematicsArg>,
    /// Test template file replacing the built-in one (copy
    /// templates/<test>.yaml and edit it).
    #[arg(long)]
    template: Option<PathBuf>,
    /// Postprocessor definition file (copy postprocessors/<dialect>.yaml and
    /// edit it), or a built-in dialect name.
    #[arg(long)]
    postprocessor: Option<String>,
    /// Tool replacing the template's (machining tests): `machine` (the
    /// machine file's tool), a YAML tool file, or an inline mapping such as
    /// '{name: D6 ball, kind: ball, diameter: 6, length: 50}'. Probing
    /// tests use the machine file's probe.
    #[arg(long)]
    tool: Option<String>,
    /// `all`: refuse (and write nothing) when the test will not identify
    /// every location error of the machine, as predicted from the plan,
    /// naming the known changes of the template that would identify more.
    #[arg(long, value_name = "WHAT", value_parser = ["all"])]
    require: Option<String>,
    /// The largest u a location error may have to count as identified: a
    /// position's in um, an orientation's in urad [default: 10,50]; a
    /// symbol with a limit in the machine file: half its half-width.
    #[arg(long, value_name = "UM,URAD")]
    useful_u: Option<String>,
    /// Print what was planned as JSON on standard output: the test, the
    /// machine, the counts, what the plan identifies (as the manifest's
    /// `identifies:`), the notes and the files written.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    ball_bar: super::ball_bar::BallBarArgs,
    #[command(flatten)]
    laser: super::laser::LaserArgs,
}

/// What one `fivecal plan` run plans: a test of the template catalogue,
/// or one of the instrument tests, which have their own options.
pub enum Route {
    /// stepped-square, nine-section, probe-columns, probe-sphere (or the
    /// test a `--supplement` asks for).
    Test(Box<Config>),
    /// The ball bar under TCP (`config/ball_bar.rs`).
    BallBar {
        cfg: super::ball_bar::BallBarPlanConfig,
        json: bool,
    },
    /// The laser interferometer's ten lines (`config/laser.rs`).
    LaserLines {
        cfg: super::laser::LaserPlanConfig,
        json: bool,
    },
}

/// `plan`'s options validated into what it runs. An option of another
/// kind of test is refused by name, never ignored: `--bar` on a stepped
/// square, or `--template` on the ball bar, would otherwise plan something
/// other than what the command line says.
pub fn route(a: PlanArgs) -> anyhow::Result<Route> {
    let test = a.test.clone().unwrap_or_default();
    let template_options = [
        ("--supplement", a.supplement.is_some()),
        ("--template", a.template.is_some()),
        ("--postprocessor", a.postprocessor.is_some()),
        ("--kinematics", a.kinematics.is_some()),
        ("--tool", a.tool.is_some()),
        ("--require", a.require.is_some()),
        ("--useful-u", a.useful_u.is_some()),
    ];
    let refuse = |given: &[&str], kind: &str| -> anyhow::Result<()> {
        match given.first() {
            Some(flag) => {
                bail!("{flag} does not apply to `plan {test}`: it is an option of {kind}")
            }
            None => Ok(()),
        }
    };
    let template_given: Vec<&str> = template_options
        .iter()
        .filter(|(_, g)| *g)
        .map(|(f, _)| *f)
        .collect();
    let (bar_given, laser_given) = (a.ball_bar.given(), a.laser.given());
    match test.as_str() {
        "ball-bar" => {
            refuse(
                &template_given,
                "the template tests (stepped-square, nine-section, probe-columns, probe-sphere)",
            )?;
            refuse(&laser_given, "`plan laser-lines`")?;
            Ok(Route::BallBar {
                cfg: super::ball_bar::config(a.machine.as_deref(), a.dialect, a.out, a.ball_bar)?,
                json: a.json,
            })
        }
        "laser-lines" => {
            refuse(
                &template_given,
                "the template tests (stepped-square, nine-section, probe-columns, probe-sphere)",
            )?;
            refuse(&bar_given, "`plan ball-bar`")?;
            Ok(Route::LaserLines {
                cfg: super::laser::config(a.machine.as_deref(), a.dialect, a.out, a.laser)?,
                json: a.json,
            })
        }
        _ => {
            refuse(&bar_given, "`plan ball-bar`")?;
            refuse(&laser_given, "`plan laser-lines`")?;
            Ok(Route::Test(Box::new(config(a)?)))
        }
    }
}
