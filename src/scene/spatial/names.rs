//! The names a user gives a spatial scene's responses and parameters, and what they are in
//! the engine ([`crate::spatial::sensitivity`]).
//!
//! Responses — the registry's kinds a spatial scene offers ([`crate::response`]'s table, read
//! for the errors' lists), each meaning what it means on a planar scene: `x:NAME`, `y:NAME`,
//! `z:NAME` (a body's centre of mass or a node's origin at the end of the run, m),
//! `strain_energy` (its mean over the run `(1/t_f) ∫U dt`, J; `U` in statics),
//! `kinetic_energy` (`∫T dt` over the run, J s; a motion's only), `compliance` (over a motion
//! the mean strain energy, J, paper Eq. 39; at an equilibrium `Fᵀu`, the dead forces' and
//! gravity's work, J),
//! `torque_squared:JOINT` (`∫λ² dt` of a driven joint's drive row: the squared torque or
//! force a motor must give, integrated, as a planar scene's), `reaction:JOINT[:OPTIONS]` (the force the joint transmits,
//! N, `|F|` over its rows that hold its points together, not a locked rotation's moment:
//! a p-mean (`p=P`, 8 by default) or KS mean (`ks=RHO,scale=S`) over the run, its peak
//! reported; at an equilibrium `|F|`), `torque:JOINT[:OPTIONS]` (a drive's torque, N m, or
//! force, N, condensed likewise), `tip_deflection` and `tip_deflection:NAME` (the mean squared
//! deflection of the scene's `tip`, or of a body's centre or a node, from its rigid
//! trajectory, m², paper Eq. 40), `stress[:NAME][:OPTIONS]` (the relaxed stresses `x^q σ` of
//! every beam's section points and every bar, or of beam or ground structure NAME's, von
//! Mises, condensed over the run and the structure; `buckling[:NAME][:OPTIONS]` the same of
//! the buckling ratios `x^q b`, each element's compression over its bar's Euler load
//! pin-ended (dimensionless, [`crate::spatial::element::Element::buckling`]),
//! Pa, [`crate::spatial::stress`]; OPTIONS as a planar scene's: `p=P` a p-mean, 8 by
//! default, or `ks=RHO,scale=S` a KS mean; `q=Q` the relaxation, 0.5 by default, 0 the solid
//! material's stress).
//!
//! Parameters: `mass:BODY` (kg), `Ixx:BODY` … `Iyz:BODY` (an entry of its inertia tensor
//! in its axes with its symmetric one, kg m²), `k:SPRING`, `c:SPRING` (a torsion spring's in
//! N m/rad, N m s/rad), `torque:MOTOR`,
//! `E:BEAM` and `rho:BEAM` (its material's Young's modulus at fixed Poisson's ratio and
//! density, Pa and kg/m³, over every element of the beam), `diameter:BEAM`, `outer:BEAM`,
//! `inner:BEAM`, `width:BEAM`, `height:BEAM` (a dimension of its section's shape, m: its
//! stiffnesses, inertias and stress points move with it), `end:JOINT`,
//! `acceleration:JOINT`, `speed:JOINT` (of a joint's trapezoidal drive: rad, rad/s², rad/s
//! on a revolute joint, m, m/s², m/s on a prismatic one; a deflection's rigid trajectory
//! moves with them too), `position_x:JOINT`, `position_y:JOINT`, `position_z:JOINT` (the
//! joint's place along an axis of space in the initial configuration, m: both its anchors'
//! points move with it in their bodies, the initial configuration unchanged; not with a
//! deflection, whose rigid trajectory would move too).

use super::SpatialScene;
use crate::error::SettingsError;
use crate::joint::motion::{LawParameter, Motion};
use crate::response::aggregation::Aggregation;
use crate::response::Response as RegisteredResponse;
use crate::response::{aggregation_and_relaxation, component_and_options};
use crate::spatial::force::ForceKind;
use crate::spatial::section::{Dimension, Shape};
use crate::spatial::sensitivity::{Elements, Parameter, Response};
use crate::spatial::stress::Criterion;

type Result<T> = std::result::Result<T, SettingsError>;

/// A parameter by name: engine parameters with the factors that turn their derivatives
/// into the named one's (`∂f/∂E = Σ (∂f/∂s_e) / E` over a beam's elements).
pub type Named = Vec<(Parameter, f64)>;

/// The inertia entries by name.
const INERTIA: [(&str, usize, usize); 6] = [
    ("Ixx", 0, 0),
    ("Iyy", 1, 1),
    ("Izz", 2, 2),
    ("Ixy", 0, 1),
    ("Ixz", 0, 2),
    ("Iyz", 1, 2),
];

