//! Symmetric factorization of the iteration matrix — the only module that touches faer.
//!
//! The iteration matrix is symmetric and, in the augmented-Lagrangian form the assembly
//! produces (see [`crate::solver::assembly`]), its DOF block is positive definite whenever the
//! mechanism is properly constrained. An `LDLᵀ` factorization without pivoting then exists
//! as soon as every multiplier is eliminated after all the DOFs its constraint touches:
//! each DOF pivot is a Schur complement of a positive definite matrix, each multiplier
//! pivot is `−bᵀA⁻¹b < 0`. So the ordering is an approximate minimum degree (AMD) ordering of
//! the DOF block with each multiplier inserted right after its last DOF. Compared with a
//! partial-pivoting LU (which must order for the pattern of `AᵀA`, nearly dense for a ground
//! structure), this halves the work and keeps the fill of a symmetric ordering.
//!
//! Symbolic analysis happens once per simulation ([`Ldlt::analyze`]), on the matrix
//! already in the elimination order; each Newton iteration gathers the values into that
//! order and refactors numerically into buffers kept from the previous call, so the loop
//! does not allocate and faer permutes nothing. Factors that would fill at least [`DENSE_FILL`] of the triangle, in a
//! system of at most [`DENSE_LIMIT`] unknowns (a mechanism of rigid bodies, a small
//! frame), are stored dense in the same order: there a sparse factorization's bookkeeping
//! costs more than the zeros it skips. An unknown whose column holds only its diagonal (a
//! continuum member node's rotation, which no cell reads: a third of a member's unknowns) is
//! its own `1 × 1` block: it is kept out of the factors and solved by a division
//! ([`Decoupled`]). A zero pivot is
//! reported with its unknown ([`FactorError::ZeroPivot`]), non-finite factors or solutions
//! as [`FactorError::Singular`].

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::ldlt::factor::{LdltError, LdltParams, LdltRegularization};
use faer::perm::PermRef;
use faer::sparse::linalg::amd;
use faer::sparse::linalg::cholesky::simplicial::SimplicialLdltRef;
use faer::sparse::linalg::cholesky::supernodal::SupernodalLdltRef;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, LdltRef, SymbolicCholesky,
    SymbolicCholeskyRaw, SymmetricOrdering,
};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat};
use faer::{Conj, MatMut, Par, Side, Spec};

/// The largest system factored as a dense matrix: the largest with a half-filled triangle
/// that was measured had 60 unknowns.
pub const DENSE_LIMIT: usize = 64;

/// The share of the lower triangle from which sparse factors are stored dense: measured
/// on mechanisms and frames of 5 to 540 unknowns (fills 0.04 to 0.8), dense factors were
/// faster from about a half-filled triangle on, sparse ones below (`cargo bench --bench ldlt`, BENCHMARKS.md
/// "Dense factors").
pub const DENSE_FILL: f64 = 0.5;

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

/// The flop ratio (flops of the factorization per nonzero of `L`, in units of faer's 40)
/// above which sparse factors are supernodal (dense blocks of columns that share their
/// pattern, BLAS-3 kernels) rather than simplicial (column by column). faer's own threshold
/// is 1.0, which left a member of 60 × 20 cells simplicial, 1.4 times slower. Measured on
/// plane meshes of one member from 20 × 6 to 120 × 40 cells and on frames (`cargo bench
/// --bench ldlt`, BENCHMARKS.md "Dense factors"): 0.5 makes supernodal the members from
/// 60 × 20 cells on and keeps simplicial the frames and the smaller members (at 40 × 12 the
/// two are within 5 %; 0.4 took it supernodal, 1.3 times slower; 0.6 left 60 × 20 simplicial).
pub const SUPERNODAL_RATIO: f64 = 0.5;

/// How the factors are stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Storage {
    /// Every entry of `L`, in the elimination order.
    Dense,
    /// `L`'s nonzeros on a symbolic analysis (faer), column by column or in supernodes as
    /// [`SUPERNODAL_RATIO`] says.
    Sparse,
    /// Sparse, column by column whatever the ratio (for benchmarks).
    Simplicial,
    /// Sparse, in supernodes whatever the ratio (for benchmarks).
    Supernodal,
}

/// `LDLᵀ` factorization of a symmetric saddle-point matrix with a fixed pattern.
pub struct Ldlt {
    /// `order[k]`: the unknown (of the matrix as given) eliminated `k`-th, of those the
    /// factors hold.
    order: Vec<usize>,
    /// The unknowns outside the factors.
    decoupled: Decoupled,
    numeric: Numeric,
    factorized: bool,
}

/// The unknowns whose row and column hold only the diagonal, each its own `1 × 1` block of
/// the matrix: outside the factors, `x_i = b_i / a_ii`.
struct Decoupled {
    unknowns: Vec<usize>,
    /// Each one's diagonal among the values of the matrix as given.
    slots: Vec<usize>,
    /// Their pivots `a_ii` at the last factorization.
    pivots: Vec<f64>,
}

