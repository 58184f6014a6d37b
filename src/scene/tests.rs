//! Scene building. Values are changed on the parsed scene; TOML text is edited only where
//! the parser's own reports (unknown keys) are under test.

use super::spec::{JointSpec, PointSpec};
use super::*;
use crate::error::Error;
use crate::mechanism::model::Analysis;

const ARM: &str = include_str!("../../examples/robot_arm.toml");
const TRUSS: &str = include_str!("../../examples/static_truss.toml");

fn error_of(text: &str) -> SceneError {
    match parse_toml(text) {
        Ok(spec) => refused(&spec),
        Err(e) => e,
    }
}

/// The scene error that refuses `spec` (a build without a checker is never interrupted).
fn refused(spec: &SceneSpec) -> SceneError {
    match build(spec) {
        Err(Error::Scene(e)) => e,
        other => panic!("expected a scene error, got {other:?}"),
    }
}

/// The reference robot arm as data, changed by `edit`; the error of building it.
fn arm_error(edit: impl FnOnce(&mut SceneSpec)) -> SceneError {
    let mut spec = parse_toml(ARM).unwrap();
    edit(&mut spec);
    refused(&spec)
}

#[test]
fn reference_scenes_build_only_what_they_need() {
    let arm = build(&parse_toml(ARM).unwrap()).unwrap();
    assert_eq!(arm.nodes.len(), 30);
    assert_eq!(arm.elements.len(), 148);
    assert_eq!(arm.n_variables(), 148);
    assert_eq!(arm.n_constraints(), 6);
    assert_eq!(arm.components, ["link1", "link2"]);
    assert_eq!(arm.nodes[arm.tip.unwrap()].name, "link2[4,1]");
    let (a, b) = (
        arm.node_index("link1[4,1]").unwrap(),
        arm.node_index("link2[0,1]").unwrap(),
    );
    let elbow = (arm.nodes[a].position - arm.nodes[b].position).norm();
    assert!(elbow < 1e-15, "link 2 starts at link 1's node (L, 0)");
    let truss = build(&parse_toml(TRUSS).unwrap()).unwrap();
    assert_eq!(truss.analysis, Analysis::Static);
    assert_eq!(
        (truss.nodes.len(), truss.n_constraints(), truss.loads.len()),
        (15, 3, 1)
    );
}

#[test]
fn split_bars_get_interior_nodes_of_their_own() {
    let mut spec = parse_toml(ARM).unwrap();
    spec.ground_structures.iter_mut().for_each(|g| g.split = 3);
    let arm = build(&spec).unwrap();
    assert_eq!(arm.elements.len(), 3 * 148);
    assert_eq!(arm.nodes.len(), 30 + 2 * 148);
    assert_eq!(arm.n_variables(), 148);
}

#[test]
fn splits_give_single_bars_their_own_elements() {
    let mut spec = parse_toml(ARM).unwrap();
    spec.splits.insert("link1/bar12".into(), 4);
    spec.splits.insert("link2/bar3".into(), 2);
    let arm = build(&spec).unwrap();
    assert_eq!(arm.elements.len(), 148 + 3 + 1);
    assert_eq!(arm.nodes.len(), 30 + 3 + 1);
    assert_eq!(arm.n_variables(), 148);
    let bar = |name: &str| arm.bars.iter().find(|b| b.name == name).unwrap();
    assert_eq!(bar("link1/bar12").elements.len(), 4);
    assert_eq!(bar("link1/bar11").elements.len(), 1);
    assert!(arm.node_index("link1/bar12:3").is_some());
    // A split given bar by bar builds the very model a uniform one does.
    let mut every = parse_toml(ARM).unwrap();
    every.ground_structures.iter_mut().for_each(|g| g.split = 2);
    let mut each = parse_toml(ARM).unwrap();
    for b in &build(&each.clone()).unwrap().bars {
        each.splits.insert(b.name.clone(), 2);
    }
    assert_eq!(build(&every).unwrap(), build(&each).unwrap());
}

#[test]
fn splits_of_unknown_bars_or_out_of_range_are_named() {
    let e = arm_error(|s| {
        s.splits.insert("link1/bar999".into(), 2);
    });
    assert_eq!(e.path, "splits.link1/bar999");
    assert!(e.message.contains("no deformable bar"), "{e}");
    let e = arm_error(|s| {
        s.splits.insert("link2/bar7".into(), 0);
    });
    assert_eq!(e.path, "splits.link2/bar7");
    assert!(e.message.contains("must be from 1"), "{e}");
}

#[test]
fn unknown_keys_are_named_with_their_path() {
    let e = error_of(&ARM.replace("speed = 0.5 }", "sped = 0.5 }"));
    assert!(e.path.starts_with("joints[0]"), "{e}");
    assert!(e.message.contains("sped"), "{e}");
    let e = error_of(&ARM.replace("nx = 5", "nx = 5\ncolumns = 5"));
    assert!(
        e.path.starts_with("ground_structures[0]") && e.message.contains("columns"),
        "{e}"
    );
}

