//! A spatial mechanism: nodes on `ℝ³ × SO(3)`, rigid bodies on them, joints between their
//! points, gravity. Built entry by entry, each checked as it comes: a value that is not
//! physical, a joint whose points do not meet, initial rates the joints forbid — a
//! [`SceneError`] naming it.

use std::collections::{HashMap, HashSet};

use nalgebra::{Matrix3, Vector3};

use crate::body::spatial::Body;
use crate::error::{short, SceneError};
use crate::group::pair::{Measure, Pair};
use crate::group::{six, split, Frame, NQ, NV};
use crate::joint::motion::Motion;
use crate::joint::spatial::{Anchor, Joint, JointKind};
use crate::mechanism::load::{samples, TimeFunction};
use crate::spatial::beam::Beam;
use crate::spatial::element::Element;
use crate::spatial::force::{Force, ForceKind};
use crate::spatial::section::Section;
use crate::spatial::truss::Truss;

/// Relative gap (of the mechanism's size) below which a joint's points meet, and relative
/// rate (of the bodies' speeds) below which initial rates satisfy the joints.
pub const MEET_TOLERANCE: f64 = 1e-9;

/// Relative asymmetry below which an inertia tensor is symmetric.
const SYMMETRY_TOLERANCE: f64 = 1e-12;

/// A spatial node: its initial frame and rates (the velocity of its origin in the inertial
/// frame, its angular velocity in its own frame).
#[derive(Debug, Clone, PartialEq)]
pub struct Node {
    /// The name of what it carries.
    pub name: String,
    /// Initial frame.
    pub frame: Frame,
    /// Initial velocity `(u̇, Ω)`.
    pub velocity: [f64; NV],
}

/// A spatial mechanism (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct SpatialModel {
    /// Nodes.
    pub nodes: Vec<Node>,
    /// Rigid bodies.
    pub bodies: Vec<Body>,
    /// Beams between nodes.
    pub beams: Vec<Beam>,
    /// Truss bars between nodes.
    pub trusses: Vec<Truss>,
    /// Joints, their rows numbered in this order.
    pub joints: Vec<Joint>,
    /// Force elements: springs, motors, loads.
    pub forces: Vec<Force>,
    /// Gravity (m/s²).
    pub gravity: Vector3<f64>,
    /// The names its entries were added under.
    names: Names,
}

/// The names each kind of entry was added under, and each node's index by its name (a
/// body's node's too): duplicates checked and nodes found in constant time, so that a
/// lattice of tens of thousands of bars builds in time proportional to its size.
#[derive(Debug, Clone, Default, PartialEq)]
struct Names {
    nodes: HashMap<String, usize>,
    taken: HashSet<(Entry, String)>,
}

/// A kind of named entry.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
enum Entry {
    Body,
    Beam,
    Truss,
    Joint,
    Force,
}

impl Names {
    fn has(&self, entry: Entry, name: &str) -> bool {
        self.taken.contains(&(entry, name.to_string()))
    }

    fn take(&mut self, entry: Entry, name: &str) {
        self.taken.insert((entry, name.to_string()));
    }
}

fn finite(path: &str, v: &Vector3<f64>) -> Result<(), SceneError> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(SceneError::new(
            path,
            format!("({}, {}, {}) is not finite", v.x, v.y, v.z),
        ))
    }
}

impl SpatialModel {
    /// An empty mechanism under `gravity` (m/s²).
    ///
    /// # Errors
    /// A [`SceneError`] for non-finite gravity.
    pub fn new(gravity: Vector3<f64>) -> Result<Self, SceneError> {
        finite("gravity", &gravity)?;
        Ok(Self {
            nodes: Vec::new(),
            bodies: Vec::new(),
            beams: Vec::new(),
            trusses: Vec::new(),
            joints: Vec::new(),
            forces: Vec::new(),
            gravity,
            names: Names::default(),
        })
    }

    /// Adds a rigid body of `mass` (kg) and `inertia` about its centre of mass in its own
    /// frame (kg m²), its centre of mass and axes at `frame`, at rest; returns its index.
    ///
    /// # Errors
    /// A [`SceneError`] at `bodies.NAME` for a duplicate name, a non-finite position, a
    /// mass that is not positive, or an inertia that no body has (not symmetric, not
    /// positive definite, principal moments that break `I₁ + I₂ ≥ I₃`).
    pub fn add_body(
        &mut self,
        name: &str,
        frame: Frame,
        mass: f64,
        inertia: Matrix3<f64>,
    ) -> Result<usize, SceneError> {
        let path = format!("bodies.{name}");
        if self.names.nodes.contains_key(name) {
            return Err(SceneError::new(
                path,
                "a node or body of this name exists already",
            ));
        }
        check_frame(&path, &frame)?;
        if !(mass.is_finite() && mass > 0.0) {
            return Err(SceneError::new(
                format!("{path}.mass"),
                format!("{} kg: must be positive", short(mass)),
            ));
        }
        check_inertia(&format!("{path}.inertia"), &inertia)?;
        self.push_node(name, frame);
        self.names.take(Entry::Body, name);
        self.bodies.push(Body {
            name: name.to_string(),
            node: self.nodes.len() - 1,
            mass,
            inertia,
        });
        Ok(self.bodies.len() - 1)
    }

    /// Adds a node at `frame`, at rest, for beams' ends (its mass comes from them); returns
    /// its index.
    ///
    /// # Errors
    /// A [`SceneError`] at `nodes.NAME` for a duplicate name (bodies' included), a
    /// non-finite position or a rotation that is not a unit quaternion.
    pub fn add_node(&mut self, name: &str, frame: Frame) -> Result<usize, SceneError> {
        let path = format!("nodes.{name}");
        if self.names.nodes.contains_key(name) {
            return Err(SceneError::new(
                path,
                "a node or body of this name exists already",
            ));
        }
        check_frame(&path, &frame)?;
        Ok(self.push_node(name, frame))
    }

