//! Natural modes of spatial mechanisms: a cantilever's bending in both planes, torsion and
//! extension against their closed forms, none missing; a narrow cantilever's lateral-torsional
//! buckling at Prandtl's load, where its lowest frequency falls to zero.

use std::f64::consts::PI;

use flextop::group::{Frame, NV};
use flextop::load::TimeFunction;
use flextop::spatial::joint::{Anchor, JointKind};
use flextop::spatial::modal::natural_modes_spatial;
use flextop::spatial::model::SpatialModel;
use flextop::spatial::section::{Section, Shape};
use flextop::spatial::statics::solve_static_spatial;
use flextop::{NewtonMatrix, StaticSettings};
use nalgebra::{UnitQuaternion, Vector3};

/// A cantilever of `elements` beams along x, clamped at the origin, sections' `e₂` along y.
fn cantilever(elements: usize, length: f64, section: &Section) -> SpatialModel {
    let mut m = SpatialModel::new(Vector3::zeros()).unwrap();
    for i in 0..=elements {
        let x = Vector3::new(length * i as f64 / elements as f64, 0.0, 0.0);
        m.add_node(&format!("n{i}"), Frame::new(x, UnitQuaternion::identity()))
            .unwrap();
    }
    for i in 0..elements {
        m.add_beam(&format!("b{i}"), i, i + 1, section, Vector3::y())
            .unwrap();
    }
    let root = Anchor::Node {
        node: 0,
        point: Vector3::zeros(),
    };
    m.add_joint(
        "clamp",
        JointKind::Weld,
        root,
        Anchor::Ground(Vector3::zeros()),
    )
    .unwrap();
    m
}

/// A steel cantilever of a 20 × 30 mm section, 1 m: its lowest ten frequencies are, in
/// order, the closed forms' — bending in either plane (`βₙ² √(EI/ρA)/L²`), torsion
/// (`(2k−1)π/2L √(GJ/ρIₚ)`), extension (`(2k−1)π/2L √(E/ρ)`) — none missing and none
/// extra, within 1.5 % at 32 elements (the higher bending modes lower by Timoshenko's shear
/// and rotary inertia, which the closed forms leave out); the first bending in each plane
/// and the first torsion within 0.1 %, converging at second order.
#[test]
fn a_cantilevers_frequencies_are_the_closed_forms() {
    let (e, g, rho) = (2.1e11, 2.1e11 / 2.6, 7850.0);
    let rectangle = Shape::Rectangle { b: 0.02, h: 0.03 }.geometry(0.3).unwrap();
    let section = Section::new(&rectangle, e, g, rho);
    let length = 1.0;
    let area = rectangle.area;
    let mut closed: Vec<f64> = Vec::new();
    for beta in [
        1.875_104_07,
        4.694_091_13,
        7.854_757_44,
        10.995_540_73,
        14.137_165_49,
    ] {
        for i in [rectangle.i2, rectangle.i3] {
            closed.push(beta * beta * (e * i / (rho * area)).sqrt() / (length * length));
        }
    }
    let polar = rectangle.i2 + rectangle.i3;
    for k in 1..=3 {
        let wave = (2 * k - 1) as f64 * PI / (2.0 * length);
        closed.push(wave * (g * rectangle.torsion / (rho * polar)).sqrt());
        closed.push(wave * (e / rho).sqrt());
    }
    closed.sort_by(f64::total_cmp);
    let count = 10;
    let lowest = |elements: usize| -> Vec<f64> {
        let m = cantilever(elements, length, &section);
        let modes = natural_modes_spatial(&m, &m.initial_configuration(), &[0.0; 6], 0.0).unwrap();
        assert_eq!(
            modes.omega_squared.len(),
            NV * elements,
            "a mode per free direction"
        );
        modes.omega_squared[..count]
            .iter()
            .map(|w| w.sqrt())
            .collect()
    };
    let omegas: Vec<Vec<f64>> = [8, 16, 32].iter().map(|&n| lowest(n)).collect();
    let errors: Vec<f64> = closed[..count]
        .iter()
        .zip(&omegas[2])
        .map(|(c, w)| (w - c) / c)
        .collect();
    println!("relative errors of the lowest {count} at 32 elements: {errors:?}");
    assert!(errors.iter().all(|x| x.abs() < 1.5e-2), "{errors:?}");
    // The first bending in each plane and the first torsion (the 8th): within 0.1 %, their
    // changes with each halving falling at second order.
    for k in [0, 1, 7] {
        assert!(errors[k].abs() < 1e-3, "mode {k}: {}", errors[k]);
        let ratio = (omegas[0][k] - omegas[1][k]) / (omegas[1][k] - omegas[2][k]);
        assert!(
            (ratio.log2() - 2.0).abs() < 0.3,
            "mode {k}: order {}",
            ratio.log2()
        );
    }
}

