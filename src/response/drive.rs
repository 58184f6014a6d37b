//! What a drive delivers: its torque `τ = −λ` of its driven row (N m; a slider drive's
//! force, N) condensed over the motion, its squared integral, its work and the energy it
//! draws.

use super::arguments::{component_and_options, drive_rate, drive_row, only};
use super::{Context, Family, Kind, Known, Partials, Sample, Weighting};
use crate::mechanism::model::Model;
use crate::mechanism::parameter::Parameter;
use crate::response::aggregation::Aggregation;

pub(super) const TORQUE: Kind = Kind {
    name: "torque",
    syntax: "torque:JOINT[:OPTIONS]",
    doc: "the torque τ = −λ a drive applies (N m), condensed over the motion by a p-mean \
          (p=P) or KS mean (ks=RHO,scale=S) as stress; p=2 is the RMS, a large p nears the \
          peak",
    peak: true,
    unit: "N m",
    spatial: Some("torque:JOINT[:OPTIONS]"),
    linear: false,
    parse: Some(|model, rest| parse_torque(model, rest, false)),
};

pub(super) const TORQUE_RMS: Kind = Kind {
    name: "torque_rms",
    syntax: "torque_rms:JOINT",
    doc: "a drive's RMS torque over the motion (N m): torque with p=2",
    peak: false,
    unit: "N m",
    spatial: None,
    linear: false,
    parse: Some(|model, rest| parse_torque(model, rest, true)),
};

pub(super) const TORQUE_SQUARED: Kind = Kind {
    name: "torque_squared",
    syntax: "torque_squared:JOINT",
    doc: "∫ τ² dt of a drive (N² m² s): the copper losses a motor is sized by",
    peak: false,
    unit: "N² m² s",
    spatial: Some("torque_squared:JOINT"),
    linear: false,
    parse: Some(|model, rest| parse_row(model, rest, "torque_squared", Drive::TorqueSquared)),
};

pub(super) const WORK: Kind = Kind {
    name: "drive_work",
    syntax: "drive_work:JOINT",
    doc: "the work ∫ τ ġ dt a drive does on the structure (J): positive where it drives, \
          negative where it brakes",
    peak: false,
    unit: "J",
    spatial: None,
    linear: false,
    parse: Some(|model, rest| parse_row(model, rest, "drive_work", Drive::Work)),
};

pub(super) const ENERGY_DRAWN: Kind = Kind {
    name: "energy_drawn",
    syntax: "energy_drawn:JOINT",
    doc: "the energy ∫ max(τ ġ, 0) dt a drive draws (J), none recovered where it brakes; \
          its gradient is exact wherever the power does not pass through zero at a step",
    peak: false,
    unit: "J",
    spatial: None,
    linear: false,
    parse: Some(|model, rest| parse_row(model, rest, "energy_drawn", Drive::EnergyDrawn)),
};

/// A drive's torque, `torque:JOINT[:p=P|ks=RHO,scale=S]` or `torque_rms:JOINT`.
fn parse_torque(model: &Model, rest: Option<&str>, rms: bool) -> Result<Box<dyn Family>, String> {
    let (joint, options) = component_and_options(rest)?;
    let joint = joint.ok_or("name the driven joint: torque:JOINT")?;
    let aggregation = if rms {
        only(&options, &[])?;
        Aggregation::PMean { p: 2.0 }
    } else {
        Aggregation::from_options(&options)?
    };
    let row = drive_row(model, joint)?;
    Ok(Box::new(Torque { row, aggregation }))
}

/// `NAME:JOINT` of a drive's integral.
fn parse_row(
    model: &Model,
    rest: Option<&str>,
    name: &str,
    of: fn(usize) -> Drive,
) -> Result<Box<dyn Family>, String> {
    let joint = rest.ok_or_else(|| format!("name the driven joint: {name}:JOINT"))?;
    Ok(Box::new(of(drive_row(model, joint)?)))
}

/// A drive's torque `τ = −λ` of its row condensed over the motion: an aggregate whose
/// points are the states.
#[derive(Debug)]
struct Torque {
    /// The driven constraint row.
    row: usize,
    /// How the torques are condensed.
    aggregation: Aggregation,
}

impl Family for Torque {
    fn weighting(&self) -> Weighting {
        Weighting::Mean
    }

    fn integrand(&self, _: &Context, at: Sample, known: Known) -> f64 {
        self.aggregation.point(at.lam[self.row], known.reference).0
    }

    fn add_partials(&self, _: &Context, at: Sample, known: Known, scale: f64, g: Partials) {
        g.lam[self.row] += scale * self.aggregation.point(at.lam[self.row], known.reference).1;
    }

    fn aggregation(&self) -> Option<Aggregation> {
        Some(self.aggregation)
    }

    fn peak(&self, _: &Context, at: Sample) -> f64 {
        at.lam[self.row].abs()
    }
}

/// Integrals over the motion of a drive's torque and its prescribed rate `ġ`.
#[derive(Debug)]
enum Drive {
    /// `∫ τ² dt`.
    TorqueSquared(usize),
    /// `∫ τ ġ dt`.
    Work(usize),
    /// `∫ max(τ ġ, 0) dt`.
    EnergyDrawn(usize),
}

impl Drive {
    fn row(&self) -> usize {
        match *self {
            Self::TorqueSquared(row) | Self::Work(row) | Self::EnergyDrawn(row) => row,
        }
    }

    /// The power `τ ġ` at a state.
    fn power(&self, ctx: &Context, at: Sample) -> f64 {
        let row = self.row();
        -at.lam[row] * drive_rate(ctx.model, row, at.t)
    }
}

impl Family for Drive {
    fn weighting(&self) -> Weighting {
        Weighting::Integral
    }

    fn integrand(&self, ctx: &Context, at: Sample, _: Known) -> f64 {
        match *self {
            Self::TorqueSquared(row) => at.lam[row] * at.lam[row],
            Self::Work(_) => self.power(ctx, at),
            Self::EnergyDrawn(_) => self.power(ctx, at).max(0.0),
        }
    }

    fn add_partials(&self, ctx: &Context, at: Sample, _: Known, scale: f64, g: Partials) {
        match *self {
            Self::TorqueSquared(row) => g.lam[row] += scale * 2.0 * at.lam[row],
            Self::EnergyDrawn(_) if self.power(ctx, at) <= 0.0 => {}
            Self::Work(row) | Self::EnergyDrawn(row) => {
                g.lam[row] -= scale * drive_rate(ctx.model, row, at.t);
            }
        }
    }

    /// A drive-law parameter moves `ġ`.
    fn parameter_partial(&self, ctx: &Context, at: Sample, _: Known, p: &Parameter) -> f64 {
        match *self {
            Self::TorqueSquared(_) => 0.0,
            Self::EnergyDrawn(_) if self.power(ctx, at) <= 0.0 => 0.0,
            Self::Work(row) | Self::EnergyDrawn(row) => {
                -at.lam[row] * p.drive_rate(ctx.model, row, at.t)
            }
        }
    }
}
