//! The material volume `Σ x_e V_e` of one component or all (paper Eq. 38, 41): explicit in
//! the design.

use super::arguments::{cells_of, component};
use super::{Context, Family, Kind, Known, Partials, Sample, Weighting};
use crate::mechanism::model::{Bar, Model};
use crate::mechanism::parameter::Parameter;

pub(super) const KIND: Kind = Kind {
    name: "volume",
    syntax: "volume[:COMPONENT]",
    doc: "material volume Σ x_e V_e of the bars and cells of one component or all (m³, paper Eq. 38, 41)",
    peak: false,
    unit: "m³",
    spatial: None,
    linear: true,
    parse: Some(parse),
};

fn parse(model: &Model, rest: Option<&str>) -> Result<Box<dyn Family>, String> {
    Ok(Box::new(Volume {
        component: component(model, rest)?,
    }))
}

/// The volume of a component's bars and cells, or all.
#[derive(Debug)]
struct Volume {
    component: Option<usize>,
}

impl Volume {
    fn bars<'a>(&self, m: &'a Model) -> impl Iterator<Item = &'a Bar> + 'a {
        let component = self.component;
        m.bars
            .iter()
            .filter(move |b| component.is_none_or(|c| b.component == c))
    }
}

impl Family for Volume {
    fn weighting(&self) -> Weighting {
        Weighting::Explicit
    }

    fn integrand(&self, ctx: &Context, _: Sample, _: Known) -> f64 {
        let m = ctx.model;
        let bars: f64 = self
            .bars(m)
            .map(|b| ctx.densities.density[b.elements.start] * b.volume)
            .sum();
        let cells: f64 = cells_of(m, self.component)
            .map(|k| ctx.densities.density[m.elements.len() + k] * m.cells[k].kernel.volume())
            .sum();
        bars + cells
    }

    fn add_partials(&self, ctx: &Context, _: Sample, _: Known, scale: f64, g: Partials) {
        for b in self.bars(ctx.model) {
            if let Some(v) = b.variable {
                g.x[v] += scale * b.volume;
            }
        }
        let m = ctx.model;
        for k in cells_of(m, self.component) {
            if let Some(v) = m.cells[k].variable {
                g.x[v] += scale * m.cells[k].kernel.volume();
            }
        }
    }

    /// A section's diameter moves its bars' area.
    fn parameter_partial(&self, ctx: &Context, _: Sample, _: Known, p: &Parameter) -> f64 {
        let Some((section, rate)) = p.section() else {
            return 0.0;
        };
        let area = ctx.model.sections[section].section.area;
        self.bars(ctx.model)
            .filter(|b| b.section == section)
            .map(|b| ctx.densities.density[b.elements.start] * b.volume * rate.area / area)
            .sum()
    }
}
