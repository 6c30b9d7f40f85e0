//! The moves a controller builds from words that are not end points:
//! canned drilling cycles (FANUC and LinuxCNC G81-G89 with G98/G99 and
//! repeats), HEIDENHAIN polar elements around the pole (`LP`, `CP`,
//! with `IPR`/`IPA` and helices), `CYCL CALL POS` holes, the corners
//! `RND`/`CHF` cut between two lines and the tangential circles `CT`. Each program is written as a shop
//! writes it, compensated against known errors, and the rewrite driven
//! through the erroneous machine by the simulator: the tip reaches every
//! intended point and stays on the intended path within the tolerance,
//! where the program as written misses by far more. At zero error the
//! rewrite is the input, byte for byte.

use fivecal::Dialect;
use fivecal::compensate::simulate::Sample;
use fivecal::compensate::{Coordinates, Settings, Summary};
use fivecal::errorfile::LoadedErrors;
use fivecal::model::Model;

use crate::compensate::{assert_on_path, check_held, compensate, errors, reported, simulate};

/// The end points of `program` on the nominal machine and of `rewritten`
/// on the erroneous one, pairwise (the rewrite inserts no block here):
/// the largest tip distance, mm. (A hole's R level is a clearance and
/// not an end point: it moves with the corrected depth.)
fn worst_end_miss(l: &LoadedErrors, d: Dialect, program: &str, rewritten: &str) -> f64 {
    let nominal = Model::new(l.model.kin.clone(), vec![]);
    let ends =
        |s: Vec<Sample>| -> Vec<Sample> { s.into_iter().filter(|x| x.fraction == 1.0).collect() };
    let a = ends(simulate(&nominal, &[], d, Coordinates::Auto, program, 0.0));
    let b = ends(simulate(
        &l.model,
        &l.theta,
        d,
        Coordinates::Auto,
        rewritten,
        0.0,
    ));
    assert_eq!(a.len(), b.len(), "the same points in both");
    a.iter()
        .zip(&b)
        .map(|(x, y)| (x.nominal.tip - y.actual.tip).norm())
        .fold(0.0, f64::max)
}

/// Compensates `program` at zero error (must give it back) and against
/// `l`; the rewrite must hold the tolerance on the simulator and the
/// program as written must not. At the `tip_only` lines (holes: the
/// rotary axes stand as they are) the tool axis is not checked.
fn holds(
    l: &LoadedErrors,
    d: Dialect,
    program: &str,
    tip_only: &[usize],
    what: &str,
) -> (String, Summary) {
    let m = l.model.kin.machine().name.clone();
    let zero = errors(&m, 0, 0.0, "");
    let (out, s0, _) = compensate(&zero, Settings::new(d), program);
    assert_eq!(out, program, "{what}: zero error must give the same bytes");
    assert_eq!(s0.changed, 0, "{what}");
    let (out, s, _) = compensate(l, Settings::new(d), program);
    check_held(
        l,
        d,
        Coordinates::Auto,
        program,
        &out,
        0.001,
        tip_only,
        what,
    );
    assert!(
        worst_end_miss(l, d, program, &out) < 1e-4,
        "{what}: an end point missed"
    );
    let before = worst_end_miss(l, d, program, program);
    assert!(
        before > 0.005,
        "{what}: the errors move the tip by only {:.2} um as written",
        before * 1e3
    );
    (out, s)
}

#[test]
fn fanuc_drilling_cycles_put_every_hole_where_it_was_meant() {
    // A post-side program: the part turned to B30 C45, four holes drilled
    // and pecked along the machine's Z with the cycles' modal depth and R.
    // The first hole comes straight after the rotary positioning, which is
    // left as written (X and Y are not known there).
    let program = "%\nO1001 (DRILL AND PECK)\nG90 G21 G17 G40 G49 G80\nG0 B30. C45.\nG43 H1 Z100.\nG98 G81 X10. Y10. Z-5. R2. F200.\nX30.\nY30. Z-6.\nG99 G83 X10. Y30. Z-8. R2. Q2. F150.\nG80\nG0 Z100.\nM30\n%\n";
    let l = errors("bc-trunnion", 91, 30.0, "");
    let (out, s) = holds(&l, Dialect::Fanuc, program, &[6, 7, 8, 9], "fanuc cycles");
    assert_eq!(s.drilled.first, [6, 7, 8, 9], "{:?}\n{out}", s.skipped);
    assert_eq!(s.skipped.len(), 1, "{:?}", s.skipped);
    assert_eq!(s.skipped[0].1.first, [4, 5], "{:?}", s.skipped);
    // The cycle words stay, X, Y and the depth are rewritten; a hole
    // without a depth word drills to the corrected depth in force.
    let lines: Vec<&str> = out.lines().collect();
    assert!(lines[5].starts_with("G98 G81 X") && lines[5].ends_with(" R2. F200."));
    assert!(!lines[5].contains("Z-5. "), "{}", lines[5]);
    assert!(lines[6].starts_with('X'), "{}", lines[6]);
    assert!(lines[8].ends_with(" R2. Q2. F150."), "{}", lines[8]);
    // The rotary axes stand as written: the holes keep the machine's
    // orientation error, reported with what it does at the R level.
    assert!(
        s.drilled_axis_error > 1.0 && s.drilled_residual > 0.0 && s.drilled_residual < 1.0,
        "{s:?}"
    );
}

#[test]
fn linuxcnc_drilling_in_g99_with_repeats_in_g90() {
    // LinuxCNC starts in G99; L2 in G90 drills the same hole twice.
    let program = "G21 G90 G17\nG0 A-20 C30\nG43 H1\nG0 Z50\nG0 X5 Y5\nG81 X5 Y5 Z-4 R1 F100 L2\nX25 Y5\nG80\nG0 Z50\nM2\n";
    let l = errors("ac-trunnion", 92, 30.0, "");
    let (out, s) = holds(&l, Dialect::Linuxcnc, program, &[], "linuxcnc cycles");
    assert_eq!(s.drilled.first, [6, 7], "{:?}\n{out}", s.skipped);
    // The positioning move before corrected the orientation, and the
    // cycle drills with it.
    assert!(s.drilled_axis_error < 0.01, "{s:?}");
}

#[test]
fn an_incremental_cycle_is_reported_at_its_line() {
    let program = "G21 G90 G17\nG0 A-20 C30\nG43 H1\nG0 Z50\nG0 X5 Y5\nG91 G81 X10 Z-4 R-45 F100 L3\nG90 G80\nG0 Z50\nM2\n";
    let l = errors("ac-trunnion", 93, 30.0, "");
    let (out, s, _) = compensate(&l, Settings::new(Dialect::Linuxcnc), program);
    let (why, lines) = s
        .skipped
        .iter()
        .find(|(w, _)| w.contains("incremental distance (G91)"))
        .unwrap_or_else(|| panic!("{:?}", s.skipped));
    assert_eq!(lines.first, [6], "{why}");
    assert_eq!(out.lines().nth(5), program.lines().nth(5));
}

#[test]
fn heidenhain_polar_lines_and_circles_are_rewritten_around_the_pole() {
    // A contour in polar coordinates as written at the control: absolute
    // and incremental radius and angle, circles about the pole both ways,
    // and a pole taken where the tool is (`CC` alone).
    let program = "0 BEGIN PGM POLAR MM\n1 BLK FORM 0.1 Z X-50 Y-50 Z-20\n2 BLK FORM 0.2 X+50 Y+50 Z+0\n3 TOOL CALL 1 Z S4000\n4 L A-20 C+30 R0 FMAX\n5 L X+40 Y+0 Z+50 R0 FMAX\n6 CC X+0 Y+0\n7 L Z-2 F300\n8 LP PR+40 PA+45 F600\n9 LP IPA+45\n10 LP PR+25 IPA+30\n11 CP PA+180 DR+\n12 CP IPA-90 DR-\n13 LP IPR+10 PA+300\n14 CC\n15 LP PR+5 PA+0\n16 L Z+50 R0 FMAX\n17 END PGM POLAR MM\n";
    let l = errors("ac-trunnion", 94, 30.0, "");
    let (out, s) = holds(&l, Dialect::Heidenhain, program, &[], "polar");
    assert_eq!(s.skipped.len(), 1, "{:?}\n{out}", s.skipped);
    assert_eq!(s.skipped[0].1.first, [5], "{:?}", s.skipped);
    // Polar blocks stay polar, with their own words.
    for kw in [
        " LP PR+",
        " IPA+",
        " LP IPR+10 PA+",
        " CP PA+",
        " CP IPA-",
        "\n15 CC\n",
    ] {
        assert!(out.contains(kw), "{kw}\n{out}");
    }
    // The circles turn about a corrected pole, inserted before them.
    assert_eq!(s.inserted, 1, "{out}");
    assert!(
        !out.lines().any(|t| t.contains("LP") && t.contains(" X")),
        "{out}"
    );
}

