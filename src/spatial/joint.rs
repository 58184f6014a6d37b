//! Spatial joints as index-3 constraints `Φ(q) = 0` with Lagrange multipliers, in the
//! Lie-group form: the gradient `B` acts on the nodes' increments `(u, θ)`, and the
//! constraint-force stiffness `∂(Bᵀλ)/∂q` — which Newton can do without but an exact
//! adjoint cannot — is part of the iteration matrix.
//!
//! A joint holds two anchors, each a point of a body (`p = x + R a`, `a` in the body's
//! frame from its centre of mass) or of the ground. The spherical joint makes them coincide:
//!
//! ```text
//! Φ = p_A − p_B,            B = ±[I, −R ã]  on each body's node (+ for A, − for B)
//! ∂(Bᵀλ)/∂θ = ± ã (Rᵀλ)~    (the rotation rows and columns of the anchor's node)
//! Φ̈ = B v̇ + b,             b = Σ ± R Ω̃ Ω̃ a
//! ```
//!
//! `λ` is the force the joint exerts on B (its opposite acts on A), in the inertial frame.

use nalgebra::{Matrix3, Matrix3x6, Vector3};

use crate::group::so3::hat;
use crate::group::{six, split, Frame};

/// A point a joint holds: of a body (by its node, the arm in the body's frame from its
/// centre of mass) or fixed in space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Anchor {
    /// A point of the ground, in the inertial frame (m).
    Ground(Vector3<f64>),
    /// A body's point.
    Body {
        /// The body's index in the model.
        body: usize,
        /// The point in the body's frame, from its centre of mass (m).
        point: Vector3<f64>,
    },
}

/// An anchor resolved to the node that carries it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Point {
    /// The node (`None`: the ground).
    pub node: Option<usize>,
    /// The arm in the node's frame, or the ground point.
    pub arm: Vector3<f64>,
}

impl Point {
    /// Where the point is at configuration `q`.
    pub fn position(&self, q: &[f64]) -> Vector3<f64> {
        match self.node {
            Some(n) => {
                let f = Frame::read(q, n);
                f.x + f.r * self.arm
            }
            None => self.arm,
        }
    }
}

/// What a joint constrains.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JointKind {
    /// The two points coincide: three rows, the rotations free.
    Spherical,
}

impl JointKind {
    /// Constraint rows of the kind.
    pub fn rows(self) -> usize {
        match self {
            Self::Spherical => 3,
        }
    }
}

/// A joint between two anchors.
#[derive(Debug, Clone, PartialEq)]
pub struct Joint {
    /// Its name in the scene.
    pub name: String,
    /// What it constrains.
    pub kind: JointKind,
    pub(crate) a: Point,
    pub(crate) b: Point,
}

impl Joint {
    /// The anchored points with their signs in `Φ = p_A − p_B`.
    pub(crate) fn signed_points(&self) -> [(f64, &Point); 2] {
        [(1.0, &self.a), (-1.0, &self.b)]
    }

