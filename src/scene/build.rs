//! Building a [`Model`] from a [`SceneSpec`], validating every entry on the way.
//!
//! Each error names the entry at fault (`sections.al.E`, `joints[1] (elbow)`, …): non-finite
//! or non-physical values, missing or duplicate nodes, zero-length bars, hinges between
//! distant nodes, and at the end the mechanism itself — redundant joints (over-constrained),
//! frames not connected to the ground (unconstrained), and for a static scene any rigid-body
//! mode left free.
//!
//! The phases, in order, each checking its own entries: sections, the mesh (nodes, ground
//! structures, continuum members, beams, rigid bodies and their points, rings), joints (a ring's hinges first), springs, motors, point masses, loads and gravity, the design, the tip, the
//! simulation defaults, and last the mechanism checks of [`crate::mechanism::rigid`]. The
//! lists of entries and the checks poll for interrupts ([`crate::poll`]): a build of many
//! thousand bodies stops soon after the caller asks.

use std::collections::HashSet;

use super::mesh::Mesh;
use super::spec::{AnalysisSpec, InitialSpec, SceneSpec};
use super::validate::unique;
use super::{
    body, design, ground_structure, joint, load, member, motor, ring, section, simulation, spring,
};
use crate::error::{Error, SceneError};
use crate::mechanism::model::{Analysis, Design, Initial, Model};
use crate::mechanism::rigid::{check_mechanism, initial_velocity};
use crate::mechanism::rows::RowDofs;
use crate::mechanism::spring::Measure;

/// Builds and validates the model of `spec`.
///
/// # Errors
/// [`Error::Scene`] naming the first entry at fault;
/// [`SolveError::Interrupted`](crate::error::SolveError::Interrupted) when this thread's
/// checker ([`crate::with_checker`]) asks the build to stop.
pub fn build(spec: &SceneSpec) -> Result<Model, Error> {
    let rigid: Vec<&str> = spec
        .ground_structures
        .iter()
        .filter(|g| g.rigid)
        .map(|g| g.section.as_str())
        .collect();
    let sections = section::sections(&spec.sections, &rigid)?;
    let mut mesh = Mesh::with_splits(&spec.splits);
    mesh.add_nodes(&spec.nodes)?;
    let mut point_masses =
        ground_structure::add_all(&mut mesh, &spec.ground_structures, &sections)?;
    let attached: HashSet<&str> = spec
        .joints
        .iter()
        .flat_map(|j| j.anchors())
        .chain(
            spec.beams
                .iter()
                .flat_map(|b| b.nodes.iter().map(String::as_str)),
        )
        .chain(
            spec.rings
                .iter()
                .flat_map(|r| r.nodes.iter().map(String::as_str)),
        )
        .collect();
    member::add_all(&mut mesh, &spec.members, &attached)?;
    mesh.add_beams(&spec.beams, &sections)?;
    mesh.check_bar_names()?;
    point_masses.extend(body::add_all(&mut mesh, &spec.rigid_bodies)?);
    let mut joint_specs = Vec::new();
    let mut averagings = Vec::new();
    for r in ring::add_all(&mut mesh, &spec.rings)? {
        point_masses.push(r.mass);
        joint_specs.extend(r.hinges);
        averagings.extend(r.averaging);
    }
    joint_specs.extend(spec.joints.iter().cloned());
    let size = mesh.size()?;
    let joints = joint::joints(&joint_specs, &mesh, size)?;
    unique("joints", joints.iter().map(|j| j.name.as_str()))?;
    let rows = joint::rows(&joints);
    let mut springs = spring::springs(&spec.springs, &mesh, &joints, size)?;
    unique("springs", springs.iter().map(|s| s.name.as_str()))?;
    let (motors, servos) =
        motor::motors(&spec.motors, &joints, 3 * mesh.nodes.len(), springs.len())?;
    unique("motors", motors.iter().map(|m| m.name.as_str()))?;
    springs.extend(servos);
    point_masses.extend(load::point_masses(&spec.point_masses, &mesh)?);
    let loads = load::loads(&spec.loads, &mesh)?;
    let gravity = load::gravity(spec.gravity)?;
    let (interpolation, x_min) = design::law(&spec.design)?;
    let mass = design::mass_law(&spec.design, spec.analysis)?;
    let tip = spec.tip.as_ref().map(|t| mesh.node("tip", t)).transpose()?;
    let mut model = Model {
        name: spec.name.clone(),
        analysis: match spec.analysis {
            AnalysisSpec::Dynamic => Analysis::Dynamic,
            AnalysisSpec::Static => Analysis::Static,
        },
        initial: match spec.initial {
            InitialSpec::Rest => Initial::Rest,
            InitialSpec::Equilibrium => Initial::Equilibrium,
        },
        initial_velocity: Vec::new(),
        nodes: mesh.nodes,
        elements: mesh.elements,
        bars: mesh.bars,
        cells: mesh.cells,
        members: mesh.members,
        sections,
        components: mesh.components,
        bodies: mesh.bodies,
        springs,
        motors,
        point_masses,
        joints,
        rows,
        averagings,
        row_dofs: RowDofs::default(),
        loads,
        gravity,
        design: Design {
            interpolation,
            mass,
            x_min,
            variables: mesh.variables.names,
        },
        tip,
        defaults: simulation::defaults(&spec.simulation, spec.analysis)?,
        absent_rotations: Vec::new(),
        bar_couplings: Vec::new(),
    };
    model.row_dofs = RowDofs::of(&model.rows, &model.averagings);
    model.absent_rotations = absent_rotations(&model)?;
    model.bar_couplings = model.end_couplings();
    let rates = joint::initial_rates(&spec.initial_rates, &model.joints)?;
    let starts = model.initial == Initial::Equilibrium || !rates.is_empty();
    if starts && model.analysis == Analysis::Static {
        let msg = "a static scene has no start: initial and initial_rates are for dynamic ones";
        return Err(SceneError::new("initial", msg).into());
    }
    check_mechanism(&model)?;
    if !rates.is_empty() {
        if model.initial == Initial::Equilibrium {
            let msg = "an equilibrium start is at rest: give initial_rates or initial = \"equilibrium\", not both";
            return Err(SceneError::new("initial_rates", msg).into());
        }
        model.initial_velocity = initial_velocity(&model, &rates)?;
        for &d in &model.absent_rotations {
            model.initial_velocity[d] = 0.0;
        }
    }
    Ok(model)
}

