//! Exact gradients of spatial motions: direct and adjoint against fourth-order differences
//! of re-run simulations (1e-6), direct against adjoint (1e-9), on the heavy top and on a
//! mechanism with every joint kind and a drive.

use crate::group::Frame;
use crate::load::TimeFunction;
use crate::motion::{Motion, Table};
use crate::response::aggregation::Aggregation;
use crate::spatial::force::ForceKind;
use crate::spatial::joint::{Anchor, JointKind};
use crate::spatial::model::SpatialModel;
use crate::spatial::sensitivity::{sensitivities, Gradients, Parameter, Response};
use crate::{Method, TimeGrid};
use nalgebra::{Matrix3, UnitQuaternion, Vector3};

use super::spatial::{settings, top_of};

/// `model` with parameter `p` moved by `e`.
pub fn moved(model: &SpatialModel, p: &Parameter, e: f64) -> SpatialModel {
    let mut m = model.clone();
    match *p {
        Parameter::Mass { body } => m.bodies[body].mass += e,
        Parameter::Inertia { body, i, j } => {
            m.bodies[body].inertia[(i, j)] += e;
            if i != j {
                m.bodies[body].inertia[(j, i)] += e;
            }
        }
        Parameter::SpringStiffness { force }
        | Parameter::SpringDamping { force }
        | Parameter::SpringRest { force }
        | Parameter::MotorTorque { force } => match (&mut m.forces[force].kind, p) {
            (
                ForceKind::Spring { rest, .. } | ForceKind::Torsion { rest, .. },
                Parameter::SpringRest { .. },
            ) => *rest += e,
            (
                ForceKind::Spring { stiffness, .. } | ForceKind::Torsion { stiffness, .. },
                Parameter::SpringStiffness { .. },
            ) => *stiffness += e,
            (
                ForceKind::Spring { damping, .. } | ForceKind::Torsion { damping, .. },
                Parameter::SpringDamping { .. },
            ) => *damping += e,
            (ForceKind::Motor { torque, .. }, _) => *torque += e,
            _ => unreachable!("the parameters below name their elements' kinds"),
        },
        Parameter::BeamStiffness { beam } => {
            let s = &mut m.beams[beam].section;
            s.c_n
                .iter_mut()
                .chain(&mut s.c_m)
                .for_each(|c| *c *= 1.0 + e);
        }
        Parameter::BeamMass { beam } => {
            let s = &mut m.beams[beam].section;
            s.rho_a *= 1.0 + e;
            s.rho_i.iter_mut().for_each(|c| *c *= 1.0 + e);
        }
        Parameter::TrussStiffness { truss } => m.trusses[truss].ea *= 1.0 + e,
        Parameter::TrussMass { truss } => m.trusses[truss].rho_a *= 1.0 + e,
        Parameter::BeamDensity { beam } => m.beams[beam].density += e,
        Parameter::TrussDensity { truss } => m.trusses[truss].density += e,
        // A factor on its buckling ratio `−ε/ε_E`.
        Parameter::TrussBuckling { truss } => m.trusses[truss].euler_strain /= 1.0 + e,
        Parameter::JointPosition { joint, axis } => {
            let j = &mut m.joints[joint];
            let arms = j.arm_rates(&Vector3::ith(axis, 1.0));
            (0..2).for_each(|s| j.pair.arms[s] += arms[s] * e);
        }
        Parameter::Drive { .. } | Parameter::BeamSize { .. } => unreachable!(
            "a drive's law and a section's size are moved by rebuilding their scene \
             (tests/python/test_spatial_drives.py, test_spatial_sizes.py)"
        ),
    }
    m
}