impl Decoupled {
    /// Those of the first `n_q` unknowns (the DOFs) of the symmetric `pattern` whose column
    /// holds only the diagonal — none where every unknown would be — and the pattern of the
    /// others, each stored value's slot in `pattern`, each unknown's index in it.
    fn split(pattern: &SymbolicSparseColMat<usize>, n_q: usize) -> (Self, Kept) {
        let (cp, ri) = (pattern.col_ptr(), pattern.row_idx());
        let n = pattern.nrows();
        let alone = |j: usize| j < n_q && cp[j + 1] - cp[j] == 1 && ri[cp[j]] == j;
        let mut unknowns: Vec<usize> = (0..n).filter(|&j| alone(j)).collect();
        if unknowns.len() == n {
            unknowns.clear();
        }
        let mut index = vec![usize::MAX; n];
        let mut kept = Vec::with_capacity(n - unknowns.len());
        for j in (0..n).filter(|j| unknowns.binary_search(j).is_err()) {
            index[j] = kept.len();
            kept.push(j);
        }
        let (mut col_ptr, mut row_idx, mut slots) = (vec![0], Vec::new(), Vec::new());
        for &j in &kept {
            for slot in cp[j]..cp[j + 1] {
                row_idx.push(index[ri[slot]]);
                slots.push(slot);
            }
            col_ptr.push(row_idx.len());
        }
        let m = kept.len();
        let decoupled = Self {
            slots: unknowns.iter().map(|&j| cp[j]).collect(),
            pivots: vec![0.0; unknowns.len()],
            unknowns,
        };
        let kept = Kept {
            pattern: SymbolicSparseColMat::new_checked(m, m, col_ptr, None, row_idx),
            slots,
            unknowns: kept,
            index,
        };
        (decoupled, kept)
    }

    /// `b_i /= a_ii` for each decoupled unknown of the column `b`.
    fn solve(&self, b: &mut [f64]) {
        for (&i, &d) in self.unknowns.iter().zip(&self.pivots) {
            b[i] /= d;
        }
    }
}

/// The unknowns the factors hold: their pattern, the slot among the values of the matrix as
/// given of each of its stored values, each one's unknown of the matrix as given, and each
/// unknown's index among them (`usize::MAX` for a decoupled one).
struct Kept {
    pattern: SymbolicSparseColMat<usize>,
    slots: Vec<usize>,
    unknowns: Vec<usize>,
    index: Vec<usize>,
}

/// The numeric phase: sparse factors on a symbolic analysis, or dense ones.
enum Numeric {
    Sparse {
        symbolic: Box<SymbolicCholesky<usize>>,
        /// The matrix in the elimination order, in the triangle the factors read.
        permuted: Permuted,
        factors: Vec<f64>,
        factor_scratch: MemBuffer,
        solve_scratch: MemBuffer,
        /// One permuted right-hand side.
        work: Vec<f64>,
    },
    Dense(Dense),
}

/// The matrix `P A Pᵀ` in the elimination order, kept in the triangle (`side`) faer's
/// numeric phase reads — the upper one for simplicial factors, the lower for supernodal —
/// and analysed in the identity order: each factorization gathers its values through
/// `gather` (a slot of `A` for each of its own) rather than permuting the matrix in faer
/// (its count, scatter and, for the simplicial factors, transpose on every call).
struct Permuted {
    pattern: SymbolicSparseColMat<usize>,
    side: Side,
    gather: Vec<usize>,
    values: Vec<f64>,
}

impl Permuted {
    /// The triangle `side` of `pattern` (read from its lower triangle, as the factors
    /// read it) with unknown `i` moved to `inv[i]`, each stored value gathered from its
    /// slot `slots[k]` of the matrix as given.
    fn new(kept: &Kept, inv: &[usize], side: Side) -> Self {
        let pattern = &kept.pattern;
        let n = pattern.nrows();
        let (cp, ri) = (pattern.col_ptr(), pattern.row_idx());
        let mut entries: Vec<(usize, usize, usize)> = (0..n)
            .flat_map(|j| (cp[j]..cp[j + 1]).map(move |slot| (ri[slot], j, slot)))
            .filter(|&(i, j, _)| i >= j)
            .map(|(i, j, slot)| {
                let (low, high) = (inv[i].min(inv[j]), inv[i].max(inv[j]));
                match side {
                    Side::Lower => (low, high, slot),
                    Side::Upper => (high, low, slot),
                }
            })
            .collect();
        entries.sort_unstable();
        let mut col_ptr = vec![0; n + 1];
        for &(col, ..) in &entries {
            col_ptr[col + 1] += 1;
        }
        for j in 0..n {
            col_ptr[j + 1] += col_ptr[j];
        }
        let row_idx = entries.iter().map(|&(_, row, _)| row).collect();
        let gather: Vec<usize> = entries.iter().map(|&(.., k)| kept.slots[k]).collect();
        Self {
            pattern: SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx),
            side,
            values: vec![0.0; gather.len()],
            gather,
        }
    }

    /// `values` of `A` gathered into the permuted matrix.
    fn gather(&mut self, values: &[f64]) -> SparseColMatRef<'_, usize, f64> {
        for (v, &slot) in self.values.iter_mut().zip(&self.gather) {
            *v = values[slot];
        }
        SparseColMatRef::new(self.pattern.as_ref(), &self.values)
    }
}