#[test]
fn a_heidenhain_helix_with_ipa_and_iz_turns_as_often_as_written() {
    let program = "0 BEGIN PGM HELIX MM\n1 TOOL CALL 1 Z S4000\n2 L A-20 C+30 R0 FMAX\n3 CC X+10 Y+5\n4 L X+22 Y+5 Z+2 R0 FMAX\n5 L Z+0 F300\n6 CP IPA+1080 IZ-6 DR+ F500\n7 L X+10 Y+5\n8 L Z+50 R0 FMAX\n9 END PGM HELIX MM\n";
    let l = errors("ac-trunnion", 95, 30.0, "");
    let (out, s) = holds(&l, Dialect::Heidenhain, program, &[], "helix");
    assert_eq!(s.skipped.len(), 1, "{:?}\n{out}", s.skipped);
    // Three turns down 6 mm, around a corrected pole.
    let helix = out.lines().find(|t| t.contains(" CP ")).unwrap();
    assert!(helix.contains("IPA+10") && helix.contains("IZ-"), "{out}");
}

#[test]
fn heidenhain_cycl_call_pos_holes_land_at_their_bottom() {
    // A 3+2 drilling job as a CAM post writes it: the part tilted to
    // A-20 C+30, cycle 200 defined once with its parameters on
    // continuation lines, then called at each hole; the Z of the call is
    // the datum the cycle's surface Q203 counts from (two holes on a step
    // 2 mm down). A third hole is called by M99 on a positioning block.
    let program = "0 BEGIN PGM DRILL MM\n1 BLK FORM 0.1 Z X-50 Y-50 Z-20\n2 BLK FORM 0.2 X+50 Y+50 Z+0\n3 TOOL CALL 5 Z S3000\n4 L A-20 C+30 R0 FMAX\n5 L X+0 Y+0 Z+100 R0 FMAX\n6 CYCL DEF 200 DRILLING ~\n  Q200=+2 ;SET-UP CLEARANCE ~\n  Q201=-8 ;DEPTH ~\n  Q206=+150 ;FEED RATE FOR PLNGNG ~\n  Q202=+3 ;PLUNGING DEPTH ~\n  Q210=+0 ;DWELL TIME AT TOP ~\n  Q203=+0 ;SURFACE COORDINATE ~\n  Q204=+50 ;2ND SET-UP CLEARANCE ~\n  Q211=+0 ;DWELL TIME AT DEPTH\n7 CYCL CALL POS X+10 Y+10 Z+0 FMAX\n8 CYCL CALL POS X+20 Y-5 Z-2 FMAX\n9 CYCL CALL POS X-15 Y+25 Z-2 FMAX M13\n10 L Z+100 R0 FMAX\n11 L X+30 Y+30 R0 FMAX M99\n12 L Z+100 R0 FMAX\n13 END PGM DRILL MM\n";
    let l = errors("ac-trunnion", 97, 30.0, "");
    let (out, s) = holds(
        &l,
        Dialect::Heidenhain,
        program,
        &[16, 17, 18],
        "cycl call pos",
    );
    // File lines: the CYCL DEF takes nine.
    assert_eq!(s.drilled.first, [16, 17, 18], "{:?}\n{out}", s.skipped);
    // Every hole's X, Y and Z datum rewritten; the cycle definition stays
    // (other calls may share it).
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines[6..15], program.lines().collect::<Vec<_>>()[6..15]);
    for (k, line) in lines.iter().enumerate().take(18).skip(15) {
        assert!(line.contains(" CYCL CALL POS X"), "{line}");
        assert_ne!(*line, program.lines().nth(k).unwrap());
    }
    assert!(lines[17].ends_with(" FMAX M13"), "{}", lines[17]);
    // The positioning move before corrected the orientation (line 6), and
    // the cycle drills with it.
    assert!(s.drilled_axis_error < 0.01, "{s:?}");
    // The M99 hole: its positioning block is a move like any other, the
    // depth of the cycle it calls is the CYCL DEF's, said at its line.
    let (why, lines) = s
        .unmodelled
        .iter()
        .find(|(w, _)| w.contains("M99"))
        .unwrap_or_else(|| panic!("{:?}", s.unmodelled));
    assert_eq!(lines.first, [20], "{why}");
}

#[test]
fn heidenhain_roundings_and_chamfers_between_lines_stay_on_the_intended_corner() {
    // A pocket outline at a fixed tilt under TCPM, corners cut by the
    // control: RND R5 and R4 (tangent arcs), CHF 3 (a chamfer). Only the
    // lines' end points are written; the simulator cuts each corner of the
    // lines as written, on the nominal machine for the original and on the
    // erroneous one for the rewrite.
    let program = "0 BEGIN PGM CORNERS MM\n1 BLK FORM 0.1 Z X-50 Y-50 Z-20\n2 BLK FORM 0.2 X+50 Y+50 Z+0\n3 TOOL CALL 1 Z S4000\n4 L A-20 C+30 R0 FMAX\n5 FUNCTION TCPM F TCP AXIS POS PATHCTRL AXIS\n6 L X+10 Y+40 Z+2 A-20 C+30 R0 FMAX\n7 L Z-1 F300\n8 L X+40 Y+25 F600\n9 RND R5 F100\n10 L X+10 Y+5\n11 CHF 3\n12 L X-20 Y+5\n13 RND R4\n14 L X-20 Y+40\n15 L Z+50 R0 FMAX\n16 FUNCTION RESET TCPM\n17 END PGM CORNERS MM\n";
    let l = errors("ac-trunnion", 98, 30.0, "");
    let (out, s) = holds(&l, Dialect::Heidenhain, program, &[], "corners");
    assert_eq!(s.skipped.len(), 1, "{:?}\n{out}", s.skipped);
    assert_eq!(s.skipped[0].1.first, [5], "{:?}", s.skipped);
    // The elements stay as written; the lines around them are rewritten.
    for k in [9, 11, 13] {
        assert_eq!(out.lines().nth(k), program.lines().nth(k));
    }
    assert_ne!(out.lines().nth(8), program.lines().nth(8));
    // The simulator really cuts the corner: on the nominal machine (TCPM:
    // the tip is the program point) the RND R5 samples lie on the circle
    // of radius 5 whose centre is R / sin(a/2) from the corner along the
    // bisector of the corner's angle a, and none reaches the corner.
    let nominal = Model::new(l.model.kin.clone(), vec![]);
    let samples = simulate(
        &nominal,
        &[],
        Dialect::Heidenhain,
        Coordinates::Auto,
        program,
        0.2,
    );
    let (a, p, b) = ([10.0, 40.0], [40.0, 25.0], [10.0, 5.0]);
    let unit = |v: [f64; 2]| {
        let n = v[0].hypot(v[1]);
        [v[0] / n, v[1] / n]
    };
    let (u, w) = (
        unit([a[0] - p[0], a[1] - p[1]]),
        unit([b[0] - p[0], b[1] - p[1]]),
    );
    let angle = (u[0] * w[0] + u[1] * w[1]).acos();
    let bis = unit([u[0] + w[0], u[1] + w[1]]);
    let d = 5.0 / (angle / 2.0).sin();
    let center = [p[0] + d * bis[0], p[1] + d * bis[1]];
    let arc: Vec<&Sample> = samples.iter().filter(|x| x.line == 10).collect();
    assert!(arc.len() > 5, "{}", arc.len());
    for x in &arc {
        let t = x.nominal.tip;
        let r = (t.x - center[0]).hypot(t.y - center[1]);
        assert!((r - 5.0).abs() < 1e-9 && (t.z + 1.0).abs() < 1e-9, "{t:?}");
    }
    let nearest = samples
        .iter()
        .map(|x| (x.nominal.tip.x - p[0]).hypot(x.nominal.tip.y - p[1]))
        .fold(f64::INFINITY, f64::min);
    assert!(nearest > d - 5.0 - 1e-9, "{nearest}");
}

