//! Springs and dampers between two points, or on a joint's coordinate ([`crate::mechanism::spring`]).

use super::joint::coordinate;
use super::mesh::Mesh;
use super::spec::SpringSpec;
use super::validate::{each, finite, non_negative, Listed, Result};
use crate::error::SceneError;
use crate::joint::planar::Joint;
use crate::mechanism::spring::{Measure, Spring};

/// The scene's springs, on the anchors of `mesh` or the `joints`, in a scene of `size`.
pub(super) fn springs(
    specs: &[SpringSpec],
    mesh: &Mesh,
    joints: &[Joint],
    size: f64,
) -> Listed<Spring> {
    each(specs, |k, s| {
        spring(&format!("springs[{k}] ({})", s.name), s, mesh, joints, size)
    })
}

/// The spring `s` at `path`.
fn spring(path: &str, s: &SpringSpec, mesh: &Mesh, joints: &[Joint], size: f64) -> Result<Spring> {
    let stiffness = non_negative(&format!("{path}.k"), s.k)?;
    let damping = non_negative(&format!("{path}.c"), s.c)?;
    if stiffness == 0.0 && damping == 0.0 {
        return Err(SceneError::new(
            path,
            "has neither stiffness `k` nor damping `c`",
        ));
    }
    let (measure, rest) = match (&s.nodes, &s.joint) {
        (Some(nodes), None) => {
            if s.rest.is_some() {
                return Err(SceneError::new(
                    path,
                    "a spring between points takes a rest `length`, not `rest`",
                ));
            }
            let at = [
                mesh.anchor(&format!("{path}.nodes[0]"), &nodes[0])?,
                mesh.anchor(&format!("{path}.nodes[1]"), &nodes[1])?,
            ];
            let reference = mesh.position(at[1]) - mesh.position(at[0]);
            if at[0].node == at[1].node || reference.norm() <= 1e-9 * size {
                return Err(SceneError::new(
                    path,
                    format!(
                        "'{}' and '{}' coincide or lie on one body: a spring between points needs \
                         two bodies or nodes apart, to have a direction",
                        nodes[0], nodes[1]
                    ),
                ));
            }
            let length = match s.length {
                Some(l) => non_negative(&format!("{path}.length"), l)?,
                None => reference.norm(),
            };
            (Measure::Distance { at, reference }, length)
        }
        (None, Some(name)) => {
            if s.length.is_some() {
                return Err(SceneError::new(
                    path,
                    "a spring on a joint takes a `rest` value, not `length`",
                ));
            }
            let (_, row) =
                coordinate(&format!("{path}.joint"), joints, name, "a spring to resist")?;
            let rest = finite(&format!("{path}.rest"), s.rest.unwrap_or(0.0))?;
            (Measure::Coordinate(row), rest)
        }
        _ => {
            return Err(SceneError::new(
                path,
                "a spring takes two `nodes` or one `joint`",
            ))
        }
    };
    Ok(Spring {
        name: s.name.clone(),
        measure,
        stiffness,
        damping,
        rest,
    })
}
