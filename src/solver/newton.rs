//! Newton's method: its iterations ([`iterate`]) over a [`System`] — the planar engine's
//! (a [`Newton`] at a [`Point`]: the generalized-α step and the static solver), a spatial
//! step's and a spatial equilibrium's — and the planar system with the small interface the
//! sensitivity analyses use: factorize the iteration matrix at a point, solve a block of
//! right-hand sides, read the assembler.
//!
//! One [`Newton`] owns the assembler of a design, the sparse `LDLᵀ` analysed once for its
//! pattern, the matrix values and the work vectors: nothing is allocated per iteration.
//! Constraint rows and multipliers are scaled by `s = c·mean(M) + mean(K)` (`c` the mass
//! coefficient of the matrix, `β'` in dynamics, so that `s` follows the step size), which
//! keeps the augmented matrix balanced; `λ = s μ`.
//! Convergence is relative: `‖r‖∞ ≤ tol · F_ref` with `F_ref` the largest magnitude among
//! the inertia, internal, external and joint forces, and `‖Φ‖∞ ≤ tol · L_ref` with `L_ref`
//! the model's size; an increment at round-off level ([`ROUND_OFF_ULPS`]) also ends the
//! iteration, since the residual of stiff elements cannot drop below their round-off.

use faer::dyn_stack::MemBuffer;

use crate::error::SolveError;
use crate::joint::planar::Turns;
use crate::mechanism::element::MassKind;
use crate::mechanism::model::{Densities, Model};
use crate::solver::assembly::{Assembler, DampingBlock, Jacobian};
use crate::solver::linsolve::{FactorError, Ldlt};

/// Largest ratio of successive residuals at which a kept factorization is used again
/// ([`Newton::keep_matrix`]).
pub const KEPT_CONTRACTION: f64 = 0.1;

/// A correction at most this many ulps of the model's size plus its largest coordinate
/// (2¹², 9.1e-13 of it) is round-off ([`at_round_off`]) and ends Newton's iterations. Cells
/// whose strains (~1e-4) are differences of positions a metre from the origin over a few
/// millimetres hold their forces to about 1e-10 of themselves: there the residual stalls
/// at 1e-10 to 4e-9 of the forces, above the default tolerance, and the corrections
/// computed from it scatter at 75–215 ulps (measured on a continuum arm of 80 × 24 cells per
/// link at h/4). At 64 ulps such runs ended in a Newton failure.
pub const ROUND_OFF_ULPS: f64 = 4096.0;

/// Newton statistics of a solve.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct NewtonReport {
    /// Iterations (solves of the iteration matrix).
    pub iterations: usize,
    /// Final relative residual.
    pub residual: f64,
}

/// Residual norms of a Newton iterate.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Residual {
    /// `‖r‖∞ / F_ref`, with `F_ref` the largest of the force terms.
    pub force: f64,
    /// `‖Φ‖∞ / L_ref`.
    pub constraint: f64,
}

impl Residual {
    /// The larger of the two, NaN if either is.
    pub fn value(&self) -> f64 {
        nan_max(self.force, self.constraint)
    }
}

/// A nonlinear system under Newton's method ([`iterate`]).
pub(crate) trait System {
    /// The residual at the iterate, kept as the next solve's right-hand side; the
    /// iteration matrix with it where `with_matrix` and the system builds both in one pass.
    ///
    /// # Errors
    /// [`SolveError`] where a force cannot be evaluated at the iterate.
    fn residual(&mut self, with_matrix: bool) -> Result<Residual, SolveError>;

    /// Newton's correction from the last residual: on new factors of the matrix at this
    /// iterate where `refactor`, on the held ones otherwise.
    ///
    /// # Errors
    /// [`SolveError::Singular`] for a singular iteration matrix.
    fn solve(&mut self, refactor: bool) -> Result<(), SolveError>;

    /// Moves the iterate by the correction; whether the correction was at round-off, where
    /// Newton cannot improve further.
    fn update(&mut self) -> bool;

    /// Whether the last solve's correction, not yet taken, is at round-off
    /// ([`at_round_off`]).
    fn correction_at_round_off(&self) -> bool;

    /// Where the system is solved (a time or a load factor), for a failure's message.
    fn at(&self) -> String;
}

/// Where the last solve ended: the iteration whose residual was its last, within the
/// tolerance or at the floor its evaluation reaches (its correction at round-off). Steps
/// of one motion end alike, so the next solve evaluates its residual at that iteration
/// without the matrix and tries the held factors first ([`iterate`]). A dynamic state
/// carries the one of the step that reached it ([`crate::solver::alpha::State`]), so that a
/// run replayed from a stored state, or a step taken again, iterates as it did; a static
/// solve starts without one.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct Forecast(Option<usize>);

