use super::*;
use crate::model::Analysis;

const ARM: &str = include_str!("../../examples/robot_arm.toml");
const TRUSS: &str = include_str!("../../examples/static_truss.toml");

fn error_of(text: &str) -> SceneError {
    match parse_toml(text).and_then(|s| build(&s)) {
        Ok(_) => panic!("scene was accepted"),
        Err(e) => e,
    }
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
    let text = ARM.replace("split = 1", "split = 3");
    let arm = build(&parse_toml(&text).unwrap()).unwrap();
    assert_eq!(arm.elements.len(), 3 * 148);
    assert_eq!(arm.nodes.len(), 30 + 2 * 148);
    assert_eq!(arm.n_variables(), 148);
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
fn non_physical_values_are_named() {
    let e = error_of(&ARM.replace("E = 70e9", "E = -1.0"));
    assert_eq!(e.path, "sections.aluminium.E");
    let e = error_of(&ARM.replace("E = 70e9", "E = nan"));
    assert!(e.message.contains("finite"), "{e}");
    let e = error_of(&ARM.replace("mass = 5.0", "mass = inf"));
    assert_eq!(e.path, "point_masses[0].mass");
    let e = error_of(&ARM.replace("x_min = 0.01", "x_min = 1.5"));
    assert_eq!(e.path, "design.x_min");
}

#[test]
fn missing_and_duplicate_nodes_are_named() {
    let e = error_of(&ARM.replace("node = \"link2[4,1]\"", "node = \"link3[4,1]\""));
    assert!(
        e.path.contains("point_masses[0].node") && e.message.contains("link3[4,1]"),
        "{e}"
    );
    let e = error_of(&ARM.replace("name = \"link2\"", "name = \"link1\""));
    assert!(
        e.message.contains("duplicate node name 'link1[0,0]'"),
        "{e}"
    );
}

#[test]
fn degenerate_geometry_is_rejected() {
    let e = error_of(&ARM.replace("height = 0.1", "height = 0.0"));
    assert!(e.path.ends_with("height"), "{e}");
    let text = "[sections.s]\nE = 1e9\nnu = 0.3\nrho = 1000.0\ndiameter = 0.01\n\
                [[nodes]]\nname = \"a\"\nx = 0.0\ny = 0.0\n[[nodes]]\nname = \"b\"\nx = 0.0\ny = 0.0\n\
                [[beams]]\nnodes = [\"a\", \"b\"]\nsection = \"s\"\n";
    let e = error_of(text);
    assert!(e.message.contains("zero-length bar"), "{e}");
    let e = error_of(&ARM.replace("origin = \"link1[4,1]\"", "origin = [0.5, 0.9]"));
    assert!(
        e.path.contains("elbow") && e.message.contains("must coincide"),
        "{e}"
    );
}

#[test]
fn over_and_under_constrained_mechanisms_are_rejected() {
    let twice = ARM.replace(
        "[design]",
        "[[joints]]\nkind = \"pin\"\nname = \"again\"\nnode = \"link1[0,1]\"\n\n[design]",
    );
    let e = error_of(&twice);
    assert!(
        e.path.contains("again") && e.message.contains("over-constrained"),
        "{e}"
    );
    let floating = ARM
        .replace("kind = \"hinge\"", "kind = \"hinge\"\n")
        .replace(
            "nodes = [\"link1[4,1]\", \"link2[0,1]\"]",
            "nodes = [\"link2[0,1]\", \"link2[0,1]\"]",
        );
    let e = error_of(&floating);
    assert!(e.message.contains("two distinct nodes"), "{e}");
    let unhinged = ARM
        .split("[[joints]]                # elbow")
        .next()
        .unwrap()
        .to_string()
        + "[design]\np = 3.0\n";
    let e = error_of(&unhinged);
    assert!(
        e.message.contains("unconstrained") && e.message.contains("link2"),
        "{e}"
    );
    let e = error_of(&TRUSS.replace("kind = \"clamp\"", "kind = \"pin\""));
    assert!(e.message.contains("mechanism with 1 free"), "{e}");
}
