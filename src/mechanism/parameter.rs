//! Scene parameters: named scalars of the scene that gradients may be asked for besides
//! the densities — springs' stiffness, damping and rest, point and body masses and
//! inertias, motors' torques and servo gains, sections' `E`, `ρ` and diameter, and the arm
//! of a body's point pinned to the ground.
//!
//! A parameter `p` enters the residual of the equations of motion and the constraints,
//!
//! ```text
//! r = M(p)(q̈ − ĝ) + C(p) q̇ + f_int(q; p) − f_ext(t; p) + Φ_q(q; p)ᵀλ,     Φ(q; p) − g(t),
//! ```
//!
//! and the sensitivities treat it as they treat a density (paper Eq. 35–36): its
//! pseudo-load `(∂r/∂p, ∂Φ/∂p)` at a converged state is the right-hand side of the direct
//! method and what the adjoint's multipliers are dotted with. Statics drop `q̈` and `C q̇`.
//!
//! Moving a point pinned to the ground moves the pin with it: the rows
//! `Φ = ±nᵀ(u + (R(φ) − I) p)` keep the reference configuration consistent whatever `p`
//! (`∂Φ/∂p = 0` at `φ = 0`), so the run still starts at rest in its reference.

use nalgebra::{Vector2, Vector4};

use crate::error::SettingsError;
use crate::joint::motion::{LawParameter, Motion, MotionState, Trapezoidal};
use crate::joint::planar::{dof, perp, turn, turned_minus, JointKind, Law};
use crate::mechanism::bar_mass::BarMass;
use crate::mechanism::element::{MassKind, Vector6};
use crate::mechanism::model::{Analysis, Densities, Model};
use crate::mechanism::motor::MotorLaw;
use crate::mechanism::section::{Section, SectionProperty};
use crate::mechanism::spring::Measure;

/// A scene parameter, named `KIND:ENTRY` (e.g. `k:bumper`, `mass:bob`, `arm_x:bob.pivot`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Parameter {
    /// `k:SPRING`, a spring's stiffness (N/m or N m/rad).
    Stiffness {
        /// Index in [`Model::springs`].
        spring: usize,
    },
    /// `c:SPRING`, a damper's coefficient (N s/m or N m s/rad).
    Damping {
        /// Index in [`Model::springs`].
        spring: usize,
    },
    /// `length:SPRING` (between points, m) or `rest:SPRING` (on a joint, rad or m): where
    /// the spring is unloaded.
    Rest {
        /// Index in [`Model::springs`].
        spring: usize,
    },
    /// `mass:NODE`, the point mass on a node or a rigid body's mass (kg).
    Mass {
        /// Index in [`Model::point_masses`].
        point: usize,
    },
    /// `inertia:NODE`, its rotary inertia (kg m²).
    Inertia {
        /// Index in [`Model::point_masses`].
        point: usize,
    },
    /// `torque:MOTOR`, a motor's torque at a table value of 1 (N m or N).
    Torque {
        /// Index in [`Model::motors`].
        motor: usize,
    },
    /// `kp:MOTOR` or `kd:MOTOR`, a servo's gain.
    Gain {
        /// Index in [`Model::motors`].
        motor: usize,
        /// The derivative gain `kd` (else `kp`).
        derivative: bool,
        /// Its spring-damper in [`Model::springs`].
        spring: usize,
    },
    /// `E:SECTION`, `rho:SECTION` or `diameter:SECTION` (a solid circle's): what the
    /// section's stiffness and inertia follow; `alpha:SECTION`, `beta:SECTION`: its
    /// Rayleigh damping.
    Section {
        /// Index in [`Model::sections`].
        section: usize,
        /// Which.
        property: SectionProperty,
        /// The section's rates `∂(A, EA, κGA, EI, ρA, ρI)/∂p` ([`Section::rate`]).
        rate: Section,
    },
    /// `end:JOINT`, `acceleration:JOINT` or `speed:JOINT`: a parameter of a joint's
    /// trapezoidal drive, in rad, rad/s², rad/s (m, m/s², m/s on a slider) whatever keys
    /// the scene gives it in.
    Drive {
        /// Index in [`Model::joints`].
        joint: usize,
        /// Its driven row.
        row: usize,
        /// Which.
        law: LawParameter,
    },
    /// `arm_x:BODY.POINT` or `arm_y:BODY.POINT`, a component of the offset of a body's
    /// point from its centre in the body's own frame (m, as the scene gives it), for a
    /// point whose joints all hold it to the ground.
    Arm {
        /// The body's node.
        node: usize,
        /// The point's offset at the reference.
        arm: Vector2<f64>,
        /// The axis of the body's frame it moves along, at the reference (unit).
        direction: Vector2<f64>,
    },
}

