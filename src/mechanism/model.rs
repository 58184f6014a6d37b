//! A built, validated mechanism: nodes, beam elements, rigid bodies, springs, point masses, joints, loads, design
//! variables and components. Produced by [`crate::scene`]; read by the solvers.
//!
//! Generalized coordinates: three per node, `q = [u, v, φ]`, the displacement and rotation
//! of the node from its reference position `X` in the inertial frame (absolute nodal
//! coordinates `x = X + u`; storing the displacement keeps round-off proportional to the
//! motion rather than to the position). Constraint multipliers follow the `n_q` DOFs.

use nalgebra::Vector2;

use crate::body::planar::{PointMass, RigidBody};
use crate::error::{DesignError, SolveError};
use crate::joint::planar::{ConstraintRow, Joint};
use crate::mechanism::averaging::Averaging;
use crate::mechanism::bar_mass::BarMass;
use crate::mechanism::element::quad::{Quad, Vector8};
use crate::mechanism::element::void::EnergyInterpolation;
use crate::mechanism::element::{Formulation, Kind, Vector6};
use crate::mechanism::interpolation::{Interpolation, MassLaw};
use crate::mechanism::load::NodalLoad;
use crate::mechanism::motor::Motor;
use crate::mechanism::rows::{Constraints, RowDofs};
use crate::mechanism::section::NamedSection;
use crate::mechanism::spring::{Measure, Spring};
use crate::settings::{MassKind, RunOptions};

/// A node of the mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct Node {
    /// Name, e.g. `link1[4,1]`.
    pub name: String,
    /// Reference position `X` (m).
    pub position: Vector2<f64>,
}

/// An element placed in the mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct Element {
    /// The element at full density, read through [`crate::mechanism::element::Kernel`].
    pub kernel: Formulation,
    /// End nodes.
    pub nodes: [usize; 2],
    /// The bar it belongs to.
    pub bar: usize,
}

impl Element {
    /// The six global DOFs `[3a, 3a+1, 3a+2, 3b, 3b+1, 3b+2]`.
    pub fn dofs(&self) -> [usize; 6] {
        let [a, b] = self.nodes;
        [3 * a, 3 * a + 1, 3 * a + 2, 3 * b, 3 * b + 1, 3 * b + 2]
    }

    /// Section forces `[N, M₁, M₂]` at state `q` with stiffness scaling `s(x)`.
    pub fn section_forces(&self, stiffness: f64, q: &[f64]) -> [f64; 3] {
        let f = self.kernel.section_forces(&self.gather(q));
        [stiffness * f[0], stiffness * f[1], stiffness * f[2]]
    }

    /// The element's slice of a global vector.
    pub fn gather(&self, q: &[f64]) -> Vector6 {
        Vector6::from_iterator(self.dofs().iter().map(|&d| q[d]))
    }
}

/// A quadrilateral of a continuum member, with its own density.
#[derive(Debug, Clone, PartialEq)]
pub struct Cell {
    /// The quadrilateral at full density.
    pub kernel: Quad,
    /// Its corners, anticlockwise.
    pub nodes: [usize; 4],
    /// The member it belongs to.
    pub member: usize,
    /// Design variable, `None` for a cell of fixed full density.
    pub variable: Option<usize>,
    /// Its energy blended between the nonlinear and the linear form by its density
    /// ([`crate::mechanism::element::void`]), or `None`: nonlinear at every density.
    pub void: Option<EnergyInterpolation>,
}

impl Cell {
    /// The eight global DOFs, the corners' translations `[3a, 3a+1, 3b, 3b+1, …]`.
    pub fn dofs(&self) -> [usize; 8] {
        std::array::from_fn(|k| 3 * self.nodes[k / 2] + k % 2)
    }

    /// The cell's slice of a global vector.
    pub fn gather(&self, q: &[f64]) -> Vector8 {
        Vector8::from_iterator(self.dofs().iter().map(|&d| q[d]))
    }

