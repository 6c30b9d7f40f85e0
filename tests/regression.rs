//! Pinned cases, each named after what it pins.

use std::path::Path;

use fivecal::errorfile::ErrorFile;
use fivecal::kinematics::Kinematics;
use fivecal::model::Context;
use fivecal::{Axes, Machine};

/// A tool axis a hair's breadth from the C axis on a machine with a C-axis
/// error map: several exact solutions lie within tens of degrees of C of
/// each other, and one at least as near the previous position as the pose
/// it came from must come back
/// (found in the forward/inverse test of the foundation, bc-trunnion pose
/// 3294 of seed 300).
#[test]
fn ik_near_singular_tilt_with_c_map_returns_the_root_nearest_the_hint() {
    let src = "machine: bc-trunnion
location_errors: {EX0B: 30.0, EZ0B: -40.0, EA0B: 80.0, EC0B: -60.0, EB0B: 50.0, EX(0B)C: 20.0, EY0C: -35.0, EA(0B)C: 90.0}
position_dependent:
  EAC(B,C): {B: [0], C: [0, 60, 120, 180, 240, 300], values: [[90.0, -60.0, 30.0, -90.0, 60.0, -30.0]]}
  EBC(B,C): {B: [0], C: [0, 60, 120, 180, 240, 300], values: [[-80.0, 40.0, 70.0, -20.0, -90.0, 50.0]]}
";
    let k = Kinematics::new(&Machine::builtin("bc-trunnion").unwrap());
    let l = ErrorFile::parse(Path::new("pinned"), src)
        .unwrap()
        .to_model(&k, Path::new("pinned"), src)
        .unwrap();
    let mut checked = 0;
    for i in 0..72 {
        let truth = Axes::new(
            120.0,
            -40.0,
            50.0,
            -6.4e-5 + 1e-5 * (i % 7) as f64,
            5.0 * i as f64,
        );
        let ctx = Context::at(truth);
        let pose = l.model.pose(&l.theta, &ctx);
        // The previous position, as a program would have it: near, not on.
        let hint = Axes {
            tilt: truth.tilt + 15.0,
            c: truth.c - 12.0,
            ..truth
        };
        let got = l.model.inverse(&l.theta, &pose, Some(&hint), &ctx).unwrap();
        // Several exact solutions exist here; the answer must be one of
        // them and no farther from the hint than the one we started from.
        let back = l.model.pose(&l.theta, &Context::at(got));
        assert!(
            (back.tip - pose.tip).norm() < 1e-9 && (back.axis - pose.axis).norm() < 1e-12,
            "C = {}: {got:?} is not a solution",
            truth.c
        );
        let distance = |a: &Axes| (a.tilt - hint.tilt).abs() + (a.c - hint.c).abs();
        assert!(
            distance(&got) <= distance(&truth) + 1e-9,
            "C = {}: {got:?} is farther from {hint:?} than {truth:?}",
            truth.c
        );
        checked += 1;
    }
    assert_eq!(checked, 72);
}

/// A HEIDENHAIN `CC` between moves names X and Y but moves nothing: it
/// once reset the tracked (corrected) position to the nominal one, so the
/// next circle started 50 um off and could not be followed at all (issue 7).
#[test]
fn compensate_heidenhain_pole_block_keeps_the_corrected_position() {
    let program = "0 BEGIN PGM ARC MM\n1 L X+20 Y+0 Z+5 B+0 C+0 R0 FMAX\n2 L Z+1 F300\n3 CC X+0 Y+0\n4 C X-20 Y+0 DR+\n5 END PGM ARC MM\n";
    let src = "machine: head-table\nlocation_errors: {EX0C: 30.0, EY0C: -20.0, EX0B: 15.0}\n";
    let k = Kinematics::new(&Machine::builtin("head-table").unwrap());
    let l = ErrorFile::parse(Path::new("t"), src)
        .unwrap()
        .to_model(&k, Path::new("t"), src)
        .unwrap();
    let c = fivecal::compensate::Compensator::new(
        &l.model,
        &l.theta,
        fivecal::compensate::Settings::new(fivecal::Dialect::Heidenhain),
    );
    let mut out = Vec::new();
    let s = c
        .run(Path::new("arc.h"), program.as_bytes(), &mut out)
        .unwrap();
    assert!(s.linearized.is_empty(), "{s:?}");
}

/// With zero errors a corrected value differs from the written one only by
/// rounding; comparing rounded values added words where a lexeme had more
/// decimals than the output resolution (`Y1.23455`, issue 7).
#[test]
fn compensate_zero_errors_keep_lexemes_finer_than_the_output_resolution() {
    let program = "G21 G90 G54 G43\nG0 X1.23455 Y1.23455 Z30.00005 B10.0000005 C20.0000005\nG1 X2.5 F100\nM2\n";
    let k = Kinematics::new(&Machine::builtin("bc-trunnion").unwrap());
    let model = fivecal::model::Model::new(k, vec![]);
    let c = fivecal::compensate::Compensator::new(
        &model,
        &[],
        fivecal::compensate::Settings::new(fivecal::Dialect::Linuxcnc),
    );
    let mut out = Vec::new();
    c.run(Path::new("p.ngc"), program.as_bytes(), &mut out)
        .unwrap();
    assert_eq!(String::from_utf8(out).unwrap(), program);
}

/// Leaving a move where C is held (tool along C, out of reach) for one
/// that is corrected exactly once jumped C between solutions inside the
/// move, and no subdivision could follow it (issue 7): C now ramps.
#[test]
fn compensate_leaving_the_singularity_ramps_c_instead_of_jumping() {
    let src = "machine: bc-trunnion\nlocation_errors: {EA0B: 80.0, EC0B: -60.0, EB0B: 50.0, EA(0B)C: 90.0}\n";
    let k = Kinematics::new(&Machine::builtin("bc-trunnion").unwrap());
    let l = ErrorFile::parse(Path::new("t"), src)
        .unwrap()
        .to_model(&k, Path::new("t"), src)
        .unwrap();
    let mut s = fivecal::compensate::Settings::new(fivecal::Dialect::Linuxcnc);
    s.max_c_swing = 360.0;
    s.max_correction = 1e7;
    let c = fivecal::compensate::Compensator::new(&l.model, &l.theta, s);
    let program = "G21 G90 G54 G43\nG0 X10 Y0 Z30 B0 C40\nG1 X20 Y5 B0.05 C80 F300\nM2\n";
    let mut out = Vec::new();
    let sum = c
        .run(Path::new("p.ngc"), program.as_bytes(), &mut out)
        .unwrap();
    assert!(sum.held_c.contains(&3), "{sum:?}");
}

/// Judged at the estimate, the exact model couples the directions a test
/// cannot see to those it can by terms of the order of the errors (1e-4
/// here): cuts at B = 0 only then reported every symbol, EY0C included, as
/// not identifiable (found while building the analyzer). Identifiability is
/// a property of the design at the nominal machine.
#[test]
fn identifiability_is_judged_at_the_nominal_design_not_at_the_estimate() {
    use fivecal::identify::{Method, Setup, synthetic};
    let k = Kinematics::new(&Machine::builtin("bc-trunnion").unwrap());
    let plan = synthetic::stepped_square(&k, &[0.0], &[0.0, 90.0, 180.0, 270.0], 15.0);
    let truth = fivecal::Model::new(
        k.clone(),
        vec![fivecal::Effect::Location {
            symbols: (0..8).collect(),
        }],
    );
    // Large errors, to make the coupling at the estimate large.
    let theta = [120.0, -400.0, 800.0, -600.0, 1500.0, 250.0, -180.0, 450.0];
    let pts = synthetic::machined(
        &truth,
        &theta,
        &plan,
        &Default::default(),
        0.0,
        &nalgebra::Isometry3::identity(),
        &mut crate::util::rng(1),
    );
    let set = fivecal::formats::detect::PointSet {
        format: "synthetic",
        points: pts,
        labeled: true,
        nominals: Vec::new(),
        warnings: Vec::new(),
    };
    let data = fivecal::identify::data::join(
        &plan,
        fivecal::formats::manifest::TestKind::Machining,
        &Default::default(),
        &[("pinned".into(), set)],
        &|p| p.p,
    )
    .unwrap();
    let setup = Setup::new(&k, &data.poses, &[]).unwrap();
    let est =
        fivecal::analyze::method::identify_with(Method::Global, &setup, &data, &Default::default())
            .unwrap();
    let (v, u) = est.get("EY0C").unwrap();
    assert!(u.is_some(), "{}", est.identifiability.render());
    // Exact only to second order: the unseen splits (EX0B against
    // EX(0B)C, ...) take the minimum-norm values, and with 1.5 mrad and
    // 0.4 mm errors their products move what is seen by ~0.6 um.
    assert!((v + 180.0).abs() < 1.0, "EY0C = {v}");
    assert_eq!(est.identifiability.rank, 10);
}

/// A DMIS point at 1e250 mm (a corrupted file) overflowed the placement
/// arithmetic and nalgebra's SVD iterated forever on the NaNs (found while
/// testing bad input). Coordinates beyond 100 m are refused at the join.
#[test]
fn dmis_point_at_1e250_mm_is_refused_instead_of_hanging_the_svd() {
    use fivecal::formats::detect::{Measurement, parse_measurement};
    let k = Kinematics::new(&Machine::builtin("bc-trunnion").unwrap());
    let plan = fivecal::identify::synthetic::stepped_square(&k, &[0.0], &[0.0, 90.0], 15.0);
    let mut src = String::from("DMISMN/'corrupt',04.0\nUNITS/MM,ANGDEC\n");
    for (i, p) in plan.points.iter().enumerate() {
        let x = if i == 3 { 1e250 } else { p.p.x };
        src.push_str(&format!(
            "FA({})=FEAT/POINT,CART,{x},{},{}\n",
            p.label, p.p.y, p.p.z
        ));
    }
    let Measurement::Points(set) = parse_measurement(Path::new("c.dmo"), &src).unwrap() else {
        panic!("points expected");
    };
    let e = fivecal::identify::data::join(
        &plan,
        fivecal::formats::manifest::TestKind::Machining,
        &Default::default(),
        &[("c.dmo".into(), set)],
        &|p| p.p,
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.starts_with("c.dmo:6:1: a coordinate of 1.000000e250 mm"),
        "{e}"
    );
}

/// Large rotary errors slide the nine-section's ball raster sideways by
/// more than half its stepover: at section 8's second point the pass next
/// to the one that made it (move 133 of pose S8, not 135) cuts deepest,
/// and the forward model must consider it as the simulator does (found
/// when the forward model took only the point's generators: 0.43 um off).
#[test]
fn neighbouring_ball_pass_cuts_deepest_when_errors_shift_the_nine_section_raster() {
    use fivecal::simulate::{self, SimOptions, forward};
    let plan = crate::simulate::planned("bc-trunnion", "nine-section");
    let errors = crate::simulate::truth(
        &plan,
        "location_errors: {EX0B: 50, EZ0B: -50, EA0B: 200, EC0B: -200, EB0B: 200, EX(0B)C: 50, EY0C: -50, EA(0B)C: 200}\n",
    );
    let fivecal::procedure::Plan::Machining(t) = &*plan else {
        unreachable!()
    };
    let fm =
        forward::MachiningForward::new(&errors.model, std::sync::Arc::new((**t).clone())).unwrap();
    let i = t
        .points
        .iter()
        .position(|p| p.point.label == "S8-2")
        .unwrap();
    let p = &t.points[i];
    assert_eq!(p.provenance.generators[0].move_index, 135);
    let mid = plan
        .poses()
        .iter()
        .find(|e| e.pose == p.point.pose)
        .map(|e| 0.5 * (e.start_min + e.end_min))
        .unwrap();
    let surfaces = fm.surfaces(&errors.theta, &p.point, mid).unwrap();
    let (deepest, s) = surfaces
        .iter()
        .min_by(|a, b| a.1.offset.total_cmp(&b.1.offset))
        .unwrap();
    assert_eq!(*deepest, 133);
    let out = simulate::run(&plan, &errors, &SimOptions::exact()).unwrap();
    assert!((s.prediction.point - out.points_w[i]).norm() < 1e-9);
}

/// With drift per minute the actual path bends and the simulator searches
/// the instants itself; on a flat end's plateau the closest instant to the
/// nominal point is where the end's rim grazes the probing line, and the
/// search must minimise the entry, not the distance (found on head-table's
/// side step B-90C0: no cut reached the point).
#[test]
fn flat_end_plateau_under_drift_per_minute_is_found_where_the_end_grazes_the_line() {
    use fivecal::simulate::{self, SimOptions, forward};
    let plan = crate::simulate::planned("head-table", "stepped-square");
    let errors = crate::simulate::truth(
        &plan,
        "effects: {thermal_drift: {EZ0B: {per: seq, rate: 5}, EX0C: {per: minute, rate: 2}, EA0C: {per: minute, rate: 10}}}\n",
    );
    let out = simulate::run(&plan, &errors, &SimOptions::exact()).unwrap();
    let points = plan.plan_points();
    let i = points
        .points
        .iter()
        .position(|p| p.label == "B-90C0-XN1")
        .unwrap();
    let p = &points.points[i];
    let mid = plan
        .poses()
        .iter()
        .find(|e| e.pose == p.pose)
        .map(|e| 0.5 * (e.start_min + e.end_min))
        .unwrap();
    let fm = forward::for_plan(&errors.model, &plan).unwrap();
    let pred = fm.predict(&errors.theta, &[], p, mid).unwrap();
    assert!((pred.point - out.points_w[i]).norm() < 1e-6);
    assert!(p.n.dot(&(out.points_w[i] - p.p)) > 0.01);
}

/// The sphere method on a head machine (`probe-sphere` on `head-table`,
/// the location errors of `--truth-example --machine head-table`): the
/// circle of the sphere's centres about C moves with the B head's offset
/// from the spindle (EX0B) exactly as with the C axis' own position, and
/// the method printed EX0C = 170 um, u = 0.07 um against a truth of 12
/// (issue 14; 196.5 um with the example's drift too). The judge of the
/// sphere method's estimator refuses it, naming EX0B; what it still
/// reports is within 4 u of the truth.
#[test]
fn sphere_method_on_head_table_refuses_ex0c_aliased_with_the_head_offset() {
    use fivecal::identify::sphere::{CircleMethod, SphereOptions};
    use fivecal::identify::{Method, Setup};
    let plan = crate::simulate::planned("head-table", "probe-sphere");
    let truth = crate::simulate::truth(
        &plan,
        "location_errors: {EX0C: 12.0, EY0C: -25.0, EA0C: 80.0, EB0C: -60.0, EX0B: 150.0, EZ0B: 25.0, EA0B: -18.0, EC0B: 45.0, EB0B: 30.0, EA(0B)S: -40.0}\n",
    );
    let truth_of = |name: &str| {
        let i = truth.model.param_names().iter().position(|n| n == name);
        truth.theta[i.unwrap()]
    };
    for seed in [1, 2] {
        let opts = fivecal::simulate::SimOptions {
            seed,
            ..Default::default()
        };
        let out = fivecal::simulate::run(&plan, &truth, &opts).unwrap();
        let data = fivecal::analyze::uncertainty::simulated::plan_dataset(
            &plan,
            "touches.log",
            out.points,
        )
        .unwrap();
        let kin = fivecal::simulate::plan_kinematics(&plan);
        let setup = Setup::new(&kin, &data.poses, &[]).unwrap();
        // The robust default as well: its Tukey reweighting once put EA0C
        // at 72.9 +- 1.1 urad on seed 1 (truth 80).
        for circle in [CircleMethod::LeastSquares, CircleMethod::Robust] {
            let sphere = SphereOptions {
                circle,
                check: None,
            };
            let est = fivecal::analyze::method::identify_with_plan(
                Method::Sphere,
                &setup,
                &data,
                &sphere,
                Some(&plan),
            )
            .unwrap();
            let (_, u) = est.get("EX0C").unwrap();
            assert!(
                u.is_none(),
                "seed {seed}, {circle}: EX0C reported\n{}",
                est.summary()
            );
            let file = est.error_file(None);
            let why = &file
                .not_identifiable
                .iter()
                .find(|n| n.symbol == "EX0C")
                .unwrap()
                .reason;
            assert!(why.contains("EX0B"), "{why}");
            let mut reported = 0;
            for name in est.model.param_names() {
                if let (v, Some(u)) = est.get(&name).unwrap() {
                    let z = (v - truth_of(&name)).abs() / u;
                    assert!(
                        z < 4.0,
                        "seed {seed}, {circle}: {name} off by {z:.1} u\n{}",
                        est.summary()
                    );
                    reported += 1;
                }
            }
            assert!(reported >= 2, "{}", est.summary());
        }
    }
}

