//! Frames given by axis–angle or by a matrix: the rotation an `orientation` gives, checked
//! (a zero axis, a matrix that is not a rotation: a [`SceneError`] naming it).

use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};

use super::spec::OrientationSpec;
use crate::error::{short, SceneError};
use crate::scene::validate::{angle, finite};

type Result<T> = std::result::Result<T, SceneError>;

/// How far a rotation matrix may be from orthonormal (`‖RᵀR − I‖` entrywise): six decimals
/// typed by hand.
pub const ORTHONORMAL_TOLERANCE: f64 = 1e-6;

/// A vector of finite numbers, each named by its index in `path`.
pub(super) fn vector(path: &str, v: [f64; 3]) -> Result<Vector3<f64>> {
    for (i, c) in v.iter().enumerate() {
        finite(&format!("{path}[{i}]"), *c)?;
    }
    Ok(Vector3::from(v))
}

/// The rotation an orientation gives: by axis and angle, or by an orthonormal matrix.
pub(super) fn rotation(path: &str, o: &OrientationSpec) -> Result<UnitQuaternion<f64>> {
    match (o.axis, o.matrix) {
        (Some(axis), None) => {
            let axis = vector(&format!("{path}.axis"), axis)?;
            let angle = angle(path, o.angle, o.angle_deg)?;
            let unit = nalgebra::Unit::try_new(axis, 0.0).ok_or_else(|| {
                SceneError::new(format!("{path}.axis"), "is zero: a rotation needs an axis")
            })?;
            Ok(UnitQuaternion::from_axis_angle(&unit, angle))
        }
        (None, Some(rows)) => {
            if o.angle.is_some() || o.angle_deg.is_some() {
                return Err(SceneError::new(
                    path,
                    "an angle goes with an `axis`, not with a `matrix`",
                ));
            }
            let m = Matrix3::from_fn(|i, j| rows[i][j]);
            if !m.iter().all(|v| v.is_finite()) {
                return Err(SceneError::new(format!("{path}.matrix"), "is not finite"));
            }
            let off = (m.transpose() * m - Matrix3::identity()).amax();
            if off > ORTHONORMAL_TOLERANCE || m.determinant() <= 0.0 {
                return Err(SceneError::new(
                    format!("{path}.matrix"),
                    format!(
                        "is not a rotation: RᵀR differs from I by {} (at most {ORTHONORMAL_TOLERANCE}), determinant {}",
                        short(off),
                        short(m.determinant())
                    ),
                ));
            }
            Ok(UnitQuaternion::from_rotation_matrix(
                &Rotation3::from_matrix(&m),
            ))
        }
        _ => Err(SceneError::new(
            path,
            "give an `axis` with an `angle` (or `angle_deg`), or a `matrix`, exactly one",
        )),
    }
}
