//! The simulator's forward model (`simulate::forward`), the one `analyze`
//! and `discover` invert: it must predict what the exact simulator measures
//! (noise off, CMM placement removed) for every effect on every test of
//! every built-in machine, and its Jacobian must be the derivative of its
//! own predictions.

use std::collections::HashMap;
use std::path::Path;
use std::sync::Arc;

use fivecal::Dialect;
use fivecal::errorfile::{ErrorFile, LoadedErrors, Quantity, Values};
use fivecal::formats::detect::{self, PointSet};
use fivecal::formats::manifest::TestKind;
use fivecal::identify::forward::{ForwardModel, Prediction, RigidPoseMachining, Wanted};
use fivecal::identify::sphere::SphereOptions;
use fivecal::identify::{Method, Setup, data::join};
use fivecal::post::PostDefinition;
use fivecal::procedure::{Plan, PlanConfig, Template, Test, plan};
use fivecal::simulate::{self, SetupErrors, SimOptions, forward};

use crate::simulate::{MACHINING, PROBING, planned};
use crate::util::{MACHINES, machine, tempdir};

/// The truth example of a machine with every error at the size the
/// forward model is specified for: 50 um and 200 urad location errors and
/// maps, 50 um/m scale, 200 urad squareness, 20 um straightness, 50 um tool
/// radius and length, 5 um per pose and 2 um (10 urad) per minute of drift.
fn full_truth(plan: &Plan) -> ErrorFile {
    let kin = simulate::plan_kinematics(plan);
    let text = simulate::truth::example(&kin);
    let mut f = ErrorFile::parse(Path::new("example.yaml"), &text).unwrap();
    let model = fivecal::model::Model::new(kin, vec![]);
    for (i, (name, q)) in f.location_errors.iter_mut().enumerate() {
        let sym = model
            .symbols
            .location
            .iter()
            .find(|s| &s.name == name)
            .unwrap();
        let sign = if i % 2 == 0 { 1.0 } else { -1.0 };
        *q = Quantity::bare(
            sign * match sym.unit {
                fivecal::kinematics::symbols::Unit::Um => 50.0,
                fivecal::kinematics::symbols::Unit::Urad => 200.0,
            },
        );
    }
    for m in f.position_dependent.values_mut() {
        m.values = match &m.values {
            Values::Flat(v) => Values::Flat(v.iter().map(|x| x * 5.0).collect()),
            Values::Rows(r) => Values::Rows(
                r.iter()
                    .map(|row| row.iter().map(|x| x * 5.0).collect())
                    .collect(),
            ),
        };
    }
    let e = &mut f.effects;
    for (k, v) in e.linear_scale.iter_mut().enumerate() {
        *v.1 = Quantity::bare(if k % 2 == 0 { 50.0 } else { -50.0 });
    }
    for (k, v) in e.squareness.iter_mut().enumerate() {
        *v.1 = Quantity::bare(if k % 2 == 0 { 200.0 } else { -200.0 });
    }
    e.straightness.clear();
    let st = "{EZX: {X: [-400, -100, 100, 400], values: [0, 20, -20, 0]}, EYZ: {Z: [-500, -200, 100], values: [0, 20, 0]}, EXY: {Y: [-300, 300], values: [-20, 20]}}";
    e.straightness = serde_yaml::from_str(st).unwrap();
    e.tool_radius = Some(Quantity::bare(50.0));
    e.tool_length = Some(Quantity::bare(-50.0));
    let names: Vec<String> = e.thermal_drift.keys().cloned().collect();
    e.thermal_drift[&names[0]].rate = Quantity::bare(5.0);
    e.thermal_drift[&names[1]].rate = Quantity::bare(2.0);
    for v in e.probe_pretravel.values_mut() {
        *v = Quantity::bare(v.value * 3.0);
    }
    e.noise = None;
    f
}

fn load(plan: &Plan, f: &ErrorFile) -> LoadedErrors {
    let kin = simulate::plan_kinematics(plan);
    let src = f.to_yaml();
    f.to_model(&kin, Path::new("truth.yaml"), &src).unwrap()
}

