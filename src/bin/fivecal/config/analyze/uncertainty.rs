//! `analyze`'s uncertainty options: the contributors of the Monte-Carlo
//! study (a named set, noise only, or a file) and the study itself (its
//! runs, seed, time limit and whether each run is simulated and fitted
//! exactly), validated.

use std::path::Path;

use anyhow::bail;
use fivecal::analyze::{self, ContributorChoice, McOptions, MonteCarlo};

/// `--contributors`: the test's default, `seed001`, `seed000`, `noise` or
/// a contributors file.
pub(super) fn contributors(spec: Option<&str>) -> anyhow::Result<ContributorChoice> {
    Ok(match spec {
        None => ContributorChoice::TestDefault,
        Some("seed001") => ContributorChoice::Given(analyze::Contributors::seed001()),
        Some("seed000") => ContributorChoice::Given(analyze::Contributors::seed000()),
        Some("noise") => ContributorChoice::NoiseOnly,
        Some(path) => {
            let path = Path::new(path);
            let src = fivecal::input::read_text(
                path,
                "contributors file",
                fivecal::limits::MAX_YAML_BYTES,
            )?;
            ContributorChoice::Given(fivecal::input::parse_yaml(path, &src)?)
        }
    })
}

/// `--mc N` with `--seed`, `--max-seconds` and `--mc-exact`: the study, or
/// none without `--mc`.
pub(super) fn monte_carlo(
    mc: Option<usize>,
    seed: u64,
    max_seconds: Option<f64>,
    exact_runs: bool,
) -> anyhow::Result<Option<MonteCarlo>> {
    Ok(match mc {
        Some(n @ (0 | 1)) => bail!("--mc {n}: the Monte-Carlo study needs at least 2 runs"),
        Some(n) if n > fivecal::limits::MAX_MC_RUNS => bail!(
            "--mc {n}: at most {} runs (the spread of u settles within a few hundred)",
            fivecal::limits::MAX_MC_RUNS
        ),
        Some(_) if max_seconds.is_some_and(|s| !(s.is_finite() && s > 0.0)) => bail!(
            "--max-seconds {}: expected a time > 0 s",
            max_seconds.unwrap_or_default()
        ),
        Some(runs) => Some(MonteCarlo {
            options: McOptions {
                runs,
                seed,
                progress: true,
                max_seconds,
            },
            exact: exact_runs,
        }),
        None => None,
    })
}
