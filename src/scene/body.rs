//! Rigid bodies: a node at the centre of mass carrying the body's mass and rotary inertia,
//! and named points on it where joints attach (`body.point`, at an arm from the node that
//! turns with the body).

use nalgebra::{Rotation2, Vector2};

use super::mesh::Mesh;
use super::spec::RigidBodySpec;
use super::validate::{angle, each, finite, non_negative, positive, Listed, Result};
use crate::body::planar::{PointMass, RigidBody};
use crate::joint::planar::Anchor;

/// Adds the scene's rigid bodies to `mesh` (their nodes and points) and returns their
/// masses.
pub(super) fn add_all(mesh: &mut Mesh, specs: &[RigidBodySpec]) -> Listed<PointMass> {
    each(specs, |k, b| {
        add(mesh, &format!("rigid_bodies[{k}] ({})", b.name), b)
    })
}

/// The body `b` at `path`.
pub(super) fn add(mesh: &mut Mesh, path: &str, b: &RigidBodySpec) -> Result<PointMass> {
    let [x, y] = b.position;
    let node = mesh.add_node(&format!("{path}.position"), &b.name, x, y)?;
    let turned = angle(path, b.angle, b.angle_deg)?;
    let turn = Rotation2::new(turned);
    let mut points = Vec::with_capacity(b.points.len());
    for (name, &[px, py]) in &b.points {
        let at = format!("{path}.points.{name}");
        let local = Vector2::new(
            finite(&format!("{at}[0]"), px)?,
            finite(&format!("{at}[1]"), py)?,
        );
        let arm = turn * local;
        mesh.add_point(&at, &format!("{}.{name}", b.name), Anchor { node, arm })?;
        points.push((name.clone(), arm));
    }
    mesh.bodies.push(RigidBody {
        name: b.name.clone(),
        node,
        angle: turned,
        points,
    });
    Ok(PointMass {
        node,
        mass: positive(&format!("{path}.mass"), b.mass)?,
        inertia: non_negative(&format!("{path}.inertia"), b.inertia)?,
    })
}
