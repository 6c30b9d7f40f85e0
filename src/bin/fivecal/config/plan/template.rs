//! The template tests' `plan` (stepped-square, nine-section,
//! probe-columns, probe-sphere, or the test a `--supplement` asks for):
//! the machine, the template (built in, a file or the supplement's),
//! dialect and postprocessor, kinematics and tool, validated into one
//! [`Config`].

use std::path::{Path, PathBuf};

use anyhow::bail;
use fivecal::formats::manifest::{KinematicsMode, TestKind};
use fivecal::io::shell_word;
use fivecal::machine::{Machine, MachineOrigin};
use fivecal::post::PostDefinition;
use fivecal::procedure::{PlanConfig, Template, Test};

use super::supplement::supplementary;
use super::tool::parse_tool;
use super::{KinematicsArg, PlanArgs};

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
    pub(super) template_file: Option<PathBuf>,
    /// Whether the template is the one `--supplement` asked for.
    pub(super) supplement: bool,
    /// This run's `fivecal plan` command without its template and output
    /// options, for the changes `plan` suggests.
    pub(super) command: String,
    /// Its `--machine` argument as written in `command`.
    pub(super) machine_arg: String,
}

/// The validated configuration of one `plan` run of a template test.
pub(super) fn config(a: PlanArgs) -> anyhow::Result<Config> {
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
        useful: crate::config::useful_u(a.useful_u.as_deref())?,
        json: a.json,
        template_file: a.template.clone(),
        supplement: supplement.is_some(),
        command,
        machine_arg: shell_word(&spec),
    })
}
