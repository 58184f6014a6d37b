//! Cost of a spatial run and of its exact gradients: one run with gradients divided by one
//! plain run, adjoint (one response) and direct (every parameter), for the heavy top, for
//! chains of rigid links (a driven hinge at the root, then spherical and universal joints
//! in turn, swinging under gravity) of 5 to 80 bodies, every mass a parameter, and for
//! flexible pendulums of 8 to 64 spatial beams, every beam's stiffness a parameter. Then the
//! cost of a spatial beam's element-step against the planar engine's, on the same pendulum
//! swinging in its plane. Prints Markdown tables: medians of nine repetitions, the ratios
//! the medians of each repetition's.
//!
//! `cargo bench --features bench --bench spatial`

use std::time::Instant;

use flextop::group::Frame;
use flextop::motion::{Motion, Table};
use flextop::spatial::integrator::simulate_spatial;
use flextop::spatial::joint::{Anchor, JointKind};
use flextop::spatial::model::SpatialModel;
use flextop::spatial::section::{Section, Shape};
use flextop::spatial::sensitivity::{sensitivities, Parameter, Response};
use flextop::{scene, simulate, DynamicSettings, MassKind, Method, NewtonMatrix, TimeGrid};
use nalgebra::{Matrix3, UnitQuaternion, Vector3};