#[test]
fn a_rounding_that_a_linear_axis_scale_error_bends_is_reported_at_its_line() {
    // X and Y scale errors (0.3 and -0.2 mm/m) are no rigid motion: the
    // control's R20 arc between the corrected lines is not the intended
    // arc on the machine. The rounding is reported with how far it
    // leaves it, and the simulator agrees that it does.
    let program = "0 BEGIN PGM BENT MM\n1 TOOL CALL 1 Z S4000\n2 L A-20 C+30 R0 FMAX\n3 L X+10 Y+40 Z+2 R0 FMAX\n4 L Z-1 F300\n5 L X+45 Y+40 F600\n6 RND R20\n7 L X+45 Y+0\n8 L Z+50 R0 FMAX\n9 END PGM BENT MM\n";
    let extra = "effects:\n  linear_scale: {EXX: 300.0, EYY: -200.0}\n";
    let l = errors("ac-trunnion", 99, 30.0, extra);
    let (out, s, _) = compensate(&l, Settings::new(Dialect::Heidenhain), program);
    let (why, lines) = s
        .skipped
        .iter()
        .find(|(w, _)| w.starts_with("rounding or chamfer"))
        .unwrap_or_else(|| panic!("{:?}", s.skipped));
    assert_eq!(lines.first, [7], "{why}");
    let reported: f64 = why
        .split("by up to ")
        .nth(1)
        .and_then(|t| t.split(' ').next())
        .and_then(|t| t.parse().ok())
        .unwrap_or_else(|| panic!("{why}"));
    let nominal = Model::new(l.model.kin.clone(), vec![]);
    let d = Dialect::Heidenhain;
    let intended = simulate(&nominal, &[], d, Coordinates::Auto, program, 0.01);
    let actual = simulate(&l.model, &l.theta, d, Coordinates::Auto, &out, 0.05);
    let arc: Vec<_> = intended.iter().filter(|x| x.line == 7).collect();
    let seg =
        |q: &nalgebra::Vector3<f64>, a: &nalgebra::Vector3<f64>, b: &nalgebra::Vector3<f64>| {
            let v = b - a;
            let t = ((q - a).dot(&v) / v.norm_squared()).clamp(0.0, 1.0);
            (a + v * t - q).norm()
        };
    let worst = actual
        .iter()
        .filter(|x| x.line == 7)
        .map(|x| {
            arc.windows(2)
                .map(|w| seg(&x.actual.tip, &w[0].nominal.tip, &w[1].nominal.tip))
                .fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max)
        * 1e3;
    assert!(
        worst > 1.0 && worst <= reported + 0.01,
        "{worst} um, reported {reported} um"
    );
}

#[test]
fn heidenhain_elements_not_corrected_yet_are_reported_at_their_lines() {
    let program = "0 BEGIN PGM REST MM\n1 TOOL CALL 1 Z S4000\n2 L A-20 C+30 R0 FMAX\n3 L X+0 Y+0 Z+2 R0 FMAX\n4 L Z-1 F300\n5 L X+20 F600\n6 CC X+20 Y+10\n7 C X+30 Y+10 DR+\n8 RND R2\n9 L Y+30\n10 CT X-5 Y+15\n11 L Z+50 R0 FMAX\n12 CYCL DEF 200 DRILLING\n13 CYCL CALL POS X+10 Y+10 Z+0 FMAX\n14 END PGM REST MM\n";
    let l = errors("ac-trunnion", 96, 30.0, "");
    let (out, s, _) = compensate(&l, Settings::new(Dialect::Heidenhain), program);
    for (what, line) in [
        // File lines: block n is line n + 1. A rounding after a circle is
        // not followed: the line after it stays as written.
        ("rounding or chamfer at line 9", 10),
        // A CT after that line: the direction it starts in is the one of
        // a line left as written.
        (
            "tangential circle (CT) left as written: the element before",
            11,
        ),
        ("CYCL CALL POS", 14),
    ] {
        let (_, lines) = s
            .skipped
            .iter()
            .find(|(w, _)| w.contains(what))
            .unwrap_or_else(|| panic!("{what}: {:?}", s.skipped));
        assert_eq!(lines.first, [line], "{what}");
        // As written (the pole inserted before the circle renumbers it).
        let text = program.lines().nth(line - 1).unwrap();
        let body = text.split_once(' ').unwrap().1;
        assert!(
            out.lines().any(|t| t.split_once(' ').unwrap().1 == body),
            "{body}\n{out}"
        );
    }
}

/// The centre of the circle that leaves `s` in the direction from `a` to
/// `s` and runs through `e`, found as the point where the normal at `s`
/// meets the perpendicular bisector of `s`-`e` (independently of the
/// closed form the interpreter uses).
fn tangent_circle_centre(a: [f64; 2], s: [f64; 2], e: [f64; 2]) -> [f64; 2] {
    // Normal at s: s + k (-(s-a).y, (s-a).x); bisector: points p with
    // (p - m).(e - s) = 0, m the midpoint.
    let n = [-(s[1] - a[1]), s[0] - a[0]];
    let m = [(s[0] + e[0]) / 2.0, (s[1] + e[1]) / 2.0];
    let d = [e[0] - s[0], e[1] - s[1]];
    let k = ((m[0] - s[0]) * d[0] + (m[1] - s[1]) * d[1]) / (n[0] * d[0] + n[1] * d[1]);
    [s[0] + k * n[0], s[1] + k * n[1]]
}

#[test]
fn heidenhain_tangential_circles_stay_ct_and_on_the_intended_arc() {
    // The manual's own contour (L X+0 Y+25, L X+25 Y+30, CT X+45 Y+20,
    // L Y+0) at a fixed tilt under TCPM, continued by a CT after a line
    // and a CT after that CT. The CTs keep their form: only their end
    // points are written, and the control's arc from the corrected lines
    // is the intended one on the erroneous machine.
    let program = "0 BEGIN PGM TANGENT MM\n1 BLK FORM 0.1 Z X-50 Y-50 Z-20\n2 BLK FORM 0.2 X+50 Y+50 Z+0\n3 TOOL CALL 1 Z S4000\n4 L A-20 C+30 R0 FMAX\n5 FUNCTION TCPM F TCP AXIS POS PATHCTRL AXIS\n6 L X+0 Y+25 Z+2 A-20 C+30 R0 FMAX\n7 L Z-1 F300\n8 L X+25 Y+30 F600\n9 CT X+45 Y+20\n10 L Y+0\n11 CT X+20 Y-15\n12 CT X+0 Y+0\n13 L Z+50 R0 FMAX\n14 FUNCTION RESET TCPM\n15 END PGM TANGENT MM\n";
    let l = errors("ac-trunnion", 101, 30.0, "");
    let d = Dialect::Heidenhain;
    let zero = errors("ac-trunnion", 0, 0.0, "");
    let (out, s0, _) = compensate(&zero, Settings::new(d), program);
    assert_eq!(out, program, "zero error must give the same bytes");
    assert_eq!(s0.changed, 0);
    let (out, s, _) = compensate(&l, Settings::new(d), program);
    // On the path within the tolerance all along; a CT carries X and Y
    // only, so its end keeps the Z of its start, which the correction
    // tilts by a fraction of a micrometre: its end lies on the intended
    // one within the tolerance, every other end within 0.1 um.
    let nominal = Model::new(l.model.kin.clone(), vec![]);
    assert_on_path(
        &simulate(&nominal, &[], d, Coordinates::Auto, program, 0.01),
        &simulate(&l.model, &l.theta, d, Coordinates::Auto, &out, 0.1),
        0.001,
        "tangential",
    );
    let ends = |m: &Model, th: &[f64], p: &str| -> Vec<Sample> {
        simulate(m, th, d, Coordinates::Auto, p, 0.0)
            .into_iter()
            .filter(|x| x.fraction == 1.0)
            .collect()
    };
    let (a, b) = (ends(&nominal, &[], program), ends(&l.model, &l.theta, &out));
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(&b) {
        let miss = (x.nominal.tip - y.actual.tip).norm();
        let ct = [10, 12, 13].contains(&x.line);
        assert!(
            miss < if ct { 1e-3 } else { 1e-4 },
            "line {}: {miss}",
            x.line
        );
    }
    let before = a
        .iter()
        .zip(&ends(&l.model, &l.theta, program))
        .map(|(x, y)| (x.nominal.tip - y.actual.tip).norm())
        .fold(0.0, f64::max);
    assert!(before > 0.005, "{before}");
    assert_eq!(s.skipped.len(), 1, "{:?}\n{out}", s.skipped);
    assert_eq!(s.skipped[0].1.first, [5], "{:?}", s.skipped);
    assert!(s.linearized.first.is_empty(), "{out}");
    for k in [9, 11, 12] {
        let (a, b) = (out.lines().nth(k).unwrap(), program.lines().nth(k).unwrap());
        assert!(a.split(' ').nth(1) == Some("CT") && a != b, "{a}");
    }
    // The simulator cuts the arc as the control does: on the nominal
    // machine (TCPM: the tip is the program point) the samples of the
    // first CT lie on the circle through its ends that leaves (25, 30) in
    // the line's direction, and leave it in that direction.
    let samples = simulate(&nominal, &[], d, Coordinates::Auto, program, 0.2);
    let (a, p, e) = ([0.0, 25.0], [25.0, 30.0], [45.0, 20.0]);
    let c = tangent_circle_centre(a, p, e);
    let r = (p[0] - c[0]).hypot(p[1] - c[1]);
    let arc: Vec<&Sample> = samples.iter().filter(|x| x.line == 10).collect();
    assert!(arc.len() > 5, "{}", arc.len());
    for x in &arc {
        let t = x.nominal.tip;
        let d = (t.x - c[0]).hypot(t.y - c[1]);
        assert!((d - r).abs() < 1e-9 && (t.z + 1.0).abs() < 1e-9, "{t:?}");
    }
    let last = arc.last().unwrap().nominal.tip;
    assert!((last.x - e[0]).abs() < 1e-9 && (last.y - e[1]).abs() < 1e-9);
    let first = arc[0].nominal.tip;
    let (dir, line) = ([first.x - p[0], first.y - p[1]], [p[0] - a[0], p[1] - a[1]]);
    let cos =
        (dir[0] * line[0] + dir[1] * line[1]) / (dir[0].hypot(dir[1]) * line[0].hypot(line[1]));
    assert!(cos > 0.999, "the arc leaves the line at acos {cos}");
}

#[test]
fn a_tangential_circle_that_a_scale_error_bends_is_written_as_lines() {
    // X and Y scale errors are no rigid motion: no circle from the
    // corrected line through the corrected end is the intended arc on the
    // machine. The CT is written as lines, which hold the tolerance.
    let program = "0 BEGIN PGM BENTCT MM\n1 TOOL CALL 1 Z S4000\n2 L A-20 C+30 R0 FMAX\n3 L X+0 Y+40 Z+2 R0 FMAX\n4 L Z-1 F300\n5 L X+20 Y+40 F600\n6 CT X+40 Y+0\n7 L X+40 Y-10\n8 L Z+50 R0 FMAX\n9 END PGM BENTCT MM\n";
    let extra = "effects:\n  linear_scale: {EXX: 300.0, EYY: -200.0}\n";
    let l = errors("ac-trunnion", 102, 30.0, extra);
    let (out, s, _) = compensate(&l, Settings::new(Dialect::Heidenhain), program);
    assert_eq!(s.linearized.first, [7], "{out}");
    assert!(!out.contains(" CT "), "{out}");
    check_held(
        &l,
        Dialect::Heidenhain,
        Coordinates::Auto,
        program,
        &out,
        0.001,
        &[],
        "bent CT",
    );
}

/// LinuxCNC's polar words: `@` the distance and `^` the angle of X Y from
/// the origin of the XY plane; the word left out is the position's; in
/// G91 `@` adds to the distance along the position's direction and `^`
/// turns about the origin (LinuxCNC's G-code reference, "Polar
/// Coordinates"). The holes of a G81 are given so too. Corrected, the
/// words stay polar (rewritten so the corrected X and Y land) and the
/// rewrite driven through the erroneous machine reaches every point.
#[test]
fn linuxcnc_polar_words_are_followed_and_corrected_in_their_own_words() {
    let program = "G21 G90 G17 G94\nG0 X0 Y0 Z50 A-20 C30\nG0 @20 ^30 Z10\nG1 @25 F500\nG1 ^60\nG91 G1 ^30\nG1 @-5 Z-2\nG90 G1 @15 ^-45 Z6\nG0 Z20\nG98 G81 @20 ^120 R12 Z2\n@20 ^150\nG80\nG0 Z50\nM2\n";
    let at = |r: f64, a: f64, z: f64| {
        let (s, c) = a.to_radians().sin_cos();
        [r * c, r * s, z]
    };
    let p8 = at(15.0, -45.0, 6.0);
    let want = [
        [0.0, 0.0, 50.0],
        at(20.0, 30.0, 10.0),
        at(25.0, 30.0, 10.0),
        at(25.0, 60.0, 10.0),
        at(25.0, 90.0, 10.0),
        at(20.0, 90.0, 8.0),
        p8,
        [p8[0], p8[1], 20.0],
        at(20.0, 120.0, 2.0),
        at(20.0, 150.0, 2.0),
        [at(20.0, 150.0, 0.0)[0], at(20.0, 150.0, 0.0)[1], 50.0],
    ];
    let l = errors("ac-trunnion", 93, 30.0, "");
    let (out, s) = crate::macros::lands(&l, Dialect::Linuxcnc, program, false, &want, "polar");
    assert_eq!(s.drilled.first, [10, 11], "{s:?}");
    // Every polar block keeps its polar words (gaining the other where the
    // corrected point needs it) and gets no X or Y.
    for (a, b) in program.lines().zip(out.lines()).skip(2).take(9) {
        if a.contains('@') || a.contains('^') {
            assert_ne!(a, b);
            assert!(!b.contains('X') && !b.contains('Y'), "{b}");
            for w in ['@', '^'] {
                assert!(!a.contains(w) || b.contains(w), "{a} -> {b}");
            }
        }
    }
    // Where LinuxCNC refuses the words, they are left as written, with why.
    let refused = "G21 G90 G17 G94\nG0 X0 Y0 Z50 A-20 C30\nG1 @10 Z40 F500\nG1 X5 @10 ^30\nG18 G1 @10 ^30\nM2\n";
    let (_, s, _) = crate::compensate::compensate(
        &l,
        {
            let mut st = Settings::new(Dialect::Linuxcnc);
            st.coordinates = Coordinates::Tcp;
            st
        },
        refused,
    );
    let lines = |what: &str| {
        s.skipped
            .iter()
            .find(|(r, _)| r.contains(what))
            .map(|(_, at)| at.first.clone())
            .unwrap_or_default()
    };
    assert_eq!(lines("at the origin"), [3], "{:?}", s.skipped);
    assert_eq!(lines("X or Y with a polar word"), [4], "{:?}", s.skipped);
    assert_eq!(lines("outside the XY plane"), [5], "{:?}", s.skipped);
}

/// Every drilling cycle FANUC reads as a hole at X Y to the depth Z from
/// the R level (peck G73, left-hand tap G74, fine boring G76, dwell G82,
/// tap G84, bore G85-G89; G87 bores back up from R below the piece to Z)
/// is corrected as its hole: the tip reaches each hole's bottom on the
/// erroneous machine where the program meant it, and the cycle words
/// (Q, P, R, F) stay as written.
#[test]
fn every_fanuc_drilling_cycle_code_is_corrected_as_its_hole() {
    let cycles = [
        "G73 X10. Y10. Z-6. R2. Q1.5 F150.",
        "G74 X20. Y10. Z-6. R2. F100.",
        "G76 X30. Y10. Z-6. R2. Q0.2 F80.",
        "G82 X10. Y20. Z-6. R2. P500 F150.",
        "G84 X20. Y20. Z-6. R2. F100.",
        "G85 X30. Y20. Z-6. R2. F80.",
        "G86 X10. Y30. Z-6. R2. F80.",
        "G87 X20. Y30. Z2. R-8. Q0.2 F80.",
        "G88 X30. Y30. Z-6. R2. P300 F80.",
        "G89 X20. Y40. Z-6. R2. P300 F80.",
    ];
    let mut program = String::from(
        "%\nO1002 (EVERY CYCLE)\nG90 G21 G17 G40 G49 G80\nG0 B30. C45.\nG43 H1 Z100.\nG0 X0. Y0.\n",
    );
    for c in cycles {
        program.push_str("G98 ");
        program.push_str(c);
        program.push('\n');
    }
    program.push_str("G80\nG0 Z100.\nM30\n%\n");
    let first = 7;
    let holes: Vec<usize> = (first..first + cycles.len()).collect();
    let l = errors("bc-trunnion", 94, 30.0, "");
    let (out, s) = holds(&l, Dialect::Fanuc, &program, &holes, "every fanuc cycle");
    assert_eq!(s.drilled.first, holes, "{:?}\n{out}", s.skipped);
    for (line, c) in out.lines().skip(first - 1).zip(cycles) {
        let code = &c[..4];
        let tail = &c[c.find(" R").unwrap()..];
        assert!(
            line.starts_with(&format!("G98 {code}")) && line.ends_with(tail),
            "{line}"
        );
        assert_ne!(&line[4..], c, "{code}: not corrected");
    }
}

/// LinuxCNC's drilling cycles other than G81 (peck G73, dwell G82, chip
/// break G83, tap G84, bore G85-G89), and the same program with the holes
/// given in the G99 return: each hole is corrected.
#[test]
fn every_linuxcnc_drilling_cycle_code_is_corrected_as_its_hole() {
    let cycles = [
        "G73 X5 Y5 Z-4 R1 Q1 F100",
        "G82 X15 Y5 Z-4 R1 P0.5 F100",
        "G83 X25 Y5 Z-4 R1 Q1 F100",
        "G84 X5 Y15 Z-4 R1 F100",
        "G85 X15 Y15 Z-4 R1 F100",
        "G86 X25 Y15 Z-4 R1 F100",
        "G88 X5 Y25 Z-4 R1 F100",
        "G89 X15 Y25 Z-4 R1 P0.5 F100",
    ];
    let mut program = String::from("G21 G90 G17\nG0 A-20 C30\nG43 H1\nG0 Z50\nG0 X0 Y0\n");
    for c in cycles {
        program.push_str(c);
        program.push('\n');
    }
    program.push_str("G80\nG0 Z50\nM2\n");
    let holes: Vec<usize> = (6..6 + cycles.len()).collect();
    let l = errors("ac-trunnion", 95, 30.0, "");
    let (out, s) = holds(&l, Dialect::Linuxcnc, &program, &[], "every linuxcnc cycle");
    assert_eq!(s.drilled.first, holes, "{:?}\n{out}", s.skipped);
    assert!(s.drilled_axis_error < 0.01, "{s:?}");
}

/// The largest end misses: `program` on
/// the nominal machine against `rewritten` on the erroneous one, pairwise,
/// the lines `loose` (ends the control computes from the written
/// directions: an `APPR LT`'s auxiliary point, a `DEP LT`'s end) apart.
fn end_misses(l: &LoadedErrors, program: &str, rewritten: &str, loose: &[usize]) -> (f64, f64) {
    let d = Dialect::Heidenhain;
    let nominal = Model::new(l.model.kin.clone(), vec![]);
    let ends = |m: &Model, th: &[f64], p: &str| -> Vec<Sample> {
        simulate(m, th, d, Coordinates::Auto, p, 0.0)
            .into_iter()
            .filter(|x| x.fraction == 1.0)
            .collect()
    };
    let (a, b) = (
        ends(&nominal, &[], program),
        ends(&l.model, &l.theta, rewritten),
    );
    assert_eq!(a.len(), b.len(), "the same points in both");
    let (mut tight, mut wide) = (0.0f64, 0.0f64);
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x.line, y.line);
        let miss = (x.nominal.tip - y.actual.tip).norm();
        if loose.contains(&x.line) {
            wide = wide.max(miss);
        } else {
            tight = tight.max(miss);
        }
    }
    (tight, wide)
}