/// A model with a design's element scalings and its inertia discretization: what the
/// pseudo-loads read besides the state.
#[derive(Debug, Clone, Copy)]
pub struct Designed<'a> {
    /// The mechanism.
    pub model: &'a Model,
    /// The design's element scalings.
    pub densities: &'a Densities,
    /// The elements' mass matrices.
    pub mass: MassKind,
}

/// A state the pseudo-loads are evaluated at: coordinates, with velocities and
/// accelerations in a motion (`None` in statics), multipliers and time.
#[derive(Debug, Clone, Copy)]
pub struct At<'a> {
    /// `q`.
    pub q: &'a [f64],
    /// `(q̇, q̈)`, or `None` for a static equilibrium.
    pub rates: Option<(&'a [f64], &'a [f64])>,
    /// `λ`.
    pub lam: &'a [f64],
    /// `t` (s).
    pub t: f64,
    /// The level of the constraints differentiated.
    pub level: Level,
}

/// Which form of the constraints a pseudo-load differentiates.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Level {
    /// `Φ(q) = g(t)`: a time step, an equilibrium.
    Position,
    /// `Φ_q q̈ = g̈`: the initial-acceleration system, at rest.
    Acceleration,
}

impl Parameter {
    /// Parses `KIND:ENTRY` against `model`.
    ///
    /// # Errors
    /// A [`SettingsError`] naming the parameter and what is wrong with it.
    pub fn parse(text: &str, model: &Model) -> Result<Self, SettingsError> {
        let err = |m: String| SettingsError::new(format!("parameter '{text}'"), m);
        let Some((kind, entry)) = text.split_once(':') else {
            return Err(err(format!("write KIND:ENTRY with KIND one of {KINDS}")));
        };
        let spring = || {
            model
                .springs
                .iter()
                .position(|s| s.name == entry)
                .ok_or_else(|| err(format!("no spring '{entry}'")))
        };
        let point = || {
            let node = model
                .node_index(entry)
                .ok_or_else(|| err(format!("no node or rigid body '{entry}'")))?;
            let mut at = model
                .point_masses
                .iter()
                .enumerate()
                .filter(|(_, p)| p.node == node);
            match (at.next(), at.next()) {
                (Some((k, _)), None) => Ok(k),
                (None, _) => Err(err(format!("'{entry}' carries no point mass"))),
                _ => Err(err(format!(
                    "'{entry}' carries several point masses: merge them into one"
                ))),
            }
        };
        let motor = || {
            model
                .motors
                .iter()
                .position(|m| m.name == entry)
                .ok_or_else(|| err(format!("no motor '{entry}'")))
        };
        match kind {
            "k" => Ok(Self::Stiffness { spring: spring()? }),
            "c" => Ok(Self::Damping { spring: spring()? }),
            "length" | "rest" => {
                let spring = spring()?;
                let between = matches!(model.springs[spring].measure, Measure::Distance { .. });
                if between != (kind == "length") {
                    let key = if between { "length" } else { "rest" };
                    return Err(err(format!("this spring's rest is its `{key}`")));
                }
                Ok(Self::Rest { spring })
            }
            "mass" => Ok(Self::Mass { point: point()? }),
            "inertia" => Ok(Self::Inertia { point: point()? }),
            "torque" => {
                let motor = motor()?;
                match model.motors[motor].law {
                    MotorLaw::Torque { .. } => Ok(Self::Torque { motor }),
                    MotorLaw::Servo { .. } => Err(err("a servo has gains kp and kd".into())),
                }
            }
            "kp" | "kd" => {
                let motor = motor()?;
                match model.motors[motor].law {
                    MotorLaw::Servo { spring, .. } => Ok(Self::Gain {
                        motor,
                        derivative: kind == "kd",
                        spring,
                    }),
                    MotorLaw::Torque { .. } => Err(err("a torque motor has no gains".into())),
                }
            }
            "arm_x" | "arm_y" => arm(model, entry, usize::from(kind == "arm_y")).map_err(err),
            "E" | "rho" | "diameter" | "alpha" | "beta" => section(model, entry, kind).map_err(err),
            "end" | "acceleration" | "speed" => drive(model, entry, kind).map_err(err),
            _ => Err(err(format!("unknown kind '{kind}' (kinds: {KINDS})"))),
        }
    }

