//! Natural frequencies and mode shapes of the structure linearized at a state, with every
//! joint a constraint (drives locked):
//!
//! `K_t(q) φ = ω² M φ`  on  `Φ_q φ = 0`.
//!
//! **Shift-invert Lanczos.** Let `S(σ)` be the constrained inverse of `K_t − σM` (a solve
//! with the augmented matrix, factorized by the same sparse `LDLᵀ` as Newton's) and
//! `M = R Rᵀ` a factor assembled from the elements' mass matrices. Then `C = Rᵀ S R` is
//! symmetric, and `C y = ν y` with `ν = 1/(ω² − σ)` gives the mode `φ = S R y / ν`,
//! mass-normalized (`φᵀMφ = |y|² = 1`). Restarted Lanczos with locking
//! ([`largest_eigenpairs`]) finds the largest `ν`: the lowest `ω²`.
//!
//! **Sturm count.** The augmented `K_t − σM` has as many negative pivots as eigenvalues
//! `ω² < σ` plus one per constraint row (its inertia is that of `Zᵀ(K_t − σM)Z` on the
//! constraints' null space, plus `(n_c, n_c)`). Counting at a bound between the last mode
//! asked for and the next one found proves that no mode below was skipped.
//!
//! **Design derivatives** of a simple eigenvalue, `φ` mass-normalized, `q` held:
//! `∂ω²/∂x_i = Σ_{e ∈ bar i} s'(x_e) φₑᵀ K_e φₑ − ω² m'(x_e) φₑᵀ M_e φₑ`, with the
//! full-density element matrices (exact at the reference state, where `K_t` does not depend
//! on the design through `q`). At a repeated eigenvalue only symmetric functions of the
//! cluster are differentiable; callers aggregate (see the Python `modes`).

mod lanczos;

use std::cell::RefCell;
use std::f64::consts::TAU;

use nalgebra::{DMatrix, SymmetricEigen};

use crate::error::{Error, SettingsError, SolveError};
use crate::mechanism::element::MassKind;
use crate::mechanism::model::{Densities, Model};
use crate::solver::assembly::{Assembler, Jacobian};
use crate::solver::linsolve::{FactorError, Ldlt};
use lanczos::{largest_eigenpairs, spread};

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

/// Modes sought, as a multiple of those asked for, before a cluster straddling the last one
/// is bounded from below instead of above ([`cluster_floor`]).
const CROWD: usize = 4;

/// Most attempts at finding enough modes before the eigen-analysis gives up.
const ATTEMPTS: usize = 5;
/// Eigen-residual of `C = Rᵀ S R` relative to its largest eigenvalue `ν`.
const EIGEN_TOL: f64 = 1e-9;
/// The smallest relative gap between two eigenvalues `ω²` at which the Sturm bound is
/// placed: identical void bars have modes equal to many digits, and a bound between them
/// would ask the pivots' signs to resolve what round-off blurs.
const GAP: f64 = 1e-3;

/// The `count` lowest natural modes of `model` at state `q` for a design's `densities`.
///
/// # Errors
/// [`SettingsError`] for `count = 0` or more modes than the structure has;
/// [`SolveError::Eigen`] when the structure is unstable at `q`, the eigensolver cannot
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
    let mut pencil = Pencil::new(model, densities, mass, q)?;
    let factor = MassFactor::of(&pencil.asm);
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
    let (lambdas, shapes, bound, below) = pencil.lowest(&factor, count)?;
    let gradients = pencil.gradients(&lambdas, &shapes, q);
    let hz = |l: f64| l.max(0.0).sqrt() / TAU;
    Ok(Modes {
        frequencies: lambdas.iter().map(|&l| hz(l)).collect(),
        shapes,
        bound: hz(bound),
        below,
        gradients,
    })
}

/// `K_t − σM` with the joints, on Newton's augmented pattern, and its factorization.
struct Pencil<'m> {
    asm: Assembler<'m>,
    /// `K_t(q)`, `M` and the constraint blocks as values on the pattern.
    stiffness: Vec<f64>,
    mass: Vec<f64>,
    constraints: Vec<f64>,
    ldlt: Ldlt,
    /// `σ₀`, a shift just below zero so that rigid modes factorize.
    shift: f64,
    /// The shift of the current factorization (NaN before the first).
    factorized_at: f64,
}

