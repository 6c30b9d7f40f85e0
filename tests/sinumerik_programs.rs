//! SINUMERIK constructs written as the Siemens manuals write them, each
//! through `compensate` and the simulator: circles through an
//! intermediate point (`CIP`, in the working plane and inclined in
//! space), label jumps (`GOTOB`, `GOTO`), `IF`/`ELSE`/`ENDIF`,
//! `WHILE`/`ENDWHILE`, `REPEAT`/`UNTIL`, `LOOP`/`ENDLOOP` with a counter,
//! arcs with `I=AC() J=AC()` centres, the settable work offsets G505-G599
//! and G54-G57, and programs in lower case. At zero error each program
//! comes back byte for byte; with errors, the rewrite (flattened by
//! `--expand` where a loop runs a block with different values) driven
//! through the erroneous machine puts the tool tip on the intended path,
//! and without `--expand` such a loop's blocks are left as written and
//! named.

use std::path::Path;

use fivecal::Dialect;
use fivecal::compensate::simulate::{SimSettings, Simulator};
use fivecal::compensate::{Compensator, Coordinates, Settings, Summary};
use fivecal::errorfile::LoadedErrors;
use fivecal::model::Model;
use nalgebra::Vector3;

use crate::compensate::{assert_reaches, check_held, compensate, errors};

const MACHINE: &str = "bc-trunnion";

fn read(name: &str) -> String {
    std::fs::read_to_string(crate::nc::fixture(&format!("sinumerik/{name}"))).unwrap()
}

fn settings(expand: bool) -> Settings {
    let mut s = Settings::new(Dialect::Sinumerik);
    s.expand = expand;
    s
}

/// At zero error `program` comes back byte for byte, nothing left as
/// written or noted; then the errors of `seed` on the B/C trunnion.
fn zero_then_errors(program: &str, seed: u64, what: &str) -> LoadedErrors {
    let zero = errors(MACHINE, 0, 0.0, "");
    let (out, s, _) = compensate(&zero, settings(false), program);
    assert_eq!(out, program, "{what}: zero error must give the same bytes");
    assert!(s.unmodelled.is_empty(), "{what}: {:?}", s.unmodelled);
    errors(MACHINE, seed, 30.0, "")
}

/// The rewrite `out` of `program`: every corrected pose reaches the
/// intended one, and the rewrite on the erroneous machine follows the
/// program on the nominal one within the tolerance (both through the
/// simulator, which runs the macro logic).
fn lands(
    l: &LoadedErrors,
    program: &str,
    out: &str,
    s: &Summary,
    vs: &[fivecal::compensate::Vertex],
    what: &str,
) {
    for v in vs {
        assert_reaches(l, v, what);
    }
    check_held(
        l,
        Dialect::Sinumerik,
        Coordinates::Auto,
        program,
        out,
        settings(false).tolerance,
        &s.held_c.first,
        what,
    );
}

/// A program whose macro logic runs blocks once, or always with the same
/// values: corrected in place, nothing left as written, and it lands.
fn corrected_in_place(name: &str, seed: u64) -> (String, String) {
    let program = read(name);
    let l = zero_then_errors(&program, seed, name);
    let (out, s, vs) = compensate(&l, settings(false), &program);
    assert!(s.skipped.is_empty(), "{name}: {:?}\n{out}", s.skipped);
    assert_eq!(s.macro_logic, None, "{name}");
    assert!(s.changed >= 5, "{name}: {s:?}");
    lands(&l, &program, &out, &s, &vs, name);
    (program, out)
}

