//! Compliance: in a dynamic scene the mean strain energy over the motion (paper Eq. 37,
//! 39), in a static one the work of the loads at equilibrium, `Fᵀu`.

use super::arguments::component;
use super::strain_energy::StrainEnergy;
use super::{Context, Family, Kind, Known, Partials, Sample, Weighting};
use crate::mechanism::element::quad::Vector8;
use crate::mechanism::element::Vector6;
use crate::mechanism::model::{Analysis, Model};
use crate::mechanism::parameter::Parameter;

pub(super) const KIND: Kind = Kind {
    name: "compliance",
    syntax: "compliance[:COMPONENT]",
    doc: "mean compliance over the motion, (1/t_f) ∫ U dt of one component or all (J, paper \
          Eq. 39); a static scene's Fᵀu (J), global",
    peak: false,
    unit: "J",
    spatial: Some("compliance"),
    linear: true,
    parse: Some(parse),
};

fn parse(model: &Model, rest: Option<&str>) -> Result<Box<dyn Family>, String> {
    match (model.analysis, rest) {
        (Analysis::Static, Some(_)) => {
            Err("static compliance Fᵀu is global; drop the component".into())
        }
        (Analysis::Static, None) => Ok(Box::new(LoadWork)),
        (Analysis::Dynamic, _) => Ok(Box::new(StrainEnergy {
            component: component(model, rest)?,
        })),
    }
}

/// `Fᵀu` at a static equilibrium: `F` the applied loads and gravity on `M(x)`.
#[derive(Debug)]
struct LoadWork;

impl Family for LoadWork {
    fn weighting(&self) -> Weighting {
        Weighting::Final
    }

    fn integrand(&self, ctx: &Context, at: Sample, _: Known) -> f64 {
        ctx.static_load.iter().zip(at.q).map(|(f, u)| f * u).sum()
    }

    /// `G_q = F`, and `G_x = uᵀ ∂F/∂x_e` with `∂F/∂x_e = m'(x_e) M_e ĝ` (gravity on the
    /// element's mass).
    fn add_partials(&self, ctx: &Context, at: Sample, _: Known, scale: f64, g: Partials) {
        let m = ctx.model;
        g.q.iter_mut()
            .zip(ctx.static_load)
            .for_each(|(g, f)| *g += scale * f);
        let gravity = m.gravity;
        if gravity.norm() == 0.0 {
            return;
        }
        let per_node = Vector6::from([gravity.x, gravity.y, 0.0, gravity.x, gravity.y, 0.0]);
        for (e, el) in m.elements.iter().enumerate() {
            if let Some(v) = m.variable_of(e) {
                let rate =
                    el.kernel.mass_matrix(ctx.mass_kind) * per_node * ctx.densities.mass_rate[e];
                g.x[v] += scale * rate.dot(&el.gather(at.q));
            }
        }
        let per_node = Vector8::from_fn(|i, _| if i % 2 == 0 { gravity.x } else { gravity.y });
        for (k, cell) in m.cells.iter().enumerate() {
            if let Some(v) = cell.variable {
                let e = m.elements.len() + k;
                let rate =
                    cell.kernel.mass_matrix(ctx.mass_kind) * per_node * ctx.densities.mass_rate[e];
                g.x[v] += scale * rate.dot(&cell.gather(at.q));
            }
        }
    }

    /// `uᵀ ∂F/∂p`: the load follows masses, motors and sections' `ρ`.
    fn parameter_partial(&self, ctx: &Context, at: Sample, _: Known, p: &Parameter) -> f64 {
        let mut g = 0.0;
        p.load_rate(&ctx.designed(), at.t, |i, v| g += v * at.q[i]);
        g
    }
}
