//! Exact gradients of a spatial motion's responses to scene parameters: direct
//! differentiation (the paper's Algorithm 2 carried to the Lie group) and the discrete
//! adjoint, both of the scheme as it runs (Brüls & Eberhard, *IJNME* 74, 2008; Sonneville &
//! Brüls, *Multibody Syst. Dyn.* 31, 2014).
//!
//! A variation of the configuration is a vector `ε` of the nodes' algebra, `δq = q ε̃`. The
//! update `qₙ₊₁ = qₙ ∘ exp(Δ)` carries it as
//!
//! ```text
//! εₙ₊₁ = Ad(exp(−Δ)) εₙ + T(Δ) Δ'          (per node: diag(I, exp(Δθ)ᵀ) and diag(I, T(Δθ)))
//! ```
//!
//! and the rest is the vector-space scheme's: with `δ` the unknown of the step,
//! `Δ' = Δ'_pred + δ`, `v' = v'_pred + γ'δ`, `v̇' = β'δ`, the linearized equations of the
//! step are solved with the step's own iteration matrix `S` at the converged state,
//!
//! ```text
//! S [δ; ν'] = −[∂r/∂p + K ε_pred + C v'_pred;  s (∂Φ/∂p + B ε_pred)],   λ' = s ν'
//! ```
//!
//! The adjoint runs the transposes of the same operations backwards, with `Sᵀ` on the same
//! factors, every response a column of one sweep ([`crate::solver::backward`]): each step's
//! matrix is factored once for all of them. The start is differentiated too: `[M, sBᵀ; sB, 0][v̇₀'; ν₀'] = −[∂r/∂p; 0]`.
//! A change of step size, which carries the pseudo-accelerations to the new step, and the
//! restart at a drive's kink are differentiated as they run.

use nalgebra::{Matrix3, SVector, Vector3};

use crate::error::{Error, SettingsError, SolveError};
use crate::group::pair::Stiffness;
use crate::group::so3::{exp, log, tangent};
use crate::group::{six, split, Frame, NV};
use crate::joint::motion::{LawParameter, Motion};
use crate::joint::spatial::{Joint, MAX_ROWS};
use crate::response::aggregation::Aggregation;
use crate::settings::{DynamicSettings, Method, StaticSettings};
use crate::solver::alpha::{step_ratio, AlphaParameters, State};
use crate::solver::backward::{self, Transposed};
use crate::solver::kink::jumps;
use crate::solver::local_error::LocalErrors;
use crate::solver::newton::Forecast;
use crate::solver::unsymmetric::Unsymmetric;
use crate::spatial::assembly::{analysed, Assembler, Coefficients};
use crate::spatial::beam::Beam;
use crate::spatial::element::Element;
use crate::spatial::force::{ForceKind, ForceParameter, Local};
use crate::spatial::integrator::{kink_jump, kinks, run};
use crate::spatial::model::{SpatialModel, MEET_TOLERANCE};
use crate::spatial::rigid::{rigid_trajectories, rigid_trajectory_rates};
use crate::spatial::section::{Dimension, Section, MAX_FIBRES};
use crate::spatial::statics::solve_static_spatial;
use crate::spatial::stress::Criterion;
use crate::TimeGrid;

/// A scene parameter of a spatial mechanism.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Parameter {
    /// A body's mass (kg).
    Mass {
        /// The body.
        body: usize,
    },
    /// Entry `(i, j)` of a body's inertia tensor and its symmetric `(j, i)` (kg m²).
    Inertia {
        /// The body.
        body: usize,
        /// Row.
        i: usize,
        /// Column.
        j: usize,
    },
    /// A spring's stiffness `k` (N/m; a torsion spring's N m/rad).
    SpringStiffness {
        /// The force element.
        force: usize,
    },
    /// A spring's damping `c` (N s/m; a torsion spring's N m s/rad).
    SpringDamping {
        /// The force element.
        force: usize,
    },
    /// A spring's rest length `l₀` (m; a torsion spring's rest angle `φ₀`, rad).
    SpringRest {
        /// The force element.
        force: usize,
    },
    /// A motor's torque (N m).
    MotorTorque {
        /// The force element.
        force: usize,
    },
    /// A factor `s` on a beam's section stiffnesses (`EA, κGA, GJ, EI` and with them its
    /// Kelvin–Voigt damping), at `s = 1`: a density's derivative is `E'(x)/E(x)` times this.
    BeamStiffness {
        /// The beam.
        beam: usize,
    },
    /// A factor on a beam's mass and rotary inertia per length (and with them its weight
    /// and Rayleigh `α M` damping), at 1.
    BeamMass {
        /// The beam.
        beam: usize,
    },
    /// A dimension of a beam's section (m): its stiffnesses (MacNeal's shear stiffness
    /// included), its mass and rotary inertia (its weight, its damping with them) and where
    /// its stresses are read, as the section's shape gives them
    /// ([`crate::spatial::section::Shape::rate`]).
    BeamSize {
        /// The beam.
        beam: usize,
        /// Which of its shape's dimensions.
        dimension: Dimension,
    },
    /// A factor on a truss bar's `EA` (and its Kelvin–Voigt damping), at 1.
    TrussStiffness {
        /// The bar.
        truss: usize,
    },
    /// A factor on a truss bar's mass per length (its weight and `α M` damping), at 1.
    TrussMass {
        /// The bar.
        truss: usize,
    },
    /// A beam's density `x` as a stress response's relaxation `x^q` reads it, at its value:
    /// the mechanism does not read it (its stiffness and mass factors above carry the
    /// density's laws), so it enters responses only, explicitly.
    BeamDensity {
        /// The beam.
        beam: usize,
    },
    /// A truss bar's density as a stress response's relaxation reads it.
    TrussDensity {
        /// The bar.
        truss: usize,
    },
    /// A factor on a truss bar's buckling ratio, at 1: what a change of its section's size
    /// does to it at fixed strain (`A'/A − I_min'/I_min`, the named size's factor), which
    /// its stiffness and mass factors do not carry. Read by buckling responses alone.
    TrussBuckling {
        /// The bar.
        truss: usize,
    },
    /// A parameter of a joint's trapezoidal drive (its end, acceleration or speed, in rad,
    /// rad/s², rad/s on a revolute joint, m, m/s², m/s on a prismatic one): it moves the
    /// driven row `Φ = h(q) − g(t)` at every step, `g̈(0)` in the initial accelerations and
    /// the jumps of `g̈` where the run restarts.
    Drive {
        /// The joint.
        joint: usize,
        /// Which.
        law: LawParameter,
    },
    /// A joint's place along the inertial axis `axis` (0, 1, 2 for x, y, z) in the initial
    /// configuration (m): both its anchors' points move with it, each in its body's or
    /// node's frame (the ground's in space), so that the initial configuration still meets
    /// and only the joint's rows move (`Joint::position_rate`).
    JointPosition {
        /// The joint.
        joint: usize,
        /// 0, 1, 2 for x, y, z.
        axis: usize,
    },
}

impl Parameter {
    /// Whether only responses read it (no force or constraint does): its derivative is
    /// the explicit one, with no sweep.
    fn explicit_only(&self) -> bool {
        matches!(
            self,
            Self::BeamDensity { .. } | Self::TrussDensity { .. } | Self::TrussBuckling { .. }
        )
    }
}

/// A response of a spatial motion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Response {
    /// A coordinate of a body's centre of mass at the end of the run (m).
    Position {
        /// The body.
        body: usize,
        /// 0, 1, 2 for x, y, z.
        axis: usize,
    },
    /// A coordinate of a node's origin at the end of the run (m): a beam's end.
    NodePosition {
        /// The node.
        node: usize,
        /// 0, 1, 2 for x, y, z.
        axis: usize,
    },
    /// `(1/t_f) ∫ U dt`, the beams' and bars' strain energy's mean over the run (J;
    /// trapezoidal rule on the run's grid), as a planar scene's `strain_energy`: a dynamic
    /// compliance.
    StrainEnergy,
    /// `∫ T dt`, the kinetic energy `½ vᵀ M v` of the bodies, beams and bars integrated over
    /// the run (J s; trapezoidal rule on the run's grid). A motion's only.
    KineticEnergy,
    /// `∫ λ² dt` of one row of a joint (trapezoidal rule on the run's grid): of a drive's
    /// row, `∫ τ² dt`, the effort a motor must deliver (`torque_squared:JOINT`).
    Effort {
        /// The joint.
        joint: usize,
        /// Its row, the drive's last.
        row: usize,
    },
    /// The mean squared deflection `(1/t_f) ∫ |r − r_rigid|² dt` of a node's origin from its
    /// rigid trajectory (m², paper Eq. 40; trapezoidal rule on the run's grid; `r_rigid`
    /// from [`crate::spatial::rigid`], which needs every freedom driven). A motion's only.
    Deflection {
        /// The node: the tip.
        node: usize,
    },
    /// The relaxed stresses `x^q σ` of every beam's fibres and every bar (Pa), or their
    /// buckling ratios `x^q b` (one per element), condensed over the run, the elements and
    /// their points by a p-mean or KS mean ([`crate::spatial::stress`]).
    Stress {
        /// What it reads at an element's points.
        criterion: Criterion,
        /// The mean.
        aggregation: Aggregation,
        /// The relaxation exponent `q` in `[0, 1]`.
        relaxation: f64,
        /// The elements it reads: every one where `None`.
        within: Option<Elements>,
    },
    /// The force a joint transmits (N): `|F| = |(λₖ)|` over the rows that hold its points
    /// together ([`Joint::force_rows`]: not a locked rotation's moment, not a drive's
    /// torque), condensed over the run by a p-mean or KS mean (the trapezoidal weights over
    /// `t_f`), its peak reported: what a bearing is sized by. At an equilibrium, `|F|`.
    Reaction {
        /// The joint.
        joint: usize,
        /// The mean over the run.
        aggregation: Aggregation,
    },
    /// The torque (N m) or force (N) a drive applies, `τ = −λ` of its row, condensed over
    /// the run as [`Response::Reaction`], its peak reported: what a motor is sized by.
    Torque {
        /// The driven joint.
        joint: usize,
        /// The mean over the run.
        aggregation: Aggregation,
    },
    /// The mean compliance `(1/t_f) ∫ U dt` over the run (J, paper Eq. 39; the trapezoidal
    /// rule on the run's grid); at an equilibrium, the work `Fᵀu` of the dead forces and
    /// gravity from the initial configuration (J; refused where a follower load, a moment or
    /// a motor acts).
    Compliance,
}

impl Response {
    /// A stress mean's criterion, aggregation, relaxation and elements; `None` for the
    /// others.
    fn stress(&self) -> Option<(Criterion, Aggregation, f64, Option<Elements>)> {
        match *self {
            Self::Stress {
                criterion,
                aggregation,
                relaxation,
                within,
            } => Some((criterion, aggregation, relaxation, within)),
            _ => None,
        }
    }

    /// The mean a response condenses its point values by, with a peak reported: a
    /// stress's, a reaction's, a torque's; `None` for the others.
    fn aggregation(&self) -> Option<Aggregation> {
        match *self {
            Self::Stress { aggregation, .. }
            | Self::Reaction { aggregation, .. }
            | Self::Torque { aggregation, .. } => Some(aggregation),
            _ => None,
        }
    }
}

/// Consecutive beams and truss bars of a mechanism, `[first, end)` of each: a scene's beam
/// or ground structure, whose stresses a response reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Elements {
    /// Of `model.beams`.
    pub beams: [usize; 2],
    /// Of `model.trusses`.
    pub trusses: [usize; 2],
}

/// Responses and their gradients: `gradient[k][i]` is `∂f_k/∂p_i`.
#[derive(Debug, Clone, PartialEq)]
pub struct Gradients {
    /// The responses' values.
    pub values: Vec<f64>,
    /// Their derivatives to the parameters.
    pub gradient: Vec<Vec<f64>>,
    /// The peak `max |x^q σ|` over the run and the structure behind each
    /// [`Response::Stress`]'s mean (`None` for the others): what a limit on the peak
    /// normalizes the mean by (Le et al. 2010).
    pub peaks: Vec<Option<f64>>,
    /// Each response's time error `f(h) − f` to leading order in the step, estimated by the
    /// adjoint sweep of a motion that made the gradients ([`time_errors`]); `None` where no
    /// such sweep made them (the direct method, an equilibrium).
    pub time_errors: Option<Vec<f64>>,
}

/// Checks that node `node` of response `k` exists.
fn node(model: &SpatialModel, node: usize, k: usize) -> Result<(), SettingsError> {
    if node >= model.nodes.len() {
        return Err(SettingsError::new(
            format!("responses[{k}]"),
            format!("no node {node} (the mechanism has {})", model.nodes.len()),
        ));
    }
    Ok(())
}