impl SpatialScene {
    /// `KIND:BEAM` for a dimension of a beam's section (module docs): each of a frame
    /// beam's elements' [`Parameter::BeamSize`]; a truss bar's stiffness and mass factors
    /// by `A'/A`, all its section's size does to a pin-jointed bar.
    fn size(&self, kind: &str, what: &str) -> Result<Named> {
        let bad = |m: String| {
            Err(SettingsError::new(
                "parameters",
                format!("'{kind}:{what}': {m}"),
            ))
        };
        let Some(beam) = self.beams.get(what) else {
            return bad(format!("'{what}' is no beam of the scene"));
        };
        let Some(&(_, dimension)) = Dimension::NAMES.iter().find(|(n, _)| *n == kind) else {
            return bad(format!("'{kind}' is not a section dimension"));
        };
        let Some((geometry, rate)) = beam.section.geometry_rate(dimension) else {
            let has = match beam.section.shape {
                Some(Shape::SolidCircle { .. }) => "a circle's diameter",
                Some(Shape::HollowCircle { .. }) => "a tube's outer and inner diameters",
                Some(Shape::Rectangle { .. }) => "a rectangle's width and height",
                None => "no shape",
            };
            return bad(format!("'{what}'s section has {has}, no {kind}"));
        };
        let area = rate.area / geometry.area;
        // The smaller second moment's rate (the first's where they are equal), for the
        // Euler load of a truss bar's buckling ratio.
        let moment = match geometry.i2 <= geometry.i3 {
            true => rate.i2 / geometry.i2,
            false => rate.i3 / geometry.i3,
        };
        Ok(beam
            .elements
            .iter()
            .flat_map(|&e| match beam.truss {
                true => vec![
                    (Parameter::TrussStiffness { truss: e }, area),
                    (Parameter::TrussMass { truss: e }, area),
                    (Parameter::TrussBuckling { truss: e }, area - moment),
                ],
                false => vec![(Parameter::BeamSize { beam: e, dimension }, 1.0)],
            })
            .collect())
    }

    /// The parameters called `names` followed by the densities' at `x` (full density where
    /// `None`): each as named (engine parameters with their factors), and the engine's
    /// parameters in the same order, flattened.
    ///
    /// # Errors
    /// A [`SettingsError`] at `parameters` for a name the scene does not have.
    pub fn named_and_densities(
        &self,
        names: &[String],
        x: Option<&[f64]>,
    ) -> Result<(Vec<Named>, Vec<Parameter>)> {
        let mut named = (names.iter())
            .map(|p| self.parameter(p))
            .collect::<Result<Vec<_>>>()?;
        let full = vec![1.0; self.n_variables()];
        named.extend(self.densities(x.unwrap_or(&full)));
        let engine = named.iter().flatten().map(|(p, _)| *p).collect();
        Ok((named, engine))
    }

    /// `reaction:JOINT[:OPTIONS]` or `torque:JOINT[:OPTIONS]` from their `kind` and what
    /// follows it (module docs).
    fn joint_mean(&self, kind: &str, rest: &str) -> std::result::Result<Response, String> {
        let (name, options) = component_and_options(Some(rest))?;
        let name = name.ok_or_else(|| format!("name the joint: {kind}:JOINT"))?;
        let Some(joint) = self.model.joints.iter().position(|j| j.name == name) else {
            return Err(format!("'{name}' is no joint of the scene"));
        };
        let aggregation = Aggregation::from_options(&options)?;
        let this = &self.model.joints[joint];
        if kind == "torque" {
            if !this.is_driven() {
                return Err(format!(
                    "joint '{name}' is not driven: only a drive has a torque"
                ));
            }
            return Ok(Response::Torque { joint, aggregation });
        }
        if this.force_rows().next().is_none() {
            return Err(format!(
                "joint '{name}' is {}: it holds no point, so it transmits no force",
                this.kind.name()
            ));
        }
        Ok(Response::Reaction { joint, aggregation })
    }

    /// `stress[:NAME][:OPTIONS]` or `buckling[:NAME][:OPTIONS]` from what follows their
    /// kind's name (module docs).
    fn stress(
        &self,
        criterion: Criterion,
        rest: Option<&str>,
    ) -> std::result::Result<Response, String> {
        let (component, options) = component_and_options(rest)?;
        let within = component.map(|c| self.elements_of(c)).transpose()?;
        let (aggregation, relaxation) = aggregation_and_relaxation(&options)?;
        Ok(Response::Stress {
            criterion,
            aggregation,
            relaxation,
            within,
        })
    }

