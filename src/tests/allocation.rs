//! The hot path allocates nothing: after the first step (which sizes faer's buffers), a
//! generalized-α step — residual and iteration-matrix assembly, numeric LDLᵀ
//! refactorization and solve (sparse or dense factors), every Newton iteration — makes no
//! heap allocation.
//! Counted with a global allocator wrapper (this test binary only), per thread, so the
//! test harness's own threads do not count.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use crate::scene;
use crate::{DynamicSettings, Integrator, MassKind, NewtonMatrix};

use super::reference;

struct Counting;

thread_local! {
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

fn count() -> usize {
    ALLOCATIONS.with(Cell::get)
}

fn record() {
    ALLOCATIONS.with(|c| c.set(c.get() + 1));
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        record();
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        record();
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn alpha_steps_do_not_allocate() {
    let runs = [1, 3].map(|split| (split, NewtonMatrix::Full, MassKind::Consistent));
    let slider_crank = include_str!("../../examples/slider_crank.toml");
    let arms = runs
        .into_iter()
        .chain([(3, NewtonMatrix::Modified, MassKind::Consistent)])
        // Bars' end nodes coupled in the mass matrix.
        .chain([(3, NewtonMatrix::Full, MassKind::BarLumped)])
        .map(|(split, newton, mass)| {
            (
                format!("arm, split = {split}, {mass:?} mass"),
                reference::robot_arm(split),
                newton,
                0.02,
                mass,
            )
        });
    // Rigid bodies, hinges on their arms (constraint Hessians) and a slider.
    let mechanism = (
        "slider-crank".to_string(),
        scene::parse_toml(slider_crank).unwrap(),
        NewtonMatrix::Full,
        2.5e-4,
        MassKind::Consistent,
    );
    // Dense factors: the four-bar's flexible coupler fills more than half the triangle.
    let four_bar = (
        "four-bar".to_string(),
        scene::parse_toml(include_str!("../../examples/four_bar.toml")).unwrap(),
        NewtonMatrix::Full,
        1e-3,
        MassKind::Consistent,
    );
    // Rayleigh damping: the α part in the constant C, the β part state-dependent.
    let mut damped = reference::robot_arm(1);
    for section in damped.sections.values_mut() {
        section.rayleigh = Some([2.0, 1e-4]);
    }
    let damped = (
        "damped arm".to_string(),
        damped,
        NewtonMatrix::Full,
        0.02,
        MassKind::Consistent,
    );
    // Truss bars, with the rotations of their pinned nodes absent from the unknowns.
    let truss = (
        "truss".to_string(),
        scene::parse_toml(TRUSS).unwrap(),
        NewtonMatrix::Full,
        5e-4,
        MassKind::Consistent,
    );
    // A continuum member: quadrilateral cells, their nodes without rotations.
    let member = (
        "member".to_string(),
        scene::parse_toml(MEMBER).unwrap(),
        NewtonMatrix::Full,
        5e-4,
        MassKind::Consistent,
    );
    // A member swinging on an averaging ring: rows on many nodes, one of them nonlinear.
    let on_ring = (
        "member on an averaging ring".to_string(),
        scene::parse_toml(&format!(
            "{}{RING}",
            &MEMBER[..MEMBER.find("[[joints]]").unwrap()]
        ))
        .unwrap(),
        NewtonMatrix::Full,
        5e-4,
        MassKind::Consistent,
    );
    // Its cells with Rayleigh damping: eight-DOF damping blocks.
    let damped_member = (
        "damped member".to_string(),
        scene::parse_toml(
            &MEMBER.replace("rho = 2700.0\n", "rho = 2700.0\nrayleigh = [2.0, 1e-4]\n"),
        )
        .unwrap(),
        NewtonMatrix::Full,
        5e-4,
        MassKind::Consistent,
    );
    assert!(damped_member.1.members[0].rayleigh.is_some());
    let runs = arms.chain([
        mechanism,
        four_bar,
        damped,
        truss,
        member,
        on_ring,
        damped_member,
    ]);
    for (name, spec, newton, h, mass) in runs {
        let model = scene::build(&spec).unwrap();
        // A member's every third cell at x = 0.05, its energy blended half way between
        // nonlinear and linear (`void = "linear_energy"`, the default): the blended path.
        let x: Vec<f64> = (0..model.n_variables())
            .map(|k| {
                if name.contains("member") && k % 3 == 0 {
                    0.05
                } else {
                    0.4
                }
            })
            .collect();
        let settings = DynamicSettings {
            t_end: 1.3,
            h,
            rho_inf: 0.8,
            tol: 1e-10,
            max_iter: 20,
            newton,
            mass,
        };
        let mut integrator =
            Integrator::new(&model, model.densities(Some(&x)).unwrap(), &settings).unwrap();
        let mut state = integrator.initial_state().unwrap();
        integrator.alpha_step(&mut state, settings.h).unwrap();
        let before = count();
        let mut iterations = 0;
        for _ in 0..30 {
            iterations += integrator
                .alpha_step(&mut state, settings.h)
                .unwrap()
                .iterations;
        }
        let allocations = count() - before;
        assert!(
            iterations >= 60,
            "the steps did Newton work ({iterations} iterations)"
        );
        assert_eq!(
            allocations, 0,
            "{name}, {newton:?} Newton: {allocations} allocations in 30 steps"
        );
    }
}

/// A truss ground structure pinned at its base column, swinging under gravity and a tip
/// load, with stiffness-proportional damping.
const TRUSS: &str = r#"
name = "moving_truss"
gravity = [0.0, -9.81]
[sections.al]
E = 70e9
rho = 2700.0
nu = 0.32
diameter = 0.02
rayleigh = [0.0, 2e-5]
[[ground_structures]]
name = "truss"
nx = 4
ny = 2
length = 0.6
height = 0.1
section = "al"
kind = "truss"
[[joints]]
kind = "pin"
name = "base0"
node = "truss[0,0]"
[[joints]]
kind = "pin"
name = "base1"
node = "truss[0,1]"
[[loads]]
node = "truss[3,1]"
force = [0.0, -2000.0]
"#;

/// A continuum member pinned at two corners of its root edge, swinging under gravity and a
/// tip load (20 N: 2 kN on one node of 5 g flings it through its cell in the first step).
const MEMBER: &str = r#"
name = "moving_member"
gravity = [0.0, -9.81]
[[members]]
name = "plate"
nx = 8
ny = 2
length = 0.6
height = 0.1
thickness = 0.005
E = 70e9
nu = 0.32
rho = 2700.0
[[joints]]
kind = "pin"
name = "base0"
node = "plate[0,0]"
[[joints]]
kind = "pin"
name = "base1"
node = "plate[0,2]"
[[loads]]
node = "plate[8,1]"
force = [0.0, -20.0]
"#;

/// [`MEMBER`]'s plate hanging from an averaging ring on its root edge, pinned at the
/// ring's centre (in place of its joints and load).
const RING: &str = r#"
[[joints]]
kind = "pin"
name = "base"
node = "hub"
[[rings]]
name = "hub"
kind = "averaging"
nodes = ["plate[0,0]", "plate[0,1]", "plate[0,2]"]
weights = [1.0, 2.0, 1.0]
"#;

/// A Lie-group α-step of a spatial mechanism — residual, non-symmetric iteration matrix,
/// sparse LU refactorization and solve, every Newton iteration — allocates nothing: a body
/// on a driven hinge, a second hung from it on a universal joint and spinning, under
/// gravity, a spring-damper and a follower load.
#[test]
fn lie_group_alpha_steps_do_not_allocate() {
    use crate::group::{so3, Frame};
    use crate::spatial::integrator::SpatialIntegrator;
    use crate::spatial::joint::{Anchor, JointKind};
    use crate::spatial::model::SpatialModel;
    use nalgebra::{Matrix3, Vector3};

    let mut m = SpatialModel::new(Vector3::new(0.0, 0.0, -9.81)).unwrap();
    let inertia = Matrix3::from_diagonal(&Vector3::new(0.1, 0.2, 0.25));
    let r1 = so3::exp(&Vector3::new(0.3, -0.2, 0.1));
    let (a1, tip) = (Vector3::new(0.0, -0.5, 0.0), Vector3::new(0.0, 0.5, 0.0));
    let one = m
        .add_body("one", Frame::new(-(r1 * a1), r1), 2.0, inertia)
        .unwrap();
    let joint_point = -(r1 * a1) + r1 * tip;
    let two = m
        .add_body(
            "two",
            Frame::new(
                joint_point + Vector3::new(0.5, 0.0, 0.0),
                nalgebra::UnitQuaternion::identity(),
            ),
            1.0,
            inertia,
        )
        .unwrap();
    let root = m
        .add_joint(
            "root",
            JointKind::Revolute {
                axis: Vector3::new(0.0, 0.6, 0.8),
            },
            Anchor::Body {
                body: one,
                point: a1,
            },
            Anchor::Ground(Vector3::zeros()),
        )
        .unwrap();
    let law = crate::motion::Table::new(vec![0.0, 0.02, 0.05], vec![0.0, 0.01, 0.05], [0.0, 2.0]);
    m.add_drive(root, crate::motion::Motion::Table(law))
        .unwrap();
    m.add_joint(
        "middle",
        JointKind::Universal {
            axis_a: Vector3::x(),
            axis_b: Vector3::y(),
        },
        Anchor::Body {
            body: one,
            point: tip,
        },
        Anchor::Body {
            body: two,
            point: Vector3::new(-0.5, 0.0, 0.0),
        },
    )
    .unwrap();
    // A spring-damper, a motor on the driven hinge's neighbour and a follower load.
    m.add_spring(
        "spring",
        Anchor::Ground(Vector3::new(1.0, 0.0, 0.0)),
        Anchor::Body {
            body: two,
            point: Vector3::new(0.5, 0.0, 0.0),
        },
        50.0,
        0.5,
        None,
    )
    .unwrap();
    let push = crate::load::TimeFunction::Table {
        t: vec![0.0, 0.05],
        value: vec![0.0, 1.0],
    };
    m.add_load(
        "push",
        Anchor::Body {
            body: one,
            point: tip,
        },
        Vector3::new(0.0, 0.0, 3.0),
        Vector3::zeros(),
        push,
        true,
    )
    .unwrap();
    m.set_rates(
        two,
        Vector3::new(0.0, 0.0, 0.0),
        Vector3::new(2.0, 0.0, 0.0),
    )
    .unwrap();
    // A damped flexible tail of two beams welded to body two.
    let start = m.nodes[m.bodies[two].node].frame.x + Vector3::new(0.5, 0.0, 0.0);
    let tail: Vec<usize> = (0..3)
        .map(|i| {
            let at = start + Vector3::new(0.3 * i as f64, 0.0, 0.0);
            let frame = Frame::new(at, nalgebra::UnitQuaternion::identity());
            m.add_node(&format!("tail{i}"), frame).unwrap()
        })
        .collect();
    let tube = crate::spatial::section::Shape::HollowCircle {
        outer: 0.02,
        inner: 0.016,
    }
    .geometry(0.33)
    .unwrap();
    let section =
        crate::spatial::section::Section::new(&tube, 7e10, 2.6e10, 2700.0).with_rayleigh(0.5, 1e-4);
    for i in 0..2 {
        m.add_beam(
            &format!("tail{i}"),
            tail[i],
            tail[i + 1],
            &section,
            Vector3::z(),
        )
        .unwrap();
    }
    for &node in &tail {
        // Turning with body two about the line they lie on.
        m.set_node_rates(node, Vector3::zeros(), Vector3::new(2.0, 0.0, 0.0))
            .unwrap();
    }
    m.add_joint(
        "weld",
        JointKind::Weld,
        Anchor::Body {
            body: two,
            point: Vector3::new(0.5, 0.0, 0.0),
        },
        Anchor::Node {
            node: tail[0],
            point: Vector3::zeros(),
        },
    )
    .unwrap();
    let settings = DynamicSettings {
        t_end: 0.0,
        h: 1e-3,
        rho_inf: 0.8,
        tol: 1e-10,
        max_iter: 20,
        newton: NewtonMatrix::Full,
        mass: MassKind::Consistent,
    };
    let mut integrator = SpatialIntegrator::new(&m, &settings).unwrap();
    let mut state = integrator.initial_state().unwrap();
    integrator.alpha_step(&mut state, 1e-3).unwrap();
    let before = count();
    let mut iterations = 0;
    for _ in 0..50 {
        iterations += integrator.alpha_step(&mut state, 1e-3).unwrap().iterations;
    }
    assert!(iterations >= 50, "Newton iterated {iterations} times");
    assert_eq!(count() - before, 0, "allocations in 50 Lie-group α-steps");
}
