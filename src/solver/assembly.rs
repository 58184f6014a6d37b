//! Assembly of the global residual and iteration matrix on a fixed sparsity pattern.
//!
//! The iteration matrix of the generalized-α Newton step (paper §2.3) is
//!
//! ```text
//! S_t = [ β'M + γ'C + K_t    s Φ_qᵀ ]
//!       [ s Φ_q              0      ]
//! ```
//!
//! with `K_t` the tangent of the elements, the springs and the joints (`Σ λₖ ∂²Φₖ/∂q²`),
//! `C` the dampers' constant matrix (the beams are elastic, the 2D mass constant). The
//! factor `s`
//! scales the constraint rows and multipliers (`λ = s μ`) so that all blocks have the
//! magnitude of `β'M + K_t`, keeping the matrix well conditioned as `h → 0` (Bottasso,
//! Bauchau & Cardona 2007).
//!
//! Every system `S_t [Δq; Δμ] = [b; c]` is solved in its augmented-Lagrangian form: the row
//! operation `E = [[I, Φ_qᵀ], [0, I]]` adds `Φ_qᵀ` times the constraint rows to the dynamic
//! rows, giving `[β'M + K_t + s Φ_qᵀΦ_q, s Φ_qᵀ; s Φ_q, 0] [Δq; Δμ] = [b + Φ_qᵀ c; c]`. The
//! solution is unchanged, the matrix stays symmetric, and its DOF block becomes positive
//! definite for any properly constrained mechanism — statics included — which is what the
//! pivot-free `LDLᵀ` of [`crate::solver::linsolve`] needs.
//!
//! The pattern — element blocks, point-mass diagonals, constraint entries and their
//! `Φ_qᵀΦ_q` couplings — is built once in [`Pattern`], with a *slot map* from each element's
//! local `(i, j)` to the position of that entry in the CSC value array, so every later
//! assembly only zeroes and accumulates values.

use std::ops::Range;

use crate::error::SolveError;
use crate::joint::planar::Turns;
use crate::mechanism::bar_mass::BarMass;
use crate::mechanism::element::quad::{Matrix8, Vector8};
use crate::mechanism::element::{Damping, MassKind};
use crate::mechanism::model::{Analysis, Densities, Model};
use crate::mechanism::spring::Spring;
use crate::solver::linsolve::{FactorError, Ldlt};
use crate::solver::sparsity::Sparsity;

/// CSC pattern of the `(n_q + n_c)²` iteration matrix with slot maps.
#[derive(Debug, Clone)]
pub struct Pattern {
    /// Number of nodal DOFs.
    pub n_q: usize,
    /// The `(n_q + n_c)²` structure.
    pub sparsity: Sparsity,
    /// Slot of element entry `(i, j)` at index `6 j + i`.
    element_slots: Vec<[usize; 36]>,
    /// For each cell, slots of `(dofᵢ, dofⱼ)` of its eight DOFs, column-major.
    cell_slots: Vec<[usize; 64]>,
    /// For each bar's end coupling ([`BarMass`], `mass = "bar_lumped"` only), slots of
    /// `(dofᵢ, dofⱼ)` of its four DOFs, column-major.
    bar_slots: Vec<[usize; 16]>,
    /// Diagonal slots of each node's three DOFs.
    node_slots: Vec<[usize; 3]>,
    /// For each spring, slots of `(dofᵢ, dofⱼ)` of its six DOFs (`usize::MAX` on the ground).
    spring_slots: Vec<[[usize; 6]; 6]>,
    /// For each entry of [`RowDofs`] (row `k`, its DOF `d`): the slots of `(n_q + k, d)`
    /// and `(d, n_q + k)`.
    row_slots: Vec<[usize; 2]>,
    /// For constraint row `k`, from `gram_offsets[k]`: the slots of `(dᵢ, dⱼ)` for its
    /// DOFs `i, j`, row-major (`Φ_qᵀΦ_q` and the row's Hessian).
    gram_slots: Vec<usize>,
    /// Where each row's block starts in `gram_slots` (one more than the rows).
    gram_offsets: Vec<usize>,
}

impl Pattern {
    /// The pattern of `model`'s iteration matrix, with the couplings `bars` of bars' end
    /// nodes.
    ///
    /// # Errors
    /// [`SolveError::Setup`] if an entry the slot maps need is missing (an engine defect).
    pub fn new(model: &Model, bars: &[BarMass]) -> Result<Self, SolveError> {
        let n_q = model.n_dofs();
        let n = n_q + model.n_constraints();
        let mut pairs: Vec<(usize, usize)> = Vec::new();
        for e in &model.elements {
            let d = e.dofs();
            pairs.extend(d.iter().flat_map(|&c| d.iter().map(move |&r| (c, r))));
        }
        for cell in &model.cells {
            let d = cell.dofs();
            pairs.extend(d.iter().flat_map(|&c| d.iter().map(move |&r| (c, r))));
        }
        pairs.extend((0..n_q).map(|i| (i, i)));
        for bar in bars {
            let d = bar.dofs();
            pairs.extend(d.iter().flat_map(|&c| d.iter().map(move |&r| (c, r))));
        }
        for spring in &model.springs {
            let d: Vec<usize> = spring.dofs().into_iter().flatten().collect();
            pairs.extend(d.iter().flat_map(|&c| d.iter().map(move |&r| (c, r))));
        }
        for k in 0..model.n_constraints() {
            let dofs = model.row_dofs.of_row(k);
            for &d in dofs {
                pairs.push((d, n_q + k));
                pairs.push((n_q + k, d));
                pairs.extend(dofs.iter().map(|&e| (d, e)));
            }
        }
        let mut p = Self {
            n_q,
            sparsity: Sparsity::from_entries(n, pairs),
            element_slots: vec![],
            cell_slots: vec![],
            bar_slots: vec![],
            node_slots: vec![],
            spring_slots: vec![],
            row_slots: vec![],
            gram_slots: vec![],
            gram_offsets: vec![0],
        };
        let missing = || SolveError::Setup("an entry missing from the sparsity pattern".into());
        p.element_slots = model
            .elements
            .iter()
            .map(|e| {
                let d = e.dofs();
                slots(|k| p.slot(d[k % 6], d[k / 6]))
            })
            .collect::<Option<_>>()
            .ok_or_else(missing)?;
        p.cell_slots = model
            .cells
            .iter()
            .map(|c| {
                let d = c.dofs();
                slots(|k| p.slot(d[k % 8], d[k / 8]))
            })
            .collect::<Option<_>>()
            .ok_or_else(missing)?;
        p.bar_slots = bars
            .iter()
            .map(|b| {
                let d = b.dofs();
                slots(|k| p.slot(d[k % 4], d[k / 4]))
            })
            .collect::<Option<_>>()
            .ok_or_else(missing)?;
        p.node_slots = (0..model.nodes.len())
            .map(|i| slots(|k| p.slot(3 * i + k, 3 * i + k)))
            .collect::<Option<_>>()
            .ok_or_else(missing)?;
        p.spring_slots = model
            .springs
            .iter()
            .map(|spring| p.block_slots(spring.dofs()))
            .collect::<Option<_>>()
            .ok_or_else(missing)?;
        let rows = &model.row_dofs;
        p.row_slots = (0..rows.rows())
            .flat_map(|k| rows.of_row(k).iter().map(move |&d| (k, d)))
            .map(|(k, d)| Some([p.slot(n_q + k, d)?, p.slot(d, n_q + k)?]))
            .collect::<Option<_>>()
            .ok_or_else(missing)?;
        let mut gram = Vec::new();
        for k in 0..rows.rows() {
            let dofs = rows.of_row(k);
            for &a in dofs {
                for &b in dofs {
                    gram.push(p.slot(a, b).ok_or_else(missing)?);
                }
            }
            p.gram_offsets.push(gram.len());
        }
        p.gram_slots = gram;
        Ok(p)
    }

