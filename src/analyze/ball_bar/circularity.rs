//! The circularity figure of each ball-bar run, ISO 230-4 / ISO 10791-6
//! style: the range of the bar's length deviation over the sweep, largest
//! minus smallest. A ball bar of fixed length under TCP has no centre to
//! fit (ISO 230-4's circular test fits a least-squares centre to a
//! contour; here the contour is the table ball's sphere and its centre is
//! the table ball itself), so nothing is removed from the readings. Where
//! the spindle ball's run-out was stated, the range with its effect taken
//! out of each reading is given beside it.

use crate::errorfile::Circularity;

/// The figure of one run from its readings (um) and, where a run-out was
/// stated, its effect on each reading (um).
pub fn of_run(setup: &str, readings: &[f64], runout: Option<&[f64]>) -> Circularity {
    let range = |v: &mut dyn Iterator<Item = f64>| {
        v.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
            (lo.min(x), hi.max(x))
        })
    };
    let (min, max) = range(&mut readings.iter().copied());
    let without = runout.map(|e| {
        let (lo, hi) = range(&mut readings.iter().zip(e).map(|(y, e)| y - e));
        hi - lo
    });
    Circularity {
        setup: setup.to_string(),
        range_um: max - min,
        max_um: max,
        min_um: min,
        range_without_runout_um: without,
    }
}

/// The figures as `analyze` prints them first.
pub fn render(v: &[Circularity]) -> String {
    use std::fmt::Write as _;
    let mut s = String::from(
        "circularity per run (ISO 230-4 / ISO 10791-6 style: the bar's length deviation over the sweep, max - min, um; nothing removed, a fixed-length bar under TCP has no centre to fit):\n",
    );
    let any_runout = v.iter().any(|c| c.range_without_runout_um.is_some());
    let _ = writeln!(
        s,
        "  {:<8} {:>9} {:>9} {:>9}{}",
        "run",
        "range",
        "max",
        "min",
        if any_runout {
            "   range without the stated run-out"
        } else {
            ""
        }
    );
    for c in v {
        let _ = write!(
            s,
            "  {:<8} {:>9.3} {:>9.3} {:>9.3}",
            c.setup, c.range_um, c.max_um, c.min_um
        );
        if let Some(w) = c.range_without_runout_um {
            let _ = write!(s, "   {w:>9.3}");
        }
        s.push('\n');
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_range_is_largest_minus_smallest_reading_with_nothing_removed() {
        // By hand: readings 1.5, -0.25, 3.0, 0.5: max 3.0, min -0.25,
        // range 3.25. The run-out's effect 1, 0, -1, 0 leaves 0.5, -0.25,
        // 4.0, 0.5: range 4.25.
        let y = [1.5, -0.25, 3.0, 0.5];
        let c = of_run("C1-X", &y, Some(&[1.0, 0.0, -1.0, 0.0]));
        assert_eq!((c.max_um, c.min_um, c.range_um), (3.0, -0.25, 3.25));
        assert_eq!(c.range_without_runout_um, Some(4.25));
        let c = of_run("C1-X", &y, None);
        assert_eq!(c.range_without_runout_um, None);
        assert!(render(&[c]).contains("C1-X"));
    }
}
