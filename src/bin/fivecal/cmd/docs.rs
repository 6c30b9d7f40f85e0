//! `fivecal completions SHELL` and `fivecal man`: shell completions and a
//! man page generated from the clap definitions, so they cannot drift from
//! the real options.

use std::io::Write;

use clap::CommandFactory;

use crate::config::completions::CompletionsArgs;

pub fn completions(args: CompletionsArgs) -> anyhow::Result<()> {
    let mut cmd = with_names(crate::Cli::command());
    let mut out = fivecal::io::stdout();
    clap_complete::generate(args.shell, &mut cmd, "fivecal", &mut out);
    out.flush()?;
    Ok(())
}

/// The command line as a shell should complete it: the tests' names for
/// `plan`, and a file wherever a file is meant, as the commands take one.
/// A machine (`--machine`, `machine show`, `machine new --from`) is a file
/// or a built-in name; clap's completions offer either a list of names or
/// files, never both, so they offer files (`fivecal machine list` names the
/// built-in machines). So are a postprocessor, a tool and a contributors
/// file, each a file or a word the option's help names.
fn with_names(cmd: clap::Command) -> clap::Command {
    use clap::ValueHint;
    use clap::builder::PossibleValuesParser;
    let tests: Vec<&'static str> = fivecal::procedure::Test::ALL
        .iter()
        .map(|t| t.as_str())
        .collect();
    fn walk(cmd: clap::Command, tests: &[&'static str]) -> clap::Command {
        let name = cmd.get_name().to_string();
        let ids: Vec<String> = cmd
            .get_arguments()
            .map(|a| a.get_id().to_string())
            .collect();
        let mut cmd = cmd;
        for id in ids {
            match (name.as_str(), id.as_str()) {
                ("plan", "test") => {
                    let n = tests.to_vec();
                    cmd = cmd.mut_arg(id, move |a| a.value_parser(PossibleValuesParser::new(n)));
                }
                (_, "machine" | "postprocessor" | "tool" | "contributors")
                | ("show", "file")
                | ("new", "from") => {
                    cmd = cmd.mut_arg(id, |a| a.value_hint(ValueHint::FilePath));
                }
                _ => {}
            }
        }
        let subs: Vec<String> = cmd
            .get_subcommands()
            .map(|s| s.get_name().to_string())
            .collect();
        for s in subs {
            cmd = cmd.mut_subcommand(s, |sub| walk(sub, tests));
        }
        cmd
    }
    walk(cmd, &tests)
}

/// The man page's EXAMPLES: one calibration from plan to export on the
/// built-in example machine, each line a command a user can paste in an
/// empty directory, in this order (a test runs them).
pub const EXAMPLES: &[(&str, &str)] = &[
    (
        "Run the whole job on the built-in example machine (plan, simulate, analyze, discover, compensate), into demo/:",
        "fivecal demo --out demo",
    ),
    (
        "Plan the stepped-square machining test for the built-in B/C trunnion in FANUC, into ss/:",
        "fivecal plan stepped-square --machine bc-trunnion --dialect fanuc --out ss",
    ),
    (
        "Write the commented truth file of a virtual machine with known errors and effects:",
        "fivecal simulate --truth-example --machine bc-trunnion > truth.yaml",
    ),
    (
        "Machine and measure the test on that virtual machine, as a CMM would (DMIS):",
        "fivecal simulate --plan ss/stepped-square.plan.yaml --errors truth.yaml --out cmm.dmo",
    ),
    (
        "Identify the location errors with their uncertainty; the verdict comes first, and a misfit names the next command:",
        "fivecal analyze --plan ss/stepped-square.plan.yaml --measured cmm.dmo --out result.yaml",
    ),
    (
        "Find the effects the model lacks, and what would separate the ones this test cannot tell apart:",
        "fivecal discover --plan ss/stepped-square.plan.yaml --measured cmm.dmo --out discovered.yaml",
    ),
    (
        "Rewrite an NC program so the errors the demo discovered cancel:",
        "fivecal compensate --machine bc-trunnion --errors demo/discovered.yaml demo/frustum.nc -o frustum-compensated.nc",
    ),
    (
        "Print the corrected tool-centre-point parameters for a FANUC control:",
        "fivecal compensate --machine bc-trunnion --errors demo/discovered.yaml --export fanuc",
    ),
    (
        "Check a compensated program: its tool tip on the machine with the errors, against the path the original asks for on the nominal machine:",
        "fivecal simulate nc --machine bc-trunnion --errors demo/truth.yaml demo/frustum.compensated.nc --against demo/frustum.nc",
    ),
    (
        "List what the results store keeps of the demo's machine, as JSON on standard output (every command with a result takes --json):",
        "fivecal history --db demo/history.db --json",
    ),
];

/// The man page's ENVIRONMENT: every variable the program reads, itself
/// (`FIVECAL_DB`) or through the user's data directory.
const ENVIRONMENT: &[(&str, &str)] = &[
    (
        "FIVECAL_DB",
        "The results store used when --db is not given: a SQLite file path or a postgres:// URL. \
         Unset: history.db in the user's data directory.",
    ),
    (
        "XDG_DATA_HOME",
        "The user's data directory, where the default results store fivecal/history.db lies \
         (Linux). Unset: $HOME/.local/share.",
    ),
    (
        "HOME",
        "The user's home directory, under which the data directory lies when XDG_DATA_HOME is unset.",
    ),
];

pub fn man() -> anyhow::Result<()> {
    let cmd = crate::Cli::command();
    let mut out = fivecal::io::stdout();
    // Not `Man::render`: its SUBCOMMANDS section points to pages such as
    // fivecal-plan(1) that are never installed. Every subcommand, nested
    // ones included (`simulate nc`, `history plot`), is a section of this
    // one page instead, as `man git` does it.
    let man = clap_mangen::Man::new(cmd.clone());
    man.render_title(&mut out)?;
    man.render_name_section(&mut out)?;
    man.render_synopsis_section(&mut out)?;
    man.render_description_section(&mut out)?;
    man.render_options_section(&mut out)?;
    if cmd.get_after_help().is_some() || cmd.get_after_long_help().is_some() {
        man.render_extra_section(&mut out)?;
    }
    fn sections(out: &mut impl Write, cmd: &clap::Command, path: &str) -> std::io::Result<()> {
        for sub in cmd.get_subcommands().filter(|s| !s.is_hide_set()) {
            let name = format!("{path} {}", sub.get_name().to_uppercase());
            writeln!(out, ".SH \"{name}\"")?;
            clap_mangen::Man::new(sub.clone()).render_description_section(out)?;
            clap_mangen::Man::new(sub.clone()).render_options_section(out)?;
            sections(out, sub, &name)?;
        }
        Ok(())
    }
    sections(&mut out, &cmd, "FIVECAL")?;
    writeln!(out, ".SH EXAMPLES")?;
    for (what, line) in EXAMPLES {
        writeln!(out, ".PP\n{}\n.PP\n.RS 4\n{}\n.RE", roff(what), roff(line))?;
    }
    writeln!(out, ".SH ENVIRONMENT")?;
    for (name, what) in ENVIRONMENT {
        writeln!(out, ".TP\n\\fB{name}\\fR\n{}", roff(what))?;
    }
    man.render_version_section(&mut out)?;
    out.flush()?;
    Ok(())
}

/// Text as roff reads it literally: backslashes and hyphens escaped, and no
/// line starting with a control character.
fn roff(text: &str) -> String {
    let escaped = text.replace('\\', "\\e").replace('-', "\\-");
    if escaped.starts_with('.') || escaped.starts_with('\'') {
        format!("\\&{escaped}")
    } else {
        escaped
    }
}
