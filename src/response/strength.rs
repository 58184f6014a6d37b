//! Stresses, shear stresses and buckling ratios at the points of a structure's elements,
//! condensed over the motion (trapezoidal in time) and the structure's length by a p-mean
//! or KS mean ([`Aggregation`]).
//!
//! The criteria ([`Criterion`]) use full-density section forces, so `x⁰` gives the solid
//! material's value; `x^q` with `q > 0` is the relaxation that keeps vanishing bars from
//! dominating (Le et al. 2010 use `q = ½`).

use nalgebra::Vector3;

use super::arguments::{component_and_options, only, option, Options};
use super::{Context, Family, Kind, Known, Partials, Sample, Weighting};
use crate::mechanism::model::Model;
use crate::mechanism::parameter::Parameter;
use crate::mechanism::section::Section;
use crate::response::aggregation::Aggregation;
use crate::response::criterion::{Criterion, ElementState};

/// The relaxation exponent used unless a response names one (Le et al. 2010).
const DEFAULT_RELAXATION: f64 = 0.5;

pub(super) const STRESS: Kind = Kind {
    name: "stress",
    syntax: "stress[:COMPONENT|BAR][:OPTIONS]",
    doc: "the fibre stresses x^q (N/A ± M c/I) at six Gauss–Lobatto points along both fibres \
          of every element, condensed over the motion and the structure's length (Pa); \
          OPTIONS: p=P, a p-mean (p=8 by default), or ks=RHO,scale=S, a KS mean; q=Q the \
          relaxation (0.5 by default, 0 gives the solid material's stress)",
    peak: true,
    unit: "Pa",
    spatial: Some("stress[:NAME][:OPTIONS]"),
    linear: false,
    parse: Some(|model, rest| parse(model, rest, Criterion::Stress)),
};

pub(super) const SHEAR: Kind = Kind {
    name: "shear",
    syntax: "shear[:COMPONENT|BAR][:OPTIONS]",
    doc: "the section's largest shear stress x^q k V/A, condensed as stress, with its \
          options (Pa)",
    peak: true,
    unit: "Pa",
    spatial: None,
    linear: false,
    parse: Some(|model, rest| parse(model, rest, Criterion::Shear)),
};

pub(super) const BUCKLING: Kind = Kind {
    name: "buckling",
    syntax: "buckling[:COMPONENT|BAR][:OPTIONS]",
    doc: "the compression over the pin-ended bar's Euler load, x^q P L²/(π² EI), condensed \
          as stress, with its options (dimensionless)",
    peak: true,
    unit: "1",
    spatial: Some("buckling[:NAME][:OPTIONS]"),
    linear: false,
    parse: Some(|model, rest| parse(model, rest, Criterion::Buckling)),
};

/// The options of an aggregate: `p=P` or `ks=RHO,scale=S` ([`Aggregation::parse`]) and the
/// relaxation `q=Q` in `[0, 1]` ([`DEFAULT_RELAXATION`] if not given).
pub(crate) fn aggregation_and_relaxation(options: &Options) -> Result<(Aggregation, f64), String> {
    only(options, &["p", "ks", "scale", "q"])?;
    let aggregation = Aggregation::parse(
        option(options, "p"),
        option(options, "ks"),
        option(options, "scale"),
    )?;
    let relaxation = option(options, "q").unwrap_or(DEFAULT_RELAXATION);
    if !(0.0..=1.0).contains(&relaxation) {
        return Err(format!("relaxation q={relaxation} must lie in [0, 1]"));
    }
    Ok((aggregation, relaxation))
}

/// An aggregate of `criterion` over the members named in `rest`, with its options.
fn parse(
    model: &Model,
    rest: Option<&str>,
    criterion: Criterion,
) -> Result<Box<dyn Family>, String> {
    let (members, options) = component_and_options(rest)?;
    let members = Members::parse(model, members)?;
    let (aggregation, relaxation) = aggregation_and_relaxation(&options)?;
    let elements: Vec<usize> = members.elements(model).collect();
    if elements.is_empty() {
        return Err(
            "the structure named has no bars (stress, shear and buckling are theirs): a continuum member's cells have `von_mises`".into(),
        );
    }
    let section = |e: usize| model.elements[e].kernel.section();
    let missing = match criterion {
        Criterion::Stress => elements
            .iter()
            .find(|&&e| section(e).fibre.is_none())
            .map(|&e| (e, "outer-fibre distance; give `c`")),
        Criterion::Shear => elements
            .iter()
            .find(|&&e| section(e).shear_factor.is_none())
            .map(|&e| (e, "peak shear factor; give `shear_factor`")),
        Criterion::Buckling => None,
    };
    if let Some((e, what)) = missing {
        return Err(format!(
            "the section of bar '{}' has no {what} in its [sections] entry",
            model.bars[model.elements[e].bar].name
        ));
    }
    let length = elements
        .iter()
        .map(|&e| model.elements[e].kernel.length())
        .sum();
    Ok(Box::new(Aggregated {
        criterion,
        members,
        aggregation,
        relaxation,
        length,
    }))
}

/// The elements an aggregate reads: all, a component's, or one bar's (per-bar limits).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Members {
    /// Every element.
    All,
    /// The elements of a component.
    Component(usize),
    /// The elements of a bar.
    Bar(usize),
}

