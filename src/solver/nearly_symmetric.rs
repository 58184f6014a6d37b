//! Solves with a nearly symmetric matrix `A` — the spatial iteration matrix, whose
//! non-symmetric part (gyroscopic terms, the tangent operators `T(Δ)`, the moments' share of
//! the tangent on the rotation group, the joints' constraint-force stiffness) is small
//! beside its symmetric part `S = (A + Aᵀ)/2` wherever the mass `β'M` or the stiffness holds
//! each direction — on the `LDLᵀ` factors of `S` ([`Ldlt`], a symmetric ordering, the
//! saddle-point order of [`crate::solver::linsolve`]), the rest by iterative refinement:
//!
//! ```text
//! x₀ = S⁻¹ b,   xₖ₊₁ = xₖ + S⁻¹ (b − A xₖ)
//! ```
//!
//! which converges as `‖S⁻¹(A − S)‖ᵏ`, to round-off in a few corrections. A partial-pivoting
//! `LU` must order for the pattern of `AᵀA` and fills several times more: the paper's arm as
//! a spatial frame at two elements per bar (1078 unknowns, 131 steps) ran in 3.6 s on `LU`
//! alone and runs in 0.94 s (0.68 s with the modified Newton matrix). Where refinement stops
//! contracting ([`CONTRACTION`]) with corrections above [`STALLED`] of the solution, or `S` has
//! a zero pivot, the same system is solved on [`Lu`] factors (made then, once per
//! [`NearlySymmetric::factorize`]; faer's supernodal `LU` allocates), so the answer is the
//! exact solution either way. `Aᵀ x = b` (the adjoint's) refines on the same factors of `S`.

use crate::solver::linsolve::{FactorError, Ldlt};
use crate::solver::lu::Lu;

/// The largest ratio of successive corrections' sizes for refinement to go on: beyond it
/// the non-symmetric part is too large for `S`'s factors, and `LU` solves.
pub const CONTRACTION: f64 = 0.5;

/// The most corrections of one solve before `LU` solves.
pub const MAX_CORRECTIONS: usize = 60;

/// A correction this small, relative to the solution, ends refinement: round-off.
const ROUND_OFF: f64 = 8.0 * f64::EPSILON;

/// A correction this small, relative to the solution, ends the refinement of a Newton
/// correction ([`NearlySymmetric::solve_correction`]): its error then takes a share of this
/// size of the next residual, far below what the quadratic term leaves there.
pub const NEWTON_ACCURACY: f64 = 1e-13;

/// Refinement that stops contracting with corrections below this share of the solution has
/// reached the round-off of the matrix's conditioning (an `LU` solve's error is of the same
/// order); above it, `LU` solves.
pub const STALLED: f64 = 1e-6;

/// Factors of a nearly symmetric matrix on a structurally symmetric CSC pattern (module
/// docs).
pub struct NearlySymmetric {
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    /// The slot of entry `(j, i)` for the slot of `(i, j)`.
    mirror: Vec<usize>,
    /// `A`'s values and `S`'s.
    values: Vec<f64>,
    symmetric: Vec<f64>,
    ldlt: Ldlt,
    /// Whether `S`'s factors are usable.
    ldlt_ok: bool,
    lu: Lu,
    /// Whether `lu` holds the factors of the current `A`.
    lu_current: bool,
    residual: Vec<f64>,
    solution: Vec<f64>,
    fallbacks: usize,
}

impl NearlySymmetric {
    /// Symbolic analysis of the `n × n` CSC pattern `(col_ptr, row_idx)` (rows sorted in each
    /// column, the pattern structurally symmetric) whose first `n_dofs` unknowns are DOFs and
    /// whose others are multipliers.
    ///
    /// # Errors
    /// [`FactorError::Analysis`] if the pattern is not structurally symmetric or a
    /// multiplier acts on no DOF (defects of the caller), or an analysis fails.
    pub fn analyze(
        n: usize,
        n_dofs: usize,
        col_ptr: Vec<usize>,
        row_idx: Vec<usize>,
    ) -> Result<Self, FactorError> {
        let mirror = mirror(&col_ptr, &row_idx)?;
        let ldlt = Ldlt::analyze_saddle_point(n, n_dofs, col_ptr.clone(), row_idx.clone())?;
        let lu = Lu::analyze(n, col_ptr.clone(), row_idx.clone())?;
        let nnz = row_idx.len();
        Ok(Self {
            col_ptr,
            row_idx,
            mirror,
            values: vec![0.0; nnz],
            symmetric: vec![0.0; nnz],
            ldlt,
            ldlt_ok: false,
            lu,
            lu_current: false,
            residual: vec![0.0; n],
            solution: vec![0.0; n],
            fallbacks: 0,
        })
    }