/// Newton's method on `system` from its iterate, in place: converged where both relative
/// residuals are at most `tol` (or a correction is at round-off), failed after `max_iter`
/// corrections or at a residual that is not finite. With `keep` (modified Newton) an
/// iteration's factors serve the next ones while the residual falls at least tenfold per
/// iteration ([`KEPT_CONTRACTION`]). Where it falls slower, the held factors' correction is
/// tried first: at round-off it ends the solve (the residual is at the floor that its
/// evaluation reaches, which no factors lower), otherwise new factors are made at the
/// iterate. The same is done at the iteration where the `forecast` says the last solve
/// ended (and is written for the next): a residual there within the tolerance needs no
/// matrix, and one at its floor no new factors, where full Newton made both.
///
/// # Errors
/// [`SolveError::NewtonFailed`] with where, the iterations and the residual; as the
/// system's phases.
pub(crate) fn iterate<S: System>(
    system: &mut S,
    tol: f64,
    max_iter: usize,
    keep: bool,
    forecast: &mut Forecast,
) -> Result<NewtonReport, SolveError> {
    let (mut iterations, mut fresh, mut previous) = (0, true, f64::INFINITY);
    let last = forecast.0.take();
    let report = |iterations, residual| NewtonReport {
        iterations,
        residual,
    };
    loop {
        let foreseen = fresh && iterations > 0 && last == Some(iterations);
        let r = system.residual(fresh && !foreseen)?;
        let residual = r.value();
        if r.force <= tol && r.constraint <= tol {
            forecast.0 = Some(iterations);
            return Ok(report(iterations, residual));
        }
        if iterations == max_iter || !residual.is_finite() {
            return Err(SolveError::NewtonFailed {
                at: system.at(),
                iterations,
                residual,
                tolerance: tol,
            });
        }
        let slow = foreseen || (!fresh && residual > KEPT_CONTRACTION * previous);
        previous = residual;
        if slow {
            system.solve(false)?;
            if system.correction_at_round_off() {
                system.update();
                forecast.0 = Some(iterations);
                return Ok(report(iterations + 1, residual));
            }
            // The held factors contract too slowly: new ones at this iterate, and the
            // residual again as their right-hand side.
            system.residual(true)?;
            fresh = true;
        }
        system.solve(fresh)?;
        fresh = !keep;
        iterations += 1;
        if system.update() {
            forecast.0 = Some(iterations - 1);
            return Ok(report(iterations, residual));
        }
    }
}

/// Newton's method on one nonlinear system, shared by the dynamic step, the initial
/// accelerations and the static solver: a residual, an iteration matrix and its `LDLᵀ`
/// analysed once.
pub struct Newton<'m> {
    /// Forces and matrices of the design.
    asm: Assembler<'m>,
    /// `LDLᵀ` of the (augmented) iteration matrix.
    ldlt: Ldlt,
    /// Values of the last assembled iteration matrix.
    matrix: Vec<f64>,
    /// The constraint Jacobian in `matrix`, which also augments its right-hand sides.
    jacobian: Jacobian,
    /// The joints' node rotations at the current iterate.
    turns: Turns,
    /// Right-hand side / solution `E[−r; −sΦ]` → `[Δq; Δμ]`.
    rhs: Vec<f64>,
    /// Constraint scaling `s` of the current matrix (`λ = s μ`).
    scale: f64,
    /// `mean(M)` and `mean(K)` at the reference state, the parts of `s`.
    mean_mass: f64,
    mean_stiffness: f64,
    /// Time (or load factor) of the current factorization, for error reports.
    factored_at: f64,
    /// Whether iterations may solve with the step's first factorization
    /// ([`Newton::keep_matrix`]).
    keep: bool,
    /// Relative tolerance.
    tol: f64,
    /// Iteration limit.
    max_iter: usize,
    /// Length scale of the model (m).
    length: f64,
    inertia: Vec<f64>,
    internal: Vec<f64>,
    external: Vec<f64>,
    joint: Vec<f64>,
    phi: Vec<f64>,
    /// The blocks of the damping whose `C` follows the state ([`DampingBlock`]) at the
    /// last factorization with velocities (empty without such damping).
    damping: Vec<DampingBlock>,
    /// Whether they hold the current factorization's.
    skewed: bool,
}

/// Most iterations of an exact solve with a non-symmetric damping part
/// ([`Newton::solve_exact`]).
pub const MAX_REFINEMENTS: usize = 60;

