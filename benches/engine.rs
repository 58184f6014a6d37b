//! Criterion timings of the engine's hot path on the reference robot arm (x = 0.4, m = 1):
//! one generalized-α step in the middle of the manoeuvre, and one full run at h = 0.02 s.
//!
//! `cargo bench --bench engine`

mod common;

use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use flextop::{simulate, Integrator};

fn alpha_step(c: &mut Criterion) {
    let arm = common::robot_arm(5, 3, 1);
    let settings = common::settings(0.02);
    let x = vec![0.4; arm.n_variables()];
    let mut integrator =
        Integrator::new(&arm, arm.densities(Some(&x)).unwrap(), &settings).unwrap();
    let mut state = integrator.initial_state().unwrap();
    for _ in 0..30 {
        integrator.alpha_step(&mut state, settings.h).unwrap();
    }
    c.bench_function("alpha_step (robot arm, 96 unknowns, t = 0.6 s)", |b| {
        b.iter_batched_ref(
            || state.clone(),
            |s| integrator.alpha_step(s, settings.h).unwrap(),
            BatchSize::SmallInput,
        )
    });
}

fn robot_arm_run(c: &mut Criterion) {
    let arm = common::robot_arm(5, 3, 1);
    let settings = common::settings(0.02);
    let x = vec![0.4; arm.n_variables()];
    c.bench_function("robot arm run (m = 1, h = 0.02 s, 65 steps)", |b| {
        b.iter(|| simulate(&arm, Some(&x), &settings).unwrap())
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(30);
    targets = alpha_step, robot_arm_run
}
criterion_main!(benches);
