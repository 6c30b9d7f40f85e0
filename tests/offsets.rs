//! What the user states and the program sets about where things are:
//! `--rotary-start` for a rotary axis the program never sets (a four-axis
//! program on a five-axis machine), and work offsets the program writes
//! itself (G10 L2 / L20), related to the `--origin` of the offset in force
//! at its first move. Each compensated program is driven through the
//! erroneous machine in the simulator, which must put the tool tip on the
//! intended path.

use fivecal::Dialect;
use fivecal::compensate::simulate::SimSettings;
use fivecal::compensate::{Settings, Vertex};

use crate::compensate::{check_simulated, compensate, errors};

/// Lines where C was held: at tilt 0 the tool is along C, and only the
/// tip is exact there (as for any program at the tilt singularity).
fn held(vs: &[Vertex]) -> Vec<usize> {
    vs.iter().filter(|v| v.held_c).map(|v| v.line).collect()
}

/// A four-axis program (A only, no C word) as a post for an A-axis
/// indexer writes it.
const FOUR_AXIS: &str = "%
O4001 (FOUR-AXIS: A ONLY)
G90 G21 G17 G94 G54
G43 H1
G0 X10. Y-5. Z40. A0.
G1 Z10. F400.
G1 X30. Y5. A-20.
G1 X40. Y10. Z5. A-35.
G1 X20. Y15. Z12. A-10.
G0 Z50.
M30
%
";

/// Without a stated C the four-axis program's moves are left as written
/// (C's position is unknown on an A/C machine); with `--rotary-start C=0`
/// every one is corrected, and the rewrite driven through the erroneous
/// machine with C at 0 puts the tip on the intended path.
#[test]
fn a_four_axis_program_is_corrected_once_c_is_stated() {
    let l = errors("ac-trunnion", 41, 20.0, "");
    let (out, s, _) = compensate(&l, Settings::new(Dialect::Fanuc), FOUR_AXIS);
    assert_eq!(out, FOUR_AXIS, "nothing is corrected without C");
    assert_eq!(s.corrected_blocks, 0, "{s:?}");
    assert!(
        s.uncorrected_blocks
            .iter()
            .any(|(r, l)| r.contains("position of C is not known") && l.len() == s.motion_blocks),
        "{:?}",
        s.uncorrected_blocks
    );

    let mut settings = Settings::new(Dialect::Fanuc);
    settings.rotary_start = vec![('C', 0.0)];
    let (out, s, vs) = compensate(&l, settings, FOUR_AXIS);
    assert_eq!(s.motion_blocks, 6, "{s:?}");
    assert_eq!(s.corrected_blocks, 6, "{:?}", s.uncorrected_blocks);
    assert_ne!(out, FOUR_AXIS);
    let mut sim = SimSettings::new(Dialect::Fanuc);
    sim.rotary_start = vec![('C', 0.0)];
    check_simulated(
        &l,
        &sim,
        FOUR_AXIS,
        &out,
        0.001,
        &held(&vs),
        "four-axis C=0",
    );
}

/// `--rotary-start` is checked before any work: a rotary axis of the
/// machine, once, with an angle inside its stroke; the run says what it
/// assumed.
#[test]
fn rotary_start_is_validated_and_reported_as_assumed() {
    let dir = crate::util::tempdir();
    let errs = dir.path().join("e.yaml");
    std::fs::write(
        &errs,
        "machine: ac-trunnion\nlocation_errors: {EY0A: 15.0, EZ0A: -10.0, EB0A: 20.0, EC0A: -12.0, EX0C: 10.0, EB(0A)C: 18.0}\n",
    )
    .unwrap();
    let prog = dir.path().join("p.nc");
    std::fs::write(&prog, FOUR_AXIS).unwrap();
    let out_nc = dir.path().join("out.nc");
    let run = |start: &str| {
        crate::cli::fivecal()
            .args(["compensate", "--machine", "ac-trunnion", "--errors"])
            .arg(&errs)
            .arg(&prog)
            .arg("-o")
            .arg(&out_nc)
            .args(["--rotary-start", start])
            .output()
            .unwrap()
    };
    for (start, want) in [
        ("B=0", "B is not a rotary axis of machine ac-trunnion"),
        ("A=45", "45 deg is outside the stroke of A (-120 to 30 deg)"),
        ("C=nan", "expected an angle in deg"),
        ("C=0,C=10", "C is given more than once"),
        ("C", "expected AXIS=DEG"),
    ] {
        let out = run(start);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{start}: {err}");
        assert!(err.contains(want), "{start}: want `{want}` in {err}");
        assert!(!out_nc.exists(), "{start}: output written");
    }
    let out = run("c=0");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        text.contains("C taken at 0 deg before the first block, as --rotary-start states"),
        "{text}"
    );
    assert!(text.contains("6 of 6 motion blocks"), "{text}");
}

/// Two fixtures on one table, their work offsets G54 and G55 written by
/// the program (G10 L2, G55 with a rotary zero shift of C and a G91
/// touch-up). `--origin` places G54's zero (the offset of the first move);
/// G55's lies where the difference of the stored values puts it.
const FANUC_TWO_OFFSETS: &str = "%
O5001 (TWO FIXTURES, OFFSETS SET BY THE PROGRAM)
G90 G21 G17 G94
G10 L2 P1 X-100. Y-50. Z-200.
G10 L2 P2 X-40. Y-50. Z-210. C30.
G54 G43 H1
G0 X10. Y5. Z40. B0. C0.
G1 Z5. F300.
G1 X30. Y15. B20. C10.
G0 Z40.
G55
G0 X10. Y5. Z40. B10. C0.
G1 Z5. F300.
G1 X25. Y-5. B25. C45.
G91 G10 L2 P2 Y2.
G90 G1 X20. Y0. B20. C40.
G0 Z50.
M30
%
";

