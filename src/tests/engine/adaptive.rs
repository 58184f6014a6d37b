//! Local error control (`simulate_adaptive`): an estimator that matches the true local
//! error, steps that land on the kinks and on t_end, second order in the tolerance,
//! stability at every ρ∞, recovery from Newton failures, and exact gradients on the
//! adapted grid.

use crate::{
    of_motion_on, simulate_adaptive, simulate_on, DynamicSettings, Error, Integrator, Memory,
    Method, Model, SolveError, StepControl, TimeGrid, Trajectory,
};

use super::common::*;
use super::sensitivity::{check, how, random_design, responses, DYNAMIC};

fn final_q(traj: &Trajectory) -> &[f64] {
    &traj.q[traj.q.len() - traj.n_q..]
}

fn max_difference(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

fn adaptive(arm: &Model, x: f64, s: &DynamicSettings, tol: f64) -> Trajectory {
    let x = vec![x; arm.n_variables()];
    simulate_adaptive(arm, Some(&x), s, &StepControl::new(tol, s.h)).unwrap()
}

/// One step of size `h` from the state a run of steps `h` reached at t = 0.52 s, against
/// 64 steps of `h/64` from the same state: the estimate `(β − γ/2 + 1/12) h² (q̈ₙ₊₁ − q̈ₙ)`
/// over the true local error of the positions tends to 1 as h → 0 (max norm).
#[test]
fn the_local_error_estimate_is_asymptotically_correct() {
    let arm = robot_arm(1, 70e9);
    let x = vec![0.4; arm.n_variables()];
    let mut ratios = Vec::new();
    for h in [0.04, 0.02, 0.01, 0.005] {
        let s = settings(1.3, h, 0.8);
        let mut it = Integrator::new(&arm, arm.densities(Some(&x)).unwrap(), &s).unwrap();
        let mut state = it.initial_state().unwrap();
        while state.t < 0.52 - 1e-9 {
            it.alpha_step(&mut state, h).unwrap();
        }
        let (mut one, mut many) = (state.clone(), state.clone());
        it.alpha_step(&mut one, h).unwrap();
        for _ in 0..64 {
            it.alpha_step(&mut many, h / 64.0).unwrap();
        }
        let p = it.params;
        let c = p.beta - 0.5 * p.gamma + 1.0 / 12.0;
        let estimate: Vec<f64> = one
            .qddot
            .iter()
            .zip(&state.qddot)
            .map(|(a, b)| c * h * h * (a - b))
            .collect();
        let truth: Vec<f64> = one.q.iter().zip(&many.q).map(|(a, b)| a - b).collect();
        let norm = |v: &[f64]| v.iter().step_by(3).fold(0.0f64, |m, e| m.max(e.abs()));
        ratios.push(norm(&estimate) / norm(&truth));
    }
    let last = ratios[ratios.len() - 1];
    assert!(
        (last - 1.0).abs() < 0.25,
        "estimate / true local error: {ratios:?}"
    );
    assert!(
        (ratios[0] - 1.0).abs() > 2.0 * (last - 1.0).abs(),
        "the ratio approaches 1 as h falls: {ratios:?}"
    );
}

/// Steps end exactly (to round-off) at each kink of the drives and at t_end.
#[test]
fn steps_land_on_the_kinks_and_on_t_end() {
    let arm = robot_arm(1, 70e9);
    let s = settings(1.3, 0.02, 0.8);
    let traj = adaptive(&arm, 0.4, &s, 1e-4);
    let mut stops = arm.kinks(1.3);
    stops.push(1.3);
    assert!(stops.len() >= 3, "the arm's trapezoidal laws have kinks");
    for stop in stops {
        let nearest = traj
            .time
            .iter()
            .map(|t| (t - stop).abs())
            .fold(f64::INFINITY, f64::min);
        assert!(
            nearest <= 1e-12,
            "no step ends at {stop} (nearest {nearest:e})"
        );
    }
    assert!((traj.time[traj.time.len() - 1] - 1.3).abs() <= 1e-12);
    assert_eq!(
        traj.grid().times(),
        traj.time.as_slice(),
        "the recorded steps replay the times bitwise"
    );
}

/// Dividing the tolerance by 8 divides the error of the final state by about 4 (global
/// error ∝ tol^(2/3) for a second-order method with local error control) and doubles
/// the steps, at x = 0.4 and at full density (measured ratios 3.2–4.5 and 1.9–2.2).
#[test]
fn the_error_is_second_order_in_the_tolerance() {
    let arm = robot_arm(1, 70e9);
    let s = settings(1.3, 0.02, 0.8);
    for x in [0.4, 1.0] {
        let xs = vec![x; arm.n_variables()];
        let reference =
            simulate_on(&arm, Some(&xs), &s, &TimeGrid::uniform(1.3 / 4160.0, 4160)).unwrap();
        let runs: Vec<Trajectory> = [1.25e-5, 1.5625e-6, 1.953125e-7]
            .iter()
            .map(|&tol| adaptive(&arm, x, &s, tol))
            .collect();
        let errors: Vec<f64> = runs
            .iter()
            .map(|t| max_difference(final_q(t), final_q(&reference)))
            .collect();
        for (pair, runs) in errors.windows(2).zip(runs.windows(2)) {
            let (ratio, steps) = (
                pair[0] / pair[1],
                runs[1].steps.len() as f64 / runs[0].steps.len() as f64,
            );
            assert!(ratio > 2.5 && ratio < 6.5, "x = {x}: errors {errors:?}");
            assert!(steps > 1.6 && steps < 2.6, "x = {x}: steps grow by {steps}");
        }
    }
}

/// Five seconds of motion and free vibration of the full-density arm, whose steps change
/// at every kink and wherever the controller decides: finite, and the strain energy after
/// the motion does not grow, for every ρ∞; without dissipation (ρ∞ = 1) the mechanical
/// energy balance holds within 1 % of the energy the drives put in.
#[test]
fn adaptive_runs_are_stable_for_every_rho() {
    let arm = robot_arm(1, 70e9);
    for rho in [0.0, 0.5, 0.8, 1.0] {
        let traj = adaptive(&arm, 1.0, &settings(5.0, 0.02, rho), 1e-6);
        assert!(
            traj.q.iter().chain(&traj.lam).all(|v| v.is_finite()),
            "ρ∞ = {rho}"
        );
        let peak = |from: f64, to: f64| {
            traj.time
                .iter()
                .zip(&traj.strain)
                .filter(|(t, _)| **t >= from && **t <= to)
                .fold(0.0f64, |m, (_, u)| m.max(*u))
        };
        let (early, late) = (peak(1.3, 2.0), peak(4.3, 5.0));
        assert!(
            late <= 1.05 * early,
            "ρ∞ = {rho}: strain energy peak grew from {early:.3e} to {late:.3e} J"
        );
        if rho == 1.0 {
            let n = traj.time.len() - 1;
            let balance =
                traj.kinetic[n] + traj.strain[n] - traj.drive_work[n] - traj.external_work[n];
            let scale = traj.drive_work.iter().fold(0.0f64, |m, w| m.max(w.abs()));
            assert!(
                balance.abs() <= 0.01 * scale,
                "energy balance {balance:.3e} of {scale:.3e} J"
            );
        }
    }
}

/// A first step too large for Newton (three iterations allowed, the fixed-step run at that
/// size fails) is cut and the run goes on; a tolerance that cannot be met ends with a
/// named error.
#[test]
fn newton_failures_shrink_the_step_and_an_impossible_tolerance_is_named() {
    let arm = robot_arm(1, 70e9);
    let x = vec![1.0; arm.n_variables()];
    let s = DynamicSettings {
        max_iter: 3,
        ..settings(1.3, 0.325, 0.8)
    };
    let fixed = simulate_on(&arm, Some(&x), &s, &TimeGrid::uniform(0.325, 4));
    assert!(
        matches!(fixed, Err(Error::Solve(SolveError::NewtonFailed { .. }))),
        "{fixed:?}"
    );
    let traj = simulate_adaptive(&arm, Some(&x), &s, &StepControl::new(1e-3, 0.325)).unwrap();
    assert!(traj.steps[1] < 0.325 && (traj.time[traj.time.len() - 1] - 1.3).abs() < 1e-12);
    let impossible = StepControl {
        h_min: 1e-4,
        ..StepControl::new(1e-14, 0.02)
    };
    let failed = simulate_adaptive(&arm, Some(&x), &settings(1.3, 0.02, 0.8), &impossible);
    assert!(
        matches!(failed, Err(Error::Solve(SolveError::StepTooSmall { .. }))),
        "{failed:?}"
    );
    let bad = simulate_adaptive(&arm, Some(&x), &s, &StepControl::new(0.0, 0.02));
    assert!(
        matches!(&bad, Err(Error::Settings(e)) if e.name == "local_tol"),
        "{bad:?}"
    );
}

/// The grid the controller chose, frozen: direct and adjoint gradients agree and match
/// finite differences of the same scheme on that grid.
#[test]
fn gradients_on_the_adapted_grid_are_exact() {
    let arm = robot_arm(1, 70e9);
    let rs = responses(&arm, &DYNAMIC);
    let x = random_design(&arm, 7);
    let s = DynamicSettings {
        tol: 1e-12,
        ..settings(1.3, 0.02, 0.8)
    };
    let grid = simulate_adaptive(&arm, Some(&x), &s, &StepControl::new(1e-4, 0.02))
        .unwrap()
        .grid();
    assert!(
        grid.steps().windows(2).any(|w| w[0] != w[1]),
        "the steps vary"
    );
    let eval =
        |x: &[f64], m: Method| of_motion_on(&arm, x, &s, &grid, &rs, &[], how(m, Memory::StoreAll));
    check(&arm, &eval, &x, &[0, 74, 147], rs.len());
}
