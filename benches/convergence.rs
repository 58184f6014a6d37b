//! Run time and mean squared tip deflection d of the reference robot arm (x = 0.4) against
//! the elements per bar m and the step size h, with errors against a converged reference.
//! Prints Markdown tables (one core: the solver runs sequentially).
//!
//! `cargo bench --features bench --bench convergence`

mod common;

use common::{robot_arm, settings, tip_deflection};

fn main() {
    if std::env::args().any(|a| a == "--list") {
        return; // `cargo bench --features bench -- --list` asks benchmarks for their names
    }
    // Reference: h → 0 at m = 16, then Richardson in m (d converges at second order in 1/m).
    let fine_h = 0.00125;
    let (d16, _) = tip_deflection(&robot_arm(5, 3, 16), 0.4, &settings(fine_h), 1);
    let (d8, _) = tip_deflection(&robot_arm(5, 3, 8), 0.4, &settings(fine_h), 1);
    let reference = d16 + (d16 - d8) / 3.0;
    println!("Converged reference d = {reference:.6e} m² (m = 8, 16 at h = {fine_h} s, Richardson in m)\n");

    println!("### Elements per bar m at h = 0.02 s\n");
    println!("| m | DOFs | run time (ms) | time per DOF-step (µs) | d (m²) | error vs converged |");
    println!("|---|---|---|---|---|---|");
    for m in [1, 2, 4, 8, 16] {
        let arm = robot_arm(5, 3, m);
        let (d, t) = tip_deflection(&arm, 0.4, &settings(0.02), if m <= 4 { 7 } else { 3 });
        let dofs = arm.n_dofs() + arm.n_constraints();
        println!(
            "| {m} | {dofs} | {:.1} | {:.3} | {d:.6e} | {:+.3} % |",
            1e3 * t,
            1e6 * t / (dofs as f64 * 65.0),
            100.0 * (d / reference - 1.0)
        );
    }

    println!("\n### Step size h at m = 1\n");
    println!("| h (s) | steps | run time (ms) | time per step (µs) | d (m²) | error vs converged | error vs m = 1, h → 0 |");
    println!("|---|---|---|---|---|---|---|");
    let arm = robot_arm(5, 3, 1);
    let (d_h0, _) = tip_deflection(&arm, 0.4, &settings(fine_h / 2.0), 1);
    for h in [0.04, 0.02, 0.01, 0.005, 0.0025] {
        let (d, t) = tip_deflection(&arm, 0.4, &settings(h), 7);
        let steps = (1.3 / h).round();
        println!(
            "| {h} | {steps} | {:.1} | {:.1} | {d:.6e} | {:+.3} % | {:+.4} % |",
            1e3 * t,
            1e6 * t / steps,
            100.0 * (d / reference - 1.0),
            100.0 * (d / d_h0 - 1.0)
        );
    }
}
