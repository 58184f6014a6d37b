//! A square sparse matrix's structure in compressed columns, and where each entry is stored:
//! what both engines' assemblers build their iteration matrices' patterns and slot maps on
//! (`solver/assembly.rs`, `spatial/assembly.rs`), and what the factorizations analyse.

use std::ops::Range;

/// The structure of an `n × n` matrix: column `c`'s entries are `row_idx[col_ptr[c]..col_ptr[c
/// + 1]]`, rows sorted; a matrix on it is its values in that order.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Sparsity {
    /// Rows and columns.
    pub n: usize,
    /// Where each column starts in `row_idx` (one more than the columns).
    pub col_ptr: Vec<usize>,
    /// Each entry's row, column by column.
    pub row_idx: Vec<usize>,
}

impl Sparsity {
    /// The structure holding the `(column, row)` `entries`, given in any order, repeats
    /// merged.
    pub fn from_entries(n: usize, mut entries: Vec<(usize, usize)>) -> Self {
        entries.sort_unstable();
        entries.dedup();
        let mut col_ptr = vec![0; n + 1];
        for &(c, _) in &entries {
            col_ptr[c + 1] += 1;
        }
        for c in 0..n {
            col_ptr[c + 1] += col_ptr[c];
        }
        let row_idx = entries.iter().map(|&(_, r)| r).collect();
        Self {
            n,
            col_ptr,
            row_idx,
        }
    }

    /// Where entry `(row, col)` is stored, if the structure holds it.
    pub fn slot(&self, row: usize, col: usize) -> Option<usize> {
        let column = self.column(col);
        let offset = self.row_idx[column.clone()].binary_search(&row).ok()?;
        Some(column.start + offset)
    }

    /// Each slot's mirror, the slot of `(col, row)` for that of `(row, col)`; `None` for
    /// a structure that is not structurally symmetric.
    pub fn mirror(&self) -> Option<Vec<usize>> {
        (0..self.n)
            .flat_map(|c| self.column(c).map(move |k| (k, c)))
            .map(|(k, c)| self.slot(c, self.row_idx[k]))
            .collect()
    }

    /// Column `col`'s slots.
    pub fn column(&self, col: usize) -> Range<usize> {
        self.col_ptr[col]..self.col_ptr[col + 1]
    }

    /// Stored entries.
    pub fn nnz(&self) -> usize {
        self.row_idx.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Entries in any order with repeats make sorted columns; every entry is found where it
    /// is stored, and none that is absent.
    #[test]
    fn entries_are_stored_column_by_column_and_found() {
        let sparsity =
            Sparsity::from_entries(3, vec![(2, 0), (0, 1), (0, 0), (2, 2), (0, 1), (1, 1)]);
        assert_eq!(sparsity.col_ptr, [0, 2, 3, 5]);
        assert_eq!(sparsity.row_idx, [0, 1, 1, 0, 2]);
        assert_eq!(sparsity.nnz(), 5);
        for (c, r) in [(0, 0), (0, 1), (1, 1), (2, 0), (2, 2)] {
            let s = sparsity.slot(r, c).unwrap();
            assert!(sparsity.column(c).contains(&s) && sparsity.row_idx[s] == r);
        }
        assert_eq!(sparsity.slot(1, 2), None);
        assert_eq!(sparsity.slot(0, 1), None);
    }
}
