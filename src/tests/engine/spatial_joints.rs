//! Spatial joints and drives in motion: a pendulum on an oblique hinge against its elliptic
//! period, a slider-crank built in space against its closed-form kinematics and the drive's
//! work against the energy it gives.

use crate::group::{so3, Frame};
use crate::motion::{Motion, Table};
use crate::spatial::joint::{Anchor, JointKind};
use crate::spatial::model::SpatialModel;
use crate::State;
use nalgebra::{Matrix3, Vector3};

use super::spatial::run;

const G: f64 = 9.81;

/// The complete elliptic integral of the first kind `K(k)`, by the arithmetic–geometric
/// mean.
fn elliptic_k(k: f64) -> f64 {
    let (mut a, mut b) = (1.0, (1.0 - k * k).sqrt());
    while (a - b).abs() > 1e-16 * a {
        (a, b) = (0.5 * (a + b), (a * b).sqrt());
    }
    std::f64::consts::PI / (2.0 * a)
}

/// A body with an arbitrary inertia hinged about an oblique axis through the origin, its
/// centre of mass at `d` from the axis, released at rest `amplitude` from its lowest place:
/// its period is `4 K(sin(θ₀/2))/ω₀`, `ω₀² = m g⊥ d / I_n`, `g⊥` gravity's part normal to
/// the axis and `I_n` the inertia about it. Measured between the first and the third
/// passage through the lowest place, it converges to that at order 2 in h.
#[test]
fn a_pendulum_on_an_oblique_hinge_swings_at_its_elliptic_period() {
    let n = Vector3::new(1.0, 1.0, 2.0).normalize();
    let (mass, d, amplitude) = (3.0, 0.4, 2.0);
    let down = -Vector3::z();
    let lowest = (down - n * down.dot(&n)).normalize();
    let start = so3::exp(&(n * amplitude)) * lowest;
    let r0 = so3::exp(&Vector3::new(0.3, -0.2, 0.5));
    let j = Matrix3::new(0.05, 0.01, -0.02, 0.01, 0.08, 0.005, -0.02, 0.005, 0.07);
    let mut m = SpatialModel::new(down * G).unwrap();
    let body = m
        .add_body("bob", Frame::new(start * d, r0), mass, j)
        .unwrap();
    let arm = r0.inverse() * (-start * d);
    m.add_joint(
        "hinge",
        JointKind::Revolute { axis: n },
        Anchor::Body { body, point: arm },
        Anchor::Ground(Vector3::zeros()),
    )
    .unwrap();
    let i_n = n.dot(&(r0 * (j * (r0.inverse() * n)))) + mass * d * d;
    let g_normal = G * (1.0 - n.z * n.z).sqrt();
    let omega0 = (mass * g_normal * d / i_n).sqrt();
    let period = 4.0 * elliptic_k((amplitude / 2.0).sin()) / omega0;
    // The signed angle of the arm from the lowest place, about n.
    let angle = |s: &State| {
        let e = Frame::read(&s.q, 0).x.normalize();
        lowest.cross(&e).dot(&n).atan2(lowest.dot(&e))
    };
    let measured = |h: f64| {
        let states = run(&m, 0.9, h, (1.6 * period / h) as usize);
        let mut crossings = Vec::new();
        for w in states.windows(2) {
            let (a, b) = (angle(&w[0]), angle(&w[1]));
            if a.signum() != b.signum() && (a - b).abs() < 1.0 {
                crossings.push(w[0].t + h * a / (a - b));
            }
        }
        crossings[2] - crossings[0]
    };
    let errors: Vec<f64> = [4e-3, 2e-3, 1e-3]
        .iter()
        .map(|&h| (measured(h) - period).abs() / period)
        .collect();
    println!("period {period:.6} s, relative errors {errors:?}");
    assert!(errors[2] < 1e-4, "{errors:?}");
    let order = (errors[1] / errors[2]).log2();
    assert!((1.8..2.3).contains(&order), "order {order}: {errors:?}");
}

/// Crank `r`, rod `l`, slider, moving in the plane z = 0 under gravity.
struct SliderCrank {
    model: SpatialModel,
    r: f64,
    l: f64,
    omega: f64,
}

