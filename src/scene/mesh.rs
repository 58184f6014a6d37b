//! The mesh: named nodes, and straight bars between them, each split into co-rotational
//! beam elements ([`crate::mechanism::element::beam`]) or, in a truss, one truss bar
//! ([`crate::mechanism::element::truss`]).
//!
//! Bars come from the scene's beams and from its ground structures
//! ([`super::ground_structure`]). A bar of `split` elements (its beam's or ground
//! structure's, or its own in the scene's `splits`) gets `split − 1` interior nodes of its
//! own, evenly spaced and named `NAME:k`. Once every bar is known, each must be
//! longer than the round-off of the scene's coordinates.

use std::collections::{BTreeMap, HashMap};

use nalgebra::Vector2;

use super::design::Variables;
use super::section::{self, Sections};
use super::spec::{BeamSpec, NodeSpec};
use super::validate::{each, finite, unknown, Listed, Result};
use crate::body::planar::RigidBody;
use crate::error::SceneError;
use crate::joint::planar::Anchor;
use crate::limits::{MAX_ELEMENTS, MAX_NODES, MAX_SPLIT};
use crate::mechanism::element::Kind;
use crate::mechanism::model::{size_of, Bar, Cell, Element, Member, Node};
use crate::mechanism::section::Section;

/// Mesh under construction.
#[derive(Default)]
pub(super) struct Mesh {
    /// Nodes, named ones first.
    pub(super) nodes: Vec<Node>,
    /// Node of each name.
    index: HashMap<String, usize>,
    /// Elements, bar by bar.
    pub(super) elements: Vec<Element>,
    /// Bars.
    pub(super) bars: Vec<Bar>,
    /// The continuum members' cells.
    pub(super) cells: Vec<Cell>,
    /// Continuum members.
    pub(super) members: Vec<Member>,
    /// Scene path of each bar, for messages.
    bar_paths: Vec<String>,
    /// Name of each component.
    pub(super) components: Vec<String>,
    /// Design variables of the bars.
    pub(super) variables: Variables,
    /// Rigid bodies.
    pub(super) bodies: Vec<RigidBody>,
    /// The points of rigid bodies, by name (`body.point`).
    points: HashMap<String, Anchor>,
    /// Elements of single bars by name, overriding their `split`, and whether a bar has
    /// taken each.
    splits: HashMap<String, (usize, bool)>,
}

/// What a new bar is made of and where it belongs.
pub(super) struct BarSpec<'a> {
    /// Scene path, for messages.
    pub(super) path: String,
    /// Name, and prefix of its interior nodes' names.
    pub(super) name: String,
    /// End nodes.
    pub(super) ends: [usize; 2],
    /// Section of its elements: its index in the scene's sections, and its properties.
    pub(super) section: (usize, &'a Section),
    /// Number of elements.
    pub(super) split: usize,
    /// Its elements' kind.
    pub(super) kind: Kind,
    /// Component.
    pub(super) component: usize,
    /// Design variable, none for a bar at full density.
    pub(super) variable: Option<usize>,
}

impl Mesh {
    /// An empty mesh whose bars named in `splits` get that many elements.
    pub(super) fn with_splits(splits: &BTreeMap<String, usize>) -> Self {
        Self {
            splits: splits
                .iter()
                .map(|(k, &v)| (k.clone(), (v, false)))
                .collect(),
            ..Self::default()
        }
    }

    /// Every bar has a name of its own, and every entry of the scene's `splits` names one.
    pub(super) fn check_bar_names(&self) -> Result<()> {
        let mut seen = HashMap::new();
        for (bar, path) in self.bars.iter().zip(&self.bar_paths) {
            if let Some(first) = seen.insert(bar.name.as_str(), path) {
                return Err(SceneError::new(
                    path,
                    format!(
                        "duplicate bar name '{}': {first} is called so too",
                        bar.name
                    ),
                ));
            }
        }
        self.check_splits()
    }

    /// Every entry of the scene's `splits` names a bar of the mesh.
    fn check_splits(&self) -> Result<()> {
        let mut unused: Vec<&String> = self
            .splits
            .iter()
            .filter(|(_, v)| !v.1)
            .map(|(k, _)| k)
            .collect();
        unused.sort();
        match unused.first() {
            None => Ok(()),
            Some(name) => Err(SceneError::new(
                format!("splits.{name}"),
                "no deformable bar is called so (a ground structure's bars are NAME/barK, a \
                 beam's its name; a rigid frame has none)",
            )),
        }
    }

