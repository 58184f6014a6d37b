//! The `strain_energy` response: the beams' elastic energy, none in rigid motion, the
//! dynamic compliance of paper Eq. 39, half of `Fᵀu` in a linear static solve (Clapeyron),
//! with exact gradients.

use crate::scene;
use crate::{evaluate, of_equilibrium, of_motion, Memory, Method, Model, Recorded};

use super::common::*;
use super::sensitivity::{check, check_gravity_truss, how, random_design, responses};

/// Values of `names` on state `q` of `model` at density `x`, held at rest for 0.1 s (a
/// mean over the motion is then the state's value).
fn values_at(model: &Model, x: &[f64], q: &[f64], names: &[&str]) -> Vec<f64> {
    let q = [q, q].concat();
    let states = 2;
    let lam = vec![0.0; states * model.n_constraints()];
    let times: Vec<f64> = (0..states).map(|n| 0.1 * n as f64).collect();
    let recorded = Recorded {
        q: &q,
        qdot: None,
        lam: &lam,
        times: &times,
        load_time: 0.0,
        mass: crate::MassKind::Consistent,
        analysis: crate::StaticAnalysis::Nonlinear,
    };
    evaluate(model, Some(x), &recorded, &responses(model, names))
        .unwrap()
        .values
}

/// The arm turned as a whole by `theta` about `(1, -2)` and moved by `(0.3, 0.7)`, and the
/// same with one node pushed by `push` along x.
fn turned(model: &Model, theta: f64, push: f64) -> Vec<f64> {
    let (c, s) = (theta.cos(), theta.sin());
    let mut q = Vec::new();
    for (i, node) in model.nodes.iter().enumerate() {
        let (x, y) = (node.position.x - 1.0, node.position.y + 2.0);
        let moved = [c * x - s * y + 1.3, s * x + c * y - 1.3];
        let extra = if i == 5 { push } else { 0.0 };
        q.extend([
            moved[0] - node.position.x + extra,
            moved[1] - node.position.y,
            theta,
        ]);
    }
    q
}

#[test]
fn rigid_motion_stores_no_strain_energy() {
    let arm = robot_arm(2, 70e9);
    let x = random_design(&arm, 5);
    for theta in [0.3, 1.7, -2.9, std::f64::consts::PI, 40.0] {
        let rigid = values_at(&arm, &x, &turned(&arm, theta, 0.0), &["strain_energy"])[0];
        let pushed = values_at(&arm, &x, &turned(&arm, theta, 1e-4), &["strain_energy"])[0];
        // A 0.1 mm push of one node stores energy of order EA δ²/L ≈ 1e-2 J; a rigid
        // motion only the round-off of the co-rotated frame, ~1e-16 of that.
        assert!(
            pushed > 1e-4,
            "θ = {theta}: the pushed node stores {pushed:e} J"
        );
        assert!(
            rigid.abs() < 1e-12 * pushed,
            "θ = {theta}: rigid motion stores {rigid:e} J"
        );
    }
}

#[test]
fn dynamic_strain_energy_is_the_mean_compliance() {
    let arm = robot_arm(1, 70e9);
    let x = random_design(&arm, 7);
    let names = [
        "strain_energy",
        "compliance",
        "strain_energy:link2",
        "compliance:link2",
    ];
    let rs = responses(&arm, &names);
    let run = of_motion(
        &arm,
        &x,
        &settings(0.4, 0.02, 0.8),
        &rs,
        &[],
        how(Method::Adjoint, Memory::default()),
    )
    .unwrap();
    assert!(run.values[0] > 0.0 && run.values[2] > 0.0 && run.values[2] < run.values[0]);
    assert_eq!(run.values[0], run.values[1]);
    assert_eq!(run.values[2], run.values[3]);
    let n_x = arm.n_variables();
    assert_eq!(run.gradients[..n_x], run.gradients[n_x..2 * n_x]);
}

#[test]
fn static_strain_energy_is_half_the_load_work_when_linear() {
    let mut spec = reference::static_truss(2);
    for load in &mut spec.loads {
        load.force = load.force.map(|f| f * 1e-6);
    }
    let truss = scene::build(&spec).expect("valid scene");
    let rs = responses(&truss, &["strain_energy", "compliance"]);
    let x = random_design(&truss, 2);
    let run = of_equilibrium(&truss, &x, &static_settings(1), &rs, &[], Method::Adjoint).unwrap();
    let (energy, work) = (run.values[0], run.values[1]);
    assert!(energy > 0.0);
    assert!(
        (energy - 0.5 * work).abs() <= 1e-6 * energy,
        "U = {energy:e} J, Fᵀu/2 = {:e} J",
        0.5 * work
    );
}

#[test]
fn strain_energy_gradients_match_differences_and_each_other() {
    let arm = robot_arm(1, 70e9);
    let rs = responses(&arm, &["strain_energy", "strain_energy:link1"]);
    let run = crate::DynamicSettings {
        tol: 1e-12,
        ..settings(0.6, 0.02, 0.8)
    };
    let eval = |x: &[f64], m: Method| of_motion(&arm, x, &run, &rs, &[], how(m, Memory::default()));
    check(
        &arm,
        &eval,
        &random_design(&arm, 13),
        &[0, 37, 74, 147],
        rs.len(),
    );

    check_gravity_truss(&["strain_energy"]);
}
