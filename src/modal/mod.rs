//! Natural frequencies and mode shapes of the structure linearized at a state, with every
//! joint a constraint (drives locked):
//!
//! `K_t(q) φ = ω² M φ`  on  `Φ_q φ = 0`.
//!
//! **Shift-invert Lanczos with a Sturm count** ([`pencil`], which the spatial engine's
//! [`crate::spatial::modal`] shares): `M = R Rᵀ` is assembled from the elements' mass
//! matrices ([`mass_factor`], a bar's end coupling joined to its end nodes' lumped mass),
//! `K_t − σM` with the joints on Newton's augmented pattern factorized by the same sparse
//! `LDLᵀ`; the count of its negative pivots at a bound proves that no mode below was
//! skipped.
//!
//! **Design derivatives** of a simple eigenvalue, `φ` mass-normalized, `q` held:
//! `∂ω²/∂x_i = Σ_{e ∈ bar i} s'(x_e) φₑᵀ K_e φₑ − ω² m'(x_e) φₑᵀ M_e φₑ`, with the
//! full-density element matrices (exact at the reference state, where `K_t` does not depend
//! on the design through `q`). At a repeated eigenvalue only symmetric functions of the
//! cluster are differentiable; callers aggregate (see the Python `modes`).

pub(crate) mod lanczos;
pub(crate) mod pencil;

use std::f64::consts::TAU;

use nalgebra::DMatrix;

use crate::error::{Error, SettingsError};
use crate::mechanism::element::MassKind;
use crate::mechanism::model::{Densities, Model};
use crate::solver::assembly::{Assembler, Jacobian};
use pencil::{eigen, MassFactor, Pencil};

/// The lowest natural modes of a structure, with the proof that none was skipped.
#[derive(Debug, Clone, PartialEq)]
pub struct Modes {
    /// Natural frequencies `ω/2π` (Hz), ascending.
    pub frequencies: Vec<f64>,
    /// Mass-normalized mode shapes (`n_q` each).
    pub shapes: Vec<Vec<f64>>,
    /// The Sturm bound (Hz): above every frequency returned and below the next mode found;
    /// when the last ones returned sit in a cluster of nearly equal modes wider than the
    /// search, below that cluster instead.
    pub bound: f64,
    /// The Sturm count: how many frequencies lie below `bound` (every one was found).
    pub below: usize,
    /// `∂f_j/∂x_i` (Hz), row-major `count × n_variables`.
    pub gradients: Vec<f64>,
}

/// The `count` lowest natural modes of `model` at state `q` for a design's `densities`.
///
/// # Errors
/// [`SettingsError`] for `count = 0` or more modes than the structure has;
/// [`crate::error::SolveError::Eigen`] when the structure is unstable at `q`, the eigensolver cannot
/// account for every mode below its bound, or the factorization fails.
pub fn natural_modes(
    model: &Model,
    densities: Densities,
    mass: MassKind,
    q: &[f64],
    count: usize,
) -> Result<Modes, Error> {
    if model.elements.is_empty() && model.cells.is_empty() {
        let msg = "the scene has no beams or continuum members: a mechanism of rigid bodies has no elastic modes";
        return Err(SettingsError::new("n", msg).into());
    }
    let asm = Assembler::new(model, densities, mass)?;
    let mut pencil = pencil(&asm, q)?;
    let factor = mass_factor(&asm);
    let available = (factor.columns.min(model.n_dofs())).saturating_sub(model.n_constraints());
    if count == 0 || count > available {
        let msg = format!("must be between 1 and {available}, the modes the structure has");
        return Err(SettingsError::new("n", msg).into());
    }
    let unstable = pencil.count_below(pencil.shift)?;
    if unstable > 0 {
        return Err(eigen(format!(
            "{unstable} eigenvalue(s) of K_t are negative on the constraints' null space: the \
             structure is unstable or a mechanism at this state, with the drives locked"
        )));
    }
    let lowest = pencil.lowest(&factor, count)?;
    let gradients = gradients(&asm, &lowest.omega_squared, &lowest.shapes, q);
    let hz = |l: f64| l.max(0.0).sqrt() / TAU;
    Ok(Modes {
        frequencies: lowest.omega_squared.iter().map(|&l| hz(l)).collect(),
        shapes: lowest.shapes,
        bound: hz(lowest.bound),
        below: lowest.below,
        gradients,
    })
}

