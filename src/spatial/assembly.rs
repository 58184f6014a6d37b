//! The residual and the iteration matrix of a spatial mechanism on a fixed sparse pattern.
//!
//! Unknowns: the increments `δ` of the nodes' algebra (six per node), then the scaled
//! multipliers `ν` (`λ = s ν`, one per constraint row). The Lie-group generalized-α
//! iteration matrix (Brüls, Cardona & Arnold 2012, Eq. 57) is
//!
//! ```text
//! [ β' M + γ' C_t + K_t T(Δ)    s Bᵀ ]
//! [ s B T(Δ)                    0    ]
//! ```
//!
//! with `C_t` the bodies' gyroscopic and the force elements' damping, `K_t` the force
//! elements' stiffness and the constraint-force stiffness `∂(Bᵀλ)/∂q` (bodies add none), `T(Δ)` the
//! tangent operator of the step's increment `Δ` node by node and `s` the row scaling. The
//! initial accelerations use the same pattern with `β' = 1`, `γ' = 0`, no `K_t` and `T = I`.
//! The pattern is analysed once; values are written through [`Sparsity::at`], so an
//! iteration allocates nothing.

use nalgebra::{Matrix3, SMatrix, SVector, Vector3, Vector6};

use crate::error::SolveError;
use crate::group::pair::{Pair, LOCAL};
use crate::group::so3::tangent;
use crate::group::{six, NV};
use crate::joint::spatial::{Gradient, Joint, Stiffness, MAX_ROWS};
use crate::solver::block_lu::Blocks;
use crate::solver::newton::{nan_max, Residual};
use crate::solver::sparsity::Sparsity;
use crate::solver::unsymmetric::Unsymmetric;
use crate::spatial::element::{Derivatives, Element, Terms};
use crate::spatial::force::Local;
use crate::spatial::model::SpatialModel;

/// The assembler of `model` and the solver of its iteration matrix analysed once on its
/// pattern ([`Unsymmetric`]).
///
/// # Errors
/// [`SolveError::Setup`] if the pattern cannot be analysed or lacks an entry the assembler
/// writes (an engine defect).
pub(crate) fn analysed(model: &SpatialModel) -> Result<(Assembler<'_>, Unsymmetric), SolveError> {
    let asm = Assembler::new(model)?;
    let p = &asm.pattern;
    let lu = Unsymmetric::analyze(p.n, p.col_ptr.clone(), p.row_idx.clone(), &asm.blocks())
        .map_err(|e| SolveError::Setup(format!("{e:?}")))?;
    Ok((asm, lu))
}

/// Forces and matrices of a spatial mechanism.
pub(crate) struct Assembler<'m> {
    pub model: &'m SpatialModel,
    /// The load factor on gravity, motors and loads: 1 in motion, climbing to 1 in a
    /// static solve.
    pub load: f64,
    pub pattern: Sparsity,
    pub values: Vec<f64>,
    /// First row of each joint.
    first_row: Vec<usize>,
    /// Each joint's `∂(Bᵀλ)/∂q` and `B` at the last [`Assembler::matrix`] with a tangent,
    /// for the sensitivities' [`Assembler::linear_terms`] at the same state.
    joint_blocks: Vec<(Stiffness, Gradient)>,
    /// Each joint's `Φ` and `B` at the last [`Assembler::matrix`], for a residual at the same
    /// state.
    joint_rows: Vec<JointRows>,
    /// Each force element's `K` and `C` at the last [`Assembler::matrix`], likewise.
    force_blocks: Vec<Derivatives>,
    /// Each structural element's (beams, then truss bars), likewise.
    element_blocks: Vec<Derivatives>,
    /// Each structural element's mass matrix, constant.
    element_masses: Vec<Stiffness>,
    /// `mean(diag M)` ([`Assembler::mean_mass`]), constant.
    mean_mass: f64,
    /// Where each body's `6 × 6` block and each joint's, force element's and beam's local
    /// block is stored ([`local_slots`]), found once.
    body_slots: Vec<Vec<usize>>,
    joint_slots: Vec<Vec<usize>>,
    force_slots: Vec<Vec<usize>>,
    element_slots: Vec<Vec<usize>>,
    /// Where each joint's rows `s B` and columns `s Bᵀ` are stored, node by node of its
    /// pair ([`row_slots`]), found once.
    row_slots: Vec<Vec<usize>>,
    /// The diagonal slots of the rotations of nodes that have none (only truss bars meet
    /// there): a unit there keeps them still.
    absent_slots: Vec<usize>,
}

/// A joint's `Φ` (its first [`Joint::n_rows`] entries) and `B`.
type JointRows = (SVector<f64, MAX_ROWS>, Gradient);

