//! The whole `fivecal demo` (plan, simulate, analyze, discover, compensate
//! on `bc-trunnion`), which issue 9 wants under 60 s in release mode on a
//! 2-core machine; ten runs, the least criterion takes.

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use fivecal::demo::{self, DemoConfig};

fn whole_demo(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let cfg = DemoConfig {
        out: dir.path().join("fivecal-demo"),
        seed: 1,
    };
    let mut g = c.benchmark_group("demo");
    g.sample_size(10).measurement_time(Duration::from_secs(60));
    g.bench_function("bc-trunnion stepped-square end to end", |b| {
        b.iter(|| black_box(demo::run(&cfg, &mut |_| {}).unwrap()))
    });
    g.finish();
}

criterion_group!(benches, whole_demo);
criterion_main!(benches);
