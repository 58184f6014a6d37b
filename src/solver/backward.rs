//! The discrete adjoint's backward sweep: Algorithm 1's run transposed, for both engines.
//!
//! A run is the start (consistent initial accelerations, or the static equilibrium it
//! starts from), then steps `n → n + 1`, each possibly beginning with a restart at a drive's
//! kink on state `n`. A response `f = Σ wₙ G(qₙ)` is linear in each state's variation, and
//! each step's variation is linear in the one before, so `∂f/∂p` is the responses' seeds
//! carried backwards through the transposes of the same operations, in reverse:
//!
//! ```text
//! seed(N)
//! for n = N − 1, …, 0:   step(n)ᵀ   restart(n)ᵀ   seed(n)
//! start ᵀ
//! ```
//!
//! one column of adjoint variables per response, each step's matrix factored once for all
//! of them; every parameter's share of an operation is taken into the gradients as the
//! column passes it. What the operations are — the vector-space Newmark step or the update
//! `qₙ ∘ exp(Δ)` on the group, how a state is read back (stored, or replayed from a
//! checkpoint) — is [`Transposed`]'s: the planar engine's `sensitivity::adjoint` and the
//! spatial engine's `spatial::sensitivity` implement it.

use crate::error::Error;

/// An engine's adjoint at each phase of [`sweep`], one column of adjoint variables per
/// response.
pub(crate) trait Transposed {
    /// Adds each response's partial derivatives at state `n` (its seed) to the adjoint
    /// variables of that state.
    fn seed(&mut self, n: usize) -> Result<(), Error>;

    /// The step from state `n` to `n + 1` transposed: the adjoint variables of `n + 1`
    /// carried to `n`, each parameter's share of the step taken into the gradients.
    fn step(&mut self, n: usize) -> Result<(), Error>;

    /// The restart at a drive's kink on state `n` transposed, where the step from `n` began
    /// with one (nothing elsewhere).
    fn restart(&mut self, n: usize) -> Result<(), Error>;

    /// The start transposed.
    fn initial(&mut self) -> Result<(), Error>;
}

/// The backward sweep over a run of `steps` steps, from its last state to its start.
///
/// # Errors
/// The engine's ([`Transposed`]); [`crate::SolveError::Interrupted`] on Ctrl-C.
pub(crate) fn sweep(adjoint: &mut impl Transposed, steps: usize) -> Result<(), Error> {
    adjoint.seed(steps)?;
    for n in (0..steps).rev() {
        crate::interrupt::poll()?;
        adjoint.step(n)?;
        adjoint.restart(n)?;
        adjoint.seed(n)?;
    }
    adjoint.initial()
}
