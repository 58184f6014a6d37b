//! Scenes and measurements shared by the benchmarks.
#![allow(dead_code)]

use std::time::Instant;

use flextop::scene;
use flextop::{evaluate, parse_responses, simulate, DynamicSettings, MassKind, Model};

/// The reference robot arm (examples/robot_arm.toml) with an `nx × ny` grid per link and
/// `split` elements per bar; the joints and tip move to the middle row.
pub fn robot_arm(nx: usize, ny: usize, split: usize) -> Model {
    let mid = ny / 2;
    let text = include_str!("../../examples/robot_arm.toml")
        .replace("nx = 5", &format!("nx = {nx}"))
        .replace("ny = 3", &format!("ny = {ny}"))
        .replace("split = 1", &format!("split = {split}"))
        .replace("link2[4,1]", &format!("link2[{},{mid}]", nx - 1))
        .replace("link1[4,1]", &format!("link1[{},{mid}]", nx - 1))
        .replace("link1[0,1]", &format!("link1[0,{mid}]"))
        .replace("link2[0,1]", &format!("link2[0,{mid}]"));
    scene::build(&scene::parse_toml(&text).expect("valid TOML")).expect("valid scene")
}

/// Reference settings: t ∈ [0, 1.3] s, ρ∞ = 0.8, Newton tolerance 1e-10.
pub fn settings(h: f64) -> DynamicSettings {
    DynamicSettings {
        t_end: 1.3,
        h,
        rho_inf: 0.8,
        tol: 1e-10,
        max_iter: 30,
        mass: MassKind::Consistent,
    }
}

/// Mean squared tip deflection d of a run of `model` at uniform density `x`, and the
/// median wall time (s) of `repeats` runs.
pub fn tip_deflection(
    model: &Model,
    x: f64,
    settings: &DynamicSettings,
    repeats: usize,
) -> (f64, f64) {
    let design = vec![x; model.n_variables()];
    let responses = parse_responses(model, &["tip_deflection".to_string()]).unwrap();
    let mut times = Vec::new();
    let mut d = 0.0;
    for _ in 0..repeats {
        let start = Instant::now();
        let traj = simulate(model, Some(&design), settings).unwrap();
        times.push(start.elapsed().as_secs_f64());
        d = evaluate(model, Some(&design), &traj.q, &traj.time, 0.0, &responses).unwrap()[0];
    }
    (d, median(&mut times))
}

/// Median of a sample.
pub fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}