    /// Whether the pseudo-load reads velocities.
    pub fn reads_velocities(&self) -> bool {
        matches!(
            self,
            Self::Damping { .. }
                | Self::Gain {
                    derivative: true,
                    ..
                }
                | Self::Section {
                    property: SectionProperty::Alpha | SectionProperty::Beta,
                    ..
                }
        )
    }

    /// Whether `Φ` depends on it (its pseudo-load has constraint rows); the rigid
    /// trajectory of the drives moves with it too.
    pub fn moves_constraints(&self) -> bool {
        matches!(self, Self::Arm { .. } | Self::Drive { .. })
    }

    /// `aᵀ (∂M/∂p) b`: the rate of the mass matrix (point masses, bodies, sections' `ρ` and
    /// diameter) between two vectors; zero for an empty `a`.
    pub fn mass_rate_times(&self, on: &Designed, a: &[f64], b: &[f64]) -> f64 {
        if a.is_empty() {
            return 0.0;
        }
        let model = on.model;
        match *self {
            Self::Mass { point } => {
                let d = dof(model.point_masses[point].node, 0);
                a[d] * b[d] + a[d + 1] * b[d + 1]
            }
            Self::Inertia { point } => {
                let d = dof(model.point_masses[point].node, 2);
                a[d] * b[d]
            }
            Self::Section { section, rate, .. } => {
                let elements: f64 = elements_of(model, section)
                    .map(|(e, el)| {
                        let m = el.kernel.mass_matrix_rate(on.mass, &rate);
                        on.densities.mass[e] * el.gather(a).dot(&(m * el.gather(b)))
                    })
                    .sum();
                let couplings: f64 = couplings_of(on, section)
                    .map(|c| {
                        let (a, b) = (c.dofs().map(|d| a[d]), c.dofs().map(|d| b[d]));
                        let m = c.matrix_rate(&rate) * on.densities.mass[c.element];
                        Vector4::from(a).dot(&(m * Vector4::from(b)))
                    })
                    .sum();
                elements + couplings
            }
            _ => 0.0,
        }
    }

    /// `∂ġ/∂p` of driven row `row` at `t`: a drive law's rate, which a drive's work reads.
    pub fn drive_rate(&self, model: &Model, row: usize, t: f64) -> f64 {
        match self.drive(model, t) {
            Some((driven, rate)) if driven == row => rate.velocity,
            _ => 0.0,
        }
    }

    /// For a drive-law parameter, its driven row and `∂(g, ġ, g̈)/∂p` there at `t`.
    pub fn drive(&self, model: &Model, t: f64) -> Option<(usize, MotionState)> {
        match *self {
            Self::Drive { joint, row, law } => {
                trapezoidal(model, joint).map(|m| (row, m.rate(t, law)))
            }
            _ => None,
        }
    }

