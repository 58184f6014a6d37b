//! A spatial scene's design (paper Eq. 1, 33, 34): one density `x_i ∈ [x_min, 1]` per beam
//! or per group of beams (a `fixed` beam has none), each of its elements' stiffnesses scaled
//! by the interpolation `s(x_i)` and its mass by the mass law `m(x_i)`, as on a planar
//! scene. The mechanism at `x` is the built one so scaled, and a response's derivative to a
//! density is read off the engine's factors on an element's stiffness `σ_e` and mass `μ_e`
//! (at 1, [`Parameter::BeamStiffness`] …):
//!
//! `∂f/∂x_i = Σ_e (s'(x_i)/s(x_i)) ∂f/∂σ_e + (m'(x_i)/m(x_i)) ∂f/∂μ_e + ∂f/∂x_e` over the
//! variable's elements, the last the explicit derivative of a stress response's relaxation
//! `x_e^q` ([`Parameter::BeamDensity`]).

use std::borrow::Cow;

use super::names::Named;
use super::SpatialScene;
use crate::error::DesignError;
use crate::mechanism::interpolation::MassLaw;
use crate::spatial::model::SpatialModel;
use crate::spatial::sensitivity::Parameter;

impl SpatialScene {
    /// The number of design variables.
    pub fn n_variables(&self) -> usize {
        self.design.variables.len()
    }

    /// The mechanism at design `x` (as built, at full density, where `None`).
    ///
    /// # Errors
    /// [`DesignError`] naming a wrong length or the first entry outside `[x_min, 1]`.
    pub fn model_at(&self, x: Option<&[f64]>) -> Result<Cow<'_, SpatialModel>, DesignError> {
        let Some(x) = x else {
            return Ok(Cow::Borrowed(&self.model));
        };
        self.design.check(x)?;
        let mut model = self.model.clone();
        let (law, mass) = (self.design.interpolation, self.design.mass);
        for beam in self.beams.values() {
            let Some(i) = beam.variable else { continue };
            let (s, m) = (law.stiffness(x[i]), mass.mass(x[i]));
            for &e in &beam.elements {
                match beam.truss {
                    true => {
                        model.trusses[e].scale(s, m);
                        model.trusses[e].density = x[i];
                    }
                    false => {
                        model.beams[e].scale(s, m);
                        model.beams[e].density = x[i];
                    }
                }
            }
        }
        Ok(Cow::Owned(model))
    }

    /// The material volume `Σ A_e L_e` (m³) of each design variable's elements at full
    /// density, and of the fixed ones: the volume at `x` is `fixed + Σ x_i V_i` (paper
    /// Eq. 38), its gradient `V`.
    pub fn volumes(&self) -> (Vec<f64>, f64) {
        self.per_variable(|m, truss, e| match truss {
            true => m.trusses[e].area * m.trusses[e].length,
            false => m.beams[e].section.area * m.beams[e].length,
        })
    }

    /// The mass (kg) of each design variable's elements at `x`, `m(x_i) M_i` (its mass law
    /// times their full-density mass `Σ ρA_e L_e`), its derivative `m'(x_i) M_i`, and the
    /// fixed ones' mass; `x` checked as [`SpatialScene::model_at`] checks it.
    ///
    /// # Errors
    /// [`DesignError`] naming a wrong length or the first entry outside `[x_min, 1]`.
    pub fn masses(&self, x: &[f64]) -> Result<(Vec<f64>, Vec<f64>, f64), DesignError> {
        self.design.check(x)?;
        let (full, fixed) = self.per_variable(|m, truss, e| match truss {
            true => m.trusses[e].rho_a * m.trusses[e].length,
            false => m.beams[e].section.rho_a * m.beams[e].length,
        });
        let law = self.design.mass;
        let at = |f: fn(_, f64) -> f64| full.iter().zip(x).map(|(m, &xi)| m * f(law, xi)).collect();
        Ok((at(MassLaw::mass), at(MassLaw::mass_derivative), fixed))
    }

    /// `measure(model, truss, element)` summed over each design variable's elements at full
    /// density, and over the fixed ones.
    fn per_variable(&self, measure: impl Fn(&SpatialModel, bool, usize) -> f64) -> (Vec<f64>, f64) {
        let (mut designed, mut fixed) = (vec![0.0; self.n_variables()], 0.0);
        for beam in self.beams.values() {
            let total: f64 = (beam.elements.iter())
                .map(|&e| measure(&self.model, beam.truss, e))
                .sum();
            match beam.variable {
                Some(i) => designed[i] += total,
                None => fixed += total,
            }
        }
        (designed, fixed)
    }

    /// For each design variable, the engine parameters whose derivatives make its own at `x`
    /// (module docs); `x` checked by [`SpatialScene::model_at`].
    pub fn densities(&self, x: &[f64]) -> Vec<Named> {
        let mut named = vec![Named::new(); self.n_variables()];
        let (law, mass) = (self.design.interpolation, self.design.mass);
        for beam in self.beams.values() {
            let Some(i) = beam.variable else { continue };
            let ds = law.stiffness_derivative(x[i]) / law.stiffness(x[i]);
            let dm = mass.mass_derivative(x[i]) / mass.mass(x[i]);
            for &e in &beam.elements {
                let (stiffness, inertia, density) = match beam.truss {
                    true => (
                        Parameter::TrussStiffness { truss: e },
                        Parameter::TrussMass { truss: e },
                        Parameter::TrussDensity { truss: e },
                    ),
                    false => (
                        Parameter::BeamStiffness { beam: e },
                        Parameter::BeamMass { beam: e },
                        Parameter::BeamDensity { beam: e },
                    ),
                };
                named[i].extend([(stiffness, ds), (inertia, dm), (density, 1.0)]);
            }
        }
        named
    }
}
