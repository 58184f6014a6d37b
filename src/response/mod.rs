//! Responses of the form of paper Eq. 8 and their partial derivatives, one file per family.
//!
//! A response is `f(x) = Σₙ wₙ G(qₙ, x)` over the recorded states: the time integral of
//! paper Eq. 8 by the trapezoidal rule (`w₀ = w_N = h/2`, `wₙ = h`, divided by `t_f` for the
//! means of Eq. 39–40), a final-time term (`w_N = 1`), or an explicit function of `x`
//! (volumes). The rule is second order and is the one differentiated, so gradients are
//! exact for the discrete scheme. A static scene has a single state.
//!
//! Each family ([`Family`]) gives its integrand `G` and the partials `G_q`, `G_λ`, `G_x`
//! (and `G_q̇`, `G_p` where it reads them) at a state, side by side in its own file; the
//! table [`KINDS`] registers its names, syntax and documentation, which the bindings hand
//! to Python. [`Objectives`] weights them over a run's states for the sensitivity sweeps.
//! A stress response is a mean of this form over the motion and the structure, of a power
//! or an exponential of the stresses, mapped to stress units at the end
//! ([`crate::response::aggregation`]).

pub(crate) mod aggregation;
mod arguments;
mod compliance;
pub(crate) mod criterion;
mod deflection;
mod displacement;
mod drive;
mod joint_position;
mod kinetic_energy;
mod objectives;
mod position;
mod reaction;
mod strain_energy;
mod strength;
mod volume;
mod von_mises;

pub(crate) use arguments::component_and_options;
pub(crate) use strength::aggregation_and_relaxation;

use std::fmt;

use crate::error::SettingsError;
use crate::mechanism::element::MassKind;
use crate::mechanism::linear::Linearized;
use crate::mechanism::model::{Analysis, Densities, Model};
use crate::mechanism::parameter::{Designed, Parameter};
use crate::response::aggregation::Aggregation;
use crate::time_grid::TimeGrid;

pub(crate) use objectives::Objectives;

/// A named kind of response: how it is written, what it measures, and its parser.
#[derive(Clone, Copy)]
pub struct Kind {
    /// The name before the first `:`.
    pub name: &'static str,
    /// How it is written, arguments in capitals and optional parts in brackets.
    pub syntax: &'static str,
    /// What it measures, with its units.
    pub doc: &'static str,
    /// Whether it condenses point values relative to their peak, so that a limit on it
    /// bounds the peak (Le et al.'s normalization): the stresses, buckling and a drive's
    /// torque, not a mean by definition such as the RMS torque.
    pub peak: bool,
    /// Its unit in SI ("1" for a ratio), for labels.
    pub unit: &'static str,
    /// How it is written on a spatial scene, where the spatial engine offers it
    /// (`scene/spatial/names.rs` reads it there); `None` where it does not.
    pub spatial: Option<&'static str>,
    /// Whether it is built for the states of a linear analysis: linear in them, explicit,
    /// or read on the linearized elements ([`Context::linear`]).
    pub linear: bool,
    /// Builds the response from a planar model and the text after the name's `:` (if any);
    /// `None` for a spatial scene's only.
    parse: Option<Parser>,
}

/// Builds a response of a kind from the model and the text after its name's `:` (if any),
/// or says what is wrong with it.
type Parser = fn(&Model, Option<&str>) -> Result<Box<dyn Family>, String>;

/// Every kind of response, of either engine, in the order the documentation lists them.
/// Registering a new family is one line here.
const KINDS: &[Kind] = &[
    compliance::KIND,
    strain_energy::KIND,
    deflection::KIND,
    volume::KIND,
    displacement::FINAL,
    displacement::INTEGRATED,
    strength::STRESS,
    strength::SHEAR,
    strength::BUCKLING,
    von_mises::KIND,
    drive::TORQUE,
    drive::TORQUE_RMS,
    drive::TORQUE_SQUARED,
    drive::WORK,
    drive::ENERGY_DRAWN,
    reaction::KIND,
    kinetic_energy::KIND,
    joint_position::KIND,
    position::X,
    position::Y,
    position::Z,
];

impl Kind {
    /// Whether a planar scene offers it.
    pub fn planar(&self) -> bool {
        self.parse.is_some()
    }
}

/// How a response weights the recorded states.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Weighting {
    /// Trapezoidal rule divided by the duration.
    Mean,
    /// Trapezoidal rule.
    Integral,
    /// The final state only.
    Final,
    /// No state: an explicit function of the design.
    Explicit,
}