    /// The section it is a property of, if any.
    pub fn section(&self) -> Option<(usize, &Section)> {
        match self {
            Self::Section { section, rate, .. } => Some((*section, rate)),
            _ => None,
        }
    }

    /// Calls `add(i, v)` for each nonzero `v` of the pseudo-load `(∂r/∂p, ∂Φ/∂p)` at `at`:
    /// `i < n_q` a coordinate's residual, `i = n_q + k` constraint row `k`.
    pub fn pseudo_load(&self, on: &Designed, at: &At, mut add: impl FnMut(usize, f64)) {
        let model = on.model;
        match *self {
            Self::Stiffness { spring } => stiffness(model, spring, at, &mut add),
            Self::Damping { spring } => damping(model, spring, at, &mut add),
            Self::Rest { spring } => {
                let s = &model.springs[spring];
                along(s.dofs(), s.measure(at.q).gradient, -s.stiffness, &mut add);
            }
            Self::Mass { point } => {
                let node = model.point_masses[point].node;
                for d in [dof(node, 0), dof(node, 1)] {
                    add(
                        d,
                        at.rates.map_or(0.0, |(_, acc)| acc[d]) - gravity(model, d),
                    );
                }
            }
            Self::Inertia { point } => {
                let d = dof(model.point_masses[point].node, 2);
                add(d, at.rates.map_or(0.0, |(_, acc)| acc[d]));
            }
            Self::Torque { .. } => self.applied_rate(model, at.t, &mut |i, v| add(i, -v)),
            Self::Gain {
                derivative, spring, ..
            } => {
                self.applied_rate(model, at.t, &mut |i, v| add(i, -v));
                if derivative {
                    damping(model, spring, at, &mut add);
                } else {
                    stiffness(model, spring, at, &mut add);
                }
            }
            Self::Arm {
                node,
                arm,
                direction,
            } => arm_rows(model, node, arm, direction, at, &mut add),
            // Φ = h(q) − g(t): at acceleration level Φ_q q̈ = g̈.
            Self::Drive { .. } => {
                if let Some((row, rate)) = self.drive(model, at.t) {
                    let g = match at.level {
                        Level::Position => rate.angle,
                        Level::Acceleration => rate.acceleration,
                    };
                    add(model.n_dofs() + row, -g);
                }
            }
            Self::Section { section, rate, .. } => {
                for (e, el) in elements_of(model, section) {
                    let load = section_load(on, e, &rate, at);
                    el.dofs()
                        .iter()
                        .zip(load.iter())
                        .for_each(|(&d, &v)| add(d, v));
                }
                for c in couplings_of(on, section) {
                    let load = coupling_load(on, c, &rate, at);
                    c.dofs()
                        .iter()
                        .zip(load.iter())
                        .for_each(|(&d, &v)| add(d, v));
                }
            }
        }
    }

    /// `∂F/∂p` of a static scene's load `F = f_ext + M ĝ` at time `t` (its compliance
    /// `Fᵀu` reads it): `add(i, v)` per nonzero.
    pub fn load_rate(&self, on: &Designed, t: f64, mut add: impl FnMut(usize, f64)) {
        let model = on.model;
        match *self {
            Self::Mass { point } => {
                let node = model.point_masses[point].node;
                for d in [dof(node, 0), dof(node, 1)] {
                    add(d, gravity(model, d));
                }
            }
            Self::Section { section, rate, .. } => {
                for (e, el) in elements_of(model, section) {
                    let dofs = el.dofs();
                    let g = Vector6::from_fn(|i, _| gravity(model, dofs[i]));
                    let load =
                        el.kernel.mass_matrix_rate(on.mass, &rate) * g * on.densities.mass[e];
                    dofs.iter().zip(load.iter()).for_each(|(&d, &v)| add(d, v));
                }
            }
            _ => {}
        }
        self.applied_rate(model, t, &mut add);
    }

