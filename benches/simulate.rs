//! Speed of the virtual machine on the planners' own tests on `bc-trunnion`:
//! the exact simulation of a stepped square (144 points, every cutting move
//! of the twelve poses swept) with location errors and linear-axis errors
//! (straight actual paths) and with every effect of the truth example
//! (drift per minute bends the paths), the nine-section test with its ball
//! raster, the column-probing test (220 touches, FANUC log), and the forward
//! model's prediction of a whole stepped square with its Jacobian (what one
//! Gauss-Newton iteration of `analyze` costs).

use std::hint::black_box;
use std::path::Path;

use criterion::{Criterion, criterion_group, criterion_main};
use fivecal::errorfile::{ErrorFile, LoadedErrors};
use fivecal::formats::manifest::KinematicsMode;
use fivecal::post::PostDefinition;
use fivecal::procedure::{Plan, PlanConfig, Template, Test, plan};
use fivecal::simulate::{self, Format, SimOptions, forward};
use fivecal::{Dialect, Machine};

fn machining(test: &str) -> Plan {
    plan(&PlanConfig {
        machine: Machine::builtin("bc-trunnion").unwrap(),
        template: Template::builtin(test.parse().unwrap()),
        post: PostDefinition::builtin(Dialect::Fanuc),
        kinematics: KinematicsMode::Post,
        tool: None,
    })
    .unwrap()
}

fn truth(plan: &Plan, full: bool) -> LoadedErrors {
    let kin = simulate::plan_kinematics(plan);
    let src = if full {
        simulate::truth::example(&kin)
    } else {
        "machine: bc-trunnion\nlocation_errors: {EX0B: 12, EZ0B: -25, EA0B: 80, EC0B: -60, EB0B: 150, EX(0B)C: 25, EY0C: -18, EA(0B)C: 45}\neffects: {linear_scale: {EXX: 4, EYY: -3}, squareness: {EC(0X)Y: 15}, tool_radius: 3}\n".to_string()
    };
    let path = Path::new("truth.yaml");
    ErrorFile::parse(path, &src)
        .unwrap()
        .to_model(&kin, path, &src)
        .unwrap()
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("simulate");
    g.sample_size(10);
    let ss = machining("stepped-square");
    let straight = truth(&ss, false);
    let full = truth(&ss, true);
    let opts = SimOptions::default();
    g.bench_function("stepped-square, location and linear-axis errors", |b| {
        b.iter(|| black_box(simulate::run(&ss, &straight, &opts).unwrap()))
    });
    g.bench_function("stepped-square, every effect (bent paths)", |b| {
        b.iter(|| black_box(simulate::run(&ss, &full, &opts).unwrap()))
    });
    let ns = machining("nine-section");
    let ns_truth = truth(&ns, false);
    g.bench_function("nine-section, heights", |b| {
        b.iter(|| {
            let out = simulate::run(&ns, &ns_truth, &opts).unwrap();
            black_box(out.render(Format::Heights).unwrap())
        })
    });
    let cols = plan(&PlanConfig {
        machine: Machine::builtin("bc-trunnion").unwrap(),
        template: Template::builtin(Test::ProbeColumns),
        post: PostDefinition::builtin(Dialect::Fanuc),
        kinematics: KinematicsMode::Post,
        tool: None,
    })
    .unwrap();
    let cols_truth = truth(&cols, true);
    g.bench_function("probe-columns, FANUC log", |b| {
        b.iter(|| {
            let out = simulate::run(&cols, &cols_truth, &opts).unwrap();
            black_box(out.render(Format::Log).unwrap())
        })
    });
    let fm = forward::for_plan(&full.model, &ss).unwrap();
    let points = ss.plan_points();
    let minutes: std::collections::HashMap<String, f64> = ss
        .poses()
        .iter()
        .map(|p| (p.pose.clone(), 0.5 * (p.start_min + p.end_min)))
        .collect();
    g.bench_function("forward model, stepped-square with Jacobian", |b| {
        b.iter(|| {
            for p in &points.points {
                black_box(fm.predict(&full.theta, &[], p, minutes[&p.pose]).unwrap());
            }
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
