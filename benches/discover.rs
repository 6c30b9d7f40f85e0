//! Speed of a discovery: the worked example of `examples/discover/` (a
//! stepped square on `bc-trunnion` with three hidden effects: three steps
//! and a last round, 42 candidates each, with the simulator's forward
//! model), one round on a piece without a hidden effect (the case the
//! 100-run test repeats), and the two probing tests on `ac-trunnion` run
//! on the machine of `fivecal simulate --truth-example --machine
//! ac-trunnion` (every effect of the catalogue at once: the columns and
//! the sphere).

use std::hint::black_box;
use std::path::{Path, PathBuf};

use criterion::{Criterion, criterion_group, criterion_main};
use fivecal::discover::{DiscoverOptions, Inputs};
use fivecal::errorfile::ErrorFile;
use fivecal::procedure::{PlanConfig, Test};
use fivecal::simulate::{self, SimOptions};
use fivecal::{Kinematics, Machine};

fn example(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples/discover")
        .join(name)
}

fn bench(c: &mut Criterion) {
    let inputs = Inputs::load(
        &example("stepped-square.plan.yaml"),
        &[example("piece.dmo")],
        &Default::default(),
    )
    .unwrap();
    let opts = DiscoverOptions::default();
    let mut group = c.benchmark_group("discover");
    group.sample_size(10);
    group.bench_function("worked example: three effects found, four rounds", |b| {
        b.iter(|| black_box(&inputs).discover(&opts).unwrap())
    });
    // The same plan run on a machine with the location errors only.
    let truth = ErrorFile::load(&example("truth.yaml"), &inputs.kin).unwrap();
    let mut errors = truth.clone();
    let n = errors
        .model
        .find("location")
        .map(|e| errors.model.param_range(e).len())
        .unwrap();
    errors.model.effects.truncate(1);
    errors.model = fivecal::Model::new(errors.model.kin.clone(), errors.model.effects.clone());
    errors.theta.truncate(n);
    errors.u.truncate(n);
    let out = simulate::run(&inputs.plan, &errors, &SimOptions::default()).unwrap();
    let null = Inputs::from_points(inputs.plan.clone(), out.points, Path::new("null.csv")).unwrap();
    group.bench_function("piece without a hidden effect: one round", |b| {
        b.iter(|| black_box(&null).discover(&opts).unwrap())
    });
    for test in [Test::ProbeColumns, Test::ProbeSphere] {
        let inputs = probing(test);
        group.bench_function(format!("{test:?} on ac-trunnion, truth example"), |b| {
            b.iter(|| black_box(&inputs).discover(&opts).unwrap())
        });
    }
    group.finish();
}

/// The probing test `test` planned for `ac-trunnion`, run on the machine of
/// its truth example (seed 1, as `fivecal simulate` runs it).
fn probing(test: Test) -> Inputs {
    let machine = Machine::builtin("ac-trunnion").unwrap();
    let kin = Kinematics::new(&machine);
    let plan = fivecal::procedure::plan(&PlanConfig::builtin(machine, test)).unwrap();
    let src = simulate::truth::example(&kin);
    let path = Path::new("truth.yaml");
    let truth = ErrorFile::parse(path, &src)
        .unwrap()
        .to_model(&kin, path, &src)
        .unwrap();
    let out = simulate::run(&plan, &truth, &SimOptions::default()).unwrap();
    Inputs::from_points(plan, out.points, Path::new("probe.csv")).unwrap()
}

criterion_group!(benches, bench);
criterion_main!(benches);
