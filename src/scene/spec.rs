//! The scene description as data: what a TOML scene file or the Python builder holds.
//!
//! Every table rejects unknown keys. Values are checked when the scene is built
//! ([`crate::scene::build()`]), where each error names its entry. Units: SI.

use std::collections::BTreeMap;
use std::fmt;

use serde::de::{self, Deserializer, SeqAccess, Visitor};
use serde::Deserialize;

use crate::mechanism::element::quad::CellKind;
use crate::mechanism::element::Kind;
use crate::settings::RunOptions;

/// A whole scene.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SceneSpec {
    /// Name of the scene.
    #[serde(default)]
    pub name: String,
    /// `"dynamic"` (default) or `"static"`.
    #[serde(default)]
    pub analysis: AnalysisSpec,
    /// How a dynamic run starts: `"rest"` (default: undeformed) or `"equilibrium"` (the
    /// static equilibrium under gravity and the loads at `t = 0`, the drives held).
    #[serde(default)]
    pub initial: InitialSpec,
    /// Rates of undriven joints' coordinates at `t = 0` (rad/s, m/s on a slider): the
    /// mechanism starts in the rigid motion they determine.
    #[serde(default)]
    pub initial_rates: BTreeMap<String, f64>,
    /// Gravity acceleration `[g_x, g_y]` (m/s²); none by default.
    #[serde(default)]
    pub gravity: Option<[f64; 2]>,
    /// Named beam sections.
    #[serde(default)]
    pub sections: BTreeMap<String, SectionSpec>,
    /// Free-standing nodes.
    #[serde(default, deserialize_with = "polled")]
    pub nodes: Vec<NodeSpec>,
    /// Ground structures (one linkage each).
    #[serde(default)]
    pub ground_structures: Vec<GroundStructureSpec>,
    /// Individual beams between named nodes.
    #[serde(default, deserialize_with = "polled")]
    pub beams: Vec<BeamSpec>,
    /// Plane-stress continuum members (one linkage each).
    #[serde(default)]
    pub members: Vec<MemberSpec>,
    /// Elements of single bars by the bar's name (`link1/bar12` of a ground structure, a
    /// beam's name), overriding the `split` of its ground structure or beam: a
    /// discretization chosen bar by bar.
    #[serde(default)]
    pub splits: BTreeMap<String, usize>,
    /// Rigid bodies.
    #[serde(default, deserialize_with = "polled")]
    pub rigid_bodies: Vec<RigidBodySpec>,
    /// Interface rings on nodes: rigid (RBE2-type) or averaging (RBE3-type).
    #[serde(default, deserialize_with = "polled")]
    pub rings: Vec<RingSpec>,
    /// Point masses.
    #[serde(default, deserialize_with = "polled")]
    pub point_masses: Vec<PointMassSpec>,
    /// Nodal loads.
    #[serde(default, deserialize_with = "polled")]
    pub loads: Vec<LoadSpec>,
    /// Joints.
    #[serde(default, deserialize_with = "polled")]
    pub joints: Vec<JointSpec>,
    /// Springs.
    #[serde(default, deserialize_with = "polled")]
    pub springs: Vec<SpringSpec>,
    /// Motors.
    #[serde(default, deserialize_with = "polled")]
    pub motors: Vec<MotorSpec>,
    /// Design parametrization.
    #[serde(default)]
    pub design: DesignSpec,
    /// Default node of the tip-deflection response.
    #[serde(default)]
    pub tip: Option<String>,
    /// Default run settings (`t_end`, `h`, `rho_inf`, `tol`, `max_iter`, `mass`,
    /// `load_steps`); a run may override each.
    #[serde(default)]
    pub simulation: RunOptions,
}

/// A list read with [`crate::poll`] between its entries: reading a scene of many thousand
/// bodies or joints stops soon after the caller asks ([`crate::with_checker`]).
fn polled<'de, D, T>(deserializer: D) -> Result<Vec<T>, D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de>,
{
    struct Entries<T>(std::marker::PhantomData<T>);

    impl<'de, T: Deserialize<'de>> Visitor<'de> for Entries<T> {
        type Value = Vec<T>;

        fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
            f.write_str("a sequence")
        }

        fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Vec<T>, A::Error> {
            let mut entries = Vec::new();
            while let Some(entry) = seq.next_element()? {
                crate::poll().map_err(de::Error::custom)?;
                entries.push(entry);
            }
            Ok(entries)
        }
    }

    deserializer.deserialize_seq(Entries(std::marker::PhantomData))
}

