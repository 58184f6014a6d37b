//! The von Mises stress of continuum members' cells at their Gauss points, relaxed by `x^q`
//! and condensed over the motion (trapezoidal in time) and the members' volume by a p-mean
//! or KS mean ([`Aggregation`]), as the bars' stresses are ([`super::strength`]).
//!
//! At a Gauss point of cell `c`, `v = x_c^q σ_vM(S(u_c))` with `S` the second
//! Piola–Kirchhoff stress of the solid material: `q = 0` gives the solid's stress at the
//! strain the design produces, `q > 0` keeps vanishing cells from dominating (the relaxed
//! stress of Le et al. 2010). Each point weighs its share of the cells' volume.

use super::aggregation::Aggregation;
use super::arguments::{cells_of, component, component_and_options};
use super::strength::aggregation_and_relaxation;
use super::{Context, Family, Kind, Known, Partials, Sample, Weighting};
use crate::mechanism::model::Model;

pub(super) const KIND: Kind = Kind {
    name: "von_mises",
    syntax: "von_mises[:COMPONENT][:OPTIONS]",
    doc: "the von Mises stress x^q σ_vM of the continuum members' cells at their Gauss points, \
          condensed over the motion and the cells' volume (Pa); OPTIONS as stress: p=P (8 by \
          default) or ks=RHO,scale=S, q=Q the relaxation (0.5 by default)",
    peak: true,
    unit: "Pa",
    spatial: None,
    linear: false,
    parse: Some(parse),
};

fn parse(model: &Model, rest: Option<&str>) -> Result<Box<dyn Family>, String> {
    let (name, options) = component_and_options(rest)?;
    let component = component(model, name)?;
    let (aggregation, relaxation) = aggregation_and_relaxation(&options)?;
    let volume: f64 = cells_of(model, component)
        .map(|k| model.cells[k].kernel.volume())
        .sum();
    if volume == 0.0 {
        return Err(
            "the structure named has no continuum cells (a bar's stress is `stress`)".into(),
        );
    }
    Ok(Box::new(VonMises {
        component,
        aggregation,
        relaxation,
        volume,
    }))
}

/// The aggregate of the cells' von Mises stresses.
#[derive(Debug)]
struct VonMises {
    /// Component, `None` for every cell.
    component: Option<usize>,
    /// How the point values are condensed.
    aggregation: Aggregation,
    /// Relaxation exponent `q`.
    relaxation: f64,
    /// Full-density volume of the cells aggregated (m³).
    volume: f64,
}

impl VonMises {
    /// Calls `visit(weight, v)` for every Gauss point of the cells at state `q`: `v = x^q σ`
    /// and the point's weight in the mean.
    fn for_each_point(&self, ctx: &Context, q: &[f64], mut visit: impl FnMut(f64, f64)) {
        let m = ctx.model;
        for k in cells_of(m, self.component) {
            let cell = &m.cells[k];
            let relax = ctx.densities.density[m.elements.len() + k].powf(self.relaxation);
            let share = cell.kernel.volume() / self.volume;
            for (sigma, part) in cell.kernel.von_mises(&cell.gather(q)) {
                visit(share * part, relax * sigma);
            }
        }
    }
}

impl Family for VonMises {
    fn weighting(&self) -> Weighting {
        Weighting::Mean
    }

    fn integrand(&self, ctx: &Context, at: Sample, known: Known) -> f64 {
        let mut sum = 0.0;
        self.for_each_point(ctx, at.q, |w, v| {
            sum += w * self.aggregation.point(v, known.reference).0;
        });
        sum
    }

    /// `G_q = Σ w φ'(v) x^q ∂σ/∂u`, `G_x = Σ w φ'(v) (q/x) v`.
    fn add_partials(&self, ctx: &Context, at: Sample, known: Known, scale: f64, g: Partials) {
        let m = ctx.model;
        for k in cells_of(m, self.component) {
            let cell = &m.cells[k];
            let x = ctx.densities.density[m.elements.len() + k];
            let relax = x.powf(self.relaxation);
            let share = cell.kernel.volume() / self.volume;
            let dofs = cell.dofs();
            for (sigma, d_sigma, part) in cell.kernel.von_mises_and_gradient(&cell.gather(at.q)) {
                let v = relax * sigma;
                let slope = scale * share * part * self.aggregation.point(v, known.reference).1;
                for (&d, ds) in dofs.iter().zip(d_sigma.iter()) {
                    g.q[d] += slope * relax * ds;
                }
                if let Some(j) = cell.variable {
                    g.x[j] += slope * self.relaxation / x * v;
                }
            }
        }
    }

    fn aggregation(&self) -> Option<Aggregation> {
        Some(self.aggregation)
    }

    fn peak(&self, ctx: &Context, at: Sample) -> f64 {
        let mut peak = 0.0_f64;
        self.for_each_point(ctx, at.q, |_, v| peak = peak.max(v));
        peak
    }
}
