//! What a simulation writes, in the format a real instrument would:
//! canonical `label,x,y,z` CSV, a CMM's DMIS output (`F(label)` nominal and
//! `FA(label)` actual) or QIF 3 results (the features of the plan's QIF
//! plan, by the same ids and names), the probe log the plan's program makes the control
//! write, or the nine-section heights `section,height_um`. Every output is
//! deterministic for a seed and written atomically.

use std::fmt;
use std::path::Path;
use std::str::FromStr;

use super::{SimError, SimOutput};
use crate::formats::dmis::{self, DmisPoint, WriteOptions};
use crate::formats::heights;
use crate::formats::manifest::TestKind;
use crate::formats::measured;
use crate::formats::qif_write::{self, QifPoint};
use crate::io::write_atomic;
use crate::procedure::Test;

/// An output format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// Canonical `label,x,y,z`.
    Csv,
    /// DMIS output of a CMM (machining tests).
    Dmis,
    /// The controller's probe log (probing tests).
    Log,
    /// Nine-section heights `section,height_um`.
    Heights,
    /// QIF 3 results of a CMM (machining tests), with the features of the
    /// plan's QIF plan.
    Qif,
}

impl Format {
    /// All formats.
    pub const ALL: [Format; 5] = [
        Format::Csv,
        Format::Dmis,
        Format::Log,
        Format::Heights,
        Format::Qif,
    ];

    /// The name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Format::Csv => "csv",
            Format::Dmis => "dmis",
            Format::Log => "log",
            Format::Heights => "heights",
            Format::Qif => "qif",
        }
    }

    /// The format a file name suggests for `test`, of `kind`: `.dmo`,
    /// `.out`, `.dmis` DMIS output; `.qif` QIF results; `.log`, `.txt`,
    /// `.lst` a probe log; `.csv` canonical CSV, or for nine-section its
    /// section heights (the CSV analyze reads for it); anything else the
    /// test's natural output (CSV for a machined piece, heights for
    /// nine-section, the log for on-machine probing).
    pub fn for_path(path: &Path, kind: TestKind, test: Test) -> Format {
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase())
            .unwrap_or_default();
        match ext.as_str() {
            "dmo" | "out" | "dmis" => Format::Dmis,
            "qif" => Format::Qif,
            "log" | "txt" | "lst" => Format::Log,
            // The one CSV of the nine-section test that analyze reads: its
            // points carry no nominal of their own to measure heights from.
            "csv" if test == Test::NineSection => Format::Heights,
            "csv" => Format::Csv,
            _ => match kind {
                TestKind::Machining if test == Test::NineSection => Format::Heights,
                TestKind::Machining => Format::Csv,
                TestKind::Probing => Format::Log,
            },
        }
    }
}

impl fmt::Display for Format {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Format {
    type Err = String;
    fn from_str(s: &str) -> Result<Format, String> {
        Format::ALL
            .into_iter()
            .find(|f| f.name() == s)
            .ok_or_else(|| format!("unknown format `{s}`: expected csv, dmis, qif, log or heights"))
    }
}

/// Whether a test of `kind` named `test` can be written as `format`, and
/// if not, why.
pub fn check(format: Format, kind: TestKind, test: Test) -> Result<(), SimError> {
    let refuse = |why: &str| {
        Err(SimError::Format(format!(
            "{format} output: {why} ({test} is a {} test)",
            match kind {
                TestKind::Machining => "machining",
                TestKind::Probing => "probing",
            }
        )))
    };
    match format {
        Format::Csv => Ok(()),
        Format::Dmis | Format::Qif if kind != TestKind::Machining => {
            refuse("a CMM measures machined pieces; on-machine probing writes a log or CSV")
        }
        Format::Log if kind != TestKind::Probing => {
            refuse("only on-machine probing writes a probe log; a CMM writes CSV or DMIS")
        }
        Format::Heights if test != Test::NineSection => {
            refuse("section heights belong to the nine-section test")
        }
        _ => Ok(()),
    }
}

impl SimOutput {
    /// Whether this run can be written as `format`, and if not, why.
    pub(crate) fn check_format(&self, format: Format) -> Result<(), SimError> {
        check(format, self.kind, self.test)
    }

    /// The text of the output in `format`.
    pub fn render(&self, format: Format) -> Result<String, SimError> {
        self.check_format(format)?;
        let head = self.comments(format);
        Ok(match format {
            Format::Csv => {
                let c: Vec<&str> = head.iter().map(|s| s.as_str()).collect();
                measured::to_csv(&self.points, &c)
            }
            Format::Dmis => {
                let pts: Vec<DmisPoint> = self
                    .points
                    .iter()
                    .zip(&self.nominals)
                    .map(|(m, (p, n))| DmisPoint {
                        label: m.label.clone(),
                        nominal: (*p, *n),
                        actual: m.p,
                    })
                    .collect();
                dmis::write_output(
                    &pts,
                    &WriteOptions {
                        name: self.test.to_string(),
                        ..WriteOptions::default()
                    },
                )
            }
            Format::Qif => {
                let measured: Vec<(QifPoint<'_>, nalgebra::Vector3<f64>)> = self
                    .points
                    .iter()
                    .zip(&self.nominals)
                    .map(|(m, (p, n))| {
                        (
                            QifPoint {
                                label: &m.label,
                                nominal: *p,
                                normal: *n,
                            },
                            m.p,
                        )
                    })
                    .collect();
                qif_write::results(&head, &measured)
            }
            Format::Log => self.log.clone().unwrap_or_default(),
            Format::Heights => {
                let c: Vec<&str> = head.iter().map(|s| s.as_str()).collect();
                heights::to_csv(self.heights.as_deref().unwrap_or_default(), &c)
            }
        })
    }

    /// Writes the output atomically.
    pub fn write(&self, format: Format, path: &Path) -> Result<(), SimError> {
        let text = self.render(format)?;
        write_atomic(path, text.as_bytes())?;
        Ok(())
    }

    fn comments(&self, format: Format) -> Vec<String> {
        let mut v = vec![format!(
            "fivecal simulate: {} on {}, seed {}",
            self.test, self.machine, self.seed
        )];
        v.push(match self.kind {
            _ if format == Format::Heights => {
                "height of each section relative to section 1, um (its points' mean deviation along the normal)".to_string()
            }
            TestKind::Machining if self.placement == nalgebra::Isometry3::identity() => {
                "machined piece measured on a CMM, part frame aligned on W (mm)".to_string()
            }
            TestKind::Machining => {
                "machined piece measured on a CMM, in the CMM's frame (mm)".to_string()
            }
            TestKind::Probing => {
                "contact points probed on the machine, in W at rotary zero (mm)".to_string()
            }
        });
        v
    }
}
