//! The lowest eigenpairs of a constrained symmetric pencil `K φ = ω² M φ` on `B φ = 0`, given
//! as values on one augmented sparse pattern — the engine the planar
//! ([`crate::natural_modes`]) and the spatial
//! ([`crate::spatial::modal::natural_modes_spatial`]) modal analyses share.
//!
//! **Shift-invert Lanczos.** Let `S(σ)` be the constrained inverse of `K − σM` (a solve
//! with the augmented matrix `[K − σM + c BᵀB, c Bᵀ; c B, 0]`, factorized by the sparse
//! `LDLᵀ` of [`Ldlt`]; the penalty `c BᵀB` vanishes on `B φ = 0` and only conditions the
//! saddle point) and `M = R Rᵀ` a factor assembled from the elements' mass matrices
//! ([`MassFactor`]). Then `C = Rᵀ S R` is symmetric, and `C y = ν y` with
//! `ν = 1/(ω² − σ)` gives the mode `φ = S R y / ν`, mass-normalized (`φᵀMφ = |y|² = 1`).
//! Restarted Lanczos with locking ([`largest_eigenpairs`]) finds the largest `ν`: the
//! lowest `ω²` above `σ`.
//!
//! **Sturm count.** The augmented `K − σM` has as many negative pivots as eigenvalues
//! `ω² < σ` plus one per constraint row: its inertia is that of `Zᵀ(K − σM)Z` on the
//! constraints' null space plus `(n_c, n_c)` (Sylvester's law of inertia; the penalty and
//! the scaling `c` are congruences, `[A + 2cBᵀB, cBᵀ; cB, 0] = Eᵀ[A, cBᵀ; cB, 0]E` with
//! `E = [I, 0; B, I]`). Counting at a bound between the last mode asked for and the next
//! one found proves that no mode below was skipped (Bathe, *Finite Element Procedures*,
//! §11.4.3; Ericsson & Ruhe 1980 for the spectral transformation).

use std::cell::RefCell;

use nalgebra::{DMatrix, SymmetricEigen};

use crate::error::{Error, SolveError};
use crate::solver::linsolve::{FactorError, Ldlt};
use lanczos::{largest_eigenpairs, spread};

use super::lanczos;

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

/// The lowest eigenpairs of a pencil and the Sturm count that proves them complete.
pub(crate) struct Lowest {
    /// `ω²` (rad²/s²), ascending.
    pub omega_squared: Vec<f64>,
    /// Mass-normalized shapes, the DOFs' part (`n_dofs` each).
    pub shapes: Vec<Vec<f64>>,
    /// The Sturm bound `ω²`: above every one returned and below the next one found; when
    /// the last ones returned sit in a cluster of nearly equal modes wider than the search,
    /// below that cluster instead.
    pub bound: f64,
    /// How many `ω²` lie below `bound` (every one was found).
    pub below: usize,
}

/// `K − σM` with the constraints, as values on an augmented pattern, and its
/// factorization.
pub(crate) struct Pencil {
    /// `K`, `M` and the constraint blocks (`c B`, `c Bᵀ` and `c BᵀB`) as values on the
    /// pattern.
    stiffness: Vec<f64>,
    mass: Vec<f64>,
    constraints: Vec<f64>,
    ldlt: Ldlt,
    /// Unknowns of the pattern: DOFs, then one multiplier per constraint row.
    n: usize,
    n_dofs: usize,
    n_constraints: usize,
    /// `σ₀`, the shift of the iteration: just below the lowest `ω²`, so that rigid modes
    /// factorize.
    pub shift: f64,
    /// The shift of the current factorization (NaN before the first).
    factorized_at: f64,
}