    /// For each constraint row, the DOFs it acts on.
    pub fn multiplier_dofs(model: &Model) -> Vec<Vec<usize>> {
        (0..model.n_constraints())
            .map(|k| model.row_dofs.of_row(k).to_vec())
            .collect()
    }

    /// Row `k`'s block of `gram_slots`, `n × n` for its `n` DOFs.
    fn gram(&self, k: usize) -> &[usize] {
        &self.gram_slots[self.gram_offsets[k]..self.gram_offsets[k + 1]]
    }

    /// Slots of `(dofᵢ, dofⱼ)` for six DOFs (`usize::MAX` where one is `None`).
    fn block_slots(&self, dofs: [Option<usize>; 6]) -> Option<[[usize; 6]; 6]> {
        slots(|i| {
            slots(|j| match (dofs[i], dofs[j]) {
                (Some(a), Some(b)) => self.slot(a, b),
                _ => Some(usize::MAX),
            })
        })
    }

    /// Position of entry `(row, col)` in the CSC value array (`None` outside the pattern).
    fn slot(&self, row: usize, col: usize) -> Option<usize> {
        self.sparsity.slot(row, col)
    }

    /// Number of stored entries.
    pub fn nnz(&self) -> usize {
        self.sparsity.nnz()
    }

    /// `out += A v` for the nodal block of a matrix with `values` on this pattern.
    fn add_dof_block_times(&self, values: &[f64], v: &[f64], out: &mut [f64]) {
        for (j, &vj) in v.iter().enumerate().take(self.n_q) {
            let column = self.sparsity.column(j);
            for (&i, &a) in self.sparsity.row_idx[column.clone()]
                .iter()
                .zip(&values[column])
            {
                if i < self.n_q {
                    out[i] += a * vj;
                }
            }
        }
    }
}

/// `Φ_q` at a state: each constraint row's gradient on its DOFs, row after row as in
/// [`RowDofs`]. The iteration matrix and the augmentation of its right-hand sides read the
/// same one, so a kept factorization is solved consistently.
#[derive(Debug, Clone)]
pub struct Jacobian(Vec<f64>);

impl Jacobian {
    /// `Φ_q(q)` of `model`.
    pub fn at(model: &Model, q: &[f64]) -> Self {
        let mut out = Self(vec![0.0; model.row_dofs.dofs().len()]);
        out.update(model, q, &Turns::at(&model.rows, q));
        out
    }

    /// Row `k`'s gradient on its DOFs ([`RowDofs::of_row`]).
    pub fn row(&self, model: &Model, k: usize) -> &[f64] {
        &self.0[model.row_dofs.range(k)]
    }

    /// Re-evaluates at `q` in place, with the nodes' `turns` at `q`.
    pub fn update(&mut self, model: &Model, q: &[f64], turns: &Turns) {
        for k in 0..model.n_constraints() {
            let g = &mut self.0[model.row_dofs.range(k)];
            g.fill(0.0);
            model
                .constraints()
                .evaluate(k, q, Some(turns), |i, v| g[i] += v);
        }
    }
}

/// `[f(0), …, f(N − 1)]`, or `None` if any is `None`.
fn slots<T: Copy + Default, const N: usize>(
    mut f: impl FnMut(usize) -> Option<T>,
) -> Option<[T; N]> {
    let mut out = [T::default(); N];
    for (k, o) in out.iter_mut().enumerate() {
        *o = f(k)?;
    }
    Some(out)
}

/// Where a block on six DOFs sits in the pattern: an element's slots (column-major), or a
/// spring's (`usize::MAX` on the ground).
enum Slots<'a> {
    Element(&'a [usize; 36]),
    Spring(&'a [[usize; 6]; 6]),
}

impl Slots<'_> {
    /// The slot of entry `(i, j)`, if it has one.
    fn at(&self, i: usize, j: usize) -> Option<usize> {
        match self {
            Self::Element(slots) => Some(slots[6 * j + i]),
            Self::Spring(slots) => Some(slots[i][j]).filter(|&s| s != usize::MAX),
        }
    }
}

/// A damping block on up to eight DOFs (`None` on the ground and past a beam's or a
/// damper's six) at a state: `∂f_d/∂q̇` and the part of `∂f_d/∂q` that is not symmetric.
#[derive(Debug, Clone, Copy)]
pub struct DampingBlock {
    /// Its DOFs.
    pub dofs: [Option<usize>; 8],
    /// `∂f_d/∂q̇`.
    pub rate: Matrix8,
    /// The non-symmetric part of `∂f_d/∂q`.
    pub skew: Matrix8,
}

