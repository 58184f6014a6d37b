//! A state of a model carried to the same scene with twice the elements per frame bar (a
//! truss bar stays one element): each coarse node keeps its coordinates, and the node that
//! splits a coarse element in two takes the element's own deformed shape at its middle
//! ([`crate::mechanism::element::Kernel::middle`]: a beam's co-rotated cubic).
//!
//! It serves as a guess, not as a result: a run on the refined model starts each step's
//! Newton iterations from the prolonged coarse state ([`crate::simulate_guided`]).

use std::collections::HashMap;

use nalgebra::Vector2;

use crate::error::SettingsError;
use crate::mechanism::element::Kind;
use crate::mechanism::model::Model;

/// Where a node of the refined model takes its coordinates from.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Source {
    /// A node of the coarse model at the same place.
    Node(usize),
    /// The middle of a coarse element.
    Middle(usize),
}

/// The map from a model's coordinates to those of the same scene with twice the elements
/// per bar.
#[derive(Debug, Clone, PartialEq)]
pub struct Prolongation {
    sources: Vec<Source>,
}

impl Prolongation {
    /// The prolongation from `coarse` to `fine`: bars are matched by name, the `k`-th
    /// element of a coarse bar by the fine bar's elements `2k` and `2k + 1`, and nodes in
    /// no bar by name.
    ///
    /// # Errors
    /// A [`SettingsError`] naming the bar or node where `fine` is not `coarse` with each
    /// element split in two (checked on the reference positions).
    pub fn between(coarse: &Model, fine: &Model) -> Result<Self, SettingsError> {
        let mismatch = |what: String| {
            SettingsError::new(
                "fine model",
                format!("is not the coarse model with every element split in two: {what}"),
            )
        };
        let tol = 1e-9 * coarse.size();
        let mut sources: Vec<Option<Source>> = vec![None; fine.nodes.len()];
        let assign =
            |sources: &mut Vec<Option<Source>>, node: usize, source: Source, at: Vector2<f64>| {
                let name = &fine.nodes[node].name;
                if (fine.nodes[node].position - at).norm() > tol {
                    return Err(mismatch(format!(
                        "node {name} is not where the coarse mesh puts it"
                    )));
                }
                match sources[node].replace(source) {
                    Some(other) if other != source => {
                        Err(mismatch(format!("node {name} has two origins")))
                    }
                    _ => Ok(()),
                }
            };
        let fine_bars: HashMap<&str, usize> = fine
            .bars
            .iter()
            .enumerate()
            .map(|(k, b)| (b.name.as_str(), k))
            .collect();
        for bar in &coarse.bars {
            // A truss bar is one element in both.
            let halves = if bar.kind == Kind::Truss { 1 } else { 2 };
            let split = fine_bars.get(bar.name.as_str()).map(|&k| &fine.bars[k]);
            let Some(split) = split.filter(|s| s.elements.len() == halves * bar.elements.len())
            else {
                return Err(mismatch(format!(
                    "bar {} is missing or not split in two",
                    bar.name
                )));
            };
            if halves == 1 {
                let ([a, b], [fa, fb]) = (
                    coarse.elements[bar.elements.start].nodes,
                    fine.elements[split.elements.start].nodes,
                );
                assign(&mut sources, fa, Source::Node(a), coarse.nodes[a].position)?;
                assign(&mut sources, fb, Source::Node(b), coarse.nodes[b].position)?;
                continue;
            }
            for (k, e) in bar.elements.clone().enumerate() {
                let [a, b] = coarse.elements[e].nodes;
                let (pa, pb) = (coarse.nodes[a].position, coarse.nodes[b].position);
                let first = &fine.elements[split.elements.start + 2 * k];
                let second = &fine.elements[split.elements.start + 2 * k + 1];
                if first.nodes[1] != second.nodes[0] {
                    return Err(mismatch(format!(
                        "the halves of bar {} do not meet",
                        bar.name
                    )));
                }
                assign(&mut sources, first.nodes[0], Source::Node(a), pa)?;
                assign(
                    &mut sources,
                    first.nodes[1],
                    Source::Middle(e),
                    0.5 * (pa + pb),
                )?;
                assign(&mut sources, second.nodes[1], Source::Node(b), pb)?;
            }
        }
        for node in 0..fine.nodes.len() {
            if sources[node].is_none() {
                let Some(c) = coarse.node_index(&fine.nodes[node].name) else {
                    return Err(mismatch(format!(
                        "node {} is in no bar and not in the coarse model",
                        fine.nodes[node].name
                    )));
                };
                assign(
                    &mut sources,
                    node,
                    Source::Node(c),
                    coarse.nodes[c].position,
                )?;
            }
        }
        Ok(Self {
            sources: sources.into_iter().flatten().collect(),
        })
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
            };
            out[3 * node..3 * node + 3].copy_from_slice(&value);
        }
    }
}
