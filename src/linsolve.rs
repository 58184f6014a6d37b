//! Sparse symmetric factorization of the iteration matrix — the only module that touches
//! faer.
//!
//! The iteration matrix is symmetric and, in the augmented-Lagrangian form the assembly
//! produces (see [`crate::assembly`]), its DOF block is positive definite whenever the
//! mechanism is properly constrained. An `LDLᵀ` factorization without pivoting then exists
//! as soon as every multiplier is eliminated after all the DOFs its constraint touches:
//! each DOF pivot is a Schur complement of a positive definite matrix, each multiplier
//! pivot is `−bᵀA⁻¹b < 0`. So the ordering is an approximate minimum degree (AMD) ordering of
//! the DOF block with each multiplier inserted right after its last DOF. Compared with a
//! partial-pivoting LU (which must order for the pattern of `AᵀA`, nearly dense for a ground
//! structure), this halves the work and keeps the fill of a symmetric ordering.
//!
//! Symbolic analysis happens once per simulation ([`SparseLdlt::analyze`]); each Newton
//! iteration refactors numerically into buffers kept from the previous call, so the loop
//! does not allocate. A zero pivot is reported with its unknown
//! ([`FactorError::ZeroPivot`]), non-finite factors or solutions as [`FactorError::Singular`].

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::ldlt::factor::{LdltError, LdltParams, LdltRegularization};
use faer::perm::PermRef;
use faer::sparse::linalg::amd;
use faer::sparse::linalg::cholesky::simplicial::SimplicialLdltRef;
use faer::sparse::linalg::cholesky::supernodal::SupernodalLdltRef;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, LdltRef, SymbolicCholesky,
    SymbolicCholeskyRaw, SymmetricOrdering,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat};
use faer::{Conj, MatMut, Par, Side, Spec};

/// Why a factorization or solve failed.
#[derive(Debug, Clone, PartialEq)]
pub enum FactorError {
    /// A zero (or non-finite) pivot at `unknown`, an index of the matrix as given.
    ZeroPivot {
        /// The unknown whose pivot vanished.
        unknown: usize,
    },
    /// Non-finite factors or solution.
    Singular(String),
    /// The symbolic analysis failed (a pattern or ordering the engine built is invalid).
    Analysis(String),
}

/// `LDLᵀ` factorization of a symmetric saddle-point matrix with a fixed pattern.
pub struct SparseLdlt {
    pattern: SymbolicSparseColMat<usize>,
    symbolic: SymbolicCholesky<usize>,
    /// `order[k]`: the unknown eliminated `k`-th.
    order: Vec<usize>,
    factors: Vec<f64>,
    factor_scratch: MemBuffer,
    solve_scratch: MemBuffer,
    factorized: bool,
}