/// The sphere method on a head machine once fitted the model's line for
/// the head's tilt (the axis of an identity rotation of the table, a
/// direction round-off picks) to the degenerate arc of centres: a
/// different but equally exact SVD moved EA0C by 9.6 u. Moving every
/// probed point by a picometre must move no estimate by more than a
/// hundredth of its u, nor change what is refused.
#[test]
fn sphere_method_on_head_table_does_not_hang_on_round_off() {
    use fivecal::identify::sphere::SphereOptions;
    use fivecal::identify::{Method, Setup};
    let plan = crate::simulate::planned("head-table", "probe-sphere");
    let truth = crate::simulate::truth(
        &plan,
        "location_errors: {EX0C: 12.0, EY0C: -25.0, EA0C: 80.0, EB0C: -60.0, EX0B: 150.0, EZ0B: 25.0, EA0B: -18.0, EC0B: 45.0, EB0B: 30.0, EA(0B)S: -40.0}\n",
    );
    let opts = fivecal::simulate::SimOptions {
        seed: 1,
        ..Default::default()
    };
    let out = fivecal::simulate::run(&plan, &truth, &opts).unwrap();
    let data =
        fivecal::analyze::uncertainty::simulated::plan_dataset(&plan, "touches.log", out.points)
            .unwrap();
    let mut moved = data.clone();
    for o in &mut moved.obs {
        o.m.x += 1e-9;
    }
    let kin = fivecal::simulate::plan_kinematics(&plan);
    let setup = Setup::new(&kin, &data.poses, &[]).unwrap();
    let run = |d| {
        fivecal::analyze::method::identify_with_plan(
            Method::Sphere,
            &setup,
            d,
            &SphereOptions::default(),
            Some(&plan),
        )
        .unwrap()
    };
    let (a, b) = (run(&data), run(&moved));
    for name in a.model.param_names() {
        match (a.get(&name).unwrap(), b.get(&name).unwrap()) {
            ((va, Some(ua)), (vb, Some(_))) => {
                assert!((va - vb).abs() < 0.01 * ua, "{name}: {va} and {vb}, u {ua}")
            }
            ((_, None), (_, None)) => {}
            (x, y) => panic!("{name}: {x:?} and {y:?}"),
        }
    }
}

/// Under tool-centre-point control, a line after a move left as written
/// (an unknown G code, an `APPR LN` with R0) starts where that move
/// leaves the tool, off its intended start: the pieces that follow a line
/// cannot start anywhere else, and the whole file was refused with "the
/// move cannot be followed within --tolerance 1 um even in 65536 pieces"
/// at the line after. Now the line's end point is corrected, the line is
/// reported with that reason, and every written point reaches its
/// intended one on the machine with the errors.
#[test]
fn a_line_after_a_move_left_as_written_under_tcp_is_reported_not_fatal() {
    use crate::compensate::{assert_reaches, compensate, errors};
    use fivecal::compensate::Settings;
    use fivecal::machine::Dialect;
    let l = errors("ac-trunnion", 104, 30.0, "");
    let fanuc = "%\nO1000\nG90 G21 G17 G94 G54\nG43.4 H1\nG0 X40. Y-10. Z2. A-20. C30.\nG1 Z-1. F300\nG1 X20. Y0. G777\nG1 X35. Y15.\nG0 Z50.\nG49\nM30\n%\n";
    let heidenhain = "0 BEGIN PGM T MM\n1 TOOL CALL 1 Z S4000\n2 FUNCTION TCPM F TCP AXIS POS PATHCTRL AXIS\n3 L X+40 Y-10 Z+2 A-20 C+30 R0 FMAX\n4 L Z-1 F300\n5 APPR LN X+20 Y+0 LEN10 R0\n6 L X+35 Y+15\n7 L Z+50 R0 FMAX\n8 END PGM T MM\n";
    for (d, program, left, after) in [
        (Dialect::Fanuc, fanuc, 7, 8),
        (Dialect::Heidenhain, heidenhain, 6, 7),
    ] {
        let (out, s, vs) = compensate(&l, Settings::new(d), program);
        let lines = |what: &str| crate::compensate::reported(&s, what);
        assert_eq!(out.lines().nth(left - 1), program.lines().nth(left - 1));
        assert_eq!(
            lines("the line starts where the move before it"),
            [after],
            "{d:?}: {:?}",
            s.skipped
        );
        assert_ne!(out.lines().nth(after - 1), program.lines().nth(after - 1));
        assert!(vs.iter().any(|v| v.line == after), "{d:?}");
        for v in &vs {
            assert_reaches(&l, v, &format!("{d:?}"));
        }
    }
}

/// A HEIDENHAIN program that turns A and C before `FUNCTION TCPM ... AXIS
/// POS` (or `M128`) and then moves X, Y and Z only: switching TCPM forgot
/// the rotary positions, and every move after it was left as written
/// ("the position of A is not known"). Switching turns no axis; under
/// AXIS POS and M128 the rotary words stay machine positions, as under
/// G43.4, so the moves are corrected and reach their intended points.
#[test]
fn heidenhain_rotary_positions_set_before_tcpm_stay_known_under_it() {
    use crate::compensate::{assert_reaches, compensate_checked, errors};
    use fivecal::compensate::Settings;
    use fivecal::machine::Dialect;
    let l = errors("ac-trunnion", 104, 30.0, "");
    for on in ["FUNCTION TCPM F TCP AXIS POS PATHCTRL AXIS", "M128"] {
        let program = format!(
            "0 BEGIN PGM T MM\n1 TOOL CALL 1 Z S4000\n2 L A-20 C+30 R0 FMAX\n3 {on}\n4 L X+40 Y-10 Z+2 R0 FMAX\n5 L Z-1 F300\n6 L X+20 Y+0\n7 L Z+50 R0 FMAX\n8 END PGM T MM\n"
        );
        let (_, s, vs) = compensate_checked(&l, Settings::new(Dialect::Heidenhain), &program);
        // Only the rotary positioning itself, before X, Y and Z are known.
        assert_eq!(s.skipped.len(), 1, "{on}: {:?}", s.skipped);
        assert_eq!(s.skipped[0].1.first, [3], "{on}: {:?}", s.skipped);
        assert_eq!((s.motion_blocks, s.corrected_blocks), (5, 4), "{on}");
        assert_eq!(vs.iter().filter(|v| v.line >= 5).count(), 4, "{on}");
        for v in &vs {
            assert_reaches(&l, v, on);
        }
    }
}

/// `analyze contour` with an OBJ whose only triangle has three equal
/// vertices, or a vertex at infinity: refused with the reason, not a panic
/// in the nearest-triangle search or `inf` in the report.
#[test]
fn contour_model_without_an_area_or_with_an_infinite_vertex_is_refused() {
    let dir = crate::util::tempdir();
    let csv = dir.path().join("p.csv");
    std::fs::write(&csv, "\u{feff}label,x,y,z\r1,0,0,0\r").unwrap();
    for (name, obj, expect) in [
        (
            "point.obj",
            "v 1 1 1\nv 1 1 1\nv 1 1 1\nf 1 2 3\n",
            "none of the 1 triangles has an area",
        ),
        (
            "inf.obj",
            "v 0 0 0\nv 1 0 0\nv inf 1 0\nf 1 2 3\n",
            "vertex 3 is",
        ),
    ] {
        let model = dir.path().join(name);
        std::fs::write(&model, obj).unwrap();
        let out = crate::cli::fivecal()
            .args(["analyze", "contour", "--model"])
            .arg(&model)
            .arg("--measured")
            .arg(&csv)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{err}");
        assert!(err.contains(name) && err.contains(expect), "{err}");
    }
    // The same CSV (a byte-order mark, lines ending in a bare CR) against a
    // real face reads as one point.
    let model = dir.path().join("face.obj");
    std::fs::write(&model, "v -1 -1 0\nv 1 -1 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let out = crate::cli::fivecal()
        .args(["analyze", "contour", "--model"])
        .arg(&model)
        .arg("--measured")
        .arg(&csv)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(text.contains("(1 points)"), "{text}");
}

/// `--maps "EBB(B),EXC(B,C)"`, the help's own example, split inside the
/// parentheses and failed with "unknown symbol `EXC(B`": a two-axis map
/// stays whole, in `analyze --maps` and `discover --start`.
#[test]
fn two_axis_map_symbols_stay_whole_in_comma_separated_lists() {
    let d = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/analyze/stepped-square");
    let dir = crate::util::tempdir();
    let out = crate::cli::fivecal()
        .args(["analyze", "--plan"])
        .arg(d.join("stepped-square.plan.yaml"))
        .arg("--measured")
        .arg(d.join("piece1.dmo"))
        .arg("--out")
        .arg(dir.path().join("r.yaml"))
        .args(["--maps", "EBB(B),EXC(B,C)"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("`EXC(B`") && !err.contains("`C)`"), "{err}");
    assert!(out.status.success() || err.contains("EXC(B,C)"), "{err}");
    let out = crate::cli::fivecal()
        .args(["discover", "--plan"])
        .arg(d.join("stepped-square.plan.yaml"))
        .arg("--measured")
        .arg(d.join("piece1.dmo"))
        .args(["--start", "location,map.EXC(B,C)", "--max-steps", "0"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !err.contains("`map.EXC(B`") && !err.contains("`C)`"),
        "{err}"
    );
}

/// Compensates `program` (LinuxCNC, bc-trunnion) with `errors` YAML
/// location errors and `settings` changed by `tweak`.
fn compensate_text(
    program: &str,
    errors: &str,
    tweak: impl FnOnce(&mut fivecal::compensate::Settings),
) -> Result<(String, fivecal::compensate::Summary), String> {
    let src = format!("machine: bc-trunnion\nlocation_errors: {errors}\n");
    let k = Kinematics::new(&Machine::builtin("bc-trunnion").unwrap());
    let l = ErrorFile::parse(Path::new("t"), &src)
        .unwrap()
        .to_model(&k, Path::new("t"), &src)
        .unwrap();
    let mut settings = fivecal::compensate::Settings::new(fivecal::Dialect::Linuxcnc);
    tweak(&mut settings);
    let c = fivecal::compensate::Compensator::new(&l.model, &l.theta, settings);
    let mut out = Vec::new();
    let s = c
        .run(Path::new("p.ngc"), program.as_bytes(), &mut out)
        .map_err(|e| e.to_string())?;
    Ok((String::from_utf8(out).unwrap(), s))
}

/// An axis value too large for a float (400 digits) was written out as
/// `XNaN YNaN ZNaN` with exit 0, even with --strict (issue 16): it is now
/// a block that cannot be read, named at its line and column, kept byte
/// for byte outside --strict and refused with it.
#[test]
fn compensate_axis_value_beyond_a_float_is_never_written_as_nan() {
    let huge = format!("1{}", "0".repeat(400));
    let program = format!("G0 X0 Y0 Z10 B0 C0\nG1 X{huge} Y0 Z0 F100\nG1 X5 Y0 Z0\nM2\n");
    let (out, s) = compensate_text(&program, "{EX0B: 30.0}", |_| {}).unwrap();
    assert!(!out.contains("NaN") && !out.contains("inf"), "{out}");
    assert_eq!(s.unreadable, vec![2]);
    assert!(out.lines().nth(1).unwrap().contains(&huge));
    // X is unknown after the unreadable block: line 3 is left as written.
    assert_eq!(out.lines().nth(2), Some("G1 X5 Y0 Z0"));
    let e = compensate_text(&program, "{EX0B: 30.0}", |s| s.strict = true).unwrap_err();
    assert!(e.contains("p.ngc:2:5:") && e.contains("too large"), "{e}");
}

/// 200,000 nested brackets overflowed the stack (issue 16): the nesting is
/// bounded and the block named.
#[test]
fn compensate_deeply_nested_brackets_are_refused_without_overflowing() {
    let deep = format!("G1 X{}1{} F100\n", "[".repeat(200_000), "]".repeat(200_000));
    let program = format!("G0 X0 Y0 Z10 B0 C0\n{deep}M2\n");
    let e = compensate_text(&program, "{EX0B: 30.0}", |s| s.strict = true).unwrap_err();
    assert!(e.contains("p.ngc:2:") && e.contains("nested deeper"), "{e}");
    let (_, s) = compensate_text(&program, "{EX0B: 30.0}", |_| {}).unwrap();
    assert_eq!(s.unreadable, vec![2]);
}

/// A chain of 200,000 `#` (`##...#1`, a parameter whose number is a
/// parameter ...) overflowed the stack as brackets did: it counts towards
/// the same depth, and the error names the line and the column of the
/// level too many.
#[test]
fn compensate_deeply_chained_parameters_are_refused_at_their_column() {
    let program = format!(
        "G0 X0 Y0 Z10 B0 C0\nG1 X{}1 F100\nM2\n",
        "#".repeat(200_000)
    );
    let e = compensate_text(&program, "{EX0B: 30.0}", |s| s.strict = true).unwrap_err();
    let column = "G1 X".len() + fivecal::limits::MAX_EXPR_DEPTH + 2;
    assert!(
        e.contains(&format!("p.ngc:2:{column}:")) && e.contains("nested deeper than 64"),
        "{e}"
    );
}

/// A raised --max-correction let a correction drive an axis beyond its
/// stroke (issue 16): a program at B = 90 (the limit of bc-trunnion) with
/// an error that needs B beyond it by far more than a hold can absorb is
/// refused at its line, and a program beyond the stroke itself is named
/// as such.
#[test]
fn compensate_never_drives_a_rotary_axis_beyond_its_stroke() {
    // Refused, or left as written with the reason: never written beyond.
    let why = |r: Result<(String, fivecal::compensate::Summary), String>| match r {
        Ok((out, s)) => {
            let reasons: Vec<String> = s
                .skipped
                .iter()
                .filter(|(_, lines)| lines.contains(&2))
                .map(|(r, _)| r.text.clone())
                .collect();
            (out, reasons.join("; "))
        }
        Err(e) => (String::new(), e),
    };
    let program = "G0 X0 Y0 Z50 B0 C0\nG1 X10 Y0 Z50 B90 C0 F100\nM2\n";
    let (out, e) = why(compensate_text(program, "{EB0B: 9000.0}", |s| {
        s.max_correction = 1e9
    }));
    assert!(e.contains("outside the limits [-90, 90]"), "{e}");
    assert!(
        out.is_empty() || out.contains("\nG1 X10 Y0 Z50 B90 C0 F100\n"),
        "{out}"
    );
    let beyond = "G0 X0 Y0 Z50 B0 C0\nG1 X10 Y0 Z50 B94.665 C0 F100\nM2\n";
    let (out, e) = why(compensate_text(beyond, "{EX0B: 0.0}", |_| {}));
    assert!(
        e.contains("B at 94.6650 deg, beyond the machine's stroke -90..90"),
        "{e}"
    );
    assert!(out.is_empty() || out == beyond, "{out}");
}

/// Only the rotary axes' strokes were checked: a correction that pushed X
/// past its stroke was written (issue 16 asks that every corrected axis
/// value be checked against the machine's strokes). bc-trunnion's X runs
/// -365..365; a move at X 364.9 with B at 30 on a machine whose B axis
/// line is 3 mm off (--max-correction raised to let it through) needs X
/// at 367.9: it is left as written with the reason, and the move after
/// it, inside, is still corrected.
#[test]
fn compensate_never_drives_a_linear_axis_beyond_its_stroke() {
    let program = "G0 X0 Y0 Z50 B0 C0\nG1 X364.9 Y0 Z50 B30 C0 F100\nX300 Y10\nM2\n";
    let (out, s) = compensate_text(program, "{EX0B: 3000.0}", |s| s.max_correction = 1e6).unwrap();
    let reasons: Vec<&String> = s
        .skipped
        .iter()
        .filter(|(_, lines)| lines.contains(&2))
        .map(|(r, _)| &r.text)
        .collect();
    assert!(
        reasons.iter().any(|r| r.contains(
            "X would be at 367.900 in machine coordinates, outside its stroke [-365, 365]"
        )),
        "{reasons:?}"
    );
    assert!(out.contains("\nG1 X364.9 Y0 Z50 B30 C0 F100\n"), "{out}");
    assert!(out.contains("\nX303 Y10"), "{out}");
    // A program that is beyond the stroke as written is not this
    // correction's doing (another machine, another --origin): it is
    // corrected as it stands.
    let beyond = "G0 X0 Y0 Z50 B0 C0\nG1 X370 Y0 Z50 B30 C0 F100\nM2\n";
    let (out, s) = compensate_text(beyond, "{EX0B: 30.0}", |_| {}).unwrap();
    assert!(out.contains("\nG1 X370.03 "), "{out}\n{:?}", s.skipped);
}

/// `fivecal` in a fresh directory holding `files`; returns the exit code,
/// stdout, stderr and the directory's files afterwards.
fn run_in(files: &[(&str, &str)], args: &[&str]) -> (Option<i32>, String, String, Vec<String>) {
    let dir = crate::util::tempdir();
    for (name, text) in files {
        std::fs::write(dir.path().join(name), text).unwrap();
    }
    let out = crate::cli::fivecal()
        .current_dir(dir.path())
        .args(args)
        .output()
        .unwrap();
    let mut left: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .collect();
    left.sort();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).to_string(),
        String::from_utf8_lossy(&out.stderr).to_string(),
        left,
    )
}

/// `compensate p.nc -o out.nc` on head-table with the errors of `e.yaml`.
const COMPENSATE_P_NC: [&str; 8] = [
    "compensate",
    "--machine",
    "head-table",
    "--errors",
    "e.yaml",
    "p.nc",
    "-o",
    "out.nc",
];

const HEAD_TABLE_ERRORS: &str =
    "machine: head-table\nlocation_errors: {EX0C: 12.0, EY0C: -8.0, EX0B: 5.0}\n";

/// A FANUC program on `head-table`, whose controller is HEIDENHAIN: read as
/// Klartext it had 0 moves, was written out as an identical copy and the
/// run exited 0 (issue 14); then it was refused (issue 14 item 5). The
/// dialect now comes from the text (issue 16 item 1): the program is read
/// as FANUC and the run says why; read as HEIDENHAIN on purpose
/// (`--dialect`), it is refused naming the dialect it shows.
#[test]
fn compensate_fanuc_program_on_a_heidenhain_machine_is_read_as_fanuc_and_refused_as_heidenhain() {
    let numbered = "%\nO1001 (PLAIN)\nN10 G90 G54 G21\nN20 G0 X10. Y10. Z50. B0. C0.\nN30 G1 X20. F300.\nN40 M30\n%\n";
    let plain = numbered.replace("O1001 (PLAIN)", "(PLAIN)");
    let tcp = plain.replace("N10 G90 G54 G21", "N10 G90 G54 G21 G43.4 H1");
    let args = COMPENSATE_P_NC;
    for (program, why) in [
        (numbered, "read as fanuc (from the text: `O-number` at line 2)".to_string()),
        (&tcp, "read as fanuc (from the text: `G43.4` at line 3)".to_string()),
        (
            &plain,
            "read as fanuc (plain G-code, `G0` at line 4, shows neither FANUC nor LinuxCNC: read as fanuc, the usual ISO control, the machine's being heidenhain; give --dialect to read it otherwise)".to_string(),
        ),
    ] {
        let (code, out, err, left) =
            run_in(&[("e.yaml", HEAD_TABLE_ERRORS), ("p.nc", program)], &args);
        assert_eq!(code, Some(0), "{err}");
        assert!(out.contains(&why), "{out}");
        assert!(out.contains("2 moves: 2 blocks changed"), "{out}");
        assert_eq!(left, ["e.yaml", "out.nc", "p.nc"]);
    }
    let mut heidenhain = args.to_vec();
    heidenhain.extend(["--dialect", "heidenhain"]);
    for (program, want) in [
        (
            numbered,
            "p.nc:2: this is a fanuc program (`O-number`), not heidenhain",
        ),
        (
            &tcp,
            "p.nc:3: this is a fanuc program (`G43.4`), not heidenhain",
        ),
        (
            &plain,
            "p.nc:4: this is a G-code program (`G0`: FANUC or LinuxCNC), not heidenhain",
        ),
    ] {
        let (code, _, err, left) = run_in(
            &[("e.yaml", HEAD_TABLE_ERRORS), ("p.nc", program)],
            &heidenhain,
        );
        assert_eq!(code, Some(2), "{err}");
        assert!(err.contains(want), "{err}");
        assert_eq!(left, ["e.yaml", "p.nc"]);
    }
    // The other way round: Klartext read as FANUC on purpose, and without
    // --dialect on a FANUC machine, where the text decides.
    let klartext =
        "0 BEGIN PGM P MM\n1 L X+10 Y+10 Z+50 B+0 C+0 R0 FMAX\n2 L X+20 R0 F300\n3 END PGM P MM\n";
    let mut fanuc = args.to_vec();
    fanuc.extend(["--dialect", "fanuc"]);
    let (code, _, err, _) = run_in(&[("e.yaml", HEAD_TABLE_ERRORS), ("p.nc", klartext)], &fanuc);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("this is a heidenhain program (`BEGIN PGM`), not fanuc"),
        "{err}"
    );
}

