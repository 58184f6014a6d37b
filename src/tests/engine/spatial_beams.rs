//! The spatial beam in statics and in motion: the Bathe–Bolourchi 45° bend, the roll-up of a
//! straight beam into a circle by an end moment (also turned obliquely in space), a
//! cantilever's first frequency against Timoshenko's, and exact gradients of a flexible
//! pendulum to its beams' stiffness and mass.

use std::f64::consts::PI;

use crate::group::{so3, Frame};
use crate::load::TimeFunction;
use crate::spatial::integrator::simulate_spatial;
use crate::spatial::joint::{Anchor, JointKind};
use crate::spatial::model::SpatialModel;
use crate::spatial::section::{Geometry, Section, Shape};
use crate::spatial::sensitivity::{Elements, Parameter, Response};
use crate::spatial::statics::solve_static_spatial;
use crate::spatial::stress::Criterion;
use crate::Aggregation;
use crate::{DynamicSettings, MassKind, NewtonMatrix, StaticSettings, TimeGrid};
use nalgebra::{UnitQuaternion, Vector3};

use super::spatial_sensitivity::{check, moved};

fn statics(load_steps: usize) -> StaticSettings {
    StaticSettings {
        load_steps,
        time: 0.0,
        tol: 1e-10,
        max_iter: 40,
        newton: NewtonMatrix::Full,
        max_cuts: 8,
    }
}

/// A chain of beams through `points`, clamped at the first (a weld to the ground), the
/// sections' `e₂` along `up`; returns the model and its last node.
fn clamped_chain(
    points: &[Vector3<f64>],
    section: &Section,
    up: Vector3<f64>,
    gravity: Vector3<f64>,
) -> (SpatialModel, usize) {
    let mut m = SpatialModel::new(gravity).unwrap();
    let nodes: Vec<usize> = points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            m.add_node(&format!("n{i}"), Frame::new(*p, UnitQuaternion::identity()))
                .unwrap()
        })
        .collect();
    for (i, w) in nodes.windows(2).enumerate() {
        m.add_beam(&format!("b{i}"), w[0], w[1], section, up)
            .unwrap();
    }
    let root = Anchor::Node {
        node: nodes[0],
        point: Vector3::zeros(),
    };
    m.add_joint("clamp", JointKind::Weld, root, Anchor::Ground(points[0]))
        .unwrap();
    (m, *nodes.last().unwrap())
}

/// The 45° bend of Bathe & Bolourchi in `elements` beams of Simo & Vu-Quoc's section
/// (EA = 1e7, GA = 5e6, GJ = EI = 833,333, ρ = 1), under `gravity` and a dead tip load
/// `load` across its plane; returns the model and the tip.
fn bend(elements: usize, gravity: f64, load: f64) -> (SpatialModel, usize) {
    let square = Geometry {
        area: 1.0,
        i2: 1.0 / 12.0,
        i3: 1.0 / 12.0,
        torsion: 1.0 / 6.0,
        shear: [1.0, 1.0],
        fibres: Shape::Rectangle { b: 1.0, h: 1.0 }
            .geometry(0.0)
            .expect("a unit square")
            .fibres,
    };
    let section = Section::new(&square, 1e7, 5e6, 1.0);
    let points: Vec<Vector3<f64>> = (0..=elements)
        .map(|i| {
            let phi = PI / 4.0 * i as f64 / elements as f64;
            Vector3::new(100.0 * (1.0 - phi.cos()), 100.0 * phi.sin(), 0.0)
        })
        .collect();
    let down = Vector3::new(0.0, 0.0, -gravity);
    let (mut m, tip) = clamped_chain(&points, &section, Vector3::z(), down);
    let at = Anchor::Node {
        node: tip,
        point: Vector3::zeros(),
    };
    let force = Vector3::new(0.0, 0.0, load);
    m.add_load(
        "tip",
        at,
        force,
        Vector3::zeros(),
        TimeFunction::Constant,
        false,
    )
    .unwrap();
    (m, tip)
}

