//! Generalized-α on the Lie group `(ℝ³ × SO(3))ⁿ` (Brüls, Cardona & Arnold, *Mech. Mach.
//! Theory* 48, 2012, Algorithm 1 there), index-3 constraints with Lagrange multipliers.
//!
//! The vector-space scheme of the paper (§2.3, [`crate::Integrator`]) with the update of
//! positions replaced by a motion on the group: with velocities `v` and accelerations `v̇` in
//! the algebra and the same parameters `α_m, α_f, β, γ` ([`AlphaParameters`]),
//!
//! ```text
//! Δₙ   = h vₙ + h²(½ − β) aₙ + h² β aₙ₊₁            (the step's increment)
//! qₙ₊₁ = qₙ ∘ exp(Δₙ)                               (node by node, [`Frame::retract`])
//! vₙ₊₁ = vₙ + h(1 − γ) aₙ + h γ aₙ₊₁
//! (1 − α_m) aₙ₊₁ + α_m aₙ = (1 − α_f) v̇ₙ₊₁ + α_f v̇ₙ
//! ```
//!
//! Newton solves `f_inertia(v, v̇) + Bᵀλ = 0`, `Φ(qₙ₊₁) = 0` for the correction `δ` of `Δₙ`:
//! `Δ += δ`, `v += γ' δ`, `v̇ += β' δ` (`β'`, `γ'` as in the vector-space scheme), with the
//! iteration matrix of `assembly.rs` factored by sparse `LU`. On `ℝ³` (and the
//! planar engine's additive angle) `T = I` and this is the vector-space step.
//!
//! The start is consistent: `M v̇₀ + Bᵀλ₀ = −f(q₀, v₀)`, `B v̇₀ = −b(q₀, v₀)`, and `a₀ = v̇₀`.

use crate::error::{Error, SettingsError, SolveError};
use crate::group::{Frame, NV};
use crate::settings::{DynamicSettings, NewtonMatrix};
use crate::solver::integrator::{rescale_pseudo_accelerations, step_ratio, AlphaParameters, State};
use crate::solver::linsolve::FactorError;
use crate::solver::lu::Lu;
use crate::solver::newton::NewtonReport;
use crate::spatial::assembly::{Assembler, Coefficients};
use crate::spatial::model::SpatialModel;
use crate::TimeGrid;

/// The largest rotation one step may give a node (rad): beyond it the step is too large for
/// the motion (the tangent operator is singular at 2π).
pub const MAX_STEP_ROTATION: f64 = std::f64::consts::PI;

/// The Lie-group generalized-α integrator of a spatial mechanism.
pub struct SpatialIntegrator<'m> {
    asm: Assembler<'m>,
    lu: Lu,
    /// Algorithmic parameters.
    pub params: AlphaParameters,
    tol: f64,
    max_iter: usize,
    /// `qₙ` of the step under way.
    start: Vec<f64>,
    /// The step's increment `Δ`.
    increment: Vec<f64>,
    /// Residual, then Newton's correction.
    rhs: Vec<f64>,
}

impl<'m> SpatialIntegrator<'m> {
    /// The integrator of `model` with `settings` (`t_end` and `h` are the caller's: any grid
    /// runs step by step).
    ///
    /// # Errors
    /// [`SettingsError`] for a modified Newton matrix (not built for spatial mechanisms);
    /// the model's initial rates that the joints forbid ([`SpatialModel::check_rates`]);
    /// [`SolveError::Setup`] if the pattern cannot be analysed.
    pub fn new(model: &'m SpatialModel, settings: &DynamicSettings) -> Result<Self, Error> {
        if settings.newton == NewtonMatrix::Modified {
            return Err(SettingsError::new(
                "newton",
                "the modified Newton matrix is not built for spatial mechanisms; use \"full\"",
            )
            .into());
        }
        model.check_rates()?;
        let asm = Assembler::new(model);
        let p = &asm.pattern;
        let lu = Lu::analyze(p.n, p.col_ptr.clone(), p.row_idx.clone())
            .map_err(|e| SolveError::Setup(format!("{e:?}")))?;
        let n = p.n;
        Ok(Self {
            asm,
            lu,
            params: AlphaParameters::chung_hulbert(settings.rho_inf),
            tol: settings.tol,
            max_iter: settings.max_iter,
            start: vec![0.0; model.n_q()],
            increment: vec![0.0; model.n_v()],
            rhs: vec![0.0; n],
        })
    }