fn check(
    model: &SpatialModel,
    responses: &[Response],
    parameters: &[Parameter],
) -> Result<(), SettingsError> {
    let body = |b: usize, what: String| {
        (b < model.bodies.len()).then_some(()).ok_or_else(|| {
            SettingsError::new(
                what,
                format!("no body {b} (the mechanism has {})", model.bodies.len()),
            )
        })
    };
    let axis = |axis: usize, k: usize| {
        (axis <= 2).then_some(()).ok_or_else(|| {
            SettingsError::new(format!("responses[{k}]"), format!("axis {axis}: 0, 1 or 2"))
        })
    };
    for (k, r) in responses.iter().enumerate() {
        match *r {
            Response::Position { body: b, axis: a } => {
                body(b, format!("responses[{k}]"))?;
                axis(a, k)?;
            }
            Response::Stress {
                within: Some(e), ..
            } => {
                let fits = |[a, b]: [usize; 2], n: usize| a <= b && b <= n;
                let empty = e.beams[0] == e.beams[1] && e.trusses[0] == e.trusses[1];
                if empty
                    || !fits(e.beams, model.beams.len())
                    || !fits(e.trusses, model.trusses.len())
                {
                    return Err(SettingsError::new(
                        format!("responses[{k}]"),
                        format!("no elements {e:?} in the mechanism"),
                    ));
                }
            }
            Response::StrainEnergy | Response::Compliance | Response::Stress { .. } => {
                if model.elements().next().is_none() {
                    return Err(SettingsError::new(
                        format!("responses[{k}]"),
                        "the mechanism has no beams or bars: no strain energy or stresses",
                    ));
                }
            }
            Response::NodePosition { node, axis: a } => {
                self::node(model, node, k)?;
                axis(a, k)?;
            }
            Response::Deflection { node } => self::node(model, node, k)?,
            Response::KineticEnergy => {}
            Response::Effort { joint, row } => {
                let rows = model.joints.get(joint).map(|j| j.n_rows());
                if rows.is_none_or(|n| row >= n) {
                    return Err(SettingsError::new(
                        format!("responses[{k}]"),
                        format!("joint {joint} has no row {row}"),
                    ));
                }
            }
            Response::Reaction { joint, .. } | Response::Torque { joint, .. } => {
                let why = match (model.joints.get(joint), r) {
                    (None, _) => format!(
                        "no joint {joint} (the mechanism has {})",
                        model.joints.len()
                    ),
                    (Some(j), Response::Torque { .. }) if !j.is_driven() => {
                        format!(
                            "joint '{}' is not driven: only a drive has a torque",
                            j.name
                        )
                    }
                    (Some(j), Response::Reaction { .. }) if j.force_rows().next().is_none() => {
                        format!("joint '{}' holds no point: it transmits no force", j.name)
                    }
                    _ => continue,
                };
                return Err(SettingsError::new(format!("responses[{k}]"), why));
            }
        }
    }
    for (k, p) in parameters.iter().enumerate() {
        match *p {
            Parameter::Mass { body: b } => body(b, format!("parameters[{k}]"))?,
            Parameter::SpringStiffness { force }
            | Parameter::SpringDamping { force }
            | Parameter::SpringRest { force } => {
                if !matches!(
                    model.forces.get(force).map(|f| &f.kind),
                    Some(ForceKind::Spring { .. } | ForceKind::Torsion { .. })
                ) {
                    return Err(SettingsError::new(
                        format!("parameters[{k}]"),
                        format!("force element {force} is not a spring"),
                    ));
                }
            }
            Parameter::MotorTorque { force } => {
                if !matches!(
                    model.forces.get(force).map(|f| &f.kind),
                    Some(ForceKind::Motor { .. })
                ) {
                    return Err(SettingsError::new(
                        format!("parameters[{k}]"),
                        format!("force element {force} is not a motor"),
                    ));
                }
            }
            Parameter::BeamStiffness { beam }
            | Parameter::BeamMass { beam }
            | Parameter::BeamDensity { beam } => {
                if beam >= model.beams.len() {
                    return Err(SettingsError::new(
                        format!("parameters[{k}]"),
                        format!("no beam {beam} (the mechanism has {})", model.beams.len()),
                    ));
                }
            }
            Parameter::BeamSize { beam, dimension } => match model.beams.get(beam) {
                None => {
                    return Err(SettingsError::new(
                        format!("parameters[{k}]"),
                        format!("no beam {beam} (the mechanism has {})", model.beams.len()),
                    ))
                }
                Some(b) if b.section_rate(dimension).is_none() => {
                    return Err(SettingsError::new(
                        format!("parameters[{k}]"),
                        format!(
                            "beam {beam}'s section ({:?}) has no {dimension:?}",
                            b.section.shape
                        ),
                    ))
                }
                Some(_) => {}
            },
            Parameter::TrussStiffness { truss }
            | Parameter::TrussMass { truss }
            | Parameter::TrussDensity { truss }
            | Parameter::TrussBuckling { truss } => {
                if truss >= model.trusses.len() {
                    return Err(SettingsError::new(
                        format!("parameters[{k}]"),
                        format!(
                            "no truss bar {truss} (the mechanism has {})",
                            model.trusses.len()
                        ),
                    ));
                }
            }
            Parameter::Drive { joint, .. } => {
                let law = model.joints.get(joint).and_then(Joint::drive_law);
                let Some(Motion::Trapezoidal(law)) = law else {
                    return Err(SettingsError::new(
                        format!("parameters[{k}]"),
                        format!("joint {joint} has no trapezoidal drive"),
                    ));
                };
                if law.duration() == 0.0 {
                    return Err(SettingsError::new(
                        format!("parameters[{k}]"),
                        format!(
                            "joint {joint}'s drive is held (it starts where it ends): its law \
                             has no rate to a parameter"
                        ),
                    ));
                }
            }
            Parameter::JointPosition { joint, axis } => {
                if joint >= model.joints.len() || axis > 2 {
                    return Err(SettingsError::new(
                        format!("parameters[{k}]"),
                        format!(
                            "joint {joint}, axis {axis}: the mechanism has {} joints, and an axis is 0, 1 or 2",
                            model.joints.len()
                        ),
                    ));
                }
                let (q, v) = (model.initial_configuration(), model.initial_velocity());
                let j = &model.joints[joint];
                let moved = j.position_rate(&q, Some(&v), 0.0, &Vector3::ith(axis, 1.0));
                let rate = moved.rate.rows(0, j.n_rows()).amax() * model.size();
                if rate > MEET_TOLERANCE * model.speed(&v).max(f64::MIN_POSITIVE) {
                    return Err(SettingsError::new(
                        format!("parameters[{k}]"),
                        format!(
                            "joint '{}': its bodies turn relative to each other at the start, so that moving its place \
                             would break their initial rates (the velocities' rate to it is not built): start them \
                             without that turn, or differentiate another parameter",
                            j.name
                        ),
                    ));
                }
                if let Some(r) = responses
                    .iter()
                    .position(|r| matches!(r, Response::Deflection { .. }))
                {
                    return Err(SettingsError::new(
                        format!("parameters[{k}]"),
                        format!(
                            "a joint's place moves responses[{r}]'s rigid trajectory, whose rate to it is not built: \
                             differentiate another response, or the deflection by differences"
                        ),
                    ));
                }
            }
            Parameter::Inertia { body: b, i, j } => {
                body(b, format!("parameters[{k}]"))?;
                if i > 2 || j > 2 {
                    return Err(SettingsError::new(
                        format!("parameters[{k}]"),
                        format!("inertia entry ({i}, {j}): 0, 1 or 2 each"),
                    ));
                }
            }
        }
    }
    Ok(())
}

/// The responses of the motion of `model` on `grid` and their exact gradients to
/// `parameters`, by `method` (`Auto`: the adjoint where there are fewer responses than
/// parameters). A run that restarts at a drive's kink where the grid lands has the
/// restart differentiated in either sweep ([`Sweep::restart_tangents`],
/// [`Sweep::restart_adjoint`]).
///
/// # Errors
/// [`SettingsError`] for a response or parameter the mechanism does not have; the run's
/// errors ([`crate::spatial::integrator::simulate_spatial`]); [`SolveError::Singular`] for a singular step matrix.
pub fn sensitivities(
    model: &SpatialModel,
    settings: &DynamicSettings,
    grid: &TimeGrid,
    responses: &[Response],
    parameters: &[Parameter],
    method: Method,
) -> Result<Gradients, Error> {
    of_motion(model, settings, grid, responses, parameters, method)
}

/// The responses of the motion of `model` on `grid` and each one's time error `f(h) − f`
/// to leading order in the step, from the run and one adjoint sweep: the steps' local
/// errors weighted by the adjoint ([`crate::solver::local_error`]).
///
/// # Errors
/// As [`sensitivities`].
pub fn time_errors(
    model: &SpatialModel,
    settings: &DynamicSettings,
    grid: &TimeGrid,
    responses: &[Response],
) -> Result<(Vec<f64>, Vec<f64>), Error> {
    let g = of_motion(model, settings, grid, responses, &[], Method::Adjoint)?;
    Ok((g.values, g.time_errors.unwrap_or_default()))
}

/// The responses' values on `states` — a run of `model` on `grid` (`restarted` its steps
/// that began with a restart at a drive's kink) or another trajectory on the same grid and
/// kinks — and, through `weights(n, k, μ)` where given, response `k`'s adjoint variables `μₙ` of the
/// force rows at every state `n`, linearized about `states`: where the force rows' residual
/// is held at `δrₙ` at `tₙ` rather than zero, the response changes by `μₙᵀ δrₙ` to first
/// order (the dual weights of [`crate::spatial::shares`]).
///
/// # Errors
/// As [`sensitivities`].
pub(crate) fn dual_weights(
    model: &SpatialModel,
    settings: &DynamicSettings,
    grid: &TimeGrid,
    responses: &[Response],
    (states, restarted): (&[State], Vec<bool>),
    weights: Option<&mut Weights<'_>>,
) -> Result<Vec<f64>, Error> {
    check(model, responses, &[])?;
    let mut sweep = prepared(model, settings, grid, responses, &[], states, restarted)?;
    let values = responses.iter().map(|r| sweep.value(r)).collect();
    if weights.is_some() {
        sweep.adjoint(responses, &[], false, weights)?;
    }
    Ok(values)
}

/// [`sensitivities`], by the adjoint with the responses' time errors ([`time_errors`]: its
/// local errors cost no measurable time beside the sweep's).
fn of_motion(
    model: &SpatialModel,
    settings: &DynamicSettings,
    grid: &TimeGrid,
    responses: &[Response],
    parameters: &[Parameter],
    method: Method,
) -> Result<Gradients, Error> {
    check(model, responses, parameters)?;
    let (states, restarted) = run(model, settings, grid)?;
    let mut sweep = prepared(
        model, settings, grid, responses, parameters, &states, restarted,
    )?;
    let values = responses.iter().map(|r| sweep.value(r)).collect();
    let swept = swept(parameters);
    let adjoint = match method {
        Method::Direct => false,
        Method::Adjoint => true,
        Method::Auto => responses.len() < swept.len(),
    };
    let (gradient, errors) = if adjoint {
        sweep.adjoint(responses, &swept, true, None)?
    } else {
        let by_parameter = sweep.direct(&swept, responses)?;
        let gradient = (0..responses.len())
            .map(|k| by_parameter.iter().map(|g| g[k]).collect())
            .collect();
        (gradient, None)
    };
    Ok(Gradients {
        time_errors: errors,
        ..sweep.gradients(values, responses, parameters, &gradient)
    })
}

/// The sweep of `states` (a run of `model` on `grid`, `restarted` its steps that began with
/// a restart at a drive's kink, or another trajectory on the same grid) for `responses` and
/// `parameters`: the rigid trajectories and their rates a tip deflection reads, and the
/// aggregated responses' means.
fn prepared<'m>(
    model: &'m SpatialModel,
    settings: &DynamicSettings,
    grid: &TimeGrid,
    responses: &[Response],
    parameters: &[Parameter],
    states: &'m [State],
    restarted: Vec<bool>,
) -> Result<Sweep<'m>, Error> {
    let mut sweep = Sweep::new(model, Some(settings.rho_inf), states)?;
    sweep.restarted = restarted;
    let tips: Vec<usize> = (responses.iter())
        .filter_map(|r| match *r {
            Response::Deflection { node } => Some(node),
            _ => None,
        })
        .collect();
    if !tips.is_empty() {
        let paths = rigid_trajectories(model, settings, grid, &tips)?;
        sweep.rigid = tips.iter().copied().zip(paths).collect();
        let drives: Vec<(usize, LawParameter)> = (parameters.iter())
            .filter_map(|p| match *p {
                Parameter::Drive { joint, law } => Some((joint, law)),
                _ => None,
            })
            .collect();
        let rates = match drives.is_empty() {
            true => Vec::new(),
            false => rigid_trajectory_rates(model, settings, grid, &tips, &drives)?,
        };
        for (&(joint, law), by_node) in drives.iter().zip(rates) {
            for (&node, path) in tips.iter().zip(by_node) {
                sweep
                    .rigid_rates
                    .push((node, Parameter::Drive { joint, law }, path));
            }
        }
    }
    sweep.prepare_means(responses);
    Ok(sweep)
}