impl<'m> Newton<'m> {
    /// Sets up the pattern, the symbolic `LDLᵀ` and the work vectors of `model`'s design.
    ///
    /// # Errors
    /// [`SolveError::Setup`] if the pattern or the symbolic analysis cannot be made.
    pub fn new(
        model: &'m Model,
        densities: Densities,
        mass: MassKind,
        tol: f64,
        max_iter: usize,
    ) -> Result<Self, SolveError> {
        let asm = Assembler::new(model, densities, mass)?;
        let (n, n_q, n_c) = (
            asm.pattern.sparsity.n,
            model.n_dofs(),
            model.n_constraints(),
        );
        let ldlt = asm.symbolic_ldlt()?;
        let matrix = vec![0.0; asm.pattern.nnz()];
        let reference = vec![0.0; n_q];
        let jacobian = Jacobian::at(model, &reference);
        let mean_mass = asm.mean_mass_diagonal();
        // A mechanism of rigid bodies alone has no stiffness to scale by.
        let mean_stiffness = match asm.mean_stiffness_diagonal(&reference) {
            k if k > 0.0 => k,
            _ => mean_mass,
        };
        Ok(Self {
            asm,
            ldlt,
            matrix,
            jacobian,
            turns: Turns::new(&model.rows, model.nodes.len()),
            rhs: vec![0.0; n],
            scale: 1.0,
            mean_mass,
            mean_stiffness,
            factored_at: 0.0,
            keep: false,
            tol,
            max_iter,
            length: model.size(),
            inertia: vec![0.0; n_q],
            internal: vec![0.0; n_q],
            external: vec![0.0; n_q],
            joint: vec![0.0; n_q],
            phi: vec![0.0; n_c],
            damping: Vec::new(),
            skewed: false,
        })
    }

    /// The assembler of the design: forces, matrices, the model and its densities.
    pub fn assembler(&self) -> &Assembler<'m> {
        &self.asm
    }

    /// Constraint scaling `s = c·mean(M) + mean(K)` of a matrix with mass coefficient `c`
    /// (without `mean(K)` for a matrix without stiffness).
    fn scaling(&self, mass_coefficient: f64, stiffness: bool) -> f64 {
        mass_coefficient * self.mean_mass + if stiffness { self.mean_stiffness } else { 0.0 }
    }

    /// The solver's error, reported at the time of the current factorization and, for a
    /// zero pivot, at the node or joint of its unknown.
    fn singular(&self) -> impl Fn(FactorError) -> SolveError + 'm {
        let (time, model) = (self.factored_at, self.asm.model);
        move |e| SolveError::Singular {
            time,
            detail: match e {
                FactorError::ZeroPivot { unknown } => {
                    format!("zero pivot at {}", model.unknown_name(unknown))
                }
                FactorError::Singular(detail) | FactorError::Analysis(detail) => detail,
            },
        }
    }

    /// Lets a solve iterate with its first factorization as long as it contracts the
    /// residual at least `1/`[`KEPT_CONTRACTION`]-fold per iteration (modified Newton, as
    /// implicit DAE solvers such as IDA do): each such iteration costs a residual and a
    /// solve instead of a tangent and a factorization. Slower contraction refactorizes at
    /// the current iterate. The converged states are the same to the tolerance. (Keeping
    /// a factorization from one step to the next was tried: on the robot arm a step then
    /// converged to a node turned by 8.5 rad.)
    pub fn keep_matrix(&mut self, keep: bool) {
        self.keep = keep;
    }

    /// Assembles `rhs = −E[r; sΦ]` and, `with_matrix`, the augmented iteration matrix
    /// `β'M + γ'C + K_t` at `(q, q̇, q̈, λ)` and `point`; `rates = None` drops inertia and
    /// damping (statics), where `point.load` scales external forces and prescribed motions.
    pub(crate) fn assemble(
        &mut self,
        q: &[f64],
        rates: Option<(&[f64], &[f64])>,
        lambda: &[f64],
        point: &Point,
        with_matrix: bool,
    ) -> Residual {
        let n_q = q.len();
        let asm = &self.asm;
        let (t, load) = (point.t, point.load);
        match rates {
            Some((velocity, acc)) => {
                self.joint
                    .iter_mut()
                    .zip(acc.iter().zip(&asm.gravity))
                    .for_each(|(w, (a, g))| *w = a - g);
                asm.mass_times(&self.joint, &mut self.inertia);
                // The dampers' C q̇ joins the inertia term M(q̈ − ĝ).
                asm.add_damping_times(velocity, &mut self.inertia);
            }
            None => self.inertia.fill(0.0),
        }
        self.joint.fill(0.0);
        let jacobian = with_matrix.then_some(&mut self.jacobian);
        self.turns.update(q);
        let turns = &self.turns;
        asm.constraint_residual(
            q,
            turns,
            lambda,
            t,
            load,
            &mut self.phi,
            &mut self.joint,
            jacobian,
        );
        if with_matrix {
            asm.start_iteration_matrix(
                point.mass_coefficient,
                self.scale,
                &self.jacobian,
                &mut self.matrix,
            );
            asm.add_damping(point.gamma_prime, &mut self.matrix);
            asm.internal_forces(q, &mut self.internal, Some(&mut self.matrix));
            asm.add_constraint_hessian(q, turns, lambda, &mut self.matrix);
        } else {
            asm.internal_forces(q, &mut self.internal, None);
        }
        if let Some((velocity, _)) = rates {
            // The Kelvin–Voigt damping of the beams joins the inertia term too; only its
            // symmetric derivatives enter the matrix (Newton then converges linearly).
            let matrix = with_matrix.then_some((point.gamma_prime, &mut self.matrix[..]));
            asm.add_structural_damping(q, velocity, &mut self.inertia, matrix, None);
        }
        match rates {
            // Dynamics: gravity is in the inertia term M(q̈ − ĝ).
            Some(_) => asm.external_forces(t, load, &mut self.external),
            None => asm.applied_loads(t, load, &mut self.external),
        }
        let mut f_ref = f64::MIN_POSITIVE;
        let mut r_max: f64 = 0.0;
        for i in 0..n_q {
            let r = self.inertia[i] + self.internal[i] - self.external[i] + self.joint[i];
            self.rhs[i] = -r;
            r_max = nan_max(r_max, r.abs());
            f_ref = f_ref
                .max(self.inertia[i].abs())
                .max(self.internal[i].abs())
                .max(self.external[i].abs())
                .max(self.joint[i].abs());
        }
        let mut phi_max: f64 = 0.0;
        for (k, &p) in self.phi.iter().enumerate() {
            self.rhs[n_q + k] = -self.scale * p;
            phi_max = nan_max(phi_max, p.abs());
        }
        asm.augment_rhs(&self.jacobian, &mut self.rhs);
        Residual {
            force: r_max / f_ref,
            constraint: phi_max / self.length,
        }
    }

    /// Factorizes the assembled matrix (unless `fresh` is false: the held factors) and
    /// solves for `[Δq; Δμ]` in `rhs`.
    fn solve_increment(&mut self, t: f64, fresh: bool) -> Result<(), SolveError> {
        if fresh {
            self.factored_at = t;
            self.ldlt.factorize(&self.matrix).map_err(self.singular())?;
        }
        self.ldlt
            .solve_in_place(&mut self.rhs)
            .map_err(self.singular())
    }

    /// Whether the increment `Δq` in `rhs` is at round-off at `q` ([`at_round_off`]).
    fn stagnated(&self, q: &[f64]) -> bool {
        at_round_off(&self.rhs[..q.len()], q, self.length)
    }
}