/// What the `APPR`/`DEP` path tests share, on `ac-trunnion` with error
/// seed `seed`: the rewrite at zero error is byte-identical and changes
/// nothing; with the errors, only the rotary positioning before X and Y
/// are known (line 5) is left; the rewrite on the erroneous machine stays
/// on the intended path within 1 um; every end point lands within 0.1 um
/// except those of the lines in `wide` (which the control computes from
/// the written directions), within 1 um; as written, the program misses
/// by more than 5 um. Returns the rewrite, the number of statements the
/// zero-error run left as written, and the tip positions the nominal
/// machine passes through at a line.
fn appr_dep_on_path(
    program: &str,
    seed: u64,
    wide: &[usize],
    what: &str,
) -> (String, usize, impl Fn(usize) -> Vec<[f64; 3]>) {
    let l = errors("ac-trunnion", seed, 30.0, "");
    let d = Dialect::Heidenhain;
    let zero = errors("ac-trunnion", 0, 0.0, "");
    let (out, s0, _) = compensate(&zero, Settings::new(d), program);
    assert_eq!(out, program, "zero error must give the same bytes");
    assert_eq!(s0.changed, 0);
    let (out, s, _) = compensate(&l, Settings::new(d), program);
    assert_eq!(s.skipped.len(), 1, "{:?}\n{out}", s.skipped);
    assert_eq!(s.skipped[0].1.first, [5], "{:?}", s.skipped);
    let nominal = Model::new(l.model.kin.clone(), vec![]);
    assert_on_path(
        &simulate(&nominal, &[], d, Coordinates::Auto, program, 0.01),
        &simulate(&l.model, &l.theta, d, Coordinates::Auto, &out, 0.1),
        0.001,
        what,
    );
    let (tight, loose) = end_misses(&l, program, &out, wide);
    assert!(tight < 1e-4 && loose < 1e-3, "{tight} {loose}");
    let (before, _) = end_misses(&l, program, program, &[]);
    assert!(before > 0.005, "{before}");
    let samples = simulate(&nominal, &[], d, Coordinates::Auto, program, 0.0);
    let at = move |line: usize| -> Vec<[f64; 3]> {
        samples
            .iter()
            .filter(|x| x.line == line)
            .map(|x| [x.nominal.tip.x, x.nominal.tip.y, x.nominal.tip.z])
            .collect()
    };
    (out, s0.skipped.len(), at)
}

