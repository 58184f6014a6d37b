//! The rates of a spatial mechanism's natural modes ([`crate::spatial::modal`]) to its
//! parameters, the configuration and the multipliers held:
//!
//! `∂ω²/∂p = φᵀ (∂K_t/∂p − ω² ∂M/∂p) φ`   (`φ` mass-normalized, `ω²` simple)
//!
//! element by element: a beam's or truss bar's stiffness factor reads its tangent at the
//! configuration (material and geometric: both linear in the factor), its mass factor its
//! mass matrix, a beam's section size both with its section's rate
//! ([`crate::spatial::beam::Beam::section_rate`]); a body's mass and inertia entries their
//! blocks of `M`. Exact about an unloaded reference, where `K_t` does not move with a
//! parameter through the state; about a loaded equilibrium the state's own change
//! (`∂K_t/∂q · dq/dp`, the prestress moving with the parameter) is left out, as the planar
//! engine's design derivatives leave it ([`crate::modal`]). Within a cluster of equal `ω²`
//! a single mode's rate is not defined, only symmetric functions of the cluster's: their
//! sum is the sum of these.

use nalgebra::Vector3;

use crate::error::SettingsError;
use crate::group::pair::Stiffness;
use crate::group::{six, split, NV};
use crate::spatial::element::{Derivatives, Element};
use crate::spatial::force::Local;
use crate::spatial::model::SpatialModel;
use crate::spatial::sensitivity::Parameter;

/// `∂ω²_k/∂p_j` (rad²/s² per unit of the parameter) of each mode `(ω²_k, φ_k)` about
/// configuration `q` (module docs): one row per mode.
///
/// # Errors
/// [`SettingsError`] for a `q` or a shape of the wrong length, a parameter the mechanism
/// does not have, or one a mode's rate is not built for (springs, motors, drives).
pub fn omega_squared_rates(
    model: &SpatialModel,
    q: &[f64],
    omega_squared: &[f64],
    shapes: &[Vec<f64>],
    parameters: &[Parameter],
) -> Result<Vec<Vec<f64>>, SettingsError> {
    let n_v = model.n_v();
    if q.len() != model.n_q() || shapes.iter().any(|phi| phi.len() != n_v) {
        return Err(SettingsError::new(
            "modes",
            format!(
                "a configuration of {} numbers and shapes of {n_v} each",
                model.n_q()
            ),
        ));
    }
    let rest = vec![0.0; n_v];
    let rates = parameters
        .iter()
        .enumerate()
        .map(|(k, p)| Rate::of(model, q, &rest, p, k))
        .collect::<Result<Vec<_>, _>>()?;
    Ok((omega_squared.iter().zip(shapes))
        .map(|(&w2, phi)| rates.iter().map(|r| r.of_mode(w2, phi)).collect())
        .collect())
}

/// What a parameter moves of `K_t` and `M`, at the held configuration.
enum Rate {
    /// A body's mass: `∂M` the identity on its node's displacement.
    Mass(usize),
    /// A body's inertia entry `(i, j)` and its symmetric one on its node's rotation.
    Inertia(usize, usize, usize),
    /// An element's `∂K` and `∂M` on its nodes' twelve unknowns.
    Element([usize; 2], Box<Stiffness>, Box<Stiffness>),
    /// Nothing the modes read (a density as a stress's relaxation reads it).
    None,
}

impl Rate {
    /// What `p` (parameter `k`) moves at `q`, at rest (`rest` the zero velocities).
    fn of(
        model: &SpatialModel,
        q: &[f64],
        rest: &[f64],
        p: &Parameter,
        k: usize,
    ) -> Result<Self, SettingsError> {
        let missing = |what: &str, index: usize, count: usize| {
            SettingsError::new(
                format!("parameters[{k}]"),
                format!("no {what} {index} (the mechanism has {count})"),
            )
        };
        let beam =
            |b: usize| (model.beams.get(b)).ok_or_else(|| missing("beam", b, model.beams.len()));
        let truss = |t: usize| {
            (model.trusses.get(t)).ok_or_else(|| missing("truss bar", t, model.trusses.len()))
        };
        let body = |b: usize| {
            (model.bodies.get(b))
                .map(|body| body.node)
                .ok_or_else(|| missing("body", b, model.bodies.len()))
        };
        let element = |e: &dyn Element, stiffness: bool| {
            let (k, m) = match stiffness {
                true => (tangent(e, q, rest), Stiffness::zeros()),
                false => (Stiffness::zeros(), e.mass_matrix()),
            };
            Rate::Element(e.nodes(), Box::new(k), Box::new(m))
        };
        Ok(match *p {
            Parameter::Mass { body: b } => Rate::Mass(body(b)?),
            Parameter::Inertia { body: b, i, j } => match i < 3 && j < 3 {
                true => Rate::Inertia(body(b)?, i, j),
                false => {
                    return Err(SettingsError::new(
                        format!("parameters[{k}]"),
                        format!("inertia entry ({i}, {j}): 0, 1 or 2 each"),
                    ))
                }
            },
            Parameter::BeamStiffness { beam: b } => element(beam(b)?, true),
            Parameter::BeamMass { beam: b } => element(beam(b)?, false),
            Parameter::TrussStiffness { truss: t } => element(truss(t)?, true),
            Parameter::TrussMass { truss: t } => element(truss(t)?, false),
            Parameter::BeamSize { beam: b, dimension } => {
                let beam = beam(b)?;
                let rate = beam.section_rate(dimension).ok_or_else(|| {
                    SettingsError::new(
                        format!("parameters[{k}]"),
                        format!("beam {b}'s section has no {dimension:?}"),
                    )
                })?;
                let k = beam.tangent_of(&rate, q, rest);
                Rate::Element(
                    beam.nodes(),
                    Box::new(k),
                    Box::new(beam.mass_matrix_of(&rate)),
                )
            }
            Parameter::BeamDensity { .. } | Parameter::TrussDensity { .. } => Rate::None,
            _ => {
                return Err(SettingsError::new(
                    format!("parameters[{k}]"),
                    format!(
                        "{p:?}: a natural mode's rate to it is not built (a body's mass and \
                         inertia, a beam's or truss bar's stiffness, mass and section size are)"
                    ),
                ))
            }
        })
    }

    /// `φᵀ (∂K − ω² ∂M) φ` for a mode.
    fn of_mode(&self, w2: f64, phi: &[f64]) -> f64 {
        match self {
            Rate::Mass(node) => -w2 * split(&six(phi, *node)).0.norm_squared(),
            Rate::Inertia(node, i, j) => {
                let turn = split(&six(phi, *node)).1;
                let twice = if i == j { 1.0 } else { 2.0 };
                -w2 * twice * turn[*i] * turn[*j]
            }
            Rate::Element(nodes, k, m) => {
                let mut local = Local::zeros();
                for (side, node) in nodes.iter().enumerate() {
                    local
                        .fixed_rows_mut::<NV>(NV * side)
                        .copy_from_slice(&six(phi, *node));
                }
                local.dot(&(k.as_ref() * local)) - w2 * local.dot(&(m.as_ref() * local))
            }
            Rate::None => 0.0,
        }
    }
}

/// An element's tangent `∂f/∂q` at `q`, at rest (`rest` the zero velocities).
fn tangent(e: &dyn Element, q: &[f64], rest: &[f64]) -> Stiffness {
    let mut d = Derivatives::zeros();
    e.terms(q, rest, None, &Vector3::zeros(), Some(&mut d));
    d.stiffness
}