/// The rotations of the nodes that only truss bars and continuum cells meet (no beam, rigid
/// body or rotary inertia there): [`Model::absent_rotations`]. The pinned bars do not turn with them, so
/// nothing may act on them.
///
/// # Errors
/// A [`SceneError`] naming a moment load, joint, spring or motor on such a rotation.
fn absent_rotations(model: &Model) -> Result<Vec<usize>, SceneError> {
    let n = model.nodes.len();
    let mut bare = vec![false; n];
    for e in model.elements.iter().filter(|e| !e.kernel.turns_nodes()) {
        e.nodes.iter().for_each(|&k| bare[k] = true);
    }
    for c in &model.cells {
        c.nodes.iter().for_each(|&k| bare[k] = true);
    }
    for e in model.elements.iter().filter(|e| e.kernel.turns_nodes()) {
        e.nodes.iter().for_each(|&k| bare[k] = false);
    }
    for b in &model.bodies {
        bare[b.node] = false;
    }
    for pm in model.point_masses.iter().filter(|pm| pm.inertia != 0.0) {
        bare[pm.node] = false;
    }
    if let Some((k, load)) = model
        .loads
        .iter()
        .enumerate()
        .find(|(_, l)| l.value[2] != 0.0 && bare[l.node])
    {
        let node = &model.nodes[load.node].name;
        let msg = format!(
            "a moment on node '{node}', which only truss bars or continuum cells meet: a pin carries no moment"
        );
        return Err(SceneError::new(format!("loads[{k}]"), msg));
    }
    check_truss_rotations(model, &bare)?;
    Ok((0..bare.len())
        .filter(|&n| bare[n])
        .map(|n| 3 * n + 2)
        .collect())
}

/// A joint, spring or motor that acts on the rotation of a `bare` node (only truss bars
/// meet there) drives, locks or loads nothing: the bars are pinned there and do not turn
/// with that rotation. Refused, so that a driven truss link is not silently left free.
///
/// # Errors
/// A [`SceneError`] naming the first such joint, spring or motor.
fn check_truss_rotations(model: &Model, bare: &[bool]) -> Result<(), SceneError> {
    let on_bare = |dofs: [Option<usize>; 6], acts: [bool; 6]| {
        (0..6).find_map(|i| dofs[i].filter(|d| acts[i] && d % 3 == 2 && bare[d / 3]))
    };
    let refuse = |at: String, d: usize| {
        let node = &model.nodes[d / 3].name;
        SceneError::new(
            at,
            format!(
                "acts on the rotation of node '{node}', which only truss bars or continuum cells meet: they are \
                 pinned there and do not turn with it, so nothing is driven, locked or loaded \
                 (pin the node instead of clamping it; a driven link is kind = \"frame\" or \
                 carries a rigid body)"
            ),
        )
    };
    for row in &model.rows {
        if let Some(d) = on_bare(row.dofs(), row.active()) {
            let name = &model.joints[row.joint].name;
            return Err(refuse(format!("joints[{}] ({name})", row.joint), d));
        }
    }
    for (k, spring) in model.springs.iter().enumerate() {
        if let Measure::Coordinate(row) = spring.measure {
            if let Some(d) = on_bare(row.dofs(), row.active()) {
                return Err(refuse(format!("springs[{k}] ({})", spring.name), d));
            }
        }
    }
    for (k, motor) in model.motors.iter().enumerate() {
        if let Some(d) = on_bare(motor.dofs, motor.direction.map(|c| c != 0.0)) {
            return Err(refuse(format!("motors[{k}] ({})", motor.name), d));
        }
    }
    Ok(())
}
