use super::*;
use crate::nc::Syntax;
pub(super) fn run(src: &str, d: Dialect) -> (Vec<Event>, Interpreter) {
    let kin = Kinematics::new(&crate::machine::Machine::builtin("bc-trunnion").unwrap());
    let mut m = Interpreter::new(&InterpreterSettings::new(d), &kin);
    let syn = Syntax {
        dialect: d,
        strict: false,
    };
    let mut out = Vec::new();
    let mut r = crate::nc::BlockReader::new(src.as_bytes(), d);
    let mut b = Block::default();
    while r.read(&mut b).unwrap() {
        syn.parse(&mut b).unwrap();
        for seg in b.segments.clone() {
            out.push(m.step(&b, &seg));
        }
    }
    (out, m)
}

fn mv(e: &Event) -> &Move {
    match e {
        Event::Move(m) => m,
        other => panic!("not a move: {other:?}"),
    }
}

#[test]
fn tracks_units_distance_motion_feed_and_offsets() {
    let (ev, m) = run(
        "G20 G91 G93 G55 G18\nG0 X1. Y2. Z3. B0 C0\nG1 X1. F2.\n",
        Dialect::Fanuc,
    );
    assert_eq!(m.units, Units::Inch);
    assert!(!m.absolute);
    assert_eq!(m.feed_mode, FeedMode::InverseTime);
    assert_eq!(m.work_offset, 550);
    assert_eq!(m.plane, ArcPlane::Zx);
    assert_eq!(m.motion, Some(Motion::Linear));
    // Incremental from unknown positions: nothing known yet.
    assert_eq!(mv(&ev[1]).end, [None; 6]);
    assert_eq!(mv(&ev[2]).end, [None; 6]);
}

#[test]
fn absolute_moves_fill_modal_axes() {
    let (ev, _) = run(
        "G90 G0 X1. Y2. Z3. B10. C20.\nG1 X5. F100.\n",
        Dialect::Fanuc,
    );
    let m = mv(&ev[1]);
    assert_eq!(
        m.start,
        [
            Some(1.0),
            Some(2.0),
            Some(3.0),
            None,
            Some(10.0),
            Some(20.0)
        ]
    );
    assert_eq!(m.end[0], Some(5.0));
    assert_eq!(m.end[4], Some(10.0));
    assert_eq!(m.feed.map(|f| f.1), Some(100.0));
}

#[test]
fn tcp_and_tilted_plane_and_machine_coordinates() {
    let (ev, m) = run(
        "G43.4 H1\nG0 X0 Y0 Z10. B0 C0\nG53 Z0\nG68.2 X0 Y0 Z0 I0 J30. K0\nG53.1\nG1 X1. Y1. Z1.\nG69\n",
        Dialect::Fanuc,
    );
    assert_eq!(m.tcp, Tcp::Axes);
    assert!(matches!(ev[1], Event::Move(_)));
    assert_eq!(ev[2], Event::Quiet);
    assert_eq!(ev[5], Event::Skip(Skip::TiltedPlane(PlaneSkip::Tcp)));
    assert!(!m.tilted);
}

#[test]
fn expressions_are_skipped_and_forget_the_axis() {
    let (ev, m) = run("G0 X1. Y2. Z3. B0 C0\nG1 X[#1+2.] F100.\n", Dialect::Fanuc);
    assert_eq!(ev[1], Event::Skip(Skip::Expression));
    assert_eq!(m.pos[0], None);
}

#[test]
fn fanuc_integers_are_ambiguous_unless_told() {
    let (ev, _) = run("G0 X10 Y2. Z3. B0 C0\n", Dialect::Fanuc);
    assert_eq!(ev[0], Event::Skip(Skip::FanucInteger));
    let (ev, _) = run("G0 X10 Y2 Z3 B0 C0\n", Dialect::Linuxcnc);
    assert!(matches!(ev[0], Event::Move(_)));
}

#[test]
fn arcs_by_centre_and_by_radius() {
    let (ev, _) = run(
        "G17 G0 X10. Y0 Z0 B0 C0\nG3 X0 Y10. I-10. J0 F100.\nG2 X10. Y0 R10.\n",
        Dialect::Fanuc,
    );
    let MoveKind::Arc(a) = mv(&ev[1]).kind else {
        panic!()
    };
    assert_eq!(a.center, [0.0, 0.0]);
    assert!(!a.cw);
    let MoveKind::Arc(a) = mv(&ev[2]).kind else {
        panic!()
    };
    assert!(a.cw);
    assert!(
        (a.center[0]).abs() < 1e-12 && a.center[1].abs() < 1e-12,
        "{:?}",
        a.center
    );
}

