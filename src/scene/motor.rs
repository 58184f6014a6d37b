//! Motors on joints' coordinates ([`crate::mechanism::motor`]): a torque, constant or from a table,
//! or a PD servo (its spring-damper among the springs).

use super::joint::{coordinate, motion};
use super::load::time;
use super::spec::MotorSpec;
use super::validate::{finite, non_negative, Result};
use crate::error::{Error, SceneError};
use crate::interrupt::poll;
use crate::joint::planar::{ConstraintRow, Joint, JointKind};
use crate::mechanism::motor::{Motor, MotorLaw};
use crate::mechanism::spring::{Measure, Spring};

/// The scene's motors on `joints` of a model with `n_dofs` coordinates, and the servos'
/// spring-dampers, to follow the model's first `first` springs.
pub(super) fn motors(
    specs: &[MotorSpec],
    joints: &[Joint],
    n_dofs: usize,
    first: usize,
) -> std::result::Result<(Vec<Motor>, Vec<Spring>), Error> {
    let mut motors = Vec::with_capacity(specs.len());
    let mut springs = Vec::new();
    for (k, m) in specs.iter().enumerate() {
        poll()?;
        let path = format!("motors[{k}] ({})", m.name);
        let (motor, spring) = motor(&path, m, joints, n_dofs, first + springs.len())?;
        motors.push(motor);
        springs.extend(spring);
    }
    Ok((motors, springs))
}

/// The motor `m` at `path`, and its servo's spring-damper.
fn motor(
    path: &str,
    m: &MotorSpec,
    joints: &[Joint],
    n_dofs: usize,
    spring: usize,
) -> Result<(Motor, Option<Spring>)> {
    let at = format!("{path}.joint");
    let (j, row) = coordinate(&at, joints, &m.joint, "a motor to turn")?;
    let joint = &joints[j];
    if joint.drive.is_some() {
        let msg = format!(
            "'{}' is driven: its drive prescribes the motion a motor would make",
            m.joint
        );
        return Err(SceneError::new(at, msg));
    }
    if !row.is_linear() {
        let msg = format!(
            "'{}' slides on a carried axis: a motor acts on pins, hinges and sliders on a ground axis",
            m.joint
        );
        return Err(SceneError::new(at, msg));
    }
    let (_, direction) = row.evaluate(&vec![0.0; n_dofs]);
    let (law, spring) = law(path, m, joint, row, spring)?;
    let motor = Motor {
        name: m.name.clone(),
        dofs: row.dofs(),
        direction,
        law,
    };
    Ok((motor, spring))
}

/// The law of motor `m` at `path` on `joint`'s coordinate `row`, and a servo's
/// spring-damper.
fn law(
    path: &str,
    m: &MotorSpec,
    joint: &Joint,
    row: ConstraintRow,
    index: usize,
) -> Result<(MotorLaw, Option<Spring>)> {
    match (m.torque, &m.servo) {
        (Some(torque), None) => {
            let law = MotorLaw::Torque {
                value: finite(&format!("{path}.torque"), torque)?,
                time: time(path, m.table.as_ref())?,
            };
            Ok((law, None))
        }
        (None, Some(servo)) if m.table.is_none() => {
            let kp = non_negative(&format!("{path}.servo.kp"), servo.kp)?;
            let kd = non_negative(&format!("{path}.servo.kd"), servo.kd)?;
            if kp == 0.0 && kd == 0.0 {
                let msg = "has neither gain `kp` nor `kd`";
                return Err(SceneError::new(format!("{path}.servo"), msg));
            }
            let travels = matches!(
                joint.kind,
                JointKind::Prismatic { .. } | JointKind::Roller { .. }
            );
            if travels && servo.motion.in_degrees() {
                let msg = "a slider's servo follows a travel in m: its law takes no `_deg` keys";
                return Err(SceneError::new(format!("{path}.servo.motion"), msg));
            }
            let law = MotorLaw::Servo {
                kp,
                kd,
                motion: motion(&format!("{path}.servo.motion"), &servo.motion)?,
                spring: index,
            };
            let spring = Spring {
                name: format!("servo of motor '{}'", m.name),
                measure: Measure::Coordinate(row),
                stiffness: kp,
                damping: kd,
                rest: 0.0,
            };
            Ok((law, Some(spring)))
        }
        _ => {
            let msg = "a motor takes a `torque` (with a `table` if it varies) or a `servo`";
            Err(SceneError::new(path, msg))
        }
    }
}
