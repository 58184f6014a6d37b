//! The linear static analysis (`analysis = "linear"`): the small-displacement problem about
//! the reference configuration `q = 0`,
//!
//! ```text
//! [K₀    Φ₀ᵀ] [u]   [F − f₀]
//! [Φ₀    0  ] [λ] = [ −Φ(0)]
//! ```
//!
//! `K₀` the tangent of the elements, cells and springs at the reference, `Φ₀ = Φ_q(0)` the
//! joints' rows linear about it (no constraint Hessian: `λ = 0` there), the whole load `F`
//! at once. It is exactly one Newton step of the static equilibrium (the equations of
//! motion without inertia, the constraints of paper Eq. 2–3) from the unloaded reference at
//! the full load; its sensitivities differentiate
//! it on the same factors (`sensitivity/statics.rs`, with the elements of
//! [`crate::mechanism::linear`]). [`crate::solve_linear`] solves it with a static solve's
//! machinery (`statics.rs`). No load stepping, no plausibility judgement: the energy is
//! quadratic, and no cell can turn inside out.
//!
//! Where the nonlinear equilibrium fails, [`explain`] measures the linear solution: a node
//! moved by more than [`LARGE_DISPLACEMENT`] of the model's size says the load is large for
//! the stiffness, and the error then names the linear analysis and how to select it.

use crate::error::SolveError;
use crate::mechanism::model::Model;
use crate::solver::newton::{Newton, Point};

/// The linear solution's largest nodal displacement, relative to the model's size
/// ([`Model::size`]), above which a failed nonlinear solve points to the linear analysis:
/// no small displacement. The 88-line code's half-MBB in its units reads 15.9, the Lee
/// frame 1.35 times past its limit load 0.13 (a limit point, no hint), the steel half-MBB
/// under 1 kN 8e-4.
pub const LARGE_DISPLACEMENT: f64 = 0.25;

/// The linear solution `(u, λ)` with the loads at `time`, by the Newton machinery of a
/// static solve: its factors are then `K₀`'s.
///
/// # Errors
/// [`SolveError::Singular`] where `K₀` with the joints' rows is singular (a mechanism).
pub(crate) fn linear_step(
    newton: &mut Newton,
    time: f64,
) -> Result<(Vec<f64>, Vec<f64>), SolveError> {
    let model = newton.assembler().model;
    let (mut q, mut lambda) = (vec![0.0; model.n_dofs()], vec![0.0; model.n_constraints()]);
    let point = Point {
        t: time,
        load: 1.0,
        mass_coefficient: 0.0,
        gamma_prime: 0.0,
    };
    newton.static_step(point, &mut q, &mut lambda)?;
    Ok((q, lambda))
}

/// A nonlinear static solve's `failure`, with the linear analysis pointed to where the
/// linear solution moves a node by more than [`LARGE_DISPLACEMENT`] of the model's size.
pub(crate) fn explain(newton: &mut Newton, time: f64, failure: SolveError) -> SolveError {
    if matches!(failure, SolveError::Interrupted | SolveError::Setup(_)) {
        return failure;
    }
    let Ok((q, _)) = linear_step(newton, time) else {
        return failure;
    };
    let model = newton.assembler().model;
    let (node, moved) = largest_displacement(model, &q);
    let ratio = moved / model.size();
    if ratio > LARGE_DISPLACEMENT {
        SolveError::LargeLoad {
            failure: Box::new(failure),
            node: model.nodes[node].name.clone(),
            ratio,
        }
    } else {
        failure
    }
}