/// A recorded state as responses read it: coordinates `q`, velocities `q̇` and multipliers
/// `λ` at time `t`.
#[derive(Debug, Clone, Copy)]
pub struct Sample<'a> {
    /// `qₙ`.
    pub q: &'a [f64],
    /// `q̇ₙ`: empty where a run does not keep them (no response reads them, or statics).
    pub v: &'a [f64],
    /// `λₙ`.
    pub lam: &'a [f64],
    /// `tₙ` (s): where a drive's prescribed rate is read.
    pub t: f64,
}

/// What the caller keeps for a response at a state besides the state itself.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Known {
    /// Rigid position of the response's tip node ([`Family::rigid_node`]).
    pub rigid: [f64; 2],
    /// Reference of an aggregate: at least the largest point value so far
    /// ([`Family::peak`]).
    pub reference: f64,
}

/// Where a response adds its partial derivatives, each scaled by the caller's weight.
pub struct Partials<'a> {
    /// `G_q`, one entry per DOF.
    pub q: &'a mut [f64],
    /// `G_λ`, one entry per constraint row.
    pub lam: &'a mut [f64],
    /// `G_x`, one entry per design variable (then per parameter, which families leave to
    /// [`Family::parameter_partial`]).
    pub x: &'a mut [f64],
}

/// What a response needs besides the state: the model, its densities and, for a static
/// scene, the load vector `F` (applied loads and gravity `M ĝ`) of the compliance `Fᵀu`.
pub struct Context<'a> {
    /// The mechanism.
    pub model: &'a Model,
    /// Element scalings of the design.
    pub densities: &'a Densities,
    /// Load vector of a static scene, empty for dynamics.
    pub static_load: &'a [f64],
    /// Inertia discretization (the gravity part of `F` depends on the densities through `M`).
    pub mass_kind: MassKind,
    /// The elements linearized about the reference, where the states are a linear
    /// analysis's (their energy is then the linear one).
    pub linear: Option<&'a Linearized>,
}

impl<'a> Context<'a> {
    /// The model and design, as the parameters' pseudo-loads read them.
    pub fn designed(&self) -> Designed<'a> {
        Designed {
            model: self.model,
            densities: self.densities,
            mass: self.mass_kind,
        }
    }

    /// The context of a dynamic run: no static load.
    pub fn dynamic(model: &'a Model, densities: &'a Densities, mass_kind: MassKind) -> Self {
        Self {
            model,
            densities,
            static_load: &[],
            mass_kind,
            linear: None,
        }
    }
}

/// A family of responses: its integrand and every partial derivative of it at a state.
/// Only [`Family::integrand`] and [`Family::add_partials`] are required; the others
/// default to a response that reads neither velocities, parameters nor a rigid trajectory
/// and is not an aggregate.
pub trait Family: fmt::Debug + Send + Sync {
    /// How the states are weighted in a dynamic run (a static scene has one final state).
    fn weighting(&self) -> Weighting;

    /// Integrand `G(qₙ, x)` at a state, with what the caller `known` at that state (the
    /// rigid position of a tip node, an aggregate's reference); for an explicit response,
    /// its value; for an aggregate, the state's share of the sum of [`Aggregation::point`]
    /// before the weight in time.
    fn integrand(&self, ctx: &Context, at: Sample, known: Known) -> f64;

    /// Adds `scale` times `G_q`, `G_λ` and `G_x` (per design variable) to `g`.
    fn add_partials(&self, ctx: &Context, at: Sample, known: Known, scale: f64, g: Partials);

    /// Whether `G` reads the velocities `q̇`.
    fn reads_velocities(&self) -> bool {
        false
    }

    /// Adds `scale · G_q̇` to `g_v`, for a response that reads velocities.
    fn add_rate_partials(&self, _ctx: &Context, _at: Sample, _scale: f64, _g_v: &mut [f64]) {}

    /// `∂G/∂p` of a scene parameter at a state.
    fn parameter_partial(&self, _ctx: &Context, _at: Sample, _known: Known, _p: &Parameter) -> f64 {
        0.0
    }

    /// The aggregation of an aggregate response, which condenses point values relative to a
    /// reference (the largest so far, [`Family::peak`]).
    fn aggregation(&self) -> Option<Aggregation> {
        None
    }

    /// The largest point value of an aggregate at a state.
    fn peak(&self, _ctx: &Context, _at: Sample) -> f64 {
        0.0
    }

    /// The node whose rigid trajectory the response needs.
    fn rigid_node(&self) -> Option<usize> {
        None
    }

    /// `G_r · ∂r_rigid/∂p`: the response's dependence on its rigid trajectory, which a
    /// drive-law parameter moves at `rate` (m per unit of it) at this state.
    fn rigid_partial(&self, _ctx: &Context, _at: Sample, _known: Known, _rate: [f64; 2]) -> f64 {
        0.0
    }
}

