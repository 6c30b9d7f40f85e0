//! `compensate --errors RESULT --export CONTROLLER -o DIR` with a
//! laser-lines result: the axes' positioning errors written as the
//! controller's own compensation tables. A laser result holds no model to
//! rewrite a program with, so the options of a rewrite and of a pivot
//! export's record are refused by name.

use std::path::{Path, PathBuf};

use anyhow::bail;
use fivecal::Dialect;
use fivecal::compensate::axis_tables::{TableLimits, laser};
use fivecal::io::{Shape, check_outputs};

use super::CompensateArgs;
use crate::config::nc::Common;

/// An export of axis tables, validated.
pub struct TablesConfig {
    /// The laser-lines result.
    pub errors_path: PathBuf,
    /// Its tables.
    pub tables: laser::LaserTables,
    /// The controller.
    pub dialect: Dialect,
    /// The directory the files go into.
    pub out: PathBuf,
    /// What a table may hold.
    pub limits: TableLimits,
    /// The inputs, never overwritten.
    pub inputs: Vec<PathBuf>,
}

impl CompensateArgs {
    /// Validates an export of the axis tables of the laser-lines result
    /// `src` (read from `--errors`).
    pub(super) fn tables(self, common: Common, src: &str) -> anyhow::Result<TablesConfig> {
        let path = self.errors.clone();
        let what = "a laser-lines result holds the axes' positioning errors, not a model";
        if let Some(i) = &self.input {
            bail!(
                "{}: {what}: no program is rewritten from it ({} not read); give --export CONTROLLER -o DIR for the axes' compensation tables",
                path.display(),
                i.display()
            );
        }
        let Some(d) = self.export else {
            bail!(
                "{}: {what}: give --export CONTROLLER -o DIR to write the axes' compensation tables",
                path.display()
            );
        };
        let dialect = Dialect::from(d);
        if self.export_to.is_some() {
            bail!(
                "--export-to names a pivot export's file; the axis tables are several files: name their directory with -o DIR"
            );
        }
        let given = [
            ("--expand", self.expand),
            ("--decimals", self.decimals.is_some()),
            ("--entered", self.entered),
            ("--accept-misfit", self.accept_misfit),
            ("--json", self.json),
        ];
        if let Some((flag, _)) = given.iter().find(|(_, g)| *g) {
            bail!(
                "{flag} does not apply to axis tables from a laser-lines result (a record in the history store and JSON output are for pivot exports)"
            );
        }
        if let Some(flag) = self.record.first_given() {
            bail!("{flag} goes with a record, and axis tables are not recorded");
        }
        let Some(out) = self.output.clone() else {
            bail!("--export {dialect} of axis tables: name the directory they go into with -o DIR");
        };
        let limits = self.limits()?;
        let tables = laser::tables(&path, src)?;
        if tables.machine != common.machine.name {
            bail!(
                "{}: the result is of machine `{}`, and --machine is `{}`",
                path.display(),
                tables.machine,
                common.machine.name
            );
        }
        // A table off the strokes is a sign of coordinates meant otherwise
        // than the machine file's: entered, it would compensate elsewhere.
        for t in &tables.tables {
            let k = "XYZ".find(t.axis).unwrap_or(0);
            let (lo, hi) = common.machine.strokes[k];
            let (a, b) = (
                t.points[0].position_mm,
                t.points[t.points.len() - 1].position_mm,
            );
            if a < lo - 1e-6 || b > hi + 1e-6 {
                bail!(
                    "{}: the {} table runs from {a} to {b} mm, beyond {}'s stroke {lo} .. {hi} mm of the machine file",
                    path.display(),
                    t.axis,
                    t.axis
                );
            }
        }
        let mut inputs = common.inputs.clone();
        inputs.push(path.clone());
        let ins: Vec<&Path> = inputs.iter().map(|p| p.as_path()).collect();
        check_outputs(&ins, &[("-o", out.as_path(), Shape::Dir)])?;
        Ok(TablesConfig {
            errors_path: path,
            tables,
            dialect,
            out,
            limits: TableLimits {
                max_correction_um: limits.change_mm * 1000.0,
                max_u_um: limits.u_mm * 1000.0,
            },
            inputs,
        })
    }
}