/// How a dynamic run starts.
#[derive(Debug, Clone, Copy, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum InitialSpec {
    /// Undeformed and at rest.
    #[default]
    Rest,
    /// At rest in the static equilibrium of `t = 0`.
    Equilibrium,
}

/// Kind of analysis; `"linear"` here, a static analysis's own kind, is pointed to where it
/// belongs (`[simulation] analysis`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum AnalysisSpec {
    /// Time integration.
    #[default]
    Dynamic,
    /// Static equilibrium.
    Static,
}

impl<'de> Deserialize<'de> for AnalysisSpec {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let name = String::deserialize(d)?;
        match name.as_str() {
            "dynamic" => Ok(Self::Dynamic),
            "static" => Ok(Self::Static),
            "linear" | "nonlinear" => Err(de::Error::custom(format!(
                "unknown value `{name}`, expected `dynamic` or `static`: a static scene's \
                 {name} analysis is analysis = \"static\" here and analysis = \"{name}\" in \
                 its [simulation] table"
            ))),
            _ => Err(de::Error::unknown_variant(&name, &["dynamic", "static"])),
        }
    }
}

/// What a ground structure's or a beam's bars are made of.
#[derive(Debug, Clone, Copy, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum KindSpec {
    /// Timoshenko beams rigidly joined at the nodes: a frame.
    #[default]
    Frame,
    /// Pin-jointed truss bars, each one element carrying axial force only.
    Truss,
}

impl From<KindSpec> for Kind {
    fn from(kind: KindSpec) -> Self {
        match kind {
            KindSpec::Frame => Kind::Frame,
            KindSpec::Truss => Kind::Truss,
        }
    }
}

/// A beam section: material plus either a solid-circle `diameter` or `A`, `I`, `kappa`.
/// Give exactly one of `G` and `nu`.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
#[allow(non_snake_case)]
pub struct SectionSpec {
    /// Young's modulus (Pa).
    pub E: f64,
    /// Density (kg/m³).
    pub rho: f64,
    /// Shear modulus (Pa).
    pub G: Option<f64>,
    /// Poisson's ratio.
    pub nu: Option<f64>,
    /// Diameter of a solid circular section (m).
    pub diameter: Option<f64>,
    /// Area (m²).
    pub A: Option<f64>,
    /// Second moment of area (m⁴).
    pub I: Option<f64>,
    /// Shear correction factor.
    pub kappa: Option<f64>,
    /// Outer-fibre distance from the neutral axis (m), for bending stresses `M c / I`
    /// (a solid circle's is `diameter / 2`).
    pub c: Option<f64>,
    /// The largest shear stress over `V/A`, for shear stresses (3/2 for a rectangle; a solid
    /// circle's is 4/3).
    pub shear_factor: Option<f64>,
    /// Rayleigh damping `[α, β]` (1/s, s): `C = α M + β K` of the section's beams.
    pub rayleigh: Option<[f64; 2]>,
}

/// A named node.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct NodeSpec {
    /// Name.
    pub name: String,
    /// x (m).
    pub x: f64,
    /// y (m).
    pub y: f64,
}

/// A point given by coordinates or by the name of an existing node.
#[derive(Debug, Clone, PartialEq)]
pub enum PointSpec {
    /// `[x, y]` (m).
    Coordinates([f64; 2]),
    /// A node name.
    Node(String),
}

impl<'de> Deserialize<'de> for PointSpec {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        deserializer.deserialize_any(PointVisitor)
    }
}

/// Reads a [`PointSpec`] from a string or a sequence of two numbers, and names both in its
/// errors.
struct PointVisitor;

impl<'de> Visitor<'de> for PointVisitor {
    type Value = PointSpec;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a node's name or coordinates [x, y] in m")
    }

    fn visit_str<E: de::Error>(self, name: &str) -> Result<PointSpec, E> {
        Ok(PointSpec::Node(name.to_string()))
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<PointSpec, A::Error> {
        let mut xy = [0.0; 2];
        for (k, v) in xy.iter_mut().enumerate() {
            *v = seq
                .next_element()?
                .ok_or_else(|| de::Error::invalid_length(k, &self))?;
        }
        if seq.next_element::<de::IgnoredAny>()?.is_some() {
            return Err(de::Error::invalid_length(3, &self));
        }
        Ok(PointSpec::Coordinates(xy))
    }
}

