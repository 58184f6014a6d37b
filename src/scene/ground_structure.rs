//! Ground structures: every bar a grid allows (paper Section 3.1).
//!
//! Nodes on an `nx × ny` grid, numbered column-major (column 0 bottom to top, then column
//! 1, …). A bar joins nodes `i < j` when their straight segment holds no third grid node,
//! i.e. when `gcd(|Δcolumn|, |Δrow|) = 1`; overlapping collinear bars are dropped and bars
//! that cross are not connected where they cross. Bars are ordered by `(i, j)`
//! lexicographically ([docs/reference-scenes.md](../../docs/reference-scenes.md)).
//!
//! In a scene, a ground structure lies in a local frame at `origin` rotated by `angle`; its
//! nodes are named `NAME[i,j]`, its bars `NAME/bar{k}` form the component `NAME`, and each
//! bar has a design variable of its own unless the structure is `fixed`. Bars listed in
//! `omit` are left out with the grid nodes only they touched; the others keep their names.
//! A ground structure declared `rigid` is one rigid body instead, a link not being designed.

use nalgebra::Vector2;

use super::mesh::{BarSpec, Mesh};
use super::section::{self, Sections};
use super::spec::{GroundStructureSpec, PointSpec};
use super::validate::{angle, finite, non_negative, positive, Result};
use crate::body::planar::{PointMass, RigidBody};
use crate::error::SceneError;
use crate::joint::planar::Anchor;
use crate::limits::MAX_GRID_NODES;
use crate::mechanism::section::Section;

/// Grid node `k` as `(column, row)`.
pub fn grid_position(k: usize, ny: usize) -> (usize, usize) {
    (k / ny, k % ny)
}

/// Local coordinates of grid node `(column, row)`: `x ∈ [0, L]`, `y ∈ [−H/2, H/2]`.
pub fn local_coordinates(
    column: usize,
    row: usize,
    nx: usize,
    ny: usize,
    length: f64,
    height: f64,
) -> [f64; 2] {
    let fraction = |i: usize, n: usize| {
        if n > 1 {
            i as f64 / (n - 1) as f64
        } else {
            0.5
        }
    };
    [
        length * fraction(column, nx),
        height * (fraction(row, ny) - 0.5),
    ]
}

/// The bars `(i, j)`, `i < j`, of an `nx × ny` ground structure in lexicographic order.
pub fn bars(nx: usize, ny: usize) -> Vec<(usize, usize)> {
    let n = nx * ny;
    let mut out = Vec::new();
    for i in 0..n {
        for j in i + 1..n {
            let ((ci, ri), (cj, rj)) = (grid_position(i, ny), grid_position(j, ny));
            if gcd(ci.abs_diff(cj), ri.abs_diff(rj)) == 1 {
                out.push((i, j));
            }
        }
    }
    out
}

fn gcd(a: usize, b: usize) -> usize {
    if b == 0 {
        a
    } else {
        gcd(b, a % b)
    }
}

/// Adds the scene's ground structures to `mesh`; returns the masses of those declared rigid.
pub(super) fn add_all(
    mesh: &mut Mesh,
    specs: &[GroundStructureSpec],
    sections: &Sections,
) -> Result<Vec<PointMass>> {
    let mut rigid = Vec::new();
    for (k, g) in specs.iter().enumerate() {
        let path = format!("ground_structures[{k}] ({})", g.name);
        rigid.extend(add(mesh, &path, g, sections)?);
    }
    Ok(rigid)
}

/// The ground structure `g` at `path`: its grid nodes, then its bars; or, declared rigid,
/// one body (its mass returned).
fn add(
    mesh: &mut Mesh,
    path: &str,
    g: &GroundStructureSpec,
    sections: &Sections,
) -> Result<Option<PointMass>> {
    let grid = Grid::of(mesh, path, g)?;
    let section = section::find(sections, path, &g.section)?;
    let kept = kept_bars(path, g)?;
    let mut touched = vec![false; g.nx * g.ny];
    for &(_, (i, j)) in &kept {
        touched[i] = true;
        touched[j] = true;
    }
    if g.rigid {
        return add_rigid(mesh, path, g, &grid, section.1, &kept, &touched).map(Some);
    }
    // Mesh index of each grid node a kept bar touches.
    let mut node = vec![usize::MAX; g.nx * g.ny];
    for k in (0..g.nx * g.ny).filter(|&k| touched[k]) {
        let (i, j) = grid_position(k, g.ny);
        let p = grid.position(i, j);
        node[k] = mesh.add_node(path, &format!("{}[{i},{j}]", g.name), p.x, p.y)?;
    }
    let component = mesh.component(&g.name);
    for (k, (i, j)) in kept {
        let name = format!("{}/bar{k}", g.name);
        let variable = (!g.fixed).then(|| mesh.variables.add(&name));
        mesh.add_bar(BarSpec {
            path: format!("{path}/bar{k}"),
            name,
            ends: [node[i], node[j]],
            section,
            split: g.split,
            kind: g.kind.into(),
            component,
            variable,
        })?;
    }
    Ok(None)
}

