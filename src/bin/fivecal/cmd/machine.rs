//! `fivecal machine show FILE`: the parsed machine, its chain and its
//! symbols; `fivecal machine new NAME --from MACHINE`: a machine file to
//! start one's own from.

use anyhow::Context as _;
use fivecal::kinematics::symbols::SymbolTable;
use fivecal::{Kinematics, Machine};

use crate::config::machine::MachineCommand;

pub fn run(cmd: MachineCommand) -> anyhow::Result<()> {
    match cmd {
        MachineCommand::List => {
            for (name, _) in fivecal::machine::BUILTIN {
                let m = Machine::builtin(name).expect("built-in machines are valid");
                outln!("{name:12} {}", m.description);
            }
            Ok(())
        }
        MachineCommand::New { name, from, output } => {
            let (m, origin) =
                Machine::resolve(&from).with_context(|| format!("cannot load machine `{from}`"))?;
            let text = starter(&m, &name, &origin.to_string())?;
            let out = output.unwrap_or_else(|| format!("{name}.yaml").into());
            let inputs: Vec<&std::path::Path> = match origin {
                fivecal::machine::MachineOrigin::File(ref p) => vec![p.as_path()],
                _ => vec![],
            };
            fivecal::io::check_outputs(&inputs, &[("--out", &out, fivecal::io::Shape::File)])?;
            if out.as_os_str() != "-" && out.exists() {
                anyhow::bail!(
                    "{} exists: a new machine file is not written over another file (give -o)",
                    out.display()
                );
            }
            fivecal::io::write_atomic(&out, text.as_bytes())
                .with_context(|| format!("cannot write {}", out.display()))?;
            if out.as_os_str() != "-" {
                outln!(
                    "wrote {} (machine {name}, copied from {}): edit its strokes, pivot, limits, tool and probe, then `fivecal machine show {}`",
                    out.display(),
                    m.name,
                    fivecal::io::shell_word(&out.display().to_string())
                );
            }
            Ok(())
        }
        MachineCommand::Show { file } => {
            let (m, origin) =
                Machine::resolve(&file).with_context(|| format!("cannot load machine `{file}`"))?;
            outln!("from        {origin}");
            out!("{}", show(&m));
            Ok(())
        }
    }
}

/// The text of `m`'s file under the name `name`, with a first line saying
/// where it was copied from; the copy reads back as the same machine.
fn starter(m: &Machine, name: &str, origin: &str) -> anyhow::Result<String> {
    let ok = !name.is_empty()
        && name.len() <= 64
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'));
    if !ok {
        anyhow::bail!(
            "machine name `{name}`: expected up to 64 letters, digits, `-`, `_` or `.` (it labels every output)"
        );
    }
    let mut renamed = false;
    // The old description names the old machine and often its controller
    // ("FANUC 31i-like"), and it is printed in every program header: a copy
    // that kept it would label a SINUMERIK program as a FANUC one. Only a
    // one-line plain description is replaced; any other form is left for the
    // user (the note below says so).
    let mut described = false;
    let mut text = format!(
        "# Machine {name}, copied from {} ({origin}) by `fivecal machine new`:\n# check every value against the real machine before use.\n",
        m.name
    );
    for line in m.source.lines() {
        if !renamed && line.starts_with("name:") {
            text.push_str(&format!("name: {name}\n"));
            renamed = true;
        } else if !described && is_plain_description(line) {
            text.push_str(&format!(
                "description: {name} (copied from {}; describe the real machine and its controller here)\n",
                m.name
            ));
            described = true;
        } else {
            text.push_str(line);
            text.push('\n');
        }
    }
    anyhow::ensure!(
        renamed,
        "machine `{}` has no top-level `name:` line to replace",
        m.name
    );
    let copy = Machine::from_yaml(std::path::Path::new(name), &text)
        .with_context(|| format!("the copy of {} does not read back", m.name))?;
    anyhow::ensure!(
        copy.name == name,
        "the copy of {} reads back as `{}`",
        m.name,
        copy.name
    );
    Ok(text)
}