    /// The nodes the joint acts on.
    pub(crate) fn nodes(&self) -> impl Iterator<Item = usize> + '_ {
        self.signed_points().into_iter().filter_map(|(_, p)| p.node)
    }

    /// `Φ(q)` (module docs).
    pub fn value(&self, q: &[f64]) -> Vector3<f64> {
        self.a.position(q) - self.b.position(q)
    }

    /// Each anchored node with its block `±[I, −R ã]` of `B` (module docs).
    pub(crate) fn gradient<'a>(
        &'a self,
        q: &'a [f64],
    ) -> impl Iterator<Item = (usize, Matrix3x6<f64>)> + 'a {
        self.signed_points()
            .into_iter()
            .filter_map(move |(sign, p)| {
                let node = p.node?;
                let r = Frame::read(q, node).rotation();
                let mut block = Matrix3x6::zeros();
                block
                    .fixed_view_mut::<3, 3>(0, 0)
                    .copy_from(&(Matrix3::identity() * sign));
                block
                    .fixed_view_mut::<3, 3>(0, 3)
                    .copy_from(&(r * hat(&p.arm) * -sign));
                Some((node, block))
            })
    }

    /// Each anchored node with `∂(Bᵀλ)/∂θ` on its rotations, `± ã (Rᵀλ)~` (module docs).
    pub(crate) fn force_stiffness<'a>(
        &'a self,
        q: &'a [f64],
        lambda: &'a Vector3<f64>,
    ) -> impl Iterator<Item = (usize, Matrix3<f64>)> + 'a {
        self.signed_points()
            .into_iter()
            .filter_map(move |(sign, p)| {
                let node = p.node?;
                let r = Frame::read(q, node).rotation();
                Some((node, hat(&p.arm) * hat(&(r.transpose() * lambda)) * sign))
            })
    }

    /// `b` of `Φ̈ = B v̇ + b` at velocity `v`: `Σ ± R Ω̃ Ω̃ a` (module docs).
    pub fn acceleration_term(&self, q: &[f64], v: &[f64]) -> Vector3<f64> {
        self.signed_points()
            .into_iter()
            .filter_map(|(sign, p)| {
                let node = p.node?;
                let (_, omega) = split(&six(v, node));
                let r = Frame::read(q, node).rotation();
                Some(r * omega.cross(&omega.cross(&p.arm)) * sign)
            })
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::group::{so3, NQ, NV};

    fn two_bodies() -> (Joint, Vec<f64>) {
        let joint = Joint {
            name: "j".into(),
            kind: JointKind::Spherical,
            a: Point {
                node: Some(0),
                arm: Vector3::new(0.3, -0.2, 0.5),
            },
            b: Point {
                node: Some(1),
                arm: Vector3::new(-0.1, 0.4, 0.2),
            },
        };
        let mut q = vec![0.0; 2 * NQ];
        Frame::new(
            Vector3::new(0.1, 0.2, 0.3),
            so3::exp(&Vector3::new(0.4, -1.2, 2.0)),
        )
        .write(&mut q, 0);
        Frame::new(
            Vector3::new(-0.5, 0.0, 1.0),
            so3::exp(&Vector3::new(-2.5, 0.3, 0.1)),
        )
        .write(&mut q, 1);
        (joint, q)
    }

    /// Perturbs node `node`'s configuration by `e` along algebra direction `k`.
    fn perturbed(q: &[f64], node: usize, k: usize, e: f64) -> Vec<f64> {
        let mut inc = [0.0; NV];
        inc[k] = e;
        let mut out = q.to_vec();
        Frame::read(q, node).retract(&inc).write(&mut out, node);
        out
    }

    #[test]
    fn gradient_and_force_stiffness_against_differences() {
        let (joint, q) = two_bodies();
        let lambda = Vector3::new(2.0, -1.0, 0.5);
        let eps = 1e-6;
        let blocks: Vec<_> = joint.gradient(&q).collect();
        let stiff: Vec<_> = joint.force_stiffness(&q, &lambda).collect();
        for ((node, b), (_, k)) in blocks.iter().zip(&stiff) {
            for c in 0..NV {
                let d = (joint.value(&perturbed(&q, *node, c, eps))
                    - joint.value(&perturbed(&q, *node, c, -eps)))
                    / (2.0 * eps);
                assert!(
                    (d - b.column(c)).norm() < 1e-8,
                    "B, node {node}, column {c}"
                );
            }
            // Bᵀλ's rotation part, differentiated in the node's rotations.
            let moment = |qq: &[f64]| -> Vector3<f64> {
                let (_, bb) = joint.gradient(qq).find(|(n, _)| n == node).unwrap();
                bb.fixed_view::<3, 3>(0, 3).transpose() * lambda
            };
            for c in 0..3 {
                let d = (moment(&perturbed(&q, *node, 3 + c, eps))
                    - moment(&perturbed(&q, *node, 3 + c, -eps)))
                    / (2.0 * eps);
                assert!(
                    (d - k.column(c)).norm() < 1e-8,
                    "K, node {node}, column {c}"
                );
            }
        }
    }

    /// `Φ̈ = B v̇ + b` along the motion `q(t) = q ⊕ (t v + ½t² v̇)` with constant body rates:
    /// second differences of `Φ` in time.
    #[test]
    fn acceleration_term_against_differences() {
        let (joint, q) = two_bodies();
        let v = [
            0.3, -0.1, 0.2, 1.5, -0.7, 2.0, -0.2, 0.4, 0.1, -1.0, 0.5, 0.3,
        ];
        let vdot = [0.0; 2 * NV];
        let at = |t: f64| {
            let mut out = q.clone();
            for n in 0..2 {
                let inc: Vec<f64> = six(&v, n).iter().map(|x| x * t).collect();
                Frame::read(&q, n).retract(&inc).write(&mut out, n);
            }
            joint.value(&out)
        };
        let h = 1e-4;
        let second = (at(h) - at(0.0) * 2.0 + at(-h)) / (h * h);
        let bvdot: Vector3<f64> = joint
            .gradient(&q)
            .map(|(n, b)| b * nalgebra::Vector6::from_column_slice(&six(&vdot, n)))
            .sum();
        let expected = bvdot + joint.acceleration_term(&q, &v);
        assert!(
            (second - expected).norm() < 1e-5 * expected.norm().max(1.0),
            "{second:?} against {expected:?}"
        );
    }
}
