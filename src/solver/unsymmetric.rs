//! Solves with the spatial iteration matrix `A`, which is not symmetric (gyroscopic terms,
//! the tangent operators `T(Δ)`, the moments' share of the tangent on the rotation group,
//! the joints' constraint-force stiffness): on its block `LU` factors
//! ([`crate::solver::block_lu`]: the nodes' `6 × 6` blocks and the joints' rows in the
//! saddle-point order, no pivoting between blocks), and on faer's partial-pivoting `LU`
//! ([`crate::solver::lu`], analysed then) where a pivot block is singular — a node that
//! only a joint eliminated after it holds, as a rigid body in a static solve. `Aᵀ x = b` (the
//! adjoint's) solves on the same factors. The sensitivities' solves are refined once
//! ([`Unsymmetric::solve_refined`], `x += A⁻¹(b − A x)`): a gradient that vanishes then
//! reads round-off of the values (1e-15 of them) rather than of the factors (unrefined,
//! 4e-14 in `every_joint_kind_has_exact_gradients`); Newton's corrections are not, the
//! iterations' own test deciding where they end.
//!
//! A partial-pivoting `LU` must order for the pattern of `AᵀA` and fills several times
//! more: the paper's arm as a spatial frame at two elements per bar (1078 unknowns, 131
//! steps) ran in 3.6 s on it alone.

use crate::solver::block_lu::{BlockLu, Blocks};
use crate::solver::linsolve::FactorError;
use crate::solver::lu::Lu;

/// Factors of the spatial iteration matrix on a fixed, structurally symmetric CSC pattern
/// (module docs).
pub struct Unsymmetric {
    block: BlockLu,
    /// Whether `block` holds the factors of the last matrix.
    block_ok: bool,
    /// The pattern, for `LU`'s analysis where a block is singular and for `A`'s products.
    pattern: (usize, Vec<usize>, Vec<usize>),
    /// A refinement's residual and its correction.
    residual: Vec<f64>,
    correction: Vec<f64>,
    lu: Option<Lu>,
    fallbacks: usize,
}

impl Unsymmetric {
    /// Symbolic analysis of the `n × n` CSC pattern `(col_ptr, row_idx)` (rows sorted in each
    /// column) whose unknowns come in `blocks`.
    ///
    /// # Errors
    /// As [`BlockLu::analyze`].
    pub fn analyze(
        n: usize,
        col_ptr: Vec<usize>,
        row_idx: Vec<usize>,
        blocks: &Blocks,
    ) -> Result<Self, FactorError> {
        Ok(Self {
            block: BlockLu::analyze(&col_ptr, &row_idx, blocks)?,
            block_ok: false,
            residual: vec![0.0; n],
            correction: vec![0.0; n],
            pattern: (n, col_ptr, row_idx),
            lu: None,
            fallbacks: 0,
        })
    }

    /// Factors `A` of CSC `values`: by blocks, or by `LU` where a pivot block is singular.
    ///
    /// # Errors
    /// [`FactorError::Singular`] (or [`FactorError::Analysis`] of `LU`'s) where neither
    /// factorization succeeds.
    pub fn factorize(&mut self, values: &[f64]) -> Result<(), FactorError> {
        self.block_ok = self.block.factorize(values).is_ok();
        if self.block_ok {
            return Ok(());
        }
        self.fallbacks += 1;
        let lu = match &mut self.lu {
            Some(lu) => lu,
            None => {
                let (n, col_ptr, row_idx) = self.pattern.clone();
                self.lu.insert(Lu::analyze(n, col_ptr, row_idx)?)
            }
        };
        lu.factorize(values)
    }

    /// How many factorizations since the analysis were made by `LU`.
    #[cfg(test)]
    pub fn fallbacks(&self) -> usize {
        self.fallbacks
    }

    /// [`Unsymmetric::solve_in_place`] refined once, `values` those factored last.
    ///
    /// # Errors
    /// As [`Unsymmetric::solve_in_place`].
    pub fn solve_refined(
        &mut self,
        values: &[f64],
        b: &mut [f64],
        transpose: bool,
    ) -> Result<(), FactorError> {
        self.residual.copy_from_slice(b);
        self.solve_in_place(b, transpose)?;
        self.subtract_product(values, b, transpose);
        let mut correction = std::mem::take(&mut self.correction);
        correction.copy_from_slice(&self.residual);
        let solved = self.solve_in_place(&mut correction, transpose);
        b.iter_mut().zip(&correction).for_each(|(x, d)| *x += d);
        self.correction = correction;
        solved
    }