/// A FANUC program that only changes tools and calls a measuring macro
/// (`G65 P919100`, as a real shop program of the corpus does) was refused
/// as "a program for another controller?", though its text is FANUC's;
/// then refused as having nothing to compensate, which stopped a batch
/// over a shop's programs at every main program of calls (issue 16: every
/// file runs through). It is now passed on as it is, exit 0, with the
/// reason in the last line.
#[test]
fn compensate_program_without_moves_in_its_own_dialect_is_passed_on_unchanged() {
    let program = "%\nO917100 (TOOL LENGTHS)\nT02 M06\nG65 P919100 H02 I-45.0 J15.0\nM02\n%\n";
    let (code, out, err, left) = run_in(
        &[("e.yaml", HEAD_TABLE_ERRORS), ("p.nc", program)],
        &COMPENSATE_P_NC,
    );
    assert_eq!(code, Some(0), "{err}");
    assert!(
        out.contains("nothing changed: no motion block in its 6 blocks, which read as fanuc (the text shows it: `O-number` at line 2): it moves no axis itself"),
        "{out}"
    );
    assert!(!out.contains("another controller"), "{out}");
    assert_eq!(left, ["e.yaml", "out.nc", "p.nc"]);
    let dir_out = out.lines().last().unwrap();
    assert!(dir_out.ends_with("out.nc is a copy of p.nc"), "{dir_out}");
}

/// FANUC axis words without a decimal point were readable only with
/// `--integer-unit` on every run (issue 16 item 3): the machine file now
/// says how its control reads them, and the flag still overrides it.
#[test]
fn compensate_integer_axis_words_follow_the_machine_file_s_integer_unit() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let machine = std::fs::read_to_string(root.join("examples/machines/bc-trunnion.yaml"))
        .unwrap()
        .replace("name: bc-trunnion", "name: my-fanuc");
    assert!(machine.contains("name: my-fanuc"));
    let errors = "machine: my-fanuc\nlocation_errors: {EX0B: 10.0}\n";
    let program = "%\nO1003\nG90 G21 G54\nG0 X10000 Y10000 Z50000 B0 C0\nG1 X20000 F300\nM30\n%\n";
    let args = [
        "compensate",
        "--machine",
        "m.yaml",
        "--errors",
        "e.yaml",
        "p.nc",
        "-o",
        "out.nc",
    ];
    // Unknown unit: nothing can be rewritten, and the refusal says how to
    // tell.
    let (code, _, err, _) = run_in(
        &[("m.yaml", &machine), ("e.yaml", errors), ("p.nc", program)],
        &args,
    );
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("set integer_unit in the machine file"),
        "{err}"
    );
    // IS-B in the machine file: X10000 is 10 mm, corrected by EX0B's 10 um.
    let is_b = format!("{machine}integer_unit: um\n");
    let dir = crate::util::tempdir();
    for (name, text) in [
        ("m.yaml", is_b.as_str()),
        ("e.yaml", errors),
        ("p.nc", program),
    ] {
        std::fs::write(dir.path().join(name), text).unwrap();
    }
    let run = |extra: &[&str]| {
        let o = crate::cli::fivecal()
            .current_dir(dir.path())
            .args(args)
            .args(extra)
            .output()
            .unwrap();
        assert_eq!(
            o.status.code(),
            Some(0),
            "{}",
            String::from_utf8_lossy(&o.stderr)
        );
        std::fs::read_to_string(dir.path().join("out.nc")).unwrap()
    };
    let out = run(&[]);
    assert!(
        out.contains("G0 X10.01 Y10000 Z50000 B0 C0\nG1 X20.01 F300\n"),
        "{out}"
    );
    // The flag overrides the file: IS-C reads X10000 as 1 mm.
    let out = run(&["--integer-unit", "0.1um"]);
    assert!(
        out.contains("G0 X1.01 Y10000 Z50000 B0 C0\nG1 X2.01 F300\n"),
        "{out}"
    );
    // A unit the control has not is refused at its key.
    let (code, _, err, _) = run_in(
        &[
            ("m.yaml", &format!("{machine}integer_unit: nm\n")),
            ("e.yaml", errors),
            ("p.nc", program),
        ],
        &args,
    );
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("m.yaml:") && err.contains("integer_unit"),
        "{err}"
    );
}

/// `simulate -o x.csv` on a nine-section plan wrote the machined piece's
/// points as label,x,y,z, which analyze refuses for this test (its points
/// have no nominal to measure heights from): the CSV it writes for
/// nine-section is now the heights analyze reads.
#[test]
fn simulate_nine_section_csv_is_the_heights_analyze_reads() {
    let dir = crate::util::tempdir();
    let d = dir.path();
    let run = |args: &[&str]| {
        let o = crate::cli::fivecal()
            .current_dir(d)
            .args(args)
            .output()
            .unwrap();
        assert_eq!(
            o.status.code(),
            Some(0),
            "{args:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        String::from_utf8_lossy(&o.stdout).into_owned()
    };
    run(&[
        "plan",
        "nine-section",
        "--machine",
        "bc-trunnion",
        "--out",
        "p",
    ]);
    std::fs::write(
        d.join("t.yaml"),
        "machine: bc-trunnion\nlocation_errors: {EX0B: 10.0, EA0B: 40.0}\n",
    )
    .unwrap();
    let said = run(&[
        "simulate",
        "--plan",
        "p/nine-section.plan.yaml",
        "--errors",
        "t.yaml",
        "-o",
        "x.csv",
    ]);
    assert!(said.contains("(heights)"), "{said}");
    let csv = std::fs::read_to_string(d.join("x.csv")).unwrap();
    assert!(csv.contains("\nsection,height_um\n1,0.0000\n"), "{csv}");
    let said = run(&[
        "analyze",
        "--plan",
        "p/nine-section.plan.yaml",
        "--measured",
        "x.csv",
        "--out",
        "r.yaml",
    ]);
    assert!(said.contains("wrote r.yaml"), "{said}");
    // The points are still there for whoever asks for them by name.
    run(&[
        "simulate",
        "--plan",
        "p/nine-section.plan.yaml",
        "--errors",
        "t.yaml",
        "-o",
        "pts.csv",
        "--format",
        "csv",
    ]);
    let pts = std::fs::read_to_string(d.join("pts.csv")).unwrap();
    assert!(pts.contains("\nlabel,x,y,z\n"), "{pts}");
}

/// A NUL byte in an NC program was reported as `line 2: a NUL byte` with
/// no file named.
#[test]
fn compensate_nul_byte_names_the_program_and_its_line() {
    let (code, _, err, left) = run_in(
        &[
            ("e.yaml", HEAD_TABLE_ERRORS),
            ("p.nc", "G0 X1 Y0 Z5 B0 C0\nG1 X2\0\n"),
        ],
        &COMPENSATE_P_NC,
    );
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("p.nc:2: a NUL byte: this is not a text file"),
        "{err}"
    );
    assert_eq!(left, ["e.yaml", "p.nc"]);
}

/// The parser corpus klartext.h has 21 moves and not one a rewrite can
/// take (unknown positions, APPR/DEP/polar elements, expressions): it was
/// written out as a copy with exit 0. Now refused, every reason listed
/// (RND, CHF and CYCL CALL POS counted since they are reported; its polar
/// blocks and its CT, whose arc is followed since, move on a rotary
/// position that is not known).
#[test]
fn compensate_program_whose_every_move_is_left_as_written_is_refused() {
    let corpus = std::fs::read_to_string(crate::nc::fixture("heidenhain/klartext.h")).unwrap();
    let (code, out, err, left) = run_in(
        &[("e.yaml", HEAD_TABLE_ERRORS), ("k.h", &corpus)],
        &[
            "compensate",
            "--machine",
            "head-table",
            "--errors",
            "e.yaml",
            "k.h",
            "-o",
            "out.h",
        ],
    );
    assert_eq!(code, Some(2), "{out}{err}");
    assert!(
        err.contains("none of its 22 moves could be rewritten")
            && err.contains("the position of B is not known here (not yet programmed: give its start with --rotary-start B=DEG; or forgotten after a jump, call, probe or tool change): lines 10, 11, 13, 19, 20, 21, 22, 23")
            && err.contains("approach or departure (APPR/DEP) left as written")
            // The reasons are many: the message may be cut before its
            // end; that nothing is written the directory shows below.
            && (err.contains("nothing written") || err.contains("(message cut)")),
        "{err}"
    );
    assert_eq!(left, ["e.yaml", "k.h"]);
}

/// A program whose only move cannot be read: nothing understood, nothing
/// to compensate (before, a copy with exit 0). The unreadable block is
/// named, not a wrong dialect guessed.
#[test]
fn compensate_program_with_no_readable_move_is_refused_naming_the_block() {
    let bad = std::fs::read_to_string(crate::nc::fixture("bad/unclosed_comment.nc")).unwrap();
    let (code, _, err, left) = run_in(
        &[
            (
                "e.yaml",
                "machine: bc-trunnion\nlocation_errors: {EX0B: 30.0}\n",
            ),
            ("p.nc", &bad),
        ],
        &[
            "compensate",
            "--machine",
            "bc-trunnion",
            "--dialect",
            "fanuc",
            "--errors",
            "e.yaml",
            "p.nc",
            "-o",
            "out.nc",
        ],
    );
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("no motion block understood in its 6 blocks read as fanuc")
            && err.contains("the first at line 4, column 14: unclosed comment"),
        "{err}"
    );
    assert_eq!(left, ["e.yaml", "p.nc"]);
}

/// `simulate nc` on a program none of whose moves it can follow printed
/// "no move could be simulated", wrote an empty sample file and exited 0.
#[test]
fn simulate_nc_program_with_no_move_to_follow_is_refused() {
    let program = "G90 G21\nG1 X[#1+2] Y0 Z0 B0 C0 F100\nM2\n";
    let (code, out, err, left) = run_in(
        &[
            (
                "e.yaml",
                "machine: bc-trunnion\nlocation_errors: {EX0B: 30.0}\n",
            ),
            ("p.ngc", program),
        ],
        &[
            "simulate",
            "nc",
            "--machine",
            "bc-trunnion",
            "--dialect",
            "linuxcnc",
            "--errors",
            "e.yaml",
            "p.ngc",
            "--out",
            "s.csv",
        ],
    );
    assert_eq!(code, Some(2), "{out}{err}");
    assert!(
        err.contains("no move of it could be simulated") && err.contains("nothing written"),
        "{err}"
    );
    assert_eq!(left, ["e.yaml", "p.ngc"]);
}

