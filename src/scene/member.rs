//! Continuum members: a rectangle meshed by `nx × ny` plane-stress quadrilaterals
//! ([`crate::mechanism::element::quad`]), each cell its own density.
//!
//! In a scene, a member lies in a local frame at `origin` rotated by `angle`, from `x = 0`
//! to `length` and centred on the local x axis; its nodes are named `NAME[i,j]` (column `i`
//! in `0..=nx`, row `j` in `0..=ny` from the bottom), its cells `NAME/cell[i,j]` (their
//! design variables, unless the member is `fixed` or the cell `solid`), and it forms the
//! component `NAME`. Cells in `holes` are left out, with the nodes only they touched. Cells
//! in `solid`, and by default those touching a node a joint or a beam attaches to (a ring
//! around the joint that an optimizer cannot take away), are passive solid.

use std::collections::HashSet;

use super::ground_structure::{local_coordinates, Placement};
use super::mesh::Mesh;
use super::spec::{MemberSpec, VoidSpec};
use super::validate::{finite, non_negative, positive, Result};
use crate::error::SceneError;
use crate::limits::MAX_ELEMENTS;
use crate::mechanism::element::quad::{PlaneMaterial, Quad};
use crate::mechanism::element::void::EnergyInterpolation;
use crate::mechanism::model::{Cell, Member};

/// Adds the scene's continuum members to `mesh`; `attached`: the names of the nodes that
/// joints and beams attach to.
pub(super) fn add_all(
    mesh: &mut Mesh,
    specs: &[MemberSpec],
    attached: &HashSet<&str>,
) -> Result<()> {
    for (k, m) in specs.iter().enumerate() {
        add(mesh, &format!("members[{k}] ({})", m.name), m, attached)?;
    }
    Ok(())
}

/// The member `m` at `path`: its grid nodes, then its cells row by row from the bottom,
/// passive solid where `m.solid` says or, with `m.solid_at_joints`, where they touch a node
/// in `attached`.
fn add(mesh: &mut Mesh, path: &str, m: &MemberSpec, attached: &HashSet<&str>) -> Result<()> {
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
    let kept: Vec<bool> = marked(&format!("{path}.holes"), m, &m.holes)?
        .iter()
        .map(|&hole| !hole)
        .collect();
    let solid = marked(&format!("{path}.solid"), m, &m.solid)?;
    if !kept.contains(&true) {
        return Err(SceneError::new(
            format!("{path}.holes"),
            "leave out every cell",
        ));
    }
    let (columns, rows) = (m.nx + 1, m.ny + 1);
    let mut touched = vec![false; columns * rows];
    for (j, i) in (0..m.ny).flat_map(|j| (0..m.nx).map(move |i| (j, i))) {
        if kept[j * m.nx + i] {
            for (a, b) in [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)] {
                touched[b * columns + a] = true;
            }
        }
    }
    let mut node = vec![usize::MAX; columns * rows];
    for j in 0..rows {
        for i in (0..columns).filter(|&i| touched[j * columns + i]) {
            let p = placement.position(local_coordinates(i, j, columns, rows, length, height));
            node[j * columns + i] =
                mesh.add_node(path, &format!("{}[{i},{j}]", m.name), p.x, p.y)?;
        }
    }
    let component = mesh.component(&m.name);
    let member = mesh.members.len();
    let first = mesh.cells.len();
    let void = energy_interpolation(m, path)?;
    for j in 0..m.ny {
        for i in (0..m.nx).filter(|&i| kept[j * m.nx + i]) {
            let nodes = [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)]
                .map(|(a, b)| node[b * columns + a]);
            let corners = nodes.map(|n| mesh.nodes[n].position);
            let kernel = Quad::new(corners, material, m.cell.into()).map_err(|_| {
                SceneError::new(path, "a cell is too thin to mesh: length and height are below the round-off of the origin")
            })?;
            let at_joint = m.solid_at_joints
                && nodes
                    .iter()
                    .any(|&n| attached.contains(mesh.nodes[n].name.as_str()));
            let designed = !(m.fixed || solid[j * m.nx + i] || at_joint);
            let variable =
                designed.then(|| mesh.variables.add(&format!("{}/cell[{i},{j}]", m.name)));
            mesh.cells.push(Cell {
                kernel,
                nodes,
                member,
                variable,
                void,
            });
        }
    }
    mesh.members.push(Member {
        name: m.name.clone(),
        component,
        cells: first..mesh.cells.len(),
    });
    Ok(())
}

/// The cells of member `m` that the rectangles `[i0, j0, i1, j1]` at `path` cover, row by
/// row: each rectangle within the member and not empty.
fn marked(path: &str, m: &MemberSpec, rectangles: &[[usize; 4]]) -> Result<Vec<bool>> {
    let mut covered = vec![false; m.nx * m.ny];
    for (k, &[i0, j0, i1, j1]) in rectangles.iter().enumerate() {
        if !(i0 < i1 && i1 <= m.nx && j0 < j1 && j1 <= m.ny) {
            let msg = format!(
                "[{i0}, {j0}, {i1}, {j1}] is no rectangle of cells [i0, j0, i1, j1] with \
                 i0 < i1 <= nx = {} and j0 < j1 <= ny = {}",
                m.nx, m.ny
            );
            return Err(SceneError::new(format!("{path}[{k}]"), msg));
        }
        for j in j0..j1 {
            covered[j * m.nx + i0..j * m.nx + i1].fill(true);
        }
    }
    Ok(covered)
}

/// The member's material and thickness: `E`, `rho` and `thickness` positive, `0 ≤ ν < 1/2`.
fn material(path: &str, m: &MemberSpec) -> Result<PlaneMaterial> {
    let poisson = finite(&format!("{path}.nu"), m.nu)?;
    if !(0.0..0.5).contains(&poisson) {
        let msg = format!("Poisson's ratio must lie in [0, 0.5), got {poisson}");
        return Err(SceneError::new(format!("{path}.nu"), msg));
    }
    let [alpha, beta] = m.rayleigh.unwrap_or([0.0; 2]);
    Ok(PlaneMaterial {
        young: positive(&format!("{path}.E"), m.E)?,
        poisson,
        density: positive(&format!("{path}.rho"), m.rho)?,
        thickness: positive(&format!("{path}.thickness"), m.thickness)?,
        alpha: non_negative(&format!("{path}.rayleigh[0]"), alpha)?,
        beta: non_negative(&format!("{path}.rayleigh[1]"), beta)?,
    })
}

/// The energy interpolation of member `m`'s cells at `path`, `None` where its void cells
/// stay nonlinear.
///
/// # Errors
/// [`SceneError`] if `void_threshold` is outside (0, 1) or given with `void = "nonlinear"`.
fn energy_interpolation(m: &MemberSpec, path: &str) -> Result<Option<EnergyInterpolation>> {
    let threshold = m.void_threshold;
    match m.void {
        VoidSpec::Nonlinear if threshold.is_some() => Err(SceneError::new(
            format!("{path}.void_threshold"),
            "is the blend's threshold of void = \"linear_energy\"; the member's void = \"nonlinear\" has none",
        )),
        VoidSpec::Nonlinear => Ok(None),
        VoidSpec::LinearEnergy => {
            let default = EnergyInterpolation::DEFAULT;
            let threshold = threshold.unwrap_or(default.threshold);
            if !(threshold > 0.0 && threshold < 1.0) {
                return Err(SceneError::new(
                    format!("{path}.void_threshold"),
                    format!("must lie in (0, 1), got {threshold}"),
                ));
            }
            Ok(Some(EnergyInterpolation { threshold, ..default }))
        }
    }
}
