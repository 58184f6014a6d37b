//! Block `LU` of a sparse matrix whose unknowns come in small blocks — the six of a spatial
//! node, the rows of a joint — without pivoting between blocks and with partial pivoting
//! inside each diagonal block:
//!
//! ```text
//! A = (I + L) D (I + D⁻¹ W),   L_ap = A_ap D_p⁻¹,   W_pa = A_pa   (block a after block p)
//! ```
//!
//! the entries `A_ap`, `A_pa` and `D_p` being those of the Schur complement left when block
//! `p` is eliminated. The order is the saddle-point order of [`crate::solver::linsolve`] by
//! blocks: an approximate minimum degree order of the DOF blocks' graph, each multiplier block
//! right after the last of its DOF blocks, so that each DOF pivot block is a Schur complement
//! of the mass- or stiffness-dominated DOF block and each multiplier pivot block
//! `−B S⁻¹ Bᵀ`. Dense `6 × 6` products replace the scalar factorization's indirection on a
//! matrix whose every entry couples whole blocks, and the factors are `A`'s own, so a
//! non-symmetric `A` needs no refinement. A pivot block that is singular (to
//! [`SINGULAR_PIVOT`] of its largest entry) is reported, for the caller to factor otherwise.
//!
//! Where a pivot's column reaches [`FRONT_BLOCKS`] blocks or more (a lattice's wide fronts),
//! its update is one dense product of the stacked blocks (faer's, on the machine's widest
//! vectors). [`BlockLu::analyze`] finds the order, the blocks' fill and where each entry of
//! `A` goes, once; [`BlockLu::factorize`] and the solves then work in buffers kept from that
//! analysis.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::amd;
use faer::sparse::SymbolicSparseColMat;
use faer::{Accum, MatMut, MatRef, Par};

use crate::solver::linsolve::FactorError;

/// A pivot this small against its block's largest entry makes the block singular.
pub const SINGULAR_PIVOT: f64 = 1e-13;

/// The fewest blocks a pivot's column reaches for its update `L_p W_p` to be made as one
/// dense product of the stacked blocks (faer's, on the machine's widest vectors) rather than a
/// `6 × 6` product per pair: a lattice's wide fronts.
pub const FRONT_BLOCKS: usize = 4;

/// The most rows a front stacked for one product may have (its product's scratch is their
/// square): wider fronts are updated pair by pair.
pub const MAX_FRONT_ROWS: usize = 768;

/// The block sizes and the count of DOF blocks of a matrix's unknowns (module docs).
pub struct Blocks {
    /// Each block's count of unknowns, in the unknowns' order (a block's unknowns are
    /// consecutive).
    pub sizes: Vec<usize>,
    /// Blocks `0..dofs` hold DOFs; the others multipliers.
    pub dofs: usize,
}

/// Block `LU` factors on an analysed pattern (module docs). Indices named `p`, `a`, `b` are
/// positions in the elimination order.
pub struct BlockLu {
    /// The first unknown and the size of the block at each position.
    at: Vec<usize>,
    size: Vec<usize>,
    /// The positions after `p` its column reaches, sorted: `rows[first[p]..first[p + 1]]`.
    first: Vec<usize>,
    rows: Vec<usize>,
    /// Where `D_p` (`D_p⁻¹` once factored) starts in `values`.
    diag: Vec<usize>,
    /// Where `L_ap` and `W_pa` start, for each entry of `rows`.
    lower: Vec<usize>,
    upper: Vec<usize>,
    /// Where each block column's storage ends.
    end: Vec<usize>,
    /// For each position `p` and each pair `a < b` its column reaches, in order, the entry
    /// of `rows` where `b` lies in `a`'s column (the fill puts it there): what `L_bp W_pa`
    /// and `L_ap W_pb` update, found once; position `p`'s from `pair_first[p]` on.
    pairs: Vec<usize>,
    pair_first: Vec<usize>,
    /// All blocks, column-major each.
    values: Vec<f64>,
    /// Where each entry of `A`'s CSC values goes in `values`.
    scatter: Vec<usize>,
    /// Room for a block's inverse and products, and a solve's block.
    work: Vec<f64>,
    pivots: Vec<usize>,
    /// Room for a front's stacked `L_p`, `W_p` and their product, and where each block's
    /// rows start in it.
    front: Vec<f64>,
    front_at: Vec<usize>,
    /// The rows of each position's front where it is updated as one product, 0 where pair
    /// by pair.
    front_rows: Vec<usize>,
}