impl Default for PointSpec {
    fn default() -> Self {
        Self::Coordinates([0.0, 0.0])
    }
}

/// A ground structure: an `nx × ny` grid over `length × height` in a local frame at `origin`
/// rotated by `angle`, with bars between every pair of nodes whose segment holds no third
/// node. Nodes are named `NAME[i,j]` (column `i`, row `j` from the bottom).
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct GroundStructureSpec {
    /// Name (also the component's name).
    pub name: String,
    /// Columns along the local x axis.
    pub nx: usize,
    /// Rows along the local y axis.
    pub ny: usize,
    /// Extent along local x (m).
    pub length: f64,
    /// Extent along local y (m), centred on the axis.
    pub height: f64,
    /// Position of the local origin.
    #[serde(default)]
    pub origin: PointSpec,
    /// Angle of the local x axis from the global x axis (rad), 0 if not given.
    #[serde(default)]
    pub angle: Option<f64>,
    /// The same angle in degrees, for scenes written by hand (instead of `angle`).
    #[serde(default)]
    pub angle_deg: Option<f64>,
    /// Section of every bar.
    pub section: String,
    /// Frame or truss.
    #[serde(default)]
    pub kind: KindSpec,
    /// Elements per bar (a truss bar is one).
    #[serde(default = "one")]
    pub split: usize,
    /// Bars at fixed full density (not design variables).
    #[serde(default)]
    pub fixed: bool,
    /// One rigid body with the frame's mass and inertia at full density instead of bars:
    /// a link not being designed, three unknowns; its grid nodes are the body's points.
    #[serde(default)]
    pub rigid: bool,
    /// Numbers `k` of bars `NAME/bar{k}` left out (a design as built, without its void
    /// bars); grid nodes that no remaining bar touches are left out too.
    #[serde(default)]
    pub omit: Vec<usize>,
}

/// A plane-stress continuum member: a `length × height` rectangle meshed by `nx × ny`
/// four-node quadrilaterals, in a local frame at `origin` rotated by `angle` (the rectangle
/// from `x = 0` to `length`, centred on the local x axis, as a ground structure's grid).
/// Nodes are named `NAME[i,j]` (column `i` in `0..=nx`, row `j` in `0..=ny` from the
/// bottom), cells' design variables `NAME/cell[i,j]`; the member is the component `NAME`.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
#[allow(non_snake_case)]
pub struct MemberSpec {
    /// Name (also the component's name).
    pub name: String,
    /// Cells along the local x axis.
    pub nx: usize,
    /// Cells along the local y axis.
    pub ny: usize,
    /// Elements per cell along each axis (1 if not given): each cell, one density, meshed
    /// by `split × split` elements, as a bar's `split` meshes it; a run to a tolerance
    /// refines a member by it.
    #[serde(default = "one")]
    pub split: usize,
    /// Extent along local x (m).
    pub length: f64,
    /// Extent along local y (m), centred on the axis.
    pub height: f64,
    /// Thickness (m).
    pub thickness: f64,
    /// Young's modulus (Pa).
    pub E: f64,
    /// Poisson's ratio.
    pub nu: f64,
    /// Density (kg/m³).
    pub rho: f64,
    /// Rayleigh damping `[α, β]` (1/s, s) of its cells: `C = αM + βK`, the stiffness
    /// part as Kelvin–Voigt on the Green–Lagrange strain rate.
    #[serde(default)]
    pub rayleigh: Option<[f64; 2]>,
    /// Its cells' strain: `enhanced` (default) or `plain`.
    #[serde(default)]
    pub cell: CellSpec,
    /// Its void cells' energy: `linear_energy` (default; each cell's energy blended
    /// between its nonlinear and its linear form by its density, Wang, Lazarov & Sigmund
    /// 2014, on its co-rotated displacement) or `nonlinear` (every cell fully nonlinear).
    #[serde(default)]
    pub void: VoidSpec,
    /// The density `η₁` about which the blend steps from linear to nonlinear (0.05 if not
    /// given), in (0, 1); with `void = "linear_energy"` only.
    #[serde(default)]
    pub void_threshold: Option<f64>,
    /// Position of the local origin.
    #[serde(default)]
    pub origin: PointSpec,
    /// Angle of the local x axis from the global x axis (rad), 0 if not given.
    #[serde(default)]
    pub angle: Option<f64>,
    /// The same angle in degrees (instead of `angle`).
    #[serde(default)]
    pub angle_deg: Option<f64>,
    /// Cells at fixed full density (not design variables).
    #[serde(default)]
    pub fixed: bool,
    /// Rectangles of cells `[i0, j0, i1, j1]`, half-open (columns `i0 ≤ i < i1`, rows
    /// `j0 ≤ j < j1`) left out: holes; a node no remaining cell touches is left out too.
    #[serde(default)]
    pub holes: Vec<[usize; 4]>,
    /// Rectangles of cells, as `holes`, at full density and not designed (passive solid,
    /// e.g. around a joint).
    #[serde(default)]
    pub solid: Vec<[usize; 4]>,
    /// Whether the cells around a node that a joint or a beam attaches to are passive solid
    /// (default), so that an optimizer cannot detach the joint.
    #[serde(default = "yes")]
    pub solid_at_joints: bool,
    /// With `solid_at_joints`, the cells whose centre lies within this distance (m) of such
    /// a node are passive solid too: a region in metres, the same on every mesh, where the
    /// cells touching the node are a region of one cell's size.
    #[serde(default)]
    pub solid_radius: Option<f64>,
}

