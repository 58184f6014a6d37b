//! Responses of the form of paper Eq. 8 and their partial derivatives.
//!
//! A response is `f(x) = Σₙ wₙ G(qₙ, x)` over the recorded states: the time integral of
//! paper Eq. 8 by the trapezoidal rule (`w₀ = w_N = h/2`, `wₙ = h`, divided by `t_f` for the
//! means of Eq. 39–40), a final-time term (`w_N = 1`), or an explicit function of `x`
//! (volumes). The rule is second order and is the one differentiated, so gradients are
//! exact for the discrete scheme. A static scene has a single state.
//!
//! Each response gives its integrand `G` and the partials `G_q`, `G_x` at a state. A stress
//! response is a mean of this form over the motion and the structure, of a power or an
//! exponential of the stresses, mapped to stress units at the end ([`crate::aggregate`]).

use nalgebra::Vector3;

use crate::aggregate::Aggregation;
use crate::constraint::ConstraintRow;
use crate::element::{MassKind, Vector6};
use crate::error::SettingsError;
use crate::model::{Analysis, Densities, Model};
use crate::parameter::{Designed, Parameter};
use crate::section::Section;
use crate::stress::{ElementState, Measure};
use crate::time_grid::TimeGrid;

/// What a response measures.
#[derive(Debug, Clone, PartialEq)]
pub enum Response {
    /// Mean compliance over the motion, `(1/t_f) ∫ U dt` with `U` the strain energy of one
    /// component or all (paper Eq. 37, 39); for a static scene the compliance `Fᵀu`.
    Compliance {
        /// Component, or `None` for the sum over all.
        component: Option<usize>,
    },
    /// Mean squared deflection `(1/t_f) ∫ |r − r_rigid|² dt` of a node from its rigid
    /// trajectory (paper Eq. 40).
    TipDeflection {
        /// The node.
        node: usize,
    },
    /// Material volume `Σ x_e V_e` of one component or all (paper Eq. 38, 41), m³.
    Volume {
        /// Component, or `None` for all.
        component: Option<usize>,
    },
    /// Displacement of a node along a unit direction at the final time (m).
    FinalDisplacement {
        /// The node.
        node: usize,
        /// Unit direction.
        direction: [f64; 2],
    },
    /// Time integral of a node's displacement along a unit direction (m s).
    IntegratedDisplacement {
        /// The node.
        node: usize,
        /// Unit direction.
        direction: [f64; 2],
    },
    /// A [`Measure`] (fibre stresses in Pa, or Euler buckling ratios) at the points of the
    /// elements of one bar, one component or all, condensed over the motion (trapezoidal in time) and
    /// the structure's length by a p-mean or KS mean. The measures use full-density section
    /// forces, so `x⁰` gives the solid material's value; `x^q` with `q > 0` is the
    /// relaxation that keeps vanishing bars from dominating (Le et al. 2010 use `q = ½`).
    Aggregate(Aggregated),
    /// The torque a drive applies on the structure, `τ = −λ` of its driven row (N m),
    /// condensed over the motion (trapezoidal in time) by a p-mean or KS mean: `p = 2` is
    /// the RMS torque a motor is sized by for heat, a large `p` approaches the peak it must
    /// deliver.
    Torque {
        /// The driven constraint row.
        row: usize,
        /// How the torques are condensed.
        aggregation: Aggregation,
    },
    /// The work a drive does on the structure over the motion, `∫ τ ġ dt` with `τ = −λ` of
    /// its row and `ġ` its prescribed rate (J): positive where the motor drives, negative
    /// where it brakes.
    DriveWork {
        /// The driven constraint row.
        row: usize,
    },
    /// The integral over the motion of a drive's squared torque (or a slider drive's squared
    /// force), `∫ τ² dt` (N² m² s): the copper losses a motor is sized by.
    TorqueSquared {
        /// The driven constraint row.
        row: usize,
    },
    /// The energy a drive draws, `∫ max(τ ġ, 0) dt` (J): its work where it drives, none
    /// recovered where it brakes. Its gradient is exact wherever the power does not pass
    /// through zero at a step's time.
    EnergyDrawn {
        /// The driven constraint row.
        row: usize,
    },
    /// The time integral of the kinetic energy `½ q̇ᵀ M q̇` over the motion (J s).
    KineticEnergy,
    /// A joint's own coordinate at the final time ([`crate::constraint::Joint::coordinate`]):
    /// a pin's rotation or a hinge's relative rotation from the reference (rad), a slider's
    /// travel (m).
    JointPosition {
        /// The coordinate as a constraint row's law.
        row: ConstraintRow,
    },
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

/// An aggregate response: what it measures, where, and how it condenses.
#[derive(Debug, Clone, PartialEq)]
pub struct Aggregated {
    /// What is measured.
    pub measure: Measure,
    /// The elements aggregated.
    pub members: Members,
    /// How the point values are condensed.
    pub aggregation: Aggregation,
    /// Relaxation exponent `q`.
    pub relaxation: f64,
    /// Total length of the elements aggregated (m), the weight of an element being its
    /// share of it.
    pub length: f64,
}

impl Aggregated {
    /// Element `e` with its full-density section `forces` at the state.
    fn element<'a>(&self, ctx: &'a Context, e: usize, forces: Vector3<f64>) -> ElementState<'a> {
        let m = ctx.model;
        let el = &m.elements[e];
        ElementState {
            element: el,
            bar_length: m.bars[el.bar].volume / el.beam.section.area,
            relax: ctx.densities.density[e].powf(self.relaxation),
            forces,
        }
    }

    /// Element `e` at state `q` (its section forces, no Jacobian).
    fn element_at<'a>(&self, ctx: &'a Context, e: usize, q: &[f64]) -> ElementState<'a> {
        let el = &ctx.model.elements[e];
        self.element(ctx, e, el.beam.section_forces(&el.gather(q)))
    }

    /// `Σ_e (L_e/L) Σ_k w_k φ(v_k; r)`: the state's share of the sum before the weight in time.
    fn sum(&self, ctx: &Context, q: &[f64], reference: f64) -> f64 {
        let mut sum = 0.0;
        for e in self.members.elements(ctx.model) {
            let el = self.element_at(ctx, e, q);
            let share = el.element.beam.length / self.length;
            self.measure.for_each_point(&el, |w, c| {
                sum += share * w * self.aggregation.point(c.dot(&el.forces), reference).0;
            });
        }
        sum
    }

    /// `∂/∂p` of [`Self::sum`] at state `q` for section `section` changing at `rate`:
    /// through the section forces `(∂D/∂p) [e, θ₁, θ₂]` and the points' coefficients.
    fn parameter_partial(
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
                .beam
                .section_forces_and_rate(&element.gather(q), rate);
            let el = self.element(ctx, e, forces);
            let share = element.beam.length / self.length;
            self.measure
                .for_each_point_and_rate(&el, Some(rate), |w, c, d_c| {
                    let (v, d_v) = (c.dot(&el.forces), d_c.dot(&el.forces) + c.dot(&d_forces));
                    partial += share * w * self.aggregation.point(v, reference).1 * d_v;
                });
        }
        partial
    }

    /// The largest point value at state `q`.
    fn peak(&self, ctx: &Context, q: &[f64]) -> f64 {
        self.members
            .elements(ctx.model)
            .map(|e| self.measure.peak(&self.element_at(ctx, e, q)))
            .fold(0.0, f64::max)
    }

    /// Adds `scale` times the partials of [`Self::sum`] to `g_q` and `g_x`.
    fn add_partials(
        &self,
        ctx: &Context,
        q: &[f64],
        reference: f64,
        scale: f64,
        g_q: &mut [f64],
        g_x: &mut [f64],
    ) {
        let m = ctx.model;
        for e in self.members.elements(m) {
            let element = &m.elements[e];
            let (forces, jacobian) = element.beam.section_forces_and_jacobian(&element.gather(q));
            let el = self.element(ctx, e, forces);
            let share = scale * el.element.beam.length / self.length;
            let (x, dofs, variable) = (
                ctx.densities.density[e],
                el.element.dofs(),
                m.variable_of(e),
            );
            self.measure.for_each_point(&el, |w, c| {
                let v = c.dot(&el.forces);
                let slope = share * w * self.aggregation.point(v, reference).1;
                let d_v = jacobian.transpose() * c;
                dofs.iter()
                    .zip(d_v.iter())
                    .for_each(|(&d, g)| g_q[d] += slope * g);
                // ∂v/∂x = q x^{q−1} v_solid = (q/x) v.
                if let Some(j) = variable {
                    g_x[j] += slope * self.relaxation / x * v;
                }
            });
        }
    }
}