/// The truth restricted to one effect group.
fn only(f: &ErrorFile, group: &str) -> ErrorFile {
    let mut g = f.clone();
    let keep_loc = group == "location";
    if !keep_loc {
        g.location_errors.clear();
    }
    if group != "maps" {
        g.position_dependent.clear();
    }
    let e = &mut g.effects;
    if group != "scale" {
        e.linear_scale.clear();
    }
    if group != "squareness" {
        e.squareness.clear();
    }
    if group != "straightness" {
        e.straightness.clear();
    }
    if group != "tool" {
        e.tool_radius = None;
        e.tool_length = None;
    }
    if group != "pretravel" {
        e.probe_pretravel.clear();
    }
    match group {
        "drift-seq" => e.thermal_drift.retain(|_, d| d.per == "seq"),
        "drift-minute" => e.thermal_drift.retain(|_, d| d.per == "minute"),
        _ => e.thermal_drift.clear(),
    }
    g
}

fn pose_minutes(plan: &Plan) -> HashMap<String, f64> {
    plan.poses()
        .iter()
        .map(|p| (p.pose.clone(), 0.5 * (p.start_min + p.end_min)))
        .collect()
}

/// Worst distance between the forward model's prediction and the exact
/// simulator's point (noise off, placement removed, probed pieces set up
/// with seeded errors given to the model as its nuisance), mm; and the
/// largest displacement of a point by the errors, mm.
fn gap(plan: &Plan, errors: &LoadedErrors) -> (f64, f64) {
    let mut opts = SimOptions::exact();
    if plan.kind() == TestKind::Probing {
        opts.setup = SetupErrors::Random {
            shift: simulate::SETUP_SHIFT_MM,
            angle: simulate::SETUP_ANGLE_RAD,
        };
        opts.seed = 3;
    }
    let out = simulate::run(plan, errors, &opts).unwrap();
    let nu = match plan {
        Plan::Probing(p) => {
            let fm = forward::ProbingForward::new(&errors.model, Arc::new((**p).clone())).unwrap();
            let setups: Vec<_> = out.setups.iter().map(|s| s.1).collect();
            fm.nuisance_of(&setups)
        }
        Plan::Machining(_) => Vec::new(),
    };
    let fm = forward::for_plan(&errors.model, plan).unwrap();
    let minutes = pose_minutes(plan);
    let pts = plan.plan_points();
    let kin = simulate::plan_kinematics(plan);
    let mut worst: f64 = 0.0;
    let mut moved: f64 = 0.0;
    for (p, w) in pts.points.iter().zip(&out.points_w) {
        let pred = fm
            .predict(&errors.theta, &nu, p, minutes[&p.pose])
            .unwrap_or_else(|e| panic!("{}: {e}", p.label));
        worst = worst.max((pred.point - w).norm());
        let nominal = match plan.kind() {
            TestKind::Machining => p.p,
            TestKind::Probing => {
                fivecal::procedure::probing::PoseFrame::new(&kin, p.tilt, p.c).to_prog(&p.p)
            }
        };
        moved = moved.max((w - nominal).norm());
    }
    (worst, moved)
}

/// Well below 0.01 um.
const AGREE_MM: f64 = 1e-6;

/// Every effect on its own, on the B/C trunnion's two machining tests and
/// two probing tests: the forward model predicts the exact simulator's
/// points to well below 0.01 um, while the effect moves them by microns.
#[test]
fn forward_model_predicts_the_simulator_for_each_effect() {
    let groups = [
        "location",
        "maps",
        "scale",
        "squareness",
        "straightness",
        "tool",
        "drift-seq",
        "drift-minute",
        "pretravel",
    ];
    for test in MACHINING.iter().chain(&PROBING) {
        let plan = planned("bc-trunnion", test);
        let full = full_truth(&plan);
        for group in groups {
            let kind = plan.kind();
            if group == "pretravel" && kind == TestKind::Machining {
                continue;
            }
            let errors = load(&plan, &only(&full, group));
            let (g, moved) = gap(&plan, &errors);
            assert!(
                g < AGREE_MM,
                "{test}, {group}: forward model {:.6} um from the simulator",
                g * 1e3
            );
            assert!(
                moved > 5e-4,
                "{test}, {group}: the effect moved nothing ({moved} mm)"
            );
        }
    }
}

