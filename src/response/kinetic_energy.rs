//! The time integral of the kinetic energy `½ q̇ᵀ M(x) q̇` over the motion: a response that
//! reads the velocities.

use super::arguments::none;
use super::{Context, Family, Kind, Known, Partials, Sample, Weighting};
use crate::mechanism::model::{Analysis, Model};
use crate::mechanism::parameter::Parameter;

pub(super) const KIND: Kind = Kind {
    name: "kinetic_energy",
    syntax: "kinetic_energy",
    doc: "the time integral ∫ ½ q̇ᵀ M q̇ dt of the kinetic energy over the motion (J s)",
    peak: false,
    unit: "J s",
    spatial: Some("kinetic_energy"),
    linear: false,
    parse: Some(parse),
};

fn parse(model: &Model, rest: Option<&str>) -> Result<Box<dyn Family>, String> {
    none(rest)?;
    if model.analysis == Analysis::Static {
        return Err(
            "a static scene has no motion: kinetic energy is a response of a dynamic one".into(),
        );
    }
    Ok(Box::new(KineticEnergy))
}

/// `½ q̇ᵀ M(x) q̇`, integrated over the motion.
#[derive(Debug)]
struct KineticEnergy;

/// Calls `add(d, (M v)_d)` for the mass matrix `M(x)` of the design (beams, cells and
/// bars' end couplings scaled by `m(x_e)`, point masses and bodies) times `v` (nothing for
/// an empty `v`).
fn add_mass_times(ctx: &Context, v: &[f64], mut add: impl FnMut(usize, f64)) {
    if v.is_empty() {
        return;
    }
    let m = ctx.model;
    for (e, el) in m.elements.iter().enumerate() {
        let p = el.kernel.mass_matrix(ctx.mass_kind) * el.gather(v) * ctx.densities.mass[e];
        el.dofs()
            .iter()
            .zip(p.iter())
            .for_each(|(&d, &x)| add(d, x));
    }
    for (k, cell) in m.cells.iter().enumerate() {
        let mass = ctx.densities.mass[m.elements.len() + k];
        let p = cell.kernel.mass_matrix(ctx.mass_kind) * cell.gather(v) * mass;
        cell.dofs()
            .iter()
            .zip(p.iter())
            .for_each(|(&d, &x)| add(d, x));
    }
    for c in m.bar_couplings(ctx.mass_kind) {
        let p = c.times(v);
        let mass = ctx.densities.mass[c.element];
        c.dofs()
            .iter()
            .zip(p.iter())
            .for_each(|(&d, &x)| add(d, x * mass));
    }
    for pm in &m.point_masses {
        let d = 3 * pm.node;
        add(d, pm.mass * v[d]);
        add(d + 1, pm.mass * v[d + 1]);
        add(d + 2, pm.inertia * v[d + 2]);
    }
}

impl Family for KineticEnergy {
    fn weighting(&self) -> Weighting {
        Weighting::Integral
    }

    fn integrand(&self, ctx: &Context, at: Sample, _: Known) -> f64 {
        let mut g = 0.0;
        add_mass_times(ctx, at.v, |d, p| g += 0.5 * at.v[d] * p);
        g
    }

    /// `G_x = ½ m'(x_e) q̇ₑᵀ Mₑ q̇ₑ`; its `G_q̇ = M q̇` in [`Family::add_rate_partials`].
    fn add_partials(&self, ctx: &Context, at: Sample, _: Known, scale: f64, g: Partials) {
        if at.v.is_empty() {
            return;
        }
        let m = ctx.model;
        for (e, el) in m.elements.iter().enumerate() {
            if let Some(j) = m.variable_of(e) {
                let v = el.gather(at.v);
                let energy = 0.5 * v.dot(&(el.kernel.mass_matrix(ctx.mass_kind) * v));
                g.x[j] += scale * ctx.densities.mass_rate[e] * energy;
            }
        }
        for c in m.bar_couplings(ctx.mass_kind) {
            if let Some(j) = m.variable_of(c.element) {
                let p = c.times(at.v);
                let energy = 0.5
                    * c.dofs()
                        .iter()
                        .zip(p)
                        .map(|(&d, x)| at.v[d] * x)
                        .sum::<f64>();
                g.x[j] += scale * ctx.densities.mass_rate[c.element] * energy;
            }
        }
        for (k, cell) in m.cells.iter().enumerate() {
            if let Some(j) = cell.variable {
                let v = cell.gather(at.v);
                let energy = 0.5 * v.dot(&(cell.kernel.mass_matrix(ctx.mass_kind) * v));
                g.x[j] += scale * ctx.densities.mass_rate[m.elements.len() + k] * energy;
            }
        }
    }

    fn reads_velocities(&self) -> bool {
        true
    }

    fn add_rate_partials(&self, ctx: &Context, at: Sample, scale: f64, g_v: &mut [f64]) {
        add_mass_times(ctx, at.v, |d, p| g_v[d] += scale * p);
    }

    /// Masses, inertias and sections' `ρ` move `M`.
    fn parameter_partial(&self, ctx: &Context, at: Sample, _: Known, p: &Parameter) -> f64 {
        0.5 * p.mass_rate_times(&ctx.designed(), at.v, at.v)
    }
}
