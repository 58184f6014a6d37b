//! Cost of a spatial run and of its exact gradients: one run with gradients divided by one
//! plain run, adjoint (one response) and direct (every parameter), for the heavy top and for
//! chains of rigid links (a driven hinge at the root, then spherical and universal joints
//! in turn, swinging under gravity) of 5 to 80 bodies, every mass a parameter. Prints a
//! Markdown table: medians of nine repetitions, the ratios the medians of each
//! repetition's.
//!
//! `cargo bench --bench spatial`

use std::time::Instant;

use flextop::group::Frame;
use flextop::motion::{Motion, Table};
use flextop::spatial::integrator::simulate_spatial;
use flextop::spatial::joint::{Anchor, JointKind};
use flextop::spatial::model::SpatialModel;
use flextop::spatial::sensitivity::{sensitivities, Parameter, Response};
use flextop::{DynamicSettings, MassKind, Method, NewtonMatrix, TimeGrid};
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
    println!("Spatial runs of 200 steps (h = 1 ms), ρ∞ = 0.8; gradients of one response to every body's mass\n");
    println!("| mechanism | bodies | unknowns | plain run (ms) | adjoint (ms) | adjoint / plain | direct (ms) | direct / plain |");
    println!("|---|---|---|---|---|---|---|---|");
    let mut cases = vec![("heavy top".to_string(), top())];
    cases.extend([5, 20, 80].map(|n| (format!("chain of {n}"), chain(n))));
    for (name, model) in cases {
        let grid = TimeGrid::uniform(1e-3, 200);
        let n = model.bodies.len();
        let parameters: Vec<Parameter> = (0..n).map(|body| Parameter::Mass { body }).collect();
        let responses = [Response::Position {
            body: n - 1,
            axis: 2,
        }];
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
}
