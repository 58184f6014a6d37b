//! Design sensitivities: direct and adjoint against central finite differences of the same
//! discrete simulation, and against each other.

use crate::scene::{
    self,
    spec::{DesignSpec, InterpolationSpec},
};
use crate::{
    of_equilibrium, of_motion, parse_responses, DynamicSettings, Error, Memory, Method, Model,
    Response, Sensitivities, SensitivitySettings, StaticSettings,
};

pub(crate) fn how(method: Method, memory: Memory) -> SensitivitySettings {
    SensitivitySettings { method, memory }
}

use super::common::*;

pub(crate) fn random_design(model: &Model, seed: u64) -> Vec<f64> {
    let mut s = seed;
    (0..model.n_variables())
        .map(|_| {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            0.1 + 0.85 * ((s >> 11) as f64 / (1u64 << 53) as f64)
        })
        .collect()
}

/// SIMP with exponent `p` and lower bound `x_min` (the scene's default mass law).
fn simp(p: f64, x_min: f64) -> DesignSpec {
    DesignSpec {
        interpolation: InterpolationSpec::Simp,
        p: Some(p),
        x_min,
        ..DesignSpec::default()
    }
}

pub(crate) fn responses(model: &Model, names: &[&str]) -> Vec<Response> {
    parse_responses(
        model,
        &names.iter().map(|s| s.to_string()).collect::<Vec<_>>(),
    )
    .unwrap()
}

/// Fourth-order central differences of every response for variables `js`:
/// `(8(f(x+ε) − f(x−ε)) − (f(x+2ε) − f(x−2ε))) / 12ε`, whose O(ε⁴) truncation allows a step
/// large enough to keep the solver's round-off out of the difference.
fn finite_differences(
    eval: &dyn Fn(&[f64]) -> Result<Sensitivities, Error>,
    x: &[f64],
    js: &[usize],
    eps: f64,
) -> Vec<Vec<f64>> {
    let at = |j: usize, step: f64| {
        let mut xs = x.to_vec();
        xs[j] += step;
        eval(&xs).unwrap().values
    };
    js.iter()
        .map(|&j| {
            let (p1, m1, p2, m2) = (at(j, eps), at(j, -eps), at(j, 2.0 * eps), at(j, -2.0 * eps));
            (0..p1.len())
                .map(|k| (8.0 * (p1[k] - m1[k]) - (p2[k] - m2[k])) / (12.0 * eps))
                .collect()
        })
        .collect()
}

/// A run with gradients of a design by a method.
pub(crate) type Evaluate<'a> = &'a dyn Fn(&[f64], Method) -> Result<Sensitivities, Error>;

pub(crate) fn check(model: &Model, eval: Evaluate, x: &[f64], js: &[usize], n_r: usize) {
    let n_x = model.n_variables();
    let direct = eval(x, Method::Direct).unwrap();
    let adjoint = eval(x, Method::Adjoint).unwrap();
    assert_eq!(direct.values, adjoint.values);
    // Every response's differences come from the same runs: made once, then read per response
    // (`by_response[k][i]`: response k along variable js[i]).
    let fd = finite_differences(&|x| eval(x, Method::Adjoint), x, js, 5e-4);
    let by_response: Vec<Vec<f64>> = (0..n_r)
        .map(|k| fd.iter().map(|d| d[k]).collect())
        .collect();
    for (k, fd) in by_response.iter().enumerate() {
        let row = |s: &Sensitivities| s.gradients[k * n_x..(k + 1) * n_x].to_vec();
        let (gd, ga) = (row(&direct), row(&adjoint));
        let scale = gd.iter().fold(0.0f64, |m, g| m.max(g.abs()));
        for j in 0..n_x {
            assert!(
                (gd[j] - ga[j]).abs() <= 1e-9 * scale,
                "response {k}, x[{j}]: direct {} vs adjoint {}",
                gd[j],
                ga[j]
            );
        }
        for (i, &j) in js.iter().enumerate() {
            // Well-scaled components: relative error; tiny ones: against the row's scale.
            let err = (fd[i] - ga[j]).abs() / ga[j].abs().max(1e-3 * scale);
            assert!(
                err < 1e-6,
                "response {k}, x[{j}]: adjoint {} vs finite difference {} (error {err:.1e})",
                ga[j],
                fd[i]
            );
        }
    }
}

