//! Variable steps: second order and stability where the step size changes abruptly, and
//! exact gradients on an uneven grid.

use crate::{of_motion_on, simulate_on, DynamicSettings, Memory, Method, Model, TimeGrid};

use super::common::*;
use super::sensitivity::{check, how, random_design, responses, DYNAMIC};

/// Steps in the ratios 1 : 2 : ½ : 1.5 (abrupt changes by factors up to 4), `n` per
/// segment between the stops (kinks of the motion law and `t_end`), each segment filled
/// exactly.
fn uneven_grid(stops: &[f64], n: usize) -> TimeGrid {
    let pattern = [1.0, 2.0, 0.5, 1.5];
    let mut steps = Vec::new();
    let mut start = 0.0;
    for &stop in stops {
        let w: Vec<f64> = (0..n).map(|k| pattern[k % 4]).collect();
        let total: f64 = w.iter().sum();
        steps.extend(w.iter().map(|wk| (stop - start) * wk / total));
        start = stop;
    }
    TimeGrid::from_steps(steps)
}

fn arm_stops(arm: &Model, t_end: f64) -> Vec<f64> {
    let mut stops = arm.kinks(t_end);
    stops.push(t_end);
    stops
}

/// Final coordinates of the arm at density 0.4 on `grid`.
fn final_state(arm: &Model, s: &DynamicSettings, grid: &TimeGrid) -> Vec<f64> {
    let x = vec![0.4; arm.n_variables()];
    let traj = simulate_on(arm, Some(&x), s, grid).unwrap();
    traj.q[traj.q.len() - traj.n_q..].to_vec()
}

fn max_difference(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

/// Halving every step of a grid whose steps change abruptly (ratios 2, ¼, 3) divides the
/// error by 4: carrying `a` to each new step keeps the scheme second order (measured
/// ratios 3.6 for ρ∞ = 0, still approaching 4, and 4.0 for ρ∞ = 0.8).
#[test]
fn uneven_steps_stay_second_order_for_every_rho() {
    let arm = robot_arm(1, 70e9);
    let t_end = 1.3;
    let stops = arm_stops(&arm, t_end);
    for rho in [0.0, 0.5, 0.8, 1.0] {
        let s = settings(t_end, 0.02, rho);
        let reference = final_state(&arm, &s, &uneven_grid(&stops, 2048));
        let errors: Vec<f64> = [128, 256]
            .iter()
            .map(|&n| max_difference(&final_state(&arm, &s, &uneven_grid(&stops, n)), &reference))
            .collect();
        for pair in errors.windows(2) {
            let ratio = pair[0] / pair[1];
            assert!(
                ratio > 3.4 && ratio < 4.6,
                "ρ∞ = {rho}: errors {errors:?} halve steps by {ratio:.2}, not 4"
            );
        }
    }
}

/// 20 s of motion and free vibration on steps alternating between 10 and 20 ms stay finite
/// with bounded strain energy for ρ∞ < 1. Measured limits, for the adaptive stepping to
/// respect: without numerical dissipation (ρ∞ = 1) this sustained twofold alternation
/// fails near t = 6 s, and a fivefold one fails for every ρ∞ < 1 within the first second.
#[test]
fn alternating_twofold_step_changes_stay_bounded_with_dissipation() {
    let arm = robot_arm(1, 70e9);
    let steps: Vec<f64> = (0..1333)
        .map(|k| if k % 2 == 0 { 0.01 } else { 0.02 })
        .collect();
    let grid = TimeGrid::from_steps(steps);
    let x = vec![0.4; arm.n_variables()];
    for rho in [0.0, 0.5, 0.8] {
        let traj = simulate_on(&arm, Some(&x), &settings(20.0, 0.02, rho), &grid).unwrap();
        let n = traj.time.len();
        let peak = |r: std::ops::Range<usize>| traj.strain[r].iter().fold(0.0f64, |m, v| m.max(*v));
        let (early, late) = (peak(150..350), peak(n - 200..n));
        assert!(
            traj.q.iter().all(|v| v.is_finite()) && late <= 1.05 * early,
            "ρ∞ = {rho}: strain energy grew from {early:.3e} to {late:.3e} J"
        );
    }
}

/// Direct and adjoint agree, and match finite differences of the same discrete scheme, on
/// a grid whose steps change at every step.
#[test]
fn gradients_on_an_uneven_grid_are_exact() {
    let arm = robot_arm(1, 70e9);
    let rs = responses(&arm, &DYNAMIC);
    let x = random_design(&arm, 5);
    let s = DynamicSettings {
        tol: 1e-12,
        ..settings(1.3, 0.02, 0.8)
    };
    let grid = uneven_grid(&arm_stops(&arm, 1.3), 16);
    let eval = |x: &[f64], m: Method| {
        of_motion_on(&arm, x, &s, &grid, &rs, &[], how(m, Memory::Checkpoints))
    };
    check(&arm, &eval, &x, &[0, 74, 147], rs.len());
}