/// A top-level `description:` line holding a one-line plain scalar (not a
/// block scalar `|`/`>`, not a quoted string continued on the next line).
fn is_plain_description(line: &str) -> bool {
    let Some(value) = line.strip_prefix("description:") else {
        return false;
    };
    let v = value.trim();
    if v.is_empty() || v.starts_with('|') || v.starts_with('>') {
        return false;
    }
    match v.chars().next() {
        Some(q @ ('"' | '\'')) => v.len() > 1 && v.ends_with(q),
        _ => true,
    }
}

fn limits(l: Option<(f64, f64)>) -> String {
    match l {
        None => "continuous".into(),
        Some((a, b)) => format!("{a} .. {b} deg"),
    }
}

pub fn show(m: &Machine) -> String {
    use std::fmt::Write;
    let k = Kinematics::new(m);
    let sym = SymbolTable::for_kinematics(&k);
    let mut s = String::new();
    let _ = writeln!(s, "machine     {}", m.name);
    let _ = writeln!(s, "            {}", m.description);
    let _ = writeln!(
        s,
        "structure   {} (chain {}, workpiece to tool)",
        m.structure, m.chain
    );
    let _ = writeln!(s, "controller  {}", m.dialect);
    for (i, l) in ['X', 'Y', 'Z'].iter().enumerate() {
        let (a, b) = m.strokes[i];
        let _ = writeln!(s, "axis {l}      {a} .. {b} mm (machine coordinates)");
    }
    for a in [&m.tilt, &m.c] {
        let _ = writeln!(
            s,
            "axis {}      {}, about {}, in the {}, on {}, direction {:+}",
            a.letter,
            limits(a.limits),
            a.about.letter(),
            if a.on_table { "table" } else { "head" },
            a.parent,
            a.direction
        );
    }
    let _ = writeln!(
        s,
        "pivot       W origin at X{} Y{} Z{} (machine coordinates)",
        m.pivot.x, m.pivot.y, m.pivot.z
    );
    if m.pivot_length > 0.0 {
        let _ = writeln!(s, "head        pivot length {} mm", m.pivot_length);
    }
    let _ = writeln!(
        s,
        "table       top at Z{} in W, radius {} mm",
        m.table.surface, m.table.radius
    );
    let _ = writeln!(
        s,
        "tool        T{} {}: {:?} D{} L{}",
        m.tool.number, m.tool.name, m.tool.kind, m.tool.diameter, m.tool.length
    );
    let _ = writeln!(
        s,
        "probe       T{} {}: ball D{} L{}",
        m.probe.number, m.probe.name, m.probe.ball_diameter, m.probe.length
    );
    let _ = writeln!(
        s,
        "rapid       {} mm/min, {} deg/min",
        m.rapid.linear, m.rapid.rotary
    );
    let _ = writeln!(
        s,
        "\nkinematic chain (mm, rad; tool = tool length {} mm):",
        k.gauge_length()
    );
    for line in k.describe_chain().lines() {
        let _ = writeln!(s, "  {line}");
    }
    let _ = writeln!(s, "\nlocation-error symbols:");
    for l in &sym.location {
        let terms: Vec<String> = l
            .terms
            .iter()
            .map(|&(slot, c)| {
                let n = k.slot_name(slot).unwrap_or_default();
                if c < 0.0 { format!("-{n}") } else { n }
            })
            .collect();
        let _ = writeln!(
            s,
            "  {:9} = {:16} [{}]  {}",
            l.name,
            terms.join(" + "),
            l.unit,
            l.description
        );
    }
    let _ = writeln!(s, "\nnot identifiable (rejected in error files):");
    for (n, why) in &sym.not_identifiable {
        let _ = writeln!(s, "  {n:9} {why}");
    }
    let maps: Vec<&str> = sym.maps.iter().map(|m| m.name.as_str()).collect();
    let _ = writeln!(s, "\nposition-dependent symbols:\n  {}", maps.join(" "));
    s
}
