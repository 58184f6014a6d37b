//! Natural modes of spatial mechanisms: a cantilever's bending in both planes, torsion and
//! extension against their closed forms, none missing; a narrow cantilever's lateral-torsional
//! buckling at Prandtl's load, where its lowest frequency falls to zero; the lowest modes by
//! the sparse path (a count) against the dense path, and past its limit against the closed
//! forms, a tube's pairs of equal bending frequencies all found.

use std::f64::consts::PI;

use crate::group::{Frame, NV};
use crate::load::TimeFunction;
use crate::spatial::joint::{Anchor, JointKind};
use crate::spatial::modal::natural_modes_spatial;
use crate::spatial::model::SpatialModel;
use crate::spatial::section::{Geometry, Section, Shape};
use crate::spatial::statics::solve_static_spatial;

use super::spatial_trusses::{statics as trusses_statics, tripod};
use crate::{NewtonMatrix, StaticSettings};
use nalgebra::{DMatrix, DVector, UnitQuaternion, Vector3};

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

/// A steel cantilever of a 20 × 30 mm section, 1 m, of `elements` beams, and its section.
fn steel_cantilever(elements: usize) -> (SpatialModel, Section) {
    let rectangle = Shape::Rectangle { b: 0.02, h: 0.03 }.geometry(0.3).unwrap();
    let section = Section::new(&rectangle, 2.1e11, 8e10, 7850.0);
    (cantilever(elements, 1.0, &section), section)
}

