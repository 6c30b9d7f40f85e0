//! One module per subcommand: its raw arguments, their validation into one
//! configuration, and the call into the library.

pub mod analyze;
pub mod compensate;
pub mod contour;
pub mod demo;
pub mod discover;
pub mod docs;
pub mod history;
pub mod machine;
pub mod measured;
pub mod plan;
pub mod record;
pub mod simulate;
pub mod simulate_nc;
pub mod verify;
pub mod vocabulary;

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