/// What the iteration matrix is made of at one iterate.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Coefficients<'a> {
    /// `β'` (1 for the initial accelerations).
    pub beta_prime: f64,
    /// `γ'` (0 for the initial accelerations).
    pub gamma_prime: f64,
    /// The row scaling `s`.
    pub scale: f64,
    /// The step's increment `Δ` and the multipliers `λ`, for `K_t T(Δ)`; `None` leaves the
    /// stiffness out and `T = I`.
    pub tangent: Option<(&'a [f64], &'a [f64])>,
}

impl<'m> Assembler<'m> {
    /// The blocks of the iteration matrix's unknowns: each node's six, each joint's rows.
    pub fn blocks(&self) -> Blocks {
        let mut sizes = vec![NV; self.model.nodes.len()];
        sizes.extend(
            self.model
                .joints
                .iter()
                .map(|j| j.n_rows())
                .filter(|&r| r > 0),
        );
        Blocks {
            sizes,
            dofs: self.model.nodes.len(),
        }
    }

    /// The pattern of `model`'s iteration matrix and where each block is stored.
    ///
    /// # Errors
    /// [`SolveError::Setup`] if an entry a block needs is missing from the pattern (an
    /// engine defect).
    pub fn new(model: &'m SpatialModel) -> Result<Self, SolveError> {
        let n_v = model.n_v();
        let n = n_v + model.n_rows();
        let mut entries = Vec::new();
        let mut block = |r0: usize, c0: usize, rows: usize, cols: usize| {
            for c in c0..c0 + cols {
                entries.extend((r0..r0 + rows).map(|r| (c, r)));
            }
        };
        for b in &model.bodies {
            block(NV * b.node, NV * b.node, NV, NV);
        }
        let mut first_row = Vec::with_capacity(model.joints.len());
        let mut row = n_v;
        for j in &model.joints {
            first_row.push(row);
            let rows = j.n_rows();
            for (_, n1) in j.local_nodes() {
                for (_, n2) in j.local_nodes() {
                    block(NV * n1, NV * n2, NV, NV);
                }
                block(row, NV * n1, rows, NV);
                block(NV * n1, row, NV, rows);
            }
            row += rows;
        }
        let absent: Vec<usize> = (model.rotation_absent().iter().enumerate())
            .filter(|(_, a)| **a)
            .flat_map(|(n, _)| (3..NV).map(move |k| NV * n + k))
            .collect();
        absent.iter().for_each(|&d| block(d, d, 1, 1));
        let pairs = model.forces.iter().map(|f| &f.pair);
        for pair in pairs.chain(model.elements().map(|e| e.pair())) {
            for (_, n1) in pair.local_nodes() {
                for (_, n2) in pair.local_nodes() {
                    block(NV * n1, NV * n2, NV, NV);
                }
            }
        }
        let pattern = Sparsity::from_entries(n, entries);
        let values = vec![0.0; pattern.row_idx.len()];
        let pair_slots = |pair: &Pair| local_slots(&pattern, pair);
        let body_slots = model
            .bodies
            .iter()
            .map(|b| {
                let local = pair_slots(&Pair {
                    nodes: [Some(b.node), None],
                    arms: [Vector3::zeros(); 2],
                })?;
                // The node's own `6 × 6` block, column by column.
                let local = &local;
                Some(
                    (0..NV)
                        .flat_map(|j| (0..NV).map(move |i| local[i + LOCAL * j]))
                        .collect(),
                )
            })
            .collect::<Option<_>>();
        let joint_slots = model
            .joints
            .iter()
            .map(|j| pair_slots(&j.pair))
            .collect::<Option<_>>();
        let row_slots = (model.joints.iter().zip(&first_row))
            .map(|(j, &row)| row_slots(&pattern, j, row))
            .collect::<Option<_>>();
        let force_slots = model
            .forces
            .iter()
            .map(|f| pair_slots(&f.pair))
            .collect::<Option<_>>();
        let element_slots = model
            .elements()
            .map(|e| pair_slots(e.pair()))
            .collect::<Option<_>>();
        let absent_slots = absent
            .iter()
            .map(|&d| pattern.slot(d, d))
            .collect::<Option<_>>();
        let missing = || SolveError::Setup("an entry missing from the sparsity pattern".into());
        let element_masses: Vec<Stiffness> = model.elements().map(|e| e.mass_matrix()).collect();
        Ok(Self {
            absent_slots: absent_slots.ok_or_else(missing)?,
            body_slots: body_slots.ok_or_else(missing)?,
            joint_slots: joint_slots.ok_or_else(missing)?,
            row_slots: row_slots.ok_or_else(missing)?,
            force_slots: force_slots.ok_or_else(missing)?,
            element_slots: element_slots.ok_or_else(missing)?,
            model,
            load: 1.0,
            pattern,
            values,
            joint_blocks: vec![(Stiffness::zeros(), Gradient::zeros()); model.joints.len()],
            joint_rows: vec![(SVector::zeros(), Gradient::zeros()); model.joints.len()],
            force_blocks: vec![Derivatives::zeros(); model.forces.len()],
            element_blocks: vec![Derivatives::zeros(); model.beams.len() + model.trusses.len()],
            mean_mass: mean_mass(model, &element_masses),
            element_masses,
            first_row,
        })
    }

