//! Continuum members: a rectangle meshed by `nx × ny` plane-stress quadrilaterals
//! ([`crate::mechanism::element::quad`]), each cell its own density.
//!
//! In a scene, a member lies in a local frame at `origin` rotated by `angle`, from `x = 0`
//! to `length` and centred on the local x axis; its nodes are named `NAME[i,j]` (column `i`
//! in `0..=nx`, row `j` in `0..=ny` from the bottom), its cells `NAME/cell[i,j]` (their
//! design variables, unless the member is `fixed` or the cell `solid`), and it forms the
//! component `NAME`. Cells in `holes` are left out, with the nodes only they touched. Cells
//! in `solid`, and by default those touching a node a joint or a beam attaches to (a ring
//! around the joint that an optimizer cannot take away) or, with `solid_radius`, whose
//! centre lies within that distance of one (the same region on every mesh), are passive
//! solid.
//!
//! With `split = s`, each cell is meshed by `s × s` elements sharing its density: the
//! nodes between the cells' corners are named by their fractional place, `NAME[7/2,2]`
//! (column 3½, row 2), and the corners keep their names, so that a scene's joints, loads
//! and rings read the same nodes at every `s`.

use std::collections::HashSet;

use super::ground_structure::{local_coordinates, Placement};
use super::mesh::Mesh;
use super::spec::{MemberSpec, VoidSpec};
use super::validate::{finite, non_negative, positive, Result};
use crate::error::SceneError;
use crate::limits::{MAX_ELEMENTS, MAX_SPLIT};
use crate::mechanism::element::quad::{PlaneMaterial, Quad};
use crate::mechanism::element::void::EnergyInterpolation;
use crate::mechanism::model::{Cell, Member};
use nalgebra::Vector2;

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

/// The member `m` at `path`: its grid nodes, then its elements row by row from the bottom,
/// `m.split × m.split` to a cell, passive solid where `m.solid` says or, with
/// `m.solid_at_joints`, where one of the cell's elements touches a node in `attached` or,
/// with `m.solid_radius`, where the cell's centre lies within that distance of one.
fn add(mesh: &mut Mesh, path: &str, m: &MemberSpec, attached: &HashSet<&str>) -> Result<()> {
    let material = material(path, m)?;
    let grid = Grid::of(path, m, mesh.cells.len())?;
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
    let (columns, rows) = (grid.nx + 1, grid.ny + 1);
    let corners = |(i, j): (usize, usize)| [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)];
    let mut touched = vec![false; columns * rows];
    for e in grid.elements().filter(|&e| kept[grid.cell(e)]) {
        for (a, b) in corners(e) {
            touched[b * columns + a] = true;
        }
    }
    let mut node = vec![usize::MAX; columns * rows];
    for j in 0..rows {
        for i in (0..columns).filter(|&i| touched[j * columns + i]) {
            let p = placement.position(local_coordinates(i, j, columns, rows, length, height));
            let name = format!("{}[{},{}]", m.name, grid.place(i), grid.place(j));
            node[j * columns + i] = mesh.add_node(path, &name, p.x, p.y)?;
        }
    }
    let held = |(i, j): (usize, usize)| {
        let k = node[j * columns + i];
        k != usize::MAX && attached.contains(mesh.nodes[k].name.as_str())
    };
    let mut at_joint = vec![false; m.nx * m.ny];
    if m.solid_at_joints {
        for e in grid.elements().filter(|&e| kept[grid.cell(e)]) {
            at_joint[grid.cell(e)] |= corners(e).into_iter().any(held);
        }
    }
    if let Some(radius) = m.solid_radius {
        let at = format!("{path}.solid_radius");
        let radius = positive(&at, radius)?;
        if !m.solid_at_joints {
            return Err(SceneError::new(at, "needs solid_at_joints = true"));
        }
        let local = |(i, j)| Vector2::from(local_coordinates(i, j, columns, rows, length, height));
        let nodes = (0..rows).flat_map(|j| (0..columns).map(move |i| (i, j)));
        let held: Vec<Vector2<f64>> = nodes.filter(|&n| held(n)).map(local).collect();
        for (c, solid) in at_joint.iter_mut().enumerate() {
            let (i, j) = ((c % m.nx) * grid.split, (c / m.nx) * grid.split);
            let centre = (local((i, j)) + local((i + grid.split, j + grid.split))) / 2.0;
            *solid |= kept[c] && held.iter().any(|p| (p - centre).norm() <= radius);
        }
    }
    let component = mesh.component(&m.name);
    let member = mesh.members.len();
    let first = mesh.cells.len();
    let void = energy_interpolation(m, path)?;
    let mut variables = vec![None; m.nx * m.ny];
    for e in grid.elements().filter(|&e| kept[grid.cell(e)]) {
        let nodes = corners(e).map(|(a, b)| node[b * columns + a]);
        let kernel = Quad::new(nodes.map(|n| mesh.nodes[n].position), material, m.cell.into())
            .map_err(|_| {
                SceneError::new(path, "a cell is too thin to mesh: length and height are below the round-off of the origin")
            })?;
        let c = grid.cell(e);
        if variables[c].is_none() && !(m.fixed || solid[c] || at_joint[c]) {
            let (i, j) = (c % m.nx, c / m.nx);
            variables[c] = Some(mesh.variables.add(&format!("{}/cell[{i},{j}]", m.name)));
        }
        mesh.cells.push(Cell {
            kernel,
            nodes,
            member,
            variable: variables[c],
            void,
        });
    }
    mesh.members.push(Member {
        name: m.name.clone(),
        component,
        cells: first..mesh.cells.len(),
    });
    Ok(())
}