/// State `n`'s weight in the trapezoidal rule over the run `states` (s).
pub(crate) fn trapezoid_weight(states: &[State], n: usize) -> f64 {
    let before = if n > 0 { states[n].h } else { 0.0 };
    let after = states.get(n + 1).map_or(0.0, |s| s.h);
    0.5 * (before + after)
}

/// The parameters a sweep carries: those the mechanism reads.
fn swept(parameters: &[Parameter]) -> Vec<Parameter> {
    (parameters.iter())
        .filter(|p| !p.explicit_only())
        .copied()
        .collect()
}

/// The responses of the static equilibrium of `model` ([`solve_static_spatial`]) and their
/// exact gradients to `parameters`: at the equilibrium `r(q, λ, p) = 0`, `Φ(q) = 0`,
///
/// ```text
/// [K_t  Bᵀ; B  0] [ε'; λ'] = −[∂r/∂p; 0]          (direct)
/// [K_t  Bᵀ; B  0]ᵀ y = [∂R/∂ε; ∂R/∂λ],  R' = −yᵀ[∂r/∂p; 0]   (adjoint)
/// ```
///
/// with `K_t` the tangent of Newton's last iteration without its `εM` (exact). A time
/// integral becomes its value at the equilibrium: [`Response::Effort`] is `λ²`,
/// [`Response::StrainEnergy`] the strain energy `U` (J).
///
/// # Errors
/// [`SettingsError`] for a response or parameter the mechanism does not have; the static
/// solve's errors; [`SolveError::Singular`] where the equilibrium's tangent is singular (a
/// direction nothing holds: its gradients are not defined).
pub fn static_sensitivities(
    model: &SpatialModel,
    settings: &StaticSettings,
    responses: &[Response],
    parameters: &[Parameter],
    method: Method,
) -> Result<Gradients, Error> {
    check(model, responses, parameters)?;
    let refused = |r: &Response| match r {
        Response::Deflection { .. } => Some(
            "a deflection from the rigid trajectory is a motion's: an equilibrium has none".into(),
        ),
        Response::KineticEnergy => {
            Some("the kinetic energy is a motion's: an equilibrium has none".into())
        }
        Response::Compliance => model.beyond_load_work().map(|name| {
            format!(
                "compliance at an equilibrium is Fᵀu, the work of dead forces and gravity: \
                 '{name}' is a follower load, a moment or a motor, which it cannot count (the \
                 strain energy U is the equilibrium's)"
            )
        }),
        _ => None,
    };
    if let Some((k, why)) = (responses.iter().enumerate()).find_map(|(k, r)| Some((k, refused(r)?)))
    {
        return Err(SettingsError::new(format!("responses[{k}]"), why).into());
    }
    let eq = solve_static_spatial(model, settings)?;
    let n_v = model.n_v();
    let states = [State {
        t: settings.time,
        q: eq.q,
        qdot: vec![0.0; n_v],
        qddot: vec![0.0; n_v],
        a: vec![0.0; n_v],
        lam: eq.lambda,
        h: 0.0,
        forecast: Forecast::default(),
    }];
    let mut sweep = Sweep::new(model, None, &states)?;
    sweep.prepare_means(responses);
    let values = responses.iter().map(|r| sweep.value(r)).collect();
    sweep.factorize_equilibrium()?;
    let (all, swept) = (parameters, swept(parameters));
    let parameters = &swept[..];
    let adjoint = match method {
        Method::Direct => false,
        Method::Adjoint => true,
        Method::Auto => responses.len() < parameters.len(),
    };
    let (mut eps, mut lam) = (vec![0.0; n_v], vec![0.0; model.n_rows()]);
    let mut rhs = vec![0.0; n_v + model.n_rows()];
    let mut gradient = vec![vec![0.0; parameters.len()]; responses.len()];
    if adjoint {
        for (g, r) in gradient.iter_mut().zip(responses) {
            sweep.seed(r, 0, &mut eps, &mut lam);
            rhs[..n_v].copy_from_slice(&eps);
            rhs[n_v..].copy_from_slice(&lam);
            sweep.solve(&mut rhs, true, 0)?;
            for (gi, p) in g.iter_mut().zip(parameters) {
                *gi = -sweep.parameter_dot(p, 0, &rhs[..n_v])
                    - sweep.constraint_dot(p, 0, Level::Position, 1.0, &rhs[n_v..]);
            }
        }
    } else {
        for (i, p) in parameters.iter().enumerate() {
            rhs.fill(0.0);
            sweep.add_parameter_load(p, 0, &mut rhs[..n_v]);
            sweep.add_constraint_load(p, 0, Level::Position, 1.0, &mut rhs[n_v..]);
            rhs.iter_mut().for_each(|x| *x = -*x);
            sweep.solve(&mut rhs, false, 0)?;
            for (g, r) in gradient.iter_mut().zip(responses) {
                sweep.seed(r, 0, &mut eps, &mut lam);
                g[i] = dot(&eps, &rhs[..n_v]) + dot(&lam, &rhs[n_v..]);
            }
        }
    }
    Ok(sweep.gradients(values, responses, all, &gradient))
}

/// The stored run and the linear algebra its sweeps share.
struct Sweep<'m> {
    asm: Assembler<'m>,
    lu: Unsymmetric,
    params: AlphaParameters,
    states: &'m [State],
    n_v: usize,
    n_rows: usize,
    /// Whether the one state is a static equilibrium: time integrals are their values.
    equilibrium: bool,
    /// Whether the step into state `n` began with a restart at a drive's kink.
    restarted: Vec<bool>,
    /// The rigid trajectory of each node a [`Response::Deflection`] names, a position per
    /// state.
    rigid: Vec<(usize, Vec<Vector3<f64>>)>,
    /// The rates of those trajectories to each drive parameter asked for
    /// ([`rigid_trajectory_rates`]): a node, the parameter, a rate per state.
    rigid_rates: Vec<(usize, Parameter, Vec<Vector3<f64>>)>,
    /// Each aggregated response's mean over the run ([`Response::aggregation`]).
    means: Vec<(Response, Mean)>,
}

/// An aggregated response's mean over the run and what its derivatives read: the
/// reference `r` its sum is kept relative to (the peak) and `d mean/dS`
/// ([`crate::response::aggregation`]).
#[derive(Debug, Clone, Copy)]
struct Mean {
    mean: f64,
    peak: f64,
    slope: f64,
}

/// A state's sensitivities to one parameter: `ε, v', v̇', a', λ'`.
#[derive(Clone)]
struct Tangent {
    eps: Vec<f64>,
    v: Vec<f64>,
    vdot: Vec<f64>,
    a: Vec<f64>,
    lam: Vec<f64>,
}

/// Which form of a driven row a parameter's derivative enters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Level {
    /// `Φ(q, t) = 0`: a step, an equilibrium.
    Position,
    /// `B v̇ + b = 0`: the initial accelerations.
    Acceleration,
}

/// The restart at a drive's kink on a state, as its derivative needs it
/// ([`Sweep::restart_tangents`]).
struct Restart {
    /// The kink's time (s).
    kink: f64,
    /// The jump `Δv̇`.
    dv: Vec<f64>,
    /// The jump of the multipliers `Δλ = s Δν`.
    mu: Vec<f64>,
    /// Whether each row's `b` jumped (the others' jumps are held at zero).
    jumped: Vec<bool>,
    /// The rows' scaling `s`.
    scale: f64,
    /// Each joint's share, in the model's order.
    joints: Vec<RestartJoint>,
}

/// A parameter's share in a restart's right-hand side ([`Sweep::restart_load`]).
struct RestartLoad {
    /// The joint it moves.
    joint: usize,
    /// On its local unknowns' force rows.
    force: Local,
    /// On its rows among the multipliers.
    constraint: RowsLoad,
}

/// A parameter's share in consecutive constraint rows: `values[k]` on row `first + k`,
/// `k < count`.
struct RowsLoad {
    first: usize,
    count: usize,
    values: SVector<f64, MAX_ROWS>,
}

impl RowsLoad {
    /// `value` on row `row` alone.
    fn one(row: usize, value: f64) -> Self {
        let mut values = SVector::zeros();
        values[0] = value;
        Self {
            first: row,
            count: 1,
            values,
        }
    }

    /// Adds `scale` times the load to the rows `out`.
    fn add_to(&self, scale: f64, out: &mut [f64]) {
        let rows = &mut out[self.first..self.first + self.count];
        rows.iter_mut()
            .zip(self.values.iter())
            .for_each(|(o, v)| *o += scale * v);
    }

    /// The load dotted with the rows `y`.
    fn dot(&self, y: &[f64]) -> f64 {
        (y[self.first..self.first + self.count].iter())
            .zip(self.values.iter())
            .map(|(y, v)| y * v)
            .sum()
    }
}

/// A joint's share in the restart's derivative, on its local unknowns.
struct RestartJoint {
    /// `∂(Bᵀ s Δν)/∂q`: the Hessians weighted by the jump's multipliers.
    force: Stiffness,
    /// `H_kᵀ Δv̇` of each row `k`, so that `∂(B Δv̇)/∂q ε` is `(H_kᵀ Δv̇) · ε` row by row.
    rows: Vec<Local>,
    /// Its first row among the multipliers.
    first: usize,
}

impl Restart {
    /// Adds the terms in the state's variation `ε` to the restart's right-hand side:
    /// `∂(Bᵀ s Δν)/∂q ε` to the force rows, `s ∂(B Δv̇)/∂q ε` to the constraint rows.
    fn add_state_terms(&self, model: &SpatialModel, eps: &[f64], rhs: &mut [f64]) {
        let n_v = model.n_v();
        for (joint, share) in model.joints.iter().zip(&self.joints) {
            let local = gather(joint, eps);
            let force = share.force * local;
            scatter(joint, &force, &mut rhs[..n_v]);
            for (k, row) in share.rows.iter().enumerate() {
                rhs[n_v + share.first + k] = self.scale * row.dot(&local);
            }
        }
    }

    /// Subtracts the transpose of [`Restart::add_state_terms`] applied to `y` from `ε̄`.
    fn subtract_state_terms_transposed(
        &self,
        model: &SpatialModel,
        y: &[f64],
        eps_bar: &mut [f64],
    ) {
        let n_v = model.n_v();
        for (joint, share) in model.joints.iter().zip(&self.joints) {
            let mut back = share.force.transpose() * gather(joint, &y[..n_v]);
            for (k, row) in share.rows.iter().enumerate() {
                back += row * (self.scale * y[n_v + share.first + k]);
            }
            scatter(joint, &(-back), eps_bar);
        }
    }
}

/// A joint's local unknowns read from a six-per-node vector.
fn gather(joint: &Joint, v: &[f64]) -> Local {
    let mut local = Local::zeros();
    for (side, node) in joint.local_nodes() {
        local
            .fixed_rows_mut::<6>(6 * side)
            .copy_from_slice(&six(v, node));
    }
    local
}

/// Adds an element's local forces to a six-per-node vector.
fn add_element_local(e: &dyn Element, local: &Local, out: &mut [f64]) {
    for (side, node) in e.nodes().into_iter().enumerate() {
        out[NV * node..NV * node + NV]
            .iter_mut()
            .zip(&local.as_slice()[NV * side..NV * side + NV])
            .for_each(|(o, x)| *o += x);
    }
}

/// Adds a joint's local forces to a six-per-node vector.
fn scatter(joint: &Joint, local: &Local, out: &mut [f64]) {
    for (side, node) in joint.local_nodes() {
        for i in 0..6 {
            out[NV * node + i] += local[6 * side + i];
        }
    }
}

impl<'m> Sweep<'m> {
    /// The sweep of a run at `rho_inf`, or of an equilibrium (`None`).
    fn new(
        model: &'m SpatialModel,
        rho_inf: Option<f64>,
        states: &'m [State],
    ) -> Result<Self, Error> {
        let (asm, lu) = analysed(model)?;
        Ok(Self {
            asm,
            lu,
            params: AlphaParameters::chung_hulbert(rho_inf.unwrap_or(1.0)),
            states,
            n_v: model.n_v(),
            n_rows: model.n_rows(),
            equilibrium: rho_inf.is_none(),
            restarted: vec![false; states.len()],
            rigid: Vec::new(),
            rigid_rates: Vec::new(),
            means: Vec::new(),
        })
    }

    /// Each aggregated response's mean over the run, made once for its value and its
    /// seeds.
    fn prepare_means(&mut self, responses: &[Response]) {
        for r in responses {
            if r.aggregation().is_some() && !self.means.iter().any(|(known, _)| known == r) {
                let mean = self.make_mean(r);
                self.means.push((*r, mean));
            }
        }
    }