#[test]
fn control_flow_forgets_positions() {
    let (ev, _) = run(
        "G0 X1. Y2. Z3. B0 C0\nWHILE [#1 LT 3] DO1\nG1 X5. F100.\nEND1\n",
        Dialect::Fanuc,
    );
    let m = mv(&ev[2]);
    assert_eq!(m.start, [None; 6]);
    assert_eq!(m.end[0], Some(5.0));
    assert_eq!(m.end[1], None);
}

#[test]
fn probing_forgets_only_what_the_probe_moves() {
    // TCH PROBE 0 moves the linear axes only: B and C stay known.
    let (ev, _) = run(
        "0 BEGIN PGM T MM\n1 L X+10 Y+0 Z+5 B+0 C+30 R0 FMAX\n2 TCH PROBE 0.0 REF. PLANE Q1 X+\n3 TCH PROBE 0.1 X+0 Y+0 Z+5\n4 L X+1 Y+2 Z+3 R0 F100\n5 TCH PROBE 403 ROT IN ROTARY AXIS ~\n  Q263=+0 ;1ST POINT 1ST AXIS\n6 L X+1 Y+2 Z+3 R0 F100\n7 END PGM T MM\n",
        Dialect::Heidenhain,
    );
    assert_eq!(ev[2], Event::Quiet);
    let m = mv(&ev[4]);
    assert_eq!(&m.start[..3], &[None; 3]);
    assert_eq!(m.start[4], Some(0.0));
    assert_eq!(m.start[5], Some(30.0));
    // Cycle 403 may turn the table: everything is forgotten.
    assert_eq!(mv(&ev[6]).start, [None; 6]);
    assert_eq!(
        heidenhain::tch_probe_number(b"12 TCH PROBE 1.0 POLAR DATUM PLANE"),
        Some(1)
    );
    assert_eq!(
        heidenhain::tch_probe_number(b"TCH PROBE 412 DATUM CIRC. CENTER"),
        Some(412)
    );
    // G31 forgets the axes it names.
    let (ev, _) = run(
        "G0 X1. Y2. Z3. B0 C0\nG31 Z-10. F100.\nG1 X2.\n",
        Dialect::Fanuc,
    );
    let m = mv(&ev[2]);
    assert_eq!(m.start[0], Some(1.0));
    assert_eq!(m.start[2], None);
    assert_eq!(m.start[5], Some(0.0));
}

#[test]
fn heidenhain_blocks() {
    let (ev, m) = run(
        "0 BEGIN PGM T MM\n1 L X+10 Y+0 Z+5 B+0 C+0 R0 FMAX\n2 CC X+0 Y+0\n3 C X+0 Y+10 DR+ F500\n4 CR X+10 Y+0 R+10 DR- F500\n5 L IX+1 F500\n6 M128\n7 CYCL DEF 7.0 DATUM SHIFT\n8 CYCL DEF 7.1 X+100\n9 PLANE SPATIAL SPA+0 SPB+30 SPC+0 TURN FMAX\n10 L X+1 Y+1 Z+1 B+0 C+0 F100\n11 PLANE RESET STAY\n12 END PGM T MM\n",
        Dialect::Heidenhain,
    );
    assert_eq!(mv(&ev[1]).kind, MoveKind::Rapid);
    let MoveKind::Arc(a) = mv(&ev[3]).kind else {
        panic!()
    };
    assert_eq!(a.center, [0.0, 0.0]);
    assert!(!a.cw);
    let MoveKind::Arc(a) = mv(&ev[4]).kind else {
        panic!()
    };
    assert!(a.cw);
    assert_eq!(mv(&ev[5]).end[0], Some(11.0));
    assert_eq!(m.tcp, Tcp::Axes);
    assert_eq!(m.shift[0], 100.0);
    assert_eq!(ev[10], Event::Skip(Skip::TiltedPlane(PlaneSkip::Tcp)));
    assert!(!m.tilted);
}

#[test]
fn radius_centres_are_on_the_right_side() {
    // Quarter circle from (10,0) to (0,10) counter-clockwise about 0.
    let c = center_from_radius([10.0, 0.0], [0.0, 10.0], 10.0, false).unwrap();
    assert!(c[0].abs() < 1e-12 && c[1].abs() < 1e-12);
    // Clockwise, same chord: centre at (10, 10).
    let c = center_from_radius([10.0, 0.0], [0.0, 10.0], 10.0, true).unwrap();
    assert!((c[0] - 10.0).abs() < 1e-12 && (c[1] - 10.0).abs() < 1e-12);
    // Negative radius: the major arc, centre on the other side.
    let c = center_from_radius([10.0, 0.0], [0.0, 10.0], -10.0, false).unwrap();
    assert!((c[0] - 10.0).abs() < 1e-12 && (c[1] - 10.0).abs() < 1e-12);
}

