//! The SINUMERIK export: the rotary axis lines as the swivel data record
//! of an orientable toolholder (`$TC_CARR..[n]`), written into its fine
//! offset fields so that the coarse values stay and zeroing the fine fields
//! undoes the change. docs/controllers.md gives every field's meaning and
//! its public source.
//!
//! The record describes the machine as a vector chain in machine
//! coordinates, unswivelled: offset vectors l1..l4 between the tool adapter
//! (the spindle gauge point), the pivots of rotary axis 1 and 2 and the
//! machine reference point, and the directions v1, v2 the axes turn about
//! (right-handed, of whatever side they carry; axis 2 is carried by axis
//! 1). The kinematic type follows from the machine's structure: `P` (the
//! part rotates) for a table-table machine with the tilt as axis 1, `T`
//! (the tool rotates) for a head-head one with C as axis 1, `M` (mixed)
//! for a head-table one with the head as axis 1. The export closes every
//! chain, so the record changes nothing at rotary zero.
//!
//! A pivot may lie anywhere on its axis line: the component of an offset
//! vector along an axis's own direction is what CYCLE996 calls a free
//! component and no test sees; it keeps its nominal value and is not
//! written. The directions have no fine fields: they are listed, with
//! their values, for the machine builder and for comparison with CYCLE996,
//! never written.

use std::fmt::Write as _;

use nalgebra::Vector3;

use super::{
    Export, ExportError, Geometry, Kind, Raw, header, listed_lines, not_held_lines, signed,
};
use crate::kinematics::Kinematics;
use crate::machine::{Machine, RotaryAxis, Structure};

/// The offset vectors l1..l4 and the axis directions v1, v2 of a swivel
/// data record, machine coordinates, mm (directions unit length).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct SwivelRecord {
    pub l: [Vector3<f64>; 4],
    pub v: [Vector3<f64>; 2],
}

/// The first coarse field of l1..l4 and of v1, v2.
const L_COARSE: [u32; 4] = [1, 4, 15, 18];
const V_COARSE: [u32; 2] = [7, 10];
/// The first fine field of l1..l4.
const L_FINE: [u32; 4] = [41, 44, 55, 58];

const XYZ: [char; 3] = ['X', 'Y', 'Z'];

/// `P`, `T` or `M` for the machine's structure.
fn kinematic_type(s: Structure) -> char {
    match s {
        Structure::TableTable => 'P',
        Structure::HeadHead => 'T',
        Structure::HeadTable => 'M',
    }
}

/// Rotary axis 1 and 2 of the record: the carrying axis first, the head's
/// axis first on a mixed machine.
fn record_axes(m: &Machine) -> [&RotaryAxis; 2] {
    match m.structure {
        Structure::TableTable | Structure::HeadTable => [&m.tilt, &m.c],
        Structure::HeadHead => [&m.c, &m.tilt],
    }
}

/// The sign taking an axis line's direction to the record's: the record
/// turns what the axis carries right-handed about v by the axis position;
/// the machine file turns a table by `R(-direction * angle)` and a head by
/// `R(+direction * angle)` (docs/model.md).
fn sense(a: &RotaryAxis) -> f64 {
    if a.on_table {
        -a.direction
    } else {
        a.direction
    }
}

/// What each offset vector runs between, and the machine axis (0, 1, 2)
/// along which it is free (the axis line its end lies on runs that way),
/// for the vectors a structure uses.
fn stretches(m: &Machine) -> Vec<(usize, String, Option<usize>)> {
    let t = m.tilt.letter;
    let it = m.tilt.about.index();
    match m.structure {
        Structure::TableTable => vec![
            (
                1,
                format!("machine reference -> axis 1 ({t}) pivot"),
                Some(it),
            ),
            (
                2,
                format!("axis 1 ({t}) pivot -> axis 2 (C) pivot"),
                Some(2),
            ),
            (3, "axis 2 (C) pivot -> machine reference".into(), None),
        ],
        Structure::HeadHead => vec![
            (0, "axis 1 (C) pivot -> tool adapter".into(), None),
            (
                1,
                format!("axis 2 ({t}) pivot -> axis 1 (C) pivot"),
                Some(2),
            ),
            (2, format!("tool adapter -> axis 2 ({t}) pivot"), Some(it)),
        ],
        Structure::HeadTable => vec![
            (0, format!("axis 1 ({t} head) pivot -> tool adapter"), None),
            (
                1,
                format!("tool adapter -> axis 1 ({t} head) pivot"),
                Some(it),
            ),
            (
                2,
                "machine reference -> axis 2 (C table) pivot".into(),
                Some(2),
            ),
            (
                3,
                "axis 2 (C table) pivot -> machine reference".into(),
                None,
            ),
        ],
    }
}