/// Whether two points agree to 1 nm.
fn near(p: [f64; 3], q: [f64; 3]) -> bool {
    (0..3).all(|i| (p[i] - q[i]).abs() < 1e-9)
}

/// HEIDENHAIN `APPR LT` and `DEP LT` without radius compensation: the
/// control runs from the start to an auxiliary point `LEN` back along the
/// first contour element, then tangentially onto it, and leaves the last
/// one `LEN` on along its direction. A contour at a fixed tilt under
/// TCPM, entered on a line and left after it, then entered on a circle
/// and left after that circle: the approach's first contour point is
/// rewritten, the departure (which has no coordinate) stays as written,
/// and the rewrite on the erroneous machine stays on the intended path
/// through the auxiliary points.
#[test]
fn heidenhain_appr_lt_and_dep_lt_stay_on_the_intended_path() {
    let program = "0 BEGIN PGM APPR MM\n1 BLK FORM 0.1 Z X-50 Y-50 Z-20\n2 BLK FORM 0.2 X+50 Y+50 Z+0\n3 TOOL CALL 1 Z S4000\n4 L A-20 C+30 R0 FMAX\n5 FUNCTION TCPM F TCP AXIS POS PATHCTRL AXIS\n6 L X+40 Y-10 Z+2 A-20 C+30 R0 FMAX\n7 L Z-1 F300\n8 APPR LT X+20 Y+0 LEN10 R0 F600\n9 L X+35 Y+15\n10 L X+35 Y+30\n11 DEP LT LEN12.5\n12 L X-10 Y+30 R0 FMAX\n13 APPR LT X+0 Y+20 LEN5 F600\n14 CR X+10 Y+10 R+10 DR+\n15 DEP LT LEN8\n16 L Z+50 R0 FMAX\n17 FUNCTION RESET TCPM\n18 END PGM APPR MM\n";
    // On the intended path within the tolerance all along; every end point
    // within 0.1 um, except the ones the control computes from the
    // written directions (the auxiliary points, the departures' ends),
    // which the correction's tilt of the plane moves by a fraction of the
    // tolerance.
    let (out, zero_skipped, at) = appr_dep_on_path(program, 103, &[9, 12, 14, 16], "appr/dep");
    assert_eq!(zero_skipped, 1);
    // The approaches keep their form with the first contour point
    // rewritten; the departures are the program's own text.
    for k in [8, 13] {
        let (a, b) = (out.lines().nth(k).unwrap(), program.lines().nth(k).unwrap());
        assert!(
            a.contains(" APPR LT X") && a.contains(" LEN") && a != b,
            "{a}"
        );
    }
    for k in [11, 15] {
        assert_eq!(out.lines().nth(k), program.lines().nth(k));
    }
    // The simulator runs the approach as the control does: on the nominal
    // machine (TCPM: the tip is the program point) the first APPR LT
    // passes through (20, 0) - 10 (1, 1) / sqrt(2), and the line after
    // that point runs along the first element's direction; the second one
    // through (0, 25), 5 before (0, 20) against the circle's start
    // direction -Y; the departures end 12.5 along +Y from (35, 30) and 8
    // along +X from (10, 10).
    let h = 10.0 / 2f64.sqrt();
    let first = at(9);
    assert_eq!(first.len(), 2, "{first:?}");
    assert!(near(first[0], [20.0 - h, -h, -1.0]), "{first:?}");
    assert!(near(first[1], [20.0, 0.0, -1.0]), "{first:?}");
    let second = at(14);
    assert!(near(second[0], [0.0, 25.0, -1.0]), "{second:?}");
    assert!(near(at(12)[0], [35.0, 42.5, -1.0]), "{:?}", at(12));
    assert!(near(at(16)[0], [18.0, 10.0, -1.0]), "{:?}", at(16));
}

/// The shape of the one real program with `APPR`/`DEP` in the corpus
/// (aptpostprocessor PROFILE.h: `APPR LT .. LEN10 RR`, four lines round a
/// rectangle, `DEP LT LEN10 R0`), with its coordinates as numbers: under
/// RR the programmed contour, the approach's path through its auxiliary
/// point and the departure included, is what is corrected (the control
/// offsets it by the tool radius afterwards, which fivecal does not
/// model). Byte-identical at zero error; on the erroneous machine on the
/// intended contour within the tolerance, with the departure kept as
/// written and the approach's first contour point rewritten.
#[test]
fn heidenhain_appr_lt_under_rr_round_a_profile_stays_on_the_programmed_contour() {
    let program = "0 BEGIN PGM PROFILE MM\n1 BLK FORM 0.1 Z X-50 Y-50 Z-20\n2 BLK FORM 0.2 X+50 Y+50 Z+0\n3 TOOL CALL 1 Z S3500\n4 L A-20 C+30 R0 FMAX\n5 FUNCTION TCPM F TCP AXIS POS PATHCTRL AXIS\n6 L X-40 Y-40 Z+2 A-20 C+30 R0 FMAX\n7 L Z-2.5 F300 M3 M8\n8 APPR LT X-30 Y-30 LEN10 RR F300\n9 L X+30\n10 L Y+30\n11 L X-30\n12 L Y-30\n13 DEP LT LEN10 R0\n14 L Z+50 R0 FMAX\n15 M9 M5\n16 FUNCTION RESET TCPM\n17 END PGM PROFILE MM\n";
    let (out, _, at) = appr_dep_on_path(program, 106, &[9, 14], "profile under RR");
    let (a, b) = (out.lines().nth(8).unwrap(), program.lines().nth(8).unwrap());
    assert!(
        a.starts_with("8 APPR LT X") && a.ends_with(" LEN10 RR F300") && a != b,
        "{a}"
    );
    assert_eq!(out.lines().nth(13), program.lines().nth(13));
    // The programmed contour's path on the nominal machine: from PS
    // (-40, -40) to PH (-40, -30), 10 before PA against +X, then to PA;
    // the departure ends 10 on along -Y from (-30, -30).
    let appr = at(9);
    assert_eq!(appr.len(), 2, "{appr:?}");
    assert!(near(appr[0], [-40.0, -30.0, -2.5]), "{appr:?}");
    assert!(near(appr[1], [-30.0, -30.0, -2.5]), "{appr:?}");
    assert!(near(at(14)[0], [-30.0, -40.0, -2.5]), "{:?}", at(14));
}