/// A dense `LDLᵀ` in the elimination order: `L` below the diagonal of `a` (column-major,
/// unit diagonal implied), `D` on it, `Lᵀ` above it.
struct Dense {
    n: usize,
    /// Where each value of the matrix as given goes in `a` (`None` for the given upper
    /// triangle and the decoupled unknowns' diagonals).
    slot: Vec<Option<usize>>,
    a: Vec<f64>,
    /// One permuted right-hand side.
    work: Vec<f64>,
}

impl Ldlt {
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
        Self::analyze_with(None, n, col_ptr, row_idx, n_q, multiplier_dofs)
    }

    /// [`Ldlt::analyze`] of a pattern whose unknowns from `n_q` on are multipliers, each
    /// acting on the DOFs its column holds.
    ///
    /// # Errors
    /// As [`Ldlt::analyze`].
    pub fn analyze_saddle_point(
        n: usize,
        n_q: usize,
        col_ptr: Vec<usize>,
        row_idx: Vec<usize>,
    ) -> Result<Self, FactorError> {
        let multiplier_dofs: Vec<Vec<usize>> = (n_q..n)
            .map(|c| {
                let rows = &row_idx[col_ptr[c]..col_ptr[c + 1]];
                rows.iter().copied().filter(|&r| r < n_q).collect()
            })
            .collect();
        Self::analyze(n, col_ptr, row_idx, n_q, &multiplier_dofs)
    }

    /// [`Ldlt::analyze`] with the factors stored as asked.
    ///
    /// # Errors
    /// As [`Ldlt::analyze`].
    pub fn analyze_as(
        storage: Storage,
        n: usize,
        col_ptr: Vec<usize>,
        row_idx: Vec<usize>,
        n_q: usize,
        multiplier_dofs: &[Vec<usize>],
    ) -> Result<Self, FactorError> {
        Self::analyze_with(Some(storage), n, col_ptr, row_idx, n_q, multiplier_dofs)
    }

    /// The ordering and the symbolic analysis, then the storage asked for or, without one,
    /// dense where the sparse factors would fill [`DENSE_FILL`] of a small triangle.
    fn analyze_with(
        storage: Option<Storage>,
        n: usize,
        col_ptr: Vec<usize>,
        row_idx: Vec<usize>,
        n_q: usize,
        multiplier_dofs: &[Vec<usize>],
    ) -> Result<Self, FactorError> {
        let given = SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx);
        let (decoupled, kept) = Decoupled::split(&given, n_q);
        let n_kept = kept.pattern.nrows();
        // A multiplier's DOFs are in its column, so none is decoupled; a caller whose list
        // disagrees with its pattern is named, not indexed past.
        let multiplier_dofs = multiplier_dofs
            .iter()
            .enumerate()
            .map(|(k, dofs)| {
                dofs.iter()
                    .map(|&d| match kept.index.get(d) {
                        Some(&i) if i != usize::MAX => Ok(i),
                        _ => Err(FactorError::Analysis(format!(
                            "constraint row {k} acts on DOF {d}, which its column does not hold"
                        ))),
                    })
                    .collect::<Result<Vec<_>, _>>()
            })
            .collect::<Result<Vec<_>, _>>()?;
        let n_q = n_q - decoupled.unknowns.len();
        let (fwd, inv) = saddle_point_ordering(&kept.pattern, n_q, &multiplier_dofs)?;
        let sparse = |ratio| Numeric::sparse(&kept, &fwd, &inv, SupernodalThreshold(ratio));
        let dense = || Numeric::Dense(Dense::new(&kept, &inv, given.compute_nnz()));
        let numeric = match storage {
            None => match sparse(SUPERNODAL_RATIO)? {
                s if s
                    .fill(n_kept)
                    .is_some_and(|f| n_kept <= DENSE_LIMIT && f >= DENSE_FILL) =>
                {
                    dense()
                }
                s => s,
            },
            Some(Storage::Dense) => dense(),
            Some(Storage::Sparse) => sparse(SUPERNODAL_RATIO)?,
            Some(Storage::Simplicial) => sparse(f64::INFINITY)?,
            Some(Storage::Supernodal) => sparse(0.0)?,
        };
        Ok(Self {
            order: fwd.iter().map(|&k| kept.unknowns[k]).collect(),
            decoupled,
            numeric,
            factorized: false,
        })
    }

    /// The number of unknowns of the matrix as given.
    fn n(&self) -> usize {
        self.order.len() + self.decoupled.unknowns.len()
    }

    /// The share of the lower triangle the sparse factors fill (`None` for dense ones), of
    /// the unknowns they hold.
    pub fn fill(&self) -> Option<f64> {
        self.numeric.fill(self.order.len())
    }

    /// Scratch for solving `nrhs` right-hand sides at once from one thread.
    pub fn scratch_for(&self, nrhs: usize) -> MemBuffer {
        MemBuffer::new(match &self.numeric {
            Numeric::Sparse { symbolic, .. } => StackReq::new::<f64>(self.order.len() * nrhs)
                .and(symbolic.solve_in_place_scratch::<f64>(nrhs, Par::Seq)),
            Numeric::Dense(d) => StackReq::new::<f64>(d.n),
        })
    }

    /// Numeric factorization of the matrix with CSC `values` on the analyzed pattern.
    pub fn factorize(&mut self, values: &[f64]) -> Result<(), FactorError> {
        self.factorized = false;
        let result = match &mut self.numeric {
            Numeric::Sparse {
                symbolic,
                permuted,
                factors,
                factor_scratch,
                ..
            } => {
                let side = permuted.side;
                let matrix = permuted.gather(values);
                let result = symbolic.factorize_numeric_ldlt(
                    factors,
                    matrix,
                    side,
                    LdltRegularization::default(),
                    Par::Seq,
                    MemStack::new(factor_scratch),
                    Spec::<LdltParams, f64>::default(),
                );
                // faer's simplicial LDLᵀ counts the failed pivot from 1 (`k + 1`), its
                // supernodal one from 0.
                let from_one = matches!(symbolic.raw(), SymbolicCholeskyRaw::Simplicial(_));
                result
                    .map(|_| ())
                    .map_err(|LdltError::ZeroPivot { index }| {
                        index.saturating_sub(usize::from(from_one))
                    })
            }
            Numeric::Dense(d) => d.factorize(values),
        };
        let decoupled = &mut self.decoupled;
        for (d, &slot) in decoupled.pivots.iter_mut().zip(&decoupled.slots) {
            *d = values[slot];
        }
        // A subnormal pivot has lost its precision, and its reciprocal overflows: zero. The
        // pivots alone say whether the factors are finite: an entry `L_ij` that is not
        // makes `d_i = a_ii − Σ_j L_ij² d_j` not finite either.
        let (mut lost, mut finite) = (None, true);
        self.for_each_pivot(|k, d| {
            if lost.is_none() && d.abs() < f64::MIN_POSITIVE {
                lost = Some(k);
            }
            finite &= d.is_finite();
        });
        match result.and_then(|()| lost.map_or(Ok(()), Err)) {
            Ok(()) if finite => {
                self.factorized = true;
                Ok(())
            }
            Ok(()) => Err(FactorError::Singular("non-finite factors".into())),
            Err(position) => Err(FactorError::ZeroPivot {
                unknown: self
                    .order
                    .iter()
                    .chain(&self.decoupled.unknowns)
                    .nth(position)
                    .copied()
                    .unwrap_or(position),
            }),
        }
    }

    /// An error if the last factorization failed (or none was made).
    fn check(&self) -> Result<(), FactorError> {
        if self.factorized {
            Ok(())
        } else {
            Err(FactorError::Singular(
                "no successful factorization to solve with".into(),
            ))
        }
    }

    /// Solves `A x = b` in place (`b` overwritten by `x`).
    pub fn solve_in_place(&mut self, b: &mut [f64]) -> Result<(), FactorError> {
        self.check()?;
        match &mut self.numeric {
            Numeric::Sparse {
                symbolic,
                factors,
                solve_scratch,
                work,
                ..
            } => {
                let n = work.len();
                permute(b, &self.order, work);
                LdltRef::new(symbolic, factors).solve_in_place_with_conj(
                    Conj::No,
                    MatMut::from_column_major_slice_mut(work, n, 1),
                    Par::Seq,
                    MemStack::new(solve_scratch),
                );
                unpermute(work, &self.order, b);
            }
            Numeric::Dense(d) => {
                let mut work = std::mem::take(&mut d.work);
                d.solve(b, b.len(), &self.order, &mut work);
                d.work = work;
            }
        }
        self.decoupled.solve(b);
        finite(b)
    }

    /// Solves `A X = B` for a column-major block `b` of `nrhs` columns, with caller scratch
    /// from [`Ldlt::scratch_for`]; usable from several threads at once.
    pub fn solve_block(
        &self,
        b: &mut [f64],
        nrhs: usize,
        scratch: &mut MemBuffer,
    ) -> Result<(), FactorError> {
        self.check()?;
        let (n, kept) = (self.n(), self.order.len());
        match &self.numeric {
            Numeric::Sparse {
                symbolic, factors, ..
            } => {
                let (mut work, stack) = MemStack::new(scratch).make_with(kept * nrhs, |_| 0.0);
                let work = &mut *work;
                for (column, out) in b.chunks(n).zip(work.chunks_mut(kept)) {
                    permute(column, &self.order, out);
                }
                LdltRef::new(symbolic, factors).solve_in_place_with_conj(
                    Conj::No,
                    MatMut::from_column_major_slice_mut(work, kept, nrhs),
                    Par::Seq,
                    stack,
                );
                for (column, out) in work.chunks(kept).zip(b.chunks_mut(n)) {
                    unpermute(column, &self.order, out);
                }
            }
            Numeric::Dense(d) => {
                let (mut work, _) = MemStack::new(scratch).make_with(kept, |_| 0.0);
                d.solve(b, n, &self.order, &mut work);
            }
        }
        b.chunks_mut(n)
            .for_each(|column| self.decoupled.solve(column));
        finite(b)
    }

    /// Number of negative pivots `D_kk < 0` of the last factorization. `LDLᵀ` is a
    /// congruence, so by Sylvester's law of inertia this is the number of negative
    /// eigenvalues of the matrix: the Sturm-sequence count of the modal analysis.
    pub fn negative_pivots(&self) -> Result<usize, FactorError> {
        self.check()?;
        let mut negative = 0;
        self.for_each_pivot(|_, d| negative += usize::from(d < 0.0));
        Ok(negative)
    }

    /// Calls `f(k, D_kk)` for each pivot, `k` its position in the elimination order (the
    /// decoupled unknowns' after the factors').
    fn for_each_pivot(&self, mut f: impl FnMut(usize, f64)) {
        let kept = self.order.len();
        for (k, &d) in self.decoupled.pivots.iter().enumerate() {
            f(kept + k, d);
        }
        match &self.numeric {
            Numeric::Dense(d) => (0..d.n).for_each(|k| f(k, d.a[k * d.n + k])),
            Numeric::Sparse {
                symbolic, factors, ..
            } => match symbolic.raw() {
                SymbolicCholeskyRaw::Simplicial(symbolic) => {
                    let l = SimplicialLdltRef::new(symbolic, factors);
                    let pattern = symbolic.factor();
                    for j in 0..symbolic.ncols() {
                        let column = pattern.col_ptr()[j]..pattern.col_ptr()[j + 1];
                        let rows = pattern.row_idx()[column.clone()].iter();
                        if let Some((_, &d)) = rows.zip(&l.values()[column]).find(|(&i, _)| i == j)
                        {
                            f(j, d);
                        }
                    }
                }
                SymbolicCholeskyRaw::Supernodal(symbolic) => {
                    let l = SupernodalLdltRef::new(symbolic, factors);
                    for s in 0..symbolic.n_supernodes() {
                        let block = l.supernode(s).val();
                        let start = symbolic.supernode_begin()[s];
                        (0..block.ncols()).for_each(|k| f(start + k, block[(k, k)]));
                    }
                }
            },
        }
    }
}