/// The differences' step: 1e-3 of a mass, a spring's constant or a torque, 1e-4 m or rad
/// of a rest length or angle, 1e-2 of the
/// body's mean principal moment for an inertia entry (an entry may be zero), where the fourth-order truncation stays below
/// 1e-8 and Newton's tolerance moves the values by less than 1e-12 of the step.
fn step(model: &SpatialModel, p: &Parameter) -> f64 {
    match *p {
        Parameter::Mass { body } => 1e-3 * model.bodies[body].mass,
        Parameter::Inertia { body, .. } => 2e-3 * model.bodies[body].inertia.trace() / 3.0,
        Parameter::SpringRest { .. } | Parameter::JointPosition { .. } => 1e-4,
        Parameter::SpringStiffness { force }
        | Parameter::SpringDamping { force }
        | Parameter::MotorTorque { force } => match model.forces[force].kind {
            ForceKind::Spring {
                stiffness, damping, ..
            }
            | ForceKind::Torsion {
                stiffness, damping, ..
            } => {
                1e-3 * if matches!(p, Parameter::SpringStiffness { .. }) {
                    stiffness
                } else {
                    damping
                }
            }
            ForceKind::Motor { torque, .. } => 1e-3 * torque.abs(),
            ForceKind::Load { .. } => unreachable!("loads have no parameter"),
        },
        Parameter::BeamStiffness { .. }
        | Parameter::BeamMass { .. }
        | Parameter::TrussStiffness { .. }
        | Parameter::TrussMass { .. }
        | Parameter::BeamDensity { .. }
        | Parameter::TrussDensity { .. }
        | Parameter::TrussBuckling { .. } => 1e-3,
        Parameter::Drive { .. } | Parameter::BeamSize { .. } => unreachable!("see `moved`"),
    }
}

/// Checks both methods against fourth-order differences and each other.
pub fn check(
    model: &SpatialModel,
    rho_inf: f64,
    grid: &TimeGrid,
    responses: &[Response],
    parameters: &[Parameter],
) {
    let s = settings(rho_inf);
    let run = |m: &SpatialModel, method| {
        sensitivities(m, &s, grid, responses, parameters, method).unwrap()
    };
    let direct = run(model, Method::Direct);
    let adjoint = run(model, Method::Adjoint);
    let values = |m: &SpatialModel| run(m, Method::Direct).values;
    for (i, p) in parameters.iter().enumerate() {
        let e = step(model, p);
        let f = |k: f64| values(&moved(model, p, k * e));
        let (p2, p1, m1, m2) = (f(2.0), f(1.0), f(-1.0), f(-2.0));
        for k in 0..responses.len() {
            let fd = (-p2[k] + 8.0 * p1[k] - 8.0 * m1[k] + m2[k]) / (12.0 * e);
            let (d, a) = (direct.gradient[k][i], adjoint.gradient[k][i]);
            // The differences' own noise, from values reproducible to 1e-10 (Newton's
            // tolerance), bounds what they can tell of a derivative that vanishes (a
            // kinematic response, a force the parameter does not reach).
            let noise = 1e-10 * direct.values[k].abs() / e;
            let scale = d.abs().max(a.abs());
            println!(
                "{:?} / {:?}: direct {d:.9e}, adjoint {a:.9e}, differences {fd:.9e}",
                responses[k], p
            );
            assert!(
                (d - fd).abs() <= 1e-6 * scale + noise,
                "{:?} / {:?}: direct {d} against differences {fd}",
                responses[k],
                p
            );
            assert!(
                (d - a).abs() <= 1e-9 * scale + 1e-15 * direct.values[k].abs(),
                "{:?} / {:?}: direct {d} against adjoint {a}",
                responses[k],
                p
            );
        }
    }
    let Gradients { values: v, .. } = adjoint;
    assert_eq!(v, direct.values);
}

