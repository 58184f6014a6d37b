//! The elastic energy stored in the beams and the continuum cells, `U = Σ_e s(x_e) U_e(q_e)`
//! with `U_e` the co-rotational (a cell's: total Lagrangian) strain energy at full density:
//! rigid motion stores none.

use super::arguments::{cells_of, component, elements_of};
use super::{Context, Family, Kind, Known, Partials, Sample, Weighting};
use crate::mechanism::parameter::Parameter;

pub(super) const KIND: Kind = Kind {
    name: "strain_energy",
    syntax: "strain_energy[:COMPONENT]",
    doc: "time-mean elastic energy (1/t_f) ∫ U dt of the beams and cells of one component or all (J), \
          rigid motion storing none; U at a static equilibrium (where compliance is Fᵀu)",
    peak: false,
    unit: "J",
    parse,
};

fn parse(
    model: &crate::mechanism::model::Model,
    rest: Option<&str>,
) -> Result<Box<dyn Family>, String> {
    Ok(Box::new(StrainEnergy {
        component: component(model, rest)?,
    }))
}

/// The strain energy of one component or all, meaned over the motion: also the dynamic
/// compliance of paper Eq. 37, 39.
#[derive(Debug)]
pub(super) struct StrainEnergy {
    /// Component, or `None` for the sum over all.
    pub(super) component: Option<usize>,
}

impl Family for StrainEnergy {
    fn weighting(&self) -> Weighting {
        Weighting::Mean
    }

    fn integrand(&self, ctx: &Context, at: Sample, _: Known) -> f64 {
        let m = ctx.model;
        let n_e = m.elements.len();
        let beams: f64 = elements_of(m, self.component)
            .map(|e| {
                let el = &m.elements[e];
                ctx.densities.stiffness[e] * el.kernel.strain_energy(&el.gather(at.q))
            })
            .sum();
        let cells: f64 = cells_of(m, self.component)
            .map(|k| {
                let cell = &m.cells[k];
                let kernel = cell.kernel.blended(ctx.densities.blend[n_e + k]);
                ctx.densities.stiffness[n_e + k] * kernel.strain_energy(&cell.gather(at.q))
            })
            .sum();
        beams + cells
    }

    /// `G_q = s(x_e) f_e(q_e)` (the internal force is the energy's gradient) and
    /// `G_x = s'(x_e) U_e(q_e)`.
    fn add_partials(&self, ctx: &Context, at: Sample, _: Known, scale: f64, g: Partials) {
        let m = ctx.model;
        for e in elements_of(m, self.component) {
            let el = &m.elements[e];
            let u = el.gather(at.q);
            let f = el.kernel.internal_force(&u);
            let s = ctx.densities.stiffness[e];
            el.dofs()
                .iter()
                .zip(f.iter())
                .for_each(|(&d, fi)| g.q[d] += scale * s * fi);
            if let Some(v) = m.variable_of(e) {
                g.x[v] += scale * ctx.densities.stiffness_rate[e] * el.kernel.strain_energy(&u);
            }
        }
        let n_e = m.elements.len();
        for k in cells_of(m, self.component) {
            let cell = &m.cells[k];
            let u = cell.gather(at.q);
            let kernel = cell.kernel.blended(ctx.densities.blend[n_e + k]);
            let f = kernel.internal_force(&u);
            let s = ctx.densities.stiffness[n_e + k];
            cell.dofs()
                .iter()
                .zip(f.iter())
                .for_each(|(&d, fi)| g.q[d] += scale * s * fi);
            if let Some(v) = cell.variable {
                // s' Ψ + s γ' ∂Ψ/∂γ.
                let (rate, blend_rate) = (
                    ctx.densities.stiffness_rate[n_e + k],
                    ctx.densities.blend_rate[n_e + k],
                );
                let mut dx = rate * kernel.strain_energy(&u);
                if blend_rate != 0.0 {
                    dx += s * blend_rate * kernel.energy_rate(&u);
                }
                g.x[v] += scale * dx;
            }
        }
    }

    /// A section's stiffness moves `U_e` of its elements.
    fn parameter_partial(&self, ctx: &Context, at: Sample, _: Known, p: &Parameter) -> f64 {
        let Some((section, rate)) = p.section() else {
            return 0.0;
        };
        let m = ctx.model;
        elements_of(m, self.component)
            .filter(|&e| m.bars[m.elements[e].bar].section == section)
            .map(|e| {
                let el = &m.elements[e];
                ctx.densities.stiffness[e] * el.kernel.strain_energy_rate(&el.gather(at.q), rate)
            })
            .sum()
    }
}
