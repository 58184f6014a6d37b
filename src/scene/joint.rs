//! Joints and their drives: clamps, pins and hinges, written as algebraic constraints
//! ([`crate::constraint`]), the rotation of a pin or hinge optionally prescribed by a
//! motion law ([`crate::motion`]).
//!
//! A hinge joins two distinct nodes that coincide, within 1e-9 of the scene's size. Scenes
//! start at rest, so every drive must too.

use super::mesh::Mesh;
use super::spec::{JointSpec, MotionSpec};
use super::validate::{finite, non_negative, positive, samples, Result};
use crate::constraint::{ConstraintRow, Joint, JointKind};
use crate::error::SceneError;
use crate::motion::{Motion, Table, Trapezoidal};

/// The scene's joints, on the nodes of `mesh`, in a scene of size `size`.
pub(super) fn joints(specs: &[JointSpec], mesh: &Mesh, size: f64) -> Result<Vec<Joint>> {
    specs
        .iter()
        .enumerate()
        .map(|(k, j)| joint(&format!("joints[{k}]"), j, mesh, size))
        .collect()
}

/// The constraint rows of `Φ`, joint by joint.
pub(super) fn rows(joints: &[Joint]) -> Vec<ConstraintRow> {
    joints
        .iter()
        .enumerate()
        .flat_map(|(k, j)| j.rows(k))
        .collect()
}

/// The joint `j` at `path`: its kind on the nodes of `mesh`, and its drive if any.
fn joint(path: &str, j: &JointSpec, mesh: &Mesh, size: f64) -> Result<Joint> {
    let (name, kind, drive) = match j {
        JointSpec::Clamp { name, node } => (
            name,
            JointKind::Clamp {
                node: mesh.node(&format!("{path}.node"), node)?,
            },
            None,
        ),
        JointSpec::Pin { name, node, drive } => (
            name,
            JointKind::Pin {
                node: mesh.node(&format!("{path}.node"), node)?,
            },
            drive.as_ref(),
        ),
        JointSpec::Hinge { name, nodes, drive } => {
            (name, hinge(path, name, nodes, mesh, size)?, drive.as_ref())
        }
    };
    Ok(Joint {
        name: name.clone(),
        kind,
        drive: drive
            .map(|d| self::drive(&format!("{path}.drive"), d))
            .transpose()?,
    })
}

/// The hinge `name` at `path` between `nodes`: two distinct nodes that coincide.
fn hinge(path: &str, name: &str, nodes: &[String; 2], mesh: &Mesh, size: f64) -> Result<JointKind> {
    let a = mesh.node(&format!("{path}.nodes[0]"), &nodes[0])?;
    let b = mesh.node(&format!("{path}.nodes[1]"), &nodes[1])?;
    let gap = (mesh.nodes[a].position - mesh.nodes[b].position).norm();
    if a == b {
        return Err(SceneError::new(
            format!("{path} ({name})"),
            "a hinge needs two distinct nodes",
        ));
    }
    if gap > 1e-9 * size {
        return Err(SceneError::new(
            format!("{path} ({name})"),
            format!(
                "hinge nodes '{}' and '{}' are {gap:.3e} m apart; they must coincide",
                nodes[0], nodes[1]
            ),
        ));
    }
    Ok(JointKind::Hinge { nodes: [a, b] })
}

/// The drive at `path`: a [`motion`] law at rest at `t = 0`.
fn drive(path: &str, d: &MotionSpec) -> Result<Motion> {
    let m = motion(path, d)?;
    let rate = m.at(0.0).velocity;
    if rate.abs() > 0.0 {
        return Err(SceneError::new(path, format!("moves at t = 0 (θ̇ = {rate} rad/s), but scenes start at rest: start the motion from rest")));
    }
    Ok(m)
}

/// The motion law at `path`: a trapezoidal velocity profile, or a clamped cubic spline
/// through samples `(t_k, θ_k)`.
fn motion(path: &str, m: &MotionSpec) -> Result<Motion> {
    Ok(match m {
        MotionSpec::Trapezoidal {
            start,
            end,
            acceleration,
            speed,
            t_start,
        } => Motion::Trapezoidal(Trapezoidal::new(
            finite(&format!("{path}.start"), *start)?,
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
        } => {
            samples(path, t, theta, "theta")?;
            let v0 = finite(&format!("{path}.start_velocity"), *start_velocity)?;
            let v1 = finite(&format!("{path}.end_velocity"), *end_velocity)?;
            Motion::Table(Table::new(t.clone(), theta.clone(), [v0, v1]))
        }
    })
}