/// The 45° bend of Bathe & Bolourchi (radius 100, unit square section, E = 1e7, ν = 0),
/// under a dead tip load of 600 across its plane: published tips (15.79, 47.23, 53.37) with 8
/// elements (Simo & Vu-Quoc 1986; Bathe & Bolourchi: 15.9, 47.2, 53.4). Ours converges at
/// second order as the elements are halved, to within 0.15 of them at 32 (the published
/// codes differ among themselves by 0.1); 8 elements are 0.44 off them, 0.7 % of the
/// classical tip's distance from the root.
#[test]
fn bathe_bolourchi_bend() {
    let tip_of = |elements: usize| {
        let (m, tip) = bend(elements, 0.0, 600.0);
        let eq = solve_static_spatial(&m, &statics(6)).unwrap();
        Frame::read(&eq.q, tip).x
    };
    let published = Vector3::new(15.79, 47.23, 53.37);
    let tips: Vec<_> = [8, 16, 32].map(tip_of).to_vec();
    for (n, t) in [8, 16, 32].iter().zip(&tips) {
        println!("{n} elements: tip ({:.3}, {:.3}, {:.3})", t.x, t.y, t.z);
    }
    let off = (tips[2] - published).abs().max();
    assert!(off < 0.15, "32 elements off the published tip by {off}");
    // At 8 elements within 1 % of the classical tip (Bathe & Bolourchi's), as a distance.
    let classical = Vector3::new(15.9, 47.2, 53.4);
    let miss = (tips[0] - classical).norm() / classical.norm();
    println!(
        "8 elements: {:.2} % of the classical tip's distance off it",
        100.0 * miss
    );
    assert!(
        miss < 0.01,
        "8 elements {:.2} % off the classical tip",
        100.0 * miss
    );
    let (d1, d2) = ((tips[1] - tips[0]).norm(), (tips[2] - tips[1]).norm());
    let order = (d1 / d2).log2();
    assert!((order - 2.0).abs() < 0.3, "order {order}: {d1} then {d2}");
}

/// An end moment `2π EI/L` rolls a straight cantilever into a full circle: the nodes make
/// a regular polygon, so the tip comes back to the root, its frame turned by 2π, to
/// round-off at any number of elements; the circle's diameter `L/π` (root to the middle
/// node) converges at second order. The same with the beam and the moment turned
/// obliquely in space.
#[test]
fn an_end_moment_rolls_a_beam_into_a_circle() {
    let square = Shape::Rectangle { b: 0.1, h: 0.1 }.geometry(0.3).unwrap();
    let section = Section::new(&square, 2e11, 2e11 / 2.6, 7800.0);
    let length = 10.0;
    let moment = 2.0 * PI * section.c_m[2] / length;
    let roll = |elements: usize, turn: UnitQuaternion<f64>| {
        let points: Vec<Vector3<f64>> = (0..=elements)
            .map(|i| turn * Vector3::new(length * i as f64 / elements as f64, 0.0, 0.0))
            .collect();
        let (mut m, tip) = clamped_chain(&points, &section, turn * Vector3::y(), Vector3::zeros());
        let at = Anchor::Node {
            node: tip,
            point: Vector3::zeros(),
        };
        m.add_load(
            "moment",
            at,
            Vector3::zeros(),
            turn * Vector3::z() * moment,
            TimeFunction::Constant,
            false,
        )
        .unwrap();
        // The closure is checked to 1e-12: Newton is asked for it (at its default 1e-10 it
        // may stop an iteration short of round-off, as the factors' round-off falls).
        let tight = StaticSettings {
            tol: 1e-12,
            ..statics(8)
        };
        let eq = solve_static_spatial(&m, &tight).unwrap();
        let end = Frame::read(&eq.q, tip);
        let gap = end.x.norm() / length;
        let turned = so3::log(&end.r).norm();
        println!(
            "{elements} elements: tip {gap:.1e} L from the root, turned {turned:.1e} rad from 2π"
        );
        assert!(
            gap < 1e-12 && turned < 1e-9,
            "{elements}: gap {gap:e}, turned {turned:e}"
        );
        let diameter = Frame::read(&eq.q, elements / 2).x.norm();
        (diameter - length / PI).abs() / (length / PI)
    };
    let oblique = so3::exp(&(Vector3::new(1.0, 1.0, 0.4).normalize() * PI / 4.0));
    for turn in [UnitQuaternion::identity(), oblique] {
        let errors: Vec<f64> = [10, 20, 40].iter().map(|&n| roll(n, turn)).collect();
        println!("diameter's error at 10, 20, 40 elements: {errors:?}");
        assert!(errors[0] < 0.08, "{errors:?}");
        for w in errors.windows(2) {
            let order = (w[0] / w[1]).log2();
            assert!((order - 2.0).abs() < 0.1, "order {order}: {errors:?}");
        }
    }
}