pub(crate) const DYNAMIC: [&str; 14] = [
    "tip_deflection",
    "compliance",
    "compliance:link2",
    "volume:link1",
    "displacement:link2[4,2]:0,1",
    "integrated_displacement:link1[2,0]:1,1",
    "stress",
    "stress:link1:ks=30,scale=1e6,q=0",
    "buckling:p=4",
    "stress:link1/bar40:p=16",
    "shear:link2",
    "torque:shoulder",
    "torque_rms:elbow",
    "torque:elbow:ks=20,scale=100",
];

/// Checks the robot arm with `split` elements per bar, run `settings` and design `design`.
fn dynamic_case(split: usize, settings: DynamicSettings, design: DesignSpec) {
    let mut spec = reference::robot_arm(split);
    spec.design = design;
    let arm = scene::build(&spec).expect("valid scene");
    let rs = responses(&arm, &DYNAMIC);
    let x = random_design(&arm, 11);
    let eval =
        |x: &[f64], m: Method| of_motion(&arm, x, &settings, &rs, &[], how(m, Memory::default()));
    check(&arm, &eval, &x, &[0, 37, 74, 147], rs.len());
}

#[test]
fn robot_arm_gradients_match_finite_differences() {
    dynamic_case(
        1,
        DynamicSettings {
            tol: 1e-12,
            ..settings(1.3, 0.02, 0.8)
        },
        simp(3.0, 0.01),
    );
}

#[test]
fn agreement_holds_for_other_p_h_rho_and_split() {
    let short = |h: f64, rho: f64| DynamicSettings {
        tol: 1e-12,
        ..settings(0.6, h, rho)
    };
    dynamic_case(1, short(0.01, 0.5), simp(1.0, 0.01));
    dynamic_case(2, short(0.03, 1.0), simp(4.0, 0.001));
    dynamic_case(1, short(0.02, 0.0), simp(3.0, 0.05));
    dynamic_case(
        1,
        DynamicSettings {
            mass: crate::MassKind::Lumped,
            ..short(0.02, 0.8)
        },
        DesignSpec {
            interpolation: InterpolationSpec::Ramp,
            q: Some(5.0),
            x_min: 0.01,
            ..DesignSpec::default()
        },
    );
}

#[test]
fn static_compliance_gradients_match_finite_differences() {
    check_gravity_truss(&[
        "compliance",
        "volume",
        "displacement:truss[4,1]:0,-1",
        "stress",
        "stress:p=16,q=1",
        "buckling:ks=20,scale=1e-3",
        "shear:p=4,q=0",
    ]);
}

/// [`check`] of responses `names` of the static truss under its load and gravity.
pub(crate) fn check_gravity_truss(names: &[&str]) {
    let mut spec = reference::static_truss(1);
    spec.gravity = Some([0.0, -9.81]);
    let truss = scene::build(&spec).expect("valid scene");
    let rs = responses(&truss, names);
    let settings = StaticSettings {
        tol: 1e-13,
        ..static_settings(1)
    };
    let eval = |x: &[f64], m: Method| of_equilibrium(&truss, x, &settings, &rs, &[], m);
    check(
        &truss,
        &eval,
        &random_design(&truss, 3),
        &[0, 20, 45, 73],
        rs.len(),
    );
}