/// A program with a loop whose `lines` run several times with different
/// values: without `--expand` exactly those are left as written and named,
/// the moves corrected reach their poses; flattened with `--expand`
/// nothing is left, each of `gone` is dropped, `runs` blocks carry the
/// loop's feed `feed`, and the rewrite lands on the intended path.
fn corrected_flattened(
    name: &str,
    seed: u64,
    lines: &[usize],
    runs: usize,
    feed: &str,
    gone: &[&str],
) -> String {
    let program = read(name);
    let l = zero_then_errors(&program, seed, name);
    let (out, s, vs) = compensate(&l, settings(false), &program);
    let (_, at) = s
        .skipped
        .iter()
        .find(|(r, _)| r.contains(&format!("runs {runs} times with different values")))
        .unwrap_or_else(|| panic!("{name}: {:?}", s.skipped));
    assert_eq!(at.first, lines, "{name}");
    for line in lines {
        assert_eq!(
            out.lines().nth(line - 1),
            program.lines().nth(line - 1),
            "{name}: line {line} is left as written"
        );
    }
    assert!(
        !vs.is_empty(),
        "{name}: the moves before the loop are corrected"
    );
    for v in &vs {
        assert_reaches(&l, v, name);
    }

    let (flat, s, vs) = compensate(&l, settings(true), &program);
    assert!(s.skipped.is_empty(), "{name}: {:?}\n{flat}", s.skipped);
    assert_eq!(flat.matches(feed).count(), runs, "{name}:\n{flat}");
    for g in gone {
        assert!(!flat.contains(g), "{name}: `{g}` left in\n{flat}");
    }
    lands(&l, &program, &flat, &s, &vs, name);
    flat
}

/// The tool tip of every sample of `line` the simulator takes on the
/// nominal machine (every 0.1 mm along feed moves).
fn traced(program: &str, line: usize) -> Vec<Vector3<f64>> {
    let l = errors(MACHINE, 0, 0.0, "");
    let model = Model::new(l.model.kin.clone(), vec![]);
    let mut s = SimSettings::new(Dialect::Sinumerik);
    s.step = 0.1;
    let sim = Simulator::new(&model, &[], s);
    let mut out = Vec::new();
    sim.run(Path::new("p.mpf"), program.as_bytes(), &mut |x| {
        if x.line == line {
            out.push(x.nominal.tip);
        }
    })
    .unwrap();
    out
}

fn angle(a: Vector3<f64>, b: Vector3<f64>) -> f64 {
    a.normalize().dot(&b.normalize()).clamp(-1.0, 1.0).acos()
}

#[test]
fn cip_circles_in_the_plane_and_in_space_stay_cip_and_land_on_the_intended_arcs() {
    let (program, out) = corrected_in_place("cip.mpf", 201);
    // Every CIP is kept, with its end and intermediate point corrected; a
    // K1 the manual's example leaves out (the circle at Z0) is added where
    // the corrected circle leaves Z0.
    for (k, (a, b)) in program.lines().zip(out.lines()).enumerate() {
        if a.contains("I1=") {
            assert_ne!(a, b, "line {}", k + 1);
            assert_eq!(a.contains("CIP"), b.contains("CIP"), "line {}", k + 1);
        }
    }
    let n80 = out.lines().find(|t| t.starts_with("N80 ")).unwrap();
    assert!(
        n80.starts_with("N80 CIP X") && n80.contains(" K1="),
        "{n80}"
    );
    assert!(out.contains("I1=IC(") && out.contains("I1=AC("), "{out}");

    // The simulator cuts the circle through the three points: under
    // TRAORI (N160, line 20) the tip is the program point, and every
    // sample sees the chord from the start to the end under the angle
    // the intermediate point sees it (the inscribed angle), in the plane
    // of the three points.
    let (s, m, e) = (
        Vector3::new(30.0, 40.0, 0.0),
        Vector3::new(40.0, 45.0, -2.0),
        Vector3::new(50.0, 40.0, -4.0),
    );
    let n = (m - s).cross(&(e - s)).normalize();
    let inscribed = angle(s - m, e - m);
    let tips = traced(&program, 20);
    assert!(tips.len() > 100, "{}", tips.len());
    assert!((tips[tips.len() - 1] - e).norm() < 1e-9);
    for p in &tips[..tips.len() - 1] {
        assert!((p - s).dot(&n).abs() < 1e-9, "{p}");
        assert!((angle(s - p, e - p) - inscribed).abs() < 1e-9, "{p}");
    }
}

