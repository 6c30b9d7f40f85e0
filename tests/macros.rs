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
use fivecal::compensate::{Compensator, Coordinates, Settings, Summary};
use fivecal::errorfile::LoadedErrors;
use fivecal::model::Model;

use crate::compensate::{check_held, compensate, errors, simulate};
use crate::nc::fixture;

fn read(rel: &str) -> String {
    std::fs::read_to_string(fixture(rel)).unwrap()
}

/// LinuxCNC's five-axis kinematics always runs TCP; the other fixtures
/// switch it on (G43.4, M128, TRAORI).
pub(crate) fn coordinates(d: Dialect) -> Coordinates {
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
/// says so, and a HEIDENHAIN program may repeat a section `CALL LBL 1 REPQ13`
/// times with Q13 read from the control (`FN 18`). Neither is a loop without end nor a subprogram calling itself:
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

    let repeat = "0 BEGIN PGM T MM\n1 FN 18: SYSREAD Q13 = ID20 NR1\n2 L X+0 Y+0 Z+50 A+0 C+0 R0 FMAX\n3 LBL 1\n4 L X+5 Y+5 Z+40 R0 F100\n5 CALL LBL 1 REPQ13\n6 L X+0 Y+0 Z+50 R0 FMAX\n7 END PGM T MM\n";
    let (_, s, _) = compensate(&l, settings(Dialect::Heidenhain, false), repeat);
    let why = s.macro_logic.as_deref().unwrap_or_default();
    assert!(
        why.contains("the repeat count is not known") && why.contains("Q13"),
        "{why}"
    );
}

/// The end points (tool tip in W) of `program` on the nominal machine, as
/// the simulator runs its macro logic: line and point. Every program below
/// runs under TCP, so a tip is the point its block means.
fn nominal_tips(l: &LoadedErrors, d: Dialect, program: &str) -> Vec<(usize, [f64; 3])> {
    let nominal = Model::new(l.model.kin.clone(), vec![]);
    simulate(&nominal, &[], d, coordinates(d), program, 0.0)
        .into_iter()
        .filter(|s| s.fraction == 1.0)
        .map(|s| (s.line, [s.nominal.tip.x, s.nominal.tip.y, s.nominal.tip.z]))
        .collect()
}

/// Runs `program` through the macro logic as its controller would: the
/// tips it reaches on the nominal machine are `want` (the path the
/// manual's semantics give, worked out by hand), the program as written
/// misses them on the machine with the errors, and the rewrite (flattened
/// with `expand`) driven through that machine lands on them and on the
/// path between within the tolerance, every move corrected. At zero error
/// the program without `--expand` comes back byte for byte.
pub(crate) fn lands(
    l: &LoadedErrors,
    d: Dialect,
    program: &str,
    expand: bool,
    want: &[[f64; 3]],
    what: &str,
) -> (String, Summary) {
    let zero = errors(&l.model.kin.machine().name, 0, 0.0, "");
    let (same, _, _) = compensate(&zero, settings(d, false), program);
    assert_eq!(same, program, "{what}: zero error must give the same bytes");
    let tips: Vec<[f64; 3]> = nominal_tips(l, d, program)
        .into_iter()
        .map(|t| t.1)
        .collect();
    assert_eq!(tips.len(), want.len(), "{what}: {tips:?}");
    for (got, want) in tips.iter().zip(want) {
        // The simulator writes the values the logic gives as literals of
        // 1 nm.
        let off = (0..3).map(|k| (got[k] - want[k]).abs()).fold(0.0, f64::max);
        assert!(off < 1e-6, "{what}: reached {got:?}, meant {want:?}");
    }
    let actual = simulate(&l.model, &l.theta, d, coordinates(d), program, 0.0);
    let worst = actual
        .iter()
        .filter(|s| s.fraction == 1.0)
        .map(|s| s.error().norm())
        .fold(0.0, f64::max);
    assert!(
        worst > 0.005,
        "{what}: the errors move the tip by only {worst} mm"
    );
    let (out, s, _) = compensate(l, settings(d, expand), program);
    // Only the moves of branches the logic does not take are left, and
    // they are named as such.
    let never: usize = s
        .skipped
        .iter()
        .map(|(why, lines)| {
            assert!(
                why.starts_with("never runs"),
                "{what}: {:?}\n{out}",
                s.skipped
            );
            lines.count
        })
        .sum();
    assert_eq!(s.macro_logic, None, "{what}");
    assert_eq!(
        s.corrected_blocks + never,
        s.motion_blocks,
        "{what}: {s:?}\n{out}"
    );
    check_held(
        l,
        d,
        coordinates(d),
        program,
        &out,
        1e-3,
        &s.held_c.first,
        what,
    );
    (out, s)
}

