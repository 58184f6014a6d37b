//! Explicit limits on the size of a model and on the work of a run, checked before
//! anything of that size is allocated. A refusal is a [`SceneError`](crate::SceneError) or
//! a [`SettingsError`](crate::SettingsError) that names the limit and what to change.
//!
//! The unknowns (three per node, one per constraint row) and the design variables (at most
//! one per bar, a bar at least one element) follow from these. Elsewhere:
//! [`crate::MAX_STEPS`] time steps and [`crate::MAX_TRAJECTORY_BYTES`] of
//! recorded trajectory per run, 8 GiB of sensitivities (the `sensitivity` module), and
//! for statics a smallest load increment and an iteration budget (`statics`).

/// Grid nodes of one ground structure (`nx · ny`): its candidate bars grow as their square.
pub const MAX_GRID_NODES: usize = 2_000;

/// Elements of one bar or beam (`split`).
pub const MAX_SPLIT: usize = 1_000;

/// Nodes of a model, the interior nodes of split bars included.
pub const MAX_NODES: usize = 1_000_000;

/// Elements of a model.
pub const MAX_ELEMENTS: usize = 1_000_000;

/// Load steps of a static solve.
pub const MAX_LOAD_STEPS: usize = 1_000_000;
