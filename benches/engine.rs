//! Criterion timings of the engine's hot path on the reference robot arm (x = 0.4, m = 1):
//! one generalized-α step in the middle of the manoeuvre, one full run at h = 0.02 s, and
//! one run with the adjoint gradients of four responses (every response family's partials
//! at every state).
//!
//! `cargo bench --features bench --bench engine`

mod common;

use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use flextop::{
    of_motion, parse_responses, simulate, Integrator, Memory, Method, SensitivitySettings,
};

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

fn adjoint_gradients(c: &mut Criterion) {
    let arm = common::robot_arm(5, 3, 1);
    let settings = common::settings(0.02);
    let x = vec![0.4; arm.n_variables()];
    let names = [
        "tip_deflection",
        "compliance",
        "stress:p=8",
        "torque:shoulder",
    ];
    let responses = parse_responses(&arm, &names.map(String::from)).unwrap();
    let how = SensitivitySettings {
        method: Method::Adjoint,
        memory: Memory::StoreAll,
    };
    c.bench_function(
        "robot arm adjoint gradients (4 responses, 148 variables)",
        |b| b.iter(|| of_motion(&arm, &x, &settings, &responses, &[], how).unwrap()),
    );
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(30);
    targets = alpha_step, robot_arm_run, adjoint_gradients
}
criterion_main!(benches);