    /// Each response's peak, an aggregated one's (`None` for the others).
    fn peaks(&self, responses: &[Response]) -> Vec<Option<f64>> {
        (responses.iter())
            .map(|r| r.aggregation().map(|_| self.mean_of(r).peak))
            .collect()
    }

    /// The mean of an aggregated response: the one [`Sweep::prepare_means`] made, or made
    /// now.
    fn mean_of(&self, r: &Response) -> Mean {
        match self.means.iter().find(|(known, _)| known == r) {
            Some(&(_, mean)) => mean,
            None => self.make_mean(r),
        }
    }

    /// The mean of an aggregated response over the run.
    fn make_mean(&self, r: &Response) -> Mean {
        match *r {
            Response::Stress {
                criterion,
                aggregation,
                relaxation,
                within,
            } => self.stress_mean(criterion, &aggregation, relaxation, within),
            Response::Reaction { joint, aggregation } => {
                self.point_mean(&aggregation, |n| self.reaction(joint, n))
            }
            Response::Torque { joint, aggregation } => {
                let k = self.drive_multiplier(joint);
                self.point_mean(&aggregation, |n| self.states[n].lam[k])
            }
            _ => Mean {
                mean: 0.0,
                peak: 0.0,
                slope: 0.0,
            },
        }
    }

    /// The p-mean or KS mean over the run of one value per state (the trapezoidal weights
    /// over `t_f`; an equilibrium's one value): its peak first, then the sum relative to it.
    fn point_mean(&self, a: &Aggregation, value: impl Fn(usize) -> f64) -> Mean {
        let states = 0..self.states.len();
        let peak = states.clone().map(|n| value(n).abs()).fold(0.0, f64::max);
        let sum: f64 = states
            .map(|n| self.weight(n) / self.duration() * a.point(value(n), peak).0)
            .sum();
        let (mean, slope) = a.mean(sum, peak);
        Mean { mean, peak, slope }
    }

    /// A reaction's or a torque's mean's derivative to the multipliers at state `n`,
    /// added to `lam`.
    fn add_point_mean_seed(&self, r: &Response, n: usize, lam: &mut [f64]) {
        let (Response::Reaction { joint, aggregation } | Response::Torque { joint, aggregation }) =
            *r
        else {
            return;
        };
        let m = self.mean_of(r);
        let w = m.slope * self.weight(n) / self.duration();
        let at = &self.states[n].lam;
        match *r {
            Response::Reaction { joint, .. } => {
                let force = self.reaction(joint, n);
                if force == 0.0 {
                    return;
                }
                let slope = w * aggregation.point(force, m.peak).1 / force;
                for k in self.force_multipliers(joint) {
                    lam[k] += slope * at[k];
                }
            }
            _ => {
                let k = self.drive_multiplier(joint);
                lam[k] += w * aggregation.point(at[k], m.peak).1;
            }
        }
    }

