//! The rewrite's settings of `compensate`: the tolerance, the largest
//! correction, the turn of C accepted next to the tilt singularity, the
//! decimals written, and whether the tolerance holds at those decimals.

use anyhow::bail;
use fivecal::compensate::Settings;

use super::CompensateArgs;
use crate::config::nc::Common;

impl CompensateArgs {
    /// The rewrite's settings, each option checked.
    pub(super) fn settings(&self, common: &Common) -> anyhow::Result<Settings> {
        let min_tol = fivecal::limits::MIN_TOLERANCE_UM;
        if !(self.tolerance.is_finite() && self.tolerance >= min_tol) {
            bail!(
                "--tolerance {}: expected a distance of at least {min_tol} um (finer than any control resolves)",
                self.tolerance
            );
        }
        if !(self.max_correction.is_finite() && self.max_correction > 0.0) {
            bail!(
                "--max-correction {}: expected a limit > 0 um",
                self.max_correction
            );
        }
        if !(self.max_c_swing.is_finite() && self.max_c_swing >= 0.0) {
            bail!(
                "--max-c-swing {}: expected an angle >= 0 deg",
                self.max_c_swing
            );
        }
        // The program's dialect is settled when it is opened.
        let mut settings = Settings::new(common.dialect.unwrap_or(common.machine.dialect));
        settings.strict = common.strict;
        settings.tolerance = self.tolerance * 1e-3;
        settings.max_correction = self.max_correction;
        settings.origin = common.origin;
        settings.coordinates = common.coordinates;
        settings.max_c_swing = self.max_c_swing;
        settings.fanuc_integer_unit = common.integer_unit;
        settings.rotary_start = common.rotary_start.clone();
        settings.subroutine_path = common.subroutine_path.clone();
        if self.expand && self.input.is_none() {
            bail!("--expand flattens an NC program: give the program to rewrite (IN)");
        }
        settings.expand = self.expand;
        if let Some(d) = &self.decimals {
            let parts: Vec<Option<u8>> =
                d.split(',').map(|x| x.trim().parse::<u8>().ok()).collect();
            match parts.as_slice() {
                [Some(l)] if *l <= 9 => settings.linear_decimals = *l,
                [Some(l), Some(r)] if *l <= 9 && *r <= 9 => {
                    settings.linear_decimals = *l;
                    settings.rotary_decimals = *r;
                }
                _ => bail!("--decimals `{d}`: expected LIN or LIN,ROT, each 0 to 9"),
            }
        }
        // The written decimals round every word: a tolerance finer than
        // that rounding could be reported met while the tip misses it.
        let (lin, rot) = (settings.linear_decimals, settings.rotary_decimals);
        let smallest =
            fivecal::compensate::tolerance::smallest_tolerance_um(&common.machine, lin, rot);
        if self.tolerance < smallest {
            bail!(
                "--tolerance {}: the words written with {lin} decimals in mm and {rot} in degrees round the tool tip by up to {:.3} um on {}, so the smallest tolerance that holds is {smallest:.3} um (as much again for the path between the written points; more decimals with --decimals LIN,ROT allow a finer one)",
                self.tolerance,
                fivecal::compensate::tolerance::rounding_bound_mm(&common.machine, lin, rot) * 1e3,
                common.machine.name
            );
        }
        Ok(settings)
    }
}
