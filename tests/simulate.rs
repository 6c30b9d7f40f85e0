//! `simulate`: the virtual machine, as worked examples. Each test plans a
//! test with the planners, gives the machine known errors through a truth
//! file, runs the simulator and checks what comes out against a closed form
//! written here, against the forward model, or against the project's own
//! readers.

use std::collections::HashMap;
use std::path::Path;
use std::sync::{Arc, Mutex, OnceLock};

use fivecal::errorfile::{ErrorFile, LoadedErrors};
use fivecal::formats::manifest::TestKind;
use fivecal::procedure::{Plan, plan};
use fivecal::simulate::{self, Placement, SimOptions};
use fivecal::{Dialect, Kinematics};
use nalgebra::Vector3;

use crate::plan::config;
use crate::probe_programs::probing;
use crate::util::MACHINES;

pub const MACHINING: [&str; 2] = ["stepped-square", "nine-section"];
pub const PROBING: [&str; 2] = ["probe-columns", "probe-sphere"];

type Plans = Mutex<HashMap<(String, String), Arc<Plan>>>;

/// A plan of the built-in template, planned once per test binary.
pub fn planned(machine: &str, test: &str) -> Arc<Plan> {
    static PLANS: OnceLock<Plans> = OnceLock::new();
    let key = (machine.to_string(), test.to_string());
    if let Some(p) = PLANS
        .get_or_init(Default::default)
        .lock()
        .unwrap()
        .get(&key)
    {
        return p.clone();
    }
    let p = Arc::new(if MACHINING.contains(&test) {
        plan(&config(
            machine,
            test,
            Dialect::Fanuc,
            fivecal::formats::manifest::KinematicsMode::Post,
        ))
        .unwrap()
    } else {
        Plan::Probing(Box::new(probing(machine, test, Dialect::Fanuc)))
    });
    PLANS
        .get_or_init(Default::default)
        .lock()
        .unwrap()
        .insert(key, p.clone());
    p
}

/// A truth file's text loaded for a plan.
pub fn truth(plan: &Plan, yaml: &str) -> LoadedErrors {
    let kin: Kinematics = simulate::plan_kinematics(plan);
    let src = format!("machine: {}\n{yaml}", kin.machine().name);
    let path = Path::new("truth.yaml");
    ErrorFile::parse(path, &src)
        .and_then(|f| f.to_model(&kin, path, &src))
        .unwrap_or_else(|e| panic!("{e}"))
}

fn nominal_points(plan: &Plan) -> Vec<Vector3<f64>> {
    match plan {
        Plan::Machining(t) => t.points.iter().map(|p| p.point.p).collect(),
        Plan::Probing(p) => p.plan.touches.iter().map(|t| t.contact_prog).collect(),
    }
}

// ---------------------------------------------------------------- zero errors

/// With all errors zero and no noise, every simulated point is its nominal
/// point, for every template on every machine; with the piece placed at
/// random on the CMM, once the placement is removed.
#[test]
fn with_no_errors_every_point_is_its_nominal_point_on_every_machine() {
    for m in MACHINES {
        for test in MACHINING.iter().chain(&PROBING) {
            let plan = planned(m, test);
            let zero = truth(&plan, "");
            let mut opts = SimOptions::exact();
            if plan.kind() == TestKind::Machining {
                opts.placement = Placement::Random;
                opts.seed = 11;
            }
            let out = simulate::run(&plan, &zero, &opts).unwrap();
            let nominal = nominal_points(&plan);
            assert_eq!(out.points.len(), nominal.len());
            let back = out.placement.inverse();
            let mut worst: f64 = 0.0;
            for (m_pt, n) in out.points.iter().zip(&nominal) {
                let w = (back * nalgebra::Point3::from(m_pt.p)).coords;
                worst = worst.max((w - n).norm());
            }
            assert!(worst < 1e-9, "{m} {test}: {worst:e} mm from nominal");
            if plan.kind() == TestKind::Machining {
                assert!(
                    out.placement.translation.vector.norm() > 1.0,
                    "{m} {test}: the piece was not moved on the CMM"
                );
            }
        }
    }
}

// ---------------------------------------------------------------- Ibaraki & Ota 2014, eq. (5)-(6)