impl BlockLu {
    /// Symbolic analysis of the `n × n` CSC pattern `(col_ptr, row_idx)` (structurally
    /// symmetric) with unknowns in `blocks`.
    ///
    /// # Errors
    /// [`FactorError::Analysis`] if the blocks do not cover the unknowns, a multiplier block
    /// acts on no DOF block, or the ordering fails.
    pub fn analyze(
        col_ptr: &[usize],
        row_idx: &[usize],
        blocks: &Blocks,
    ) -> Result<Self, FactorError> {
        let n = col_ptr.len() - 1;
        let (start, block_of) = block_map(&blocks.sizes, n)?;
        let graph = block_graph(col_ptr, row_idx, &block_of);
        let order = saddle_point_order(&graph, blocks.dofs)?;
        let mut position = vec![0; order.len()];
        order.iter().enumerate().for_each(|(p, &k)| position[k] = p);
        let (first, rows) = fill(&graph, &order, &position);
        let size: Vec<usize> = order.iter().map(|&k| blocks.sizes[k]).collect();
        let at: Vec<usize> = order.iter().map(|&k| start[k]).collect();
        let mut lu = Self {
            at,
            first,
            rows,
            diag: Vec::with_capacity(order.len()),
            lower: Vec::new(),
            upper: Vec::new(),
            pairs: Vec::new(),
            pair_first: Vec::new(),
            end: Vec::with_capacity(order.len()),
            values: Vec::new(),
            scatter: Vec::with_capacity(row_idx.len()),
            work: Vec::new(),
            pivots: Vec::new(),
            front: Vec::new(),
            front_at: Vec::new(),
            front_rows: Vec::new(),
            size,
        };
        lu.lay_out();
        for c in 0..n {
            for &r in &row_idx[col_ptr[c]..col_ptr[c + 1]] {
                let (pr, pc) = (position[block_of[r]], position[block_of[c]]);
                let slot = lu.slot(pr, pc)?;
                let (i, j) = (r - lu.at[pr], c - lu.at[pc]);
                lu.scatter.push(slot + i + j * lu.size[pr]);
            }
        }
        Ok(lu)
    }

    /// Places every block in `values` and sizes the work space.
    fn lay_out(&mut self) {
        let mut offset = 0;
        for p in 0..self.size.len() {
            let s = self.size[p];
            self.diag.push(offset);
            offset += s * s;
            for &a in &self.rows[self.first[p]..self.first[p + 1]] {
                self.lower.push(offset);
                self.upper.push(offset + s * self.size[a]);
                offset += 2 * s * self.size[a];
            }
            self.end.push(offset);
        }
        self.values = vec![0.0; offset];
        for p in 0..self.size.len() {
            self.pair_first.push(self.pairs.len());
            let entries = &self.rows[self.first[p]..self.first[p + 1]];
            for (ia, &a) in entries.iter().enumerate() {
                let mut k = self.first[a];
                for &b in &entries[ia + 1..] {
                    while self.rows[k] != b {
                        k += 1;
                    }
                    self.pairs.push(k);
                }
            }
        }
        let (mut rows, mut reach) = (0, 0);
        for p in 0..self.size.len() {
            let entries = &self.rows[self.first[p]..self.first[p + 1]];
            let r: usize = entries.iter().map(|&a| self.size[a]).sum();
            let wide = entries.len() >= FRONT_BLOCKS && r <= MAX_FRONT_ROWS;
            self.front_rows.push(if wide { r } else { 0 });
            if wide {
                rows = rows.max(r + 2 * self.size[p]);
                reach = reach.max(entries.len());
            }
        }
        self.front = vec![0.0; rows * rows];
        self.front_at = vec![0; reach];
        let largest = self.size.iter().copied().max().unwrap_or(0);
        self.work = vec![0.0; 3 * largest * largest];
        self.pivots = vec![0; largest];
    }

    /// Where the block of positions `(pr, pc)` starts: `D`, `L` below, `W` above.
    fn slot(&self, pr: usize, pc: usize) -> Result<usize, FactorError> {
        let (column, row) = (pr.min(pc), pr.max(pc));
        if column == row {
            return Ok(self.diag[column]);
        }
        let entries = self.first[column]..self.first[column + 1];
        let k = self.rows[entries.clone()]
            .binary_search(&row)
            .map_err(|_| FactorError::Analysis("a block outside the fill".into()))?;
        Ok(if pr > pc { &self.lower } else { &self.upper }[entries.start + k])
    }

