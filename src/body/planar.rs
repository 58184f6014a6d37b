//! Planar rigid bodies and point masses: a body is a node at its centre of mass carrying its
//! mass and rotary inertia (a [`PointMass`] there) and the points where joints attach; it adds
//! no unknowns of its own.

use nalgebra::Vector2;

/// A non-design point mass on a node.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointMass {
    /// Node.
    pub node: usize,
    /// Mass (kg).
    pub mass: f64,
    /// Rotary inertia (kg m²).
    pub inertia: f64,
}

/// A planar rigid body: its node is the centre of mass (its mass and rotary inertia are a
/// [`PointMass`] there), its points where joints attach.
#[derive(Debug, Clone, PartialEq)]
pub struct RigidBody {
    /// Name; also its node's.
    pub name: String,
    /// Its node.
    pub node: usize,
    /// Its angle at the reference (rad): the scene gives its points in its own frame,
    /// turned by it (a frame declared rigid: 0, its points where the grid puts them).
    pub angle: f64,
    /// Named points: their offsets from the centre of mass at the reference (m).
    pub points: Vec<(String, Vector2<f64>)>,
}