#[test]
fn fanuc_if_goto_goto_and_if_then_take_the_branch_the_control_takes() {
    let l = errors("ac-trunnion", 31, 30.0, "");
    // Forward jumps only: every block runs once and is corrected in place.
    let program = "%\nO3001 (BRANCHES)\nG90 G21 G17 G40 G49 G80 G94\nG43.4 H1\nG0 X0. Y0. Z50. A-20. C30.\n#1=3.\n#2=0.\nN10 IF [#1 LT 2.] GOTO30\nG1 X[#1*10.] Y5. Z10. F500.\nIF [#1 GT 2.] THEN #2=7.5\nGOTO40\nN30 G1 X-9. Y-9. Z10. F500.\nN40 G1 X20. Y#2 Z5.\nIF [#2 EQ 0.] THEN #2=1.\nG1 X[#2+1.] Y-#2 Z5.\nG0 Z50.\nG49\nM30\n%\n";
    let want = [
        [0.0, 0.0, 50.0],
        [30.0, 5.0, 10.0],
        [20.0, 7.5, 5.0],
        [8.5, -7.5, 5.0],
        [8.5, -7.5, 50.0],
    ];
    let (out, _) = lands(&l, Dialect::Fanuc, program, false, &want, "IF GOTO");
    // The branch not taken is left as it is; the logic too.
    assert!(out.contains("\nN30 G1 X-9. Y-9. Z10. F500.\n"), "{out}");
    assert!(
        out.contains("\nIF [#1 GT 2.] THEN #2=7.5\nGOTO40\n"),
        "{out}"
    );

    // A loop of jumps back: its block runs three times with different
    // values, corrected flattened.
    let program = "%\nO3002 (A LOOP OF JUMPS)\nG90 G21 G17 G40 G49 G80 G94\nG43.4 H1\nG0 X0. Y0. Z50. A-20. C30.\n#3=0\nN50 G1 X[#3*5.] Y20. Z5. F500.\n#3=#3+1.\nIF [#3 LT 3.] GOTO50\nG1 X15. Y25. Z5.\nG0 Z50.\nG49\nM30\n%\n";
    let want = [
        [0.0, 0.0, 50.0],
        [0.0, 20.0, 5.0],
        [5.0, 20.0, 5.0],
        [10.0, 20.0, 5.0],
        [15.0, 25.0, 5.0],
        [15.0, 25.0, 50.0],
    ];
    let (_, s, _) = compensate(&l, settings(Dialect::Fanuc, false), program);
    assert!(
        s.skipped
            .iter()
            .any(|(r, at)| r.contains("runs 3 times") && at.first == [7]),
        "{:?}",
        s.skipped
    );
    let (flat, _) = lands(&l, Dialect::Fanuc, program, true, &want, "GOTO loop");
    assert_eq!(flat.matches("G1 X").count(), 4, "{flat}");
    assert!(!flat.contains("GOTO"), "{flat}");
}

#[test]
fn linuxcnc_o_word_branches_loops_and_calls_run_as_linuxcnc_runs_them() {
    let l = errors("ac-trunnion", 32, 30.0, "");
    let d = Dialect::Linuxcnc;
    let branches = "G21 G90 G17 G94\nG0 X0 Y0 Z50 A-20 C30\n#<r> = 12\no100 if [#<r> LT 10]\n  G1 X-9 Y-9 Z10 F500\no100 elseif [#<r> LT 20]\n  G1 X#<r> Y4 Z10 F500\no100 else\n  G1 X9 Y9 Z10 F500\no100 endif\no101 if [#<r> GT 100]\n  G1 X-1 Y-1 Z-1\no101 else\n  G1 X[#<r> + 3] Y-2 Z6\no101 endif\nG0 Z50\nM2\n";
    let want = [
        [0.0, 0.0, 50.0],
        [12.0, 4.0, 10.0],
        [15.0, -2.0, 6.0],
        [15.0, -2.0, 50.0],
    ];
    let (out, s) = lands(&l, d, branches, false, &want, "if/elseif/else");
    // The blocks that run are corrected in place, the three of the
    // branches not taken are kept and named.
    assert_eq!((s.motion_blocks, s.corrected_blocks), (7, 4), "{s:?}");
    for kept in [
        "  G1 X-9 Y-9 Z10 F500\n",
        "  G1 X9 Y9 Z10 F500\n",
        "  G1 X-1 Y-1 Z-1\n",
    ] {
        assert!(out.contains(kept), "{out}");
    }

    // repeat, do/while with break, while with continue, a named
    // subroutine called with arguments: each run of a block is its own.
    let loops = "o<corner> sub\n  G1 X#1 Y#2 Z#3\no<corner> endsub\nG21 G90 G17 G94\nG0 X0 Y0 Z50 A-20 C30\nG1 X10 Y0 Z5 F500\no101 repeat [3]\n  G91 G1 X5 Y1\no101 endrepeat\nG90\n#1 = 0\no102 do\n  #1 = [#1 + 1]\n  o104 if [#1 GT 3]\n    o102 break\n  o104 endif\n  G1 X[20 + #1] Y[#1 * 2] Z8\no102 while [#1 LT 10]\n#2 = 0\no105 while [#2 LT 4]\n  #2 = [#2 + 1]\n  o106 if [#2 EQ 2]\n    o105 continue\n  o106 endif\n  G1 X30 Y[10 + #2] Z7\no105 endwhile\no<corner> call [30] [-5] [6]\nG0 Z50\nM2\n";
    let want = [
        [0.0, 0.0, 50.0],
        [10.0, 0.0, 5.0],
        [15.0, 1.0, 5.0],
        [20.0, 2.0, 5.0],
        [25.0, 3.0, 5.0],
        [21.0, 2.0, 8.0],
        [22.0, 4.0, 8.0],
        [23.0, 6.0, 8.0],
        [30.0, 11.0, 7.0],
        [30.0, 13.0, 7.0],
        [30.0, 14.0, 7.0],
        [30.0, -5.0, 6.0],
        [30.0, -5.0, 50.0],
    ];
    let (flat, _) = lands(&l, d, loops, true, &want, "repeat/do/while/call");
    for logic in ["repeat", " do", "while", "break", "continue", "call", "sub"] {
        assert!(!flat.contains(logic), "`{logic}` left in\n{flat}");
    }
    // The repeated incremental block, once per run.
    assert_eq!(flat.matches("G91 G1 X").count(), 3, "{flat}");
}