    /// The multipliers of a joint's rows that hold its points together
    /// ([`Joint::force_rows`]).
    fn force_multipliers(&self, joint: usize) -> impl Iterator<Item = usize> + 'm {
        let start = self.row_of(joint, 0);
        self.model().joints[joint]
            .force_rows()
            .map(move |k| start + k)
    }

    /// The multiplier of a driven joint's drive row ([`check`] made sure it is driven).
    fn drive_multiplier(&self, joint: usize) -> usize {
        let row = self.model().joints[joint].drive_row_index().unwrap_or(0);
        self.row_of(joint, row)
    }

    /// The magnitude of the force joint `joint` transmits at state `n` (N).
    fn reaction(&self, joint: usize, n: usize) -> f64 {
        let lam = &self.states[n].lam;
        (self.force_multipliers(joint))
            .map(|k| lam[k] * lam[k])
            .sum::<f64>()
            .sqrt()
    }

    /// Element `e`'s values of `criterion` at state `n` into `out` (its fibres' stresses,
    /// or its buckling ratio), how many, and their weight each in a stress mean (module docs
    /// of [`crate::spatial::stress`]; `total` the elements' length).
    fn element_stresses(
        &self,
        criterion: Criterion,
        n: usize,
        e: &dyn Element,
        total: f64,
        out: &mut [f64; MAX_FIBRES],
    ) -> (usize, f64) {
        let q = &self.states[n].q;
        let count = match criterion {
            Criterion::VonMises => e.stresses(q, out),
            Criterion::Buckling => {
                out[0] = e.buckling(q).0;
                1
            }
        };
        let time = self.weight(n) / self.duration();
        (count, time * e.length() / (total * count as f64))
    }

    /// The elements a stress response reads (every one where `within` is `None`).
    fn stressed(&self, within: Option<Elements>) -> impl Iterator<Item = &'m dyn Element> {
        let m = self.model();
        let all = Elements {
            beams: [0, m.beams.len()],
            trusses: [0, m.trusses.len()],
        };
        let Elements { beams, trusses } = within.unwrap_or(all);
        let beams = m.beams[beams[0]..beams[1]]
            .iter()
            .map(|e| e as &dyn Element);
        beams.chain(
            m.trusses[trusses[0]..trusses[1]]
                .iter()
                .map(|e| e as &dyn Element),
        )
    }

    /// Their length (m), the stress means' measure.
    fn total_length(&self, within: Option<Elements>) -> f64 {
        self.stressed(within).map(|e| e.length()).sum()
    }

    /// The p-mean or KS mean of `x^q σ` over the run, the elements and their fibres: its
    /// peak first, then the sum relative to it.
    fn stress_mean(
        &self,
        criterion: Criterion,
        a: &Aggregation,
        relaxation: f64,
        within: Option<Elements>,
    ) -> Mean {
        let total = self.total_length(within);
        let mut out = [0.0; MAX_FIBRES];
        let (mut peak, mut sum) = (0.0f64, 0.0);
        for pass in 0..2 {
            for n in 0..self.states.len() {
                for e in self.stressed(within) {
                    let (count, w) = self.element_stresses(criterion, n, e, total, &mut out);
                    let x = e.density().powf(relaxation);
                    for sigma in &out[..count] {
                        match pass {
                            0 => peak = peak.max((x * sigma).abs()),
                            _ => sum += w * a.point(x * sigma, peak).0,
                        }
                    }
                }
            }
        }
        let (mean, slope) = a.mean(sum, peak);
        Mean { mean, peak, slope }
    }

    /// A stress mean's derivative to the states at state `n`, added to `eps`.
    fn add_stress_seed(&self, r: &Response, n: usize, eps: &mut [f64]) {
        let Some((criterion, aggregation, relaxation, within)) = r.stress() else {
            return;
        };
        let (m, total) = (self.mean_of(r), self.total_length(within));
        let (mut out, mut weights) = ([0.0; MAX_FIBRES], [0.0; MAX_FIBRES]);
        let q = &self.states[n].q;
        for e in self.stressed(within) {
            let (count, w) = self.element_stresses(criterion, n, e, total, &mut out);
            let x = e.density().powf(relaxation);
            for (weight, sigma) in weights.iter_mut().zip(&out[..count]) {
                *weight = m.slope * w * aggregation.point(x * sigma, m.peak).1 * x;
            }
            let local = match criterion {
                Criterion::VonMises => e.stress_gradient(q, &weights[..count]),
                Criterion::Buckling => e.buckling(q).1 * weights[0],
            };
            add_element_local(e, &local, eps);
        }
    }

    /// A stress mean's explicit derivative to the density of element `e` (a beam, or a
    /// truss bar, number `index` of its kind): its relaxation's,
    /// `Σ ∂mean/∂(x^q σ) q x^{q−1} σ`; zero for an element the mean does not read.
    fn relaxation_rate(&self, r: &Response, e: &dyn Element, truss: bool, index: usize) -> f64 {
        let Some((_, _, relaxation, _)) = r.stress() else {
            return 0.0;
        };
        if relaxation == 0.0 {
            return 0.0;
        }
        let x = e.density();
        let rate = relaxation * x.powf(relaxation - 1.0);
        self.point_sum(r, e, truss, index, |sigma| rate * sigma)
    }

    /// `∂mean/∂ ln b` of a buckling mean to a factor on one element's buckling ratios
    /// (a beam, or a truss bar, number `index` of its kind): `Σ ∂mean/∂(x^q b) x^q b`;
    /// zero for a von Mises mean or an element the mean does not read.
    fn buckling_share(&self, r: &Response, e: &dyn Element, truss: bool, index: usize) -> f64 {
        match r.stress() {
            Some((Criterion::Buckling, _, relaxation, _)) => {
                let relaxed = e.density().powf(relaxation);
                self.point_sum(r, e, truss, index, |b| relaxed * b)
            }
            _ => 0.0,
        }
    }

    /// `Σ ∂mean/∂(x^q σ) · f(σ)` over one element's points and the run, the element a beam
    /// or a truss bar, number `index` of its kind; zero where the mean does not read it.
    fn point_sum(
        &self,
        r: &Response,
        e: &dyn Element,
        truss: bool,
        index: usize,
        f: impl Fn(f64) -> f64,
    ) -> f64 {
        let Some((criterion, aggregation, relaxation, within)) = r.stress() else {
            return 0.0;
        };
        let read = within.is_none_or(|w| {
            let [a, b] = if truss { w.trusses } else { w.beams };
            (a..b).contains(&index)
        });
        if !read {
            return 0.0;
        }
        let (m, total) = (self.mean_of(r), self.total_length(within));
        let relaxed = e.density().powf(relaxation);
        let mut out = [0.0; MAX_FIBRES];
        let mut sum = 0.0;
        for n in 0..self.states.len() {
            let (count, w) = self.element_stresses(criterion, n, e, total, &mut out);
            for sigma in &out[..count] {
                sum += w * aggregation.point(relaxed * sigma, m.peak).1 * f(*sigma);
            }
        }
        m.slope * sum
    }

    /// A beam and its section's rate to one of its dimensions ([`check`] made sure it has
    /// it).
    fn size_rate(&self, beam: usize, dimension: Dimension) -> (&'m Beam, Section) {
        let beam = &self.model().beams[beam];
        let rate = beam.section_rate(dimension).unwrap_or(beam.section);
        (beam, rate)
    }

    /// A stress response's explicit derivative to a beam's section size: its fibres moved,
    /// `Σ ∂mean/∂(x^q σ) x^q ∂σ/∂p` at fixed strains; zero for a beam the mean does not read.
    fn fibre_rate(&self, r: &Response, index: usize, dimension: Dimension) -> f64 {
        let Some((criterion, aggregation, relaxation, within)) = r.stress() else {
            return 0.0;
        };
        if criterion == Criterion::Buckling {
            let (beam, rate) = self.size_rate(index, dimension);
            return beam.buckling_log_rate(&rate) * self.buckling_share(r, beam, false, index);
        }
        if !within.is_none_or(|w| (w.beams[0]..w.beams[1]).contains(&index)) {
            return 0.0;
        }
        let (beam, rate) = self.size_rate(index, dimension);
        let (m, total) = (self.mean_of(r), self.total_length(within));
        let relaxed = beam.density().powf(relaxation);
        let (mut out, mut moved) = ([0.0; MAX_FIBRES], [0.0; MAX_FIBRES]);
        let mut sum = 0.0;
        for n in 0..self.states.len() {
            let (count, w) = self.element_stresses(criterion, n, beam, total, &mut out);
            beam.stress_rates(&rate, &self.states[n].q, &mut moved);
            for (sigma, sigma_rate) in out[..count].iter().zip(&moved) {
                sum += w * aggregation.point(relaxed * sigma, m.peak).1 * relaxed * sigma_rate;
            }
        }
        m.slope * sum
    }

    /// The responses' `values` with their gradients (those of the `swept` parameters
    /// spread over `parameters`, their explicit parts added) and peaks.
    fn gradients(
        &self,
        values: Vec<f64>,
        responses: &[Response],
        parameters: &[Parameter],
        swept: &[Vec<f64>],
    ) -> Gradients {
        Gradients {
            values,
            gradient: self.with_explicit(responses, parameters, swept),
            peaks: self.peaks(responses),
            time_errors: None,
        }
    }

    /// The gradients of the swept parameters spread over `parameters` (zero where a
    /// parameter was not swept), each with its explicit part added.
    fn with_explicit(
        &self,
        responses: &[Response],
        parameters: &[Parameter],
        swept: &[Vec<f64>],
    ) -> Vec<Vec<f64>> {
        (responses.iter().zip(swept))
            .map(|(r, g)| {
                let mut carried = g.iter();
                (parameters.iter())
                    .map(|p| {
                        let implicit = match p.explicit_only() {
                            true => 0.0,
                            false => *carried.next().expect("one per swept parameter"),
                        };
                        implicit + self.explicit(r, p)
                    })
                    .collect()
            })
            .collect()
    }

    fn model(&self) -> &'m SpatialModel {
        self.asm.model
    }

    /// The value of a response over the stored run.
    fn value(&self, r: &Response) -> f64 {
        match *r {
            Response::Position { body, axis } => {
                self.final_coordinate(self.model().bodies[body].node, axis)
            }
            Response::NodePosition { node, axis } => self.final_coordinate(node, axis),
            Response::Effort { joint, row } => {
                let k = self.row_of(joint, row);
                (0..self.states.len())
                    .map(|n| self.weight(n) * self.states[n].lam[k].powi(2))
                    .sum()
            }
            Response::StrainEnergy => {
                let energy: f64 = self.model().elements().map(|e| self.energy(e)).sum();
                energy / self.duration()
            }
            Response::Compliance if self.equilibrium => {
                let s = &self.states[0];
                self.model().load_work(&s.q, s.t)
            }
            Response::Compliance => self.value(&Response::StrainEnergy),
            Response::Reaction { .. } | Response::Torque { .. } => self.mean_of(r).mean,
            Response::KineticEnergy => (0..self.states.len())
                .map(|n| self.weight(n) * self.model().kinetic_energy(&self.states[n].qdot))
                .sum(),
            Response::Stress { .. } => self.mean_of(r).mean,
            Response::Deflection { node } => {
                (0..self.states.len())
                    .map(|n| self.weight(n) * self.deflection(node, n).norm_squared())
                    .sum::<f64>()
                    / self.duration()
            }
        }
    }

    /// A deflection's explicit derivative to a drive parameter, through its rigid
    /// trajectory: `−(2/t_f) Σ wₙ (r − r_rigid)ₙ · ∂r_rigid,ₙ/∂p`.
    fn rigid_share(&self, node: usize, p: &Parameter) -> f64 {
        let Some((.., rates)) = (self.rigid_rates.iter()).find(|(n, q, _)| *n == node && q == p)
        else {
            return 0.0;
        };
        let share: f64 = (rates.iter().enumerate())
            .map(|(n, rate)| self.weight(n) * self.deflection(node, n).dot(rate))
            .sum();
        -2.0 * share / self.duration()
    }

    /// `r − r_rigid` of node `node` at state `n` (a deflection's rigid trajectory made).
    fn deflection(&self, node: usize, n: usize) -> Vector3<f64> {
        let rigid = (self.rigid.iter())
            .find(|(k, _)| *k == node)
            .map_or_else(Vector3::zeros, |(_, path)| path[n]);
        Frame::read(&self.states[n].q, node).x - rigid
    }

    /// The run's duration `t_f` (s).
    fn duration(&self) -> f64 {
        let [first, .., last] = self.states else {
            return 1.0;
        };
        last.t - first.t
    }

    /// `∫ U dt` of one element over the stored run.
    fn energy(&self, element: &dyn Element) -> f64 {
        (0..self.states.len())
            .map(|n| self.weight(n) * element.strain_energy(&self.states[n].q))
            .sum()
    }

    /// The element a beam's or a bar's parameter scales, and whether its stiffness.
    fn element_of(&self, p: &Parameter) -> Option<(&'m dyn Element, bool)> {
        let model = self.model();
        match *p {
            Parameter::BeamStiffness { beam } => Some((&model.beams[beam], true)),
            Parameter::BeamMass { beam } => Some((&model.beams[beam], false)),
            Parameter::TrussStiffness { truss } => Some((&model.trusses[truss], true)),
            Parameter::TrussMass { truss } => Some((&model.trusses[truss], false)),
            _ => None,
        }
    }

    /// A response's explicit partial derivative to a parameter (at fixed states): an
    /// element's stiffness factor scales its strain energy.
    fn explicit(&self, r: &Response, p: &Parameter) -> f64 {
        let model = self.model();
        match (r, p) {
            (Response::Stress { .. }, Parameter::BeamDensity { beam }) => {
                self.relaxation_rate(r, &model.beams[*beam], false, *beam)
            }
            (Response::Stress { .. }, Parameter::TrussDensity { truss }) => {
                self.relaxation_rate(r, &model.trusses[*truss], true, *truss)
            }
            (Response::Stress { .. }, Parameter::TrussBuckling { truss }) => {
                self.buckling_share(r, &model.trusses[*truss], true, *truss)
            }
            (Response::StrainEnergy, Parameter::BeamSize { beam, dimension }) => {
                let (beam, rate) = self.size_rate(*beam, *dimension);
                let energy: f64 = (0..self.states.len())
                    .map(|n| self.weight(n) * beam.strain_energy_of(&rate, &self.states[n].q))
                    .sum();
                energy / self.duration()
            }
            (Response::Stress { .. }, Parameter::BeamSize { beam, dimension }) => {
                self.fibre_rate(r, *beam, *dimension)
            }
            (Response::StrainEnergy, _) => match self.element_of(p) {
                Some((element, true)) => self.energy(element) / self.duration(),
                _ => 0.0,
            },
            (Response::Compliance, _) if self.equilibrium => self.weight_work_rate(p),
            (Response::Compliance, _) => self.explicit(&Response::StrainEnergy, p),
            (Response::KineticEnergy, _) => self.kinetic_rate(p),
            (Response::Deflection { node }, Parameter::Drive { .. }) => self.rigid_share(*node, p),
            _ => 0.0,
        }
    }

    /// A static compliance's explicit derivative to a parameter on a mass, `Fᵀu` being
    /// linear in each weight: a body's `g·u`, an element's mass factor's or section size's
    /// `(m'/2) g·(u_A + u_B)` at its nodes.
    fn weight_work_rate(&self, p: &Parameter) -> f64 {
        let model = self.model();
        let q = &self.states[0].q;
        let moved = |node: usize| {
            let start = model.nodes[node].frame.x;
            model.gravity.dot(&(Frame::read(q, node).x - start))
        };
        let ends = |e: &dyn Element| e.nodes().map(moved).iter().sum::<f64>() * 0.5 * e.mass();
        match *p {
            Parameter::Mass { body } => moved(model.bodies[body].node),
            Parameter::BeamMass { beam } => ends(&model.beams[beam]),
            Parameter::TrussMass { truss } => ends(&model.trusses[truss]),
            Parameter::BeamSize { beam, dimension } => {
                let (beam, rate) = self.size_rate(beam, dimension);
                ends(beam) * rate.rho_a / beam.section.rho_a
            }
            _ => 0.0,
        }
    }

    /// `∫ T dt`'s explicit derivative to a parameter on an inertia, `T` being linear in each:
    /// an element's mass factor's `∫ T_e dt`, a body's mass's `∫ ½|u̇|² dt`, an inertia
    /// entry's `∫ ½ Ωᵀ(e_ij + e_ji)Ω dt` (halved on the diagonal).
    fn kinetic_rate(&self, p: &Parameter) -> f64 {
        let model = self.model();
        let rate = |n: usize| -> f64 {
            let v = &self.states[n].qdot;
            match *p {
                Parameter::BeamMass { beam } => model.beams[beam].kinetic_energy(v),
                Parameter::BeamSize { beam, dimension } => {
                    let (beam, rate) = self.size_rate(beam, dimension);
                    beam.kinetic_energy_of(&rate, v)
                }
                Parameter::TrussMass { truss } => model.trusses[truss].kinetic_energy(v),
                Parameter::Mass { body } => {
                    0.5 * split(&six(v, model.bodies[body].node)).0.norm_squared()
                }
                Parameter::Inertia { body, i, j } => {
                    let omega = split(&six(v, model.bodies[body].node)).1;
                    omega[i] * omega[j] * if i == j { 0.5 } else { 1.0 }
                }
                _ => 0.0,
            }
        };
        (0..self.states.len())
            .map(|n| self.weight(n) * rate(n))
            .sum()
    }

    /// A response's partial derivative to the velocities `v` at state `n` into `out`;
    /// `false` (and `out` untouched) where it reads none.
    fn velocity_seed(&self, r: &Response, n: usize, out: &mut [f64]) -> bool {
        if *r != Response::KineticEnergy {
            return false;
        }
        out.fill(0.0);
        (self.model()).add_momenta(&self.states[n].qdot, self.weight(n), out);
        true
    }

    /// Coordinate `axis` of node `node`'s origin at the end of the run.
    fn final_coordinate(&self, node: usize, axis: usize) -> f64 {
        Frame::read(&self.states[self.states.len() - 1].q, node).x[axis]
    }

    /// The multiplier of a joint's row ([`check`] made sure it has it).
    fn row_of(&self, joint: usize, row: usize) -> usize {
        self.model().joint_rows(joint).map_or(0, |r| r.start) + row
    }

    /// The trapezoidal weight of state `n` (1 for an equilibrium).
    fn weight(&self, n: usize) -> f64 {
        match self.equilibrium {
            true => 1.0,
            false => trapezoid_weight(self.states, n),
        }
    }

    /// A response's partial derivatives at state `n`: to `ε` and to `λ`.
    fn seed(&self, r: &Response, n: usize, eps: &mut [f64], lam: &mut [f64]) {
        eps.fill(0.0);
        lam.fill(0.0);
        match *r {
            Response::Position { .. } | Response::NodePosition { .. } => {
                let (node, axis) = match *r {
                    Response::Position { body, axis } => (self.model().bodies[body].node, axis),
                    Response::NodePosition { node, axis } => (node, axis),
                    _ => return,
                };
                if n + 1 == self.states.len() {
                    eps[NV * node + axis] = 1.0;
                }
            }
            Response::Effort { joint, row } => {
                let k = self.row_of(joint, row);
                lam[k] = 2.0 * self.weight(n) * self.states[n].lam[k];
            }
            Response::Deflection { node } => {
                let gap = self.deflection(node, n) * (2.0 * self.weight(n) / self.duration());
                eps[NV * node..NV * node + 3].copy_from_slice(gap.as_slice());
            }
            Response::Compliance if self.equilibrium => {
                let s = &self.states[n];
                self.model().add_load_work_gradient(&s.q, s.t, 1.0, eps);
            }
            Response::StrainEnergy | Response::Compliance => {
                let w = self.weight(n) / self.duration();
                for e in self.model().elements() {
                    add_element_local(e, &(e.elastic_force(&self.states[n].q) * w), eps);
                }
            }
            Response::Stress { .. } => self.add_stress_seed(r, n, eps),
            Response::Reaction { .. } | Response::Torque { .. } => {
                self.add_point_mean_seed(r, n, lam);
            }
            // It reads the velocities only ([`Sweep::velocity_seed`]).
            Response::KineticEnergy => {}
        }
    }

    /// `∂r/∂p` at state `n`: the nodes it reaches (at most two) and its force rows there
    /// (no parameter here enters the constraints).
    fn parameter_load(&self, p: &Parameter, n: usize) -> ([Option<usize>; 2], Local) {
        let s = &self.states[n];
        let model = self.model();
        let mut local = Local::zeros();
        let body_node = |body: usize| [Some(model.bodies[body].node), None];
        match *p {
            Parameter::Mass { body } => {
                let node = model.bodies[body].node;
                let (udot, _) = split(&six(&s.qddot, node));
                local
                    .fixed_rows_mut::<3>(0)
                    .copy_from(&(udot - model.gravity));
                (body_node(body), local)
            }
            Parameter::Inertia { body, i, j } => {
                let node = model.bodies[body].node;
                let mut e = Matrix3::zeros();
                e[(i, j)] = 1.0;
                e[(j, i)] = 1.0;
                let (_, omega) = split(&six(&s.qdot, node));
                let (_, omegadot) = split(&six(&s.qddot, node));
                local
                    .fixed_rows_mut::<3>(3)
                    .copy_from(&(e * omegadot + omega.cross(&(e * omega))));
                (body_node(body), local)
            }
            Parameter::SpringStiffness { force }
            | Parameter::SpringDamping { force }
            | Parameter::SpringRest { force }
            | Parameter::MotorTorque { force } => {
                let which = match p {
                    Parameter::SpringStiffness { .. } => ForceParameter::Stiffness,
                    Parameter::SpringDamping { .. } => ForceParameter::Damping,
                    Parameter::SpringRest { .. } => ForceParameter::Rest,
                    _ => ForceParameter::Torque,
                };
                let element = &model.forces[force];
                (
                    element.pair.nodes,
                    element.parameter_rate(which, &s.q, &s.qdot, s.t),
                )
            }
            Parameter::BeamStiffness { beam } => self.element_load(&model.beams[beam], true, n),
            Parameter::BeamMass { beam } => self.element_load(&model.beams[beam], false, n),
            Parameter::TrussStiffness { truss } => {
                self.element_load(&model.trusses[truss], true, n)
            }
            Parameter::TrussMass { truss } => self.element_load(&model.trusses[truss], false, n),
            Parameter::BeamSize { beam, dimension } => {
                let (beam, rate) = self.size_rate(beam, dimension);
                let load = beam.section_load(&rate, &s.q, &s.qdot, &s.qddot, &model.gravity);
                (beam.pair().nodes, load)
            }
            Parameter::Drive { joint, law } => {
                let j = &model.joints[joint];
                match j.drive_rate(&s.q, None, s.t, law) {
                    Some((row, rate)) => {
                        let lambda = s.lam[self.row_of(joint, row)];
                        (j.pair.nodes, rate.gradient * lambda)
                    }
                    None => ([None, None], local),
                }
            }
            Parameter::JointPosition { joint, axis } => {
                let j = &model.joints[joint];
                let rate = j.position_rate(&s.q, None, s.t, &Vector3::ith(axis, 1.0));
                (
                    j.pair.nodes,
                    rate.gradient.tr_mul(&self.joint_multipliers(joint, &s.lam)),
                )
            }
            Parameter::BeamDensity { .. }
            | Parameter::TrussDensity { .. }
            | Parameter::TrussBuckling { .. } => ([None, None], local),
        }
    }

    /// Joint `joint`'s rows of the multipliers `lam`, padded to [`MAX_ROWS`].
    fn joint_multipliers(&self, joint: usize, lam: &[f64]) -> SVector<f64, MAX_ROWS> {
        let (first, n) = (self.row_of(joint, 0), self.model().joints[joint].n_rows());
        let mut out = SVector::<f64, MAX_ROWS>::zeros();
        out.rows_mut(0, n).copy_from_slice(&lam[first..first + n]);
        out
    }

    /// `values` on joint `joint`'s rows among the multipliers.
    fn joint_load(&self, joint: usize, values: SVector<f64, MAX_ROWS>) -> RowsLoad {
        RowsLoad {
            first: self.row_of(joint, 0),
            count: self.model().joints[joint].n_rows(),
            values,
        }
    }

    /// A parameter's share in the constraint rows at state `n` (`level` position: `∂Φ/∂p`,
    /// at a step or an equilibrium; acceleration: `∂B/∂p v̇ + ∂b/∂p`, at the start): a
    /// drive parameter's on its driven row, a joint's place's on its rows; `None` for the
    /// other parameters.
    fn constraint_load(&self, p: &Parameter, n: usize, level: Level) -> Option<RowsLoad> {
        let s = &self.states[n];
        let v = (level == Level::Acceleration).then_some(&s.qdot[..]);
        match *p {
            Parameter::Drive { joint, law } => {
                let (row, rate) = self.model().joints[joint].drive_rate(&s.q, v, s.t, law)?;
                let value = match level {
                    Level::Position => rate.value,
                    Level::Acceleration => rate.term,
                };
                Some(RowsLoad::one(self.row_of(joint, row), value))
            }
            Parameter::JointPosition { joint, axis } => {
                let j = &self.model().joints[joint];
                let rate = j.position_rate(&s.q, v, s.t, &Vector3::ith(axis, 1.0));
                let values = match level {
                    Level::Position => rate.value,
                    Level::Acceleration => rate.term + rate.gradient * gather(j, &s.qddot),
                };
                Some(self.joint_load(joint, values))
            }
            _ => None,
        }
    }

    /// Adds `scale` times [`Sweep::constraint_load`] to the constraint rows `out`.
    fn add_constraint_load(
        &self,
        p: &Parameter,
        n: usize,
        level: Level,
        scale: f64,
        out: &mut [f64],
    ) {
        if let Some(load) = self.constraint_load(p, n, level) {
            load.add_to(scale, out);
        }
    }

    /// `scale` times [`Sweep::constraint_load`] dotted with the constraint rows `y`.
    fn constraint_dot(&self, p: &Parameter, n: usize, level: Level, scale: f64, y: &[f64]) -> f64 {
        self.constraint_load(p, n, level)
            .map_or(0.0, |load| scale * load.dot(y))
    }

    /// `∂r/∂p` at state `n` of a factor on an element's stiffness or its mass: its elastic
    /// and viscous forces, or its inertia and weight — both linear in their factor.
    fn element_load(
        &self,
        element: &dyn Element,
        stiffness: bool,
        n: usize,
    ) -> ([Option<usize>; 2], Local) {
        let s = &self.states[n];
        let terms = element.terms(&s.q, &s.qdot, Some(&s.qddot), &self.model().gravity, None);
        let local = if stiffness {
            terms.internal
        } else {
            terms.inertia
        };
        (element.pair().nodes, local)
    }

    /// `(∂r/∂p) · y` at state `n`.
    fn parameter_dot(&self, p: &Parameter, n: usize, y: &[f64]) -> f64 {
        let (nodes, local) = self.parameter_load(p, n);
        (0..2)
            .filter_map(|side| {
                nodes[side].map(|node| {
                    dot(
                        &local.as_slice()[NV * side..NV * side + NV],
                        &y[NV * node..NV * node + NV],
                    )
                })
            })
            .sum()
    }

    /// Adds `∂r/∂p` at state `n` to the force rows `out`.
    fn add_parameter_load(&self, p: &Parameter, n: usize, out: &mut [f64]) {
        let (nodes, local) = self.parameter_load(p, n);
        for (side, node) in nodes.iter().enumerate() {
            if let Some(node) = *node {
                out[NV * node..NV * node + NV]
                    .iter_mut()
                    .zip(&local.as_slice()[NV * side..NV * side + NV])
                    .for_each(|(o, l)| *o += l);
            }
        }
    }

    /// The row scaling of the step into state `n` (`n > 0`) or of the start.
    fn scale(&self, n: usize) -> f64 {
        let c = if n == 0 {
            1.0
        } else {
            self.params.beta_prime(self.states[n].h)
        };
        c * self.asm.mean_mass()
    }

    /// Factorizes the matrix of the start (`n = 0`) or of the step into state `n`, at its
    /// converged state.
    fn factorize(&mut self, n: usize) -> Result<(), SolveError> {
        let s = &self.states[n];
        let scale = self.scale(n);
        let increment;
        let c = if n == 0 {
            Coefficients {
                beta_prime: 1.0,
                gamma_prime: 0.0,
                scale,
                tangent: None,
            }
        } else {
            increment = increments(self.model(), &self.states[n - 1].q, &s.q);
            Coefficients {
                beta_prime: self.params.beta_prime(s.h),
                gamma_prime: self.params.gamma_prime(s.h),
                scale,
                tangent: Some((&increment, &s.lam)),
            }
        };
        self.asm.matrix(&s.q, &s.qdot, s.t, c)?;
        let values = &self.asm.values;
        self.lu.factorize(values).map_err(|e| SolveError::Singular {
            time: s.t,
            detail: format!("{e:?}"),
        })
    }

    /// Factorizes the exact tangent `[K_t, Bᵀ; B, 0]` of the equilibrium (the one state).
    fn factorize_equilibrium(&mut self) -> Result<(), SolveError> {
        let s = &self.states[0];
        let rest = vec![0.0; self.n_v];
        let c = Coefficients {
            beta_prime: 0.0,
            gamma_prime: 0.0,
            scale: 1.0,
            tangent: Some((&rest, &s.lam)),
        };
        self.asm.matrix(&s.q, &s.qdot, s.t, c)?;
        self.lu
            .factorize(&self.asm.values)
            .map_err(|e| SolveError::Singular {
                time: s.t,
                detail: format!(
                    "{e:?}: the equilibrium's tangent is singular (a direction nothing holds), \
                     its gradients are not defined"
                ),
            })
    }

    /// `A x = rhs` (or `Aᵀ x = rhs`) refined once ([`Unsymmetric::solve_refined`]), in place.
    fn solve(&mut self, rhs: &mut [f64], transpose: bool, n: usize) -> Result<(), SolveError> {
        let time = self.states[n].t;
        self.lu
            .solve_refined(&self.asm.values, rhs, transpose)
            .map_err(|e| SolveError::Singular {
                time,
                detail: format!("{e:?}"),
            })
    }

    /// Direct differentiation: every response's derivative to every parameter,
    /// `[parameter][response]`, each step's matrix factored once for all parameters.
    fn direct(
        &mut self,
        parameters: &[Parameter],
        responses: &[Response],
    ) -> Result<Vec<Vec<f64>>, SolveError> {
        let (n_v, m) = (self.n_v, self.n_rows);
        let mut rhs = vec![0.0; n_v + m];
        // The start: ε₀ = v₀' = 0.
        self.factorize(0)?;
        let s0 = self.scale(0);
        let mut tangents = Vec::with_capacity(parameters.len());
        for p in parameters {
            rhs.fill(0.0);
            self.add_parameter_load(p, 0, &mut rhs[..n_v]);
            self.add_constraint_load(p, 0, Level::Acceleration, s0, &mut rhs[n_v..]);
            rhs.iter_mut().for_each(|r| *r = -*r);
            self.solve(&mut rhs, false, 0)?;
            tangents.push(Tangent {
                eps: vec![0.0; n_v],
                v: vec![0.0; n_v],
                vdot: rhs[..n_v].to_vec(),
                a: rhs[..n_v].to_vec(),
                lam: rhs[n_v..].iter().map(|x| x * s0).collect(),
            });
        }
        let mut gradient = vec![vec![0.0; responses.len()]; parameters.len()];
        let (mut g_eps, mut g_lam, mut g_v) = (vec![0.0; n_v], vec![0.0; m], vec![0.0; n_v]);
        for n in 0..self.states.len() {
            crate::interrupt::poll()?;
            if n > 0 {
                if self.restarted[n] {
                    self.restart_tangents(n - 1, parameters, &mut tangents)?;
                }
                self.factorize(n)?;
                for (p, z) in parameters.iter().zip(tangents.iter_mut()) {
                    self.direct_step(p, n, z, &mut rhs)?;
                }
            }
            for (k, r) in responses.iter().enumerate() {
                self.seed(r, n, &mut g_eps, &mut g_lam);
                let fast = self.velocity_seed(r, n, &mut g_v);
                for (g, z) in gradient.iter_mut().zip(&tangents) {
                    g[k] += dot(&g_eps, &z.eps) + dot(&g_lam, &z.lam);
                    if fast {
                        g[k] += dot(&g_v, &z.v);
                    }
                }
            }
        }
        Ok(gradient)
    }

    /// The restart at a drive's kink on state `n` differentiated: its jump
    /// `[M, sBᵀ; sB, 0][Δv̇; Δν] = [0; −s Δb]` moves with the state and the parameters as
    ///
    /// ```text
    /// M Δv̇' + s Bᵀ Δν' = −(∂M/∂p) Δv̇ − ∂(Bᵀ s Δν)/∂q ε
    /// s B Δv̇'          = −s (∂(B Δv̇)/∂q ε + Δb')
    /// ```
    ///
    /// (`M` is constant on the group: bodies' and beams' inertia in their own axes), and
    /// `v̇' += Δv̇'`, `a' += Δv̇'` as the run's `v̇` and `a` moved. `Δb'` is left out: a
    /// drive's jump in `b` is `−cos(φ − ψ) Δψ̈` (a constant `−Δψ̈` for a slide), whose
    /// derivative `sin(φ − ψ) Δψ̈ φ'` vanishes with the constraint, to Newton's tolerance.
    fn restart_tangents(
        &mut self,
        n: usize,
        parameters: &[Parameter],
        tangents: &mut [Tangent],
    ) -> Result<(), SolveError> {
        let Some(restart) = self.restart(n)? else {
            return Ok(());
        };
        let n_v = self.n_v;
        let mut rhs = vec![0.0; n_v + self.n_rows];
        for (p, z) in parameters.iter().zip(tangents.iter_mut()) {
            rhs.fill(0.0);
            self.add_mass_rate(p, &restart.dv, &mut rhs[..n_v]);
            restart.add_state_terms(self.model(), &z.eps, &mut rhs);
            if let Some(load) = self.restart_load(p, &restart, n) {
                let (force, constraint) = rhs.split_at_mut(n_v);
                scatter(&self.model().joints[load.joint], &load.force, force);
                load.constraint.add_to(1.0, constraint);
            }
            rhs.iter_mut().for_each(|r| *r = -*r);
            self.solve(&mut rhs, false, n)?;
            for ((vdot, a), d) in z.vdot.iter_mut().zip(z.a.iter_mut()).zip(&rhs[..n_v]) {
                *vdot += d;
                *a += d;
            }
        }
        Ok(())
    }

    /// [`Sweep::restart_tangents`] transposed, for the adjoint sweep, on every column: with
    /// `d̄ = v̇̄ + ā` (the restart adds `Δv̇'` to both) and `y` from
    /// `[M, sBᵀ; sB, 0]ᵀ y = [d̄; 0]`, `ε̄ −= (∂(Bᵀ s Δν)/∂q)ᵀ y_v + s (∂(B Δv̇)/∂q)ᵀ y_ν`
    /// and each parameter's gradient `−= y_v · (∂M/∂p) Δv̇`.
    fn restart_adjoint(
        &mut self,
        n: usize,
        parameters: &[Parameter],
        columns: &mut [Column],
    ) -> Result<(), SolveError> {
        let Some(restart) = self.restart(n)? else {
            return Ok(());
        };
        let n_v = self.n_v;
        let mut y = vec![0.0; n_v + self.n_rows];
        let mut rate = vec![0.0; n_v];
        for c in columns {
            y.fill(0.0);
            for ((y, v), a) in y.iter_mut().zip(&c.vdot).zip(&c.a) {
                *y = v + a;
            }
            self.solve(&mut y, true, n)?;
            restart.subtract_state_terms_transposed(self.model(), &y, &mut c.eps);
            for (g, p) in c.gradient.iter_mut().zip(parameters) {
                rate.fill(0.0);
                self.add_mass_rate(p, &restart.dv, &mut rate);
                *g -= dot(&rate, &y[..n_v]);
                if let Some(load) = self.restart_load(p, &restart, n) {
                    let joint = &self.model().joints[load.joint];
                    *g -=
                        load.force.dot(&gather(joint, &y[..n_v])) + load.constraint.dot(&y[n_v..]);
                }
            }
        }
        Ok(())
    }

    /// The restart's jump at state `n`, its matrix factored, or `None` where no drive's
    /// law has a kink on it.
    fn restart(&mut self, n: usize) -> Result<Option<Restart>, SolveError> {
        let model = self.model();
        let (n_v, m) = (self.n_v, self.n_rows);
        let s = &self.states[n];
        let Some(kink) = kinks(model).at(s.t, s.h) else {
            return Ok(None);
        };
        let mut jump = [vec![0.0; m], vec![0.0; m]];
        let mut forward = vec![0.0; n_v + m];
        if !kink_jump(
            &mut self.asm,
            &mut self.lu,
            s,
            kink,
            &mut jump,
            &mut forward,
        )? {
            return Ok(None);
        }
        let scale = self.asm.mean_mass();
        let jumped = jump[0]
            .iter()
            .zip(&jump[1])
            .map(|(b, a)| jumps(*b, *a))
            .collect();
        let (dv, dnu) = forward.split_at(n_v);
        let mut row = 0;
        let joints = (model.joints.iter())
            .map(|j| {
                let rows = row..row + j.n_rows();
                row = rows.end;
                let mu: Vec<f64> = dnu[rows.clone()].iter().map(|x| scale * x).collect();
                let mut w = Local::zeros();
                for (side, node) in j.local_nodes() {
                    w.fixed_rows_mut::<6>(6 * side)
                        .copy_from_slice(&six(dv, node));
                }
                // `∂(B Δv̇)/∂q` row by row: `(H_k ε) · w = (H_kᵀ w) · ε`.
                let unit = |k: usize| {
                    let mut e = vec![0.0; rows.len()];
                    e[k] = 1.0;
                    j.stiffness(&s.q, s.t, &e).transpose() * w
                };
                RestartJoint {
                    force: j.stiffness(&s.q, s.t, &mu),
                    rows: (0..rows.len()).map(unit).collect(),
                    first: rows.start,
                }
            })
            .collect();
        Ok(Some(Restart {
            kink,
            dv: dv.to_vec(),
            mu: dnu.iter().map(|x| scale * x).collect(),
            jumped,
            scale,
            joints,
        }))
    }

    /// A drive parameter's or a joint's place's share in the right-hand side of the restart
    /// on state `n`: `Δλ ∂B/∂p` on the force rows, `s (∂B/∂p Δv̇ + ∂Δb/∂p)` on its rows
    /// (`Δb'` where a driven row's `b` jumped; a place's `b'` does not jump: the drives'
    /// rows that move with it, a slide's, have constant coefficients); `None` for the other
    /// parameters.
    fn restart_load(&self, p: &Parameter, restart: &Restart, n: usize) -> Option<RestartLoad> {
        if let Parameter::JointPosition { joint, axis } = *p {
            let s = &self.states[n];
            let j = &self.model().joints[joint];
            let rate = j.position_rate(&s.q, Some(&s.qdot), s.t, &Vector3::ith(axis, 1.0));
            let mu = self.joint_multipliers(joint, &restart.mu);
            return Some(RestartLoad {
                joint,
                force: rate.gradient.tr_mul(&mu),
                constraint: self.joint_load(
                    joint,
                    rate.gradient * gather(j, &restart.dv) * restart.scale,
                ),
            });
        }
        let Parameter::Drive { joint, law } = *p else {
            return None;
        };
        let s = &self.states[n];
        let j = &self.model().joints[joint];
        let term = |t: f64| {
            j.drive_rate(&s.q, Some(&s.qdot), t, law)
                .map(|(_, r)| r.term)
        };
        let (local_row, rate) = j.drive_rate(&s.q, Some(&s.qdot), s.t, law)?;
        let row = self.row_of(joint, local_row);
        let mut constraint = rate.gradient.dot(&gather(j, &restart.dv));
        if restart.jumped[row] {
            constraint += term(restart.kink.next_up())? - term(restart.kink.next_down())?;
        }
        Some(RestartLoad {
            joint,
            force: rate.gradient * restart.mu[row],
            constraint: RowsLoad::one(row, restart.scale * constraint),
        })
    }

    /// `(∂M/∂p) w` of a parameter on an inertia (a body's mass or inertia, a beam's or a
    /// bar's mass factor) into `out`; nothing for the others.
    fn add_mass_rate(&self, p: &Parameter, w: &[f64], out: &mut [f64]) {
        let model = self.model();
        let element = |e: &dyn Element, out: &mut [f64]| {
            add_element_local(e, &(e.mass_matrix() * e.local(w)), out);
        };
        match *p {
            Parameter::Mass { body } => {
                let node = model.bodies[body].node;
                for i in 0..3 {
                    out[NV * node + i] += w[NV * node + i];
                }
            }
            Parameter::Inertia { body, i, j } => {
                let node = model.bodies[body].node;
                let r = NV * node + 3;
                out[r + i] += w[r + j];
                if i != j {
                    out[r + j] += w[r + i];
                }
            }
            Parameter::BeamMass { beam } => element(&model.beams[beam], out),
            Parameter::TrussMass { truss } => element(&model.trusses[truss], out),
            Parameter::BeamSize { beam, dimension } => {
                let (beam, rate) = self.size_rate(beam, dimension);
                add_element_local(beam, &(beam.mass_matrix_of(&rate) * beam.local(w)), out);
            }
            _ => {}
        }
    }

    /// Carries the sensitivities `z` of state `n − 1` to state `n` (module docs).
    fn direct_step(
        &mut self,
        p: &Parameter,
        n: usize,
        z: &mut Tangent,
        rhs: &mut [f64],
    ) -> Result<(), SolveError> {
        let (n_v, m) = (self.n_v, self.n_rows);
        let AlphaParameters {
            alpha_m, alpha_f, ..
        } = self.params;
        let h = self.states[n].h;
        let (bp, gp) = (self.params.beta_prime(h), self.params.gamma_prime(h));
        let w = (1.0 - alpha_f) / (1.0 - alpha_m);
        if let Some(ratio) = step_ratio(self.states[n - 1].h, h) {
            z.a.iter_mut()
                .zip(&z.vdot)
                .for_each(|(a, acc)| *a = acc + ratio * (*a - acc));
        }
        let increment = increments(self.model(), &self.states[n - 1].q, &self.states[n].q);
        let mut a_next = vec![0.0; n_v];
        let mut delta_pred = vec![0.0; n_v];
        let mut v_pred = vec![0.0; n_v];
        for i in 0..n_v {
            let p = self.params.predict(h, z.v[i], z.vdot[i], z.a[i], 0.0);
            (delta_pred[i], v_pred[i], a_next[i]) = (p.increment, p.qdot, p.a_next);
        }
        let mut eps_pred = transport(&increment, &z.eps, false);
        let t_delta = apply_tangent(&increment, &delta_pred, false);
        eps_pred.iter_mut().zip(&t_delta).for_each(|(e, t)| *e += t);
        // The right-hand side −[∂r/∂p + K ε + C v'; s (∂Φ/∂p + B ε)], on the factors of
        // the step's matrix at its converged state.
        let scale = self.scale(n);
        let s = &self.states[n];
        rhs.fill(0.0);
        let (force, constraint) = rhs.split_at_mut(n_v);
        self.asm
            .linear_terms(&s.qdot, &eps_pred, &v_pred, force, constraint);
        self.add_parameter_load(p, n, force);
        self.add_constraint_load(p, n, Level::Position, 1.0, constraint);
        force.iter_mut().for_each(|f| *f = -*f);
        constraint.iter_mut().for_each(|c| *c *= -scale);
        self.solve(rhs, false, n)?;
        let (delta, nu) = rhs.split_at(n_v);
        let t_step = apply_tangent(&increment, delta, false);
        for i in 0..n_v {
            z.eps[i] = eps_pred[i] + t_step[i];
            z.v[i] = v_pred[i] + gp * delta[i];
            z.vdot[i] = bp * delta[i];
            z.a[i] = a_next[i] + w * bp * delta[i];
        }
        z.lam.iter_mut().zip(nu).for_each(|(l, x)| *l = scale * x);
        debug_assert_eq!(z.lam.len(), m);
        Ok(())
    }

    /// The discrete adjoint (module docs; each operation of [`Sweep::direct_step`] transposed,
    /// in reverse, [`backward::sweep`]): every response's gradient to every parameter,
    /// `[response][parameter]`, one column of adjoint variables per response ([`Column`]),
    /// each step's matrix factored once for all of them.
    /// With `estimate`, each response's time error too ([`time_errors`]).
    fn adjoint(
        &mut self,
        responses: &[Response],
        parameters: &[Parameter],
        estimate: bool,
        weights: Option<&mut Weights<'_>>,
    ) -> Result<Swept, Error> {
        let params = self.params;
        let (n_v, m, steps) = (self.n_v, self.n_rows, self.states.len() - 1);
        let mut reverse = Reverse {
            columns: (responses.iter())
                .map(|_| Column::new(n_v, m, parameters.len()))
                .collect(),
            sweep: self,
            responses,
            parameters,
            rhs: vec![0.0; n_v + m],
            seed: (vec![0.0; n_v], vec![0.0; m], vec![0.0; n_v]),
            local: estimate.then(|| LocalErrors::new(&params, n_v, responses.len())),
            weights,
        };
        backward::sweep(&mut reverse, steps)?;
        let errors = reverse.local.take().map(|mut local| {
            let states = reverse.sweep.states;
            local.add_quadrature(states[1].h, states[steps].h);
            local.errors
        });
        Ok((
            reverse.columns.into_iter().map(|c| c.gradient).collect(),
            errors,
        ))
    }

    /// `G` of a time sum `r` at state `n`, as the sum weighs it (per unit time for a mean);
    /// `None` for a final value, an aggregated mean (its terms read the run's peak) and any
    /// equilibrium's.
    fn integrand(&self, r: &Response, n: usize) -> Option<f64> {
        if self.equilibrium {
            return None;
        }
        let s = &self.states[n];
        match *r {
            Response::Effort { joint, row } => Some(s.lam[self.row_of(joint, row)].powi(2)),
            Response::StrainEnergy | Response::Compliance => {
                let energy: f64 = self.model().elements().map(|e| e.strain_energy(&s.q)).sum();
                Some(energy / self.duration())
            }
            Response::KineticEnergy => Some(self.model().kinetic_energy(&s.qdot)),
            Response::Deflection { node } => {
                Some(self.deflection(node, n).norm_squared() / self.duration())
            }
            _ => None,
        }
    }

    /// One column's adjoint variables carried back over the step into state `n` (increment
    /// `increment`), its matrix factored: the step's operations transposed, last first.
    ///
    /// With the step's local errors `(l_Δ, l_v)` ([`crate::solver::local_error`]), returns
    /// what they change the column's response by (0 without).
    fn step_transposed(
        &mut self,
        n: usize,
        increment: &[f64],
        parameters: &[Parameter],
        c: &mut Column,
        rhs: &mut [f64],
        local: Option<(&[f64], &[f64])>,
    ) -> Result<f64, SolveError> {
        let n_v = self.n_v;
        let AlphaParameters {
            alpha_m,
            alpha_f,
            beta,
            gamma,
        } = self.params;
        let w = (1.0 - alpha_f) / (1.0 - alpha_m);
        let h = self.states[n].h;
        let (bp, gp) = (self.params.beta_prime(h), self.params.gamma_prime(h));
        let scale = self.scale(n);
        // Step 7 transposed: δ̄ = Tᵀ ε̄ + γ' v̄ + β' v̇̄ + w β' ā, ν̄ = s λ̄.
        let t_eps = apply_tangent(increment, &c.eps, true);
        for i in 0..n_v {
            rhs[i] = t_eps[i] + gp * c.v[i] + bp * c.vdot[i] + w * bp * c.a[i];
        }
        (rhs[n_v..].iter_mut())
            .zip(&c.lam)
            .for_each(|(x, l)| *x = scale * l);
        // The local errors' share through the state after the step: v̄ᵀ l_v less the part
        // of δ̄ beyond Tᵀε̄ on l_Δ, which the equilibrium's solve gives back below.
        let mut error = local.map_or(0.0, |(l_delta, l_v)| {
            (0..n_v)
                .map(|i| {
                    let beyond = gp * c.v[i] + bp * c.vdot[i] + w * bp * c.a[i];
                    c.v[i] * l_v[i] - beyond * l_delta[i]
                })
                .sum()
        });
        self.solve(rhs, true, n)?;
        // Step 5 transposed: the parameters' share and ε̄_pred, v̄_pred.
        for (g, p) in c.gradient.iter_mut().zip(parameters) {
            *g -= self.parameter_dot(p, n, &rhs[..n_v])
                + self.constraint_dot(p, n, Level::Position, scale, &rhs[n_v..]);
        }
        let (y_force, y_constraint) = rhs.split_at_mut(n_v);
        y_force.iter_mut().for_each(|y| *y = -*y);
        y_constraint.iter_mut().for_each(|y| *y *= -scale);
        let s = &self.states[n];
        let mut eps_pred_bar = c.eps.clone();
        let mut v_pred_bar = c.v.clone();
        self.asm.linear_terms_transpose(
            &s.qdot,
            y_force,
            y_constraint,
            &mut eps_pred_bar,
            &mut v_pred_bar,
        );
        if let Some((l_delta, l_v)) = local {
            // −yᵀτ, τ = −(β'M + γ'C) l_Δ + C l_v the step's residual on the exact motion;
            // the force rows hold −y now, and v̄_pred − v̄ is −Cᵀy.
            let mut m_minus_y = vec![0.0; n_v];
            self.model().add_momenta(y_force, 1.0, &mut m_minus_y);
            error -= (0..n_v)
                .map(|i| {
                    let minus_cty = v_pred_bar[i] - c.v[i];
                    bp * m_minus_y[i] * l_delta[i] + minus_cty * (gp * l_delta[i] - l_v[i])
                })
                .sum::<f64>();
        }
        let mut a_next_bar = c.a.clone();
        // Step 4: ε̄ₙ = Adᵀ ε̄_pred, Δ̄_pred = Tᵀ ε̄_pred.
        c.eps = transport(increment, &eps_pred_bar, true);
        let delta_bar = apply_tangent(increment, &eps_pred_bar, true);
        // Steps 3, 2, 1.
        for i in 0..n_v {
            c.v[i] = v_pred_bar[i] + h * delta_bar[i];
            c.a[i] = h * (1.0 - gamma) * v_pred_bar[i] + h * h * (0.5 - beta) * delta_bar[i];
            a_next_bar[i] += h * gamma * v_pred_bar[i] + h * h * beta * delta_bar[i];
            c.vdot[i] = alpha_f / (1.0 - alpha_m) * a_next_bar[i];
            c.a[i] -= alpha_m / (1.0 - alpha_m) * a_next_bar[i];
        }
        if let Some(ratio) = step_ratio(self.states[n - 1].h, h) {
            for (vdot, a) in c.vdot.iter_mut().zip(c.a.iter_mut()) {
                *vdot += (1.0 - ratio) * *a;
                *a *= ratio;
            }
        }
        Ok(error)
    }
}

