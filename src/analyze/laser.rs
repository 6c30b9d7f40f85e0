//! `analyze` of a ten-line plan: each run file joined to its line of the
//! plan (by the line's name), its readings tabulated at the plan's targets
//! and the ISO 230-2 figures of [`super::iso230_2`] computed with the
//! plan's instrument uncertainty; the result file holds them per line with
//! the environment each file states. Then the linear axes' errors the
//! lines determine ([`super::laser_identify`]).

use std::path::{Path, PathBuf};

use indexmap::IndexMap;
use serde::Serialize;

use super::iso230_2::{self, Instrument, LineFigures};
use super::laser_identify::{self, Identification, MeasuredLine};
use crate::formats::laser::{LaserManifest, LaserRun};
use crate::machine::Machine;
use crate::source::SourceError;

/// One line's result.
#[derive(Clone, Debug, Serialize)]
pub struct LineResult {
    /// The run file.
    pub file: PathBuf,
    /// Its format.
    pub format: String,
    /// The axes that moved.
    pub axes: String,
    /// The measured point at target 0, machine coordinates, mm (the
    /// plan's; with `direction` it places every target on the machine,
    /// which an axis compensation table needs).
    pub start: [f64; 3],
    /// Unit direction of rising target positions.
    pub direction: [f64; 3],
    /// The measured point's offset from the spindle point P, mm (zero on
    /// the base lines L1, L2, L3).
    pub offset: [f64; 3],
    /// The environment and its compensation, as the file states them.
    pub environment: IndexMap<String, String>,
    /// The figures.
    #[serde(flatten)]
    pub figures: LineFigures,
}

/// The result of a ten-line analysis.
#[derive(Clone, Debug, Serialize)]
pub struct LaserResult {
    /// What the file is.
    pub fivecal_laser_result: u32,
    /// The machine.
    pub machine: String,
    /// How the u of each figure was found.
    pub uncertainty: String,
    /// The plan's standard uncertainty of one reading, um.
    pub reading_u_um: f64,
    /// The plan's standard uncertainty of a length, ppm.
    pub length_u_ppm: f64,
    /// The lines, in the plan's order.
    pub lines: Vec<LineResult>,
    /// The plan's lines without a run file.
    pub not_measured: Vec<String>,
    /// The error file of the linear axes' errors the lines determine
    /// (written beside the result, [`LaserResult::errors_path`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub linear_errors: Option<PathBuf>,
    /// What the lines determine and what not.
    #[serde(skip)]
    pub identification: Option<Identification>,
}

/// Why the analysis cannot be made.
#[derive(Debug, thiserror::Error)]
pub enum LaserAnalyzeError {
    /// A file that cannot be read.
    #[error(transparent)]
    Source(#[from] SourceError),
    /// The lines cannot be identified from.
    #[error(transparent)]
    Identify(#[from] laser_identify::IdentifyError),
    /// A run that does not fit the plan.
    #[error("{file}: {message}")]
    Plan {
        /// The run file.
        file: PathBuf,
        /// What does not fit.
        message: String,
    },
}

/// Analyzes the run files `runs` of the plan `plan` on `machine` (`None`:
/// the figures alone, no identification).
pub fn analyze(
    plan: &LaserManifest,
    machine: Option<&Machine>,
    runs: &[PathBuf],
) -> Result<LaserResult, LaserAnalyzeError> {
    let inst = Instrument {
        reading_u_um: plan.reading_u_um,
        length_u_ppm: plan.length_u_ppm,
    };
    let mut found: Vec<(usize, LineResult)> = Vec::new();
    for f in runs {
        let run = LaserRun::read(f)?;
        let bad = |message: String| LaserAnalyzeError::Plan {
            file: f.clone(),
            message,
        };
        let Some(k) = plan.lines.iter().position(|l| l.name == run.line) else {
            return Err(bad(format!(
                "line `{}` is not in the plan (its lines: {})",
                run.line,
                plan.lines
                    .iter()
                    .map(|l| l.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            )));
        };
        if found.iter().any(|(j, _)| *j == k) {
            return Err(bad(format!("a second run file of line {}", run.line)));
        }
        let line = &plan.lines[k];
        // The runs the file holds: an operator may stop early or run more
        // than planned; the figures say how many they rest on.
        let runs = run.readings.iter().map(|r| r.run).max().unwrap_or(0);
        let table =
            iso230_2::tabulate(&run, &line.targets, runs).map_err(|e| bad(e.to_string()))?;
        let figures = iso230_2::figures(&line.name, &line.targets, &table, inst)
            .map_err(|e| bad(e.to_string()))?;
        found.push((
            k,
            LineResult {
                file: f.clone(),
                format: run.format.to_string(),
                axes: line.axes.clone(),
                start: line.start,
                direction: line.direction,
                offset: line.offset,
                environment: run.environment.iter().cloned().collect(),
                figures,
            },
        ));
    }
    found.sort_by_key(|(k, _)| *k);
    let measured: Vec<MeasuredLine> = found
        .iter()
        .map(|(k, r)| MeasuredLine {
            line: &plan.lines[*k],
            means_um: r.figures.targets.iter().map(|t| t.mean()).collect(),
            runs: r.figures.runs,
        })
        .collect();
    let identification = match machine {
        Some(m) => Some(laser_identify::identify(plan, m, &measured)?),
        None => None,
    };
    let not_measured = plan
        .lines
        .iter()
        .enumerate()
        .filter(|(k, _)| !found.iter().any(|(j, _)| j == k))
        .map(|(_, l)| l.name.clone())
        .collect();
    Ok(LaserResult {
        fivecal_laser_result: 1,
        machine: plan.machine.clone(),
        uncertainty: format!(
            "standard uncertainty (k = 1) of each figure: a reading's {} um divided by the square root of the runs for a mean, {} ppm of the distance between the two targets a difference spans, and s / sqrt(2 (n - 1)) for each standard deviation s of n runs, combined in quadrature",
            crate::numbers::echo(plan.reading_u_um),
            crate::numbers::echo(plan.length_u_ppm)
        ),
        reading_u_um: plan.reading_u_um,
        length_u_ppm: plan.length_u_ppm,
        lines: found.into_iter().map(|(_, r)| r).collect(),
        not_measured,
        linear_errors: None,
        identification,
    })
}

impl LaserResult {
    /// The result file's text: JSON when `json`, else YAML.
    pub fn to_text(&self, json: bool) -> String {
        if json {
            serde_json::to_string_pretty(self).expect("results serialize") + "\n"
        } else {
            serde_yaml::to_string(self).expect("results serialize")
        }
    }

    /// Where the identified errors go beside the result `out`:
    /// `laser.yaml` -> `laser.errors.yaml` (`.json` likewise).
    pub fn errors_path(out: &Path) -> PathBuf {
        let stem = out
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "laser".into());
        let ext = if Self::json_name(out) { "json" } else { "yaml" };
        out.with_file_name(format!("{stem}.errors.{ext}"))
    }

    /// Whether the file name asks for JSON.
    pub fn json_name(path: &Path) -> bool {
        path.extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("json"))
    }
}