/// The elements an aggregate reads: all, a component's, or one bar's (per-bar limits).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Members {
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

/// What the caller keeps for a response at a state besides the state itself.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Known {
    /// Rigid position of the response's tip node ([`Response::rigid_node`]).
    pub rigid: [f64; 2],
    /// Reference of an aggregate: at least the largest point value so far
    /// ([`Response::peak`]).
    pub reference: f64,
}

/// The relaxation exponent used unless a response names one (Le et al. 2010).
pub const DEFAULT_RELAXATION: f64 = 0.5;

/// How a response weights the recorded states.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Weighting {
    /// Trapezoidal rule divided by the duration.
    Mean,
    /// Trapezoidal rule.
    Integral,
    /// The final state only.
    Final,
    /// No state: an explicit function of the design.
    Explicit,
}

impl Response {
    /// Parses `name[:argument]`: `compliance[:COMPONENT]`, `tip_deflection[:NODE]`,
    /// `volume[:COMPONENT]`, `displacement:NODE:DX,DY`, `integrated_displacement:NODE:DX,DY`
    /// (direction normalized).
    ///
    /// # Errors
    /// A [`SettingsError`] naming the response if it is unknown or its argument is.
    pub fn parse(text: &str, model: &Model) -> Result<Self, SettingsError> {
        let err = |m: String| SettingsError::new(format!("response '{text}'"), m);
        let (name, rest) = text
            .split_once(':')
            .map_or((text, None), |(a, b)| (a, Some(b)));
        let component = |arg: Option<&str>| match arg {
            None => Ok(None),
            Some(c) => model
                .components
                .iter()
                .position(|x| x == c)
                .map(Some)
                .ok_or_else(|| {
                    err(format!(
                        "unknown component '{c}' (components: {})",
                        model.components.join(", ")
                    ))
                }),
        };
        let node = |n: &str| {
            model
                .node_index(n)
                .ok_or_else(|| err(format!("unknown node '{n}'")))
        };
        let node_and_direction = |arg: Option<&str>| -> Result<(usize, [f64; 2]), SettingsError> {
            let arg = arg.ok_or_else(|| err("needs NODE:DX,DY".into()))?;
            let (n, d) = arg
                .rsplit_once(':')
                .ok_or_else(|| err("needs NODE:DX,DY".into()))?;
            let v: Vec<f64> = d
                .split(',')
                .map(|s| s.trim().parse::<f64>())
                .collect::<Result<_, _>>()
                .map_err(|e| err(format!("direction: {e}")))?;
            let norm = v.iter().map(|c| c * c).sum::<f64>().sqrt();
            if v.len() != 2 || !(norm.is_finite() && norm > 0.0) {
                return Err(err(
                    "direction must be two finite numbers, not both zero".into()
                ));
            }
            Ok((node(n)?, [v[0] / norm, v[1] / norm]))
        };
        match name {
            "compliance" if model.analysis == Analysis::Static && rest.is_some() => Err(err("static compliance Fᵀu is global; drop the component".into())),
            "compliance" => Ok(Self::Compliance { component: component(rest)? }),
            "volume" => Ok(Self::Volume { component: component(rest)? }),
            "tip_deflection" => {
                if model.analysis == Analysis::Static {
                    return Err(err("a static scene has no motion to deflect from".into()));
                }
                let n = match rest {
                    Some(n) => node(n)?,
                    None => model.tip.ok_or_else(|| err("the scene has no `tip`; write tip_deflection:NODE".into()))?,
                };
                Ok(Self::TipDeflection { node: n })
            }
            "displacement" => node_and_direction(rest).map(|(node, direction)| Self::FinalDisplacement { node, direction }),
            "integrated_displacement" => node_and_direction(rest).map(|(node, direction)| Self::IntegratedDisplacement { node, direction }),
            "stress" | "shear" | "buckling" => {
                let measure = match name {
                    "stress" => Measure::Stress,
                    "shear" => Measure::Shear,
                    _ => Measure::Buckling,
                };
                let (members, options) = component_and_options(rest).map_err(err)?;
                let members = Members::parse(model, members).map_err(err)?;
                Self::aggregate(model, measure, members, &options).map_err(err)
            }
            "torque" | "torque_rms" => Self::torque(model, name == "torque_rms", rest).map_err(err),
            "drive_work" => {
                let joint = rest.ok_or_else(|| err("name the driven joint: drive_work:JOINT".into()))?;
                Ok(Self::DriveWork { row: drive_row(model, joint).map_err(err)? })
            }
            "torque_squared" => {
                let joint = rest.ok_or_else(|| err("name the driven joint: torque_squared:JOINT".into()))?;
                Ok(Self::TorqueSquared { row: drive_row(model, joint).map_err(err)? })
            }
            "energy_drawn" => {
                let joint = rest.ok_or_else(|| err("name the driven joint: energy_drawn:JOINT".into()))?;
                Ok(Self::EnergyDrawn { row: drive_row(model, joint).map_err(err)? })
            }
            "kinetic_energy" if rest.is_none() => {
                if model.analysis == Analysis::Static {
                    return Err(err("a static scene has no motion: kinetic energy is a response of a dynamic one".into()));
                }
                Ok(Self::KineticEnergy)
            }
            "joint_position" => {
                let name = rest.ok_or_else(|| err("name the joint: joint_position:JOINT".into()))?;
                let j = joint_index(model, name).map_err(err)?;
                let row = model.joints[j].coordinate(j).ok_or_else(|| {
                    err(format!("joint '{name}' is a {}: it holds every coordinate, so it has no position", model.joints[j].kind.name()))
                })?;
                Ok(Self::JointPosition { row })
            }
            _ => Err(err("unknown response; use compliance, tip_deflection, volume, displacement, integrated_displacement, stress, shear, buckling, torque, torque_rms, torque_squared, drive_work, energy_drawn, kinetic_energy or joint_position".into())),
        }
    }