#[test]
fn a_cip_the_errors_bend_is_written_as_lines_and_the_next_block_keeps_its_cip() {
    // Scale errors of the linear axes turn a circle into an ellipse, by
    // more the larger it is: the half circle of radius 40 (N80) no longer
    // stays within 0.5 um of the corrected circle through its corrected
    // points and becomes lines; the one of radius 1 after it (N90, a CIP
    // by the modal mode) stays a CIP, and gets its CIP written back; the
    // arc of radius 40 after it (N100, by CR=) becomes lines too.
    let program = "\
%_N_CIPLIN_MPF
N10 G17 G90 G710 G94
N20 T=\"MILL D10\" M6
N30 D1
N40 G54
N50 G0 X0 Y0 Z60 B20 C10
N60 G0 X-40 Y0 Z5
N70 G1 Z0 F300
N80 CIP X40 Y0 I1=0 J1=40 F600
N90 X42 Y0 I1=41 J1=1
N100 G2 X2 Y-40 CR=40
N110 G1 X50
N120 G0 Z60
N130 M30
";
    let extra = "effects:\n  linear_scale: {EXX: 60.0, EYY: -40.0}\n";
    let l = errors(MACHINE, 202, 30.0, extra);
    let mut st = settings(false);
    st.tolerance = 0.0005;
    let (out, s, _) = compensate(&l, st.clone(), program);
    assert!(s.skipped.is_empty(), "{:?}", s.skipped);
    assert_eq!(s.linearized.first, vec![9, 11], "{out}");
    let n80 = out.lines().find(|t| t.starts_with("N80 ")).unwrap();
    assert!(n80.starts_with("N80 G1 X") && !n80.contains("1="), "{n80}");
    let n90 = out.lines().find(|t| t.starts_with("N90 ")).unwrap();
    assert!(
        n90.starts_with("N90 CIP X42.") && n90.contains(" K1="),
        "{n90}"
    );
    // A CR arc written as lines keeps no radius word either.
    let n100 = out.lines().find(|t| t.starts_with("N100 ")).unwrap();
    assert!(
        n100.starts_with("N100 G1 X") && !n100.contains("CR"),
        "{n100}"
    );
    check_held(
        &l,
        Dialect::Sinumerik,
        Coordinates::Auto,
        program,
        &out,
        st.tolerance,
        &s.held_c.first,
        "a linearized CIP",
    );
}

#[test]
fn a_cip_through_three_points_on_a_line_is_an_error_at_its_line_and_column() {
    // N90's intermediate point on the line from its start to its end.
    let program = read("cip.mpf").replace(
        "N90 X60 Y30 Z-5 I1=IC(8) J1=IC(-3) K1=IC(-2)",
        "N90 X60 Y30 Z-5 I1=IC(5) J1=IC(-5) K1=IC(-2.5)",
    );
    let l = errors(MACHINE, 203, 30.0, "");
    for expand in [false, true] {
        let c = Compensator::new(&l.model, &l.theta, settings(expand));
        let mut out = Vec::new();
        let e = c
            .run(Path::new("p.mpf"), program.as_bytes(), &mut out)
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("p.mpf:13:17: CIP:") && e.contains("one straight line"),
            "{e}"
        );
    }
    let sim = Simulator::new(&l.model, &l.theta, SimSettings::new(Dialect::Sinumerik));
    let e = sim
        .run(Path::new("p.mpf"), program.as_bytes(), &mut |_| {})
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("p.mpf:13:17: CIP:"), "{e}");
    // A CIP back to its start (a full circle) likewise, at its command.
    let closed = read("cip.mpf").replace("N80 CIP X50 Y40", "N80 CIP X30 Y40");
    let c = Compensator::new(&l.model, &l.theta, settings(false));
    let e = c
        .run(Path::new("p.mpf"), closed.as_bytes(), &mut Vec::new())
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("p.mpf:12:5: CIP:") && e.contains("full circle"),
        "{e}"
    );
}

