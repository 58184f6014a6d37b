//! Motors on joints' coordinates ([`crate::motor`]): a torque, constant or from a table,
//! or a PD servo (its spring-damper among the springs).

use super::joint::motion;
use super::load::time;
use super::spec::MotorSpec;
use super::validate::{finite, non_negative, unknown, Result};
use crate::constraint::Joint;
use crate::error::SceneError;
use crate::motor::{Motor, MotorLaw};
use crate::spring::{Measure, Spring};

/// The scene's motors on `joints` of a model with `n_dofs` coordinates, and the servos'
/// spring-dampers.
pub(super) fn motors(
    specs: &[MotorSpec],
    joints: &[Joint],
    n_dofs: usize,
) -> Result<(Vec<Motor>, Vec<Spring>)> {
    let mut motors = Vec::with_capacity(specs.len());
    let mut springs = Vec::new();
    for (k, m) in specs.iter().enumerate() {
        let (motor, spring) = motor(&format!("motors[{k}] ({})", m.name), m, joints, n_dofs)?;
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
) -> Result<(Motor, Option<Spring>)> {
    let j = joints
        .iter()
        .position(|j| j.name == m.joint)
        .ok_or_else(|| unknown(format!("{path}.joint"), "joint", &m.joint))?;
    let joint = &joints[j];
    let at = format!("{path}.joint");
    let row = joint.coordinate(j).ok_or_else(|| {
        let kind = joint.kind.name();
        SceneError::new(
            &at,
            format!(
                "'{}' is a {kind}: it holds every coordinate, nothing for a motor to turn",
                m.joint
            ),
        )
    })?;
    if joint.drive.is_some() {
        let msg = format!(
            "'{}' is driven: its drive prescribes the motion a motor would make",
            m.joint
        );
        return Err(SceneError::new(at, msg));
    }
    if !row.is_linear() {
        let msg = format!("'{}' slides on a carried axis: a motor acts on pins, hinges and sliders on a ground axis", m.joint);
        return Err(SceneError::new(at, msg));
    }
    let (direction, law, spring) = {
        let (_, direction) = row.evaluate(&vec![0.0; n_dofs]);
        match (m.torque, &m.servo) {
            (Some(torque), None) => {
                let law = MotorLaw::Torque {
                    value: finite(&format!("{path}.torque"), torque)?,
                    time: time(path, m.table.as_ref())?,
                };
                (direction, law, None)
            }
            (None, Some(servo)) if m.table.is_none() => {
                let kp = non_negative(&format!("{path}.servo.kp"), servo.kp)?;
                let kd = non_negative(&format!("{path}.servo.kd"), servo.kd)?;
                if kp == 0.0 && kd == 0.0 {
                    return Err(SceneError::new(
                        format!("{path}.servo"),
                        "has neither gain `kp` nor `kd`",
                    ));
                }
                let law = MotorLaw::Servo {
                    kp,
                    kd,
                    motion: motion(&format!("{path}.servo.motion"), &servo.motion)?,
                };
                let spring = Spring {
                    name: format!("servo of motor '{}'", m.name),
                    measure: Measure::Coordinate(row),
                    stiffness: kp,
                    damping: kd,
                    rest: 0.0,
                };
                (direction, law, Some(spring))
            }
            _ => {
                let msg = "a motor takes a `torque` (with a `table` if it varies) or a `servo`";
                return Err(SceneError::new(path, msg));
            }
        }
    };
    let motor = Motor {
        name: m.name.clone(),
        dofs: row.dofs(),
        direction,
        law,
    };
    Ok((motor, spring))
}
