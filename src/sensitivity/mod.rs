//! Design sensitivities of responses, exact for the discrete scheme (paper §2.5, §3).
//!
//! Two methods differentiate the same discrete equations:
//!
//! * [`direct`] — Algorithm 2: after each step, the step's iteration matrix, factorized
//!   once, solves the linear sensitivity step (Eq. 20–24) for all `n` design variables at
//!   once (column blocks in parallel); cost grows with `n`.
//! * [`adjoint`] — the discrete adjoint: a forward sweep stores the states, a backward sweep
//!   runs the transposed recurrence with one right-hand side per response; cost independent
//!   of `n`.
//!
//! Both use the pseudo-loads of Eq. 35–36: the residual depends on an element's density
//! through its inertia (`m(x)`, linear in the paper's Eq. 33) and its stiffness (`s(x)`,
//! Eq. 34), so `∂r/∂x_e = m'(x_e) M_e (q̈_e − ĝ_e) + s'(x_e) f_e(q_e)` with full-density
//! element quantities.
//! Static scenes use the same pieces on the equilibrium `K_t u' = −r_x` ([`statics`]), and
//! on the linear analysis's `K₀ u' = −r_x` with `∂r/∂x_e = s'(x_e) (f₀ + K₀ u_e)`
//! ([`crate::mechanism::linear`]).

pub mod adjoint;
pub mod direct;
mod kink;
pub mod shares;
mod start;
pub mod statics;

use crate::error::{Error, SettingsError};
use crate::mechanism::bar_mass::BarMass;
use crate::mechanism::element::quad::{Matrix8, Vector8};
use crate::mechanism::element::{MassKind, Matrix6, Vector6};
use crate::mechanism::linear::Linearized;
use crate::mechanism::model::{Analysis, Densities, Model};
use crate::mechanism::parameter::{At, Designed, Parameter};
use crate::response::{Context, Objectives, Response, Sample};
use crate::settings::{
    DynamicSettings, Memory, Method, SensitivitySettings, StaticAnalysis, StaticSettings,
};
use crate::solver::assembly::Assembler;
use crate::time_grid::TimeGrid;

/// Responses and their gradients.
#[derive(Debug, Clone, PartialEq)]
pub struct Sensitivities {
    /// `f_k(x)`.
    pub values: Vec<f64>,
    /// `∂f_k/∂x_j`, row-major `n_responses × n_variables`.
    pub gradients: Vec<f64>,
    /// `∂f_k/∂p_i` of the scene parameters asked for, row-major
    /// `n_responses × n_parameters`.
    pub parameter_gradients: Vec<f64>,
    /// The method actually used.
    pub method: Method,
    /// Wall time (s) of the simulation and of the sensitivity analysis.
    pub timings: Timings,
    /// Per response: the largest point value of an aggregate (a stress response's peak,
    /// Pa) over the states, `None` for the others.
    pub peaks: Vec<Option<f64>>,
    /// Per response: its time error `f(h) − f` to leading order in the step, estimated by
    /// the adjoint sweep that made the gradients ([`adjoint::time_errors`]); `None` where no
    /// adjoint sweep of a motion made them (the direct method, an equilibrium).
    pub time_errors: Option<Vec<f64>>,
}

impl Sensitivities {
    /// The result of a sweep whose gradient rows (row-major, one per value) hold the design
    /// variables' columns, then the parameters'.
    fn new(
        model: &Model,
        values: Vec<f64>,
        rows: &[f64],
        method: Method,
        timings: Timings,
        peaks: Vec<Option<f64>>,
    ) -> Self {
        let n_x = model.n_variables();
        let width = rows.len() / values.len().max(1);
        let (mut gradients, mut parameter_gradients) = (Vec::new(), Vec::new());
        for row in rows.chunks(width.max(1)) {
            gradients.extend_from_slice(&row[..n_x]);
            parameter_gradients.extend_from_slice(&row[n_x..]);
        }
        Self {
            values,
            gradients,
            parameter_gradients,
            method,
            timings,
            peaks,
            time_errors: None,
        }
    }
}

