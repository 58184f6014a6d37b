//! Joints and their drives: clamps, pins, hinges, welds, sliders (prismatic joints) and
//! rollers (a point on a ground axis, its rotation free),
//! written as algebraic constraints ([`crate::joint::planar`]) on nodes or rigid-body points,
//! the rotation of a pin or hinge, or a slider's travel, optionally prescribed by a motion
//! law ([`crate::joint::motion`]).
//!
//! A hinge or weld joins two distinct nodes or bodies at points that coincide, within 1e-9
//! of the scene's size. Drives start at rest; a scene starts moving only through its
//! undriven joints' initial rates.

use super::mesh::Mesh;
use super::spec::{JointSpec, MotionSpec};
use nalgebra::Vector2;

use super::validate::{each, finite, non_negative, positive, samples, unknown, Listed, Result};
use crate::error::SceneError;
use crate::joint::motion::{Motion, Table, Trapezoidal};
use crate::joint::planar::{Anchor, ConstraintRow, Joint, JointKind};

/// The scene's joints, on the nodes of `mesh`, in a scene of size `size`.
pub(super) fn joints(specs: &[JointSpec], mesh: &Mesh, size: f64) -> Listed<Joint> {
    each(specs, |k, j| joint(&format!("joints[{k}]"), j, mesh, size))
}

/// The constraint rows of `Φ`, joint by joint.
pub(super) fn rows(joints: &[Joint]) -> Vec<ConstraintRow> {
    joints
        .iter()
        .enumerate()
        .flat_map(|(k, j)| j.rows(k))
        .collect()
}

/// The joint `j` at `path`: its kind on the anchors of `mesh`, and its drive if any.
fn joint(path: &str, j: &JointSpec, mesh: &Mesh, size: f64) -> Result<Joint> {
    let anchor = |key: &str, name: &str| mesh.anchor(&format!("{path}.{key}"), name);
    let (name, kind, drive) = match j {
        JointSpec::Clamp { name, node } => (
            name,
            JointKind::Clamp {
                at: anchor("node", node)?,
            },
            None,
        ),
        JointSpec::Pin { name, node, drive } => (
            name,
            JointKind::Pin {
                at: anchor("node", node)?,
            },
            drive.as_ref(),
        ),
        JointSpec::Hinge { name, nodes, drive } => (
            name,
            JointKind::Hinge {
                at: coincident(path, name, nodes, mesh, size)?,
            },
            drive.as_ref(),
        ),
        JointSpec::Weld { name, nodes } => (
            name,
            JointKind::Weld {
                at: coincident(path, name, nodes, mesh, size)?,
            },
            None,
        ),
        JointSpec::Prismatic {
            name,
            nodes,
            axis,
            drive,
        } => (name, prismatic(path, nodes, *axis, mesh)?, drive.as_ref()),
        JointSpec::Roller {
            name,
            node,
            axis,
            drive,
        } => (
            name,
            JointKind::Roller {
                at: anchor("node", node)?,
                axis: unit_axis(path, *axis)?,
            },
            drive.as_ref(),
        ),
    };
    Ok(Joint {
        name: name.clone(),
        kind,
        drive: drive
            .map(|d| self::drive(&format!("{path}.drive"), d))
            .transpose()?,
    })
}

/// The anchors `nodes` of the hinge or weld `name` at `path`: on two distinct nodes, and
/// coincident.
fn coincident(
    path: &str,
    name: &str,
    nodes: &[String; 2],
    mesh: &Mesh,
    size: f64,
) -> Result<[Anchor; 2]> {
    let a = mesh.anchor(&format!("{path}.nodes[0]"), &nodes[0])?;
    let b = mesh.anchor(&format!("{path}.nodes[1]"), &nodes[1])?;
    let gap = (mesh.position(a) - mesh.position(b)).norm();
    if a.node == b.node {
        return Err(SceneError::new(
            format!("{path} ({name})"),
            "a joint needs two distinct nodes or bodies",
        ));
    }
    if gap > 1e-9 * size {
        return Err(SceneError::new(
            format!("{path} ({name})"),
            format!(
                "'{}' and '{}' are {gap:.3e} m apart; they must coincide",
                nodes[0], nodes[1]
            ),
        ));
    }
    Ok([a, b])
}

/// The prismatic joint at `path`: slider `nodes[1]` on an axis through its reference
/// position, carried by `nodes[0]` (the ground if `None`), along `axis` made unit.
fn prismatic(
    path: &str,
    nodes: &[Option<String>; 2],
    axis: [f64; 2],
    mesh: &Mesh,
) -> Result<JointKind> {
    let (slider_key, carrier_key) = match nodes[0] {
        Some(_) => ("nodes[1]", "nodes[0]"),
        None => ("node", ""),
    };
    let slider = match &nodes[1] {
        Some(name) => mesh.anchor(&format!("{path}.{slider_key}"), name)?,
        None => return Err(SceneError::new(path, "a prismatic joint needs its slider")),
    };
    let carrier = match &nodes[0] {
        Some(name) => {
            let node = mesh.anchor(&format!("{path}.{carrier_key}"), name)?.node;
            if node == slider.node {
                return Err(SceneError::new(
                    path,
                    "a prismatic joint needs two distinct nodes or bodies",
                ));
            }
            Some(Anchor {
                node,
                arm: mesh.position(slider) - mesh.nodes[node].position,
            })
        }
        None => None,
    };
    Ok(JointKind::Prismatic {
        carrier,
        slider,
        axis: unit_axis(path, axis)?,
    })
}