    /// Numeric factorization of the matrix with CSC `values` on the analysed pattern.
    ///
    /// # Errors
    /// [`FactorError::ZeroPivot`] at the first unknown of a singular pivot block.
    pub fn factorize(&mut self, values: &[f64]) -> Result<(), FactorError> {
        self.values.fill(0.0);
        for (&slot, &v) in self.scatter.iter().zip(values) {
            self.values[slot] = v;
        }
        for p in 0..self.size.len() {
            self.eliminate(p)?;
        }
        Ok(())
    }

    /// Inverts `D_p`, turns `A_ap` into `L_ap` and subtracts `L_ap W_pb` from every later
    /// block `(a, b)` of column `p`'s reach.
    fn eliminate(&mut self, p: usize) -> Result<(), FactorError> {
        let s = self.size[p];
        let (done, later) = self.values.split_at_mut(self.end[p]);
        let d = &mut done[self.diag[p]..self.diag[p] + s * s];
        invert(d, s, &mut self.work, &mut self.pivots).map_err(|()| FactorError::ZeroPivot {
            unknown: self.at[p],
        })?;
        let entries = self.first[p]..self.first[p + 1];
        for e in entries.clone() {
            let m = self.size[self.rows[e]];
            let (head, tail) = done.split_at_mut(self.lower[e]);
            let product = &mut self.work[..m * s];
            product.fill(0.0);
            add_product(
                product,
                &tail[..m * s],
                &head[self.diag[p]..],
                (m, s, s),
                1.0,
            );
            tail[..m * s].copy_from_slice(product);
        }
        let pairs = self.pair_first[p];
        if self.front_rows[p] > 0 {
            self.update_front(p, self.front_rows[p], pairs);
            return Ok(());
        }
        let base = self.end[p];
        let mut pair = pairs;
        for (ia, ea) in entries.clone().enumerate() {
            let a = self.rows[ea];
            let sa = self.size[a];
            let (l_a, w_a) = (&done[self.lower[ea]..], &done[self.upper[ea]..]);
            let target = &mut later[self.diag[a] - base..];
            add_product(target, l_a, w_a, (sa, s, sa), -1.0);
            for eb in entries.clone().skip(ia + 1) {
                let b = self.rows[eb];
                let k = self.pairs[pair];
                pair += 1;
                let sb = self.size[b];
                let (l_b, w_b) = (&done[self.lower[eb]..], &done[self.upper[eb]..]);
                let below = &mut later[self.lower[k] - base..];
                add_product(below, l_b, w_a, (sb, s, sa), -1.0);
                let above = &mut later[self.upper[k] - base..];
                add_product(above, l_a, w_b, (sa, s, sb), -1.0);
            }
        }
        Ok(())
    }

    /// The update of [`BlockLu::eliminate`] for a wide front of `rows` rows: `L_p` and `W_p`
    /// stacked, their product made at once, each block of it subtracted where it belongs
    /// (`pair`: the first of `p`'s entries in `pairs`).
    fn update_front(&mut self, p: usize, rows: usize, mut pair: usize) {
        let s = self.size[p];
        let entries = self.first[p]..self.first[p + 1];
        let (lower, rest) = self.front.split_at_mut(rows * s);
        let (upper, product) = rest.split_at_mut(s * rows);
        let product = &mut product[..rows * rows];
        let mut at = 0;
        for (i, e) in entries.clone().enumerate() {
            let m = self.size[self.rows[e]];
            self.front_at[i] = at;
            let block = &self.values[self.lower[e]..self.lower[e] + m * s];
            for (j, column) in block.chunks_exact(m).enumerate() {
                lower[at + j * rows..at + j * rows + m].copy_from_slice(column);
            }
            upper[at * s..(at + m) * s]
                .copy_from_slice(&self.values[self.upper[e]..self.upper[e] + s * m]);
            at += m;
        }
        faer::linalg::matmul::matmul(
            MatMut::from_column_major_slice_mut(product, rows, rows),
            Accum::Replace,
            MatRef::from_column_major_slice(lower, rows, s),
            MatRef::from_column_major_slice(upper, s, rows),
            1.0,
            Par::Seq,
        );
        // Block (a, b) of the product, subtracted from the `sa × sb` block at `target`.
        let subtract = |values: &mut [f64],
                        target: usize,
                        (ra, sa): (usize, usize),
                        (cb, sb): (usize, usize)| {
            for j in 0..sb {
                let from = &product[ra + (cb + j) * rows..ra + (cb + j) * rows + sa];
                let to = &mut values[target + j * sa..target + (j + 1) * sa];
                to.iter_mut().zip(from).for_each(|(t, f)| *t -= f);
            }
        };
        for (ia, ea) in entries.clone().enumerate() {
            let a = self.rows[ea];
            let ra = (self.front_at[ia], self.size[a]);
            subtract(&mut self.values, self.diag[a], ra, ra);
            for (ib, eb) in entries.clone().enumerate().skip(ia + 1) {
                let b = self.rows[eb];
                let k = self.pairs[pair];
                pair += 1;
                let rb = (self.front_at[ib], self.size[b]);
                subtract(&mut self.values, self.lower[k], rb, ra);
                subtract(&mut self.values, self.upper[k], ra, rb);
            }
        }
    }