    fn singular(time: f64) -> impl Fn(FactorError) -> SolveError {
        move |e| SolveError::Singular {
            time,
            detail: format!("{e:?}"),
        }
    }

    /// The model's initial configuration and rates with consistent accelerations and
    /// multipliers (module docs).
    ///
    /// # Errors
    /// [`SolveError::Singular`] if the mass matrix is singular on the constraint manifold.
    pub fn initial_state(&mut self) -> Result<State, SolveError> {
        let model = self.asm.model;
        let (q, v) = (model.initial_configuration(), model.initial_velocity());
        let scale = self.asm.mean_mass();
        self.asm.matrix(
            &q,
            &v,
            0.0,
            Coefficients {
                beta_prime: 1.0,
                gamma_prime: 0.0,
                scale,
                tangent: None,
            },
        )?;
        self.lu
            .factorize(&self.asm.values)
            .map_err(Self::singular(0.0))?;
        self.asm
            .acceleration_rhs(&q, &v, 0.0, scale, &mut self.rhs)?;
        self.lu
            .solve_in_place(&mut self.rhs, false)
            .map_err(Self::singular(0.0))?;
        let n_v = model.n_v();
        let vdot = self.rhs[..n_v].to_vec();
        let lam = self.rhs[n_v..].iter().map(|x| x * scale).collect();
        Ok(State {
            t: 0.0,
            q,
            qdot: v,
            a: vdot.clone(),
            qddot: vdot,
            lam,
            h: 0.0,
        })
    }

    /// One Lie-group generalized-α step of size `h` from `s`, in place (module docs).
    ///
    /// # Errors
    /// [`SolveError::NewtonFailed`] when Newton does not converge; [`SolveError::Diverged`]
    /// when a node turns by more than [`MAX_STEP_ROTATION`] in the step;
    /// [`SolveError::Singular`] for a singular iteration matrix; [`SolveError::Interrupted`].
    pub fn alpha_step(&mut self, s: &mut State, h: f64) -> Result<NewtonReport, SolveError> {
        crate::interrupt::poll_at(s.t)?;
        let AlphaParameters {
            alpha_m, alpha_f, ..
        } = self.params;
        let (bp, gp) = (self.params.beta_prime(h), self.params.gamma_prime(h));
        if let Some(ratio) = step_ratio(s.h, h) {
            rescale_pseudo_accelerations(&mut s.a, &s.qddot, ratio);
        }
        s.h = h;
        self.start.copy_from_slice(&s.q);
        // The predictor: v̇ₙ₊₁ = v̇ₙ (rigid bodies' accelerations are smooth).
        for i in 0..s.qdot.len() {
            let p = self
                .params
                .predict(h, s.qdot[i], s.qddot[i], s.a[i], s.qddot[i]);
            self.increment[i] = p.increment;
            s.qdot[i] = p.qdot;
            s.a[i] = p.a_next;
        }
        s.t += h;
        self.retract(&mut s.q);
        let report = self.newton(s, bp, gp)?;
        self.check_rotations(s.t)?;
        let w = (1.0 - alpha_f) / (1.0 - alpha_m);
        s.a.iter_mut()
            .zip(&s.qddot)
            .for_each(|(a, acc)| *a += w * acc);
        Ok(report)
    }