/// The record of the axis lines `g`, the pivots placed where the nominal
/// lines `gn` have them along each axis's own direction (the free
/// components keep their nominal values exactly).
pub(super) fn record(m: &Machine, g: &Geometry, gn: &Geometry) -> SwivelRecord {
    let it = m.tilt.about.index();
    let (tilt, c) = (sense(&m.tilt), sense(&m.c));
    let z = Vector3::zeros();
    match m.structure {
        Structure::TableTable => {
            let (p1n, p2n) = gn.tilt.common_perpendicular(&gn.c, &m.pivot);
            let p1 = g.tilt.at(it, p1n[it]);
            let p2 = g.c.at(2, p1.z + (p2n - p1n).z);
            SwivelRecord {
                l: [z, p1, p2 - p1, -p2],
                v: [tilt * g.tilt.dir, c * g.c.dir],
            }
        }
        Structure::HeadHead => {
            let (ga, gan) = (g.gauge, gn.gauge);
            let p2n = gn.tilt.nearest(&(gan + m.pivot_length * Vector3::z()));
            let p1n = gn.c.nearest(&p2n);
            let p2 = g.tilt.at(it, ga[it] + (p2n - gan)[it]);
            let p1 = g.c.at(2, p2.z + (p1n - p2n).z);
            SwivelRecord {
                l: [ga - p1, p1 - p2, p2 - ga, z],
                v: [c * g.c.dir, tilt * g.tilt.dir],
            }
        }
        Structure::HeadTable => {
            let (ga, gan) = (g.gauge, gn.gauge);
            let p1n = gn.tilt.nearest(&(gan + m.pivot_length * Vector3::z()));
            let p2n = gn.c.nearest(&m.pivot);
            let p1 = g.tilt.at(it, ga[it] + (p1n - gan)[it]);
            let p2 = g.c.at(2, p2n.z);
            SwivelRecord {
                l: [ga - p1, p1 - ga, p2, -p2],
                v: [tilt * g.tilt.dir, c * g.c.dir],
            }
        }
    }
}

/// The fine offsets of the record for the lines `g` (their nominal values
/// 0), then the directions' components across each axis, listed (urad).
pub(super) fn parameters(
    kin: &Kinematics,
    g: &Geometry,
    gn: &Geometry,
) -> Result<Vec<Raw>, ExportError> {
    let m = kin.machine();
    record_number(m)?;
    let (r, rn) = (record(m, g, gn), record(m, gn, gn));
    let mut out = Vec::new();
    for (k, what, free) in stretches(m) {
        for i in (0..3).filter(|&i| Some(i) != free) {
            out.push(Raw {
                name: format!("$TC_CARR{}", L_FINE[k] + i as u32),
                what: format!("fine l{} {}: {what}", k + 1, XYZ[i]),
                kind: Kind::Length,
                value: r.l[k][i] - rn.l[k][i],
                nominal: 0.0,
                entered: true,
            });
        }
    }
    out.sort_by_key(|p| field(&p.name));
    for (j, a) in record_axes(m).into_iter().enumerate() {
        let along = if a.letter == 'C' { 2 } else { a.about.index() };
        for i in (0..3).filter(|&i| i != along) {
            out.push(Raw {
                name: format!("$TC_CARR{}", V_COARSE[j] + i as u32),
                what: format!(
                    "v{} {}: direction of axis {} ({}), across it",
                    j + 1,
                    XYZ[i],
                    j + 1,
                    a.letter
                ),
                kind: Kind::Angle,
                value: r.v[j][i] * 1e6,
                nominal: rn.v[j][i] * 1e6,
                entered: false,
            });
        }
    }
    Ok(out)
}

fn field(name: &str) -> u32 {
    name.trim_start_matches("$TC_CARR").parse().unwrap_or(0)
}

/// The record number from the machine file, or why there is none.
fn record_number(m: &Machine) -> Result<u32, ExportError> {
    m.sinumerik.map(|s| s.swivel_record).ok_or_else(|| {
        ExportError::Unsupported(format!(
            "--export sinumerik: the machine file of {} does not say which swivel data record holds its kinematics: add `sinumerik: {{swivel_record: N}}` (N as in TCARR=N, the record CYCLE800 and CYCLE996 use); nothing written",
            m.name
        ))
    })
}

/// `v` with `decimals` decimals as a SINUMERIK value: a sign only when
/// negative, never `-0.0`.
fn number(v: f64, decimals: usize) -> String {
    signed(v, decimals).trim_start_matches('+').to_string()
}

/// The tilt of the tool axis at rotary zero from Z, urad about X and Y,
/// when it is visible at the resolution written: the record takes the tool
/// along Z unswivelled, so it holds none of it.
pub(super) fn tool_tilt(g: &Geometry) -> Option<String> {
    let t = Vector3::z().cross(&g.spindle.dir) * 1e6;
    (t.x.abs() >= 0.005 || t.y.abs() >= 0.005).then(|| {
        format!(
            "the tool axis at rotary zero, turned {} urad about X and {} urad about Y from Z (the orientation errors of the head's lines and of the spindle): the swivel data record takes the tool along Z unswivelled",
            signed(t.x, 2),
            signed(t.y, 2)
        )
    })
}

