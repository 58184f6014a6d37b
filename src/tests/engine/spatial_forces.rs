//! Spatial force elements in motion: a mass on an oblique spring against `√(k/m)` and its
//! damped decay, a motor spinning a wheel about an oblique axis, the energy of bodies joined
//! by a spring under a dead load.

use crate::group::{so3, Frame};
use crate::load::TimeFunction;
use crate::spatial::joint::{Anchor, JointKind};
use crate::spatial::model::SpatialModel;
use crate::State;
use nalgebra::{Matrix3, UnitQuaternion, Vector3};

use super::spatial::run;

/// A body on a spring along the oblique line `n` from a ground point, released `s₀` from
/// its rest length: `s(t) = s₀ e^{−ζωt}(cos ω_d t + (ζω/ω_d) sin ω_d t)`, `ω² = k/m`,
/// `ζ = c/(2√(km))`, `ω_d = ω√(1 − ζ²)`. Undamped and damped, the error at the end falls at
/// order 2 in h.
#[test]
fn a_mass_on_an_oblique_spring_oscillates_as_its_closed_form() {
    let n = Vector3::new(1.0, -2.0, 2.0).normalize();
    let (mass, k, rest, s0) = (2.0, 800.0, 0.5, 0.05);
    for c in [0.0, 4.0] {
        let mut m = SpatialModel::new(Vector3::zeros()).unwrap();
        let frame = Frame::new(n * (rest + s0), so3::exp(&Vector3::new(0.3, 0.1, -0.4)));
        let b = m
            .add_body(
                "bob",
                frame,
                mass,
                Matrix3::from_diagonal(&Vector3::new(0.01, 0.02, 0.025)),
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
            c,
            Some(rest),
        )
        .unwrap();
        let omega = (k / mass).sqrt();
        let zeta = c / (2.0 * (k * mass).sqrt());
        let wd = omega * (1.0 - zeta * zeta).sqrt();
        let t_end = 1.0;
        let exact = s0
            * (-zeta * omega * t_end).exp()
            * ((wd * t_end).cos() + zeta * omega / wd * (wd * t_end).sin());
        let error = |h: f64| {
            let states = run(&m, 0.9, h, (t_end / h).round() as usize);
            let x = Frame::read(&states.last().unwrap().q, 0).x;
            let off_line = (x - n * n.dot(&x)).norm();
            assert!(
                off_line < 1e-12,
                "the body left the spring's line by {off_line:.3e} m"
            );
            (n.dot(&x) - rest - exact).abs() / s0
        };
        let errors = [error(2e-3), error(1e-3), error(5e-4)];
        println!("c = {c}: relative errors {errors:?}");
        assert!(errors[2] < 2e-3, "{errors:?}");
        let order = (errors[1] / errors[2]).log2();
        assert!((1.8..2.3).contains(&order), "c = {c}: order {order}");
    }
}

/// A motor's constant torque `τ` turns a wheel on a hinge about an oblique axis `n` at
/// `φ = ½ (τ/I_n) t²`, `I_n` the wheel's inertia about the axis: to round-off, the scheme
/// being exact for a constant acceleration about a fixed axis.
#[test]
fn a_motor_spins_a_wheel_at_constant_acceleration() {
    let n = Vector3::new(0.2, 0.5, 1.0).normalize();
    let r0 = so3::exp(&Vector3::new(-0.3, 0.8, 0.2));
    let j = Matrix3::new(0.3, 0.02, 0.01, 0.02, 0.2, -0.03, 0.01, -0.03, 0.25);
    let mut m = SpatialModel::new(Vector3::new(0.0, 0.0, -9.81)).unwrap();
    let wheel = m
        .add_body("wheel", Frame::new(Vector3::new(1.0, 2.0, 0.5), r0), 4.0, j)
        .unwrap();
    let hinge = m
        .add_joint(
            "axle",
            JointKind::Revolute { axis: n },
            Anchor::Ground(Vector3::new(1.0, 2.0, 0.5)),
            Anchor::Body {
                body: wheel,
                point: Vector3::zeros(),
            },
        )
        .unwrap();
    let tau = 3.0;
    m.add_motor("motor", hinge, tau, TimeFunction::Constant)
        .unwrap();
    let i_n = n.dot(&(r0 * (j * (r0.inverse() * n))));
    let (h, steps) = (1e-2, 300);
    let states = run(&m, 0.8, h, steps);
    let mut worst = 0.0f64;
    for s in &states {
        let phi = 0.5 * tau / i_n * s.t * s.t;
        let exact = UnitQuaternion::from_scaled_axis(n * phi) * r0;
        worst = worst.max(Frame::read(&s.q, 0).r.angle_to(&exact));
    }
    println!(
        "worst rotation error {worst:.3e} rad after {:.1} rad",
        0.5 * tau / i_n * 9.0
    );
    assert!(worst < 1e-9, "{worst:.3e} rad");
}

