//! Speed of the Monte-Carlo study of `analyze --mc` on the demo's stepped
//! square (`bc-trunnion`, Ibaraki & Ota 2014, table 4 contributors): the whole
//! analysis with 1000 and 10,000 linearized runs (the targets: under
//! 1 s and 5 s on two cores), and with 10 runs of the exact study
//! (`--mc-exact`, every run simulated and fitted) for the cost per run it
//! replaces.

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use fivecal::analyze::{self, ContributorChoice, McOptions, MonteCarlo, Request};
use fivecal::demo::{self, DemoConfig};

fn request(dir: &std::path::Path, runs: usize, exact: bool) -> Request {
    let mut r = Request::new(
        &dir.join("plan/stepped-square.plan.yaml"),
        vec![dir.join("measured.dmo")],
    );
    r.contributors = ContributorChoice::TestDefault;
    r.monte_carlo = Some(MonteCarlo {
        options: McOptions {
            runs,
            seed: 1,
            progress: false,
            max_seconds: None,
        },
        exact,
    });
    r
}

fn bench(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("fivecal-demo");
    demo::run(
        &DemoConfig {
            out: out.clone(),
            seed: 1,
        },
        &mut |_| {},
    )
    .unwrap();
    let mut g = c.benchmark_group("analyze --mc, stepped square");
    g.sample_size(10).measurement_time(Duration::from_secs(20));
    for (name, runs, exact) in [
        ("1000 runs", 1000, false),
        ("10000 runs", 10_000, false),
        ("10 runs --mc-exact", 10, true),
    ] {
        let req = request(&out, runs, exact);
        g.bench_function(name, |b| b.iter(|| black_box(analyze::run(&req).unwrap())));
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