/// The node that `q` moves farthest, and how far (m).
fn largest_displacement(model: &Model, q: &[f64]) -> (usize, f64) {
    (0..model.nodes.len())
        .map(|n| (n, q[3 * n].hypot(q[3 * n + 1])))
        .fold(
            (0, 0.0),
            |best, (n, d)| if d > best.1 { (n, d) } else { best },
        )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanism::model::Densities;
    use crate::settings::{RunOptions, StaticAnalysis, StaticSettings};
    use crate::solver::statics::{solve_linear, solve_static};

    /// A steel plate of 6 × 2 plain cells pinned along its left edge, braced from above by a
    /// beam to its top-right corner, 1 kN down at its bottom-right corner.
    const BRACED: &str = r#"
name = "braced plate"
analysis = "static"
nodes = [{ name = "top", x = 0.0, y = 0.5 }]
beams = [{ nodes = ["top", "plate[6,2]"], section = "steel", name = "brace" }]
loads = [{ node = "plate[6,0]", force = [0.0, -1000.0] }]
joints = [
    { kind = "pin", name = "wall0", node = "plate[0,0]" },
    { kind = "pin", name = "wall1", node = "plate[0,1]" },
    { kind = "pin", name = "wall2", node = "plate[0,2]" },
    { kind = "pin", name = "anchor", node = "top" },
]
[[members]]
name = "plate"
nx = 6
ny = 2
length = 0.6
height = 0.2
thickness = 0.01
E = 200e9
nu = 0.3
rho = 7870.0
solid_at_joints = false
cell = "plain"
[sections.steel]
E = 200e9
rho = 7870.0
nu = 0.3
diameter = 0.02
[design]
interpolation = "simp"
p = 3.0
x_min = 0.001
"#;

    /// The braced plate under `load` times its 1 kN.
    fn braced(load: f64) -> Model {
        let text = BRACED.replace("-1000.0", &format!("{:e}", -1e3 * load));
        crate::scene::build(&crate::scene::parse_toml(&text).unwrap()).unwrap()
    }

    /// Densities between 0.3 and 1, uneven so that nothing is symmetric.
    fn design(model: &Model) -> Densities {
        let x: Vec<f64> = (0..model.n_variables())
            .map(|k| 0.3 + 0.7 * (0.618_034 * (k + 1) as f64).fract())
            .collect();
        model.densities(Some(&x)).unwrap()
    }

    fn settings(max_iter: usize) -> StaticSettings {
        let (analysis, settings) = RunOptions {
            max_iter: Some(max_iter),
            ..RunOptions::default()
        }
        .equilibrium(&RunOptions::default())
        .unwrap();
        assert_eq!(analysis, StaticAnalysis::Nonlinear);
        settings
    }

    fn largest(v: &[f64]) -> f64 {
        v.iter().fold(0.0, |m: f64, x| m.max(x.abs()))
    }

    /// `max |a/scale − b| / max |b|`.
    fn departure(a: &[f64], scale: f64, b: &[f64]) -> f64 {
        let d: Vec<f64> = a.iter().zip(b).map(|(a, b)| a / scale - b).collect();
        largest(&d) / largest(b)
    }

    #[test]
    fn the_solution_scales_with_the_load_exactly() {
        let (one, seven) = (braced(1.0), braced(7.0));
        let s = settings(20);
        let u1 = solve_linear(&one, design(&one), &s).unwrap();
        let u7 = solve_linear(&seven, design(&seven), &s).unwrap();
        assert!(
            departure(&u7.q, 7.0, &u1.q) < 1e-14,
            "{}",
            departure(&u7.q, 7.0, &u1.q)
        );
        assert!(departure(&u7.lambda, 7.0, &u1.lambda) < 1e-13);
        assert_eq!((u1.iterations, u1.load_steps), (1, 1));
        // The tip moves by 0.17 mm: a small displacement, carried by plate and brace.
        let tip = 3 * one
            .nodes
            .iter()
            .position(|n| n.name == "plate[6,0]")
            .unwrap()
            + 1;
        assert!((-1.8e-4..-1.7e-4).contains(&u1.q[tip]), "{}", u1.q[tip]);
    }

    /// The nonlinear equilibrium departs from the linear solution at first order in the load:
    /// 100 times less load, 100 times less departure (measured 1.8e-2, 1.8e-4 and 1.8e-6 at
    /// 100 kN, 1 kN and 10 N).
    #[test]
    fn it_is_the_small_load_limit_of_the_nonlinear_equilibrium() {
        let unit = braced(1.0);
        let linear = solve_linear(&unit, design(&unit), &settings(20)).unwrap();
        let departures: Vec<f64> = [1e2, 1.0, 1e-2]
            .iter()
            .map(|&load| {
                let m = braced(load);
                let q = solve_static(&m, design(&m), &settings(20)).unwrap().q;
                departure(&q, load, &linear.q)
            })
            .collect();
        let ratios = [departures[0] / departures[1], departures[1] / departures[2]];
        assert!(
            ratios.iter().all(|r| (90.0..110.0).contains(r)),
            "{departures:?}"
        );
        assert!(departures[2] < 2e-6, "{departures:?}");
    }

    /// A nonlinear failure where the linear solution moves little keeps its own message.
    #[test]
    fn a_failure_under_a_small_load_does_not_name_the_linear_analysis() {
        let m = braced(1.0);
        let e = solve_static(&m, design(&m), &settings(1)).unwrap_err();
        assert!(matches!(e, SolveError::NewtonFailed { .. }), "{e}");
        assert!(!e.to_string().contains("linear"), "{e}");
    }
}
