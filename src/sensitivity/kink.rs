//! The restart at a kink of a drive's law ([`crate::solver::kink`]), differentiated.
//!
//! The restart adds `Δq̈(qₖ, x)` to `q̈ₖ` and `aₖ`, where
//! `[M, Φ_qᵀ; Φ_q, 0] [Δq̈; Δλ] = [0; Δg̈]`. Differentiated at fixed `Δg̈` of the grid's
//! node (a parameter of the law changes its size, not its place),
//!
//! ```text
//! [M, Φ_qᵀ; Φ_q, 0] [Δq̈'; Δλ'] = −[M'Δq̈ + Φ_q'ᵀΔλ + (Σ Δλₖ Hₖ) q'; (Φ_q Δq̈)' − Δg̈' + (Hₖ Δq̈)ᵀ q']
//! ```
//!
//! (`Hₖ` the rows' Hessians; primes on `M`, `Φ_q`, `g̈` are the pseudo-loads at the
//! jump, less those at rest), and `q̈'ₖ`, `a'ₖ` gain `Δq̈'`. The adjoint transposes it: the
//! adjoints `ā + Ā` of the restarted `aₖ`, `q̈ₖ` solve the same symmetric system, and its
//! solution `ν` gives `x̄ += νᵀ b_x` and `q̄ₖ −= (Σ Δλₖ Hₖ) ν_q + Σₖ s νₖ Hₖ Δq̈`.

use super::{Curvature, PseudoLoads};
use crate::error::SolveError;
use crate::mechanism::parameter::{At, Level};
use crate::solver::assembly::Assembler;
use crate::solver::integrator::Integrator;
use crate::solver::kink::Jump;

/// The two sides of the jump as the pseudo-loads read them: `(q̈, λ) = (Δq̈, Δλ)` on the
/// new law's side, at rest on the old one's; their difference is what `x` changes of
/// `[M Δq̈ + Φ_qᵀΔλ; Φ_q Δq̈ − Δg̈]`.
fn sides<'a>(jump: &'a Jump, still: &'a [f64], none: &'a [f64]) -> [At<'a>; 2] {
    let at = |acc, lam, t| At {
        q: &jump.q,
        rates: Some((still, acc)),
        lam,
        t,
        level: Level::Acceleration,
    };
    [
        at(&jump.dacc, &jump.dlam, jump.t.next_up()),
        at(still, none, jump.t.next_down()),
    ]
}

/// Direct: the columns `Δq̈'` (into `rhs`, leading dimension `n_q + n_c`, the multiplier
/// rows holding the solve's `μ`) for sensitivities `dq` (`q'ₖ`, column-major `n_q × n_x`).
///
/// # Errors
/// [`SolveError::Singular`] if `M` is singular on the constraint manifold.
pub(super) fn direct(
    it: &mut Integrator,
    jump: &Jump,
    pseudo: &PseudoLoads,
    dq: &[f64],
    rhs: &mut [f64],
) -> Result<(), SolveError> {
    it.newton.factorize(&jump.q, None, None, 1.0, 0.0, jump.t)?;
    let scale = it.newton.multiplier_scale();
    let asm = it.assembler();
    let (n_q, n_c, n_x) = (
        asm.model.n_dofs(),
        asm.model.n_constraints(),
        pseudo.columns(),
    );
    let n = n_q + n_c;
    let (still, none) = (vec![0.0; n_q], vec![0.0; n_c]);
    let [after, before] = sides(jump, &still, &none);
    rhs.fill(0.0);
    pseudo.subtract_columns(asm, &after, scale, rhs, n, 0..n_x);
    let mut rest = vec![0.0; rhs.len()];
    pseudo.subtract_columns(asm, &before, scale, &mut rest, n, 0..n_x);
    rhs.iter_mut().zip(&rest).for_each(|(r, b)| *r -= b);
    let (hessian, curvature) = hessians(asm, jump);
    let terms = Curvature {
        matrix: &hessian,
        curvature: &curvature,
    };
    terms.subtract(asm, dq, scale, rhs);
    it.newton.augment(rhs);
    it.newton
        .solve_block(rhs, n_x, &mut it.newton.scratch(n_x.max(1)))
}

/// Adjoint: `rhs` holds `[ā + Ā; 0]` of the restarted `aₖ`, `q̈ₖ` (one column per
/// response, leading dimension `n_q + n_c`); adds the restart's share to `q̄ₖ` (`qbar`,
/// column-major `n_q × n_r`) and to `x̄` (`xbar`, row-major `n_r × n_x`).
///
/// # Errors
/// [`SolveError::Singular`] if `M` is singular on the constraint manifold.
pub(super) fn adjoint(
    it: &mut Integrator,
    jump: &Jump,
    pseudo: &PseudoLoads,
    rhs: &mut [f64],
    qbar: &mut [f64],
    xbar: &mut [f64],
) -> Result<(), SolveError> {
    it.newton.factorize(&jump.q, None, None, 1.0, 0.0, jump.t)?;
    let scale = it.newton.multiplier_scale();
    let (n_q, n_c) = {
        let model = it.assembler().model;
        (model.n_dofs(), model.n_constraints())
    };
    let (n, n_x) = (n_q + n_c, pseudo.columns());
    let n_r = rhs.len() / n;
    it.newton
        .solve_block(rhs, n_r, &mut it.newton.scratch(n_r.max(1)))?;
    it.newton.unaugment(rhs);
    let asm = it.assembler();
    let (still, none) = (vec![0.0; n_q], vec![0.0; n_c]);
    let [after, before] = sides(jump, &still, &none);
    let mut rest = vec![0.0; n_x];
    for (nu, xbar) in rhs.chunks(n).zip(xbar.chunks_mut(n_x.max(1))) {
        pseudo.subtract_transposed(asm, &after, scale, nu, xbar);
        rest.fill(0.0);
        pseudo.subtract_transposed(asm, &before, scale, nu, &mut rest);
        xbar.iter_mut().zip(&rest).for_each(|(x, r)| *x -= r);
    }
    let (hessian, curvature) = hessians(asm, jump);
    let terms = Curvature {
        matrix: &hessian,
        curvature: &curvature,
    };
    terms.subtract_transposed(asm, rhs, scale, qbar);
    Ok(())
}

/// `Σ Δλₖ Hₖ` on the pattern and `Hₖ Δq̈` per row, at `qₖ`: how the jump system changes
/// with `q`.
fn hessians(asm: &Assembler, jump: &Jump) -> (Vec<f64>, Vec<f64>) {
    (
        asm.constraint_hessian(&jump.q, &jump.dlam),
        asm.constraint_curvature(&jump.q, &jump.dacc),
    )
}
