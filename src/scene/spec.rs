//! The scene description as data: what a TOML scene file or the Python builder holds.
//!
//! Every table rejects unknown keys. Values are checked when the scene is built
//! ([`crate::scene::build()`]), where each error names its entry. Units: SI.

use std::collections::BTreeMap;

use serde::Deserialize;

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
    /// Gravity acceleration `[g_x, g_y]` (m/s²); none by default.
    #[serde(default)]
    pub gravity: Option<[f64; 2]>,
    /// Named beam sections.
    #[serde(default)]
    pub sections: BTreeMap<String, SectionSpec>,
    /// Free-standing nodes.
    #[serde(default)]
    pub nodes: Vec<NodeSpec>,
    /// Ground structures (one linkage each).
    #[serde(default)]
    pub ground_structures: Vec<GroundStructureSpec>,
    /// Individual beams between named nodes.
    #[serde(default)]
    pub beams: Vec<BeamSpec>,
    /// Point masses.
    #[serde(default)]
    pub point_masses: Vec<PointMassSpec>,
    /// Nodal loads.
    #[serde(default)]
    pub loads: Vec<LoadSpec>,
    /// Joints.
    #[serde(default)]
    pub joints: Vec<JointSpec>,
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

/// Kind of analysis.
#[derive(Debug, Clone, Copy, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum AnalysisSpec {
    /// Time integration.
    #[default]
    Dynamic,
    /// Static equilibrium.
    Static,
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
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(untagged)]
pub enum PointSpec {
    /// `[x, y]` (m).
    Coordinates([f64; 2]),
    /// A node name.
    Node(String),
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
    /// Angle of the local x axis from the global x axis (rad).
    #[serde(default)]
    pub angle: f64,
    /// Section of every bar.
    pub section: String,
    /// Elements per bar.
    #[serde(default = "one")]
    pub split: usize,
    /// Bars at fixed full density (not design variables).
    #[serde(default)]
    pub fixed: bool,
    /// Numbers `k` of bars `NAME/bar{k}` left out (a design as built, without its void
    /// bars); grid nodes that no remaining bar touches are left out too.
    #[serde(default)]
    pub omit: Vec<usize>,
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
    /// Elements in the bar.
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
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
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
}

/// A motion law `θ(t)`; the joint follows `θ(t) − θ(0)`.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
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
        /// Start time (s).
        #[serde(default)]
        t_start: f64,
    },
    /// Clamped cubic spline through `(t, theta)`.
    Table {
        /// Times (s), strictly increasing.
        t: Vec<f64>,
        /// Angles (rad).
        theta: Vec<f64>,
        /// Velocity before the table (rad/s).
        #[serde(default)]
        start_velocity: f64,
        /// Velocity after the table (rad/s).
        #[serde(default)]
        end_velocity: f64,
    },
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

fn one() -> usize {
    1
}

fn default_x_min() -> f64 {
    0.01
}
