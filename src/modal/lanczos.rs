//! The largest eigenpairs of a symmetric operator given only as `y = A x`: Lanczos cycles
//! with full reorthogonalization, explicit restarts and locking (Saad, *Numerical Methods
//! for Large Eigenvalue Problems*, §6.3 and §5.3).
//!
//! Each cycle builds an orthonormal Krylov basis `V` and the tridiagonal `T = VᵀAV`
//! (`α` on the diagonal, `β` beside it); a Ritz pair `(θ, V s)` of `T` has residual
//! `‖A V s − θ V s‖ = β_m |s_m|`. Pairs whose residual meets the tolerance are locked, and
//! later cycles are kept orthogonal to them; the next cycle starts from the sum of the
//! wanted Ritz vectors that have not converged, and a last, short cycle from a fresh vector
//! verifies that no larger eigenvalue was missed. Each new basis vector is orthogonalized
//! against the basis and the locked vectors, a second time when the first pass removed most
//! of it ("twice is enough"): a fixed limit of two passes.
//!
//! Why not faer's `matrix_free::eigen::partial_self_adjoint_eigen`: in faer 0.24.4 its
//! reorthogonalization repeats until a relative test passes, with no pass limit, and on
//! the clustered spectra of optimized frames measured here (identical void bars, modes
//! equal to nine digits) it never returned. A run must not hang, so the method is here,
//! short, with a bounded amount of work: [`MAX_CYCLES`] cycles of at most `m` steps.

use nalgebra::{DMatrix, SymmetricEigen};

/// Most Lanczos cycles before [`largest_eigenpairs`] reports what it has.
pub const MAX_CYCLES: usize = 200;

/// A second reorthogonalization pass follows when the first left less than this fraction
/// of the vector.
const DGKS: f64 = 0.7;

/// Steps of the verifying cycle that looks for an eigenvalue the others missed.
const VERIFY: usize = 20;

/// Below this size the operator is formed and decomposed densely.
const DENSE: usize = 64;

/// The `count` eigenpairs of largest magnitude of the symmetric `n × n` operator `apply`
/// (`apply(x, y)` sets `y = A x`), each with residual `‖A u − θ u‖ ≤ tol` and `|u| = 1`,
/// in descending magnitude; `seed` picks the start vectors. Fewer than `count` when
/// [`MAX_CYCLES`] did not suffice. One Krylov space holds one direction of each
/// eigenspace, so once `count` pairs are locked a short cycle from a fresh vector looks for
/// a larger one (a copy of a repeated eigenvalue); callers that must not miss one still
/// check with a count of their own (the modal analysis's Sturm count) and retry with
/// another `seed` and a larger `count`.
pub fn largest_eigenpairs(
    n: usize,
    count: usize,
    tol: f64,
    seed: usize,
    apply: &dyn Fn(&[f64], &mut [f64]),
) -> (Vec<f64>, Vec<Vec<f64>>) {
    let count = count.min(n);
    if n <= DENSE.max(3 * count) {
        return dense(n, count, apply);
    }
    let m = n.min((2 * count + 20).max(40));
    let mut locked: Vec<(f64, Vec<f64>)> = Vec::new();
    let mut restart = vec![0.0; n];
    for cycle in 0..MAX_CYCLES {
        // Wanted: the largest not locked; once `count` are, a short verifying cycle looks
        // for any larger one (a copy of a repeated eigenvalue the first cycles missed).
        let verifying = locked.len() >= count;
        let floor = if verifying {
            locked
                .iter()
                .map(|l| l.0.abs())
                .fold(f64::INFINITY, f64::min)
        } else {
            0.0
        };
        let (wanted, steps) = if verifying {
            (count, m.min(VERIFY))
        } else {
            (count - locked.len(), m)
        };
        let start = fresh(restart, seed * MAX_CYCLES + cycle);
        let Some(v0) = unit(orthogonal(start, &[], &locked)) else {
            break;
        };
        let (basis, alpha, beta) = cycle_basis(v0, steps, &locked, apply);
        let last = beta[beta.len() - 1];
        restart = vec![0.0; n];
        let mut open = false;
        for (theta, s) in tridiagonal_eigen(&alpha, &beta).into_iter().take(wanted) {
            if theta.abs() <= floor * (1.0 + 1e-9) {
                break;
            }
            let u = combine(&basis, &s);
            if last * s[s.len() - 1].abs() <= tol {
                locked.push((theta, u));
            } else {
                open = true;
                restart.iter_mut().zip(&u).for_each(|(r, x)| *r += x);
            }
        }
        locked.sort_by(|a, b| b.0.abs().total_cmp(&a.0.abs()));
        locked.truncate(count);
        if verifying && !open && locked.len() == count {
            break;
        }
    }
    locked.into_iter().unzip()
}

