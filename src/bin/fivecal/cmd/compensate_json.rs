//! What `compensate --json` prints on standard output: the rewrite's
//! summary (moves corrected, left as written and why, the largest
//! corrections), the export's parameters, and the files written. Kept
//! beside `compensate.rs` so that its printing stays one place.

use std::path::Path;

use fivecal::compensate::Summary;
use fivecal::compensate::export::{Export, Kind};
use serde::Serialize;

use crate::out::{AtLine, ReasonLines};

#[derive(Serialize, Default)]
pub struct Compensated {
    pub machine: String,
    pub errors: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rewrite: Option<Rewritten>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub export: Option<Exported>,
    /// Why the rewritten program is a copy of the input, when it is.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub unchanged: Option<String>,
    /// The files written.
    pub files: Vec<String>,
}

/// The rewrite of one program.
#[derive(Serialize)]
pub struct Rewritten {
    pub program: String,
    pub out: String,
    /// The dialect the program was read in.
    pub dialect: String,
    pub blocks: usize,
    pub moves: usize,
    /// Blocks rewritten.
    pub corrected: usize,
    /// Blocks inserted (subdivided moves, linearized arcs).
    pub inserted: usize,
    /// Largest correction of X, Y, Z, um.
    pub largest_linear_um: Option<AtLine>,
    /// Largest correction of the tool orientation, urad.
    pub largest_rotary_urad: Option<AtLine>,
    /// Moves left as written, by reason.
    pub skipped: Vec<ReasonLines>,
    /// Errors of the file a rewrite does not correct, and why.
    pub not_compensated: Vec<String>,
}

impl Rewritten {
    pub fn new(s: &Summary, program: &Path, out: &Path, dialect: fivecal::Dialect) -> Rewritten {
        Rewritten {
            program: program.display().to_string(),
            out: out.display().to_string(),
            dialect: dialect.to_string(),
            blocks: s.blocks,
            moves: s.moves,
            corrected: s.changed,
            inserted: s.inserted,
            largest_linear_um: s.largest_linear.map(AtLine::from),
            largest_rotary_urad: s.largest_rotary.map(AtLine::from),
            skipped: ReasonLines::all(&s.skipped),
            not_compensated: s.not_compensated.clone(),
        }
    }
}

/// The parameters of `--export`.
#[derive(Serialize)]
pub struct Exported {
    pub controller: String,
    /// Where they were written (absent: standard error had them).
    pub file: Option<String>,
    pub parameters: Vec<ParameterJson>,
}

#[derive(Serialize)]
pub struct ParameterJson {
    pub name: String,
    pub what: String,
    /// mm or urad.
    pub unit: &'static str,
    pub value: f64,
    pub nominal: f64,
    pub current: Option<f64>,
    pub u: Option<f64>,
}

impl Exported {
    pub fn new(e: &Export, file: Option<&Path>) -> Exported {
        Exported {
            controller: e.dialect.to_string(),
            file: file.map(|f| f.display().to_string()),
            parameters: e
                .parameters
                .iter()
                .map(|p| ParameterJson {
                    name: p.name.clone(),
                    what: p.what.clone(),
                    unit: match p.kind {
                        Kind::Length => "mm",
                        Kind::Angle => "urad",
                    },
                    value: p.value,
                    nominal: p.nominal,
                    current: p.current,
                    u: p.u,
                })
                .collect(),
        }
    }
}
