//! Which points of the axis lines each controller holds, under which
//! names, and the text a person enters at the control. docs/controllers.md
//! gives every parameter's meaning with its public source; the choices
//! here follow it.

use std::fmt::Write as _;

use nalgebra::Vector3;

use super::{
    Export, ExportError, Geometry, Kind, Raw, after_entering, header, listed_lines, not_held_lines,
};
use crate::geom::Axis3;
use crate::kinematics::Kinematics;
use crate::machine::{Dialect, Machine, Structure};

const XYZ: [char; 3] = ['X', 'Y', 'Z'];

fn length(name: String, what: String, value: f64, nominal: f64) -> Raw {
    Raw {
        name,
        what,
        kind: Kind::Length,
        value,
        nominal,
        entered: true,
    }
}

/// Three parameters `first..first+2`, the X, Y, Z of `v` (nominal `vn`).
fn triple(out: &mut Vec<Raw>, first: u32, what: &str, v: &Vector3<f64>, vn: &Vector3<f64>) {
    for i in 0..3 {
        out.push(length(
            (first + i as u32).to_string(),
            format!("{what}, {}", XYZ[i]),
            v[i],
            vn[i],
        ));
    }
}

/// The two machine axes across a rotary axis turning about `about` (for
/// B about Y: X and Z).
fn across(about: Axis3) -> [usize; 2] {
    match about {
        Axis3::X => [1, 2],
        Axis3::Y => [0, 2],
        Axis3::Z => [0, 1],
    }
}

/// The points a head's tool side is described by, from the spindle gauge
/// point G (the tool reference point): D on the spindle axis at the
/// machine file's pivot length above G (what FANUC's tool holder offset,
/// 19666, places), E the point of the tilt axis nearest D, F the point of
/// the C axis nearest E.
struct HeadPoints {
    g: Vector3<f64>,
    d: Vector3<f64>,
    e: Vector3<f64>,
    f: Vector3<f64>,
}

fn head_points(m: &Machine, g: &Geometry) -> HeadPoints {
    let d = g.gauge + m.pivot_length * g.spindle.dir;
    let e = g.tilt.nearest(&d);
    HeadPoints {
        g: g.gauge,
        d,
        e,
        f: g.c.nearest(&e),
    }
}

/// The parameters of `dialect` for the axis lines `g` (nominal `gn`).
pub(super) fn parameters(
    kin: &Kinematics,
    g: &Geometry,
    gn: &Geometry,
    dialect: Dialect,
) -> Result<Vec<Raw>, ExportError> {
    let m = kin.machine();
    let mut out = Vec::new();
    match (dialect, m.structure) {
        (Dialect::Fanuc, _) => fanuc(&mut out, m, g, gn),
        (Dialect::Heidenhain, _) => {
            heidenhain_offsets(&mut out, m, g, gn);
            heidenhain_orientations(&mut out, m, g, gn);
        }
        (Dialect::Linuxcnc, Structure::TableTable) => linuxcnc_trt(&mut out, m, g, gn),
        (Dialect::Sinumerik, _) => return super::sinumerik::parameters(kin, g, gn),
        (Dialect::Linuxcnc, s) => {
            return Err(ExportError::Unsupported(format!(
                "LinuxCNC's stock kinematics with pivot offsets (xyzac-trt-kins, xyzbc-trt-kins) are for tilting-table machines; {} is {s}: rewrite its programs with `fivecal compensate` instead",
                m.name
            )));
        }
    }
    Ok(out)
}

