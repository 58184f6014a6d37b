//! Static equilibria of spatial mechanisms against closed forms: a body hung on a spring, a
//! pendulum on an oblique hinge pushed sideways by a dead force, a motor holding a pendulum
//! up; a motor too weak for any equilibrium named.

use crate::group::Frame;
use crate::load::TimeFunction;
use crate::spatial::joint::{Anchor, JointKind};
use crate::spatial::model::SpatialModel;
use crate::spatial::statics::solve_static_spatial;
use crate::{Error, NewtonMatrix, SolveError, StaticSettings};
use nalgebra::{Matrix3, UnitQuaternion, Vector3};

const G: f64 = 9.81;

fn settings(load_steps: usize) -> StaticSettings {
    StaticSettings {
        load_steps,
        time: 0.0,
        tol: 1e-12,
        max_iter: 30,
        newton: NewtonMatrix::Full,
        max_cuts: 8,
    }
}

fn at(x: Vector3<f64>) -> Frame {
    Frame::new(x, UnitQuaternion::identity())
}

/// A body on a vertical spring stretches it by `m g / k`, its multiplier-free equilibrium
/// exact to Newton's tolerance.
#[test]
fn a_body_hangs_on_a_spring() {
    let (mass, k) = (2.0, 500.0);
    let mut m = SpatialModel::new(Vector3::new(0.0, 0.0, -G)).unwrap();
    let b = m
        .add_body(
            "bob",
            at(Vector3::new(0.0, 0.0, -1.0)),
            mass,
            Matrix3::identity() * 0.01,
        )
        .unwrap();
    m.add_spring(
        "spring",
        Anchor::Ground(Vector3::zeros()),
        Anchor::Body {
            body: b,
            point: Vector3::zeros(),
        },
        k,
        0.0,
        None,
    )
    .unwrap();
    let eq = solve_static_spatial(&m, &settings(1)).unwrap();
    let x = Frame::read(&eq.q, 0).x;
    let expected = Vector3::new(0.0, 0.0, -1.0 - mass * G / k);
    assert!((x - expected).norm() < 1e-12, "{x:?} against {expected:?}");
}

/// A pendulum on a hinge about an oblique horizontal axis, pushed by a dead force `F`
/// normal to the axis and to gravity at its centre of mass, turns to `tan θ = F/(m g)`;
/// the hinge's force balances the weight and the push; with either Newton matrix.
#[test]
fn a_pushed_pendulum_leans_to_its_closed_form() {
    let n = Vector3::new(1.0, 2.0, 0.0).normalize();
    let (mass, d, push) = (3.0, 0.8, 12.0);
    let mut m = SpatialModel::new(Vector3::new(0.0, 0.0, -G)).unwrap();
    let b = m
        .add_body(
            "bob",
            at(Vector3::new(0.0, 0.0, -d)),
            mass,
            Matrix3::from_diagonal(&Vector3::new(0.02, 0.03, 0.01)),
        )
        .unwrap();
    let hinge = m
        .add_joint(
            "hinge",
            JointKind::Revolute { axis: n },
            Anchor::Ground(Vector3::zeros()),
            Anchor::Body {
                body: b,
                point: Vector3::new(0.0, 0.0, d),
            },
        )
        .unwrap();
    let side = n.cross(&Vector3::z());
    m.add_load(
        "push",
        Anchor::Body {
            body: b,
            point: Vector3::zeros(),
        },
        side * push,
        Vector3::zeros(),
        TimeFunction::Constant,
        false,
    )
    .unwrap();
    // The modified Newton matrix (the factors kept while they contract) reaches the same
    // equilibrium.
    for newton in [NewtonMatrix::Modified, NewtonMatrix::Full] {
        let eq = solve_static_spatial(
            &m,
            &StaticSettings {
                newton,
                ..settings(4)
            },
        )
        .unwrap();
        let x = Frame::read(&eq.q, 0).x;
        let theta = (push / (mass * G)).atan();
        let expected = (side * theta.sin() - Vector3::z() * theta.cos()) * d;
        assert!(
            (x - expected).norm() < 1e-10,
            "{newton:?}: {x:?} against {expected:?}"
        );
    }
    let eq = solve_static_spatial(&m, &settings(4)).unwrap();
    // The hinge's rows 0..3 are the force on the ground's point from the body's: it carries
    // the weight and the push.
    let rows = m.joint_rows(hinge).unwrap();
    let reaction = Vector3::new(
        eq.lambda[rows.start],
        eq.lambda[rows.start + 1],
        eq.lambda[rows.start + 2],
    );
    let carried = Vector3::new(0.0, 0.0, -mass * G) + side * push;
    assert!(
        (reaction.norm() - carried.norm()).abs() < 1e-9 * carried.norm(),
        "{reaction:?} against ±{carried:?}"
    );
}