/// The slider-crank built in space: the crank on a driven revolute joint, the rod on a
/// spherical joint at the crank's pin and a universal joint at the slider, the slider on a
/// prismatic joint along x; started at the dead centre, the crank turning at `omega`.
fn slider_crank(omega: f64) -> SliderCrank {
    let (r, l) = (0.15, 0.3);
    let rod_inertia = |m: f64, length: f64| {
        Matrix3::from_diagonal(&Vector3::new(
            m * 1e-4 / 8.0,
            m * length * length / 12.0,
            m * length * length / 12.0,
        ))
    };
    let at = |x: f64| {
        Frame::new(
            Vector3::new(x, 0.0, 0.0),
            nalgebra::UnitQuaternion::identity(),
        )
    };
    let mut m = SpatialModel::new(Vector3::new(0.0, -G, 0.0)).unwrap();
    let crank = m
        .add_body("crank", at(r / 2.0), 0.4, rod_inertia(0.4, r))
        .unwrap();
    let rod = m
        .add_body("rod", at(r + l / 2.0), 0.6, rod_inertia(0.6, l))
        .unwrap();
    let slider = m
        .add_body("slider", at(r + l), 0.3, Matrix3::identity() * 1e-4)
        .unwrap();
    let point = |body, x: f64| Anchor::Body {
        body,
        point: Vector3::new(x, 0.0, 0.0),
    };
    let drive = m
        .add_joint(
            "crank",
            JointKind::Revolute { axis: Vector3::z() },
            Anchor::Ground(Vector3::zeros()),
            point(crank, -r / 2.0),
        )
        .unwrap();
    m.add_joint(
        "pin",
        JointKind::Spherical,
        point(crank, r / 2.0),
        point(rod, -l / 2.0),
    )
    .unwrap();
    let cardan = JointKind::Universal {
        axis_a: Vector3::y(),
        axis_b: Vector3::z(),
    };
    m.add_joint("wrist", cardan, point(rod, l / 2.0), point(slider, 0.0))
        .unwrap();
    m.add_joint(
        "slide",
        JointKind::Prismatic { axis: Vector3::x() },
        Anchor::Ground(Vector3::new(r + l, 0.0, 0.0)),
        point(slider, 0.0),
    )
    .unwrap();
    m.add_drive(
        drive,
        Motion::Table(Table::new(vec![0.0, 1.0], vec![0.0, omega], [omega, omega])),
    )
    .unwrap();
    // At the dead centre: the pin moves at r ω along y, the rod turns at −r ω / l.
    m.set_rates(
        crank,
        Vector3::new(0.0, r * omega / 2.0, 0.0),
        Vector3::new(0.0, 0.0, omega),
    )
    .unwrap();
    m.set_rates(
        rod,
        Vector3::new(0.0, r * omega / 2.0, 0.0),
        Vector3::new(0.0, 0.0, -r * omega / l),
    )
    .unwrap();
    SliderCrank {
        model: m,
        r,
        l,
        omega,
    }
}

/// The slider follows `x = r cos θ + √(l² − r² sin²θ)` to Newton's tolerance at every step
/// (index-3 constraints hold exactly), over two turns.
#[test]
fn a_spatial_slider_crank_follows_its_closed_form() {
    let sc = slider_crank(10.0);
    let states = run(&sc.model, 0.8, 2e-3, 1300);
    let mut worst = 0.0f64;
    for s in &states {
        let theta = sc.omega * s.t;
        let exact = sc.r * theta.cos() + (sc.l * sc.l - (sc.r * theta.sin()).powi(2)).sqrt();
        let slider = Frame::read(&s.q, 2).x;
        worst = worst
            .max((slider.x - exact).abs())
            .max(slider.y.abs())
            .max(slider.z.abs());
    }
    println!("worst slider error {worst:.3e} m");
    assert!(worst < 1e-10, "{worst:.3e}");
}