/// HEIDENHAIN `APPR LN`/`DEP LN` under RR round the same profile: the
/// auxiliary point lies `LEN` from the first contour point square to the
/// first element, the departure's end `LEN` from the last contour point
/// square to the last one, both on the right of the direction of travel
/// (the side RR puts the tool on; the programmed contour, radius zero).
/// Byte-identical at zero error; on the intended path within the
/// tolerance on the erroneous machine.
#[test]
fn heidenhain_appr_ln_and_dep_ln_under_rr_stay_on_the_programmed_contour() {
    let program = "0 BEGIN PGM PROFILN MM\n1 BLK FORM 0.1 Z X-50 Y-50 Z-20\n2 BLK FORM 0.2 X+50 Y+50 Z+0\n3 TOOL CALL 1 Z S3500\n4 L A-20 C+30 R0 FMAX\n5 FUNCTION TCPM F TCP AXIS POS PATHCTRL AXIS\n6 L X-45 Y-45 Z+2 A-20 C+30 R0 FMAX\n7 L Z-2.5 F300 M3 M8\n8 APPR LN X-30 Y-30 LEN10 RR F300\n9 L X+30\n10 L Y+30\n11 L X-30\n12 L Y-30\n13 DEP LN LEN10 R0\n14 L X-40 Y+20 RL F300\n15 APPR LN X-20 Y+20 LEN5 RL\n16 CR X-10 Y+10 R+10 DR-\n17 DEP LN LEN8\n18 L Z+50 R0 FMAX\n19 M9 M5\n20 FUNCTION RESET TCPM\n21 END PGM PROFILN MM\n";
    let (out, _, at) = appr_dep_on_path(program, 106, &[9, 14, 16, 18], "appr ln/dep ln");
    for k in [8, 15] {
        let (a, b) = (out.lines().nth(k).unwrap(), program.lines().nth(k).unwrap());
        assert!(
            a.contains(" APPR LN X") && a.contains(" LEN") && a != b,
            "{a}"
        );
    }
    for k in [13, 17] {
        assert_eq!(out.lines().nth(k), program.lines().nth(k));
    }
    // On the nominal machine: the first approach through (-30, -40), right
    // of +X below PA; the departure to (-40, -30), right of -Y. Under RL
    // the second approach through (-20, 25), left of the clockwise
    // circle's start direction +X about (-20, 10); the departure from
    // (-10, 10), where that circle runs along -Y, to its left, (-2, 10).
    let appr = at(9);
    assert_eq!(appr.len(), 2, "{appr:?}");
    assert!(near(appr[0], [-30.0, -40.0, -2.5]), "{appr:?}");
    assert!(near(appr[1], [-30.0, -30.0, -2.5]), "{appr:?}");
    assert!(near(at(14)[0], [-40.0, -30.0, -2.5]), "{:?}", at(14));
    assert!(near(at(16)[0], [-20.0, 25.0, -2.5]), "{:?}", at(16));
    assert!(near(at(18)[0], [-2.0, 10.0, -2.5]), "{:?}", at(18));
}

/// The nominal machine's tip positions (TCPM: the program points) along
/// the leg of an `APPR` (file line `line`) after its auxiliary point,
/// sampled every `step` mm, with the fraction of the leg each is at: the
/// samples of that line after the first that ends a leg (PH).
fn after_aux(program: &str, line: usize, step: f64) -> Vec<(f64, [f64; 3])> {
    let l = errors("ac-trunnion", 0, 0.0, "");
    let nominal = Model::new(l.model.kin.clone(), vec![]);
    let samples = simulate(
        &nominal,
        &[],
        Dialect::Heidenhain,
        Coordinates::Auto,
        program,
        step,
    );
    let at: Vec<_> = samples.iter().filter(|x| x.line == line).collect();
    let ph = at.iter().position(|x| x.fraction == 1.0).unwrap();
    at[ph + 1..]
        .iter()
        .map(|x| {
            (
                x.fraction,
                [x.nominal.tip.x, x.nominal.tip.y, x.nominal.tip.z],
            )
        })
        .collect()
}

/// Whether `p` lies on the circle about `c` (XY) of radius `r` at the
/// angle `t` (rad), at depth `z`, to 1 nm.
fn on_circle(p: [f64; 3], c: [f64; 2], r: f64, t: f64, z: f64) -> bool {
    near(p, [c[0] + r * t.cos(), c[1] + r * t.sin(), z])
}

/// HEIDENHAIN `APPR CT`/`DEP CT` under RR and RL: the control runs from
/// the start to an auxiliary point, then on an arc of radius |R| through
/// the centre angle CCA tangentially onto the first contour element, and
/// leaves the last one on such an arc; the arc turns as RL/RR and the
/// sign of R say (TNC7 user's manuals: RR with R positive clockwise, RL
/// with R negative clockwise, RL with R positive counter-clockwise).
/// Round the profile under RR, then onto and off a circle under RL:
/// byte-identical at zero error; on the intended path, arcs included,
/// within the tolerance on the erroneous machine; the approaches' first
/// contour points rewritten, the departures (no coordinate) as written.
#[test]
fn heidenhain_appr_ct_and_dep_ct_stay_on_the_intended_arcs() {
    let program = "0 BEGIN PGM PROFICT MM\n1 BLK FORM 0.1 Z X-50 Y-50 Z-20\n2 BLK FORM 0.2 X+50 Y+50 Z+0\n3 TOOL CALL 1 Z S3500\n4 L A-20 C+30 R0 FMAX\n5 FUNCTION TCPM F TCP AXIS POS PATHCTRL AXIS\n6 L X-45 Y-45 Z+2 A-20 C+30 R0 FMAX\n7 L Z-2.5 F300 M3 M8\n8 APPR CT X-30 Y-30 CCA90 R+10 RR F300\n9 L X+30\n10 L Y+30\n11 L X-30\n12 L Y-30\n13 DEP CT CCA90 R+10 F300\n14 L X-10 Y+40 R0 F300\n15 APPR CT X-20 Y+20 CCA60 R-5 RL\n16 CR X-10 Y+10 R+10 DR-\n17 DEP CT CCA120 R+4\n18 L Z+50 R0 FMAX\n19 M9 M5\n20 FUNCTION RESET TCPM\n21 END PGM PROFICT MM\n";
    let (out, _, at) = appr_dep_on_path(program, 106, &[9, 14, 16, 18], "appr ct/dep ct");
    for k in [8, 15] {
        let (a, b) = (out.lines().nth(k).unwrap(), program.lines().nth(k).unwrap());
        assert!(
            a.contains(" APPR CT X") && a.contains(" CCA") && a != b,
            "{a}"
        );
    }
    for k in [13, 17] {
        assert_eq!(out.lines().nth(k), program.lines().nth(k));
    }
    let z = -2.5;
    let deg = |a: f64| a.to_radians();
    // By hand. First approach, RR R+10: clockwise; PA (-30, -30), the
    // first element along +X, so the centre 10 to its right, (-30, -40);
    // PA at 90 deg about it, PH 90 deg back against a clockwise turn, at
    // 180 deg: (-40, -40).
    let appr = at(9);
    assert_eq!(appr.len(), 2, "{appr:?}");
    assert!(near(appr[0], [-40.0, -40.0, z]), "{appr:?}");
    assert!(near(appr[1], [-30.0, -30.0, z]), "{appr:?}");
    let arc = after_aux(program, 9, 1.0);
    assert!(arc.len() > 5, "{arc:?}");
    for &(u, p) in &arc {
        let t = deg(180.0 - 90.0 * u);
        assert!(on_circle(p, [-30.0, -40.0], 10.0, t, z), "{u} {p:?}");
    }
    // First departure, after the contour under RR, R+10: clockwise; PE
    // (-30, -30), the last element along -Y, the centre 10 to its right,
    // (-40, -30); PE at 0 deg, PN at -90 deg: (-40, -40), and the arc
    // through -45 deg.
    let dep = at(14);
    assert!(near(dep[0], [-40.0, -40.0, z]), "{dep:?}");
    // Second approach, RL R-5: clockwise; PA (-20, 20), the circle after
    // it starting along +X, the centre 5 to the right, (-20, 15); PA at
    // 90 deg, PH at 150 deg.
    let c2 = [-20.0, 15.0];
    let appr = at(16);
    assert!(on_circle(appr[0], c2, 5.0, deg(150.0), z), "{appr:?}");
    assert!(near(appr[1], [-20.0, 20.0, z]), "{appr:?}");
    for &(u, p) in &after_aux(program, 16, 1.0) {
        assert!(on_circle(p, c2, 5.0, deg(150.0 - 60.0 * u), z), "{u} {p:?}");
    }
    // Second departure, after that circle under RL, R+4:
    // counter-clockwise; PE (-10, 10), where the circle about (-20, 10)
    // runs along -Y, the centre 4 to its left, (-6, 10); PE at 180 deg,
    // PN 120 deg on, at 300 deg.
    let dep = at(18);
    assert!(
        on_circle(dep[0], [-6.0, 10.0], 4.0, deg(300.0), z),
        "{dep:?}"
    );
    // The departure's arc as the simulator runs it.
    let l = errors("ac-trunnion", 0, 0.0, "");
    let nominal = Model::new(l.model.kin.clone(), vec![]);
    let samples = simulate(
        &nominal,
        &[],
        Dialect::Heidenhain,
        Coordinates::Auto,
        program,
        1.0,
    );
    let dep: Vec<_> = samples.iter().filter(|x| x.line == 18).collect();
    assert!(dep.len() > 5);
    for x in dep {
        let p = [x.nominal.tip.x, x.nominal.tip.y, x.nominal.tip.z];
        let t = deg(180.0 + 120.0 * x.fraction);
        assert!(
            on_circle(p, [-6.0, 10.0], 4.0, t, z),
            "{} {p:?}",
            x.fraction
        );
    }
}