    /// `∂f_ext/∂p` at `t`: a motor's torque per unit of it, a servo's feed per unit gain
    /// (`θ_r(t) − θ_r(0)`, and `θ̇_r(t)` in a motion, as in [`crate::mechanism::motor::Motor::applied`]).
    fn applied_rate(&self, model: &Model, t: f64, add: &mut impl FnMut(usize, f64)) {
        let (Self::Torque { motor } | Self::Gain { motor, .. }) = *self else {
            return;
        };
        let m = &model.motors[motor];
        let rate = match (&m.law, self) {
            (MotorLaw::Torque { time, .. }, _) => time.at(t),
            (
                MotorLaw::Servo { motion, .. },
                Self::Gain {
                    derivative: false, ..
                },
            ) => motion.at(t).angle - motion.at(0.0).angle,
            (MotorLaw::Servo { motion, .. }, _) if model.analysis == Analysis::Dynamic => {
                motion.at(t).velocity
            }
            _ => return,
        };
        along(m.dofs, m.direction, rate, add);
    }
}

/// The kinds of [`Parameter`], for messages.
const KINDS: &str =
    "k, c, length, rest, mass, inertia, torque, kp, kd, E, rho, diameter, alpha, beta, end, acceleration, speed, arm_x, arm_y";

/// `∂r_e/∂p` of element `e` for its section changing at `rate`: `m(x_e)(M' (q̈ − ĝ + α q̇)
/// + α' M q̇) + s(x_e)(f' + f_d')` with the Rayleigh damping's terms in a motion.
fn section_load(on: &Designed, e: usize, rate: &Section, at: &At) -> Vector6 {
    let el = &on.model.elements[e];
    let (dofs, u) = (el.dofs(), el.gather(at.q));
    let (mass, kernel) = (el.kernel.mass_matrix_rate(on.mass, rate), &el.kernel);
    let mut inertia = mass * Vector6::from_fn(|i, _| -gravity(on.model, dofs[i]));
    let mut stiffness = kernel.internal_force_rate(&u, rate);
    if let Some((v, acc)) = at.rates {
        inertia += mass * el.gather(acc);
        // Velocities are kept where damping reads them.
        if !v.is_empty() {
            let v = el.gather(v);
            inertia +=
                mass * v * kernel.section().alpha + kernel.mass_matrix(on.mass) * v * rate.alpha;
            stiffness += kernel.damping_force_rate(&u, &v, rate.beta, rate);
        }
    }
    inertia * on.densities.mass[e] + stiffness * on.densities.stiffness[e]
}

/// `m(x_b)(M_c' (q̈ + α q̇) + α' M_c q̇)` of a bar's end coupling for its section changing
/// at `rate` (`M_c ĝ = 0`: gravity is uniform; zero in statics).
fn coupling_load(on: &Designed, c: &BarMass, rate: &Section, at: &At) -> Vector4<f64> {
    let Some((v, acc)) = at.rates else {
        return Vector4::zeros();
    };
    let gather = |x: &[f64]| Vector4::from(c.dofs().map(|d| x[d]));
    let mut inertia = c.matrix_rate(rate) * gather(acc);
    if !v.is_empty() {
        let alpha = on.model.elements[c.element].kernel.section().alpha;
        inertia += (c.matrix_rate(rate) * alpha + c.matrix() * rate.alpha) * gather(v);
    }
    inertia * on.densities.mass[c.element]
}

/// The end couplings of the bars of section `k` in the design's mass matrix.
fn couplings_of<'a>(on: &Designed<'a>, k: usize) -> impl Iterator<Item = &'a BarMass> {
    let model = on.model;
    model
        .bar_couplings(on.mass)
        .iter()
        .filter(move |c| model.bars[model.elements[c.element].bar].section == k)
}

/// The trapezoidal drive of joint `j`, if it has one.
fn trapezoidal(model: &Model, j: usize) -> Option<&Trapezoidal> {
    match &model.joints[j].drive {
        Some(Motion::Trapezoidal(m)) => Some(m),
        _ => None,
    }
}

