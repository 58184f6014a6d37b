//! A state of a model carried to the same scene with twice the elements per frame bar (a
//! truss bar stays one element) and per side of a member's cell: each coarse node keeps its
//! coordinates, the node that splits a coarse element in two takes the element's own
//! deformed shape at its middle ([`crate::mechanism::element::Kernel::middle`]: a beam's
//! co-rotated cubic), and a node inside or on the side of a coarse cell the cell's
//! bilinear interpolation of its corners.
//!
//! It serves as a guess, not as a result: a run on the refined model starts each step's
//! Newton iterations from the prolonged coarse state ([`crate::simulate_guided`]).

use std::collections::HashMap;

use nalgebra::Vector2;

use crate::error::SettingsError;
use crate::mechanism::element::Kind;
use crate::mechanism::model::{Bar, Model};

/// Where a node of the refined model takes its coordinates from.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Source {
    /// A node of the coarse model at the same place.
    Node(usize),
    /// The middle of a coarse element.
    Middle(usize),
    /// A point of a coarse member's cell, with the bilinear weights of its corners.
    Cell(usize, [f64; 4]),
}

/// The map from a model's coordinates to those of the same scene with twice the elements
/// per bar.
#[derive(Debug, Clone, PartialEq)]
pub struct Prolongation {
    sources: Vec<Source>,
}

impl Prolongation {
    /// The prolongation from `coarse` to `fine`: bars are matched by name, the `k`-th
    /// element of a coarse bar by the fine bar's elements `2k` and `2k + 1`, members by
    /// name, each fine member node a coarse one of its name or a point of the coarse cell
    /// it lies in, and the other nodes by name.
    ///
    /// # Errors
    /// A [`SettingsError`] naming the bar or node where `fine` is not `coarse` with each
    /// element split in two (checked on the reference positions).
    pub fn between(coarse: &Model, fine: &Model) -> Result<Self, SettingsError> {
        let mut m = Matching {
            coarse,
            fine,
            tol: 1e-9 * coarse.size(),
            sources: vec![None; fine.nodes.len()],
        };
        let fine_bars: HashMap<&str, usize> = fine
            .bars
            .iter()
            .enumerate()
            .map(|(k, b)| (b.name.as_str(), k))
            .collect();
        for bar in &coarse.bars {
            m.bar(
                bar,
                fine_bars.get(bar.name.as_str()).map(|&k| &fine.bars[k]),
            )?;
        }
        m.members()?;
        m.outside_bars()?;
        Ok(Self {
            sources: m.sources.into_iter().flatten().collect(),
        })
    }

    /// The coarse node that fine node `node` is, or `None` for an element's middle or a
    /// point of a cell.
    pub fn coarse_node(&self, node: usize) -> Option<usize> {
        match self.sources[node] {
            Source::Node(c) => Some(c),
            Source::Middle(_) | Source::Cell(..) => None,
        }
    }

    /// Coordinates of the refined model (`3` per node) for coordinates `q` of `coarse`.
    pub fn apply(&self, coarse: &Model, q: &[f64], out: &mut [f64]) {
        for (node, source) in self.sources.iter().enumerate() {
            let value = match *source {
                Source::Node(c) => [q[3 * c], q[3 * c + 1], q[3 * c + 2]],
                Source::Middle(e) => {
                    let el = &coarse.elements[e];
                    el.kernel.middle(&el.gather(q))
                }
                Source::Cell(c, weights) => {
                    let mut value = [0.0; 3];
                    for (&corner, w) in coarse.cells[c].nodes.iter().zip(weights) {
                        for (v, &qi) in value.iter_mut().zip(&q[3 * corner..3 * corner + 3]) {
                            *v += w * qi;
                        }
                    }
                    value
                }
            };
            out[3 * node..3 * node + 3].copy_from_slice(&value);
        }
    }
}

/// The sources of the fine model's nodes as they are matched, checked on the reference
/// positions (within `tol`).
struct Matching<'m> {
    coarse: &'m Model,
    fine: &'m Model,
    tol: f64,
    sources: Vec<Option<Source>>,
}

/// The refusal of a fine model that is not the coarse one split in two.
fn mismatch(what: String) -> SettingsError {
    SettingsError::new(
        "fine model",
        format!("is not the coarse model with every element split in two: {what}"),
    )
}