    /// Adds a node at rest, its name indexed; returns its index.
    fn push_node(&mut self, name: &str, frame: Frame) -> usize {
        self.names.nodes.insert(name.to_string(), self.nodes.len());
        self.nodes.push(Node {
            name: name.to_string(),
            frame,
            velocity: [0.0; NV],
        });
        self.nodes.len() - 1
    }

    /// The node called `name` (a body's node by the body's name).
    pub fn node_named(&self, name: &str) -> Option<usize> {
        self.names.nodes.get(name).copied()
    }

    /// Adds a beam of `section` (at full density) from node `a` to node `b`, its section's
    /// `e₂` axis the component of `up` across the bar; returns its index.
    ///
    /// # Errors
    /// A [`SceneError`] at `beams.NAME` for a duplicate name, an unknown node, a section no
    /// beam has ([`Section::implausible`]), ends that coincide or `up` along the bar.
    pub fn add_beam(
        &mut self,
        name: &str,
        a: usize,
        b: usize,
        section: &Section,
        up: Vector3<f64>,
    ) -> Result<usize, SceneError> {
        let path = format!("beams.{name}");
        if self.names.has(Entry::Beam, name) {
            return Err(SceneError::new(path, "a beam of this name exists already"));
        }
        let node = |n: usize, end: &str| {
            self.nodes.get(n).map(|node| &node.frame).ok_or_else(|| {
                SceneError::new(
                    format!("{path}.{end}"),
                    format!("no node {n} (the mechanism has {})", self.nodes.len()),
                )
            })
        };
        let frames = [node(a, "a")?, node(b, "b")?];
        if let Some(what) = section.implausible() {
            return Err(SceneError::new(
                format!("{path}.section"),
                format!("its {what} must be positive and finite (damping not negative)"),
            ));
        }
        finite(&format!("{path}.up"), &up)?;
        let beam = Beam::new(name, [a, b], frames, &up, section).ok_or_else(|| {
            SceneError::new(
                &path,
                "its ends coincide, or `up` lies along it: a beam needs a length and a section's axis across it",
            )
        })?;
        self.names.take(Entry::Beam, name);
        self.beams.push(beam);
        Ok(self.beams.len() - 1)
    }

    /// Adds a truss bar of `section` (its `EA`, `ρA` and Rayleigh damping, at full density)
    /// between the origins of nodes `a` and `b`; returns its index. A node that only bars
    /// meet has no rotation: joints hold it at its origin (spherical), loads push it without
    /// moments ([`SpatialModel::check_nodes`]).
    ///
    /// # Errors
    /// A [`SceneError`] at `trusses.NAME` for a duplicate name, an unknown node, a section no
    /// bar has or ends that coincide.
    pub fn add_truss(
        &mut self,
        name: &str,
        a: usize,
        b: usize,
        section: &Section,
    ) -> Result<usize, SceneError> {
        let path = format!("trusses.{name}");
        if self.names.has(Entry::Truss, name) {
            return Err(SceneError::new(
                path,
                "a truss bar of this name exists already",
            ));
        }
        let node = |n: usize, end: &str| {
            self.nodes.get(n).map(|node| node.frame.x).ok_or_else(|| {
                SceneError::new(
                    format!("{path}.{end}"),
                    format!("no node {n} (the mechanism has {})", self.nodes.len()),
                )
            })
        };
        let (xa, xb) = (node(a, "a")?, node(b, "b")?);
        if let Some(what) = section.implausible() {
            return Err(SceneError::new(
                format!("{path}.section"),
                format!("its {what} must be positive and finite (damping not negative)"),
            ));
        }
        let bar = Truss::new(name, [a, b], &xa, &xb, section)
            .ok_or_else(|| SceneError::new(&path, "its ends coincide: a bar needs a length"))?;
        self.names.take(Entry::Truss, name);
        self.trusses.push(bar);
        Ok(self.trusses.len() - 1)
    }

