//! Physics and numerics of the engine, checked against analytic solutions, convergence
//! orders and conservation laws.

mod adaptive;
mod common;
mod dynamics;
mod guides;
mod sensitivity;
mod spatial;
mod spatial_beams;
mod spatial_forces;
mod spatial_joints;
mod spatial_modes;
mod spatial_sensitivity;
mod spatial_shares;
mod spatial_statics;
mod spatial_trusses;
mod statics;
mod strain_energy;
mod variable_steps;