/// The plan's own points.csv given as the measurement "identified" errors
/// of 1e-28 with u of 1e-12 (issue 14). Refused, for a machined piece (also
/// placed rigidly elsewhere, as a noise-free simulation of a perfect
/// machine writes it) and for a probing run.
#[test]
fn analyze_plan_points_given_as_the_measurement_are_refused() {
    let dir = crate::util::tempdir();
    let d = dir.path();
    let analyze = |test: &str, measured: &str| {
        crate::cli::fivecal()
            .current_dir(d)
            .args(["analyze", "--plan", &format!("{test}/{test}.plan.yaml")])
            .args(["--measured", measured, "--out", "r.yaml", "--no-record"])
            .output()
            .unwrap()
    };
    for test in ["stepped-square", "probe-sphere"] {
        let out = crate::cli::fivecal()
            .current_dir(d)
            .args(["plan", test, "--machine", "bc-trunnion", "--out", test])
            .output()
            .unwrap();
        assert!(out.status.success(), "{test}: {out:?}");
        let out = analyze(test, &format!("{test}/{test}.points.csv"));
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{test}: {err}");
        assert!(
            err.contains("are the plan's nominal points") && err.contains("not a measurement"),
            "{test}: {err}"
        );
        assert!(!d.join("r.yaml").exists());
    }
    // The machined piece's points turned and shifted, as a CMM's frame
    // has them: still the nominal points.
    let src = std::fs::read_to_string(d.join("stepped-square/stepped-square.points.csv")).unwrap();
    let mut moved = String::from("label,x,y,z\n");
    let (s, c) = (0.3f64.sin(), 0.3f64.cos());
    for line in src
        .lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("label"))
    {
        let f: Vec<&str> = line.split(',').collect();
        let p: Vec<f64> = f[5..8].iter().map(|v| v.parse().unwrap()).collect();
        moved += &format!(
            "{},{:.4},{:.4},{:.4}\n",
            f[0],
            c * p[0] - s * p[1] + 250.0,
            s * p[0] + c * p[1] - 40.0,
            p[2] + 12.5
        );
    }
    std::fs::write(d.join("moved.csv"), &moved).unwrap();
    let out = analyze("stepped-square", "moved.csv");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("moved.csv: its 144 points are the plan's nominal points"),
        "{err}"
    );
    // One point 0.3 um off (a real measurement has all of them off by more)
    // is no longer a copy: the check does not refuse measurements.
    let first = moved.lines().nth(1).unwrap().to_string();
    let f: Vec<&str> = first.split(',').collect();
    let x: f64 = f[1].parse().unwrap();
    let nudged = moved.replacen(
        &first,
        &format!("{},{:.4},{},{}", f[0], x + 0.0003, f[2], f[3]),
        1,
    );
    std::fs::write(d.join("moved.csv"), &nudged).unwrap();
    let out = analyze("stepped-square", "moved.csv");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("nominal points"), "{err}");
}

/// `--export fanuc` of an EX0B of 1 m wrote a 1000 mm shift; of 1e300 a
/// 300-digit number (issue 14). The error file refuses such a value (and
/// writes 1e300 as 1e300); a value it takes but beyond --max-change is
/// refused with the parameter named, for every controller, and nothing is
/// written.
#[test]
fn export_of_an_implausible_error_is_refused_with_the_parameter_named() {
    let huge = "machine: bc-trunnion\nlocation_errors: {EX0B: 1e300}\n";
    let (code, _, err, _) = run_in(
        &[("e.yaml", huge)],
        &[
            "compensate",
            "--machine",
            "bc-trunnion",
            "--errors",
            "e.yaml",
            "--export",
            "fanuc",
        ],
    );
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("EX0B 1e300 um is not plausible"), "{err}");
    assert!(err.len() < 300, "{err}");
    let big = "machine: bc-trunnion\nlocation_errors: {EX0B: {value: 5000.0, u: 0.4}}\n";
    for (d, name) in [
        ("fanuc", "parameter 19700"),
        ("heidenhain", "parameter B.X"),
        ("linuxcnc", "parameter x-rot-point"),
    ] {
        let (code, out, err, left) = run_in(
            &[("e.yaml", big)],
            &[
                "compensate",
                "--machine",
                "bc-trunnion",
                "--errors",
                "e.yaml",
                "--export",
                d,
                "--export-to",
                "p.txt",
                "--no-record",
            ],
        );
        assert_eq!(code, Some(2), "{d}: {out}{err}");
        assert!(
            err.contains(name)
                && err.contains("+5000.00 um")
                && err.contains("beyond --max-change 0.1 mm"),
            "{d}: {err}"
        );
        assert_eq!(left, ["e.yaml"], "{d}");
        assert!(out.is_empty(), "{d}: {out}");
    }
}

/// `--strict` let unknown M functions and G10 work-offset changes pass,
/// and an address the machine lacks (`W5`) or an unknown G code alone in a
/// block went unreported (issue 16): each is named at its own line, the
/// moves in an offset G10 changed whose relation to the offset of the first
/// move is not known are left as written, and `--strict` refuses what is
/// not modelled at the line and column (G10 L2 to an offset not identified
/// among them; G10 L2 with literal values is modelled).
#[test]
fn compensate_reports_unknown_m_codes_g10_and_foreign_addresses_at_their_own_line() {
    let program = "G54\nG0 X0 Y0 Z10 B0 C0\nM77\nG1 X10 Y0 Z0 F100\nG777\nW5\nG10 L2 P2 X5\nG1 X12 Y0 Z0\nG10 L2 P1 X5\nG1 X14 Y0 Z0\nG55\nG1 X15 Y0 Z0\nM2\n";
    let (out, s) = compensate_text(program, "{EX0B: 30.0}", |_| {}).unwrap();
    let lines_of = |list: &[(String, fivecal::compensate::Lines)], needle: &str| {
        list.iter()
            .find(|(w, _)| w.contains(needle))
            .map(|(_, l)| l.first.clone())
            .unwrap_or_else(|| panic!("no `{needle}` in {list:?}"))
    };
    assert_eq!(lines_of(&s.unmodelled, "M77"), vec![3]);
    assert_eq!(lines_of(&s.unmodelled, "`G777`"), vec![5]);
    assert!(
        s.unmodelled.iter().all(|(w, _)| !w.contains("G10")),
        "{:?}",
        s.unmodelled
    );
    let skipped: Vec<(String, fivecal::compensate::Lines)> = s
        .skipped
        .iter()
        .map(|(r, l)| (r.text.clone(), l.clone()))
        .collect();
    assert_eq!(lines_of(&skipped, "axis W"), vec![6]);
    // G10 on G55 (P2) leaves G54 as it was: line 8 is corrected; G54's X
    // set (P1) is no longer related to the value G54 had at the first
    // move (unknown), and neither is G55's.
    assert_eq!(lines_of(&skipped, "G10 L2/L20"), vec![10, 12]);
    let row = |n: usize| out.lines().nth(n - 1).unwrap().to_string();
    assert_ne!(row(8), "G1 X12 Y0 Z0", "{out}");
    assert_eq!(row(10), "G1 X14 Y0 Z0");
    assert_eq!(row(12), "G1 X15 Y0 Z0");
    for (block, what) in [
        ("M77", "p.ngc:2:1: M77"),
        ("N5 G10 L2 P#1 X5", "p.ngc:2:4: G10"),
    ] {
        let cut = format!("G0 X0 Y0 Z10 B0 C0\n{block}\nM2\n");
        let e = compensate_text(&cut, "{EX0B: 30.0}", |s| s.strict = true).unwrap_err();
        assert!(e.starts_with(what) && e.contains("--strict"), "{e}");
    }
    // LinuxCNC's own M functions (M64: a digital output) are known.
    let e = compensate_text("G0 X0 Y0 Z10 B0 C0\nM64 P1\nM2\n", "{EX0B: 30.0}", |s| {
        s.strict = true
    });
    assert!(e.is_ok(), "M64 is LinuxCNC's own: {e:?}");
}

/// `compensate --note` without `--export` was accepted and silently
/// dropped (a program rewrite is not recorded): it is refused, naming the
/// flag, before anything is written.
#[test]
fn compensate_note_without_export_is_refused_not_ignored() {
    let dir = tempfile::tempdir().unwrap();
    let prog = dir.path().join("p.ngc");
    std::fs::write(&prog, "G0 X0 Y0 Z10 B0 C0\nM2\n").unwrap();
    let errs = dir.path().join("e.yaml");
    std::fs::write(
        &errs,
        "machine: bc-trunnion\nlocation_errors: {EX0B: 3.0}\n",
    )
    .unwrap();
    let out = dir.path().join("o.ngc");
    let run = crate::cli::fivecal()
        .args([
            "compensate",
            "--machine",
            "bc-trunnion",
            "--dialect",
            "linuxcnc",
        ])
        .arg("--errors")
        .arg(&errs)
        .arg(&prog)
        .arg("-o")
        .arg(&out)
        .args(["--note", "after the crash"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success(), "{err}");
    assert!(err.contains("--note") && err.contains("--export"), "{err}");
    assert!(!out.exists());
}

/// A program whose lines end in a bare CR (old Mac files) was read as one
/// block of the whole file: `compensate` reported 1 block, 0 moves and
/// exit 0 with nothing corrected (and a large such file grew one block
/// without bound). It is read line by line, corrected like its LF twin,
/// and keeps its CR line ends.
#[test]
fn compensate_reads_a_program_whose_lines_end_in_a_bare_cr() {
    let lf = "G21 G90 G17\nG0 X0 Y0 Z10 B0 C0\nG1 X10 Y5 Z2 B10 F100\nM2\n";
    let cr = lf.replace('\n', "\r");
    let (out_lf, s_lf) = compensate_text(lf, "{EX0B: 30.0}", |_| {}).unwrap();
    let (out_cr, s_cr) = compensate_text(&cr, "{EX0B: 30.0}", |_| {}).unwrap();
    assert_eq!(
        (s_cr.blocks, s_cr.moves, s_cr.changed),
        (4, 2, 2),
        "{s_cr:?}"
    );
    assert_eq!(out_cr, out_lf.replace('\n', "\r"));
    assert_eq!(s_lf.changed, s_cr.changed);
    assert!(!out_cr.contains('\n'));
}

/// Found by the NC property tests, at zero error: a value written with
/// more decimals than a float holds (`Y-20.00099999999999999999999999`)
/// was rewritten for floating-point noise (`-20.000999999999998`).
#[test]
fn compensate_at_zero_error_keeps_lexemes_longer_than_a_float() {
    let program =
        "G21 G90 G17\nG0 X10 Y20 Z5 B25 C65\nG1 X10 Y-20.00099999999999999999999999 F100\nM2\n";
    let (out, s) = compensate_text(program, "{EX0B: 0.0}", |_| {}).unwrap();
    assert_eq!(out, program);
    assert_eq!((s.changed, s.inserted), (0, 0), "{s:?}");
}

/// Found by the NC property tests, at zero error: an arc during which B
/// moves (`G2 X-10b.000 ...`, a `b` typed into X-10.000) was linearized
/// although nothing needed correcting. It stays as written; with a real
/// error it is still linearized (tests/compensate.rs checks its path).
#[test]
fn compensate_at_zero_error_keeps_arcs_that_turn_the_rotary_axes() {
    let program = "G21 G90 G17\nG0 X10 Y20 Z5 B25 C65\nG2 X-10b.000 Y20.000 I-10.000 J0 F100\nG3 X10 Y20 I10 J0 B25 C80\nM2\n";
    let (out, s) = compensate_text(program, "{EX0B: 0.0}", |_| {}).unwrap();
    assert_eq!(out, program);
    assert_eq!((s.changed, s.inserted), (0, 0), "{s:?}");
    assert!(s.linearized.is_empty());
}

/// An arc of a hundred million turns (LinuxCNC's P word) that had to be
/// linearized asked for billions of pieces at once and grew without
/// bound: it is refused at its line before any is made.
#[test]
fn compensate_refuses_an_arc_of_too_many_pieces_before_making_them() {
    let program = "G21 G90 G17\nG0 X10 Y0 Z5 B0 C0\nG2 X10 Y0 I-10 J0 P100000000 B10 F100\nM2\n";
    let e = compensate_text(program, "{EX0B: 30.0}", |_| {}).unwrap_err();
    assert!(
        e.contains(":3") && e.contains("even in 65536 pieces"),
        "{e}"
    );
}

/// Axis, centre and radius values beyond a control's five integer digits
/// (a J of 1e58 after a damaged edit, X of 1e47): the arc's centre was
/// lost in floating point and compensate at zero error refused the
/// program ("cannot be followed even in 65536 pieces", "a correction of
/// 2e34 um"). A control alarms there: the block is left as written with
/// the reason, the axis forgotten until a block sets it again.
#[test]
fn compensate_leaves_values_beyond_a_control_s_range_as_written() {
    let huge = format!("{}.5", "9".repeat(58));
    let program = format!(
        "G21 G90 G17\nG0 X-20 Y20 Z5 B20 C90\nG2 X-30 Y10 I-10 J{huge} F600\nG1 X{huge} Y10\nG1 X5 Y5\nM2\n"
    );
    for errors in ["{EX0B: 0.0}", "{EX0B: 30.0}"] {
        let (out, s) = compensate_text(&program, errors, |_| {}).unwrap();
        let lines: Vec<&str> = out.lines().collect();
        assert_eq!(lines[2], format!("G2 X-30 Y10 I-10 J{huge} F600"));
        assert_eq!(lines[3], format!("G1 X{huge} Y10"));
        let beyond = |letter: &str, line: usize| {
            s.skipped.iter().any(|(why, at)| {
                why.starts_with(&format!("{letter} value beyond what a control takes"))
                    && at.contains(&line)
            })
        };
        assert!(beyond("J", 3) && beyond("X", 4), "{s:?}");
    }
}

/// A machine pivot of -1e300 mm was once blamed on `stock.height`; named
/// at its key now, it was still echoed as three hundred digits, and so
/// were an error value, a noise and a rapid rate of 1e300: each is
/// written as `1e300` in the message.
#[test]
fn implausible_machine_and_error_values_are_echoed_short() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let machine = std::fs::read_to_string(root.join("examples/machines/bc-trunnion.yaml")).unwrap();
    for (from, to, expect) in [
        (
            "pivot: [0.0, 0.0, -420.0]",
            "pivot: [0.0, 0.0, -1e300]",
            "pivot -1e300 mm is beyond any machine tool",
        ),
        (
            "linear: 20000.0",
            "linear: 1e300",
            "rapid linear rate 1e300 mm/min",
        ),
    ] {
        assert!(machine.contains(from), "{from}");
        let e = Machine::from_yaml(Path::new("m.yaml"), &machine.replacen(from, to, 1))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("m.yaml:") && e.contains(expect), "{e}");
        assert!(e.len() < 200, "{e}");
    }
    let k = Kinematics::new(&Machine::builtin("bc-trunnion").unwrap());
    for (src, expect) in [
        (
            "machine: bc-trunnion\nlocation_errors: {EX0B: 1e300}\n",
            "EX0B 1e300 um is not plausible",
        ),
        (
            "machine: bc-trunnion\nlocation_errors: {EX0B: 1.0}\neffects: {noise: {cmm: 1e300}}\n",
            "noise cmm 1e300 um",
        ),
    ] {
        let e = ErrorFile::parse(Path::new("e.yaml"), src)
            .and_then(|f| f.to_model(&k, Path::new("e.yaml"), src).map(|_| ()))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("e.yaml:") && e.contains(expect), "{e}");
        assert!(e.len() < 200, "{e}");
    }
}