/// One Lanczos cycle of at most `steps` from the unit vector `v`, kept orthogonal to the
/// locked vectors: the basis, `α` and `β` (the last `β` the residual's norm). It stops
/// early when the Krylov space becomes invariant.
#[allow(clippy::type_complexity)]
fn cycle_basis(
    mut v: Vec<f64>,
    steps: usize,
    locked: &[(f64, Vec<f64>)],
    apply: &dyn Fn(&[f64], &mut [f64]),
) -> (Vec<Vec<f64>>, Vec<f64>, Vec<f64>) {
    let (mut basis, mut alpha, mut beta) = (Vec::with_capacity(steps), Vec::new(), Vec::new());
    let mut w = vec![0.0; v.len()];
    loop {
        apply(&v, &mut w);
        let a = dot(&v, &w);
        // The three-term recurrence, then a full reorthogonalization pass, and a second
        // one only when the first removed most of what was left (Daniel, Gragg, Kaufman
        // and Stewart's test): at most two passes.
        w.iter_mut().zip(&v).for_each(|(wi, vi)| *wi -= a * vi);
        if let (Some(previous), Some(&b)) = (basis.last(), beta.last()) {
            w.iter_mut()
                .zip(previous)
                .for_each(|(wi, pi): (&mut f64, &f64)| *wi -= b * pi);
        }
        alpha.push(a);
        basis.push(v);
        let before = norm(&w);
        w = orthogonal(w, &basis, locked);
        if norm(&w) < DGKS * before {
            w = orthogonal(w, &basis, locked);
        }
        let b = norm(&w);
        beta.push(b);
        if basis.len() == steps || b <= 1e-14 * a.abs().max(b) {
            return (basis, alpha, beta);
        }
        v = w.iter().map(|x| x / b).collect();
    }
}

/// The next cycle's start: the unconverged wanted Ritz vectors, or a fresh spread vector
/// when there are none (the first cycle, and the verifying ones: one Krylov space holds
/// only one direction of each eigenspace, so a fresh vector brings the other copies of a
/// repeated eigenvalue).
fn fresh(restart: Vec<f64>, cycle: usize) -> Vec<f64> {
    if norm(&restart) > 0.0 {
        return restart;
    }
    let n = restart.len();
    (0..n).map(|i| spread(cycle * n + i)).collect()
}

/// Eigenpairs of the tridiagonal with diagonal `alpha` and off-diagonal `beta[..k−1]`,
/// by descending magnitude.
fn tridiagonal_eigen(alpha: &[f64], beta: &[f64]) -> Vec<(f64, Vec<f64>)> {
    let k = alpha.len();
    let t = DMatrix::from_fn(k, k, |i, j| match i.abs_diff(j) {
        0 => alpha[i],
        1 => beta[i.min(j)],
        _ => 0.0,
    });
    let eig = SymmetricEigen::new(t);
    let mut pairs: Vec<(f64, Vec<f64>)> = (0..k)
        .map(|j| {
            (
                eig.eigenvalues[j],
                eig.eigenvectors.column(j).iter().copied().collect(),
            )
        })
        .collect();
    pairs.sort_by(|a, b| b.0.abs().total_cmp(&a.0.abs()));
    pairs
}

