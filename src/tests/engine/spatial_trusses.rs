//! Spatial truss bars: a tripod's deflection and its only modes against their closed forms,
//! a hanging bar swinging at a rigid bar's period, exact gradients in statics and in
//! motion, and the nodes without rotation held to what they can carry.

use std::f64::consts::PI;

use crate::group::{Frame, NV};
use crate::load::TimeFunction;
use crate::spatial::integrator::simulate_spatial;
use crate::spatial::joint::{Anchor, JointKind};
use crate::spatial::modal::natural_modes_spatial;
use crate::spatial::model::SpatialModel;
use crate::spatial::section::{Section, Shape};
use crate::spatial::sensitivity::{static_sensitivities, Parameter, Response};
use crate::spatial::statics::solve_static_spatial;
use crate::spatial::stress::Criterion;
use crate::Aggregation;
use crate::{DynamicSettings, MassKind, Method, NewtonMatrix, StaticSettings, TimeGrid};
use nalgebra::{UnitQuaternion, Vector3};

use super::spatial_sensitivity::check;

fn steel_rod() -> Section {
    let circle = Shape::SolidCircle { d: 0.02 }.geometry(0.3).unwrap();
    Section::new(&circle, 2.1e11, 8.1e10, 7850.0)
}

fn node(m: &mut SpatialModel, name: &str, x: Vector3<f64>) -> usize {
    m.add_node(name, Frame::new(x, UnitQuaternion::identity()))
        .unwrap()
}

fn pinned(m: &mut SpatialModel, name: &str, n: usize) {
    let at = m.nodes[n].frame.x;
    let origin = Anchor::Node {
        node: n,
        point: Vector3::zeros(),
    };
    m.add_joint(name, JointKind::Spherical, origin, Anchor::Ground(at))
        .unwrap();
}

/// Three bars from an apex at height `h` to feet pinned on a circle of radius `r`, the
/// apex loaded downwards by `p`.
pub(crate) fn tripod(h: f64, r: f64, p: f64) -> (SpatialModel, usize) {
    let mut m = SpatialModel::new(Vector3::zeros()).unwrap();
    let apex = node(&mut m, "apex", Vector3::new(0.0, 0.0, h));
    for k in 0..3 {
        let a = 2.0 * PI * k as f64 / 3.0;
        let foot = node(
            &mut m,
            &format!("foot{k}"),
            Vector3::new(r * a.cos(), r * a.sin(), 0.0),
        );
        pinned(&mut m, &format!("pin{k}"), foot);
        m.add_truss(&format!("leg{k}"), foot, apex, &steel_rod())
            .unwrap();
    }
    let at = Anchor::Node {
        node: apex,
        point: Vector3::zeros(),
    };
    m.add_load(
        "push",
        at,
        Vector3::new(0.0, 0.0, -p),
        Vector3::zeros(),
        TimeFunction::Constant,
        false,
    )
    .unwrap();
    (m, apex)
}

pub(crate) fn statics() -> StaticSettings {
    StaticSettings {
        load_steps: 1,
        time: 0.0,
        tol: 1e-12,
        max_iter: 30,
        newton: NewtonMatrix::Full,
        max_cuts: 4,
    }
}

/// A tripod under a small apex load sinks by `P L³/(3 h² EA)`; each leg's stiffness factor
/// takes a third of `dδ/ds = −δ` (direct and adjoint); unloaded, it has exactly three modes,
/// the apex's translations, the vertical one at `ω² = 3 EA h²/(L³ ρAL)` — none from the
/// rotations the bars leave out.
#[test]
fn a_tripod_against_its_closed_forms() {
    let (h, r, p) = (1.2, 0.5, 1e3);
    let (m, apex) = tripod(h, r, p);
    let section = steel_rod();
    let length = (h * h + r * r).sqrt();
    let ea = section.c_n[0];
    let eq = solve_static_spatial(&m, &statics()).unwrap();
    let sink = m.nodes[apex].frame.x.z - Frame::read(&eq.q, apex).x.z;
    let closed = p * length.powi(3) / (3.0 * h * h * ea);
    assert!(
        (sink / closed - 1.0).abs() < 1e-5,
        "{sink:e} against {closed:e}"
    );
    let responses = [Response::NodePosition {
        node: apex,
        axis: 2,
    }];
    let parameters: Vec<Parameter> = (0..3)
        .map(|truss| Parameter::TrussStiffness { truss })
        .collect();
    for method in [Method::Direct, Method::Adjoint] {
        let g = static_sensitivities(&m, &statics(), &responses, &parameters, method).unwrap();
        for d in &g.gradient[0] {
            assert!(
                (d / (sink / 3.0) - 1.0).abs() < 1e-4,
                "{method:?}: {d:e} against {:e}",
                sink / 3.0
            );
        }
    }
    // Each leg carries `N = P L/(3h)` in compression: its buckling ratio `N L²/(π² E I)`,
    // the mean of three equal ones, each a third of its rate to a factor on a leg's ratio.
    let buckling = [Response::Stress {
        criterion: Criterion::Buckling,
        aggregation: Aggregation::PMean { p: 8.0 },
        relaxation: 0.5,
        within: None,
    }];
    let factors: Vec<Parameter> = (0..3)
        .map(|truss| Parameter::TrussBuckling { truss })
        .collect();
    let g = static_sensitivities(&m, &statics(), &buckling, &factors, Method::Adjoint).unwrap();
    let euler = PI * PI * section.c_m[1] / length.powi(2);
    let ratio = p * length / (3.0 * h) / euler;
    assert!(
        (g.values[0] / ratio - 1.0).abs() < 1e-5,
        "{} against {ratio}",
        g.values[0]
    );
    for d in &g.gradient[0] {
        assert!(
            (d / (ratio / 3.0) - 1.0).abs() < 1e-5,
            "{d} against {ratio}/3"
        );
    }
    let (free, _) = tripod(h, r, 0.0);
    let modes =
        natural_modes_spatial(&free, &free.initial_configuration(), &[0.0; 9], 0.0, None).unwrap();
    assert_eq!(modes.omega_squared.len(), 3, "{:?}", modes.omega_squared);
    let vertical = 3.0 * ea * h * h / (length.powi(3) * section.rho_a * length);
    let found = modes
        .omega_squared
        .iter()
        .zip(&modes.shapes)
        .find(|(_, s)| s[2].abs() > 0.5 * s[..NV].iter().fold(0.0f64, |a, x| a.max(x.abs())))
        .map(|(w, _)| *w)
        .unwrap();
    assert!(
        (found / vertical - 1.0).abs() < 1e-10,
        "{found} against {vertical}"
    );
}

