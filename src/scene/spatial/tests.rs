//! Spatial scenes read as the mechanism they describe, and their errors named.

use nalgebra::{Matrix3, UnitQuaternion, Vector3};

use super::{build_spatial, parse_spatial_toml, SpatialScene};
use crate::error::Error;
use crate::group::Frame;
use crate::joint::spatial::{Anchor, JointKind};
use crate::spatial::force::ForceKind;
use crate::spatial::model::SpatialModel;
use crate::spatial::sensitivity::{Parameter, Response};

/// The module's example.
const HINGED_BAR: &str = r#"
name = "hinged bar"
dimension = 3
gravity = [0.0, 0.0, -9.81]

[[rigid_bodies]]
name = "bar"
mass = 1.0
inertia = [0.001, 0.0833, 0.0833]
position = [0.5, 0.0, 0.0]
points = { pivot = [-0.5, 0.0, 0.0] }

[[joints]]
name = "hinge"
kind = "revolute"
a = "bar.pivot"
axis = [0.0, 1.0, 0.0]

[simulation]
t_end = 1.0
h = 0.001
"#;

pub(crate) fn built(text: &str) -> Result<SpatialScene, Error> {
    build_spatial(&parse_spatial_toml(text)?)
}

/// The error's text, for a scene that must not build.
fn refused(text: &str) -> String {
    match built(text) {
        Ok(_) => panic!("built:\n{text}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn a_scene_is_the_mechanism_built_by_hand() {
    let scene = built(HINGED_BAR).unwrap();
    let mut m = SpatialModel::new(Vector3::new(0.0, 0.0, -9.81)).unwrap();
    let inertia = Matrix3::from_diagonal(&Vector3::new(0.001, 0.0833, 0.0833));
    let frame = Frame::new(Vector3::new(0.5, 0.0, 0.0), UnitQuaternion::identity());
    let bar = m.add_body("bar", frame, 1.0, inertia).unwrap();
    let pivot = Anchor::Body {
        body: bar,
        point: Vector3::new(-0.5, 0.0, 0.0),
    };
    let axis = Vector3::y();
    m.add_joint(
        "hinge",
        JointKind::Revolute { axis },
        pivot,
        Anchor::Ground(Vector3::zeros()),
    )
    .unwrap();
    assert_eq!(scene.model, m);
    assert_eq!(
        (scene.options.t_end, scene.options.h),
        (Some(1.0), Some(0.001))
    );
}

/// A frame turned a third of a turn about (1, 1, 1) permutes the axes: the same by axis
/// and angle, in degrees, and by matrix; an angular velocity given in space is the body's
/// own turned back.
#[test]
fn orientations_agree_and_bad_ones_are_named() {
    let third = 2.0 * std::f64::consts::PI / 3.0;
    let scenes = [
        format!("{{ axis = [1.0, 1.0, 1.0], angle = {third} }}"),
        "{ axis = [2.0, 2.0, 2.0], angle_deg = 120.0 }".to_string(),
        "{ matrix = [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] }".to_string(),
    ];
    for text in &scenes {
        let text = HINGED_BAR.replace(
            "points = {",
            &format!("orientation = {text}\nangular_velocity = [0.0, 0.0, 2.0]\npoints = {{"),
        );
        let text = text.split("[[joints]]").next().unwrap().to_string();
        let scene = built(&text).unwrap();
        let node = &scene.model.nodes[0];
        let r = node.frame.rotation();
        let expected = Matrix3::new(0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0);
        assert!((r - expected).amax() < 1e-12, "{text}: {r}");
        // ω = 2 e_z in space is 2 e_y in the body's axes (R e_y = e_z).
        let omega = Vector3::new(node.velocity[3], node.velocity[4], node.velocity[5]);
        assert!(
            (omega - Vector3::new(0.0, 2.0, 0.0)).amax() < 1e-12,
            "{omega}"
        );
    }
    for (orientation, path, words) in [
        ("{ axis = [0.0, 0.0, 0.0], angle = 1.0 }", "orientation.axis", "is zero"),
        ("{ matrix = [[1.0, 0.1, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]] }", "orientation.matrix", "not a rotation"),
        ("{ matrix = [[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]] }", "orientation.matrix", "determinant"),
        ("{ axis = [1.0, 0.0, 0.0], matrix = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]] }", "orientation", "exactly one"),
        ("{ axis = [1.0, 0.0, 0.0], angle = 1.0, angle_deg = 3.0 }", "orientation.angle_deg", "not both"),
    ] {
        let text = HINGED_BAR.replace("points = {", &format!("orientation = {orientation}\npoints = {{"));
        let e = refused(&text);
        assert!(e.contains(path) && e.contains(words), "{orientation}: {e}");
    }
}

const ROD: &str = r#"
dimension = 3
[sections.steel]
E = 2.0e11
rho = 7800.0
nu = 0.3
shape = "rectangle"
width = 0.02
height = 0.01

[[nodes]]
name = "a"
position = [0.0, 0.0, 0.0]

[[nodes]]
name = "b"
position = [1.0, 2.0, 2.0]
velocity = [3.0, 0.0, 0.0]

[[beams]]
name = "rod"
nodes = ["a", "b"]
section = "steel"
split = 3

[[joints]]
name = "clamp"
kind = "weld"
a = "a"
"#;

/// A beam in three elements: inner nodes on its chord, named, with rates between the ends';
/// `E:rod` over its three elements, each `1/E`.
#[test]
fn beams_split_on_their_chord() {
    let scene = built(ROD).unwrap_or_else(|e| panic!("{e}"));
    let m = &scene.model;
    assert_eq!(m.beams.len(), 3);
    let names: Vec<_> = m.nodes.iter().map(|n| n.name.as_str()).collect();
    assert_eq!(names, ["a", "b", "rod[1]", "rod[2]"]);
    let third = &m.nodes[2];
    assert!((third.frame.x - Vector3::new(1.0, 2.0, 2.0) / 3.0).norm() < 1e-15);
    assert!((third.velocity[0] - 1.0).abs() < 1e-15);
    let e = scene.parameter("E:rod").unwrap();
    assert_eq!(e.len(), 3);
    assert!(e
        .iter()
        .enumerate()
        .all(|(k, (p, f))| { *p == Parameter::BeamStiffness { beam: k } && *f == 1.0 / 2.0e11 }));
    assert_eq!(
        scene.parameter("rho:rod").unwrap()[1],
        (Parameter::BeamMass { beam: 1 }, 1.0 / 7800.0)
    );
    assert_eq!(
        scene.response("z:rod[2]").unwrap(),
        Response::NodePosition { node: 3, axis: 2 }
    );
    let truss = built(
        &ROD.replace("split = 3", "kind = \"truss\"")
            .replace("kind = \"weld\"", "kind = \"spherical\""),
    )
    .unwrap();
    assert_eq!(
        truss.parameter("E:rod").unwrap(),
        vec![(Parameter::TrussStiffness { truss: 0 }, 1.0 / 2.0e11)]
    );
}

/// Each mistake is refused with the entry's path and what is wrong.
#[test]
fn errors_name_their_entry() {
    let cases = [
        (
            HINGED_BAR.replace("dimension = 3", "dimension = 2"),
            "dimension",
            "dimension 3",
        ),
        (
            HINGED_BAR.replace(
                "axis = [0.0, 1.0, 0.0]",
                "axes = [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0]]",
            ),
            "joints[0] (hinge).axes",
            "no `axes`",
        ),
        (
            HINGED_BAR.replace("axis = [0.0, 1.0, 0.0]", ""),
            "joints[0] (hinge)",
            "needs an `axis`",
        ),
        (
            HINGED_BAR.replace("bar.pivot", "bar.pin"),
            "joints[0] (hinge).a",
            "no point 'pin'",
        ),
        (
            HINGED_BAR.replace("bar.pivot", "beam.pivot"),
            "joints[0] (hinge).a",
            "is no body",
        ),
        (
            HINGED_BAR.replace(
                "a = \"bar.pivot\"",
                "a = \"bar.pivot\"\nb = [0.1, 0.0, 0.0]",
            ),
            "joints.hinge",
            "are apart",
        ),
        (
            HINGED_BAR.replace("a = \"bar.pivot\"", "a = \"ground\""),
            "joints[0] (hinge)",
            "both anchors",
        ),
        (
            HINGED_BAR.replace("mass = 1.0", "mass = -1.0"),
            "bodies.bar.mass",
            "positive",
        ),
        (
            HINGED_BAR.replace(
                "inertia = [0.001, 0.0833, 0.0833]",
                "inertia = [1.0, 0.1, 0.1]",
            ),
            "bodies.bar.inertia",
            "",
        ),
        (
            HINGED_BAR.replace("dimension = 3", "dimension = 3\ntip = \"top\""),
            "tip",
            "'top'",
        ),
        (
            HINGED_BAR.replace("kind = \"revolute\"", "kind = \"hinge\""),
            "joints[0].kind",
            "unknown variant",
        ),
        (
            HINGED_BAR.replace("t_end = 1.0", "t_end = 1.0\nstep = 1.0"),
            "simulation",
            "unknown field",
        ),
        (
            ROD.replace("width = 0.02", "diameter = 0.02"),
            "sections.steel.diameter",
            "not a dimension",
        ),
        (
            ROD.replace("nu = 0.3", "nu = 0.5"),
            "sections.steel.nu",
            "Poisson",
        ),
        (
            ROD.replace("section = \"steel\"", "section = \"iron\""),
            "beams[0] (rod).section",
            "'iron'",
        ),
        (
            ROD.replace("split = 3", "split = 0"),
            "beams[0] (rod).split",
            "between 1",
        ),
        (
            ROD.replace("split = 3", "split = 3\nkind = \"truss\""),
            "beams[0] (rod)",
            "one element",
        ),
        (
            ROD.replace("\"a\", \"b\"", "\"a\", \"a\""),
            "beams.rod",
            "coincide",
        ),
        (
            ROD.replace("a = \"a\"", "a = \"b\""),
            "joints",
            "initial rates",
        ),
    ];
    for (text, path, words) in cases {
        let e = refused(&text);
        assert!(
            e.contains(path) && e.contains(words),
            "expected {path} … {words}, got: {e}"
        );
    }
}

/// Responses and parameters by name, and the names that are not.
#[test]
fn names_of_responses_and_parameters() {
    let text = HINGED_BAR.replace(
        "[simulation]",
        "[[motors]]\nname = \"m\"\njoint = \"hinge\"\ntorque = 1.0\n\n\
         [[springs]]\nname = \"s\"\na = \"bar\"\nb = [0.5, 0.0, 1.0]\nk = 10.0\n\n[simulation]",
    );
    let scene = built(&text).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        scene.response("x:bar").unwrap(),
        Response::Position { body: 0, axis: 0 }
    );
    assert_eq!(
        scene.response("strain_energy").unwrap(),
        Response::StrainEnergy
    );
    assert_eq!(
        scene.parameter("Ixz:bar").unwrap(),
        vec![(
            Parameter::Inertia {
                body: 0,
                i: 0,
                j: 2
            },
            1.0
        )]
    );
    assert_eq!(
        scene.parameter("k:s").unwrap(),
        vec![(Parameter::SpringStiffness { force: 0 }, 1.0)]
    );
    assert_eq!(
        scene.parameter("length:s").unwrap(),
        vec![(Parameter::SpringRest { force: 0 }, 1.0)]
    );
    assert_eq!(
        scene.parameter("torque:m").unwrap(),
        vec![(Parameter::MotorTorque { force: 1 }, 1.0)]
    );
    for (name, words) in [
        ("w:bar", "not a spatial scene's response kind"),
        ("effort:hinge", "not a spatial scene's response kind"),
        ("x:top", "no body or node"),
        ("torque_squared:hinge", "not driven"),
        ("tip", "responses are compliance, strain_energy"),
    ] {
        let e = scene.response(name).unwrap_err().to_string();
        assert!(e.contains(words), "{name}: {e}");
    }
    // The registry's spatial kinds are the ones the names parse: each, written with this
    // scene's names, is read as its kind (or refused for what the scene lacks).
    for (kind, syntax) in crate::response::Response::spatial_kinds() {
        let text = syntax
            .split('[')
            .next()
            .unwrap()
            .replace("NAME", "bar")
            .replace("JOINT", "hinge");
        match scene.response(&text) {
            Ok(_) => {}
            Err(e) => assert!(
                !e.to_string()
                    .contains("not a spatial scene's response kind"),
                "{kind}: {e}"
            ),
        }
    }
    for (name, words) in [
        ("k:m", "no spring"),
        ("length:m", "no spring"),
        ("rest:s", "its rest is a length, length:s"),
        ("torque:s", "no motor"),
        ("E:bar", "no beam"),
        ("Iww:bar", "not a parameter kind"),
        ("mass", "KIND:NAME"),
    ] {
        let e = scene.parameter(name).unwrap_err().to_string();
        assert!(e.contains(words), "{name}: {e}");
    }
}

/// A flexible pendulum in space: two beams of two elements, on a tilted hinge, a point mass
/// at the end, a truss bar from a point of the hinge's axis bracing the elbow.
pub(crate) const PENDULUM: &str = r#"
dimension = 3
gravity = [0.0, 0.0, -9.81]
[sections.alu]
E = 7.0e10
rho = 2700.0
nu = 0.33
shape = "tube"
outer = 0.02
inner = 0.016

[[nodes]]
name = "a"
position = [0.0, 0.0, 0.0]
[[nodes]]
name = "b"
position = [0.5, 0.0, 0.0]
[[nodes]]
name = "c"
position = [0.5, 0.4, -0.1]
[[nodes]]
name = "d"
position = [0.0, 0.5, 0.15]

[[beams]]
name = "upper"
nodes = ["a", "b"]
section = "alu"
split = 2
[[beams]]
name = "lower"
nodes = ["b", "c"]
section = "alu"
split = 2
[[beams]]
name = "brace"
nodes = ["d", "b"]
section = "alu"
kind = "truss"

[[point_masses]]
name = "payload"
node = "c"
mass = 0.5

[[joints]]
name = "hinge"
kind = "revolute"
a = "a"
axis = [0.0, 1.0, 0.3]
[[joints]]
name = "pin"
kind = "spherical"
a = "d"

[simulation]
t_end = 0.1
h = 0.005
"#;

/// Densities scale each beam's and bar's stiffness by `s(x)` and mass by `m(x)`; groups and
/// fixed beams share or have no variable; a design of the wrong length or outside
/// `[x_min, 1]` is named.
#[test]
fn a_design_scales_its_beams() {
    let scene = built(PENDULUM).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.design.variables, ["upper", "lower", "brace"]);
    assert_eq!(*scene.model_at(Some(&[1.0; 3])).unwrap(), scene.model);
    let x = [0.5, 0.2, 0.05];
    let at = scene.model_at(Some(&x)).unwrap();
    let (law, mass) = (scene.design.interpolation, scene.design.mass);
    for (b, x) in [(0, 0.5), (1, 0.5), (2, 0.2), (3, 0.2)] {
        let (built, scaled) = (&scene.model.beams[b].section, &at.beams[b].section);
        assert_eq!(scaled.c_m[1], built.c_m[1] * law.stiffness(x));
        assert_eq!(scaled.c_n[2], built.c_n[2] * law.stiffness(x));
        assert_eq!(scaled.rho_i[0], built.rho_i[0] * mass.mass(x));
    }
    assert_eq!(
        at.trusses[0].ea,
        scene.model.trusses[0].ea * 0.05f64.powi(3)
    );
    let grouped = PENDULUM
        .replace(
            "split = 2\n[[beams]]",
            "split = 2\ngroup = \"arm\"\n[[beams]]",
        )
        .replace("kind = \"truss\"", "kind = \"truss\"\nfixed = true");
    let grouped = built(&grouped).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(grouped.design.variables, ["arm"]);
    let e = grouped.model_at(Some(&[0.5, 0.5])).unwrap_err().to_string();
    assert!(
        e.contains("2 entries") && e.contains("1 design variables"),
        "{e}"
    );
    let e = scene
        .model_at(Some(&[0.5, 0.001, 0.5]))
        .unwrap_err()
        .to_string();
    assert!(e.contains("x[1] (lower)") && e.contains("[0.01, 1]"), "{e}");
    let e = refused(&PENDULUM.replace(
        "kind = \"truss\"",
        "kind = \"truss\"\nfixed = true\ngroup = \"g\"",
    ));
    assert!(e.contains("beams[2]") && e.contains("fixed beam"), "{e}");
}