/// The axis `[x, y]` of the joint at `path`, made unit.
fn unit_axis(path: &str, axis: [f64; 2]) -> Result<Vector2<f64>> {
    let axis = Vector2::new(
        finite(&format!("{path}.axis[0]"), axis[0])?,
        finite(&format!("{path}.axis[1]"), axis[1])?,
    );
    let length = axis.norm();
    if !(length.is_normal()) {
        return Err(SceneError::new(
            format!("{path}.axis"),
            "an axis of zero length: give its direction [x, y]",
        ));
    }
    Ok(axis / length)
}

/// The joint called `name` (at `path`) with its own coordinate as a row, for a spring or a
/// motor (`what`) to act on.
pub(super) fn coordinate(
    path: &str,
    joints: &[Joint],
    name: &str,
    what: &str,
) -> Result<(usize, ConstraintRow)> {
    let j = joints
        .iter()
        .position(|j| j.name == name)
        .ok_or_else(|| unknown(path, "joint", name))?;
    let row = joints[j].coordinate(j).ok_or_else(|| {
        let kind = joints[j].kind.name();
        SceneError::new(
            path,
            format!("'{name}' is a {kind}: it holds every coordinate, nothing for {what}"),
        )
    })?;
    Ok((j, row))
}

/// The scene's initial rates: for each named joint, its coordinate's row and rate; the
/// joint undriven (a drive starts at rest).
pub(super) fn initial_rates(
    rates: &std::collections::BTreeMap<String, f64>,
    joints: &[Joint],
) -> Result<Vec<(ConstraintRow, f64)>> {
    rates
        .iter()
        .map(|(name, &rate)| {
            let path = format!("initial_rates.{name}");
            let (j, row) = coordinate(&path, joints, name, "a rate to set")?;
            if joints[j].drive.is_some() {
                let msg = "the joint is driven: its drive starts at rest";
                return Err(SceneError::new(path, msg));
            }
            Ok((row, finite(&path, rate)?))
        })
        .collect()
}

/// The drive at `path`: a [`motion`] law at rest at `t = 0`.
pub(super) fn drive(path: &str, d: &MotionSpec) -> Result<Motion> {
    let m = motion(path, d)?;
    let rate = m.at(0.0).velocity;
    if rate.abs() > 0.0 {
        return Err(SceneError::new(path, format!("moves at t = 0 (rate {rate} per s), but drives start at rest: start the motion from rest")));
    }
    Ok(m)
}

/// How finely a law's values must be held, relative to its travel (to 1 rad or m for a
/// law that holds still): a double holds `θ` only to `|θ| ε`, so a law from 1e15 rad
/// moves by multiples of 0.125 rad, and one from 1e17 rad not at all.
const RESOLUTION: f64 = 1e-6;

/// `start` if a law between `start` and `end` is held by doubles to [`RESOLUTION`] of its
/// travel; a `SceneError` naming the law otherwise (it would turn by another angle, or not
/// at all, without a word).
fn resolved(path: &str, start: f64, end: f64) -> Result<f64> {
    let spacing = start.abs().max(end.abs()) * f64::EPSILON;
    let travel = (end - start).abs();
    if spacing > RESOLUTION * if travel > 0.0 { travel } else { 1.0 } {
        return Err(SceneError::new(
            path,
            format!("moves {travel:.3e} from {start:.6e}, where numbers are held only to {spacing:.3e}: the motion \
                     would be lost in rounding; give it from the joint's position (start = 0)"),
        ));
    }
    Ok(start)
}

/// The motion law at `path`: a trapezoidal velocity profile, or a clamped cubic spline
/// through samples `(t_k, θ_k)`.
pub(super) fn motion(path: &str, m: &MotionSpec) -> Result<Motion> {
    Ok(match m {
        MotionSpec::Trapezoidal {
            start,
            end,
            acceleration,
            speed,
            t_start,
            ..
        } => Motion::Trapezoidal(Trapezoidal::new(
            resolved(path, finite(&format!("{path}.start"), *start)?, *end)?,
            finite(&format!("{path}.end"), *end)?,
            positive(&format!("{path}.acceleration"), *acceleration)?,
            positive(&format!("{path}.speed"), *speed)?,
            non_negative(&format!("{path}.t_start"), *t_start)?,
        )),
        MotionSpec::Table {
            t,
            theta,
            start_velocity,
            end_velocity,
            ..
        } => {
            samples(path, t, theta, "theta")?;
            let (low, high) = theta
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
                    (l.min(v), h.max(v))
                });
            resolved(path, low, high)?;
            let v0 = finite(&format!("{path}.start_velocity"), *start_velocity)?;
            let v1 = finite(&format!("{path}.end_velocity"), *end_velocity)?;
            Motion::Table(Table::new(t.clone(), theta.clone(), [v0, v1]))
        }
    })
}