/// A bar hanging from a spherical joint swings as a rigid bar: small oscillations at
/// `T = 2π √(2L/3g)` (its consistent mass carries a rigid bar's inertia exactly), within
/// 1e-4; its gradients to its stiffness and mass, direct and adjoint, against differences.
#[test]
fn a_hanging_bar_swings_as_a_rigid_one() {
    let (length, g) = (1.0, 9.81);
    let mut m = SpatialModel::new(Vector3::new(0.0, 0.0, -g)).unwrap();
    let top = node(&mut m, "top", Vector3::zeros());
    let bottom = node(&mut m, "bottom", Vector3::new(0.0, 0.0, -length));
    pinned(&mut m, "pivot", top);
    m.add_truss("bar", top, bottom, &steel_rod().with_rayleigh(0.0, 1e-6))
        .unwrap();
    m.set_node_rates(bottom, Vector3::new(0.01, 0.0, 0.0), Vector3::zeros())
        .unwrap();
    let period = 2.0 * PI * (2.0 * length / (3.0 * g)).sqrt();
    let steps = 2000;
    let h = 1.5 * period / steps as f64;
    let settings = DynamicSettings {
        t_end: 0.0,
        h: 0.0,
        rho_inf: 0.9,
        tol: 1e-11,
        max_iter: 20,
        newton: NewtonMatrix::Full,
        mass: MassKind::Consistent,
    };
    let states = simulate_spatial(&m, &settings, &TimeGrid::uniform(h, steps)).unwrap();
    let x: Vec<f64> = states
        .iter()
        .map(|s| Frame::read(&s.q, bottom).x.x)
        .collect();
    let crossings: Vec<f64> = (2..x.len())
        .filter(|&n| x[n - 1].signum() != x[n].signum())
        .map(|n| h * ((n - 1) as f64 + x[n - 1] / (x[n - 1] - x[n])))
        .collect();
    let measured = 2.0 * (crossings[1] - crossings[0]);
    assert!(
        (measured / period - 1.0).abs() < 1e-4,
        "{measured} against {period}"
    );
    let responses = [
        Response::NodePosition {
            node: bottom,
            axis: 0,
        },
        Response::Effort { joint: 0, row: 2 },
        Response::StrainEnergy,
    ];
    let parameters = [
        Parameter::TrussStiffness { truss: 0 },
        Parameter::TrussMass { truss: 0 },
    ];
    check(
        &m,
        0.8,
        &TimeGrid::uniform(1e-3, 60),
        &responses,
        &parameters,
    );
}

/// A node only bars meet has no rotation: a hinge or a weld on it, a load with a moment or
/// following it, a spring at an offset point are named; a node nothing carries too.
#[test]
fn nodes_without_rotation_carry_only_what_they_can() {
    let (m, apex) = tripod(1.0, 0.5, 10.0);
    let settings = statics();
    let mut hinged = m.clone();
    let at = Anchor::Node {
        node: apex,
        point: Vector3::zeros(),
    };
    hinged
        .add_joint(
            "hinge",
            JointKind::Revolute { axis: Vector3::x() },
            at,
            Anchor::Ground(Vector3::new(0.0, 0.0, 1.0)),
        )
        .unwrap();
    let err = solve_static_spatial(&hinged, &settings)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("joints.hinge") && err.contains("no rotation"),
        "{err}"
    );
    let mut twisted = m.clone();
    twisted
        .add_load(
            "twist",
            at,
            Vector3::zeros(),
            Vector3::z(),
            TimeFunction::Constant,
            false,
        )
        .unwrap();
    let err = solve_static_spatial(&twisted, &settings)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("forces.twist") && err.contains("without moments"),
        "{err}"
    );
    let mut lonely = m.clone();
    node(&mut lonely, "lonely", Vector3::new(3.0, 0.0, 0.0));
    let err = solve_static_spatial(&lonely, &settings)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("nodes.lonely") && err.contains("no mass"),
        "{err}"
    );
    let mut short = m;
    let coincide = short
        .add_truss("zero", apex, apex, &steel_rod())
        .unwrap_err();
    assert!(coincide.to_string().contains("coincide"), "{coincide}");
    assert!(short.add_truss("far", apex, 99, &steel_rod()).is_err());
}
