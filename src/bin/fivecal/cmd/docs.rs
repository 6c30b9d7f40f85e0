//! `fivecal completions SHELL` and `fivecal man`: shell completions and a
//! man page generated from the clap definitions, so they cannot drift from
//! the real options.

use std::io::Write;

use clap::{Args, CommandFactory};
use clap_complete::Shell;

#[derive(Args, Debug)]
pub struct CompletionsArgs {
    /// bash, zsh, fish, powershell or elvish.
    shell: Shell,
}

pub fn completions(args: CompletionsArgs) -> anyhow::Result<()> {
    let mut cmd = with_names(crate::Cli::command());
    let mut out = fivecal::io::stdout();
    clap_complete::generate(args.shell, &mut cmd, "fivecal", &mut out);
    out.flush()?;
    Ok(())
}

/// The command line with the names a shell should offer: the tests for
/// `plan`, the built-in machines for every `--machine` (and `machine
/// show`, `machine new --from`). Only the completions see them: the
/// commands themselves take any file path as well.
fn with_names(cmd: clap::Command) -> clap::Command {
    use clap::builder::PossibleValuesParser;
    let machines: Vec<&'static str> = fivecal::machine::BUILTIN.iter().map(|(n, _)| *n).collect();
    let tests: Vec<&'static str> = fivecal::procedure::Test::ALL
        .iter()
        .map(|t| t.as_str())
        .collect();
    fn walk(
        cmd: clap::Command,
        machines: &[&'static str],
        tests: &[&'static str],
    ) -> clap::Command {
        let name = cmd.get_name().to_string();
        let ids: Vec<String> = cmd
            .get_arguments()
            .map(|a| a.get_id().to_string())
            .collect();
        let mut cmd = cmd;
        for id in ids {
            let names = match (name.as_str(), id.as_str()) {
                (_, "machine") | ("show", "file") | ("new", "from") => Some(machines),
                ("plan", "test") => Some(tests),
                _ => None,
            };
            if let Some(n) = names {
                let n = n.to_vec();
                cmd = cmd.mut_arg(id, move |a| a.value_parser(PossibleValuesParser::new(n)));
            }
        }
        let subs: Vec<String> = cmd
            .get_subcommands()
            .map(|s| s.get_name().to_string())
            .collect();
        for s in subs {
            cmd = cmd.mut_subcommand(s, |sub| walk(sub, machines, tests));
        }
        cmd
    }
    walk(cmd, &machines, &tests)
}

pub fn man() -> anyhow::Result<()> {
    let cmd = crate::Cli::command();
    let mut out = fivecal::io::stdout();
    // Not `Man::render`: its SUBCOMMANDS section points to pages such as
    // fivecal-plan(1) that are never installed. Every subcommand is a
    // section of this one page instead, as `man git` does it.
    let man = clap_mangen::Man::new(cmd.clone());
    man.render_title(&mut out)?;
    man.render_name_section(&mut out)?;
    man.render_synopsis_section(&mut out)?;
    man.render_description_section(&mut out)?;
    man.render_options_section(&mut out)?;
    if cmd.get_after_help().is_some() || cmd.get_after_long_help().is_some() {
        man.render_extra_section(&mut out)?;
    }
    man.render_version_section(&mut out)?;
    for sub in cmd.get_subcommands().filter(|s| !s.is_hide_set()) {
        writeln!(out, ".SH \"FIVECAL {}\"", sub.get_name().to_uppercase())?;
        clap_mangen::Man::new(sub.clone()).render_description_section(&mut out)?;
        clap_mangen::Man::new(sub.clone()).render_options_section(&mut out)?;
    }
    out.flush()?;
    Ok(())
}