/// FN 0-FN 8 and FN 13 as the TNC manuals write them, the FN 9-FN 12
/// jumps taken and not taken, a subprogram `CALL LBL` ending in `LBL 0`
/// and `PLANE RELATIV` after `PLANE SPATIAL`.
#[test]
fn heidenhain_fn_arithmetic_jumps_subprograms_and_plane_relativ_land_on_the_intended_path() {
    let l = errors("ac-trunnion", 33, 30.0, "");
    let d = Dialect::Heidenhain;
    let program = "\
0 BEGIN PGM FNJUMP MM
1 BLK FORM 0.1 Z X-40 Y-30 Z-10
2 BLK FORM 0.2 X+40 Y+30 Z+0
3 TOOL CALL 1 Z S8000
4 M128
5 L X+0 Y+0 Z+50 A-20 C+30 R0 FMAX M3
6 FN 0: Q1 = +12
7 FN 2: Q2 = +Q1 - +4
8 FN 4: Q3 = +Q2 DIV +4
9 FN 5: Q4 = SQRT +Q1
10 FN 6: Q5 = SIN +30
11 FN 7: Q6 = COS +60
12 FN 8: Q7 = +6 LEN +8
13 FN 13: Q8 = +10 ANG -10
14 FN 13: Q10 = -10 ANG +10
15 FN 9: IF +Q1 EQU +12 GOTO LBL 1
16 L X-9 Y-9 Z+10 R0 F500
17 LBL 1
18 L X+Q7 Y+Q3 Z+10 R0 F500
19 FN 10: IF +Q2 NE +8 GOTO LBL 2
20 L X+Q4 Y+Q5 Z+8
21 LBL 2
22 FN 11: IF +Q2 GT +Q1 GOTO LBL 3
23 L X+20 Y+Q6 Z+6
24 LBL 3
25 FN 12: IF +Q2 LT +Q1 GOTO LBL 4
26 L X-9 Y-9 Z+6
27 LBL 4
28 Q9 = Q8 / 10
29 L X+Q9 Y-Q4 Z+4
30 Q11 = Q10 / 20
31 L X+Q11 Y+0 Z+4
32 L Z+50 R0 FMAX
33 M129
34 END PGM FNJUMP MM
";
    let r12 = 12f64.sqrt();
    // FN 13 `a ANG b`: the angle whose sine and cosine are as a to b,
    // 0..360 (atan2(10, -10) = 135, atan2(-10, 10) = 315 deg).
    let want = [
        [0.0, 0.0, 50.0],
        [10.0, 2.0, 10.0],
        [r12, 30f64.to_radians().sin(), 8.0],
        [20.0, 60f64.to_radians().cos(), 6.0],
        [13.5, -r12, 4.0],
        [15.75, 0.0, 4.0],
        [15.75, 0.0, 50.0],
    ];
    let (out, _) = lands(&l, d, program, false, &want, "FN and jumps");
    for kept in ["\n16 L X-9 Y-9 Z+10 R0 F500\n", "\n26 L X-9 Y-9 Z+6\n"] {
        assert!(out.contains(kept), "{out}");
    }

    // A subprogram after the main program's end, called twice, in a plane
    // tilted by PLANE SPATIAL and turned further by PLANE RELATIV.
    let program = "\
0 BEGIN PGM SUBREL MM
1 BLK FORM 0.1 Z X-40 Y-30 Z-10
2 BLK FORM 0.2 X+40 Y+30 Z+0
3 TOOL CALL 1 Z S8000
4 L Z+100 R0 FMAX M91
5 PLANE SPATIAL SPA-25 SPB+0 SPC+0 TURN MB MAX FMAX SEQ-
6 PLANE RELATIV SPA+10 TURN MB MAX FMAX SEQ-
7 L X-10 Y-5 Z+20 R0 FMAX M3
8 CALL LBL 5
9 L X+5 Y+5 Z+20 R0 FMAX
10 CALL LBL 5
11 PLANE RESET TURN MB MAX FMAX
12 M30
13 LBL 5
14 L IZ-18 R0 F300
15 L IX+10
16 L IY+10
17 L IZ+18 R0 FMAX
18 LBL 0
19 END PGM SUBREL MM
";
    // The same program in the plane SPA-15 written at once.
    let direct = program.replace("SPA-25", "SPA-15").replace(
        "6 PLANE RELATIV SPA+10 TURN MB MAX FMAX SEQ-\n",
        "6 ; RELATIV\n",
    );
    let nominal = Model::new(l.model.kin.clone(), vec![]);
    let ends = |p: &str| -> Vec<(usize, nalgebra::Vector3<f64>, nalgebra::Vector3<f64>)> {
        simulate(&nominal, &[], d, Coordinates::Auto, p, 0.0)
            .into_iter()
            .filter(|s| s.fraction == 1.0)
            .map(|s| (s.line, s.nominal.tip, s.nominal.axis))
            .collect()
    };
    let (a, b) = (ends(program), ends(&direct));
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(&b) {
        assert!(
            (x.1 - y.1).norm() < 1e-9 && (x.2 - y.2).norm() < 1e-12,
            "line {}: {x:?} vs {y:?}",
            x.0
        );
    }
    let (s, c) = (-15f64).to_radians().sin_cos();
    // SPA: about X; the tool along the plane's Z.
    let axis = nalgebra::Vector3::new(0.0, -s, c);
    let in_plane: Vec<_> = a
        .iter()
        // Blocks 7 and 9 and the subprogram's, twice (file lines).
        .filter(|e| [8, 10, 15, 16, 17, 18].contains(&e.0))
        .collect();
    assert_eq!(in_plane.len(), 10, "{a:?}");
    assert!(
        in_plane.iter().all(|e| (e.2 - axis).norm() < 1e-12),
        "{a:?}"
    );
    let zero = errors("ac-trunnion", 0, 0.0, "");
    let (same, s0, _) = compensate(&zero, settings(d, false), program);
    assert_eq!(same, program);
    assert!(
        s0.skipped.iter().any(|(r, _)| r.contains("not known")),
        "without --expand the subprogram's moves are left: {:?}",
        s0.skipped
    );
    let (flat, s, _) = compensate(&l, settings(d, true), program);
    assert!(s.skipped.is_empty(), "{:?}\n{flat}", s.skipped);
    assert!(!flat.contains("LBL"), "{flat}");
    // In the plane the rotary positions are the plane's (the tip is checked
    // to 0.1 um, the axis to 1 mrad).
    let plane = [8, 10, 15, 16, 17, 18];
    check_held(
        &l,
        d,
        Coordinates::Auto,
        program,
        &flat,
        1e-3,
        &plane,
        "CALL LBL",
    );
}