impl Numeric {
    /// The share of the lower triangle of `n` unknowns sparse factors fill.
    fn fill(&self, n: usize) -> Option<f64> {
        let n = n as f64;
        match self {
            Self::Sparse { symbolic, .. } => {
                Some(symbolic.len_val() as f64 / (n * (n + 1.0) / 2.0))
            }
            Self::Dense(_) => None,
        }
    }

    /// The symbolic analysis of `pattern` in the order `(fwd, inv)` and its buffers,
    /// supernodal above the flop ratio `supernodal`.
    fn sparse(
        kept: &Kept,
        fwd: &[usize],
        inv: &[usize],
        supernodal: SupernodalThreshold,
    ) -> Result<Self, FactorError> {
        let pattern = &kept.pattern;
        let perm = PermRef::new_checked(fwd, inv, fwd.len());
        let params = || CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: supernodal,
            ..Default::default()
        };
        let analysis = |e| FactorError::Analysis(format!("symbolic Cholesky: {e:?}"));
        // The analysis in the elimination order tells which factors (simplicial or
        // supernodal) and so which triangle they read; then the permuted matrix in that
        // triangle is analysed in the identity order, the same structure.
        let side = match factorize_symbolic_cholesky(
            pattern.as_ref(),
            Side::Lower,
            SymmetricOrdering::Custom(perm),
            params(),
        )
        .map_err(analysis)?
        .raw()
        {
            SymbolicCholeskyRaw::Simplicial(_) => Side::Upper,
            SymbolicCholeskyRaw::Supernodal(_) => Side::Lower,
        };
        // faer analyses a matrix given in the identity order as its upper triangle,
        // whatever side it is told.
        let upper = Permuted::new(kept, inv, Side::Upper);
        let symbolic = factorize_symbolic_cholesky(
            upper.pattern.as_ref(),
            Side::Upper,
            SymmetricOrdering::Identity,
            params(),
        )
        .map_err(analysis)?;
        let permuted = match side {
            Side::Upper => upper,
            Side::Lower => Permuted::new(kept, inv, Side::Lower),
        };
        let factor_req = symbolic
            .factorize_numeric_ldlt_scratch::<f64>(Par::Seq, Spec::<LdltParams, f64>::default());
        let solve_req = symbolic.solve_in_place_scratch::<f64>(1, Par::Seq);
        Ok(Self::Sparse {
            factors: vec![0.0; symbolic.len_val()],
            symbolic: Box::new(symbolic),
            permuted,
            factor_scratch: MemBuffer::new(factor_req),
            solve_scratch: MemBuffer::new(solve_req),
            work: vec![0.0; fwd.len()],
        })
    }
}