/// A member's mesh: `nx × ny` elements, `split × split` to each of its cells.
struct Grid {
    nx: usize,
    ny: usize,
    split: usize,
    cells_x: usize,
}

impl Grid {
    /// The mesh of member `m` at `path`, checked against the elements the model already
    /// holds (`before`) and [`MAX_ELEMENTS`].
    fn of(path: &str, m: &MemberSpec, before: usize) -> Result<Self> {
        if m.nx == 0 || m.ny == 0 {
            let msg = format!("needs nx >= 1 and ny >= 1 cells, got {} × {}", m.nx, m.ny);
            return Err(SceneError::new(path, msg));
        }
        if !(1..=MAX_SPLIT).contains(&m.split) {
            let msg = format!(
                "must be a whole number of elements per cell in 1..={MAX_SPLIT}, got {}",
                m.split
            );
            return Err(SceneError::new(format!("{path}.split"), msg));
        }
        let elements = [m.nx, m.ny, m.split, m.split]
            .iter()
            .try_fold(1usize, |n, &k| n.checked_mul(k));
        if elements.is_none_or(|n| n > MAX_ELEMENTS.saturating_sub(before)) {
            let msg = format!(
                "{} × {} cells of {} × {} elements: the model would have more than {MAX_ELEMENTS} elements",
                m.nx, m.ny, m.split, m.split
            );
            return Err(SceneError::new(path, msg));
        }
        Ok(Self {
            nx: m.nx * m.split,
            ny: m.ny * m.split,
            split: m.split,
            cells_x: m.nx,
        })
    }

    /// The elements `(i, j)`, row by row from the bottom.
    fn elements(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        (0..self.ny).flat_map(move |j| (0..self.nx).map(move |i| (i, j)))
    }

    /// The index, row by row, of the cell element `(i, j)` lies in.
    fn cell(&self, (i, j): (usize, usize)) -> usize {
        (j / self.split) * self.cells_x + i / self.split
    }

    /// Grid line `k` of the mesh in cells: `k / split` whole, or as the reduced fraction
    /// (`2/4` reads `1/2`: the same point has the same name at every split).
    fn place(&self, k: usize) -> String {
        let common = gcd(k, self.split);
        let (numerator, denominator) = (k / common, self.split / common);
        if denominator == 1 {
            numerator.to_string()
        } else {
            format!("{numerator}/{denominator}")
        }
    }
}

/// The greatest common divisor of `a` and `b` (Euclid); `gcd(0, b) = b`.
fn gcd(a: usize, b: usize) -> usize {
    if b == 0 {
        a
    } else {
        gcd(b, a % b)
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_split_cell_names_its_inner_nodes_by_their_place_and_maps_its_elements() {
        let m = MemberSpec {
            nx: 3,
            ny: 2,
            split: 4,
            ..Default::default()
        };
        let grid = Grid::of("members[0] (plate)", &m, 0).unwrap();
        assert_eq!((grid.nx, grid.ny), (12, 8));
        let places: Vec<String> = (0..=4).map(|k| grid.place(k)).collect();
        assert_eq!(places, ["0", "1/4", "1/2", "3/4", "1"]);
        assert_eq!(grid.place(10), "5/2");
        // Element (5, 6) lies in cell (1, 1), the fifth row by row.
        assert_eq!(grid.cell((5, 6)), 4);
        assert_eq!(grid.elements().filter(|&e| grid.cell(e) == 4).count(), 16);
        let zero = MemberSpec { split: 0, ..m };
        let err = Grid::of("members[0] (plate)", &zero, 0).err().unwrap();
        assert!(
            err.to_string().contains("members[0] (plate).split"),
            "{err}"
        );
    }
}
