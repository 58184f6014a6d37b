//! Companion runs of step doubling: a state carried to twice the elements per bar
//! (`Prolongation`), runs guided by a nearby run's states, and modified Newton. Each must
//! reach the states an ordinary run reaches, to Newton's tolerance.

use crate::{
    simulate, simulate_guided, simulate_on, DynamicSettings, Error, Model, NewtonMatrix,
    Prolongation, Trajectory,
};

use super::common::*;

/// `q` of a rigid motion of `model`: turned by `angle` about the origin, then moved by `shift`.
fn rigid_motion(model: &Model, angle: f64, shift: [f64; 2]) -> Vec<f64> {
    let (c, s) = (angle.cos(), angle.sin());
    model
        .nodes
        .iter()
        .flat_map(|n| {
            let p = n.position;
            let x = c * p.x - s * p.y + shift[0];
            let y = s * p.x + c * p.y + shift[1];
            [x - p.x, y - p.y, angle]
        })
        .collect()
}

#[test]
fn prolongation_carries_rigid_motions_exactly() {
    let (coarse, fine) = (robot_arm(1, 70e9), robot_arm(2, 70e9));
    for angle in [0.3, 2.5, -3.0] {
        let worst = rigid_motion_error(&coarse, &fine, angle);
        assert!(worst < 1e-12, "angle {angle}: off by {worst:e}");
    }
}

/// The largest difference between the prolongation of `coarse`'s rigid motion (turned by
/// `angle`, moved by (0.2, −0.1)) onto `fine` and `fine`'s own.
fn rigid_motion_error(coarse: &Model, fine: &Model, angle: f64) -> f64 {
    let map = Prolongation::between(coarse, fine).unwrap();
    let mut out = vec![f64::NAN; fine.n_dofs()];
    map.apply(coarse, &rigid_motion(coarse, angle, [0.2, -0.1]), &mut out);
    let want = rigid_motion(fine, angle, [0.2, -0.1]);
    (out.iter().zip(&want))
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max)
}

/// A member of 3 × 2 cells, `split × split` elements to a cell, pinned at two corners,
/// turned by 0.3 rad.
fn member(split: usize) -> Model {
    model(&format!(
        "joints = [{{ kind = \"pin\", name = \"a\", node = \"plate[0,0]\" }}, \
         {{ kind = \"pin\", name = \"b\", node = \"plate[0,2]\" }}]\n\
         [[members]]\nname = \"plate\"\nnx = 3\nny = 2\nsplit = {split}\nlength = 0.3\n\
         height = 0.2\nthickness = 0.01\nE = 70e9\nnu = 0.3\nrho = 2700.0\nangle = 0.3\n"
    ))
}

#[test]
fn prolongation_carries_a_members_rigid_motions_exactly_and_refuses_a_split_not_in_two() {
    for (coarse, fine) in [(member(1), member(2)), (member(2), member(4))] {
        let worst = rigid_motion_error(&coarse, &fine, 2.5);
        assert!(worst < 1e-12, "off by {worst:e}");
    }
    let err = Prolongation::between(&member(1), &member(3)).unwrap_err();
    assert!(err.message.contains("not four times"), "{err}");
}

#[test]
fn prolongation_refuses_a_model_that_is_not_split_in_two() {
    let err = Prolongation::between(&robot_arm(1, 70e9), &robot_arm(3, 70e9)).unwrap_err();
    assert!(err.message.contains("not split in two"), "{err}");
}

fn arm_run(steps: usize, newton: NewtonMatrix) -> DynamicSettings {
    DynamicSettings {
        tol: 1e-8,
        newton,
        ..settings(1.3, 1.3 / steps as f64, 0.8)
    }
}