fn dynamics(rho_inf: f64, h: f64, t_end: f64) -> DynamicSettings {
    DynamicSettings {
        t_end,
        h,
        rho_inf,
        tol: 1e-10,
        max_iter: 20,
        newton: NewtonMatrix::Full,
        mass: MassKind::Consistent,
    }
}

/// A steel cantilever set moving in its first mode's shape swings at its first frequency:
/// the period of the tip's swing within 0.1 % of Euler–Bernoulli's `1.8751² √(EI/ρAL⁴)` at
/// 8 elements, 0.03 % at 32 (a slender bar: shear and rotary inertia, and the start's other
/// modes, move it by less), converging at second order or faster (the differences to 32
/// elements fall 5.8 times from 2 to 4 elements, 15 times from 4 to 8); the other bending
/// plane stays at rest.
#[test]
fn a_cantilever_swings_at_its_first_frequency() {
    let circle = Shape::SolidCircle { d: 0.02 }.geometry(0.3).unwrap();
    let section = Section::new(&circle, 2.1e11, 2.1e11 / 2.6, 7850.0);
    let length: f64 = 1.0;
    let beta = 1.875_104_068_711_961;
    let omega = beta * beta * (section.c_m[2] / (section.rho_a * length.powi(4))).sqrt();
    let period = 2.0 * PI / omega;
    let measured = |elements: usize| {
        let points: Vec<Vector3<f64>> = (0..=elements)
            .map(|i| Vector3::new(length * i as f64 / elements as f64, 0.0, 0.0))
            .collect();
        let (mut m, tip) = clamped_chain(&points, &section, Vector3::y(), Vector3::zeros());
        // The static deflection's shape (close to the first mode's), as velocities.
        for (node, p) in points.iter().enumerate().skip(1) {
            let s = p.x / length;
            let shape = s * s * (3.0 - s) / 2.0;
            let slope = 3.0 * s * (2.0 - s) / (2.0 * length);
            m.set_node_rates(
                node,
                Vector3::y() * 0.01 * shape,
                Vector3::z() * 0.01 * slope,
            )
            .unwrap();
        }
        let steps = 4000;
        let h = 2.0 * period / steps as f64;
        let settings = dynamics(0.9, h, 2.0 * period);
        let states = simulate_spatial(&m, &settings, &TimeGrid::uniform(h, steps)).unwrap();
        let y: Vec<f64> = states.iter().map(|s| Frame::read(&s.q, tip).x.y).collect();
        let off_plane = states
            .iter()
            .map(|s| Frame::read(&s.q, tip).x.z.abs())
            .fold(0.0, f64::max);
        assert!(off_plane < 1e-12, "{off_plane:e}");
        // Zero crossings of the tip, downward then upward: its period, interpolated.
        let crossings: Vec<f64> = (1..y.len())
            .filter(|&n| y[n - 1] > 0.0 && y[n] <= 0.0 || y[n - 1] < 0.0 && y[n] >= 0.0)
            .map(|n| h * ((n - 1) as f64 + y[n - 1] / (y[n - 1] - y[n])))
            .collect();
        crossings[2] - crossings[0]
    };
    let periods: Vec<f64> = [2, 4, 8, 32].iter().map(|&n| measured(n)).collect();
    let analytic: Vec<f64> = periods
        .iter()
        .map(|p| (p - period).abs() / period)
        .collect();
    println!("first period's error at 2, 4, 8, 32 elements: {analytic:?}");
    assert!(analytic[2] < 1e-3 && analytic[3] < 3e-4, "{analytic:?}");
    // Orders against the finest.
    let errors: Vec<f64> = periods[..3]
        .iter()
        .map(|p| (p - periods[3]).abs())
        .collect();
    for w in errors.windows(2) {
        let order = (w[0] / w[1]).log2();
        assert!(order > 1.8, "order {order}: {errors:?}");
    }
}