impl Matching<'_> {
    /// Fine node `node` takes its coordinates from `source`, which puts it at `at`.
    fn assign(
        &mut self,
        node: usize,
        source: Source,
        at: Vector2<f64>,
    ) -> Result<(), SettingsError> {
        let name = &self.fine.nodes[node].name;
        if (self.fine.nodes[node].position - at).norm() > self.tol {
            return Err(mismatch(format!(
                "node {name} is not where the coarse mesh puts it"
            )));
        }
        match self.sources[node].replace(source) {
            Some(other) if other != source => Err(mismatch(format!("node {name} has two origins"))),
            _ => Ok(()),
        }
    }

    /// The nodes of coarse `bar` and of its fine version `split`: each element's ends and
    /// the node between its halves; a truss bar, one element in both, its ends.
    fn bar(&mut self, bar: &Bar, split: Option<&Bar>) -> Result<(), SettingsError> {
        let (coarse, fine) = (self.coarse, self.fine);
        let halves = if bar.kind == Kind::Truss { 1 } else { 2 };
        let Some(split) = split.filter(|s| s.elements.len() == halves * bar.elements.len()) else {
            return Err(mismatch(format!(
                "bar {} is missing or not split in two",
                bar.name
            )));
        };
        for (k, e) in bar.elements.clone().enumerate() {
            let [a, b] = coarse.elements[e].nodes;
            let (pa, pb) = (coarse.nodes[a].position, coarse.nodes[b].position);
            let first = &fine.elements[split.elements.start + halves * k];
            let last = &fine.elements[split.elements.start + halves * k + halves - 1];
            if halves == 2 {
                if first.nodes[1] != last.nodes[0] {
                    return Err(mismatch(format!(
                        "the halves of bar {} do not meet",
                        bar.name
                    )));
                }
                self.assign(first.nodes[1], Source::Middle(e), 0.5 * (pa + pb))?;
            }
            self.assign(first.nodes[0], Source::Node(a), pa)?;
            self.assign(last.nodes[1], Source::Node(b), pb)?;
        }
        Ok(())
    }

    /// The nodes of each member of `fine`, whose cells are the coarse member's split in two
    /// along each side: a node of a coarse node's name is that node, any other the point of
    /// the coarse cell it lies in.
    fn members(&mut self) -> Result<(), SettingsError> {
        let (coarse, fine) = (self.coarse, self.fine);
        for member in &fine.members {
            let Some(parent) = coarse.members.iter().find(|m| m.name == member.name) else {
                return Err(mismatch(format!(
                    "member {} is not in the coarse model",
                    member.name
                )));
            };
            if member.cells.len() != 4 * parent.cells.len() {
                return Err(mismatch(format!(
                    "member {} has {} cells, not four times the coarse {}",
                    member.name,
                    member.cells.len(),
                    parent.cells.len()
                )));
            }
            for node in member.cells.clone().flat_map(|c| fine.cells[c].nodes) {
                if self.sources[node].is_some() {
                    continue;
                }
                let at = fine.nodes[node].position;
                if let Some(c) = coarse.node_index(&fine.nodes[node].name) {
                    self.assign(node, Source::Node(c), coarse.nodes[c].position)?;
                    continue;
                }
                let Some((cell, weights)) = self.locate(parent.cells.clone(), at) else {
                    let name = &fine.nodes[node].name;
                    return Err(mismatch(format!(
                        "node {name} lies in no cell of member {}",
                        member.name
                    )));
                };
                let corners = coarse.cells[cell].nodes.map(|n| coarse.nodes[n].position);
                let mapped = corners
                    .iter()
                    .zip(weights)
                    .map(|(p, w)| w * p)
                    .sum::<Vector2<f64>>();
                self.assign(node, Source::Cell(cell, weights), mapped)?;
            }
        }
        Ok(())
    }

    /// The coarse cell among `cells` that the point `at` lies in (on its sides too), and
    /// the bilinear weights of its corners there: a member's cells are parallelograms, whose
    /// map from `(ξ, η)` in the unit square is affine and inverted exactly.
    fn locate(&self, cells: std::ops::Range<usize>, at: Vector2<f64>) -> Option<(usize, [f64; 4])> {
        let slack = self.tol / self.coarse.size().max(f64::MIN_POSITIVE);
        cells.into_iter().find_map(|c| {
            let [p0, p1, _, p3] = self.coarse.cells[c]
                .nodes
                .map(|n| self.coarse.nodes[n].position);
            let sides = nalgebra::Matrix2::from_columns(&[p1 - p0, p3 - p0]);
            let local = sides.try_inverse()? * (at - p0);
            let inside = |t: f64| (-slack..=1.0 + slack).contains(&t);
            (inside(local.x) && inside(local.y)).then(|| {
                let (xi, eta) = (local.x.clamp(0.0, 1.0), local.y.clamp(0.0, 1.0));
                (
                    c,
                    [
                        (1.0 - xi) * (1.0 - eta),
                        xi * (1.0 - eta),
                        xi * eta,
                        (1.0 - xi) * eta,
                    ],
                )
            })
        })
    }

    /// The nodes in no bar (rigid bodies' centres), matched by name.
    fn outside_bars(&mut self) -> Result<(), SettingsError> {
        for node in 0..self.fine.nodes.len() {
            if self.sources[node].is_none() {
                let name = &self.fine.nodes[node].name;
                let Some(c) = self.coarse.node_index(name) else {
                    return Err(mismatch(format!(
                        "node {name} is in no bar and not in the coarse model"
                    )));
                };
                self.assign(node, Source::Node(c), self.coarse.nodes[c].position)?;
            }
        }
        Ok(())
    }
}