    /// An aggregate of `measure` over `members` from `key=value` options `p`, `ks`,
    /// `scale`, `q`.
    fn aggregate(
        model: &Model,
        measure: Measure,
        members: Members,
        options: &[(String, f64)],
    ) -> Result<Self, String> {
        let get = |key: &str| options.iter().find(|(k, _)| k == key).map(|&(_, v)| v);
        if let Some((k, _)) = options
            .iter()
            .find(|(k, _)| !["p", "ks", "scale", "q"].contains(&k.as_str()))
        {
            return Err(format!("unknown option '{k}' (options: p, ks, scale, q)"));
        }
        let aggregation = Aggregation::parse(get("p"), get("ks"), get("scale"))?;
        let relaxation = get("q").unwrap_or(DEFAULT_RELAXATION);
        if !(0.0..=1.0).contains(&relaxation) {
            return Err(format!("relaxation q={relaxation} must lie in [0, 1]"));
        }
        let elements: Vec<usize> = members.elements(model).collect();
        if elements.is_empty() {
            return Err("the structure named has no elements".into());
        }
        let section = |e: usize| &model.elements[e].beam.section;
        let missing = match measure {
            Measure::Stress => elements
                .iter()
                .find(|&&e| section(e).fibre.is_none())
                .map(|&e| (e, "outer-fibre distance; give `c`")),
            Measure::Shear => elements
                .iter()
                .find(|&&e| section(e).shear_factor.is_none())
                .map(|&e| (e, "peak shear factor; give `shear_factor`")),
            Measure::Buckling => None,
        };
        if let Some((e, what)) = missing {
            return Err(format!(
                "the section of bar '{}' has no {what} in its [sections] entry",
                model.bars[model.elements[e].bar].name
            ));
        }
        let length = elements
            .iter()
            .map(|&e| model.elements[e].beam.length)
            .sum();
        Ok(Self::Aggregate(Aggregated {
            measure,
            members,
            aggregation,
            relaxation,
            length,
        }))
    }