/// HEIDENHAIN `APPR PLT`, `APPR PLN` and `APPR PCT`: the first contour
/// point given as `PR`/`PA` around the pole `CC`, as an `LP` gives its
/// end, the path to it as `LT`, `LN` and `CT`. Byte-identical at zero
/// error; on the intended path within the tolerance on the erroneous
/// machine, the approaches rewritten in their own polar words.
#[test]
fn heidenhain_polar_approaches_stay_on_the_intended_path() {
    let program = "0 BEGIN PGM PROFIPOL MM\n1 BLK FORM 0.1 Z X-50 Y-50 Z-20\n2 BLK FORM 0.2 X+50 Y+50 Z+0\n3 TOOL CALL 1 Z S3500\n4 L A-20 C+30 R0 FMAX\n5 FUNCTION TCPM F TCP AXIS POS PATHCTRL AXIS\n6 CC X+0 Y+0\n7 L X-40 Y-40 Z+2 A-20 C+30 R0 FMAX\n8 L Z-2.5 F300 M3 M8\n9 APPR PLT PR+30 PA+180 LEN10 RR F300\n10 L X-30 Y-30\n11 L X+30\n12 DEP LT LEN10 R0\n13 L X+40 Y+40 R0 F300\n14 APPR PLN PR+30 PA+90 LEN5 RL\n15 L X-30 Y+30\n16 DEP LN LEN8\n17 L X-50 Y+10 R0 F300\n18 APPR PCT PR+30 PA+180 CCA90 R+10 RR\n19 L X-30 Y-30\n20 DEP CT CCA90 R+10\n21 L Z+50 R0 FMAX\n22 M9 M5\n23 FUNCTION RESET TCPM\n24 END PGM PROFIPOL MM\n";
    let (out, _, at) = appr_dep_on_path(program, 106, &[10, 13, 15, 17, 19, 21], "polar appr");
    for (k, kw) in [
        (9, " APPR PLT PR+"),
        (14, " APPR PLN PR+"),
        (18, " APPR PCT PR+"),
    ] {
        let (a, b) = (out.lines().nth(k).unwrap(), program.lines().nth(k).unwrap());
        assert!(a.contains(kw) && !a.contains(" X") && a != b, "{a}");
    }
    let z = -2.5;
    // By hand: PA (-30, 0), the first element along -Y: PH 10 back, at
    // (-30, 10).
    let appr = at(10);
    assert!(near(appr[0], [-30.0, 10.0, z]), "{appr:?}");
    assert!(near(appr[1], [-30.0, 0.0, z]), "{appr:?}");
    // PA (0, 30), the first element along -X, RL: PH 5 to its left, below
    // it, at (0, 25).
    let appr = at(15);
    assert!(near(appr[0], [0.0, 25.0, z]), "{appr:?}");
    assert!(near(appr[1], [0.0, 30.0, z]), "{appr:?}");
    // PA (-30, 0), along -Y, RR R+10: clockwise about (-40, 0), PA at 0
    // deg, PH at 90 deg, (-40, 10); the arc between them.
    let appr = at(19);
    assert!(near(appr[0], [-40.0, 10.0, z]), "{appr:?}");
    assert!(near(appr[1], [-30.0, 0.0, z]), "{appr:?}");
    let arc = after_aux(program, 19, 1.0);
    assert!(arc.len() > 5, "{arc:?}");
    for &(u, p) in &arc {
        let t = (90.0 - 90.0 * u).to_radians();
        assert!(on_circle(p, [-40.0, 0.0], 10.0, t, z), "{u} {p:?}");
    }
}

/// X and Y scale errors bend an `APPR CT`/`DEP CT` as they bend an `LT`:
/// the arc tangent to the corrected element is not the intended one on
/// the machine. Both are reported at their line with how far they stray;
/// the departure is left as written.
#[test]
fn a_circular_approach_and_departure_that_a_scale_error_bends_are_reported() {
    let program = "0 BEGIN PGM BENTCT MM\n1 TOOL CALL 1 Z S4000\n2 L A-20 C+30 R0 FMAX\n3 L X+40 Y-40 Z+2 R0 FMAX\n4 L Z-1 F300\n5 APPR CT X+20 Y+0 CCA90 R+30 RR F600\n6 L X+35 Y+15\n7 L X+35 Y+30\n8 DEP CT CCA90 R+30\n9 L Z+50 R0 FMAX\n10 END PGM BENTCT MM\n";
    bent_by_scale(program, 108, "CT");
}

/// X and Y scale errors bend an `APPR LN`/`DEP LN` as they bend an `LT`:
/// the point square to the corrected element is not the intended one on
/// the machine. Both are reported with how far they leave the path.
#[test]
fn a_perpendicular_approach_and_departure_that_a_scale_error_bends_are_reported() {
    let program = "0 BEGIN PGM BENTLN MM\n1 TOOL CALL 1 Z S4000\n2 L A-20 C+30 R0 FMAX\n3 L X+40 Y-20 Z+2 R0 FMAX\n4 L Z-1 F300\n5 APPR LN X+20 Y+0 LEN30 RR F600\n6 L X+35 Y+15\n7 L X+35 Y+30\n8 DEP LN LEN30 R0\n9 L Z+50 R0 FMAX\n10 END PGM BENTLN MM\n";
    let extra = "effects:\n  linear_scale: {EXX: 300.0, EYY: -200.0}\n";
    let l = errors("ac-trunnion", 108, 30.0, extra);
    let (out, s, _) = compensate(&l, Settings::new(Dialect::Heidenhain), program);
    let found = |what: &str| {
        s.skipped
            .iter()
            .find(|(w, _)| w.contains(what))
            .unwrap_or_else(|| panic!("{what}: {:?}\n{out}", s.skipped))
            .clone()
    };
    assert_eq!(found("approach (APPR LN): the control's path").1.first, [6]);
    assert_eq!(found("the DEP LN the control runs").1.first, [9]);
    assert_eq!(out.lines().nth(8), program.lines().nth(8));
}

