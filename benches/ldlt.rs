//! Dense against sparse `LDLᵀ` factors of the iteration matrix: one refactorization and one
//! solve, as a Newton iteration with a fresh matrix does, on mechanisms and frames from 5
//! to a few hundred unknowns; then sparse factors simplicial against supernodal on frames
//! and continuum members (plane meshes) up to 30,000 unknowns. The smallest time of several
//! batches, one core. Prints Markdown tables; `DENSE_FILL`, `DENSE_LIMIT` and
//! `SUPERNODAL_RATIO` are where the engine switches.
//!
//! `cargo bench --features bench --bench ldlt`

mod common;

use std::time::Instant;

use flextop::bench_support::{Refactoring, Storage, DENSE_FILL, DENSE_LIMIT, SUPERNODAL_RATIO};
use flextop::scene;
use flextop::Model;

/// The crank-rocker of `benches/mechanisms.py` with three rigid links: 9 DOFs, 8 rows.
const RIGID_FOUR_BAR: &str = r#"
name = "rigid four-bar"
analysis = "dynamic"
gravity = [0.0, -9.81]
[[rigid_bodies]]
name = "crank"
mass = 0.5
inertia = 4.2e-4
position = [0.0, 0.05]
points = { a = [0.0, -0.05], b = [0.0, 0.05] }
[[rigid_bodies]]
name = "coupler"
mass = 1.0
inertia = 7.5e-3
position = [0.13, 0.2]
points = { a = [-0.13, -0.1], b = [0.13, 0.1] }
[[rigid_bodies]]
name = "rocker"
mass = 0.5
inertia = 2.6e-3
position = [0.28, 0.15]
points = { a = [-0.02, 0.15], b = [0.02, -0.15] }
[[joints]]
kind = "pin"
name = "A"
node = "crank.a"
[[joints]]
kind = "hinge"
name = "B"
nodes = ["crank.b", "coupler.a"]
[[joints]]
kind = "hinge"
name = "C"
nodes = ["coupler.b", "rocker.a"]
[[joints]]
kind = "pin"
name = "D"
node = "rocker.b"
[simulation]
t_end = 1.0
h = 0.001
"#;

/// A continuum member of `nx × ny` cells, 1.0 m × 0.1 m of aluminium, pinned along its
/// root edge: the plane mesh of a continuum link.
fn member(nx: usize, ny: usize) -> Model {
    let pins: String = (0..=ny)
        .map(|j| {
            format!("[[joints]]\nkind = \"pin\"\nname = \"root{j}\"\nnode = \"plate[0,{j}]\"\n")
        })
        .collect();
    example(&format!(
        "name = \"member\"\n[[members]]\nname = \"plate\"\nnx = {nx}\nny = {ny}\nlength = 1.0\n\
         height = 0.1\nthickness = 0.005\nE = 70e9\nnu = 0.32\nrho = 2700.0\n{pins}"
    ))
}

fn example(toml: &str) -> Model {
    scene::build(&scene::parse_toml(toml).expect("valid scene")).expect("valid scene")
}

/// Seconds per refactorization and solve (the best of 7 batches).
fn time(model: &Model, storage: Storage) -> (usize, Option<f64>, f64) {
    let mut matrix = Refactoring::new(model, None, 1e6, storage).expect("factorable");
    let reps = 20_000 / (1 + model.n_dofs() / 10);
    let best = (0..7)
        .map(|_| {
            let start = Instant::now();
            for _ in 0..reps {
                matrix.run().expect("factorable");
            }
            start.elapsed().as_secs_f64() / reps as f64
        })
        .fold(f64::INFINITY, f64::min);
    (matrix.unknowns, matrix.fill, best)
}

fn main() {
    if std::env::args().any(|a| a == "--list") {
        return;
    }
    let mut scenes: Vec<(String, Model)> = vec![
        (
            "pendulum".into(),
            example(include_str!("../examples/pendulum.toml")),
        ),
        ("rigid four-bar".into(), example(RIGID_FOUR_BAR)),
        (
            "slider-crank, flexible rod".into(),
            example(include_str!("../examples/slider_crank.toml")),
        ),
        (
            "four-bar, flexible coupler".into(),
            example(include_str!("../examples/four_bar.toml")),
        ),
    ];
    for (nx, ny, split) in [(3, 3, 1), (5, 3, 1), (5, 3, 2)] {
        scenes.push((
            format!("robot arm {nx}×{ny}, m = {split}"),
            common::robot_arm(nx, ny, split),
        ));
    }
    println!("Engine switch: dense factors where sparse ones would fill at least {DENSE_FILL} of the lower triangle, up to {DENSE_LIMIT} unknowns.\n");
    println!(
        "| scene | unknowns | fill of sparse factors | dense (µs) | sparse (µs) | sparse / dense |"
    );
    println!("|---|---|---|---|---|---|");
    for (name, model) in &scenes {
        let (n, _, dense) = time(model, Storage::Dense);
        let (_, fill, sparse) = time(model, Storage::Sparse);
        println!(
            "| {name} | {n} | {:.2} | {:.2} | {:.2} | {:.2} |",
            fill.unwrap_or(1.0),
            1e6 * dense,
            1e6 * sparse,
            sparse / dense
        );
    }
    let mut sparse: Vec<(String, Model)> = [(5, 3, 2), (5, 3, 8)]
        .into_iter()
        .map(|(nx, ny, split)| {
            let name = format!("robot arm {nx}×{ny}, m = {split}");
            (name, common::robot_arm(nx, ny, split))
        })
        .collect();
    for (nx, ny) in [(20, 6), (40, 12), (60, 20), (120, 40)] {
        sparse.push((format!("member {nx} × {ny}"), member(nx, ny)));
    }
    println!("\nEngine switch: supernodal factors above a flop ratio of {SUPERNODAL_RATIO} (faer's own: 1.0).\n");
    println!("| scene | unknowns | engine's choice | simplicial (µs) | supernodal (µs) | supernodal / simplicial |");
    println!("|---|---|---|---|---|---|");
    for (name, model) in &sparse {
        let (n, simplicial_fill, simplicial) = time(model, Storage::Simplicial);
        let (_, chosen_fill, _) = time(model, Storage::Sparse);
        let (_, _, supernodal) = time(model, Storage::Supernodal);
        let chosen = if chosen_fill == simplicial_fill {
            "simplicial"
        } else {
            "supernodal"
        };
        println!(
            "| {name} | {n} | {chosen} | {:.1} | {:.1} | {:.2} |",
            1e6 * simplicial,
            1e6 * supernodal,
            supernodal / simplicial
        );
    }
}
