//! What the scene puts on its nodes besides beams and joints: point masses, nodal forces
//! and moments scaled in time, and gravity.

use nalgebra::Vector2;

use super::mesh::Mesh;
use super::spec::{LoadSpec, LoadTableSpec, PointMassSpec};
use super::validate::{each, finite, non_negative, positive, samples, Listed, Result};
use crate::body::planar::PointMass;
use crate::mechanism::load::{NodalLoad, TimeFunction};

/// The scene's point masses: mass `m > 0` and rotary inertia `J ≥ 0` on a node.
pub(super) fn point_masses(specs: &[PointMassSpec], mesh: &Mesh) -> Listed<PointMass> {
    each(specs, |k, p| {
        let path = format!("point_masses[{k}]");
        Ok(PointMass {
            node: mesh.node(&format!("{path}.node"), &p.node)?,
            mass: positive(&format!("{path}.mass"), p.mass)?,
            inertia: non_negative(&format!("{path}.inertia"), p.inertia)?,
        })
    })
}

/// The scene's nodal loads.
pub(super) fn loads(specs: &[LoadSpec], mesh: &Mesh) -> Listed<NodalLoad> {
    each(specs, |k, l| load(&format!("loads[{k}]"), l, mesh))
}

/// The load at `path`: force `[F_x, F_y]` and moment `M` on a node, times its [`time`]
/// function.
fn load(path: &str, l: &LoadSpec, mesh: &Mesh) -> Result<NodalLoad> {
    let value = [
        finite(&format!("{path}.force[0]"), l.force[0])?,
        finite(&format!("{path}.force[1]"), l.force[1])?,
        finite(&format!("{path}.moment"), l.moment)?,
    ];
    let time = time(path, l.table.as_ref())?;
    Ok(NodalLoad {
        node: mesh.node(&format!("{path}.node"), &l.node)?,
        value,
        time,
    })
}

/// Constant in time, or scaled piecewise-linearly through the samples of its `table`.
pub(super) fn time(path: &str, table: Option<&LoadTableSpec>) -> Result<TimeFunction> {
    Ok(match table {
        None => TimeFunction::Constant,
        Some(t) => {
            samples(&format!("{path}.table"), &t.t, &t.scale, "scale")?;
            TimeFunction::Table {
                t: t.t.clone(),
                value: t.scale.clone(),
            }
        }
    })
}

/// Gravitational acceleration `g` (m/s²), zero when the scene gives none.
pub(super) fn gravity(g: Option<[f64; 2]>) -> Result<Vector2<f64>> {
    Ok(match g {
        Some([gx, gy]) => Vector2::new(finite("gravity[0]", gx)?, finite("gravity[1]", gy)?),
        None => Vector2::zeros(),
    })
}
