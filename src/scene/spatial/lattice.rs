//! Spatial ground structures: the bars a box lattice allows (paper Section 3.1, in space).
//!
//! Nodes on an `nx × ny × nz` lattice over a link of `length × height × width`, numbered
//! `(i ny + j) nz + k` (column `i` along the length, row `j` across its height, layer `k`
//! across its width), local coordinates `x ∈ [0, L]`, `y ∈ [−H/2, H/2]`, `z ∈ [−W/2, W/2]`
//! (a single row or layer in the middle). Which pairs `a < b` are joined is the
//! `connectivity`, over the steps `(Δi, Δj, Δk)` between them:
//!
//! - `"full"` (default): every bar whose segment holds no third lattice node,
//!   `gcd(|Δi|, |Δj|, |Δk|) = 1` — overlapping collinear bars dropped; with `nz = 1`, the
//!   planar ground structure's bars in its order;
//! - `"diagonals"`: steps of at most one in each direction — edges, face and body diagonals;
//! - `"faces"`: edges and face diagonals (at most two directions);
//! - `"edges"`: the lattice's edges.
//!
//! Bars are ordered by `(a, b)` lexicographically and named `NAME/bar{m}`, nodes
//! `NAME[i,j,k]`; each bar is a beam of the structure's section (or a truss bar), with a
//! design variable of its own unless the structure is `fixed`. The lattice is placed by a
//! frame: `origin` and `orientation`. A ground structure expands into the scene's nodes and
//! beams, which are built and checked as the rest.

use super::orientation::rotation;
use super::spec::{Connectivity, SpatialBeamSpec, SpatialGroundStructureSpec, SpatialNodeSpec};
use crate::error::SceneError;
use crate::limits::{MAX_ELEMENTS, MAX_GRID_NODES};

/// Lattice node `n` as `(i, j, k)`.
fn position(n: usize, ny: usize, nz: usize) -> [usize; 3] {
    [n / (ny * nz), (n / nz) % ny, n % nz]
}

fn gcd(a: usize, b: usize) -> usize {
    if b == 0 {
        a
    } else {
        gcd(b, a % b)
    }
}

/// Whether `connectivity` joins two nodes `steps` apart.
fn joins(connectivity: Connectivity, steps: [usize; 3]) -> bool {
    let moved = steps.iter().filter(|&&s| s > 0).count();
    let unit = steps.iter().all(|&s| s <= 1);
    match connectivity {
        Connectivity::Full => gcd(gcd(steps[0], steps[1]), steps[2]) == 1,
        Connectivity::Diagonals => unit,
        Connectivity::Faces => unit && moved <= 2,
        Connectivity::Edges => unit && moved == 1,
    }
}

/// The bars `(a, b)`, `a < b`, of an `nx × ny × nz` lattice in lexicographic order.
///
/// # Errors
/// A [`SceneError`] at `path` where they would pass [`MAX_ELEMENTS`];
/// [`crate::SolveError::Interrupted`] where the caller asks to stop.
pub fn lattice_bars(
    path: &str,
    [nx, ny, nz]: [usize; 3],
    connectivity: Connectivity,
) -> Result<Vec<(usize, usize)>, crate::error::Error> {
    let n = nx * ny * nz;
    let mut out = Vec::new();
    for a in 0..n {
        crate::poll()?;
        let pa = position(a, ny, nz);
        for b in a + 1..n {
            let pb = position(b, ny, nz);
            if joins(connectivity, [0, 1, 2].map(|d| pa[d].abs_diff(pb[d]))) {
                out.push((a, b));
            }
        }
        if out.len() > MAX_ELEMENTS {
            return Err(SceneError::new(
                path,
                format!("more than {MAX_ELEMENTS} bars: a coarser lattice or connectivity"),
            )
            .into());
        }
    }
    Ok(out)
}

/// The nodes and beams ground structure `g` at `path` expands into (module docs).
///
/// # Errors
/// A [`SceneError`] naming a lattice of no nodes or past [`MAX_GRID_NODES`], or one whose
/// extent is negative or not finite (the rest is checked as the scene's nodes and beams).
pub fn expand(
    path: &str,
    g: &SpatialGroundStructureSpec,
) -> Result<(Vec<SpatialNodeSpec>, Vec<SpatialBeamSpec>), crate::error::Error> {
    let counts = [g.nx, g.ny, g.nz];
    let n = counts.iter().try_fold(1usize, |p, &c| p.checked_mul(c));
    if counts.contains(&0) || n.is_none_or(|n| n > MAX_GRID_NODES) {
        return Err(SceneError::new(
            path,
            format!(
                "{} × {} × {} nodes: at least one each way, at most {MAX_GRID_NODES} in all",
                g.nx, g.ny, g.nz
            ),
        )
        .into());
    }
    for (what, value) in [
        ("length", g.length),
        ("height", g.height),
        ("width", g.width),
    ] {
        if !(value.is_finite() && value >= 0.0) {
            return Err(SceneError::new(
                format!("{path}.{what}"),
                format!("{value}: must be finite and not negative"),
            )
            .into());
        }
    }
    let rotation = match &g.orientation {
        Some(o) => rotation(&format!("{path}.orientation"), o)?,
        None => nalgebra::UnitQuaternion::identity(),
    };
    let origin = nalgebra::Vector3::from(g.origin);
    let fraction = |i: usize, n: usize| {
        if n > 1 {
            i as f64 / (n - 1) as f64
        } else {
            0.5
        }
    };
    let name = |p: [usize; 3]| format!("{}[{},{},{}]", g.name, p[0], p[1], p[2]);
    let nodes = (0..g.nx * g.ny * g.nz)
        .map(|m| {
            let p = position(m, g.ny, g.nz);
            let local = nalgebra::Vector3::new(
                g.length * fraction(p[0], g.nx),
                g.height * (fraction(p[1], g.ny) - 0.5),
                g.width * (fraction(p[2], g.nz) - 0.5),
            );
            SpatialNodeSpec {
                name: name(p),
                position: (origin + rotation * local).into(),
                ..SpatialNodeSpec::default()
            }
        })
        .collect();
    let beams = lattice_bars(path, counts, g.connectivity)?
        .into_iter()
        .enumerate()
        .map(|(m, (a, b))| SpatialBeamSpec {
            name: format!("{}/bar{m}", g.name),
            nodes: [a, b].map(|n| name(position(n, g.ny, g.nz))),
            section: g.section.clone(),
            kind: g.kind,
            split: g.split,
            fixed: g.fixed,
            ..SpatialBeamSpec::default()
        })
        .collect();
    Ok((nodes, beams))
}
