//! Dynamic benchmarks: convergence order, energy, numerical dissipation, rigid limit.

use crate::{simulate, DynamicSettings, MassKind, Model, Trajectory};
use nalgebra::{DMatrix, DVector, SymmetricEigen};

use super::common::*;

/// Largest tip distance between two robot-arm runs at the times of the coarser one.
fn tip_gap(model: &Model, coarse: &Trajectory, fine: &Trajectory) -> f64 {
    let tip = model.tip.unwrap();
    let ratio = (fine.time.len() - 1) / (coarse.time.len() - 1);
    (0..coarse.time.len())
        .map(|k| {
            let (a, b) = (
                position(model, coarse, tip, k),
                position(model, fine, tip, k * ratio),
            );
            ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt()
        })
        .fold(0.0, f64::max)
}

#[test]
fn robot_arm_positions_converge_at_second_order_in_time() {
    let arm = robot_arm(1, 70e9);
    let x = vec![0.4; arm.n_variables()];
    let run = |h: f64| simulate(&arm, Some(&x), &settings(1.3, h, 0.8)).unwrap();
    let reference = run(0.3125e-3);
    let hs = [0.02, 0.01, 0.005, 0.0025];
    let errors: Vec<f64> = hs
        .iter()
        .map(|&h| tip_gap(&arm, &run(h), &reference))
        .collect();
    let order = log_slope(&hs, &errors);
    assert!(
        order > 1.85 && order < 2.3,
        "order {order:.2}, errors {errors:?}"
    );
}

#[test]
fn drive_work_balances_the_mechanical_energy() {
    // T + U − W_d = 0 for the exact solution; the discrete balance closes at second order.
    let arm = robot_arm(1, 70e9);
    let x = vec![0.4; arm.n_variables()];
    let gaps: Vec<f64> = [0.02, 0.01, 0.005]
        .iter()
        .map(|&h| {
            let t = simulate(&arm, Some(&x), &settings(1.3, h, 0.8)).unwrap();
            let n = t.time.len() - 1;
            (t.kinetic[n] + t.strain[n] - t.drive_work[n]).abs()
        })
        .collect();
    assert!(
        gaps[0] / gaps[1] > 3.0 && gaps[1] / gaps[2] > 3.0,
        "{gaps:?}"
    );
}

#[test]
fn a_very_stiff_arm_follows_the_rigid_kinematics() {
    let errors: Vec<f64> = [1e4, 1e5, 1e6]
        .iter()
        .map(|&k| {
            let arm = robot_arm(1, 70e9 * k);
            let traj = simulate(&arm, None, &settings(1.3, 0.02, 0.8)).unwrap();
            (0..traj.time.len())
                .map(|n| {
                    let (r, rr) = (
                        position(&arm, &traj, arm.tip.unwrap(), n),
                        rigid_tip(traj.time[n]),
                    );
                    ((r[0] - rr[0]).powi(2) + (r[1] - rr[1]).powi(2)).sqrt()
                })
                .fold(0.0, f64::max)
        })
        .collect();
    // Past the dynamic range (ωh ≫ 1) the deflection is quasi-static, ∝ 1/E, and vanishes.
    for w in errors.windows(2) {
        assert!((w[0] / w[1] / 10.0 - 1.0).abs() < 0.05, "{errors:?}");
    }
    assert!(errors[2] < 2e-8, "{errors:?}");
}

/// A free flexible pendulum (two hinged beams, pinned to the ground) kicked by a load pulse.
fn kicked_pendulum() -> Model {
    model(&format!(
        "{ALUMINIUM}\
         [[nodes]]\nname = \"o\"\nx = 0.0\ny = 0.0\n[[nodes]]\nname = \"e1\"\nx = 0.6\ny = 0.0\n\
         [[nodes]]\nname = \"e2\"\nx = 0.6\ny = 0.0\n[[nodes]]\nname = \"t\"\nx = 1.0\ny = 0.3\n\
         [[beams]]\nnodes = [\"o\", \"e1\"]\nsection = \"al\"\nsplit = 4\n\
         [[beams]]\nnodes = [\"e2\", \"t\"]\nsection = \"al\"\nsplit = 4\n\
         [[point_masses]]\nnode = \"t\"\nmass = 0.5\n\
         [[joints]]\nkind = \"pin\"\nname = \"ground\"\nnode = \"o\"\n\
         [[joints]]\nkind = \"hinge\"\nname = \"knee\"\nnodes = [\"e1\", \"e2\"]\n\
         [[loads]]\nnode = \"t\"\nforce = [0.0, 400.0]\ntable = {{ t = [0.0, 0.01, 0.02], scale = [0.0, 1.0, 0.0] }}\n"
    ))
}

#[test]
fn rho_inf_one_conserves_the_energy_of_a_free_mechanism() {
    let model = kicked_pendulum();
    let h = 1e-3;
    let traj = simulate(&model, None, &settings(1.02, h, 1.0)).unwrap();
    assert_eq!(traj.time.len(), 1021);
    let start = (0.02 / h) as usize; // the pulse is over: free motion from here on
    let energy: Vec<f64> = (start..traj.time.len())
        .map(|k| traj.kinetic[k] + traj.strain[k])
        .collect();
    let e0 = energy[0];
    let drift = energy.iter().map(|e| (e - e0).abs()).fold(0.0, f64::max) / e0;
    assert!(e0 > 1.0, "the kick puts energy in: {e0}");
    assert!(
        drift < 2e-3,
        "relative energy drift over 1000 steps: {drift:.2e}"
    );
    // The pendulum really moves: a large rigid rotation happens during the run.
    let tip = model.node_index("t").unwrap();
    let travel = (position(&model, &traj, tip, traj.time.len() - 1)[1] - 0.3).abs();
    assert!(travel > 0.1, "tip travel {travel}");
}