#[test]
fn a_cip_leaving_out_k1_in_g90_away_from_z0_is_left_as_written_with_the_reason() {
    // The manual gives an omitted interpolation parameter the value 0; at
    // Z-1 that is either the point Z0 or the start's Z, which it does not
    // decide: the block is kept, and said to be.
    let program = read("cip.mpf").replace("N70 G1 Z0 F300", "N70 G1 Z-1 F300");
    let l = errors(MACHINE, 204, 30.0, "");
    let (out, s, _) = compensate(&l, settings(false), &program);
    let (why, at) = s
        .skipped
        .iter()
        .find(|(r, _)| r.contains("leaves out I1=, J1= or K1= under G90"))
        .unwrap_or_else(|| panic!("{:?}", s.skipped));
    assert_eq!(at.first, vec![12], "{why}");
    assert_eq!(out.lines().nth(11), program.lines().nth(11));
    // N90 starts where N80, left as written, ends: off the intended
    // start by the errors, which no circle from there makes up for; so
    // does N100 after it. The line after them ends where it should, and
    // is reported: from where N100 leaves the tool to that end, no pieces
    // keep it within the tolerance.
    let at = |what: &str| crate::compensate::reported(&s, what);
    assert_eq!(at("the arc starts where the move before it"), vec![13, 14]);
    assert_eq!(at("the line starts where the move before it"), vec![15]);
    assert_eq!(s.skipped_count(), 4, "{:?}", s.skipped);
    assert_ne!(out.lines().nth(14), program.lines().nth(14));
}

#[test]
fn gotob_and_goto_jumps_are_followed() {
    // N90 (line 13) sets the depth of each of the three passes; GOTO
    // jumps over N160, which never runs.
    let flat = corrected_flattened(
        "gotob.mpf",
        205,
        &[13],
        3,
        "F300",
        &["N140 IF", "N150 GOTO", "PASS:", "LIFT:", "N160"],
    );
    assert!(flat.contains("\nN170 G0 Z"), "{flat}");
}

#[test]
fn if_else_endif_runs_the_branch_its_condition_picks() {
    let (_, out) = corrected_in_place("if_else.mpf", 206);
    // Both branches end where they start: the moves after ENDIF are
    // corrected from there.
    assert_ne!(
        out.lines().find(|t| t.starts_with("N200")),
        Some("N200 G0 Z60")
    );
    let program = read("if_else.mpf");
    let l = errors(MACHINE, 206, 30.0, "");
    let (flat, s, vs) = compensate(&l, settings(true), &program);
    for g in ["N100 IF", "N150 ELSE", "N190 ENDIF", "N160", "N170", "N180"] {
        assert!(!flat.contains(g), "`{g}` left in\n{flat}");
    }
    lands(&l, &program, &flat, &s, &vs, "if_else.mpf --expand");
}

#[test]
fn while_endwhile_is_followed_pass_by_pass() {
    // The ring shrinks from 30 to 22 to 14: three passes of N100-N140.
    corrected_flattened(
        "while.mpf",
        207,
        &[13, 14, 15, 16, 17],
        3,
        "F600",
        &["N90 WHILE", "N160 ENDWHILE"],
    );
}

#[test]
fn repeat_until_with_the_same_values_each_run_is_corrected_in_place() {
    // A spring pass: the outline runs twice with the same values, so its
    // blocks are corrected where they stand, and flattened they appear
    // twice.
    corrected_in_place("repeat_until.mpf", 208);
    let program = read("repeat_until.mpf");
    let l = errors(MACHINE, 208, 30.0, "");
    let (flat, s, vs) = compensate(&l, settings(true), &program);
    assert_eq!(flat.matches("N110 ").count(), 2, "{flat}");
    assert!(
        !flat.contains("N80 REPEAT") && !flat.contains("N150 UNTIL"),
        "{flat}"
    );
    lands(&l, &program, &flat, &s, &vs, "repeat_until.mpf --expand");
}

#[test]
fn an_endless_loop_counted_in_a_parameter_and_left_by_gotof_is_followed() {
    // N90 (line 11) places each of the four slots.
    corrected_flattened(
        "loop_counter.mpf",
        209,
        &[11],
        4,
        "F600",
        &["N80 LOOP", "N140 IF", "N150 ENDLOOP", "DONE:"],
    );
}

#[test]
fn arcs_with_absolute_centres_keep_them_absolute() {
    let (program, out) = corrected_in_place("arc_ac.mpf", 210);
    // Kept as arcs: the absolute centres rewritten inside their AC(),
    // the incremental ones as increments from the written start.
    for n in ["N80 G2", "N90 G2", "N100 G91 G2", "N110 G3"] {
        let a = program.lines().find(|t| t.starts_with(n)).unwrap();
        let b = out.lines().find(|t| t.starts_with(n)).unwrap();
        assert_ne!(a, b);
    }
    let n80 = out.lines().find(|t| t.starts_with("N80 ")).unwrap();
    assert!(n80.contains(" I=AC(") && n80.contains(" J=AC("), "{n80}");
    assert!(!n80.contains("AC(0)") && !n80.contains("AC(10)"), "{n80}");
}