#[test]
fn taylor_remainder_falls_as_epsilon_squared() {
    let arm = robot_arm(1, 70e9);
    let rs = responses(&arm, &["tip_deflection"]);
    let s = DynamicSettings {
        tol: 1e-12,
        ..settings(1.3, 0.02, 0.8)
    };
    let x = random_design(&arm, 5);
    let base = of_motion(
        &arm,
        &x,
        &s,
        &rs,
        &[],
        how(Method::Adjoint, Memory::default()),
    )
    .unwrap();
    let mut seed = 99u64;
    let v: Vec<f64> = (0..x.len())
        .map(|_| {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1);
            ((seed >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        })
        .collect();
    let slope: f64 = base.gradients.iter().zip(&v).map(|(g, vi)| g * vi).sum();
    let epsilons = [1e-2, 1e-3, 1e-4, 1e-5];
    let remainders: Vec<f64> = epsilons
        .iter()
        .map(|&e| {
            let xe: Vec<f64> = x.iter().zip(&v).map(|(xi, vi)| xi + e * vi).collect();
            let f = of_motion(
                &arm,
                &xe,
                &s,
                &rs,
                &[],
                how(Method::Adjoint, Memory::default()),
            )
            .unwrap()
            .values[0];
            (f - base.values[0] - e * slope).abs()
        })
        .collect();
    let order = log_slope(&epsilons, &remainders);
    assert!(
        (order - 2.0).abs() < 0.1,
        "remainder order {order:.3}: {remainders:?}"
    );
}

#[test]
fn checkpointed_adjoint_is_bitwise_the_stored_one() {
    let arm = robot_arm(1, 70e9);
    let rs = responses(
        &arm,
        &["tip_deflection", "compliance:link1", "torque_rms:shoulder"],
    );
    let x = random_design(&arm, 8);
    // 65 steps: checkpoints every 9 steps, segments replayed backwards.
    let s = settings(1.3, 0.02, 0.8);
    let stored = of_motion(
        &arm,
        &x,
        &s,
        &rs,
        &[],
        how(Method::Adjoint, Memory::StoreAll),
    )
    .unwrap();
    let replayed = of_motion(
        &arm,
        &x,
        &s,
        &rs,
        &[],
        how(Method::Adjoint, Memory::Checkpoints),
    )
    .unwrap();
    assert_eq!(stored.values, replayed.values);
    assert_eq!(stored.gradients, replayed.gradients);
    // A step count that is a perfect square, so segment ends meet the final step exactly.
    let s = settings(0.98, 0.02, 0.8);
    let stored = of_motion(
        &arm,
        &x,
        &s,
        &rs,
        &[],
        how(Method::Adjoint, Memory::StoreAll),
    )
    .unwrap();
    let replayed = of_motion(
        &arm,
        &x,
        &s,
        &rs,
        &[],
        how(Method::Adjoint, Memory::Auto { budget_bytes: 1 }),
    )
    .unwrap();
    assert_eq!(stored.gradients, replayed.gradients);
}

/// The adjoint about a run's own states (`of_motion_about`, an optimizer's trial kept after
/// its values were judged) is the adjoint of that run, bit for bit, with modified Newton and
/// a scene parameter too; a path of the wrong size is named.
#[test]
fn the_adjoint_about_a_runs_states_is_that_runs_bit_for_bit() {
    let arm = robot_arm(1, 70e9);
    let rs = responses(&arm, &["tip_deflection", "torque_rms:shoulder"]);
    let parameters = crate::parse_parameters(&arm, &["E:aluminium".into()], &rs).unwrap();
    let x = random_design(&arm, 3);
    let s = DynamicSettings {
        newton: crate::NewtonMatrix::Modified,
        ..settings(1.3, 0.02, 0.8)
    };
    let grid = s.grid();
    let run = crate::simulate(&arm, Some(&x), &s).unwrap();
    let path = crate::Path {
        q: &run.q,
        qdot: &run.qdot,
        qddot: &run.qddot,
        lam: &run.lam,
    };
    let about = crate::of_motion_about(&arm, &x, &s, &grid, &rs, &parameters, path).unwrap();
    let own = of_motion(
        &arm,
        &x,
        &s,
        &rs,
        &parameters,
        how(Method::Adjoint, Memory::StoreAll),
    )
    .unwrap();
    assert_eq!(about.values, own.values);
    assert_eq!(about.gradients, own.gradients);
    assert_eq!(about.parameter_gradients, own.parameter_gradients);
    let short = crate::Path {
        q: &run.q[arm.n_dofs()..],
        ..path
    };
    let refused = crate::of_motion_about(&arm, &x, &s, &grid, &rs, &parameters, short);
    assert!(
        matches!(&refused, Err(Error::Settings(e)) if e.name == "path"),
        "{refused:?}"
    );
}