/// A flexible pendulum in space: an aluminium tube of three beams on a spherical joint, a
/// point mass at its tip, spinning about the vertical as it falls, damped (Kelvin–Voigt and
/// `α M`). The tip's
/// final height, the pivot's vertical effort `∫λ² dt` and the strain energy `∫U dt`,
/// differentiated to two beams'
/// stiffness, one's mass and the point mass: direct and adjoint against fourth-order
/// differences (1e-6)
/// and each other (1e-9).
/// The damped flexible pendulum spinning as it falls, its point mass body 0 at node 3.
/// An aluminium tube (20 mm, 2 mm wall) of three beams of 0.4 m along x under gravity
/// along −z, damped by `rayleigh`, the sections' `e₂` the part of `up` across it: nodes
/// `n0` … `n3`, beams `b0` … `b2`, and the nodes' positions.
fn tube_arm(rayleigh: [f64; 2], up: Vector3<f64>) -> (SpatialModel, Vec<Vector3<f64>>) {
    let tube = Shape::HollowCircle {
        outer: 0.02,
        inner: 0.016,
    }
    .geometry(0.33)
    .unwrap();
    let section = Section::new(&tube, 7e10, 2.6e10, 2700.0).with_rayleigh(rayleigh[0], rayleigh[1]);
    let points: Vec<Vector3<f64>> = (0..=3)
        .map(|i| Vector3::new(0.4 * i as f64, 0.0, 0.0))
        .collect();
    let mut m = SpatialModel::new(Vector3::new(0.0, 0.0, -9.81)).unwrap();
    for (i, p) in points.iter().enumerate() {
        m.add_node(&format!("n{i}"), Frame::new(*p, UnitQuaternion::identity()))
            .unwrap();
    }
    for i in 0..3 {
        m.add_beam(&format!("b{i}"), i, i + 1, &section, up)
            .unwrap();
    }
    (m, points)
}

fn spinning_pendulum() -> SpatialModel {
    let (mut m, points) = tube_arm([0.5, 2e-4], Vector3::new(0.0, 0.3, 1.0));
    let pivot = Anchor::Node {
        node: 0,
        point: Vector3::zeros(),
    };
    m.add_joint(
        "pivot",
        JointKind::Spherical,
        pivot,
        Anchor::Ground(Vector3::zeros()),
    )
    .unwrap();
    let spin = Vector3::new(0.0, 0.0, 3.0);
    for (i, p) in points.iter().enumerate() {
        m.set_node_rates(i, spin.cross(p), spin).unwrap();
    }
    m.add_point_mass("bob", 3, 0.2).unwrap();
    m
}