#[test]
fn an_arc_runs_only_where_a_control_runs_it() {
    // LinuxCNC's rule: radii at most 0.0283 mm apart, or at most 100
    // times that and 0.1 % of the radius; neither radius below 1.27 um.
    let s = [10.0, 0.0];
    assert!(arc_runs(s, [0.0, 10.0], [0.0, 0.0], 1.0));
    assert!(arc_runs(s, [0.0, 10.02], [0.0, 0.0], 1.0));
    assert!(!arc_runs(s, [0.0, 10.05], [0.0, 0.0], 1.0));
    // 0.05 mm on a radius of 100 mm is 0.05 %.
    assert!(arc_runs([100.0, 0.0], [0.0, 100.05], [0.0, 0.0], 1.0));
    // 3 mm is beyond 100 times the absolute tolerance on any radius.
    assert!(!arc_runs([10_000.0, 0.0], [0.0, 10_003.0], [0.0, 0.0], 1.0));
    // A centre on the start point is no arc.
    assert!(!arc_runs(s, [0.0, 10.0], s, 1.0));
    // Inches: 0.001 in (0.0254 mm) runs, 0.002 in on 1 in does not.
    assert!(arc_runs([1.0, 0.0], [0.0, 1.001], [0.0, 0.0], 25.4));
    assert!(!arc_runs([1.0, 0.0], [0.0, 1.002], [0.0, 0.0], 25.4));
}

#[test]
fn off_circle_arcs_are_left_as_written_as_a_control_alarms() {
    for d in [Dialect::Fanuc, Dialect::Linuxcnc] {
        let (ev, _) = run(
            "G17 G0 X10. Y0 Z0 B0 C0\nG3 X0 Y10. I-10. J5. F100.\nG3 X-10. Y0 I0 J-10.\n",
            d,
        );
        assert!(
            matches!(ev[1], Event::Skip(Skip::Element(_, w)) if w.starts_with("off-circle arc")),
            "{d}: {:?}",
            ev[1]
        );
        // The end point is still where the block says: the next arc runs.
        assert!(matches!(mv(&ev[2]).kind, MoveKind::Arc(_)), "{d}");
    }
    let (ev, _) = run(
        "0 BEGIN PGM T MM\n1 L X+10 Y+0 Z+5 B+0 C+0 R0 FMAX\n2 CC X+0 Y+0\n3 C X+0 Y+12 DR+ F500\n4 C X+0 Y-12 DR+\n5 END PGM T MM\n",
        Dialect::Heidenhain,
    );
    assert!(
        matches!(ev[3], Event::Skip(Skip::Element(_, w)) if w.starts_with("off-circle circle")),
        "{:?}",
        ev[3]
    );
    assert!(matches!(mv(&ev[4]).kind, MoveKind::Arc(_)));
}

#[test]
fn values_beyond_a_control_s_five_digits_are_left_as_written() {
    // 1e47 mm made every later position meaningless in floating point.
    let (ev, m) = run(
        "G0 X0 Y0 Z10 B0 C0\nG1 X99999999999999999999999999999999999999999999999.5 F100\nG1 Y1\nG1 X100000 Y1\nG1 C100000.001\nG2 X0 Y0 I1000000 J0\n",
        Dialect::Linuxcnc,
    );
    assert_eq!(ev[1], Event::Skip(Skip::OutOfRange(b'X')));
    // X is forgotten, Y still moves.
    assert_eq!(mv(&ev[2]).end[0], None);
    assert_eq!(mv(&ev[2]).end[1], Some(1.0));
    // 100 m is the limit, inclusive; a rotary axis counts in degrees.
    assert_eq!(mv(&ev[3]).end[0], Some(100_000.0));
    assert_eq!(ev[4], Event::Skip(Skip::OutOfRange(b'C')));
    assert_eq!(ev[5], Event::Skip(Skip::OutOfRange(b'I')));
    assert_eq!(m.pos[5], None);
    // In inches the limit is the same length: 4,000 in is beyond it.
    let (ev, _) = run("G20 G0 X3900. Y0 Z0 B0 C0\nG1 X4000.\n", Dialect::Fanuc);
    assert!(matches!(ev[0], Event::Move(_)), "{:?}", ev[0]);
    assert_eq!(ev[1], Event::Skip(Skip::OutOfRange(b'X')));
    // HEIDENHAIN: the radius of CR as well.
    let (ev, _) = run(
        "0 BEGIN PGM T MM\n1 L X+10 Y+0 Z+5 B+0 C+0 R0 FMAX\n2 CR X+0 Y+10 R+1000000 DR+ F500\n3 END PGM T MM\n",
        Dialect::Heidenhain,
    );
    assert_eq!(ev[2], Event::Skip(Skip::OutOfRange(b'R')));
}