/// The heavy top: its centre of mass at the end, to its mass and inertia.
#[test]
fn heavy_top_gradients_are_exact() {
    // The guide's top with products of inertia.
    let j = Matrix3::new(0.25, 0.01, 0.0, 0.01, 0.46875, 0.02, 0.0, 0.02, 0.25);
    let m = top_of(
        j,
        UnitQuaternion::identity(),
        Vector3::new(0.0, 150.0, -4.61538),
    );
    // Positions and the kinetic energy: at 150 rad/s the gyroscopic moments are 10⁴ N m, and what Newton's
    // tolerance leaves in the multipliers, differences of ∫λ² dt amplify as the step falls
    // (measured over 120 steps: 7e-7 from the exact value with a step of 1e-3, 6e-6 with
    // 1e-4, 4e-4 with 1e-5 — noise, while the positions agree to 1e-11). The reactions'
    // gradients are checked on the mechanism below.
    let responses = [
        Response::Position { body: 0, axis: 0 },
        Response::Position { body: 0, axis: 2 },
        Response::KineticEnergy,
    ];
    let parameters = [
        Parameter::Mass { body: 0 },
        Parameter::Inertia {
            body: 0,
            i: 1,
            j: 1,
        },
        Parameter::Inertia {
            body: 0,
            i: 0,
            j: 2,
        },
    ];
    // Uneven steps: the pseudo-accelerations' carry to a new step is differentiated too.
    let steps: Vec<f64> = (0..120)
        .map(|n| if n % 3 == 0 { 1.5e-3 } else { 1e-3 })
        .collect();
    check(
        &m,
        0.9,
        &TimeGrid::from_steps(steps),
        &responses,
        &parameters,
    );
}