fn worst_difference(a: &Trajectory, b: &Trajectory) -> f64 {
    a.q.iter()
        .zip(&b.q)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

#[test]
fn a_run_guided_by_the_coarser_mesh_reaches_the_same_states_in_fewer_iterations() {
    let (coarse, fine) = (robot_arm(1, 70e9), robot_arm(2, 70e9));
    let x = vec![0.4; fine.n_variables()];
    let s = arm_run(34, NewtonMatrix::Full);
    let on_coarse = simulate(&coarse, Some(&x), &s).unwrap();
    let map = Prolongation::between(&coarse, &fine).unwrap();
    let mut guide = vec![0.0; on_coarse.time.len() * fine.n_dofs()];
    for (row, out) in on_coarse
        .q
        .chunks(coarse.n_dofs())
        .zip(guide.chunks_mut(fine.n_dofs()))
    {
        map.apply(&coarse, row, out);
    }
    let plain = simulate(&fine, Some(&x), &s).unwrap();
    let guided = simulate_guided(&fine, Some(&x), &s, &s.grid(), &guide).unwrap();
    let worst = worst_difference(&plain, &guided);
    assert!(worst < 1e-7, "guided states off by {worst:e}");
    let total = |t: &Trajectory| t.iterations.iter().sum::<usize>();
    assert!(
        total(&guided) < total(&plain) * 9 / 10,
        "iterations: guided {}, plain {}",
        total(&guided),
        total(&plain)
    );
    let short = simulate_guided(&fine, Some(&x), &s, &s.grid(), &guide[1..]);
    assert!(matches!(short, Err(Error::Settings(e)) if e.name == "guide"));
}

#[test]
fn modified_newton_reaches_the_states_of_newton() {
    let model = robot_arm(1, 70e9);
    let x = vec![0.4; model.n_variables()];
    let full = arm_run(68, NewtonMatrix::Full);
    let modified = arm_run(68, NewtonMatrix::Modified);
    let a = simulate_on(&model, Some(&x), &full, &full.grid()).unwrap();
    let b = simulate_on(&model, Some(&x), &modified, &modified.grid()).unwrap();
    let worst = worst_difference(&a, &b);
    assert!(worst < 1e-7, "modified Newton's states off by {worst:e}");
    assert!("modified".parse::<NewtonMatrix>() == Ok(NewtonMatrix::Modified));
    let e = "exact".parse::<NewtonMatrix>().unwrap_err();
    assert!(
        e.name == "newton" && e.message.contains("'full', 'modified'"),
        "{e}"
    );
}

/// Each bar's share of the change from one to two elements per bar (dual-weighted
/// residuals): the shares add up to the change the split run measures, and a share weighted
/// by the coarse run's adjoint alone would not (the tip deflection is quadratic in the
/// motion: the trapezoidal weights make the sum exact for a linear scheme).
#[test]
fn the_bars_shares_add_up_to_the_change_of_splitting_every_bar() {
    let (coarse, fine) = (robot_arm(1, 70e9), robot_arm(2, 70e9));
    let x = vec![0.4; coarse.n_variables()];
    let s = arm_run(136, NewtonMatrix::Full);
    let responses = crate::parse_responses(&coarse, &["tip_deflection".into()]).unwrap();
    let run = simulate(&fine, Some(&x), &s).unwrap();
    let states = crate::Path {
        q: &run.q,
        qdot: &run.qdot,
        qddot: &run.qddot,
        lam: &run.lam,
    };
    let shares = crate::bar_shares(&coarse, &fine, &x, &s, &s.grid(), &responses, states).unwrap();
    let value = |m: &Model| {
        let tip = crate::parse_responses(m, &["tip_deflection".into()]).unwrap();
        crate::of_motion(m, &x, &s, &tip, &[], Default::default())
            .unwrap()
            .values[0]
    };
    let change = value(&fine) - value(&coarse);
    assert!((shares.values[0] - value(&coarse)).abs() <= 1e-12 * value(&coarse));
    let sum: f64 = shares.shares.iter().sum();
    assert!(
        (sum / change - 1.0).abs() < 1e-2,
        "shares {sum:e}, change {change:e}"
    );
    let first: f64 = shares.first_order.iter().sum();
    assert!(
        (first / change - 1.0).abs() > 2e-2,
        "first order {first:e}, change {change:e}"
    );
    let refused = crate::bar_shares(&coarse, &coarse, &x, &s, &s.grid(), &responses, states);
    assert!(matches!(refused, Err(Error::Settings(_))));
}
