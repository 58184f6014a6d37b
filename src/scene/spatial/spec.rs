//! A spatial scene as data: what a TOML file with `dimension = 3` or the Python
//! `SpatialScene` builder holds. Every table rejects unknown keys; values are checked as the
//! scene is built ([`super::build()`]), each error naming its entry. Units: SI; points and
//! axes in the inertial frame unless a key says otherwise.

use std::collections::BTreeMap;
use std::fmt;

use serde::de::{self, Deserializer, SeqAccess, Visitor};
use serde::Deserialize;

use crate::scene::spec::{AnalysisSpec, DesignSpec, KindSpec, LoadTableSpec, MotionSpec};
use crate::settings::RunOptions;

/// A whole spatial scene.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SpatialSceneSpec {
    /// Name of the scene.
    #[serde(default)]
    pub name: String,
    /// Must be 3: what marks a scene as spatial.
    pub dimension: u8,
    /// `"dynamic"` (default) or `"static"`.
    #[serde(default)]
    pub analysis: AnalysisSpec,
    /// Gravity `[g_x, g_y, g_z]` (m/s²); none by default.
    #[serde(default)]
    pub gravity: Option<[f64; 3]>,
    /// Named beam sections.
    #[serde(default)]
    pub sections: BTreeMap<String, SpatialSectionSpec>,
    /// Rigid bodies.
    #[serde(default)]
    pub rigid_bodies: Vec<SpatialBodySpec>,
    /// Nodes: beams' and bars' ends.
    #[serde(default)]
    pub nodes: Vec<SpatialNodeSpec>,
    /// Beams and truss bars between nodes.
    #[serde(default)]
    pub beams: Vec<SpatialBeamSpec>,
    /// Box lattices of bars over links ([`super::lattice`]).
    #[serde(default)]
    pub ground_structures: Vec<SpatialGroundStructureSpec>,
    /// Point masses on nodes.
    #[serde(default)]
    pub point_masses: Vec<SpatialPointMassSpec>,
    /// Joints between anchors.
    #[serde(default)]
    pub joints: Vec<SpatialJointSpec>,
    /// Spring-dampers between anchors.
    #[serde(default)]
    pub springs: Vec<SpatialSpringSpec>,
    /// Motors on revolute joints.
    #[serde(default)]
    pub motors: Vec<SpatialMotorSpec>,
    /// Loads at anchors.
    #[serde(default)]
    pub loads: Vec<SpatialLoadSpec>,
    /// The design: one density per beam (or group of beams) unless `fixed`, its laws.
    #[serde(default)]
    pub design: DesignSpec,
    /// The body or node whose final position is the default response.
    #[serde(default)]
    pub tip: Option<String>,
    /// Elements of frame beams by name (a ground structure's bars are `NAME/barK`), in place
    /// of their `split`: how a refinement bar by bar grades them, as a planar scene's
    /// `splits`.
    #[serde(default)]
    pub splits: BTreeMap<String, usize>,
    /// Default run settings, as a planar scene's.
    #[serde(default)]
    pub simulation: RunOptions,
}

/// A rotation: `axis` and `angle` (rad) or `angle_deg`, or a rotation `matrix` (rows), whose
/// columns are the frame's axes in the inertial frame.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct OrientationSpec {
    /// Axis of the rotation (any length but zero).
    pub axis: Option<[f64; 3]>,
    /// Angle about `axis` (rad).
    pub angle: Option<f64>,
    /// Angle about `axis` (degrees).
    pub angle_deg: Option<f64>,
    /// The rotation matrix, row by row: orthonormal, determinant +1.
    pub matrix: Option<[[f64; 3]; 3]>,
}

/// A beam section: material and shape.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
#[allow(non_snake_case)]
pub struct SpatialSectionSpec {
    /// Young's modulus (Pa).
    pub E: f64,
    /// Density (kg/m³).
    pub rho: f64,
    /// Poisson's ratio (`G = E / 2(1 + ν)`).
    pub nu: f64,
    /// `"circle"` (`diameter`), `"tube"` (`outer`, `inner`) or `"rectangle"` (`width`
    /// along the section's `e₂`, `height` along `e₃`).
    pub shape: ShapeSpec,
    /// A circle's diameter (m).
    pub diameter: Option<f64>,
    /// A tube's outer diameter (m).
    pub outer: Option<f64>,
    /// A tube's inner diameter (m).
    pub inner: Option<f64>,
    /// A rectangle's width along `e₂` (m).
    pub width: Option<f64>,
    /// A rectangle's height along `e₃` (m).
    pub height: Option<f64>,
    /// Rayleigh damping `[α, β]` (1/s, s): `C = α M + β K`.
    pub rayleigh: Option<[f64; 2]>,
}