/// The part program of a finished export.
pub(super) fn render(m: &Machine, export: &Export, not_held: &[String], source: &str) -> String {
    let Ok(n) = record_number(m) else {
        // `parameters` refused the export before anything is rendered.
        return String::new();
    };
    let ty = kinematic_type(m.structure);
    let [a1, a2] = record_axes(m);
    let mut s = header(
        m,
        export,
        &format!(
            "fivecal: SINUMERIK swivel data record {n} ($TC_CARR..[{n}], type {ty}), fine offsets: a part program to run once"
        ),
        source,
        ";",
    );
    let gn = super::geometry(
        &Kinematics::new(m),
        &crate::kinematics::Perturbation::zero(),
    );
    let rn = record(m, &gn, &gn);
    let vec = |v: &Vector3<f64>, d| {
        format!(
            "({}, {}, {})",
            number(v.x, d),
            number(v.y, d),
            number(v.z, d)
        )
    };
    let _ = writeln!(
        s,
        "; It writes only fine offset fields: the coarse values stay, and setting each field below to 0 undoes it.
; The fine offsets act only with SD42974 $SC_TOCARR_FINE_CORRECTION = TRUE; MD20188/MD20190 limit their size.
; CYCLE996 measures and writes this record: compare its offset vectors (coarse plus fine) and v1, v2
;   with these, its free components (SD55645) with the ones kept below (docs/controllers.md).
; Expected, not written here (the machine file's nominal geometry, its machine coordinates; a record
;   whose machine reference point lies elsewhere differs by a constant in l2 and l4, the fine values do not):
;   $TC_CARR23[{n}]=\"{ty}\" ({}), axis 1 = {} ($TC_CARR21), axis 2 = {} ($TC_CARR22)",
        match ty {
            'P' => "the part rotates",
            'T' => "the tool rotates",
            _ => "mixed: the tool's axis first",
        },
        a1.letter,
        a2.letter
    );
    for (k, what, _) in stretches(m) {
        let f = L_COARSE[k];
        let _ = writeln!(
            s,
            ";   l{} ($TC_CARR{f}..{}) = {}  {what}",
            k + 1,
            f + 2,
            vec(&rn.l[k], 4)
        );
    }
    for (j, (&f, v)) in V_COARSE.iter().zip(&rn.v).enumerate() {
        let _ = writeln!(s, ";   v{} ($TC_CARR{f}..{}) = {}", j + 1, f + 2, vec(v, 1));
    }
    let _ = writeln!(s, ";");
    for p in export.parameters.iter().filter(|p| p.entered) {
        let _ = writeln!(s, "{}[{n}]={} ; {}", p.name, number(p.value, 5), p.what);
    }
    let _ = writeln!(s, ";");
    let _ = writeln!(
        s,
        "; Free components, not written (along an axis's own direction: no test sees them; CYCLE996 calls them free components):"
    );
    for (k, what, free) in stretches(m) {
        if let Some(i) = free {
            let _ = writeln!(
                s,
                ";   $TC_CARR{}[{n}] (fine l{} {}: {what})",
                L_FINE[k] + i as u32,
                k + 1,
                XYZ[i]
            );
        }
    }
    let _ = writeln!(
        s,
        "; Not written: the axis directions (coarse fields; the record has no fine ones), for the machine builder
;   and to compare with CYCLE996, each the full vector with the errors (8 decimals: 0.01 urad), then the
;   components across each axis (the vector's component times 10^6, urad):"
    );
    let listed: Vec<_> = export.parameters.iter().filter(|p| !p.entered).collect();
    for (j, (&f, vn)) in V_COARSE.iter().zip(&rn.v).enumerate() {
        // The components across the axis as listed, the one along it
        // nominal (a direction's length does not matter).
        let mut v = *vn;
        for p in &listed {
            let i = field(&p.name);
            if (f..f + 3).contains(&i) {
                v[(i - f) as usize] = p.value * 1e-6;
            }
        }
        let _ = writeln!(
            s,
            ";   v{}: $TC_CARR{f}[{n}]={} $TC_CARR{}[{n}]={} $TC_CARR{}[{n}]={}",
            j + 1,
            number(v.x, 8),
            f + 1,
            number(v.y, 8),
            f + 2,
            number(v.z, 8)
        );
    }
    listed_lines(&mut s, export, ";");
    let _ = writeln!(
        s,
        "; Not held by the swivel data record; rewrite programs with `fivecal compensate` for them:"
    );
    not_held_lines(&mut s, not_held, ";");
    s += "M30\n";
    s
}
