//! `fivecal measured FILE [--json]`: what a measurement file holds before
//! any plan is involved. Also the flags every command that reads
//! measurement files shares (`--run`, `--units`, `--encoding`).

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::{Context as _, bail};
use clap::Args;
use fivecal::formats::detect::{self, LengthUnit, MeasuredOptions, ReadContext};
use fivecal::formats::encoding;
use fivecal::formats::inventory::Inventory;
use nalgebra::Vector3;

/// What the user says about measurement files where a file cannot.
#[derive(Args, Debug, Clone, Default)]
pub struct MeasuredFlags {
    /// Read measurement run N (from 1) of a file holding several (QIF
    /// results, CALYPSO tables of several parts).
    #[arg(long, value_name = "N")]
    pub run: Option<usize>,
    /// Length unit of a measurement file that does not state it (QIF
    /// without FileUnits, CALYPSO tables without a unit column, point
    /// tables and clouds): mm or inch.
    #[arg(long, value_name = "UNIT")]
    pub units: Option<String>,
    /// Encoding of a measurement file not in UTF-8 (windows-1252,
    /// iso-8859-1, utf-16le, shift_jis, ...).
    #[arg(long, value_name = "NAME")]
    pub encoding: Option<String>,
}

impl MeasuredFlags {
    /// The validated options.
    pub fn options(&self) -> anyhow::Result<MeasuredOptions> {
        let units = match &self.units {
            None => None,
            Some(u) => Some(
                LengthUnit::parse(u)
                    .with_context(|| format!("--units {u}: expected mm or inch"))?,
            ),
        };
        let encoding = match &self.encoding {
            None => None,
            Some(e) => Some(encoding::by_name(e).with_context(|| {
                format!("--encoding {e}: not an encoding name (expected e.g. windows-1252, iso-8859-1, utf-16le)")
            })?),
        };
        if self.run == Some(0) {
            bail!("--run 0: runs are numbered from 1");
        }
        Ok(MeasuredOptions {
            run: self.run,
            units,
            encoding,
        })
    }
}

#[derive(Args, Debug)]
pub struct MeasuredArgs {
    /// The measurement file (DMIS output, QIF results, CALYPSO table, CSV,
    /// point list, nine-section heights, a probe log as the control wrote
    /// it).
    file: PathBuf,
    /// Print JSON: the file's format, units and runs, and one object per
    /// point with `label`, `nominal`, `actual` and `normal`.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    flags: MeasuredFlags,
}

pub fn run(a: MeasuredArgs) -> anyhow::Result<()> {
    let ctx = ReadContext {
        options: a.flags.options()?,
        ..Default::default()
    };
    let inv = detect::inventory(&a.file, &ctx)?;
    if a.json {
        outln!("{}", serde_json::to_string_pretty(&json(&inv))?);
    } else {
        out!("{}", text(&inv));
    }
    Ok(())
}

fn v(x: Option<Vector3<f64>>) -> serde_json::Value {
    match x {
        Some(p) => serde_json::json!([p.x, p.y, p.z]),
        None => serde_json::Value::Null,
    }
}

fn json(inv: &Inventory) -> serde_json::Value {
    let points: Vec<serde_json::Value> = inv
        .entries
        .iter()
        .map(|e| {
            let mut o = serde_json::json!({
                "label": e.label,
                "kind": e.kind,
                "run": e.run + 1,
                "nominal": v(e.nominal),
                "actual": v(e.actual),
                "normal": v(e.normal),
                "line": e.line,
            });
            if let Some(x) = e.value {
                o["value"] = serde_json::json!(x);
            }
            if !e.points.is_empty() {
                o["measured_points"] = serde_json::json!(e.points.len());
            }
            o
        })
        .collect();
    serde_json::json!({
        "format": inv.format,
        "version": inv.version,
        "units": inv.units,
        "runs": inv.runs,
        "points": points,
        "skipped": inv.skipped.iter().map(|s| serde_json::json!({
            "line": s.line, "what": s.what, "why": s.why
        })).collect::<Vec<_>>(),
        "warnings": inv.warnings,
    })
}

fn xyz(x: Option<Vector3<f64>>, d: usize) -> String {
    match x {
        Some(p) => format!("{:.d$} {:.d$} {:.d$}", p.x, p.y, p.z),
        None => "-".into(),
    }
}

fn text(inv: &Inventory) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "format   {}{}",
        inv.format,
        inv.version
            .as_deref()
            .map_or(String::new(), |v| format!(" {v}"))
    );
    let _ = writeln!(s, "units    {} (lengths below in mm)", inv.units);
    if inv.runs.len() > 1 || inv.runs.first().is_some_and(|r| !r.is_empty()) {
        let _ = writeln!(s, "runs     {}: {}", inv.runs.len(), inv.runs.join(", "));
    }
    let points = inv.entries.iter().filter(|e| e.is_point()).count();
    let _ = writeln!(
        s,
        "entries  {} ({points} measured points)",
        inv.entries.len()
    );
    let multi = inv.runs.len() > 1;
    for e in &inv.entries {
        let _ = write!(s, "  ");
        if multi {
            let _ = write!(s, "run {} ", e.run + 1);
        }
        let _ = write!(
            s,
            "{:16} {:10} nominal {}  actual {}  normal {}",
            if e.label.is_empty() { "-" } else { &e.label },
            e.kind,
            xyz(e.nominal, 4),
            xyz(e.actual, 4),
            xyz(e.normal, 4)
        );
        if let Some(x) = e.value {
            let _ = write!(s, "  value {x}");
        }
        if !e.points.is_empty() {
            let _ = write!(s, "  ({} measured points)", e.points.len());
        }
        let _ = writeln!(s, "  [line {}]", e.line);
    }
    for k in &inv.skipped {
        let _ = writeln!(s, "skipped  line {}: {}: {}", k.line, k.what, k.why);
    }
    for w in &inv.warnings {
        let _ = writeln!(s, "warning  {w}");
    }
    s
}