/// How a member's void cells store energy.
#[derive(Debug, Clone, Copy, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum VoidSpec {
    /// Blended towards the linear energy as the density falls: they cannot turn inside out.
    #[default]
    LinearEnergy,
    /// Fully nonlinear at every density.
    Nonlinear,
}

/// Which strain a member's cells interpolate.
#[derive(Debug, Clone, Copy, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum CellSpec {
    /// Enhanced by four condensed incompatible modes: no locking in bending.
    #[default]
    Enhanced,
    /// The compatible bilinear strain alone (the 88-line code's element).
    Plain,
}

impl From<CellSpec> for CellKind {
    fn from(cell: CellSpec) -> Self {
        match cell {
            CellSpec::Enhanced => CellKind::Enhanced,
            CellSpec::Plain => CellKind::Plain,
        }
    }
}

/// A beam between two named nodes.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct BeamSpec {
    /// Name (default `beams[k]`).
    pub name: Option<String>,
    /// End nodes.
    pub nodes: [String; 2],
    /// Section.
    pub section: String,
    /// Frame or truss.
    #[serde(default)]
    pub kind: KindSpec,
    /// Elements in the bar (a truss bar is one).
    #[serde(default = "one")]
    pub split: usize,
    /// Component (default `frame`).
    pub component: Option<String>,
    /// Design group shared with other beams (default: a variable of its own).
    pub group: Option<String>,
    /// Fixed at full density.
    #[serde(default)]
    pub fixed: bool,
}

/// A planar rigid body: three coordinates, those of its centre of mass. Its node is
/// called `name`, its points `name.point`; joints attach to either.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RigidBodySpec {
    /// Name.
    pub name: String,
    /// Mass (kg).
    pub mass: f64,
    /// Rotary inertia about the centre of mass (kg m²).
    #[serde(default)]
    pub inertia: f64,
    /// Centre of mass `[x, y]` (m).
    pub position: [f64; 2],
    /// Angle of the body's frame from the global frame (rad), 0 if not given.
    #[serde(default)]
    pub angle: Option<f64>,
    /// The same angle in degrees (instead of `angle`).
    #[serde(default)]
    pub angle_deg: Option<f64>,
    /// Named points `[x, y]` in the body's frame, from its centre of mass (m).
    #[serde(default)]
    pub points: BTreeMap<String, [f64; 2]>,
}

/// A rigid interface ring (RBE2-type): its `nodes` (of a continuum member's hole or edge,
/// or of a frame) move as one rigid frame, whose centre is the node called `name` — joints,
/// springs, loads and point masses attach there as to a rigid body's centre. Built as a light
/// rigid body at `centre` (the nodes' mean if not given) hinged to each node (hinges
/// `name.0`, `name.1`, …, in the order of `nodes`).
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RingSpec {
    /// Name.
    pub name: String,
    /// The nodes that follow the ring: two or more, not all at one place.
    pub nodes: Vec<String>,
    /// The ring's centre `[x, y]` (m); the mean of its nodes if not given (an averaging
    /// ring's is their weighted mean).
    #[serde(default)]
    pub centre: Option<[f64; 2]>,
    /// How the ring holds its nodes.
    #[serde(default)]
    pub kind: RingKind,
    /// An averaging ring's weight of each node (positive; all equal if not given).
    #[serde(default)]
    pub weights: Option<Vec<f64>>,
}

