//! 3+2 programs: moves in a tilted working plane (FANUC and LinuxCNC
//! G68.2 + G53.1, HEIDENHAIN PLANE and CYCL DEF 19, SINUMERIK CYCLE800)
//! are corrected in the plane so that the tool tip, on the machine with
//! the errors, lands where the program meant it; the plane definitions and
//! their rotary positions stay as written and the orientation error that
//! coordinates cannot correct is reported.

use std::path::Path;

use fivecal::Dialect;
use fivecal::compensate::simulate::{SimSettings, Simulator};
use fivecal::compensate::{Compensator, Coordinates, Settings};
use fivecal::model::Model;
use nalgebra::Vector3;

use crate::compensate::{assert_reaches, check_held, compensate, errors};

/// The fixture's text.
fn read(rel: &str) -> String {
    std::fs::read_to_string(crate::nc::fixture(rel)).unwrap()
}

/// End points of `program` on the nominal machine (no errors): line, tip, axis.
fn nominal_ends(
    machine: &str,
    d: Dialect,
    program: &str,
) -> Vec<(usize, Vector3<f64>, Vector3<f64>)> {
    let l = errors(machine, 0, 0.0, "");
    let model = Model::new(l.model.kin.clone(), vec![]);
    let sim = Simulator::new(&model, &[], SimSettings::new(d));
    let mut out = Vec::new();
    sim.run(Path::new("p"), program.as_bytes(), &mut |s| {
        if s.fraction == 1.0 {
            out.push((s.line, s.nominal.tip, s.nominal.axis));
        }
    })
    .unwrap();
    out
}

/// Lines whose text differs between two programs (1-based).
fn changed_lines(a: &str, b: &str) -> Vec<usize> {
    a.lines()
        .zip(b.lines())
        .enumerate()
        .filter(|(_, (x, y))| x != y)
        .map(|(i, _)| i + 1)
        .collect()
}

#[test]
fn a_3_plus_2_program_in_each_dialect_lands_on_the_intended_points() {
    // fixture, dialect, machine, the lines corrected in the plane.
    let cases: [(&str, Dialect, &str, &[usize]); 5] = [
        (
            "fanuc/tilted_plane.nc",
            Dialect::Fanuc,
            "bc-trunnion",
            &[15, 16, 17, 18, 19, 20, 21, 22, 23],
        ),
        (
            "heidenhain/plane_spatial.h",
            Dialect::Heidenhain,
            "ac-trunnion",
            &[8, 9, 10, 11, 13, 14, 15, 16],
        ),
        (
            "heidenhain/cycle19.h",
            Dialect::Heidenhain,
            "ac-trunnion",
            &[13, 14, 15, 16, 17, 18, 19, 20],
        ),
        (
            "linuxcnc/tilted_plane.ngc",
            Dialect::Linuxcnc,
            "head-table",
            &[10, 11, 12, 13, 14, 15, 16, 17],
        ),
        (
            "sinumerik/cycle800.mpf",
            Dialect::Sinumerik,
            "bc-trunnion",
            &[9, 10, 11, 12, 13, 14, 15, 16, 17],
        ),
    ];
    for (seed, (rel, d, m, lines)) in cases.into_iter().enumerate() {
        let program = read(rel);
        let zero = errors(m, 0, 0.0, "");
        let (out, s0, _) = compensate(&zero, Settings::new(d), &program);
        assert_eq!(out, program, "{rel}: zero error must give the same bytes");
        assert_eq!(s0.tilted_plane.first, lines, "{rel}: {:?}", s0.skipped);
        let l = errors(m, 70 + seed as u64, 30.0, "");
        let (out, s, vs) = compensate(&l, Settings::new(d), &program);
        assert_eq!(s.tilted_plane.first, lines, "{rel}: {:?}", s.skipped);
        // Every move in the plane is rewritten (the errors move the tip
        // by tens of um), and nothing else: the plane, its rotary
        // positions and the moves outside it stay as written.
        if s.inserted == 0 {
            assert_eq!(changed_lines(&out, &program), lines, "{rel}:\n{out}");
        } else {
            // A HEIDENHAIN circle gets a new pole block before it, and the
            // blocks after it are renumbered.
            assert!(s.changed >= lines.len(), "{rel}:\n{out}");
        }
        for def in program.lines().filter(|t| {
            [
                "G68.2", "G53.1", "G69", "PLANE", "CYCL DEF", "CYCLE800", "B0. C0.",
            ]
            .iter()
            .any(|k| t.contains(k))
        }) {
            assert!(
                out.lines()
                    .any(|o| o.ends_with(def.trim_start_matches(|c: char| c.is_ascii_digit()))),
                "{rel}: {def}\n{out}"
            );
        }
        // The orientation cannot be corrected by coordinates: what is left
        // is reported, never claimed corrected.
        assert!(
            s.tilted_plane_axis_error > 1.0 && s.tilted_plane_axis_error < 500.0,
            "{rel}: {} urad",
            s.tilted_plane_axis_error
        );
        let in_plane: Vec<_> = vs.iter().filter(|v| v.tilted_plane).collect();
        assert!(in_plane.len() >= lines.len(), "{rel}");
        for v in &vs {
            assert_reaches(&l, v, rel);
        }
        // Independently: the original on the nominal machine and the
        // rewrite on the erroneous one, through fivecal's simulator.
        check_held(&l, d, Coordinates::Auto, &program, &out, 0.001, lines, rel);
    }
}

