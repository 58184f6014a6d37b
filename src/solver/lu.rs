//! Sparse `LU` with partial pivoting of a non-symmetric matrix on a fixed pattern: the
//! spatial iteration matrix (tangent operators, gyroscopic terms and the joints'
//! constraint-force stiffness make it non-symmetric). Beside [`crate::solver::linsolve`] the
//! only module that touches faer.
//!
//! The column ordering (COLAMD) and the symbolic structure are computed once
//! ([`Lu::analyze`]); each Newton iteration refactors numerically into the buffers of the
//! previous one, re-choosing the row pivots, so that the multipliers' zero diagonal needs no
//! special ordering. `A x = b` and `Aᵀ x = b` (the adjoint's) solve on the same factors. A
//! zero pivot is not reported by faer (its reciprocal is taken): a non-finite solution is
//! reported as [`FactorError::Singular`].

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::lu::partial_pivoting::factor::PartialPivLuParams;
use faer::sparse::linalg::lu::{
    factorize_symbolic_lu, LuRef, LuSymbolicParams, NumericLu, SymbolicLu,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat};
use faer::{Conj, MatMut, Par, Spec};

use crate::solver::linsolve::FactorError;

/// `LU` factors of a square matrix with a fixed CSC pattern.
pub struct Lu {
    pattern: SymbolicSparseColMat<usize>,
    symbolic: SymbolicLu<usize>,
    numeric: NumericLu<usize, f64>,
    scratch: MemBuffer,
    factorized: bool,
}

impl Lu {
    /// Symbolic analysis of the `n × n` CSC pattern `(col_ptr, row_idx)` (rows sorted in
    /// each column).
    ///
    /// # Errors
    /// [`FactorError::Analysis`] if the pattern is invalid or the ordering fails (defects
    /// of the caller).
    pub fn analyze(
        n: usize,
        col_ptr: Vec<usize>,
        row_idx: Vec<usize>,
    ) -> Result<Self, FactorError> {
        let analysis = |e: String| FactorError::Analysis(e);
        let pattern = SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx);
        let symbolic = factorize_symbolic_lu(pattern.as_ref(), LuSymbolicParams::default())
            .map_err(|e| analysis(format!("{e:?}")))?;
        let scratch = MemBuffer::try_new(StackReq::any_of(&[
            symbolic.factorize_numeric_lu_scratch::<f64>(
                Par::Seq,
                Spec::<PartialPivLuParams, f64>::default(),
            ),
            symbolic.solve_in_place_scratch::<f64>(1, Par::Seq),
            symbolic.solve_transpose_in_place_scratch::<f64>(1, Par::Seq),
        ]))
        .map_err(|e| analysis(format!("{e:?}")))?;
        Ok(Self {
            pattern,
            symbolic,
            numeric: NumericLu::new(),
            scratch,
            factorized: false,
        })
    }

    /// Numeric factorization of the matrix with CSC `values` on the analyzed pattern.
    ///
    /// # Errors
    /// [`FactorError::Singular`] if a column has no entry left to pivot on (structurally
    /// singular); a numerically zero pivot shows in the solve instead.
    pub fn factorize(&mut self, values: &[f64]) -> Result<(), FactorError> {
        self.factorized = false;
        let matrix = SparseColMatRef::new(self.pattern.as_ref(), values);
        self.symbolic
            .factorize_numeric_lu(
                &mut self.numeric,
                matrix,
                Par::Seq,
                MemStack::new(&mut self.scratch),
                Spec::<PartialPivLuParams, f64>::default(),
            )
            .map_err(|e| FactorError::Singular(format!("{e:?}")))?;
        self.factorized = true;
        Ok(())
    }

    /// Solves `A x = b` (or `Aᵀ x = b` with `transpose`) in place.
    ///
    /// # Errors
    /// [`FactorError::Singular`] without a successful factorization or for a non-finite
    /// solution (a zero pivot).
    pub fn solve_in_place(&mut self, b: &mut [f64], transpose: bool) -> Result<(), FactorError> {
        if !self.factorized {
            return Err(FactorError::Singular(
                "no successful factorization to solve with".into(),
            ));
        }
        let n = b.len();
        let lu = LuRef::new_unchecked(&self.symbolic, &self.numeric);
        let rhs = MatMut::from_column_major_slice_mut(b, n, 1);
        let stack = MemStack::new(&mut self.scratch);
        if transpose {
            lu.solve_transpose_in_place_with_conj(Conj::No, rhs, Par::Seq, stack);
        } else {
            lu.solve_in_place_with_conj(Conj::No, rhs, Par::Seq, stack);
        }
        if b.iter().all(|v| v.is_finite()) {
            Ok(())
        } else {
            Err(FactorError::Singular(
                "non-finite solution (a zero pivot)".into(),
            ))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A non-symmetric saddle-point matrix `[A, Bᵀ; B, 0]` with a zero diagonal block, its
    /// solution and its transpose's against a dense product.
    #[test]
    fn solves_a_saddle_point_and_its_transpose() {
        // Columns of a 4 × 4 matrix, (row, value); the last unknown a multiplier.
        let columns: [&[(usize, f64)]; 4] = [
            &[(0, 4.0), (1, 1.0), (3, 1.0)],
            &[(0, -2.0), (1, 5.0), (2, 1.0)],
            &[(1, 0.5), (2, 3.0), (3, 2.0)],
            &[(0, 1.0), (2, 2.0)],
        ];
        let mut col_ptr = vec![0];
        let (mut rows, mut values) = (vec![], vec![]);
        for c in columns {
            rows.extend(c.iter().map(|e| e.0));
            values.extend(c.iter().map(|e| e.1));
            col_ptr.push(rows.len());
        }
        let dense = |i: usize, j: usize| columns[j].iter().find(|e| e.0 == i).map_or(0.0, |e| e.1);
        let mut lu = Lu::analyze(4, col_ptr, rows).unwrap();
        lu.factorize(&values).unwrap();
        for transpose in [false, true] {
            let b = [1.0, -2.0, 0.5, 3.0];
            let mut x = b;
            lu.solve_in_place(&mut x, transpose).unwrap();
            for (i, bi) in b.iter().enumerate() {
                let ax: f64 = (0..4)
                    .map(|j| if transpose { dense(j, i) } else { dense(i, j) } * x[j])
                    .sum();
                assert!((ax - bi).abs() < 1e-13, "row {i}: {ax} against {bi}");
            }
        }
    }

    #[test]
    fn a_singular_matrix_is_named() {
        let mut lu = Lu::analyze(2, vec![0, 2, 4], vec![0, 1, 0, 1]).unwrap();
        lu.factorize(&[1.0, 2.0, 2.0, 4.0]).unwrap();
        let mut x = [1.0, 1.0];
        assert!(matches!(
            lu.solve_in_place(&mut x, false),
            Err(FactorError::Singular(_))
        ));
    }
}