/// Where the time of a run with gradients went.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Timings {
    /// The simulation itself (forward sweep), s.
    pub simulation: f64,
    /// The sensitivity analysis (linear solves, pseudo-loads, backward sweep), s.
    pub gradients: f64,
}

/// Pseudo-loads `∂r/∂x` (paper Eq. 35–36), element by element, then those of the scene
/// parameters ([`Parameter::pseudo_load`]): one column per design variable, then one per
/// parameter.
pub(crate) struct PseudoLoads {
    /// Full-density element mass matrices.
    masses: Vec<Matrix6>,
    /// Each cell's mass matrix at full density.
    cell_masses: Vec<Matrix8>,
    /// Design variables, the first columns.
    n_x: usize,
    pub(super) parameters: Vec<Parameter>,
    /// Whether damping reads the velocities ([`Model::damping_reads_velocities`]).
    damped: bool,
    /// The elements linearized about the reference, for the pseudo-loads of a linear
    /// analysis: `s'(x_e) (f₀ + K₀ u_e)`.
    linear: Option<Linearized>,
}

impl PseudoLoads {
    pub(crate) fn new(model: &Model, kind: MassKind, parameters: &[Parameter]) -> Self {
        Self {
            masses: model
                .elements
                .iter()
                .map(|e| e.kernel.mass_matrix(kind))
                .collect(),
            cell_masses: model
                .cells
                .iter()
                .map(|c| c.kernel.mass_matrix(kind))
                .collect(),
            n_x: model.n_variables(),
            parameters: parameters.to_vec(),
            damped: model.damping_reads_velocities(),
            linear: None,
        }
    }

    /// The pseudo-loads of a linear analysis: the elements' forces those of `linear`.
    pub(crate) fn of_linear(mut self, linear: Linearized) -> Self {
        self.linear = Some(linear);
        self
    }

    /// Design variables and parameters: the columns of the sensitivities.
    fn columns(&self) -> usize {
        self.n_x + self.parameters.len()
    }

    /// Whether the sweeps read velocities: a parameter's pseudo-load, a density's of a beam
    /// with Rayleigh damping, or a damper's state-following `C`.
    fn reads_velocities(&self) -> bool {
        self.damped || self.parameters.iter().any(Parameter::reads_velocities)
    }

    /// Whether a parameter's pseudo-load has constraint rows: right-hand sides then need
    /// the augmentation, and transposed solutions its transpose.
    fn moves_constraints(&self) -> bool {
        self.parameters.iter().any(Parameter::moves_constraints)
    }

    /// `m'(x_e) M_e (q̈_e − ĝ_e + α q̇_e) + s'(x_e) (f_e(q_e) + f_d,e(q_e, q̇_e))` of
    /// element `e`, with its Rayleigh damping (`q̈ = q̇ = 0` for statics).
    fn element(&self, asm: &Assembler, e: usize, at: &At) -> Vector6 {
        let d = &asm.densities;
        self.element_residual(asm, e, at, d.mass_rate[e], d.stiffness_rate[e])
    }

    /// `m M_e (q̈_e − ĝ_e + α q̇_e) + s (f_e(q_e) + f_d,e(q_e, q̇_e))`: element `e`'s terms
    /// of the residual (`f_e = f₀ + K₀ u_e` in a linear analysis) with its mass scaled by `m`
    /// and its stiffness by `s` (the densities'
    /// `m(x)` and `s(x)` give its share of the residual, their rates its pseudo-load).
    pub(crate) fn element_residual(
        &self,
        asm: &Assembler,
        e: usize,
        at: &At,
        m: f64,
        s: f64,
    ) -> Vector6 {
        let el = &asm.model.elements[e];
        let dofs = el.dofs();
        let u = el.gather(at.q);
        let (alpha, beta) = (el.kernel.section().alpha, el.kernel.section().beta);
        let mut inertia = Vector6::from_fn(|i, _| -asm.gravity[dofs[i]]);
        let mut stiffness = match &self.linear {
            Some(linear) => linear.element_force(e, &u),
            None => el.kernel.internal_force(&u),
        };
        if let Some((v, acc)) = at.rates {
            inertia += Vector6::from_fn(|i, _| acc[dofs[i]]);
            if alpha > 0.0 {
                inertia += el.gather(v) * alpha;
            }
            if beta > 0.0 {
                stiffness += el.kernel.damping(&u, &el.gather(v)).force;
            }
        }
        self.masses[e] * inertia * m + stiffness * s
    }