    /// The relative residuals of `r`, [`Assembler::residual`]'s with its `F_ref`
    /// `reference`: `‖r_f‖∞ / F_ref` and `‖Φ‖∞ / L`, `L` the model's size; NaN where an entry
    /// is.
    pub fn measure(&self, r: &[f64], reference: f64) -> Residual {
        let n_v = self.model.n_v();
        let largest = |x: &[f64]| x.iter().fold(0.0f64, |m, x| nan_max(m, x.abs()));
        Residual {
            force: largest(&r[..n_v]) / reference.max(f64::MIN_POSITIVE),
            constraint: largest(&r[n_v..]) / self.model.size(),
        }
    }

    /// The residual `[f_inertia + f_forces + Bᵀλ; Φ]` at `(q, v, v̇, λ)` and time `t` into `r`
    /// (length `n`); returns `F_ref`, the largest magnitude among the inertia, gravity,
    /// force elements' and joint forces.
    ///
    /// # Errors
    /// A force element's ([`crate::spatial::force::Force::terms`]).
    pub fn residual(
        &self,
        q: &[f64],
        v: &[f64],
        vdot: &[f64],
        lambda: &[f64],
        t: f64,
        r: &mut [f64],
    ) -> Result<f64, SolveError> {
        let mut reference = self.residual_without_elements(q, v, vdot, lambda, t, r, None)?;
        let model = self.model;
        let gravity = model.gravity * self.load;
        for element in model.elements() {
            let terms = element.terms(q, v, Some(vdot), &gravity, None);
            reference = add_element_forces(r, element, &terms, &gravity, reference);
        }
        Ok(reference)
    }

    /// The residual's terms of the bodies, joints and force elements (every one but the
    /// structural elements') into `r`, and their `F_ref`; the joints' `Φ` and `B` from
    /// `joints` where given (the last [`Assembler::matrix_without_elements`]'s, at the same
    /// state).
    #[allow(clippy::too_many_arguments)]
    fn residual_without_elements(
        &self,
        q: &[f64],
        v: &[f64],
        vdot: &[f64],
        lambda: &[f64],
        t: f64,
        r: &mut [f64],
        joints: Option<&[JointRows]>,
    ) -> Result<f64, SolveError> {
        let model = self.model;
        let n_v = model.n_v();
        r.fill(0.0);
        let mut reference = 0.0f64;
        for b in &model.bodies {
            let gravity = model.gravity * self.load;
            let f = b.inertia_force(&six(v, b.node), &six(vdot, b.node), &gravity);
            add_six(r, b.node, &Vector6::from(f));
            let weight = b.mass * gravity.norm();
            reference = f.iter().fold(reference.max(weight), |m, x| m.max(x.abs()));
        }
        for (k, (j, &row)) in model.joints.iter().zip(&self.first_row).enumerate() {
            let n = j.n_rows();
            let l = multipliers(&lambda[row - n_v..row - n_v + n]);
            let computed;
            let (values, g) = match joints {
                Some(rows) => (&rows[k].0, &rows[k].1),
                None => {
                    computed = j.values_and_gradient(q, t);
                    (&computed.0, &computed.1)
                }
            };
            let forces = g.tr_mul(&l);
            for (side, node) in j.local_nodes() {
                let f = forces.fixed_rows::<NV>(NV * side);
                reference = f.iter().fold(reference, |m, x| m.max(x.abs()));
                r[NV * node..NV * node + NV]
                    .iter_mut()
                    .zip(f.iter())
                    .for_each(|(ri, fi)| *ri += fi);
            }
            r[row..row + n].copy_from_slice(&values.as_slice()[..n]);
        }
        for force in &model.forces {
            let f = force.terms(q, v, t, self.load)?.force;
            reference = f.iter().fold(reference, |m, x| m.max(x.abs()));
            scatter(r, &force.pair, &f);
        }
        Ok(reference)
    }

    /// [`Assembler::residual`] and [`Assembler::matrix`] with the coefficients `c` at the
    /// same state in one pass over the elements: each element's forces and derivatives
    /// from one evaluation of its kinematics (a Newton iterate that will factor its matrix).
    ///
    /// # Errors
    /// As both.
    pub fn residual_and_matrix(
        &mut self,
        (q, v, vdot): (&[f64], &[f64], &[f64]),
        lambda: &[f64],
        t: f64,
        r: &mut [f64],
        c: Coefficients<'_>,
    ) -> Result<f64, SolveError> {
        self.matrix_without_elements(q, v, t, c)?;
        let joints = Some(self.joint_rows.as_slice());
        let mut reference = self.residual_without_elements(q, v, vdot, lambda, t, r, joints)?;
        let model = self.model;
        let gravity = model.gravity * self.load;
        let increment = c.tangent.map(|(inc, _)| inc);
        for (k, element) in model.elements().enumerate() {
            let d = &mut self.element_blocks[k];
            let terms = element.terms(q, v, Some(vdot), &gravity, increment.map(|_| &mut *d));
            reference = add_element_forces(r, element, &terms, &gravity, reference);
            self.put_element(k, element, c);
        }
        self.hold_absent();
        Ok(reference)
    }