/// The ground structure `g` at `path` declared rigid: one rigid body named after it, with
/// the frame's mass, centre of mass and rotary inertia at full density (each bar a uniform
/// rod `ρA L` with its section's rotary inertia `ρI L`, the beams' consistent inertia in a
/// rigid motion), its grid nodes as points `NAME[i,j]` where joints attach as to the
/// nodes of the flexible frame. Three unknowns instead of three per node.
fn add_rigid(
    mesh: &mut Mesh,
    path: &str,
    g: &GroundStructureSpec,
    grid: &Grid,
    section: &Section,
    kept: &[(usize, (usize, usize))],
    touched: &[bool],
) -> Result<PointMass> {
    let at = |k: usize| {
        let (i, j) = grid_position(k, g.ny);
        grid.position(i, j)
    };
    let rods: Vec<(f64, Vector2<f64>, f64)> = kept
        .iter()
        .map(|&(_, (a, b))| {
            let length = (at(b) - at(a)).norm();
            (section.rho_a * length, 0.5 * (at(a) + at(b)), length)
        })
        .collect();
    let mass: f64 = rods.iter().map(|r| r.0).sum();
    let centre = rods.iter().map(|r| r.0 * r.1).sum::<Vector2<f64>>() / mass;
    let inertia: f64 = rods
        .iter()
        .map(|&(m, c, l)| m * (l * l / 12.0 + (c - centre).norm_squared()) + section.rho_i * l)
        .sum();
    let node = mesh.add_node(path, &g.name, centre.x, centre.y)?;
    let mut points = Vec::new();
    for k in (0..g.nx * g.ny).filter(|&k| touched[k]) {
        let (i, j) = grid_position(k, g.ny);
        let name = format!("{}[{i},{j}]", g.name);
        let arm = at(k) - centre;
        mesh.add_point(path, &name, Anchor { node, arm })?;
        points.push((name, arm));
    }
    mesh.bodies.push(RigidBody {
        name: g.name.clone(),
        node,
        angle: 0.0,
        points,
    });
    Ok(PointMass {
        node,
        mass,
        inertia,
    })
}

/// The bars of `g` not in its `omit` list, with their numbers `k`; each listed number must
/// name a bar, once.
fn kept_bars(path: &str, g: &GroundStructureSpec) -> Result<Vec<(usize, (usize, usize))>> {
    let all = bars(g.nx, g.ny);
    let mut omitted = vec![false; all.len()];
    for (n, &k) in g.omit.iter().enumerate() {
        let at = format!("{path}.omit[{n}]");
        match omitted.get_mut(k) {
            None => {
                let msg = format!("bar {k} does not exist (bars 0..{})", all.len());
                return Err(SceneError::new(at, msg));
            }
            Some(true) => return Err(SceneError::new(at, format!("bar {k} is listed twice"))),
            Some(o) => *o = true,
        }
    }
    Ok(all
        .into_iter()
        .enumerate()
        .filter(|(k, _)| !omitted[*k])
        .collect())
}

/// The grid of a ground structure, placed in the scene.
struct Grid {
    nx: usize,
    ny: usize,
    length: f64,
    height: f64,
    placement: Placement,
}

/// A local frame placed in the scene: its origin and the angle of its x axis.
pub(super) struct Placement {
    origin: Vector2<f64>,
    /// `(cos, sin)` of the frame's angle.
    rotation: (f64, f64),
}