/// The gradient to the densities, read off the elements' stiffness and mass factors, against
/// fourth-order differences of runs at shifted designs, and direct against adjoint.
#[test]
fn density_gradients_match_differences() {
    use crate::settings::{Method, RunOptions};
    use crate::spatial::sensitivity::sensitivities;
    let scene = built(PENDULUM).unwrap_or_else(|e| panic!("{e}"));
    let settings = RunOptions {
        tol: Some(1e-11),
        ..RunOptions::default()
    }
    .dynamic(&scene.options)
    .unwrap();
    let grid = settings.grid();
    let responses = [
        scene.response("z:c").unwrap(),
        scene.response("strain_energy").unwrap(),
    ];
    let x = [0.7, 0.4, 0.3];
    let named = scene.densities(&x);
    let parameters: Vec<Parameter> = named.iter().flatten().map(|(p, _)| *p).collect();
    let model = scene.model_at(Some(&x)).unwrap();
    let gradient = |method| {
        let g = sensitivities(&model, &settings, &grid, &responses, &parameters, method).unwrap();
        let per_variable = |row: &[f64]| {
            let mut parts = row.iter();
            (named.iter())
                .map(|n| n.iter().zip(&mut parts).map(|((_, f), d)| f * d).sum())
                .collect::<Vec<f64>>()
        };
        (
            g.values,
            g.gradient
                .iter()
                .map(|r| per_variable(r))
                .collect::<Vec<_>>(),
        )
    };
    let (values, direct) = gradient(Method::Direct);
    let (_, adjoint) = gradient(Method::Adjoint);
    let value = |x: &[f64]| {
        let model = scene.model_at(Some(x)).unwrap();
        sensitivities(&model, &settings, &grid, &responses, &[], Method::Direct)
            .unwrap()
            .values
    };
    let h = 1e-3;
    for i in 0..3 {
        let shifted = |k: f64| {
            let mut y = x;
            y[i] += k * h;
            value(&y)
        };
        let (m2, m1, p1, p2) = (shifted(-2.0), shifted(-1.0), shifted(1.0), shifted(2.0));
        for r in 0..2 {
            let fd = (m2[r] - 8.0 * m1[r] + 8.0 * p1[r] - p2[r]) / (12.0 * h);
            let scale = direct[r].iter().map(|g| g.abs()).fold(0.0, f64::max);
            assert!(scale > 0.0 && values[r].is_finite());
            assert!(
                (direct[r][i] - fd).abs() < 1e-6 * scale,
                "{r} {i}: {} vs {fd}",
                direct[r][i]
            );
            assert!(
                (direct[r][i] - adjoint[r][i]).abs() < 1e-9 * scale,
                "{r} {i}"
            );
        }
    }
}