impl DampingBlock {
    /// The block of a damping on `N` DOFs, padded to eight.
    fn new<const N: usize>(dofs: [Option<usize>; N], d: &Damping<N>) -> Self {
        let mut block = Self {
            dofs: [None; 8],
            rate: Matrix8::zeros(),
            skew: Matrix8::zeros(),
        };
        block.dofs[..N].copy_from_slice(&dofs);
        block.rate.fixed_view_mut::<N, N>(0, 0).copy_from(&d.rate);
        block.skew.fixed_view_mut::<N, N>(0, 0).copy_from(&d.skew);
        block
    }

    /// `out += factor · A v` for `A` its `rate` (or `skew`), transposed or not.
    pub fn add_times(&self, skew: bool, transposed: bool, factor: f64, v: &[f64], out: &mut [f64]) {
        let a = if skew { &self.skew } else { &self.rate };
        let local = Vector8::from(self.dofs.map(|d| d.map_or(0.0, |d| v[d])));
        let product = if transposed {
            a.transpose() * local
        } else {
            a * local
        };
        for (d, x) in self.dofs.iter().zip(product.iter()) {
            if let Some(d) = d {
                out[*d] += factor * x;
            }
        }
    }
}

/// Everything a run needs to evaluate forces and matrices of one design.
pub struct Assembler<'m> {
    /// The mechanism.
    pub model: &'m Model,
    /// Iteration-matrix pattern.
    pub pattern: Pattern,
    /// Element scalings of the design.
    pub densities: Densities,
    /// Inertia discretization.
    pub mass_kind: MassKind,
    /// Values of `M` on the pattern (zero outside the `n_q` block).
    mass: Vec<f64>,
    /// Values of the constant `C` on the pattern — the dampers' and the beams' Rayleigh
    /// `α m(x_e) M_e` — `None` without either.
    damping: Option<Vec<f64>>,
    /// Whether a beam has stiffness-proportional damping (`β > 0`) or a damper acts on a
    /// distance or a carried axis: their `C` follows the state.
    structural: bool,
    /// Gravity as a DOF-wise acceleration `ĝ = [g_x, g_y, 0, …]`.
    pub gravity: Vec<f64>,
    /// The gravity load `M ĝ` (zero without gravity).
    gravity_load: Vec<f64>,
}

impl<'m> Assembler<'m> {
    /// Assembler of `model` for a design's `densities`.
    ///
    /// # Errors
    /// As [`Pattern::new`].
    pub fn new(
        model: &'m Model,
        densities: Densities,
        mass_kind: MassKind,
    ) -> Result<Self, SolveError> {
        let bar_masses = model.bar_couplings(mass_kind);
        let pattern = Pattern::new(model, bar_masses)?;
        let mut mass = vec![0.0; pattern.nnz()];
        for (bar, slots) in bar_masses.iter().zip(&pattern.bar_slots) {
            let m = bar.matrix() * densities.mass[bar.element];
            for (k, &slot) in slots.iter().enumerate() {
                mass[slot] += m[(k % 4, k / 4)];
            }
        }
        for (e, el) in model.elements.iter().enumerate() {
            let m = el.kernel.mass_matrix(mass_kind) * densities.mass[e];
            for (k, &slot) in pattern.element_slots[e].iter().enumerate() {
                mass[slot] += m[(k % 6, k / 6)];
            }
        }
        let n_e = model.elements.len();
        for (k, cell) in model.cells.iter().enumerate() {
            let m = cell.kernel.mass_matrix(mass_kind) * densities.mass[n_e + k];
            for (i, &slot) in pattern.cell_slots[k].iter().enumerate() {
                mass[slot] += m[(i % 8, i / 8)];
            }
        }
        for pm in &model.point_masses {
            let s = pattern.node_slots[pm.node];
            mass[s[0]] += pm.mass;
            mass[s[1]] += pm.mass;
            mass[s[2]] += pm.inertia;
        }
        let dampers: Vec<_> = model
            .springs
            .iter()
            .enumerate()
            .filter(|(_, s)| s.damping > 0.0 && !s.damps_nonlinearly())
            .collect();
        let n_e = model.elements.len();
        let rayleigh = model
            .elements
            .iter()
            .any(|e| e.kernel.section().alpha > 0.0)
            || model.cells.iter().any(|c| c.kernel.material.alpha > 0.0);
        let damping = (!dampers.is_empty() || rayleigh).then(|| {
            let (mut values, reference) = (vec![0.0; pattern.nnz()], vec![0.0; model.n_dofs()]);
            for (e, el) in model.elements.iter().enumerate() {
                let alpha = el.kernel.section().alpha;
                if alpha > 0.0 {
                    let m = el.kernel.mass_matrix(mass_kind) * (alpha * densities.mass[e]);
                    for (k, &slot) in pattern.element_slots[e].iter().enumerate() {
                        values[slot] += m[(k % 6, k / 6)];
                    }
                }
            }
            for (k, cell) in model.cells.iter().enumerate() {
                let alpha = cell.kernel.material.alpha;
                if alpha > 0.0 {
                    let m = cell.kernel.mass_matrix(mass_kind) * (alpha * densities.mass[n_e + k]);
                    for (i, &slot) in pattern.cell_slots[k].iter().enumerate() {
                        values[slot] += m[(i % 8, i / 8)];
                    }
                }
            }
            for (bar, slots) in bar_masses.iter().zip(&pattern.bar_slots) {
                let alpha = model.elements[bar.element].kernel.section().alpha;
                let m = bar.matrix() * (alpha * densities.mass[bar.element]);
                for (k, &slot) in slots.iter().enumerate() {
                    values[slot] += m[(k % 4, k / 4)];
                }
            }
            for (k, spring) in dampers {
                let c = spring.damping_matrix(&reference);
                for (i, j) in (0..36).map(|m| (m / 6, m % 6)) {
                    let slot = pattern.spring_slots[k][i][j];
                    if slot != usize::MAX {
                        values[slot] += c[i][j];
                    }
                }
            }
            values
        });
        let g = model.gravity;
        let gravity: Vec<f64> = (0..model.n_dofs())
            .map(|d| [g.x, g.y, 0.0][d % 3])
            .collect();
        let mut asm = Self {
            model,
            pattern,
            densities,
            mass_kind,
            mass,
            damping,
            structural: model.elements.iter().any(|e| e.kernel.section().beta > 0.0)
                || model.cells.iter().any(|c| c.kernel.material.beta > 0.0)
                || model.springs.iter().any(Spring::damps_nonlinearly),
            gravity_load: vec![0.0; gravity.len()],
            gravity,
        };
        let mut load = vec![0.0; asm.gravity.len()];
        asm.mass_times(&asm.gravity, &mut load);
        asm.gravity_load = load;
        Ok(asm)
    }