/// The twelve constant terms of a table-table machine's two links (the
/// tilt axis T relative to Y: `d_TY`, `w_TY`; C relative to T: `d_CT`,
/// `w_CT`), translations in mm and rotations in rad.
#[derive(Clone, Copy, Default)]
struct Terms {
    d_ty: Vector3<f64>,
    w_ty: Vector3<f64>,
    d_ct: Vector3<f64>,
    w_ct: Vector3<f64>,
}

/// Sets one of the terms to a value (mm or rad).
type SetTerm = fn(&mut Terms, f64);

/// Ibaraki & Ota 2014, eq. (6) for the B/C machine, and its mirror for the A/C
/// machine (the tilt about X instead of Y): the displacement (dX, dY, dZ)
/// and rotation (dA, dB, dC) of the machined surface at (tilt, C), to first
/// order in the errors.
fn eq6(ac: bool, t: &Terms, tilt_deg: f64, c_deg: f64) -> (Vector3<f64>, Vector3<f64>) {
    let (st, ct) = tilt_deg.to_radians().sin_cos();
    let (sc, cc) = c_deg.to_radians().sin_cos();
    let one = |ty: &Vector3<f64>, cb: &Vector3<f64>| {
        if !ac {
            // Ibaraki & Ota 2014, eq. (6), as printed.
            let a = ty.x * ct + ty.z * st + cb.x;
            let b = ty.y + cb.y;
            Vector3::new(
                -a * cc + b * sc,
                -a * sc - b * cc,
                ty.x * st - ty.z * ct - cb.z,
            )
        } else {
            // A/C: the tilt turns about X, so Y and Z mix instead.
            let a = ty.x + cb.x;
            let b = ty.y * ct - ty.z * st + cb.y;
            Vector3::new(
                -a * cc + b * sc,
                -a * sc - b * cc,
                -(ty.y * st + ty.z * ct) - cb.z,
            )
        }
    };
    (one(&t.d_ty, &t.d_ct), one(&t.w_ty, &t.w_ct))
}

/// A single location error of 10 um or 50 urad displaces every machined
/// surface of the stepped square as Ibaraki & Ota 2014, eq. (5)-(6) says, within
/// second-order terms: each CMM point moves along its normal by
/// `n . (dT + dW x p)`. All eight symbols, on both trunnions.
#[test]
fn a_single_location_error_gives_seed_001s_displacement_pattern() {
    for (m, ac) in [("bc-trunnion", false), ("ac-trunnion", true)] {
        let plan = planned(m, "stepped-square");
        // Symbol, its term (written independently of the symbol table),
        // and its value.
        let symbols: [(&str, SetTerm); 8] = if !ac {
            [
                ("EX0B", |t, v| t.d_ty.x = v),
                ("EZ0B", |t, v| t.d_ty.z = v),
                ("EA0B", |t, v| t.w_ty.x = v),
                ("EC0B", |t, v| t.w_ty.z = v),
                ("EB0B", |t, v| t.w_ct.y = v),
                ("EX(0B)C", |t, v| t.d_ct.x = v),
                ("EY0C", |t, v| t.d_ct.y = v),
                ("EA(0B)C", |t, v| t.w_ct.x = v),
            ]
        } else {
            [
                ("EY0A", |t, v| t.d_ty.y = v),
                ("EZ0A", |t, v| t.d_ty.z = v),
                ("EB0A", |t, v| t.w_ty.y = v),
                ("EC0A", |t, v| t.w_ty.z = v),
                ("EA0A", |t, v| t.w_ct.x = v),
                ("EY(0A)C", |t, v| t.d_ct.y = v),
                ("EX0C", |t, v| t.d_ct.x = v),
                ("EB(0A)C", |t, v| t.w_ct.y = v),
            ]
        };
        for (name, set) in symbols {
            let angle = name.starts_with("EA") || name.starts_with("EB") || name.starts_with("EC");
            let (value, model_value) = if angle { (50.0, 50e-6) } else { (10.0, 10e-3) };
            let errors = truth(&plan, &format!("location_errors: {{{name}: {value}}}\n"));
            let out = simulate::run(&plan, &errors, &SimOptions::exact()).unwrap();
            let mut terms = Terms::default();
            set(&mut terms, model_value);
            let mut largest: f64 = 0.0;
            for (p, w) in plan.plan_points().points.iter().zip(&out.points_w) {
                let (dt, dw) = eq6(ac, &terms, p.tilt, p.c);
                let expected = p.n.dot(&(dt + dw.cross(&p.p)));
                let got = p.n.dot(&(w - p.p));
                // Second order: (50 urad)^2 x 200 mm and 50 urad x 10 um.
                assert!(
                    (got - expected).abs() < 1e-6,
                    "{m} {name} {}: {got:.7} mm, eq. (6) says {expected:.7}",
                    p.label
                );
                largest = largest.max(expected.abs());
            }
            assert!(largest > 5e-4, "{m} {name}: pattern too small ({largest})");
        }
    }
}