    /// The scene's named nodes.
    pub(super) fn add_nodes(&mut self, nodes: &[NodeSpec]) -> Listed<usize> {
        each(nodes, |k, n| {
            self.add_node(&format!("nodes[{k}] ({})", n.name), &n.name, n.x, n.y)
        })
    }

    /// A node at `(x, y)` called `name`, which no other node may have.
    pub(super) fn add_node(&mut self, path: &str, name: &str, x: f64, y: f64) -> Result<usize> {
        finite(&format!("{path}.x"), x)?;
        finite(&format!("{path}.y"), y)?;
        if self.index.contains_key(name) || self.points.contains_key(name) {
            return Err(SceneError::new(
                path,
                format!("duplicate node name '{name}'"),
            ));
        }
        if self.nodes.len() == MAX_NODES {
            return Err(SceneError::new(
                path,
                format!("the model would have more than {MAX_NODES} nodes; split its bars less or use fewer of them"),
            ));
        }
        self.index.insert(name.to_string(), self.nodes.len());
        self.nodes.push(Node {
            name: name.to_string(),
            position: Vector2::new(x, y),
        });
        Ok(self.nodes.len() - 1)
    }

    /// A point of a rigid body called `name`, which no node or other point may be called.
    pub(super) fn add_point(&mut self, path: &str, name: &str, anchor: Anchor) -> Result<()> {
        if self.index.contains_key(name) || self.points.contains_key(name) {
            return Err(SceneError::new(
                path,
                format!("duplicate name '{name}': a node or point is already called so"),
            ));
        }
        self.points.insert(name.to_string(), anchor);
        Ok(())
    }

    /// Where `name` at `path` is: a node (a rigid body's is its centre of mass), or a point
    /// of a rigid body (`body.point`).
    pub(super) fn anchor(&self, path: &str, name: &str) -> Result<Anchor> {
        match (self.index.get(name), self.points.get(name)) {
            (Some(&node), _) => Ok(Anchor::at(node)),
            (None, Some(&anchor)) => Ok(anchor),
            (None, None) => Err(unknown(path, "node or rigid-body point", name)),
        }
    }

    /// Reference position of `anchor` (m).
    pub(super) fn position(&self, anchor: Anchor) -> Vector2<f64> {
        self.nodes[anchor.node].position + anchor.arm
    }

    /// The node called `name` at `path`.
    pub(super) fn node(&self, path: &str, name: &str) -> Result<usize> {
        match (self.index.get(name), self.points.get(name)) {
            (Some(&node), _) => Ok(node),
            (None, Some(anchor)) => Err(SceneError::new(
                path,
                format!(
                    "'{name}' is a point of the rigid body '{}': only joints attach to a body's \
                     points; loads, point masses and the tip act on its centre, '{}'",
                    self.nodes[anchor.node].name, self.nodes[anchor.node].name
                ),
            )),
            (None, None) => Err(unknown(path, "node", name)),
        }
    }

    /// The component called `name`, added on first use.
    pub(super) fn component(&mut self, name: &str) -> usize {
        self.components
            .iter()
            .position(|c| c == name)
            .unwrap_or_else(|| {
                self.components.push(name.to_string());
                self.components.len() - 1
            })
    }

    /// The scene's beams, each a bar between two named nodes (default name `beams[k]`,
    /// default component `frame`).
    pub(super) fn add_beams(&mut self, beams: &[BeamSpec], sections: &Sections) -> Listed<()> {
        each(beams, |k, b| {
            self.add_beam(&format!("beams[{k}]"), k, b, sections)
        })
    }

    /// The beam `b`, the `k`-th of the scene, at `path`.
    fn add_beam(&mut self, path: &str, k: usize, b: &BeamSpec, sections: &Sections) -> Result<()> {
        let name = b.name.clone().unwrap_or_else(|| format!("beams[{k}]"));
        let ends = [
            self.node(&format!("{path}.nodes[0]"), &b.nodes[0])?,
            self.node(&format!("{path}.nodes[1]"), &b.nodes[1])?,
        ];
        let section = section::find(sections, path, &b.section)?;
        let component = self.component(b.component.as_deref().unwrap_or("frame"));
        let variable = self.variables.of_beam(path, &name, b)?;
        self.add_bar(BarSpec {
            path: path.to_string(),
            name,
            ends,
            section,
            split: b.split,
            kind: b.kind.into(),
            component,
            variable,
        })
    }