    /// The symbolic `LDLᵀ` of this pattern's iteration matrix, ready for numeric
    /// factorizations (Newton's, the modal analysis's).
    ///
    /// # Errors
    /// [`SolveError::Setup`] if the ordering or the symbolic analysis fails.
    pub fn symbolic_ldlt(&self) -> Result<Ldlt, SolveError> {
        let p = &self.pattern;
        Ldlt::analyze(
            p.sparsity.n,
            p.sparsity.col_ptr.clone(),
            p.sparsity.row_idx.clone(),
            p.n_q,
            &Pattern::multiplier_dofs(self.model),
        )
        .map_err(|e| match e {
            FactorError::Analysis(detail) => SolveError::Setup(detail),
            other => SolveError::Setup(format!("{other:?}")),
        })
    }

    /// `out = M a` (mass matrix times a nodal vector).
    pub fn mass_times(&self, a: &[f64], out: &mut [f64]) {
        out[..self.pattern.n_q].fill(0.0);
        self.pattern.add_dof_block_times(&self.mass, a, out);
    }

    /// `out += C v` (the dampers' matrix times a nodal vector; nothing without dampers).
    pub fn add_damping_times(&self, v: &[f64], out: &mut [f64]) {
        if let Some(damping) = &self.damping {
            self.pattern.add_dof_block_times(damping, v, out);
        }
    }

    /// Adds `coefficient · C` (`γ'` in a dynamic step) to the matrix values.
    pub fn add_damping(&self, coefficient: f64, values: &mut [f64]) {
        if let Some(damping) = &self.damping {
            values
                .iter_mut()
                .zip(damping)
                .for_each(|(v, c)| *v += coefficient * c);
        }
    }

    /// Whether some damping's `C` follows the state (beams' `β`, dampers on distances).
    pub fn has_structural_damping(&self) -> bool {
        self.structural
    }

    /// The dampings whose `C` follows the state, in the scene's words, for messages: the
    /// bars with stiffness-proportional damping, the dampers on distances or axes.
    pub fn structural_damping_sources(&self) -> String {
        let damped: Vec<&str> = self
            .model
            .bars
            .iter()
            .filter(|b| {
                self.model.elements[b.elements.clone()]
                    .iter()
                    .any(|e| e.kernel.section().beta > 0.0)
            })
            .map(|b| b.name.as_str())
            .collect();
        let dampers: Vec<String> = self
            .model
            .springs
            .iter()
            .filter(|s| s.damps_nonlinearly())
            .map(|s| format!("'{}'", s.name))
            .collect();
        let members: Vec<String> = (self.model.members.iter().enumerate())
            .filter(|(m, _)| {
                (self.model.cells.iter()).any(|c| c.member == *m && c.kernel.material.beta > 0.0)
            })
            .map(|(_, m)| format!("'{}'", m.name))
            .collect();
        let mut parts = Vec::new();
        if !members.is_empty() {
            parts.push(format!(
                "stiffness-proportional damping (β > 0 on member {})",
                members.join(", ")
            ));
        }
        if let Some(first) = damped.first() {
            let others = match damped.len() {
                1 => String::new(),
                n => format!(" and {} other bars", n - 1),
            };
            parts.push(format!(
                "stiffness-proportional damping (β > 0 on bar '{first}'{others})"
            ));
        }
        if !dampers.is_empty() {
            parts.push(format!("the damper {}", dampers.join(", ")));
        }
        parts.join(" and ")
    }

    /// Adds the damping whose `C` follows the state at `(q, v)` to `f` — the beams'
    /// stiffness-proportional `Σ s(x_e) β Bᵀ D B q̇` and the dampers on distances or carried
    /// axes; with `matrix = Some((γ', values))` also `γ' ∂f_d/∂q̇` and the symmetric part of
    /// `∂f_d/∂q` ([`Damping`]) to the matrix values; with `blocks`, in the same pass, what
    /// the matrix leaves for the exact sensitivity solves (cleared first).
    pub fn add_structural_damping(
        &self,
        q: &[f64],
        v: &[f64],
        f: &mut [f64],
        mut matrix: Option<(f64, &mut [f64])>,
        mut blocks: Option<&mut Vec<DampingBlock>>,
    ) {
        if let Some(blocks) = blocks.as_mut() {
            blocks.clear();
        }
        if !self.structural {
            return;
        }
        for (dofs, slots, d) in self.state_dampings(q, v) {
            for (k, x) in dofs.iter().zip(d.force.iter()) {
                if let Some(k) = k {
                    f[*k] += x;
                }
            }
            if let Some((gamma, values)) = matrix.as_mut() {
                let block = d.rate * *gamma + d.symmetric;
                for (i, j) in (0..36).map(|k| (k / 6, k % 6)) {
                    if let Some(slot) = slots.at(i, j) {
                        values[slot] += block[(i, j)];
                    }
                }
            }
            if let Some(blocks) = blocks.as_mut() {
                blocks.push(DampingBlock::new(dofs, &d));
            }
        }
        let n_e = self.model.elements.len();
        let damped =
            (self.model.cells.iter().enumerate()).filter(|(_, c)| c.kernel.material.beta > 0.0);
        for (k, cell) in damped {
            let d = (cell.kernel.blended(self.densities.blend[n_e + k]))
                .damping(&cell.gather(q), &cell.gather(v))
                .scaled(self.densities.stiffness[n_e + k]);
            let dofs = cell.dofs();
            dofs.iter()
                .zip(d.force.iter())
                .for_each(|(&k, x)| f[k] += x);
            if let Some((gamma, values)) = matrix.as_mut() {
                let block = d.rate * *gamma + d.symmetric;
                for (i, &slot) in self.pattern.cell_slots[k].iter().enumerate() {
                    values[slot] += block[(i % 8, i / 8)];
                }
            }
            if let Some(blocks) = blocks.as_mut() {
                blocks.push(DampingBlock::new(dofs.map(Some), &d));
            }
        }
    }