// ---------------------------------------------------------------- nine sections

/// The nine-section heights relative to section 1 for a single error, by
/// hand. Every section is a plane with normal +Z in W, and a translation of
/// an axis line moves what the machine cuts rigidly by eq. (6)'s (dX, dY,
/// dZ) (exact for a translation): the surface rises by dZ, and the ball's
/// raster slides sideways by the rest, which lifts a point that sat on a
/// pass by the scallop `R - sqrt(R^2 - y^2)` (y the sideways shift across
/// the passes, R the ball's radius: 1 nm for 2.6 um, 17 nm for 10 um). So:
/// - A/C, EZ0A = 10 um: `dZ = -EZ0A cos A`, heights `EZ0A (1 - cos A)`:
///   0.341 um at A = -15, 1.340 um at A = -30 (plus scallops);
/// - A/C, EY0A = 10 um: `dZ = -EY0A sin A`: 2.588 um at A = -15, 5 um at -30;
/// - B/C, EY0C = 10 um: a shift in the sections' planes: heights 0 but for
///   the scallops.
#[test]
fn nine_section_heights_match_the_hand_calculation() {
    let cases: [(&str, &str, bool, SetTerm); 3] = [
        ("ac-trunnion", "EZ0A", true, |t, v| t.d_ty.z = v),
        ("ac-trunnion", "EY0A", true, |t, v| t.d_ty.y = v),
        ("bc-trunnion", "EY0C", false, |t, v| t.d_ct.y = v),
    ];
    for (m, name, ac, set) in cases {
        let plan = planned(m, "nine-section");
        let errors = truth(&plan, &format!("location_errors: {{{name}: 10}}\n"));
        let out = simulate::run(&plan, &errors, &SimOptions::exact()).unwrap();
        let heights = out.heights.as_ref().unwrap();
        let Plan::Machining(t) = &*plan else {
            unreachable!()
        };
        let kin = simulate::plan_kinematics(&plan);
        let mut terms = Terms::default();
        set(&mut terms, 10e-3);
        let r = t.cutter.radius;
        // By hand, per point, then averaged per section (um).
        let mut sums = vec![(0.0, 0.0); t.poses.len()];
        for pp in &t.points {
            let p = &pp.point;
            let (d, _) = eq6(ac, &terms, p.tilt, p.c);
            let g = &pp.provenance.generators[0];
            let (a, b) = t.poses[pp.provenance.pose].segment(g.move_index);
            let e = (kin.forward_nominal(&b).tip - kin.forward_nominal(&a).tip).normalize();
            let side = d - e * d.dot(&e) - p.n * d.dot(&p.n);
            let y = side.norm();
            let h = d.dot(&p.n) + (r - (r * r - y * y).sqrt());
            sums[pp.provenance.pose].0 += h * 1e3;
            sums[pp.provenance.pose].1 += 1.0;
        }
        let mean: Vec<f64> = sums.iter().map(|(s, k)| s / k).collect();
        assert_eq!(heights.len(), 9);
        assert_eq!(heights[0].height_um, 0.0);
        for (h, (pose, mu)) in heights.iter().zip(t.poses.iter().zip(&mean)) {
            let want = mu - mean[0];
            assert!(
                (h.height_um - want).abs() < 1e-6,
                "{m} {name} section {} ({} = {}, C = {}): {} um, by hand {want} um",
                h.section,
                t.machine.tilt.letter,
                pose.tilt,
                pose.c,
                h.height_um
            );
        }
        // The closed forms above, within the scallops: at most
        // (10 um)^2 / (2 x 3 mm) = 0.017 um.
        for (h, pose) in heights.iter().zip(&t.poses) {
            let a = pose.tilt.to_radians();
            let plain = match name {
                "EZ0A" => 10.0 * (1.0 - a.cos()),
                "EY0A" => -10.0 * a.sin(),
                _ => 0.0,
            };
            assert!(
                (h.height_um - plain).abs() < 0.02,
                "{m} {name} section {}: {} um, closed form {plain} um",
                h.section,
                h.height_um
            );
        }
    }
}