/// Small operators: formed column by column and decomposed densely.
fn dense(n: usize, count: usize, apply: &dyn Fn(&[f64], &mut [f64])) -> (Vec<f64>, Vec<Vec<f64>>) {
    let mut a = DMatrix::zeros(n, n);
    let (mut e, mut y) = (vec![0.0; n], vec![0.0; n]);
    for j in 0..n {
        e.fill(0.0);
        e[j] = 1.0;
        apply(&e, &mut y);
        a.column_mut(j)
            .iter_mut()
            .zip(&y)
            .for_each(|(c, v)| *c = *v);
    }
    let eig = SymmetricEigen::new((&a + a.transpose()) * 0.5);
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&i, &j| {
        eig.eigenvalues[j]
            .abs()
            .total_cmp(&eig.eigenvalues[i].abs())
    });
    order
        .into_iter()
        .take(count)
        .map(|j| {
            (
                eig.eigenvalues[j],
                eig.eigenvectors.column(j).iter().copied().collect(),
            )
        })
        .unzip()
}

/// `x` less its components along `basis` and the locked vectors (one classical
/// Gram–Schmidt pass).
fn orthogonal(mut x: Vec<f64>, basis: &[Vec<f64>], locked: &[(f64, Vec<f64>)]) -> Vec<f64> {
    for q in basis.iter().chain(locked.iter().map(|(_, u)| u)) {
        let c = dot(q, &x);
        x.iter_mut().zip(q).for_each(|(xi, qi)| *xi -= c * qi);
    }
    x
}

fn unit(x: Vec<f64>) -> Option<Vec<f64>> {
    let r = norm(&x);
    (r > 0.0 && r.is_finite()).then(|| x.iter().map(|v| v / r).collect())
}

fn combine(basis: &[Vec<f64>], s: &[f64]) -> Vec<f64> {
    let mut u = vec![0.0; basis[0].len()];
    for (v, c) in basis.iter().zip(s) {
        u.iter_mut().zip(v).for_each(|(ui, vi)| *ui += c * vi);
    }
    u
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn norm(a: &[f64]) -> f64 {
    dot(a, a).sqrt()
}

/// A fixed, well-spread value for index `k` (a hash in `[−½, ½)`): start vectors that no
/// mode is orthogonal to by a symmetry of the structure.
pub fn spread(k: usize) -> f64 {
    let mut h = (k as u64).wrapping_add(0x9E37_79B9_7F4A_7C15);
    h = (h ^ (h >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    h = (h ^ (h >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    h ^= h >> 31;
    (h >> 11) as f64 / (1u64 << 53) as f64 - 0.5
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A diagonal operator with a cluster of equal eigenvalues at the top: every pair
    /// found, residuals met.
    #[test]
    fn finds_a_cluster_of_equal_eigenvalues() {
        let n = 500;
        let d: Vec<f64> = (0..n)
            .map(|i| if i < 3 { 1.0 } else { 0.9 / (1.0 + i as f64) })
            .collect();
        let apply =
            |x: &[f64], y: &mut [f64]| y.iter_mut().enumerate().for_each(|(i, v)| *v = d[i] * x[i]);
        let (theta, u) = largest_eigenpairs(n, 5, 1e-12, 0, &apply);
        assert_eq!(theta.len(), 5);
        for (t, expected) in theta.iter().zip([1.0, 1.0, 1.0, 0.9 / 4.0, 0.9 / 5.0]) {
            assert!((t - expected).abs() < 1e-12, "{theta:?}");
        }
        let mut y = vec![0.0; n];
        for (t, v) in theta.iter().zip(&u) {
            apply(v, &mut y);
            let r = y
                .iter()
                .zip(v)
                .map(|(a, b)| (a - t * b).powi(2))
                .sum::<f64>()
                .sqrt();
            assert!(r <= 1e-12 && (norm(v) - 1.0).abs() < 1e-12);
        }
    }
}
