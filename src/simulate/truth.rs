//! The example truth file `fivecal simulate --truth-example` prints: every
//! effect the simulator supports, with the machine's own symbols, its units
//! and what it means, as YAML that [`crate::errorfile::ErrorFile::load`]
//! reads back.

use std::fmt::Write as _;

use crate::kinematics::Kinematics;
use crate::kinematics::symbols::{SymbolTable, Unit};

/// A commented truth file for the machine of `kin` with every supported
/// effect set to a plausible value (tens of um, a hundred urad: a machine
/// that needs calibrating, well within what every plan can measure).
pub fn example(kin: &Kinematics) -> String {
    let m = kin.machine();
    let sym = SymbolTable::for_kinematics(kin);
    let t = m.tilt.letter;
    let mut s = String::new();
    let w = &mut s;
    let _ = writeln!(
        w,
        "# fivecal truth file: the errors of a virtual machine (docs/formats.md)."
    );
    let _ = writeln!(
        w,
        "#   fivecal simulate --plan DIR/<test>.plan.yaml --errors THIS.yaml --out FILE [--seed N]"
    );
    let _ = writeln!(
        w,
        "# Units: um for lengths, urad for angles (1 urad = 1 um/m). A value is a bare number;"
    );
    let _ = writeln!(
        w,
        "# `{{value: 12.0, u: 0.4}}` (what analyze writes) is read as well. Every section is optional."
    );
    let _ = writeln!(w, "machine: {}", m.name);
    let _ = writeln!(
        w,
        "# effect `location`: constant location errors of the rotary axes (`fivecal machine show {}`)",
        m.name
    );
    let _ = writeln!(w, "location_errors:");
    let loc_values = [
        12.0, -25.0, 80.0, -60.0, 150.0, 25.0, -18.0, 45.0, 30.0, -40.0,
    ];
    for (i, l) in sym.location.iter().enumerate() {
        let v = loc_values[i % loc_values.len()];
        let _ = writeln!(
            w,
            "  {:<9} {:>7.1}   # {}, {}",
            format!("{}:", l.name),
            v,
            l.unit,
            l.description
        );
    }
    let _ = writeln!(
        w,
        "# effect `map.<SYMBOL>`: error maps over the index angles, added to the location errors;"
    );
    let _ = writeln!(
        w,
        "# linear between nodes (periodic in C), constant beyond the end nodes of the tilt"
    );
    let _ = writeln!(w, "position_dependent:");
    let (lo, hi) = m.tilt.limits.unwrap_or((-90.0, 90.0));
    let tilt_nodes = [lo.max(-90.0), 0.0, hi.min(90.0)];
    // A tilt map in urad over three tilt angles, and a C map in um over
    // four C angles (one node of any other angle it runs over).
    // Preferably the tilt axis' own angular positioning error (EBB(B)).
    let own = format!("E{}{t}", m.tilt.about.rot_letter());
    let tilt_map = sym
        .maps
        .iter()
        .filter(|ms| ms.deps.contains(&0) && ms.unit == Unit::Urad)
        .min_by_key(|ms| (!ms.name.starts_with(&own), ms.deps.len()));
    if let Some(ms) = tilt_map {
        map_entry(
            w,
            &ms.name,
            &ms.deps,
            t,
            &tilt_nodes,
            &[0.0, 180.0],
            &[20.0, 0.0, -15.0],
            ms.unit,
        );
    }
    let c_map = sym
        .maps
        .iter()
        .find(|ms| ms.deps.contains(&1) && ms.unit == Unit::Um);
    if let Some(ms) = c_map {
        map_entry(
            w,
            &ms.name,
            &ms.deps,
            t,
            &[0.0],
            &[0.0, 90.0, 180.0, 270.0],
            &[2.0, -1.0, -2.0, 1.0],
            ms.unit,
        );
    }
    let first = &sym.location[0].name;
    let second = &sym.location[1].name;
    let _ = writeln!(w, "effects:");
    let _ = writeln!(
        w,
        "  # effect `drift.<SYMBOL>`: thermal drift of a location error, its value grows by"
    );
    let _ = writeln!(
        w,
        "  # rate per pose (`seq`, the pose's execution order from 0) or per minute since the"
    );
    let _ = writeln!(
        w,
        "  # program started (`minute`, continuous along each cut, from the plan's timing)"
    );
    let _ = writeln!(w, "  thermal_drift:");
    let _ = writeln!(w, "    {first}: {{per: seq, rate: 1.5}}");
    let _ = writeln!(w, "    {second}: {{per: minute, rate: -0.2}}");
    let _ = writeln!(
        w,
        "  # effect `scale.EXX` (EYY, EZZ): linear positioning error, um/m, zero at the W origin"
    );
    let _ = writeln!(w, "  linear_scale: {{EXX: 4.0, EYY: -3.0, EZZ: 2.0}}");
    let _ = writeln!(
        w,
        "  # effect `squareness.<SYMBOL>`, urad: EC(0X)Y moves X by -EC(0X)Y * y, EB(0X)Z moves X"
    );
    let _ = writeln!(w, "  # by +EB(0X)Z * z, EA(0Y)Z moves Y by -EA(0Y)Z * z");
    let _ = writeln!(
        w,
        "  squareness: {{EC(0X)Y: 15.0, EB(0X)Z: -10.0, EA(0Y)Z: 8.0}}"
    );
    let _ = writeln!(
        w,
        "  # effect `straightness.E<dir><axis>`: deviation of an axis' motion in another direction,"
    );
    let _ = writeln!(
        w,
        "  # um at positions of the moving axis (mm, program coordinates), linear in between"
    );
    let _ = writeln!(w, "  straightness:");
    let _ = writeln!(
        w,
        "    EYX: {{X: [-300, -100, 100, 300], values: [0.0, 1.5, -1.0, 0.0]}}"
    );
    let _ = writeln!(w, "    EZY: {{Y: [-300, 0, 300], values: [0.0, 1.0, 0.0]}}");
    let _ = writeln!(
        w,
        "  tool_radius: 3.0        # effect `tool_radius`: actual minus nominal radius, um (machining)"
    );
    let _ = writeln!(
        w,
        "  tool_length: -2.0       # effect `tool_length`: actual minus nominal tool or probe length, um"
    );
    let _ = writeln!(
        w,
        "  # effect `probe_pretravel`: how far the probe travels past the contact before it"
    );
    let _ = writeln!(
        w,
        "  # triggers, um, by approach direction in the probe's own frame (probing)"
    );
    let _ = writeln!(
        w,
        "  probe_pretravel: {{X+: 1.0, X-: 1.2, Y+: 0.9, Y-: 1.1, Z+: 0.0, Z-: 0.6}}"
    );
    let _ = writeln!(
        w,
        "  # measurement noise, um (standard deviation): the CMM along each probing direction and"
    );
    let _ = writeln!(
        w,
        "  # the probe's repeatability along its probing move (default 0.35, Ibaraki & Ota 2014, table 4)"
    );
    let _ = writeln!(w, "  noise: {{cmm: 0.35, probe: 0.35}}");
    s
}