    /// The elements of the beam `name`, or of the ground structure `name` (its beams
    /// `name/…`): consecutive beams and truss bars of the model.
    fn elements_of(&self, name: &str) -> std::result::Result<Elements, String> {
        let prefix = format!("{name}/");
        let mine: Vec<_> = (self.beams.iter())
            .filter(|(beam, _)| *beam == name || beam.starts_with(&prefix))
            .map(|(_, b)| b)
            .collect();
        if mine.is_empty() {
            return Err(format!(
                "'{name}' is no beam or ground structure of the scene (write stress:NAME:OPTIONS)"
            ));
        }
        let range = |truss: bool| -> std::result::Result<[usize; 2], String> {
            let mut all: Vec<usize> = (mine.iter())
                .filter(|b| b.truss == truss)
                .flat_map(|b| b.elements.iter().copied())
                .collect();
            all.sort_unstable();
            match (all.first(), all.last()) {
                (Some(&a), Some(&b)) if b - a + 1 == all.len() => Ok([a, b + 1]),
                (None, None) => Ok([0, 0]),
                _ => Err(format!(
                    "the elements of '{name}' are not consecutive in the model"
                )),
            }
        };
        Ok(Elements {
            beams: range(false)?,
            trusses: range(true)?,
        })
    }

    /// The response called `name` (module docs).
    ///
    /// # Errors
    /// A [`SettingsError`] at `responses` naming what is not in the scene.
    pub fn response(&self, name: &str) -> Result<Response> {
        let bad = |m: String| Err(SettingsError::new("responses", format!("'{name}': {m}")));
        let m = &self.model;
        let node_of = |what: &str| {
            let body = m.bodies.iter().find(|b| b.name == what).map(|b| b.node);
            body.or_else(|| m.nodes.iter().position(|n| n.name == what))
        };
        for (kind, criterion) in [
            ("stress", Criterion::VonMises),
            ("buckling", Criterion::Buckling),
        ] {
            if let Some(rest) = name.strip_prefix(kind) {
                if rest.is_empty() || rest.starts_with(':') {
                    return self.stress(criterion, rest.strip_prefix(':')).or_else(&bad);
                }
            }
        }
        match name {
            "strain_energy" => return Ok(Response::StrainEnergy),
            "kinetic_energy" => return Ok(Response::KineticEnergy),
            "compliance" => return Ok(Response::Compliance),
            "tip_deflection" => {
                let Some(tip) = &self.tip else {
                    return bad("the scene has no `tip`; write tip_deflection:NAME".into());
                };
                return match node_of(tip) {
                    Some(node) => Ok(Response::Deflection { node }),
                    None => bad(format!("the tip '{tip}' is no body or node of the scene")),
                };
            }
            _ => {}
        }
        let Some((kind, what)) = name.split_once(':') else {
            let written: Vec<&str> = RegisteredResponse::spatial_kinds()
                .map(|(_, s)| s)
                .collect();
            return bad(format!("responses are {}", written.join(", ")));
        };
        match kind {
            "tip_deflection" => match node_of(what) {
                Some(node) => Ok(Response::Deflection { node }),
                None => bad(format!("'{what}' is no body or node of the scene")),
            },
            "x" | "y" | "z" => {
                let axis = usize::from(kind == "y") + 2 * usize::from(kind == "z");
                if let Some(body) = m.bodies.iter().position(|b| b.name == what) {
                    return Ok(Response::Position { body, axis });
                }
                match m.nodes.iter().position(|n| n.name == what) {
                    Some(node) => Ok(Response::NodePosition { node, axis }),
                    None => bad(format!("'{what}' is no body or node of the scene")),
                }
            }
            "torque_squared" => {
                let Some(joint) = m.joints.iter().position(|j| j.name == what) else {
                    return bad(format!("'{what}' is no joint of the scene"));
                };
                if !m.joints[joint].is_driven() {
                    return bad(format!(
                        "joint '{what}' is not driven: only a drive's row has a torque"
                    ));
                }
                let row = m.joints[joint].n_rows() - 1;
                Ok(Response::Effort { joint, row })
            }
            "reaction" | "torque" => self.joint_mean(kind, what).or_else(bad),
            _ => {
                let kinds: Vec<&str> = RegisteredResponse::spatial_kinds()
                    .map(|(k, _)| k)
                    .collect();
                bad(format!(
                    "'{kind}' is not a spatial scene's response kind ({})",
                    kinds.join(", ")
                ))
            }
        }
    }

