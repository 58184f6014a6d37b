//! Static equilibrium of a spatial mechanism, `f(q) + Bᵀλ = 0`, `Φ(q, t) = 0`, by Newton's
//! method on the group with the load stepping of the planar engine
//! ([`crate::solve_static`]'s, shared): gravity, motors and loads scaled by a load factor
//! climbing to 1; the drives hold their law at [`StaticSettings::time`]. The drives move with
//! the load factor: at a factor `f` every law (and load) is read at `f · time`, so that a
//! mechanism the drives carry far from its initial configuration (the spatial robot arm at
//! the end of its motion, turned by a radian) is reached by the load steps from there, not in
//! one Newton solve; at the full load the equilibrium is the one at `time`. A step that lands
//! a revolute drive half a turn off its law (its row `sin(φ − ψ)` vanishes there too) fails
//! and is cut, as a jump to another branch.
//!
//! Each iteration solves `[K + εM, sBᵀ; sB, 0][δ; Δν] = −[r; sΦ]` with `K` the force
//! elements' and the joints' constraint-force stiffness at `q` and updates `q ← q ∘ exp(δ)`
//! node by node: the derivative of `r(q ∘ exp(δ))` at `δ = 0` is `K` itself, so the
//! iteration is Newton's but for `εM`, [`REGULARIZATION`] of the mechanism's stiffness
//! scale: a rigid body has directions nothing holds in statics (a body hung on a spring
//! turns freely about its line; a pendulum at no load has no stiffness yet), where `K`
//! alone is singular. It changes the iterations, not the equilibrium they converge to; an
//! iteration that would turn a node by more than [`MAX_ITERATION_ROTATION`] is shortened to
//! it. A load step that turns a node by more than [`MAX_LOAD_STEP_ROTATION`] is a jump to
//! another branch and counts as failed.
//!
//! With `newton = "modified"` an iteration's factors serve the next ones while they
//! contract the residual tenfold ([`crate::solver::newton::iterate`], as in a step).

use crate::error::{Error, SolveError};
use crate::group::so3::log;
use crate::group::{Frame, NV};
use crate::settings::{NewtonMatrix, StaticSettings};
use crate::solver::newton::{self, at_round_off, Forecast, NewtonReport, Residual, System};
use crate::solver::statics::{step_loads, Equilibrium, StaticSolution};
use crate::solver::unsymmetric::Unsymmetric;
use crate::spatial::assembly::{analysed, Assembler, Coefficients};
use crate::spatial::force::ForceKind;
use crate::spatial::model::SpatialModel;

/// `ε` of the module docs relative to the stiffness scale `k_ref / m_ref`: springs' `k`
/// and weights and loads per length of the mechanism, per mass.
pub const REGULARIZATION: f64 = 1e-9;

/// The largest rotation a load step may give a node (rad), as in the planar engine: more is
/// a jump to another branch, and the step is halved.
pub const MAX_LOAD_STEP_ROTATION: f64 = std::f64::consts::FRAC_PI_2;

/// The largest rotation one Newton iteration gives a node (rad); a longer step is shortened.
pub const MAX_ITERATION_ROTATION: f64 = 0.25;

/// The static equilibrium of `model` (module docs), from its initial configuration.
///
/// # Errors
/// [`SettingsError`] for settings out of range ([`StaticSettings::validate`]);
/// [`SolveError::Setup`] if the pattern cannot be analysed; the load stepping's errors
/// ([`SolveError::LoadStepping`] where no equilibrium is found).
pub fn solve_static_spatial(
    model: &SpatialModel,
    settings: &StaticSettings,
) -> Result<StaticSolution, Error> {
    settings.validate()?;
    model.check_nodes()?;
    let (asm, lu) = analysed(model)?;
    let n = asm.pattern.n;
    let mut equilibrium = Spatial {
        asm,
        lu,
        settings: *settings,
        rest: vec![0.0; model.n_v()],
        rhs: vec![0.0; n],
    };
    let (q, lambda) = (model.initial_configuration(), vec![0.0; model.n_rows()]);
    Ok(step_loads(&mut equilibrium, q, lambda, settings)?)
}

/// Newton's machinery of a spatial equilibrium.
struct Spatial<'m> {
    asm: Assembler<'m>,
    lu: Unsymmetric,
    settings: StaticSettings,
    /// Zero velocities, accelerations and increment.
    rest: Vec<f64>,
    rhs: Vec<f64>,
}

impl Equilibrium for Spatial<'_> {
    fn solve_at(
        &mut self,
        load: f64,
        q: &mut [f64],
        lambda: &mut [f64],
        q_prev: &[f64],
    ) -> Result<NewtonReport, SolveError> {
        self.asm.load = load;
        let model = self.asm.model;
        let epsilon = REGULARIZATION * stiffness_scale(model) / self.asm.mean_mass();
        let (tol, max_iter) = (self.settings.tol, self.settings.max_iter);
        let keep = self.settings.newton == NewtonMatrix::Modified;
        let mut system = AtLoad {
            equilibrium: self,
            load,
            q,
            lambda,
            epsilon,
        };
        let report = newton::iterate(&mut system, tol, max_iter, keep, &mut Forecast::default())?;
        let model = self.asm.model;
        let t = load * self.settings.time;
        for joint in &model.joints {
            if joint.drive_alignment(q, t).is_some_and(|c| c < 0.0) {
                return Err(SolveError::Diverged {
                    at: format!("load factor {load:.6}"),
                    rotation: std::f64::consts::PI,
                    node: format!("{} (its drive half a turn off its law)", joint.name),
                });
            }
        }
        for (node, n) in model.nodes.iter().enumerate() {
            let turned =
                log(&(Frame::read(q_prev, node).r.inverse() * Frame::read(q, node).r)).norm();
            if turned > MAX_LOAD_STEP_ROTATION {
                return Err(SolveError::Diverged {
                    at: format!("load factor {load:.6}"),
                    rotation: turned,
                    node: n.name.clone(),
                });
            }
        }
        Ok(report)
    }
}