#[test]
fn the_plane_frame_is_the_hand_computed_one() {
    // G68.2 X10 I0 J30 K0: the plane's origin at X10, turned 30 deg about
    // X. Its point (0, 10, 0) lies at (10, 10 cos 30, 10 sin 30) in the
    // workpiece, the tool along (0, -sin 30, cos 30).
    let fanuc = "G90 G21 G17\nG0 B30. C-90.\nG68.2 X10. Y0. Z0. I0. J30. K0.\nG53.1\nG43 H1\nG0 X0. Y10. Z0.\nG69\n";
    let ends = nominal_ends("bc-trunnion", Dialect::Fanuc, fanuc);
    let (line, tip, axis) = ends.last().copied().unwrap();
    assert_eq!(line, 6);
    let (s, c) = 30f64.to_radians().sin_cos();
    assert!(
        (tip - Vector3::new(10.0, 10.0 * c, 10.0 * s)).norm() < 1e-9,
        "{tip}"
    );
    assert!((axis - Vector3::new(0.0, -s, c)).norm() < 1e-9, "{axis}");
    // LinuxCNC's R turns the plane about the workpiece Z first: R90 puts
    // the plane's X along the workpiece Y, so X10 lies at (0, 10, 0).
    let linuxcnc =
        "G21 G90\nG0 B-30 C180\nG68.2 R90 I0 J30 K0\nG53.1\nG43\nG0 X10 Y0 Z0\nG69\nM2\n";
    let ends = nominal_ends("head-table", Dialect::Linuxcnc, linuxcnc);
    let (_, tip, _) = ends.last().copied().unwrap();
    assert!((tip - Vector3::new(0.0, 10.0, 0.0)).norm() < 1e-9, "{tip}");
}

#[test]
fn one_plane_defined_four_ways_gives_the_same_compensated_program() {
    // SPA+0 SPB+30 SPC+90 as spatial angles, as Euler angles, as its X
    // and Z axes and as three points: the same frame, so the same moves.
    let r = fivecal::nc::interp::plane::spatial(0.0, 30.0, 90.0);
    let [pr, nu, rot] = fivecal::post::euler_zxz(&r);
    let (x, z) = (r.column(0), r.column(2));
    let y = r.column(1);
    let forms = [
        "PLANE SPATIAL SPA+0 SPB+30 SPC+90 TURN MB MAX FMAX SEQ-".to_string(),
        format!("PLANE EULER EULPR{pr:+.9} EULNU{nu:+.9} EULROT{rot:+.9} TURN MB MAX FMAX SEQ-"),
        format!(
            "PLANE VECTOR BX{:+.9} BY{:+.9} BZ{:+.9} NX{:+.9} NY{:+.9} NZ{:+.9} TURN MB MAX FMAX SEQ-",
            x[0], x[1], x[2], z[0], z[1], z[2]
        ),
        format!(
            "PLANE POINTS P1X+0 P1Y+0 P1Z+0 P2X{:+.9} P2Y{:+.9} P2Z{:+.9} P3X{:+.9} P3Y{:+.9} P3Z{:+.9} TURN MB MAX FMAX SEQ-",
            20.0 * x[0],
            20.0 * x[1],
            20.0 * x[2],
            5.0 * y[0],
            5.0 * y[1],
            5.0 * y[2]
        ),
    ];
    let l = errors("ac-trunnion", 81, 30.0, "");
    let mut outs = Vec::new();
    for form in &forms {
        let program = format!(
            "0 BEGIN PGM P MM\n1 TOOL CALL 1 Z S5000\n2 {form}\n3 L X-10 Y-10 Z+20 R0 FMAX\n4 L Z-1 F300\n5 L X+25 F800\n6 L Y+15\n7 PLANE RESET STAY\n8 END PGM P MM\n"
        );
        let (out, s, _) = compensate(&l, Settings::new(Dialect::Heidenhain), &program);
        assert_eq!(
            s.tilted_plane.first,
            [4, 5, 6, 7],
            "{form}: {:?}",
            s.skipped
        );
        let moves: Vec<String> = out.lines().skip(3).map(String::from).collect();
        outs.push((
            moves,
            nominal_ends("ac-trunnion", Dialect::Heidenhain, &program),
        ));
    }
    for (k, (moves, ends)) in outs.iter().enumerate().skip(1) {
        assert_eq!(moves, &outs[0].0, "{}", forms[k]);
        for (a, b) in ends.iter().zip(&outs[0].1) {
            // The angles and vectors are written with 9 decimals.
            assert!(
                (a.1 - b.1).norm() < 1e-7 && (a.2 - b.2).norm() < 1e-8,
                "{}: {} {} {} {}",
                forms[k],
                a.1,
                b.1,
                a.2,
                b.2
            );
        }
    }
}

