//! The solver: the residual and iteration matrix on a fixed sparse pattern (`assembly`),
//! their `LDLᵀ` factors (`linsolve`; the spatial engine's non-symmetric matrix by its blocks'
//! `LU`, `block_lu`, behind `unsymmetric`, faer's `LU` where a pivot block is singular, `lu`),
//! Newton's method (`newton`), generalized-α (`alpha`,
//! paper Algorithm 1, the phases of a step on either engine's configuration space; `integrator`,
//! the planar engine's equations) with its local error control (`step_control`) and its
//! restart at a drive's kink (`kink`), the discrete adjoint's backward sweep (`backward`, Algorithm 1's run transposed) and the time error it estimates from the local errors (`local_error`), static equilibrium by load stepping (`statics`) and the linear static analysis
//! (`linear`), the
//! time loop (`simulation`) and a state carried to twice the elements per bar
//! (`prolongation`).

pub(crate) mod alpha;
pub(crate) mod assembly;
pub(crate) mod backward;
pub(crate) mod block_lu;
pub(crate) mod integrator;
pub(crate) mod kink;
pub(crate) mod linear;
pub(crate) mod linsolve;
pub(crate) mod local_error;
pub(crate) mod lu;
pub(crate) mod newton;
pub(crate) mod prolongation;
pub(crate) mod simulation;
pub(crate) mod sparsity;
pub(crate) mod statics;
pub(crate) mod step_control;
pub(crate) mod unsymmetric;