#[test]
fn flexible_pendulum_gradients() {
    let m = spinning_pendulum();
    let bob = 0;
    let responses = [
        Response::NodePosition { node: 3, axis: 2 },
        Response::Effort { joint: 0, row: 2 },
        Response::StrainEnergy,
        Response::Compliance,
        Response::KineticEnergy,
        Response::Reaction {
            joint: 0,
            aggregation: Aggregation::PMean { p: 8.0 },
        },
        Response::Stress {
            criterion: Criterion::VonMises,
            aggregation: Aggregation::PMean { p: 8.0 },
            relaxation: 0.5,
            within: None,
        },
        // The middle beam's alone: the others' densities do not relax it.
        Response::Stress {
            criterion: Criterion::VonMises,
            aggregation: Aggregation::PMean { p: 4.0 },
            relaxation: 1.0,
            within: Some(Elements {
                beams: [1, 2],
                trusses: [0, 0],
            }),
        },
    ];
    let parameters = [
        Parameter::BeamStiffness { beam: 0 },
        Parameter::BeamStiffness { beam: 2 },
        Parameter::BeamMass { beam: 1 },
        Parameter::Mass { body: bob },
        Parameter::BeamDensity { beam: 1 },
        Parameter::BeamDensity { beam: 2 },
    ];
    check(
        &m,
        0.8,
        &TimeGrid::uniform(2e-3, 50),
        &responses,
        &parameters,
    );
}

/// A flexible arm of three beams on a hinge driven by a trapezoidal law, a point mass at its
/// tip, on a grid that lands on the law's first kink: the restart there differentiated (the
/// jump's share moves with the beams' mass and the state), the tip's final height and the
/// drive's effort against fourth-order differences and direct against adjoint, the restart
/// differentiated in both sweeps (without its derivative the tip's gradient to the first
/// beam's mass is 1.7 % off; without it in the adjoint sweep alone, direct and adjoint part).
#[test]
fn gradients_through_a_drives_restarts() {
    let (mut m, hinge, ..) = driven_arm();
    let bob = m.add_point_mass("bob", 3, 0.2).unwrap();
    let grid = TimeGrid::uniform(4e-3, 25);
    let row = m.joint_rows(hinge).unwrap().len() - 1;
    check(
        &m,
        0.8,
        &grid,
        &[
            Response::NodePosition { node: 3, axis: 1 },
            Response::Effort { joint: hinge, row },
        ],
        &[
            Parameter::BeamStiffness { beam: 1 },
            Parameter::BeamMass { beam: 0 },
            Parameter::Mass { body: bob },
        ],
    );
}

/// The flexible arm of three beams on an oblique hinge driven by a trapezoidal law with kinks
/// at 0.02 s (on a grid of 4 ms), 0.15 and 0.17 s: the model, the hinge, the law and the
/// hinge's point.
fn driven_arm() -> (SpatialModel, usize, crate::motion::Motion, Vector3<f64>) {
    use crate::motion::{Motion, Trapezoidal};
    let (mut m, _) = tube_arm([0.0, 0.0], Vector3::z());
    // The hinge 5 cm behind the root node: the drive's jump moves the node's translations,
    // which the beams' consistent mass couples to the next node's.
    let offset = Vector3::new(-0.05, 0.0, 0.0);
    let root = Anchor::Node {
        node: 0,
        point: offset,
    };
    let axis = Vector3::new(0.0, 0.3, 1.0);
    let hinge = m
        .add_joint(
            "hinge",
            JointKind::Revolute { axis },
            Anchor::Ground(offset),
            root,
        )
        .unwrap();
    let law = Motion::Trapezoidal(Trapezoidal::new(0.0, 0.3, 100.0, 2.0, 0.0));
    m.add_drive(hinge, law.clone()).unwrap();
    (m, hinge, law, offset)
}

