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