/// A torsion spring on a joint by name: its `k:` and `c:` parameters, and the mistakes
/// named (both anchors and a joint, a joint that does not turn, a rest angle past half a
/// turn, a negative stiffness).
#[test]
fn torsion_springs_on_joints() {
    let coil = |keys: &str| {
        HINGED_BAR.replace(
            "[simulation]",
            &format!("[[springs]]\nname = \"coil\"\n{keys}\n\n[simulation]"),
        )
    };
    let scene = built(&coil("joint = \"hinge\"\nk = 3.0\nc = 0.1\nrest = 0.2")).unwrap();
    assert!(matches!(
        scene.model.forces[0].kind,
        ForceKind::Torsion { stiffness, damping, rest, .. } if (stiffness, damping, rest) == (3.0, 0.1, 0.2)
    ));
    assert_eq!(
        scene.parameter("c:coil").unwrap(),
        vec![(Parameter::SpringDamping { force: 0 }, 1.0)]
    );
    for (keys, words) in [
        ("joint = \"hinge\"\na = \"bar\"", "not both"),
        ("joint = \"hinge\"\nlength = 1.0", "not both"),
        ("a = \"bar\"\nrest = 0.1", "not both"),
        (
            "joint = \"elbow\"",
            "springs[0] (coil).joint: no joint called 'elbow'",
        ),
        (
            "joint = \"hinge\"\nrest = 3.5",
            "forces.coil.rest: 3.5: a rest angle lies within half a turn",
        ),
        (
            "joint = \"hinge\"\nk = -1.0",
            "forces.coil.k: -1: must be finite and not negative",
        ),
    ] {
        let e = refused(&coil(keys));
        assert!(e.contains(words), "{keys}: {e}");
    }
    let welded = coil("joint = \"hinge\"")
        .replace("kind = \"revolute\"", "kind = \"spherical\"")
        .replace("axis = [0.0, 1.0, 0.0]\n", "");
    let e = refused(&welded);
    assert!(
        e.contains("a torsion spring turns with a revolute or cylindrical joint"),
        "{e}"
    );
}

