//! Programs that keep their moves in variables and macro logic, in every
//! dialect: parameters set once are evaluated and the moves that read them
//! corrected in place; a loop's moves, which run several times with
//! different values, are reported without `--expand` and corrected in the
//! flattened program with it; a loop that never ends is an error at its
//! line. Each rewrite is driven through the erroneous machine by the
//! simulator (which runs the macro logic too) and compared with the
//! original on the nominal machine.

use std::path::Path;

use fivecal::Dialect;
use fivecal::compensate::{Compensator, Coordinates, Settings};

use crate::compensate::{check_held, compensate, errors};
use crate::nc::fixture;

fn read(rel: &str) -> String {
    std::fs::read_to_string(fixture(rel)).unwrap()
}

/// LinuxCNC's five-axis kinematics always runs TCP; the other fixtures
/// switch it on (G43.4, M128, TRAORI).
fn coordinates(d: Dialect) -> Coordinates {
    if d == Dialect::Linuxcnc {
        Coordinates::Tcp
    } else {
        Coordinates::Auto
    }
}

fn settings(d: Dialect, expand: bool) -> Settings {
    let mut s = Settings::new(d);
    s.coordinates = coordinates(d);
    s.expand = expand;
    s
}

#[test]
fn parameters_set_once_are_evaluated_and_their_moves_corrected_in_place() {
    let l = errors("ac-trunnion", 16, 30.0, "");
    let zero = errors("ac-trunnion", 16, 0.0, "");
    for (file, d) in [
        ("fanuc/macro_pocket.nc", Dialect::Fanuc),
        ("heidenhain/q_params.h", Dialect::Heidenhain),
        ("linuxcnc/params.ngc", Dialect::Linuxcnc),
        ("sinumerik/r_params.mpf", Dialect::Sinumerik),
    ] {
        let program = read(file);
        let (out, s, vs) = compensate(&l, settings(d, false), &program);
        assert!(s.skipped.is_empty(), "{file}: {:?}", s.skipped);
        assert_eq!(s.macro_logic, None, "{file}");
        // Every move reads a parameter or follows one that does: all of
        // them are written, eight or more per program.
        assert!(vs.len() >= 8 && s.changed >= 8, "{file}: {s:?}\n{out}");
        // Assignments stay as they are; only value lexemes changed.
        for (a, b) in program.lines().zip(out.lines()) {
            let assignment =
                a.contains('=') && !a.contains("X=") && !a.contains("Y=") && !a.contains("Z=");
            if assignment || a.contains("FN ") {
                assert_eq!(a, b, "{file}");
            }
        }
        // The first positioning, at A0, is next to the singularity: C is
        // held there and only the tip is checked.
        check_held(
            &l,
            d,
            coordinates(d),
            &program,
            &out,
            1e-3,
            &s.held_c.first,
            file,
        );
        let (same, _, _) = compensate(&zero, settings(d, false), &program);
        assert_eq!(same, program, "{file}: zero error must give the same bytes");
    }
}

#[test]
fn loops_are_reported_without_expand_and_corrected_flattened_with_it() {
    let l = errors("ac-trunnion", 17, 30.0, "");
    // The loop's first move is the only one with F600.
    for (file, d, runs, lines, macro_logic) in [
        (
            "fanuc/macro_while.nc",
            Dialect::Fanuc,
            5,
            vec![16, 17],
            &["WHILE [", "END1"][..],
        ),
        (
            "heidenhain/lbl_rep.h",
            Dialect::Heidenhain,
            4,
            vec![13, 15],
            &["LBL"][..],
        ),
        (
            "linuxcnc/owhile.ngc",
            Dialect::Linuxcnc,
            5,
            vec![4, 5],
            &["o100", "o<pass>", "Y#1"][..],
        ),
        (
            "sinumerik/for_loop.mpf",
            Dialect::Sinumerik,
            5,
            vec![13, 14],
            &["FOR PASS", "ENDFOR", "Y=R10"][..],
        ),
    ] {
        let program = read(file);
        let (out, s, _) = compensate(&l, settings(d, false), &program);
        let why = format!("runs {runs} times with different values");
        let (_, at) = s
            .skipped
            .iter()
            .find(|(r, _)| r.contains(&why) && r.contains("--expand"))
            .unwrap_or_else(|| panic!("{file}: {:?}", s.skipped));
        assert_eq!(at.first, lines, "{file}");
        for line in &lines {
            assert_eq!(
                out.lines().nth(line - 1),
                program.lines().nth(line - 1),
                "{file}: line {line} is left as written"
            );
        }

        let (flat, s, vs) = compensate(&l, settings(d, true), &program);
        assert!(s.skipped.is_empty(), "{file}: {:?}\n{flat}", s.skipped);
        // One block per run of the loop's first move, every move literal,
        // no loop or jump left.
        assert_eq!(flat.matches("F600").count(), runs, "{file}:\n{flat}");
        for logic in macro_logic {
            assert!(!flat.contains(logic), "{file}: `{logic}` left in\n{flat}");
        }
        assert!(vs.len() > 3 * runs, "{file}");
        check_held(
            &l,
            d,
            coordinates(d),
            &program,
            &flat,
            1e-3,
            &s.held_c.first,
            file,
        );
        if d == Dialect::Heidenhain {
            for (i, line) in flat.lines().enumerate() {
                assert!(
                    line.starts_with(&format!("{i} ")),
                    "{file}: renumbered\n{flat}"
                );
            }
        }
    }
}

