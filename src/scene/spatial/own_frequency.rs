//! Each beam's own lowest bending frequency and its mass at a design: the a-priori indicator
//! of where a spatial scene's beams need more elements, as a planar scene's bars
//! ([`crate::mechanism::bar_frequency`], whose clamped–clamped formula this is, over both of
//! the section's bending planes: the softer one's).

use super::SpatialScene;
use crate::error::DesignError;
use crate::mechanism::bar_frequency::{clamped_frequency, Bending};

impl SpatialScene {
    /// Each scene beam's lowest clamped–clamped bending frequency (Hz) at design `x` (full
    /// density where `None`), in the order of [`SpatialScene::beams`]; infinite for a truss
    /// bar, whose one element has no internal dynamics.
    ///
    /// # Errors
    /// [`DesignError`] naming a wrong length or an entry outside `[x_min, 1]`.
    pub fn beam_frequencies(&self, x: Option<&[f64]>) -> Result<Vec<f64>, DesignError> {
        let scales = self.scales(x)?;
        let model = &self.model;
        let frequency = |(beam, (s, m)): (&super::BeamElements, (f64, f64))| {
            if beam.truss {
                return f64::INFINITY;
            }
            let length: f64 = beam.elements.iter().map(|&e| model.beams[e].length).sum();
            let c = &beam.section;
            let plane = |axis: usize| Bending {
                ei: c.c_m[axis],
                gak: c.c_n[3 - axis],
                rho_a: c.rho_a,
                rho_i: c.rho_i[axis],
            };
            clamped_frequency(length, &[plane(1), plane(2)], s, m)
        };
        Ok(self.beams.values().zip(scales).map(frequency).collect())
    }

    /// Each scene beam's mass (kg) at design `x`, in the order of [`SpatialScene::beams`].
    ///
    /// # Errors
    /// As [`SpatialScene::beam_frequencies`].
    pub fn beam_masses(&self, x: Option<&[f64]>) -> Result<Vec<f64>, DesignError> {
        let scales = self.scales(x)?;
        let model = &self.model;
        let mass = |(beam, (_, m)): (&super::BeamElements, (f64, f64))| {
            let length = |e: usize| match beam.truss {
                true => model.trusses[e].length,
                false => model.beams[e].length,
            };
            let total: f64 = beam.elements.iter().map(|&e| length(e)).sum();
            beam.section.rho_a * total * m
        };
        Ok(self.beams.values().zip(scales).map(mass).collect())
    }

    /// Each scene beam's stiffness and mass factors `(s(x), m(x))` at design `x` (1 where it
    /// is fixed or `x` is `None`).
    fn scales(&self, x: Option<&[f64]>) -> Result<Vec<(f64, f64)>, DesignError> {
        if let Some(x) = x {
            self.design.check(x)?;
        }
        let (law, mass) = (self.design.interpolation, self.design.mass);
        let scale = |beam: &super::BeamElements| match (beam.variable, x) {
            (Some(i), Some(x)) => (law.stiffness(x[i]), mass.mass(x[i])),
            _ => (1.0, 1.0),
        };
        Ok(self.beams.values().map(scale).collect())
    }
}