#[test]
fn a_linear_analysis_is_a_static_scenes_and_named_by_its_values() {
    let e = arm_error(|s| s.simulation.analysis = Some(crate::settings::StaticAnalysis::Linear));
    assert_eq!(e.path, "simulation.analysis");
    assert!(e.message.contains("'linear' is a static analysis"), "{e}");
    let e = error_of(&TRUSS.replace("[simulation]", "[simulation]\nanalysis = \"linearised\""));
    assert!(
        e.to_string()
            .contains("must be one of 'nonlinear', 'linear', got 'linearised'"),
        "{e}"
    );
    let e = error_of(&TRUSS.replace("analysis = \"static\"", "analysis = \"linear\""));
    assert_eq!(e.path, "analysis");
    assert!(
        e.message
            .contains("analysis = \"linear\" in its [simulation] table"),
        "{e}"
    );
    let e = error_of(&TRUSS.replace("analysis = \"static\"", "analysis = \"modal\""));
    assert!(
        e.message
            .contains("unknown variant `modal`, expected `dynamic` or `static`"),
        "{e}"
    );
    let mut truss = parse_toml(TRUSS).unwrap();
    truss.simulation.analysis = Some(crate::settings::StaticAnalysis::Linear);
    assert!(build(&truss).is_ok());
}

#[test]
fn non_physical_values_are_named() {
    let section = |s: &mut SceneSpec| s.sections.values_mut().next().unwrap().E = -1.0;
    assert_eq!(arm_error(section).path, "sections.aluminium.E");
    let e = arm_error(|s| s.sections.values_mut().next().unwrap().E = f64::NAN);
    assert!(e.message.contains("finite"), "{e}");
    let e = arm_error(|s| s.point_masses[0].mass = f64::INFINITY);
    assert_eq!(e.path, "point_masses[0].mass");
    assert_eq!(arm_error(|s| s.design.x_min = 1.5).path, "design.x_min");
}

#[test]
fn missing_and_duplicate_nodes_are_named() {
    let e = arm_error(|s| s.point_masses[0].node = "link3[4,1]".into());
    assert!(
        e.path.contains("point_masses[0].node") && e.message.contains("link3[4,1]"),
        "{e}"
    );
    let e = arm_error(|s| s.ground_structures[1].name = "link1".into());
    assert!(
        e.message.contains("duplicate node name 'link1[0,0]'"),
        "{e}"
    );
}

#[test]
fn degenerate_geometry_is_rejected() {
    let e = arm_error(|s| s.ground_structures[0].height = 0.0);
    assert!(e.path.ends_with("height"), "{e}");
    let text = "[sections.s]\nE = 1e9\nnu = 0.3\nrho = 1000.0\ndiameter = 0.01\n\
                [[nodes]]\nname = \"a\"\nx = 0.0\ny = 0.0\n[[nodes]]\nname = \"b\"\nx = 0.0\ny = 0.0\n\
                [[beams]]\nnodes = [\"a\", \"b\"]\nsection = \"s\"\n";
    let e = error_of(text);
    assert!(e.message.contains("zero-length bar"), "{e}");
    let e = arm_error(|s| s.ground_structures[1].origin = PointSpec::Coordinates([0.5, 0.9]));
    assert!(
        e.path.contains("elbow") && e.message.contains("must coincide"),
        "{e}"
    );
}

#[test]
fn duplicate_names_are_named() {
    // Two joints called alike: the second's reactions and drive torque would be lost.
    let e = arm_error(|s| {
        if let JointSpec::Hinge { name, .. } = &mut s.joints[1] {
            *name = "shoulder".into();
        }
    });
    assert_eq!(e.path, "joints[1] (shoulder)");
    assert!(
        e.message.contains("joints[0] is called 'shoulder' too"),
        "{e}"
    );
    let mut spec = parse_toml(&cantilever_pair()).unwrap();
    spec.beams[1].name = Some("one".into());
    let e = refused(&spec);
    assert_eq!(e.path, "beams[1]");
    assert!(e.message.contains("duplicate bar name 'one'"), "{e}");
}

/// Two beams in a row from a clamp, `one` and `two`.
fn cantilever_pair() -> String {
    "[sections.al]\nE = 70e9\nnu = 0.3\nrho = 2700.0\ndiameter = 0.02\n\
     [[nodes]]\nname = \"a\"\nx = 0.0\ny = 0.0\n[[nodes]]\nname = \"b\"\nx = 1.0\ny = 0.0\n\
     [[nodes]]\nname = \"c\"\nx = 2.0\ny = 0.0\n\
     [[beams]]\nname = \"one\"\nnodes = [\"a\", \"b\"]\nsection = \"al\"\n\
     [[beams]]\nname = \"two\"\nnodes = [\"b\", \"c\"]\nsection = \"al\"\n\
     [[joints]]\nkind = \"clamp\"\nname = \"root\"\nnode = \"a\"\n"
        .into()
}