    /// Solves `A x = b` (or `Aᵀ x = b` with `transpose`) in place on the factors.
    ///
    /// # Errors
    /// [`FactorError::Singular`] for a non-finite solution.
    pub fn solve_in_place(&mut self, b: &mut [f64], transpose: bool) -> Result<(), FactorError> {
        if transpose {
            self.solve_transposed(b);
        } else {
            self.solve(b);
        }
        if b.iter().all(|x| x.is_finite()) {
            Ok(())
        } else {
            Err(FactorError::Singular("non-finite solution".into()))
        }
    }

    /// `(I + L) y = b`, then `x_p = D_p⁻¹ (y_p − Σ_a W_pa x_a)` backwards.
    fn solve(&mut self, b: &mut [f64]) {
        for p in 0..self.size.len() {
            let (s, at) = (self.size[p], self.at[p]);
            let bp = &mut self.work[..s];
            bp.copy_from_slice(&b[at..at + s]);
            for e in self.first[p]..self.first[p + 1] {
                let a = self.rows[e];
                let target = &mut b[self.at[a]..self.at[a] + self.size[a]];
                add_product(
                    target,
                    &self.values[self.lower[e]..],
                    bp,
                    (self.size[a], s, 1),
                    -1.0,
                );
            }
        }
        for p in (0..self.size.len()).rev() {
            let (s, at) = (self.size[p], self.at[p]);
            let (t, x) = self.work.split_at_mut(s);
            t.copy_from_slice(&b[at..at + s]);
            for e in self.first[p]..self.first[p + 1] {
                let a = self.rows[e];
                let xa = &b[self.at[a]..self.at[a] + self.size[a]];
                add_product(
                    t,
                    &self.values[self.upper[e]..],
                    xa,
                    (s, self.size[a], 1),
                    -1.0,
                );
            }
            let x = &mut x[..s];
            x.fill(0.0);
            add_product(x, &self.values[self.diag[p]..], t, (s, s, 1), 1.0);
            b[at..at + s].copy_from_slice(x);
        }
    }

    /// `Aᵀ = (I + D⁻¹W)ᵀ Dᵀ (I + L)ᵀ`: `y_p = D_p⁻ᵀ z_p` forwards with `z_a −= W_paᵀ y_p`,
    /// then `x_p = y_p − Σ_a L_apᵀ x_a` backwards.
    fn solve_transposed(&mut self, b: &mut [f64]) {
        for p in 0..self.size.len() {
            let (s, at) = (self.size[p], self.at[p]);
            let (z, y) = self.work.split_at_mut(s);
            z.copy_from_slice(&b[at..at + s]);
            let y = &mut y[..s];
            y.fill(0.0);
            add_transposed_product(y, &self.values[self.diag[p]..], z, (s, s), 1.0);
            b[at..at + s].copy_from_slice(y);
            for e in self.first[p]..self.first[p + 1] {
                let a = self.rows[e];
                let target = &mut b[self.at[a]..self.at[a] + self.size[a]];
                add_transposed_product(
                    target,
                    &self.values[self.upper[e]..],
                    y,
                    (s, self.size[a]),
                    -1.0,
                );
            }
        }
        for p in (0..self.size.len()).rev() {
            let (s, at) = (self.size[p], self.at[p]);
            let x = &mut self.work[..s];
            x.copy_from_slice(&b[at..at + s]);
            for e in self.first[p]..self.first[p + 1] {
                let a = self.rows[e];
                let xa = &b[self.at[a]..self.at[a] + self.size[a]];
                add_transposed_product(
                    x,
                    &self.values[self.lower[e]..],
                    xa,
                    (self.size[a], s),
                    -1.0,
                );
            }
            b[at..at + s].copy_from_slice(x);
        }
    }
}