#[test]
fn a_loop_that_never_ends_is_an_error_at_its_line() {
    let l = errors("ac-trunnion", 18, 30.0, "");
    for (program, d, at) in [
        (
            "%\nO1\nG90 G0 X0. Y0. Z50.\n#1=0\nWHILE [1 EQ 1] DO1\nG1 X[#1] F500.\n#1=#1+1\nEND1\nM30\n%\n",
            Dialect::Fanuc,
            "p.nc:",
        ),
        (
            "o<again> sub\n  G1 X1 F100\n  o<again> call\no<again> endsub\nG0 X0 Y0 Z50\no<again> call\nM2\n",
            Dialect::Linuxcnc,
            "p.nc:3:",
        ),
        (
            "G0 X0 Y0 Z50\nLOOP\n  G1 X=R1 F100\n  R1=R1+1\nENDLOOP\nM30\n",
            Dialect::Sinumerik,
            "p.nc:",
        ),
    ] {
        for expand in [false, true] {
            let c = Compensator::new(&l.model, &l.theta, settings(d, expand));
            let mut out = Vec::new();
            let e = c
                .run(Path::new("p.nc"), program.as_bytes(), &mut out)
                .unwrap_err()
                .to_string();
            assert!(e.starts_with(at), "{d}: {e}");
            assert!(e.contains("loop") || e.contains("calls nested"), "{d}: {e}");
        }
    }
}

#[test]
fn a_value_the_program_does_not_fix_is_never_guessed() {
    // #5063 (the probed Z) is the controller's: the move that reads it is
    // left as written, the others are corrected; --expand refuses at the
    // word, naming the variable.
    let l = errors("ac-trunnion", 19, 30.0, "");
    let program = "%\nO1\nG90 G43.4 H1\nG0 X0. Y0. Z50. A-10. C0.\n#1=10.\nG1 X#1 F500.\n#2=#5063+1.\nG1 Z#2\nM30\n%\n";
    let (out, s, _) = compensate(&l, settings(Dialect::Fanuc, false), program);
    assert!(out.lines().nth(5).unwrap().starts_with("G1 X10."), "{out}");
    assert_eq!(out.lines().nth(7), Some("G1 Z#2"));
    let (reason, at) = &s.skipped[0];
    assert!(reason.contains("expressions"), "{reason}");
    assert_eq!(at.first, vec![8]);
    let c = Compensator::new(&l.model, &l.theta, settings(Dialect::Fanuc, true));
    let e = c
        .run(Path::new("p.nc"), program.as_bytes(), &mut Vec::new())
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("p.nc:8:5:") && e.contains("#5063"), "{e}");
}

/// Real programs loop on what only the control knows: LinuxCNC's own
/// `smartprobe.ngc` repeats `G38.3` while `#5070` (the probe's "touched")
/// says so, and a HEIDENHAIN sample repeats a section `CALL LBL 1 REPQ13`
/// times. Neither is a loop without end nor a subprogram calling itself:
/// following the logic stops there, named, and the run goes on (the
/// literal moves before it corrected, the file refused for neither).
#[test]
fn a_loop_on_the_probe_result_or_a_parametric_repeat_stops_the_logic_not_the_run() {
    let l = errors("ac-trunnion", 21, 30.0, "");
    let probing = "G90 G0 X0 Y0 Z50 A0 C0\n#5070=1\no4 while [#5070 NE 0]\n  G38.3 X10\no4 endwhile\nG1 X5 Y5 Z40 F100\nM2\n";
    let (out, s, _) = compensate(&l, settings(Dialect::Linuxcnc, false), probing);
    let why = s.macro_logic.as_deref().unwrap_or_default();
    assert!(
        why.contains("#5070 is set by the probing move at line 4"),
        "{why}"
    );
    assert_ne!(out.lines().next(), Some("G90 G0 X0 Y0 Z50 A0 C0"), "{out}");

    let repeat = "0 BEGIN PGM T MM\n1 FN 0: Q13 =+3\n2 L X+0 Y+0 Z+50 A+0 C+0 R0 FMAX\n3 LBL 1\n4 L X+5 Y+5 Z+40 R0 F100\n5 CALL LBL 1 REPQ13\n6 L X+0 Y+0 Z+50 R0 FMAX\n7 END PGM T MM\n";
    let (_, s, _) = compensate(&l, settings(Dialect::Heidenhain, false), repeat);
    let why = s.macro_logic.as_deref().unwrap_or_default();
    assert!(
        why.contains("repeat count that is not a number (`REPQ13`)"),
        "{why}"
    );
}