impl Members {
    /// Parses a component's or a bar's name (components first), `None` for all.
    fn parse(model: &Model, name: Option<&str>) -> Result<Self, String> {
        let Some(name) = name else {
            return Ok(Self::All);
        };
        if let Some(c) = model.components.iter().position(|x| x == name) {
            return Ok(Self::Component(c));
        }
        model
            .bars
            .iter()
            .position(|b| b.name == name)
            .map(Self::Bar)
            .ok_or_else(|| {
                format!(
                    "unknown component or bar '{name}' (components: {})",
                    model.components.join(", ")
                )
            })
    }

    /// The element indices.
    fn elements(self, m: &Model) -> impl Iterator<Item = usize> + '_ {
        let range = match self {
            Self::Bar(b) => m.bars[b].elements.clone(),
            _ => 0..m.elements.len(),
        };
        range.filter(move |&e| match self {
            Self::Component(c) => m.bars[m.elements[e].bar].component == c,
            _ => true,
        })
    }
}

/// An aggregate response: what it measures, where, and how it condenses.
#[derive(Debug)]
struct Aggregated {
    /// What is measured.
    criterion: Criterion,
    /// The elements aggregated.
    members: Members,
    /// How the point values are condensed.
    aggregation: Aggregation,
    /// Relaxation exponent `q`.
    relaxation: f64,
    /// Total length of the elements aggregated (m), the weight of an element being its
    /// share of it.
    length: f64,
}

impl Aggregated {
    /// Element `e` with its full-density section `forces` at the state.
    fn element<'a>(&self, ctx: &'a Context, e: usize, forces: Vector3<f64>) -> ElementState<'a> {
        let m = ctx.model;
        let el = &m.elements[e];
        ElementState {
            element: el,
            bar_length: m.bars[el.bar].volume / el.kernel.section().area,
            relax: ctx.densities.density[e].powf(self.relaxation),
            forces,
        }
    }

    /// Element `e` at state `q` (its section forces, no Jacobian).
    fn element_at<'a>(&self, ctx: &'a Context, e: usize, q: &[f64]) -> ElementState<'a> {
        let el = &ctx.model.elements[e];
        self.element(ctx, e, el.kernel.section_forces(&el.gather(q)))
    }

    /// `∂/∂p` of the sum at state `q` for section `section` changing at `rate`: through
    /// the section forces `(∂D/∂p) [e, θ₁, θ₂]` and the points' coefficients.
    fn section_partial(
        &self,
        ctx: &Context,
        q: &[f64],
        reference: f64,
        section: usize,
        rate: &Section,
    ) -> f64 {
        let m = ctx.model;
        let mut partial = 0.0;
        for e in self.members.elements(m) {
            let element = &m.elements[e];
            if m.bars[element.bar].section != section {
                continue;
            }
            let (forces, d_forces) = element
                .kernel
                .section_forces_and_rate(&element.gather(q), rate);
            let el = self.element(ctx, e, forces);
            let share = element.kernel.length() / self.length;
            self.criterion
                .for_each_point_and_rate(&el, Some(rate), |w, c, d_c| {
                    let (v, d_v) = (c.dot(&el.forces), d_c.dot(&el.forces) + c.dot(&d_forces));
                    partial += share * w * self.aggregation.point(v, reference).1 * d_v;
                });
        }
        partial
    }
}

impl Family for Aggregated {
    fn weighting(&self) -> Weighting {
        Weighting::Mean
    }

    /// `Σ_e (L_e/L) Σ_k w_k φ(v_k; r)`: the state's share of the sum before the weight in
    /// time.
    fn integrand(&self, ctx: &Context, at: Sample, known: Known) -> f64 {
        let mut sum = 0.0;
        for e in self.members.elements(ctx.model) {
            let el = self.element_at(ctx, e, at.q);
            let share = el.element.kernel.length() / self.length;
            self.criterion.for_each_point(&el, |w, c| {
                sum += share * w * self.aggregation.point(c.dot(&el.forces), known.reference).0;
            });
        }
        sum
    }

    fn add_partials(&self, ctx: &Context, at: Sample, known: Known, scale: f64, g: Partials) {
        let m = ctx.model;
        for e in self.members.elements(m) {
            let element = &m.elements[e];
            let (forces, jacobian) = element
                .kernel
                .section_forces_and_jacobian(&element.gather(at.q));
            let el = self.element(ctx, e, forces);
            let share = scale * el.element.kernel.length() / self.length;
            let (x, dofs, variable) = (
                ctx.densities.density[e],
                el.element.dofs(),
                m.variable_of(e),
            );
            self.criterion.for_each_point(&el, |w, c| {
                let v = c.dot(&el.forces);
                let slope = share * w * self.aggregation.point(v, known.reference).1;
                let d_v = jacobian.transpose() * c;
                dofs.iter()
                    .zip(d_v.iter())
                    .for_each(|(&d, dv)| g.q[d] += slope * dv);
                // ∂v/∂x = q x^{q−1} v_solid = (q/x) v.
                if let Some(j) = variable {
                    g.x[j] += slope * self.relaxation / x * v;
                }
            });
        }
    }

    /// Stresses and buckling read the section through its forces and their coefficients.
    fn parameter_partial(&self, ctx: &Context, at: Sample, known: Known, p: &Parameter) -> f64 {
        p.section().map_or(0.0, |(section, rate)| {
            self.section_partial(ctx, at.q, known.reference, section, rate)
        })
    }

    fn aggregation(&self) -> Option<Aggregation> {
        Some(self.aggregation)
    }

    fn peak(&self, ctx: &Context, at: Sample) -> f64 {
        self.members
            .elements(ctx.model)
            .map(|e| self.criterion.peak(&self.element_at(ctx, e, at.q)))
            .fold(0.0, f64::max)
    }
}