impl Placement {
    /// The frame at `origin` (coordinates, or a node or point of `mesh`) turned by the
    /// angle given in radians or degrees, for the entry at `path`.
    pub(super) fn of(
        mesh: &Mesh,
        path: &str,
        origin: &PointSpec,
        rad: Option<f64>,
        deg: Option<f64>,
    ) -> Result<Self> {
        let angle = angle(path, rad, deg)?;
        let origin = match origin {
            PointSpec::Coordinates([x, y]) => Vector2::new(
                finite(&format!("{path}.origin[0]"), *x)?,
                finite(&format!("{path}.origin[1]"), *y)?,
            ),
            PointSpec::Node(n) => mesh.position(mesh.anchor(&format!("{path}.origin"), n)?),
        };
        Ok(Self {
            origin,
            rotation: (angle.cos(), angle.sin()),
        })
    }

    /// Scene position of local coordinates `[x, y]` (m).
    pub(super) fn position(&self, [lx, ly]: [f64; 2]) -> Vector2<f64> {
        let (c, s) = self.rotation;
        self.origin + Vector2::new(c * lx - s * ly, s * lx + c * ly)
    }
}

impl Grid {
    /// The grid of `g` at `path`: at least `2 × 1` nodes over `length > 0` and
    /// `height ≥ 0` (`> 0` with more than one row), its `origin` given by coordinates or by
    /// a node of `mesh`.
    fn of(mesh: &Mesh, path: &str, g: &GroundStructureSpec) -> Result<Self> {
        if g.nx < 2 || g.ny < 1 {
            return Err(SceneError::new(
                path,
                format!("needs nx >= 2 and ny >= 1, got {} × {}", g.nx, g.ny),
            ));
        }
        if g.nx.checked_mul(g.ny).is_none_or(|n| n > MAX_GRID_NODES) {
            return Err(SceneError::new(
                path,
                format!(
                    "{} × {} grid nodes: at most {MAX_GRID_NODES} per ground structure (its \
                     bars grow as their square); use a coarser grid or several ground structures",
                    g.nx, g.ny
                ),
            ));
        }
        let length = positive(&format!("{path}.length"), g.length)?;
        let height = if g.ny > 1 {
            positive(&format!("{path}.height"), g.height)?
        } else {
            non_negative(&format!("{path}.height"), g.height)?
        };
        Ok(Self {
            nx: g.nx,
            ny: g.ny,
            length,
            height,
            placement: Placement::of(mesh, path, &g.origin, g.angle, g.angle_deg)?,
        })
    }

    /// Scene position of grid node `(column, row)`: its [`local_coordinates`] rotated and
    /// moved to the origin.
    fn position(&self, column: usize, row: usize) -> Vector2<f64> {
        let local = local_coordinates(column, row, self.nx, self.ny, self.length, self.height);
        self.placement.position(local)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Brute force: a bar is kept when no third grid node lies on its segment.
    fn bars_by_geometry(nx: usize, ny: usize) -> Vec<(usize, usize)> {
        let n = nx * ny;
        let p = |k: usize| {
            let (c, r) = grid_position(k, ny);
            (c as i64, r as i64)
        };
        let mut out = Vec::new();
        for i in 0..n {
            for j in i + 1..n {
                let ((xi, yi), (xj, yj)) = (p(i), p(j));
                let blocked = (0..n).filter(|&k| k != i && k != j).any(|k| {
                    let (xk, yk) = p(k);
                    let cross = (xj - xi) * (yk - yi) - (yj - yi) * (xk - xi);
                    let within = (xk - xi) * (xk - xj) <= 0 && (yk - yi) * (yk - yj) <= 0;
                    cross == 0 && within
                });
                if !blocked {
                    out.push((i, j));
                }
            }
        }
        out
    }

    #[test]
    fn reference_grid_has_74_bars() {
        assert_eq!(bars(5, 3).len(), 74);
    }

    #[test]
    fn gcd_rule_matches_geometry() {
        for (nx, ny) in [(5, 3), (4, 4), (7, 2), (3, 1), (21, 5)] {
            assert_eq!(bars(nx, ny), bars_by_geometry(nx, ny), "{nx}×{ny}");
        }
    }

    #[test]
    fn nodes_are_column_major_bottom_to_top() {
        assert_eq!(grid_position(4, 3), (1, 1));
        let [x, y] = local_coordinates(1, 0, 5, 3, 1.0, 0.1);
        assert!((x - 0.25).abs() < 1e-15 && (y + 0.05).abs() < 1e-15);
    }
}