impl SparseLdlt {
    /// Symbolic analysis of the symmetric CSC pattern `(col_ptr, row_idx)` (both triangles)
    /// of an `n × n` matrix whose first `n_q` unknowns are DOFs and whose unknown `n_q + k`
    /// is a multiplier acting on the DOFs `multiplier_dofs[k]`.
    ///
    /// # Errors
    /// [`FactorError::Analysis`] if the ordering or the symbolic factorization fails, or a
    /// constraint acts on no DOF (defects of the caller; an invalid CSC structure is
    /// faer's own check).
    pub fn analyze(
        n: usize,
        col_ptr: Vec<usize>,
        row_idx: Vec<usize>,
        n_q: usize,
        multiplier_dofs: &[Vec<usize>],
    ) -> Result<Self, FactorError> {
        let pattern = SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx);
        let (fwd, inv) = saddle_point_ordering(&pattern, n_q, multiplier_dofs)?;
        let perm = PermRef::new_checked(&fwd, &inv, n);
        let symbolic = factorize_symbolic_cholesky(
            pattern.as_ref(),
            Side::Lower,
            SymmetricOrdering::Custom(perm),
            CholeskySymbolicParams::default(),
        )
        .map_err(|e| FactorError::Analysis(format!("symbolic Cholesky: {e:?}")))?;
        let factor_req = symbolic
            .factorize_numeric_ldlt_scratch::<f64>(Par::Seq, Spec::<LdltParams, f64>::default());
        let solve_req = symbolic.solve_in_place_scratch::<f64>(1, Par::Seq);
        Ok(Self {
            factors: vec![0.0; symbolic.len_val()],
            order: fwd,
            pattern,
            symbolic,
            factor_scratch: MemBuffer::new(factor_req),
            solve_scratch: MemBuffer::new(solve_req),
            factorized: false,
        })
    }

    /// Scratch for solving `nrhs` right-hand sides at once from one thread.
    pub fn scratch_for(&self, nrhs: usize) -> MemBuffer {
        MemBuffer::new(self.symbolic.solve_in_place_scratch::<f64>(nrhs, Par::Seq))
    }

    /// Numeric factorization of the matrix with CSC `values` on the analyzed pattern.
    pub fn factorize(&mut self, values: &[f64]) -> Result<(), FactorError> {
        self.factorized = false;
        let matrix = SparseColMatRef::new(self.pattern.as_ref(), values);
        let result = self
            .symbolic
            .factorize_numeric_ldlt(
                &mut self.factors,
                matrix,
                Side::Lower,
                LdltRegularization::default(),
                Par::Seq,
                MemStack::new(&mut self.factor_scratch),
                Spec::<LdltParams, f64>::default(),
            )
            .map(|_| ());
        match result {
            Ok(_) if self.factors.iter().all(|v| v.is_finite()) => {
                self.factorized = true;
                Ok(())
            }
            Ok(_) => Err(FactorError::Singular("non-finite factors".into())),
            // faer counts the failed pivot from 1 (`k + 1` in its simplicial LDLᵀ).
            Err(LdltError::ZeroPivot { index }) => Err(FactorError::ZeroPivot {
                unknown: self.order[index.saturating_sub(1)],
            }),
        }
    }

    /// The factors, or an error if the last factorization failed (or none was made).
    fn factors(&self) -> Result<LdltRef<'_, usize, f64>, FactorError> {
        if !self.factorized {
            return Err(FactorError::Singular(
                "no successful factorization to solve with".into(),
            ));
        }
        Ok(LdltRef::new(&self.symbolic, &self.factors))
    }

    /// Solves `A x = b` in place (`b` overwritten by `x`).
    pub fn solve_in_place(&mut self, b: &mut [f64]) -> Result<(), FactorError> {
        self.factors()?;
        let ldlt = LdltRef::new(&self.symbolic, &self.factors);
        let n = b.len();
        ldlt.solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(b, n, 1),
            Par::Seq,
            MemStack::new(&mut self.solve_scratch),
        );
        finite(b)
    }

    /// Solves `A X = B` for a column-major block `b` of `nrhs` columns, with caller scratch
    /// from [`SparseLdlt::scratch_for`]; usable from several threads at once.
    pub fn solve_block(
        &self,
        b: &mut [f64],
        nrhs: usize,
        scratch: &mut MemBuffer,
    ) -> Result<(), FactorError> {
        let n = self.pattern.nrows();
        let block = MatMut::from_column_major_slice_mut(b, n, nrhs);
        self.factors()?
            .solve_in_place_with_conj(Conj::No, block, Par::Seq, MemStack::new(scratch));
        finite(b)
    }

    /// Number of negative pivots `D_kk < 0` of the last factorization. `LDLᵀ` is a
    /// congruence, so by Sylvester's law of inertia this is the number of negative
    /// eigenvalues of the matrix: the Sturm-sequence count of the modal analysis.
    pub fn negative_pivots(&self) -> Result<usize, FactorError> {
        self.factors()?;
        let negative = |d: f64| usize::from(d < 0.0);
        Ok(match self.symbolic.raw() {
            SymbolicCholeskyRaw::Simplicial(symbolic) => {
                let l = SimplicialLdltRef::new(symbolic, &self.factors);
                let pattern = symbolic.factor();
                (0..symbolic.ncols())
                    .map(|j| {
                        let column = pattern.col_ptr()[j]..pattern.col_ptr()[j + 1];
                        pattern.row_idx()[column.clone()]
                            .iter()
                            .zip(&l.values()[column])
                            .find(|(&i, _)| i == j)
                            .map_or(0, |(_, &d)| negative(d))
                    })
                    .sum()
            }
            SymbolicCholeskyRaw::Supernodal(symbolic) => {
                let l = SupernodalLdltRef::new(symbolic, &self.factors);
                (0..symbolic.n_supernodes())
                    .map(|s| {
                        let block = l.supernode(s).val();
                        (0..block.ncols())
                            .map(|k| negative(block[(k, k)]))
                            .sum::<usize>()
                    })
                    .sum()
            }
        })
    }
}

/// AMD order of the DOF block, each multiplier inserted right after the last of its DOFs.
fn saddle_point_ordering(
    pattern: &SymbolicSparseColMat<usize>,
    n_q: usize,
    multiplier_dofs: &[Vec<usize>],
) -> Result<(Vec<usize>, Vec<usize>), FactorError> {
    let (cp, ri) = (pattern.col_ptr(), pattern.row_idx());
    let mut block_ptr = vec![0usize; n_q + 1];
    let mut block_idx = Vec::new();
    for j in 0..n_q {
        block_idx.extend(ri[cp[j]..cp[j + 1]].iter().copied().filter(|&i| i < n_q));
        block_ptr[j + 1] = block_idx.len();
    }
    let block = SymbolicSparseColMat::new_checked(n_q, n_q, block_ptr, None, block_idx);
    let (mut dof_fwd, mut dof_inv) = (vec![0usize; n_q], vec![0usize; n_q]);
    let mut mem = MemBuffer::new(amd::order_scratch::<usize>(n_q, block.compute_nnz()));
    amd::order(
        &mut dof_fwd,
        &mut dof_inv,
        block.as_ref(),
        amd::Control::default(),
        MemStack::new(&mut mem),
    )
    .map_err(|e| FactorError::Analysis(format!("AMD ordering: {e:?}")))?;
    // For each DOF, the multipliers whose last DOF (in elimination order) it is.
    let mut after: Vec<Vec<usize>> = vec![Vec::new(); n_q];
    for (k, dofs) in multiplier_dofs.iter().enumerate() {
        let last = dofs
            .iter()
            .copied()
            .max_by_key(|&d| dof_inv[d])
            .ok_or_else(|| FactorError::Analysis(format!("constraint row {k} acts on no DOF")))?;
        after[last].push(n_q + k);
    }
    let fwd: Vec<usize> = dof_fwd
        .iter()
        .flat_map(|&d| std::iter::once(d).chain(after[d].iter().copied()))
        .collect();
    let mut inv = vec![0usize; fwd.len()];
    fwd.iter().enumerate().for_each(|(pos, &i)| inv[i] = pos);
    Ok((fwd, inv))
}

