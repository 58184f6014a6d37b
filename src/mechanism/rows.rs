//! Every constraint row of a model behind one interface: the joints' rows on at most two
//! nodes ([`ConstraintRow`]) and the averaging rings' rows on many ([`Averaging`]),
//! numbered in that order, the multipliers' order. Assembly, Newton, the sensitivities and
//! the rigid kinematics read `Φ`, `Φ_q` and `∂²Φ/∂q²` through it; what only joints have (a
//! drive, a reaction, a coordinate for springs and motors) stays on [`ConstraintRow`].

use std::ops::Range;

use crate::joint::planar::{ConstraintRow, Joint, Turns};
use crate::mechanism::averaging::{Averaging, Component};

/// A model's constraint rows, as [`crate::mechanism::model::Model::constraints`] lends
/// them: the joints with their rows, then the averaging rings, and every row's DOFs.
#[derive(Debug, Clone, Copy)]
pub struct Constraints<'m> {
    /// The joints (for their drives and names).
    pub joints: &'m [Joint],
    /// Their rows.
    pub rows: &'m [ConstraintRow],
    /// The averaging rings, three rows each.
    pub averagings: &'m [Averaging],
    /// Every row's DOFs.
    pub dofs: &'m RowDofs,
}

/// Row `k` of the joints' `rows` followed by the `averagings`' rows.
fn row<'m>(rows: &'m [ConstraintRow], averagings: &'m [Averaging], k: usize) -> Row<'m> {
    match rows.get(k) {
        Some(row) => Row::Joint(row),
        None => {
            let r = k - rows.len();
            Row::Ring(&averagings[r / 3], Component::ALL[r % 3])
        }
    }
}

/// One constraint row.
#[derive(Debug, Clone, Copy)]
pub enum Row<'m> {
    /// A joint's.
    Joint(&'m ConstraintRow),
    /// An averaging ring's.
    Ring(&'m Averaging, Component),
}

/// The DOFs each row acts on, its structural nonzeros, row after row (compressed rows).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct RowDofs {
    /// Row `k`'s DOFs are `dofs[offsets[k]..offsets[k + 1]]`.
    offsets: Vec<usize>,
    /// The DOFs.
    dofs: Vec<usize>,
}

impl RowDofs {
    /// Of every row of the joints' `rows` and the `averagings`' rows, in that order.
    pub fn of(rows: &[ConstraintRow], averagings: &[Averaging]) -> Self {
        let mut out = Self {
            offsets: vec![0],
            dofs: Vec::new(),
        };
        for k in 0..rows.len() + 3 * averagings.len() {
            match row(rows, averagings, k) {
                Row::Joint(row) => {
                    let active = row.active();
                    let dofs = row.dofs().into_iter().zip(active);
                    out.dofs.extend(dofs.filter_map(|(d, on)| d.filter(|_| on)));
                }
                Row::Ring(ring, c) => out.dofs.extend(ring.dofs(c)),
            }
            out.offsets.push(out.dofs.len());
        }
        out
    }

    /// Where row `k`'s entries are in a row-wise array ([`RowDofs::dofs`]).
    pub fn range(&self, k: usize) -> Range<usize> {
        self.offsets[k]..self.offsets[k + 1]
    }

    /// Row `k`'s DOFs.
    pub fn of_row(&self, k: usize) -> &[usize] {
        &self.dofs[self.range(k)]
    }

    /// The number of rows.
    pub fn rows(&self) -> usize {
        self.offsets.len() - 1
    }

    /// Every row's DOFs, row after row.
    pub fn dofs(&self) -> &[usize] {
        &self.dofs
    }

    /// Each row's entries of a row-wise array `values` (as long as [`RowDofs::dofs`]).
    pub fn split<'a>(&'a self, values: &'a [f64]) -> impl Iterator<Item = &'a [f64]> + 'a {
        self.offsets.windows(2).map(move |w| &values[w[0]..w[1]])
    }
}

impl<'m> Constraints<'m> {
    /// Row `k`: a joint's below `rows.len()`, an averaging ring's after.
    pub fn row(&self, k: usize) -> Row<'m> {
        row(self.rows, self.averagings, k)
    }

    /// `h_k(q)`, and its gradient on the row's DOFs ([`RowDofs::of_row`]) through
    /// `gradient(local index, value)`; `turns`, the nodes' at `q`, if read already.
    pub fn evaluate(
        &self,
        k: usize,
        q: &[f64],
        turns: Option<&Turns>,
        mut gradient: impl FnMut(usize, f64),
    ) -> f64 {
        match self.row(k) {
            Row::Joint(row) => {
                let (value, g) = match turns {
                    Some(turns) => row.evaluate_with(q, turns),
                    None => row.evaluate(q),
                };
                let active = g.iter().zip(row.active()).filter(|(_, on)| *on);
                active.enumerate().for_each(|(i, (g, _))| gradient(i, *g));
                value
            }
            Row::Ring(ring, c) => ring.evaluate(c, q, gradient),
        }
    }

    /// Row `k`'s gradient at `q` on its DOFs.
    pub fn gradient(&self, k: usize, q: &[f64]) -> Vec<f64> {
        let mut g = vec![0.0; self.dofs.range(k).len()];
        self.evaluate(k, q, None, |i, v| g[i] += v);
        g
    }

    /// Adds `weight · ∂²h_k/∂q²` at `q` through `add(local i, local j, value)`, on the
    /// row's DOFs; nothing for a linear row.
    pub fn add_hessian(
        &self,
        k: usize,
        q: &[f64],
        turns: Option<&Turns>,
        weight: f64,
        mut add: impl FnMut(usize, usize, f64),
    ) {
        match self.row(k) {
            Row::Joint(row) => {
                if row.is_linear() {
                    return;
                }
                let mut h = [[0.0; 6]; 6];
                match turns {
                    Some(turns) => row.add_hessian_with(q, turns, weight, &mut h),
                    None => row.add_hessian(q, weight, &mut h),
                }
                let active = row.active();
                let on = || (0..6).filter(|&i| active[i]).enumerate();
                for (li, i) in on() {
                    for (lj, j) in on() {
                        add(li, lj, h[i][j]);
                    }
                }
            }
            Row::Ring(ring, c) => ring.add_hessian(c, q, weight, add),
        }
    }

    /// Whether row `k` is linear in `q` (no Hessian).
    pub fn is_linear(&self, k: usize) -> bool {
        match self.row(k) {
            Row::Joint(row) => row.is_linear(),
            Row::Ring(_, c) => c != Component::Rotation,
        }
    }

    /// `g_k(t)` and its first two rates: a driven joint row's law, zero otherwise.
    pub fn prescribed(&self, k: usize, t: f64) -> [f64; 3] {
        match self.row(k) {
            Row::Joint(row) => self.joints[row.joint].prescribed(row, t),
            Row::Ring(..) => [0.0; 3],
        }
    }

    /// Whether row `k` follows a drive.
    pub fn driven(&self, k: usize) -> bool {
        matches!(self.row(k), Row::Joint(row) if row.driven)
    }

    /// What owns row `k`, for messages: `joint 'elbow'`, `ring 'hub'`.
    pub fn owner(&self, k: usize) -> String {
        match self.row(k) {
            Row::Joint(row) => format!("joint '{}'", self.joints[row.joint].name),
            Row::Ring(ring, _) => format!("ring '{}'", ring.name),
        }
    }
}
