//! Cost of gradients: one run with gradients divided by one plain run, adjoint and direct,
//! for the robot arm on ground structures from 5 × 3 (148 design variables) to 21 × 5.
//! Prints a Markdown table. The adjoint ratio should stay flat; the direct one grows with n.
//!
//! `cargo bench --features bench --bench sensitivity`

mod common;

use std::time::Instant;

use common::{median, robot_arm, settings};
use flextop::{of_motion, parse_responses, simulate, Memory, Method, SensitivitySettings};

fn time<F: FnMut()>(repeats: usize, mut f: F) -> f64 {
    let mut t: Vec<f64> = (0..repeats)
        .map(|_| {
            let start = Instant::now();
            f();
            start.elapsed().as_secs_f64()
        })
        .collect();
    median(&mut t)
}

fn main() {
    if std::env::args().any(|a| a == "--list") {
        return;
    }
    println!("Robot arm, x = 0.4, h = 0.02 s, responses: tip_deflection, compliance ({} rayon threads)\n", rayon::current_num_threads());
    println!("| grid | n (design variables) | DOFs | plain run (ms) | adjoint (ms) | adjoint / plain | direct (ms) | direct / plain |");
    println!("|---|---|---|---|---|---|---|---|");
    for (nx, ny) in [(5, 3), (7, 3), (9, 3), (9, 5), (13, 5), (17, 5), (21, 5)] {
        let arm = robot_arm(nx, ny, 1);
        let s = settings(0.02);
        let x = vec![0.4; arm.n_variables()];
        let names = ["tip_deflection".to_string(), "compliance".to_string()];
        let responses = parse_responses(&arm, &names).unwrap();
        let repeats = if arm.n_variables() < 1000 { 5 } else { 2 };
        let plain = time(repeats, || drop(simulate(&arm, Some(&x), &s).unwrap()));
        let adjoint = time(repeats, || {
            let how = SensitivitySettings {
                method: Method::Adjoint,
                memory: Memory::StoreAll,
            };
            drop(of_motion(&arm, &x, &s, &responses, &[], how).unwrap())
        });
        let direct = time(1, || {
            let how = SensitivitySettings {
                method: Method::Direct,
                memory: Memory::StoreAll,
            };
            drop(of_motion(&arm, &x, &s, &responses, &[], how).unwrap())
        });
        println!(
            "| {nx} × {ny} | {} | {} | {:.1} | {:.1} | {:.2} | {:.0} | {:.1} |",
            arm.n_variables(),
            arm.n_dofs() + arm.n_constraints(),
            1e3 * plain,
            1e3 * adjoint,
            adjoint / plain,
            1e3 * direct,
            direct / plain
        );
    }
}