    /// The damping whose `C` follows the state at `(q, v)`, one block at a time: its DOFs,
    /// its slots in the pattern and its [`Damping`] (a beam's scaled by `s(x_e)`).
    fn state_dampings<'s>(
        &'s self,
        q: &'s [f64],
        v: &'s [f64],
    ) -> impl Iterator<Item = ([Option<usize>; 6], Slots<'s>, Damping)> + 's {
        let beams = self
            .model
            .elements
            .iter()
            .enumerate()
            .filter(|(_, el)| el.kernel.section().beta > 0.0)
            .map(move |(e, el)| {
                let d = el.kernel.damping(&el.gather(q), &el.gather(v));
                let slots = Slots::Element(&self.pattern.element_slots[e]);
                (
                    el.dofs().map(Some),
                    slots,
                    d.scaled(self.densities.stiffness[e]),
                )
            });
        let dampers = self
            .model
            .springs
            .iter()
            .zip(&self.pattern.spring_slots)
            .filter(|(s, _)| s.damps_nonlinearly())
            .map(move |(s, slots)| (s.dofs(), Slots::Spring(slots), s.damper(q, v)));
        beams.chain(dampers)
    }

    /// Mean diagonal of `M` over the nodal DOFs, a scale for the constraint rows.
    pub fn mean_mass_diagonal(&self) -> f64 {
        (0..self.pattern.n_q)
            .map(|i| self.mass[self.pattern.node_slots[i / 3][i % 3]])
            .sum::<f64>()
            / self.pattern.n_q as f64
    }

    /// Internal forces `f = Σ s(x_e) f_e(q)` of the beams and cells and those of the
    /// springs; with `tangent`, also adds `Σ s(x_e) K_e(q)` and the springs' tangents to the
    /// matrix values.
    pub fn internal_forces(&self, q: &[f64], f: &mut [f64], mut tangent: Option<&mut [f64]>) {
        f.fill(0.0);
        for (e, el) in self.model.elements.iter().enumerate() {
            let u = el.gather(q);
            let s = self.densities.stiffness[e];
            let dofs = el.dofs();
            match tangent.as_deref_mut() {
                Some(values) => {
                    let (fe, ke) = el.kernel.internal_force_and_tangent(&u);
                    for (k, &slot) in self.pattern.element_slots[e].iter().enumerate() {
                        values[slot] += s * ke[(k % 6, k / 6)];
                    }
                    dofs.iter().zip(fe.iter()).for_each(|(&d, v)| f[d] += s * v);
                }
                None => {
                    let fe = el.kernel.internal_force(&u);
                    dofs.iter().zip(fe.iter()).for_each(|(&d, v)| f[d] += s * v);
                }
            }
        }
        let n_e = self.model.elements.len();
        for (k, cell) in self.model.cells.iter().enumerate() {
            let u = cell.gather(q);
            let s = self.densities.stiffness[n_e + k];
            let kernel = cell.kernel.blended(self.densities.blend[n_e + k]);
            let fe = match tangent.as_deref_mut() {
                Some(values) => {
                    let (fe, ke) = kernel.internal_force_and_tangent(&u);
                    for (i, &slot) in self.pattern.cell_slots[k].iter().enumerate() {
                        values[slot] += s * ke[(i % 8, i / 8)];
                    }
                    fe
                }
                None => kernel.internal_force(&u),
            };
            cell.dofs()
                .iter()
                .zip(fe.iter())
                .for_each(|(&d, v)| f[d] += s * v);
        }
        for (spring, slots) in self.model.springs.iter().zip(&self.pattern.spring_slots) {
            let (fs, ks) = spring.force_and_tangent(q);
            for (d, v) in spring.dofs().iter().zip(fs) {
                if let Some(d) = d {
                    f[*d] += v;
                }
            }
            if let Some(values) = tangent.as_deref_mut() {
                for (i, j) in (0..36).map(|k| (k / 6, k % 6)) {
                    if slots[i][j] != usize::MAX {
                        values[slots[i][j]] += ks[i][j];
                    }
                }
            }
        }
    }

    /// Applied nodal loads and motor torques at time `t`, scaled by `factor`.
    pub fn external_forces(&self, t: f64, factor: f64, f: &mut [f64]) {
        f.fill(0.0);
        for load in &self.model.loads {
            let g = factor * load.time.at(t);
            for k in 0..3 {
                f[3 * load.node + k] += g * load.value[k];
            }
        }
        let motion = self.model.analysis == Analysis::Dynamic;
        for motor in &self.model.motors {
            motor.add_force(t, factor, motion, f);
        }
    }

    /// Applied loads and gravity `factor · (f_ext(t) + M ĝ)`: the load of a static scene,
    /// whose power `(f_ext + M ĝ)ᵀ q̇` is the external power of a dynamic one.
    pub fn applied_loads(&self, t: f64, factor: f64, f: &mut [f64]) {
        self.external_forces(t, factor, f);
        f.iter_mut()
            .zip(&self.gravity_load)
            .for_each(|(fi, g)| *fi += factor * g);
    }

    /// Constraint values `Φ_k = h_k(q) − factor · g_k(t)` and, in one pass, the joint
    /// forces `forces += Φ_q(q)ᵀ λ` and, if given, `jacobian = Φ_q(q)`; `turns` are the
    /// nodes' at `q`.
    #[allow(clippy::too_many_arguments)]
    pub fn constraint_residual(
        &self,
        q: &[f64],
        turns: &Turns,
        lambda: &[f64],
        t: f64,
        factor: f64,
        phi: &mut [f64],
        forces: &mut [f64],
        mut jacobian: Option<&mut Jacobian>,
    ) {
        let model = self.model;
        if let Some(j) = jacobian.as_deref_mut() {
            j.0.fill(0.0);
        }
        for k in 0..model.n_constraints() {
            let (range, dofs) = (model.row_dofs.range(k), model.row_dofs.of_row(k));
            let mut entries = jacobian.as_deref_mut().map(|j| &mut j.0[range]);
            let value = model.constraints().evaluate(k, q, Some(turns), |i, g| {
                forces[dofs[i]] += g * lambda[k];
                if let Some(entries) = entries.as_deref_mut() {
                    entries[i] += g;
                }
            });
            phi[k] = value - factor * model.constraints().prescribed(k, t)[0];
        }
    }

    /// Prescribed constraint accelerations `g̈_k(t)` (`Φ_q q̈ = g̈` at rest).
    pub fn constraint_accelerations(&self, t: f64, out: &mut [f64]) {
        for (k, o) in out.iter_mut().enumerate() {
            *o = self.model.constraints().prescribed(k, t)[2];
        }
    }

    /// Starts an augmented iteration matrix: `values = mass_coefficient · M + s Φ_qᵀΦ_q` plus
    /// the constraint blocks `s Φ_q`, `s Φ_qᵀ` of `jacobian`, and `s` on the diagonal of each
    /// absent rotation ([`Model::absent_rotations`]: a zero row and column otherwise, its
    /// unknown stays zero); [`Assembler::internal_forces`]
    /// then adds `K_t`, and [`Assembler::add_constraint_hessian`] the joints' part of it.
    pub fn start_iteration_matrix(
        &self,
        mass_coefficient: f64,
        constraint_scale: f64,
        jacobian: &Jacobian,
        values: &mut [f64],
    ) {
        values
            .iter_mut()
            .zip(&self.mass)
            .for_each(|(v, m)| *v = mass_coefficient * m);
        let p = &self.pattern;
        for &d in &self.model.absent_rotations {
            values[p.node_slots[d / 3][2]] += constraint_scale;
        }
        let rows = &self.model.row_dofs;
        for (k, g) in rows.split(&jacobian.0).enumerate() {
            let slots = &p.row_slots[rows.range(k)];
            let gram = p.gram(k);
            for (i, (gi, slot)) in g.iter().zip(slots).enumerate() {
                values[slot[0]] += constraint_scale * gi;
                values[slot[1]] += constraint_scale * gi;
                for (gj, &s) in g.iter().zip(&gram[i * g.len()..]) {
                    values[s] += constraint_scale * gi * gj;
                }
            }
        }
    }

    /// Adds `Σ_k λ_k ∂²h_k/∂q²` at `q`, the joints' part of the tangent (nonzero only for
    /// rows on arms or carried directions), to the matrix values.
    pub fn add_constraint_hessian(
        &self,
        q: &[f64],
        turns: &Turns,
        lambda: &[f64],
        values: &mut [f64],
    ) {
        let model = self.model;
        for (k, &l) in lambda.iter().enumerate() {
            if model.constraints().is_linear(k) {
                continue;
            }
            let (gram, n) = (self.pattern.gram(k), model.row_dofs.range(k).len());
            model
                .constraints()
                .add_hessian(k, q, Some(turns), l, |i, j, h| values[gram[i * n + j]] += h);
        }
    }

    /// `Σ λₖ ∂²Φₖ/∂q²` alone as values on the pattern, for products with
    /// [`Assembler::add_tangent_times`].
    pub fn constraint_hessian(&self, q: &[f64], lambda: &[f64]) -> Vec<f64> {
        let mut values = vec![0.0; self.pattern.nnz()];
        let turns = Turns::at(&self.model.rows, q);
        self.add_constraint_hessian(q, &turns, lambda, &mut values);
        values
    }

    /// The tangent `K_t(q) + Σ λₖ ∂²Φₖ/∂q²` (elements, springs, joints) as values on the
    /// pattern, for products with [`Assembler::add_tangent_times`].
    pub fn tangent(&self, q: &[f64], lambda: &[f64]) -> Vec<f64> {
        let mut values = vec![0.0; self.pattern.nnz()];
        self.internal_forces(q, &mut vec![0.0; self.pattern.n_q], Some(&mut values));
        let turns = Turns::at(&self.model.rows, q);
        self.add_constraint_hessian(q, &turns, lambda, &mut values);
        values
    }

    /// `out += K v` for a [`Assembler::tangent`]'s values `K`.
    pub fn add_tangent_times(&self, tangent: &[f64], v: &[f64], out: &mut [f64]) {
        self.pattern.add_dof_block_times(tangent, v, out);
    }

    /// For each constraint row, `(∂²Φₖ/∂q²) a` at `q` on its DOFs (zero for a linear
    /// row), row after row as in [`RowDofs`]: how `Φ_q a` changes with `q`.
    pub fn constraint_curvature(&self, q: &[f64], a: &[f64]) -> Vec<f64> {
        let model = self.model;
        let mut out = vec![0.0; model.row_dofs.dofs().len()];
        for k in (0..model.n_constraints()).filter(|&k| !model.constraints().is_linear(k)) {
            let (range, dofs) = (model.row_dofs.range(k), model.row_dofs.of_row(k));
            let entries = &mut out[range];
            model
                .constraints()
                .add_hessian(k, q, None, 1.0, |i, j, h| entries[i] += h * a[dofs[j]]);
        }
        out
    }

    /// Applies the augmentation `E` of `jacobian` to a right-hand side `[b; c]`:
    /// `b += Φ_qᵀ c`.
    pub fn augment_rhs(&self, jacobian: &Jacobian, rhs: &mut [f64]) {
        let n_q = self.pattern.n_q;
        let rows = &self.model.row_dofs;
        for (k, g) in rows.split(&jacobian.0).enumerate() {
            let c = rhs[n_q + k];
            for (&d, gi) in rows.of_row(k).iter().zip(g) {
                rhs[d] += gi * c;
            }
        }
    }

    /// Mean diagonal of `K_t` at `q` over the nodal DOFs.
    pub fn mean_stiffness_diagonal(&self, q: &[f64]) -> f64 {
        let mut values = vec![0.0; self.pattern.nnz()];
        let mut f = vec![0.0; self.pattern.n_q];
        self.internal_forces(q, &mut f, Some(&mut values));
        (0..self.pattern.n_q)
            .map(|i| values[self.pattern.node_slots[i / 3][i % 3]].abs())
            .sum::<f64>()
            / self.pattern.n_q as f64
    }

    /// Strain energy `Σ_e s(x_e) U_e(q)` of the beams and the cells, and the springs' energy (J).
    pub fn strain_energy(&self, q: &[f64]) -> f64 {
        let beams: f64 = self
            .model
            .elements
            .iter()
            .enumerate()
            .map(|(e, el)| self.densities.stiffness[e] * el.kernel.strain_energy(&el.gather(q)))
            .sum();
        let n_e = self.model.elements.len();
        let cells: f64 = (self.model.cells.iter().enumerate())
            .map(|(k, c)| {
                let kernel = c.kernel.blended(self.densities.blend[n_e + k]);
                self.densities.stiffness[n_e + k] * kernel.strain_energy(&c.gather(q))
            })
            .sum();
        beams + cells + self.model.springs.iter().map(|s| s.energy(q)).sum::<f64>()
    }

    /// `M`, `K_t(q)` and `Φ_q` as compressed sparse columns, each without explicit zeros,
    /// for eigenvalue analyses and export.
    pub fn linearization(&self, q: &[f64]) -> Linearization {
        let (n, n_c) = (self.pattern.n_q, self.model.n_constraints());
        let mut values = vec![0.0; self.pattern.nnz()];
        let jacobian = Jacobian::at(self.model, q);
        self.start_iteration_matrix(1.0, 0.0, &jacobian, &mut values);
        let mass = self.pattern.block(&values, 0..n, 0..n);
        self.start_iteration_matrix(0.0, 0.0, &jacobian, &mut values);
        self.internal_forces(q, &mut vec![0.0; n], Some(&mut values));
        let stiffness = self.pattern.block(&values, 0..n, 0..n);
        self.start_iteration_matrix(0.0, 1.0, &jacobian, &mut values);
        let jacobian = self.pattern.block(&values, n..n + n_c, 0..n);
        Linearization {
            mass,
            stiffness,
            jacobian,
        }
    }
}