/// The planar system at a point: `(q, λ)`, and `(q̇, q̈)` for dynamics, its iterate.
struct AtPoint<'a, 'm> {
    newton: &'a mut Newton<'m>,
    point: Point,
    q: &'a mut [f64],
    lambda: &'a mut [f64],
    rates: Option<(&'a mut [f64], &'a mut [f64])>,
    /// Whether the matrix was assembled with the last residual.
    matrix_current: bool,
}

impl AtPoint<'_, '_> {
    fn assemble(&mut self, with_matrix: bool) -> Residual {
        let state = self.rates.as_ref().map(|(v, acc)| (&v[..], &acc[..]));
        self.matrix_current = with_matrix;
        (self.newton).assemble(self.q, state, self.lambda, &self.point, with_matrix)
    }
}

impl System for AtPoint<'_, '_> {
    fn residual(&mut self, with_matrix: bool) -> Result<Residual, SolveError> {
        Ok(self.assemble(with_matrix))
    }

    fn solve(&mut self, refactor: bool) -> Result<(), SolveError> {
        if refactor && !self.matrix_current {
            self.assemble(true);
        }
        self.newton.solve_increment(self.point.t, refactor)
    }

    fn update(&mut self) -> bool {
        let newton = &*self.newton;
        let (dq, dmu) = newton.rhs.split_at(self.q.len());
        self.q.iter_mut().zip(dq).for_each(|(x, d)| *x += d);
        (self.lambda.iter_mut())
            .zip(dmu)
            .for_each(|(l, d)| *l += newton.scale * d);
        if let Some((v, acc)) = self.rates.as_mut() {
            for (i, d) in dq.iter().enumerate() {
                v[i] += self.point.gamma_prime * d;
                acc[i] += self.point.mass_coefficient * d;
            }
        }
        newton.stagnated(self.q)
    }

    fn correction_at_round_off(&self) -> bool {
        self.newton.stagnated(self.q)
    }

    fn at(&self) -> String {
        self.point.at(self.rates.is_some())
    }
}

/// Whether a correction is at round-off level: its largest entry within
/// [`ROUND_OFF_ULPS`] of the model's size `length` plus the largest entry of `state`
/// (positions, or a step's increment), where Newton cannot improve the iterate further.
pub(crate) fn at_round_off(correction: &[f64], state: &[f64], length: f64) -> bool {
    let largest = |v: &[f64]| v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    largest(correction) <= ROUND_OFF_ULPS * f64::EPSILON * (length + largest(state))
}

