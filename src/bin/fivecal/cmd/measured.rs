//! `fivecal measured FILE [--json]`: what a measurement file holds before
//! any plan is involved. The options are `config/measured.rs`'s.

use std::fmt::Write as _;

use fivecal::formats::detect::{self, ReadContext};
use fivecal::formats::inventory::Inventory;
use nalgebra::Vector3;

use crate::config::measured::MeasuredArgs;

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