    /// A drive's torque, `torque:JOINT[:p=P|ks=RHO,scale=S]` or `torque_rms:JOINT`.
    fn torque(model: &Model, rms: bool, rest: Option<&str>) -> Result<Self, String> {
        let (joint, options) = component_and_options(rest)?;
        let joint = joint.ok_or("name the driven joint: torque:JOINT")?;
        let get = |key: &str| options.iter().find(|(k, _)| k == key).map(|&(_, v)| v);
        let allowed: &[&str] = if rms { &[] } else { &["p", "ks", "scale"] };
        if let Some((k, _)) = options.iter().find(|(k, _)| !allowed.contains(&k.as_str())) {
            return Err(format!(
                "unknown option '{k}' (options: {})",
                if rms {
                    "none".into()
                } else {
                    allowed.join(", ")
                }
            ));
        }
        let row = drive_row(model, joint)?;
        let aggregation = if rms {
            Aggregation::PMean { p: 2.0 }
        } else {
            Aggregation::parse(get("p"), get("ks"), get("scale"))?
        };
        Ok(Self::Torque { row, aggregation })
    }

    fn weighting(&self, analysis: Analysis) -> Weighting {
        match (self, analysis) {
            (Self::Volume { .. }, _) => Weighting::Explicit,
            (_, Analysis::Static) | (Self::FinalDisplacement { .. }, _) => Weighting::Final,
            (Self::JointPosition { .. }, _) => Weighting::Final,
            (
                Self::IntegratedDisplacement { .. }
                | Self::TorqueSquared { .. }
                | Self::DriveWork { .. }
                | Self::EnergyDrawn { .. }
                | Self::KineticEnergy,
                _,
            ) => Weighting::Integral,
            _ => Weighting::Mean,
        }
    }