fn seconds<F: FnMut()>(mut f: F) -> f64 {
    let start = Instant::now();
    f();
    start.elapsed().as_secs_f64()
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn top() -> SpatialModel {
    let mut m = SpatialModel::new(Vector3::new(0.0, 0.0, -9.81)).unwrap();
    let arm = Vector3::new(0.0, 1.0, 0.0);
    let j = Matrix3::from_diagonal(&Vector3::new(0.25, 0.46875, 0.25));
    let b = m
        .add_body("top", Frame::new(arm, UnitQuaternion::identity()), 15.0, j)
        .unwrap();
    m.add_joint(
        "pivot",
        JointKind::Spherical,
        Anchor::Body {
            body: b,
            point: -arm,
        },
        Anchor::Ground(Vector3::zeros()),
    )
    .unwrap();
    let omega = Vector3::new(0.0, 150.0, -4.61538);
    m.set_rates(b, omega.cross(&arm), omega).unwrap();
    m
}

/// `n` links of 0.5 m along x, the first on a driven hinge about y.
fn chain(n: usize) -> SpatialModel {
    let link = 0.5;
    let mut m = SpatialModel::new(Vector3::new(0.0, 0.0, -9.81)).unwrap();
    let inertia = Matrix3::from_diagonal(&Vector3::new(1e-3, 0.02, 0.02));
    let half = Vector3::new(link / 2.0, 0.0, 0.0);
    for k in 0..n {
        let x = Vector3::new(link * (k as f64 + 0.5), 0.0, 0.0);
        let b = m
            .add_body(
                &format!("link{k}"),
                Frame::new(x, UnitQuaternion::identity()),
                1.0,
                inertia,
            )
            .unwrap();
        let (kind, previous) = match k {
            0 => (
                JointKind::Revolute { axis: Vector3::y() },
                Anchor::Ground(Vector3::zeros()),
            ),
            _ if k % 2 == 1 => (
                JointKind::Spherical,
                Anchor::Body {
                    body: k - 1,
                    point: half,
                },
            ),
            _ => (
                JointKind::Universal {
                    axis_a: Vector3::y(),
                    axis_b: Vector3::z(),
                },
                Anchor::Body {
                    body: k - 1,
                    point: half,
                },
            ),
        };
        let j = m
            .add_joint(
                &format!("j{k}"),
                kind,
                previous,
                Anchor::Body {
                    body: b,
                    point: -half,
                },
            )
            .unwrap();
        if k == 0 {
            m.add_drive(
                j,
                Motion::Table(Table::new(
                    vec![0.0, 0.2, 0.4],
                    vec![0.0, 0.3, 0.5],
                    [0.0, 0.0],
                )),
            )
            .unwrap();
        }
    }
    m
}

/// The pendulum's tube: aluminium, 20 mm across, 2 mm wall.
const E: f64 = 7e10;
const G: f64 = 2.6e10;
const RHO: f64 = 2700.0;

fn tube() -> Section {
    let shape = Shape::HollowCircle {
        outer: 0.02,
        inner: 0.016,
    };
    Section::new(&shape.geometry(E / (2.0 * G) - 1.0).unwrap(), E, G, RHO)
}

/// A flexible pendulum of `n` beams, 1 m along x, hinged about z at the origin, falling
/// under gravity along −y: it swings in its plane.
fn flexible(n: usize) -> SpatialModel {
    let mut m = SpatialModel::new(Vector3::new(0.0, -9.81, 0.0)).unwrap();
    for i in 0..=n {
        let x = Vector3::new(i as f64 / n as f64, 0.0, 0.0);
        m.add_node(&format!("n{i}"), Frame::new(x, UnitQuaternion::identity()))
            .unwrap();
    }
    for i in 0..n {
        m.add_beam(&format!("b{i}"), i, i + 1, &tube(), Vector3::y())
            .unwrap();
    }
    let root = Anchor::Node {
        node: 0,
        point: Vector3::zeros(),
    };
    let hinge = JointKind::Revolute { axis: Vector3::z() };
    m.add_joint("hinge", hinge, root, Anchor::Ground(Vector3::zeros()))
        .unwrap();
    m
}

/// The same pendulum in the planar engine: `n` beams of the same section on a pin.
fn planar(n: usize) -> flextop::Model {
    let g = tube();
    let mut toml = format!(
        "name = \"flexible\"\nanalysis = \"dynamic\"\ngravity = [0.0, -9.81]\n\
         [sections.tube]\nE = {E}\nG = {G}\nrho = {RHO}\nA = {}\nI = {}\nkappa = {}\n",
        g.area,
        g.c_m[2] / E,
        g.c_n[1] / (G * g.area)
    );
    for i in 0..=n {
        toml += &format!(
            "[[nodes]]\nname = \"n{i}\"\nx = {}\ny = 0.0\n",
            i as f64 / n as f64
        );
    }
    for i in 0..n {
        toml += &format!(
            "[[beams]]\nnodes = [\"n{i}\", \"n{}\"]\nsection = \"tube\"\nfixed = true\n",
            i + 1
        );
    }
    toml += "[[joints]]\nkind = \"pin\"\nname = \"hinge\"\nnode = \"n0\"\n";
    scene::build(&scene::parse_toml(&toml).unwrap()).unwrap()
}

/// Median seconds per element-step of the spatial and the planar pendulum of `n` beams.
fn element_steps(n: usize, settings: &DynamicSettings, h: f64, steps: usize) -> (f64, f64, f64) {
    let spatial = flexible(n);
    let plane = planar(n);
    let grid = TimeGrid::uniform(h, steps);
    let planar_settings = DynamicSettings {
        t_end: h * steps as f64,
        h,
        ..*settings
    };
    let x = vec![1.0; plane.n_variables()];
    let mut times = [vec![], vec![]];
    for _ in 0..9 {
        times[0].push(seconds(|| {
            drop(simulate_spatial(&spatial, settings, &grid).unwrap())
        }));
        times[1].push(seconds(|| {
            drop(simulate(&plane, Some(&x), &planar_settings).unwrap())
        }));
    }
    let ratio = median(times[0].iter().zip(&times[1]).map(|(s, p)| s / p).collect());
    let per = (n * steps) as f64;
    let [s, p] = times.map(median);
    (s / per, p / per, ratio)
}

fn main() {
    if std::env::args().any(|a| a == "--list") {
        return;
    }
    let settings = DynamicSettings {
        t_end: 0.0,
        h: 0.0,
        rho_inf: 0.8,
        tol: 1e-10,
        max_iter: 20,
        newton: NewtonMatrix::Full,
        mass: MassKind::Consistent,
    };
    println!("Spatial runs of 200 steps (h = 1 ms), ρ∞ = 0.8; gradients of one response to every body's mass or beam's stiffness\n");
    println!("| mechanism | bodies or beams | unknowns | plain run (ms) | adjoint (ms) | adjoint / plain | direct (ms) | direct / plain |");
    println!("|---|---|---|---|---|---|---|---|");
    let mut cases = vec![("heavy top".to_string(), top())];
    cases.extend([5, 20, 80].map(|n| (format!("chain of {n}"), chain(n))));
    cases.extend([8, 64].map(|n| (format!("flexible pendulum of {n} beams"), flexible(n))));
    for (name, model) in cases {
        let grid = TimeGrid::uniform(1e-3, 200);
        let (parameters, responses): (Vec<Parameter>, _) = if model.beams.is_empty() {
            let n = model.bodies.len();
            let response = Response::Position {
                body: n - 1,
                axis: 2,
            };
            (
                (0..n).map(|body| Parameter::Mass { body }).collect(),
                [response],
            )
        } else {
            let n = model.beams.len();
            let response = Response::NodePosition { node: n, axis: 1 };
            (
                (0..n)
                    .map(|beam| Parameter::BeamStiffness { beam })
                    .collect(),
                [response],
            )
        };
        let n = model.bodies.len() + model.beams.len();
        // Plain, adjoint and direct runs one after the other, repeated: the median of each
        // and of the ratios within a repetition, which the machine's drift moves least.
        let with = |method| {
            sensitivities(&model, &settings, &grid, &responses, &parameters, method).unwrap()
        };
        let mut times = [vec![], vec![], vec![]];
        for _ in 0..9 {
            times[0].push(seconds(|| {
                drop(simulate_spatial(&model, &settings, &grid).unwrap())
            }));
            times[1].push(seconds(|| drop(with(Method::Adjoint))));
            times[2].push(seconds(|| drop(with(Method::Direct))));
        }
        let ratio = |k: usize| median(times[k].iter().zip(&times[0]).map(|(t, p)| t / p).collect());
        let (adjoint_ratio, direct_ratio) = (ratio(1), ratio(2));
        let [plain, adjoint, direct] = times.map(median);
        println!(
            "| {name} | {n} | {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} |",
            model.n_v() + model.n_rows(),
            1e3 * plain,
            1e3 * adjoint,
            adjoint_ratio,
            1e3 * direct,
            direct_ratio
        );
    }
    println!("\nThe flexible pendulum swinging in its plane, 200 steps of 1 ms: spatial beams against the planar engine's\n");
    println!("| beams | spatial (µs per element-step) | planar (µs per element-step) | spatial / planar |");
    println!("|---|---|---|---|");
    for n in [8, 32, 128] {
        let (s, p, ratio) = element_steps(n, &settings, 1e-3, 200);
        println!("| {n} | {:.2} | {:.2} | {ratio:.2} |", 1e6 * s, 1e6 * p);
    }
}