/// All effects at once on every test of every built-in machine (and a
/// bull-nose cutting the nine sections with its torus): agreement well
/// below 0.01 um.
#[test]
fn forward_model_predicts_the_simulator_on_every_machine_and_test() {
    for m in MACHINES {
        for test in MACHINING.iter().chain(&PROBING) {
            let plan = planned(m, test);
            let errors = load(&plan, &full_truth(&plan));
            let (g, moved) = gap(&plan, &errors);
            assert!(
                g < AGREE_MM,
                "{m} {test}: forward model {:.6} um from the simulator",
                g * 1e3
            );
            assert!(
                moved > 0.02,
                "{m} {test}: errors moved points by {moved} mm only"
            );
        }
    }
    let plan = bull_nose_nine_section();
    let errors = load(&plan, &full_truth(&plan));
    let (g, _) = gap(&plan, &errors);
    assert!(g < AGREE_MM, "bull-nose nine-section: {:.6} um", g * 1e3);
}

fn bull_nose_nine_section() -> Plan {
    let cfg = PlanConfig {
        machine: machine("head-table"),
        template: Template::builtin(Test::NineSection),
        post: PostDefinition::builtin(Dialect::Heidenhain),
        kinematics: fivecal::formats::manifest::KinematicsMode::Post,
        tool: Some(machine("head-table").tool),
    };
    plan(&cfg).unwrap()
}

/// Largest difference between the forward model's Jacobian and central
/// differences of its own predictions, over every parameter and nuisance
/// and every `step`-th point, mm per unit. A machined point's prediction is
/// the deepest of the surfaces its passes leave, which has a kink where two
/// passes tie; each surface is smooth, so each is checked on its own (and
/// the prediction is checked to be the deepest).
fn jacobian_error(plan: &Plan, errors: &LoadedErrors, step: usize) -> f64 {
    let fm = forward::for_plan(&errors.model, plan).unwrap();
    let machining = match plan {
        Plan::Machining(t) => {
            Some(forward::MachiningForward::new(&errors.model, Arc::new((**t).clone())).unwrap())
        }
        Plan::Probing(_) => None,
    };
    let k = fm.nuisance_names().len();
    let nu: Vec<f64> = (0..k)
        .map(|i| [30.0, -20.0, 10.0, 150.0, -80.0, 60.0][i % 6])
        .collect();
    let theta = &errors.theta;
    let minutes = pose_minutes(plan);
    let pts = plan.plan_points();
    // Small against the curvature of a flat end's rim term near the edge of
    // its pass, large against round-off.
    let h = 1e-3;
    let mut worst: f64 = 0.0;
    for p in pts.points.iter().step_by(step) {
        let min = minutes[&p.pose];
        // (move, prediction) pairs, or the one prediction of a touch.
        let eval = |t: &[f64], n: &[f64]| -> Vec<(usize, Prediction)> {
            match &machining {
                Some(m) => m
                    .surfaces(t, p, min)
                    .unwrap()
                    .into_iter()
                    .map(|(mv, s)| (mv, s.prediction))
                    .collect(),
                None => vec![(0, fm.predict(t, n, p, min).unwrap())],
            }
        };
        let base = eval(theta, &nu);
        let best = fm.predict(theta, &nu, p, min).unwrap();
        let deepest = base
            .iter()
            .map(|(_, q)| p.n.dot(&(q.point - p.p)))
            .fold(f64::INFINITY, f64::min);
        assert_eq!(p.n.dot(&(best.point - p.p)), deepest, "{}", p.label);
        for j in 0..theta.len() + k {
            let shifted = |d: f64| {
                let (mut t, mut n) = (theta.clone(), nu.clone());
                if j < t.len() {
                    t[j] += d;
                } else {
                    n[j - t.len()] += d;
                }
                eval(&t, &n)
            };
            let (plus, minus) = (shifted(h), shifted(-h));
            for (mv, pred) in &base {
                let find = |v: &[(usize, Prediction)]| {
                    v.iter().find(|(m, _)| m == mv).map(|(_, q)| q.point)
                };
                let (Some(a), Some(b)) = (find(&plus), find(&minus)) else {
                    continue;
                };
                let fd = (a - b) / (2.0 * h);
                let an = pred.d_point.column(j).into_owned();
                worst = worst.max((fd - &an).norm() / (1.0 + an.norm() * 1e3));
            }
        }
    }
    worst
}