impl Dense {
    /// Room for the factors of the `kept` unknowns eliminated in the order whose inverse is
    /// `inv`, of a matrix of `values` stored values.
    fn new(kept: &Kept, inv: &[usize], values: usize) -> Self {
        let pattern = &kept.pattern;
        let n = pattern.nrows();
        let (cp, ri) = (pattern.col_ptr(), pattern.row_idx());
        // The lower triangle as given (as the sparse factors read it), placed below the
        // diagonal in the elimination order.
        let mut slot = vec![None; values];
        for j in 0..n {
            for k in cp[j]..cp[j + 1] {
                let i = ri[k];
                let (r, c) = (inv[i].max(inv[j]), inv[i].min(inv[j]));
                slot[kept.slots[k]] = (i >= j).then_some(c * n + r);
            }
        }
        Self {
            n,
            slot,
            a: vec![0.0; n * n],
            work: vec![0.0; n],
        }
    }

    /// Scatters `values` into the lower triangle and factors it column by column (the
    /// outer-product form: column `k` becomes `L`'s, its pivot `D_kk`, and updates the
    /// columns right of it); a zero, subnormal or non-finite pivot's position on failure.
    fn factorize(&mut self, values: &[f64]) -> Result<(), usize> {
        let n = self.n;
        let a = &mut self.a;
        a.fill(0.0);
        for (&slot, &v) in self.slot.iter().zip(values) {
            if let Some(k) = slot {
                a[k] = v;
            }
        }
        for k in 0..n {
            // A subnormal pivot has lost its precision, and its reciprocal overflows.
            let d = a[k * n + k];
            if !(d.abs() >= f64::MIN_POSITIVE && d.is_finite()) {
                return Err(k);
            }
            let (done, rest) = a.split_at_mut((k + 1) * n);
            let column = &mut done[k * n + k + 1..];
            for j in 0..column.len() {
                // a[i, k+1+j] −= a[i, k] a[k+1+j, k] / d for i ≥ k+1+j.
                let w = column[j] / d;
                if w != 0.0 {
                    let target = &mut rest[j * n + k + 1 + j..(j + 1) * n];
                    for (t, &c) in target.iter_mut().zip(&column[j..]) {
                        *t -= c * w;
                    }
                }
            }
            column.iter_mut().for_each(|c| *c /= d);
        }
        // Lᵀ above the diagonal, so that both triangular solves run down columns.
        for k in 0..n {
            for i in k + 1..n {
                a[i * n + k] = a[k * n + i];
            }
        }
        Ok(())
    }

