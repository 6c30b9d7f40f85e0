//! Speed of the kinematic core: forward kinematics, the full Jacobian, and
//! inverse kinematics nominal and with location errors.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use fivecal::kinematics::{Kinematics, Perturbation};
use fivecal::{Axes, Machine};

fn errors() -> Perturbation {
    let mut p = Perturbation::zero();
    for (i, v) in p.0.iter_mut().take(12).enumerate() {
        *v = if i % 6 < 3 {
            0.03 * (i as f64 - 5.0) / 5.0
        } else {
            80e-6 * (i as f64 - 6.0) / 6.0
        };
    }
    p
}

fn bench(c: &mut Criterion) {
    let m = Machine::builtin("bc-trunnion").unwrap();
    let k = Kinematics::new(&m);
    let p = errors();
    let a = Axes::new(35.0, -20.0, 40.0, 37.5, 123.0);
    let target = k.forward(&a, &p);
    let hint = Axes {
        tilt: 36.0,
        c: 120.0,
        ..a
    };
    c.bench_function("forward with errors", |b| {
        b.iter(|| k.forward(black_box(&a), black_box(&p)))
    });
    c.bench_function("jacobian (29 variables)", |b| {
        b.iter(|| k.jacobian(black_box(&a), black_box(&p)))
    });
    c.bench_function("inverse nominal", |b| {
        b.iter(|| k.inverse_nominal(black_box(&target), Some(&hint)).unwrap())
    });
    c.bench_function("inverse with location errors", |b| {
        b.iter(|| k.inverse(black_box(&target), Some(&hint), |_| p).unwrap())
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