/// Errors within the plausible range but too large for a plan (10 mm and
/// 10 mrad) gave "point B0C0-XP1: no cut reaches its surface" with no
/// file named: the message now names the plan and the error file, and
/// says the errors are too large for the plan.
#[test]
fn simulate_names_the_plan_and_the_errors_when_no_cut_reaches_a_point() {
    let d = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/analyze/stepped-square");
    let dir = crate::util::tempdir();
    let errors = dir.path().join("large.yaml");
    std::fs::write(
        &errors,
        "machine: bc-trunnion\nlocation_errors: {EX0B: 9999.0, EA0B: 9999.0, EC0B: 9999.0}\n",
    )
    .unwrap();
    let out = crate::cli::fivecal()
        .args(["simulate", "--plan"])
        .arg(d.join("stepped-square.plan.yaml"))
        .arg("--errors")
        .arg(&errors)
        .arg("-o")
        .arg(dir.path().join("m.dmo"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("stepped-square.plan.yaml")
            && err.contains("large.yaml")
            && err.contains("no cut reaches its surface")
            && err.contains("the errors are too large for this plan"),
        "{err}"
    );
    assert!(!dir.path().join("m.dmo").exists());
}

/// An `--out` directory with a space and a trailing slash: the second-run
/// commands `plan` suggests were built from the directory already quoted,
/// so `'first dir/'-second` named a directory `first dir/-second`. Each
/// suggested command, split by a real shell, must give the paths the plan
/// wrote and the second run's directory beside it.
#[test]
fn suggested_commands_keep_an_out_directory_with_a_space_one_word() {
    let tmp = crate::util::tempdir();
    let dir = tmp.path();
    let run = crate::cli::fivecal()
        .args([
            "plan",
            "probe-columns",
            "--machine",
            "head-table",
            "--out",
            "first dir/",
        ])
        .current_dir(dir)
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let manifest =
        fivecal::formats::manifest::Manifest::read(&dir.join("first dir/probe-columns.plan.yaml"))
            .unwrap();
    let s = manifest
        .suggestions
        .iter()
        .find(|s| s.second_run.is_some())
        .expect("head-table's probe columns suggest a second run");
    let shell_words = |command: &str| -> Vec<String> {
        let out = std::process::Command::new("sh")
            .arg("-c")
            .arg(format!("printf '%s\\n' {command}"))
            .output()
            .unwrap();
        String::from_utf8(out.stdout)
            .unwrap()
            .lines()
            .map(String::from)
            .collect()
    };
    let after = |words: &[String], flag: &str| -> Vec<String> {
        words
            .windows(2)
            .filter(|w| w[0] == flag)
            .map(|w| w[1].clone())
            .collect()
    };
    let plan = shell_words(s.command.as_deref().unwrap());
    assert_eq!(after(&plan, "--out"), ["first dir-second"], "{plan:?}");
    let together = shell_words(&s.second_run.as_ref().unwrap().together);
    assert_eq!(
        after(&together, "--plan"),
        [
            "first dir/probe-columns.plan.yaml",
            "first dir-second/probe-columns.plan.yaml"
        ],
        "{together:?}"
    );
}

/// The moves of `a` and `b` after their first `n_a` and `n_b` lines, as
/// rewritten, and the number of their vertices that were written.
fn tails(a: &str, n_a: usize, b: &str, n_b: usize) -> (Vec<String>, Vec<String>) {
    let tail = |t: &str, n: usize| t.lines().skip(n).map(str::to_string).collect::<Vec<_>>();
    (tail(a, n_a), tail(b, n_b))
}

/// ElMoe's SINUMERIK keychain program positions B and C in program
/// coordinates, then selects its work offset (`G54`) and machines without
/// another rotary word. The change of work offset once forgot B and C
/// (233 of its 577 motion blocks left as written); the rotary positions
/// are machine positions whatever the work offset (each lies on the W
/// origin at rotary zero), so the moves after it are corrected exactly as
/// without the `G54`, and land on the intended points.
#[test]
fn compensate_sinumerik_g54_after_rotary_positioning_keeps_b_and_c() {
    let l = crate::compensate::errors("bc-trunnion", 16, 20.0, "");
    let head = "N270 G0 X0 Y0 Z50. B30. C45.\nN280 CYCLE832(0.02,1,1)\nN290 COMPOF\n";
    let moves = "N330 G0 X-10.46 Y-22.721 Z16.\nN340 G1 Z0.0 F2069.\nN350 X-14.543\nN360 G3 X-15.843 Y-24.021 I0.0 J-1.3\nN370 G1 Y-27.041\nM30\n";
    let with = format!("{head}N320 G54\n{moves}");
    let without = format!("{head}{moves}");
    let settings = || fivecal::compensate::Settings::new(fivecal::Dialect::Sinumerik);
    let (out_with, s, vs) = crate::compensate::compensate(&l, settings(), &with);
    let (out_without, _, _) = crate::compensate::compensate(&l, settings(), &without);
    assert!(s.skipped.is_empty(), "{:?}", s.skipped);
    assert_eq!((s.motion_blocks, s.corrected_blocks), (6, 6));
    let (a, b) = tails(&out_with, 4, &out_without, 3);
    assert_eq!(a, b);
    assert!(a[0] != "N330 G0 X-10.46 Y-22.721 Z16.", "{out_with}");
    for v in vs.iter().filter(|v| v.line >= 5) {
        crate::compensate::assert_reaches(&l, v, "after G54");
    }
}

/// The same on FANUC and LinuxCNC: a change of work offset (`G55`) keeps
/// the rotary positions; the linear ones are forgotten until written
/// again.
#[test]
fn compensate_iso_work_offset_change_keeps_the_rotary_positions() {
    let l = crate::compensate::errors("bc-trunnion", 17, 20.0, "");
    for d in [fivecal::Dialect::Fanuc, fivecal::Dialect::Linuxcnc] {
        let program =
            "G90 G54 G0 X0. Y0. Z50. B30. C45.\nG55\nG0 X10. Y5. Z20.\nG1 X20. F500.\nM30\n";
        let (out, s, vs) =
            crate::compensate::compensate(&l, fivecal::compensate::Settings::new(d), program);
        assert!(s.skipped.is_empty(), "{d}: {:?}", s.skipped);
        assert_eq!((s.motion_blocks, s.corrected_blocks), (3, 3), "{d}");
        assert!(out.lines().nth(2) != Some("G0 X10. Y5. Z20."), "{d}: {out}");
        for v in &vs {
            crate::compensate::assert_reaches(&l, v, "after G55");
        }
    }
}

/// 121philip's SINUMERIK CAM program homes its axes in machine
/// coordinates (`SUPA ... A=_A_HOME C=_C_HOME` with the variables set to
/// 0) and never writes A again: every one of its 973 moves was left as
/// written ("the position of A is not known"). A rotary axis positioned in
/// machine coordinates is at the angle written in program coordinates too
/// (no work offset has a rotary part), so the moves after it are corrected
/// as after a `G0 A0 C0`; on FANUC a `G53 B-30.` is a `G0 B-30.`, and an
/// incremental G53 word or a linear axis stays unknown.
#[test]
fn compensate_rotary_axis_positioned_in_machine_coordinates_is_known_after() {
    let l = crate::compensate::errors("ac-trunnion", 18, 20.0, "");
    let sinumerik = |rotary: &str| {
        format!(
            "N10 DEF REAL _A_HOME, _C_HOME\nN20 _A_HOME=0 _C_HOME=0\nN30 G17 G710 G94 G90\n{rotary}\nN150 G54\nN180 G0 X165.356 Y114.944 Z60. D1\nN190 Z53.\nN200 G1 X166.816 Y118.479 F250.\nM30\n"
        )
    };
    let settings = |d| fivecal::compensate::Settings::new(d);
    let d = fivecal::Dialect::Sinumerik;
    let (supa, s, vs) = crate::compensate::compensate(
        &l,
        settings(d),
        &sinumerik("N90 SUPA G0 A=_A_HOME C=_C_HOME D1"),
    );
    let (plain, _, _) =
        crate::compensate::compensate(&l, settings(d), &sinumerik("N90 G0 A0 C0 D1"));
    assert_eq!(
        s.skipped
            .iter()
            .map(|(r, _)| r.text.as_str())
            .collect::<Vec<_>>(),
        Vec::<&str>::new(),
        "{supa}"
    );
    assert_eq!((s.motion_blocks, s.corrected_blocks), (4, 3));
    let (a, b) = tails(&supa, 5, &plain, 5);
    assert_eq!(a, b);
    for v in &vs {
        crate::compensate::assert_reaches(&l, v, "after SUPA");
    }

    let l = crate::compensate::errors("bc-trunnion", 19, 20.0, "");
    let fanuc = |rotary: &str| {
        format!(
            "G90 G54 G0 X0. Y0. Z100. B0. C0.\n{rotary}\nG0 X10. Y5. Z20.\nG1 X20. F500.\nM30\n"
        )
    };
    let d = fivecal::Dialect::Fanuc;
    let (g53, s, vs) = crate::compensate::compensate(&l, settings(d), &fanuc("G53 B-30."));
    let (_, _, plain) = crate::compensate::compensate(&l, settings(d), &fanuc("G0 B-30."));
    assert!(s.skipped.is_empty(), "{:?}", s.skipped);
    assert_eq!(g53.lines().nth(1), Some("G53 B-30."));
    // The G53 block is kept; the next move writes the corrected B and C
    // that the `G0 B-30.` block wrote itself: the same axis positions.
    let after = |v: &[fivecal::compensate::Vertex]| {
        v.iter()
            .filter(|v| v.line >= 3)
            .map(|v| v.written)
            .collect::<Vec<_>>()
    };
    assert_eq!(after(&vs).len(), 2);
    assert_eq!(after(&vs), after(&plain));
    for v in &vs {
        crate::compensate::assert_reaches(&l, v, "after G53");
    }
    // Incremental: where B ends is not written, and stays unknown.
    let (_, s, _) = crate::compensate::compensate(&l, settings(d), &fanuc("G91 G53 B-30.\nG90"));
    assert!(
        s.skipped.iter().any(|(r, _)| r.contains("position of B")),
        "{:?}",
        s.skipped
    );
}

/// The NX post for a Haas UMC-750 (read as FANUC) switches tool centre
/// point control on with Haas's `G234 H02` and positions 3+2 sections
/// with the dynamic work offset `G254`, cancelled by `G255`. Both were
/// unknown codes "taken to move no axis", so the tip coordinates after
/// `G234` were corrected as axis positions. `G234` is now read as `G43.4`
/// is (the same rewrite), and the rotary positions written before it stay
/// known under it (switching TCP turns no rotary axis).
#[test]
fn compensate_haas_g234_is_tool_centre_point_control() {
    let l = crate::compensate::errors("bc-trunnion", 20, 20.0, "");
    let program = |tcp: &str| {
        format!(
            "G17 G54 G90\nG00 B7.125 C0.\n{tcp} H02\nG90 X-4.6 Y41.3 Z88.3\nG01 X-10.9 Y41.5 Z35.7 F250.\nX-10.4 Y41.8 Z35.\nG255\nG53 G00 Z0.\nG00 B82.875 C-180.\nG254\nG54 G90 G00 X-48.8 Y-59.\nG43 H01 Z7.\nG01 Y-64.1 Z6.8 F250.\nG255\nM30\n"
        )
    };
    let settings = || fivecal::compensate::Settings::new(fivecal::Dialect::Fanuc);
    let (haas, s, vs) = crate::compensate::compensate(&l, settings(), &program("G234"));
    let (fanuc, _, _) = crate::compensate::compensate(&l, settings(), &program("G43.4"));
    let tail = |t: &str| t.lines().skip(3).map(str::to_string).collect::<Vec<_>>();
    assert_eq!(tail(&haas), tail(&fanuc));
    assert!(
        s.coordinates
            .iter()
            .any(|c| c.meaning.contains("TCP") && c.why.contains("G234") && c.lines.0 == 4),
        "{:?}",
        s.coordinates
    );
    // B and C, positioned before G234, stay known under it: every move
    // of the section is corrected.
    let tcpc: Vec<_> = vs.iter().filter(|v| (4..=6).contains(&v.line)).collect();
    assert_eq!(
        tcpc.iter().map(|v| v.line).collect::<Vec<_>>(),
        vec![4, 5, 6],
        "{:?}",
        s.skipped
    );
    for v in tcpc {
        assert!(v.tcp != fivecal::nc::interp::Tcp::Off, "line {}", v.line);
        crate::compensate::assert_reaches(&l, v, "under G234");
    }
    assert!(
        !s.unmodelled
            .iter()
            .any(|(w, _)| w.contains("G234") || w.contains("G254") || w.contains("G255")),
        "{:?}",
        s.unmodelled
    );
}

/// Haas's dynamic work offset `G254` (the Haas mill operator's manual:
/// TCPC for 3+1 and 3+2 positioning, X, Y, Z the workpiece's own
/// coordinates turned with the table to the rotary positions in force,
/// which stay until `G255`) was reported and its moves left as written:
/// 224 motion blocks of the real UMC-750 program of the corpus. Its moves
/// are now corrected as the tips they are: on the erroneous machine the
/// rewrite puts the tip where the program on the nominal machine puts it,
/// and the rotary positions are not touched.
#[test]
fn compensate_haas_g254_moves_are_the_workpiece_s_coordinates_turned_with_the_table() {
    let l = crate::compensate::errors("bc-trunnion", 20, 20.0, "");
    let program = "G17 G90 G49\nG53 G00 Z0.\nG00 B82.875 C-180.\nG254\nG54 G90 G00 X-48.8 Y-59.\nG43 H01 Z7.\nG01 Y-64.1 Z6.8 F250.\nX-20. Y-40.\nG255\nG53 G00 Z0.\nG00 B30. C45.\nG254\nG00 X10. Y5.\nZ20.\nG01 X30. Z12.\nG255\nM30\n";
    let d = fivecal::Dialect::Fanuc;
    let settings = fivecal::compensate::Settings::new(d);
    let (out, s, vs) = crate::compensate::compensate_checked(&l, settings.clone(), program);
    // After G254 the control needs X, Y and Z again: line 5 writes no Z.
    let corrected: Vec<usize> = vs.iter().map(|v| v.line).collect();
    assert_eq!(corrected, [6, 7, 8, 14, 15], "{:?}\n{out}", s.skipped);
    for v in &vs {
        assert!(v.tilted_plane, "line {}", v.line);
        crate::compensate::assert_reaches(&l, v, "under G254");
    }
    // Only X, Y, Z change; B and C stay as the table was turned.
    for (a, b) in program.lines().zip(out.lines()) {
        let rotary = |t: &str| {
            t.split_whitespace()
                .filter(|w| w.starts_with('B') || w.starts_with('C'))
                .map(str::to_string)
                .collect::<Vec<_>>()
        };
        assert_eq!(rotary(a), rotary(b), "{b}");
    }
    assert!(
        !s.skipped.iter().any(|(r, _)| r.contains("G254")),
        "{:?}",
        s.skipped
    );
    // What G254 means: the tip is at the written X, Y, Z in the
    // workpiece's own axes (the program zero at the origin of W), however
    // the table is turned, and the tool points as B and C put it.
    let nominal = fivecal::model::Model::new(l.model.kin.clone(), vec![]);
    let samples = crate::compensate::simulate_with(
        &nominal,
        &[],
        fivecal::compensate::simulate::SimSettings::new(d),
        program,
        0.0,
    );
    let tip = |line: usize| {
        samples
            .iter()
            .find(|x| x.line == line && x.fraction == 1.0)
            .map(|x| x.nominal)
            .unwrap_or_else(|| panic!("line {line} not simulated: {samples:?}"))
    };
    assert!((tip(8).tip - nalgebra::Vector3::new(-20.0, -40.0, 6.8)).norm() < 1e-9);
    assert!((tip(15).tip - nalgebra::Vector3::new(30.0, 5.0, 12.0)).norm() < 1e-9);
    let kin = &l.model.kin;
    let axis_at = |b: f64, c: f64| {
        kin.forward(
            &fivecal::Axes::new(0.0, 0.0, 0.0, b, c),
            &Default::default(),
        )
        .axis
    };
    assert!((tip(8).axis - axis_at(82.875, -180.0)).norm() < 1e-12);
    assert!((tip(15).axis - axis_at(30.0, 45.0)).norm() < 1e-12);
    // The tool axis keeps the erroneous machine's tilt (3+2: the rotary
    // positions are the program's), so the axis is checked loosely there.
    crate::compensate::check_simulated(
        &l,
        &fivecal::compensate::simulate::SimSettings::new(d),
        program,
        &out,
        settings.tolerance,
        &[6, 7, 8, 14, 15],
        "moves under G254",
    );
}

/// The column probing test run with the truth example (`fivecal simulate
/// --truth-example`: EY0A drifting 1.5 um per pose, and the three columns
/// clamped with seeded setup errors), read back from the probe's log: the
/// location errors cannot follow the drift, and the columns' setups turn
/// about their probed points in directions the test sees only a
/// ten-millionth as well as the rest. Discover's starting fit must still be
/// the location model's minimum, the one analyze's global fit finds on the
/// same points; it once stopped where an undamped step along those turns
/// gained nothing, and reported a 33.6 um gap where the minimum leaves
/// 1.9 um.
#[test]
fn discover_starts_from_the_location_minimum_on_the_columns_of_the_truth_example() {
    use fivecal::discover::Fitter;
    use fivecal::discover::fit::{PlanRef, forward_model};
    use fivecal::discover::inputs::Inputs;
    use fivecal::formats::detect::MeasuredOptions;
    use fivecal::identify::{global, lsq};

    let dir = crate::util::tempdir();
    let d = dir.path();
    let run = |args: &[&str]| {
        crate::cli::fivecal()
            .current_dir(d)
            .args(args)
            .assert()
            .success()
            .get_output()
            .stdout
            .clone()
    };
    run(&[
        "plan",
        "probe-columns",
        "--machine",
        "ac-trunnion",
        "--dialect",
        "fanuc",
        "--out",
        "co",
    ]);
    let truth = run(&["simulate", "--truth-example", "--machine", "ac-trunnion"]);
    std::fs::write(d.join("truth.yaml"), truth).unwrap();
    let plan = "co/probe-columns.plan.yaml";
    run(&[
        "simulate",
        "--plan",
        plan,
        "--errors",
        "truth.yaml",
        "--out",
        "columns.log",
    ]);
    let inputs = Inputs::load(
        &d.join(plan),
        &[d.join("columns.log")],
        &MeasuredOptions::default(),
    )
    .unwrap();

    let (fitter, _) = Fitter::new(&[inputs.part()], &[]).unwrap();
    let symbols: Vec<usize> = (0..8).collect();
    let start = fitter.fit(&fitter.location(&symbols), None).unwrap();
    let fm = forward_model(
        start.spec.model.clone(),
        &inputs.data,
        Some(&PlanRef::new(&inputs.plan)),
    )
    .unwrap();
    let analyzed = global::identify(
        &*fm,
        &start.spec.setup(),
        &inputs.data,
        &lsq::Options::default(),
    )
    .unwrap();
    let minimum: f64 = analyzed.residuals.iter().map(|r| r * r).sum();
    // A thousandth of the sum of squares: far below what separates a
    // stalled fit (two orders of magnitude above) from the minimum.
    assert!(
        (start.rss - minimum).abs() <= 1e-3 * minimum,
        "discover's starting fit leaves {:.3} um^2, analyze's minimum {minimum:.3} um^2",
        start.rss
    );
}

/// A SINUMERIK program on the B/C trunnion: the zero-error rewrite is the
/// same bytes; the errors of seed 20 and what `compensate` makes of them.
fn sinumerik_on_bc_trunnion(
    program: &str,
) -> (
    fivecal::errorfile::LoadedErrors,
    (
        String,
        fivecal::compensate::Summary,
        Vec<fivecal::compensate::Vertex>,
    ),
) {
    let settings = fivecal::compensate::Settings::new(fivecal::Dialect::Sinumerik);
    let zero = crate::compensate::errors("bc-trunnion", 0, 0.0, "");
    let (out, _, _) = crate::compensate::compensate(&zero, settings.clone(), program);
    assert_eq!(out, program);
    let l = crate::compensate::errors("bc-trunnion", 20, 20.0, "");
    let run = crate::compensate::compensate(&l, settings, program);
    (l, run)
}

/// A move after tool-vector moves (SINUMERIK TRAORI `A3= B3= C3=`, FANUC
/// G43.5 `I J K`) that does not write the rotary axes: the controller's
/// rotary positions are the ones it solved for the written vector, but
/// the rewriter kept those from before the vectors and, at zero errors,
/// added `B.. C..` to the next block. Zero errors must give the same
/// bytes; with errors the block after TRAFOOF still reaches its point.
#[test]
fn compensate_move_after_tool_vectors_keeps_the_rotary_positions_solved_for_them() {
    let program = "N10 G17 G90 G710 G94\nN20 T=\"MILL D10\" M6\nN30 D1\nN40 G54\nN50 G0 X0 Y0 Z60 B20 C10\nN60 TRAORI\nN70 G1 X10 Y5 Z3 A3=0.1 B3=0.2 C3=1 F500\nN80 TRAFOOF\nN90 G0 X0 Y0 Z60\nN100 M30\n";
    let (l, (_, s, vs)) = sinumerik_on_bc_trunnion(program);
    assert!(s.skipped.is_empty(), "{:?}", s.skipped);
    assert!(vs.iter().any(|v| v.line == 9));
    for v in &vs {
        crate::compensate::assert_reaches(&l, v, "after tool vectors");
    }
}

/// A tool vector that leaves a component out (`C3=1` alone, zero for
/// the others): the correction of the orientation needs the others too.
/// They were dropped, so the rewritten block turned the tool along the
/// uncorrected direction; they are added after the block's vector words.
/// Here the vector is written in a frame turned by `ROT X10`.
#[test]
fn compensate_tool_vector_components_the_block_leaves_out_are_added() {
    let program = "N10 G17 G90 G710 G94\nN20 T=\"MILL D10\" M6\nN30 D1\nN40 G54\nN50 G0 X0 Y0 Z60 B15 C-80\nN60 ROT X10\nN70 TRAORI\nN80 G1 X10 Y5 Z3 C3=1 F500\nN90 X12\nN100 TRAFOOF\nN110 M30\n";
    let (l, (out, s, _)) = sinumerik_on_bc_trunnion(program);
    assert!(s.skipped.is_empty(), "{:?}", s.skipped);
    let n80 = out.lines().nth(7).unwrap();
    assert!(n80.contains(" C3=1 A3=") && n80.contains(" B3="), "{n80}");
    crate::compensate::check_against_simulation(
        &l,
        fivecal::Dialect::Sinumerik,
        fivecal::compensate::Coordinates::Auto,
        program,
        &out,
        0.001,
        "C3= alone",
    );
}

/// A machine whose tilt turns more than a turn either way (an A stroke of
/// -360..360 deg) and a program that turns A through -180 to -200: the
/// inverse kinematics took the tilt's principal value (A180 for the
/// program's A-180., A160 for A-200.), a turn from what the program wrote,
/// and the run was refused as a correction of 6,283,182 urad. The corrected
/// A is at the program's own turn, and the tip stays on the path.
#[test]
fn compensate_keeps_the_programs_turn_of_a_tilt_whose_stroke_exceeds_a_turn() {
    let mut machine = crate::util::machine("ac-trunnion");
    machine.tilt.limits = Some((-360.0, 360.0));
    let l = crate::compensate::errors_on(&machine, 3, 5.0, "");
    let program = "%\nO1000\nG90 G54 G0 X0. Y0. Z50. A-150. C0.\nG1 X0.495 Z27. A-170. F2122.\nX0.5 Z27. A-180.\nX0.505 Z26.994 A-190.\nX1. A-200.\nM30\n%\n";
    let settings = fivecal::compensate::Settings::new(fivecal::Dialect::Fanuc);
    let (out, s, _) = crate::compensate::compensate(&l, settings, program);
    assert!(s.skipped.is_empty(), "{:?}", s.skipped);
    let a_words: Vec<f64> = out
        .lines()
        .filter_map(|line| {
            let i = line.find('A')?;
            let v: String = line[i + 1..]
                .chars()
                .take_while(|c| c.is_ascii_digit() || matches!(c, '.' | '-'))
                .collect();
            v.parse().ok()
        })
        .collect();
    // Each block's A within a hundredth of a degree of the program's (a
    // correction is micro-radians), pieces of a split move in between.
    for want in [-170.0, -180.0, -190.0, -200.0] {
        assert!(
            a_words.iter().any(|a| (a - want).abs() < 0.01),
            "no A near {want}:\n{out}"
        );
    }
    assert!(a_words.iter().all(|a| *a <= -149.99), "{out}");
    // At A = -180 the tool lies along C, where C is held (the singularity
    // policy): on lines 4 to 7 only the tip is checked.
    crate::compensate::check_held(
        &l,
        fivecal::Dialect::Fanuc,
        fivecal::compensate::Coordinates::Auto,
        program,
        &out,
        0.001,
        &[4, 5, 6, 7],
        "A through -180 on a stroke of two turns",
    );
}

#[test]
fn simulate_and_expand_keep_an_unreadable_block_after_the_macro_logic_starts() {
    // A SINUMERIK post (rybakov25's, in the real-file corpus) writes a
    // FANUC-style `(TOOL NAME: ..)` comment, which SINUMERIK cannot read.
    // Once a program has macro logic, `simulate nc` and `--expand` run it
    // flattened; the unreadable block used to stop both with "the
    // expanded block does not read back".
    use fivecal::compensate::Coordinates;
    use fivecal::compensate::simulate::SimSettings;
    use fivecal::model::Model;
    let program = "G17 G90 G710\nR1=10.\nG0 X=R1 Y0 Z50 A0 C0\n(TOOL NAME: D25R4)\nG90 G1 X20 Y5 Z40 A0 C0 F500\nX=R1+20 Y10\nM30\n";
    let d = fivecal::Dialect::Sinumerik;
    let l = crate::compensate::errors("ac-trunnion", 5, 10.0, "");
    let nominal = Model::new(l.model.kin.clone(), vec![]);
    let samples =
        crate::compensate::simulate_with(&nominal, &[], SimSettings::new(d), program, 0.0);
    let ends: Vec<usize> = samples
        .iter()
        .filter(|s| s.fraction == 1.0)
        .map(|s| s.line)
        .collect();
    // Line 5 states every axis again (G90, X Y Z A C) after the unreadable
    // line 4: from there the position is known.
    assert_eq!(ends, [3, 5, 6], "{samples:?}");
    let end = samples.last().unwrap().nominal.tip;
    let first = samples[0].nominal.tip;
    assert!(((end - first) - nalgebra::Vector3::new(20.0, 10.0, -10.0)).norm() < 1e-9);
    let mut settings = fivecal::compensate::Settings::new(d);
    settings.expand = true;
    settings.coordinates = Coordinates::Auto;
    let (out, s, _) = crate::compensate::compensate(&l, settings.clone(), program);
    assert_eq!(s.unreadable, vec![4], "{s:?}");
    assert!(out.contains("\n(TOOL NAME: D25R4)\n"), "{out}");
    assert_eq!(s.corrected_blocks, 3, "{s:?}\n{out}");
    crate::compensate::check_simulated(
        &l,
        &SimSettings::new(d),
        program,
        &out,
        settings.tolerance,
        // A0: the tool lies along C, whose correction is held there (the
        // tool axis within --max-c-swing's tolerance, the tip exact).
        &[3, 5, 6],
        "an unreadable block in a flattened program",
    );
}

/// Older TNCs print a dialog field left without an entry as its bare
/// letter: `L X+12,500 R F M` (the corpus' `language-klartext/700.klartext`
/// and `668.klartext`, with decimal commas) means the radius
/// compensation, feed and M function as they were. The bare `R` stopped
/// the block as unreadable and the bare `F` left its axis words as
/// written ("coordinates are expressions"), and so did a feed from a Q
/// parameter, though Klartext has no inverse-time feed that would need
/// its value (issue 16: a non-axis word never stops the axis words of its
/// block from being corrected).
#[test]
fn compensate_older_tnc_empty_fields_and_parameter_feeds_keep_their_axis_words_corrected() {
    let program = "0 BEGIN PGM 700 MM\n1 L A-20,000 C+0,000 R0 FMAX\n2 L X+0,000 Y+9,500 Z+2,000 R F5000 M13\n3 L Z-4,000 R F100 M\n4 L X+12,500 R F M\n5 Q5 = 250\n6 L Y+6,500 R0 FQ5\n7 L X+23,500 R F M\n8 END PGM 700 MM\n";
    let d = fivecal::Dialect::Heidenhain;
    let l = crate::compensate::errors("ac-trunnion", 7, 10.0, "");
    let settings = fivecal::compensate::Settings::new(d);
    let (out, s, vs) = crate::compensate::compensate_checked(&l, settings.clone(), program);
    assert!(s.unreadable.is_empty(), "{s:?}");
    let lines: Vec<usize> = vs.iter().map(|v| v.line).collect();
    // Line 2 positions A and C only: X, Y, Z are not known yet there.
    assert_eq!(lines, [3, 4, 5, 7, 8], "{:?}\n{out}", s.skipped);
    assert!(out.contains(" R F M\n"), "{out}");
    // Words the correction adds are written as the program writes its
    // numbers, with a decimal comma.
    assert!(
        !out.lines().any(|l| l.contains('.')),
        "a decimal point in a program of decimal commas:\n{out}"
    );
    crate::compensate::check_simulated(
        &l,
        &fivecal::compensate::simulate::SimSettings::new(d),
        program,
        &out,
        settings.tolerance,
        &[],
        "empty dialog fields",
    );
}

/// Issue 16: G52, G51 and an `R0` arc were reported as "the move cannot
/// be followed within --tolerance 1 um even in 65536 pieces" at the next
/// line. G52 (local coordinates) is modelled: the moves after it land
/// where the program means. G51 (scaling) is not: the moves under it are
/// left as written with that reason at their own lines (the G51 block's
/// X, Y are the scaling centre, not a move).
/// An arc whose radius cannot reach its end is left as written at its
/// own line, its reason in words.
#[test]
fn compensate_g52_g51_and_an_r0_arc_are_handled_at_their_own_lines() {
    let d = fivecal::Dialect::Fanuc;
    let l = crate::compensate::errors("bc-trunnion", 31, 20.0, "");
    let settings = fivecal::compensate::Settings::new(d);
    let g52 = "G0 X0. Y0. Z50. B20. C0.\nG52 X10. Y5.\nG1 X20. Y0. Z40. B30. C10. F100.\nX25. Y-5.\nG52 X0 Y0\nG1 X30. F100.\nM30\n";
    let (out, s, vs) = crate::compensate::compensate(&l, settings.clone(), g52);
    assert!(s.skipped.is_empty(), "{:?}", s.skipped);
    assert_eq!(vs.iter().map(|v| v.line).collect::<Vec<_>>(), [1, 3, 4, 6]);
    // The local shift is the program's: with it, line 3 is X30 Y5 in the
    // work offset, on the nominal machine as on the actual one.
    let nominal = fivecal::model::Model::new(l.model.kin.clone(), vec![]);
    let samples = crate::compensate::simulate_with(
        &nominal,
        &[],
        fivecal::compensate::simulate::SimSettings::new(d),
        g52,
        0.0,
    );
    let unshifted = crate::compensate::simulate_with(
        &nominal,
        &[],
        fivecal::compensate::simulate::SimSettings::new(d),
        "G0 X0. Y0. Z50. B20. C0.\nG1 X30. Y5. Z40. B30. C10. F100.\nM30\n",
        0.0,
    );
    let end = |v: &[fivecal::compensate::simulate::Sample], line: usize| {
        v.iter()
            .find(|x| x.line == line && x.fraction == 1.0)
            .map(|x| x.nominal.tip)
            .unwrap()
    };
    assert!((end(&samples, 3) - end(&unshifted, 2)).norm() < 1e-9);
    crate::compensate::check_simulated(
        &l,
        &fivecal::compensate::simulate::SimSettings::new(d),
        g52,
        &out,
        settings.tolerance,
        &[],
        "moves after G52",
    );

    let g51 = "G0 X0. Y0. Z50. B20. C0.\nG51 X0 Y0 P2000\nG1 X20. Y0. Z40. B30. C10. F100.\nG50\nG1 X30. F100.\nM30\n";
    let (out, s, _) = crate::compensate::compensate(&l, settings.clone(), g51);
    let scaled = crate::compensate::reported(&s, "scaling (G51)");
    assert_eq!(scaled, [3], "{:?}", s.skipped);
    assert!(
        out.contains("\nG1 X20. Y0. Z40. B30. C10. F100.\n"),
        "{out}"
    );
    assert!(!out.contains("\nG1 X30. F100.\n"), "{out}");
    let r0 = "G0 X0. Y0. Z50. B30. C0.\nG1 X10. F100.\nG2 X20. Y0. R0 F100.\nG1 X30.\nM30\n";
    let (_, s, _) = crate::compensate::compensate(&l, settings, r0);
    assert_eq!(
        s.skipped
            .iter()
            .map(|(r, l)| (r.text.as_str(), l.first.clone()))
            .collect::<Vec<_>>(),
        [
            (
                "not compensated: an arc whose radius does not reach its end point",
                vec![3]
            ),
            // The line after it starts where the arc left as written
            // leaves the tool: its end is corrected, and it is said.
            (
                "the line starts where the move before it, left as written, leaves the tool: off its intended start by more than --tolerance; its end point is corrected, the path to it is not within the tolerance",
                vec![4]
            )
        ]
    );
}

/// A HEIDENHAIN polar circle left as written (its IPA and DR turn
/// opposite ways) still moves the tool, though it names neither X nor Y:
/// the incremental line after it must count from where the control then
/// stands, not from where the tool was before the circle.
#[test]
fn compensate_incremental_line_after_a_polar_circle_left_as_written_counts_from_its_end() {
    let d = fivecal::Dialect::Heidenhain;
    let l = crate::compensate::errors("ac-trunnion", 97, 30.0, "");
    let program = "0 BEGIN PGM POLAR MM\n1 TOOL CALL 1 Z S4000\n2 L A-20 C+30 R0 FMAX\n3 L X+0 Y+0 Z+2 R0 FMAX\n4 CC X+0 Y+0\n5 L X+10 Y+0 Z-1 F300\n6 CP IPA+90 DR- F300\n7 L IX+5 F300\n8 L Z+50 R0 FMAX\n9 END PGM POLAR MM\n";
    let (out, s, _) =
        crate::compensate::compensate(&l, fivecal::compensate::Settings::new(d), program);
    assert!(
        s.skipped.iter().any(|(w, _)| w.contains("IPA and DR")),
        "{:?}",
        s.skipped
    );
    let nominal = fivecal::model::Model::new(l.model.kin.clone(), vec![]);
    let settings = fivecal::compensate::simulate::SimSettings::new(d);
    let intended = crate::compensate::simulate_with(&nominal, &[], settings.clone(), program, 0.0);
    let actual = crate::compensate::simulate_with(&l.model, &l.theta, settings, &out, 0.0);
    let end_of = |v: &[fivecal::compensate::simulate::Sample], text: &str| {
        let line = text.lines().position(|t| t.contains(" L IX")).unwrap() + 1;
        v.iter()
            .rfind(|x| x.line == line && x.fraction == 1.0)
            .map(|x| (x.nominal.tip, x.actual.tip))
            .unwrap()
    };
    let meant = end_of(&intended, program).0;
    let reached = end_of(&actual, &out).1;
    // The circle as written carries the machine's error (tens of um);
    // counting from the tool's position before it would miss by the
    // circle's own displacement (14 mm).
    let miss = (meant - reached).norm();
    assert!(miss < 0.1, "{miss} mm off:\n{out}");
}

/// A file that only defines a subroutine (as LinuxCNC's `qpocket.ngc`
/// does) moves the axes whenever a program calls it, with the caller's
/// values: its moves are reported as left as written, never passed on
/// as "a program that moves no axis", and a move in a branch not taken
/// is reported too, without disturbing the moves around it.
#[test]
fn compensate_moves_in_a_subroutine_never_called_here_are_reported_not_hidden() {
    let d = fivecal::Dialect::Linuxcnc;
    let l = crate::compensate::errors("ac-trunnion", 98, 30.0, "");
    let settings = fivecal::compensate::Settings::new(d);
    let library = "o<pocket> sub\nG0 X#1 Y#2 Z5\nG1 Z-1 F300\nG1 X[#1+10]\no<pocket> endsub\nM2\n";
    let (out, s, _) = crate::compensate::compensate(&l, settings.clone(), library);
    assert_eq!(out, library);
    assert_eq!(s.moves, 3, "{s:?}");
    let (why, lines) = s
        .skipped
        .iter()
        .find(|(w, _)| w.contains("never runs"))
        .unwrap_or_else(|| panic!("{:?}", s.skipped));
    assert_eq!(lines.first, [2, 3, 4], "{why}");
    // A branch not taken between two corrected moves: they stay corrected.
    let branch = "G21 G90 G17\nG0 X0 Y0 Z10 A-20 C30\n#1 = 0\no10 if [#1 GT 0]\nG0 X50\no10 endif\nG1 X10 Y5 Z2 F300\nM2\n";
    let (out, s, _) = crate::compensate::compensate(&l, settings, branch);
    let (_, lines) = s
        .skipped
        .iter()
        .find(|(w, _)| w.contains("never runs"))
        .unwrap_or_else(|| panic!("{:?}", s.skipped));
    assert_eq!(lines.first, [5]);
    assert_eq!(out.lines().nth(4), Some("G0 X50"));
    assert_ne!(out.lines().nth(6), Some("G1 X10 Y5 Z2 F300"), "{out}");
}

/// Two runs creating a new SQLite store at the same moment: both open it.
/// Turning the new file to WAL needs its exclusive lock, and SQLite
/// answers "database is locked" at once, without waiting, to one of two
/// connections that ask together; one CI run in about twenty failed
/// `store::two_processes_writing_at_once_both_land` on it.
#[test]
fn store_created_by_two_runs_at_once_opens_in_both() {
    for round in 0..50 {
        let s = crate::store::sqlite_store();
        let start = std::sync::Barrier::new(2);
        std::thread::scope(|scope| {
            for k in 0..2 {
                let (s, start) = (&s, &start);
                scope.spawn(move || {
                    start.wait();
                    if let Err(e) = fivecal::store::Store::open(&s.location) {
                        panic!("round {round}, run {k}: {e}");
                    }
                });
            }
        });
    }
}

#[test]
fn simulate_samples_a_359_degree_turn_along_its_path_not_its_chord() {
    // A turn of A from -30 to -359 deg without TCP swings the tip round the
    // A axis, and ends a degree of turn from where it started. The samples
    // were spaced by the chord between the ends (2.7 mm here): about 270
    // at a step of 0.01 mm on an arc of 29 mm, 1.2 deg apart. A polyline
    // through them cuts 0.3 um inside the arc, which a path check of the
    // rewrite counted as leaving the path (1.13 um against a tolerance of 1).
    use fivecal::model::Model;
    let mut machine = crate::util::machine("ac-trunnion");
    machine.tilt.limits = Some((-360.0, 360.0));
    let k = fivecal::kinematics::Kinematics::new(&machine);
    let nominal = Model::new(k, vec![]);
    let program =
        "%\nO1000\nG90 G54 G0 X0. Y0. Z160. A-30. C0.\nG1 X0. Z60. A-30. F2122.\nA-359.\nM30\n%\n";
    let step = 0.1;
    let samples = crate::compensate::simulate(
        &nominal,
        &[],
        fivecal::Dialect::Fanuc,
        fivecal::compensate::Coordinates::Auto,
        program,
        step,
    );
    // The turn's samples, from the end of the line before.
    let first = samples.iter().position(|s| s.line == 5).unwrap();
    let turn: Vec<_> = samples[first - 1..]
        .iter()
        .filter(|s| s.line >= 4)
        .collect();
    let mut length = 0.0;
    for w in turn.windows(2) {
        let gap = (w[1].nominal.tip - w[0].nominal.tip).norm();
        assert!(gap <= step * 1.001, "samples {gap:.4} mm apart");
        length += gap;
    }
    // The circle through three samples gives the arc's length: 329 deg of
    // it.
    let n = turn.len();
    let (a, b, c) = (
        turn[0].nominal.tip,
        turn[n / 3].nominal.tip,
        turn[2 * n / 3].nominal.tip,
    );
    let radius =
        (a - b).norm() * (b - c).norm() * (c - a).norm() / (2.0 * (b - a).cross(&(c - a)).norm());
    let arc = radius * 329f64.to_radians();
    assert!(
        arc > 20.0 && arc > 5.0 * (turn[n - 1].nominal.tip - a).norm(),
        "{radius}"
    );
    assert!(
        (length - arc).abs() < 1e-3 * arc,
        "{length} mm sampled, arc {arc} mm"
    );
    assert!(turn.len() as f64 >= arc / step, "{} samples", turn.len());
}

/// `program` rewritten for `l` on FANUC: nothing left as written, one move
/// in pieces, and the rewrite on the erroneous machine reaches every
/// intended end point (the tool axis loosely at the `held` lines) and stays
/// within 1 um of the intended path.
fn rewritten_in_pieces_within_a_micrometre(
    l: &fivecal::errorfile::LoadedErrors,
    program: &str,
    held: &[usize],
    what: &str,
) -> fivecal::compensate::Summary {
    let settings = fivecal::compensate::Settings::new(fivecal::Dialect::Fanuc);
    let (out, s, _) = crate::compensate::compensate(l, settings, program);
    assert!(s.skipped.is_empty(), "{what}: {:?}", s.skipped);
    assert_eq!(s.subdivided.count, 1, "{what}:\n{out}");
    crate::compensate::check_held(
        l,
        fivecal::Dialect::Fanuc,
        fivecal::compensate::Coordinates::Auto,
        program,
        &out,
        0.001,
        held,
        what,
    );
    s
}

#[test]
fn compensate_keeps_a_359_degree_a_turn_within_the_tolerance() {
    // The case left unexplained when the tilt's turns were fixed: a long
    // turn of A, split into pieces, seemed to leave the intended path by
    // more than the tolerance. It was the check's samples (see
    // `simulate_samples_a_359_degree_turn_along_its_path_not_its_chord`).
    let mut machine = crate::util::machine("ac-trunnion");
    machine.tilt.limits = Some((-360.0, 360.0));
    let l = crate::compensate::errors_on(&machine, 3, 5.0, "");
    for z in [27.0, 60.0, 150.0] {
        let program = format!(
            "%\nO1000\nG90 G54 G0 X0. Y0. Z160. A-30. C0.\nG1 X0. Z{z:.1} A-30. F2122.\nA-359.\nM30\n%\n"
        );
        // The ends are checked in full: the tool lies along C only at A 0
        // and -180, which the turn passes mid-move.
        rewritten_in_pieces_within_a_micrometre(
            &l,
            &program,
            &[],
            &format!("A -30 to -359 at Z{z}"),
        );
    }
}

/// A FANUC program whose line 7 turns C by `turns` turns at X40 Z50, under
/// TCP (`G43.4`) or not, the tilt `tilt` at -30 deg.
fn c_turns_program(tcp: bool, tilt: char, turns: f64) -> String {
    let c = 360.0 * turns;
    let tcp = if tcp { "G43.4 H1" } else { "G43 H1" };
    format!(
        "%\nO1000\nG90 G21 G17 G94 G54\n{tcp}\nG0 X40. Y0. Z60. {tilt}-30. C0.\nG1 X40. Z50. F2122.\nC{c:.1}\nM30\n%\n"
    )
}

#[test]
fn compensate_splits_whole_turns_of_c_whose_middle_sample_showed_nothing() {
    // Two or four whole turns of C bring the tool back where it started at
    // the middle and the quarters of the move, where the rewrite looked for
    // the path's deviation: it found none, wrote one block, and the tip
    // left the path by 51 to 166 um against a tolerance of 1 um, under TCP
    // on three machines and without it on head-head (C in the head).
    for (name, tcp) in [
        ("head-head", false),
        ("head-head", true),
        ("bc-trunnion", true),
    ] {
        let mut machine = crate::util::machine(name);
        machine.c.limits = None;
        let l = crate::compensate::errors_on(&machine, 4, 60.0, "");
        for turns in [2.0, 4.0] {
            let program = c_turns_program(tcp, machine.tilt.letter, turns);
            let what = format!("{name} tcp={tcp} {turns} turns");
            rewritten_in_pieces_within_a_micrometre(&l, &program, &[], &what);
        }
    }
}

#[test]
fn simulate_samples_a_turn_round_a_still_tip_every_degree() {
    // Under TCP, C turns twice round a tip that stays where it is: sampled
    // by the tip's path there was one sample, at the end, and whatever the
    // errors did on the way was never seen.
    use fivecal::model::Model;
    let mut machine = crate::util::machine("bc-trunnion");
    machine.c.limits = None;
    let l = crate::compensate::errors_on(&machine, 4, 60.0, "");
    let nominal = Model::new(l.model.kin.clone(), vec![]);
    let program = c_turns_program(true, machine.tilt.letter, 2.0);
    let mut settings = fivecal::compensate::simulate::SimSettings::new(fivecal::Dialect::Fanuc);
    settings.coordinates = fivecal::compensate::Coordinates::Auto;
    for (model, theta) in [(&nominal, &[][..]), (&l.model, &l.theta[..])] {
        let samples =
            crate::compensate::simulate_with(model, theta, settings.clone(), &program, 0.1);
        let turn: Vec<_> = samples.iter().filter(|s| s.line == 7).collect();
        assert_eq!(turn.len(), 720, "{} samples", turn.len());
        let first = turn[0].nominal.tip;
        assert!(turn.iter().all(|s| (s.nominal.tip - first).norm() < 1e-9));
        // On the erroneous machine the samples show the tip moving.
        if !theta.is_empty() {
            let spread = turn
                .iter()
                .map(|s| (s.actual.tip - turn[0].actual.tip).norm())
                .fold(0.0, f64::max);
            assert!(spread > 0.01, "{spread}");
        }
    }
}

#[test]
fn compensate_ramps_c_through_the_singularity_a_move_passes_between_exact_ends() {
    // From a random program: B from -54.6 to 21.9 deg on head-table, C
    // turning 135 deg. Both ends are far from the tool-along-C singularity
    // at B = 0, which the move passes. There the exact correction of C
    // grows without bound, the pieces jumped between it and C held, and
    // the move was refused ("cannot be followed within --tolerance 1 um
    // even in 65536 pieces"). C's correction now ramps between the ends',
    // as where an end is held, and the tip follows the path.
    let mut machine = crate::util::machine("head-table");
    machine.c.limits = None;
    let l = crate::compensate::errors_on(&machine, 3, 40.0, "");
    let program = "%\nO1000\nG90 G21 G17 G94 G54\nG43 H1\nG0 X-1.579 Y7.928 Z48.645 B-54.557 C-132.599\nG1 X39.018 Y-18.484 Z59.703 B21.947 C-267.700 F1000.\nM30\n%\n";
    let s = rewritten_in_pieces_within_a_micrometre(&l, program, &[6], "B through 0 while C turns");
    assert_eq!(s.subdivided.first, [6]);
    assert_eq!(s.held_c.first, [6]);
}

#[test]
fn compensate_linearizes_an_arc_over_which_c_turns_sixteen_times() {
    // Whether an arc stays an arc was checked at its sixteenths: with C
    // turning 16 whole turns over the arc, the tool is back where it
    // started at each, the arc was kept, and the tip left the path by 46 to
    // 165 um against a tolerance of 1 um.
    for (name, tcp) in [("head-head", false), ("bc-trunnion", true)] {
        let mut machine = crate::util::machine(name);
        machine.c.limits = None;
        let l = crate::compensate::errors_on(&machine, 4, 60.0, "");
        let (t, tl) = (if tcp { "G43.4 H1" } else { "G43 H1" }, machine.tilt.letter);
        let program = format!(
            "%\nO1000\nG90 G21 G17 G94 G54\n{t}\nG0 X40. Y0. Z60. {tl}-30. C0.\nG1 X40. Z50. F2122.\nG3 X0. Y40. I-40. J0. C5760.\nM30\n%\n"
        );
        let settings = fivecal::compensate::Settings::new(fivecal::Dialect::Fanuc);
        let (out, s, _) = crate::compensate::compensate(&l, settings, &program);
        let what = format!("{name} tcp={tcp}");
        assert!(s.skipped.is_empty(), "{what}: {:?}", s.skipped);
        assert_eq!(s.linearized.first, [7], "{what}");
        crate::compensate::check_held(
            &l,
            fivecal::Dialect::Fanuc,
            fivecal::compensate::Coordinates::Auto,
            &program,
            &out,
            0.001,
            &s.held_c.first,
            &what,
        );
    }
}

/// `fivecal` with `args` in `dir`, succeeding; its standard output.
fn fivecal_ok(dir: &Path, args: &[&str]) -> String {
    let out = crate::cli::fivecal()
        .current_dir(dir)
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "fivecal {}: {}",
        args.join(" "),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).to_string()
}