/// A section's shape.
#[derive(Debug, Clone, Copy, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum ShapeSpec {
    /// Solid circle.
    #[default]
    Circle,
    /// Hollow circle.
    Tube,
    /// Rectangle.
    Rectangle,
}

/// A rigid body: its centre of mass at `position`, its axes at `orientation`.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SpatialBodySpec {
    /// Name.
    pub name: String,
    /// Mass (kg).
    pub mass: f64,
    /// Principal moments `[I₁₁, I₂₂, I₃₃]` about the centre of mass in the body's axes
    /// (kg m²).
    pub inertia: [f64; 3],
    /// Products `[I₁₂, I₁₃, I₂₃]` (kg m²) where the axes are not principal.
    #[serde(default)]
    pub products: [f64; 3],
    /// Centre of mass (m).
    pub position: [f64; 3],
    /// Axes (identity by default).
    pub orientation: Option<OrientationSpec>,
    /// Named points in the body's axes from its centre of mass (m).
    #[serde(default)]
    pub points: BTreeMap<String, [f64; 3]>,
    /// Initial velocity of the centre of mass (m/s).
    #[serde(default)]
    pub velocity: [f64; 3],
    /// Initial angular velocity in the inertial frame (rad/s).
    #[serde(default)]
    pub angular_velocity: [f64; 3],
}

/// A node: a beam's or bar's end.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SpatialNodeSpec {
    /// Name.
    pub name: String,
    /// Position (m).
    pub position: [f64; 3],
    /// The node's axes (identity by default).
    pub orientation: Option<OrientationSpec>,
    /// Initial velocity (m/s).
    #[serde(default)]
    pub velocity: [f64; 3],
    /// Initial angular velocity in the inertial frame (rad/s).
    #[serde(default)]
    pub angular_velocity: [f64; 3],
}

/// A beam (or a truss bar) between two nodes, in `split` elements.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SpatialBeamSpec {
    /// Name; its inner nodes are `NAME[1]` … `NAME[split − 1]`.
    pub name: String,
    /// End nodes.
    pub nodes: [String; 2],
    /// Section name.
    pub section: String,
    /// `"frame"` (default) or `"truss"`.
    #[serde(default)]
    pub kind: KindSpec,
    /// Elements along the beam (1 by default; a truss bar has one).
    #[serde(default = "one")]
    pub split: usize,
    /// A direction across the beam: its section's `e₂` is the part of `up` normal to the
    /// beam (default: the inertial `z`, or `y` for a beam along `z`).
    pub up: Option<[f64; 3]>,
    /// Design group shared with other beams (default: a variable of its own).
    pub group: Option<String>,
    /// At full density, not designed.
    #[serde(default)]
    pub fixed: bool,
}

/// Which lattice pairs a ground structure joins (`lattice`'s docs).
#[derive(Debug, Clone, Copy, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Connectivity {
    /// Every bar that overlaps no other.
    #[default]
    Full,
    /// Edges, face and body diagonals.
    Diagonals,
    /// Edges and face diagonals.
    Faces,
    /// Edges.
    Edges,
}

impl fmt::Display for Connectivity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Full => "full",
            Self::Diagonals => "diagonals",
            Self::Faces => "faces",
            Self::Edges => "edges",
        })
    }
}

/// A box lattice of bars over a link (`lattice`'s docs).
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SpatialGroundStructureSpec {
    /// Name: the component, its nodes' and bars' prefix.
    pub name: String,
    /// Nodes along the length.
    pub nx: usize,
    /// Nodes across the height.
    pub ny: usize,
    /// Nodes across the width (1: a planar lattice).
    #[serde(default = "one")]
    pub nz: usize,
    /// Length along the local x (m).
    pub length: f64,
    /// Height along the local y (m).
    pub height: f64,
    /// Width along the local z (m); 0 for a single layer.
    #[serde(default)]
    pub width: f64,
    /// Which pairs are joined.
    #[serde(default)]
    pub connectivity: Connectivity,
    /// The local frame's origin: the lattice's `x = 0` face centre (m).
    #[serde(default)]
    pub origin: [f64; 3],
    /// The local frame's axes (identity by default).
    pub orientation: Option<OrientationSpec>,
    /// Every bar's section.
    pub section: String,
    /// `"frame"` (default) or `"truss"`.
    #[serde(default)]
    pub kind: KindSpec,
    /// Elements per frame bar.
    #[serde(default = "one")]
    pub split: usize,
    /// At full density, not designed.
    #[serde(default)]
    pub fixed: bool,
}

fn one() -> usize {
    1
}