/// What fivecal does not correct of `APPR`/`DEP` is left as written and
/// reported at its line with the reason: a perpendicular variant with R0
/// (no side to put its point on), a `DEP CT` after a contour under R0
/// and an `APPR CT` with R0 (the arc turns as RL/RR say), the `LCT`
/// variants (no turning direction in the manuals read), a tool-axis move in the block, and an approach whose first
/// contour element is a `CT` (which starts in the approach's own
/// direction); an `APPR LT`/`DEP LT` under RL/RR is corrected as the
/// programmed contour.
#[test]
fn heidenhain_appr_dep_not_corrected_are_reported_with_their_reason() {
    let program = "0 BEGIN PGM NOAPPR MM\n1 TOOL CALL 1 Z S4000\n2 L A-20 C+30 R0 FMAX\n3 L X+40 Y-10 Z+2 R0 FMAX\n4 L Z-1 F300\n5 APPR LT X+20 Y+0 LEN10 RR F600\n6 L X+35 Y+15\n7 DEP LT LEN10\n8 L X+40 Y-10 R0 FMAX\n9 APPR LN X+20 Y+0 LEN10 R0\n10 L X+35 Y+15\n11 DEP CT CCA90 R+5\n12 L X+40 Y-10 R0 FMAX\n13 APPR LCT X+20 Y+0 R5 RR\n14 L X+35 Y+15\n15 DEP LT LEN10\n16 L X+40 Y-10 R0 FMAX\n17 APPR LT X+20 Y+0 Z-3 LEN10 R0\n18 L X+35 Y+15\n19 L X+40 Y-10 Z-1 R0 FMAX\n20 APPR LT X+20 Y+0 LEN10 R0\n21 CT X+35 Y+15\n22 L Z+50 R0 FMAX\n23 END PGM NOAPPR MM\n";
    let l = errors("ac-trunnion", 104, 30.0, "");
    let (out, s, _) = compensate(&l, Settings::new(Dialect::Heidenhain), program);
    let lines = |what: &str| reported(&s, what);
    // Under RL/RR an APPR LT and a DEP LT are corrected as the
    // programmed contour, like the elements between them.
    for line in [6, 8] {
        assert!(
            s.skipped.iter().all(|(_, at)| !at.first.contains(&line)),
            "line {line}: {:?}",
            s.skipped
        );
    }
    assert_ne!(out.lines().nth(5), program.lines().nth(5));
    assert_eq!(
        lines("perpendicular approach or departure (LN) without radius compensation"),
        [10]
    );
    // The DEP CT after a contour under R0: its arc turns as RL/RR say.
    assert_eq!(
        lines("a circular departure (DEP CT) after a contour without radius compensation"),
        [12]
    );
    assert_eq!(lines("on a line and a tangential arc (LCT)"), [14]);
    assert_eq!(lines("it moves the tool axis or a rotary axis"), [18]);
    // The line before the last DEP LT starts where the APPR LCT left as
    // written leaves the tool: its direction, and the departure's along
    // it, are off by the machine's error.
    assert_eq!(lines("the DEP LT the control runs"), [16]);
    // The last APPR LT is corrected, but the CT after it cannot be
    // followed: the approach is reported, its path not checked.
    assert_eq!(
        lines("path through the auxiliary point is not checked"),
        [21]
    );
    // Every refused block is the program's own text.
    for line in [10, 12, 14, 18] {
        assert_eq!(
            out.lines().nth(line - 1),
            program.lines().nth(line - 1),
            "line {line}"
        );
    }
    // An APPR CT with R0, which the TNC7 refuses, a DEP LCT, whose
    // turning direction no manual read gives, and polar approaches with
    // no pole or with X/Y or as LCT.
    let noct = "0 BEGIN PGM NOCT MM\n1 TOOL CALL 1 Z S4000\n2 L A-20 C+30 R0 FMAX\n3 L X+40 Y-10 Z+2 R0 FMAX\n4 L Z-1 F300\n5 APPR CT X+20 Y+0 CCA90 R+5 R0 F600\n6 L X+35 Y+15\n7 DEP LCT X+50 Y+20 R5\n8 L Z+50 R0 FMAX\n9 L X+40 Y-10 R0 FMAX\n10 APPR PLT PR+20 PA+0 LEN10 RR\n11 L X+35 Y+15\n12 DEP LT LEN10\n13 CC X+0 Y+0\n14 L X+40 Y-10 R0 FMAX\n15 APPR PLN X+20 PR+20 PA+0 LEN10 RR\n16 L X+35 Y+15\n17 DEP LT LEN10\n18 L X+40 Y-10 R0 FMAX\n19 APPR PLCT PR+20 PA+0 R5 RR\n20 L X+35 Y+15\n21 L X+40 Y-10 R0 FMAX\n22 APPR CT X+20 Y+0 ICCA90 R+5 RR\n23 L X+35 Y+15\n24 END PGM NOCT MM\n";
    let (out, s, _) = compensate(&l, Settings::new(Dialect::Heidenhain), noct);
    let lines = |what: &str| reported(&s, what);
    assert_eq!(lines("a circular approach (APPR CT) with R0"), [6]);
    assert_eq!(lines("on a line and a tangential arc (LCT)"), [8, 20]);
    assert_eq!(lines("a polar approach without a known pole (CC)"), [11]);
    assert_eq!(lines("X or Y in a polar approach"), [16]);
    assert_eq!(lines("an incremental ICCA"), [23]);
    for line in [6, 8, 11, 16, 20, 23] {
        assert_eq!(
            out.lines().nth(line - 1),
            noct.lines().nth(line - 1),
            "line {line}"
        );
    }
    // An approach the program ends after: nothing places its auxiliary
    // point, which is said.
    let last = "0 BEGIN PGM LAST MM\n1 TOOL CALL 1 Z S4000\n2 L X+40 Y-10 Z-1 A-20 C+30 R0 FMAX\n3 APPR LT X+20 Y+0 LEN10 R0 F600\n4 END PGM LAST MM\n";
    let (_, s, _) = compensate(&l, Settings::new(Dialect::Heidenhain), last);
    let (_, at) = s
        .skipped
        .iter()
        .find(|(w, _)| w.contains("path through the auxiliary point is not checked"))
        .unwrap_or_else(|| panic!("{:?}", s.skipped));
    assert_eq!(at.first, [4]);
}

/// What the scale-error tests of `APPR`/`DEP` share: `program` (an
/// approach at line 5 whose first element is line 6, a departure at line
/// 8) compensated on `ac-trunnion` with error seed `seed` and X and Y
/// scale errors; the approach is reported at its first element's line and
/// the departure at its own with how far the path of type `kind` (LT, CT)
/// strays, and the departure is the program's own text.
fn bent_by_scale(program: &str, seed: u64, kind: &str) -> (LoadedErrors, String, Summary) {
    let extra = "effects:\n  linear_scale: {EXX: 300.0, EYY: -200.0}\n";
    let l = errors("ac-trunnion", seed, 30.0, extra);
    let (out, s, _) = compensate(&l, Settings::new(Dialect::Heidenhain), program);
    let found = |what: &str| {
        s.skipped
            .iter()
            .find(|(w, _)| w.contains(what))
            .unwrap_or_else(|| panic!("{what}: {:?}\n{out}", s.skipped))
            .clone()
    };
    let (why, lines) = found(&format!("approach (APPR {kind}): the control's path"));
    assert_eq!(lines.first, [6], "{why}");
    let (why, lines) = found(&format!("the DEP {kind} the control runs"));
    assert_eq!(lines.first, [9], "{why}");
    assert_eq!(out.lines().nth(8), program.lines().nth(8));
    (l, out, s)
}

/// X and Y scale errors are no rigid motion: the auxiliary point the
/// control puts `LEN` back along the corrected first element, and the end
/// of a `DEP LT` along the corrected last one, are not the intended ones
/// on the machine. The approach is reported at its line with how far it
/// leaves the intended path (its end point is corrected), the departure
/// is left as written with the same, and the simulator agrees.
#[test]
fn an_approach_and_departure_that_a_scale_error_bends_are_reported() {
    let program = "0 BEGIN PGM BENTAPPR MM\n1 TOOL CALL 1 Z S4000\n2 L A-20 C+30 R0 FMAX\n3 L X+40 Y-10 Z+2 R0 FMAX\n4 L Z-1 F300\n5 APPR LT X+20 Y+0 LEN30 R0 F600\n6 L X+35 Y+15\n7 L X+35 Y+30\n8 DEP LT LEN30\n9 L Z+50 R0 FMAX\n10 END PGM BENTAPPR MM\n";
    let (l, out, s) = bent_by_scale(program, 105, "LT");
    // The reported deviation is what the simulator finds: the auxiliary
    // point as the control places it on the erroneous machine.
    let why = s
        .skipped
        .iter()
        .find(|(w, _)| w.contains("approach (APPR LT): the control's path"))
        .map(|(w, _)| w.clone())
        .unwrap();
    let reported: f64 = why
        .split("by up to ")
        .nth(1)
        .and_then(|t| t.split(' ').next())
        .and_then(|t| t.parse().ok())
        .unwrap();
    let d = Dialect::Heidenhain;
    let nominal = Model::new(l.model.kin.clone(), vec![]);
    let a = simulate(&nominal, &[], d, Coordinates::Auto, program, 0.0);
    let b = simulate(&l.model, &l.theta, d, Coordinates::Auto, &out, 0.0);
    let ph = |x: &[Sample]| {
        x.iter()
            .find(|x| x.line == 6)
            .map(|x| (x.nominal.tip, x.actual.tip))
            .unwrap()
    };
    let miss = (ph(&a).0 - ph(&b).1).norm() * 1e3;
    assert!(
        miss > 1.0 && miss <= reported + 0.01,
        "{miss} um, reported {reported} um"
    );
}