/// FANUC's tool-holder and table parameters (19700-19714): each a point
/// or an offset between axis lines, as X, Y, Z.
fn fanuc(out: &mut Vec<Raw>, m: &Machine, g: &Geometry, gn: &Geometry) {
    let t = m.tilt.letter;
    let pivot = m.pivot;
    match m.structure {
        Structure::TableTable => {
            let (a, b) = g.tilt.common_perpendicular(&g.c, &pivot);
            let (an, bn) = gn.tilt.common_perpendicular(&gn.c, &pivot);
            triple(
                out,
                19700,
                &format!("rotary table position: {t}-axis line, point nearest the C axis"),
                &a,
                &an,
            );
            triple(
                out,
                19703,
                &format!("intersection offset {t} axis -> C axis"),
                &(b - a),
                &(bn - an),
            );
        }
        Structure::HeadTable => {
            triple(
                out,
                19700,
                "rotary table position: C-axis line, point nearest the pivot",
                &g.c.nearest(&pivot),
                &gn.c.nearest(&pivot),
            );
            let (h, hn) = (head_points(m, g), head_points(m, gn));
            triple(
                out,
                19709,
                &format!("intersection offset tool axis (point D) -> {t} axis"),
                &(h.e - h.d),
                &(hn.e - hn.d),
            );
        }
        Structure::HeadHead => {
            let (h, hn) = (head_points(m, g), head_points(m, gn));
            triple(
                out,
                19709,
                &format!("intersection offset tool axis (point D) -> {t} axis"),
                &(h.e - h.d),
                &(hn.e - hn.d),
            );
            triple(
                out,
                19712,
                &format!("intersection offset {t} axis -> C axis"),
                &(h.f - h.e),
                &(hn.f - hn.e),
            );
        }
    }
}

/// HEIDENHAIN's kinematics table: the Trans rows before each MachAxis,
/// across the axis (along it a row moves nothing).
fn heidenhain_offsets(out: &mut Vec<Raw>, m: &Machine, g: &Geometry, gn: &Geometry) {
    let t = m.tilt.letter;
    let pivot = m.pivot;
    let structure = m.structure;
    let tilt_rows = across(m.tilt.about);
    let c_rows = across(Axis3::Z);
    let mut rows =
        |axis: char, idx: [usize; 2], v: Vector3<f64>, vn: Vector3<f64>, stretch: &str| {
            for i in idx {
                out.push(length(
                    format!("{axis}.{}", XYZ[i]),
                    format!("Trans {} {stretch}", XYZ[i]),
                    v[i],
                    vn[i],
                ));
            }
        };
    match structure {
        Structure::TableTable => {
            // The tilt row point stays where the table has it along
            // the tilt axis (its nominal point), so the C rows carry
            // all of C's offset from it.
            let (an, bn) = gn.tilt.common_perpendicular(&gn.c, &pivot);
            let a = g.tilt.nearest(&an);
            let b = g.c.nearest(&a);
            rows(
                t,
                tilt_rows,
                a,
                an,
                &format!("before MachAxis {t}: machine datum -> {t} axis"),
            );
            rows(
                'C',
                c_rows,
                b - a,
                bn - an,
                &format!("between MachAxis {t} and MachAxis C: {t} axis -> C axis"),
            );
        }
        Structure::HeadTable | Structure::HeadHead => {
            let (h, hn) = (head_points(m, g), head_points(m, gn));
            rows(
                t,
                tilt_rows,
                h.e - h.g,
                hn.e - hn.g,
                &format!("before MachAxis {t}: tool reference point -> {t} axis"),
            );
            // The C table stands on the machine; a C head carries the
            // tilt head.
            if structure == Structure::HeadTable {
                rows(
                    'C',
                    c_rows,
                    g.c.nearest(&pivot),
                    gn.c.nearest(&pivot),
                    "before MachAxis C: machine datum -> C axis",
                );
            } else {
                rows(
                    'C',
                    c_rows,
                    h.f - h.e,
                    hn.f - hn.e,
                    &format!("between MachAxis {t} and MachAxis C: {t} axis -> C axis"),
                );
            }
        }
    }
}

/// HEIDENHAIN: the axes' directions, listed and not entered.
fn heidenhain_orientations(out: &mut Vec<Raw>, m: &Machine, g: &Geometry, gn: &Geometry) {
    let t = m.tilt.letter;
    // The orientations, for the machine builder: the small rotation
    // taking each nominal direction to the actual one, about the
    // machine axes across it (about its own direction it is the
    // axis's zero, not its line).
    let mut lines = vec![
        (t, m.tilt.about, &g.tilt, &gn.tilt),
        ('C', Axis3::Z, &g.c, &gn.c),
    ];
    if m.structure != Structure::TableTable {
        lines.push(('S', Axis3::Z, &g.spindle, &gn.spindle));
    }
    for (axis, about, l, ln) in lines {
        let rot = ln.dir.cross(&l.dir) * 1e6;
        let who = if axis == 'S' {
            "spindle axis".to_string()
        } else {
            format!("{axis} axis")
        };
        for i in across(about) {
            out.push(Raw {
                name: format!(
                    "{}.{}",
                    if axis == 'S' {
                        "spindle".into()
                    } else {
                        axis.to_string()
                    },
                    ['A', 'B', 'C'][i]
                ),
                what: format!("direction of the {who}, turned about {}", XYZ[i]),
                kind: Kind::Angle,
                value: rot[i],
                nominal: 0.0,
                entered: false,
            });
        }
    }
}