    /// `m'(x_b) M_c (q̈ + α q̇)` on the four DOFs of a bar's end coupling `bar` (gravity is
    /// uniform, so `M_c ĝ = 0`; zero for statics).
    fn bar(asm: &Assembler, bar: &BarMass, at: &At) -> [f64; 4] {
        Self::coupling_residual(bar, asm, at, asm.densities.mass_rate[bar.element])
    }

    /// `m M_c (q̈ + α q̇)`: the terms of the residual of a bar's end coupling `bar` with its
    /// mass scaled by `m`.
    pub(crate) fn coupling_residual(
        bar: &BarMass,
        asm: &Assembler,
        at: &At,
        rate: f64,
    ) -> [f64; 4] {
        let Some((v, acc)) = at.rates else {
            return [0.0; 4];
        };
        let alpha = asm.model.elements[bar.element].kernel.section().alpha;
        // Velocities are kept where damping reads them.
        let b = if v.is_empty() { [0.0; 4] } else { bar.times(v) };
        let a = bar.times(acc);
        std::array::from_fn(|i| rate * (a[i] + alpha * b[i]))
    }

    /// `m'(x_c) M_c (q̈_c − ĝ_c + α q̇_c) + s'(x_c) (f_c + f_d,c) + s(x_c) γ'(x_c) ∂(f_c +
    /// f_d,c)/∂γ` of cell `k` (its energy blended by `γ`:
    /// [`crate::mechanism::element::void`]), with its member's Rayleigh damping (`q̈ = q̇ =
    /// 0` for statics); `s'(x_c) K₀ u_c` in a linear analysis, whose `K₀` has no blend.
    fn cell(&self, asm: &Assembler, k: usize, at: &At) -> Vector8 {
        let cell = &asm.model.cells[k];
        let e = asm.model.elements.len() + k;
        let d = &asm.densities;
        let (kernel, blend_rate) = (cell.kernel.blended(d.blend[e]), d.blend_rate[e]);
        let dofs = cell.dofs();
        let u = cell.gather(at.q);
        let (alpha, beta) = (cell.kernel.material.alpha, cell.kernel.material.beta);
        let mut inertia = Vector8::from_fn(|i, _| -asm.gravity[dofs[i]]);
        let (mut stiffness, mut blending) = match self.linear {
            // The linear cell's K₀ does not depend on the blend.
            Some(_) => (
                Linearized::cell_force(cell.kernel.small_strain_stiffness(), &u),
                Vector8::zeros(),
            ),
            None if blend_rate != 0.0 => (kernel.internal_force(&u), kernel.force_rate(&u)),
            None => (kernel.internal_force(&u), Vector8::zeros()),
        };
        if let Some((v, acc)) = at.rates {
            inertia += Vector8::from_fn(|i, _| acc[dofs[i]]);
            if alpha > 0.0 {
                inertia += cell.gather(v) * alpha;
            }
            if beta > 0.0 {
                let v = cell.gather(v);
                stiffness += kernel.damping(&u, &v).force;
                if blend_rate != 0.0 {
                    blending += kernel.damping_rate(&u, &v);
                }
            }
        }
        self.cell_masses[k] * inertia * d.mass_rate[e]
            + stiffness * d.stiffness_rate[e]
            + blending * (d.stiffness[e] * blend_rate)
    }