/// The tip deflection of paper Eq. 40 in space: the rigid trajectory of the driven arm's tip
/// is its start turned about the hinge's oblique axis by the law's angle (to 1e-10 m, the
/// companion's three welds and hinge run on the engine's integrator); its mean squared
/// deflection from it has exact gradients (differences 1e-6, direct = adjoint 1e-9) through
/// the drive's restart; an undriven pendulum has no rigid trajectory and says so, as does an
/// equilibrium.
#[test]
fn tip_deflection_from_the_rigid_trajectory() {
    use crate::spatial::rigid::rigid_trajectories;
    use crate::spatial::sensitivity::{sensitivities, static_sensitivities};
    let (mut m, hinge, law, offset) = driven_arm();
    let grid = TimeGrid::uniform(4e-3, 25);
    let paths = rigid_trajectories(&m, &super::spatial::settings(0.8), &grid, &[3]).unwrap();
    let axis = nalgebra::Unit::new_normalize(Vector3::new(0.0, 0.3, 1.0));
    let tip = Vector3::new(1.2, 0.0, 0.0);
    let mut turned = 0.0f64;
    for (t, r) in grid.times().iter().zip(&paths[0]) {
        let angle = law.at(*t).angle - law.at(0.0).angle;
        let exact = offset + UnitQuaternion::from_axis_angle(&axis, angle) * (tip - offset);
        assert!((r - exact).norm() < 1e-10, "t = {t}: {r} against {exact}");
        turned = turned.max(angle);
    }
    assert!(turned > 0.05, "the arm turns: {turned} rad");
    let bob = m.add_point_mass("bob", 3, 0.2).unwrap();
    let deflection = [Response::Deflection { node: 3 }];
    let parameters = [
        Parameter::BeamStiffness { beam: 1 },
        Parameter::BeamMass { beam: 0 },
        Parameter::Mass { body: bob },
    ];
    check(&m, 0.8, &grid, &deflection, &parameters);
    // The deflection is the flexible tip's: a stiffer arm follows its rigid path closer.
    let s = super::spatial::settings(0.8);
    let d = |m: &SpatialModel| {
        sensitivities(m, &s, &grid, &deflection, &[], crate::Method::Adjoint)
            .unwrap()
            .values[0]
    };
    let stiffer = moved(&m, &Parameter::BeamStiffness { beam: 0 }, 9.0);
    let (soft, stiff) = (d(&m), d(&stiffer));
    assert!(soft > 0.0 && stiff < soft, "{stiff} against {soft}");
    // Undriven, the rigid arm is a pendulum whose swing its masses set.
    let (mut free, ..) = driven_arm();
    free.joints[hinge] = {
        let (mut bare, _) = tube_arm([0.0, 0.0], Vector3::z());
        let root = Anchor::Node {
            node: 0,
            point: offset,
        };
        let kind = JointKind::Revolute {
            axis: Vector3::new(0.0, 1.0, 0.2),
        };
        bare.add_joint("hinge", kind, Anchor::Ground(offset), root)
            .unwrap();
        bare.joints.remove(0)
    };
    let err = sensitivities(&free, &s, &grid, &deflection, &[], crate::Method::Adjoint)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("tip_deflection") && err.contains("freedom"),
        "{err}"
    );
    let err = static_sensitivities(&m, &statics(1), &deflection, &[], crate::Method::Adjoint)
        .unwrap_err()
        .to_string();
    assert!(err.contains("motion's"), "{err}");
}

/// Modified Newton (the step's first factorization kept while the residual falls tenfold
/// per iteration) ends each step on the full Newton's solution: the spinning pendulum's
/// motion the same to the Newton tolerance.
#[test]
fn modified_newton_follows_the_full_newtons_motion() {
    let m = spinning_pendulum();
    let run = |newton| {
        let settings = DynamicSettings {
            newton,
            ..dynamics(0.8, 2e-3, 0.2)
        };
        simulate_spatial(&m, &settings, &TimeGrid::uniform(2e-3, 100)).unwrap()
    };
    let (full, modified) = (run(NewtonMatrix::Full), run(NewtonMatrix::Modified));
    let apart = (full.last().unwrap().q.iter())
        .zip(&modified.last().unwrap().q)
        .fold(0.0f64, |d, (a, b)| d.max((a - b).abs()));
    assert!(apart < 1e-8, "{apart:e}");
    let moved = (full[0].q.iter().zip(&full.last().unwrap().q))
        .fold(0.0f64, |d, (a, b)| d.max((a - b).abs()));
    assert!(moved > 0.1, "{moved}");
}

