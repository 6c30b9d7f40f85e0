//! The command line in one place: each command's options as clap reads
//! them (every command's, the small ones included), and their validation
//! into the one configuration the command's `run` (in `cmd/`) turns into
//! library calls and prints. What several commands take is defined once
//! here, so that it is spelled and checked the same way everywhere: the
//! dialect ([`DialectArg`]), the lists of symbols and effects
//! ([`list_items`]), the instrument's noise ([`noise_arg`]), the machine
//! and program options of `compensate` and `simulate nc` ([`nc`]), the
//! results store ([`record`]), the measurement files' flags
//! ([`measured`]); `--json` is the one switch for machine-readable output
//! on standard output. Earlier releases' spellings are mapped onto this
//! vocabulary before clap sees them (`cmd/vocabulary.rs`).

pub mod analyze;
pub mod ball_bar;
pub mod compensate;
pub mod completions;
pub mod demo;
pub mod discover;
pub mod history;
pub mod laser;
pub mod machine;
pub mod measured;
pub mod nc;
pub mod plan;
pub mod record;
pub mod simulate;
pub mod verify;

use clap::ValueEnum;
use fivecal::Dialect;

/// A controller dialect, as every `--dialect` and `--export` takes it: one
/// list of values, offered by the completions and `--help` alike.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum DialectArg {
    #[value(name = "fanuc")]
    Fanuc,
    #[value(name = "heidenhain")]
    Heidenhain,
    #[value(name = "linuxcnc")]
    Linuxcnc,
    #[value(name = "sinumerik")]
    Sinumerik,
}

impl From<DialectArg> for Dialect {
    fn from(d: DialectArg) -> Dialect {
        match d {
            DialectArg::Fanuc => Dialect::Fanuc,
            DialectArg::Heidenhain => Dialect::Heidenhain,
            DialectArg::Linuxcnc => Dialect::Linuxcnc,
            DialectArg::Sinumerik => Dialect::Sinumerik,
        }
    }
}

/// The items of comma-separated list options given once or more
/// (`--maps EBB(B),EXC(B,C)`): split at the commas outside parentheses, so
/// that a two-axis map symbol stays whole; blanks dropped.
pub fn list_items(values: &[String]) -> Vec<String> {
    let mut items = Vec::new();
    for v in values {
        let mut depth = 0usize;
        let mut item = String::new();
        for c in v.chars() {
            match c {
                '(' => depth += 1,
                ')' => depth = depth.saturating_sub(1),
                ',' if depth == 0 => {
                    items.push(std::mem::take(&mut item));
                    continue;
                }
                _ => {}
            }
            item.push(c);
        }
        items.push(item);
    }
    items
        .into_iter()
        .map(|s| s.trim().to_string())
        .filter(|s| !s.is_empty())
        .collect()
}

/// `--noise UM` of analyze and discover: the instrument's standard
/// deviation the fit is judged against.
pub fn noise_arg(noise: Option<f64>) -> anyhow::Result<Option<f64>> {
    if let Some(n) = noise {
        let max = fivecal::limits::MAX_NOISE_UM;
        if !(n.is_finite() && n > 0.0 && n <= max) {
            anyhow::bail!(
                "--noise {n}: expected a standard deviation above 0 and at most {max} um"
            );
        }
    }
    Ok(noise)
}

/// `--json` and `-o -` both want standard output.
pub fn json_or_stdout(json: bool, outs: &[Option<&std::path::Path>]) -> anyhow::Result<()> {
    if json && outs.iter().flatten().any(|p| p.as_os_str() == "-") {
        anyhow::bail!(
            "--json prints on standard output, and so does `-o -`: name a file, or leave out --json"
        );
    }
    Ok(())
}

/// `--useful-u UM,URAD` of plan and analyze: the largest u a location
/// error may have to count as identified (the defaults when not given).
pub fn useful_u(arg: Option<&str>) -> anyhow::Result<fivecal::analyze::usefulness::Usefulness> {
    match arg {
        Some(s) => fivecal::analyze::usefulness::Usefulness::parse(s)
            .map_err(|e| anyhow::anyhow!("--useful-u {e}")),
        None => Ok(Default::default()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_dialect_is_a_value_under_its_own_name() {
        // The values clap offers are the names the library reads back.
        for v in DialectArg::value_variants() {
            let name = v.to_possible_value().unwrap().get_name().to_string();
            assert_eq!(name.parse::<Dialect>(), Ok(Dialect::from(*v)), "{name}");
        }
        assert_eq!(DialectArg::value_variants().len(), 4);
    }

    #[test]
    fn a_map_symbol_with_two_axes_stays_one_item() {
        assert_eq!(
            list_items(&["EBB(B), EXC(B,C)".into(), " ,drift".into()]),
            ["EBB(B)", "EXC(B,C)", "drift"]
        );
    }
}