#[test]
fn numerical_dissipation_acts_on_high_frequencies_only() {
    // A small-amplitude cantilever: modes from its linearized M and K (clamped DOFs removed).
    let text = cantilever(1.0, 8, "[[loads]]\nnode = \"b\"\nforce = [300.0, 5.0]\nmoment = 1.0\ntable = { t = [0.0, 0.002, 0.004], scale = [0.0, 1.0, 0.0] }\n");
    let model = model(&text);
    let n = model.n_dofs();
    let lin = crate::linearize(
        &model,
        model.densities(None).unwrap(),
        MassKind::Consistent,
        &vec![0.0; n],
    )
    .unwrap();
    let dense = |m: &crate::Csc| {
        let mut d = DMatrix::zeros(n, n);
        for j in 0..n {
            for k in m.indptr[j]..m.indptr[j + 1] {
                d[(m.indices[k], j)] = m.data[k];
            }
        }
        d.remove_rows(0, 3).remove_columns(0, 3)
    };
    let mass = dense(&lin.mass);
    let stiffness = dense(&lin.stiffness);
    let l_inv = mass.clone().cholesky().unwrap().l().try_inverse().unwrap();
    let eig = SymmetricEigen::new(&l_inv * &stiffness * l_inv.transpose());
    let order: Vec<usize> = {
        let mut o: Vec<usize> = (0..eig.eigenvalues.len()).collect();
        o.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
        o
    };
    let modes = l_inv.transpose() * eig.eigenvectors.select_columns(&order);
    let omega = DVector::from_iterator(
        order.len(),
        order.iter().map(|&i| eig.eigenvalues[i].sqrt()),
    );
    let h = 2e-3;
    let (lowest, highest) = (0, order.len() - 1);
    let period = 2.0 * std::f64::consts::PI / omega[lowest];
    assert!(
        omega[lowest] * h < 0.2 && omega[highest] * h > 50.0,
        "ωh spans {:.2}..{:.0}",
        omega[lowest] * h,
        omega[highest] * h
    );
    // Modal amplitudes after an impulse (the load acts at step 1 only). The lowest mode
    // is tracked by its displacement over eight periods; the highest (ωh ≈ 280) by its
    // velocity, since at ωh ≫ 1 a stiff mode's displacement is slaved to the current load.
    let amplitudes = |rho: f64| {
        let steps = (8.0 * period / h).round() as usize + 2;
        let traj = simulate(
            &model,
            None,
            &DynamicSettings {
                t_end: steps as f64 * h,
                h,
                rho_inf: rho,
                tol: 1e-12,
                ..settings(1.0, h, rho)
            },
        )
        .unwrap();
        let modal = |data: &[f64], mode: usize, k: usize| {
            let y = DVector::from_column_slice(&data[k * n + 3..(k + 1) * n]);
            (modes.column(mode).transpose() * &mass * y)[0].abs()
        };
        let window = |data: &[f64], mode: usize, from: usize, to: usize| {
            (from..to).map(|k| modal(data, mode, k)).fold(0.0, f64::max)
        };
        let per = (period / h).ceil() as usize;
        let low = window(&traj.q, lowest, steps + 1 - per, steps + 1)
            / window(&traj.q, lowest, 2, 2 + per);
        let start = window(&traj.qdot, highest, 2, 6);
        (
            low,
            window(&traj.qdot, highest, 8, 12) / start,
            window(&traj.qdot, highest, 100, 104) / start,
        )
    };
    let (low1, _, _) = amplitudes(1.0);
    assert!(
        (low1 - 1.0).abs() < 2e-3,
        "ρ∞ = 1 keeps the lowest mode: {low1}"
    );
    let mut previous_early = f64::INFINITY;
    for rho in [0.8, 0.5, 0.0] {
        let (low, early, late) = amplitudes(rho);
        // The highest mode dies out, the faster the smaller ρ∞ (ρ∞ = 0 annihilates it in
        // a few steps); after 100 steps it is gone for every ρ∞ < 1.
        assert!(
            early < previous_early,
            "ρ∞ = {rho}: smaller ρ∞ damps faster ({early:.2e} after 6 steps)"
        );
        assert!(
            late < 1e-3,
            "ρ∞ = {rho}: highest mode kept {late:.2e} after 100 steps"
        );
        previous_early = early;
        // The lowest mode (ωh = 0.18) loses little over eight periods: < 1 % for ρ∞ ≥ 0.5.
        let allowed = if rho >= 0.5 { 0.01 } else { 0.15 };
        assert!(
            1.0 - low < allowed,
            "ρ∞ = {rho}: lowest mode kept {low:.4} over eight periods"
        );
    }
    assert!(
        previous_early < 1e-6,
        "ρ∞ = 0 annihilates the highest mode: {previous_early:.2e}"
    );
}
