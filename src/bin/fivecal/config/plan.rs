//! `fivecal plan`'s options and their validation into one [`Config`]: the
//! machine (named, or the supplement's), the test and its template
//! (built in, a file, or the supplementary test a `discover` result asks
//! for), dialect and postprocessor, kinematics and tool, the output
//! directory; and the command line `plan` quotes when it suggests a change.

use std::path::{Path, PathBuf};

use anyhow::bail;
use clap::{Args, ValueEnum};
use fivecal::formats::manifest::{KinematicsMode, TestKind};
use fivecal::io::shell_word;
use fivecal::machine::{Machine, MachineOrigin};
use fivecal::post::PostDefinition;
use fivecal::procedure::{PlanConfig, Template, Test};

use super::DialectArg;

mod recipe;
mod supplement;
mod tool;

pub use recipe::recipe;

use supplement::supplementary;
use tool::parse_tool;

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

/// The validated configuration of one `plan` run.
pub struct Config {
    /// What to plan: machine, template, postprocessor, kinematics, tool.
    pub plan: PlanConfig,
    /// The output directory.
    pub out: PathBuf,
    /// Input files of the run (never to be overwritten).
    pub inputs: Vec<PathBuf>,
    /// Which machine the run used, built in or a file.
    pub origin: String,
    /// `--require all`.
    pub require_all: bool,
    /// `--useful-u`: what counts as identified.
    pub useful: fivecal::analyze::usefulness::Usefulness,
    /// `--json`: what was planned, as JSON on standard output.
    pub json: bool,
    /// The template file given with `--template`.
    template_file: Option<PathBuf>,
    /// Whether the template is the one `--supplement` asked for.
    supplement: bool,
    /// This run's `fivecal plan` command without its template and output
    /// options, for the changes `plan` suggests.
    command: String,
    /// Its `--machine` argument as written in `command`.
    machine_arg: String,
}

/// The validated configuration of one `plan` run of a template test.
fn config(a: PlanArgs) -> anyhow::Result<Config> {
    let mut inputs = Vec::new();
    let supplement = a.supplement.as_deref().map(supplementary).transpose()?;
    if let Some(s) = &supplement {
        inputs.push(s.file.clone());
    }
    let spec = match (&a.machine, &supplement) {
        (Some(m), _) => m.clone(),
        (None, Some(s)) => s
            .machine_file
            .as_ref()
            .map_or(s.machine_name.clone(), |p| p.display().to_string()),
        // No silent default: a program planned for a machine the user did
        // not name would run on theirs with another's strokes and pivot.
        (None, None) => bail!(
            "plan needs --machine: a machine file, or a built-in machine ({}); `fivecal machine new NAME --from bc-trunnion` writes a file to start one's own from",
            fivecal::machine::BUILTIN
                .iter()
                .map(|(n, _)| *n)
                .collect::<Vec<_>>()
                .join(", ")
        ),
    };
    // Flattened: MachineError repeats its cause as its source.
    let (machine, origin) = Machine::resolve(&spec)
        .map_err(|e| anyhow::anyhow!("cannot load machine `{spec}`: {e}"))?;
    if let MachineOrigin::File(p) = &origin {
        inputs.push(p.clone());
    }
    if let Some(s) = &supplement
        && s.machine_name != machine.name
    {
        bail!(
            "{} is a result for machine `{}`, but the machine in use is `{}`: the supplementary test is for the same machine (give its file with --machine)",
            s.file.display(),
            s.machine_name,
            machine.name
        );
    }
    let origin = format!("machine {}: {origin}", machine.name);
    let dialect = a
        .dialect
        .map(fivecal::Dialect::from)
        .or(supplement.as_ref().and_then(|s| s.dialect));
    let post = match &a.postprocessor {
        Some(spec) => {
            if fivecal::machine::is_path_spec(spec) {
                inputs.push(PathBuf::from(spec));
            }
            let p = PostDefinition::load(spec)?;
            if let Some(d) = dialect
                && d != p.dialect
            {
                bail!(
                    "--dialect {d} contradicts --postprocessor {spec}, which writes {}",
                    p.dialect
                );
            }
            p
        }
        None => PostDefinition::builtin(dialect.unwrap_or(machine.dialect)),
    };
    let test_arg = match (&a.test, &supplement) {
        (Some(t), _) => t.clone(),
        (None, Some(s)) => s.supplement.test.clone(),
        (None, None) => bail!("name the test to plan (or give --supplement DISCOVER.yaml)"),
    };
    let template = match (&a.template, &supplement) {
        (_, Some(s)) => {
            if test_arg != s.supplement.test {
                bail!(
                    "{} asks for a {} test, but the command asks for `{test_arg}`",
                    s.file.display(),
                    s.supplement.test
                );
            }
            let text = fivecal::discover::separate::template_text(&s.supplement);
            Template::parse(
                Path::new(&format!("<supplement of {}>", s.file.display())),
                &text,
            )?
        }
        (Some(p), None) => {
            inputs.push(p.clone());
            let text = fivecal::input::read_text(p, "template", fivecal::limits::MAX_YAML_BYTES)?;
            let t = Template::parse(p, &text)?;
            if t.test().as_str() != test_arg {
                bail!(
                    "{}: the template is for test `{}`, but the command asks for `{}`",
                    p.display(),
                    t.test(),
                    test_arg
                );
            }
            t
        }
        (None, None) => Template::builtin(test_arg.parse::<Test>().map_err(|_| {
            anyhow::anyhow!(
                "unknown test `{}`: expected {} (or pass --template FILE)",
                test_arg,
                Test::names()
            )
        })?),
    };
    let test = template.test();
    let mut command = format!("fivecal plan {test} --machine {}", shell_word(&spec));
    let dialect_arg = a.dialect.map(|d| fivecal::Dialect::from(d).to_string());
    for (flag, value) in [
        ("--dialect", &dialect_arg),
        ("--postprocessor", &a.postprocessor),
        ("--tool", &a.tool),
    ] {
        if let Some(v) = value {
            command.push_str(&format!(" {flag} {}", shell_word(v)));
        }
    }
    if a.kinematics == Some(KinematicsArg::Controller) {
        command.push_str(" --kinematics controller");
    }
    if test.kind() == TestKind::Probing {
        if a.kinematics == Some(KinematicsArg::Controller) {
            bail!(
                "--kinematics controller: the {test} program positions every axis itself (no TCP, no tilted plane), so that the log records positions in the work offset on W"
            );
        }
        if a.tool.is_some() {
            bail!(
                "--tool: the {test} test uses the machine file's probe (`probe:` in {}), not a cutting tool",
                machine.name
            );
        }
    }
    let tool = match &a.tool {
        Some(spec) => {
            let (t, file) = parse_tool(spec, &machine)?;
            inputs.extend(file);
            Some(t)
        }
        None => None,
    };
    Ok(Config {
        plan: PlanConfig {
            machine,
            template,
            post,
            kinematics: match a.kinematics.unwrap_or(KinematicsArg::Post) {
                KinematicsArg::Post => KinematicsMode::Post,
                KinematicsArg::Controller => KinematicsMode::Controller,
            },
            tool,
        },
        // Eleven files land in it: never the current directory unasked.
        out: a.out.unwrap_or_else(|| PathBuf::from(test.as_str())),
        inputs,
        origin,
        require_all: a.require.is_some(),
        useful: super::useful_u(a.useful_u.as_deref())?,
        json: a.json,
        template_file: a.template.clone(),
        supplement: supplement.is_some(),
        command,
        machine_arg: shell_word(&spec),
    })
}