/// The larger of `a` and `b`, NaN if either is: a residual with a NaN entry is not
/// converged (`f64::max` would drop the NaN).
pub(crate) fn nan_max(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() {
        f64::NAN
    } else {
        a.max(b)
    }
}

/// Where a Newton solve happens: time, load factor and how accelerations and velocities
/// follow the positions (`q̈ += β'Δq`, `q̇ += γ'Δq`; `β' = 0` for statics).
#[derive(Debug, Clone, Copy)]
pub struct Point {
    /// Time (s).
    pub t: f64,
    /// Factor on external loads and prescribed motions (1 in dynamics).
    pub load: f64,
    /// `β'`, the coefficient of `M` in the iteration matrix.
    pub mass_coefficient: f64,
    /// `γ'`.
    pub gamma_prime: f64,
}

impl Point {
    /// Where the solve is, in words: `t = … s` in dynamics, `load factor …` in statics.
    fn at(&self, dynamic: bool) -> String {
        if dynamic {
            format!("t = {:.6} s", self.t)
        } else {
            format!("load factor {:.6}", self.load)
        }
    }
}

impl<'m> Newton<'m> {
    /// Newton iterations at `point` from the given iterate, updated in place: `(q, λ)`, and
    /// `(q̇, q̈)` for dynamics; from the `forecast` of the solve before, written for the next
    /// ([`iterate`]).
    ///
    /// # Errors
    /// [`SolveError::NewtonFailed`] after `max_iter` iterations or on a non-finite residual;
    /// [`SolveError::Singular`] for a singular iteration matrix.
    pub(crate) fn solve(
        &mut self,
        point: Point,
        q: &mut [f64],
        lambda: &mut [f64],
        rates: Option<(&mut [f64], &mut [f64])>,
        forecast: &mut Forecast,
    ) -> Result<NewtonReport, SolveError> {
        self.scale = self.scaling(point.mass_coefficient, true);
        let (tol, max_iter, keep) = (self.tol, self.max_iter, self.keep);
        let mut system = AtPoint {
            newton: self,
            point,
            q,
            lambda,
            rates,
            matrix_current: false,
        };
        iterate(&mut system, tol, max_iter, keep, forecast)
    }

    /// One Newton step of a static solve at `point` from `(q, λ)`, updated in place, on a
    /// fresh factorization: from the unloaded reference, the linear analysis
    /// ([`crate::solve_linear`]).
    ///
    /// # Errors
    /// [`SolveError::Singular`] for a singular iteration matrix or a non-finite step.
    pub(crate) fn static_step(
        &mut self,
        point: Point,
        q: &mut [f64],
        lambda: &mut [f64],
    ) -> Result<(), SolveError> {
        self.scale = self.scaling(point.mass_coefficient, true);
        self.assemble(q, None, lambda, &point, true);
        self.solve_increment(point.t, true)?;
        if self.rhs.iter().any(|v| !v.is_finite()) {
            let detail = "the step is not finite".to_string();
            return Err(SolveError::Singular {
                time: point.t,
                detail,
            });
        }
        let (dq, dmu) = self.rhs.split_at(q.len());
        q.iter_mut().zip(dq).for_each(|(x, d)| *x += d);
        lambda
            .iter_mut()
            .zip(dmu)
            .for_each(|(l, d)| *l += self.scale * d);
        Ok(())
    }

    /// Assembles and factorizes the augmented iteration matrix at state `q`, time `t`, for
    /// the linear solves of the sensitivity analysis, with the scaling `s` of a Newton solve
    /// of the same mass coefficient `c`: `c M + d C + K_t(q) + Σ λₖ ∂²Φₖ/∂q²` and `Φ_q(q)`
    /// with `tangent = Some(λ)` (`d = γ'` in a dynamic step), `c M` and `Φ_q(q)` alone with
    /// `None` (the initial accelerations). With the `velocity` of a dynamic state the
    /// beams' stiffness-proportional damping enters too, its non-symmetric part kept for
    /// [`Newton::solve_exact`].
    ///
    /// # Errors
    /// [`SolveError::Singular`] for a singular matrix.
    pub fn factorize(
        &mut self,
        q: &[f64],
        tangent: Option<&[f64]>,
        velocity: Option<&[f64]>,
        mass_coefficient: f64,
        damping_coefficient: f64,
        t: f64,
    ) -> Result<(), SolveError> {
        self.scale = self.scaling(mass_coefficient, tangent.is_some());
        self.factored_at = t;
        self.turns.update(q);
        self.jacobian.update(self.asm.model, q, &self.turns);
        self.asm.start_iteration_matrix(
            mass_coefficient,
            self.scale,
            &self.jacobian,
            &mut self.matrix,
        );
        if let Some(lambda) = tangent {
            self.asm
                .internal_forces(q, &mut self.internal, Some(&mut self.matrix));
            self.asm
                .add_constraint_hessian(q, &self.turns, lambda, &mut self.matrix);
            self.asm.add_damping(damping_coefficient, &mut self.matrix);
        }
        self.skewed = false;
        if let (Some(_), Some(v)) = (tangent, velocity) {
            if self.asm.has_structural_damping() {
                // The force goes to scratch: only the matrix and the blocks are wanted.
                let matrix = Some((damping_coefficient, &mut self.matrix[..]));
                let blocks = Some(&mut self.damping);
                self.asm
                    .add_structural_damping(q, v, &mut self.internal, matrix, blocks);
                self.skewed = true;
            }
        }
        self.ldlt.factorize(&self.matrix).map_err(self.singular())
    }