/// `end`, `acceleration` or `speed` (`kind`) of joint `entry`'s drive, which must be
/// trapezoidal.
fn drive(model: &Model, entry: &str, kind: &str) -> Result<Parameter, String> {
    let joint = model
        .joints
        .iter()
        .position(|j| j.name == entry)
        .ok_or_else(|| format!("no joint '{entry}'"))?;
    let Some(motion) = trapezoidal(model, joint) else {
        let what = if model.joints[joint].drive.is_some() {
            "a table"
        } else {
            "no drive"
        };
        return Err(format!(
            "'{entry}' has {what}: only a trapezoidal drive has an end, acceleration and speed"
        ));
    };
    if motion.duration() == 0.0 {
        return Err(format!(
            "'{entry}' is held (its drive starts where it ends): its law has no rate to a parameter"
        ));
    }
    let law = match kind {
        "end" => LawParameter::End,
        "acceleration" => LawParameter::Acceleration,
        _ => LawParameter::Speed,
    };
    Ok(Parameter::Drive {
        joint,
        row: model.joint_rows(joint).end - 1,
        law,
    })
}

/// `ĝ` at coordinate `d`: gravity on translations, none on rotations.
fn gravity(model: &Model, d: usize) -> f64 {
    [model.gravity.x, model.gravity.y, 0.0][d % 3]
}

/// The elements made of section `k`, with their indices.
pub(crate) fn elements_of(
    model: &Model,
    k: usize,
) -> impl Iterator<Item = (usize, &crate::mechanism::model::Element)> {
    model
        .elements
        .iter()
        .enumerate()
        .filter(move |(_, el)| model.bars[el.bar].section == k)
}

/// `E`, `rho` or `diameter` (`kind`) of section `entry`: refused for a section a rigid
/// ground structure is made of, and `diameter` for one not given as a solid circle.
fn section(model: &Model, entry: &str, kind: &str) -> Result<Parameter, String> {
    let k = model
        .sections
        .iter()
        .position(|s| s.name == entry)
        .ok_or_else(|| format!("no section '{entry}'"))?;
    let named = &model.sections[k];
    if named.rigid {
        return Err("a ground structure declared rigid is made of it, whose body's mass would follow it: not built".into());
    }
    let property = match kind {
        "E" => SectionProperty::E,
        "rho" => SectionProperty::Rho,
        "alpha" => SectionProperty::Alpha,
        "beta" => SectionProperty::Beta,
        _ if named.made.diameter.is_none() => {
            return Err("the section is given by A, I and kappa, not a diameter".into())
        }
        _ => SectionProperty::Diameter,
    };
    Ok(Parameter::Section {
        section: k,
        property,
        rate: named.section.rate(&named.made, property),
    })
}

/// `add(dof, scale · g)` over the present DOFs.
fn along(dofs: [Option<usize>; 6], g: [f64; 6], scale: f64, add: &mut impl FnMut(usize, f64)) {
    for (d, gi) in dofs.iter().zip(g) {
        if let Some(d) = d {
            if gi != 0.0 {
                add(*d, scale * gi);
            }
        }
    }
}

/// `∂f/∂k = (s − s₀) ∂s/∂q` of spring `k`.
fn stiffness(model: &Model, k: usize, at: &At, add: &mut impl FnMut(usize, f64)) {
    let s = &model.springs[k];
    let local = s.measure(at.q);
    along(s.dofs(), local.gradient, local.value - s.rest, add);
}

/// `∂(C q̇)/∂c = (∂s/∂q · q̇) ∂s/∂q` of spring `k` (nothing in statics).
fn damping(model: &Model, k: usize, at: &At, add: &mut impl FnMut(usize, f64)) {
    let Some((v, _)) = at.rates else { return };
    let s = &model.springs[k];
    let (dofs, g) = (s.dofs(), s.measure(at.q).gradient);
    let rate: f64 = dofs
        .iter()
        .zip(g)
        .filter_map(|(d, gi)| d.map(|d| gi * v[d]))
        .sum();
    along(dofs, g, rate, add);
}