    /// Weight `wₙ` of state `n` of `grid` (a grid without steps: a static state): the
    /// trapezoidal rule on the step times, divided by the duration for a mean.
    pub fn weight(&self, analysis: Analysis, n: usize, grid: &TimeGrid) -> f64 {
        match self.weighting(analysis) {
            Weighting::Mean => grid.trapezoid(n) / grid.duration(),
            Weighting::Integral => grid.trapezoid(n),
            Weighting::Final => f64::from(u8::from(n == grid.len())),
            Weighting::Explicit => 0.0,
        }
    }

    /// Whether the response depends on the states at all.
    pub fn depends_on_states(&self) -> bool {
        !matches!(self, Self::Volume { .. })
    }

    /// Whether the response reads the velocities `q̇`.
    pub fn reads_velocities(&self) -> bool {
        matches!(self, Self::KineticEnergy)
    }
}

/// Calls `add(d, (M v)_d)` for the mass matrix `M(x)` of the design (beams scaled by
/// `m(x_e)`, point masses and bodies) times `v` (nothing for an empty `v`).
fn add_mass_times(ctx: &Context, v: &[f64], mut add: impl FnMut(usize, f64)) {
    if v.is_empty() {
        return;
    }
    let m = ctx.model;
    for (e, el) in m.elements.iter().enumerate() {
        let p = el.beam.mass_matrix(ctx.mass_kind) * el.gather(v) * ctx.densities.mass[e];
        el.dofs()
            .iter()
            .zip(p.iter())
            .for_each(|(&d, &x)| add(d, x));
    }
    for pm in &m.point_masses {
        let d = 3 * pm.node;
        add(d, pm.mass * v[d]);
        add(d + 1, pm.mass * v[d + 1]);
        add(d + 2, pm.inertia * v[d + 2]);
    }
}

/// The prescribed rate `ġ(t)` of driven row `row`.
fn drive_rate(model: &Model, row: usize, t: f64) -> f64 {
    let r = &model.rows[row];
    model.joints[r.joint].prescribed(r, t)[1]
}

/// The index of the joint called `name`.
fn joint_index(model: &Model, name: &str) -> Result<usize, String> {
    model
        .joints
        .iter()
        .position(|j| j.name == name)
        .ok_or_else(|| {
            let names: Vec<&str> = model.joints.iter().map(|j| j.name.as_str()).collect();
            format!("unknown joint '{name}' (joints: {})", names.join(", "))
        })
}