/// How a ring holds its nodes.
#[derive(Debug, Clone, Copy, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum RingKind {
    /// RBE2-type: the nodes follow the ring's rigid frame.
    #[default]
    Rigid,
    /// RBE3-type: the ring's centre follows its nodes' weighted mean and least-squares
    /// rotation; the nodes stay free, the ring adds no stiffness.
    Averaging,
}

/// A linear spring and damper: between two points (`nodes`; `k` in N/m; rest `length`, the
/// reference distance if not given) or on a joint's own coordinate (`joint`; `k` in N m/rad
/// at a pin or hinge, N/m along a slider; `rest`, the reference (0) if not given; damping
/// `c`).
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SpringSpec {
    /// Name.
    pub name: String,
    /// The two nodes or rigid-body points it joins.
    pub nodes: Option<[String; 2]>,
    /// The joint whose coordinate it resists.
    pub joint: Option<String>,
    /// Stiffness (0 for a damper alone).
    #[serde(default)]
    pub k: f64,
    /// Damping (N s/m or N m s/rad), 0 if not given.
    #[serde(default)]
    pub c: f64,
    /// Rest length between points (m).
    pub length: Option<f64>,
    /// Rest value of a joint's coordinate (rad or m).
    pub rest: Option<f64>,
}

/// A motor on a joint's own coordinate (a pin, a hinge, a slider on a ground axis, none
/// driven): a constant `torque` (N m, or N on a slider), scaled by a `table` if given, or a
/// PD `servo` following a motion law.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MotorSpec {
    /// Name.
    pub name: String,
    /// The joint it turns (or pushes).
    pub joint: String,
    /// Constant torque (N m or N).
    pub torque: Option<f64>,
    /// Time scaling of `torque`.
    pub table: Option<LoadTableSpec>,
    /// A PD servo instead.
    pub servo: Option<ServoSpec>,
}

/// A PD servo: `τ = kp (θ_r − s) + kd (θ̇_r − ṡ)` following `motion` (`θ_r(t) − θ_r(0)`).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ServoSpec {
    /// Proportional gain (N m/rad or N/m).
    pub kp: f64,
    /// Derivative gain (N m s/rad or N s/m), 0 if not given.
    #[serde(default)]
    pub kd: f64,
    /// The reference motion law.
    pub motion: MotionSpec,
}

/// A point mass.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PointMassSpec {
    /// Node.
    pub node: String,
    /// Mass (kg).
    pub mass: f64,
    /// Rotary inertia (kg m²).
    #[serde(default)]
    pub inertia: f64,
}

/// A force and moment on a node, optionally scaled in time by a piecewise-linear table.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct LoadSpec {
    /// Node.
    pub node: String,
    /// Force `[F_x, F_y]` (N).
    #[serde(default)]
    pub force: [f64; 2],
    /// Moment (N m).
    #[serde(default)]
    pub moment: f64,
    /// Time scaling; constant when absent.
    pub table: Option<LoadTableSpec>,
}

/// Samples `(t, scale)` of a load's time history.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct LoadTableSpec {
    /// Times (s), strictly increasing.
    pub t: Vec<f64>,
    /// Scale factors.
    pub scale: Vec<f64>,
}

/// A joint.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(try_from = "JointEntry")]
pub enum JointSpec {
    /// Fixes a node's position and rotation.
    Clamp {
        /// Name.
        name: String,
        /// Node.
        node: String,
    },
    /// Fixes a node's position; `drive` prescribes its absolute rotation.
    Pin {
        /// Name.
        name: String,
        /// Node.
        node: String,
        /// Motion law of the rotation.
        drive: Option<MotionSpec>,
    },
    /// Keeps two coincident nodes together; `drive` prescribes `φ_b − φ_a`.
    Hinge {
        /// Name.
        name: String,
        /// `[a, b]`.
        nodes: [String; 2],
        /// Motion law of the relative rotation.
        drive: Option<MotionSpec>,
    },
    /// Keeps two coincident nodes together with their relative rotation locked.
    Weld {
        /// Name.
        name: String,
        /// `[a, b]`.
        nodes: [String; 2],
    },
    /// A slider: `nodes[1]` moves along `axis` carried by `nodes[0]`, or along an axis
    /// fixed on the ground with `node`; relative rotation locked; `drive` prescribes the
    /// travel (m).
    Prismatic {
        /// Name.
        name: String,
        /// `[carrier, slider]`; the carrier is `None` for the ground.
        nodes: [Option<String>; 2],
        /// Direction of the axis `[x, y]` at the reference (any length but zero).
        axis: [f64; 2],
        /// Motion law of the travel along the axis (m).
        drive: Option<MotionSpec>,
    },
    /// A roller support: `node` moves along `axis` through its position on the ground, its
    /// rotation free; `drive` prescribes the travel (m).
    Roller {
        /// Name.
        name: String,
        /// Node or rigid-body point.
        node: String,
        /// Direction of the axis `[x, y]` (any length but zero).
        axis: [f64; 2],
        /// Motion law of the travel along the axis (m).
        drive: Option<MotionSpec>,
    },
}