/// A response: one of the [`KINDS`], parsed against a model; it reads as its [`Family`].
#[derive(Debug)]
pub struct Response {
    family: Box<dyn Family>,
    /// The text it was parsed from, `name[:argument]`.
    text: String,
    /// Whether its kind is built for a linear analysis ([`Kind::linear`]).
    linear: bool,
}

impl std::ops::Deref for Response {
    type Target = dyn Family;

    fn deref(&self) -> &Self::Target {
        self.family.as_ref()
    }
}

impl Response {
    /// Parses `name[:argument]` by the [`KINDS`] table.
    ///
    /// # Errors
    /// A [`SettingsError`] naming the response if it is unknown or its argument is.
    pub fn parse(text: &str, model: &Model) -> Result<Self, SettingsError> {
        let err = |m: String| SettingsError::new(format!("response '{text}'"), m);
        let (name, rest) = text
            .split_once(':')
            .map_or((text, None), |(a, b)| (a, Some(b)));
        let planar = || {
            let names: Vec<&str> = (KINDS.iter().filter(|k| k.parse.is_some()))
                .map(|k| k.name)
                .collect();
            names.join(", ")
        };
        let Some(kind) = KINDS.iter().find(|k| k.name == name) else {
            return Err(err(format!("unknown response; use {}", planar())));
        };
        let Some(parse) = kind.parse else {
            let only = format!(
                "a spatial scene's response; a planar scene offers {}",
                planar()
            );
            return Err(err(only));
        };
        let family = parse(model, rest).map_err(err)?;
        Ok(Self {
            family,
            text: text.to_string(),
            linear: kind.linear,
        })
    }

    /// Every kind of response, by name: the table the bindings and the documentation read.
    pub fn kinds() -> &'static [Kind] {
        KINDS
    }

    /// The kinds a spatial scene offers, and how each is written there (the registry's
    /// `spatial`).
    pub fn spatial_kinds() -> impl Iterator<Item = (&'static str, &'static str)> {
        (KINDS.iter()).filter_map(|k| Some((k.name, k.spatial?)))
    }

    /// Weight `wₙ` of state `n` of `grid` (a grid without steps: a static state): the
    /// trapezoidal rule on the step times, divided by the duration for a mean.
    pub fn weight(&self, analysis: Analysis, n: usize, grid: &TimeGrid) -> f64 {
        let weighting = match self.family.weighting() {
            Weighting::Explicit => Weighting::Explicit,
            _ if analysis == Analysis::Static => Weighting::Final,
            w => w,
        };
        match weighting {
            Weighting::Mean => grid.trapezoid(n) / grid.duration(),
            Weighting::Integral => grid.trapezoid(n),
            Weighting::Final => f64::from(u8::from(n == grid.len())),
            Weighting::Explicit => 0.0,
        }
    }

    /// The factor on the integrand of a response that is a time sum by the trapezoidal rule
    /// (`1/t_f` for a mean, 1 for an integral) in a dynamic run of `duration`; `None` for a
    /// final value, an explicit one and any static response.
    pub fn per_time(&self, analysis: Analysis, duration: f64) -> Option<f64> {
        match self.family.weighting() {
            _ if analysis == Analysis::Static => None,
            Weighting::Mean => Some(1.0 / duration),
            Weighting::Integral => Some(1.0),
            Weighting::Final | Weighting::Explicit => None,
        }
    }

    /// Whether the response depends on the states at all.
    pub fn depends_on_states(&self) -> bool {
        self.family.weighting() != Weighting::Explicit
    }

    /// The response for a linear analysis, or a [`SettingsError`] naming it where it is not
    /// built for one ([`Kind::linear`]).
    ///
    /// # Errors
    /// As above.
    pub fn check_linear(&self) -> Result<(), SettingsError> {
        if self.linear {
            return Ok(());
        }
        let built: Vec<&str> = KINDS.iter().filter(|k| k.linear).map(|k| k.name).collect();
        Err(SettingsError::new(
            format!("response '{}'", self.text),
            format!(
                "not built for the linear analysis (it reads the nonlinear elements or a \
                 motion); the linear analysis offers {}",
                built.join(", ")
            ),
        ))
    }

    /// Whether the response reads the velocities `q̇`.
    pub fn reads_velocities(&self) -> bool {
        self.family.reads_velocities()
    }

    /// The node whose rigid trajectory the response needs.
    pub fn rigid_node(&self) -> Option<usize> {
        self.family.rigid_node()
    }
}
