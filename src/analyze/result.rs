//! The result files of an analysis. Every entry of an error file is added
//! here or in what this calls: the values the test identifies with their
//! `u` and the symbols it cannot identify, with the reason
//! ([`Identification::error_file`]), and the measurement noise the fit
//! found. `analyze`, the demo and `discover` all write their error files
//! through [`error_file`].
//!
//! An analysis writes one error file (YAML, or JSON on request); a series
//! writes one per piece beside the series table (`RESULT.1.yaml`, ...); the
//! nine-section test writes its statistics and lists every location symbol
//! as not identifiable.

use std::path::{Path, PathBuf};

use serde::Serialize;

use super::{AnalyzeError, Found, NineSectionOutcome, Outcome};
use crate::errorfile::{ErrorFile, Noise, NotIdentified};
use crate::formats::manifest::TestKind;
use crate::identify::Identification;
use crate::identify::nine_section::NineSection;
use crate::io::write_atomic;

/// The error file of an identification of a test of `kind`, reporting the
/// uncertainties `u`: the identified values, what the test cannot
/// identify, and the noise the fit found (the CMM's for a machined piece,
/// the probe's for on-machine probing).
pub fn error_file(est: &Identification, u: &[Option<f64>], kind: TestKind) -> ErrorFile {
    let mut f = est.error_file(Some(u));
    f.effects.noise = Some(Noise::of_kind(kind, est.sigma_um));
    f
}

/// The file of piece `k` of a series written to `out`: `RESULT.k.yaml`.
pub(crate) fn piece_path(out: &Path, k: usize, json: bool) -> PathBuf {
    let stem = out
        .file_stem()
        .map_or("result".into(), |s| s.to_string_lossy().to_string());
    let ext = if json { "json" } else { "yaml" };
    out.with_file_name(format!("{stem}.{k}.{ext}"))
}

fn serialize<T: Serialize>(v: &T, json: bool) -> Result<String, AnalyzeError> {
    let text = if json {
        serde_json::to_string_pretty(v)
            .map(|s| s + "\n")
            .map_err(|e| e.to_string())
    } else {
        serde_yaml::to_string(v).map_err(|e| e.to_string())
    };
    text.map_err(|e| AnalyzeError::Plan(format!("cannot write the result: {e}")))
}

/// The nine-section result file, flat as every result file: its test and
/// machine, each piece's section heights and statistics by name, the rate
/// of improvement from the first piece to the last, and the symbols the
/// test cannot identify.
#[derive(Serialize)]
struct NineSectionEntry<'a> {
    test: &'static str,
    machine: &'a str,
    pieces: Vec<NineSectionPiece>,
    #[serde(skip_serializing_if = "Option::is_none")]
    improvement_percent: Option<Improvement>,
    not_identifiable: &'a [NotIdentified],
}

/// One piece of a nine-section result.
#[derive(Serialize)]
struct NineSectionPiece {
    measured: String,
    sections: Vec<SectionRow>,
    avg_um: f64,
    max_um: f64,
    rms_um: f64,
}

/// One section's height.
#[derive(Serialize)]
struct SectionRow {
    section: u32,
    height_um: f64,
}

/// The rates of improvement, %; a statistic that was zero on the first
/// piece has none and is left out.
#[derive(Serialize)]
struct Improvement {
    #[serde(skip_serializing_if = "Option::is_none")]
    avg: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    max: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    rms: Option<f64>,
}

fn nine_section_entry(n: &NineSectionOutcome) -> NineSectionEntry<'_> {
    NineSectionEntry {
        test: crate::formats::manifest::Test::NineSection.as_str(),
        machine: &n.machine,
        pieces: n
            .stats
            .iter()
            .map(|(p, s): &(_, NineSection)| NineSectionPiece {
                measured: p.display().to_string(),
                sections: s
                    .sections
                    .iter()
                    .map(|&(section, height_um)| SectionRow { section, height_um })
                    .collect(),
                avg_um: s.avg_um,
                max_um: s.max_um,
                rms_um: s.rms_um,
            })
            .collect(),
        improvement_percent: n
            .improvement
            .map(|[avg, max, rms]| Improvement { avg, max, rms }),
        not_identifiable: &n.not_identifiable,
    }
}

