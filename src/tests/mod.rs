//! Tests across the wings, in the library's own test binary (one compilation of the crate
//! serves them and every module's unit tests; scripts/test.sh): the engine's physics and
//! numerics against analytic solutions, convergence orders and conservation laws
//! ([`engine`]), and a hot path that allocates nothing ([`allocation`]). They reach the crate
//! through its public paths only, as a user's code would.

mod allocation;
mod engine;
pub(crate) mod reference;
