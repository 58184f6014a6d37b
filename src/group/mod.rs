//! **The configuration spaces**, behind one interface ([`ConfigurationSpace`]): the planar
//! engine's nodes, `(x, y, φ)` with an additive angle ([`Additive`]), and the spatial
//! engine's, `ℝ³ × SO(3)`, a position and a rotation per node ([`Frames`]), on which the
//! Lie-group generalized-α method moves (Brüls, Cardona & Arnold, *Mech. Mach. Theory* 48,
//! 2012). [`crate::solver::alpha::step`] moves on either.
//!
//! A node's configuration is stored as seven numbers `(x, y, z, w, i, j, k)`: its position in
//! the inertial frame and the unit quaternion of its rotation. Its velocity, acceleration
//! and every increment are six numbers of the algebra `(u, θ)`: a translation in the inertial
//! frame and a rotation vector in the node's own frame, acting as
//! `(x, R) ⊕ (u, θ) = (x + u, R exp(θ̃))` ([`Frame::retract`]). The tangent operator of that
//! map is `diag(I, T(θ))` ([`tangent_block`]). The planar engine's `ℝ² × SO(2)` with an
//! additive angle is the abelian case of the same structure, where `T = I`.
//!
//! Two anchors on it — points of two nodes' frames or of the ground — and what a joint or a
//! force element measures between them, with their derivatives: `pair`.

pub(crate) mod pair;
pub mod so3;

use nalgebra::{Matrix3, Matrix6, Quaternion, UnitQuaternion, Vector3};

/// Numbers stored per spatial node in `q`: a position and a unit quaternion.
pub const NQ: usize = 7;
/// Numbers per spatial node in velocities, accelerations and increments.
pub const NV: usize = 6;

/// A node's position (m) and rotation: a frame in space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// Position in the inertial frame.
    pub x: Vector3<f64>,
    /// Rotation from the node's frame to the inertial one.
    pub r: UnitQuaternion<f64>,
}

impl Frame {
    /// The frame at `x` with rotation `r`.
    pub fn new(x: Vector3<f64>, r: UnitQuaternion<f64>) -> Self {
        Self { x, r }
    }

    /// Node `node`'s frame in the configuration vector `q`.
    pub fn read(q: &[f64], node: usize) -> Self {
        let c = &q[NQ * node..NQ * node + NQ];
        Self {
            x: Vector3::new(c[0], c[1], c[2]),
            r: UnitQuaternion::new_unchecked(Quaternion::new(c[3], c[4], c[5], c[6])),
        }
    }

    /// Writes the frame as node `node`'s configuration in `q`.
    pub fn write(&self, q: &mut [f64], node: usize) {
        let c = &mut q[NQ * node..NQ * node + NQ];
        c[..3].copy_from_slice(self.x.as_slice());
        let r = self.r.quaternion();
        c[3..].copy_from_slice(&[r.w, r.i, r.j, r.k]);
    }

    /// `(x + u, R exp(θ̃))` for the increment `(u, θ)`.
    pub fn retract(&self, increment: &[f64]) -> Self {
        let u = Vector3::new(increment[0], increment[1], increment[2]);
        let theta = Vector3::new(increment[3], increment[4], increment[5]);
        Self {
            x: self.x + u,
            r: self.r * so3::exp(&theta),
        }
    }

    /// The rotation matrix.
    pub fn rotation(&self) -> Matrix3<f64> {
        *self.r.to_rotation_matrix().matrix()
    }
}

/// Where a mechanism's configuration lives, and how an increment moves it:
/// `q = q₀ ⊕ Δ` (Algorithm 1's position update on a Lie group).
pub trait ConfigurationSpace {
    /// `q = q₀ ⊕ Δ`, `Δ` one number per velocity coordinate.
    fn retract(&self, q0: &[f64], increment: &[f64], q: &mut [f64]);
}

/// `ℝⁿ`: `q₀ + Δ`. The planar engine's nodes `(x, y, φ)`: `SE(2)` taken as `ℝ² × SO(2)`, the
/// abelian `SO(2)` as its additive angle, where the tangent operator is the identity.
#[derive(Debug, Clone, Copy)]
pub struct Additive;

impl ConfigurationSpace for Additive {
    fn retract(&self, q0: &[f64], increment: &[f64], q: &mut [f64]) {
        for ((q, q0), d) in q.iter_mut().zip(q0).zip(increment) {
            *q = q0 + d;
        }
    }
}

/// `(ℝ³ × SO(3))ⁿ`: `n` spatial nodes, [`Frame::retract`] node by node.
#[derive(Debug, Clone, Copy)]
pub struct Frames {
    /// The nodes.
    pub nodes: usize,
}

impl ConfigurationSpace for Frames {
    fn retract(&self, q0: &[f64], increment: &[f64], q: &mut [f64]) {
        for node in 0..self.nodes {
            Frame::read(q0, node)
                .retract(&increment[NV * node..NV * node + NV])
                .write(q, node);
        }
    }
}

/// The tangent operator of [`Frame::retract`] at the increment `(u, θ)`: `diag(I, T(θ))`.
pub fn tangent_block(increment: &[f64]) -> Matrix6<f64> {
    let theta = Vector3::new(increment[3], increment[4], increment[5]);
    let mut t = Matrix6::identity();
    t.fixed_view_mut::<3, 3>(3, 3)
        .copy_from(&so3::tangent(&theta));
    t
}

/// The six numbers of node `node` in a velocity-like vector.
pub fn six(v: &[f64], node: usize) -> [f64; NV] {
    let mut out = [0.0; NV];
    out.copy_from_slice(&v[NV * node..NV * node + NV]);
    out
}

/// The translational and rotational parts of six numbers.
pub fn split(v: &[f64; NV]) -> (Vector3<f64>, Vector3<f64>) {
    (
        Vector3::new(v[0], v[1], v[2]),
        Vector3::new(v[3], v[4], v[5]),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_frame_survives_the_configuration_vector() {
        let f = Frame::new(
            Vector3::new(1.0, -2.0, 3.0),
            so3::exp(&Vector3::new(0.3, 0.2, -1.1)),
        );
        let mut q = vec![0.0; 2 * NQ];
        f.write(&mut q, 1);
        assert_eq!(Frame::read(&q, 1), f);
    }

    /// The tangent block is the derivative of the retraction: a change `δ` of the increment
    /// moves the frame by `T δ` in the frame's own algebra.
    #[test]
    fn tangent_block_is_the_derivative_of_retract() {
        let f = Frame::new(
            Vector3::new(0.5, 0.0, 1.0),
            so3::exp(&Vector3::new(1.0, -2.0, 0.5)),
        );
        let inc = [0.1, 0.2, -0.3, 2.0, -1.5, 0.7];
        let delta = [0.3, -0.1, 0.4, 0.2, 0.5, -0.6];
        let eps = 1e-6;
        let moved = |e: f64| {
            let mut i = inc;
            i.iter_mut().zip(&delta).for_each(|(a, d)| *a += e * d);
            f.retract(&i)
        };
        let (plus, minus, base) = (moved(eps), moved(-eps), f.retract(&inc));
        let du = (plus.x - minus.x) / (2.0 * eps);
        let dtheta = (so3::log(&(base.r.inverse() * plus.r))
            - so3::log(&(base.r.inverse() * minus.r)))
            / (2.0 * eps);
        let exact = tangent_block(&inc) * nalgebra::Vector6::from_column_slice(&delta);
        assert!((du - exact.fixed_rows::<3>(0)).norm() < 1e-9);
        assert!((dtheta - exact.fixed_rows::<3>(3)).norm() < 1e-8);
    }
}