    /// Solves `A x = b` (or `Aᵀ x = b` with `transpose`) in place.
    ///
    /// # Errors
    /// [`FactorError::Singular`] without a successful factorization or for a non-finite
    /// solution.
    pub fn solve_in_place(&mut self, b: &mut [f64], transpose: bool) -> Result<(), FactorError> {
        match (&mut self.lu, self.block_ok) {
            (_, true) => self.block.solve_in_place(b, transpose),
            (Some(lu), false) => lu.solve_in_place(b, transpose),
            (None, false) => Err(FactorError::Singular("no factors".into())),
        }
    }

    /// `residual −= A x` (or `Aᵀ x`), `A` of CSC `values`.
    fn subtract_product(&mut self, values: &[f64], x: &[f64], transpose: bool) {
        let (_, col_ptr, row_idx) = &self.pattern;
        for c in 0..col_ptr.len() - 1 {
            let range = col_ptr[c]..col_ptr[c + 1];
            let entries = row_idx[range.clone()].iter().zip(&values[range]);
            if transpose {
                self.residual[c] -= entries.map(|(&r, v)| v * x[r]).sum::<f64>();
            } else {
                entries.for_each(|(&r, v)| self.residual[r] -= v * x[c]);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A saddle point `[[K, bᵀ], [b, 0]]`, `K` 3 × 3 with a skew part, one multiplier on
    /// DOFs 0 and 2: solved to round-off against the dense matrix, `A x = b` and `Aᵀ x = b`,
    /// by blocks where `K` holds every direction and by `LU` where only the multiplier holds
    /// one (`K`'s last row and column zero).
    #[test]
    fn solves_by_blocks_or_by_lu_where_a_block_is_singular() {
        let n = 4;
        let mut entries = Vec::new();
        for c in 0..3 {
            for r in 0..3 {
                entries.push((c, r));
            }
        }
        entries.extend([(3, 0), (3, 2), (0, 3), (2, 3), (3, 3)]);
        entries.sort();
        let mut col_ptr = vec![0; n + 1];
        entries.iter().for_each(|&(c, _)| col_ptr[c + 1] += 1);
        (0..n).for_each(|c| col_ptr[c + 1] += col_ptr[c]);
        let row_idx: Vec<usize> = entries.iter().map(|&(_, r)| r).collect();
        let dense = |held: f64| {
            let mut a = [[0.0; 4]; 4];
            let k = [[4.0, 1.0, 0.5], [1.0, 3.0, 0.2], [0.5, 0.2, 5.0]];
            for i in 0..3 {
                for j in 0..3 {
                    a[i][j] = (k[i][j] + 0.3 * (i as f64 - j as f64))
                        * if i == 2 || j == 2 { held } else { 1.0 };
                }
            }
            (a[3][0], a[3][2], a[0][3], a[2][3]) = (1.0, 2.0, 1.1, 2.0);
            a
        };
        let blocks = Blocks {
            sizes: vec![3, 1],
            dofs: 1,
        };
        for (held, by_blocks) in [(1.0, true), (0.0, false)] {
            let a = dense(held);
            let values: Vec<f64> = entries.iter().map(|&(c, r)| a[r][c]).collect();
            let mut solver =
                Unsymmetric::analyze(n, col_ptr.clone(), row_idx.clone(), &blocks).unwrap();
            solver.factorize(&values).unwrap();
            for transpose in [false, true] {
                let b = [1.0, -2.0, 0.5, 3.0];
                let mut x = b;
                solver.solve_in_place(&mut x, transpose).unwrap();
                for (i, bi) in b.iter().enumerate() {
                    let ax: f64 = (0..4)
                        .map(|j| if transpose { a[j][i] } else { a[i][j] } * x[j])
                        .sum();
                    assert!((ax - bi).abs() < 1e-13, "held {held}: row {i}: {ax} ≠ {bi}");
                }
            }
            assert_eq!(solver.fallbacks() == 0, by_blocks, "held {held}");
        }
    }
}