    /// `q = qₙ ∘ exp(Δ)` node by node.
    fn retract(&self, q: &mut [f64]) {
        for node in 0..self.asm.model.nodes.len() {
            Frame::read(&self.start, node)
                .retract(&self.increment[NV * node..NV * node + NV])
                .write(q, node);
        }
    }

    fn newton(&mut self, s: &mut State, bp: f64, gp: f64) -> Result<NewtonReport, SolveError> {
        let n_v = self.asm.model.n_v();
        let scale = bp * self.asm.mean_mass();
        let length = self.asm.model.size();
        let mut iterations = 0;
        loop {
            let force = self
                .asm
                .residual(&s.q, &s.qdot, &s.qddot, &s.lam, s.t, &mut self.rhs)?;
            let f_res = self.rhs[..n_v].iter().fold(0.0f64, |m, x| m.max(x.abs()))
                / force.max(f64::MIN_POSITIVE);
            let c_res = self.rhs[n_v..].iter().fold(0.0f64, |m, x| m.max(x.abs())) / length;
            let residual = f_res.max(c_res);
            if f_res <= self.tol && c_res <= self.tol {
                return Ok(NewtonReport {
                    iterations,
                    residual,
                });
            }
            if iterations == self.max_iter || !residual.is_finite() {
                return Err(SolveError::NewtonFailed {
                    at: format!("t = {:.6} s", s.t),
                    iterations,
                    residual,
                    tolerance: self.tol,
                });
            }
            self.asm.matrix(
                &s.q,
                &s.qdot,
                s.t,
                Coefficients {
                    beta_prime: bp,
                    gamma_prime: gp,
                    scale,
                    tangent: Some((&self.increment, &s.lam)),
                },
            )?;
            self.lu
                .factorize(&self.asm.values)
                .map_err(Self::singular(s.t))?;
            self.rhs.iter_mut().for_each(|x| *x = -*x);
            self.rhs[n_v..].iter_mut().for_each(|x| *x *= scale);
            self.lu
                .solve_in_place(&mut self.rhs, false)
                .map_err(Self::singular(s.t))?;
            iterations += 1;
            let (delta, dnu) = self.rhs.split_at(n_v);
            for (i, d) in delta.iter().enumerate() {
                self.increment[i] += d;
                s.qdot[i] += gp * d;
                s.qddot[i] += bp * d;
            }
            s.lam.iter_mut().zip(dnu).for_each(|(l, d)| *l += scale * d);
            self.retract(&mut s.q);
            let inc_max = self.increment.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            let delta_max = delta.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            if delta_max <= 64.0 * f64::EPSILON * (length + inc_max) {
                return Ok(NewtonReport {
                    iterations,
                    residual,
                });
            }
        }
    }

    fn check_rotations(&self, t: f64) -> Result<(), SolveError> {
        for (node, inc) in self.increment.chunks(NV).enumerate() {
            let rotation = (inc[3] * inc[3] + inc[4] * inc[4] + inc[5] * inc[5]).sqrt();
            if rotation > MAX_STEP_ROTATION {
                return Err(SolveError::Diverged {
                    at: format!("t = {t:.6} s"),
                    rotation,
                    node: self.asm.model.nodes[node].name.clone(),
                });
            }
        }
        Ok(())
    }
}

/// The motion of `model` over `grid` from its consistent start: every state.
///
/// # Errors
/// As [`SpatialIntegrator::new`], [`SpatialIntegrator::initial_state`] and
/// [`SpatialIntegrator::alpha_step`].
pub fn simulate_spatial(
    model: &SpatialModel,
    settings: &DynamicSettings,
    grid: &TimeGrid,
) -> Result<Vec<State>, Error> {
    let mut integrator = SpatialIntegrator::new(model, settings)?;
    let mut state = integrator.initial_state()?;
    let mut states = Vec::with_capacity(grid.steps().len() + 1);
    states.push(state.clone());
    for &h in grid.steps() {
        integrator.alpha_step(&mut state, h)?;
        states.push(state.clone());
    }
    Ok(states)
}