/// The spatial run transposed ([`backward::sweep`]) on the stored states.
struct Reverse<'s, 'm, 'w> {
    sweep: &'s mut Sweep<'m>,
    responses: &'s [Response],
    parameters: &'s [Parameter],
    columns: Vec<Column>,
    rhs: Vec<f64>,
    /// A response's partial derivatives at a state: to `ε`, `λ` and `v`.
    seed: (Vec<f64>, Vec<f64>, Vec<f64>),
    /// The steps' local errors and the responses' time errors, if asked.
    local: Option<LocalErrors>,
    /// Where each state's adjoint variables of the force rows go, if asked.
    weights: Option<&'s mut Weights<'w>>,
}

/// Called with `(n, k, μ)`: response `k`'s adjoint variables `μ` of the force rows at state
/// `n` ([`dual_weights`]).
pub(crate) type Weights<'a> = dyn FnMut(usize, usize, &[f64]) + 'a;

impl Reverse<'_, '_, '_> {
    /// The local errors of the step from state `n` ([`crate::solver::local_error`]) from
    /// the stored accelerations: `v̇ₙ₊₁`, and `v̇ₙ` with the jump of a restart on it; on the
    /// rotations the exact increment's `(h³/12) ω × ω̇` besides.
    fn local_errors(&mut self, n: usize) -> Result<(), Error> {
        let states = self.sweep.states;
        let jump = match self.sweep.restarted[n + 1] {
            true => self.sweep.restart(n)?.map(|r| r.dv),
            false => None,
        };
        let Some(local) = self.local.as_mut() else {
            return Ok(());
        };
        let (s, s1) = (&states[n], &states[n + 1]);
        local.next.copy_from_slice(&s1.qddot);
        local.now.copy_from_slice(&s.qddot);
        if let Some(dv) = jump {
            local.now.iter_mut().zip(&dv).for_each(|(a, d)| *a += d);
        }
        let after = states.get(n + 2).map(|s| s.h);
        local.of_step(s1.h, after);
        let h3 = s1.h.powi(3);
        for node in 0..s.qdot.len() / NV {
            let mean = |v: &[f64], w: &[f64]| 0.5 * (rotation_of(v, node) + rotation_of(w, node));
            let (omega, omega_dot) = (mean(&s.qdot, &s1.qdot), mean(&local.now, &local.next));
            let magnus = omega.cross(&omega_dot) * (h3 / 12.0);
            for k in 0..3 {
                local.lq[NV * node + 3 + k] -= magnus[k];
            }
        }
        Ok(())
    }
}