    /// Factors `A` of CSC `values`: `S`'s `LDLᵀ`, or `LU` where `S` has a zero pivot.
    ///
    /// # Errors
    /// [`FactorError::Singular`] where neither factorization succeeds.
    pub fn factorize(&mut self, values: &[f64]) -> Result<(), FactorError> {
        self.values.copy_from_slice(values);
        for (k, s) in self.symmetric.iter_mut().enumerate() {
            *s = 0.5 * (values[k] + values[self.mirror[k]]);
        }
        self.lu_current = false;
        self.ldlt_ok = self.ldlt.factorize(&self.symmetric).is_ok();
        if self.ldlt_ok {
            Ok(())
        } else {
            self.factor_lu()
        }
    }

    /// Factors `A` of CSC `values` by `LU` alone: cheaper where many right-hand sides share
    /// the factors (each refinement costs products and solves).
    ///
    /// # Errors
    /// [`FactorError::Singular`] where the factorization fails.
    pub fn factorize_lu(&mut self, values: &[f64]) -> Result<(), FactorError> {
        self.values.copy_from_slice(values);
        self.ldlt_ok = false;
        self.factor_lu()
    }

    /// How many solves since the analysis were made on `LU` factors.
    #[cfg(test)]
    pub fn fallbacks(&self) -> usize {
        self.fallbacks
    }

    fn factor_lu(&mut self) -> Result<(), FactorError> {
        self.lu.factorize(&self.values)?;
        self.lu_current = true;
        Ok(())
    }

    /// Solves `A x = b` (or `Aᵀ x = b` with `transpose`) in place.
    ///
    /// # Errors
    /// [`FactorError::Singular`] without a successful factorization or for a non-finite
    /// solution.
    pub fn solve_in_place(&mut self, b: &mut [f64], transpose: bool) -> Result<(), FactorError> {
        self.solve_to(b, transpose, ROUND_OFF)
    }

    /// Solves `A x = b` in place for a Newton correction: refined to [`NEWTON_ACCURACY`]
    /// rather than to round-off, as an inexact Newton method (the iterations' own
    /// convergence test decides where they end).
    ///
    /// # Errors
    /// As [`NearlySymmetric::solve_in_place`].
    pub fn solve_correction(&mut self, b: &mut [f64]) -> Result<(), FactorError> {
        self.solve_to(b, false, NEWTON_ACCURACY)
    }

    /// Solves on `S`'s factors refined until a correction is `accuracy` of the solution, or
    /// on `LU`'s where refinement stalls above round-off.
    fn solve_to(
        &mut self,
        b: &mut [f64],
        transpose: bool,
        accuracy: f64,
    ) -> Result<(), FactorError> {
        if self.ldlt_ok && self.refine(b, transpose, accuracy)? {
            b.copy_from_slice(&self.solution);
            return Ok(());
        }
        if !self.lu_current {
            self.factor_lu()?;
        }
        self.fallbacks += 1;
        self.lu.solve_in_place(b, transpose)
    }

    /// Iterative refinement on `S`'s factors into `solution`: whether it reached `accuracy`
    /// (or stalled at round-off).
    fn refine(&mut self, b: &[f64], transpose: bool, accuracy: f64) -> Result<bool, FactorError> {
        self.solution.copy_from_slice(b);
        self.ldlt.solve_in_place(&mut self.solution)?;
        let mut previous = f64::INFINITY;
        for _ in 0..MAX_CORRECTIONS {
            self.residual.copy_from_slice(b);
            self.subtract_product(transpose);
            self.ldlt.solve_in_place(&mut self.residual)?;
            let correction = max_abs(&self.residual);
            let size = max_abs(&self.solution);
            self.solution
                .iter_mut()
                .zip(&self.residual)
                .for_each(|(x, d)| *x += d);
            if correction <= accuracy * size {
                return Ok(true);
            }
            if correction > CONTRACTION * previous || !correction.is_finite() {
                // Stalled: at the round-off the matrix's conditioning allows, or not contracting.
                return Ok(correction <= STALLED * size);
            }
            previous = correction;
        }
        Ok(false)
    }

