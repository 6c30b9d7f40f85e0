//! Bounds on what a test template asks for, checked before any work is
//! done. A value finer than any machine resolves (a depth of 1e-9 mm), one
//! larger than any test piece (a block of 1e300 mm), or counts that
//! multiply into a program nobody could run (100,000 points per wall)
//! would otherwise make `plan` loop for ever or fill the memory. Each is
//! refused with the template's `file:line:column`, the key, the value and
//! the accepted range; the ranges are the constants of [`crate::limits`],
//! listed in `docs/input-and-output.md`.
//!
//! The templates check every value against its range when they are read;
//! the designs count the moves and points a plan would have (from the
//! template, the tool and the machine) before they make any, so that a
//! template built in code rather than read is bounded too.

pub(crate) use crate::numbers::echo;

use crate::limits::{MAX_PLAN_DEG, MAX_PLAN_LIST, MAX_PLAN_MM, MIN_PLAN_MM, PLAN_FEED_MM_PER_MIN};
use crate::procedure::TemplateSource;
use crate::source::SourceError;

/// The key path as the user reads it: `columns[1].size`.
fn name(keys: &[&str]) -> String {
    keys.join(".")
}

/// `v` within `[lo, hi]` `unit`; else an error at `keys` with the key, the
/// value, the range and why the range is what it is.
pub(crate) fn within(
    src: &TemplateSource,
    keys: &[&str],
    v: f64,
    (lo, hi): (f64, f64),
    unit: &str,
    why: &str,
) -> Result<f64, SourceError> {
    if v.is_finite() && (lo..=hi).contains(&v) {
        return Ok(v);
    }
    let why = if why.is_empty() {
        String::new()
    } else {
        format!(" ({why})")
    };
    Err(src.error(
        keys,
        format!(
            "{} must be between {lo} and {hi} {unit}{why}, got {}",
            name(keys),
            echo(v)
        ),
    ))
}

/// A length that must be more than nothing: a size, a step, a depth, a
/// clearance, mm.
pub(crate) fn length(src: &TemplateSource, keys: &[&str], v: f64) -> Result<f64, SourceError> {
    within(
        src,
        keys,
        v,
        (MIN_PLAN_MM, MAX_PLAN_MM),
        "mm",
        "1 um is the finest step a control resolves; a test piece and its setup fit in 2 m",
    )
}

/// A length that may be zero: a riser, a lip, an allowance, a margin, mm.
pub(crate) fn length_or_zero(
    src: &TemplateSource,
    keys: &[&str],
    v: f64,
) -> Result<f64, SourceError> {
    within(
        src,
        keys,
        v,
        (0.0, MAX_PLAN_MM),
        "mm",
        "a test piece and its setup fit in 2 m",
    )
}

/// A coordinate in W, mm.
pub(crate) fn position(src: &TemplateSource, keys: &[&str], v: f64) -> Result<f64, SourceError> {
    within(
        src,
        keys,
        v,
        (-MAX_PLAN_MM, MAX_PLAN_MM),
        "mm",
        "a test piece and its setup fit in 2 m",
    )
}

/// An angle, deg (the machine's limits are checked once it is known).
pub(crate) fn angle(src: &TemplateSource, keys: &[&str], v: f64) -> Result<f64, SourceError> {
    within(
        src,
        keys,
        v,
        (-MAX_PLAN_DEG, MAX_PLAN_DEG),
        "deg",
        "at most a full turn either way",
    )
}

/// Every angle of a list, and the list's length (at least one entry).
pub(crate) fn angles(src: &TemplateSource, keys: &[&str], v: &[f64]) -> Result<(), SourceError> {
    entries(src, keys, v.len(), 1)?;
    for &a in v {
        angle(src, keys, a)?;
    }
    Ok(())
}

/// A feed, mm/min.
pub(crate) fn feed(src: &TemplateSource, keys: &[&str], v: f64) -> Result<f64, SourceError> {
    within(src, keys, v, PLAN_FEED_MM_PER_MIN, "mm/min", "")
}

/// The number of entries of a list: at least `min`, at most
/// [`MAX_PLAN_LIST`].
pub(crate) fn entries(
    src: &TemplateSource,
    keys: &[&str],
    n: usize,
    min: usize,
) -> Result<(), SourceError> {
    if (min..=MAX_PLAN_LIST).contains(&n) {
        return Ok(());
    }
    Err(src.error(
        keys,
        format!(
            "{} must have {min} to {MAX_PLAN_LIST} entries, got {n}",
            name(keys)
        ),
    ))
}

/// A count that must lie within `[lo, hi]`.
pub(crate) fn count(
    src: &TemplateSource,
    keys: &[&str],
    n: usize,
    (lo, hi): (usize, usize),
) -> Result<usize, SourceError> {
    if (lo..=hi).contains(&n) {
        return Ok(n);
    }
    Err(src.error(
        keys,
        format!("{} must be {lo} to {hi}, got {n}", name(keys)),
    ))
}

/// The total of `what` a plan would have, counted before any is made, at
/// most `max`; `hint` says which keys to change. `n` is a float so that a
/// count from absurd values cannot overflow (NaN counts as too many).
pub(crate) fn total(
    src: &TemplateSource,
    keys: &[&str],
    n: f64,
    max: usize,
    what: &str,
    hint: &str,
) -> Result<(), SourceError> {
    if n <= max as f64 {
        return Ok(());
    }
    Err(src.error(
        keys,
        format!(
            "the plan would have {} {what}, more than the {max} a plan may have: {hint}",
            if n.is_finite() && n < 1e15 {
                format!("about {}", n.ceil())
            } else {
                "countless".to_string()
            }
        ),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    fn src() -> TemplateSource {
        TemplateSource::new(
            Path::new("t.yaml"),
            "test: stepped-square\ncutting:\n  axial_depth: 1e-9\n",
        )
    }

    #[test]
    fn a_value_out_of_range_names_file_line_key_value_and_range() {
        let e = length(&src(), &["cutting", "axial_depth"], 1e-9).unwrap_err();
        assert_eq!(
            e.to_string(),
            "t.yaml:3:3: cutting.axial_depth must be between 0.001 and 2000 mm (1 um is the finest step a control resolves; a test piece and its setup fit in 2 m), got 1e-9"
        );
        let e = length(&src(), &["cutting", "axial_depth"], 1e300).unwrap_err();
        assert!(e.to_string().ends_with("got 1e300"), "{e}");
        assert!(length(&src(), &["cutting", "axial_depth"], f64::NAN).is_err());
        assert_eq!(
            length(&src(), &["cutting", "axial_depth"], 0.001),
            Ok(0.001)
        );
        assert_eq!(length_or_zero(&src(), &["cutting"], 0.0), Ok(0.0));
        assert!(angle(&src(), &["cutting"], -361.0).is_err());
    }

    #[test]
    fn a_total_beyond_its_limit_says_how_many() {
        let e = total(&src(), &["cutting"], 1.2e7, 100_000, "moves", "raise x").unwrap_err();
        assert!(
            e.to_string().ends_with(
                "the plan would have about 12000000 moves, more than the 100000 a plan may have: raise x"
            ),
            "{e}"
        );
        let e = total(&src(), &["cutting"], f64::NAN, 10, "points", "h").unwrap_err();
        assert!(e.to_string().contains("countless points"), "{e}");
        assert!(total(&src(), &["cutting"], 10.0, 10, "points", "h").is_ok());
    }
}