/// The rows of a point at `arm` on `node` held to the ground, and their pseudo-loads for a
/// change of the arm along `e`: on `φ`, `λ ∂²Φ/∂φ∂p = λ σ nᵀ J R(φ) e` (`σ = ±1`, the
/// point's side of the row); on the row, `∂Φ/∂p = σ nᵀ(R(φ) − I)e`, or at acceleration
/// level `∂(Φ_q q̈)/∂p = σ nᵀ J R(φ) e φ̈`.
fn arm_rows(
    model: &Model,
    node: usize,
    arm: Vector2<f64>,
    e: Vector2<f64>,
    at: &At,
    add: &mut impl FnMut(usize, f64),
) {
    let phi = at.q[dof(node, 2)];
    let moved = turned_minus(e, turn(phi));
    for (k, row) in model.rows.iter().enumerate() {
        let Law::Separation {
            arms, direction, ..
        } = row.law
        else {
            continue;
        };
        for (sign, (n, a)) in [1.0, -1.0].into_iter().zip(row.nodes.iter().zip(arms)) {
            if *n == Some(node) && a == arm {
                let bend = sign * direction.dot(&perp(e + moved));
                let row = match (at.level, at.rates) {
                    (Level::Acceleration, Some((_, acc))) => bend * acc[dof(node, 2)],
                    _ => sign * direction.dot(&moved),
                };
                add(model.n_dofs() + k, row);
                add(dof(node, 2), at.lam[k] * bend);
            }
        }
    }
}

/// `arm_x`/`arm_y` (`axis`) of point `entry` = `BODY.POINT`: refused unless every joint at
/// the point holds it to the ground and no spring ends there.
fn arm(model: &Model, entry: &str, axis: usize) -> Result<Parameter, String> {
    let (body, point) = entry
        .rsplit_once('.')
        .ok_or_else(|| "write BODY.POINT".to_string())?;
    let b = model
        .bodies
        .iter()
        .find(|b| b.name == body)
        .ok_or_else(|| format!("no rigid body '{body}'"))?;
    let arm = b
        .points
        .iter()
        .find(|(n, _)| n == point)
        .map(|(_, a)| *a)
        .ok_or_else(|| format!("body '{body}' has no point '{point}'"))?;
    if b.points.iter().filter(|(_, a)| *a == arm).count() > 1 {
        return Err(format!("another point of '{body}' lies at '{point}'"));
    }
    let here = |a: &crate::joint::planar::Anchor| a.node == b.node && a.arm == arm;
    let mut held = false;
    for j in &model.joints {
        let anchors: Vec<_> = match j.kind {
            JointKind::Clamp { at } | JointKind::Pin { at } | JointKind::Roller { at, .. } => {
                vec![at]
            }
            JointKind::Hinge { at } | JointKind::Weld { at } => at.to_vec(),
            JointKind::Prismatic {
                carrier, slider, ..
            } => carrier.into_iter().chain([slider]).collect(),
        };
        if anchors.iter().any(here) {
            if !j.is_grounded() {
                return Err(format!(
                    "joint '{}' ties the point to another body: only a point held to the ground may move",
                    j.name
                ));
            }
            held = true;
        }
    }
    let sprung = model.springs.iter().any(|s| match s.measure {
        Measure::Distance { at, .. } => at.iter().any(here),
        Measure::Coordinate(_) => false,
    });
    if sprung {
        return Err(
            "a spring ends at the point: only a point held to the ground by joints may move".into(),
        );
    }
    if !held {
        return Err("no joint holds the point to the ground: moving it changes nothing".into());
    }
    let (s, c) = b.angle.sin_cos();
    let direction = [Vector2::new(c, s), Vector2::new(-s, c)][axis];
    Ok(Parameter::Arm {
        node: b.node,
        arm,
        direction,
    })
}