#[test]
fn a_plane_fivecal_does_not_model_is_reported_at_its_own_line() {
    let l = errors("ac-trunnion", 82, 30.0, "");
    // PLANE AXIAL without C: whether the control keeps C where it is or
    // takes it to 0 is not modelled.
    let program = "0 BEGIN PGM P MM\n1 TOOL CALL 1 Z S5000\n2 L X+0 Y+0 Z+50 A+0 C+0 R0 FMAX\n3 PLANE AXIAL A+20 TURN FMAX\n4 L X-10 Y-10 Z+20 R0 FMAX\n5 L Z-1 F300\n6 PLANE RESET TURN FMAX\n7 END PGM P MM\n";
    let (out, s, _) = compensate(&l, Settings::new(Dialect::Heidenhain), program);
    assert_eq!(changed_lines(&out, program), [3], "{out}");
    let (what, lines) = &s.unmodelled[0];
    assert!(
        what.contains("both of the machine's rotary axes") && lines.first == [4],
        "{what}"
    );
    let (why, lines) = &s.skipped[s.skipped.len() - 1];
    assert!(why.contains("line 4") && lines.first == [5, 6], "{why}");
    // --strict refuses it, naming the line and column.
    let mut strict = Settings::new(Dialect::Heidenhain);
    strict.strict = true;
    let c = Compensator::new(&l.model, &l.theta, strict);
    let err = c
        .run(Path::new("p.h"), program.as_bytes(), &mut Vec::new())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("p.h:4:") && err.contains("both of the machine's rotary axes"),
        "{err}"
    );
    // STAY: the rotary axes stay where they were (here not along the
    // plane), so the moves are left as written with the reason.
    let stay = program.replace(
        "PLANE AXIAL A+20 TURN FMAX",
        "PLANE SPATIAL SPA+20 SPB+0 SPC+0 STAY",
    );
    let (out, s, _) = compensate(&l, Settings::new(Dialect::Heidenhain), &stay);
    assert_eq!(changed_lines(&out, &stay), [3], "{out}");
    assert!(
        s.skipped
            .iter()
            .any(|(why, lines)| why.contains("do not put the tool along") && lines.first == [5, 6]),
        "{:?}",
        s.skipped
    );
    // FANUC G68.2 with a macro variable: not known statically.
    let fanuc = "G90 G21\nG0 B30. C-90.\nG68.2 X0. Y0. Z0. I0. J#1 K0.\nG53.1\nG43 H1\nG0 X0. Y10. Z5.\nG69\n";
    let f = errors("bc-trunnion", 83, 30.0, "");
    let (out, s, _) = compensate(&f, Settings::new(Dialect::Fanuc), fanuc);
    assert_eq!(out, fanuc);
    assert!(s.unmodelled[0].1.first == [3], "{:?}", s.unmodelled);
}

#[test]
fn heidenhain_q120_to_q122_are_the_positions_the_control_computed() {
    // After CYCL DEF 19 the TNC puts the rotary positions for the plane in
    // Q120..Q122; `L A+Q120 C+Q122` turns there. With the axes at A0 C0
    // before, the nearer of A-25 C0 and A+25 C180 is taken.
    let literal = read("heidenhain/cycle19.h");
    let q = literal
        .replace("11 L A-25 C+0 R0 FMAX", "11 L A+Q120 C+Q122 R0 FMAX")
        .replace("4  L Z+100 R0 FMAX M91", "4  L A+0 C+0 R0 FMAX");
    let l = errors("ac-trunnion", 84, 30.0, "");
    let (_, s, vs) = compensate(&l, Settings::new(Dialect::Heidenhain), &q);
    assert_eq!(
        s.tilted_plane.first,
        [13, 14, 15, 16, 17, 18, 19, 20],
        "{:?}",
        s.skipped
    );
    for v in &vs {
        assert_reaches(&l, v, "Q120..Q122");
    }
    // Without the positions before the plane both solutions are as near:
    // the moves are left as written, with the reason.
    let unknown = literal.replace("11 L A-25 C+0 R0 FMAX", "11 L A+Q120 C+Q122 R0 FMAX");
    let (out, s, _) = compensate(&l, Settings::new(Dialect::Heidenhain), &unknown);
    assert_eq!(out, unknown);
    assert!(
        s.skipped.iter().any(
            |(why, lines)| why.contains("rotary positions the controller chose")
                && lines.first.contains(&13)
        ),
        "{:?}",
        s.skipped
    );
}