/// LinuxCNC's xyzac-trt-kins / xyzbc-trt-kins pins: the C axis's point,
/// the height where the tilt axis crosses it, and the tilt axis's offset.
fn linuxcnc_trt(out: &mut Vec<Raw>, m: &Machine, g: &Geometry, gn: &Geometry) {
    let t = m.tilt.letter;
    let pivot = m.pivot;
    // C turns about (x-rot-point, y-rot-point); the tilt axis runs
    // through (rot-point + offset).
    let point = |g: &Geometry| {
        let ct = g.c.nearest(&g.tilt.nearest(&pivot));
        (ct, g.tilt.nearest(&ct))
    };
    let ((ct, tp), (ctn, tpn)) = (point(g), point(gn));
    out.push(length("x-rot-point".into(), "C axis X".into(), ct.x, ctn.x));
    out.push(length("y-rot-point".into(), "C axis Y".into(), ct.y, ctn.y));
    out.push(length(
        "z-rot-point".into(),
        format!("Z where the {t} axis crosses C"),
        tp.z,
        tpn.z,
    ));
    let i = if t == 'A' { 1 } else { 0 };
    out.push(length(
        format!("{}-offset", ['x', 'y'][i]),
        format!("{t} axis {} minus C axis {}", XYZ[i], XYZ[i]),
        tp[i] - ct[i],
        tpn[i] - ctn[i],
    ));
    out.push(length(
        "z-offset".into(),
        "kept 0: the height is all in z-rot-point".into(),
        0.0,
        0.0,
    ));
}

fn trt_kins(m: &Machine) -> &'static str {
    match m.tilt.letter {
        'A' => "xyzac-trt-kins",
        _ => "xyzbc-trt-kins",
    }
}

