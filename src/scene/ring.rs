//! Interface rings: the nodes of a hole, a boss or an edge and one frame that joints attach
//! to, a light rigid body at the ring's centre. Its mass and rotary inertia are
//! [`RING_MASS`], so that the iteration matrix keeps a pivot on each of its coordinates: it
//! carries the joints, not inertia.
//!
//! * **Rigid** (RBE2-type): the body is hinged to each node; a node's translation is the
//!   frame's at its arm, its own rotation stays free (a member's nodes have none).
//! * **Averaging** (RBE3-type): the body sits at the nodes' weighted mean and follows their
//!   mean and least-squares rotation ([`Averaging`]); the nodes stay free, so the ring adds
//!   no stiffness.

use std::collections::BTreeMap;

use nalgebra::Vector2;

use super::body;
use super::mesh::Mesh;
use super::spec::{JointSpec, RigidBodySpec, RingKind, RingSpec};
use super::validate::{each, finite, positive, Listed, Result};
use crate::body::planar::PointMass;
use crate::error::{short, SceneError};
use crate::mechanism::averaging::{weighted_centre, Averaging};

/// The mass (kg) and rotary inertia (kg m²) of a ring's body.
const RING_MASS: f64 = 1e-6;

/// A ring as built: its body's mass and what holds the body to the nodes.
pub(super) struct Ring {
    /// The light body's.
    pub mass: PointMass,
    /// A rigid ring's hinges, one per node.
    pub hinges: Vec<JointSpec>,
    /// An averaging ring's rows.
    pub averaging: Option<Averaging>,
}

/// Adds the scene's rings to `mesh` as light rigid bodies, with what holds each to its
/// nodes.
pub(super) fn add_all(mesh: &mut Mesh, specs: &[RingSpec]) -> Listed<Ring> {
    each(specs, |k, r| {
        add(mesh, &format!("rings[{k}] ({})", r.name), r)
    })
}

/// A ring's `name`: not empty, without a dot (its hinges are `NAME.0`, `NAME.1`, …, its
/// points `NAME.n0`, …, and a body's points are read as `BODY.POINT`), and no member's or
/// ground structure's (responses and volumes name those).
fn name(mesh: &Mesh, path: &str, name: &str) -> Result<()> {
    let msg = if name.is_empty() || name.contains('.') {
        format!("'{name}' is no ring name: give one that is not empty and has no '.' (its hinges are NAME.0, NAME.1, …)")
    } else if mesh.components.iter().any(|c| c == name) {
        format!(
            "a member or ground structure is called '{name}' too: give the ring a name of its own"
        )
    } else {
        return Ok(());
    };
    Err(SceneError::new(format!("{path}.name"), msg))
}

/// The ring `r` at `path`.
fn add(mesh: &mut Mesh, path: &str, r: &RingSpec) -> Result<Ring> {
    if r.nodes.len() < 2 {
        let msg = "a ring needs two nodes or more: its frame's angle follows from where they are";
        return Err(SceneError::new(format!("{path}.nodes"), msg));
    }
    name(mesh, path, &r.name)?;
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
    let weights = weights(path, r)?;
    let spread = positions
        .iter()
        .map(|p| (p - positions[0]).norm())
        .fold(0.0, f64::max);
    if spread == 0.0 {
        let msg = "its nodes are all at one place: a ring's angle needs two distinct positions";
        return Err(SceneError::new(format!("{path}.nodes"), msg));
    }
    let mean = weighted_centre(&positions, &weights);
    let centre = match r.centre {
        Some([x, y]) => Vector2::new(
            finite(&format!("{path}.centre[0]"), x)?,
            finite(&format!("{path}.centre[1]"), y)?,
        ),
        None => mean,
    };
    if r.kind == RingKind::Averaging && (centre - mean).norm() > 1e-9 * spread {
        let msg = format!(
            "an averaging ring's centre is its nodes' weighted mean, ({}, {}): leave it out, or attach joints at a point of a body there",
            short(mean.x), short(mean.y)
        );
        return Err(SceneError::new(format!("{path}.centre"), msg));
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
    if r.kind == RingKind::Averaging {
        let nodes = (r.nodes.iter())
            .map(|name| mesh.node(path, name))
            .collect::<Result<Vec<usize>>>()?;
        let averaging = Averaging::new(r.name.clone(), mass.node, nodes, &positions, &weights);
        return Ok(Ring {
            mass,
            hinges: Vec::new(),
            averaging: Some(averaging),
        });
    }
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
    Ok(Ring {
        mass,
        hinges,
        averaging: None,
    })
}

/// The ring's weights, summing to one: an averaging ring's as given (each positive, one
/// per node) or all equal.
fn weights(path: &str, r: &RingSpec) -> Result<Vec<f64>> {
    let n = r.nodes.len();
    let given = match (&r.weights, r.kind) {
        (None, _) => vec![1.0; n],
        (Some(_), RingKind::Rigid) => {
            let msg = "weights are for averaging rings (kind = \"averaging\"): a rigid ring's \
                       nodes all follow its frame";
            return Err(SceneError::new(format!("{path}.weights"), msg));
        }
        (Some(w), RingKind::Averaging) if w.len() != n => {
            let msg = format!("{} weights for {n} nodes: give one per node", w.len());
            return Err(SceneError::new(format!("{path}.weights"), msg));
        }
        (Some(w), RingKind::Averaging) => (w.iter().enumerate())
            .map(|(i, &v)| positive(&format!("{path}.weights[{i}]"), v))
            .collect::<Result<_>>()?,
    };
    let total: f64 = given.iter().sum();
    let weights: Vec<f64> = given.into_iter().map(|w| w / total).collect();
    if !total.is_finite() || weights.iter().any(|&w| w < 1e-12) {
        let msg = "each weight must be at least 1e-12 of their sum, and the sum finite: a ring's \
                   rotation is a weighted fit over its nodes";
        return Err(SceneError::new(format!("{path}.weights"), msg));
    }
    Ok(weights)
}
