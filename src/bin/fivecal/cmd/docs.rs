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
    let mut cmd = crate::Cli::command();
    let mut out = fivecal::io::stdout();
    clap_complete::generate(args.shell, &mut cmd, "fivecal", &mut out);
    out.flush()?;
    Ok(())
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