impl Pencil {
    /// The pencil of `stiffness`, `mass` and `constraints` (values on the pattern `ldlt` was
    /// analysed on: `n_dofs` DOFs, then `n_constraints` multipliers), shifted by `shift`.
    pub fn new(
        [stiffness, mass, constraints]: [Vec<f64>; 3],
        ldlt: Ldlt,
        [n_dofs, n_constraints]: [usize; 2],
        shift: f64,
    ) -> Self {
        Self {
            stiffness,
            mass,
            constraints,
            ldlt,
            n: n_dofs + n_constraints,
            n_dofs,
            n_constraints,
            shift,
            factorized_at: f64::NAN,
        }
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
    pub fn count_below(&mut self, sigma: f64) -> Result<usize, Error> {
        self.factorize(sigma)?;
        let negative = self
            .ldlt
            .negative_pivots()
            .map_err(|e| eigen(format!("{e:?}")))?;
        negative.checked_sub(self.n_constraints).ok_or_else(|| {
            eigen("fewer negative pivots than constraint rows: the joints or averaging rings are redundant".into())
        })
    }

    /// `ω²` and mass-normalized shapes of the `count` lowest modes above the shift, the
    /// Sturm bound and count: a guard of extra modes, doubled until the count agrees.
    pub fn lowest(&mut self, factor: &MassFactor, count: usize) -> Result<Lowest, Error> {
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
            // Fewer found than sought: perhaps all there are (a mechanism of few free
            // directions); the count says.
            let fewer_than_sought = pairs.len() < want;
            let every = (2.0 * pairs[pairs.len() - 1].0.abs() + 1.0, pairs.len());
            let (bound, expected) = match sturm_bound(&pairs, count) {
                Some(found) => found,
                None if exhaustive => every,
                None if crowded => match cluster_floor(&pairs, count) {
                    Some(found) => found,
                    None if fewer_than_sought => every,
                    None => break,
                },
                None if fewer_than_sought => every,
                None => {
                    want = (2 * want).min(factor.columns);
                    continue;
                }
            };
            let below = self.count_below(bound)?;
            if below == expected {
                let omega_squared = pairs[..count].iter().map(|p| p.0).collect();
                let shapes = self.shapes(factor, &pairs[..count])?;
                return Ok(Lowest {
                    omega_squared,
                    shapes,
                    bound,
                    below,
                });
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
        let scratch = RefCell::new((self.ldlt.scratch_for(1), vec![0.0; self.n]));
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
        Ok(pairs
            .iter()
            .map(|(l, y)| {
                let mut phi = self.apply_s_r(factor, y);
                let nu = 1.0 / (l - self.shift);
                phi.iter_mut().for_each(|v| *v /= nu);
                phi.truncate(self.n_dofs);
                phi
            })
            .collect())
    }

    /// `S(σ) R y` on the current factorization (DOFs then multipliers).
    fn apply_s_r(&self, factor: &MassFactor, y: &[f64]) -> Vec<f64> {
        let mut rhs = vec![0.0; self.n];
        factor.times(y, &mut rhs);
        let mut mem = self.ldlt.scratch_for(1);
        // The factorization succeeded in `lowest`; a failure here leaves non-finite shapes
        // that the caller's frequencies would not hide, so it is reported as such.
        if self.ldlt.solve_block(&mut rhs, 1, &mut mem).is_err() {
            rhs.fill(f64::NAN);
        }
        rhs
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

/// `M = R Rᵀ`, assembled from blocks `M_e = L_e L_eᵀ` (an element's, a body's, a point
/// mass's): `R` has one column per nonzero eigenvalue of each block.
pub(crate) struct MassFactor {
    /// Per block: its DOFs and its `L_e` (`dofs × columns`).
    blocks: Vec<(Vec<usize>, DMatrix<f64>)>,
    /// Columns of `R`.
    pub columns: usize,
}

impl MassFactor {
    /// The factor of `Σ_e M_e` from each block's DOFs and symmetric positive semi-definite
    /// `M_e`.
    pub fn new(blocks: impl IntoIterator<Item = (Vec<usize>, DMatrix<f64>)>) -> Self {
        let blocks: Vec<_> = blocks.into_iter().map(|(d, m)| (d, root(m))).collect();
        let columns = blocks.iter().map(|(_, l)| l.ncols()).sum();
        Self { blocks, columns }
    }

    /// `out[..n_dofs] += R y`.
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

pub(crate) fn eigen(detail: String) -> Error {
    SolveError::Eigen(detail).into()
}