/// A point mass on a node.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SpatialPointMassSpec {
    /// Name (a body's: its mass is a parameter, its position a response).
    pub name: String,
    /// Node.
    pub node: String,
    /// Mass (kg).
    pub mass: f64,
}

/// Where a joint, spring or load acts: `"BODY"` (its centre of mass), `"BODY.POINT"`,
/// `"NODE"`, `"ground"`, or a point of the ground `[x, y, z]` (m).
#[derive(Debug, Clone, PartialEq)]
pub enum AnchorSpec {
    /// By name.
    Named(String),
    /// A point of the ground.
    Ground([f64; 3]),
}

impl Default for AnchorSpec {
    fn default() -> Self {
        Self::Named("ground".into())
    }
}

impl<'de> Deserialize<'de> for AnchorSpec {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct Anchor;

        impl<'de> Visitor<'de> for Anchor {
            type Value = AnchorSpec;

            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str(
                    "a name (\"BODY\", \"BODY.POINT\", \"NODE\", \"ground\") or a point [x, y, z]",
                )
            }

            fn visit_str<E: de::Error>(self, v: &str) -> Result<AnchorSpec, E> {
                Ok(AnchorSpec::Named(v.to_string()))
            }

            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<AnchorSpec, A::Error> {
                let mut p = [0.0; 3];
                for (i, c) in p.iter_mut().enumerate() {
                    *c = seq
                        .next_element()?
                        .ok_or_else(|| de::Error::invalid_length(i, &self))?;
                }
                if seq.next_element::<f64>()?.is_some() {
                    return Err(de::Error::invalid_length(4, &self));
                }
                Ok(AnchorSpec::Ground(p))
            }
        }

        deserializer.deserialize_any(Anchor)
    }
}

/// A joint's kind.
#[derive(Debug, Clone, Copy, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum JointKindSpec {
    /// Points coincide.
    #[default]
    Spherical,
    /// Points coincide; turns about `axis`.
    Revolute,
    /// Points coincide; turns about `axes[0]` (on A) and `axes[1]` (on B).
    Universal,
    /// Slides along and turns about `axis`.
    Cylindrical,
    /// Slides along `axis`.
    Prismatic,
    /// Holds everything.
    Weld,
}

/// A joint between anchors `a` and `b` (the ground by default, where `a` is).
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SpatialJointSpec {
    /// Name.
    pub name: String,
    /// Kind.
    pub kind: JointKindSpec,
    /// First anchor (a prismatic or cylindrical joint's axis is carried by it).
    pub a: AnchorSpec,
    /// Second anchor.
    #[serde(default)]
    pub b: AnchorSpec,
    /// A revolute, cylindrical or prismatic joint's axis.
    pub axis: Option<[f64; 3]>,
    /// A universal joint's axes, on A and on B, at right angles.
    pub axes: Option<[[f64; 3]; 2]>,
    /// A revolute joint's angle (rad) or a prismatic joint's travel (m) in time.
    pub drive: Option<MotionSpec>,
}

/// A spring-damper between two anchors, or a torsion spring-damper on a revolute or
/// cylindrical `joint`'s angle.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SpatialSpringSpec {
    /// Name.
    pub name: String,
    /// First anchor.
    pub a: Option<AnchorSpec>,
    /// Second anchor.
    pub b: Option<AnchorSpec>,
    /// The joint whose angle a torsion spring resists (instead of `a` and `b`).
    pub joint: Option<String>,
    /// Stiffness (N/m, or N m/rad on a joint).
    #[serde(default)]
    pub k: f64,
    /// Damping (N s/m, or N m s/rad on a joint).
    #[serde(default)]
    pub c: f64,
    /// Rest length (m); the initial distance by default.
    pub length: Option<f64>,
    /// A torsion spring's rest angle from where the joint is built (rad, 0 by default).
    pub rest: Option<f64>,
}

/// A motor on a revolute joint.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SpatialMotorSpec {
    /// Name.
    pub name: String,
    /// The revolute joint.
    pub joint: String,
    /// Torque about the axis on the joint's `b` (N m).
    pub torque: f64,
    /// Time scaling; constant when absent.
    pub table: Option<LoadTableSpec>,
}

/// A force and moment at an anchor.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SpatialLoadSpec {
    /// Name.
    pub name: String,
    /// Where it acts.
    pub at: AnchorSpec,
    /// Force (N).
    #[serde(default)]
    pub force: [f64; 3],
    /// Moment (N m).
    #[serde(default)]
    pub moment: [f64; 3],
    /// Whether it turns with what it acts on (its values then in its axes).
    #[serde(default)]
    pub follower: bool,
    /// Time scaling; constant when absent.
    pub table: Option<LoadTableSpec>,
}