impl JointSpec {
    /// The names of the nodes or rigid-body points the joint acts on.
    pub fn anchors(&self) -> Vec<&str> {
        match self {
            Self::Clamp { node, .. } | Self::Pin { node, .. } | Self::Roller { node, .. } => {
                vec![node]
            }
            Self::Hinge { nodes, .. } | Self::Weld { nodes, .. } => {
                nodes.iter().map(String::as_str).collect()
            }
            Self::Prismatic { nodes, .. } => nodes.iter().flatten().map(String::as_str).collect(),
        }
    }
}

/// A joint as written: every key a joint of any kind may have. Read as a plain struct, so
/// that errors inside it keep their path (`joints[0].drive.acceleration`); [`JointSpec`]
/// then checks the keys its kind takes.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct JointEntry {
    kind: JointKind,
    name: String,
    node: Option<String>,
    nodes: Option<[String; 2]>,
    drive: Option<MotionSpec>,
    axis: Option<[f64; 2]>,
    axis_deg: Option<f64>,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "snake_case")]
enum JointKind {
    Clamp,
    Pin,
    Hinge,
    Weld,
    Prismatic,
    Roller,
}

impl TryFrom<JointEntry> for JointSpec {
    type Error = String;

    fn try_from(e: JointEntry) -> Result<Self, String> {
        let JointEntry {
            kind,
            name,
            node,
            nodes,
            drive,
            axis,
            axis_deg,
        } = e;
        let along = matches!(kind, JointKind::Prismatic | JointKind::Roller);
        let axis = match (along, axis, axis_deg) {
            (true, Some(_), Some(_)) => {
                return Err("give `axis` [x, y] or `axis_deg`, not both".into())
            }
            (true, Some(axis), None) => axis,
            (true, None, Some(deg)) => {
                let (s, c) = deg.to_radians().sin_cos();
                [c, s]
            }
            (true, None, None) => {
                return Err(
                    "a prismatic joint or a roller needs its `axis` [x, y] or `axis_deg`".into(),
                )
            }
            (false, None, None) => [0.0; 2],
            _ => return Err("only a prismatic joint or a roller takes an `axis`".into()),
        };
        match (kind, node, nodes, drive) {
            (JointKind::Clamp, _, _, Some(_)) => {
                Err("a clamp has no drive (a pin's drive prescribes a rotation)".into())
            }
            (JointKind::Weld, _, _, Some(_)) => {
                Err("a weld has no drive (a hinge's drive prescribes a rotation)".into())
            }
            (JointKind::Clamp, Some(node), None, None) => Ok(Self::Clamp { name, node }),
            (JointKind::Pin, Some(node), None, drive) => Ok(Self::Pin { name, node, drive }),
            (JointKind::Hinge, None, Some(nodes), drive) => Ok(Self::Hinge { name, nodes, drive }),
            (JointKind::Weld, None, Some(nodes), None) => Ok(Self::Weld { name, nodes }),
            (JointKind::Prismatic | JointKind::Roller, _, _, Some(drive)) if drive.in_degrees() => {
                Err("the drive of a prismatic joint or a roller is a travel in m: it takes no `_deg` keys".into())
            }
            (JointKind::Roller, Some(node), None, drive) => Ok(Self::Roller {
                name,
                node,
                axis,
                drive,
            }),
            (JointKind::Roller, ..) => Err("a roller takes one `node`, not `nodes`".into()),
            (JointKind::Prismatic, Some(node), None, drive) => Ok(Self::Prismatic {
                name,
                nodes: [None, Some(node)],
                axis,
                drive,
            }),
            (JointKind::Prismatic, None, Some([a, b]), drive) => Ok(Self::Prismatic {
                name,
                nodes: [Some(a), Some(b)],
                axis,
                drive,
            }),
            (JointKind::Prismatic, ..) => Err(
                "a prismatic joint takes `node` (a slider on the ground) or `nodes` [carrier, slider]".into(),
            ),
            (JointKind::Hinge, ..) => Err("a hinge takes two `nodes` [a, b], not `node`".into()),
            (JointKind::Weld, ..) => Err("a weld takes two `nodes` [a, b], not `node`".into()),
            (JointKind::Clamp, ..) => Err("a clamp takes one `node`, not `nodes`".into()),
            (JointKind::Pin, ..) => Err("a pin takes one `node`, not `nodes`".into()),
        }
    }
}