    /// The right-hand side `[−f(q, v); −b(q, v)]` of the initial accelerations, `f` the
    /// inertia forces at zero acceleration and the force elements', `b` the joints'
    /// acceleration terms, scaled rows `−s b`.
    ///
    /// # Errors
    /// A force element's.
    pub fn acceleration_rhs(
        &self,
        q: &[f64],
        v: &[f64],
        t: f64,
        scale: f64,
        rhs: &mut [f64],
    ) -> Result<(), SolveError> {
        let zero = [0.0; NV];
        rhs.fill(0.0);
        let model = self.model;
        for b in &model.bodies {
            let f = b.inertia_force(&six(v, b.node), &zero, &(model.gravity * self.load));
            rhs[NV * b.node..NV * b.node + NV]
                .iter_mut()
                .zip(f)
                .for_each(|(r, fi)| *r -= fi);
        }
        for (j, &row) in model.joints.iter().zip(&self.first_row) {
            let out = &mut rhs[row..row + j.n_rows()];
            j.acceleration_terms(q, v, t, out);
            out.iter_mut().for_each(|x| *x *= -scale);
        }
        for force in &model.forces {
            let f = -force.terms(q, v, t, self.load)?.force;
            scatter(rhs, &force.pair, &f);
        }
        for element in model.elements() {
            let terms = element.terms(q, v, None, &(model.gravity * self.load), None);
            scatter(rhs, element.pair(), &-(terms.internal + terms.inertia));
        }
        Ok(())
    }

    /// Writes the iteration matrix at `(q, v)` and time `time` (module docs).
    ///
    /// # Errors
    /// A force element's.
    pub fn matrix(
        &mut self,
        q: &[f64],
        v: &[f64],
        time: f64,
        c: Coefficients<'_>,
    ) -> Result<(), SolveError> {
        self.matrix_without_elements(q, v, time, c)?;
        let model = self.model;
        let gravity = model.gravity * self.load;
        for (k, element) in model.elements().enumerate() {
            let d = &mut self.element_blocks[k];
            if c.tangent.is_some() {
                element.terms(q, v, None, &gravity, Some(d));
            }
            self.put_element(k, element, c);
        }
        self.hold_absent();
        Ok(())
    }

    /// Adds structural element `k`'s block of the iteration matrix ([`scatter_element`]),
    /// from the derivatives its last [`Element::terms`] wrote.
    fn put_element(&mut self, k: usize, element: &dyn Element, c: Coefficients<'_>) {
        let (mass, d) = (&self.element_masses[k], &self.element_blocks[k]);
        scatter_element(
            &mut self.values,
            &self.element_slots[k],
            mass,
            d,
            element,
            c,
        );
    }

    /// The iteration matrix's entries of the bodies, joints and force elements (the
    /// structural elements' left out), the rest zero.
    fn matrix_without_elements(
        &mut self,
        q: &[f64],
        v: &[f64],
        time: f64,
        c: Coefficients<'_>,
    ) -> Result<(), SolveError> {
        self.values.fill(0.0);
        let model = self.model;
        let n_v = model.n_v();
        for (b, slots) in model.bodies.iter().zip(&self.body_slots) {
            let block = b.iteration_block(&six(v, b.node), c.beta_prime, c.gamma_prime);
            for (&slot, &x) in slots.iter().zip(block.as_slice()) {
                self.values[slot] += x;
            }
        }
        for (k, j) in model.joints.iter().enumerate() {
            let (row, n) = (self.first_row[k], j.n_rows());
            let increment = c.tangent.map(|(inc, _)| inc);
            let (values, g) = &mut self.joint_rows[k];
            let (stiffness, gradient) = &mut self.joint_blocks[k];
            let lambda = c
                .tangent
                .map(|(_, lambda)| &lambda[row - n_v..row - n_v + n]);
            j.rows_into(q, time, lambda.map(|l| (l, &mut *stiffness)), (values, g));
            if c.tangent.is_some() {
                gradient.copy_from(g);
                let kt = times_tangent(stiffness, &j.pair, increment);
                scatter_block(&mut self.values, &self.joint_slots[k], &kt);
            }
            let g = &self.joint_rows[k].1;
            // Borrowed by the closures below: each `move` copies a reference, not the blocks.
            let gt = &(times_tangent(g, &j.pair, increment) * c.scale);
            let gs = &(g.transpose() * c.scale);
            let mut slots = self.row_slots[k].iter();
            for (side, _) in j.local_nodes() {
                let rows = (0..NV).flat_map(|c| (0..n).map(move |r| gt[(r, NV * side + c)]));
                let columns = (0..n).flat_map(|c| (0..NV).map(move |r| gs[(NV * side + r, c)]));
                for (value, &s) in rows.chain(columns).zip(&mut slots) {
                    self.values[s] += value;
                }
            }
        }
        if let Some((inc, _)) = c.tangent {
            for (k, force) in model.forces.iter().enumerate() {
                let terms = force.terms(q, v, time, self.load)?;
                let kt = times_tangent(&terms.stiffness, &force.pair, Some(inc));
                scatter_block(
                    &mut self.values,
                    &self.force_slots[k],
                    &(kt + terms.damping * c.gamma_prime),
                );
                self.force_blocks[k] = Derivatives {
                    stiffness: terms.stiffness,
                    damping: terms.damping,
                };
            }
        }
        Ok(())
    }