#[test]
fn over_and_under_constrained_mechanisms_are_rejected() {
    let e = arm_error(|s| {
        s.joints.push(JointSpec::Pin {
            name: "again".into(),
            node: "link1[0,1]".into(),
            drive: None,
        })
    });
    assert!(
        e.path.contains("again") && e.message.contains("over-constrained"),
        "{e}"
    );
    let e = arm_error(|s| {
        for joint in &mut s.joints {
            if let JointSpec::Hinge { nodes, .. } = joint {
                nodes[0] = nodes[1].clone();
            }
        }
    });
    assert!(e.message.contains("two distinct nodes"), "{e}");
    let e = arm_error(|s| s.joints.retain(|j| !matches!(j, JointSpec::Hinge { .. })));
    assert!(
        e.message.contains("unconstrained") && e.message.contains("link2"),
        "{e}"
    );
    let mut truss = parse_toml(TRUSS).unwrap();
    for joint in &mut truss.joints {
        if let JointSpec::Clamp { name, node } = joint {
            let (name, node) = (name.clone(), node.clone());
            *joint = JointSpec::Pin {
                name,
                node,
                drive: None,
            };
        }
    }
    let e = refused(&truss);
    assert!(e.message.contains("mechanism with 1 free"), "{e}");
}

#[test]
fn angles_written_in_degrees_are_the_angles_in_radians() {
    let rad =
        "start = 1.0471975511965976, end = 1.5707963267948966, acceleration = 2.0, speed = 0.5 }";
    let deg = "start_deg = 60.0, end_deg = 90.0, acceleration_deg = 114.59155902616465, speed_deg = 28.64788975654116 }";
    let (a, b) = (
        parse_toml(ARM).unwrap(),
        parse_toml(&ARM.replace(rad, deg)).unwrap(),
    );
    assert_eq!(a.joints.len(), b.joints.len());
    let (a, b) = (build(&a).unwrap(), build(&b).unwrap());
    for (p, q) in a.joints.iter().zip(&b.joints) {
        let (p, q) = (p.drive.as_ref().unwrap(), q.drive.as_ref().unwrap());
        for t in [0.0, 0.3, 0.9, 2.0] {
            let (x, y) = (p.at(t), q.at(t));
            assert!(
                (x.angle - y.angle).abs() < 1e-14 && (x.velocity - y.velocity).abs() < 1e-14,
                "t = {t}"
            );
        }
    }
    let mut spec = parse_toml(ARM).unwrap();
    spec.ground_structures[0].angle = None;
    spec.ground_structures[0].angle_deg = Some(30.0);
    let turned = build(&spec).unwrap();
    spec.ground_structures[0].angle_deg = None;
    spec.ground_structures[0].angle = Some(std::f64::consts::PI / 6.0);
    let same = build(&spec).unwrap();
    for (p, q) in turned.nodes.iter().zip(&same.nodes) {
        assert!((p.position - q.position).norm() < 1e-15, "{}", p.name);
    }
    spec.ground_structures[0].angle_deg = Some(30.0);
    let e = refused(&spec);
    assert!(
        e.path == "ground_structures[0] (link1).angle_deg" && e.message.contains("not both"),
        "{e}"
    );
    let e = error_of(&ARM.replacen(
        "start = 1.0471975511965976,",
        "start = 1.0471975511965976, start_deg = 60.0,",
        1,
    ));
    assert!(
        e.path.starts_with("joints[0]") && e.message.contains("`start` (rad) or `start_deg`"),
        "{e}"
    );
}

#[test]
fn a_table_of_degrees_is_a_table_of_radians() {
    let law = |text: &str| toml::from_str::<super::spec::MotionSpec>(text);
    let deg =
        law("kind = \"table\"\nt = [0.0, 1.0]\ntheta_deg = [0.0, 90.0]\nend_velocity_deg = 180.0")
            .unwrap();
    let rad = law("kind = \"table\"\nt = [0.0, 1.0]\ntheta = [0.0, 1.5707963267948966]\nend_velocity = 3.141592653589793").unwrap();
    assert!(deg.in_degrees() && !rad.in_degrees());
    let values = |m: &super::spec::MotionSpec| match m {
        super::spec::MotionSpec::Table {
            t,
            theta,
            start_velocity,
            end_velocity,
            ..
        } => (t.clone(), theta.clone(), *start_velocity, *end_velocity),
        other => panic!("not a table: {other:?}"),
    };
    assert_eq!(values(&deg), values(&rad));
    let both = law("kind = \"table\"\nt = [0.0, 1.0]\ntheta = [0.0, 1.0]\ntheta_deg = [0.0, 90.0]")
        .unwrap_err();
    assert!(
        both.to_string().contains("`theta` (rad) or `theta_deg`"),
        "{both}"
    );
}