impl Transposed for Reverse<'_, '_, '_> {
    fn seed(&mut self, n: usize) -> Result<(), Error> {
        let last = self.sweep.states.len() - 1;
        if let Some(local) = self.local.as_mut() {
            if let Some(end) = LocalErrors::end_of(n, last) {
                for (g, r) in local.ends.iter_mut().zip(self.responses) {
                    g[end] = self.sweep.integrand(r, n);
                }
            }
        }
        let (g_eps, g_lam, g_v) = &mut self.seed;
        for (c, r) in self.columns.iter_mut().zip(self.responses) {
            self.sweep.seed(r, n, g_eps, g_lam);
            c.eps.iter_mut().zip(&*g_eps).for_each(|(e, g)| *e += g);
            c.lam.copy_from_slice(g_lam);
            if self.sweep.velocity_seed(r, n, g_v) {
                c.v.iter_mut().zip(&*g_v).for_each(|(v, g)| *v += g);
            }
        }
        Ok(())
    }

    fn step(&mut self, n: usize) -> Result<(), Error> {
        let states = self.sweep.states;
        let increment = increments(self.sweep.model(), &states[n].q, &states[n + 1].q);
        if self.local.is_some() {
            self.local_errors(n)?;
        }
        self.sweep.factorize(n + 1)?;
        for (k, c) in self.columns.iter_mut().enumerate() {
            let local = self.local.as_ref().map(|l| (&l.lq[..], &l.lv[..]));
            let error = (self.sweep).step_transposed(
                n + 1,
                &increment,
                self.parameters,
                c,
                &mut self.rhs,
                local,
            )?;
            if let Some(l) = self.local.as_mut() {
                l.errors[k] += error;
            }
            if let Some(weights) = self.weights.as_mut() {
                // The force rows hold −y after the transposed step; the dual weight is y.
                let mu: Vec<f64> = self.rhs[..self.sweep.n_v].iter().map(|y| -y).collect();
                weights(n + 1, k, &mu);
            }
        }
        Ok(())
    }

    fn restart(&mut self, n: usize) -> Result<(), Error> {
        if self.sweep.restarted[n + 1] {
            (self.sweep).restart_adjoint(n, self.parameters, &mut self.columns)?;
        }
        Ok(())
    }

    /// The start: `ε₀` and `v₀` do not depend on `p`; `v̇₀' = a₀'` and `λ₀'` from its
    /// solve.
    fn initial(&mut self) -> Result<(), Error> {
        let (sweep, rhs) = (&mut *self.sweep, &mut self.rhs);
        let n_v = sweep.n_v;
        let s0 = sweep.scale(0);
        sweep.factorize(0)?;
        for (k, c) in self.columns.iter_mut().enumerate() {
            for (r, (vdot, a)) in rhs.iter_mut().zip(c.vdot.iter().zip(&c.a)) {
                *r = vdot + a;
            }
            (rhs[n_v..].iter_mut())
                .zip(&c.lam)
                .for_each(|(x, l)| *x = s0 * l);
            sweep.solve(rhs, true, 0)?;
            for (g, p) in c.gradient.iter_mut().zip(self.parameters) {
                *g -= sweep.parameter_dot(p, 0, &rhs[..n_v])
                    + sweep.constraint_dot(p, 0, Level::Acceleration, s0, &rhs[n_v..]);
            }
            if let Some(weights) = self.weights.as_mut() {
                weights(0, k, &rhs[..n_v]);
            }
        }
        Ok(())
    }
}