/// The text of a finished export.
pub(super) fn render(m: &Machine, export: &Export, not_held: &[String], source: &str) -> String {
    let t = m.tilt.letter;
    let mut s = String::new();
    match export.dialect {
        Dialect::Fanuc => {
            s += &header(
                m,
                export,
                "fivecal: FANUC tool centre point control parameters (30i-class, manual A-79348E)",
                source,
                "#",
            );
            let (ty, what) = match m.structure {
                Structure::TableTable => {
                    ("12", format!("two table rotary axes, {t} master, C slave"))
                }
                Structure::HeadTable => ("21", format!("mixed: {t} head first, C table second")),
                Structure::HeadHead => ("2", format!("two tool rotary axes, C master, {t} slave")),
            };
            let _ = writeln!(
                s,
                "# expected, not written here: 19680 = {ty} ({what}), set by the machine builder"
            );
            if m.structure != Structure::TableTable {
                let _ = writeln!(
                    s,
                    "# expected: 19666 (tool holder offset) = {:.4}, the machine file's pivot length (gauge line to the head's axis);",
                    m.pivot_length
                );
                let _ = writeln!(
                    s,
                    "#   19709-19711 start at D, that far above the gauge point, and hold any error of that length"
                );
            }
            let _ = writeln!(s, "#");
            for p in export.parameters.iter().filter(|p| p.withheld.is_none()) {
                let _ = writeln!(s, "{} = {}", p.name, p.written(p.value));
            }
            let _ = writeln!(s, "#");
            let _ = writeln!(
                s,
                "# Not held by these parameters (positions only); rewrite programs with `fivecal compensate` for them:"
            );
            not_held_lines(&mut s, not_held, "#");
            s += &after_entering(m, export, "#");
        }
        Dialect::Heidenhain => {
            s += &header(
                m,
                export,
                "fivecal: HEIDENHAIN kinematics description, corrections of the Trans rows (iTNC 530 table format)",
                source,
                ";",
            );
            s += &format!(
                "; INCREMENTAL entries, never absolute: ADD each change to the COORD of the Trans row of that
;   axis letter in the stretch of the description named (insert one there if there is none).
;   The description runs from the tool reference point; the rows named are the ones before
;   MachAxis {t} and MachAxis C. Each change is from the value given as now (see change above):
;   if the table holds an earlier calibration the machine file does not list, the changes are wrong.
; Convention assumed (docs/controllers.md): a Trans row is the step from the element before it to the
;   element after it, in the order of the description, machine axes, everything at 0 [iTNC 530
;   technical manual pp. 670, 722: the sequence starts at the tool reference point; its example puts
;   the head's B axis 250.051 mm above the tool reference point with Trans Z +250.051].
;   Rows marked (table side) follow the same order, machine datum towards the table; no public source
;   shows a table-side row whose value fixes its direction: the machine builder must confirm that the
;   description runs from the machine base towards the table before they are entered.
;
"
            );
            for p in export
                .parameters
                .iter()
                .filter(|p| p.entered && p.withheld.is_none())
            {
                let table_side =
                    p.what.contains("machine datum") || m.structure == Structure::TableTable;
                let _ = writeln!(
                    s,
                    "ADD {} TO {}   ; {} now {}, new {}{}",
                    p.written(p.change()),
                    p.what,
                    p.name,
                    p.written(p.reference()),
                    p.written(p.value),
                    if table_side { " (table side)" } else { "" }
                );
            }
            s += ";
; Not written as rows: the axis directions, for the machine builder (a rotation entry of the
;   table; no public source consulted gives its sign convention, docs/controllers.md), urad,
;   the right-handed turn about the machine axis named that takes each nominal direction to the actual:
";
            listed_lines(&mut s, export, ";");
            let _ = writeln!(
                s,
                "; Not held by the kinematics; rewrite programs with `fivecal compensate` for them:"
            );
            not_held_lines(&mut s, not_held, ";");
            s += &after_entering(m, export, ";");
        }
        Dialect::Linuxcnc => {
            let kins = trt_kins(m);
            s += &header(
                m,
                export,
                &format!("fivecal: LinuxCNC {kins} pivot offsets (HAL pins)"),
                source,
                "#",
            );
            // trt-kins turns both table axes one way: R(+angle) by default,
            // R(-angle) with conventional-directions; the machine file's
            // direction 1 is R(-angle) for a table axis.
            match (m.tilt.direction > 0.0, m.c.direction > 0.0) {
                (true, true) => {
                    s += &format!(
                        "# directions: the machine file turns {t} and C by R(-angle) (direction 1), the conventional way;
#   trt-kins does so only with its conventional-directions pin set (below). A LinuxCNC without
#   that pin refuses the line: reverse both rotary joints there instead (negative scale).
setp {kins}.conventional-directions 1
"
                    );
                }
                (false, false) => {
                    s += &format!(
                        "# directions: the machine file turns {t} and C by R(+angle) (direction -1), trt-kins's default;
#   leave its conventional-directions pin (where it exists) at 0
"
                    );
                }
                _ => {
                    s += &format!(
                        "# directions: the machine file turns {t} by direction {} and C by direction {}; trt-kins turns
#   both the same way: reverse the joint of one of them (negative scale) so they agree
",
                        m.tilt.direction, m.c.direction
                    );
                }
            }
            for p in export.parameters.iter().filter(|p| p.withheld.is_none()) {
                let _ = writeln!(s, "setp {kins}.{} {}", p.name, p.written(p.value));
            }
            let _ = writeln!(s, "#");
            let _ = writeln!(
                s,
                "# trt-kins takes no orientation errors and no zero-point errors of the rotary axes; not held:"
            );
            not_held_lines(&mut s, not_held, "#");
            s += &after_entering(m, export, "#");
        }
        Dialect::Sinumerik => s += &super::sinumerik::render(m, export, not_held, source),
    }
    s
}
