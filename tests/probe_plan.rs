//! Probing plans: the column and sphere patterns on every example machine,
//! each touch along its normal, every move checked against the setup by a
//! brute-force distance computation independent of the planner's GJK
//! checker, labels and points.csv, run time, and the YAML templates.

use std::path::Path;

use fivecal::formats::points::PlanPoints;
use fivecal::kinematics::Kinematics;
use fivecal::procedure::probing::columns::ColumnsTemplate;
use fivecal::procedure::probing::sphere::SphereTemplate;
use fivecal::procedure::probing::{
    Checker, ConvexSolid, PoseFrame, ProbingMoveKind, TouchPlan, columns, sphere,
};
use fivecal::procedure::{PlanError, TemplateSource};
use fivecal::{Axes, Machine};
use nalgebra::Vector3;
use rand::RngExt;

use crate::util::{MACHINES, machine, rng};

fn columns_plan(name: &str) -> TouchPlan {
    columns::touch_plan(&machine(name), &ColumnsTemplate::builtin())
        .unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn sphere_plan(name: &str) -> TouchPlan {
    sphere::touch_plan(&machine(name), &SphereTemplate::builtin())
        .unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn seed003_template() -> SphereTemplate {
    let text = fivecal::procedure::probing::sphere::BUILTIN_TEMPLATE
        .replace("pattern: seed-004", "pattern: seed-003");
    SphereTemplate::parse(TemplateSource {
        path: "seed003.yaml".into(),
        text,
    })
    .unwrap()
}

#[test]
fn pose_frames_put_the_ball_where_the_plan_wants_it_on_every_machine() {
    for (mi, name) in MACHINES.iter().enumerate() {
        let m = machine(name);
        let kin = Kinematics::with_gauge_length(&m, m.probe.length);
        let mut r = rng(700 + mi as u64);
        for _ in 0..200 {
            let (lo, hi) = m.tilt.limits.unwrap();
            let t = r.random_range(lo..hi);
            let c = r.random_range(-180.0..180.0);
            let frame = PoseFrame::new(&kin, t, c);
            let b = Vector3::new(
                r.random_range(-200.0..200.0),
                r.random_range(-200.0..200.0),
                r.random_range(-100.0..300.0),
            );
            let axes = frame.commanded(&b);
            let pose = kin.forward_nominal(&axes);
            assert!((pose.tip - b).norm() < 1e-9, "{name} t {t} c {c}");
            assert!((frame.ball_w(&axes.xyz) - b).norm() < 1e-9);
            assert!((frame.probe_axis_w() - pose.axis).norm() < 1e-12);
            // Program coordinates are W turned by rTw*, nothing else.
            let q = kin.nominal_table_transform(t, c) * nalgebra::Point3::from(b);
            assert!((frame.to_prog(&b) - q.coords).norm() < 1e-9);
        }
    }
}

#[test]
fn column_plan_on_the_seeds_machine_probes_15_reference_points_and_revisits_them() {
    let plan = columns_plan("ac-trunnion");
    assert_eq!(
        plan.poses.len(),
        24,
        "A 0, -30, -60, -90 x C 0, 60, ..., 300"
    );
    let reference = &plan.poses[0];
    assert_eq!(
        (reference.id.as_str(), reference.tilt, reference.c),
        ("A0C0", 0.0, 0.0)
    );
    assert_eq!(
        reference.touches.len(),
        15,
        "3 columns x 5 points, as in Ibaraki, Iritani & Matsushita 2013"
    );
    let refs = &plan.touches[reference.touches.clone()];
    for pose in &plan.poses {
        let n = pose.touches.len();
        assert!((1..=15).contains(&n), "{}: {n} touches", pose.id);
        if pose.tilt != 0.0 {
            assert!(n < 15, "{}: a tilted table turns faces away", pose.id);
        }
        for t in &plan.touches[pose.touches.clone()] {
            let r = refs
                .iter()
                .find(|r| r.feature == t.feature)
                .unwrap_or_else(|| panic!("{} is not a reference point", t.label));
            assert_eq!(
                (r.contact_w, r.normal_w),
                (t.contact_w, t.normal_w),
                "{}",
                t.label
            );
            assert_eq!(t.label, format!("{}_{}", pose.id, t.feature));
        }
    }
    for s in &plan.skipped {
        assert!(
            s.reason.contains("comes closer than") || s.reason.contains("stroke"),
            "{s:?}"
        );
    }
    // Up to 30 deg from level every pose fixes the table's six pose
    // components on its own; at -90 the columns hide each other and the
    // plan says which poses only add to a joint identification.
    for w in &plan.warnings {
        assert!(w.starts_with("pose A-90"), "{w}");
    }
    for pose in &plan.poses {
        if plan
            .warnings
            .iter()
            .any(|w| w.starts_with(&format!("pose {}:", pose.id)))
        {
            continue;
        }
        // An independent look: six touches or more, normals along all
        // three axes of W.
        let ts = &plan.touches[pose.touches.clone()];
        assert!(ts.len() >= 6, "{}", pose.id);
        for axis in 0..3 {
            assert!(
                ts.iter().any(|t| t.normal_w[axis].abs() > 0.5),
                "{} axis {axis}",
                pose.id
            );
        }
    }
}

#[test]
fn every_touch_approaches_along_its_normal_and_never_from_below() {
    let mut plans = Vec::new();
    for name in MACHINES {
        plans.push((name, columns_plan(name)));
        plans.push((name, sphere_plan(name)));
    }
    for (name, plan) in &plans {
        let r = plan.probe.ball_radius;
        let s = &plan.settings;
        for t in &plan.touches {
            let n = t.normal_w;
            assert!((t.start.ball_w - (t.contact_w + n * (r + s.clearance))).norm() < 1e-9);
            assert!((t.contact.ball_w - (t.contact_w + n * r)).norm() < 1e-9);
            assert!((t.end.ball_w - (t.contact_w + n * (r - s.overtravel))).norm() < 1e-9);
            // The probing move in program coordinates runs along -n'.
            let d = (t.end.axes.xyz - t.start.axes.xyz).normalize();
            assert!((d + t.normal_prog).norm() < 1e-9, "{name} {}", t.label);
            // A vertical probe never touches a face that looks down (the
            // stylus would be inside the piece); a tilted head may lean
            // over an equator touch, and the collision check rules there.
            if machine(name).structure == fivecal::machine::Structure::TableTable {
                assert!(
                    t.normal_prog.z > -1e-9,
                    "{name} {}: normal {:?}",
                    t.label,
                    t.normal_prog
                );
            }
        }
        // The path has exactly one probing move per touch, in index order.
        let probes: Vec<usize> = plan
            .moves
            .iter()
            .filter_map(|m| match m.kind {
                ProbingMoveKind::Probe(i) => Some(i),
                _ => None,
            })
            .collect();
        assert_eq!(
            probes,
            (0..plan.touches.len()).collect::<Vec<_>>(),
            "{name}"
        );
        for (i, t) in plan.touches.iter().enumerate() {
            assert_eq!(t.index, i + 1);
        }
    }
}

// ------------------------------------------------- independent clearance check

/// Exact distance from a point to a solid (0 inside), written here apart
/// from the planner's support-function code.
fn distance(p: &Vector3<f64>, s: &ConvexSolid) -> f64 {
    match s {
        ConvexSolid::Cuboid { centre, axes, half } => {
            let local = axes.transpose() * (p - centre);
            let out = Vector3::new(
                (local.x.abs() - half.x).max(0.0),
                (local.y.abs() - half.y).max(0.0),
                (local.z.abs() - half.z).max(0.0),
            );
            out.norm()
        }
        ConvexSolid::Ball { centre, radius } => ((p - centre).norm() - radius).max(0.0),
        ConvexSolid::Cylinder { a, b, radius } => {
            let len = (b - a).norm();
            let ax = (b - a) / len;
            let along = (p - a).dot(&ax);
            let radial = (p - a - ax * along).norm();
            let dr = (radial - radius).max(0.0);
            let dz = (-along).max(along - len).max(0.0);
            dr.hypot(dz)
        }
    }
}

/// The smallest gap between a probe part (the segment `s0..s1` along the
/// axis from the ball centre, grown by `radius`) and a solid, sampled every
/// `h` mm at most; stretches where a sample shows the gap cannot fall
/// below `floor` (gaps change by at most 1 mm per mm along the part) are
/// returned as that bound instead of being sampled further.
#[allow(clippy::too_many_arguments)]
fn part_gap(
    tip: &Vector3<f64>,
    axis: &Vector3<f64>,
    s0: f64,
    s1: f64,
    radius: f64,
    solid: &ConvexSolid,
    h: f64,
    floor: f64,
) -> f64 {
    let mid = 0.5 * (s0 + s1);
    let g = distance(&(tip + axis * mid), solid) - radius;
    let half = 0.5 * (s1 - s0);
    if g - half >= floor {
        return g - half;
    }
    if s1 - s0 <= h {
        return g;
    }
    part_gap(tip, axis, s0, mid, radius, solid, h, floor)
        .min(part_gap(tip, axis, mid, s1, radius, solid, h, floor))
}

/// Samples every move in the axis values (as the machine moves) every
/// 1 mm of probe travel (0.1 mm on probing moves) and each probe part
/// every 0.5 mm, and returns the smallest gap between probe surface and
/// setup: (probing moves and retracts, all other moves).
fn sampled_gaps(plan: &TouchPlan) -> (f64, f64) {
    let p = &plan.probe;
    let (mut probe_gap, mut other_gap) = (f64::INFINITY, f64::INFINITY);
    for mv in &plan.moves {
        let (from, to) = match mv.kind {
            ProbingMoveKind::Probe(t) => (mv.from.axes, plan.touches[t].contact.axes),
            _ => (mv.from.axes, mv.to.axes),
        };
        let lerp = |s: f64| Axes {
            xyz: from.xyz + (to.xyz - from.xyz) * s,
            tilt: from.tilt + (to.tilt - from.tilt) * s,
            c: from.c + (to.c - from.c) * s,
        };
        let probe_move = matches!(
            mv.kind,
            ProbingMoveKind::Probe(_) | ProbingMoveKind::Retract(_)
        );
        let step = if probe_move { 0.1 } else { 1.0 };
        // Travel of the farthest probe point, from a coarse pass.
        let mut travel = 0.0_f64;
        let mut prev: Option<(Vector3<f64>, Vector3<f64>)> = None;
        for k in 0..=64 {
            let pose = plan.kin.forward_nominal(&lerp(k as f64 / 64.0));
            let end = pose.tip + pose.axis * (p.stylus_length + p.body_length + p.spindle_length);
            if let Some((a, b)) = prev {
                travel = travel.max((pose.tip - a).norm()).max((end - b).norm());
            }
            prev = Some((pose.tip, end));
        }
        let n = ((travel * 64.0 / step).ceil() as usize).max(1);
        let floor = if probe_move { 0.5 } else { 2.5 };
        for k in 0..=n {
            let pose = plan.kin.forward_nominal(&lerp(k as f64 / n as f64));
            for o in &plan.obstacles {
                let ball = distance(&pose.tip, &o.solid) - p.ball_radius;
                let stylus = part_gap(
                    &pose.tip,
                    &pose.axis,
                    0.0,
                    p.stylus_length,
                    p.stylus_radius,
                    &o.solid,
                    0.5,
                    floor,
                );
                let body = part_gap(
                    &pose.tip,
                    &pose.axis,
                    p.stylus_length,
                    p.stylus_length + p.body_length,
                    p.body_radius,
                    &o.solid,
                    0.5,
                    floor,
                );
                let g = p.stylus_length + p.body_length;
                let spindle = part_gap(
                    &pose.tip,
                    &pose.axis,
                    g,
                    g + p.spindle_length,
                    p.spindle_radius,
                    &o.solid,
                    0.5,
                    floor,
                );
                let gap = ball.min(stylus).min(body).min(spindle);
                if probe_move {
                    probe_gap = probe_gap.min(gap);
                } else {
                    other_gap = other_gap.min(gap);
                }
            }
        }
    }
    (probe_gap, other_gap)
}

/// No move passes through a column, the sphere, its stem or the table:
/// every default plan, sampled move by move, keeps its margin (2 mm; the
/// sampling, 1 mm along the move and 0.5 mm along the probe, can
/// overestimate a gap by at most 0.75 mm, so a sampled gap of 1.9 mm proves
/// a true gap of at least 1.15 mm), and probing moves only touch.
#[test]
fn every_move_of_every_default_plan_clears_the_setup_by_an_independent_check() {
    let mut plans: Vec<(String, TouchPlan)> = Vec::new();
    for name in MACHINES {
        plans.push((format!("{name} columns"), columns_plan(name)));
        plans.push((format!("{name} sphere"), sphere_plan(name)));
    }
    let ac = machine("ac-trunnion");
    plans.push((
        "ac-trunnion LAMDAMAP 2015".into(),
        sphere::touch_plan(&ac, &seed003_template()).unwrap(),
    ));
    for (what, plan) in &plans {
        assert!(plan.check().is_empty(), "{what}: {:?}", plan.check());
        assert!(
            plan.check_limits().is_empty(),
            "{what}: {:?}",
            plan.check_limits()
        );
        let (probe_gap, other_gap) = sampled_gaps(plan);
        assert!(
            other_gap >= 1.9,
            "{what}: a positioning move comes within {other_gap:.3} mm"
        );
        // Probing moves end with the ball on the surface (gap 0) and may
        // pass a stylus 1 mm from it (sampled to within 0.3 mm).
        assert!(
            probe_gap > -1e-6,
            "{what}: a probing move intrudes {probe_gap:.3} mm"
        );
        assert!(
            probe_gap < 1e-6,
            "{what}: probing moves should end on the surface ({probe_gap})"
        );
    }
}

#[test]
fn the_checker_catches_moves_through_the_setup_and_passes_them_over_it() {
    let plan = columns_plan("ac-trunnion");
    let checker = Checker::new(&plan.kin, &plan.obstacles, &plan.probe);
    let z_side = 100.0 - 15.0; // side-point height: table at -50, columns 150 tall
    let through = |z: f64, tilt: f64, c: f64| {
        (
            Axes::new(-150.0, -45.0, z, tilt, c),
            Axes::new(150.0, -45.0, z, tilt, c),
        )
    };
    let (a, b) = through(z_side, 0.0, 0.0);
    let e = checker.check_move(&a, &b, 2.0).unwrap_err();
    assert_eq!(e.obstacle, "C1");
    assert!(
        (e.at.xyz.x - (-60.0 - 25.0 - 3.0 - 2.0)).abs() < 0.01,
        "first contact at {:?}",
        e.at
    );
    let (a, b) = through(plan.poses[0].clear_z, 0.0, 0.0);
    checker.check_move(&a, &b, 2.0).unwrap();
    // Turning the table with the probe low hits a column; at the safe
    // height it does not.
    let low = Axes::new(0.0, -45.0, z_side + 30.0, 0.0, 0.0);
    let e = checker
        .check_move(&low, &Axes { tilt: -90.0, ..low }, 2.0)
        .unwrap_err();
    assert!(e.obstacle.starts_with('C'), "{e}");
    let high = Axes::new(0.0, -45.0, plan.safe_z, 0.0, 0.0);
    checker
        .check_move(
            &high,
            &Axes {
                tilt: -90.0,
                c: 300.0,
                ..high
            },
            2.0,
        )
        .unwrap();
}

#[test]
fn at_the_safe_height_any_rotary_position_clears_the_setup() {
    for (mi, name) in MACHINES.iter().enumerate() {
        let m = machine(name);
        let mut r = rng(800 + mi as u64);
        for plan in [columns_plan(name), sphere_plan(name)] {
            let checker = Checker::new(&plan.kin, &plan.obstacles, &plan.probe);
            for _ in 0..300 {
                let (lo, hi) = m.tilt.limits.unwrap();
                let a = Axes::new(
                    r.random_range(-300.0..300.0),
                    r.random_range(-300.0..300.0),
                    plan.safe_z,
                    r.random_range(lo..hi),
                    r.random_range(0.0..360.0),
                );
                checker
                    .check_at(&a, plan.settings.safe_margin)
                    .unwrap_or_else(|e| panic!("{name}: {e}"));
            }
        }
    }
}

#[test]
fn labels_are_stable_and_points_csv_round_trips() {
    let plan = columns_plan("ac-trunnion");
    let points = plan.points();
    let csv = points.to_csv(&["probe-columns on ac-trunnion"]);
    let back = PlanPoints::parse(Path::new("p.csv"), &csv).unwrap();
    assert_eq!(back.tilt_letter, 'A');
    assert_eq!(back.points.len(), plan.touches.len());
    for (i, (p, t)) in back.points.iter().zip(&plan.touches).enumerate() {
        assert_eq!(p.label, t.label, "row {} is index {}", i + 1, t.index);
        assert_eq!(p.seq, plan.poses[t.pose].seq);
        assert!((p.p - t.contact_w).norm() < 1e-6 && (p.n - t.normal_w).norm() < 1e-8);
    }
    // Without column C3 the other columns' labels stay what they were.
    let t = ColumnsTemplate::builtin();
    let text = t.source.text.replace(
        "  - {name: C3, centre: [0, 65], size: [50, 50], height: 150}\n",
        "",
    );
    let two = ColumnsTemplate::parse(TemplateSource {
        path: "two.yaml".into(),
        text,
    })
    .unwrap();
    let small = columns::touch_plan(&machine("ac-trunnion"), &two).unwrap();
    // Labels name what is probed where, not the order: a touch in both
    // plans has the same label, point and pose in both (its index differs).
    let full: std::collections::HashMap<&str, _> =
        plan.touches.iter().map(|t| (t.label.as_str(), t)).collect();
    assert!(small.touches.len() < plan.touches.len());
    let mut shared = 0;
    for t in &small.touches {
        assert_ne!(t.piece, "C3");
        assert_eq!(t.label, format!("{}_{}", small.poses[t.pose].id, t.feature));
        if let Some(f) = full.get(t.label.as_str()) {
            shared += 1;
            assert_eq!((f.contact_w, f.normal_w), (t.contact_w, t.normal_w));
            let (pf, ps) = (&plan.poses[f.pose], &small.poses[t.pose]);
            assert_eq!((pf.tilt, pf.c), (ps.tilt, ps.c));
        }
    }
    assert!(
        shared * 10 > small.touches.len() * 9,
        "{shared} of {}",
        small.touches.len()
    );
    let reference: Vec<&str> = small.touches[small.poses[0].touches.clone()]
        .iter()
        .map(|t| t.label.as_str())
        .collect();
    assert_eq!(
        reference,
        [
            "A0C0_C1_t1",
            "A0C0_C1_xp",
            "A0C0_C1_yp",
            "A0C0_C1_xn",
            "A0C0_C1_yn",
            "A0C0_C2_t1",
            "A0C0_C2_xp",
            "A0C0_C2_yp",
            "A0C0_C2_xn",
            "A0C0_C2_yn"
        ]
    );
}

#[test]
fn sphere_plan_follows_seed004_with_axis_parallel_touches_on_the_sphere() {
    let m = machine("ac-trunnion");
    let t = SphereTemplate::builtin();
    let plan = sphere_plan("ac-trunnion");
    assert_eq!(plan.poses.len(), 36 + 13);
    let ids: Vec<&str> = plan.poses.iter().map(|p| p.id.as_str()).collect();
    assert_eq!(&ids[..3], ["A0C0", "A0C10", "A0C20"]);
    assert_eq!(ids[35], "A0C350");
    assert_eq!(&ids[36..39], ["A-90C0", "A-80C0", "A-70C0"]);
    assert_eq!(
        ids[45], "A0C0.2",
        "the reference pose again, as in Cubas Brizuela & Yeh's (2023) 49 positions"
    );
    assert_eq!(ids[48], "A30C0");
    let centre = sphere::sphere_centre(&m, &t);
    let axis_dirs = [
        Vector3::x(),
        -Vector3::x(),
        Vector3::y(),
        -Vector3::y(),
        Vector3::z(),
    ];
    let check = t.sphere_check(plan.probe.ball_radius);
    for (i, pose) in plan.poses.iter().enumerate() {
        let touches = &plan.touches[pose.touches.clone()];
        assert!(touches.len() >= 4, "{}", pose.id);
        for tc in touches {
            assert!((tc.contact_w - centre).norm() - t.diameter / 2.0 < 1e-9);
            assert!(
                axis_dirs
                    .iter()
                    .any(|d| (d - tc.normal_prog).norm() < 1e-12),
                "{}: normal {:?} is not along an axis of the program",
                tc.label,
                tc.normal_prog
            );
        }
        // The nominal ball centres of a pose fit the ball-centre sphere
        // exactly: what the controller's sphere check would accept.
        let balls: Vec<Vector3<f64>> = touches.iter().map(|t| t.contact.ball_prog).collect();
        let fit = check.check(&pose.id, &balls).unwrap();
        let frame = plan.frame(i);
        assert!((fit.sphere.centre - frame.to_prog(&centre)).norm() < 1e-9);
    }
    assert!(plan.warnings.is_empty(), "{:?}", plan.warnings);
    // Where a touch is left out, it is the one from the stem's side.
    for s in &plan.skipped {
        assert!(s.reason.contains("stem"), "{s:?}");
    }
}

#[test]
fn sphere_plan_seed003_spreads_50_poses_over_the_tilt_and_nine_turns_of_c() {
    let plan = sphere::touch_plan(&machine("ac-trunnion"), &seed003_template()).unwrap();
    assert_eq!(plan.poses.len(), 50);
    for (k, p) in plan.poses.iter().enumerate() {
        assert_eq!(p.id, format!("S{k:02}"));
        let s = k as f64 / 49.0;
        assert!((p.tilt - (-90.0 + 120.0 * s)).abs() < 1e-5);
        let c = (9.0 * 360.0 * s).rem_euclid(360.0);
        let dc = (p.c - c).rem_euclid(360.0);
        assert!(dc.min(360.0 - dc) < 1e-5, "{}: C {} vs {c}", p.id, p.c);
        assert!((0.0..360.0).contains(&p.c));
    }
}

#[test]
fn sphere_plan_grid_probes_every_tilt_at_every_c_tilt_by_tilt() {
    let text = fivecal::procedure::probing::sphere::BUILTIN_TEMPLATE
        .replace("pattern: seed-004", "pattern: grid");
    let t = SphereTemplate::parse(TemplateSource {
        path: "grid.yaml".into(),
        text: text.clone(),
    })
    .unwrap();
    // The built-in grid block: tilt [-90, -45, 0], C [0, 90, 180, 270].
    let plan = sphere::touch_plan(&machine("bc-trunnion"), &t).unwrap();
    let ids: Vec<&str> = plan.poses.iter().map(|p| p.id.as_str()).collect();
    let mut want = Vec::new();
    for a in ["-90", "-45", "0"] {
        for c in ["0", "90", "180", "270"] {
            want.push(format!("B{a}C{c}"));
        }
    }
    assert_eq!(ids, want);
    // The pattern needs its block.
    let l = text.lines().position(|l| l.contains("pattern:")).unwrap() + 1;
    let without: String = text
        .lines()
        .filter(|l| {
            !l.starts_with("grid:") && !l.starts_with("  tilt: [") && !l.starts_with("  c: [")
        })
        .map(|l| format!("{l}\n"))
        .collect();
    assert_eq!(
        template_error("sphere", &without),
        format!(
            "t.yaml:{l}:1: pattern: grid needs a `grid:` section with its `tilt` and `c` angles (deg)"
        )
    );
    // Every tilt with every C: 200 x 100 poses is over the plan's bound of
    // 10,000, refused by count before a single pose is made.
    let list = |n: usize, span: f64| {
        let v: Vec<String> = (0..n)
            .map(|k| format!("{}", -span * k as f64 / n as f64))
            .collect();
        v.join(", ")
    };
    let huge: String = text
        .lines()
        .map(|l| {
            if l.starts_with("  tilt: [") {
                format!("  tilt: [{}]\n", list(200, 90.0))
            } else if l.starts_with("  c: [") {
                format!("  c: [{}]\n", list(100, -350.0))
            } else {
                format!("{l}\n")
            }
        })
        .collect();
    let t = SphereTemplate::parse(TemplateSource {
        path: "huge.yaml".into(),
        text: huge,
    })
    .unwrap();
    let e = sphere::touch_plan(&machine("bc-trunnion"), &t)
        .unwrap_err()
        .to_string();
    assert!(e.contains("about 20000 poses, more than the 10000"), "{e}");
}

#[test]
fn plans_work_on_the_bc_trunnion_and_on_head_machines() {
    for name in ["bc-trunnion", "head-table", "head-head"] {
        let plan = columns_plan(name);
        assert_eq!(plan.poses[0].touches.len(), 15, "{name}");
        assert!(plan.touches.len() > 150, "{name}: {}", plan.touches.len());
        let letter = machine(name).tilt_letter();
        assert!(plan.poses.iter().all(|p| p.id.starts_with(letter)));
        let s = sphere_plan(name);
        assert_eq!(s.poses.len(), 49, "{name}");
    }
}

/// A plan of one touch: the run time is the sum of its moves' times, each
/// computed here from the machine's rapids and the template's feeds.
#[test]
fn run_time_of_a_one_touch_plan_is_the_sum_of_its_moves() {
    let text = ColumnsTemplate::builtin()
        .source
        .text
        .replace(
            "  - {name: C2, centre: [60, -45], size: [50, 50], height: 150}\n",
            "",
        )
        .replace(
            "  - {name: C3, centre: [0, 65], size: [50, 50], height: 150}\n",
            "",
        )
        .replace("sides: [+x, +y, -x, -y]", "sides: []")
        .replace("tilt: [0, -30, -60, -90]", "tilt: [0]")
        .replace("c: [0, 60, 120, 180, 240, 300]", "c: [0]");
    let t = ColumnsTemplate::parse(TemplateSource {
        path: "one.yaml".into(),
        text,
    })
    .unwrap();
    let m = machine("ac-trunnion");
    let plan = columns::touch_plan(&m, &t).unwrap();
    assert_eq!(plan.touches.len(), 1);
    let kinds: Vec<ProbingMoveKind> = plan.moves.iter().map(|m| m.kind).collect();
    assert_eq!(
        kinds,
        [
            ProbingMoveKind::Rapid,
            ProbingMoveKind::Position,
            ProbingMoveKind::Probe(0),
            ProbingMoveKind::Retract(0),
            ProbingMoveKind::Position,
            ProbingMoveKind::Rapid
        ]
    );
    let touch = &plan.touches[0];
    let (safe, clear, start) = (plan.safe_z, plan.poses[0].clear_z, touch.start.axes.xyz.z);
    let s = &t.probing;
    let rapid = m.rapid.linear / 60.0; // mm/s
    let position = s.positioning_feed / 60.0;
    let want = 2.0 * (safe - clear) / rapid
        + 2.0 * (clear - start) / position
        + s.clearance / (s.feed / 60.0)
        + s.touch_overhead
        + s.clearance / position;
    let got = plan.run_time();
    assert!(
        (got.total_min * 60.0 - want).abs() < 1e-9,
        "{} s vs {want} s",
        got.total_min * 60.0
    );
    assert_eq!(got.poses, [(0.0, got.total_min)]);
}

/// Ibaraki, Iritani & Matsushita 2013 probed 219 points in about 28 min (7.7 s a point). The default
/// column pattern on the papers' machine comes out at a similar count and
/// pace with the template's feeds (probing 100 mm/min over 5 mm,
/// positioning 2000 mm/min) and overheads (1 s a touch, 3 s a pose).
#[test]
fn default_column_plan_takes_about_as_long_as_seed000s_test() {
    let plan = columns_plan("ac-trunnion");
    let rt = plan.run_time();
    eprintln!(
        "probe-columns on ac-trunnion: {} touches in {:.1} min ({:.1} s a touch; rapids {:.0} s, positioning {:.0} s, probing {:.0} s, overheads {:.0} s)",
        rt.touches,
        rt.total_min,
        rt.per_touch_s(),
        rt.rapid_s,
        rt.positioning_s,
        rt.probing_s,
        rt.overhead_s
    );
    assert!((200..=260).contains(&rt.touches), "{} touches", rt.touches);
    assert!(
        (5.0..=10.0).contains(&rt.per_touch_s()),
        "{:.1} s a touch",
        rt.per_touch_s()
    );
    let sum = rt.rapid_s + rt.positioning_s + rt.probing_s + rt.overhead_s;
    assert!((sum / 60.0 - rt.total_min).abs() < 1e-9);
    // Poses follow each other without gaps.
    for w in rt.poses.windows(2) {
        assert!((w[0].1 - w[1].0).abs() < 1e-9 && w[1].0 < w[1].1);
    }
}

fn template_error(kind: &str, text: &str) -> String {
    let dir = crate::util::tempdir();
    let path = dir.path().join("t.yaml");
    std::fs::write(&path, text).unwrap();
    let src = TemplateSource::load(path.to_str().unwrap()).unwrap();
    let e = match kind {
        "columns" => ColumnsTemplate::parse(src).err().map(|e| e.to_string()),
        _ => SphereTemplate::parse(src).err().map(|e| e.to_string()),
    }
    .expect("the template is refused");
    e.replace(&format!("{}", path.display()), "t.yaml")
}

#[test]
fn bad_templates_are_rejected_with_file_line_and_key() {
    let cols = fivecal::procedure::probing::columns::BUILTIN_TEMPLATE;
    let sph = fivecal::procedure::probing::sphere::BUILTIN_TEMPLATE;
    let line_of = |text: &str, pat: &str| text.lines().position(|l| l.contains(pat)).unwrap() + 1;
    let l = line_of(cols, "name: C2");
    assert_eq!(
        template_error(
            "columns",
            &cols.replace(
                "size: [50, 50], height: 150}\n  - {name: C3",
                "size: [0, 50], height: 150}\n  - {name: C3"
            )
        ),
        format!(
            "t.yaml:{l}:35: columns[1].size must be between 0.001 and 2000 mm (1 um is the finest step a control resolves; a test piece and its setup fit in 2 m), got 0"
        )
    );
    let l = line_of(cols, "safe_margin");
    assert_eq!(
        template_error(
            "columns",
            &cols.replace("safe_margin: 2 ", "safe_margin: 6 ")
        ),
        format!(
            "t.yaml:{l}:3: probing.safe_margin must be at least 0 and smaller than the clearance (5 mm), got 6"
        )
    );
    let l = line_of(cols, "sides:");
    assert_eq!(
        template_error("columns", &cols.replace("[+x, +y, -x, -y]", "[+x, +z]")),
        format!("t.yaml:{l}:3: points.sides: unknown side `+z`: expected +x, -x, +y or -y")
    );
    let e = template_error("columns", &cols.replace("  side_depth:", "  side_dept:"));
    let l = line_of(cols, "side_depth:");
    assert!(
        e.starts_with(&format!("t.yaml:{l}:3: points: unknown field `side_dept`")),
        "{e}"
    );
    let l = line_of(cols, "{name: C3");
    assert_eq!(
        template_error(
            "columns",
            &cols.replace("centre: [0, 65]", "centre: [50, -30]")
        ),
        format!("t.yaml:{l}:16: columns[2] (C3): its footprint overlaps column C2")
    );
    let l = line_of(sph, "touches:");
    assert_eq!(
        template_error(
            "sphere",
            &sph.replace("[+x, -x, +y, -y, -z]", "[+x, -x, +y, -y]")
        ),
        format!(
            "t.yaml:{l}:1: touches: a sphere needs at least four touches, one of them -z (the equator alone lies in one plane)"
        )
    );
    let l = line_of(sph, "pattern:");
    assert_eq!(
        template_error(
            "sphere",
            &sph.replace("pattern: seed-004", "pattern: seed-005")
        ),
        format!("t.yaml:{l}:1: pattern: unknown `seed-005`: expected seed-004, seed-003 or grid")
    );
    let l = line_of(sph, "stem_diameter");
    assert_eq!(
        template_error(
            "sphere",
            &sph.replace("stem_diameter: 12 ", "stem_diameter: 40 ")
        ),
        format!(
            "t.yaml:{l}:3: sphere.stem_diameter (40) must be smaller than the sphere's diameter (30)"
        )
    );
    // What depends on the machine is checked when the plan is made, with
    // the same kind of message.
    let t = ColumnsTemplate::parse(TemplateSource {
        path: "c.yaml".into(),
        text: cols.replace("tilt: [0, -30, -60, -90]", "tilt: [0, 45]"),
    })
    .unwrap();
    let l = line_of(cols, "tilt: [0");
    match columns::touch_plan(&machine("ac-trunnion"), &t) {
        Err(PlanError::Template(e)) => assert_eq!(
            e.to_string(),
            format!(
                "c.yaml:{l}:3: poses.tilt: A = 45 deg is outside the limits of ac-trunnion [-120, 30]"
            )
        ),
        other => panic!("{other:?}"),
    }
    let t = ColumnsTemplate::parse(TemplateSource {
        path: "c.yaml".into(),
        text: cols.replace("centre: [60, -45]", "centre: [110, -45]"),
    })
    .unwrap();
    let l = line_of(cols, "{name: C2");
    match columns::touch_plan(&machine("bc-trunnion"), &t) {
        Err(PlanError::Template(e)) => assert_eq!(
            e.to_string(),
            format!(
                "c.yaml:{l}:16: column C2 reaches 152.1 mm from the C axis, beyond the table of bc-trunnion (radius 125 mm)"
            )
        ),
        other => panic!("{other:?}"),
    }
    assert!(
        TemplateSource::load("probe-sphere")
            .unwrap()
            .path
            .to_str()
            .unwrap()
            .contains("built-in")
    );
    assert_eq!(
        TemplateSource::load("no-such-template")
            .unwrap_err()
            .to_string(),
        "no-such-template: no such template file, and no built-in template of that name (built-in: stepped-square, nine-section, probe-columns, probe-sphere)"
    );
}

#[test]
fn a_machine_without_room_for_the_safe_height_is_refused() {
    // Shorten Z so that the probe cannot rise above the columns.
    let m = machine("ac-trunnion");
    let src = m.source.replace("Z: [-660, 0]", "Z: [-660, -400]");
    let short = Machine::from_yaml(Path::new("short.yaml"), &src).unwrap();
    match columns::touch_plan(&short, &ColumnsTemplate::builtin()) {
        Err(PlanError::Unreachable(msg)) => assert!(
            msg.contains("Z would be at") && msg.contains("outside its stroke [-660, -400]"),
            "{msg}"
        ),
        Err(e) => panic!("{e}"),
        Ok(p) => panic!("planned {} touches", p.touches.len()),
    }
}