    /// A unit on the diagonal of every absent rotation: it keeps them still.
    fn hold_absent(&mut self) {
        for &slot in &self.absent_slots {
            self.values[slot] = 1.0;
        }
    }

    /// Adds `K ε + C v'` to `force` and `B ε` to `constraint`: the residual's change with
    /// a variation `ε` of the configuration (in the nodes' algebra) and `v'` of the
    /// velocities — the terms the sensitivities carry from step to step — at velocity `v`
    /// and the configuration, multipliers and time of the last [`Assembler::matrix`] with
    /// a tangent.
    pub fn linear_terms(
        &self,
        v: &[f64],
        eps: &[f64],
        vp: &[f64],
        force: &mut [f64],
        constraint: &mut [f64],
    ) {
        let model = self.model;
        let n_v = model.n_v();
        for b in &model.bodies {
            let c = b.iteration_block(&six(v, b.node), 0.0, 1.0);
            let f = c * Vector6::from_column_slice(&six(vp, b.node));
            add_six(force, b.node, &f);
        }
        for ((j, &row), (stiffness, gradient)) in model
            .joints
            .iter()
            .zip(&self.first_row)
            .zip(&self.joint_blocks)
        {
            let n = j.n_rows();
            let local = gather(&j.pair, eps);
            let k = stiffness * local;
            for (side, node) in j.local_nodes() {
                add_six(force, node, &k.fixed_rows::<NV>(NV * side).into_owned());
            }
            let b = gradient * local;
            constraint[row - n_v..row - n_v + n]
                .iter_mut()
                .zip(b.iter())
                .for_each(|(c, x)| *c += x);
        }
        let pairs = model.forces.iter().map(|f| &f.pair);
        let blocks = self.force_blocks.iter().chain(&self.element_blocks);
        for (pair, d) in pairs.chain(model.elements().map(|e| e.pair())).zip(blocks) {
            let f = d.stiffness * gather(pair, eps) + d.damping * gather(pair, vp);
            scatter(force, pair, &f);
        }
    }

    /// The transpose of [`Assembler::linear_terms`]: adds `Kᵀ y_f + Bᵀ y_c` to `eps_bar` and
    /// `Cᵀ y_f` to `v_bar`, at the same state.
    pub fn linear_terms_transpose(
        &self,
        v: &[f64],
        y_force: &[f64],
        y_constraint: &[f64],
        eps_bar: &mut [f64],
        v_bar: &mut [f64],
    ) {
        let model = self.model;
        let n_v = model.n_v();
        for b in &model.bodies {
            let c = b.iteration_block(&six(v, b.node), 0.0, 1.0);
            let f = c.transpose() * Vector6::from_column_slice(&six(y_force, b.node));
            add_six(v_bar, b.node, &f);
        }
        for ((j, &row), (stiffness, gradient)) in model
            .joints
            .iter()
            .zip(&self.first_row)
            .zip(&self.joint_blocks)
        {
            let n = j.n_rows();
            let local = gather(&j.pair, y_force);
            let mut from_rows = multipliers(&y_constraint[row - n_v..row - n_v + n]);
            from_rows.rows_mut(n, MAX_ROWS - n).fill(0.0);
            let back = stiffness.transpose() * local + gradient.transpose() * from_rows;
            for (side, node) in j.local_nodes() {
                add_six(
                    eps_bar,
                    node,
                    &back.fixed_rows::<NV>(NV * side).into_owned(),
                );
            }
        }
        let pairs = model.forces.iter().map(|f| &f.pair);
        let blocks = self.force_blocks.iter().chain(&self.element_blocks);
        for (pair, d) in pairs.chain(model.elements().map(|e| e.pair())).zip(blocks) {
            let y = gather(pair, y_force);
            scatter(eps_bar, pair, &(d.stiffness.transpose() * y));
            scatter(v_bar, pair, &(d.damping.transpose() * y));
        }
    }

    /// `mean(diag M)`, the scale of the multipliers' rows at `β' = 1`.
    pub fn mean_mass(&self) -> f64 {
        self.mean_mass
    }
}

