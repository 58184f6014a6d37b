//! The Newton tangent is the exact derivative of the residual.

use flextop::assembly::Assembler;
use flextop::element::MassKind;

use crate::common::*;

/// A deterministic pseudo-random sequence in [−1, 1].
fn noise(seed: u64) -> impl FnMut() -> f64 {
    let mut s = seed;
    move || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    }
}

#[test]
fn iteration_matrix_equals_central_differences_of_the_residual() {
    let arm = robot_arm(2, 70e9);
    let x: Vec<f64> = (0..arm.n_variables())
        .map(|i| 0.05 + 0.9 * ((i * 37 % 101) as f64 / 101.0))
        .collect();
    let asm = Assembler::new(&arm, arm.densities(Some(&x)).unwrap(), MassKind::Consistent);
    let n = arm.n_dofs();
    let beta_prime = 4.0e3;
    for seed in 1..4 {
        let mut rnd = noise(seed);
        // A large rigid rotation of everything plus random deformation.
        let angle = 1.3 * rnd();
        let q: Vec<f64> = (0..n)
            .map(|d| {
                let p = arm.nodes[d / 3].position;
                let rigid = [
                    p.x * (angle.cos() - 1.0) - p.y * angle.sin(),
                    p.x * angle.sin() + p.y * (angle.cos() - 1.0),
                    angle,
                ][d % 3];
                rigid + 2e-3 * rnd()
            })
            .collect();
        let acc0: Vec<f64> = (0..n).map(|_| rnd()).collect();
        // Step residual as a function of q: r = M q̈(q) + f_int(q), q̈ = q̈₀ + β'(q − q₀).
        let residual = |qq: &[f64]| {
            let acc: Vec<f64> = (0..n)
                .map(|i| acc0[i] + beta_prime * (qq[i] - q[i]))
                .collect();
            let (mut inertia, mut f) = (vec![0.0; n], vec![0.0; n]);
            asm.mass_times(&acc, &mut inertia);
            asm.internal_forces(qq, &mut f, None);
            inertia
                .iter()
                .zip(&f)
                .map(|(a, b)| a + b)
                .collect::<Vec<f64>>()
        };
        let mut values = vec![0.0; asm.pattern.nnz()];
        asm.start_iteration_matrix(beta_prime, 0.0, &mut values);
        asm.internal_forces(&q, &mut vec![0.0; n], Some(&mut values));
        let p = &asm.pattern;
        let scale = values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for j in (0..n).step_by(7) {
            let eps = 1e-7;
            let (mut qp, mut qm) = (q.clone(), q.clone());
            qp[j] += eps;
            qm[j] -= eps;
            let (rp, rm) = (residual(&qp), residual(&qm));
            let mut column = vec![0.0; n];
            for idx in p.col_ptr[j]..p.col_ptr[j + 1] {
                if p.row_idx[idx] < n {
                    column[p.row_idx[idx]] = values[idx];
                }
            }
            for i in 0..n {
                let fd = (rp[i] - rm[i]) / (2.0 * eps);
                assert!(
                    (fd - column[i]).abs() < 1e-6 * scale,
                    "S[{i},{j}] = {} vs {fd}",
                    column[i]
                );
            }
        }
    }
}