#[test]
fn settable_work_offsets_g505_to_g599_and_g54_to_g57_are_work_offsets() {
    // Read strictly (every code known), corrected and driven: the program
    // zero of each is where --origin puts the first one's, since the
    // program sets none of them.
    corrected_in_place("offsets.mpf", 211);
    let program = read("offsets.mpf");
    let l = errors(MACHINE, 211, 30.0, "");
    let mut st = settings(false);
    st.strict = true;
    let (_, s, _) = compensate(&l, st, &program);
    assert!(s.skipped.is_empty(), "{:?}", s.skipped);

    // A settable frame written by the program moves that offset's zero by
    // what fivecal does not follow: nothing after it is corrected, and
    // --strict refuses it at the assignment.
    let written = program.replace(
        "N110 G599\n",
        "N110 $P_UIFR[99]=CTRANS(X,10,Y,0,Z,0)\nN115 G599\n",
    );
    let (out, s, _) = compensate(&l, settings(false), &written);
    let (why, at) = s
        .skipped
        .iter()
        .find(|(r, _)| r.contains("$P_UIFR"))
        .unwrap_or_else(|| panic!("{:?}", s.skipped));
    assert_eq!(at.first, (15..=22).collect::<Vec<_>>(), "{why}");
    for k in 14..22 {
        assert_eq!(out.lines().nth(k), written.lines().nth(k));
    }
    let mut st = settings(false);
    st.strict = true;
    let c = Compensator::new(&l.model, &l.theta, st);
    let e = c
        .run(Path::new("p.mpf"), written.as_bytes(), &mut Vec::new())
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("p.mpf:13:6:") && e.contains("$P_UIFR"), "{e}");
}

#[test]
fn a_program_in_lower_case_is_corrected_in_lower_case() {
    let (program, out) = corrected_in_place("lower.mpf", 212);
    for (a, b) in program.lines().zip(out.lines()) {
        if a != b {
            let code = b.split(';').next().unwrap();
            assert_eq!(code, code.to_ascii_lowercase(), "{b}");
        }
    }
    // The parameter words are rewritten as the numbers they are, the
    // comment glued to the block stays.
    let n80 = out.lines().find(|t| t.starts_with("n80 ")).unwrap();
    assert!(
        n80.starts_with("n80 g1 x=12.") && n80.ends_with(";to the end of the slot"),
        "{n80}"
    );
}

#[test]
fn an_arc_after_a_move_left_as_written_is_left_too_with_the_reason() {
    // N80, an arc by opening angle, is left as written: the tool ends it
    // where the errors put it, tens of um from where N90 should start. No
    // arc nor lines from there follow N90 within the tolerance, which was
    // an error for the whole run ("cannot be followed ... in 65536
    // pieces"); it is left as written and named, and the line after it is
    // corrected.
    let program = "\
%_N_AR_MPF
N10 G17 G90 G710 G94
N20 T=\"MILL D10\" M6
N30 D1
N40 G54
N50 G0 X0 Y0 Z60 B20 C10
N60 G0 X30 Y40 Z5
N70 G1 Z-1 F300
N80 G2 X50 Y40 AR=90 F600
N90 G3 X60 Y30 CR=12
N100 G1 X70 Y40
N110 G0 Z60
N120 M30
";
    let l = errors(MACHINE, 213, 30.0, "");
    let (out, s, _) = compensate(&l, settings(false), program);
    let (_, at) = s
        .skipped
        .iter()
        .find(|(r, _)| r.contains("off its intended start"))
        .unwrap_or_else(|| panic!("{:?}", s.skipped));
    assert_eq!(at.first, vec![10]);
    assert_eq!(out.lines().nth(9), program.lines().nth(9));
    assert_ne!(out.lines().nth(10), program.lines().nth(10));
}