/// A box lattice's bars: a single layer is the planar ground structure's, in its order;
/// the counts of edges, faces and diagonals are the lattice's; every "full" bar holds no
/// third node and every pair left out holds one.
#[test]
fn lattices_join_what_their_connectivity_says() {
    use super::lattice::lattice_bars;
    use super::spec::Connectivity;
    use crate::scene::ground_structure::bars;
    for (nx, ny) in [(5, 3), (4, 4), (2, 1)] {
        let full = lattice_bars("g", [nx, ny, 1], Connectivity::Full).unwrap();
        assert_eq!(full, bars(nx, ny));
    }
    let (nx, ny, nz) = (4usize, 3usize, 2usize);
    let edges = (nx - 1) * ny * nz + nx * (ny - 1) * nz + nx * ny * (nz - 1);
    let faces =
        2 * ((nx - 1) * (ny - 1) * nz + (nx - 1) * ny * (nz - 1) + nx * (ny - 1) * (nz - 1));
    let bodies = 4 * (nx - 1) * (ny - 1) * (nz - 1);
    let count = |c| lattice_bars("g", [nx, ny, nz], c).unwrap().len();
    assert_eq!(count(Connectivity::Edges), edges);
    assert_eq!(count(Connectivity::Faces), edges + faces);
    assert_eq!(count(Connectivity::Diagonals), edges + faces + bodies);
    let at = |n: usize| [n / (ny * nz), (n / nz) % ny, n % nz].map(|c| c as i64);
    let full = lattice_bars("g", [nx, ny, nz], Connectivity::Full).unwrap();
    let n = nx * ny * nz;
    for a in 0..n {
        for b in a + 1..n {
            let (pa, pb) = (at(a), at(b));
            let inside = (0..n).filter(|&c| c != a && c != b).any(|c| {
                let pc = at(c);
                let (d, e) = (
                    [0, 1, 2].map(|i| pb[i] - pa[i]),
                    [0, 1, 2].map(|i| pc[i] - pa[i]),
                );
                let cross = [
                    d[1] * e[2] - d[2] * e[1],
                    d[2] * e[0] - d[0] * e[2],
                    d[0] * e[1] - d[1] * e[0],
                ];
                let along: i64 = (0..3).map(|i| d[i] * e[i]).sum();
                cross == [0, 0, 0] && along > 0 && along < (0..3).map(|i| d[i] * d[i]).sum()
            });
            assert_eq!(full.contains(&(a, b)), !inside, "{a}-{b}");
        }
    }
}