/// What the adjoint sweep gives: each response's gradient (`[response][parameter]`) and,
/// where asked, each one's time error.
type Swept = (Vec<Vec<f64>>, Option<Vec<f64>>);

/// One response's adjoint variables in the backward sweep — `ε̄, λ̄, v̄, v̇̄, ā` of the
/// state reached — and its gradient so far.
struct Column {
    eps: Vec<f64>,
    lam: Vec<f64>,
    v: Vec<f64>,
    vdot: Vec<f64>,
    a: Vec<f64>,
    gradient: Vec<f64>,
}

impl Column {
    fn new(n_v: usize, n_rows: usize, n_parameters: usize) -> Self {
        Self {
            eps: vec![0.0; n_v],
            lam: vec![0.0; n_rows],
            v: vec![0.0; n_v],
            vdot: vec![0.0; n_v],
            a: vec![0.0; n_v],
            gradient: vec![0.0; n_parameters],
        }
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// The step's increment `Δ` from `q₀` to `q₁`, node by node: `(x₁ − x₀, log(R₀ᵀR₁))`.
fn increments(model: &SpatialModel, q0: &[f64], q1: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; model.n_v()];
    for node in 0..model.nodes.len() {
        let (a, b) = (Frame::read(q0, node), Frame::read(q1, node));
        let theta = log(&(a.r.inverse() * b.r));
        out[NV * node..NV * node + 3].copy_from_slice((b.x - a.x).as_slice());
        out[NV * node + 3..NV * node + 6].copy_from_slice(theta.as_slice());
    }
    out
}

/// The rotation part of node `node` of a six-per-node vector.
fn rotation_of(v: &[f64], node: usize) -> Vector3<f64> {
    Vector3::new(v[NV * node + 3], v[NV * node + 4], v[NV * node + 5])
}

/// `Ad(exp(−Δ)) x` node by node, `diag(I, exp(Δθ)ᵀ)` (or its transpose).
fn transport(increment: &[f64], x: &[f64], transpose: bool) -> Vec<f64> {
    let mut out = x.to_vec();
    for node in 0..x.len() / NV {
        let r = exp(&rotation_of(increment, node)).to_rotation_matrix();
        let rot = if transpose {
            r * rotation_of(x, node)
        } else {
            r.inverse() * rotation_of(x, node)
        };
        out[NV * node + 3..NV * node + 6].copy_from_slice(rot.as_slice());
    }
    out
}

/// `T(Δ) x` node by node, `diag(I, T(Δθ))` (or its transpose).
fn apply_tangent(increment: &[f64], x: &[f64], transpose: bool) -> Vec<f64> {
    let mut out = x.to_vec();
    for node in 0..x.len() / NV {
        let t = tangent(&rotation_of(increment, node));
        let rot = if transpose { t.transpose() } else { t } * rotation_of(x, node);
        out[NV * node + 3..NV * node + 6].copy_from_slice(rot.as_slice());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::UnitQuaternion;

    #[test]
    fn responses_and_parameters_the_mechanism_lacks_are_named() {
        let mut m = SpatialModel::new(Vector3::zeros()).unwrap();
        let frame = Frame::new(Vector3::zeros(), UnitQuaternion::identity());
        m.add_body("b", frame, 1.0, Matrix3::identity()).unwrap();
        let ok = [Response::Position { body: 0, axis: 1 }];
        let bad_body = [Response::Position { body: 1, axis: 0 }];
        let err = check(&m, &bad_body, &[]).unwrap_err();
        assert!(
            err.name == "responses[0]" && err.message.contains("no body 1"),
            "{err}"
        );
        let err = check(&m, &[Response::Position { body: 0, axis: 3 }], &[]).unwrap_err();
        assert!(err.message.contains("axis 3"), "{err}");
        let err = check(&m, &[Response::Effort { joint: 0, row: 0 }], &[]).unwrap_err();
        assert!(err.message.contains("joint 0 has no row 0"), "{err}");
        let err = check(
            &m,
            &ok,
            &[Parameter::Inertia {
                body: 0,
                i: 0,
                j: 5,
            }],
        )
        .unwrap_err();
        assert!(
            err.name == "parameters[0]" && err.message.contains("(0, 5)"),
            "{err}"
        );
        check(&m, &ok, &[Parameter::Mass { body: 0 }]).unwrap();
    }
}