    /// `out += C v` with the damping matrix of the last factorization: the constant part
    /// and, with velocities, the state's `∂f_d/∂q̇` of the damping that follows the state.
    pub fn add_damping_times(&self, v: &[f64], out: &mut [f64]) {
        self.asm.add_damping_times(v, out);
        if self.skewed {
            for block in &self.damping {
                block.add_times(false, false, 1.0, v, out);
            }
        }
    }

    /// Solves the exact sensitivity systems `(S + N) z = b` (or `(S + N)ᵀ z = b`,
    /// `transposed`) for the `cols` right-hand sides in `rhs`, where `S` is the factorized
    /// (symmetric) matrix and `N` the damping's non-symmetric part at its state: by the
    /// iteration `S z ← b − N z` from `z = S⁻¹ b`, until every column's change is at
    /// round-off. With no such part it is [`Newton::solve_block`]. `work` is resized to
    /// hold `b`, a residual and each column's last change.
    ///
    /// # Errors
    /// [`SolveError::Singular`] for non-finite values, or an iteration that does not
    /// converge within [`MAX_REFINEMENTS`] (damping too strong for the step).
    pub fn solve_exact(
        &self,
        rhs: &mut [f64],
        cols: usize,
        scratch: &mut MemBuffer,
        transposed: bool,
        work: &mut Vec<f64>,
    ) -> Result<(), SolveError> {
        if !self.skewed {
            return self.solve_block(rhs, cols, scratch);
        }
        let (len, n) = (rhs.len(), self.rhs.len());
        work.resize(2 * len + cols, 0.0);
        let (b, rest) = work.split_at_mut(len);
        let (r, previous) = rest.split_at_mut(len);
        b.copy_from_slice(rhs);
        previous.fill(f64::INFINITY);
        self.solve_block(rhs, cols, scratch)?;
        for _ in 0..MAX_REFINEMENTS {
            r.copy_from_slice(b);
            for (column, z) in r.chunks_mut(n).zip(rhs.chunks(n)) {
                for block in &self.damping {
                    block.add_times(true, transposed, -1.0, z, column);
                }
            }
            self.solve_block(r, cols, scratch)?;
            // Each column settles when its change is at round-off: below 1e-14 of it, or
            // below 1e-9 of it and no longer contracting.
            let mut settled = true;
            for ((new, old), last) in r.chunks(n).zip(rhs.chunks(n)).zip(previous.iter_mut()) {
                let size = new.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
                let change = new
                    .iter()
                    .zip(old)
                    .fold(0.0_f64, |m, (a, z)| m.max((a - z).abs()));
                let stalled = change <= 1e-9 * size && change > 0.5 * *last;
                settled &= change <= 1e-14 * size || stalled;
                *last = change;
            }
            rhs.copy_from_slice(r);
            if settled {
                return Ok(());
            }
        }
        Err(SolveError::Unsettled {
            time: self.factored_at,
            damping: self.asm.structural_damping_sources(),
        })
    }

    /// Applies the augmentation `E` of the factorized matrix to right-hand sides `[b; c]`
    /// with nonzero constraint rows (`b += Φ_qᵀ c`), before [`Newton::solve_block`].
    pub fn augment(&self, rhs: &mut [f64]) {
        let n = self.rhs.len();
        for column in rhs.chunks_mut(n) {
            self.asm.augment_rhs(&self.jacobian, column);
        }
    }

    /// Applies `Eᵀ` to solutions of [`Newton::solve_block`] (`μ += Φ_q ν`): the transposed
    /// system's multiplier part, for adjoints that read it (the solve itself is symmetric).
    pub fn unaugment(&self, solution: &mut [f64]) {
        let n = self.rhs.len();
        let model = self.asm.model;
        for column in solution.chunks_mut(n) {
            let (dofs, multipliers) = column.split_at_mut(n - model.n_constraints());
            for (k, m) in multipliers.iter_mut().enumerate() {
                let g = self.jacobian.row(model, k);
                for (&d, gi) in model.row_dofs.of_row(k).iter().zip(g) {
                    *m += gi * dofs[d];
                }
            }
        }
    }

    /// The scaling `s` of the constraint rows set by the last [`Newton::factorize`] (or
    /// solve): a solution's multiplier rows are `μ = λ/s`. Read it right after
    /// `factorize`, as the sensitivity analyses do.
    pub fn multiplier_scale(&self) -> f64 {
        self.scale
    }

