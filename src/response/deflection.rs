//! The mean squared deflection of a node from its rigid trajectory (paper Eq. 40).

use super::arguments::node;
use super::{Context, Family, Kind, Known, Partials, Sample, Weighting};
use crate::mechanism::model::{Analysis, Model};

pub(super) const KIND: Kind = Kind {
    name: "tip_deflection",
    syntax: "tip_deflection[:NODE]",
    doc: "mean squared deflection (1/t_f) ∫ |r − r_rigid|² dt of the scene's tip or a node \
          from its rigid trajectory (m², paper Eq. 40)",
    peak: false,
    unit: "m²",
    spatial: Some("tip_deflection[:NAME]"),
    linear: false,
    parse: Some(parse),
};

fn parse(model: &Model, rest: Option<&str>) -> Result<Box<dyn Family>, String> {
    if model.analysis == Analysis::Static {
        return Err("a static scene has no motion to deflect from".into());
    }
    let node = match rest {
        Some(n) => node(model, n)?,
        None => model
            .tip
            .ok_or("the scene has no `tip`; write tip_deflection:NODE")?,
    };
    Ok(Box::new(TipDeflection { node }))
}

/// `|r − r_rigid|²` of a node, meaned over the motion.
#[derive(Debug)]
struct TipDeflection {
    node: usize,
}

impl TipDeflection {
    /// `r − r_rigid` at a state.
    fn gap(&self, ctx: &Context, at: Sample, known: Known) -> [f64; 2] {
        let (p, d) = (ctx.model.nodes[self.node].position, 3 * self.node);
        [
            p.x + at.q[d] - known.rigid[0],
            p.y + at.q[d + 1] - known.rigid[1],
        ]
    }
}

impl Family for TipDeflection {
    fn weighting(&self) -> Weighting {
        Weighting::Mean
    }

    fn integrand(&self, ctx: &Context, at: Sample, known: Known) -> f64 {
        let [dx, dy] = self.gap(ctx, at, known);
        dx * dx + dy * dy
    }

    fn add_partials(&self, ctx: &Context, at: Sample, known: Known, scale: f64, g: Partials) {
        let [dx, dy] = self.gap(ctx, at, known);
        g.q[3 * self.node] += scale * 2.0 * dx;
        g.q[3 * self.node + 1] += scale * 2.0 * dy;
    }

    fn rigid_node(&self) -> Option<usize> {
        Some(self.node)
    }

    fn rigid_partial(&self, ctx: &Context, at: Sample, known: Known, rate: [f64; 2]) -> f64 {
        let [dx, dy] = self.gap(ctx, at, known);
        -2.0 * (dx * rate[0] + dy * rate[1])
    }
}