/// The driven constraint row of the joint called `name`.
fn drive_row(model: &Model, name: &str) -> Result<usize, String> {
    if model.analysis == Analysis::Static {
        return Err(
            "a static scene has no motion to drive; torques are responses of a dynamic one".into(),
        );
    }
    let index = joint_index(model, name)?;
    model
        .rows
        .iter()
        .position(|r| r.joint == index && r.driven)
        .ok_or(format!(
            "joint '{name}' has no drive: a drive's torque (−λ of its row) is a response, a \
             motor's is its input"
        ))
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
        }
    }
}

impl Response {
    /// `∂G/∂p` of a scene parameter at a state: the compliance's (a static scene's load
    /// `F` follows masses, motors and sections' `ρ`; the strain energy follows sections'
    /// stiffness), the volume's (a section's diameter) and the aggregates' (stresses and
    /// buckling read the section through its forces and their coefficients, with `known`'s
    /// reference); zero for the others, which do not read a parameter.
    pub fn parameter_partial(&self, ctx: &Context, at: Sample, known: Known, p: &Parameter) -> f64 {
        let m = ctx.model;
        match (self, p.section()) {
            (Self::Aggregate(a), Some((section, rate))) => {
                a.parameter_partial(ctx, at.q, known.reference, section, rate)
            }
            (Self::Compliance { .. }, _) if m.analysis == Analysis::Static => {
                let mut g = 0.0;
                p.load_rate(&ctx.designed(), at.t, |i, v| g += v * at.q[i]);
                g
            }
            (Self::Compliance { component }, Some((section, rate))) => elements_of(m, *component)
                .filter(|&e| m.bars[m.elements[e].bar].section == section)
                .map(|e| {
                    let el = &m.elements[e];
                    ctx.densities.stiffness[e] * el.beam.strain_energy_rate(&el.gather(at.q), rate)
                })
                .sum(),
            (Self::DriveWork { row }, _) => -at.lam[*row] * p.drive_rate(m, *row, at.t),
            (Self::EnergyDrawn { row }, _) if -at.lam[*row] * drive_rate(m, *row, at.t) > 0.0 => {
                -at.lam[*row] * p.drive_rate(m, *row, at.t)
            }
            (Self::KineticEnergy, _) => 0.5 * p.mass_rate_times(&ctx.designed(), at.v, at.v),
            (Self::Volume { component }, Some((section, rate))) => m
                .bars
                .iter()
                .filter(|b| b.section == section && component.is_none_or(|c| b.component == c))
                .map(|b| {
                    let area = m.sections[section].section.area;
                    ctx.densities.density[b.elements.start] * b.volume * rate.area / area
                })
                .sum(),
            _ => 0.0,
        }
    }

    /// Integrand `G(qₙ, x)` at state `n`, with what the caller `known` at that state (the
    /// rigid position of a tip node, an aggregate's reference); for [`Response::Volume`],
    /// the volume; for [`Response::Aggregate`], the state's share of the sum of
    /// [`Aggregation::point`] before the weight in time.
    pub fn integrand(&self, ctx: &Context, at: Sample, known: Known) -> f64 {
        let (m, q) = (ctx.model, at.q);
        match *self {
            Self::Compliance { .. } if m.analysis == Analysis::Static => {
                ctx.static_load.iter().zip(q).map(|(f, u)| f * u).sum()
            }
            Self::Compliance { component } => elements_of(m, component)
                .map(|e| {
                    ctx.densities.stiffness[e]
                        * m.elements[e].beam.strain_energy(&m.elements[e].gather(q))
                })
                .sum(),
            Self::TipDeflection { node } => {
                let r = known.rigid;
                let p = m.nodes[node].position;
                (p.x + q[3 * node] - r[0]).powi(2) + (p.y + q[3 * node + 1] - r[1]).powi(2)
            }
            Self::Volume { component } => m
                .bars
                .iter()
                .filter(|b| component.is_none_or(|c| b.component == c))
                .map(|b| ctx.densities.density[b.elements.start] * b.volume)
                .sum(),
            Self::FinalDisplacement { node, direction }
            | Self::IntegratedDisplacement { node, direction } => {
                direction[0] * q[3 * node] + direction[1] * q[3 * node + 1]
            }
            Self::Aggregate(ref a) => a.sum(ctx, q, known.reference),
            Self::Torque { row, aggregation } => aggregation.point(at.lam[row], known.reference).0,
            Self::TorqueSquared { row } => at.lam[row] * at.lam[row],
            Self::DriveWork { row } => -at.lam[row] * drive_rate(m, row, at.t),
            Self::EnergyDrawn { row } => (-at.lam[row] * drive_rate(m, row, at.t)).max(0.0),
            Self::KineticEnergy => {
                let mut g = 0.0;
                add_mass_times(ctx, at.v, |d, p| g += 0.5 * at.v[d] * p);
                g
            }
            Self::JointPosition { row } => row.evaluate(q).0,
        }
    }