/// `K_t(q) − σM` with the joints on Newton's augmented pattern (the constraint rows and
/// their penalty scaled by the mean stiffness diagonal), shifted just below zero so that
/// rigid modes factorize.
fn pencil(asm: &Assembler<'_>, q: &[f64]) -> Result<Pencil, Error> {
    let model = asm.model;
    let n_q = model.n_dofs();
    if q.len() != n_q {
        let msg = format!("has {} entries, the model has {n_q} DOFs", q.len());
        return Err(SettingsError::new("q", msg).into());
    }
    if let Some(k) = q.iter().position(|v| !v.is_finite()) {
        let msg = format!("entry {k} is {}: the state must be finite", q[k]);
        return Err(SettingsError::new("q", msg).into());
    }
    let nnz = asm.pattern.nnz();
    let (mut stiffness, mut mass) = (vec![0.0; nnz], vec![0.0; nnz]);
    let jacobian = Jacobian::at(model, q);
    asm.start_iteration_matrix(1.0, 0.0, &jacobian, &mut mass);
    asm.start_iteration_matrix(0.0, 0.0, &jacobian, &mut stiffness);
    asm.internal_forces(q, &mut vec![0.0; n_q], Some(&mut stiffness));
    let (mean_k, mean_m) = (asm.mean_stiffness_diagonal(q), asm.mean_mass_diagonal());
    let mut constraints = vec![0.0; nnz];
    asm.start_iteration_matrix(0.0, mean_k, &jacobian, &mut constraints);
    let ldlt = asm.symbolic_ldlt()?;
    let shift = if mean_m > 0.0 {
        -1e-8 * mean_k / mean_m
    } else {
        0.0
    };
    Ok(Pencil::new(
        [stiffness, mass, constraints],
        ldlt,
        [n_q, model.n_constraints()],
        shift,
    ))
}

/// `∂f_j/∂x_i` (Hz) from `∂ω²/∂x_i` (module docs) and `∂f/∂ω² = 1/(8π² f)`.
fn gradients(asm: &Assembler<'_>, lambdas: &[f64], shapes: &[Vec<f64>], q: &[f64]) -> Vec<f64> {
    let model = asm.model;
    let (d, kind) = (&asm.densities, asm.mass_kind);
    let n_var = model.n_variables();
    let mut out = vec![0.0; lambdas.len() * n_var];
    for (e, el) in model.elements.iter().enumerate() {
        let Some(v) = model.variable_of(e) else {
            continue;
        };
        let (_, k) = el.kernel.internal_force_and_tangent(&el.gather(q));
        let m = el.kernel.mass_matrix(kind);
        for (j, (lambda, phi)) in lambdas.iter().zip(shapes).enumerate() {
            let p = el.gather(phi);
            let dlambda =
                d.stiffness_rate[e] * p.dot(&(k * p)) - lambda * d.mass_rate[e] * p.dot(&(m * p));
            let f = lambda.max(0.0).sqrt() / TAU;
            out[j * n_var + v] += dlambda / (2.0 * TAU * TAU * f).max(1e-300);
        }
    }
    for c in model.bar_couplings(kind) {
        let Some(v) = model.variable_of(c.element) else {
            continue;
        };
        let m = c.matrix();
        for (j, (lambda, phi)) in lambdas.iter().zip(shapes).enumerate() {
            let p = nalgebra::Vector4::from(c.dofs().map(|d| phi[d]));
            let dlambda = -lambda * d.mass_rate[c.element] * p.dot(&(m * p));
            let f = lambda.max(0.0).sqrt() / TAU;
            out[j * n_var + v] += dlambda / (2.0 * TAU * TAU * f).max(1e-300);
        }
    }
    let n_e = model.elements.len();
    for (c, cell) in model.cells.iter().enumerate() {
        let Some(v) = cell.variable else {
            continue;
        };
        let (e, u) = (n_e + c, cell.gather(q));
        let kernel = cell.kernel.blended(d.blend[e]);
        // d(s K)/dx = s' K + s γ' ∂K/∂γ.
        let mut k = kernel.internal_force_and_tangent(&u).1 * d.stiffness_rate[e];
        if d.blend_rate[e] != 0.0 {
            k += kernel.tangent_rate(&u) * (d.stiffness[e] * d.blend_rate[e]);
        }
        let m = cell.kernel.mass_matrix(kind);
        for (j, (lambda, phi)) in lambdas.iter().zip(shapes).enumerate() {
            let p = cell.gather(phi);
            let dlambda = p.dot(&(k * p)) - lambda * d.mass_rate[n_e + c] * p.dot(&(m * p));
            let f = lambda.max(0.0).sqrt() / TAU;
            out[j * n_var + v] += dlambda / (2.0 * TAU * TAU * f).max(1e-300);
        }
    }
    out
}