/// A narrow cantilever (10 × 200 mm, 2 m) under a dead end load at its centroid along the
/// strong direction buckles sideways at Prandtl's `P = 4.013 √(E I_weak G J)/L²` (the
/// in-plane deflection before it raises it by 0.14 %): its lowest `ω²` on the loaded
/// equilibria changes sign within 1 % of it.
#[test]
fn lateral_torsional_buckling_at_prandtls_load() {
    let (e, g) = (2.1e11, 2.1e11 / 2.6);
    let narrow = Shape::Rectangle { b: 0.01, h: 0.2 }.geometry(0.3).unwrap();
    let section = Section::new(&narrow, e, g, 7850.0);
    let length = 2.0;
    let prandtl = 4.013 * (e * narrow.i3 * g * narrow.torsion).sqrt() / (length * length);
    let lowest = |load: f64| {
        let mut m = cantilever(16, length, &section);
        let tip = Anchor::Node {
            node: 16,
            point: Vector3::zeros(),
        };
        let force = Vector3::new(0.0, 0.0, -load);
        m.add_load(
            "tip",
            tip,
            force,
            Vector3::zeros(),
            TimeFunction::Constant,
            false,
        )
        .unwrap();
        let settings = StaticSettings {
            load_steps: 4,
            time: 0.0,
            tol: 1e-10,
            max_iter: 30,
            newton: NewtonMatrix::Full,
            max_cuts: 6,
        };
        let eq = solve_static_spatial(&m, &settings).unwrap();
        natural_modes_spatial(&m, &eq.q, &eq.lambda, 0.0).unwrap()
    };
    let (stable, unstable) = (lowest(0.99 * prandtl), lowest(1.01 * prandtl));
    println!(
        "lowest ω² at 0.99 and 1.01 of Prandtl's load: {:.4e}, {:.4e}",
        stable.omega_squared[0], unstable.omega_squared[0]
    );
    assert!(stable.omega_squared[0] > 0.0 && stable.frequencies().is_some());
    assert!(unstable.omega_squared[0] < 0.0 && unstable.frequencies().is_none());
    // The buckling mode: sideways (y) and twisting (about x), not in the load's plane.
    let shape = &unstable.shapes[0];
    let sideways = (1..=16)
        .map(|n| shape[NV * n + 1].abs())
        .fold(0.0, f64::max);
    let in_plane = (1..=16)
        .map(|n| shape[NV * n + 2].abs())
        .fold(0.0, f64::max);
    assert!(
        in_plane < 1e-6 * sideways,
        "{in_plane:e} against {sideways:e}"
    );
}

/// Bad input named: a configuration or multipliers of the wrong length or not finite, a
/// loaded state that is not an equilibrium and an equilibrium under a dead moment (not
/// conservative in space): `K_t` is not symmetric there.
#[test]
fn bad_states_are_named() {
    let rectangle = Shape::Rectangle { b: 0.02, h: 0.03 }.geometry(0.3).unwrap();
    let section = Section::new(&rectangle, 2.1e11, 8e10, 7850.0);
    let m = cantilever(4, 1.0, &section);
    let q = m.initial_configuration();
    let err = natural_modes_spatial(&m, &q[1..], &[0.0; 6], 0.0).unwrap_err();
    assert!(err.to_string().contains("q"), "{err}");
    let err = natural_modes_spatial(&m, &q, &[f64::NAN; 6], 0.0).unwrap_err();
    assert!(
        err.to_string().contains("lambda") && err.to_string().contains("finite"),
        "{err}"
    );
    let settings = StaticSettings {
        load_steps: 1,
        time: 0.0,
        tol: 1e-10,
        max_iter: 30,
        newton: NewtonMatrix::Full,
        max_cuts: 4,
    };
    let loaded = |force: Vector3<f64>, moment: Vector3<f64>| {
        let mut m = m.clone();
        let tip = Anchor::Node {
            node: 4,
            point: Vector3::zeros(),
        };
        m.add_load("tip", tip, force, moment, TimeFunction::Constant, false)
            .unwrap();
        let eq = solve_static_spatial(&m, &settings).unwrap();
        (m, eq)
    };
    let (pushed, eq) = loaded(Vector3::new(0.0, 3e3, 2e3), Vector3::zeros());
    natural_modes_spatial(&pushed, &eq.q, &eq.lambda, 0.0).unwrap();
    let err = natural_modes_spatial(&pushed, &q, &eq.lambda, 0.0).unwrap_err();
    assert!(err.to_string().contains("not an equilibrium"), "{err}");
    let (twisted, eq) = loaded(Vector3::zeros(), Vector3::new(0.0, 0.0, 5e3));
    let err = natural_modes_spatial(&twisted, &eq.q, &eq.lambda, 0.0).unwrap_err();
    assert!(err.to_string().contains("not conservative"), "{err}");
}

/// A cantilever with a point mass five times its own at the tip swings at the root of
/// `1 + cos β cosh β + μ β (cos β sinh β − sin β cosh β) = 0` (μ the mass ratio),
/// `ω = β² √(EI/ρAL⁴)`, within 0.1 % at 16 elements; a point mass that is not positive, or
/// on a node the mechanism lacks, is named.
#[test]
fn a_tip_mass_lowers_the_first_frequency() {
    let rectangle = Shape::Rectangle { b: 0.02, h: 0.03 }.geometry(0.3).unwrap();
    let section = Section::new(&rectangle, 2.1e11, 8e10, 7850.0);
    let length: f64 = 1.0;
    let mu = 5.0;
    let mut m = cantilever(16, length, &section);
    m.add_point_mass("tip", 16, mu * section.rho_a * length)
        .unwrap();
    let modes = natural_modes_spatial(&m, &m.initial_configuration(), &[0.0; 6], 0.0).unwrap();
    let f = |b: f64| 1.0 + b.cos() * b.cosh() + mu * b * (b.cos() * b.sinh() - b.sin() * b.cosh());
    let (mut lo, mut hi) = (0.1, 1.875);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if f(lo) * f(mid) <= 0.0 {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    let beta = 0.5 * (lo + hi);
    let closed = beta * beta * (section.c_m[2] / (section.rho_a * length.powi(4))).sqrt();
    let omega = modes.omega_squared[0].sqrt();
    assert!(
        (omega / closed - 1.0).abs() < 1e-3,
        "{omega} against {closed}"
    );
    let err = m.add_point_mass("bad", 3, -1.0).unwrap_err();
    assert_eq!(err.path, "bodies.bad.mass");
    assert_eq!(
        m.add_point_mass("far", 99, 1.0).unwrap_err().path,
        "bodies.far.node"
    );
}