#[test]
fn a_heidenhain_c_block_turns_about_the_pole_whatever_r_it_has() {
    // The R word of a C block was taken for the radius word, and
    // compensate wrote the pole's radius into it (R+10 became R+22.3607).
    let (ev, _) = run(
        "0 BEGIN PGM T MM\n1 L X+10 Y+0 Z+5 B+0 C+0 R0 FMAX\n2 CC X+0 Y+0\n3 C X+0 Y+10 R+5 DR+ F500\n4 CR X+10 Y+0 R+10 DR-\n5 END PGM T MM\n",
        Dialect::Heidenhain,
    );
    let MoveKind::Arc(a) = mv(&ev[3]).kind else {
        panic!("{:?}", ev[3])
    };
    assert_eq!((a.center, a.radius_word), ([0.0, 0.0], None));
    let MoveKind::Arc(a) = mv(&ev[4]).kind else {
        panic!("{:?}", ev[4])
    };
    assert!(a.radius_word.is_some());
}

#[test]
fn the_code_that_switched_tcp_is_quoted_without_its_comment() {
    let (_, m) = run(
        "N10 G43.4 H1 (TCP ON, SEE SHEET 3)\nG0 X0 Y0 Z10. B0 C0\n",
        Dialect::Fanuc,
    );
    assert_eq!(m.coordinates_why(), "`N10 G43.4 H1` at line 1");
    let (_, m) = run(
        "0 BEGIN PGM P MM\n1 M128 ; TCPM EIN\n2 L X+0 Y+0 Z+10 B+0 C+0 R0 FMAX\n",
        Dialect::Heidenhain,
    );
    assert_eq!(m.coordinates_why(), "`1 M128` at line 2");
}

#[test]
fn linuxcnc_g68_2_parts_are_kept_until_the_plane_is_whole() {
    // G69 drops the parts given so far, as the remap's reset does; the
    // plane is set by the block that gives the last part.
    let parts = "G68.2 P2 Q1 X0 Y0 Z0\nG68.2 P2 Q2 X1 Y0 Z0\nG68.2 P2 Q3 X0 Y1 Z0\n";
    let (_, m) = run(
        &format!("G21 G90\nG68.2 P2 Q0 X5 Y0 Z0\nG69\n{parts}"),
        Dialect::Linuxcnc,
    );
    assert!(m.working_plane.is_none() && !m.tilted);
    assert_eq!(m.plane_pending.map(|p| p.parts[0]), Some(None));
    let (_, m) = run(
        &format!("G21 G90\n{parts}G68.2 P2 Q0 X5 Y0 Z0 R90\n"),
        Dialect::Linuxcnc,
    );
    let Some(Tilt::Plane(w)) = m.working_plane else {
        panic!("{:?}", m.working_plane)
    };
    assert!(m.plane_pending.is_none());
    assert!((w.rot - plane::about(b'Z', 90.0)).abs().max() < 1e-12);
    assert_eq!(w.origin, Vector3::new(5.0, 0.0, 0.0));
    // Parts of P3 among those of P2: not one definition.
    let (_, m) = run(
        "G21 G90\nG68.2 P2 Q1 X0 Y0 Z0\nG68.2 P3 Q1 I0 J0 K1\n",
        Dialect::Linuxcnc,
    );
    assert!(matches!(m.working_plane, Some(Tilt::Unmodelled { .. })));
    // FANUC's P forms are not guessed.
    let (_, m) = run(
        "G21 G90\nG68.2 P1 X0. Y0. Z0. I10. J20. K0.\n",
        Dialect::Fanuc,
    );
    assert!(matches!(m.working_plane, Some(Tilt::Unmodelled { why, .. }) if why.contains("FANUC")));
}

#[test]
fn an_additive_cycle800_needs_a_plane_it_can_build_on() {
    // Additive on a plane fivecal does not model (a parameter in it).
    let (_, m) = run(
        "G17 G90\nCYCLE800(1,\"T\",0,57,0,0,0,0,R1,0,0,0,0,1)\nCYCLE800(1,\"T\",1,57,0,0,0,0,0,20,0,0,0,1)\n",
        Dialect::Sinumerik,
    );
    assert!(
        matches!(m.working_plane, Some(Tilt::Unmodelled { why, .. }) if why.contains("additive")),
        "{:?}",
        m.working_plane
    );
    // Two additive turns about Z make one of their sum.
    let (_, m) = run(
        "G17 G90\nCYCLE800(1,\"T\",1,57,0,0,0,0,0,20,0,0,0,0)\nCYCLE800(1,\"T\",1,57,0,0,0,0,0,15,0,0,0,0)\n",
        Dialect::Sinumerik,
    );
    let Some(Tilt::Plane(w)) = m.working_plane else {
        panic!("{:?}", m.working_plane)
    };
    assert!((w.rot - plane::about(b'Z', 35.0)).abs().max() < 1e-12);
}