impl<'m> Pencil<'m> {
    fn new(
        model: &'m Model,
        densities: Densities,
        mass: MassKind,
        q: &[f64],
    ) -> Result<Self, Error> {
        let asm = Assembler::new(model, densities, mass)?;
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
        let (mut stiffness, mut mass_values) = (vec![0.0; nnz], vec![0.0; nnz]);
        let jacobian = Jacobian::at(model, q);
        asm.start_iteration_matrix(1.0, 0.0, &jacobian, &mut mass_values);
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
        Ok(Self {
            asm,
            stiffness,
            mass: mass_values,
            constraints,
            ldlt,
            shift,
            factorized_at: f64::NAN,
        })
    }

    fn factorize(&mut self, sigma: f64) -> Result<(), Error> {
        if sigma == self.factorized_at {
            return Ok(());
        }
        self.factorized_at = f64::NAN;
        let values: Vec<f64> = (self.stiffness.iter().zip(&self.mass))
            .zip(&self.constraints)
            .map(|((k, m), g)| k - sigma * m + g)
            .collect();
        self.ldlt.factorize(&values).map_err(|e| match e {
            FactorError::ZeroPivot { .. } => eigen(format!(
                "K_t − σM is singular at σ = {sigma:.6e} rad²/s² (a natural frequency sits \
                 exactly there, or the joints are redundant)"
            )),
            other => eigen(format!("{other:?}")),
        })?;
        self.factorized_at = sigma;
        Ok(())
    }

    /// The Sturm count: eigenvalues `ω² < sigma` on the constraints' null space.
    fn count_below(&mut self, sigma: f64) -> Result<usize, Error> {
        self.factorize(sigma)?;
        let negative = self
            .ldlt
            .negative_pivots()
            .map_err(|e| eigen(format!("{e:?}")))?;
        let n_c = self.asm.model.n_constraints();
        negative.checked_sub(n_c).ok_or_else(|| {
            eigen("fewer negative pivots than constraint rows: the joints or averaging rings are redundant".into())
        })
    }

    /// `ω²` and mass-normalized shapes of the `count` lowest modes, the Sturm bound and
    /// count: a guard of extra modes, doubled until the count agrees.
    #[allow(clippy::type_complexity)]
    fn lowest(
        &mut self,
        factor: &MassFactor,
        count: usize,
    ) -> Result<(Vec<f64>, Vec<Vec<f64>>, f64, usize), Error> {
        let mut want = count + count.max(4);
        for attempt in 0..ATTEMPTS {
            self.factorize(self.shift)?;
            let pairs = self.shift_invert(factor, want, attempt)?;
            let exhaustive = want >= factor.columns;
            if pairs.len() < count {
                if exhaustive {
                    break;
                }
                want = (2 * want).min(factor.columns);
                continue;
            }
            let crowded = want >= CROWD * count;
            let (bound, expected) = match sturm_bound(&pairs, count) {
                Some(found) => found,
                None if exhaustive => (2.0 * pairs[pairs.len() - 1].0.abs() + 1.0, pairs.len()),
                None if crowded => match cluster_floor(&pairs, count) {
                    Some(found) => found,
                    None => break,
                },
                None => {
                    want = (2 * want).min(factor.columns);
                    continue;
                }
            };
            let below = self.count_below(bound)?;
            if below == expected {
                let lambdas = pairs[..count].iter().map(|p| p.0).collect();
                let shapes = self.shapes(factor, &pairs[..count])?;
                return Ok((lambdas, shapes, bound, below));
            }
            want = (2 * want).max(below + count).min(factor.columns);
        }
        Err(eigen(format!(
            "the eigensolver did not find every mode below its Sturm bound after {ATTEMPTS} attempts"
        )))
    }