    /// Work space for solving `cols` right-hand sides at once with [`Newton::solve_block`].
    pub fn scratch(&self, cols: usize) -> MemBuffer {
        self.ldlt.scratch_for(cols)
    }

    /// Solves the factorized system for the `cols` right-hand sides of the column-major
    /// block `rhs` (`[Δq; Δμ]` each), in place.
    ///
    /// # Errors
    /// [`SolveError::Singular`] if the solve produces non-finite values.
    pub fn solve_block(
        &self,
        rhs: &mut [f64],
        cols: usize,
        scratch: &mut MemBuffer,
    ) -> Result<(), SolveError> {
        self.ldlt
            .solve_block(rhs, cols, scratch)
            .map_err(self.singular())
    }

    /// The jump `(Δq̈, Δλ)` of accelerations and multipliers at `q` (time `t`) when the
    /// drives' prescribed accelerations jump by `dg` at a kink of a motion law
    /// ([`crate::solver::kink`]): `[M, Φ_qᵀ; Φ_q, 0] [Δq̈; Δλ] = [0; Δg̈]`. Leaves that
    /// system factorized.
    ///
    /// # Errors
    /// [`SolveError::Singular`] if `M` is singular on the constraint manifold.
    pub fn acceleration_jump(
        &mut self,
        q: &[f64],
        t: f64,
        dg: &[f64],
        dacc: &mut [f64],
        dlam: &mut [f64],
    ) -> Result<(), SolveError> {
        let n_q = q.len();
        self.factorize(q, None, None, 1.0, 0.0, t)?;
        let scale = self.scale;
        self.rhs[..n_q].fill(0.0);
        for (r, g) in self.rhs[n_q..].iter_mut().zip(dg) {
            *r = scale * g;
        }
        self.asm.augment_rhs(&self.jacobian, &mut self.rhs);
        self.ldlt
            .solve_in_place(&mut self.rhs)
            .map_err(self.singular())?;
        dacc.copy_from_slice(&self.rhs[..n_q]);
        for (l, m) in dlam.iter_mut().zip(&self.rhs[n_q..]) {
            *l = scale * m;
        }
        Ok(())
    }