    /// Subtracts column `j` of the pseudo-loads from column `j` of the column-major block
    /// `rhs` (leading dimension `ld`) for `j` in `columns` (the block holds those columns
    /// only); a parameter's constraint rows enter scaled by `scale` (the solve's `s`).
    fn subtract_columns(
        &self,
        asm: &Assembler,
        at: &At,
        scale: f64,
        rhs: &mut [f64],
        ld: usize,
        columns: std::ops::Range<usize>,
    ) {
        for e in 0..self.masses.len() {
            if let Some(j) = asm.model.variable_of(e).filter(|j| columns.contains(j)) {
                let p = self.element(asm, e, at);
                let col = &mut rhs[(j - columns.start) * ld..];
                asm.model.elements[e]
                    .dofs()
                    .iter()
                    .zip(p.iter())
                    .for_each(|(&d, v)| col[d] -= v);
            }
        }
        for (k, cell) in asm.model.cells.iter().enumerate() {
            if let Some(j) = cell.variable.filter(|j| columns.contains(j)) {
                let p = self.cell(asm, k, at);
                let col = &mut rhs[(j - columns.start) * ld..];
                cell.dofs()
                    .iter()
                    .zip(p.iter())
                    .for_each(|(&d, v)| col[d] -= v);
            }
        }
        for bar in asm.model.bar_couplings(asm.mass_kind) {
            if let Some(j) = asm
                .model
                .variable_of(bar.element)
                .filter(|j| columns.contains(j))
            {
                let p = Self::bar(asm, bar, at);
                let col = &mut rhs[(j - columns.start) * ld..];
                bar.dofs()
                    .iter()
                    .zip(p.iter())
                    .for_each(|(&d, v)| col[d] -= v);
            }
        }
        let n_q = asm.model.n_dofs();
        for (k, p) in self.parameters.iter().enumerate() {
            let j = self.n_x + k;
            if columns.contains(&j) {
                let col = &mut rhs[(j - columns.start) * ld..(j - columns.start + 1) * ld];
                p.pseudo_load(&designed(asm), at, |i, v| {
                    col[i] -= if i < n_q { v } else { scale * v };
                });
            }
        }
    }

    /// `x̄ −= (∂r/∂x)ᵀ μ` over every column: `μ` a transposed solution `[μ_q; μ_c]` whose
    /// multiplier part is unaugmented ([`crate::solver::newton::Newton::unaugment`]) where a
    /// parameter moves the constraints, scaled by `scale` as the solve's.
    fn subtract_transposed(
        &self,
        asm: &Assembler,
        at: &At,
        scale: f64,
        mu: &[f64],
        xbar: &mut [f64],
    ) {
        for e in 0..self.masses.len() {
            if let Some(j) = asm.model.variable_of(e) {
                let p = self.element(asm, e, at);
                xbar[j] -= asm.model.elements[e]
                    .dofs()
                    .iter()
                    .zip(p.iter())
                    .map(|(&d, v)| v * mu[d])
                    .sum::<f64>();
            }
        }
        for (k, cell) in asm.model.cells.iter().enumerate() {
            if let Some(j) = cell.variable {
                let p = self.cell(asm, k, at);
                xbar[j] -= cell
                    .dofs()
                    .iter()
                    .zip(p.iter())
                    .map(|(&d, v)| v * mu[d])
                    .sum::<f64>();
            }
        }
        for bar in asm.model.bar_couplings(asm.mass_kind) {
            if let Some(j) = asm.model.variable_of(bar.element) {
                let p = Self::bar(asm, bar, at);
                xbar[j] -= bar
                    .dofs()
                    .iter()
                    .zip(p.iter())
                    .map(|(&d, v)| v * mu[d])
                    .sum::<f64>();
            }
        }
        let n_q = asm.model.n_dofs();
        for (k, p) in self.parameters.iter().enumerate() {
            let mut sum = 0.0;
            p.pseudo_load(&designed(asm), at, |i, v| {
                sum += if i < n_q {
                    v * mu[i]
                } else {
                    scale * v * mu[i]
                };
            });
            xbar[self.n_x + k] -= sum;
        }
    }
}

/// How a system `[A, Φ_qᵀ; Φ_q, 0][u; μ] = [b; c]` solved at `q` changes with `q`: `A` by
/// the symmetric `matrix` (values on the pattern) and row `k` of `Φ_q u` by its Hessian
/// times `u`, `curvature[k] = Hₖ u` ([`Assembler::constraint_curvature`]). The initial
/// accelerations ([`start`]) and a restart's jump ([`kink`]) both differentiate one.
struct Curvature<'a> {
    matrix: &'a [f64],
    curvature: &'a [f64],
}