    /// The structural elements: beams, then truss bars.
    pub(crate) fn elements(&self) -> impl Iterator<Item = &dyn Element> + '_ {
        let beams = self.beams.iter().map(|b| b as &dyn Element);
        beams.chain(self.trusses.iter().map(|t| t as &dyn Element))
    }

    /// Which nodes have no rotation: those only truss bars and point masses meet (no rigid
    /// body, no beam).
    pub(crate) fn rotation_absent(&self) -> Vec<bool> {
        let mut turns = vec![false; self.nodes.len()];
        (self.bodies.iter())
            .filter(|b| b.inertia != Matrix3::zeros())
            .for_each(|b| turns[b.node] = true);
        self.beams
            .iter()
            .flat_map(|b| b.nodes())
            .for_each(|n| turns[n] = true);
        turns.iter().map(|t| !t).collect()
    }

    /// Adds a point mass of `mass` (kg) at node `node`'s origin — a beam's end, a bar's
    /// joint —; returns its index among the bodies: a body of no rotary inertia, its mass a
    /// [`crate::spatial::sensitivity::Parameter::Mass`], its position a response.
    ///
    /// # Errors
    /// A [`SceneError`] at `bodies.NAME` for a duplicate name, an unknown node or a mass that
    /// is not positive.
    pub fn add_point_mass(
        &mut self,
        name: &str,
        node: usize,
        mass: f64,
    ) -> Result<usize, SceneError> {
        let path = format!("bodies.{name}");
        if self.names.has(Entry::Body, name) {
            return Err(SceneError::new(path, "a body of this name exists already"));
        }
        if node >= self.nodes.len() {
            return Err(SceneError::new(
                format!("{path}.node"),
                format!("no node {node} (the mechanism has {})", self.nodes.len()),
            ));
        }
        if !(mass.is_finite() && mass > 0.0) {
            return Err(SceneError::new(
                format!("{path}.mass"),
                format!("{} kg: must be positive", short(mass)),
            ));
        }
        self.names.take(Entry::Body, name);
        self.bodies.push(Body {
            name: name.to_string(),
            node,
            mass,
            inertia: Matrix3::zeros(),
        });
        Ok(self.bodies.len() - 1)
    }

    /// Sets body `body`'s initial rates: the velocity of its centre of mass (m/s, inertial
    /// frame) and its angular velocity (rad/s, in its own frame).
    ///
    /// # Errors
    /// A [`SceneError`] for an unknown body or non-finite rates.
    pub fn set_rates(
        &mut self,
        body: usize,
        velocity: Vector3<f64>,
        angular_velocity: Vector3<f64>,
    ) -> Result<(), SceneError> {
        let b = self
            .bodies
            .get(body)
            .ok_or_else(|| SceneError::new(format!("bodies[{body}]"), "no such body"))?;
        self.set_node_rates(b.node, velocity, angular_velocity)
    }

    /// Sets node `node`'s initial rates: the velocity of its origin (m/s, inertial frame)
    /// and its angular velocity (rad/s, in its own frame).
    ///
    /// # Errors
    /// A [`SceneError`] for an unknown node or non-finite rates.
    pub fn set_node_rates(
        &mut self,
        node: usize,
        velocity: Vector3<f64>,
        angular_velocity: Vector3<f64>,
    ) -> Result<(), SceneError> {
        let n = self
            .nodes
            .get_mut(node)
            .ok_or_else(|| SceneError::new(format!("nodes[{node}]"), "no such node"))?;
        let path = format!("nodes.{}", n.name);
        finite(&format!("{path}.velocity"), &velocity)?;
        finite(&format!("{path}.angular_velocity"), &angular_velocity)?;
        n.velocity[..3].copy_from_slice(velocity.as_slice());
        n.velocity[3..].copy_from_slice(angular_velocity.as_slice());
        Ok(())
    }

    /// Adds a joint of `kind` between anchors `a` and `b`, its axes given in the initial
    /// configuration; returns its index.
    ///
    /// # Errors
    /// A [`SceneError`] at `joints.NAME` for a duplicate name, an unknown body, both anchors
    /// on the ground or on one body, non-finite points, a zero axis, a universal joint's
    /// axes not at right angles, or a joint the initial configuration breaks (points that
    /// do not meet, B's point off a prismatic joint's axis).
    pub fn add_joint(
        &mut self,
        name: &str,
        kind: JointKind,
        a: Anchor,
        b: Anchor,
    ) -> Result<usize, SceneError> {
        let path = format!("joints.{name}");
        if self.names.has(Entry::Joint, name) {
            return Err(SceneError::new(path, "a joint of this name exists already"));
        }
        let (node_a, arm_a) = self.resolve(&format!("{path}.a"), a)?;
        let (node_b, arm_b) = self.resolve(&format!("{path}.b"), b)?;
        if node_a == node_b {
            let what = if node_a.is_none() {
                "the ground"
            } else {
                "one body"
            };
            return Err(SceneError::new(
                path,
                format!(
                    "both anchors are on {what}: a joint joins two bodies, or a body to the ground"
                ),
            ));
        }
        let rotation =
            |n: Option<usize>| n.map_or_else(Matrix3::identity, |n| self.nodes[n].frame.rotation());
        let joint = Joint::new(
            name,
            kind,
            [node_a, node_b],
            [arm_a, arm_b],
            [rotation(node_a), rotation(node_b)],
        )
        .map_err(|m| SceneError::new(&path, m))?;
        if let Some((value, what)) =
            joint.broken(&self.initial_configuration(), self.size(), MEET_TOLERANCE)
        {
            return Err(SceneError::new(
                path,
                format!("{what} in the initial configuration (by {}); place its bodies so that it holds", short(value)),
            ));
        }
        self.names.take(Entry::Joint, name);
        self.joints.push(joint);
        Ok(self.joints.len() - 1)
    }

    /// Drives joint `joint` by `law`: a revolute joint's angle about its axis (rad), a
    /// prismatic joint's travel along its axis (m), each `f(t) − f(0)` from where it starts.
    ///
    /// # Errors
    /// A [`SceneError`] at `joints.NAME.drive` for an unknown joint, a joint of another kind
    /// or one driven already.
    pub fn add_drive(&mut self, joint: usize, law: Motion) -> Result<(), SceneError> {
        let q = self.initial_configuration();
        let j = self
            .joints
            .get_mut(joint)
            .ok_or_else(|| SceneError::new(format!("joints[{joint}]"), "no such joint"))?;
        j.drive(law, &q)
            .map_err(|m| SceneError::new(format!("joints.{}.drive", j.name), m))
    }

    /// Checks a time function's table: two samples at least, as many values as times,
    /// finite, times strictly increasing.
    fn check_time(path: &str, time: &TimeFunction) -> Result<(), SceneError> {
        match time {
            TimeFunction::Constant => Ok(()),
            TimeFunction::Table { t, value } => samples(&format!("{path}.time"), t, value, "value"),
        }
    }

    /// Adds a force element, its name taken.
    fn push_force(&mut self, force: Force) {
        self.names.take(Entry::Force, &force.name);
        self.forces.push(force);
    }

    fn new_force(&self, name: &str) -> Result<String, SceneError> {
        let path = format!("forces.{name}");
        if self.names.has(Entry::Force, name) {
            return Err(SceneError::new(
                path,
                "a force element of this name exists already",
            ));
        }
        Ok(path)
    }

    /// Adds a spring-damper of stiffness `k` (N/m) and damping `c` (N s/m) between anchors
    /// `a` and `b`, at rest at length `rest` (m; `None`: their distance now); returns its index.
    ///
    /// # Errors
    /// A [`SceneError`] at `forces.NAME` for a duplicate name, an unknown body, a negative or
    /// non-finite `k`, `c` or `rest`, or points that coincide (the spring has no line).
    pub fn add_spring(
        &mut self,
        name: &str,
        a: Anchor,
        b: Anchor,
        k: f64,
        c: f64,
        rest: Option<f64>,
    ) -> Result<usize, SceneError> {
        let path = self.new_force(name)?;
        not_negative(&path, [("k", k), ("c", c), ("rest", rest.unwrap_or(0.0))])?;
        let pair = Pair {
            nodes: [
                self.resolve(&format!("{path}.a"), a)?.0,
                self.resolve(&format!("{path}.b"), b)?.0,
            ],
            arms: [
                self.resolve(&format!("{path}.a"), a)?.1,
                self.resolve(&format!("{path}.b"), b)?.1,
            ],
        };
        let q = self.initial_configuration();
        let length = pair
            .evaluate(&Measure::Gap, &pair.sides(&q, None))
            .value
            .norm();
        if length <= MEET_TOLERANCE * self.size() {
            return Err(SceneError::new(
                path,
                "its points coincide: a spring needs a line between them",
            ));
        }
        let kind = ForceKind::Spring {
            stiffness: k,
            damping: c,
            rest: rest.unwrap_or(length),
        };
        self.push_force(Force {
            name: name.to_string(),
            kind,
            pair,
        });
        Ok(self.forces.len() - 1)
    }

    /// Joint `joint`, for the force element at `path`.
    fn joint_at(&self, path: &str, joint: usize) -> Result<&Joint, SceneError> {
        (self.joints.get(joint))
            .ok_or_else(|| SceneError::new(format!("{path}.joint"), format!("no joint {joint}")))
    }

    /// Adds a torsion spring-damper of stiffness `k` (N m/rad) and damping `c` (N m s/rad)
    /// on revolute or cylindrical joint `joint`'s angle, at rest at `rest` (rad from where
    /// the joint is built; 0 by default); returns its index.
    ///
    /// # Errors
    /// A [`SceneError`] at `forces.NAME` for a duplicate name, an unknown joint, a joint of
    /// another kind, a negative or non-finite `k` or `c`, or a rest angle not within half a
    /// turn.
    pub fn add_torsion(
        &mut self,
        name: &str,
        joint: usize,
        k: f64,
        c: f64,
        rest: Option<f64>,
    ) -> Result<usize, SceneError> {
        let path = self.new_force(name)?;
        let j = self.joint_at(&path, joint)?;
        let axes = j.angle_axes().ok_or_else(|| {
            SceneError::new(
                format!("{path}.joint"),
                format!(
                    "joint '{}' is {}: a torsion spring turns with a revolute or cylindrical joint",
                    j.name,
                    j.kind.name()
                ),
            )
        })?;
        not_negative(&path, [("k", k), ("c", c)])?;
        let rest = rest.unwrap_or(0.0);
        if rest.is_nan() || rest.abs() >= std::f64::consts::PI {
            return Err(SceneError::new(
                format!("{path}.rest"),
                format!(
                    "{}: a rest angle lies within half a turn (rad)",
                    short(rest)
                ),
            ));
        }
        self.push_force(Force {
            name: name.to_string(),
            kind: ForceKind::Torsion {
                stiffness: k,
                damping: c,
                rest,
                axes,
            },
            pair: j.pair.clone(),
        });
        Ok(self.forces.len() - 1)
    }

    /// Adds a motor on revolute joint `joint`: a torque `torque · g(t)` (N m) about its axis,
    /// on its body B (the opposite on A); returns its index.
    ///
    /// # Errors
    /// A [`SceneError`] at `forces.NAME` for a duplicate name, an unknown joint, a joint of
    /// another kind or a non-finite torque.
    pub fn add_motor(
        &mut self,
        name: &str,
        joint: usize,
        torque: f64,
        time: TimeFunction,
    ) -> Result<usize, SceneError> {
        let path = self.new_force(name)?;
        let j = self.joint_at(&path, joint)?;
        let JointKind::Revolute { axis } = j.kind else {
            return Err(SceneError::new(
                format!("{path}.joint"),
                format!(
                    "joint '{}' is {}: a motor turns a revolute joint",
                    j.name,
                    j.kind.name()
                ),
            ));
        };
        if !torque.is_finite() {
            return Err(SceneError::new(format!("{path}.torque"), "must be finite"));
        }
        Self::check_time(&path, &time)?;
        let rotation =
            j.pair.nodes[0].map_or_else(Matrix3::identity, |n| self.nodes[n].frame.rotation());
        let kind = ForceKind::Motor {
            torque,
            time,
            axis: rotation.transpose() * axis.normalize(),
        };
        self.push_force(Force {
            name: name.to_string(),
            kind,
            pair: j.pair.clone(),
        });
        Ok(self.forces.len() - 1)
    }

    /// Adds a load at a body's or a node's point: a force (N) and a moment (N m) scaled by
    /// `g(t)`, fixed in space or, for a `follower`, in the body; returns its index.
    ///
    /// # Errors
    /// A [`SceneError`] at `forces.NAME` for a duplicate name, an anchor on the ground, an
    /// unknown body or node, or non-finite values.
    pub fn add_load(
        &mut self,
        name: &str,
        at: Anchor,
        force: Vector3<f64>,
        moment: Vector3<f64>,
        time: TimeFunction,
        follower: bool,
    ) -> Result<usize, SceneError> {
        let path = self.new_force(name)?;
        let (node, arm) = self.resolve(&path, at)?;
        let Some(node) = node else {
            return Err(SceneError::new(
                path,
                "a load acts on a body's or a node's point, not on the ground",
            ));
        };
        let node = Some(node);
        finite(&format!("{path}.force"), &force)?;
        finite(&format!("{path}.moment"), &moment)?;
        Self::check_time(&path, &time)?;
        let kind = ForceKind::Load {
            force,
            moment,
            time,
            follower,
        };
        let pair = Pair {
            nodes: [node, None],
            arms: [arm, Vector3::zeros()],
        };
        self.push_force(Force {
            name: name.to_string(),
            kind,
            pair,
        });
        Ok(self.forces.len() - 1)
    }

    /// An anchor's node (`None`: the ground) and point.
    fn resolve(
        &self,
        path: &str,
        anchor: Anchor,
    ) -> Result<(Option<usize>, Vector3<f64>), SceneError> {
        match anchor {
            Anchor::Ground(p) => {
                finite(path, &p)?;
                Ok((None, p))
            }
            Anchor::Body { body, point } => {
                let b = self.bodies.get(body).ok_or_else(|| {
                    SceneError::new(
                        path,
                        format!("no body {body} (the mechanism has {})", self.bodies.len()),
                    )
                })?;
                finite(path, &point)?;
                Ok((Some(b.node), point))
            }
            Anchor::Node { node, point } => {
                if node >= self.nodes.len() {
                    return Err(SceneError::new(
                        path,
                        format!("no node {node} (the mechanism has {})", self.nodes.len()),
                    ));
                }
                finite(path, &point)?;
                Ok((Some(node), point))
            }
        }
    }

    /// Unknowns of a configuration `q` (seven per node).
    pub fn n_q(&self) -> usize {
        NQ * self.nodes.len()
    }

    /// Unknowns of a velocity (six per node).
    pub fn n_v(&self) -> usize {
        NV * self.nodes.len()
    }

    /// Constraint rows.
    pub fn n_rows(&self) -> usize {
        self.joints.iter().map(Joint::n_rows).sum()
    }

    /// The rows of joint `joint` among the multipliers `λ`, its drive's last (`None` for a
    /// joint the mechanism does not have): `λ` of a point's rows is the force the joint
    /// exerts on A's point (N, its opposite on B's), of an angle's a moment (N m), of a
    /// drive's the generalized force it takes from the joint's coordinate (N m or N: the
    /// drive applies its opposite).
    pub fn joint_rows(&self, joint: usize) -> Option<std::ops::Range<usize>> {
        let this = self.joints.get(joint)?;
        let start: usize = self.joints[..joint].iter().map(Joint::n_rows).sum();
        Some(start..start + this.n_rows())
    }

    /// The mechanism's size (m): the diagonal of the box around its nodes and the ground
    /// points of its joints and force elements, 1 m for a single point: the reference of
    /// length tolerances, wherever the mechanism sits.
    pub fn size(&self) -> f64 {
        let nodes = self.nodes.iter().map(|n| n.frame.x);
        let ground = self
            .joints
            .iter()
            .map(|j| &j.pair)
            .chain(self.forces.iter().map(|f| &f.pair))
            .flat_map(|p| {
                (0..2)
                    .filter(|&s| p.nodes[s].is_none())
                    .map(move |s| p.arms[s])
            });
        let mut points = nodes.chain(ground);
        let Some(first) = points.next() else {
            return 1.0;
        };
        let (lo, hi) = points.fold((first, first), |(lo, hi), p| (lo.inf(&p), hi.sup(&p)));
        let diagonal = (hi - lo).norm();
        if diagonal > 0.0 {
            diagonal
        } else {
            1.0
        }
    }

    /// The mechanism at rest: its loads and motors at zero and no gravity, so that its
    /// initial configuration without constraint forces is an equilibrium wherever no spring
    /// is preloaded; what its structural modes are taken about (each entry where it was,
    /// its parameters numbered as in `self`).
    pub fn at_rest(&self) -> SpatialModel {
        let mut m = self.clone();
        for f in &mut m.forces {
            match &mut f.kind {
                ForceKind::Load { force, moment, .. } => {
                    *force = Vector3::zeros();
                    *moment = Vector3::zeros();
                }
                ForceKind::Motor { torque, .. } => *torque = 0.0,
                ForceKind::Spring { .. } | ForceKind::Torsion { .. } => {}
            }
        }
        m.gravity = Vector3::zeros();
        m
    }

    /// The initial configuration.
    pub fn initial_configuration(&self) -> Vec<f64> {
        let mut q = vec![0.0; self.n_q()];
        self.nodes
            .iter()
            .enumerate()
            .for_each(|(i, n)| n.frame.write(&mut q, i));
        q
    }

    /// The initial velocities.
    pub fn initial_velocity(&self) -> Vec<f64> {
        self.nodes.iter().flat_map(|n| n.velocity).collect()
    }

    /// Checks that the initial rates keep the joints (`B v = 0`).
    ///
    /// # Errors
    /// A [`SceneError`] naming the first joint the rates break.
    pub fn check_rates(&self) -> Result<(), SceneError> {
        let (q, v) = (self.initial_configuration(), self.initial_velocity());
        let speed = self.speed(&v);
        for j in &self.joints {
            let rate = j.rates(&q, &v, 0.0).rows(0, j.n_rows()).amax();
            if rate > MEET_TOLERANCE * speed.max(f64::MIN_POSITIVE) {
                return Err(SceneError::new(
                    format!("joints.{}", j.name),
                    format!(
                        "the initial rates break it at {} (m/s, or rad/s)",
                        short(rate)
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The scale of the velocities `v` (m/s): the model's size times its largest angular
    /// speed plus its largest linear one, what a joint's rates are measured against.
    pub(crate) fn speed(&self, v: &[f64]) -> f64 {
        let (mut linear, mut angular) = (0.0f64, 0.0f64);
        for c in v.chunks(NV) {
            let (u, omega) = split(&six(c, 0));
            (linear, angular) = (linear.max(u.norm()), angular.max(omega.norm()));
        }
        self.size() * angular + linear
    }

    /// Kinetic energy at velocity `v` (J).
    pub fn kinetic_energy(&self, v: &[f64]) -> f64 {
        let bodies: f64 = self
            .bodies
            .iter()
            .map(|b| b.kinetic_energy(&six(v, b.node)))
            .sum();
        bodies + self.elements().map(|e| e.kinetic_energy(v)).sum::<f64>()
    }

    /// Adds the momenta `M v` scaled by `w` to `out` (six per node): the kinetic energy's
    /// derivative to the velocities.
    pub(crate) fn add_momenta(&self, v: &[f64], w: f64, out: &mut [f64]) {
        for b in &self.bodies {
            let p = b.mass_matrix() * nalgebra::Vector6::from(six(v, b.node));
            out[NV * b.node..NV * b.node + NV]
                .iter_mut()
                .zip(p.iter())
                .for_each(|(m, x)| *m += w * x);
        }
        for e in self.elements() {
            e.add_momenta(v, w, out);
        }
    }

    /// Potential energy at `q` (J): of gravity, zero at the origin, of the beams' strains,
    /// of the springs and of the constant dead forces ([`Force::potential`]).
    pub fn potential_energy(&self, q: &[f64]) -> f64 {
        let height = |node: usize| -self.gravity.dot(&Frame::read(q, node).x);
        let bodies: f64 = self.bodies.iter().map(|b| b.mass * height(b.node)).sum();
        let elements: f64 = self
            .elements()
            .map(|e| {
                let [n1, n2] = e.nodes();
                0.5 * e.mass() * (height(n1) + height(n2)) + e.strain_energy(q)
            })
            .sum();
        bodies + elements + self.forces.iter().map(|f| f.potential(q)).sum::<f64>()
    }

    /// Every dead force on a node at time `t`, as (node, its point in the node's frame,
    /// the force): the loads' without moment (a ground point's left out) and each weight — a
    /// body's `m g` at its centre, an element's `ρAL g/2` at each end.
    fn dead_forces(
        &self,
        t: f64,
    ) -> impl Iterator<Item = (usize, Vector3<f64>, Vector3<f64>)> + '_ {
        let g = self.gravity;
        let bodies = (self.bodies.iter()).map(move |b| (b.node, Vector3::zeros(), g * b.mass));
        let elements = self.elements().flat_map(move |e| {
            e.nodes()
                .map(|n| (n, Vector3::zeros(), g * (0.5 * e.mass())))
        });
        let loads = self
            .forces
            .iter()
            .filter_map(move |f| match (&f.kind, f.pair.nodes[0]) {
                (ForceKind::Load { force, time, .. }, Some(node)) => {
                    Some((node, f.pair.arms[0], force * time.at(t)))
                }
                _ => None,
            });
        bodies.chain(elements).chain(loads)
    }

    /// The force element a static compliance `Fᵀu` cannot count, by name: a follower load,
    /// a load with a moment, a motor (`Fᵀu` is the work of dead forces).
    pub(crate) fn beyond_load_work(&self) -> Option<&str> {
        self.forces.iter().find_map(|f| match &f.kind {
            ForceKind::Load {
                moment, follower, ..
            } if *follower || moment.norm() > 0.0 => Some(f.name.as_str()),
            ForceKind::Motor { .. } => Some(f.name.as_str()),
            _ => None,
        })
    }

    /// The work `Fᵀu` the dead forces at time `t` do from the initial configuration to `q`
    /// (J): each on its point's displacement ([`SpatialModel::dead_forces`]).
    pub(crate) fn load_work(&self, q: &[f64], t: f64) -> f64 {
        let point = |f: Frame, arm: &Vector3<f64>| f.x + f.r * arm;
        (self.dead_forces(t))
            .map(|(node, arm, force)| {
                let start = point(self.nodes[node].frame, &arm);
                force.dot(&(point(Frame::read(q, node), &arm) - start))
            })
            .sum()
    }

    /// Adds `w` times [`SpatialModel::load_work`]'s derivative at `q` in the nodes' algebra
    /// to `out`: `F` on a node's translation, `a × RᵀF` on its rotation.
    pub(crate) fn add_load_work_gradient(&self, q: &[f64], t: f64, w: f64, out: &mut [f64]) {
        for (node, arm, force) in self.dead_forces(t) {
            let turned = arm.cross(&(Frame::read(q, node).r.inverse() * force));
            for i in 0..3 {
                out[NV * node + i] += w * force[i];
                out[NV * node + 3 + i] += w * turned[i];
            }
        }
    }

    /// The beams' and bars' strain energy at `q` (J).
    pub fn strain_energy(&self, q: &[f64]) -> f64 {
        self.elements().map(|e| e.strain_energy(q)).sum()
    }

    /// Angular momentum about the point `c` of the inertial frame (kg m²/s):
    /// `Σ (x − c) × p + R J Ω` over the nodes, `p` and `J Ω` their shares of the momenta
    /// (`M v`).
    pub fn angular_momentum(&self, q: &[f64], v: &[f64], c: &Vector3<f64>) -> Vector3<f64> {
        let mut momenta = vec![0.0; self.n_v()];
        self.add_momenta(v, 1.0, &mut momenta);
        (0..self.nodes.len())
            .map(|n| {
                let f = Frame::read(q, n);
                let (p, spin) = split(&six(&momenta, n));
                (f.x - c).cross(&p) + f.r * spin
            })
            .sum()
    }

    /// Checks the nodes: every one carries mass (a body's, a beam's or a bar's), and one
    /// that only truss bars meet (no rotation) is held only at its origin by spherical
    /// joints, springs and loads without moments.
    ///
    /// # Errors
    /// A [`SceneError`] naming the first node with no mass, or the joint, force element
    /// that would turn a node without rotation.
    pub fn check_nodes(&self) -> Result<(), SceneError> {
        let mut carried = vec![false; self.nodes.len()];
        self.bodies.iter().for_each(|b| carried[b.node] = true);
        self.elements()
            .flat_map(|e| e.nodes())
            .for_each(|n| carried[n] = true);
        if let Some(n) = carried.iter().position(|c| !c) {
            return Err(SceneError::new(
                format!("nodes.{}", self.nodes[n].name),
                "carries no mass: end a beam or a bar on it, or make it a body",
            ));
        }
        let absent = self.rotation_absent();
        let turns = |pair: &Pair| {
            (0..2).any(|s| {
                pair.nodes[s].is_some_and(|n| absent[n]) && pair.arms[s] != Vector3::zeros()
            })
        };
        let on_absent = |pair: &Pair| pair.nodes.iter().flatten().copied().find(|&n| absent[n]);
        for j in &self.joints {
            if let Some(n) = on_absent(&j.pair) {
                if j.kind != JointKind::Spherical || turns(&j.pair) {
                    return Err(SceneError::new(
                        format!("joints.{}", j.name),
                        format!(
                            "node '{}' only truss bars meet has no rotation: hold it at its origin by a spherical joint",
                            self.nodes[n].name
                        ),
                    ));
                }
            }
        }
        for f in &self.forces {
            let Some(n) = on_absent(&f.pair) else {
                continue;
            };
            let moment = match &f.kind {
                ForceKind::Load {
                    moment, follower, ..
                } => *follower || *moment != Vector3::zeros(),
                ForceKind::Motor { .. } | ForceKind::Torsion { .. } => true,
                ForceKind::Spring { .. } => false,
            };
            if moment || turns(&f.pair) {
                return Err(SceneError::new(
                    format!("forces.{}", f.name),
                    format!(
                        "node '{}' only truss bars meet has no rotation: act on its origin, without moments or following it",
                        self.nodes[n].name
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// Each named constant of the force element at `path` finite and not negative.
fn not_negative<const N: usize>(path: &str, values: [(&str, f64); N]) -> Result<(), SceneError> {
    match values
        .into_iter()
        .find(|(_, v)| !(v.is_finite() && *v >= 0.0))
    {
        Some((what, value)) => Err(SceneError::new(
            format!("{path}.{what}"),
            format!("{}: must be finite and not negative", short(value)),
        )),
        None => Ok(()),
    }
}

/// A frame a node can have: a finite position, a unit quaternion.
fn check_frame(path: &str, frame: &Frame) -> Result<(), SceneError> {
    finite(&format!("{path}.position"), &frame.x)?;
    let r = frame.r.quaternion();
    if !(r.coords.iter().all(|c| c.is_finite()) && (r.norm() - 1.0).abs() <= 1e-9) {
        return Err(SceneError::new(
            format!("{path}.rotation"),
            format!(
                "({}, {}, {}, {}) is not a unit quaternion",
                r.w, r.i, r.j, r.k
            ),
        ));
    }
    Ok(())
}

/// An inertia tensor a body can have: symmetric, its principal moments positive and each
/// at most the sum of the other two.
fn check_inertia(path: &str, j: &Matrix3<f64>) -> Result<(), SceneError> {
    let scale = j.abs().max();
    if !j.iter().all(|x| x.is_finite()) || scale <= 0.0 {
        return Err(SceneError::new(path, "must be finite and not zero"));
    }
    if (j - j.transpose()).abs().max() > SYMMETRY_TOLERANCE * scale {
        return Err(SceneError::new(path, "is not symmetric"));
    }
    let mut moments: Vec<f64> = j.symmetric_eigenvalues().iter().copied().collect();
    moments.sort_by(f64::total_cmp);
    if moments[0] <= 0.0 {
        return Err(SceneError::new(
            path,
            format!(
                "has principal moment {} kg m²: must be positive definite",
                short(moments[0])
            ),
        ));
    }
    if moments[0] + moments[1] < moments[2] * (1.0 - 1e-12) {
        return Err(SceneError::new(
            path,
            format!(
                "has principal moments {}, {}, {} kg m²: no body has one larger than the sum of the other two",
                short(moments[0]),
                short(moments[1]),
                short(moments[2])
            ),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::UnitQuaternion;

    fn at(x: f64, y: f64, z: f64) -> Frame {
        Frame::new(Vector3::new(x, y, z), UnitQuaternion::identity())
    }

    /// Every kind of entry refuses a name it has, a node a body's name and the other way
    /// round, and a failed entry leaves its name free; nodes are found by name.
    #[test]
    fn names_are_taken_once() {
        let mut m = SpatialModel::new(Vector3::zeros()).unwrap();
        let j = Matrix3::identity();
        let section = Section::new(
            &crate::spatial::section::Shape::SolidCircle { d: 0.01 }
                .geometry(0.3)
                .unwrap(),
            2e11,
            8e10,
            7850.0,
        );
        m.add_body("hub", at(0.0, 0.0, 0.0), 1.0, j).unwrap();
        let clash = |e: SceneError| assert!(e.to_string().contains("exists already"), "{e}");
        clash(m.add_node("hub", at(1.0, 0.0, 0.0)).unwrap_err());
        clash(m.add_body("hub", at(1.0, 0.0, 0.0), 1.0, j).unwrap_err());
        assert!(m.add_node("end", at(f64::NAN, 0.0, 0.0)).is_err());
        let end = m.add_node("end", at(1.0, 0.0, 0.0)).unwrap();
        let tip = m.add_node("tip", at(2.0, 0.0, 0.0)).unwrap();
        clash(m.add_body("end", at(1.0, 0.0, 0.0), 1.0, j).unwrap_err());
        assert_eq!(
            (m.node_named("hub"), m.node_named("end")),
            (Some(0), Some(end))
        );
        assert_eq!(m.node_named("nowhere"), None);
        m.add_beam("rod", end, tip, &section, Vector3::z()).unwrap();
        clash(
            m.add_beam("rod", end, tip, &section, Vector3::z())
                .unwrap_err(),
        );
        m.add_truss("rod", end, tip, &section).unwrap();
        clash(m.add_truss("rod", end, tip, &section).unwrap_err());
        m.add_point_mass("bob", tip, 0.1).unwrap();
        clash(m.add_point_mass("bob", end, 0.1).unwrap_err());
        let pin = |node| Anchor::Node {
            node,
            point: Vector3::zeros(),
        };
        m.add_joint(
            "ball",
            JointKind::Spherical,
            pin(end),
            Anchor::Ground(Vector3::x()),
        )
        .unwrap();
        clash(
            m.add_joint(
                "ball",
                JointKind::Spherical,
                pin(tip),
                Anchor::Ground(2.0 * Vector3::x()),
            )
            .unwrap_err(),
        );
        let (force, moment) = (Vector3::z(), Vector3::zeros());
        let mut push = || {
            m.add_load(
                "push",
                pin(tip),
                force,
                moment,
                TimeFunction::Constant,
                false,
            )
        };
        push().unwrap();
        clash(push().unwrap_err());
    }

    #[test]
    fn bad_bodies_are_named() {
        let mut m = SpatialModel::new(Vector3::zeros()).unwrap();
        let j = Matrix3::identity();
        let err = m.add_body("rod", at(0.0, 0.0, 0.0), -1.0, j).unwrap_err();
        assert_eq!(err.path, "bodies.rod.mass");
        let err = m
            .add_body(
                "rod",
                at(0.0, 0.0, 0.0),
                1.0,
                Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, 3.0)),
            )
            .unwrap_err();
        assert!(err.message.contains("sum of the other two"), "{err}");
        let mut skew = j;
        skew[(0, 1)] = 0.5;
        assert!(m
            .add_body("rod", at(0.0, 0.0, 0.0), 1.0, skew)
            .unwrap_err()
            .message
            .contains("not symmetric"));
        let err = m
            .add_body("rod", at(f64::NAN, 0.0, 0.0), 1.0, j)
            .unwrap_err();
        assert_eq!(err.path, "bodies.rod.position");
        m.add_body("rod", at(0.0, 0.0, 0.0), 1.0, j).unwrap();
        assert!(m
            .add_body("rod", at(0.0, 0.0, 0.0), 1.0, j)
            .unwrap_err()
            .message
            .contains("exists"));
    }

    #[test]
    fn bad_joints_are_named() {
        let mut m = SpatialModel::new(Vector3::zeros()).unwrap();
        let b = m
            .add_body("top", at(0.0, 1.0, 0.0), 1.0, Matrix3::identity())
            .unwrap();
        let pivot = Anchor::Body {
            body: b,
            point: Vector3::new(0.0, -1.0, 0.0),
        };
        let err = m
            .add_joint(
                "pivot",
                JointKind::Spherical,
                pivot,
                Anchor::Ground(Vector3::new(0.0, 0.0, 0.1)),
            )
            .unwrap_err();
        assert_eq!(err.path, "joints.pivot");
        assert!(
            err.message
                .contains("its points are apart in the initial configuration (by 0.1)"),
            "{err}"
        );
        let err = m
            .add_joint(
                "pivot",
                JointKind::Spherical,
                Anchor::Ground(Vector3::zeros()),
                Anchor::Ground(Vector3::zeros()),
            )
            .unwrap_err();
        assert!(err.message.contains("the ground"), "{err}");
        let err = m
            .add_joint(
                "pivot",
                JointKind::Spherical,
                Anchor::Body {
                    body: 3,
                    point: Vector3::zeros(),
                },
                Anchor::Ground(Vector3::zeros()),
            )
            .unwrap_err();
        assert_eq!(err.path, "joints.pivot.a");
        m.add_joint(
            "pivot",
            JointKind::Spherical,
            pivot,
            Anchor::Ground(Vector3::zeros()),
        )
        .unwrap();
        // A spin about the pivot's axis is allowed; a drift of the centre of mass is not.
        m.set_rates(b, Vector3::zeros(), Vector3::new(0.0, 5.0, 0.0))
            .unwrap();
        m.check_rates().unwrap();
        m.set_rates(b, Vector3::new(0.0, 0.0, 1.0), Vector3::zeros())
            .unwrap();
        let err = m.check_rates().unwrap_err();
        assert!(
            err.path == "joints.pivot" && err.message.contains("break it at 1 "),
            "{err}"
        );
    }

    #[test]
    fn bad_force_elements_are_named() {
        let mut m = SpatialModel::new(Vector3::zeros()).unwrap();
        let b = m
            .add_body("bob", at(0.0, 1.0, 0.0), 1.0, Matrix3::identity())
            .unwrap();
        let (ground, bob) = (
            Anchor::Ground(Vector3::zeros()),
            Anchor::Body {
                body: b,
                point: Vector3::zeros(),
            },
        );
        let err = m.add_spring("s", ground, bob, -1.0, 0.0, None).unwrap_err();
        assert_eq!(err.path, "forces.s.k");
        let err = m
            .add_spring("s", ground, bob, 1.0, f64::NAN, None)
            .unwrap_err();
        assert_eq!(err.path, "forces.s.c");
        let on_it = Anchor::Ground(Vector3::new(0.0, 1.0, 0.0));
        assert!(m
            .add_spring("s", on_it, bob, 1.0, 0.0, None)
            .unwrap_err()
            .message
            .contains("coincide"));
        m.add_spring("s", ground, bob, 1.0, 0.0, None).unwrap();
        assert!(m
            .add_spring("s", ground, bob, 1.0, 0.0, None)
            .unwrap_err()
            .message
            .contains("exists"));
        let pivot = m
            .add_joint(
                "pivot",
                JointKind::Spherical,
                Anchor::Body {
                    body: b,
                    point: Vector3::new(0.0, -1.0, 0.0),
                },
                ground,
            )
            .unwrap();
        let err = m
            .add_motor("m", pivot, 1.0, TimeFunction::Constant)
            .unwrap_err();
        assert!(
            err.path == "forces.m.joint" && err.message.contains("is spherical"),
            "{err}"
        );
        assert_eq!(
            m.add_motor("m", 7, 1.0, TimeFunction::Constant)
                .unwrap_err()
                .path,
            "forces.m.joint"
        );
        let nan = Vector3::new(f64::NAN, 0.0, 0.0);
        let err = m
            .add_load(
                "l",
                Anchor::Body {
                    body: b,
                    point: Vector3::zeros(),
                },
                nan,
                Vector3::zeros(),
                TimeFunction::Constant,
                false,
            )
            .unwrap_err();
        assert_eq!(err.path, "forces.l.force");
        assert!(m
            .add_load(
                "l",
                Anchor::Body {
                    body: 3,
                    point: Vector3::zeros(),
                },
                Vector3::x(),
                Vector3::zeros(),
                TimeFunction::Constant,
                true
            )
            .is_err());
    }
}
