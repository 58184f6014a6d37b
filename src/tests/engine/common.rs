//! Scenes and helpers shared by the engine tests.

use crate::scene;
use crate::{DynamicSettings, MassKind, Model, NewtonMatrix, StaticSettings, Trajectory};

pub(crate) use crate::tests::reference;

/// Aluminium, solid circle d = 20 mm (docs/reference-scenes.md).
pub const ALUMINIUM: &str = "[sections.al]\nE = 70e9\nnu = 0.32\nrho = 2700.0\ndiameter = 0.02\n";

/// Builds a model from TOML text.
pub fn model(text: &str) -> Model {
    scene::build(&scene::parse_toml(text).expect("valid TOML")).expect("valid scene")
}

/// A cantilever along x of `length`, `m` elements, clamped at `a`, free end `b`, plus `extra`.
pub fn cantilever(length: f64, m: usize, extra: &str) -> String {
    format!(
        "{ALUMINIUM}[[nodes]]\nname = \"a\"\nx = 0.0\ny = 0.0\n[[nodes]]\nname = \"b\"\nx = {length}\ny = 0.0\n\
         [[beams]]\nname = \"beam\"\nnodes = [\"a\", \"b\"]\nsection = \"al\"\nsplit = {m}\n\
         [[joints]]\nkind = \"clamp\"\nname = \"root\"\nnode = \"a\"\n{extra}"
    )
}

/// `text` as a static scene.
pub fn static_scene(text: &str) -> String {
    format!("analysis = \"static\"\n{text}")
}

/// The robot arm of examples/robot_arm.toml with `split` elements per bar and Young's modulus `e`.
pub fn robot_arm(split: usize, e: f64) -> Model {
    let mut spec = reference::robot_arm(split);
    for section in spec.sections.values_mut() {
        section.E = e;
    }
    scene::build(&spec).expect("valid scene")
}

/// Section properties of [`ALUMINIUM`]: (EA, κGA, EI).
pub fn aluminium() -> (f64, f64, f64) {
    let s = *model(&cantilever(1.0, 1, "")).elements[0].kernel.section();
    (s.ea, s.gak, s.ei)
}

/// Dynamic settings with consistent mass and a tight Newton tolerance.
pub fn settings(t_end: f64, h: f64, rho_inf: f64) -> DynamicSettings {
    DynamicSettings {
        t_end,
        h,
        rho_inf,
        tol: 1e-10,
        max_iter: 30,
        newton: NewtonMatrix::Full,
        mass: MassKind::Consistent,
    }
}

/// Static settings.
pub fn static_settings(load_steps: usize) -> StaticSettings {
    StaticSettings {
        load_steps,
        time: 0.0,
        tol: 1e-10,
        max_iter: 30,
        newton: NewtonMatrix::Full,
        max_cuts: 8,
    }
}

/// Current position of `node` at record `k` of a trajectory.
pub fn position(model: &Model, traj: &Trajectory, node: usize, k: usize) -> [f64; 2] {
    let p = model.nodes[node].position;
    let q = &traj.q[k * traj.n_q..];
    [p.x + q[3 * node], p.y + q[3 * node + 1]]
}

/// Rigid tip position of the robot arm from the prescribed joint angles.
pub fn rigid_tip(t: f64) -> [f64; 2] {
    use crate::motion::{Motion, Trapezoidal};
    use std::f64::consts::PI;
    let law = Motion::Trapezoidal(Trapezoidal::new(PI / 3.0, PI / 2.0, 2.0, 0.5, 0.0));
    let th = law.at(t).angle;
    [th.cos() + (2.0 * th).cos(), th.sin() + (2.0 * th).sin()]
}

/// Least-squares slope of log(y) against log(x).
pub fn log_slope(x: &[f64], y: &[f64]) -> f64 {
    let lx: Vec<f64> = x.iter().map(|v| v.ln()).collect();
    let ly: Vec<f64> = y.iter().map(|v| v.ln()).collect();
    let n = lx.len() as f64;
    let (mx, my) = (lx.iter().sum::<f64>() / n, ly.iter().sum::<f64>() / n);
    let num: f64 = lx.iter().zip(&ly).map(|(a, b)| (a - mx) * (b - my)).sum();
    let den: f64 = lx.iter().map(|a| (a - mx).powi(2)).sum();
    num / den
}