/// `M`, `K_t(q)` and `Φ_q` of `model` for a design's `densities` (see
/// [`Assembler::linearization`]).
///
/// # Errors
/// As [`Pattern::new`].
pub fn linearize(
    model: &Model,
    densities: Densities,
    mass: MassKind,
    q: &[f64],
) -> Result<Linearization, SolveError> {
    Ok(Assembler::new(model, densities, mass)?.linearization(q))
}

/// A sparse matrix in compressed sparse columns (the layout of `scipy.sparse.csc_matrix`).
#[derive(Debug, Clone, PartialEq)]
pub struct Csc {
    /// `(rows, columns)`.
    pub shape: (usize, usize),
    /// Nonzero values, column by column.
    pub data: Vec<f64>,
    /// Row of each value.
    pub indices: Vec<usize>,
    /// Start of each column in `data`, and the end.
    pub indptr: Vec<usize>,
}

/// The linearized equations of motion at a state: `M`, `K_t` and `Φ_q`.
#[derive(Debug, Clone, PartialEq)]
pub struct Linearization {
    /// Mass matrix `M` (`n_q × n_q`).
    pub mass: Csc,
    /// Tangent stiffness `K_t` (`n_q × n_q`).
    pub stiffness: Csc,
    /// Constraint Jacobian `Φ_q` (`n_c × n_q`).
    pub jacobian: Csc,
}