/// Compensates `program` on `machine` with and without errors and checks
/// what every 3+2 test asserts: zero error gives the same bytes, the
/// moves in the planes are the `lines` corrected, and the rewrite driven
/// through the machine with the errors puts the tip where the original
/// puts it on the nominal machine. Returns the rewrite.
fn lands_on_the_path(
    machine: &str,
    d: Dialect,
    seed: u64,
    program: &str,
    lines: &[usize],
    what: &str,
) -> String {
    let zero = errors(machine, 0, 0.0, "");
    let (out, s0, _) = compensate(&zero, Settings::new(d), program);
    assert_eq!(out, program, "{what}: zero error must give the same bytes");
    assert_eq!(s0.tilted_plane.first, lines, "{what}: {:?}", s0.skipped);
    assert!(s0.unmodelled.is_empty(), "{what}: {:?}", s0.unmodelled);
    let l = errors(machine, seed, 30.0, "");
    let (out, s, vs) = compensate(&l, Settings::new(d), program);
    assert_eq!(s.tilted_plane.first, lines, "{what}: {:?}", s.skipped);
    assert_eq!(changed_lines(&out, program), lines, "{what}:\n{out}");
    for v in &vs {
        assert_reaches(&l, v, what);
    }
    check_held(&l, d, Coordinates::Auto, program, &out, 0.001, lines, what);
    out
}

#[test]
fn heidenhain_plane_projected_and_plane_axial_land_on_the_intended_points() {
    let program = "\
0  BEGIN PGM PROJ MM
1  BLK FORM 0.1 Z X-50 Y-50 Z-40
2  BLK FORM 0.2  X+50  Y+50  Z+0
3  TOOL CALL 5 Z S6000 F800
4  L Z+100 R0 FMAX M91
5  PLANE PROJECTED PROPR+15 PROMIN-20 ROT+10 TURN MB MAX FMAX SEQ-
6  L X-20 Y-10 Z+20 R0 FMAX M3
7  L Z+5 R0 FMAX
8  L Z-1 R0 F300
9  L X+20 R0 F800
10 L Y+10
11 L X-20
12 L Z+50 R0 FMAX
13 PLANE RESET TURN MB MAX FMAX
14 PLANE AXIAL A-25 C+40 TURN MB MAX FMAX
15 L X-20 Y-10 Z+20 R0 FMAX
16 L Z+5 R0 FMAX
17 L Z-1 R0 F300
18 L X+20 R0 F800
19 L Y+10
20 L Z+50 R0 FMAX
21 PLANE RESET TURN MB MAX FMAX
22 M30
23 END PGM PROJ MM
";
    let lines = [7, 8, 9, 10, 11, 12, 13, 16, 17, 18, 19, 20, 21];
    lands_on_the_path(
        "ac-trunnion",
        Dialect::Heidenhain,
        91,
        program,
        &lines,
        "PROJECTED/AXIAL",
    );
    // The frames by hand. PROJECTED: the plane's X is its trace in the ZX
    // plane, PROPR below X, turned ROT about the plane's normal
    // (tan PROPR, -tan PROMIN, 1); the tool lies along that normal.
    let ends = nominal_ends("ac-trunnion", Dialect::Heidenhain, program);
    let at = |line: usize| ends.iter().rev().find(|e| e.0 == line).copied().unwrap();
    let (a, b) = (15f64.to_radians(), (-20f64).to_radians());
    let n = Vector3::new(a.tan(), -b.tan(), 1.0).normalize();
    let x0 = Vector3::new(a.cos(), 0.0, -a.sin());
    let (s, c) = 10f64.to_radians().sin_cos();
    let x = c * x0 + s * n.cross(&x0);
    let (_, tip, axis) = at(10);
    // Line 10 is block 9: X+20 Y-10 Z-1 in the plane.
    assert!((axis - n).norm() < 1e-9, "{axis} {n}");
    assert!(
        (tip - (20.0 * x - 10.0 * n.cross(&x) - n)).norm() < 1e-9,
        "{tip}"
    );
    // AXIAL A-25 C+40: the tool along the machine's tool axis at those
    // positions, the plane's X and Y the machine's X and Y seen from the
    // table.
    let l = errors("ac-trunnion", 0, 0.0, "");
    let k = &l.model.kin;
    let pose = |x: f64, y: f64, z: f64| {
        k.forward_nominal(&fivecal::kinematics::Axes::new(x, y, z, -25.0, 40.0))
    };
    let o = pose(0.0, 0.0, 0.0);
    let (px, py) = (
        pose(1.0, 0.0, 0.0).tip - o.tip,
        pose(0.0, 1.0, 0.0).tip - o.tip,
    );
    let (_, tip, axis) = at(19);
    assert!((axis - o.axis).norm() < 1e-9, "{axis}");
    assert!(
        (tip - (20.0 * px - 10.0 * py - o.axis)).norm() < 1e-9,
        "{tip}"
    );
}