    /// `residual −= A solution` (or `Aᵀ solution`).
    fn subtract_product(&mut self, transpose: bool) {
        for c in 0..self.col_ptr.len() - 1 {
            let range = self.col_ptr[c]..self.col_ptr[c + 1];
            let rows = &self.row_idx[range.clone()];
            let values = &self.values[range];
            if transpose {
                let dot: f64 = rows
                    .iter()
                    .zip(values)
                    .map(|(&r, v)| v * self.solution[r])
                    .sum();
                self.residual[c] -= dot;
            } else {
                let x = self.solution[c];
                for (&r, v) in rows.iter().zip(values) {
                    self.residual[r] -= v * x;
                }
            }
        }
    }
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

/// Each slot's mirror slot `(j, i)`, or an error for a pattern that is not structurally
/// symmetric.
pub(crate) fn mirror(col_ptr: &[usize], row_idx: &[usize]) -> Result<Vec<usize>, FactorError> {
    let mut mirror = vec![0; row_idx.len()];
    for c in 0..col_ptr.len() - 1 {
        for k in col_ptr[c]..col_ptr[c + 1] {
            let r = row_idx[k];
            let column = &row_idx[col_ptr[r]..col_ptr[r + 1]];
            let found = column.binary_search(&c).map_err(|_| {
                FactorError::Analysis(format!(
                    "the pattern has ({r}, {c}) but not ({c}, {r}): not structurally symmetric"
                ))
            })?;
            mirror[k] = col_ptr[r] + found;
        }
    }
    Ok(mirror)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 2 × 2 saddle point `[[a, b], [b', 0]]` with a 3 × 3 DOF block around it: solved to
    /// round-off against the dense solution, `A x = b` and `Aᵀ x = b`, by refinement where
    /// the skew part is small and by `LU` where it is not.
    #[test]
    fn solves_nearly_and_far_from_symmetric_systems() {
        // Unknowns 0..3 DOFs, 3 a multiplier on DOFs 0 and 2. Full pattern of the DOF block.
        let n = 4;
        let mut entries = Vec::new();
        for c in 0..3 {
            for r in 0..3 {
                entries.push((c, r));
            }
        }
        entries.extend([(3, 0), (3, 2), (0, 3), (2, 3)]);
        entries.sort();
        let mut col_ptr = vec![0; n + 1];
        entries.iter().for_each(|&(c, _)| col_ptr[c + 1] += 1);
        (0..n).for_each(|c| col_ptr[c + 1] += col_ptr[c]);
        let row_idx: Vec<usize> = entries.iter().map(|&(_, r)| r).collect();
        let dense = |skew: f64| {
            let mut a = [[0.0; 4]; 4];
            let k = [[4.0, 1.0, 0.5], [1.0, 3.0, 0.2], [0.5, 0.2, 5.0]];
            for i in 0..3 {
                for j in 0..3 {
                    a[i][j] = k[i][j] + skew * (i as f64 - j as f64);
                }
            }
            (a[3][0], a[3][2], a[0][3], a[2][3]) = (1.0, 2.0, 1.0 + 0.1 * skew, 2.0);
            a
        };
        for (skew, refined) in [(0.05, true), (30.0, false)] {
            let a = dense(skew);
            let values: Vec<f64> = entries.iter().map(|&(c, r)| a[r][c]).collect();
            let mut solver =
                NearlySymmetric::analyze(n, 3, col_ptr.clone(), row_idx.clone()).unwrap();
            solver.factorize(&values).unwrap();
            for transpose in [false, true] {
                let b = [1.0, -2.0, 0.5, 3.0];
                let mut x = b;
                solver.solve_in_place(&mut x, transpose).unwrap();
                for (i, bi) in b.iter().enumerate() {
                    let ax: f64 = (0..4)
                        .map(|j| if transpose { a[j][i] } else { a[i][j] } * x[j])
                        .sum();
                    assert!((ax - bi).abs() < 1e-13, "skew {skew}: row {i}: {ax} ≠ {bi}");
                }
            }
            assert_eq!(solver.fallbacks() == 0, refined, "skew {skew}");
        }
    }
}