    /// The parameter called `name` (module docs).
    ///
    /// # Errors
    /// A [`SettingsError`] at `parameters` naming what is not in the scene.
    pub fn parameter(&self, name: &str) -> Result<Named> {
        let bad = |m: String| Err(SettingsError::new("parameters", format!("'{name}': {m}")));
        let Some((kind, what)) = name.split_once(':') else {
            return bad("parameters are KIND:NAME (mass, Ixx … Iyz, k, c, length, rest, torque, E, rho, diameter, outer, inner, width, height, end, acceleration, speed, position_x, position_y, position_z)".into());
        };
        let m = &self.model;
        let body = || m.bodies.iter().position(|b| b.name == what);
        let force = || m.forces.iter().position(|f| f.name == what);
        let one = |p: Parameter| Ok(vec![(p, 1.0)]);
        match kind {
            "mass" => match body() {
                Some(body) => one(Parameter::Mass { body }),
                None => bad(format!("'{what}' is no body or point mass of the scene")),
            },
            "k" | "c" => match force().map(|f| (f, &m.forces[f].kind)) {
                Some((force, ForceKind::Spring { .. } | ForceKind::Torsion { .. })) => {
                    one(match kind {
                        "k" => Parameter::SpringStiffness { force },
                        _ => Parameter::SpringDamping { force },
                    })
                }
                _ => bad(format!("'{what}' is no spring of the scene")),
            },
            "length" | "rest" => match force().map(|f| (f, &m.forces[f].kind)) {
                Some((force, ForceKind::Spring { .. })) if kind == "length" => {
                    one(Parameter::SpringRest { force })
                }
                Some((force, ForceKind::Torsion { .. })) if kind == "rest" => {
                    one(Parameter::SpringRest { force })
                }
                Some((_, ForceKind::Spring { .. })) => bad(format!(
                    "'{what}' is a spring between points: its rest is a length, length:{what}"
                )),
                Some((_, ForceKind::Torsion { .. })) => bad(format!(
                    "'{what}' is a torsion spring: its rest is an angle, rest:{what}"
                )),
                _ => bad(format!("'{what}' is no spring of the scene")),
            },
            "torque" => match force().map(|f| (f, &m.forces[f].kind)) {
                Some((force, ForceKind::Motor { .. })) => one(Parameter::MotorTorque { force }),
                _ => bad(format!("'{what}' is no motor of the scene")),
            },
            "end" | "acceleration" | "speed" => {
                let Some(joint) = m.joints.iter().position(|j| j.name == what) else {
                    return bad(format!("'{what}' is no joint of the scene"));
                };
                let law = match kind {
                    "end" => LawParameter::End,
                    "acceleration" => LawParameter::Acceleration,
                    _ => LawParameter::Speed,
                };
                match m.joints[joint].drive_law() {
                    Some(Motion::Trapezoidal(t)) if t.duration() > 0.0 => {
                        one(Parameter::Drive { joint, law })
                    }
                    Some(Motion::Trapezoidal(_)) => bad(format!(
                        "'{what}' is held (its drive starts where it ends): its law has no rate to a parameter"
                    )),
                    Some(Motion::Table(_)) => bad(format!(
                        "'{what}' has a table: only a trapezoidal drive has an end, acceleration and speed"
                    )),
                    None => bad(format!("'{what}' has no drive")),
                }
            }
            "position_x" | "position_y" | "position_z" => {
                match m.joints.iter().position(|j| j.name == what) {
                    Some(joint) => one(Parameter::JointPosition {
                        joint,
                        axis: usize::from(kind.as_bytes()[9] - b'x'),
                    }),
                    None => bad(format!("'{what}' is no joint of the scene")),
                }
            }
            "E" | "rho" => {
                let Some(beam) = self.beams.get(what) else {
                    return bad(format!("'{what}' is no beam of the scene"));
                };
                let stiffness = kind == "E";
                let value = beam.material[usize::from(!stiffness)];
                let part = |e: usize| match (beam.truss, stiffness) {
                    (false, true) => Parameter::BeamStiffness { beam: e },
                    (false, false) => Parameter::BeamMass { beam: e },
                    (true, true) => Parameter::TrussStiffness { truss: e },
                    (true, false) => Parameter::TrussMass { truss: e },
                };
                Ok(beam
                    .elements
                    .iter()
                    .map(|&e| (part(e), 1.0 / value))
                    .collect())
            }
            _ if Dimension::NAMES.iter().any(|(n, _)| *n == kind) => self.size(kind, what),
            _ => match INERTIA.iter().find(|(n, ..)| *n == kind) {
                Some(&(_, i, j)) => match body() {
                    Some(body) if m.bodies[body].inertia != nalgebra::Matrix3::zeros() => {
                        one(Parameter::Inertia { body, i, j })
                    }
                    _ => bad(format!("'{what}' is no rigid body of the scene")),
                },
                None => bad(format!(
                    "'{kind}' is not a parameter kind (mass, Ixx … Iyz, k, c, torque, E, rho, diameter, outer, inner, width, height, end, acceleration, speed, position_x, position_y, position_z)"
                )),
            },
        }
    }
}