    /// Eigenpairs `(ω², y)` of `C = Rᵀ S(σ₀) R` (the matrix factorized at `σ₀`), ascending
    /// in `ω²`.
    fn shift_invert(
        &self,
        factor: &MassFactor,
        want: usize,
        attempt: usize,
    ) -> Result<Vec<(f64, Vec<f64>)>, Error> {
        let n = self.asm.pattern.n;
        let scratch = RefCell::new((self.ldlt.scratch_for(1), vec![0.0; n]));
        let failed = RefCell::new(None);
        let apply = |y: &[f64], out: &mut [f64]| {
            let (mem, rhs) = &mut *scratch.borrow_mut();
            rhs.fill(0.0);
            factor.times(y, rhs);
            if let Err(e) = self.ldlt.solve_block(rhs, 1, mem) {
                *failed.borrow_mut() = Some(e);
            }
            factor.transpose_times(rhs, out);
        };
        let mut probe: Vec<f64> = (0..factor.columns).map(spread).collect();
        let mut image = vec![0.0; factor.columns];
        for _ in 0..4 {
            apply(&probe, &mut image);
            let norm = image.iter().map(|v| v * v).sum::<f64>().sqrt();
            probe
                .iter_mut()
                .zip(&image)
                .for_each(|(p, v)| *p = v / norm.max(1e-300));
        }
        let largest = image.iter().map(|v| v * v).sum::<f64>().sqrt();
        let (nu, y) =
            largest_eigenpairs(factor.columns, want, EIGEN_TOL * largest, attempt, &apply);
        if let Some(e) = failed.into_inner() {
            return Err(eigen(format!("{e:?}")));
        }
        let mut pairs: Vec<(f64, Vec<f64>)> = nu
            .into_iter()
            .zip(y)
            .filter(|(v, _)| v.abs() > 1e-13 * largest)
            .map(|(v, y)| (self.shift + 1.0 / v, y))
            .collect();
        pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
        if pairs.iter().any(|p| !p.0.is_finite()) {
            return Err(eigen("non-finite eigenvalues".into()));
        }
        Ok(pairs)
    }

    /// The mass-normalized modes `φ = S(σ₀) R y / ν` of the eigenpairs `(ω², y)`.
    fn shapes(
        &mut self,
        factor: &MassFactor,
        pairs: &[(f64, Vec<f64>)],
    ) -> Result<Vec<Vec<f64>>, Error> {
        self.factorize(self.shift)?;
        let n_q = self.asm.model.n_dofs();
        Ok(pairs
            .iter()
            .map(|(l, y)| {
                let mut phi = self.apply_s_r(factor, y);
                let nu = 1.0 / (l - self.shift);
                phi.iter_mut().for_each(|v| *v /= nu);
                phi.truncate(n_q);
                phi
            })
            .collect())
    }

    /// `S(σ) R y` on the current factorization (DOFs then multipliers).
    fn apply_s_r(&self, factor: &MassFactor, y: &[f64]) -> Vec<f64> {
        let mut rhs = vec![0.0; self.asm.pattern.n];
        factor.times(y, &mut rhs);
        let mut mem = self.ldlt.scratch_for(1);
        // The factorization succeeded in `lowest`; a failure here leaves non-finite shapes
        // that the caller's frequencies would not hide, so it is reported as such.
        if self.ldlt.solve_block(&mut rhs, 1, &mut mem).is_err() {
            rhs.fill(f64::NAN);
        }
        rhs
    }