/// A free flexible rod tumbling in space, thrown spinning about an oblique axis with its
/// ends flapping: undamped at ρ∞ = 1, its energy and angular momentum are kept to 1e-4
/// over a thousand steps with no drift; with Kelvin–Voigt damping its energy falls at
/// every step while its angular momentum, which internal forces cannot change, stays.
#[test]
fn a_free_rod_keeps_its_invariants() {
    let tube = Shape::HollowCircle {
        outer: 0.03,
        inner: 0.026,
    }
    .geometry(0.33)
    .unwrap();
    let run = |beta: f64| {
        let section = Section::new(&tube, 7e10, 2.6e10, 2700.0).with_rayleigh(0.0, beta);
        let mut m = SpatialModel::new(Vector3::zeros()).unwrap();
        let spin = Vector3::new(0.3, 1.0, 4.0);
        for i in 0..=6 {
            let x = Vector3::new(i as f64 / 6.0 - 0.5, 0.0, 0.0);
            m.add_node(&format!("n{i}"), Frame::new(x, UnitQuaternion::identity()))
                .unwrap();
            // Bending rates with the sections turning along: v_z = 1.6 x², Ω_y = −v_z'.
            let flap = Vector3::new(0.0, 0.0, 1.6 * x.x * x.x);
            let bend = Vector3::new(0.0, -3.2 * x.x, 0.0);
            m.set_node_rates(i, spin.cross(&x) + flap, spin + bend)
                .unwrap();
        }
        for i in 0..6 {
            m.add_beam(&format!("b{i}"), i, i + 1, &section, Vector3::z())
                .unwrap();
        }
        let h = 5e-4;
        let states =
            simulate_spatial(&m, &dynamics(1.0, h, 0.5), &TimeGrid::uniform(h, 1000)).unwrap();
        let energy: Vec<f64> = states
            .iter()
            .map(|s| m.kinetic_energy(&s.qdot) + m.potential_energy(&s.q))
            .collect();
        let momentum: Vec<Vector3<f64>> = states
            .iter()
            .map(|s| m.angular_momentum(&s.q, &s.qdot, &Vector3::zeros()))
            .collect();
        (energy, momentum)
    };
    let (energy, momentum) = run(0.0);
    let drift = |e: &[f64]| e.iter().map(|x| (x / e[0] - 1.0).abs()).fold(0.0, f64::max);
    let turn = |l: &[Vector3<f64>]| {
        l.iter()
            .map(|x| (x - l[0]).norm() / l[0].norm())
            .fold(0.0, f64::max)
    };
    println!(
        "undamped: energy within {:e}, angular momentum within {:e}",
        drift(&energy),
        turn(&momentum)
    );
    assert!(drift(&energy) < 1e-4 && turn(&momentum) < 1e-4);
    let (energy, momentum) = run(2e-5);
    assert!(energy.windows(2).all(|w| w[1] < w[0]), "damped energy rose");
    let lost = 1.0 - energy[energy.len() - 1] / energy[0];
    println!(
        "damped: {:.3} % of the energy lost, angular momentum within {:e}",
        100.0 * lost,
        turn(&momentum)
    );
    assert!(lost > 1e-3 && turn(&momentum) < 1e-4, "{lost}");
}