/// `M = R Rᵀ` from each element's mass matrix (and point masses'): a bar's end coupling
/// (negative semidefinite) joined to the lumped translational mass of its end nodes, which
/// it leaves positive definite.
fn mass_factor(asm: &Assembler<'_>) -> MassFactor {
    let model = asm.model;
    let mut blocks = Vec::new();
    let mut masses: Vec<_> = (model.elements.iter().enumerate())
        .map(|(e, el)| el.kernel.mass_matrix(asm.mass_kind) * asm.densities.mass[e])
        .collect();
    for c in model.bar_couplings(asm.mass_kind) {
        let bar = &model.bars[model.elements[c.element].bar];
        let (first, last) = (bar.elements.start, bar.elements.end - 1);
        let (la, lb) = (masses[first][(0, 0)], masses[last][(3, 3)]);
        for (e, k) in [(first, 0), (first, 1), (last, 3), (last, 4)] {
            masses[e][(k, k)] = 0.0;
        }
        let mut m = c.matrix() * asm.densities.mass[c.element];
        for (k, l) in [la, la, lb, lb].into_iter().enumerate() {
            m[(k, k)] += l;
        }
        blocks.push((
            c.dofs().to_vec(),
            DMatrix::from_iterator(4, 4, m.iter().copied()),
        ));
    }
    for (el, m) in model.elements.iter().zip(&masses) {
        blocks.push((
            el.dofs().to_vec(),
            DMatrix::from_iterator(6, 6, m.iter().copied()),
        ));
    }
    let n_e = model.elements.len();
    for (k, cell) in model.cells.iter().enumerate() {
        let m = cell.kernel.mass_matrix(asm.mass_kind) * asm.densities.mass[n_e + k];
        blocks.push((
            cell.dofs().to_vec(),
            DMatrix::from_iterator(8, 8, m.iter().copied()),
        ));
    }
    for pm in &model.point_masses {
        let dofs = (0..3).map(|k| 3 * pm.node + k).collect();
        let m = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![
            pm.mass, pm.mass, pm.inertia,
        ]));
        blocks.push((dofs, m));
    }
    MassFactor::new(blocks)
}

#[cfg(test)]
mod tests {
    //! Against a dense eigen-solve of the same matrices, and finite differences.

    use super::lanczos::spread;
    use super::*;
    use crate::solver::assembly::linearize;
    use nalgebra::{DMatrix, SymmetricEigen};