/// Each block's first unknown (and `n` after the last), and each unknown's block.
fn block_map(sizes: &[usize], n: usize) -> Result<(Vec<usize>, Vec<usize>), FactorError> {
    let mut start = Vec::with_capacity(sizes.len() + 1);
    let mut block_of = Vec::with_capacity(n);
    for (k, &s) in sizes.iter().enumerate() {
        start.push(block_of.len());
        block_of.extend(std::iter::repeat_n(k, s));
    }
    start.push(block_of.len());
    if block_of.len() != n || sizes.contains(&0) {
        return Err(FactorError::Analysis(format!(
            "blocks of {} unknowns (an empty one among them: {}) for a matrix of {n}",
            block_of.len(),
            sizes.contains(&0)
        )));
    }
    Ok((start, block_of))
}

/// Each block's neighbours (the blocks its columns reach, itself left out), sorted.
fn block_graph(col_ptr: &[usize], row_idx: &[usize], block_of: &[usize]) -> Vec<Vec<usize>> {
    let blocks = block_of.last().map_or(0, |&k| k + 1);
    let mut graph = vec![Vec::new(); blocks];
    for c in 0..col_ptr.len() - 1 {
        let bc = block_of[c];
        for &r in &row_idx[col_ptr[c]..col_ptr[c + 1]] {
            if block_of[r] != bc {
                graph[bc].push(block_of[r]);
            }
        }
    }
    for neighbours in &mut graph {
        neighbours.sort_unstable();
        neighbours.dedup();
    }
    graph
}

/// AMD order of the DOF blocks `0..dofs`, each multiplier block right after the last of its
/// DOF blocks: the block at each position.
fn saddle_point_order(graph: &[Vec<usize>], dofs: usize) -> Result<Vec<usize>, FactorError> {
    let (mut col_ptr, mut row_idx) = (vec![0], Vec::new());
    for (k, neighbours) in graph[..dofs].iter().enumerate() {
        let mut column: Vec<usize> = neighbours.iter().copied().filter(|&b| b < dofs).collect();
        let at = column.partition_point(|&b| b < k);
        column.insert(at, k);
        row_idx.extend(column);
        col_ptr.push(row_idx.len());
    }
    let nnz = row_idx.len();
    let pattern = SymbolicSparseColMat::new_checked(dofs, dofs, col_ptr, None, row_idx);
    let (mut fwd, mut inv) = (vec![0usize; dofs], vec![0usize; dofs]);
    let mut mem = MemBuffer::new(amd::order_scratch::<usize>(dofs, nnz));
    amd::order(
        &mut fwd,
        &mut inv,
        pattern.as_ref(),
        amd::Control::default(),
        MemStack::new(&mut mem),
    )
    .map_err(|e| FactorError::Analysis(format!("AMD ordering of the blocks: {e:?}")))?;
    let mut after: Vec<Vec<usize>> = vec![Vec::new(); dofs];
    for (k, neighbours) in graph.iter().enumerate().skip(dofs) {
        let last = (neighbours.iter().copied().filter(|&b| b < dofs))
            .max_by_key(|&b| inv[b])
            .ok_or_else(|| FactorError::Analysis(format!("multiplier block {k} acts on no DOF")))?;
        after[last].push(k);
    }
    Ok(fwd
        .iter()
        .flat_map(|&b| std::iter::once(b).chain(after[b].iter().copied()))
        .collect())
}

/// The positions after each position `p` that its block column of the factors reaches: its
/// later neighbours and, through the elimination tree, its children's reach.
fn fill(graph: &[Vec<usize>], order: &[usize], position: &[usize]) -> (Vec<usize>, Vec<usize>) {
    let count = order.len();
    let (mut first, mut rows) = (vec![0], Vec::new());
    let mut children: Vec<Vec<usize>> = vec![Vec::new(); count];
    let mut mark = vec![usize::MAX; count];
    for p in 0..count {
        let begin = rows.len();
        let later = graph[order[p]].iter().map(|&b| position[b]);
        let inherited = children[p]
            .iter()
            .flat_map(|&c| first[c]..first[c + 1])
            .map(|e| rows[e])
            .collect::<Vec<usize>>();
        for a in later.chain(inherited) {
            if a > p && mark[a] != p {
                mark[a] = p;
                rows.push(a);
            }
        }
        rows[begin..].sort_unstable();
        if let Some(&parent) = rows.get(begin) {
            children[parent].push(p);
        }
        first.push(rows.len());
    }
    (first, rows)
}

/// `d⁻¹` of the column-major `s × s` block `d` in place, by `LU` with partial pivoting;
/// `Err` for a pivot below [`SINGULAR_PIVOT`] of its largest entry.
fn invert(d: &mut [f64], s: usize, work: &mut [f64], pivots: &mut [usize]) -> Result<(), ()> {
    match s {
        6 => invert_fixed::<6>(d),
        _ => invert_any(d, s, work, pivots),
    }
}