/// A motor's torque `τ` holds a pendulum at `sin θ = τ/(m g d)`; a torque above `m g d`
/// has no equilibrium, and the solve fails saying at which load factor.
#[test]
fn a_motor_holds_a_pendulum_up_or_cannot() {
    let (mass, d) = (2.0, 0.5);
    let build = |tau: f64| {
        let mut m = SpatialModel::new(Vector3::new(0.0, 0.0, -G)).unwrap();
        let b = m
            .add_body(
                "arm",
                at(Vector3::new(0.0, 0.0, -d)),
                mass,
                Matrix3::identity() * 0.01,
            )
            .unwrap();
        let hinge = m
            .add_joint(
                "shoulder",
                JointKind::Revolute { axis: Vector3::y() },
                Anchor::Ground(Vector3::zeros()),
                Anchor::Body {
                    body: b,
                    point: Vector3::new(0.0, 0.0, d),
                },
            )
            .unwrap();
        m.add_motor("motor", hinge, tau, TimeFunction::Constant)
            .unwrap();
        m
    };
    let tau = 0.6 * mass * G * d;
    let m = build(tau);
    let eq = solve_static_spatial(&m, &settings(3)).unwrap();
    let x = Frame::read(&eq.q, 0).x;
    let theta = (tau / (mass * G * d)).asin();
    // A torque about +y turns the arm from −z towards −x.
    let expected = Vector3::new(-theta.sin(), 0.0, -theta.cos()) * d;
    assert!((x - expected).norm() < 1e-10, "{x:?} against {expected:?}");
    let err = solve_static_spatial(&build(1.5 * mass * G * d), &settings(3)).unwrap_err();
    // Gravity and the motor grow together with the load factor: no step finds an
    // equilibrium, and the last failure is reported once the first step is halved
    // max_cuts times.
    assert!(
        matches!(
            err,
            Error::Solve(SolveError::NewtonFailed { .. } | SolveError::LoadStepping { .. })
        ),
        "{err}"
    );
    assert!(err.to_string().contains("load factor"), "{err}");
}

/// A motor's torque `τ` on a hinge held by a torsion spring `k` turns it by `τ/k` from the
/// spring's rest angle, about an oblique axis; a spring turned past half a turn is named.
#[test]
fn a_torsion_spring_balances_a_motor() {
    let n = Vector3::new(1.0, 2.0, -0.5).normalize();
    let build = |tau: f64| {
        let mut m = SpatialModel::new(Vector3::zeros()).unwrap();
        let b = m
            .add_body(
                "disc",
                at(Vector3::new(0.0, 0.0, 0.0)),
                1.0,
                Matrix3::identity() * 0.01,
            )
            .unwrap();
        let hinge = m
            .add_joint(
                "hinge",
                JointKind::Revolute { axis: n },
                Anchor::Ground(Vector3::zeros()),
                Anchor::Body {
                    body: b,
                    point: Vector3::zeros(),
                },
            )
            .unwrap();
        m.add_torsion("coil", hinge, 5.0, 0.0, Some(0.25)).unwrap();
        m.add_motor("motor", hinge, tau, TimeFunction::Constant)
            .unwrap();
        m
    };
    let eq = solve_static_spatial(&build(2.0), &settings(4)).unwrap();
    let turned = Frame::read(&eq.q, 0).r.scaled_axis();
    assert!(
        (turned - n * (0.25 + 2.0 / 5.0)).norm() < 1e-10,
        "{turned:?}"
    );
    let err = solve_static_spatial(&build(20.0), &settings(4)).unwrap_err();
    assert!(err.to_string().contains("torsion spring 'coil'"), "{err}");
}

/// A body on a hinge about the vertical, its drive turning it 2.5 rad by the time asked:
/// the drive moves with the load steps (more than the π/2 one load step may turn a node,
/// so the steps are cut), and the body rests turned by the law's angle, to round-off.
#[test]
fn a_drive_carries_a_body_far_from_its_start() {
    use crate::motion::{Motion, Trapezoidal};
    let d = 0.7;
    let mut m = SpatialModel::new(Vector3::new(0.0, 0.0, -G)).unwrap();
    let b = m
        .add_body(
            "arm",
            at(Vector3::new(d, 0.0, 0.0)),
            2.0,
            Matrix3::from_diagonal(&Vector3::new(0.01, 0.02, 0.03)),
        )
        .unwrap();
    let hinge = m
        .add_joint(
            "hinge",
            JointKind::Revolute { axis: Vector3::z() },
            Anchor::Ground(Vector3::zeros()),
            Anchor::Body {
                body: b,
                point: Vector3::new(-d, 0.0, 0.0),
            },
        )
        .unwrap();
    let law = Motion::Trapezoidal(Trapezoidal::new(0.0, 2.5, 10.0, 2.0, 0.0));
    m.add_drive(hinge, law.clone()).unwrap();
    let time = 2.0;
    let angle = law.at(time).angle - law.at(0.0).angle;
    assert!((angle - 2.5).abs() < 1e-12, "the law has ended: {angle}");
    let eq = solve_static_spatial(
        &m,
        &StaticSettings {
            time,
            ..settings(1)
        },
    )
    .unwrap();
    let x = Frame::read(&eq.q, 0).x;
    let expected = Vector3::new(angle.cos(), angle.sin(), 0.0) * d;
    assert!((x - expected).norm() < 1e-10, "{x:?} against {expected:?}");
    assert!(eq.load_steps > 1, "{} load steps", eq.load_steps);
}