/// Two bodies joined by a spring between points off their centres, one tethered to the
/// ground by another and pushed by a constant dead force at a point, at ρ∞ = 1: their energy (kinetic, the spring's, the
/// force's potential `−F·p`) oscillates in a band that falls at order 2 with h and does not
/// drift (over 20,000 steps the band of the first 5,000, within 10 %).
#[test]
fn bodies_on_a_spring_under_a_dead_load_keep_their_energy() {
    let mut m = SpatialModel::new(Vector3::zeros()).unwrap();
    let j = Matrix3::from_diagonal(&Vector3::new(0.05, 0.08, 0.1));
    let a = m
        .add_body(
            "a",
            Frame::new(Vector3::zeros(), UnitQuaternion::identity()),
            1.0,
            j,
        )
        .unwrap();
    let b = m
        .add_body(
            "b",
            Frame::new(
                Vector3::new(0.6, 0.1, 0.0),
                so3::exp(&Vector3::new(0.2, 0.0, 0.4)),
            ),
            1.5,
            j * 2.0,
        )
        .unwrap();
    m.add_spring(
        "spring",
        Anchor::Body {
            body: a,
            point: Vector3::new(0.1, 0.05, 0.0),
        },
        Anchor::Body {
            body: b,
            point: Vector3::new(-0.1, 0.0, 0.08),
        },
        500.0,
        0.0,
        Some(0.3),
    )
    .unwrap();
    // Tethered to the ground: the load then does bounded work.
    m.add_spring(
        "tether",
        Anchor::Ground(Vector3::new(-0.3, 0.0, 0.0)),
        Anchor::Body {
            body: a,
            point: Vector3::new(-0.1, 0.0, -0.05),
        },
        300.0,
        0.0,
        Some(0.2),
    )
    .unwrap();
    m.add_load(
        "push",
        Anchor::Body {
            body: a,
            point: Vector3::new(0.0, 0.1, 0.05),
        },
        Vector3::new(0.0, 0.0, 2.0),
        Vector3::zeros(),
        TimeFunction::Constant,
        false,
    )
    .unwrap();
    m.set_rates(a, Vector3::zeros(), Vector3::new(1.0, -2.0, 0.5))
        .unwrap();
    let energy = |s: &State| m.kinetic_energy(&s.qdot) + m.potential_energy(&s.q);
    let band = |states: &[State], n: usize| {
        let e0 = energy(&states[0]);
        states[..n]
            .iter()
            .map(|s| (energy(s) - e0).abs())
            .fold(0.0, f64::max)
            / e0.abs()
    };
    let coarse = run(&m, 1.0, 1e-3, 20_000);
    let fine = run(&m, 1.0, 5e-4, 10_000);
    let (first, long, halved) = (
        band(&coarse, 5_001),
        band(&coarse, 20_001),
        band(&fine, 10_001),
    );
    let order = (first / halved).log2();
    println!("energy bands {first:.3e} (5,000 steps), {long:.3e} (20,000), {halved:.3e} (h/2); order {order:.2}");
    assert!(first < 1e-3 && (1.8..2.2).contains(&order), "order {order}");
    // A secular drift would grow the band fourfold over four times the steps; the bodies
    // tumble through new configurations, so its extremes may move a little.
    assert!(
        long < 1.1 * first,
        "the energy drifts: {long:.3e} against {first:.3e}"
    );
}

/// A wheel on an oblique axle held by a torsion spring-damper whose rest angle is `−φ₀`
/// from where the wheel is built and released, no gravity: its turn from rest `φ(t)` is the
/// damped oscillator's closed form with `ω² = k/I_n`, `ζ = c/(2√(k I_n))`, undamped and
/// damped; the error at the end falls at order 2 in h.
#[test]
fn a_torsion_spring_swings_a_wheel_as_its_closed_form() {
    let n = Vector3::new(0.3, -0.4, 1.0).normalize();
    let r0 = so3::exp(&Vector3::new(0.5, 0.1, -0.7));
    let j = Matrix3::new(0.3, 0.02, 0.01, 0.02, 0.2, -0.03, 0.01, -0.03, 0.25);
    let i_n = n.dot(&(r0 * (j * (r0.inverse() * n))));
    let (k, phi0) = (40.0, 0.6);
    for zeta in [0.0, 0.1] {
        let c = 2.0 * zeta * (k * i_n).sqrt();
        let mut m = SpatialModel::new(Vector3::zeros()).unwrap();
        let wheel = m
            .add_body("wheel", Frame::new(Vector3::zeros(), r0), 4.0, j)
            .unwrap();
        let axle = m
            .add_joint(
                "axle",
                JointKind::Revolute { axis: n },
                Anchor::Ground(Vector3::zeros()),
                Anchor::Body {
                    body: wheel,
                    point: Vector3::zeros(),
                },
            )
            .unwrap();
        m.add_torsion("coil", axle, k, c, Some(-phi0)).unwrap();
        let omega = (k / i_n).sqrt();
        let wd = omega * (1.0 - zeta * zeta).sqrt();
        let exact = |t: f64| {
            phi0 * (-zeta * omega * t).exp() * ((wd * t).cos() + zeta * omega / wd * (wd * t).sin())
        };
        let t_end = 0.5;
        let error = |steps: usize| {
            let states = run(&m, 0.9, t_end / steps as f64, steps);
            let last = states.last().unwrap();
            // the wheel's turn about n from where it was built: φ − φ₀
            let turned = Frame::read(&last.q, 0).r * r0.inverse();
            let angle = turned.scaled_axis().dot(&n);
            (angle - (exact(last.t) - phi0)).abs()
        };
        let (coarse, fine) = (error(200), error(400));
        let order = (coarse / fine).log2();
        println!("ζ = {zeta}: errors {coarse:.3e}, {fine:.3e}, order {order:.2}");
        assert!(fine < 1e-3 * phi0 && (order - 2.0).abs() < 0.15, "{order}");
    }
}