/// An equilibrium's system for Newton at a load factor: the correction `δ`,
/// `q ← q ∘ exp(δ)` node by node, `λ += δν` (module docs).
struct AtLoad<'a, 'm> {
    equilibrium: &'a mut Spatial<'m>,
    load: f64,
    q: &'a mut [f64],
    lambda: &'a mut [f64],
    /// `ε` of the module docs, per mass.
    epsilon: f64,
}

impl AtLoad<'_, '_> {
    fn time(&self) -> f64 {
        self.load * self.equilibrium.settings.time
    }
}

impl System for AtLoad<'_, '_> {
    fn residual(&mut self, _with_matrix: bool) -> Result<Residual, SolveError> {
        let t = self.time();
        let e = &mut *self.equilibrium;
        let force = (e.asm).residual(self.q, &e.rest, &e.rest, self.lambda, t, &mut e.rhs)?;
        Ok(e.asm.measure(&e.rhs, force))
    }

    /// Constraint rows unscaled: there is no `β'` to balance, and the `LU`'s row pivoting
    /// takes the joints' rows in whatever units the forces come.
    fn solve(&mut self, refactor: bool) -> Result<(), SolveError> {
        let (t, load) = (self.time(), self.load);
        let e = &mut *self.equilibrium;
        let c = Coefficients {
            beta_prime: self.epsilon,
            gamma_prime: 0.0,
            scale: 1.0,
            tangent: Some((&e.rest, self.lambda)),
        };
        let singular = |e| SolveError::Singular {
            time: t,
            detail: format!("{e:?} at load factor {load:.6}"),
        };
        if refactor {
            e.asm.matrix(self.q, &e.rest, t, c)?;
            e.lu.factorize(&e.asm.values).map_err(singular)?;
        }
        e.rhs.iter_mut().for_each(|x| *x = -*x);
        e.lu.solve_in_place(&mut e.rhs, false).map_err(singular)
    }

    /// A step that would turn a node by more than [`MAX_ITERATION_ROTATION`] is shortened
    /// to it: where nothing holds a rotation yet (no load, multipliers still zero), `εM`
    /// alone would send it round. The multipliers take their whole step: with them the
    /// joints' stiffness that holds the rotation arrives.
    fn update(&mut self) -> bool {
        let e = &mut *self.equilibrium;
        let model = e.asm.model;
        let n_v = model.n_v();
        let turn = e.rhs[..n_v]
            .chunks(NV)
            .map(|d| (d[3] * d[3] + d[4] * d[4] + d[5] * d[5]).sqrt())
            .fold(0.0f64, f64::max);
        if turn > MAX_ITERATION_ROTATION {
            let shorten = MAX_ITERATION_ROTATION / turn;
            e.rhs[..n_v].iter_mut().for_each(|x| *x *= shorten);
        }
        let (delta, dnu) = e.rhs.split_at(n_v);
        for node in 0..model.nodes.len() {
            Frame::read(self.q, node)
                .retract(&delta[NV * node..NV * node + NV])
                .write(self.q, node);
        }
        self.lambda.iter_mut().zip(dnu).for_each(|(l, d)| *l += d);
        at_round_off(delta, self.q, model.size())
    }

    fn correction_at_round_off(&self) -> bool {
        let e = &*self.equilibrium;
        at_round_off(&e.rhs[..e.asm.model.n_v()], self.q, e.asm.model.size())
    }

    fn at(&self) -> String {
        format!("load factor {:.6}", self.load)
    }
}

/// The mechanism's stiffness scale (N/m): its springs' `k`, and its weights (beams'
/// included), loads and motors per its size. Not the beams' stiffness: an `εM` of it
/// would slow Newton's convergence on their soft modes, which it does not need to hold.
fn stiffness_scale(model: &SpatialModel) -> f64 {
    let size = model.size();
    let weights: f64 = model
        .bodies
        .iter()
        .map(|b| b.mass * model.gravity.norm())
        .sum::<f64>()
        / size;
    let beams: f64 = model
        .elements()
        .map(|e| e.mass() * model.gravity.norm() / size)
        .sum();
    let forces: f64 = model
        .forces
        .iter()
        .map(|f| match &f.kind {
            ForceKind::Spring { stiffness, .. } => *stiffness,
            ForceKind::Torsion { stiffness, .. } => stiffness / (size * size),
            ForceKind::Motor { torque, .. } => torque.abs() / (size * size),
            ForceKind::Load { force, moment, .. } => {
                force.norm() / size + moment.norm() / (size * size)
            }
        })
        .sum();
    (weights + beams + forces).max(f64::MIN_POSITIVE)
}