/// A motion law `θ(t)`; the joint follows `θ(t) − θ(0)`.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(try_from = "MotionEntry")]
pub enum MotionSpec {
    /// Trapezoidal velocity profile from `start` to `end` (rad).
    Trapezoidal {
        /// Initial angle (rad).
        start: f64,
        /// Final angle (rad).
        end: f64,
        /// Acceleration and deceleration (rad/s²).
        acceleration: f64,
        /// Cruise speed (rad/s).
        speed: f64,
        /// Start time (s), 0 if not given.
        t_start: f64,
        /// Whether a value was given in degrees (`NAME_deg`).
        degrees: bool,
    },
    /// Clamped cubic spline through `(t, theta)`.
    Table {
        /// Times (s), strictly increasing.
        t: Vec<f64>,
        /// Angles (rad).
        theta: Vec<f64>,
        /// Velocity before the table (rad/s), 0 if not given.
        start_velocity: f64,
        /// Velocity after the table (rad/s), 0 if not given.
        end_velocity: f64,
        /// Whether a value was given in degrees (`NAME_deg`).
        degrees: bool,
    },
}

impl MotionSpec {
    /// Whether a value of the law was given in degrees.
    pub fn in_degrees(&self) -> bool {
        match self {
            Self::Trapezoidal { degrees, .. } | Self::Table { degrees, .. } => *degrees,
        }
    }
}

/// A motion law as written: every key of any kind, checked by [`MotionSpec`] (read as a
/// plain struct for the same reason as [`JointEntry`]).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MotionEntry {
    kind: MotionKind,
    start: Option<f64>,
    end: Option<f64>,
    acceleration: Option<f64>,
    speed: Option<f64>,
    t_start: Option<f64>,
    t: Option<Vec<f64>>,
    theta: Option<Vec<f64>>,
    start_velocity: Option<f64>,
    end_velocity: Option<f64>,
    start_deg: Option<f64>,
    end_deg: Option<f64>,
    acceleration_deg: Option<f64>,
    speed_deg: Option<f64>,
    theta_deg: Option<Vec<f64>>,
    start_velocity_deg: Option<f64>,
    end_velocity_deg: Option<f64>,
}

impl MotionEntry {
    /// The entry with every `NAME_deg` key (degrees, for laws written by hand) turned into
    /// `NAME` in radians; both for one quantity is an error.
    fn in_radians(mut self) -> Result<Self, String> {
        let one = |name: &str, rad: Option<f64>, deg: Option<f64>| match (rad, deg) {
            (Some(_), Some(_)) => Err(format!("give `{name}` (rad) or `{name}_deg`, not both")),
            (rad, deg) => Ok(rad.or(deg.map(f64::to_radians))),
        };
        for (name, rad, deg) in [
            ("start", &mut self.start, &mut self.start_deg),
            ("end", &mut self.end, &mut self.end_deg),
            (
                "acceleration",
                &mut self.acceleration,
                &mut self.acceleration_deg,
            ),
            ("speed", &mut self.speed, &mut self.speed_deg),
            (
                "start_velocity",
                &mut self.start_velocity,
                &mut self.start_velocity_deg,
            ),
            (
                "end_velocity",
                &mut self.end_velocity,
                &mut self.end_velocity_deg,
            ),
        ] {
            *rad = one(name, *rad, deg.take())?;
        }
        self.theta = match (self.theta, self.theta_deg.take()) {
            (Some(_), Some(_)) => return Err("give `theta` (rad) or `theta_deg`, not both".into()),
            (rad, deg) => rad.or(deg.map(|d| d.into_iter().map(f64::to_radians).collect())),
        };
        Ok(self)
    }
}

#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "snake_case")]
enum MotionKind {
    Trapezoidal,
    Table,
}

impl TryFrom<MotionEntry> for MotionSpec {
    type Error = String;