/// The Jacobian is the derivative of the prediction: central differences
/// (0.001 um or urad) agree to 1e-9 mm per unit on every test of every
/// machine with every effect set.
#[test]
fn forward_jacobian_matches_central_differences_of_itself() {
    for m in MACHINES {
        for test in MACHINING.iter().chain(&PROBING) {
            let plan = planned(m, test);
            let errors = load(&plan, &full_truth(&plan));
            let step = if plan.kind() == TestKind::Probing {
                17
            } else {
                5
            };
            let e = jacobian_error(&plan, &errors, step);
            assert!(e < 1e-9, "{m} {test}: Jacobian off by {e:e} mm per unit");
        }
    }
    let plan = bull_nose_nine_section();
    let errors = load(&plan, &full_truth(&plan));
    let e = jacobian_error(&plan, &errors, 3);
    assert!(e < 1e-9, "bull-nose nine-section: Jacobian off by {e:e}");
}

/// A fit of a few effects with a machining test's whole catalogue model
/// asks for the derivatives of its own effects only
/// (`ForwardModel::predict_wanted`): those columns are `predict`'s to the
/// bit, so a discovery prints the same; the others are not computed.
/// Checked with every second effect at zero, as a catalogue's fits have
/// most of theirs (an effect at zero is skipped in the perturbation), on
/// both machining tests of every machine and the bull-nose nine-section.
#[test]
fn predict_wanted_gives_the_wanted_columns_of_predict_to_the_bit() {
    let plans = machining_plans();
    for (name, plan) in &plans {
        let errors = load(plan, &full_truth(plan));
        let model = &errors.model;
        let fm = forward::for_plan(model, plan).unwrap();
        let mut theta = errors.theta.clone();
        for e in (1..model.effects.len()).step_by(2) {
            for c in model.param_range(e) {
                theta[c] = 0.0;
            }
        }
        let wanted = Wanted::new(model, |c| {
            let e = (0..model.effects.len())
                .find(|&e| model.param_range(e).contains(&c))
                .unwrap();
            e % 3 == 0
        });
        assert!(!wanted.columns().is_empty() && wanted.columns().len() < theta.len());
        let minutes = pose_minutes(plan);
        let pts = plan.plan_points();
        let mut nonzero = 0;
        for p in pts.points.iter().step_by(7) {
            let min = minutes[&p.pose];
            let all = fm.predict(&theta, &[], p, min).unwrap();
            let some = fm.predict_wanted(&theta, &[], p, min, &wanted).unwrap();
            assert_eq!(all.point, some.point, "{name} {}", p.label);
            assert_eq!(all.normal, some.normal, "{name} {}", p.label);
            for j in 0..theta.len() {
                let (a, b) = (all.d_point.column(j), some.d_point.column(j));
                let (na, nb) = (all.d_normal.column(j), some.d_normal.column(j));
                if wanted.columns().contains(&j) {
                    assert_eq!(a, b, "{name} {} column {j}", p.label);
                    assert_eq!(na, nb, "{name} {} column {j}", p.label);
                    nonzero += usize::from(a.norm() > 0.0);
                } else {
                    assert_eq!(b.norm() + nb.norm(), 0.0, "{name} {} column {j}", p.label);
                }
            }
        }
        assert!(nonzero > 0, "{name}: no wanted column moves a point");
    }
}