impl Curvature<'_> {
    /// Direct: subtracts `[A q'; s (Hₖ u)ᵀ q']` from each column of `rhs` (leading dimension
    /// `n_q + n_c`), `q'` the columns of `dq`, constraint rows scaled by `scale`.
    fn subtract(&self, asm: &Assembler, dq: &[f64], scale: f64, rhs: &mut [f64]) {
        let n_q = asm.model.n_dofs();
        let n = n_q + asm.model.n_constraints();
        let mut product = vec![0.0; n_q];
        for (column, dq) in rhs.chunks_mut(n).zip(dq.chunks(n_q)) {
            product.fill(0.0);
            asm.add_tangent_times(self.matrix, dq, &mut product);
            column[..n_q]
                .iter_mut()
                .zip(&product)
                .for_each(|(r, p)| *r -= p);
            let rows = &asm.model.row_dofs;
            for ((k, h), r) in rows
                .split(self.curvature)
                .enumerate()
                .zip(&mut column[n_q..])
            {
                let change: f64 = rows
                    .of_row(k)
                    .iter()
                    .zip(h)
                    .map(|(&d, hi)| hi * dq[d])
                    .sum();
                *r -= scale * change;
            }
        }
    }

    /// Adjoint: `q̄ −= A ν_q + Σₖ s νₖ Hₖ u` for each transposed solution `ν` (leading
    /// dimension `n_q + n_c`) and its column of `qbar`.
    fn subtract_transposed(&self, asm: &Assembler, solution: &[f64], scale: f64, qbar: &mut [f64]) {
        let n_q = asm.model.n_dofs();
        let n = n_q + asm.model.n_constraints();
        let mut product = vec![0.0; n_q];
        for (nu, qbar) in solution.chunks(n).zip(qbar.chunks_mut(n_q)) {
            product.fill(0.0);
            asm.add_tangent_times(self.matrix, &nu[..n_q], &mut product);
            qbar.iter_mut().zip(&product).for_each(|(q, p)| *q -= p);
            let rows = &asm.model.row_dofs;
            for ((k, h), mu) in rows.split(self.curvature).enumerate().zip(&nu[n_q..]) {
                for (&d, hi) in rows.of_row(k).iter().zip(h) {
                    qbar[d] -= scale * mu * hi;
                }
            }
        }
    }
}

/// The assembler's model and design, as the parameters' pseudo-loads read them.
fn designed<'a>(asm: &'a Assembler) -> Designed<'a> {
    Designed {
        model: asm.model,
        densities: &asm.densities,
        mass: asm.mass_kind,
    }
}

/// Parses response names against a model.
///
/// # Errors
/// A [`SettingsError`] naming the response.
pub fn parse_responses(model: &Model, names: &[String]) -> Result<Vec<Response>, SettingsError> {
    if names.is_empty() {
        return Err(SettingsError::new(
            "responses",
            "give at least one response",
        ));
    }
    names.iter().map(|n| Response::parse(n, model)).collect()
}

/// Parses scene-parameter names against a model and the responses they will be asked of.
///
/// # Errors
/// A [`SettingsError`] naming the parameter: unknown, or a combination not built (a
/// point's arm with a response that follows a rigid trajectory, or with initial rates).
pub fn parse_parameters(
    model: &Model,
    names: &[String],
    responses: &[Response],
) -> Result<Vec<Parameter>, SettingsError> {
    let parameters = names
        .iter()
        .map(|n| Parameter::parse(n, model))
        .collect::<Result<Vec<_>, _>>()?;
    for (name, p) in names.iter().zip(&parameters) {
        let at = format!("parameter '{name}'");
        if !p.moves_constraints() {
            continue;
        }
        let arm = matches!(p, Parameter::Arm { .. });
        if arm && responses.iter().any(|r| r.rigid_node().is_some()) {
            let msg = "a response follows a rigid trajectory, which it moves: not built";
            return Err(SettingsError::new(at, msg));
        }
        if matches!(p, Parameter::Arm { .. }) && !model.initial_velocity.is_empty() {
            let msg = "the initial rates' motion depends on the point's place: not built";
            return Err(SettingsError::new(at, msg));
        }
    }
    Ok(parameters)
}

