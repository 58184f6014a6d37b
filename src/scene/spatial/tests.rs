//! Spatial scenes read as the mechanism they describe, and their errors named.

use nalgebra::{Matrix3, UnitQuaternion, Vector3};

use super::{build_spatial, parse_spatial_toml, SpatialScene};
use crate::error::Error;
use crate::group::Frame;
use crate::spatial::joint::{Anchor, JointKind};
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

fn built(text: &str) -> Result<SpatialScene, Error> {
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
        scene.parameter("torque:m").unwrap(),
        vec![(Parameter::MotorTorque { force: 1 }, 1.0)]
    );
    for (name, words) in [
        ("w:bar", "not a response kind"),
        ("x:top", "no body or node"),
        ("effort:hinge", "not driven"),
        ("tip", "responses are"),
    ] {
        let e = scene.response(name).unwrap_err().to_string();
        assert!(e.contains(words), "{name}: {e}");
    }
    for (name, words) in [
        ("k:m", "no spring"),
        ("torque:s", "no motor"),
        ("E:bar", "no beam"),
        ("Iww:bar", "not a parameter kind"),
        ("mass", "KIND:NAME"),
    ] {
        let e = scene.parameter(name).unwrap_err().to_string();
        assert!(e.contains(words), "{name}: {e}");
    }
}