impl Pattern {
    /// The nonzero `rows × cols` block of `values` (on this pattern) as a [`Csc`].
    fn block(&self, values: &[f64], rows: Range<usize>, cols: Range<usize>) -> Csc {
        let shape = (rows.len(), cols.len());
        let (mut data, mut indices, mut indptr) = (Vec::new(), Vec::new(), vec![0]);
        for j in cols {
            let column = self.sparsity.column(j);
            for (&i, &v) in self.sparsity.row_idx[column.clone()]
                .iter()
                .zip(&values[column])
            {
                if rows.contains(&i) && v != 0.0 {
                    data.push(v);
                    indices.push(i - rows.start);
                }
            }
            indptr.push(data.len());
        }
        Csc {
            shape,
            data,
            indices,
            indptr,
        }
    }
}

#[cfg(test)]
mod tests {
    //! The Newton tangent is the exact derivative of the residual.

    use super::*;

    /// A deterministic pseudo-random sequence in [−1, 1].
    fn noise(seed: u64) -> impl FnMut() -> f64 {
        let mut s = seed;
        move || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        }
    }

    /// A failed sensitivity solve names the damping at fault in the scene's words: a
    /// damper on a distance was called stiffness-proportional damping before.
    #[test]
    fn state_following_damping_is_named_by_its_source() {
        let text = include_str!("../../examples/slider_crank.toml");
        let source = |extra: &str| {
            let spec = crate::scene::parse_toml(&format!("{text}\n{extra}")).unwrap();
            let model = crate::scene::build(&spec).unwrap();
            let asm = Assembler::new(&model, model.densities(None).unwrap(), MassKind::Consistent)
                .unwrap();
            asm.structural_damping_sources()
        };
        let damper = "[[springs]]\nname = \"d\"\nnodes = [\"rod0\", \"rod4\"]\nk = 0.0\nc = 5.0\n";
        assert_eq!(source(damper), "the damper 'd'");
        let rayleigh = text.replace(
            "diameter = 0.006",
            "diameter = 0.006\nrayleigh = [0.0, 1e-4]",
        );
        let spec = crate::scene::parse_toml(&rayleigh).unwrap();
        let model = crate::scene::build(&spec).unwrap();
        let asm =
            Assembler::new(&model, model.densities(None).unwrap(), MassKind::Consistent).unwrap();
        assert_eq!(
            asm.structural_damping_sources(),
            "stiffness-proportional damping (β > 0 on bar 'rod/bar0' and 3 other bars)"
        );
    }

    /// With joints on rigid-body points and a slider, the iteration matrix's joint part —
    /// `Φ_qᵀ` blocks and the Hessian `Σ λₖ ∂²Φₖ/∂q²` scattered by the slot maps — is the
    /// derivative of the joint forces `Φ_q(q)ᵀλ` and of `Φ(q)`.
    #[test]
    fn joint_terms_of_the_iteration_matrix_equal_central_differences() {
        let spec =
            crate::scene::parse_toml(include_str!("../../examples/slider_crank.toml")).unwrap();
        let model = crate::scene::build(&spec).unwrap();
        let x = vec![0.6; model.n_variables()];
        let asm = Assembler::new(
            &model,
            model.densities(Some(&x)).unwrap(),
            MassKind::Consistent,
        )
        .unwrap();
        let (n, n_c) = (model.n_dofs(), model.n_constraints());
        let mut rnd = noise(7);
        let q: Vec<f64> = (0..n)
            .map(|d| {
                if d % 3 == 2 {
                    2.0 * rnd()
                } else {
                    0.05 * rnd()
                }
            })
            .collect();
        let lambda: Vec<f64> = (0..n_c).map(|_| 10.0 * rnd()).collect();
        let residual = |qq: &[f64]| {
            let (mut r, mut phi) = (vec![0.0; n], vec![0.0; n_c]);
            let turns = Turns::at(&model.rows, qq);
            asm.constraint_residual(qq, &turns, &lambda, 0.0, 1.0, &mut phi, &mut r, None);
            [r, phi].concat()
        };
        let mut values = vec![0.0; asm.pattern.nnz()];
        asm.start_iteration_matrix(0.0, 1.0, &Jacobian::at(&model, &q), &mut values);
        asm.add_constraint_hessian(&q, &Turns::at(&model.rows, &q), &lambda, &mut values);
        // Undo the augmentation: the DOF block holds ΣλH + Φ_qᵀΦ_q.
        let jac = Jacobian::at(&model, &q);
        let p = &asm.pattern;
        let scale = values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for j in 0..n {
            let eps = 1e-7;
            let (mut qp, mut qm) = (q.clone(), q.clone());
            qp[j] += eps;
            qm[j] -= eps;
            let (rp, rm) = (residual(&qp), residual(&qm));
            let mut column = vec![0.0; n + n_c];
            for idx in p.sparsity.col_ptr[j]..p.sparsity.col_ptr[j + 1] {
                column[p.sparsity.row_idx[idx]] = values[idx];
            }
            for k in 0..n_c {
                let (dofs, g) = (model.row_dofs.of_row(k), jac.row(&model, k));
                if let Some(gj) = dofs.iter().position(|&d| d == j).map(|i| g[i]) {
                    for (&d, gi) in dofs.iter().zip(g) {
                        column[d] -= gi * gj;
                    }
                }
            }
            for i in 0..n + n_c {
                let fd = (rp[i] - rm[i]) / (2.0 * eps);
                assert!(
                    (fd - column[i]).abs() < 1e-6 * scale,
                    "S[{i},{j}] = {} vs {fd}",
                    column[i]
                );
            }
        }
    }

    #[test]
    fn iteration_matrix_equals_central_differences_of_the_residual() {
        let mut spec =
            crate::scene::parse_toml(include_str!("../../examples/robot_arm.toml")).unwrap();
        spec.ground_structures.iter_mut().for_each(|g| g.split = 2);
        let arm = crate::scene::build(&spec).unwrap();
        let x: Vec<f64> = (0..arm.n_variables())
            .map(|i| 0.05 + 0.9 * ((i * 37 % 101) as f64 / 101.0))
            .collect();
        let asm =
            Assembler::new(&arm, arm.densities(Some(&x)).unwrap(), MassKind::Consistent).unwrap();
        let n = arm.n_dofs();
        let beta_prime = 4.0e3;
        for seed in 1..4 {
            let mut rnd = noise(seed);
            // A large rigid rotation of everything plus random deformation.
            let angle = 1.3 * rnd();
            let q: Vec<f64> = (0..n)
                .map(|d| {
                    let p = arm.nodes[d / 3].position;
                    let rigid = [
                        p.x * (angle.cos() - 1.0) - p.y * angle.sin(),
                        p.x * angle.sin() + p.y * (angle.cos() - 1.0),
                        angle,
                    ][d % 3];
                    rigid + 2e-3 * rnd()
                })
                .collect();
            let acc0: Vec<f64> = (0..n).map(|_| rnd()).collect();
            // Step residual as a function of q: r = M q̈(q) + f_int(q), q̈ = q̈₀ + β'(q − q₀).
            let residual = |qq: &[f64]| {
                let acc: Vec<f64> = (0..n)
                    .map(|i| acc0[i] + beta_prime * (qq[i] - q[i]))
                    .collect();
                let (mut inertia, mut f) = (vec![0.0; n], vec![0.0; n]);
                asm.mass_times(&acc, &mut inertia);
                asm.internal_forces(qq, &mut f, None);
                inertia
                    .iter()
                    .zip(&f)
                    .map(|(a, b)| a + b)
                    .collect::<Vec<f64>>()
            };
            let mut values = vec![0.0; asm.pattern.nnz()];
            asm.start_iteration_matrix(beta_prime, 0.0, &Jacobian::at(&arm, &q), &mut values);
            asm.internal_forces(&q, &mut vec![0.0; n], Some(&mut values));
            let p = &asm.pattern;
            let scale = values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for j in (0..n).step_by(7) {
                let eps = 1e-7;
                let (mut qp, mut qm) = (q.clone(), q.clone());
                qp[j] += eps;
                qm[j] -= eps;
                let (rp, rm) = (residual(&qp), residual(&qm));
                let mut column = vec![0.0; n];
                for idx in p.sparsity.col_ptr[j]..p.sparsity.col_ptr[j + 1] {
                    if p.sparsity.row_idx[idx] < n {
                        column[p.sparsity.row_idx[idx]] = values[idx];
                    }
                }
                for i in 0..n {
                    let fd = (rp[i] - rm[i]) / (2.0 * eps);
                    assert!(
                        (fd - column[i]).abs() < 1e-6 * scale,
                        "S[{i},{j}] = {} vs {fd}",
                        column[i]
                    );
                }
            }
        }
    }
}