/// Both machining tests of every machine, and the bull-nose nine-section.
fn machining_plans() -> Vec<(String, Arc<Plan>)> {
    let mut plans: Vec<(String, Arc<Plan>)> = MACHINES
        .iter()
        .flat_map(|m| {
            MACHINING
                .iter()
                .map(move |t| (format!("{m} {t}"), planned(m, t)))
        })
        .collect();
    plans.push((
        "bull-nose nine-section".into(),
        Arc::new(bull_nose_nine_section()),
    ));
    plans
}

/// A machined point's prediction is the deepest of the surfaces the moves
/// near it leave (the first of equals), to the bit: the forward model finds
/// each move's offset first and differentiates the deepest alone.
#[test]
fn the_prediction_is_the_deepest_surface_to_the_bit() {
    let plans = machining_plans();
    let mut several = 0;
    for (name, plan) in &plans {
        let Plan::Machining(mp) = &**plan else {
            unreachable!()
        };
        let errors = load(plan, &full_truth(plan));
        let fm = forward::MachiningForward::new(&errors.model, Arc::new((**mp).clone())).unwrap();
        let minutes = pose_minutes(plan);
        for p in plan.plan_points().points.iter().step_by(3) {
            let min = minutes[&p.pose];
            let got = fm.predict(&errors.theta, &[], p, min).unwrap();
            let surfaces = fm.surfaces(&errors.theta, p, min).unwrap();
            several += usize::from(surfaces.len() > 1);
            let want = surfaces
                .into_iter()
                .map(|(_, s)| s)
                .min_by(|a, b| a.offset.total_cmp(&b.offset))
                .unwrap()
                .prediction;
            assert_eq!(got, want, "{name} {}", p.label);
        }
    }
    assert!(several > 20, "{several}");
}