    /// The largest point value of an aggregate at a state (0 for other responses).
    pub fn peak(&self, ctx: &Context, at: Sample) -> f64 {
        match *self {
            Self::Aggregate(ref a) => a.peak(ctx, at.q),
            Self::Torque { row, .. } => at.lam[row].abs(),
            _ => 0.0,
        }
    }

    /// The aggregation of an aggregate response.
    pub fn aggregation(&self) -> Option<Aggregation> {
        match *self {
            Self::Aggregate(ref a) => Some(a.aggregation),
            Self::Torque { aggregation, .. } => Some(aggregation),
            _ => None,
        }
    }

    /// Adds `scale · G_q` to `g_q`, `scale · G_λ` to `g_lam` and `scale · G_x` to `g_x`
    /// (per design variable).
    #[allow(clippy::too_many_arguments)]
    pub fn add_partials(
        &self,
        ctx: &Context,
        at: Sample,
        known: Known,
        scale: f64,
        g_q: &mut [f64],
        g_lam: &mut [f64],
        g_x: &mut [f64],
    ) {
        let (m, q) = (ctx.model, at.q);
        match *self {
            Self::Compliance { .. } if m.analysis == Analysis::Static => {
                g_q.iter_mut()
                    .zip(ctx.static_load)
                    .for_each(|(g, f)| *g += scale * f);
                // ∂F/∂x_e = M_e ĝ (gravity on the element's mass).
                let g = m.gravity;
                let gravity = Vector6::from([g.x, g.y, 0.0, g.x, g.y, 0.0]);
                for (e, el) in m.elements.iter().enumerate() {
                    if let (Some(v), true) = (m.variable_of(e), g.norm() > 0.0) {
                        let rate = el.beam.mass_matrix(ctx.mass_kind)
                            * gravity
                            * ctx.densities.mass_rate[e];
                        g_x[v] += scale * rate.dot(&el.gather(q));
                    }
                }
            }
            Self::Compliance { component } => {
                for e in elements_of(m, component) {
                    let el = &m.elements[e];
                    let u = el.gather(q);
                    let (s, rate) = (ctx.densities.stiffness[e], ctx.densities.stiffness_rate[e]);
                    let f = el.beam.internal_force(&u);
                    el.dofs()
                        .iter()
                        .zip(f.iter())
                        .for_each(|(&d, fi)| g_q[d] += scale * s * fi);
                    if let Some(v) = m.variable_of(e) {
                        g_x[v] += scale * rate * el.beam.strain_energy(&u);
                    }
                }
            }
            Self::TipDeflection { node } => {
                let r = known.rigid;
                let p = m.nodes[node].position;
                g_q[3 * node] += scale * 2.0 * (p.x + q[3 * node] - r[0]);
                g_q[3 * node + 1] += scale * 2.0 * (p.y + q[3 * node + 1] - r[1]);
            }
            Self::Volume { component } => {
                for b in m
                    .bars
                    .iter()
                    .filter(|b| component.is_none_or(|c| b.component == c))
                {
                    if let Some(v) = b.variable {
                        g_x[v] += scale * b.volume;
                    }
                }
            }
            Self::FinalDisplacement { node, direction }
            | Self::IntegratedDisplacement { node, direction } => {
                g_q[3 * node] += scale * direction[0];
                g_q[3 * node + 1] += scale * direction[1];
            }
            Self::Aggregate(ref a) => a.add_partials(ctx, q, known.reference, scale, g_q, g_x),
            Self::Torque { row, aggregation } => {
                g_lam[row] += scale * aggregation.point(at.lam[row], known.reference).1;
            }
            Self::TorqueSquared { row } => g_lam[row] += scale * 2.0 * at.lam[row],
            Self::DriveWork { row } => g_lam[row] -= scale * drive_rate(m, row, at.t),
            Self::EnergyDrawn { row } => {
                let rate = drive_rate(m, row, at.t);
                if -at.lam[row] * rate > 0.0 {
                    g_lam[row] -= scale * rate;
                }
            }
            // ½ m'(x_e) q̇ₑᵀ Mₑ q̇ₑ; its G_q̇ = M q̇ in `add_rate_partials`.
            Self::KineticEnergy if !at.v.is_empty() => {
                for (e, el) in m.elements.iter().enumerate() {
                    if let Some(j) = m.variable_of(e) {
                        let v = el.gather(at.v);
                        let energy = 0.5 * v.dot(&(el.beam.mass_matrix(ctx.mass_kind) * v));
                        g_x[j] += scale * ctx.densities.mass_rate[e] * energy;
                    }
                }
            }
            Self::KineticEnergy => {}
            Self::JointPosition { row } => {
                for (d, g) in row.dofs().iter().zip(row.evaluate(q).1) {
                    if let Some(d) = d {
                        g_q[*d] += scale * g;
                    }
                }
            }
        }
    }