/// `mean(diag M)` of `model`, whose elements' mass matrices are `masses`: its bodies' and
/// elements' diagonals over its unknowns (1 without nodes).
fn mean_mass(model: &SpatialModel, masses: &[Stiffness]) -> f64 {
    if model.nodes.is_empty() {
        return 1.0;
    }
    let bodies: f64 = model
        .bodies
        .iter()
        .map(|b| 3.0 * b.mass + b.inertia.trace())
        .sum();
    let elements: f64 = masses.iter().map(|m| m.trace()).sum();
    (bodies + elements) / model.n_v() as f64
}

/// Where joint `j`'s rows (from `row`) and columns of `B` are stored, node by node of its
/// pair: its rows' block on the node's six columns column by column, then its columns' block
/// on the node's six rows, as [`Assembler::matrix`] adds them; `None` where the pattern
/// lacks one.
fn row_slots(pattern: &Sparsity, j: &Joint, row: usize) -> Option<Vec<usize>> {
    let n = j.n_rows();
    let mut slots = Vec::with_capacity(2 * NV * n * 2);
    for (_, node) in j.local_nodes() {
        let rows = (0..NV).flat_map(|c| (0..n).map(move |r| (row + r, NV * node + c)));
        let columns = (0..n).flat_map(|c| (0..NV).map(move |r| (NV * node + r, row + c)));
        for (r, c) in rows.chain(columns) {
            slots.push(pattern.slot(r, c)?);
        }
    }
    Some(slots)
}

/// Where each entry of a pair's local `12 × 12` block is stored, column by column
/// ([`ABSENT`] on the ground's side): the order [`scatter_block`] reads; `None` where the
/// pattern lacks one.
fn local_slots(pattern: &Sparsity, pair: &Pair) -> Option<Vec<usize>> {
    let node = |s: usize| pair.nodes[s];
    (0..LOCAL)
        .flat_map(|c| (0..LOCAL).map(move |r| (r, c)))
        .map(|(r, c)| match (node(r / NV), node(c / NV)) {
            (Some(a), Some(b)) => pattern.slot(NV * a + r % NV, NV * b + c % NV),
            _ => Some(ABSENT),
        })
        .collect()
}

/// Adds a structural element's forces `terms` to `r`; returns `reference` raised to their
/// largest magnitude and the element's weight.
fn add_element_forces(
    r: &mut [f64],
    element: &dyn Element,
    terms: &Terms,
    gravity: &Vector3<f64>,
    reference: f64,
) -> f64 {
    let weight = 0.5 * element.mass() * gravity.norm();
    scatter(r, element.pair(), &(terms.internal + terms.inertia));
    (terms.internal.iter())
        .chain(terms.inertia.iter())
        .fold(reference.max(weight), |m, x| m.max(x.abs()))
}

/// Adds a structural element's block `β'M + γ'C + K T(Δ)` of the iteration matrix at its
/// [`local_slots`], from its mass matrix `mass` and its derivatives `d` (their part left
/// out where `c` asks for no tangent), entry by entry: `T(Δ)` turns only the rotations'
/// columns.
fn scatter_element(
    values: &mut [f64],
    slots: &[usize],
    mass: &Stiffness,
    d: &Derivatives,
    element: &dyn Element,
    c: Coefficients<'_>,
) {
    let Some((inc, _)) = c.tangent else {
        for (&slot, &m) in slots.iter().zip(mass.as_slice()) {
            if slot != ABSENT {
                values[slot] += c.beta_prime * m;
            }
        }
        return;
    };
    let mut turn = [Matrix3::identity(); 2];
    for (side, node) in element.pair().local_nodes() {
        let d = six(inc, node);
        turn[side] = tangent(&Vector3::new(d[3], d[4], d[5]));
    }
    let (k, damping) = (&d.stiffness, &d.damping);
    for j in 0..12 {
        let (side, local) = (j / NV, j % NV);
        let column = |i: usize| match local {
            0..3 => k[(i, j)],
            _ => (0..3)
                .map(|m| k[(i, NV * side + 3 + m)] * turn[side][(m, local - 3)])
                .sum(),
        };
        for i in 0..12 {
            let slot = slots[i + 12 * j];
            if slot != ABSENT {
                values[slot] +=
                    c.beta_prime * mass[(i, j)] + c.gamma_prime * damping[(i, j)] + column(i);
            }
        }
    }
}

/// A slot of a local block on the ground: not stored.
const ABSENT: usize = usize::MAX;

/// Adds a local `12 × 12` block at its [`local_slots`].
fn scatter_block(values: &mut [f64], slots: &[usize], block: &Stiffness) {
    for (&slot, &x) in slots.iter().zip(block.as_slice()) {
        if slot != ABSENT {
            values[slot] += x;
        }
    }
}