/// A slider-crank driven at its crank (revolute, spherical, universal, prismatic), a
/// bracket welded to its slider and a sleeve on a cylindrical joint along the bracket, a
/// spring-damper, a motor and a load: its
/// slider's and sleeve's places, the drive's effort `∫τ² dt` and the pin's `∫F_x² dt`, to
/// three bodies' masses, two inertias, the springs' constants and rest lengths or angles and
/// the motor's torque, and to every joint's place.
#[test]
fn every_joint_kind_has_exact_gradients() {
    let (r, l) = (0.15, 0.3);
    let rod = |m: f64, length: f64| {
        Matrix3::from_diagonal(&Vector3::new(
            m * 1e-4,
            m * length * length / 12.0,
            m * length * length / 12.0,
        ))
    };
    let at = |x: f64, y: f64| Frame::new(Vector3::new(x, y, 0.0), UnitQuaternion::identity());
    let mut m = SpatialModel::new(Vector3::new(0.0, -9.81, -3.0)).unwrap();
    let crank = m
        .add_body("crank", at(r / 2.0, 0.0), 0.4, rod(0.4, r))
        .unwrap();
    let link = m
        .add_body("rod", at(r + l / 2.0, 0.0), 0.6, rod(0.6, l))
        .unwrap();
    let slider = m
        .add_body("slider", at(r + l, 0.0), 0.3, Matrix3::identity() * 1e-3)
        .unwrap();
    let bracket = m
        .add_body("bracket", at(r + l, 0.1), 0.2, Matrix3::identity() * 2e-4)
        .unwrap();
    let sleeve = m
        .add_body(
            "sleeve",
            at(r + l + 0.05, 0.1),
            0.1,
            Matrix3::from_diagonal(&Vector3::new(1e-4, 2e-4, 2e-4)),
        )
        .unwrap();
    let point = |body, x: f64, y: f64| Anchor::Body {
        body,
        point: Vector3::new(x, y, 0.0),
    };
    let drive = m
        .add_joint(
            "crank",
            JointKind::Revolute { axis: Vector3::z() },
            Anchor::Ground(Vector3::zeros()),
            point(crank, -r / 2.0, 0.0),
        )
        .unwrap();
    m.add_joint(
        "pin",
        JointKind::Spherical,
        point(crank, r / 2.0, 0.0),
        point(link, -l / 2.0, 0.0),
    )
    .unwrap();
    let cardan = JointKind::Universal {
        axis_a: Vector3::y(),
        axis_b: Vector3::z(),
    };
    m.add_joint(
        "wrist",
        cardan,
        point(link, l / 2.0, 0.0),
        point(slider, 0.0, 0.0),
    )
    .unwrap();
    m.add_joint(
        "slide",
        JointKind::Prismatic { axis: Vector3::x() },
        Anchor::Ground(Vector3::new(r + l, 0.0, 0.0)),
        point(slider, 0.0, 0.0),
    )
    .unwrap();
    m.add_joint(
        "weld",
        JointKind::Weld,
        point(slider, 0.0, 0.05),
        point(bracket, 0.0, -0.05),
    )
    .unwrap();
    m.add_joint(
        "sleeve",
        JointKind::Cylindrical {
            axis: Vector3::new(1.0, 0.0, 0.3),
        },
        point(bracket, 0.0, 0.0),
        point(sleeve, -0.05, 0.0),
    )
    .unwrap();
    m.add_drive(
        drive,
        // A spline whose acceleration is continuous over the run (its table ends after it):
        // no restart, which the gradients do not differentiate yet.
        Motion::Table(Table::new(
            vec![0.0, 0.1, 0.2, 0.4],
            vec![0.0, 0.5, 1.5, 3.0],
            [0.0, 10.0],
        )),
    )
    .unwrap();
    // Force elements: a spring-damper from the sleeve to the ground, a motor helping the
    // drive, a dead load on the bracket, a torsion spring on the sleeve.
    let anchor = Anchor::Ground(Vector3::new(r + l + 0.3, 0.3, 0.1));
    m.add_spring(
        "tether",
        point(sleeve, 0.05, 0.0),
        anchor,
        40.0,
        0.5,
        Some(0.2),
    )
    .unwrap();
    m.add_motor("motor", drive, 0.3, TimeFunction::Constant)
        .unwrap();
    let push = (Vector3::new(0.0, 0.0, 1.0), Vector3::new(0.01, 0.0, 0.0));
    m.add_load(
        "push",
        Anchor::Body {
            body: bracket,
            point: Vector3::new(0.02, 0.0, 0.0),
        },
        push.0,
        push.1,
        TimeFunction::Constant,
        false,
    )
    .unwrap();
    // A torsion spring-damper on the sleeve's turn, at rest 0.2 rad from where it is built.
    m.add_torsion("coil", 5, 0.02, 2e-4, Some(0.2)).unwrap();
    // The forces the spherical pin, the prismatic slide (normal to its axis), the weld and
    // the cylindrical sleeve transmit, condensed over the motion: p-means and a KS mean.
    let ks = Aggregation::KsMean {
        rho: 20.0,
        scale: 5.0,
    };
    let p = |p: f64| Aggregation::PMean { p };
    let reactions = [(1, p(8.0)), (3, p(2.0)), (4, ks), (5, p(4.0))]
        .map(|(joint, aggregation)| Response::Reaction { joint, aggregation });
    let mut responses = vec![
        Response::Position { body: 2, axis: 0 },
        Response::Position { body: 4, axis: 2 },
        Response::Effort { joint: 0, row: 5 },
        // A reaction's component: the pin's force along x.
        Response::Effort { joint: 1, row: 0 },
        Response::KineticEnergy,
        // The drive's torque, condensed likewise.
        Response::Torque {
            joint: 0,
            aggregation: p(8.0),
        },
    ];
    responses.extend(reactions);
    let parameters = [
        Parameter::Mass { body: 0 },
        Parameter::Mass { body: 1 },
        Parameter::Mass { body: 4 },
        Parameter::Inertia {
            body: 1,
            i: 2,
            j: 2,
        },
        Parameter::Inertia {
            body: 4,
            i: 0,
            j: 0,
        },
        Parameter::SpringStiffness { force: 0 },
        Parameter::SpringDamping { force: 0 },
        Parameter::MotorTorque { force: 1 },
        Parameter::SpringStiffness { force: 3 },
        Parameter::SpringDamping { force: 3 },
        Parameter::SpringRest { force: 0 },
        Parameter::SpringRest { force: 3 },
        // Every joint's place: the driven crank's pivot on the ground, the pin, the wrist,
        // the slide, the weld and the sleeve, each along one axis or two.
        Parameter::JointPosition { joint: 0, axis: 0 },
        Parameter::JointPosition { joint: 1, axis: 0 },
        Parameter::JointPosition { joint: 1, axis: 1 },
        Parameter::JointPosition { joint: 2, axis: 2 },
        Parameter::JointPosition { joint: 3, axis: 1 },
        Parameter::JointPosition { joint: 4, axis: 0 },
        Parameter::JointPosition { joint: 5, axis: 2 },
    ];
    check(
        &m,
        0.8,
        &TimeGrid::uniform(2e-3, 150),
        &responses,
        &parameters,
    );
}