    /// What the cell carries at displacements `q` with stiffness factor `s(x)`: the von
    /// Mises stress (Pa), the volume mean over its Gauss points of `s(x)` times the solid's
    /// at the cell's strain, and its strain energy `s(x) U` (J).
    pub fn stress_and_energy(&self, stiffness: f64, blend: f64, q: &[f64]) -> [f64; 2] {
        let u = self.gather(q);
        let stress: f64 = self.kernel.von_mises(&u).iter().map(|(s, w)| s * w).sum();
        [
            stiffness * stress,
            stiffness * self.kernel.blended(blend).strain_energy(&u),
        ]
    }

    /// The blend `γ(x)` of its energy and its rate `γ'(x)` at density `x` (`(1, 0)` for a
    /// cell whose energy is not interpolated).
    pub fn blend(&self, x: f64) -> (f64, f64) {
        self.void
            .map_or((1.0, 0.0), |law| (law.blend(x), law.blend_rate(x)))
    }
}

/// A plane-stress continuum member: a structured mesh of quadrilateral cells, each with a
/// density.
#[derive(Debug, Clone, PartialEq)]
pub struct Member {
    /// Name, e.g. `link1`; its nodes are `NAME[i,j]`, its cells' variables `NAME/cell[i,j]`.
    pub name: String,
    /// Component (linkage) it belongs to.
    pub component: usize,
    /// Its cells in [`Model::cells`], row by row from the bottom.
    pub cells: std::ops::Range<usize>,
}

/// A straight structural member between two nodes, made of `m` collinear elements, with one
/// density (its own design variable, a shared group variable, or fixed at 1).
#[derive(Debug, Clone, PartialEq)]
pub struct Bar {
    /// Name, e.g. `link1/bar12`.
    pub name: String,
    /// Component (linkage) it belongs to.
    pub component: usize,
    /// Design variable, `None` for a bar of fixed full density.
    pub variable: Option<usize>,
    /// Its elements.
    pub elements: std::ops::Range<usize>,
    /// Full-density volume `A L` (m³).
    pub volume: f64,
    /// Its section's index in [`Model::sections`].
    pub section: usize,
    /// Its elements' kind: a frame's beams or one truss bar.
    pub kind: Kind,
}

/// How a dynamic run starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Initial {
    /// Undeformed and at rest.
    #[default]
    Rest,
    /// At rest in the static equilibrium under gravity and the loads at `t = 0`, the drives
    /// held at their start.
    Equilibrium,
}

/// Static (load-stepped equilibrium) or dynamic (time integration) analysis.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Analysis {
    /// Time integration with generalized-α.
    Dynamic,
    /// Static equilibrium at the end of the load history.
    Static,
}

/// The scene's design parametrization (paper Eq. 1, 33, 34).
#[derive(Debug, Clone, PartialEq)]
pub struct Design {
    /// Stiffness interpolation.
    pub interpolation: Interpolation,
    /// Inertia interpolation.
    pub mass: MassLaw,
    /// Lower bound on densities.
    pub x_min: f64,
    /// Name of each design variable.
    pub variables: Vec<String>,
}

impl Design {
    /// Whether `x` is a design of these variables: one finite entry in `[x_min, 1]` each.
    ///
    /// # Errors
    /// [`DesignError`] naming the length or the first entry that is not.
    pub fn check(&self, x: &[f64]) -> Result<(), DesignError> {
        let n = self.variables.len();
        if x.len() != n {
            return Err(DesignError::Length {
                expected: n,
                got: x.len(),
            });
        }
        let lower = self.x_min;
        match x
            .iter()
            .position(|&v| !(v.is_finite() && v >= lower && v <= 1.0))
        {
            Some(i) => Err(DesignError::OutOfBounds {
                index: i,
                name: self.variables[i].clone(),
                value: x[i],
                lower,
            }),
            None => Ok(()),
        }
    }
}