    fn arm() -> Model {
        let spec = crate::scene::parse_toml(include_str!("../../examples/robot_arm.toml")).unwrap();
        crate::scene::build(&spec).unwrap()
    }

    fn design(model: &Model) -> Vec<f64> {
        (0..model.n_variables())
            .map(|i| 0.05 + 0.95 * (spread(i) + 0.5))
            .collect()
    }

    fn dense(c: &crate::solver::assembly::Csc) -> DMatrix<f64> {
        let mut d = DMatrix::zeros(c.shape.0, c.shape.1);
        for j in 0..c.shape.1 {
            for k in c.indptr[j]..c.indptr[j + 1] {
                d[(c.indices[k], j)] = c.data[k];
            }
        }
        d
    }

    /// Lowest `ω²` on the null space of `G` by dense algebra.
    fn dense_eigenvalues(model: &Model, x: &[f64]) -> Vec<f64> {
        let q = vec![0.0; model.n_dofs()];
        let lin = linearize(
            model,
            model.densities(Some(x)).unwrap(),
            MassKind::Consistent,
            &q,
        )
        .unwrap();
        let (m, k, g) = (
            dense(&lin.mass),
            dense(&lin.stiffness),
            dense(&lin.jacobian),
        );
        let gram = SymmetricEigen::new(g.transpose() * &g);
        let top = gram.eigenvalues.max();
        let null: Vec<usize> = (0..g.ncols())
            .filter(|&k| gram.eigenvalues[k] < 1e-12 * top)
            .collect();
        let z = gram.eigenvectors.select_columns(&null);
        let (mr, kr) = (z.transpose() * &m * &z, z.transpose() * &k * &z);
        let l = mr.cholesky().unwrap().l();
        let li = l.clone().try_inverse().unwrap();
        let a = &li * kr * li.transpose();
        let mut e: Vec<f64> = SymmetricEigen::new((&a + a.transpose()) * 0.5)
            .eigenvalues
            .iter()
            .copied()
            .collect();
        e.sort_by(f64::total_cmp);
        e
    }

    #[test]
    fn lowest_modes_match_a_dense_solve_and_the_sturm_count_holds() {
        let model = arm();
        let x = design(&model);
        let q = vec![0.0; model.n_dofs()];
        let modes = natural_modes(
            &model,
            model.densities(Some(&x)).unwrap(),
            MassKind::Consistent,
            &q,
            6,
        )
        .unwrap();
        let reference = dense_eigenvalues(&model, &x);
        for (f, l) in modes.frequencies.iter().zip(&reference) {
            let exact = l.sqrt() / TAU;
            assert!((f - exact).abs() < 1e-9 * exact, "{f} vs {exact}");
        }
        assert_eq!(modes.below, 6);
        let seventh = reference[6].sqrt() / TAU;
        assert!(modes.bound > modes.frequencies[5] && modes.bound < seventh);
    }

    #[test]
    fn frequency_derivatives_match_central_differences() {
        let model = arm();
        let x = design(&model);
        let q = vec![0.0; model.n_dofs()];
        let run = |x: &[f64]| {
            natural_modes(
                &model,
                model.densities(Some(x)).unwrap(),
                MassKind::Consistent,
                &q,
                3,
            )
            .unwrap()
        };
        let modes = run(&x);
        let n_var = model.n_variables();
        for i in [0, 17, 60, 101] {
            let eps = 1e-4;
            let (mut up, mut down) = (x.clone(), x.clone());
            up[i] += eps;
            down[i] -= eps;
            let (fu, fd) = (run(&up), run(&down));
            for j in 0..3 {
                let fd_slope = (fu.frequencies[j] - fd.frequencies[j]) / (2.0 * eps);
                let exact = modes.gradients[j * n_var + i];
                let scale = modes.frequencies[j];
                assert!(
                    (fd_slope - exact).abs() < 1e-6 * scale,
                    "mode {j}, x{i}: {fd_slope} vs {exact}"
                );
            }
        }
    }
}