/// A lattice cantilever of frame bars: placed by its frame, a density per bar (none where
/// fixed), mistakes named; its static strain energy's gradient to the densities against
/// fourth-order differences and direct against adjoint.
#[test]
fn a_lattice_cantilever_has_exact_density_gradients() {
    use crate::settings::{Method, RunOptions};
    use crate::spatial::sensitivity::static_sensitivities;
    let text = r#"
dimension = 3
analysis = "static"
[sections.steel]
E = 2.1e11
rho = 7850.0
nu = 0.3
shape = "circle"
diameter = 0.01
[[ground_structures]]
name = "box"
nx = 3
ny = 2
nz = 2
length = 0.4
height = 0.1
width = 0.08
connectivity = "edges"
origin = [1.0, 0.0, 0.5]
orientation = { axis = [0.0, 0.0, 1.0], angle_deg = 90.0 }
section = "steel"
[[joints]]
name = "c0"
kind = "weld"
a = "box[0,0,0]"
[[joints]]
name = "c1"
kind = "weld"
a = "box[0,1,1]"
[[loads]]
name = "push"
at = "box[2,1,1]"
force = [30.0, 0.0, -50.0]
"#;
    let scene = built(text).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.model.beams.len(), 20);
    assert_eq!(scene.design.variables.len(), 20);
    assert_eq!(scene.design.variables[0], "box/bar0");
    let tip = scene
        .model
        .nodes
        .iter()
        .find(|n| n.name == "box[2,1,1]")
        .unwrap();
    assert!((tip.frame.x - Vector3::new(1.0 - 0.05, 0.4, 0.5 + 0.04)).norm() < 1e-15);
    let settings = RunOptions {
        load_steps: Some(1),
        ..RunOptions::default()
    }
    .statics(&scene.options)
    .unwrap();
    let responses = [
        scene.response("strain_energy").unwrap(),
        scene.response("z:box[2,1,1]").unwrap(),
    ];
    let x: Vec<f64> = (0..20).map(|i| 0.3 + 0.03 * i as f64).collect();
    let named = scene.densities(&x);
    let parameters: Vec<Parameter> = named.iter().flatten().map(|(p, _)| *p).collect();
    let model = scene.model_at(Some(&x)).unwrap();
    let per_variable = |row: &[f64]| {
        let mut parts = row.iter();
        (named.iter())
            .map(|n| n.iter().zip(&mut parts).map(|((_, f), d)| f * d).sum())
            .collect::<Vec<f64>>()
    };
    let gradient = |method| {
        let g = static_sensitivities(&model, &settings, &responses, &parameters, method).unwrap();
        g.gradient
            .iter()
            .map(|r| per_variable(r))
            .collect::<Vec<_>>()
    };
    let (direct, adjoint) = (gradient(Method::Direct), gradient(Method::Adjoint));
    let value = |x: &[f64]| {
        let model = scene.model_at(Some(x)).unwrap();
        static_sensitivities(&model, &settings, &responses, &[], Method::Direct)
            .unwrap()
            .values
    };
    let h = 1e-4;
    for i in [0, 7, 19] {
        let shifted = |k: f64| {
            let mut y = x.clone();
            y[i] += k * h;
            value(&y)
        };
        let (m2, m1, p1, p2) = (shifted(-2.0), shifted(-1.0), shifted(1.0), shifted(2.0));
        for r in 0..2 {
            let fd = (m2[r] - 8.0 * m1[r] + 8.0 * p1[r] - p2[r]) / (12.0 * h);
            let scale = direct[r].iter().map(|g| g.abs()).fold(0.0, f64::max);
            assert!(
                (direct[r][i] - fd).abs() < 1e-6 * scale,
                "{r} {i}: {} vs {fd}",
                direct[r][i]
            );
            assert!(
                (direct[r][i] - adjoint[r][i]).abs() < 1e-9 * scale,
                "{r} {i}"
            );
        }
    }
    let fixed = built(&text.replace(
        "section = \"steel\"\n[[joints]]",
        "section = \"steel\"\nfixed = true\n[[joints]]",
    ))
    .unwrap();
    assert!(fixed.design.variables.is_empty());
    for (from, to, words) in [
        (
            "nz = 2",
            "nz = 0",
            "ground_structures[0] (box): 3 × 2 × 0 nodes",
        ),
        (
            "connectivity = \"edges\"",
            "connectivity = \"some\"",
            "connectivity",
        ),
        (
            "width = 0.08",
            "width = -0.08",
            "ground_structures[0] (box).width",
        ),
        (
            "section = \"steel\"\n[[joints]]",
            "section = \"iron\"\n[[joints]]",
            "ground_structures[0] (box).bars[0] (box/bar0).section",
        ),
    ] {
        let e = refused(&text.replace(from, to));
        assert!(e.contains(words), "{to}: {e}");
    }
}
