//! Speed of identification on the synthetic tests: the global and
//! two-stage fits of a stepped-square piece (144 points, with a B-axis
//! map), the sphere method (49 positions), the unlabelled placement search,
//! and a full-size Monte-Carlo study (200 runs) of the global fit; and on
//! the simulator: one run of the planner's stepped square simulated and
//! identified, and the 200-run Monte Carlo `analyze --mc 200` makes of it
//! with Ibaraki & Ota's (2014) contributors.

use std::collections::HashMap;
use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use fivecal::analyze::uncertainty::simulated::{self, SimulatedTest};
use fivecal::analyze::uncertainty::{self, Contributors, McOptions, SyntheticTest};
use fivecal::errorfile::ErrorFile;
use fivecal::formats::detect::PointSet;
use fivecal::formats::manifest::KinematicsMode;
use fivecal::formats::manifest::TestKind;
use fivecal::formats::points::PlanPoints;
use fivecal::identify::sphere::SphereOptions;
use fivecal::identify::{Dataset, Method, Setup, data, synthetic};
use fivecal::kinematics::Kinematics;
use fivecal::model::{Effect, Model};
use fivecal::post::PostDefinition;
use fivecal::procedure::{PlanConfig, Template, Test};
use fivecal::simulate::{self, SimOptions};
use fivecal::{Dialect, Machine, placement};
use nalgebra::{Isometry3, Vector3};
use rand::SeedableRng;
use rand::rngs::StdRng;

fn dataset(
    plan: &PlanPoints,
    kind: TestKind,
    pts: Vec<fivecal::formats::measured::MeasuredPoint>,
) -> Dataset {
    let set = PointSet {
        format: "synthetic",
        points: pts,
        labeled: true,
        nominals: Vec::new(),
        warnings: Vec::new(),
    };
    data::join(
        plan,
        kind,
        &HashMap::new(),
        &[("bench".into(), set)],
        &|p| p.p,
    )
    .unwrap()
}