/// Issue 41, the drifting sphere: `plan probe-sphere --machine
/// ac-trunnion`, simulated with the location errors of `simulate
/// --truth-example` plus a thermal drift of EZ0A of 1 um per pose. The
/// sphere method's per-pose spheres fit each pose as well as the probe
/// allows, and its robust circle fit set the drifted centres aside, so the
/// default analysis said `fit: fits (ratio 1.02)` with EZ0A 40 u and EA0A
/// 105 u from the truth, and `compensate --export` took it. The verdict,
/// on every touch against the complete model at the sphere method's
/// estimate, is a misfit (or every value is within 4 u), names what the
/// circle fit set aside, and the export is refused.
#[test]
fn drifting_sphere_is_judged_on_every_touch_not_on_the_centres_left() {
    let dir = crate::util::tempdir();
    let d = dir.path();
    fivecal_ok(
        d,
        &[
            "plan",
            "probe-sphere",
            "--machine",
            "ac-trunnion",
            "--out",
            "ps",
        ],
    );
    let example = fivecal_ok(
        d,
        &["simulate", "--truth-example", "--machine", "ac-trunnion"],
    );
    let full: serde_yaml::Value = serde_yaml::from_str(&example).unwrap();
    let mut truth = serde_yaml::Mapping::new();
    truth.insert("machine".into(), "ac-trunnion".into());
    truth.insert("location_errors".into(), full["location_errors"].clone());
    let truth = serde_yaml::to_string(&truth).unwrap()
        + "effects:\n  thermal_drift:\n    EZ0A: {per: seq, rate: 1.0}\n";
    std::fs::write(d.join("truth.yaml"), &truth).unwrap();
    fivecal_ok(
        d,
        &[
            "simulate",
            "--plan",
            "ps/probe-sphere.plan.yaml",
            "--errors",
            "truth.yaml",
            "-o",
            "touches.log",
        ],
    );
    let printed = fivecal_ok(
        d,
        &[
            "analyze",
            "--plan",
            "ps/probe-sphere.plan.yaml",
            "--measured",
            "touches.log",
            "--out",
            "result.yaml",
        ],
    );
    // The verdict comes first.
    assert!(printed.starts_with("verdict: "), "{printed}");
    let text = std::fs::read_to_string(d.join("result.yaml")).unwrap();
    let result: ErrorFile = serde_yaml::from_str(&text).unwrap();
    let fit = result.fit.as_ref().expect("a verdict");
    assert!(
        fit.on
            .as_deref()
            .is_some_and(|o| o.contains("every one of")),
        "{fit:?}"
    );
    let within_4u = result.location_errors.iter().all(|(name, q)| {
        let t = full["location_errors"][name.as_str()]
            .as_f64()
            .unwrap_or(0.0);
        q.u.is_some_and(|u| (q.value - t).abs() < 4.0 * u)
    });
    assert!(
        fit.verdict == fivecal::errorfile::FitVerdict::Misfit || within_4u,
        "the sphere result fits and is off:\n{text}"
    );
    if fit.verdict == fivecal::errorfile::FitVerdict::Misfit {
        assert!(printed.starts_with("verdict: misfit"), "{printed}");
        // What the robust circle fit set aside is named in the verdict.
        assert!(
            fit.set_aside.iter().any(|s| s.contains("centres at")),
            "{fit:?}"
        );
        let out = crate::cli::fivecal()
            .current_dir(d)
            .args([
                "compensate",
                "--machine",
                "ac-trunnion",
                "--errors",
                "result.yaml",
                "--export",
                "fanuc",
                "--no-record",
            ])
            .output()
            .unwrap();
        assert!(!out.status.success());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains("does not fit"), "{err}");
    }
}