/// A built mechanism.
#[derive(Debug, Clone, PartialEq)]
pub struct Model {
    /// Scene name.
    pub name: String,
    /// Kind of analysis the scene asks for.
    pub analysis: Analysis,
    /// How a dynamic run starts.
    pub initial: Initial,
    /// Velocities `q̇₀` at `t = 0`: a rigid motion consistent with the joints (empty: at
    /// rest).
    pub initial_velocity: Vec<f64>,
    /// Nodes.
    pub nodes: Vec<Node>,
    /// Elements.
    pub elements: Vec<Element>,
    /// Bars (groups of elements carrying one density).
    pub bars: Vec<Bar>,
    /// The quadrilaterals of the continuum members. Their densities follow the elements'
    /// in [`Densities`]: cell `k` is entry `elements.len() + k`.
    pub cells: Vec<Cell>,
    /// Continuum members.
    pub members: Vec<Member>,
    /// The scene's sections, in name order.
    pub sections: Vec<NamedSection>,
    /// Component names (linkages), for per-component responses.
    pub components: Vec<String>,
    /// Rigid bodies.
    pub bodies: Vec<RigidBody>,
    /// Springs and dampers (a servo's among them).
    pub springs: Vec<Spring>,
    /// Motors.
    pub motors: Vec<Motor>,
    /// Point masses, the rigid bodies' first.
    pub point_masses: Vec<PointMass>,
    /// Joints.
    pub joints: Vec<Joint>,
    /// Their constraint rows, in joint order.
    pub rows: Vec<ConstraintRow>,
    /// Averaging rings (RBE3-type), three rows each after the joints'.
    pub averagings: Vec<Averaging>,
    /// The DOFs of every constraint row, joints' and rings' ([`RowDofs`]).
    pub row_dofs: RowDofs,
    /// Applied loads.
    pub loads: Vec<NodalLoad>,
    /// Gravity acceleration (m/s²), zero by default.
    pub gravity: Vector2<f64>,
    /// Design parametrization.
    pub design: Design,
    /// Default node for the tip-deflection response.
    pub tip: Option<usize>,
    /// Default run settings of the scene.
    pub defaults: RunOptions,
    /// The rotation DOFs that nothing acts on — of the nodes that only truss bars meet, with
    /// no joint, spring, motor, rotary inertia or moment on them: they are no unknowns of
    /// the mechanism. Their rows are zero in every equation; the iteration matrix carries
    /// its scale on their diagonal ([`crate::solver`]'s assembly) so that it stays regular,
    /// and they stay zero.
    pub absent_rotations: Vec<usize>,
    /// The coupling of each bar's end nodes that `mass = "bar_lumped"` adds to its lumped
    /// mass ([`BarMass`]; read through [`Model::bar_couplings`]).
    pub bar_couplings: Vec<BarMass>,
}

/// Per-element scaling of inertia and stiffness for one design (paper Eq. 33–34): the
/// elements of the bars, then the cells of the continuum members.
#[derive(Debug, Clone, PartialEq)]
pub struct Densities {
    /// Density `x_e` (1 for a fixed bar): the volume fraction.
    pub density: Vec<f64>,
    /// Mass factor `m(x_e)`.
    pub mass: Vec<f64>,
    /// `dm/dx` at `x_e`.
    pub mass_rate: Vec<f64>,
    /// Stiffness factor `s(x_e)`.
    pub stiffness: Vec<f64>,
    /// `ds/dx` at `x_e`.
    pub stiffness_rate: Vec<f64>,
    /// The blend `γ(x_e)` of a cell's nonlinear and linear energies (1 for a bar's element
    /// and a cell not interpolated: [`Cell::blend`]).
    pub blend: Vec<f64>,
    /// `dγ/dx` at `x_e`.
    pub blend_rate: Vec<f64>,
}

/// Shortest length of a spring between points, as a fraction of its length in the scene,
/// before its direction counts as lost.
pub const COLLAPSED_SPRING: f64 = 1e-6;

