//! The elastic energy stored in the beams and the continuum cells, `U = Σ_e s(x_e) U_e(q_e)`
//! with `U_e` the co-rotational (a cell's: total Lagrangian) strain energy at full density:
//! rigid motion stores none. In a linear analysis `U_e` is the linearized element's
//! `f₀ᵀu + ½ uᵀK₀u` ([`crate::mechanism::linear`]), so that `U = ½ Fᵀu` (Clapeyron).

use super::arguments::{cells_of, component, elements_of};
use super::{Context, Family, Kind, Known, Partials, Sample, Weighting};
use crate::mechanism::element::quad::Vector8;
use crate::mechanism::element::Vector6;
use crate::mechanism::linear::Linearized;
use crate::mechanism::parameter::Parameter;

pub(super) const KIND: Kind = Kind {
    name: "strain_energy",
    syntax: "strain_energy[:COMPONENT]",
    doc: "time-mean elastic energy (1/t_f) ∫ U dt of the beams and cells of one component or all (J), \
          rigid motion storing none; U at a static equilibrium (where compliance is Fᵀu)",
    peak: false,
    unit: "J",
    spatial: Some("strain_energy"),
    linear: true,
    parse: Some(parse),
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
            .map(|e| ctx.densities.stiffness[e] * element_energy(ctx, e, at.q))
            .sum();
        let cells: f64 = cells_of(m, self.component)
            .map(|k| ctx.densities.stiffness[n_e + k] * cell_energy(ctx, k, at.q))
            .sum();
        beams + cells
    }

    /// `G_q = s(x_e) f_e(q_e)` (the internal force is the energy's gradient) and
    /// `G_x = s'(x_e) U_e(q_e)`, with `s(x_e) γ'(x_e) ∂U_e/∂γ` of a blended cell.
    fn add_partials(&self, ctx: &Context, at: Sample, _: Known, scale: f64, g: Partials) {
        let m = ctx.model;
        for e in elements_of(m, self.component) {
            let el = &m.elements[e];
            let (energy, f) = element_terms(ctx, e, at.q);
            let s = ctx.densities.stiffness[e];
            el.dofs()
                .iter()
                .zip(f.iter())
                .for_each(|(&d, fi)| g.q[d] += scale * s * fi);
            if let Some(v) = m.variable_of(e) {
                g.x[v] += scale * ctx.densities.stiffness_rate[e] * energy;
            }
        }
        let n_e = m.elements.len();
        for k in cells_of(m, self.component) {
            let cell = &m.cells[k];
            let (energy, f, blending) = cell_terms(ctx, k, at.q);
            let s = ctx.densities.stiffness[n_e + k];
            cell.dofs()
                .iter()
                .zip(f.iter())
                .for_each(|(&d, fi)| g.q[d] += scale * s * fi);
            if let Some(v) = cell.variable {
                // s' Ψ + s γ' ∂Ψ/∂γ.
                let rate = ctx.densities.stiffness_rate[n_e + k];
                g.x[v] +=
                    scale * (rate * energy + s * ctx.densities.blend_rate[n_e + k] * blending);
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

/// Element `e`'s energy at full density at `q` (as [`element_terms`]).
fn element_energy(ctx: &Context, e: usize, q: &[f64]) -> f64 {
    let el = &ctx.model.elements[e];
    let u = el.gather(q);
    match ctx.linear {
        Some(linear) => linear.element_energy(e, &u),
        None => el.kernel.strain_energy(&u),
    }
}

/// Cell `k`'s energy at full density at `q` (as [`cell_terms`]).
fn cell_energy(ctx: &Context, k: usize, q: &[f64]) -> f64 {
    let cell = &ctx.model.cells[k];
    let u = cell.gather(q);
    if ctx.linear.is_some() {
        return Linearized::cell_energy(cell.kernel.small_strain_stiffness(), &u);
    }
    let blend = ctx.densities.blend[ctx.model.elements.len() + k];
    cell.kernel.blended(blend).strain_energy(&u)
}

/// Element `e`'s energy and force at full density at `q`: the co-rotational ones, or the
/// linearized element's in a linear analysis.
fn element_terms(ctx: &Context, e: usize, q: &[f64]) -> (f64, Vector6) {
    let el = &ctx.model.elements[e];
    let u = el.gather(q);
    match ctx.linear {
        Some(linear) => (linear.element_energy(e, &u), linear.element_force(e, &u)),
        None => (el.kernel.strain_energy(&u), el.kernel.internal_force(&u)),
    }
}

/// Cell `k`'s energy, force and energy's rate to its blend `∂Ψ/∂γ` at full density at `q`:
/// its blended energy's, or the linear cell's (no blend) in a linear analysis.
fn cell_terms(ctx: &Context, k: usize, q: &[f64]) -> (f64, Vector8, f64) {
    let cell = &ctx.model.cells[k];
    let u = cell.gather(q);
    if ctx.linear.is_some() {
        let k0 = cell.kernel.small_strain_stiffness();
        return (
            Linearized::cell_energy(k0, &u),
            Linearized::cell_force(k0, &u),
            0.0,
        );
    }
    let e = ctx.model.elements.len() + k;
    let kernel = cell.kernel.blended(ctx.densities.blend[e]);
    let blending = if ctx.densities.blend_rate[e] != 0.0 {
        kernel.energy_rate(&u)
    } else {
        0.0
    };
    (
        kernel.strain_energy(&u),
        kernel.internal_force(&u),
        blending,
    )
}