    /// A straight bar split into `split` elements (or as many as the scene's `splits` gives
    /// it), interior nodes named `NAME:k` (its length is checked by [`Mesh::size`] once the
    /// whole mesh is known).
    pub(super) fn add_bar(&mut self, mut b: BarSpec) -> Result<()> {
        let [a, z] = b.ends;
        let length = (self.nodes[z].position - self.nodes[a].position).norm();
        let mut split_at = format!("{}.split", b.path);
        if let Some((split, used)) = self.splits.get_mut(&b.name) {
            (b.split, *used) = (*split, true);
            split_at = format!("splits.{}", b.name);
        }
        let chain = self.chain(&b, &split_at)?;
        let first = self.elements.len();
        let bar = self.bars.len();
        for w in chain.windows(2) {
            let (x1, x2) = (self.nodes[w[0]].position, self.nodes[w[1]].position);
            self.elements.push(Element {
                kernel: b.kind.element(x1, x2, *b.section.1),
                nodes: [w[0], w[1]],
                bar,
            });
        }
        self.bars.push(Bar {
            name: b.name,
            component: b.component,
            variable: b.variable,
            elements: first..self.elements.len(),
            volume: b.section.1.area * length,
            section: b.section.0,
            kind: b.kind,
        });
        self.bar_paths.push(b.path);
        Ok(())
    }

    /// The nodes along bar `b`, end to end: its ends and `split − 1` new interior nodes
    /// (`split_at`: where the scene gives the number).
    fn chain(&mut self, b: &BarSpec, split_at: &str) -> Result<Vec<usize>> {
        let [a, z] = b.ends;
        let (xa, xz) = (self.nodes[a].position, self.nodes[z].position);
        if b.split == 0 || b.split > MAX_SPLIT {
            return Err(SceneError::new(
                split_at,
                format!("must be from 1 to {MAX_SPLIT}, got {}", b.split),
            ));
        }
        if b.kind == Kind::Truss && b.split != 1 {
            return Err(SceneError::new(
                split_at,
                format!(
                    "a truss bar is one element, got {}: pins at its inner nodes would make it a \
                     mechanism (a bar that bends is kind = \"frame\")",
                    b.split
                ),
            ));
        }
        if self.elements.len() + b.split > MAX_ELEMENTS {
            return Err(SceneError::new(
                &b.path,
                format!("the model would have more than {MAX_ELEMENTS} elements; split its bars less or use fewer of them"),
            ));
        }
        let mut chain = vec![a];
        for k in 1..b.split {
            let p = xa + (xz - xa) * (k as f64 / b.split as f64);
            chain.push(self.add_node(&b.path, &format!("{}:{k}", b.name), p.x, p.y)?);
        }
        chain.push(z);
        Ok(chain)
    }

    /// The scene's size, the diagonal of the bounding box ([`size_of`]) of its nodes and
    /// rigid-body points, once the mesh is known to have beams or bodies, no beam of zero
    /// length.
    pub(super) fn size(&self) -> Result<f64> {
        if self.elements.is_empty() && self.cells.is_empty() && self.bodies.is_empty() {
            return Err(SceneError::new(
                "scene",
                "has no beams, continuum members or rigid bodies",
            ));
        }
        let points = self.points.values().map(|&a| self.position(a));
        let size = size_of(self.nodes.iter().map(|n| n.position).chain(points));
        self.check_lengths(size)?;
        Ok(size)
    }

    /// Every bar has a finite length above 1e-9 of the model's size and above the round-off
    /// of its end coordinates (1e-12 of their magnitude).
    fn check_lengths(&self, size: f64) -> Result<()> {
        if !size.is_finite() {
            return Err(SceneError::new(
                "nodes",
                format!("the scene spans {size} m: coordinates too large to compute with"),
            ));
        }
        for (bar, path) in self.bars.iter().zip(&self.bar_paths) {
            let (a, z) = (
                self.elements[bar.elements.start].nodes[0],
                self.elements[bar.elements.end - 1].nodes[1],
            );
            let (xa, xz) = (self.nodes[a].position, self.nodes[z].position);
            let length = (xz - xa).norm();
            let too_short = length.partial_cmp(&(1e-9 * size).max(1e-12 * (xa.norm() + xz.norm())))
                != Some(std::cmp::Ordering::Greater);
            if too_short {
                let (na, nz) = (&self.nodes[a].name, &self.nodes[z].name);
                return Err(SceneError::new(path, format!("zero-length bar: nodes '{na}' and '{nz}' coincide ({length:.1e} m apart in a scene of {size:.3} m)")));
            }
        }
        Ok(())
    }
}