/// Largest rotation of a node in one time step or load step (rad).
pub const MAX_ROTATION_STEP: f64 = std::f64::consts::FRAC_PI_2;

impl Model {
    /// Number of nodal DOFs `n_q`.
    pub fn n_dofs(&self) -> usize {
        3 * self.nodes.len()
    }

    /// Refuses a step (or load step) from coordinates `before` to `after` that turns a
    /// node by more than [`MAX_ROTATION_STEP`]: such a step has jumped to another
    /// solution branch or wound a node around, and its caller cuts it or fails clearly; and
    /// one that ends with a spring between points shorter than [`COLLAPSED_SPRING`] of its
    /// length in the scene, or turned about through zero length; and one that turns a
    /// continuum cell inside out (`det F ≤ 0` at a Gauss point), as finite-element codes
    /// refuse a negative Jacobian: no material passes through zero volume. A cell whose
    /// energy is blended by `γ` (`densities.blend`) is checked where its nonlinear part
    /// acts, `det(I + γH)`: a void cell's linear energy has no inside out.
    ///
    /// # Errors
    /// [`SolveError::Diverged`] naming the node and `at`, where the step ends;
    /// [`SolveError::SpringCollapsed`] naming the spring; [`SolveError::CellInverted`]
    /// naming the first cell turned inside out.
    pub fn plausible_step(
        &self,
        densities: &Densities,
        before: &[f64],
        after: &[f64],
        at: impl Fn() -> String,
    ) -> Result<(), SolveError> {
        let (node, rotation) = (0..self.nodes.len())
            .map(|k| (k, (after[3 * k + 2] - before[3 * k + 2]).abs()))
            .fold((0, 0.0), |best, c| if c.1 > best.1 { c } else { best });
        if rotation > MAX_ROTATION_STEP {
            return Err(SolveError::Diverged {
                at: at(),
                rotation,
                node: self.nodes[node].name.clone(),
            });
        }
        for spring in &self.springs {
            let (Some(d0), Some(d1), Measure::Distance { reference, .. }) = (
                spring.separation(before),
                spring.separation(after),
                spring.measure,
            ) else {
                continue;
            };
            // Shrunk to nothing, or passed through its own point: the direction is lost.
            let length = d1.norm();
            if length.is_nan()
                || length <= COLLAPSED_SPRING * reference.norm()
                || d0.dot(&d1) <= 0.0
            {
                return Err(SolveError::SpringCollapsed {
                    at: at(),
                    spring: spring.name.clone(),
                    length,
                });
            }
        }
        let first = self.elements.len();
        let blends = &densities.blend[first..];
        let inverted = self
            .cells
            .iter()
            .zip(blends)
            .enumerate()
            .find_map(|(k, (cell, &blend))| {
                let ratio = (cell.kernel.blended(blend)).smallest_area_ratio(&cell.gather(after));
                (ratio.is_nan() || ratio <= 0.0).then_some((k, cell, ratio))
            });
        if let Some((k, cell, ratio)) = inverted {
            return Err(SolveError::CellInverted {
                at: at(),
                cell: self.cell_name(cell),
                density: densities.density[first + k],
                ratio,
            });
        }
        Ok(())
    }

    /// A cell in the user's words, `NAME/cell[i,j]`, from its first corner `NAME[i,j]`.
    pub fn cell_name(&self, cell: &Cell) -> String {
        let member = &self.members[cell.member].name;
        let corner = &self.nodes[cell.nodes[0]].name;
        format!("{member}/cell{}", &corner[member.len()..])
    }