/// [`invert`] for a size known when compiled (the nodes' 6), on the stack: Gauss–Jordan
/// elimination on the rows of `Dᵀ` (the column-major `d` read by rows), with partial
/// pivoting, gives `D⁻ᵀ` by rows, which is `D⁻¹` by columns.
fn invert_fixed<const S: usize>(d: &mut [f64]) -> Result<(), ()> {
    let (mut a, mut inverse) = ([[0.0; S]; S], [[0.0; S]; S]);
    for (r, row) in a.iter_mut().enumerate() {
        row.copy_from_slice(&d[S * r..S * r + S]);
        inverse[r][r] = 1.0;
    }
    let largest = d[..S * S].iter().fold(0.0f64, |m, x| m.max(x.abs()));
    for k in 0..S {
        let pivot_row =
            (k + 1..S).fold(k, |p, i| if a[i][k].abs() > a[p][k].abs() { i } else { p });
        let pivot = a[pivot_row][k].abs();
        if pivot <= SINGULAR_PIVOT * largest || pivot.is_nan() {
            return Err(());
        }
        a.swap(k, pivot_row);
        inverse.swap(k, pivot_row);
        let reciprocal = 1.0 / a[k][k];
        let (row, inverse_row) = (
            a[k].map(|x| x * reciprocal),
            inverse[k].map(|x| x * reciprocal),
        );
        (a[k], inverse[k]) = (row, inverse_row);
        for i in (0..S).filter(|&i| i != k) {
            let f = a[i][k];
            for j in 0..S {
                a[i][j] -= f * row[j];
                inverse[i][j] -= f * inverse_row[j];
            }
        }
    }
    for (r, row) in inverse.iter().enumerate() {
        d[S * r..S * r + S].copy_from_slice(row);
    }
    Ok(())
}

fn invert_any(d: &mut [f64], s: usize, work: &mut [f64], pivots: &mut [usize]) -> Result<(), ()> {
    let (a, inverse) = work.split_at_mut(s * s);
    let (a, inverse) = (&mut a[..s * s], &mut inverse[..s * s]);
    a.copy_from_slice(&d[..s * s]);
    lu_in_place(a, s, &mut pivots[..s])?;
    inverse_from_lu(a, s, pivots, inverse);
    d[..s * s].copy_from_slice(inverse);
    Ok(())
}

/// `P a = L U` in place (`L` unit lower below the diagonal, `U` above it and its diagonal's
/// reciprocals on it), the row swaps in `pivots`.
#[inline(always)]
fn lu_in_place(a: &mut [f64], s: usize, pivots: &mut [usize]) -> Result<(), ()> {
    let largest = a.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    for k in 0..s {
        let mut pivot_row = k;
        for i in k + 1..s {
            if a[i + k * s].abs() > a[pivot_row + k * s].abs() {
                pivot_row = i;
            }
        }
        let pivot = a[pivot_row + k * s].abs();
        if pivot <= SINGULAR_PIVOT * largest || pivot.is_nan() {
            return Err(());
        }
        pivots[k] = pivot_row;
        if pivot_row != k {
            (0..s).for_each(|j| a.swap(k + j * s, pivot_row + j * s));
        }
        let inv = 1.0 / a[k + k * s];
        a[k + k * s] = inv;
        for i in k + 1..s {
            a[i + k * s] *= inv;
        }
        for j in k + 1..s {
            let akj = a[k + j * s];
            for i in k + 1..s {
                a[i + j * s] -= a[i + k * s] * akj;
            }
        }
    }
    Ok(())
}

/// `a⁻¹ = U⁻¹ L⁻¹ P` into `inverse` from [`lu_in_place`]'s factors, column by column.
#[inline(always)]
fn inverse_from_lu(lu: &[f64], s: usize, pivots: &[usize], inverse: &mut [f64]) {
    inverse.fill(0.0);
    for j in 0..s {
        let column = &mut inverse[j * s..(j + 1) * s];
        column[j] = 1.0;
        for (k, &p) in pivots[..s].iter().enumerate() {
            column.swap(k, p);
        }
        for k in 0..s {
            let ck = column[k];
            for i in k + 1..s {
                column[i] -= lu[i + k * s] * ck;
            }
        }
        for k in (0..s).rev() {
            column[k] *= lu[k + k * s];
            let ck = column[k];
            for i in 0..k {
                column[i] -= lu[i + k * s] * ck;
            }
        }
    }
}

