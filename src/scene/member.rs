//! Continuum members: a rectangle meshed by `nx × ny` plane-stress quadrilaterals
//! ([`crate::mechanism::element::quad`]), each cell its own density.
//!
//! In a scene, a member lies in a local frame at `origin` rotated by `angle`, from `x = 0`
//! to `length` and centred on the local x axis; its nodes are named `NAME[i,j]` (column `i`
//! in `0..=nx`, row `j` in `0..=ny` from the bottom), its cells `NAME/cell[i,j]` (their
//! design variables, unless the member is `fixed`), and it forms the component `NAME`.

use super::ground_structure::{local_coordinates, Placement};
use super::mesh::Mesh;
use super::spec::MemberSpec;
use super::validate::{finite, positive, Result};
use crate::error::SceneError;
use crate::limits::MAX_ELEMENTS;
use crate::mechanism::element::quad::{PlaneMaterial, Quad};
use crate::mechanism::model::{Cell, Member};

/// Adds the scene's continuum members to `mesh`.
pub(super) fn add_all(mesh: &mut Mesh, specs: &[MemberSpec]) -> Result<()> {
    for (k, m) in specs.iter().enumerate() {
        add(mesh, &format!("members[{k}] ({})", m.name), m)?;
    }
    Ok(())
}

/// The member `m` at `path`: its grid nodes, then its cells row by row from the bottom.
fn add(mesh: &mut Mesh, path: &str, m: &MemberSpec) -> Result<()> {
    let material = material(path, m)?;
    if m.nx == 0 || m.ny == 0 {
        let msg = format!("needs nx >= 1 and ny >= 1 cells, got {} × {}", m.nx, m.ny);
        return Err(SceneError::new(path, msg));
    }
    let cells = m.nx.checked_mul(m.ny);
    if cells.is_none_or(|n| n > MAX_ELEMENTS.saturating_sub(mesh.cells.len())) {
        let msg = format!(
            "{} × {} cells: the model would have more than {MAX_ELEMENTS} elements",
            m.nx, m.ny
        );
        return Err(SceneError::new(path, msg));
    }
    let length = positive(&format!("{path}.length"), m.length)?;
    let height = positive(&format!("{path}.height"), m.height)?;
    let placement = Placement::of(mesh, path, &m.origin, m.angle, m.angle_deg)?;
    let (columns, rows) = (m.nx + 1, m.ny + 1);
    let mut node = Vec::with_capacity(columns * rows);
    for j in 0..rows {
        for i in 0..columns {
            let p = placement.position(local_coordinates(i, j, columns, rows, length, height));
            node.push(mesh.add_node(path, &format!("{}[{i},{j}]", m.name), p.x, p.y)?);
        }
    }
    let component = mesh.component(&m.name);
    let member = mesh.members.len();
    let first = mesh.cells.len();
    for j in 0..m.ny {
        for i in 0..m.nx {
            let nodes = [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)]
                .map(|(a, b)| node[b * columns + a]);
            let corners = nodes.map(|n| mesh.nodes[n].position);
            let kernel = Quad::new(corners, material).map_err(|_| {
                SceneError::new(path, "a cell is too thin to mesh: length and height are below the round-off of the origin")
            })?;
            let variable =
                (!m.fixed).then(|| mesh.variables.add(&format!("{}/cell[{i},{j}]", m.name)));
            mesh.cells.push(Cell {
                kernel,
                nodes,
                member,
                variable,
            });
        }
    }
    mesh.members.push(Member {
        name: m.name.clone(),
        component,
        cells: first..mesh.cells.len(),
        shape: [m.nx, m.ny],
    });
    Ok(())
}

/// The member's material and thickness: `E`, `rho` and `thickness` positive, `0 ≤ ν < 1/2`.
fn material(path: &str, m: &MemberSpec) -> Result<PlaneMaterial> {
    let poisson = finite(&format!("{path}.nu"), m.nu)?;
    if !(0.0..0.5).contains(&poisson) {
        let msg = format!("Poisson's ratio must lie in [0, 0.5), got {poisson}");
        return Err(SceneError::new(format!("{path}.nu"), msg));
    }
    Ok(PlaneMaterial {
        young: positive(&format!("{path}.E"), m.E)?,
        poisson,
        density: positive(&format!("{path}.rho"), m.rho)?,
        thickness: positive(&format!("{path}.thickness"), m.thickness)?,
    })
}
