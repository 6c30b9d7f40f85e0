//! One command-line vocabulary for every command, and the spellings of
//! earlier releases mapped onto it. Every output is `-o/--out`, the NC
//! program is positional wherever one is read, and `--json` is the one
//! switch for machine-readable output; `--output` (compensate, `simulate
//! nc`, `analyze contour`, `machine new`), `simulate nc --program` and
//! `history export --format csv|json` keep working for one release, each
//! with a note on standard error saying what to write instead. The rewrite
//! happens once, here, on the raw arguments, before clap sees them, so that
//! no command carries two spellings of one concept. (`analyze --json`,
//! which chose the result file's format, changed its meaning rather than
//! its spelling: `config/analyze.rs` keeps the old meaning one release
//! more, with its note.)

use std::ffi::OsString;

/// What a spelling of an earlier release became.
#[derive(Clone, Copy)]
enum Becomes {
    /// Another option, with the same value.
    Option(&'static str),
    /// The value alone, as the command's argument.
    Positional,
    /// A switch without a value (`--format json` is `--json`).
    Switch(&'static str),
    /// Nothing: the value was the default (`--format csv`).
    Default,
}

/// A spelling of an earlier release and what it became.
struct Deprecated {
    old: &'static str,
    /// The one value this entry is about (`None`: any value).
    value: Option<&'static str>,
    new: Becomes,
    /// The subcommand path the old spelling belonged to (`None`: any).
    only_in: Option<&'static [&'static str]>,
}

const DEPRECATED: &[Deprecated] = &[
    Deprecated {
        old: "--output",
        value: None,
        new: Becomes::Option("--out"),
        only_in: None,
    },
    Deprecated {
        old: "--program",
        value: None,
        new: Becomes::Positional,
        only_in: Some(&["simulate", "nc"]),
    },
    Deprecated {
        old: "--format",
        value: Some("json"),
        new: Becomes::Switch("--json"),
        only_in: Some(&["history", "export"]),
    },
    Deprecated {
        old: "--format",
        value: Some("csv"),
        new: Becomes::Default,
        only_in: Some(&["history", "export"]),
    },
];

impl Deprecated {
    /// The note printed when this spelling is met.
    fn note(&self) -> String {
        let old = match self.value {
            Some(v) => format!("{} {v}", self.old),
            None => self.old.to_string(),
        };
        let what = match self.new {
            Becomes::Option(new) => format!("`{old}` is now `-o/{new}`, as in every command"),
            Becomes::Positional => format!(
                "`{old}` is no longer needed: give the program as the argument, as in every command"
            ),
            Becomes::Switch(new) => format!("`{old}` is now `{new}`, as in every command"),
            Becomes::Default => {
                format!("`{old}` is no longer needed: it is what the command writes without --json")
            }
        };
        format!("note: {what}; the old spelling works until the next release")
    }
}

/// `args` (program name first) with every deprecated spelling replaced, and
/// one note per spelling replaced.
pub fn normalize(args: impl IntoIterator<Item = OsString>) -> (Vec<OsString>, Vec<String>) {
    let mut out = Vec::new();
    let mut notes: Vec<String> = Vec::new();
    let mut path: Vec<String> = Vec::new();
    let mut in_options = false;
    let mut literal = false;
    let mut args = args.into_iter().enumerate().peekable();
    while let Some((i, arg)) = args.next() {
        let Some(text) = arg.to_str().map(str::to_string) else {
            out.push(arg);
            continue;
        };
        if i == 0 || literal {
            out.push(arg);
            continue;
        }
        if text == "--" {
            literal = true;
            out.push(arg);
            continue;
        }
        // The subcommand path: the leading words before the first option.
        if !in_options && !text.starts_with('-') && path.len() < 2 {
            path.push(text);
            out.push(arg);
            continue;
        }
        in_options = true;
        let (flag, inline) = match text.split_once('=') {
            Some((f, v)) if f.starts_with("--") => (f.to_string(), Some(v.to_string())),
            _ => (text.clone(), None),
        };
        // The value an entry about one value looks at: inline, or the next
        // argument (taken only when the entry matches).
        let next = args
            .peek()
            .and_then(|(_, a)| a.to_str())
            .map(str::to_string);
        let hit = DEPRECATED.iter().find(|d| {
            d.old == flag
                && d.only_in
                    .is_none_or(|p| path.iter().map(String::as_str).eq(p.iter().copied()))
                && d.value
                    .is_none_or(|v| inline.as_deref().or(next.as_deref()) == Some(v))
        });
        let Some(d) = hit else {
            out.push(arg);
            continue;
        };
        let note = d.note();
        if !notes.contains(&note) {
            notes.push(note);
        }
        if d.value.is_some() && inline.is_none() {
            // The value was the next argument: it is part of the old
            // spelling.
            args.next();
        }
        match (d.new, inline) {
            (Becomes::Option(new), Some(v)) => out.push(format!("{new}={v}").into()),
            (Becomes::Option(new), None) => out.push(new.into()),
            (Becomes::Positional, Some(v)) => out.push(v.into()),
            (Becomes::Positional, None) => {}
            (Becomes::Switch(new), _) => out.push(new.into()),
            (Becomes::Default, _) => {}
        }
    }
    (out, notes)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn norm(args: &[&str]) -> (Vec<String>, usize) {
        let (a, n) = normalize(args.iter().map(OsString::from));
        (
            a.into_iter().map(|s| s.into_string().unwrap()).collect(),
            n.len(),
        )
    }

    #[test]
    fn output_becomes_out_in_any_command_with_one_note() {
        assert_eq!(
            norm(&[
                "fivecal",
                "compensate",
                "p.nc",
                "--output",
                "q.nc",
                "--output=r.nc"
            ]),
            (
                [
                    "fivecal",
                    "compensate",
                    "p.nc",
                    "--out",
                    "q.nc",
                    "--out=r.nc"
                ]
                .map(String::from)
                .to_vec(),
                1
            )
        );
    }

    #[test]
    fn program_becomes_positional_in_simulate_nc_only() {
        assert_eq!(
            norm(&[
                "fivecal",
                "simulate",
                "nc",
                "--errors",
                "e.yaml",
                "--program",
                "p.nc"
            ])
            .0,
            ["fivecal", "simulate", "nc", "--errors", "e.yaml", "p.nc"]
        );
        // Elsewhere `--program` is not this project's word: left for clap
        // to refuse.
        assert_eq!(
            norm(&["fivecal", "compensate", "--program", "p.nc"]).0,
            ["fivecal", "compensate", "--program", "p.nc"]
        );
    }

    #[test]
    fn format_json_becomes_the_json_switch_in_history_export_only() {
        assert_eq!(
            norm(&[
                "fivecal", "history", "export", "--format", "json", "-o", "h"
            ]),
            (
                ["fivecal", "history", "export", "--json", "-o", "h"]
                    .map(String::from)
                    .to_vec(),
                1
            )
        );
        assert_eq!(
            norm(&["fivecal", "history", "export", "--format=csv"]),
            (
                ["fivecal", "history", "export"].map(String::from).to_vec(),
                1
            )
        );
        // simulate's --format names a measurement format: its own word.
        assert_eq!(
            norm(&["fivecal", "simulate", "--format", "csv"]),
            (
                ["fivecal", "simulate", "--format", "csv"]
                    .map(String::from)
                    .to_vec(),
                0
            )
        );
    }

    #[test]
    fn values_after_a_double_dash_are_left_alone() {
        assert_eq!(
            norm(&["fivecal", "compensate", "--", "--output"]),
            (
                ["fivecal", "compensate", "--", "--output"]
                    .map(String::from)
                    .to_vec(),
                0
            )
        );
    }
}