/// `c += w a b` for column-major `a` (`m × k`), `b` (`k × n`) and `c` (`m × n`), each read
/// from the start of its slice: a node's `6 × 6` products with every size known when
/// compiled, the others with their rows known up to six ([`product`] inlined with its sizes
/// constant).
fn add_product(c: &mut [f64], a: &[f64], b: &[f64], (m, k, n): (usize, usize, usize), w: f64) {
    match (m, k, n) {
        (6, 6, 6) => product(c, a, b, (6, 6, 6), w),
        (6, 6, 1) => product(c, a, b, (6, 6, 1), w),
        _ => add_product_other(c, a, b, (m, k, n), w),
    }
}

/// [`add_product`] of the other sizes: a joint's `r` rows against a node's six, `(r, 6, 6)`,
/// `(r, 6, r)`, `(6, 6, r)`, `(6, r, r)`, `(6, r, 6)` and the solves' `(r, 6, 1)`,
/// `(6, r, 1)`, each with its sizes known when compiled; any other (a front, a joint's pivot
/// block's own solve, two joints' rows) with its rows known.
#[inline(never)]
fn add_product_other(
    c: &mut [f64],
    a: &[f64],
    b: &[f64],
    (m, k, n): (usize, usize, usize),
    w: f64,
) {
    /// The shapes with `r` rows of a joint.
    macro_rules! joint {
        ($($r:literal),*) => {
            match (m, k, n) {
                $(
                    ($r, 6, 6) => return product(c, a, b, ($r, 6, 6), w),
                    ($r, 6, $r) => return product(c, a, b, ($r, 6, $r), w),
                    ($r, 6, 1) => return product(c, a, b, ($r, 6, 1), w),
                    (6, 6, $r) => return product(c, a, b, (6, 6, $r), w),
                    (6, $r, $r) => return product(c, a, b, (6, $r, $r), w),
                    (6, $r, 6) => return product(c, a, b, (6, $r, 6), w),
                    (6, $r, 1) => return product(c, a, b, (6, $r, 1), w),
                )*
                _ => {}
            }
        };
    }
    joint!(2, 3, 4, 5);
    match m {
        1 => product(c, a, b, (1, k, n), w),
        2 => product(c, a, b, (2, k, n), w),
        3 => product(c, a, b, (3, k, n), w),
        4 => product(c, a, b, (4, k, n), w),
        5 => product(c, a, b, (5, k, n), w),
        6 => product(c, a, b, (6, k, n), w),
        _ => product(c, a, b, (m, k, n), w),
    }
}

/// The loops of [`add_product`], column by column; inlined where it is called, so that the
/// sizes given there as constants bound its loops when compiled.
#[inline(always)]
fn product(c: &mut [f64], a: &[f64], b: &[f64], (m, k, n): (usize, usize, usize), w: f64) {
    let (c, a, b) = (&mut c[..m * n], &a[..m * k], &b[..k * n]);
    for j in 0..n {
        for l in 0..k {
            let blj = w * b[l + j * k];
            for i in 0..m {
                c[i + j * m] += a[i + l * m] * blj;
            }
        }
    }
}