/// Exact gradients of static equilibria: a cantilever's tip deflection `δ ∝ 1/s` and its
/// strain energy `U = Pδ/2 ∝ 1/s` under a small tip load fall by themselves when every
/// beam's stiffness factor `s` rises (the sum of the beams' derivatives is `−δ`, `−U`); on
/// the Bathe–Bolourchi bend under its own weight and the tip load, far from linear, direct
/// and adjoint agree with fourth-order differences (1e-6) and each other (1e-9) for the
/// tip's height, the strain energy and a clamp's moment `λ²` (its forces are the loads',
/// whatever the stiffness).
#[test]
fn static_gradients() {
    use crate::spatial::sensitivity::static_sensitivities;
    use crate::Method;
    let rectangle = Shape::Rectangle { b: 0.02, h: 0.03 }.geometry(0.3).unwrap();
    let section = Section::new(&rectangle, 2.1e11, 8e10, 7850.0);
    let points: Vec<Vector3<f64>> = (0..=6)
        .map(|i| Vector3::new(i as f64 / 6.0, 0.0, 0.0))
        .collect();
    let (mut m, tip) = clamped_chain(&points, &section, Vector3::y(), Vector3::zeros());
    let at = Anchor::Node {
        node: tip,
        point: Vector3::zeros(),
    };
    m.add_load(
        "tip",
        at,
        Vector3::new(0.0, 0.0, -10.0),
        Vector3::zeros(),
        TimeFunction::Constant,
        false,
    )
    .unwrap();
    let responses = [
        Response::NodePosition { node: tip, axis: 2 },
        Response::StrainEnergy,
    ];
    let parameters: Vec<Parameter> = (0..6)
        .map(|beam| Parameter::BeamStiffness { beam })
        .collect();
    for method in [Method::Direct, Method::Adjoint] {
        let g = static_sensitivities(&m, &statics(1), &responses, &parameters, method).unwrap();
        for k in 0..2 {
            let total: f64 = g.gradient[k].iter().sum();
            let expected = -g.values[k];
            assert!(
                (total / expected - 1.0).abs() < 1e-5,
                "{method:?} {k}: {total} against {expected}"
            );
        }
    }
    // The bend, heavy and loaded.
    let (m, tip) = bend(8, 2.0, 300.0);
    let responses = [
        Response::NodePosition { node: tip, axis: 2 },
        Response::StrainEnergy,
        Response::Effort { joint: 0, row: 4 },
        Response::Reaction {
            joint: 0,
            aggregation: Aggregation::PMean { p: 8.0 },
        },
    ];
    let parameters = [
        Parameter::BeamStiffness { beam: 0 },
        Parameter::BeamStiffness { beam: 5 },
        Parameter::BeamMass { beam: 3 },
    ];
    let run = |m: &SpatialModel, method| {
        static_sensitivities(m, &statics(6), &responses, &parameters, method).unwrap()
    };
    let (direct, adjoint) = (run(&m, Method::Direct), run(&m, Method::Adjoint));
    for (i, p) in parameters.iter().enumerate() {
        let moved = |e: f64| run(&moved(&m, p, e), Method::Direct).values;
        let e = 1e-3;
        let (p2, p1, m1, m2) = (moved(2.0 * e), moved(e), moved(-e), moved(-2.0 * e));
        for k in 0..responses.len() {
            let fd = (-p2[k] + 8.0 * p1[k] - 8.0 * m1[k] + m2[k]) / (12.0 * e);
            let (d, a) = (direct.gradient[k][i], adjoint.gradient[k][i]);
            println!(
                "{:?} / {p:?}: direct {d:.9e}, adjoint {a:.9e}, differences {fd:.9e}",
                responses[k]
            );
            assert!(
                (d - fd).abs() <= 1e-6 * d.abs().max(fd.abs()) + 1e-12 * direct.values[k].abs() / e
            );
            // The clamp's reaction does not depend on the stiffnesses (the bend is statically
            // determinate): those derivatives vanish, and the two methods agree to the
            // solves' round-off (1.5e-9 N here against a reaction of 143 N, its moments
            // 1e4 N m): 1e-10 of the value.
            let floor = 1e-10 * direct.values[k].abs();
            assert!((d - a).abs() <= 1e-9 * d.abs().max(a.abs()) + floor);
        }
    }
    // The clamp carries the tip's load and the weight of every element.
    let weight: f64 = m.elements().map(|e| e.mass()).sum::<f64>() * -2.0;
    let expected = (300.0 + weight).abs();
    assert!(
        (direct.values[3] / expected - 1.0).abs() < 1e-9,
        "the clamp's reaction {} against the loads' {expected}",
        direct.values[3]
    );
}