/// Responses and gradients of a dynamic run on the fixed-step grid of `settings`.
///
/// # Errors
/// Design, settings and solve errors.
pub fn of_motion(
    model: &Model,
    x: &[f64],
    settings: &DynamicSettings,
    responses: &[Response],
    parameters: &[Parameter],
    how: SensitivitySettings,
) -> Result<Sensitivities, Error> {
    settings.validate()?;
    of_motion_on(
        model,
        x,
        settings,
        &settings.grid(),
        responses,
        parameters,
        how,
    )
}

/// Responses and gradients of a dynamic run on the steps of `grid`, equal or not: the
/// gradients are exact for the scheme that ran on that grid.
///
/// # Errors
/// Design, settings and solve errors.
pub fn of_motion_on(
    model: &Model,
    x: &[f64],
    settings: &DynamicSettings,
    grid: &TimeGrid,
    responses: &[Response],
    parameters: &[Parameter],
    how: SensitivitySettings,
) -> Result<Sensitivities, Error> {
    let densities = model.densities(Some(x))?;
    if !responses.iter().any(Response::depends_on_states) {
        return explicit(model, &densities, responses, parameters);
    }
    let (n_q, n, n_x) = (
        model.n_dofs(),
        model.n_dofs() + model.n_constraints(),
        model.n_variables() + parameters.len(),
    );
    let gib = |doubles: f64| doubles * 8.0 / (1u64 << 30) as f64;
    match resolve(how.method, responses, model) {
        Method::Direct => {
            // q', q̇', q̈', a' and the right-hand sides, each a column per design variable.
            let need = gib((4 * n_q + n) as f64 * n_x as f64);
            if need > MAX_GIB {
                return Err(SettingsError::new("method", format!("the direct method would hold {need:.1} GiB of sensitivities (at most {MAX_GIB} GiB); use method='adjoint'")).into());
            }
            direct::differentiate_forward(model, densities, settings, grid, responses, parameters)
        }
        _ => {
            let velocities = model.damping_reads_velocities()
                || parameters.iter().any(Parameter::reads_velocities);
            let rows = if velocities { 3.0 } else { 2.0 };
            let need = gib(rows * n_q as f64 * (grid.len() + 1) as f64);
            if how.memory == Memory::StoreAll && need > MAX_GIB {
                return Err(SettingsError::new("memory", format!("storing every state would take {need:.1} GiB (at most {MAX_GIB} GiB); use memory='checkpoints'")).into());
            }
            let about = adjoint::About::Run(how.memory);
            adjoint::differentiate_backward(
                model, densities, settings, grid, responses, parameters, about,
            )
        }
    }
}

/// [`of_motion_on`] by the adjoint method about `path`, the model's own run for the design
/// `x` on `grid` with `settings` (the states [`crate::simulate_on`] returns): the same
/// values and gradients without making the run again, so that a run first judged on its
/// values (an optimizer's trial, which it may reject) is differentiated only if it is kept.
/// A path of another design or other settings gives the gradients about that path, not
/// those of the run: the caller keeps them together.
///
/// # Errors
/// A [`SettingsError`] naming `path` unless it has a finite row of the model's coordinates
/// and multipliers at every time of `grid`; design and solve errors.
pub fn of_motion_about(
    model: &Model,
    x: &[f64],
    settings: &DynamicSettings,
    grid: &TimeGrid,
    responses: &[Response],
    parameters: &[Parameter],
    path: adjoint::Path<'_>,
) -> Result<Sensitivities, Error> {
    let densities = model.densities(Some(x))?;
    path.check(
        "path",
        model.n_dofs(),
        model.n_constraints(),
        grid.len() + 1,
    )?;
    if !responses.iter().any(Response::depends_on_states) {
        return explicit(model, &densities, responses, parameters);
    }
    let about = adjoint::About::Path(path);
    adjoint::differentiate_backward(
        model, densities, settings, grid, responses, parameters, about,
    )
}

/// Memory a sensitivity analysis may hold in its largest arrays (GiB).
const MAX_GIB: f64 = 8.0;