/// A pair's twelve local numbers of a six-per-node vector (zero on the ground).
fn gather(pair: &Pair, x: &[f64]) -> Local {
    let mut local = Local::zeros();
    for (side, node) in pair.local_nodes() {
        local
            .fixed_rows_mut::<NV>(NV * side)
            .copy_from_slice(&six(x, node));
    }
    local
}

/// Adds a pair's twelve local numbers to its nodes' in `out`.
fn scatter(out: &mut [f64], pair: &Pair, local: &Local) {
    for (side, node) in pair.local_nodes() {
        add_six(out, node, &local.fixed_rows::<NV>(NV * side).into_owned());
    }
}

/// `m diag(I, T_A, I, T_B)`: `m` on a pair's local unknowns times the tangent operators of
/// the step's increment at its nodes (`None`: `m`).
fn times_tangent<const R: usize>(
    m: &SMatrix<f64, R, 12>,
    pair: &Pair,
    increment: Option<&[f64]>,
) -> SMatrix<f64, R, 12> {
    let mut out = SMatrix::zeros();
    add_times_tangent(&mut out, m, pair, increment);
    out
}

/// Adds [`times_tangent`] to `out`, only the rotation columns turned.
fn add_times_tangent<const R: usize>(
    out: &mut SMatrix<f64, R, 12>,
    m: &SMatrix<f64, R, 12>,
    pair: &Pair,
    increment: Option<&[f64]>,
) {
    *out += m;
    let Some(inc) = increment else { return };
    for (side, node) in pair.local_nodes() {
        let d = six(inc, node);
        let at = NV * side + 3;
        let columns = m.fixed_view::<R, 3>(0, at);
        let turned = columns * (tangent(&Vector3::new(d[3], d[4], d[5])) - Matrix3::identity());
        let mut target = out.fixed_view_mut::<R, 3>(0, at);
        target += turned;
    }
}

/// Adds six numbers to node `node`'s in `out`.
fn add_six(out: &mut [f64], node: usize, f: &Vector6<f64>) {
    out[NV * node..NV * node + NV]
        .iter_mut()
        .zip(f.iter())
        .for_each(|(o, x)| *o += x);
}