/// `y += w aᵀ x` for column-major `a` (`m × n`), `x` of `m` and `y` of `n`.
fn add_transposed_product(y: &mut [f64], a: &[f64], x: &[f64], (m, n): (usize, usize), w: f64) {
    for (j, yj) in y[..n].iter_mut().enumerate() {
        let column = &a[j * m..(j + 1) * m];
        *yj += w * column.iter().zip(&x[..m]).map(|(a, x)| a * x).sum::<f64>();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Blocks of 6 on `nodes` coupled along `edges`, a 3-row joint on nodes 0 and 1 and a
    /// 2-row one on the last node, non-symmetric and mass-dominated: its CSC pattern, values
    /// and dense form.
    type Saddle = (Vec<usize>, Vec<usize>, Vec<f64>, Vec<Vec<f64>>, Blocks);

    fn saddle(nodes: usize, edges: &[(usize, usize)], skew: f64) -> Saddle {
        let n = 6 * nodes + 5;
        let mut dense = vec![vec![0.0; n]; n];
        let mut seed = 7u64;
        let mut random = move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let mut couple = |dense: &mut Vec<Vec<f64>>, a: usize, b: usize| {
            for i in 0..6 {
                for j in 0..6 {
                    let x = random();
                    dense[6 * a + i][6 * b + j] += x;
                    dense[6 * b + j][6 * a + i] += x + skew * random();
                }
            }
        };
        for k in 0..nodes {
            couple(&mut dense, k, k);
            (0..6).for_each(|i| dense[6 * k + i][6 * k + i] += 20.0);
        }
        edges.iter().for_each(|&(a, b)| couple(&mut dense, a, b));
        let last = [nodes - 1];
        let joints = [(6 * nodes, 3, &[0, 1][..]), (6 * nodes + 3, 2, &last[..])];
        for (row, rows, on) in joints {
            let columns = || on.iter().flat_map(|&node| 6 * node..6 * node + 6);
            for (r, j) in (row..row + rows).flat_map(|r| columns().map(move |j| (r, j))) {
                let x = random() + 1.0;
                dense[r][j] = x;
                dense[j][r] = x * (1.0 + skew * random());
            }
        }
        let (mut col_ptr, mut row_idx, mut values) = (vec![0], vec![], vec![]);
        for c in 0..n {
            for (r, row) in dense.iter().enumerate() {
                let structural = row[c] != 0.0 || dense[c][r] != 0.0 || r == c;
                if structural {
                    row_idx.push(r);
                    values.push(row[c]);
                }
            }
            col_ptr.push(row_idx.len());
        }
        let mut sizes = vec![6; nodes];
        sizes.extend([3, 2]);
        (
            col_ptr,
            row_idx,
            values,
            dense,
            Blocks { sizes, dofs: nodes },
        )
    }

    /// A chain of `nodes` (each coupled to the next).
    fn chain(nodes: usize, skew: f64) -> Saddle {
        let edges: Vec<(usize, usize)> = (1..nodes).map(|k| (k - 1, k)).collect();
        saddle(nodes, &edges, skew)
    }

    /// A 4 × 4 lattice of nodes coupled to their neighbours and across each square's
    /// diagonals: the elimination tree branches, and fill joins its branches.
    fn lattice(skew: f64) -> Saddle {
        let at = |i: usize, j: usize| 4 * i + j;
        let mut edges = Vec::new();
        for (i, j) in (0..4).flat_map(|i| (0..4).map(move |j| (i, j))) {
            if i + 1 < 4 {
                edges.push((at(i, j), at(i + 1, j)));
            }
            if j + 1 < 4 {
                edges.push((at(i, j), at(i, j + 1)));
            }
            if i + 1 < 4 && j + 1 < 4 {
                edges.extend([(at(i, j), at(i + 1, j + 1)), (at(i + 1, j), at(i, j + 1))]);
            }
        }
        saddle(16, &edges, skew)
    }

    /// `A x = b` and `Aᵀ x = b` on the block factors of non-symmetric saddle points (a chain,
    /// a lattice), against the matrix itself to round-off.
    #[test]
    fn solves_a_saddle_point_and_its_transpose() {
        for (skew, shape) in [0.0, 0.3]
            .into_iter()
            .flat_map(|s| [(s, "chain"), (s, "lattice")])
        {
            let (col_ptr, row_idx, values, dense, blocks) = match shape {
                "chain" => chain(7, skew),
                _ => lattice(skew),
            };
            let n = dense.len();
            let mut lu = BlockLu::analyze(&col_ptr, &row_idx, &blocks).unwrap();
            lu.factorize(&values).unwrap();
            for transpose in [false, true] {
                let b: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin()).collect();
                let mut x = b.clone();
                lu.solve_in_place(&mut x, transpose).unwrap();
                for (i, bi) in b.iter().enumerate() {
                    let ax: f64 = (0..n)
                        .map(|j| if transpose { dense[j][i] } else { dense[i][j] } * x[j])
                        .sum();
                    assert!(
                        (ax - bi).abs() < 1e-12,
                        "{shape}, skew {skew}, transpose {transpose}: row {i}: {ax} ≠ {bi}"
                    );
                }
            }
        }
    }

    /// A node block with nothing on its diagonal (and no neighbour eliminated before it)
    /// is named at its first unknown; blocks that miss unknowns are refused.
    #[test]
    fn reports_a_singular_block_and_a_bad_partition() {
        let (col_ptr, row_idx, mut values, _, blocks) = chain(3, 0.0);
        let mut lu = BlockLu::analyze(&col_ptr, &row_idx, &blocks).unwrap();
        let first = lu.at[0];
        let on_block = |r: usize| (first..first + 6).contains(&r);
        for c in first..first + 6 {
            for k in col_ptr[c]..col_ptr[c + 1] {
                if on_block(row_idx[k]) {
                    values[k] = 0.0;
                }
            }
        }
        assert_eq!(
            lu.factorize(&values),
            Err(FactorError::ZeroPivot { unknown: first })
        );
        let short = Blocks {
            sizes: vec![6, 6, 6, 3],
            dofs: 3,
        };
        assert!(matches!(
            BlockLu::analyze(&col_ptr, &row_idx, &short),
            Err(FactorError::Analysis(_))
        ));
    }
}