/// The files an outcome writes to `out` (YAML, or JSON with `json`), with
/// their text, in the order they are written: a series' pieces first, its
/// table last, at `out`.
pub fn files(
    outcome: &Outcome,
    out: &Path,
    json: bool,
) -> Result<Vec<(PathBuf, String)>, AnalyzeError> {
    match &outcome.found {
        Found::NineSection(n) => Ok(vec![(
            out.to_path_buf(),
            serialize(&nine_section_entry(n), json)?,
        )]),
        Found::Identified(id) => match &id.series {
            Some(series) => {
                let mut v = Vec::new();
                for (k, p) in id.pieces.iter().enumerate() {
                    v.push((piece_path(out, k + 1, json), serialize(&p.file, json)?));
                }
                v.push((out.to_path_buf(), serialize(series, json)?));
                Ok(v)
            }
            None => {
                let f = &id.pieces[0].file;
                let text = if json {
                    f.to_json() + "\n"
                } else {
                    f.to_yaml()
                };
                Ok(vec![(out.to_path_buf(), text)])
            }
        },
    }
}

/// Writes the result files of an outcome (each atomically), returning
/// their paths.
pub fn write(outcome: &Outcome, out: &Path, json: bool) -> Result<Vec<PathBuf>, AnalyzeError> {
    let files = files(outcome, out, json)?;
    for (path, text) in &files {
        write_atomic(path, text.as_bytes())?;
    }
    Ok(files.into_iter().map(|f| f.0).collect())
}

/// The `uncertainty:` section as `analyze` prints it under the values:
/// what every `u` holds, then per value the full `u`, the noise-only `u`
/// and the largest contributors with their share of the variance.
pub fn render_uncertainty(s: &crate::errorfile::UncertaintySection) -> String {
    use std::fmt::Write as _;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "u (standard uncertainty, k = 1) holds {}; noise {:.3} um per measured point",
        s.basis, s.noise_um
    );
    if let Some(w) = s.widened_by {
        let _ = writeln!(
            out,
            "  every u is widened by the ratio {w:.2}: the model does not fit, and the study drew the stated noise"
        );
    }
    if s.values.is_empty() {
        return out;
    }
    let _ = writeln!(
        out,
        "  {:<24} {:>10} {:>14}   largest contributors (share of u^2)",
        "value", "u", "u noise only"
    );
    for (name, v) in &s.values {
        let largest: Vec<String> = v
            .largest
            .iter()
            .map(|sh| format!("{} {:.0} %", sh.contributor, sh.share * 100.0))
            .collect();
        let noise = v.u_noise.map_or("-".to_string(), |x| format!("{x:.3}"));
        let _ = writeln!(
            out,
            "  {:<24} {:>10.3} {:>14}   {}",
            name,
            v.u,
            noise,
            if largest.is_empty() {
                "-".to_string()
            } else {
                largest.join(", ")
            }
        );
    }
    for n in &s.not_included {
        let _ = writeln!(out, "  not included: {n}");
    }
    out
}

/// The location errors seen but not usefully, as `analyze` and `plan`
/// print them (empty when there are none).
pub fn render_not_useful(
    v: &[crate::errorfile::NotUseful],
    units: &dyn Fn(&str) -> String,
) -> String {
    use std::fmt::Write as _;
    let mut out = String::new();
    if v.is_empty() {
        return out;
    }
    let _ = writeln!(
        out,
        "seen, but not usefully (u above the threshold: not counted as identified, not exported, not compensated):"
    );
    for n in v {
        let unit = units(&n.symbol);
        let _ = writeln!(
            out,
            "  {:<10} {:>10.3} {unit:<5} u = {:.3} > {:.3} {unit} ({})",
            n.symbol, n.value, n.u, n.threshold, n.from
        );
    }
    out
}