    /// `∂f_j/∂x_i` (Hz) from `∂ω²/∂x_i` (module docs) and `∂f/∂ω² = 1/(8π² f)`.
    fn gradients(&self, lambdas: &[f64], shapes: &[Vec<f64>], q: &[f64]) -> Vec<f64> {
        let model = self.asm.model;
        let (d, kind) = (&self.asm.densities, self.asm.mass_kind);
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
                let dlambda = d.stiffness_rate[e] * p.dot(&(k * p))
                    - lambda * d.mass_rate[e] * p.dot(&(m * p));
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
}

/// Where to count when the last mode asked for sits in a cluster wider than the modes
/// found (dozens of identical void bars): the gap before the cluster. The modes below are
/// proven complete; those returned from the cluster are eigenpairs within its span.
fn cluster_floor(pairs: &[(f64, Vec<f64>)], count: usize) -> Option<(f64, usize)> {
    (1..count)
        .rev()
        .find(|&j| pairs[j].0 - pairs[j - 1].0 > GAP * pairs[j].0.abs())
        .map(|j| (0.5 * (pairs[j - 1].0 + pairs[j].0), j))
}

/// Where to count: the midpoint of the first gap (relative [`GAP`]) after the `count`
/// lowest of the ascending eigenvalues `pairs`, and how many lie below it.
fn sturm_bound(pairs: &[(f64, Vec<f64>)], count: usize) -> Option<(f64, usize)> {
    (count..pairs.len())
        .find(|&j| pairs[j].0 - pairs[j - 1].0 > GAP * pairs[j].0.abs())
        .map(|j| (0.5 * (pairs[j - 1].0 + pairs[j].0), j))
}

/// `M = R Rᵀ`, assembled from each element's `M_e = L_e L_eᵀ` (and point masses): `R` has
/// one column per nonzero eigenvalue of each element mass matrix.
struct MassFactor {
    /// Per element (or point mass): its DOFs and its `L_e` (`dofs × columns`).
    blocks: Vec<(Vec<usize>, DMatrix<f64>)>,
    /// Columns of `R`.
    columns: usize,
}

impl MassFactor {
    fn of(asm: &Assembler<'_>) -> Self {
        let model = asm.model;
        let mut blocks = Vec::new();
        let mut masses: Vec<_> = (model.elements.iter().enumerate())
            .map(|(e, el)| el.kernel.mass_matrix(asm.mass_kind) * asm.densities.mass[e])
            .collect();
        // A bar's end coupling (negative semidefinite) joins the lumped translational
        // mass of its end nodes, which it leaves positive definite.
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
                root(DMatrix::from_iterator(4, 4, m.iter().copied())),
            ));
        }
        for (el, m) in model.elements.iter().zip(&masses) {
            blocks.push((
                el.dofs().to_vec(),
                root(DMatrix::from_iterator(6, 6, m.iter().copied())),
            ));
        }
        let n_e = model.elements.len();
        for (k, cell) in model.cells.iter().enumerate() {
            let m = cell.kernel.mass_matrix(asm.mass_kind) * asm.densities.mass[n_e + k];
            blocks.push((
                cell.dofs().to_vec(),
                root(DMatrix::from_iterator(8, 8, m.iter().copied())),
            ));
        }
        for pm in &model.point_masses {
            let dofs = (0..3).map(|k| 3 * pm.node + k).collect();
            let m = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![
                pm.mass, pm.mass, pm.inertia,
            ]));
            blocks.push((dofs, root(m)));
        }
        let columns = blocks.iter().map(|(_, l)| l.ncols()).sum();
        Self { blocks, columns }
    }

    /// `out[..n_q] += R y`.
    fn times(&self, y: &[f64], out: &mut [f64]) {
        let mut at = 0;
        for (dofs, l) in &self.blocks {
            for c in 0..l.ncols() {
                dofs.iter()
                    .enumerate()
                    .for_each(|(r, &d)| out[d] += l[(r, c)] * y[at + c]);
            }
            at += l.ncols();
        }
    }

    /// `out = Rᵀ v`.
    fn transpose_times(&self, v: &[f64], out: &mut [f64]) {
        let mut at = 0;
        for (dofs, l) in &self.blocks {
            for c in 0..l.ncols() {
                out[at + c] = dofs
                    .iter()
                    .enumerate()
                    .map(|(r, &d)| l[(r, c)] * v[d])
                    .sum();
            }
            at += l.ncols();
        }
    }
}

/// `L` with `L Lᵀ = m` for a symmetric positive semi-definite `m`, without the columns of
/// its zero eigenvalues (massless rotations of a lumped mass, for instance).
fn root(m: DMatrix<f64>) -> DMatrix<f64> {
    let rows = m.nrows();
    let eig = SymmetricEigen::new(m);
    let largest = eig.eigenvalues.iter().fold(0.0_f64, |a, &b| a.max(b));
    let keep: Vec<usize> = (0..eig.eigenvalues.len())
        .filter(|&k| eig.eigenvalues[k] > 1e-12 * largest)
        .collect();
    DMatrix::from_fn(rows, keep.len(), |r, c| {
        eig.eigenvectors[(r, keep[c])] * eig.eigenvalues[keep[c]].sqrt()
    })
}

fn eigen(detail: String) -> Error {
    SolveError::Eigen(detail).into()
}

#[cfg(test)]
mod tests {
    //! Against a dense eigen-solve of the same matrices, and finite differences.

    use super::*;
    use crate::solver::assembly::linearize;
    use nalgebra::DMatrix;

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