fn bench(c: &mut Criterion) {
    let mut rng = StdRng::seed_from_u64(1);
    let k = Kinematics::new(&Machine::builtin("bc-trunnion").unwrap());
    let plan = synthetic::stepped_square(&k, &[-90.0, 0.0, 90.0], &[0.0, 90.0, 180.0, 270.0], 15.0);
    let truth = Model::new(
        k.clone(),
        vec![Effect::Location {
            symbols: (0..8).collect(),
        }],
    );
    let theta = [12.0, -40.0, 80.0, -60.0, 150.0, 25.0, -18.0, 45.0];
    let pl = Isometry3::new(
        Vector3::new(600.0, -300.0, 200.0),
        Vector3::new(0.3, 1.2, -2.0),
    );
    let pts = synthetic::machined(&truth, &theta, &plan, &HashMap::new(), 0.35, &pl, &mut rng);
    let measured: Vec<Vector3<f64>> = pts.iter().map(|p| p.p).collect();
    let d = dataset(&plan, TestKind::Machining, pts);
    let setup = Setup::new(&k, &d.poses, &["EBB(B)".to_string()]).unwrap();
    let so = SphereOptions::default();
    c.bench_function("global stepped square 144 points + EBB(B)", |b| {
        b.iter(|| {
            fivecal::analyze::method::identify_with(Method::Global, black_box(&setup), &d, &so)
                .unwrap()
        })
    });
    c.bench_function("two-stage stepped square 144 points + EBB(B)", |b| {
        b.iter(|| {
            fivecal::analyze::method::identify_with(Method::TwoStage, black_box(&setup), &d, &so)
                .unwrap()
        })
    });
    let noms: Vec<(Vector3<f64>, Vector3<f64>)> = plan.points.iter().map(|p| (p.p, p.n)).collect();
    c.bench_function("placement without labels, 144 points", |b| {
        b.iter(|| placement::place_unlabeled(black_box(&noms), &measured).unwrap())
    });

    let ka = Kinematics::with_gauge_length(&Machine::builtin("ac-trunnion").unwrap(), 110.0);
    let mut poses: Vec<(f64, f64)> = (0..36).map(|i| (0.0, 10.0 * i as f64)).collect();
    poses.extend(
        (0..13)
            .map(|i| (-90.0 + 10.0 * i as f64, 0.0))
            .filter(|p| p.0 != 0.0),
    );
    let centre = Vector3::new(120.0, -40.0, 60.0);
    let splan = synthetic::sphere_plan(&ka, &centre, 15.0, &poses);
    let struth = Model::new(
        ka.clone(),
        vec![Effect::Location {
            symbols: (0..8).collect(),
        }],
    );
    let stheta = [15.0, -30.0, 60.0, -90.0, 120.0, 20.0, -25.0, 40.0];
    let spts = synthetic::probed_sphere(&struth, &stheta, &splan, &centre, 15.0, 0.35, &mut rng);
    let sd = dataset(&splan, TestKind::Probing, spts);
    let ssetup = Setup::new(&ka, &sd.poses, &[]).unwrap();
    c.bench_function("sphere method, 49 positions, robust", |b| {
        b.iter(|| {
            fivecal::analyze::method::identify_with(Method::Sphere, black_box(&ssetup), &sd, &so)
                .unwrap()
        })
    });

    let loc = Setup::new(&k, &d.poses, &[]).unwrap();
    let est = fivecal::analyze::method::identify_with(Method::Global, &loc, &d, &so).unwrap();
    let t = SyntheticTest {
        estimate: &est,
        setup: &loc,
        data: &d,
        method: Method::Global,
        sphere: so,
        sphere_geometry: None,
        contributors: Contributors::seed001(),
    };
    let mut group = c.benchmark_group("monte carlo");
    group.sample_size(10);
    group.bench_function(
        "200 runs of the global fit, Ibaraki & Ota 2014, table 4",
        |b| {
            b.iter(|| {
                uncertainty::montecarlo::run(
                    &McOptions {
                        runs: 200,
                        seed: 3,
                        progress: false,
                        max_seconds: None,
                    },
                    est.theta.len(),
                    |_, r| uncertainty::synthetic_run(&t, r),
                )
            })
        },
    );
    group.finish();

    // The simulator: the planner's stepped square on bc-trunnion.
    let m = Machine::builtin("bc-trunnion").unwrap();
    let plan = fivecal::procedure::plan(&PlanConfig {
        machine: m,
        template: Template::builtin(Test::SteppedSquare),
        post: PostDefinition::builtin(Dialect::Fanuc),
        kinematics: KinematicsMode::Post,
        tool: None,
    })
    .unwrap();
    let kin = simulate::plan_kinematics(&plan);
    let src = "machine: bc-trunnion\nlocation_errors: {EX0B: 12, EZ0B: -40, EA0B: 80, EC0B: -60, EB0B: 150, EX(0B)C: 25, EY0C: -18, EA(0B)C: 45}\n";
    let path = std::path::Path::new("truth.yaml");
    let truth = ErrorFile::parse(path, src)
        .and_then(|f| f.to_model(&kin, path, src))
        .unwrap();
    let out = simulate::run(&plan, &truth, &SimOptions::default()).unwrap();
    let sd = simulated::plan_dataset(&plan, "sim", out.points).unwrap();
    let ssetup = Setup::new(&kin, &sd.poses, &[]).unwrap();
    c.bench_function(
        "simulate the planned stepped square and identify (global)",
        |b| {
            b.iter(|| {
                let out = simulate::run(black_box(&plan), &truth, &SimOptions::default()).unwrap();
                let d = simulated::plan_dataset(&plan, "sim", out.points).unwrap();
                fivecal::analyze::method::identify_with(Method::Global, &ssetup, &d, &so).unwrap()
            })
        },
    );
    let est = fivecal::analyze::method::identify_with(Method::Global, &ssetup, &sd, &so).unwrap();
    let t = SimulatedTest::from_estimate(&plan, &est, &ssetup, &sd, so, Contributors::seed001());
    let mut group = c.benchmark_group("monte carlo on the simulator");
    group.sample_size(10);
    group.bench_function(
        "200 runs of the planned stepped square, Ibaraki & Ota 2014, table 4",
        |b| {
            b.iter(|| {
                uncertainty::montecarlo::run(
                    &McOptions {
                        runs: 200,
                        seed: 3,
                        progress: false,
                        max_seconds: None,
                    },
                    est.theta.len(),
                    |_, r| simulated::simulated_run(&t, r),
                )
            })
        },
    );
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
