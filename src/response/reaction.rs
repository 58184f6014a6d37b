//! The force a joint transmits, `|F| = |(λₖ)|` over its separation rows (N): a pin's or a
//! hinge's two components along x and y, a slider's normal force. Condensed over the
//! motion like a drive's torque, with its peak: what a bearing is sized by.

use super::aggregation::Aggregation;
use super::arguments::{component_and_options, joint_index};
use super::{Context, Family, Kind, Known, Partials, Sample, Weighting};
use crate::joint::planar::Law;
use crate::mechanism::model::Model;

pub(super) const KIND: Kind = Kind {
    name: "reaction",
    syntax: "reaction:JOINT[:p=P|ks=RHO,scale=S]",
    doc: "the force a joint transmits (N): the magnitude of its rows' forces in position \
          (a pin's or hinge's x and y, a slider's normal force; not a drive's torque or a \
          locked rotation's moment), condensed over the motion by a p-mean (p=P) or KS mean \
          as torque, its peak reported",
    peak: true,
    unit: "N",
    spatial: Some("reaction:JOINT[:OPTIONS]"),
    linear: false,
    parse: Some(parse),
};

fn parse(model: &Model, rest: Option<&str>) -> Result<Box<dyn Family>, String> {
    let (name, options) = component_and_options(rest)?;
    let name = name.ok_or("name the joint: reaction:JOINT")?;
    let j = joint_index(model, name)?;
    let rows: Vec<usize> = model
        .joint_rows(j)
        .filter(|&k| matches!(model.rows[k].law, Law::Separation { .. }))
        .collect();
    if rows.is_empty() {
        return Err(format!("joint '{name}' holds no position: it has no force"));
    }
    let aggregation = Aggregation::from_options(&options)?;
    Ok(Box::new(Reaction { rows, aggregation }))
}

/// The magnitude of a joint's force over its separation rows, an aggregate whose points
/// are the states.
#[derive(Debug)]
struct Reaction {
    /// The joint's separation rows (orthonormal directions: the force's components).
    rows: Vec<usize>,
    /// How the magnitudes are condensed.
    aggregation: Aggregation,
}

impl Reaction {
    fn magnitude(&self, lam: &[f64]) -> f64 {
        self.rows
            .iter()
            .map(|&k| lam[k] * lam[k])
            .sum::<f64>()
            .sqrt()
    }
}

impl Family for Reaction {
    fn weighting(&self) -> Weighting {
        Weighting::Mean
    }

    fn integrand(&self, _: &Context, at: Sample, known: Known) -> f64 {
        self.aggregation
            .point(self.magnitude(at.lam), known.reference)
            .0
    }

    /// `∂φ/∂λₖ = φ'(|F|) λₖ/|F|`, zero at `|F| = 0` (where `φ'` is, for `p ≥ 2`).
    fn add_partials(&self, _: &Context, at: Sample, known: Known, scale: f64, g: Partials) {
        let force = self.magnitude(at.lam);
        if force == 0.0 {
            return;
        }
        let slope = self.aggregation.point(force, known.reference).1;
        for &k in &self.rows {
            g.lam[k] += scale * slope * at.lam[k] / force;
        }
    }

    fn aggregation(&self) -> Option<Aggregation> {
        Some(self.aggregation)
    }

    fn peak(&self, _: &Context, at: Sample) -> f64 {
        self.magnitude(at.lam)
    }
}