/// The FANUC program is corrected in both offsets (`--strict` too: what
/// it does is modelled), each corrected point aims at the place the
/// offsets' values say, computed here by hand, and the rewrite driven
/// through the erroneous machine puts the tip on the intended path.
#[test]
fn fanuc_g10_l2_offsets_are_followed_in_both_fixtures() {
    let l = errors("bc-trunnion", 43, 20.0, "");
    let origin = nalgebra::Vector3::new(5.0, -3.0, 2.0);
    let mut settings = Settings::new(Dialect::Fanuc);
    settings.strict = true;
    settings.origin = origin;
    let (out, s, vs) = compensate(&l, settings, FANUC_TWO_OFFSETS);
    assert_eq!(
        s.corrected_blocks, s.motion_blocks,
        "{:?}",
        s.uncorrected_blocks
    );
    assert_eq!(s.motion_blocks, 9, "{s:?}");
    // In G55: X, Y, Z shifted by G55 - G54 = (60, 0, -10) mm, C by 30 deg;
    // after the G91 touch-up Y by 2 mm more.
    let at = |line: usize| {
        vs.iter()
            .rev()
            .find(|v| v.line == line && !v.inserted)
            .unwrap()
    };
    for (line, xyz, b, c) in [
        (9, [30.0, 15.0, 5.0], 20.0, 10.0),
        (14, [25.0 + 60.0, -5.0, 5.0 - 10.0], 25.0, 45.0 + 30.0),
        (16, [20.0 + 60.0, 2.0, 5.0 - 10.0], 20.0, 40.0 + 30.0),
    ] {
        let n = at(line).nominal;
        let want = nalgebra::Vector3::from(xyz) + origin;
        assert!(
            (n.xyz - want).norm() < 1e-9,
            "line {line}: {n:?}, want {want}"
        );
        assert!(
            (n.tilt - b).abs() < 1e-9 && (n.c - c).abs() < 1e-9,
            "line {line}: {n:?}"
        );
    }
    let mut sim = SimSettings::new(Dialect::Fanuc);
    sim.origin = origin;
    check_simulated(
        &l,
        &sim,
        FANUC_TWO_OFFSETS,
        &out,
        0.001,
        &held(&vs),
        "FANUC G10 L2",
    );
}

/// LinuxCNC's G10 L20 sets an offset so that the current position reads
/// as written there: G55 made at the point X20 Y10 Z30 of G54 reads it as
/// X0 Y0 Z0, so G55 = G54 + (20, 10, 30) mm.
const LINUXCNC_L20: &str = "G21 G90 G17 G94
G54 G43 H1
G0 X20 Y10 Z30 B0 C0
G10 L20 P2 X0 Y0 Z0
G1 X22 Y10 Z30 F400
G55
G1 X5 Y0 Z-20 B15 C20
G1 X10 Y5 Z-25 B25 C60
G0 Z10
M2
";

#[test]
fn linuxcnc_g10_l20_offset_is_followed() {
    let l = errors("bc-trunnion", 44, 20.0, "");
    let mut settings = Settings::new(Dialect::Linuxcnc);
    settings.strict = true;
    let (out, s, vs) = compensate(&l, settings, LINUXCNC_L20);
    assert_eq!(
        s.corrected_blocks, s.motion_blocks,
        "{:?}",
        s.uncorrected_blocks
    );
    assert_eq!(s.motion_blocks, 5, "{s:?}");
    let n = vs
        .iter()
        .rev()
        .find(|v| v.line == 8 && !v.inserted)
        .unwrap()
        .nominal;
    assert!(
        (n.xyz - nalgebra::Vector3::new(30.0, 15.0, 5.0)).norm() < 1e-9,
        "{n:?}"
    );
    // The rewrite moved the point G10 L20 measures from: its values move
    // with it, so G55 is stored where the program meant it.
    assert_ne!(out.lines().nth(3), Some("G10 L20 P2 X0 Y0 Z0"), "{out}");
    let sim = SimSettings::new(Dialect::Linuxcnc);
    check_simulated(
        &l,
        &sim,
        LINUXCNC_L20,
        &out,
        0.001,
        &held(&vs),
        "LinuxCNC G10 L20",
    );
}

/// Where the relation to `--origin` is not determined, moves stay left as
/// written and reported: G55 set by the program while the first move ran in
/// G54, which the program never set, and G56, which it never set either.
/// G54 itself stays corrected.
#[test]
fn an_offset_the_program_did_not_relate_stays_reported() {
    let program = "%
O5002
G90 G21 G54 G43 H1
G0 X10. Y5. Z40. B0. C0.
G10 L2 P2 X-40. Y-50. Z-210.
G1 Z5. F300.
G55
G0 X10. Y5. Z40. B10. C0.
G56
G0 X10. Y5. Z40. B10. C0.
G54
G0 X12. Y5. Z40. B10. C0.
M30
%
";
    let l = errors("bc-trunnion", 45, 20.0, "");
    let (out, s, _) = compensate(&l, Settings::new(Dialect::Fanuc), program);
    let left: Vec<usize> = s
        .uncorrected_blocks
        .iter()
        .filter(|(r, _)| r.contains("relation to the one in force at the first move"))
        .flat_map(|(_, l)| l.first.clone())
        .collect();
    assert_eq!(left, vec![8, 10], "{:?}", s.uncorrected_blocks);
    assert_eq!(s.corrected_blocks, 3, "{:?}", s.uncorrected_blocks);
    assert_eq!(out.lines().nth(7), Some("G0 X10. Y5. Z40. B10. C0."));
}
