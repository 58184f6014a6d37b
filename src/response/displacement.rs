//! A node's displacement along a direction: at the final time, or integrated over the
//! motion.

use super::arguments::node_and_direction;
use super::{Context, Family, Kind, Known, Partials, Sample, Weighting};
use crate::mechanism::model::Model;

pub(super) const FINAL: Kind = Kind {
    name: "displacement",
    syntax: "displacement:NODE:DX,DY",
    doc: "a node's displacement along the direction (DX, DY), normalized, at the final time \
          or the static equilibrium (m)",
    peak: false,
    unit: "m",
    spatial: None,
    linear: true,
    parse: Some(|model, rest| parse(model, rest, Weighting::Final)),
};

pub(super) const INTEGRATED: Kind = Kind {
    name: "integrated_displacement",
    syntax: "integrated_displacement:NODE:DX,DY",
    doc: "the time integral of a node's displacement along the direction (DX, DY), \
          normalized (m s)",
    peak: false,
    unit: "m s",
    spatial: None,
    linear: true,
    parse: Some(|model, rest| parse(model, rest, Weighting::Integral)),
};

fn parse(
    model: &Model,
    rest: Option<&str>,
    weighting: Weighting,
) -> Result<Box<dyn Family>, String> {
    let (node, direction) = node_and_direction(model, rest)?;
    Ok(Box::new(Displacement {
        node,
        direction,
        weighting,
    }))
}

/// `d · u` of a node, `d` a unit direction.
#[derive(Debug)]
struct Displacement {
    node: usize,
    direction: [f64; 2],
    weighting: Weighting,
}

impl Family for Displacement {
    fn weighting(&self) -> Weighting {
        self.weighting
    }

    fn integrand(&self, _: &Context, at: Sample, _: Known) -> f64 {
        let d = 3 * self.node;
        self.direction[0] * at.q[d] + self.direction[1] * at.q[d + 1]
    }

    fn add_partials(&self, _: &Context, _: Sample, _: Known, scale: f64, g: Partials) {
        g.q[3 * self.node] += scale * self.direction[0];
        g.q[3 * self.node + 1] += scale * self.direction[1];
    }
}
