//! The start of a run from the static equilibrium ([`crate::mechanism::model::Initial::Equilibrium`]):
//! `q₀(x)` solves `r_s(q₀, λ_s, x) = f_int − f_ext − M ĝ + Φ_qᵀλ_s = 0`, so the gradients
//! start from `q₀' = −K_s⁻¹ ∂r_s/∂x` (the static sensitivity, `K_s` the equilibrium's
//! augmented tangent), and the initial-acceleration system
//! `[M, Φ_qᵀ; Φ_q, 0] [q̈₀; λ₀] = [f_ext + M ĝ − f_int(q₀); g̈(0)]` changes with `q₀`:
//!
//! ```text
//! M q̈₀' + Φ_qᵀλ₀' = −∂r₀/∂x − (K_t + Σ λ₀ₖ Hₖ) q₀'        Φ_q q̈₀' = −(Hₖ q̈₀)ᵀ q₀'
//! ```
//!
//! (`Hₖ` the rows' Hessians). The adjoint transposes both: the adjoint of `q₀` collects the
//! initial system's share, then one static solve carries it to `x`.

use super::{Curvature, PseudoLoads};
use crate::error::SolveError;
use crate::mechanism::parameter::{At, Level};
use crate::solver::alpha::State;
use crate::solver::integrator::Integrator;
use crate::solver::statics::StaticSolution;

/// Direct: the columns `q₀'` (`n_q × n_x`, column-major) of the static sensitivity.
///
/// # Errors
/// [`SolveError::Singular`] for a singular equilibrium tangent.
pub(super) fn direct(
    it: &mut Integrator,
    eq: &StaticSolution,
    pseudo: &PseudoLoads,
) -> Result<Vec<f64>, SolveError> {
    let asm = it.assembler();
    let (n_q, n_x) = (asm.model.n_dofs(), pseudo.columns());
    let n = n_q + asm.model.n_constraints();
    it.newton
        .factorize(&eq.q, Some(&eq.lambda), None, 0.0, 0.0, 0.0)?;
    let mut rhs = vec![0.0; n * n_x];
    let scale = it.newton.multiplier_scale();
    pseudo.subtract_columns(it.assembler(), &at(eq), scale, &mut rhs, n, 0..n_x);
    if pseudo.moves_constraints() {
        it.newton.augment(&mut rhs);
    }
    it.newton
        .solve_block(&mut rhs, n_x, &mut it.newton.scratch(n_x.max(1)))?;
    Ok(rhs
        .chunks(n)
        .flat_map(|column| column[..n_q].iter().copied())
        .collect())
}

/// Direct: adds the initial system's terms in `q₀'` (columns `dq`) to its right-hand sides
/// `rhs` (leading dimension `n`, constraint rows scaled by `scale` as the solve wants).
pub(super) fn add_initial_terms(
    it: &Integrator,
    s: &State,
    dq: &[f64],
    scale: f64,
    rhs: &mut [f64],
) {
    let asm = it.assembler();
    let matrix = asm.tangent(&s.q, &s.lam);
    let curvature = asm.constraint_curvature(&s.q, &s.qddot);
    let terms = Curvature {
        matrix: &matrix,
        curvature: &curvature,
    };
    terms.subtract(asm, dq, scale, rhs);
}

/// The equilibrium as a state the pseudo-loads are evaluated at.
fn at(eq: &StaticSolution) -> At<'_> {
    At {
        q: &eq.q,
        rates: None,
        lam: &eq.lambda,
        t: 0.0,
        level: Level::Position,
    }
}

/// Adjoint: with `solution` the transposed initial solve's (unaugmented) solutions, one
/// column per response, adds to the adjoints `qbar` of `q₀` the initial system's share,
/// `−(K_t + Σλ₀H) ν − Σₖ s νₖ Hₖ q̈₀`, then carries them to `x`: `K_s ψ = q̄₀`,
/// `x̄ −= ψᵀ ∂r_s/∂x`.
///
/// # Errors
/// [`SolveError::Singular`] for a singular equilibrium tangent.
pub(super) fn adjoint(
    it: &mut Integrator,
    eq: &StaticSolution,
    s0: (&[f64], &[f64], &[f64]),
    pseudo: &PseudoLoads,
    solution: &mut [f64],
    qbar: &mut [f64],
    xbar: &mut [f64],
) -> Result<(), SolveError> {
    let (q0, acc0, lam0) = s0;
    let scale = it.newton.multiplier_scale();
    let asm = it.assembler();
    let (n_q, n_x) = (asm.model.n_dofs(), pseudo.columns());
    let n = n_q + asm.model.n_constraints();
    let n_r = qbar.len() / n_q.max(1);
    let matrix = asm.tangent(q0, lam0);
    let curvature = asm.constraint_curvature(q0, acc0);
    let terms = Curvature {
        matrix: &matrix,
        curvature: &curvature,
    };
    let mut total = qbar.to_vec();
    terms.subtract_transposed(asm, solution, scale, &mut total);
    let mut rhs = vec![0.0; n * n_r];
    for (column, total) in rhs.chunks_mut(n).zip(total.chunks(n_q)) {
        column[..n_q].copy_from_slice(total);
    }
    it.newton
        .factorize(&eq.q, Some(&eq.lambda), None, 0.0, 0.0, 0.0)?;
    it.newton
        .solve_block(&mut rhs, n_r, &mut it.newton.scratch(n_r))?;
    it.newton.unaugment(&mut rhs);
    let scale = it.newton.multiplier_scale();
    for (psi, xbar) in rhs.chunks(n).zip(xbar.chunks_mut(n_x.max(1))) {
        pseudo.subtract_transposed(it.assembler(), &at(eq), scale, psi, xbar);
    }
    Ok(())
}