/// Responses and gradients of a static equilibrium.
///
/// # Errors
/// Design, settings and solve errors.
pub fn of_equilibrium(
    model: &Model,
    x: &[f64],
    settings: &StaticSettings,
    responses: &[Response],
    parameters: &[Parameter],
    method: Method,
) -> Result<Sensitivities, Error> {
    let analysis = StaticAnalysis::Nonlinear;
    equilibrium(model, x, settings, analysis, responses, parameters, method)
}

/// Responses and gradients of the linear static analysis ([`crate::solve_linear`]):
/// exact for `K₀ u = f`, direct or adjoint.
///
/// # Errors
/// A [`SettingsError`] naming a response that is not built for the linear analysis
/// ([`Response::check_linear`]) or `parameters` (not built); design, settings and solve
/// errors.
pub fn of_linear_equilibrium(
    model: &Model,
    x: &[f64],
    settings: &StaticSettings,
    responses: &[Response],
    parameters: &[Parameter],
    method: Method,
) -> Result<Sensitivities, Error> {
    check_linear(responses, parameters)?;
    let analysis = StaticAnalysis::Linear;
    equilibrium(model, x, settings, analysis, responses, parameters, method)
}

/// The equilibrium of `analysis` and its sensitivities; the responses that do not depend on
/// the state explicit.
fn equilibrium(
    model: &Model,
    x: &[f64],
    settings: &StaticSettings,
    analysis: StaticAnalysis,
    responses: &[Response],
    parameters: &[Parameter],
    method: Method,
) -> Result<Sensitivities, Error> {
    settings.validate()?;
    let densities = model.densities(Some(x))?;
    if !responses.iter().any(Response::depends_on_states) {
        return explicit(model, &densities, responses, parameters);
    }
    let method = resolve(method, responses, model);
    statics::differentiate_equilibrium(
        model, densities, settings, analysis, responses, parameters, method,
    )
}

/// The responses and parameters of a linear analysis: each response's kind built for it, no
/// parameters.
///
/// # Errors
/// A [`SettingsError`] naming the first that is not.
fn check_linear(responses: &[Response], parameters: &[Parameter]) -> Result<(), SettingsError> {
    responses.iter().try_for_each(Response::check_linear)?;
    if parameters.is_empty() {
        Ok(())
    } else {
        let msg = "the scene parameters' gradients are not built for the linear analysis";
        Err(SettingsError::new("parameters", msg))
    }
}

/// Responses evaluated on recorded states: their values and, per aggregate, its peak.
#[derive(Debug, Clone, PartialEq)]
pub struct Evaluated {
    /// `f_k`.
    pub values: Vec<f64>,
    /// Per response: the largest point value of an aggregate over the states, `None` for
    /// the others.
    pub peaks: Vec<Option<f64>>,
}

/// The recorded states of a run, as responses read them: row-major, one row of `n_q`
/// coordinates (and velocities) and of `n_c` multipliers per state, at `times`; one row for
/// a static scene, whose loads act at `load_time`.
#[derive(Debug, Clone, Copy)]
pub struct Recorded<'a> {
    /// `q`.
    pub q: &'a [f64],
    /// `q̇`, if the run kept them (a response that reads them needs them).
    pub qdot: Option<&'a [f64]>,
    /// `λ`.
    pub lam: &'a [f64],
    /// The states' times (s).
    pub times: &'a [f64],
    /// When a static scene's loads act (s).
    pub load_time: f64,
    /// The run's inertia discretization.
    pub mass: MassKind,
    /// The static problem the states solve (a dynamic run's: nonlinear).
    pub analysis: StaticAnalysis,
}

