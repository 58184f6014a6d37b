//! Rigid interface rings (RBE2-type): the nodes of a hole, a boss or an edge follow one rigid
//! frame. A ring is a light rigid body at its centre, hinged to each of its nodes: a node's
//! translation is the frame's at its arm, its own rotation stays free (a member's nodes have
//! none). The body carries the joints, not inertia: its mass and rotary inertia are
//! [`RING_MASS`], so that the iteration matrix keeps a pivot on each of its coordinates.

use std::collections::BTreeMap;

use nalgebra::Vector2;

use super::body;
use super::mesh::Mesh;
use super::spec::{JointSpec, RigidBodySpec, RingSpec};
use super::validate::{each, finite, Listed, Result};
use crate::error::SceneError;
use crate::mechanism::model::PointMass;

/// The mass (kg) and rotary inertia (kg m²) of a ring's body.
const RING_MASS: f64 = 1e-6;

/// Adds the scene's rings to `mesh` as rigid bodies and returns, per ring, the body's mass
/// and the hinges that join it to its nodes.
pub(super) fn add_all(mesh: &mut Mesh, specs: &[RingSpec]) -> Listed<(PointMass, Vec<JointSpec>)> {
    each(specs, |k, r| {
        add(mesh, &format!("rings[{k}] ({})", r.name), r)
    })
}

/// The ring `r` at `path`.
fn add(mesh: &mut Mesh, path: &str, r: &RingSpec) -> Result<(PointMass, Vec<JointSpec>)> {
    if r.nodes.len() < 2 {
        let msg = "a ring needs two nodes or more: its frame's angle follows from where they are";
        return Err(SceneError::new(format!("{path}.nodes"), msg));
    }
    if mesh.node("", &r.name).is_ok() {
        let msg = format!(
            "a node or body is already called '{}': a ring's centre is a node of its own",
            r.name
        );
        return Err(SceneError::new(format!("{path}.name"), msg));
    }
    for (i, name) in r.nodes.iter().enumerate() {
        if let Some(first) = r.nodes[..i].iter().position(|n| n == name) {
            let msg = format!("'{name}' is listed twice (also nodes[{first}])");
            return Err(SceneError::new(format!("{path}.nodes[{i}]"), msg));
        }
    }
    let positions = r
        .nodes
        .iter()
        .enumerate()
        .map(|(i, name)| Ok(mesh.nodes[mesh.node(&format!("{path}.nodes[{i}]"), name)?].position))
        .collect::<Result<Vec<Vector2<f64>>>>()?;
    let centre = match r.centre {
        Some([x, y]) => Vector2::new(
            finite(&format!("{path}.centre[0]"), x)?,
            finite(&format!("{path}.centre[1]"), y)?,
        ),
        None => positions.iter().sum::<Vector2<f64>>() / positions.len() as f64,
    };
    let spread = positions
        .iter()
        .map(|p| (p - positions[0]).norm())
        .fold(0.0, f64::max);
    if spread == 0.0 {
        let msg = "its nodes are all at one place: a ring's angle needs two distinct positions";
        return Err(SceneError::new(format!("{path}.nodes"), msg));
    }
    let points: BTreeMap<String, [f64; 2]> = positions
        .iter()
        .enumerate()
        .map(|(i, p)| (format!("n{i}"), [p.x - centre.x, p.y - centre.y]))
        .collect();
    let spec = RigidBodySpec {
        name: r.name.clone(),
        mass: RING_MASS,
        inertia: RING_MASS,
        position: [centre.x, centre.y],
        angle: None,
        angle_deg: None,
        points,
    };
    let mass = body::add(mesh, path, &spec)?;
    let hinges = r
        .nodes
        .iter()
        .enumerate()
        .map(|(i, node)| JointSpec::Hinge {
            name: format!("{}.{i}", r.name),
            nodes: [format!("{}.n{i}", r.name), node.clone()],
            drive: None,
        })
        .collect();
    Ok((mass, hinges))
}