    /// Unknown `i` of the iteration matrix in the user's words: a node's coordinate with a
    /// bar that ends there (`x of node 'link1[2,0]' (bar link1/bar7)`), or a joint's
    /// multiplier.
    pub fn unknown_name(&self, i: usize) -> String {
        let Some(row) = i.checked_sub(self.n_dofs()) else {
            let (node, k) = (i / 3, i % 3);
            let bar = self.elements.iter().find(|e| e.nodes.contains(&node));
            let cell = self.cells.iter().find(|c| c.nodes.contains(&node));
            let bar = match (bar, cell) {
                (Some(e), _) => format!(" (bar {})", self.bars[e.bar].name),
                (None, Some(c)) => format!(" (member {})", self.members[c.member].name),
                (None, None) => String::new(),
            };
            let which = ["x", "y", "the rotation"][k];
            return format!("{which} of node '{}'{bar}", self.nodes[node].name);
        };
        if row < self.n_constraints() {
            format!("a multiplier of {}", self.constraints().owner(row))
        } else {
            format!("unknown {i}")
        }
    }

    /// Number of constraint rows `n_c`.
    pub fn n_constraints(&self) -> usize {
        self.rows.len() + 3 * self.averagings.len()
    }

    /// Every constraint row, the joints' and the averaging rings' ([`Constraints`]).
    pub fn constraints(&self) -> Constraints<'_> {
        Constraints {
            joints: &self.joints,
            rows: &self.rows,
            averagings: &self.averagings,
            dofs: &self.row_dofs,
        }
    }

    /// Whether the gradients read every state's velocities: a beam's or a cell's Rayleigh
    /// damping (its force follows the densities) or a damper whose `C` follows the state (on a
    /// distance or a carried axis: the iteration matrix at a state reads `q̇`).
    pub fn damping_reads_velocities(&self) -> bool {
        self.elements
            .iter()
            .any(|e| e.kernel.section().alpha > 0.0 || e.kernel.section().beta > 0.0)
            || (self.cells.iter())
                .any(|c| c.kernel.material.alpha > 0.0 || c.kernel.material.beta > 0.0)
            || self.springs.iter().any(Spring::damps_nonlinearly)
    }

    /// Number of design variables.
    pub fn n_variables(&self) -> usize {
        self.design.variables.len()
    }

    /// Design variable of element `e`, if any; `e ≥ elements.len()` is cell
    /// `e − elements.len()`.
    pub fn variable_of(&self, e: usize) -> Option<usize> {
        match self.elements.get(e) {
            Some(el) => self.bars[el.bar].variable,
            None => self.cells[e - self.elements.len()].variable,
        }
    }

    /// The constraint rows of joint `j`, the drive row last (an empty range where they
    /// would be for a joint without rows), found by bisection: the rows are in the order
    /// of their joints.
    pub fn joint_rows(&self, j: usize) -> std::ops::Range<usize> {
        self.rows.partition_point(|r| r.joint < j)..self.rows.partition_point(|r| r.joint <= j)
    }

    /// Times in `(0, t_end)` where a drive, a load table or a motor is not smooth, sorted, without
    /// repeats: where a variable step must end exactly.
    pub fn kinks(&self, t_end: f64) -> Vec<f64> {
        let drives = self
            .joints
            .iter()
            .filter_map(|j| j.drive.as_ref())
            .flat_map(|m| m.kinks());
        let loads = self.loads.iter().flat_map(|l| l.time.kinks());
        let motors = self.motors.iter().flat_map(|m| m.kinks());
        let mut t: Vec<f64> = drives
            .chain(loads)
            .chain(motors)
            .filter(|&t| t > 0.0 && t < t_end)
            .collect();
        t.sort_by(f64::total_cmp);
        t.dedup_by(|a, b| (*a - *b).abs() <= 1e-12 * t_end);
        t
    }

    /// The end coupling of every bar's mass ([`BarMass`]), built once with the model.
    pub fn end_couplings(&self) -> Vec<BarMass> {
        self.bars
            .iter()
            .map(|bar| {
                let elements = &self.elements[bar.elements.clone()];
                let length = elements.iter().map(|e| e.kernel.length()).sum();
                let ends = [elements[0].nodes[0], elements[elements.len() - 1].nodes[1]];
                let rho_a = elements[0].kernel.section().rho_a;
                BarMass::new(ends, bar.elements.start, elements.len(), length, rho_a)
            })
            .collect()
    }

    /// The couplings of bars' end nodes in the mass matrix of `kind`: every bar's for
    /// `bar_lumped`, none otherwise.
    pub fn bar_couplings(&self, kind: MassKind) -> &[BarMass] {
        match kind {
            MassKind::BarLumped => &self.bar_couplings,
            MassKind::Consistent | MassKind::Lumped => &[],
        }
    }

    /// Index of the node called `name`.
    pub fn node_index(&self, name: &str) -> Option<usize> {
        self.nodes.iter().position(|n| n.name == name)
    }

    /// Checks `x` (length, finiteness, bounds) and returns the element scalings.
    /// `None` means every bar at full density.
    pub fn densities(&self, x: Option<&[f64]>) -> Result<Densities, DesignError> {
        if let Some(x) = x {
            self.design.check(x)?;
        }
        let (law, mass) = (self.design.interpolation, self.design.mass);
        let value = |e: usize| match (self.variable_of(e), x) {
            (Some(i), Some(x)) => x[i],
            _ => 1.0,
        };
        let xe: Vec<f64> = (0..self.elements.len() + self.cells.len())
            .map(value)
            .collect();
        let n_e = self.elements.len();
        let blends: Vec<(f64, f64)> = (xe.iter().enumerate())
            .map(|(e, &v)| {
                e.checked_sub(n_e)
                    .map_or((1.0, 0.0), |k| self.cells[k].blend(v))
            })
            .collect();
        Ok(Densities {
            blend: blends.iter().map(|b| b.0).collect(),
            blend_rate: blends.iter().map(|b| b.1).collect(),
            stiffness: xe.iter().map(|&v| law.stiffness(v)).collect(),
            stiffness_rate: xe.iter().map(|&v| law.stiffness_derivative(v)).collect(),
            mass: xe.iter().map(|&v| mass.mass(v)).collect(),
            mass_rate: xe.iter().map(|&v| mass.mass_derivative(v)).collect(),
            density: xe,
        })
    }

    /// Reference positions, flattened `[X₀, Y₀, X₁, …]`.
    pub fn reference_positions(&self) -> Vec<f64> {
        self.nodes
            .iter()
            .flat_map(|n| [n.position.x, n.position.y])
            .collect()
    }

    /// Size of the model: the diagonal of the bounding box of its nodes and rigid-body
    /// points (m), a length scale for tolerances; 1 m for a model of one point (a body
    /// without points), which has no extent to measure by.
    pub fn size(&self) -> f64 {
        let points = self.bodies.iter().flat_map(|b| {
            let centre = self.nodes[b.node].position;
            b.points.iter().map(move |(_, arm)| centre + arm)
        });
        match size_of(self.nodes.iter().map(|n| n.position).chain(points)) {
            s if s > f64::MIN_POSITIVE => s,
            _ => 1.0,
        }
    }

    /// Full-density volume of each component (m³).
    pub fn component_volumes(&self) -> Vec<f64> {
        let mut v = vec![0.0; self.components.len()];
        for bar in &self.bars {
            v[bar.component] += bar.volume;
        }
        for cell in &self.cells {
            v[self.members[cell.member].component] += cell.kernel.volume();
        }
        v
    }
}

/// Diagonal of the bounding box of `points` (m), at least the smallest positive number;
/// infinite if the coordinates are too large to subtract.
pub fn size_of(points: impl Iterator<Item = Vector2<f64>>) -> f64 {
    let (mut lo, mut hi) = (
        Vector2::repeat(f64::INFINITY),
        Vector2::repeat(f64::NEG_INFINITY),
    );
    for p in points {
        lo = lo.inf(&p);
        hi = hi.sup(&p);
    }
    (hi - lo).norm().max(f64::MIN_POSITIVE)
}