    /// Adds `scale · G_q̇` to `g_v`, for a response that reads velocities.
    pub fn add_rate_partials(&self, ctx: &Context, at: Sample, scale: f64, g_v: &mut [f64]) {
        if let Self::KineticEnergy = self {
            add_mass_times(ctx, at.v, |d, p| g_v[d] += scale * p);
        }
    }

    /// `G_r · ∂r_rigid/∂p`: the response's dependence on its rigid trajectory, which a
    /// drive-law parameter moves at `rate` (m per unit of it) at this state.
    pub fn rigid_partial(&self, ctx: &Context, at: Sample, known: Known, rate: [f64; 2]) -> f64 {
        match *self {
            Self::TipDeflection { node } => {
                let p = ctx.model.nodes[node].position;
                let gap = [
                    p.x + at.q[3 * node] - known.rigid[0],
                    p.y + at.q[3 * node + 1] - known.rigid[1],
                ];
                -2.0 * (gap[0] * rate[0] + gap[1] * rate[1])
            }
            _ => 0.0,
        }
    }

    /// The node whose rigid trajectory the response needs.
    pub fn rigid_node(&self) -> Option<usize> {
        match *self {
            Self::TipDeflection { node } => Some(node),
            _ => None,
        }
    }
}

/// `key=value` options of a response, in the order given.
type Options = Vec<(String, f64)>;

/// `COMPONENT` and `key=value,...` options of a response argument `[COMPONENT][:OPTIONS]`
/// (the part with `=` is the options).
fn component_and_options(rest: Option<&str>) -> Result<(Option<&str>, Options), String> {
    let mut component = None;
    let mut options = Vec::new();
    for part in rest.into_iter().flat_map(|r| r.split(':')) {
        if !part.contains('=') {
            if component.replace(part).is_some() {
                return Err("give at most one component".into());
            }
            continue;
        }
        for option in part.split(',') {
            let (k, v) = option
                .split_once('=')
                .ok_or(format!("option '{option}' needs KEY=VALUE"))?;
            let value = v
                .trim()
                .parse::<f64>()
                .map_err(|e| format!("option '{option}': {e}"))?;
            if options
                .iter()
                .any(|(key, _): &(String, f64)| key == k.trim())
            {
                return Err(format!("option '{}' given twice", k.trim()));
            }
            options.push((k.trim().to_string(), value));
        }
    }
    Ok((component, options))
}

fn elements_of(m: &Model, component: Option<usize>) -> impl Iterator<Item = usize> + '_ {
    (0..m.elements.len())
        .filter(move |&e| component.is_none_or(|c| m.bars[m.elements[e].bar].component == c))
}