    /// Consistent accelerations and multipliers at `(q, q̇, t = 0)`, from
    /// `[M, Φ_qᵀ; Φ_q, 0] [q̈; λ] = [M ĝ + f_ext − f_int(q) − C q̇; g̈(0) − (Hₖ q̇)ᵀ q̇]` (the
    /// last the rows' curvature along the motion, zero at rest).
    ///
    /// # Errors
    /// [`SolveError::Singular`] if `M` is singular on the constraint manifold.
    pub fn initial_accelerations(
        &mut self,
        q: &[f64],
        qdot: &[f64],
    ) -> Result<(Vec<f64>, Vec<f64>), SolveError> {
        let (n_q, n_c) = (q.len(), self.phi.len());
        // At q̈ = 0, λ = 0 the DOF rows of −E r are M ĝ + f_ext − f_int(q) − C q̇;
        // Φ(q, 0) = 0 adds nothing to them.
        let start = Point {
            t: 0.0,
            load: 1.0,
            mass_coefficient: 1.0,
            gamma_prime: 0.0,
        };
        self.assemble(
            q,
            Some((qdot, &vec![0.0; n_q])),
            &vec![0.0; n_c],
            &start,
            false,
        );
        self.factorize(q, None, None, 1.0, 0.0, 0.0)?;
        let mut g = vec![0.0; n_c];
        self.asm.constraint_accelerations(0.0, &mut g);
        let curvature = self.asm.constraint_curvature(q, qdot);
        let scale = self.scale;
        let rows = &self.asm.model.row_dofs;
        for (k, (r, gk)) in self.rhs[n_q..].iter_mut().zip(&g).enumerate() {
            let along: f64 = rows
                .of_row(k)
                .iter()
                .zip(&curvature[rows.range(k)])
                .map(|(&d, h)| h * qdot[d])
                .sum();
            *r = scale * (gk - along);
        }
        self.asm.augment_rhs(&self.jacobian, &mut self.rhs);
        self.ldlt
            .solve_in_place(&mut self.rhs)
            .map_err(self.singular())?;
        Ok((
            self.rhs[..n_q].to_vec(),
            self.rhs[n_q..].iter().map(|m| m * scale).collect(),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A system whose iterates give scripted residuals: `round_off[k]` says whether the
    /// correction from iterate `k` is at round-off. It counts matrices and factorizations.
    struct Scripted {
        residuals: Vec<f64>,
        round_off: Vec<bool>,
        k: usize,
        matrices: usize,
        factorizations: usize,
    }

    impl Scripted {
        fn new(residuals: &[f64], round_off: &[bool]) -> Self {
            let (residuals, round_off) = (residuals.to_vec(), round_off.to_vec());
            Self {
                residuals,
                round_off,
                k: 0,
                matrices: 0,
                factorizations: 0,
            }
        }
    }

    impl System for Scripted {
        fn residual(&mut self, with_matrix: bool) -> Result<Residual, SolveError> {
            self.matrices += usize::from(with_matrix);
            let force = self.residuals[self.k];
            Ok(Residual {
                force,
                constraint: 0.0,
            })
        }

        fn solve(&mut self, refactor: bool) -> Result<(), SolveError> {
            self.factorizations += usize::from(refactor);
            assert!(
                self.matrices >= self.factorizations,
                "factors without a matrix"
            );
            assert!(self.factorizations > 0, "held factors that do not exist");
            Ok(())
        }

        fn update(&mut self) -> bool {
            self.k += 1;
            self.round_off[self.k - 1]
        }

        fn correction_at_round_off(&self) -> bool {
            self.round_off[self.k]
        }

        fn at(&self) -> String {
            "the script".into()
        }
    }

    #[test]
    fn a_residual_at_its_floor_ends_modified_newton_without_new_factors() {
        // The residual stalls at 2e-11, above the tolerance: the held factors' correction
        // there is at round-off, and new factors would not lower it.
        let residuals = [1.0, 1e-4, 1e-8, 2e-11, 2.1e-11];
        let round_off = [false, false, false, false, true];
        let mut system = Scripted::new(&residuals, &round_off);
        let report = iterate(&mut system, 1e-12, 20, true, &mut Forecast::default()).unwrap();
        assert_eq!((report.iterations, report.residual), (5, 2.1e-11));
        assert_eq!(system.factorizations, 1);
    }

    #[test]
    fn a_slow_contraction_away_from_round_off_refactors_at_the_iterate() {
        let residuals = [1.0, 0.5, 1e-3, 1e-13];
        let mut system = Scripted::new(&residuals, &[false; 4]);
        let report = iterate(&mut system, 1e-12, 20, true, &mut Forecast::default()).unwrap();
        assert_eq!((report.iterations, system.factorizations), (3, 2));
        // Full Newton factors at every iterate.
        let mut system = Scripted::new(&residuals, &[false; 4]);
        iterate(&mut system, 1e-12, 20, false, &mut Forecast::default()).unwrap();
        assert_eq!(system.factorizations, 3);
    }

    /// Full Newton's steps, each solved from the `forecast` the one before left.
    fn steps(
        residuals: &[f64],
        round_off: &[bool],
        forecast: &mut Forecast,
    ) -> (usize, usize, usize) {
        let mut system = Scripted::new(residuals, round_off);
        let report = iterate(&mut system, 1e-12, 20, false, forecast).unwrap();
        (report.iterations, system.matrices, system.factorizations)
    }

    #[test]
    fn full_newton_ends_where_the_step_before_ended_without_new_factors() {
        // A residual at its floor at the third iterate, whose correction is round-off.
        let (residuals, round_off) = ([1.0, 1e-4, 1e-8], [false, false, true]);
        let mut forecast = Forecast::default();
        assert_eq!(steps(&residuals, &round_off, &mut forecast), (3, 3, 3));
        assert_eq!(forecast.0, Some(2));
        // Foreseen: its residual without the matrix, the held factors' correction.
        assert_eq!(steps(&residuals, &round_off, &mut forecast), (3, 2, 2));
        // A step ending within the tolerance needs no matrix at its last iterate.
        let converged = [1.0, 1e-4, 1e-13];
        assert_eq!(steps(&converged, &[false; 3], &mut forecast), (2, 2, 2));
        assert_eq!(forecast.0, Some(2));
        // Foreseen wrongly (the residual at iterate 2 is not at its floor): the matrix and
        // new factors there after all, the same iterations, matrices and factors as
        // without the forecast (a residual and a held solve more).
        let slower = [1.0, 1e-2, 1e-6, 1e-13];
        assert_eq!(steps(&slower, &[false; 4], &mut forecast), (3, 4, 3));
        assert_eq!(
            steps(&slower, &[false; 4], &mut Forecast::default()),
            (3, 4, 3)
        );
        // A failed solve leaves no forecast.
        let mut system = Scripted::new(&[1.0, 0.5, 0.4], &[false; 3]);
        assert!(iterate(&mut system, 1e-12, 2, false, &mut forecast).is_err());
        assert_eq!(forecast, Forecast::default());
        // Modified Newton reads none: its later iterates are held already.
        let mut forecast = Forecast(Some(1));
        let mut system = Scripted::new(&[1.0, 1e-4, 1e-13], &[false; 3]);
        iterate(&mut system, 1e-12, 20, true, &mut forecast).unwrap();
        assert_eq!((system.matrices, system.factorizations), (1, 1));
    }
}