// ---------------------------------------------------------------- noise, setups, pre-travel

/// The CMM noise has the truth's standard deviation, along each probing
/// direction; the probe's repeatability likewise along the probing move.
#[test]
fn noise_has_the_truths_standard_deviation() {
    for (m, test) in [
        ("bc-trunnion", "stepped-square"),
        ("ac-trunnion", "probe-sphere"),
    ] {
        let plan = planned(m, test);
        let errors = truth(&plan, "effects: {noise: {cmm: 0.5, probe: 0.5}}\n");
        let exact = simulate::run(&plan, &errors, &SimOptions::exact()).unwrap();
        let mut opts = SimOptions::exact();
        opts.noise = simulate::NoiseOverrides::default();
        opts.seed = 9;
        let noisy = simulate::run(&plan, &errors, &opts).unwrap();
        let d: Vec<f64> = exact
            .points_w
            .iter()
            .zip(&noisy.points_w)
            .map(|(a, b)| (b - a).norm() * 1e3)
            .collect();
        let rms = (d.iter().map(|x| x * x).sum::<f64>() / d.len() as f64).sqrt();
        // n >= 130 draws: the sample deviation is within 20 % of 0.5 um.
        assert!(d.len() >= 130, "{}", d.len());
        assert!((rms - 0.5).abs() < 0.1, "{m} {test}: rms {rms} um");
    }
}

/// Probed pieces sit where seeded setup errors put them: each column
/// shifted by at most 0.1 mm and turned by at most 1 mrad, differently for
/// each column and each seed.
#[test]
fn probed_pieces_get_seeded_setup_errors_within_the_bounds() {
    let plan = planned("ac-trunnion", "probe-columns");
    let errors = truth(&plan, "");
    let Plan::Probing(p) = &*plan else {
        unreachable!()
    };
    let fivecal::procedure::probing::ProbedGeometry::Columns(cols) = &p.setup else {
        unreachable!()
    };
    let run = |seed| {
        let mut o = SimOptions::exact();
        o.setup = simulate::SetupErrors::Random {
            shift: simulate::SETUP_SHIFT_MM,
            angle: simulate::SETUP_ANGLE_RAD,
        };
        o.seed = seed;
        simulate::run(&plan, &errors, &o).unwrap().setups
    };
    let a = run(1);
    assert_eq!(a.len(), cols.len());
    for ((name, s), c) in a.iter().zip(cols) {
        assert_eq!(name, &c.name);
        let shift = (s * nalgebra::Point3::from(c.centre)).coords - c.centre;
        let angle = s.rotation.angle();
        assert!(
            shift.norm() <= 0.1 + 1e-12 && shift.norm() > 1e-4,
            "{name}: {shift:?}"
        );
        assert!(angle <= 1e-3 + 1e-15 && angle > 1e-6, "{name}: {angle}");
    }
    assert_ne!(a[0].1, a[1].1);
    assert_ne!(a, run(2));
}

/// Pre-travel by approach direction: with only `X+` set, the touches that
/// approach along +X trigger that far beyond the contact, the others not at
/// all, and those in between by the squared component of their approach.
#[test]
fn pre_travel_acts_along_each_touch_by_its_approach_direction() {
    let plan = planned("bc-trunnion", "probe-sphere");
    let clean = simulate::run(&plan, &truth(&plan, ""), &SimOptions::exact()).unwrap();
    let errors = truth(&plan, "effects: {probe_pretravel: {X+: 2.0}}\n");
    let out = simulate::run(&plan, &errors, &SimOptions::exact()).unwrap();
    let Plan::Probing(p) = &*plan else {
        unreachable!()
    };
    let mut along_x = 0;
    for ((t, a), b) in p.plan.touches.iter().zip(&clean.points).zip(&out.points) {
        let approach = -t.normal_prog;
        let moved = (b.p - a.p).dot(&approach);
        let want = 2e-3 * approach.x.max(0.0).powi(2);
        assert!(
            (moved - want).abs() < 1e-12 && ((b.p - a.p) - approach * moved).norm() < 1e-12,
            "{}: moved {moved} mm along its approach, expected {want}",
            t.label
        );
        along_x += usize::from(approach.x > 0.999);
    }
    assert!(along_x > 10);
}