/// The drive's work `∫ τ ψ̇ dt`, `τ = −λ` its multiplier (the generalized force it applies),
/// equals the kinetic and potential energy it gives the mechanism, to an error that falls
/// at order 2 in h.
#[test]
fn the_drive_works_as_the_energy_changes() {
    let sc = slider_crank(10.0);
    let m = &sc.model;
    let energy = |s: &State| m.kinetic_energy(&s.qdot) + m.potential_energy(&s.q);
    let mismatch = |h: f64| {
        let states = run(m, 0.8, h, (1.2 / h).round() as usize);
        let drive_row = m.joint_rows(0).unwrap().end - 1;
        let power = |s: &State| -s.lam[drive_row] * sc.omega;
        let work: f64 = states
            .windows(2)
            .map(|w| 0.5 * (power(&w[0]) + power(&w[1])) * (w[1].t - w[0].t))
            .sum();
        let gained = energy(states.last().unwrap()) - energy(&states[0]);
        let peak = states
            .iter()
            .map(|s| (energy(s) - energy(&states[0])).abs())
            .fold(0.0, f64::max);
        (work - gained).abs() / peak
    };
    let errors = [mismatch(2e-3), mismatch(1e-3)];
    println!("relative mismatch {errors:?}");
    assert!(errors[1] < 1e-3, "{errors:?}");
    let order = (errors[0] / errors[1]).log2();
    assert!((1.7..2.4).contains(&order), "order {order}");
}

/// A wheel on a hinge about an oblique axis driven by a trapezoidal law, whose acceleration
/// jumps at four kinks the grid lands on: with the restart there the drive's multiplier is
/// the inverse dynamics `λ = −I_n ψ̈(t)` at every state (the left limit at a kink); without
/// it, on a grid that steps over the kinks by a hair, it would ring after each.
#[test]
fn a_drive_restarts_at_its_kinks() {
    use crate::motion::Trapezoidal;
    let n = Vector3::new(0.3, -0.2, 1.0).normalize();
    let r0 = so3::exp(&Vector3::new(0.2, 0.4, -0.1));
    let j = Matrix3::new(0.3, 0.02, 0.0, 0.02, 0.2, 0.01, 0.0, 0.01, 0.25);
    let mut m = SpatialModel::new(Vector3::zeros()).unwrap();
    let wheel = m
        .add_body("wheel", Frame::new(Vector3::zeros(), r0), 2.0, j)
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
    let law = Motion::Trapezoidal(Trapezoidal::new(0.0, 2.0, 10.0, 2.0, 0.1));
    m.add_drive(axle, law.clone()).unwrap();
    let i_n = n.dot(&(r0 * (j * (r0.inverse() * n))));
    let row = m.joint_rows(axle).unwrap().end - 1;
    let worst = |steps: Vec<f64>| {
        let states = run_on(&m, 0.8, steps);
        states
            .iter()
            .map(|s| {
                // At a kink the multiplier is the left limit: the old piece's acceleration.
                let kink = law.kinks().into_iter().find(|&k| (k - s.t).abs() < 1e-9);
                let t = kink.map_or(s.t, f64::next_down);
                (s.lam[row] + i_n * law.at(t).acceleration).abs()
            })
            .fold(0.0, f64::max)
    };
    let landing = worst(vec![0.01; 150]);
    // 1e-7 short of every hundredth of a second: the same steps, no state on a kink.
    let missing = worst(
        (0..150)
            .map(|k| if k == 0 { 0.01 - 1e-7 } else { 0.01 })
            .collect(),
    );
    let scale = i_n * 10.0;
    println!("largest |λ + I ψ̈|: {landing:.3e} landing on the kinks, {missing:.3e} stepping over them (I ψ̈ = {scale:.3})");
    assert!(landing < 1e-6 * scale, "{landing:.3e}");
    assert!(
        missing > 0.1 * scale,
        "without the restart the multiplier should ring: {missing:.3e}"
    );
}

fn run_on(model: &SpatialModel, rho_inf: f64, steps: Vec<f64>) -> Vec<State> {
    crate::spatial::integrator::simulate_spatial(
        model,
        &super::spatial::settings(rho_inf),
        &crate::TimeGrid::from_steps(steps),
    )
    .unwrap()
}