fn finite(x: &[f64]) -> Result<(), FactorError> {
    if x.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(FactorError::Singular("non-finite solution".into()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [[2, 1, 1], [1, 3, 0], [1, 0, 0]] in CSC: DOFs 0, 1; multiplier 2 acts on DOF 0.
    fn saddle() -> (Vec<usize>, Vec<usize>, Vec<f64>) {
        (
            vec![0, 3, 5, 6],
            vec![0, 1, 2, 0, 1, 0],
            vec![2.0, 1.0, 1.0, 1.0, 3.0, 1.0],
        )
    }

    #[test]
    fn solves_a_saddle_point_system_and_refactors() {
        let (cp, ri, v) = saddle();
        let mut ldlt = SparseLdlt::analyze(3, cp, ri, 2, &[vec![0]]).unwrap();
        ldlt.factorize(&v).unwrap();
        let mut b = vec![4.0, 4.0, 1.0]; // x = [1, 1, 1]
        ldlt.solve_in_place(&mut b).unwrap();
        assert!(b.iter().all(|x| (x - 1.0).abs() < 1e-14), "{b:?}");
        let w: Vec<f64> = v.iter().map(|x| 2.0 * x).collect();
        ldlt.factorize(&w).unwrap();
        let mut block = vec![8.0, 8.0, 2.0, 4.0, 4.0, 1.0];
        let mut scratch = ldlt.scratch_for(2);
        ldlt.solve_block(&mut block, 2, &mut scratch).unwrap();
        assert!(
            (block[0] - 1.0).abs() < 1e-14 && (block[5] - 0.5).abs() < 1e-14,
            "{block:?}"
        );
    }

    #[test]
    fn a_constraint_on_no_dof_is_an_analysis_error_not_a_panic() {
        let (cp, ri, _) = saddle();
        let res = SparseLdlt::analyze(3, cp, ri, 2, &[vec![]]);
        assert!(
            matches!(&res, Err(FactorError::Analysis(d)) if d.contains("row 0 acts on no DOF")),
            "{:?}",
            res.err()
        );
    }

    /// Sylvester's law: the DOF block `[[2, 1], [1, 3]]` on the null space of the
    /// constraint (DOF 1 alone) is `3`; shifted by `−5` it is `−2`. The negative pivots
    /// count that, plus one per constraint row.
    #[test]
    fn negative_pivots_count_the_inertia() {
        let (cp, ri, v) = saddle();
        let mut ldlt = SparseLdlt::analyze(3, cp, ri, 2, &[vec![0]]).unwrap();
        ldlt.factorize(&v).unwrap();
        assert_eq!(ldlt.negative_pivots(), Ok(1));
        let shifted = [v[0] - 5.0, v[1], v[2], v[3], v[4] - 5.0, v[5]];
        ldlt.factorize(&shifted).unwrap();
        assert_eq!(ldlt.negative_pivots(), Ok(2));
    }

    #[test]
    fn multipliers_follow_their_dofs() {
        let (cp, ri, _) = saddle();
        let pattern = SymbolicSparseColMat::new_checked(3, 3, cp, None, ri);
        let (fwd, inv) = saddle_point_ordering(&pattern, 2, &[vec![0]]).unwrap();
        assert!(inv[2] > inv[0], "{fwd:?}");
    }

    #[test]
    fn singular_matrices_are_reported() {
        let (cp, ri, mut v) = saddle();
        v[2] = 0.0;
        v[5] = 0.0; // the multiplier's row vanishes: its pivot is zero, the DOFs' are not
        let mut ldlt = SparseLdlt::analyze(3, cp, ri, 2, &[vec![0]]).unwrap();
        let res = ldlt.factorize(&v);
        assert_eq!(res, Err(FactorError::ZeroPivot { unknown: 2 }));
        let (_, _, mut v) = saddle();
        v[4] = f64::NAN; // a non-finite pivot is reported as a zero one, at its unknown
        let res = ldlt.factorize(&v);
        assert_eq!(res, Err(FactorError::ZeroPivot { unknown: 1 }));
    }
}