/// One map of `position_dependent`: its node lists in the symbol's order
/// (tilt nodes for angle 0, C nodes for angle 1) and values along the
/// varying dimension, `pattern` repeated (halved on a second row).
#[allow(clippy::too_many_arguments)]
fn map_entry(
    w: &mut String,
    name: &str,
    deps: &[usize],
    tilt: char,
    tilt_nodes: &[f64],
    c_nodes: &[f64],
    pattern: &[f64],
    unit: Unit,
) {
    let nodes_of = |d: usize| if d == 0 { tilt_nodes } else { c_nodes };
    let letter = |d: usize| if d == 0 { tilt } else { 'C' };
    let list = |v: &[f64]| {
        v.iter()
            .map(|x| format!("{x}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let value = |i: usize| pattern[i % pattern.len()];
    let _ = writeln!(w, "  {name}:   # {unit} at each node");
    for &d in deps {
        let _ = writeln!(w, "    {}: [{}]", letter(d), list(nodes_of(d)));
    }
    if deps.len() == 1 {
        let v: Vec<f64> = (0..nodes_of(deps[0]).len()).map(value).collect();
        let _ = writeln!(w, "    values: [{}]", list(&v));
    } else {
        let (rows, cols) = (nodes_of(deps[0]).len(), nodes_of(deps[1]).len());
        let row = |r: usize| {
            let k = if r.is_multiple_of(2) { 1.0 } else { 0.5 };
            let v: Vec<f64> = (0..cols)
                .map(|c| if cols > 1 { value(c) * k } else { value(r) })
                .collect();
            format!("[{}]", list(&v))
        };
        let all: Vec<String> = (0..rows).map(row).collect();
        let _ = writeln!(w, "    values: [{}]", all.join(", "));
    }
}