/// The tool's own demo data did not converge: `plan probe-columns`,
/// `simulate --truth-example`, `analyze` said NOT CONVERGED on bc-trunnion
/// and head-head. Each column turned about the point between its top and
/// side touches moves no touch to first order; the exact model sees those
/// nine turns at 1e-7 of the other directions, above the rounding floor,
/// so they were counted as identifiable (condition number 2e7) and the
/// fit slid along them for 96 steps, past its limit of 50. Now the rank
/// stops at that gap: on all four built-in machines the fit of the full
/// truth example converges (its verdict is a misfit: the example has
/// maps, drift and scale the default model lacks), and the fit of the
/// example's location errors alone fits, every printed value within 3 u
/// of the truth.
#[test]
fn probe_columns_on_the_truth_example_converges_on_every_built_in_machine() {
    use fivecal::errorfile::FitVerdict;
    let dir = crate::util::tempdir();
    let d = dir.path();
    for machine in ["bc-trunnion", "ac-trunnion", "head-table", "head-head"] {
        let pc = format!("pc-{machine}");
        fivecal_ok(
            d,
            &["plan", "probe-columns", "--machine", machine, "--out", &pc],
        );
        let example = fivecal_ok(d, &["simulate", "--truth-example", "--machine", machine]);
        let full: serde_yaml::Value = serde_yaml::from_str(&example).unwrap();
        let mut located = serde_yaml::Mapping::new();
        located.insert("machine".into(), machine.into());
        located.insert("location_errors".into(), full["location_errors"].clone());
        std::fs::write(d.join("full.yaml"), &example).unwrap();
        std::fs::write(
            d.join("located.yaml"),
            serde_yaml::to_string(&located).unwrap(),
        )
        .unwrap();
        let plan = format!("{pc}/probe-columns.plan.yaml");
        for truth in ["full", "located"] {
            let log = format!("{truth}-{machine}.log");
            let result = format!("{truth}-{machine}.yaml");
            let truth_file = format!("{truth}.yaml");
            fivecal_ok(
                d,
                &[
                    "simulate",
                    "--plan",
                    &plan,
                    "--errors",
                    &truth_file,
                    "-o",
                    &log,
                ],
            );
            let printed = fivecal_ok(
                d,
                &[
                    "analyze",
                    "--plan",
                    &plan,
                    "--measured",
                    &log,
                    "--out",
                    &result,
                ],
            );
            let what = format!("{machine}, {truth} truth:\n{printed}");
            assert!(!printed.contains("NOT CONVERGED"), "{what}");
            assert!(!printed.contains("without converging"), "{what}");
            let text = std::fs::read_to_string(d.join(&result)).unwrap();
            let r: ErrorFile = serde_yaml::from_str(&text).unwrap();
            let fit = r.fit.as_ref().expect("a verdict");
            if truth == "full" {
                assert_eq!(fit.verdict, FitVerdict::Misfit, "{what}");
                continue;
            }
            assert_eq!(fit.verdict, FitVerdict::Fits, "{what}");
            // Three location errors at least on every machine (head-head
            // sees six of its ten).
            let reported: Vec<_> = r
                .location_errors
                .iter()
                .filter(|(_, q)| q.u.is_some())
                .collect();
            assert!(reported.len() >= 3, "{what}");
            for (name, q) in reported {
                let t = full["location_errors"][name.as_str()].as_f64().unwrap();
                let u = q.u.unwrap();
                assert!(
                    (q.value - t).abs() < 3.0 * u,
                    "{name} = {} u {u} against {t}: {what}",
                    q.value
                );
            }
        }
    }
}