/// Values of `responses` on `recorded` states for design `x` (`None`: full density), with
/// the aggregates' peaks.
///
/// # Errors
/// Settings errors for states and times that do not match; design errors; kinematics
/// errors of the rigid trajectory.
pub fn evaluate(
    model: &Model,
    x: Option<&[f64]>,
    recorded: &Recorded,
    responses: &[Response],
) -> Result<Evaluated, Error> {
    let Recorded {
        q,
        qdot,
        lam,
        times,
        load_time,
        mass,
        analysis,
    } = *recorded;
    if analysis == StaticAnalysis::Linear {
        responses.iter().try_for_each(Response::check_linear)?;
    }
    let n_q = model.n_dofs();
    let states = q.len() / n_q;
    if states == 0 || states * n_q != q.len() {
        return Err(SettingsError::new(
            "q",
            format!("needs rows of {n_q} coordinates, got {} values", q.len()),
        )
        .into());
    }
    if lam.len() != states * model.n_constraints() {
        return Err(SettingsError::new(
            "lam",
            format!(
                "needs {states} rows of {} multipliers, got {} values",
                model.n_constraints(),
                lam.len()
            ),
        )
        .into());
    }
    if qdot.is_some_and(|v| v.len() != q.len()) {
        return Err(SettingsError::new("qdot", format!("needs {} values, as q", q.len())).into());
    }
    if qdot.is_none() && responses.iter().any(Response::reads_velocities) {
        let msg = "a response reads the velocities: give them";
        return Err(SettingsError::new("qdot", msg).into());
    }
    if times.len() != states {
        return Err(SettingsError::new(
            "times",
            format!("has {} entries for {states} states", times.len()),
        )
        .into());
    }
    let grid = TimeGrid::from_steps(times.windows(2).map(|w| w[1] - w[0]).collect());
    let densities = model.densities(x)?;
    let mut load = vec![0.0; n_q];
    if model.analysis == Analysis::Static {
        Assembler::new(model, densities.clone(), mass)?.applied_loads(load_time, 1.0, &mut load);
    }
    let linear = (analysis == StaticAnalysis::Linear).then(|| Linearized::new(model));
    let ctx = Context {
        model,
        densities: &densities,
        static_load: &load,
        mass_kind: mass,
        linear: linear.as_ref(),
    };
    let mut objectives = Objectives::new(model, responses, &[], &grid)?;
    let mut values = vec![0.0; responses.len()];
    let n_c = model.n_constraints();
    for (n, q) in q.chunks(n_q).enumerate() {
        let at = Sample {
            q,
            v: qdot.map_or(&[][..], |v| &v[n * n_q..(n + 1) * n_q]),
            lam: &lam[n * n_c..(n + 1) * n_c],
            t: times[n],
        };
        objectives.observe(&ctx, at, &mut values, &mut []);
        objectives.add_values(&ctx, n, at, &mut values);
    }
    objectives.finish(&mut values, &mut []);
    Ok(Evaluated {
        values,
        peaks: objectives.peaks(),
    })
}

/// Responses that are explicit in `x` (volumes) need no simulation, and depend on no
/// parameter.
fn explicit(
    model: &Model,
    densities: &Densities,
    responses: &[Response],
    parameters: &[Parameter],
) -> Result<Sensitivities, Error> {
    let ctx = Context::dynamic(model, densities, MassKind::Consistent);
    let grid = TimeGrid::single();
    let objectives = Objectives::new(model, responses, parameters, &grid)?;
    let (n_q, n_x) = (model.n_dofs(), model.n_variables() + parameters.len());
    let (q, lam) = (vec![0.0; n_q], vec![0.0; model.n_constraints()]);
    let at = Sample {
        q: &q,
        v: &[],
        lam: &lam,
        t: 0.0,
    };
    let mut values = vec![0.0; responses.len()];
    objectives.add_values(&ctx, 0, at, &mut values);
    let mut gradients = vec![0.0; responses.len() * n_x];
    let (mut g_q, mut g_lam) = (vec![0.0; n_q], vec![0.0; model.n_constraints()]);
    for (k, row) in gradients.chunks_mut(n_x.max(1)).enumerate() {
        objectives.add_partials(&ctx, k, 0, at, &mut g_q, &mut g_lam, row, &mut []);
    }
    let peaks = objectives.peaks();
    let timings = Timings::default();
    Ok(Sensitivities::new(
        model,
        values,
        &gradients,
        Method::Direct,
        timings,
        peaks,
    ))
}

fn resolve(method: Method, responses: &[Response], model: &Model) -> Method {
    match method {
        Method::Auto
            if responses.iter().filter(|r| r.depends_on_states()).count() < model.n_variables() =>
        {
            Method::Adjoint
        }
        Method::Auto => Method::Direct,
        m => m,
    }
}