/// A joint's multipliers, padded with zeros to [`MAX_ROWS`].
fn multipliers(lambda: &[f64]) -> SVector<f64, MAX_ROWS> {
    let mut l = SVector::<f64, MAX_ROWS>::zeros();
    l.rows_mut(0, lambda.len()).copy_from_slice(lambda);
    l
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::group::{so3, Frame, NQ};
    use crate::joint::spatial::{Anchor, JointKind};
    use crate::mechanism::load::TimeFunction;
    use crate::spatial::section::{Section, Shape};

    /// Two bodies, one hinged to the ground, joined to each other at one point by a joint of
    /// every kind (far too many constraints to move, but each row's derivatives count), and
    /// every force element.
    fn chain() -> SpatialModel {
        let mut m = SpatialModel::new(Vector3::new(0.0, 0.0, -9.81)).unwrap();
        let r1 = so3::exp(&Vector3::new(0.3, -0.5, 1.0));
        let r2 = so3::exp(&Vector3::new(-1.2, 0.4, 0.2));
        let inertia = nalgebra::Matrix3::new(3.0, 0.2, -0.1, 0.2, 2.0, 0.3, -0.1, 0.3, 1.5);
        let a1 = Vector3::new(0.1, -0.6, 0.2);
        let a2 = Vector3::new(-0.3, 0.2, 0.5);
        let b1 = m
            .add_body("one", Frame::new(-(r1 * a1), r1), 2.0, inertia)
            .unwrap();
        let tip = Vector3::new(0.2, 0.7, -0.1);
        let joint_point = -(r1 * a1) + r1 * tip;
        let b2 = m
            .add_body(
                "two",
                Frame::new(joint_point - r2 * a2, r2),
                1.5,
                inertia * 0.5,
            )
            .unwrap();
        let axis = Vector3::new(0.3, -0.5, 0.8);
        let root = JointKind::Revolute {
            axis: Vector3::new(0.0, 0.6, 0.8),
        };
        m.add_joint(
            "root",
            root,
            Anchor::Body {
                body: b1,
                point: a1,
            },
            Anchor::Ground(Vector3::zeros()),
        )
        .unwrap();
        let kinds = [
            JointKind::Spherical,
            JointKind::Revolute { axis },
            JointKind::Universal {
                axis_a: axis,
                axis_b: Vector3::new(0.8, 0.0, -0.3),
            },
            JointKind::Cylindrical { axis },
            JointKind::Prismatic { axis },
            JointKind::Weld,
        ];
        for (k, kind) in kinds.into_iter().enumerate() {
            let (a, b) = (
                Anchor::Body {
                    body: b1,
                    point: tip,
                },
                Anchor::Body {
                    body: b2,
                    point: a2,
                },
            );
            m.add_joint(&format!("middle{k}"), kind, a, b).unwrap();
        }
        // Every force element: a spring-damper off its rest length, a motor between the two
        // bodies, a dead and a follower load varying in time.
        let spring = (
            Anchor::Body {
                body: b1,
                point: a1 * 0.5,
            },
            Anchor::Body {
                body: b2,
                point: -a2,
            },
        );
        m.add_spring("spring", spring.0, spring.1, 300.0, 4.0, Some(0.2))
            .unwrap();
        let ramp = TimeFunction::Table {
            t: vec![0.0, 1.0],
            value: vec![0.5, 1.5],
        };
        m.add_motor("motor", 2, 7.0, ramp.clone()).unwrap();
        let (f, moment) = (Vector3::new(3.0, -2.0, 5.0), Vector3::new(0.4, 0.1, -0.3));
        let at = |point| Anchor::Body { body: b2, point };
        m.add_load("dead", at(a2 * 0.7), f, moment, ramp.clone(), false)
            .unwrap();
        m.add_load("follower", at(-a2), f * 0.5, moment, ramp, true)
            .unwrap();
        // A damped beam from body two's point to a free node, turned.
        let tube = Shape::HollowCircle {
            outer: 0.05,
            inner: 0.04,
        }
        .geometry(0.3)
        .unwrap();
        let section = Section::new(&tube, 2e7, 8e6, 1200.0).with_rayleigh(0.7, 3e-2);
        let start = m.nodes[1].frame.x;
        let end = Frame::new(
            start + Vector3::new(0.3, -0.2, 0.4),
            so3::exp(&Vector3::new(0.2, 0.9, -0.4)),
        );
        let free = m.add_node("free", end).unwrap();
        m.add_beam("beam", 1, free, &section, Vector3::new(0.0, 0.0, 1.0))
            .unwrap();
        m
    }

    /// The iteration matrix is the derivative of the residual in the Newton unknowns: a change
    /// `δ` of the increment moves `q = qₙ ∘ exp(Δ)`, `v` by `γ'δ` and `v̇` by `β'δ`; a change
    /// of `ν` moves `λ` by `s`. Central differences, column by column.
    #[test]
    fn iteration_matrix_against_differences() {
        let model = chain();
        let mut asm = Assembler::new(&model).unwrap();
        let n_v = model.n_v();
        let n = asm.pattern.n;
        let start = model.initial_configuration();
        let inc: Vec<f64> = (0..n_v).map(|i| 0.3 * ((i as f64) * 1.7).sin()).collect();
        let v: Vec<f64> = (0..n_v).map(|i| 2.0 * ((i as f64) * 0.9).cos()).collect();
        let vdot: Vec<f64> = (0..n_v).map(|i| ((i as f64) * 2.3).sin()).collect();
        let lam: Vec<f64> = (0..model.n_rows())
            .map(|i| 5.0 * ((i as f64) * 1.1 + 0.5).cos())
            .collect();
        let (bp, gp, scale) = (40.0, 3.0, 7.0);
        let residual_at = |e: f64, k: usize| {
            let (mut inc, mut v, mut vdot, mut lam) =
                (inc.clone(), v.clone(), vdot.clone(), lam.clone());
            if k < n_v {
                inc[k] += e;
                v[k] += gp * e;
                vdot[k] += bp * e;
            } else {
                lam[k - n_v] += scale * e;
            }
            let mut q = vec![0.0; NQ * model.nodes.len()];
            for node in 0..model.nodes.len() {
                Frame::read(&start, node)
                    .retract(&inc[NV * node..NV * node + NV])
                    .write(&mut q, node);
            }
            let mut r = vec![0.0; n];
            Assembler::new(&model)
                .unwrap()
                .residual(&q, &v, &vdot, &lam, 0.3, &mut r)
                .unwrap();
            r[n_v..].iter_mut().for_each(|x| *x *= scale);
            r
        };
        let mut q = vec![0.0; NQ * model.nodes.len()];
        for node in 0..model.nodes.len() {
            Frame::read(&start, node)
                .retract(&inc[NV * node..NV * node + NV])
                .write(&mut q, node);
        }
        asm.matrix(
            &q,
            &v,
            0.3,
            Coefficients {
                beta_prime: bp,
                gamma_prime: gp,
                scale,
                tangent: Some((&inc, &lam)),
            },
        )
        .unwrap();
        let entry = |r: usize, c: usize| {
            let (s, e) = (asm.pattern.col_ptr[c], asm.pattern.col_ptr[c + 1]);
            asm.pattern.row_idx[s..e]
                .binary_search(&r)
                .map_or(0.0, |k| asm.values[s + k])
        };
        let eps = 1e-6;
        for c in 0..n {
            let (p, m) = (residual_at(eps, c), residual_at(-eps, c));
            for r in 0..n {
                let fd = (p[r] - m[r]) / (2.0 * eps);
                let exact = entry(r, c);
                assert!(
                    (fd - exact).abs() < 1e-6 * (1.0 + exact.abs()),
                    "({r}, {c}): {fd} against {exact}"
                );
            }
        }
    }
}