#[test]
fn sinumerik_additive_cycle800_is_composed_onto_the_plane_in_force() {
    // A 30 deg face (B about Y), then a further turn of 25 deg about its
    // own Z with the zero point moved 5 along the X that turn gives.
    let program = "\
%_N_ADD_MPF
N10 G17 G90 G710 G94
N20 T=\"MILL D10\" M6
N30 D1
N40 G54
N50 CYCLE800(1,\"TC1\",0,57,0,0,0,0,30,0,0,0,0,-1,100,1)
N60 CYCLE800(1,\"TC1\",1,57,0,0,0,0,0,25,5,0,0,-1,100,1)
N70 G0 X-20 Y-10 Z20
N80 Z5
N90 G1 Z-1 F300
N100 X20 F800
N110 Y10
N120 X-20
N130 G0 Z20
N140 CYCLE800()
N150 M30
";
    let lines = [8, 9, 10, 11, 12, 13, 14];
    lands_on_the_path(
        "bc-trunnion",
        Dialect::Sinumerik,
        92,
        program,
        &lines,
        "additive",
    );
    // By hand: R = Ry(30) Rz(25), the zero point 5 along the new X:
    // origin R (5, 0, 0).
    let ends = nominal_ends("bc-trunnion", Dialect::Sinumerik, program);
    let (_, tip, axis) = ends.iter().rev().find(|e| e.0 == 11).copied().unwrap();
    let r = rot(Vector3::y(), 30.0) * rot(Vector3::z(), 25.0);
    let origin = r * Vector3::new(5.0, 0.0, 0.0);
    assert!((axis - r * Vector3::z()).norm() < 1e-9, "{axis}");
    assert!(
        (tip - (origin + r * Vector3::new(20.0, -10.0, -1.0))).norm() < 1e-9,
        "{tip}"
    );
    // Additive on no plane is a new plane.
    let alone = program.replace(
        "N50 CYCLE800(1,\"TC1\",0,57,0,0,0,0,30,0,0,0,0,-1,100,1)\n",
        "",
    );
    let again = alone.replace(
        "CYCLE800(1,\"TC1\",1,57,0,0,0,0,0,25,5,0,0",
        "CYCLE800(1,\"TC1\",0,57,0,0,0,0,0,25,5,0,0",
    );
    let e1 = nominal_ends("bc-trunnion", Dialect::Sinumerik, &alone);
    let e2 = nominal_ends("bc-trunnion", Dialect::Sinumerik, &again);
    assert_eq!(e1, e2);
}

#[test]
fn linuxcnc_g68_2_by_points_and_by_vectors_is_the_same_plane_as_by_angles() {
    // The fixture's plane (I90 J35 K-90 about the origin (5, -3, 0)) given
    // three ways: Euler angles, three points at a right angle (P2) and
    // the X direction and normal (P3), over several blocks in any order.
    use fivecal::nc::interp::plane::about;
    let r = about(b'Z', 90.0) * about(b'X', 35.0) * about(b'Z', -90.0);
    let (x, y, z) = (r.column(0), r.column(1), r.column(2));
    let o = Vector3::new(5.0, -3.0, 0.0);
    let p = |v: Vector3<f64>| format!("X{:.12} Y{:.12} Z{:.12}", v[0], v[1], v[2]);
    let ijk = |v: Vector3<f64>| format!("I{:.12} J{:.12} K{:.12}", v[0], v[1], v[2]);
    let forms = [
        "G68.2 X5 Y-3 Z0 I90 J35 K-90".to_string(),
        format!(
            "G68.2 P2 Q1 {}\nG68.2 P2 Q3 {}\nG68.2 P2 Q0 X5 Y-3 Z0\nG68.2 P2 Q2 {}",
            p(o + 2.0 * x),
            p(o + 2.0 * x + 7.0 * y),
            p(o + 12.0 * x)
        ),
        format!(
            "G68.2 P3 Q1 {}\nG68.2 P3 X5 Y-3 Z0 {}",
            ijk(z.into_owned()),
            ijk(o + 10.0 * x)
        ),
    ];
    let mut outs = Vec::new();
    for (k, form) in forms.iter().enumerate() {
        let program = format!(
            "G21 G90 G17 G94 G40 G49\nG54\nT2 M6\nS6000 M3\nG0 B-35 C180\n{form}\nG53.1\nG43 H2\nG0 X-15 Y-10 Z20\nG0 Z5\nG1 Z-0.5 F200\nG1 X15 F600\nG1 Y10\nG1 X-15\nG0 Z20\nG69\nG49\nG0 B0 C0\nM5\nM2\n"
        );
        let n = form.lines().count();
        let lines: Vec<usize> = (9..=15).map(|l| l + n - 1).collect();
        let out = lands_on_the_path("head-table", Dialect::Linuxcnc, 93, &program, &lines, form);
        outs.push((
            out.lines()
                .skip(6 + n)
                .map(String::from)
                .collect::<Vec<_>>(),
            nominal_ends("head-table", Dialect::Linuxcnc, &program),
        ));
        if k == 0 {
            continue;
        }
        assert_eq!(outs[k].0, outs[0].0, "{form}");
        for (a, b) in outs[k].1.iter().zip(&outs[0].1).skip(1) {
            assert!(
                (a.1 - b.1).norm() < 1e-9 && (a.2 - b.2).norm() < 1e-9,
                "{form}"
            );
        }
    }
    // A plane not yet complete is no plane: with Q2 missing the moves
    // run in the workpiece frame, and the definition is reported nowhere.
    let partial = forms[1].lines().take(3).collect::<Vec<_>>().join("\n");
    let program = format!("G21 G90\nG0 B-35 C180\n{partial}\nG43 H2\nG0 X-15 Y-10 Z20\nM2\n");
    let zero = errors("head-table", 0, 0.0, "");
    let (_, s, _) = compensate(&zero, Settings::new(Dialect::Linuxcnc), &program);
    assert!(s.tilted_plane.first.is_empty() && s.unmodelled.is_empty());
    // Points not at a right angle: the remap's frame is no rotation, left
    // as written with the reason.
    let skew = forms[1].replace(&p(o + 2.0 * x + 7.0 * y), &p(o + 5.0 * x + 7.0 * y));
    let program =
        format!("G21 G90\nG0 B-35 C180\n{skew}\nG53.1\nG43 H2\nG0 X-15 Y-10 Z20\nG69\nM2\n");
    let l = errors("head-table", 94, 30.0, "");
    let (out, s, _) = compensate(&l, Settings::new(Dialect::Linuxcnc), &program);
    assert_eq!(out, program);
    assert!(
        s.unmodelled.iter().any(|(w, _)| w.contains("right angle")),
        "{:?}",
        s.unmodelled
    );
}

/// Rotation by `deg` degrees about `axis` (right hand).
fn rot(axis: Vector3<f64>, deg: f64) -> nalgebra::Matrix3<f64> {
    nalgebra::Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(axis), deg.to_radians())
        .into_inner()
}

/// A SINUMERIK program with programmable frames on the B/C trunnion: at
/// zero errors it comes back byte for byte with nothing left or noted;
/// with the errors of `seed` exactly the `moves` lines change, each
/// corrected pose and the rewritten program driven through the erroneous
/// machine reach the intended points and path. Returns the zero-error
/// model for the hand computations.
fn sinumerik_frames_corrected(
    program: &str,
    seed: u64,
    moves: &[usize],
    what: &str,
) -> fivecal::errorfile::LoadedErrors {
    let zero = errors("bc-trunnion", 0, 0.0, "");
    let (out, s0, _) = compensate(&zero, Settings::new(Dialect::Sinumerik), program);
    assert_eq!(out, program, "zero error must give the same bytes");
    assert!(s0.skipped.is_empty(), "{:?}", s0.skipped);
    assert!(s0.unmodelled.is_empty(), "{:?}", s0.unmodelled);
    let l = errors("bc-trunnion", seed, 30.0, "");
    let (out, s, vs) = compensate(&l, Settings::new(Dialect::Sinumerik), program);
    assert!(s.skipped.is_empty(), "{:?}", s.skipped);
    assert_eq!(changed_lines(&out, program), moves, "{out}");
    assert!(vs.len() >= moves.len());
    for v in &vs {
        assert_reaches(&l, v, what);
    }
    check_held(
        &l,
        Dialect::Sinumerik,
        Coordinates::Auto,
        program,
        &out,
        0.001,
        &[],
        what,
    );
    zero
}

#[test]
fn sinumerik_rot_and_arot_frames_land_on_the_intended_points() {
    // A programmable frame built up step by step (TRANS, AROT about Z,
    // ATRANS along the turned X, AROT about the turned X) with a line and
    // a CR= arc in it, then ROT RPL= replacing it, with axis positions and
    // under TRAORI; the rotary axes stay where N50 put them.
    let program = "\
%_N_ROT_MPF
N10 G17 G90 G710 G94
N20 T=\"MILL D10\" M6
N30 D1
N40 G54
N50 G0 X0 Y0 Z60 B20 C10
N60 TRANS X10 Y-5
N70 AROT Z30
N80 G1 X20 Y0 Z5 F500
N90 ATRANS X5
N100 AROT X10
N110 G1 X20 Y10 Z2
N120 G2 X30 Y0 CR=10
N130 G0 Z40
N140 ROT RPL=-45
N150 G1 X15 Y5 Z3
N160 TRAORI
N170 G1 X10 Y5 Z3 B25 C15
N180 X12 Y6 Z4 B30 C20
N190 TRAFOOF
N200 ROT
N210 G0 X0 Y0 Z60
N220 M30
";
    let moves = [6, 9, 12, 13, 14, 16, 18, 19, 22];
    let zero = sinumerik_frames_corrected(program, 93, &moves, "ROT/AROT");
    // The frames by hand, on the nominal machine: the axes at
    // T(10, -5, 0) Rz(30) (T(5, 0, 0) Rx(10) p) for line 12, Rz(-45) p for
    // line 16 (ROT replaced TRANS), and under TRAORI the tip in W is
    // Rz(-45) p.
    let ends = nominal_ends("bc-trunnion", Dialect::Sinumerik, program);
    let at = |line: usize| ends.iter().rev().find(|e| e.0 == line).copied().unwrap();
    let k = &zero.model.kin;
    let tip = |p: Vector3<f64>, b: f64, c: f64| {
        k.forward_nominal(&fivecal::kinematics::Axes::new(p.x, p.y, p.z, b, c))
            .tip
    };
    let a12 = Vector3::new(10.0, -5.0, 0.0)
        + rot(Vector3::z(), 30.0)
            * (Vector3::new(5.0, 0.0, 0.0)
                + rot(Vector3::x(), 10.0) * Vector3::new(20.0, 10.0, 2.0));
    assert!(
        (at(12).1 - tip(a12, 20.0, 10.0)).norm() < 1e-9,
        "{}",
        at(12).1
    );
    let a16 = rot(Vector3::z(), -45.0) * Vector3::new(15.0, 5.0, 3.0);
    assert!(
        (at(16).1 - tip(a16, 20.0, 10.0)).norm() < 1e-9,
        "{}",
        at(16).1
    );
    let w19 = rot(Vector3::z(), -45.0) * Vector3::new(12.0, 6.0, 4.0);
    assert!((at(19).1 - w19).norm() < 1e-9, "{}", at(19).1);
}

#[test]
fn sinumerik_traori_inside_a_swivel_plane_is_left_as_written_with_the_reason() {
    // CYCLE800 then TRAORI with rotary positions and with a tool vector:
    // the swivel frame would turn both the tip and the orientation, which
    // fivecal does not model; those moves are kept byte for byte and
    // named, and the 3+2 move before them is corrected.
    let program = "\
N10 G17 G90 G710
N20 T=\"MILL D10\" M6
N30 D1
N40 G54
N50 CYCLE800(1,\"TC1\",0,57,0,0,0,0,30,0,0,0,0,-1,100,1)
N60 G0 X-20 Y-10 Z20
N70 TRAORI
N80 G1 X10 Y0 Z5 F500
N90 X12 A3=0 B3=0.2 C3=1
N100 X14 B20 C10
N110 TRAFOOF
N120 G0 X-20 Y-10 Z20
N130 CYCLE800()
N140 M30
";
    let l = errors("bc-trunnion", 94, 30.0, "");
    let (out, s, _) = compensate(&l, Settings::new(Dialect::Sinumerik), program);
    assert_eq!(changed_lines(&out, program), [6], "{out}");
    let left: Vec<(String, String)> = s
        .skipped
        .iter()
        .map(|(why, lines)| (why.text.clone(), lines.list()))
        .collect();
    assert!(
        left.iter().any(|(why, lines)| why
            .contains("tool centre point control inside a tilted working plane")
            && lines == "8, 9, 10"),
        "{left:?}"
    );
    // N100 left the rotary axes off the plane: its moves after TRAFOOF
    // are not 3+2 moves any more, and are said to be so.
    assert!(
        left.iter()
            .any(|(why, lines)| why.contains("rotary positions") && lines == "12"),
        "{left:?}"
    );
}

#[test]
fn sinumerik_solid_angles_plane_rotations_and_turned_tool_vectors_land_on_the_intended_points() {
    // ROTS by two solid angles (X, Y), AROTS by the pair (Z, X) on top of
    // it, ROT RPL= in G18 replacing them and AROT RPL= in G19 adding to
    // that, then TRAORI with tool vectors written in the turned frame.
    let program = "\
%_N_SOLID_MPF
N10 G17 G90 G710 G94
N20 T=\"MILL D10\" M6
N30 D1
N40 G54
N50 G0 X0 Y0 Z60 B20 C10
N60 ROTS X10 Y20
N70 G1 X20 Y5 Z5 F500
N80 G2 X30 Y-5 CR=10
N90 AROTS Z15 X-10
N100 G1 X25 Y8 Z4
N110 G0 Z40
N120 G18
N130 ROT RPL=25
N140 G1 X10 Y-5 Z12
N150 G19
N160 AROT RPL=-15
N170 G1 X12 Y-4 Z10
N180 G17
N190 TRAORI
N200 G1 X10 Y5 Z3 A3=0.1 B3=0.2 C3=1
N210 X12 Y6 Z4 A3=-0.1 B3=0.15 C3=1
N220 TRAFOOF
N230 ROT
N240 G0 X0 Y0 Z60
N250 M30
";
    let moves = [6, 8, 9, 11, 12, 15, 18, 21, 22, 25];
    let zero = sinumerik_frames_corrected(program, 95, &moves, "ROTS/RPL");
    // The frames by hand on the nominal machine. ROTS X10 Y20: the plane
    // through its traces, X turned 20 deg about Y in ZX and Y turned
    // 10 deg about X in YZ, its X along the first.
    let traces = |first: Vector3<f64>, second: Vector3<f64>, f: f64, s: f64| {
        // The turned first and third axes, the second completing them.
        let t1 = rot(second, s) * first;
        let t2 = rot(first, f) * second;
        let n = t1.cross(&t2).normalize();
        (t1, n.cross(&t1), n)
    };
    let (x, y, z) = traces(Vector3::x(), Vector3::y(), 10.0, 20.0);
    let r1 = nalgebra::Matrix3::from_columns(&[x, y, z]);
    // AROTS Z15 X-10: the pair (Z, X) of G18, Z turned -10 deg about X in
    // YZ, X turned 15 deg about Z in XY; the new Z, Y and X.
    let (zz, xx, yy) = traces(Vector3::z(), Vector3::x(), 15.0, -10.0);
    let r2 = nalgebra::Matrix3::from_columns(&[xx, yy, zz]);
    let ends = nominal_ends("bc-trunnion", Dialect::Sinumerik, program);
    let at = |line: usize| ends.iter().rev().find(|e| e.0 == line).copied().unwrap();
    let k = &zero.model.kin;
    let tip = |p: Vector3<f64>| {
        k.forward_nominal(&fivecal::kinematics::Axes::new(p.x, p.y, p.z, 20.0, 10.0))
            .tip
    };
    for (line, frame, p) in [
        (8, r1, Vector3::new(20.0, 5.0, 5.0)),
        (11, r1 * r2, Vector3::new(25.0, 8.0, 4.0)),
        // RPL= in G18 about Y, then in G19 about the turned X.
        (15, rot(Vector3::y(), 25.0), Vector3::new(10.0, -5.0, 12.0)),
        (
            18,
            rot(Vector3::y(), 25.0) * rot(Vector3::x(), -15.0),
            Vector3::new(12.0, -4.0, 10.0),
        ),
    ] {
        let want = tip(frame * p);
        assert!(
            (at(line).1 - want).norm() < 1e-9,
            "line {line}: {}",
            at(line).1
        );
    }
    // Under TRAORI the written vector is in the turned frame: the tool
    // axis in W is R v.
    let r = rot(Vector3::y(), 25.0) * rot(Vector3::x(), -15.0);
    for (line, p, v) in [
        (
            21,
            Vector3::new(10.0, 5.0, 3.0),
            Vector3::new(0.1, 0.2, 1.0),
        ),
        (
            22,
            Vector3::new(12.0, 6.0, 4.0),
            Vector3::new(-0.1, 0.15, 1.0),
        ),
    ] {
        assert!((at(line).1 - r * p).norm() < 1e-9, "line {line}");
        assert!(
            (at(line).2 - (r * v).normalize()).norm() < 1e-9,
            "line {line}"
        );
    }
}

#[test]
fn g68_4_puts_its_plane_on_the_plane_in_force() {
    // G68.2 I90 turns the plane 90 deg about Z with its origin at X10; on
    // it G68.4 X5 J30 tilts 30 deg about the plane's X with the origin
    // 5 mm along the plane's X (the workpiece Y): the plane G68.2 X10 Y5
    // I90 J30 gives at once.
    let head = "G90 G21 G17\nG0 B30. C-90.\n";
    let tail = "G53.1\nG43 H1\nG0 X0. Y10. Z0.\nG0 X5. Y0. Z2.\nG69\n";
    let incremental =
        format!("{head}G68.2 X10. Y0. Z0. I90. J0. K0.\nG68.4 X5. Y0. Z0. I0. J30. K0.\n{tail}");
    let direct = format!("{head}G68.2 X10. Y5. Z0. I90. J30. K0.\n{tail}");
    let a = nominal_ends("bc-trunnion", Dialect::Fanuc, &incremental);
    let b = nominal_ends("bc-trunnion", Dialect::Fanuc, &direct);
    assert_eq!(a.len(), b.len());
    assert!(a.len() >= 2, "{a:?}");
    for (p, q) in a.iter().zip(&b) {
        assert!(
            (p.1 - q.1).norm() < 1e-9 && (p.2 - q.2).norm() < 1e-9,
            "{p:?} {q:?}"
        );
    }
}

#[test]
fn g68_4_without_a_plane_g68_3_and_g53_6_are_refused_with_their_kind() {
    let l = errors("bc-trunnion", 3, 10.0, "");
    for (d, program, why) in [
        (
            Dialect::Fanuc,
            "G90 G21 G17\nG0 B0. C0.\nG68.4 X5. Y0. Z0. I0. J30. K0.\nG53.1\nG0 X0. Y10. Z0.\n",
            "the file does not say which",
        ),
        (
            Dialect::Linuxcnc,
            "G90 G21 G17\nG0 B0 C0\nG68.3 X0 Y0 Z0\nG0 X0 Y10 Z0\n",
            "not implemented yet",
        ),
        (
            Dialect::Linuxcnc,
            "G90 G21 G17\nG0 B0 C0\nG68.2 X0 Y0 Z0 I0 J30 K0\nG53.6\nG0 X0 Y10 Z0\n",
            "not implemented yet",
        ),
    ] {
        let (out, s, _) = compensate(&l, Settings::new(d), program);
        let last = program.lines().last().unwrap();
        assert_eq!(out.lines().last(), Some(last), "{program}\n{out}");
        let notes = format!("{:?}", s);
        assert!(notes.contains(why), "{program}: {notes}");
    }
}