/// A HEIDENHAIN value written apart from its letter (`L Z 25.000 FMAX`)
/// and a parameter written so (`L Z + Q13 FMAX`), as older posts write
/// them: the tool goes to Z 25 and to the value of Q13 (the simulator
/// says so), and the rewrite lands there.
#[test]
fn heidenhain_values_apart_from_their_letter_are_the_values_meant() {
    let l = errors("ac-trunnion", 34, 30.0, "");
    let program = "0 BEGIN PGM SPACED MM\n1 TOOL CALL 1 Z S3000\n2 M128\n3 L X+0 Y+0 Z+50 A-20 C+30 R0 FMAX\n4 L X+10 Y+5 Z 25.000 FMAX\n5 Q13 = 32.5\n6 L Z + Q13 FMAX\n7 L X+12 Z - Q13 R0 F500\n8 M129\n9 END PGM SPACED MM\n";
    let want = [
        [0.0, 0.0, 50.0],
        [10.0, 5.0, 25.0],
        [10.0, 5.0, 32.5],
        [12.0, 5.0, -32.5],
    ];
    let (out, _) = lands(&l, Dialect::Heidenhain, program, false, &want, "Z 25.000");
    // Written back in the block's own way, the value still apart.
    assert!(out.lines().nth(4).unwrap().contains(" Z +25.0"), "{out}");
}
