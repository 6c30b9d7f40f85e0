//! The finest `--tolerance` a rewritten program can hold: the written
//! decimals round every coordinate, and no path check can make the tool
//! tip follow the intended path closer than that rounding moves it.
//!
//! A linear word rounded to `L` decimals (mm) is off by up to half a unit
//! of its last digit, `0.5 * 10^-L` mm, in each of X, Y and Z; a rotary
//! word rounded to `R` decimals (deg) is off by up to `0.5 * 10^-R` deg,
//! which moves the tip by that angle times its distance from the axis. The
//! tip can then be off by up to
//!
//! ```text
//! sqrt(3) * 0.5 * 10^-L  +  2 * (0.5 * 10^-R * pi / 180) * lever     (mm)
//! ```
//!
//! with `lever` a bound on the tip's distance from either rotary axis: the
//! diagonal of the machine's strokes plus its pivot offset, pivot length
//! and tool length. Every path check holds the tolerance less that bound
//! (so the path of the rounded words, not only of the values checked,
//! stays within it), which leaves the check nothing below the bound; the
//! smallest tolerance accepted is twice the bound, half for the path
//! between the written points and half for their rounding. A finer one is
//! refused with the smallest that works, rather than reported as met.

use crate::machine::Machine;

/// The largest distance, mm, the rounding of the written words can move
/// the tool tip on `machine` with `linear_decimals` (mm) and
/// `rotary_decimals` (deg).
pub fn rounding_bound_mm(machine: &Machine, linear_decimals: u8, rotary_decimals: u8) -> f64 {
    let half = |d: u8| 0.5 * 10f64.powi(-i32::from(d));
    let diagonal = machine
        .strokes
        .iter()
        .map(|(lo, hi)| (hi - lo).powi(2))
        .sum::<f64>()
        .sqrt();
    let lever =
        diagonal + machine.pivot.norm() + machine.pivot_length.abs() + machine.tool.length.abs();
    3f64.sqrt() * half(linear_decimals) + 2.0 * half(rotary_decimals).to_radians() * lever
}

/// The smallest tolerance, um, that the written decimals leave room for:
/// twice the rounding bound (as much for the path checked as for the
/// rounding), rounded up to two significant digits (so the number printed
/// is itself accepted).
pub fn smallest_tolerance_um(machine: &Machine, linear_decimals: u8, rotary_decimals: u8) -> f64 {
    let um = 2.0 * rounding_bound_mm(machine, linear_decimals, rotary_decimals) * 1e3;
    let step = 10f64.powf(um.log10().floor() - 1.0);
    (um / step).ceil() * step
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bound by hand for the built-in trunnion: its strokes, pivot and
    /// tool give the lever; 4 decimals in mm give sqrt(3) * 0.05 um.
    #[test]
    fn the_bound_is_the_rounding_of_each_word_summed() {
        let m = Machine::builtin("bc-trunnion").unwrap();
        let d: f64 = m
            .strokes
            .iter()
            .map(|(a, b)| (b - a) * (b - a))
            .sum::<f64>()
            .sqrt();
        let lever = d + m.pivot.norm() + m.pivot_length.abs() + m.tool.length.abs();
        let by_hand =
            3f64.sqrt() * 0.00005 + 2.0 * (0.0000005f64 * std::f64::consts::PI / 180.0) * lever;
        assert!((rounding_bound_mm(&m, 4, 6) - by_hand).abs() < 1e-15);
        // Not finer than the linear rounding alone, and a decimal more
        // makes it ten times finer.
        assert!(rounding_bound_mm(&m, 4, 6) > 0.0000866);
        let finer = rounding_bound_mm(&m, 5, 7);
        assert!((finer * 10.0 - rounding_bound_mm(&m, 4, 6)).abs() < 1e-12);
        // The smallest tolerance printed is at or above twice the bound,
        // within one step of its second digit.
        let s = smallest_tolerance_um(&m, 4, 6);
        let b = 2.0 * rounding_bound_mm(&m, 4, 6) * 1e3;
        assert!(s >= b && s <= b * 1.11, "{s} against {b}");
    }
}