/// analyze's global method on a head machine, which the rigid-pose model
/// refuses: the simulator's CSV of a stepped square machined on
/// `head-table` (0.35 um CMM noise, the piece anywhere on the CMM) gives
/// back the location errors that went in, within 4 standard uncertainties.
/// The probing forward model follows the probe along its line with the
/// table's part of the chain multiplied once (and the errors worked out
/// once when no linear-axis error is at work): every ball centre it meets
/// is the one worked out afresh, to the bit, with and without linear-axis
/// errors, on a table-table and a head-table machine. The pre-travel,
/// worked out from its own effect alone, is the perturbation's.
#[test]
fn the_ball_along_a_touch_line_is_the_ball_worked_out_afresh_to_the_bit() {
    for machine in ["ac-trunnion", "head-table"] {
        for test in PROBING {
            let plan = planned(machine, test);
            let Plan::Probing(p) = &*plan else {
                unreachable!()
            };
            let full = full_truth(&plan);
            for group in [
                "location",
                "maps",
                "scale",
                "straightness",
                "drift-minute",
                "pretravel",
            ] {
                let errors = load(&plan, &only(&full, group));
                let kin = simulate::plan_kinematics(&plan);
                let model = fivecal::model::Model::new(kin, errors.model.effects.clone());
                let pr = simulate::probing::Probing::new(model, Arc::new((**p).clone()));
                let theta = &errors.theta;
                assert_eq!(
                    pr.model.varies_with_xyz(theta),
                    matches!(group, "scale" | "straightness"),
                    "{group}"
                );
                for i in (0..p.plan.touches.len()).step_by(7) {
                    // The pre-travel from its own effect's terms is the
                    // whole perturbation's pre-travel slot.
                    let whole = pr.model.perturbation(theta, &pr.context(i, 0.0, 0.0));
                    assert_eq!(
                        pr.pretravel(theta, i).0.to_bits(),
                        whole.0[fivecal::kinematics::SLOT_PRETRAVEL].to_bits()
                    );
                    let line = pr.ball_line(theta, i, 0.3);
                    for tau in [-2.0, -0.1, 0.0, 0.4, 3.0] {
                        assert_eq!(
                            line.ball(tau).map(f64::to_bits),
                            pr.ball(theta, i, tau, 0.3).map(f64::to_bits),
                            "{machine} {test} {group} touch {i} at {tau}"
                        );
                        // And the errors there, which the contact's
                        // Jacobian is taken with.
                        let ctx = pr.context(i, tau, 0.3);
                        assert_eq!(
                            line.perturbation(&ctx).0.map(f64::to_bits),
                            pr.model.perturbation(theta, &ctx).0.map(f64::to_bits),
                            "{machine} {test} {group} touch {i} at {tau}"
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn analyze_global_recovers_a_head_machine_through_the_forward_model() {
    let plan = planned("head-table", "stepped-square");
    let kin = simulate::plan_kinematics(&plan);
    let src = "machine: head-table\nlocation_errors: {EX0C: 20, EY0C: -15, EA0C: 60, EB0C: -40, EX0B: 12, EA0B: 80, EC0B: -50, EB0B: 70}\neffects: {noise: {cmm: 0.35}}\n";
    let truth = ErrorFile::parse(Path::new("t.yaml"), src)
        .unwrap()
        .to_model(&kin, Path::new("t.yaml"), src)
        .unwrap();
    let out = simulate::run(
        &plan,
        &truth,
        &SimOptions {
            seed: 21,
            ..SimOptions::default()
        },
    )
    .unwrap();
    let dir = tempdir();
    let csv = dir.path().join("piece.csv");
    out.write(simulate::Format::Csv, &csv).unwrap();
    let set: PointSet = match detect::read_measurement(&csv).unwrap() {
        detect::Measurement::Points(s) => s,
        _ => panic!("not points"),
    };
    let points = plan.plan_points();
    let minutes = plan
        .poses()
        .iter()
        .map(|p| (p.pose.clone(), (p.start_min, p.end_min)))
        .collect();
    let data = join(
        &points,
        TestKind::Machining,
        &minutes,
        &[(csv.clone(), set)],
        &|p| p.p,
    )
    .unwrap();
    let setup = Setup::new(&kin, &data.poses, &[]).unwrap();
    assert!(RigidPoseMachining::new(setup.model.clone()).is_err());
    assert!(fivecal::analyze::method::rigid_refuses(&setup.model));
    let est = fivecal::analyze::method::identify_with_plan(
        Method::Global,
        &setup,
        &data,
        &SphereOptions::default(),
        Some(&plan),
    )
    .unwrap();
    let mut checked = 0;
    for (name, q) in &truth_values(&truth) {
        if let Some((v, Some(u))) = est.get(name) {
            assert!(
                (v - q).abs() < 4.0 * u + 0.05,
                "{name}: {v:.3} +- {u:.3}, truth {q}"
            );
            checked += 1;
        }
    }
    assert!(checked >= 6, "only {checked} symbols identifiable");
}

fn truth_values(l: &LoadedErrors) -> Vec<(String, f64)> {
    l.model
        .param_names()
        .into_iter()
        .zip(l.theta.iter().copied())
        .collect()
}

#[test]
fn a_turned_zero_column_is_positive_zero_to_the_bit() {
    // The probing prediction leaves the normal's derivative columns that
    // no parameter turns at +0 rather than turning them into program
    // coordinates: the same bits, since the frame's unit quaternion adds
    // the vector it turns last (+0 + -0 is +0).
    use rand::RngExt;
    let mut r = crate::util::rng(61);
    for _ in 0..2000 {
        let mut a = || r.random_range(-3.2..3.2);
        let frame = nalgebra::Isometry3::new(
            nalgebra::Vector3::new(a(), a(), a()),
            nalgebra::Vector3::new(a(), a(), a()),
        );
        let turned = frame.rotation * nalgebra::Vector3::<f64>::zeros();
        assert!(
            turned.iter().all(|x| x.to_bits() == 0),
            "{frame:?}: {turned:?}"
        );
    }
}