/// Issue 41, a fit that stopped is called a fit: on head-table, a
/// probe-columns analysis printed "the fit stopped after 50 steps without
/// converging", then `fit: fits`, the result file kept no trace of it, and
/// `compensate --export fanuc` took its values. Here the global fit is
/// stopped after one step (the case itself stopped after fifty): the
/// verdict is not-converged whatever the residuals, the result file says
/// so, and the export refuses it, naming why.
#[test]
fn fit_stopped_before_converging_is_recorded_and_refused_by_the_export() {
    use fivecal::analyze::goodness::ExpectedNoise;
    use fivecal::errorfile::FitVerdict;
    use fivecal::identify::{Setup, global, lsq};
    let plan = crate::simulate::planned("head-table", "probe-columns");
    let truth = crate::simulate::truth(
        &plan,
        HEAD_TABLE_ERRORS.trim_start_matches("machine: head-table\n"),
    );
    let out = fivecal::simulate::run(&plan, &truth, &Default::default()).unwrap();
    let data =
        fivecal::analyze::uncertainty::simulated::plan_dataset(&plan, "touches.log", out.points)
            .unwrap();
    let kin = fivecal::simulate::plan_kinematics(&plan);
    let setup = Setup::new(&kin, &data.poses, &[]).unwrap();
    let fm = fivecal::simulate::forward::for_plan(&setup.model, &plan).unwrap();
    let stopped = lsq::Options {
        max_iter: 1,
        ..Default::default()
    };
    let est = global::identify(fm.as_ref(), &setup, &data, &stopped).unwrap();
    assert!(!est.converged, "{}", est.summary());
    let expected = ExpectedNoise::new(None, data.kind, plan.test());
    let fit =
        fivecal::analyze::verdict::of(&est, &setup, &data, plan.test(), Some(&plan), &expected)
            .unwrap()
            .unwrap();
    assert_eq!(fit.verdict, FitVerdict::NotConverged, "{fit:?}");
    assert!(
        fivecal::analyze::verdict::render(Some(&fit)).starts_with("verdict: NOT CONVERGED"),
        "{fit:?}"
    );
    let mut file = fivecal::analyze::result::error_file(&est, &est.u(), data.kind);
    file.fit = Some(fit);
    let text = file.to_yaml();
    assert!(text.contains("verdict: not-converged"), "{text}");
    let dir = crate::util::tempdir();
    std::fs::write(dir.path().join("result.yaml"), &text).unwrap();
    let loaded = ErrorFile::load(&dir.path().join("result.yaml"), &kin).unwrap();
    assert!(loaded.not_converged().is_some());
    let out = crate::cli::fivecal()
        .current_dir(dir.path())
        .args([
            "compensate",
            "--machine",
            "head-table",
            "--errors",
            "result.yaml",
            "--export",
            "fanuc",
            "--accept-misfit",
            "--no-record",
        ])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("result.yaml: the fit of this result did not converge"),
        "{err}"
    );
    assert!(
        out.stdout.is_empty(),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
}

/// The nine-section heights respond to the location errors (issue 41: EY0A
/// moves sections 2-9 by 0.26-0.50 um per um), so the preview's rank is
/// that of their real sensitivity, 5 of 8 on ac-trunnion, not 0. Checked
/// against an independent finite difference: the heights simulated with
/// 2 um of EY0A alone, less those without errors, halved (to 0.01 um per
/// um: the deepest pass of the raster makes the heights only piecewise
/// linear).
#[test]
fn nine_section_preview_reports_the_rank_of_the_heights_real_sensitivity() {
    let plan = crate::simulate::planned("ac-trunnion", "nine-section");
    let p = fivecal::analyze::preview::predict(&plan, None, None).unwrap();
    assert_eq!(p.rank, (5, 8), "{}", p.render());
    assert!(p.rows.iter().all(|r| r.u.is_none()), "{}", p.render());
    let ey = p.rows.iter().find(|r| r.symbol == "EY0A").unwrap();
    assert!(
        ey.reason
            .as_deref()
            .unwrap()
            .contains("0.26-0.50 um per um"),
        "{:?}",
        ey.reason
    );
    let (names, j) = fivecal::analyze::preview::nine_section_sensitivity(&plan).unwrap();
    let col = names.iter().position(|n| n == "EY0A").unwrap();
    let heights = |src: &str| -> Vec<f64> {
        let k = fivecal::simulate::plan_kinematics(&plan);
        let l = ErrorFile::parse(Path::new("t"), src)
            .unwrap()
            .to_model(&k, Path::new("t"), src)
            .unwrap();
        let out =
            fivecal::simulate::run(&plan, &l, &fivecal::simulate::SimOptions::exact()).unwrap();
        out.heights
            .unwrap()
            .iter()
            .filter(|h| h.section > 1)
            .map(|h| h.height_um)
            .collect()
    };
    let zero = heights("machine: ac-trunnion\n");
    let two = heights("machine: ac-trunnion\nlocation_errors: {EY0A: 2.0}\n");
    assert_eq!(j.nrows(), 8);
    for (r, (a, b)) in two.iter().zip(&zero).enumerate() {
        assert!(
            ((a - b) / 2.0 - j[(r, col)]).abs() < 0.01,
            "section {}: {} against {}",
            r + 2,
            (a - b) / 2.0,
            j[(r, col)]
        );
    }
    assert!(p.render().contains("design rank 5 of 8"), "{}", p.render());
}

/// Issue 41: `plan stepped-square --machine head-table` counted EY0C at
/// u = 47.6 um and EB0B at 203 urad as identified ("identifies 7 of 10").
/// A value that loose is seen, but not usefully: not counted, and said so
/// with its u and the threshold; a looser threshold the user sets counts
/// it again.
#[test]
fn a_location_error_seen_at_u_of_tens_of_micrometres_is_not_counted_as_identified() {
    use fivecal::analyze::usefulness::Usefulness;
    let plan = crate::simulate::planned("head-table", "stepped-square");
    let p = fivecal::analyze::preview::predict(&plan, None, None).unwrap();
    let row = |s: &str| p.rows.iter().find(|r| r.symbol == s).unwrap().clone();
    for s in ["EY0C", "EX0B", "EB0B"] {
        let r = row(s);
        assert!(r.u.is_none(), "{s}: {r:?}");
        let why = r.reason.unwrap();
        assert!(
            why.starts_with("seen, but not usefully: u = "),
            "{s}: {why}"
        );
        assert!(why.contains("--useful-u"), "{s}: {why}");
    }
    assert!(
        p.render().starts_with("identifies 4 of 10"),
        "{}",
        p.render()
    );
    assert!(p.missing().contains(&"EY0C"));
    let loose = Usefulness { um: 1e4, urad: 1e5 };
    let q = fivecal::analyze::preview::predict_useful(&plan, None, None, &loose).unwrap();
    assert!(
        q.rows
            .iter()
            .find(|r| r.symbol == "EY0C")
            .unwrap()
            .u
            .is_some()
    );
    assert!(
        q.render().starts_with("identifies 7 of 10"),
        "{}",
        q.render()
    );
}

/// Issue 41: a result's values with u above the threshold are moved out of
/// `location_errors:` (what compensate and the exports act on) into
/// `seen_not_usefully:`, with value, u and threshold.
#[test]
fn analyze_keeps_a_value_seen_but_not_usefully_out_of_what_compensate_reads() {
    let dir = crate::util::tempdir();
    let manifest = crate::analyze_sim::plan_with_cli(
        &dir.path().join("plan"),
        "stepped-square",
        "bc-trunnion",
        None,
    );
    let truth = dir.path().join("truth.yaml");
    std::fs::write(
        &truth,
        format!("machine: bc-trunnion\n{}", crate::analyze_sim::BC_ERRORS),
    )
    .unwrap();
    let measured = dir.path().join("piece.dmo");
    crate::analyze_sim::simulate_with_cli(&manifest, &truth, &measured, 5);
    let out = dir.path().join("r.yaml");
    let a = crate::analyze_sim::analyze_with_cli(
        &manifest,
        &measured,
        &out,
        &["--useful-u", "1.5,1000"],
    )
    .success();
    let text = String::from_utf8(a.get_output().stdout.clone()).unwrap();
    assert!(text.contains("seen, but not usefully"), "{text}");
    let (file, _) = fivecal::errorfile::ErrorFile::read(&out).unwrap();
    // EZ0B's u on this design is about 1.6 um (scale and straightness of
    // the linear axes), EX0B's about 1.4 um.
    let moved: Vec<&str> = file
        .seen_not_usefully
        .iter()
        .map(|n| n.symbol.as_str())
        .collect();
    assert!(moved.contains(&"EZ0B"), "{moved:?}");
    for n in &file.seen_not_usefully {
        assert!(n.u > n.threshold && n.threshold == 1.5, "{n:?}");
        assert!(!file.location_errors.contains_key(&n.symbol));
    }
    assert!(file.location_errors.contains_key("EX0B"));
}