/// A cantilever's `ω` by the closed forms, ascending: bending in either plane
/// (`βₙ² √(EI/ρA)/L²`, five each), torsion (`(2k−1)π/2L √(GJ/ρIₚ)`) and extension
/// (`(2k−1)π/2L √(E/ρ)`), three each.
fn closed_forms(section: &Geometry, e: f64, g: f64, rho: f64, length: f64) -> Vec<f64> {
    let mut closed: Vec<f64> = Vec::new();
    for beta in [
        1.875_104_07,
        4.694_091_13,
        7.854_757_44,
        10.995_540_73,
        14.137_165_49,
    ] {
        for i in [section.i2, section.i3] {
            closed.push(beta * beta * (e * i / (rho * section.area)).sqrt() / (length * length));
        }
    }
    let polar = section.i2 + section.i3;
    for k in 1..=3 {
        let wave = (2 * k - 1) as f64 * PI / (2.0 * length);
        closed.push(wave * (g * section.torsion / (rho * polar)).sqrt());
        closed.push(wave * (e / rho).sqrt());
    }
    closed.sort_by(f64::total_cmp);
    closed
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
    let closed = closed_forms(&rectangle, e, g, rho, length);
    let count = 10;
    let lowest = |elements: usize| -> Vec<f64> {
        let m = cantilever(elements, length, &section);
        let modes =
            natural_modes_spatial(&m, &m.initial_configuration(), &[0.0; 6], 0.0, None).unwrap();
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
/// equilibria changes sign within 1 % of it; past it, the sparse path's lowest two are the
/// dense path's.
#[test]
fn lateral_torsional_buckling_at_prandtls_load() {
    let (e, g) = (2.1e11, 2.1e11 / 2.6);
    let narrow = Shape::Rectangle { b: 0.01, h: 0.2 }.geometry(0.3).unwrap();
    let section = Section::new(&narrow, e, g, 7850.0);
    let length = 2.0;
    let prandtl = 4.013 * (e * narrow.i3 * g * narrow.torsion).sqrt() / (length * length);
    let loaded = |load: f64| {
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
        (m, eq)
    };
    let lowest = |load: f64| {
        let (m, eq) = loaded(load);
        natural_modes_spatial(&m, &eq.q, &eq.lambda, 0.0, None).unwrap()
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
    // The lowest two by the sparse path: the shift moves below the negative `ω²`.
    let (m, eq) = loaded(1.01 * prandtl);
    assert_lowest_are_dense(&m, &eq.q, &eq.lambda, 2);
}

/// Bad input named: a configuration or multipliers of the wrong length or not finite, a
/// loaded state that is not an equilibrium and an equilibrium under a dead moment (not
/// conservative in space): `K_t` is not symmetric there, on the free directions (every mode)
/// or entry by entry (the lowest); under a dead force it is, and both paths agree.
#[test]
fn bad_states_are_named() {
    let (m, _) = steel_cantilever(4);
    let q = m.initial_configuration();
    let err = natural_modes_spatial(&m, &q[1..], &[0.0; 6], 0.0, None).unwrap_err();
    assert!(err.to_string().contains("q"), "{err}");
    let err = natural_modes_spatial(&m, &q, &[f64::NAN; 6], 0.0, None).unwrap_err();
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
    natural_modes_spatial(&pushed, &eq.q, &eq.lambda, 0.0, None).unwrap();
    assert_lowest_are_dense(&pushed, &eq.q, &eq.lambda, 3);
    let err = natural_modes_spatial(&pushed, &q, &eq.lambda, 0.0, None).unwrap_err();
    assert!(err.to_string().contains("not an equilibrium"), "{err}");
    let (twisted, eq) = loaded(Vector3::zeros(), Vector3::new(0.0, 0.0, 5e3));
    for count in [None, Some(3)] {
        let err = natural_modes_spatial(&twisted, &eq.q, &eq.lambda, 0.0, count).unwrap_err();
        assert!(
            err.to_string().contains("not conservative"),
            "{count:?}: {err}"
        );
    }
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
    let modes =
        natural_modes_spatial(&m, &m.initial_configuration(), &[0.0; 6], 0.0, None).unwrap();
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

/// The lowest `count` modes against every mode of the dense solve: `ω²` to `1e-10` of the
/// largest compared beside the dense solve's round-off (`ε` of the largest `ω²` of all), each shape in the span of the dense shapes of its cluster (modes
/// within `1e-6` of each other) to `1e-7`, and the Sturm bound between the `below`-th
/// dense `ω²` and the next.
fn assert_lowest_are_dense(m: &SpatialModel, q: &[f64], lambda: &[f64], count: usize) {
    let dense = natural_modes_spatial(m, q, lambda, 0.0, None).unwrap();
    let sparse = natural_modes_spatial(m, q, lambda, 0.0, Some(count)).unwrap();
    assert_eq!(sparse.omega_squared.len(), count);
    let scale = dense.omega_squared[count - 1].abs();
    // The dense solve's own accuracy: `ε ‖C‖`, one round-off of the largest `ω²` (2e10 rad²/s²
    // on the buckled beam: 4.5e-6 beside its lowest 3595).
    let largest = (dense.omega_squared.iter()).fold(0.0f64, |m, w| m.max(w.abs()));
    for (s, d) in sparse.omega_squared.iter().zip(&dense.omega_squared) {
        assert!(
            (s - d).abs() < 1e-10 * scale + f64::EPSILON * largest,
            "{s} against {d}"
        );
    }
    let n = dense.shapes[0].len();
    for (j, (w, shape)) in sparse.omega_squared.iter().zip(&sparse.shapes).enumerate() {
        let cluster: Vec<usize> = (0..dense.omega_squared.len())
            .filter(|&i| (dense.omega_squared[i] - w).abs() <= 1e-6 * scale)
            .collect();
        let basis = DMatrix::from_fn(n, cluster.len(), |r, c| dense.shapes[cluster[c]][r]);
        let s = DVector::from_column_slice(shape);
        let fit = basis.clone().svd(true, true).solve(&s, 1e-12).unwrap();
        let off = (&basis * fit - &s).amax() / s.amax();
        assert!(
            off < 1e-7,
            "mode {j} off its cluster {cluster:?} by {off:e}"
        );
    }
    let sturm = sparse.sturm.unwrap();
    assert!(sturm.below >= count, "{sturm:?}");
    assert!(
        dense.omega_squared[sturm.below - 1] < sturm.bound
            && sturm.bound < dense.omega_squared[sturm.below],
        "{sturm:?} against {:?}",
        &dense.omega_squared[..=sturm.below]
    );
    assert!(dense.sturm.is_none());
}

/// The sparse path (a count) finds the dense path's lowest modes: the cantilever's ten, the
/// tip mass's four, and a tripod of truss bars' two lowest, free and pushed down (its nodes'
/// rotations no unknowns).
#[test]
fn the_lowest_modes_are_the_dense_ones() {
    let (m, section) = steel_cantilever(16);
    let rest = m.initial_configuration();
    assert_lowest_are_dense(&m, &rest, &[0.0; 6], 10);
    let mut tipped = m.clone();
    tipped
        .add_point_mass("tip", 16, 5.0 * section.rho_a)
        .unwrap();
    assert_lowest_are_dense(&tipped, &rest, &[0.0; 6], 4);
    for push in [0.0, 2e4] {
        let (legs, _) = tripod(1.0, 0.8, push);
        let eq = solve_static_spatial(&legs, &trusses_statics()).unwrap();
        assert_lowest_are_dense(&legs, &eq.q, &eq.lambda, 2);
    }
}

/// A steel tube (50 × 5 mm, 3 m) of 300 elements, 1806 unknowns, past the dense limit:
/// its lowest nine modes by the sparse path are four pairs of equal bending frequencies
/// (`βₙ² √(EI/ρA)/L²`, the first within 0.1 %, the others within 1.5 %: Timoshenko's shear
/// and rotary inertia lower them) and the first torsion (`π/2L √(G/ρ)`, within 1e-4), the
/// Sturm count nine; each pair bends in both planes (its tip's sideways and vertical
/// motions independent). A 20 × 30 mm rectangle, 1 m, of 300 elements: its lowest ten are
/// the closed forms' in order (bending in either plane, torsion, extension), the first
/// bending in each plane and the first torsion within 0.1 %, the others within 2.5 %
/// (Timoshenko's lowering, 2.1 % at the fifth bending, undisguised at this mesh).
#[test]
fn a_tube_past_the_dense_limit_has_its_pairs_of_bending_modes() {
    let (e, nu, rho, length) = (2.1e11, 0.3, 7850.0, 3.0);
    let g = e / (2.0 * (1.0 + nu));
    let tube = Shape::HollowCircle {
        outer: 0.05,
        inner: 0.04,
    }
    .geometry(nu)
    .unwrap();
    let elements = 300;
    let m = cantilever(elements, length, &Section::new(&tube, e, g, rho));
    let (q, lambda) = (m.initial_configuration(), [0.0; 6]);
    let err = natural_modes_spatial(&m, &q, &lambda, 0.0, None).unwrap_err();
    assert!(err.to_string().contains("pass a count"), "{err}");
    let count = 9;
    let modes = natural_modes_spatial(&m, &q, &lambda, 0.0, Some(count)).unwrap();
    let omega: Vec<f64> = modes.omega_squared.iter().map(|w| w.sqrt()).collect();
    let bending = (e * tube.i2 / (rho * tube.area)).sqrt() / (length * length);
    for (k, beta) in [1.875_104_07, 4.694_091_13, 7.854_757_44, 10.995_540_73]
        .iter()
        .enumerate()
    {
        let closed = beta * beta * bending;
        let (a, b) = (omega[2 * k], omega[2 * k + 1]);
        assert!((a / b - 1.0).abs() < 1e-8, "pair {k}: {a} and {b}");
        let tolerance = if k == 0 { 1e-3 } else { 1.5e-2 };
        assert!(
            (a / closed - 1.0).abs() < tolerance,
            "pair {k}: {a} against {closed}"
        );
        let tip = |j: usize| {
            [
                modes.shapes[j][NV * elements + 1],
                modes.shapes[j][NV * elements + 2],
            ]
        };
        let (s, t) = (tip(2 * k), tip(2 * k + 1));
        let independent = (s[0] * t[1] - s[1] * t[0]).abs();
        assert!(
            independent > 0.1 * (s[0].hypot(s[1]) * t[0].hypot(t[1])),
            "pair {k}: tips {s:?} and {t:?} bend in one plane"
        );
    }
    let torsion = PI / (2.0 * length) * (g / rho).sqrt();
    assert!(
        (omega[8] / torsion - 1.0).abs() < 1e-4,
        "{} against {torsion}",
        omega[8]
    );
    let sturm = modes.sturm.unwrap();
    assert_eq!(sturm.below, count);
    assert!(sturm.bound > modes.omega_squared[8]);
    let fifth = 14.137_165_49_f64.powi(2) * bending;
    assert!(sturm.bound < fifth * fifth, "{sturm:?}");

    let rectangle = Shape::Rectangle { b: 0.02, h: 0.03 }.geometry(0.3).unwrap();
    let section = Section::new(&rectangle, e, e / 2.6, rho);
    let m = cantilever(elements, 1.0, &section);
    let closed = closed_forms(&rectangle, e, e / 2.6, rho, 1.0);
    assert!(m.n_v() > 1500);
    let modes =
        natural_modes_spatial(&m, &m.initial_configuration(), &lambda, 0.0, Some(10)).unwrap();
    for (k, (w, c)) in modes.omega_squared.iter().zip(&closed).enumerate() {
        let tolerance = if [0, 1, 7].contains(&k) { 1e-3 } else { 2.5e-2 };
        let error = w.sqrt() / c - 1.0;
        assert!(error.abs() < tolerance, "mode {k}: {error:e}");
    }
    assert!(modes.sturm.unwrap().below >= 10);
}

/// A bad count is named: zero, or past the mechanism's free directions.
#[test]
fn a_bad_count_is_named() {
    let (m, _) = steel_cantilever(4);
    let q = m.initial_configuration();
    for (count, words) in [(0, "is 0"), (25, "24 free directions")] {
        let err = natural_modes_spatial(&m, &q, &[0.0; 6], 0.0, Some(count)).unwrap_err();
        let text = err.to_string();
        assert!(text.contains("count") && text.contains(words), "{text}");
    }
}
