//! The mechanism: what a scene builds and every solver reads. The [`model::Model`] (nodes,
//! elements grouped in bars, rigid bodies, joints and their rows, loads, design
//! variables), its finite [`element`]s, [`section`]s and their material [`interpolation`],
//! nodal [`load`]s (the joints it holds are in [`crate::joint`]), [`spring`]s and
//! [`motor`]s, the elements [`linear`]ized about the reference, the rigid clusters and kinematics of `rigid` and the rank analysis of the
//! joints' Jacobian (`rank`), and the scene [`parameter`]s with their pseudo-loads.

pub mod averaging;
pub mod bar_frequency;
pub mod bar_mass;
pub mod element;
pub mod interpolation;
pub mod linear;
pub mod load;
pub mod model;
pub mod motor;
pub mod parameter;
pub(crate) mod rank;
pub(crate) mod rigid;
pub mod rows;
pub mod section;
pub mod spring;