    /// Solves for the columns of `b` (column-major, `rows` rows), each permuted by `order`
    /// into `w` (`n` long) and back: `L y = b`, `D z = y`, `Lᵀ x = z`.
    fn solve(&self, b: &mut [f64], rows: usize, order: &[usize], w: &mut [f64]) {
        let n = self.n;
        for col in b.chunks_exact_mut(rows) {
            w.iter_mut().zip(order).for_each(|(w, &i)| *w = col[i]);
            for k in 0..n {
                let (x, below) = (w[k], &self.a[k * n + k + 1..(k + 1) * n]);
                if x != 0.0 {
                    w[k + 1..]
                        .iter_mut()
                        .zip(below)
                        .for_each(|(w, l)| *w -= l * x);
                }
            }
            w.iter_mut()
                .enumerate()
                .for_each(|(k, w)| *w /= self.a[k * n + k]);
            for k in (0..n).rev() {
                let (x, above) = (w[k], &self.a[k * n..k * n + k]);
                if x != 0.0 {
                    w[..k].iter_mut().zip(above).for_each(|(w, u)| *w -= u * x);
                }
            }
            order.iter().zip(w.iter()).for_each(|(&i, &x)| col[i] = x);
        }
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

/// `out[k] = b[order[k]]`: a vector into the elimination order.
fn permute(b: &[f64], order: &[usize], out: &mut [f64]) {
    for (o, &i) in out.iter_mut().zip(order) {
        *o = b[i];
    }
}

/// `out[order[k]] = y[k]`: a vector back from the elimination order.
fn unpermute(y: &[f64], order: &[usize], out: &mut [f64]) {
    for (&v, &i) in y.iter().zip(order) {
        out[i] = v;
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

    /// Every storage: dense, the engine's sparse choice, and both sparse forms forced.
    const ALL: [Storage; 4] = [
        Storage::Dense,
        Storage::Sparse,
        Storage::Simplicial,
        Storage::Supernodal,
    ];

    #[test]
    fn solves_a_saddle_point_system_and_refactors() {
        for storage in ALL {
            solves_and_refactors(storage);
        }
    }

    fn solves_and_refactors(storage: Storage) {
        let (cp, ri, v) = saddle();
        let mut ldlt = Ldlt::analyze_as(storage, 3, cp, ri, 2, &[vec![0]]).unwrap();
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

    /// A symmetric saddle-point system in CSC (both triangles): a chain of `n_q` DOFs with
    /// `diagonal(i)` on the diagonal and `−1` between neighbours `i`, `i + 1` where
    /// `linked(i)`, and a row `x_a − ½ x_b` per pair `[a, b]` of `dofs`.
    struct Chain {
        columns: Vec<Vec<(usize, f64)>>,
        col_ptr: Vec<usize>,
        row_idx: Vec<usize>,
        values: Vec<f64>,
    }

    impl Chain {
        fn new(
            n_q: usize,
            dofs: &[Vec<usize>],
            diagonal: impl Fn(usize) -> f64,
            linked: impl Fn(usize) -> bool,
        ) -> Self {
            let mut columns: Vec<Vec<(usize, f64)>> = vec![Vec::new(); n_q + dofs.len()];
            let mut put = |i: usize, j: usize, v: f64| {
                columns[j].push((i, v));
                if i != j {
                    columns[i].push((j, v));
                }
            };
            for i in 0..n_q {
                put(i, i, diagonal(i));
                if i + 1 < n_q && linked(i) {
                    put(i + 1, i, -1.0);
                }
            }
            for (k, d) in dofs.iter().enumerate() {
                put(n_q + k, d[0], 1.0);
                put(n_q + k, d[1], -0.5);
            }
            let (mut col_ptr, mut row_idx, mut values) = (vec![0], Vec::new(), Vec::new());
            for column in &mut columns {
                column.sort_by_key(|e| e.0);
                row_idx.extend(column.iter().map(|e| e.0));
                values.extend(column.iter().map(|e| e.1));
                col_ptr.push(row_idx.len());
            }
            Self {
                columns,
                col_ptr,
                row_idx,
                values,
            }
        }

        /// `A x`.
        fn times(&self, x: &[f64]) -> Vec<f64> {
            let mut y = vec![0.0; self.columns.len()];
            for (j, column) in self.columns.iter().enumerate() {
                column.iter().for_each(|&(i, a)| y[i] += a * x[j]);
            }
            y
        }

        fn analyze(&self, storage: Storage, n_q: usize, dofs: &[Vec<usize>]) -> Ldlt {
            let (cp, ri) = (self.col_ptr.clone(), self.row_idx.clone());
            Ldlt::analyze_as(storage, self.columns.len(), cp, ri, n_q, dofs).unwrap()
        }
    }

    /// A chain of twelve DOFs whose 5th and 9th stand alone (a diagonal only, one of them
    /// negative), two rows tying DOFs 0–1 and 2–3: every storage keeps those two out of
    /// its factors, solves one right-hand side and a block to round-off, counts the
    /// negative alone pivot in the inertia and names a zero one.
    #[test]
    fn decoupled_unknowns_are_solved_outside_the_factors() {
        let (n_q, alone) = (12, [5, 9]);
        let n = n_q + 2;
        let dofs = [vec![0, 1], vec![2, 3]];
        let diagonal = |i: usize| if i == 9 { -2.0 } else { 3.0 + (i % 4) as f64 };
        let linked = |i: usize| !alone.contains(&i) && !alone.contains(&(i + 1));
        let system = Chain::new(n_q, &dofs, diagonal, linked);
        let (cp, v, times) = (&system.col_ptr, &system.values, |x: &[f64]| system.times(x));
        let want: Vec<f64> = (0..2 * n).map(|i| ((i * 5) % 7) as f64 - 3.0).collect();
        for storage in ALL {
            let mut ldlt = system.analyze(storage, n_q, &dofs);
            assert_eq!(ldlt.decoupled.unknowns, alone);
            assert!(!ldlt.order.iter().any(|i| alone.contains(i)));
            ldlt.factorize(v).unwrap();
            let mut one = times(&want[..n]);
            ldlt.solve_in_place(&mut one).unwrap();
            let mut block = [times(&want[..n]), times(&want[n..])].concat();
            ldlt.solve_block(&mut block, 2, &mut ldlt.scratch_for(2))
                .unwrap();
            for (x, w) in one.iter().chain(&block).zip(want[..n].iter().chain(&want)) {
                assert!((x - w).abs() < 1e-13, "{storage:?}: {x} vs {w}");
            }
            assert_eq!(ldlt.negative_pivots(), Ok(3), "{storage:?}");
            let mut zero = v.clone();
            zero[cp[9]] = 0.0;
            let failed = ldlt.factorize(&zero);
            assert_eq!(failed, Err(FactorError::ZeroPivot { unknown: 9 }));
        }
        // A row said to act on a DOF its column does not hold (one alone, or none at all)
        // is an analysis error, not an index past the end.
        for wrong in [5, 99] {
            let (cp, ri) = (system.col_ptr.clone(), system.row_idx.clone());
            let said = [vec![0, 1], vec![2, wrong]];
            let res = Ldlt::analyze(n, cp, ri, n_q, &said);
            assert!(
                matches!(&res, Err(FactorError::Analysis(d)) if d.contains("row 1 acts on DOF")),
                "{:?}",
                res.err()
            );
        }
    }

    #[test]
    fn a_constraint_on_no_dof_is_an_analysis_error_not_a_panic() {
        let (cp, ri, _) = saddle();
        let res = Ldlt::analyze(3, cp, ri, 2, &[vec![]]);
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
        for storage in ALL {
            let (cp, ri, v) = saddle();
            let mut ldlt = Ldlt::analyze_as(storage, 3, cp, ri, 2, &[vec![0]]).unwrap();
            ldlt.factorize(&v).unwrap();
            assert_eq!(ldlt.negative_pivots(), Ok(1));
            let shifted = [v[0] - 5.0, v[1], v[2], v[3], v[4] - 5.0, v[5]];
            ldlt.factorize(&shifted).unwrap();
            assert_eq!(ldlt.negative_pivots(), Ok(2), "{storage:?}");
        }
    }

    /// A chain of `n_q` unknowns with springs to the ground, `n_c` rows tying unknown
    /// `2k` to `2k + 1`: dense, simplicial and supernodal factors solve it alike, to
    /// round-off, for one right-hand side and for a block.
    #[test]
    fn dense_and_sparse_factors_agree_on_a_larger_system() {
        let (n_q, n_c) = (40, 12);
        let n = n_q + n_c;
        let dofs: Vec<Vec<usize>> = (0..n_c).map(|k| vec![2 * k, 2 * k + 1]).collect();
        let system = Chain::new(n_q, &dofs, |i| 3.0 + (i % 5) as f64, |_| true);
        let times = |x: &[f64]| system.times(x);
        let (cp, ri, v) = (&system.col_ptr, &system.row_idx, &system.values);
        let want: Vec<Vec<f64>> = (0..2)
            .map(|c| {
                (0..n)
                    .map(|i| ((i * 7 + c * 3) % 11) as f64 - 5.0)
                    .collect()
            })
            .collect();
        let mut got = Vec::new();
        for storage in ALL {
            let mut ldlt = system.analyze(storage, n_q, &dofs);
            ldlt.factorize(v).unwrap();
            let mut one = times(&want[0]);
            ldlt.solve_in_place(&mut one).unwrap();
            let mut block = [times(&want[0]), times(&want[1])].concat();
            ldlt.solve_block(&mut block, 2, &mut ldlt.scratch_for(2))
                .unwrap();
            for (x, w) in one
                .iter()
                .chain(&block)
                .zip(want[0].iter().chain(&want.concat()))
            {
                assert!((x - w).abs() < 1e-12, "{storage:?}: {x} vs {w}");
            }
            got.push(ldlt.negative_pivots().unwrap());
        }
        assert_eq!(got, [n_c; 4]);
        // A chain fills little of the triangle: the engine keeps it sparse; the small
        // saddle above it stores dense.
        let chain = Ldlt::analyze(n, cp.clone(), ri.clone(), n_q, &dofs).unwrap();
        assert!(
            chain.fill().is_some_and(|f| f < DENSE_FILL),
            "{:?}",
            chain.fill()
        );
        let (cp, ri, _) = saddle();
        assert_eq!(
            Ldlt::analyze(3, cp, ri, 2, &[vec![0]]).unwrap().fill(),
            None
        );
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
        for storage in ALL {
            let (cp, ri) = (cp.clone(), ri.clone());
            let mut ldlt = Ldlt::analyze_as(storage, 3, cp, ri, 2, &[vec![0]]).unwrap();
            let res = ldlt.factorize(&v);
            assert_eq!(
                res,
                Err(FactorError::ZeroPivot { unknown: 2 }),
                "{storage:?}"
            );
            let (_, _, mut v) = saddle();
            v[4] = f64::NAN; // a non-finite pivot is reported as a zero one, at its unknown
            let res = ldlt.factorize(&v);
            assert_eq!(
                res,
                Err(FactorError::ZeroPivot { unknown: 1 }),
                "{storage:?}"
            );
        }
    }
}