    fn try_from(e: MotionEntry) -> Result<Self, String> {
        let degrees = [
            e.start_deg,
            e.end_deg,
            e.acceleration_deg,
            e.speed_deg,
            e.start_velocity_deg,
            e.end_velocity_deg,
        ]
        .iter()
        .any(Option::is_some)
            || e.theta_deg.is_some();
        let e = e.in_radians()?;
        let given = |name: &'static str, present: bool| present.then_some(name);
        match e.kind {
            MotionKind::Trapezoidal => {
                let what = "a trapezoidal law";
                let table_keys = [
                    given("t", e.t.is_some()),
                    given("theta", e.theta.is_some()),
                    given("start_velocity", e.start_velocity.is_some()),
                    given("end_velocity", e.end_velocity.is_some()),
                ];
                refuse_foreign(what, &table_keys)?;
                let need = |name, v: Option<f64>| {
                    v.ok_or_else(|| {
                        format!("{what} needs `{name}` (start, end, acceleration, speed)")
                    })
                };
                Ok(Self::Trapezoidal {
                    start: need("start", e.start)?,
                    end: need("end", e.end)?,
                    acceleration: need("acceleration", e.acceleration)?,
                    speed: need("speed", e.speed)?,
                    t_start: e.t_start.unwrap_or(0.0),
                    degrees,
                })
            }
            MotionKind::Table => {
                let trapezoidal_keys = [
                    given("start", e.start.is_some()),
                    given("end", e.end.is_some()),
                    given("acceleration", e.acceleration.is_some()),
                    given("speed", e.speed.is_some()),
                    given("t_start", e.t_start.is_some()),
                ];
                refuse_foreign("a table", &trapezoidal_keys)?;
                let need = |name, v: Option<Vec<f64>>| {
                    v.ok_or_else(|| format!("a table needs `{name}` (t and theta)"))
                };
                Ok(Self::Table {
                    t: need("t", e.t)?,
                    theta: need("theta", e.theta)?,
                    start_velocity: e.start_velocity.unwrap_or(0.0),
                    end_velocity: e.end_velocity.unwrap_or(0.0),
                    degrees,
                })
            }
        }
    }
}

/// An error naming the keys given (`Some`) that `what` does not take, if any.
fn refuse_foreign(what: &str, keys: &[Option<&str>]) -> Result<(), String> {
    let keys: Vec<String> = keys.iter().flatten().map(|k| format!("`{k}`")).collect();
    if keys.is_empty() {
        Ok(())
    } else {
        Err(format!("{what} does not take {}", keys.join(", ")))
    }
}

/// Design parametrization: SIMP exponent `p` or RAMP parameter `q`, lower bound `x_min`.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct DesignSpec {
    /// `"simp"` (default) or `"ramp"`.
    #[serde(default)]
    pub interpolation: InterpolationSpec,
    /// SIMP exponent (default 3).
    pub p: Option<f64>,
    /// RAMP parameter (default 8).
    pub q: Option<f64>,
    /// SIMP's stiffness of void `E_min/E` in `E_min + (E − E_min) xᵖ` (default 0).
    pub e_min: Option<f64>,
    /// Lower bound on densities (default 0.01).
    #[serde(default = "default_x_min")]
    pub x_min: f64,
    /// Inertia law: `"du_olhoff"` (default of dynamic scenes) or `"linear"` (the paper's
    /// law; default of static scenes).
    pub mass: Option<MassSpec>,
    /// Density below which the Du–Olhoff mass falls like `x⁶` (default 0.1).
    pub mass_threshold: Option<f64>,
    /// Floor `c` of the Du–Olhoff mass, `m ≥ c x` (default 1e-3).
    pub mass_floor: Option<f64>,
}

impl Default for DesignSpec {
    fn default() -> Self {
        Self {
            interpolation: InterpolationSpec::Simp,
            p: None,
            q: None,
            e_min: None,
            x_min: default_x_min(),
            mass: None,
            mass_threshold: None,
            mass_floor: None,
        }
    }
}

/// Stiffness interpolation law.
#[derive(Debug, Clone, Copy, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum InterpolationSpec {
    /// `xᵖ`.
    #[default]
    Simp,
    /// `x / (1 + q(1 − x))`.
    Ramp,
}

/// Inertia interpolation law.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum MassSpec {
    /// `m = x` (the paper's law).
    Linear,
    /// `m = x` above the threshold, `x r⁵(6 − 5r)` below.
    DuOlhoff,
}

fn yes() -> bool {
    true
}

fn one() -> usize {
    1
}

fn default_x_min() -> f64 {
    0.01
}
