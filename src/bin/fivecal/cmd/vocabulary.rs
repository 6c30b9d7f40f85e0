//! One command-line vocabulary for every command, and the spellings of
//! earlier releases mapped onto it. Every output is `-o/--out`, the NC
//! program is positional wherever one is read; `--output` (compensate,
//! `simulate nc`, `analyze contour`, `machine new`) and `simulate nc
//! --program` keep working for one release, each with a note on standard
//! error saying what to write instead. The rewrite happens once, here, on
//! the raw arguments, before clap sees them, so that no command carries two
//! spellings of one concept.

use std::ffi::OsString;

/// A spelling of an earlier release and what it became.
struct Deprecated {
    old: &'static str,
    /// The option it became, or `None` where the value is now positional.
    new: Option<&'static str>,
    /// The subcommand path the old spelling belonged to (`None`: any).
    only_in: Option<&'static [&'static str]>,
}

const DEPRECATED: &[Deprecated] = &[
    Deprecated {
        old: "--output",
        new: Some("--out"),
        only_in: None,
    },
    Deprecated {
        old: "--program",
        new: None,
        only_in: Some(&["simulate", "nc"]),
    },
];

/// `args` (program name first) with every deprecated spelling replaced, and
/// one note per spelling replaced.
pub fn normalize(args: impl IntoIterator<Item = OsString>) -> (Vec<OsString>, Vec<String>) {
    let mut out = Vec::new();
    let mut notes: Vec<String> = Vec::new();
    let mut path: Vec<String> = Vec::new();
    let mut in_options = false;
    let mut literal = false;
    for (i, arg) in args.into_iter().enumerate() {
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
        let (flag, value) = match text.split_once('=') {
            Some((f, v)) if f.starts_with("--") => (f.to_string(), Some(v.to_string())),
            _ => (text.clone(), None),
        };
        let hit = DEPRECATED.iter().find(|d| {
            d.old == flag
                && d.only_in
                    .is_none_or(|p| path.iter().map(String::as_str).eq(p.iter().copied()))
        });
        let Some(d) = hit else {
            out.push(arg);
            continue;
        };
        let note = match d.new {
            Some(new) => format!(
                "note: `{}` is now `-o/{new}`, as in every command; the old spelling works until the next release",
                d.old
            ),
            None => format!(
                "note: `{}` is no longer needed: give the program as the argument, as in every command; the old spelling works until the next release",
                d.old
            ),
        };
        if !notes.contains(&note) {
            notes.push(note);
        }
        match (d.new, value) {
            (Some(new), Some(v)) => out.push(format!("{new}={v}").into()),
            (Some(new), None) => out.push(new.into()),
            (None, Some(v)) => out.push(v.into()),
            (None, None) => {}
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
