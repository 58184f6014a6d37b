//! A spatial scene built into a [`SpatialModel`], in the order a mechanism is put
//! together: sections, bodies and nodes, beams (split into elements, their inner nodes
//! named `BEAM[k]`), point masses, joints and drives, springs, motors, loads. Each value is
//! checked where it is read; the model checks each entry as it is added (points that meet,
//! rates the joints allow).

use std::collections::BTreeMap;

use nalgebra::{Matrix3, UnitQuaternion, Vector3};

use super::lattice::expand;
use super::orientation::{rotation, vector};
use super::spec::{
    AnchorSpec, JointKindSpec, OrientationSpec, ShapeSpec, SpatialBeamSpec, SpatialBodySpec,
    SpatialJointSpec, SpatialSceneSpec, SpatialSectionSpec,
};
use super::{BeamElements, SpatialScene};
use crate::error::{short, Error, SceneError};
use crate::group::Frame;
use crate::joint::spatial::{Anchor, JointKind};
use crate::limits::{MAX_NODES, MAX_SPLIT};
use crate::mechanism::model::{Analysis, Design};
use crate::scene::design::{self, Variables};
use crate::scene::joint::drive;
use crate::scene::load::time;
use crate::scene::spec::{AnalysisSpec, KindSpec};
use crate::scene::validate::{non_negative, positive, unique};
use crate::spatial::model::SpatialModel;
use crate::spatial::section::{Section, Shape};

type Result<T> = std::result::Result<T, SceneError>;

/// Builds the spatial scene `spec` describes (module docs).
///
/// # Errors
/// A [`SceneError`] naming the first entry that is wrong; [`crate::SolveError::Interrupted`]
/// where the caller asks to stop.
pub fn build_spatial(spec: &SpatialSceneSpec) -> std::result::Result<SpatialScene, Error> {
    if spec.dimension != 3 {
        return Err(SceneError::new(
            "dimension",
            format!("{}: a spatial scene has dimension 3", spec.dimension),
        )
        .into());
    }
    let gravity = vector("gravity", spec.gravity.unwrap_or_default())?;
    let mut model = SpatialModel::new(gravity)?;
    let sections = sections(&spec.sections)?;
    for (k, b) in spec.rigid_bodies.iter().enumerate() {
        crate::poll()?;
        body(&mut model, &format!("rigid_bodies[{k}] ({})", b.name), b)?;
    }
    let lattices = (spec.ground_structures.iter().enumerate())
        .map(|(k, g)| {
            let path = format!("ground_structures[{k}] ({})", g.name);
            expand(&path, g).map(|(nodes, beams)| (path, nodes, beams))
        })
        .collect::<std::result::Result<Vec<_>, _>>()?;
    let named = |what: &str, k: usize, name: &str| format!("{what}[{k}] ({name})");
    let nodes = (spec.nodes.iter().enumerate())
        .map(|(k, n)| (named("nodes", k, &n.name), n))
        .chain(lattices.iter().flat_map(|(path, nodes, _)| {
            (nodes.iter().enumerate())
                .map(move |(k, n)| (named(&format!("{path}.nodes"), k, &n.name), n))
        }));
    for (path, n) in nodes {
        crate::poll()?;
        let frame = frame(&path, &n.position, n.orientation.as_ref())?;
        let node = model.add_node(&n.name, frame)?;
        let omega = frame.rotation().transpose() * vector(&path, n.angular_velocity)?;
        model.set_node_rates(node, vector(&path, n.velocity)?, omega)?;
    }
    let all_beams: Vec<(String, &SpatialBeamSpec)> = (spec.beams.iter().enumerate())
        .map(|(k, b)| (named("beams", k, &b.name), b))
        .chain(lattices.iter().flat_map(|(path, _, beams)| {
            (beams.iter().enumerate())
                .map(move |(k, b)| (named(&format!("{path}.bars"), k, &b.name), b))
        }))
        .collect();
    unique("beams", all_beams.iter().map(|(_, b)| b.name.as_str()))?;
    check_splits(&spec.splits, &all_beams)?;
    let (interpolation, x_min) = design::law(&spec.design)?;
    let mass = design::mass_law(&spec.design, spec.analysis)?;
    let mut variables = Variables::default();
    let mut beams = BTreeMap::new();
    for (path, b) in all_beams {
        crate::poll()?;
        if model.bodies.iter().any(|body| body.name == b.name) {
            return Err(SceneError::new(
                path,
                "a body has this name: parameters `mass:NAME` would name both",
            )
            .into());
        }
        let resplit;
        let b = match spec.splits.get(&b.name) {
            Some(&split) => {
                resplit = SpatialBeamSpec { split, ..b.clone() };
                &resplit
            }
            None => b,
        };
        let mut elements = beam(&mut model, &path, b, &sections)?;
        elements.variable = variables.of(&path, &b.name, b.group.as_deref(), b.fixed)?;
        beams.insert(b.name.clone(), elements);
    }
    for (k, p) in spec.point_masses.iter().enumerate() {
        let path = format!("point_masses[{k}] ({})", p.name);
        if beams.contains_key(&p.name) {
            return Err(SceneError::new(path, "a beam has this name").into());
        }
        let node = node(&model, &format!("{path}.node"), &p.node)?;
        model.add_point_mass(&p.name, node, p.mass)?;
    }
    let points: Points = (spec.rigid_bodies.iter())
        .map(|b| (b.name.as_str(), &b.points))
        .collect();
    for (k, j) in spec.joints.iter().enumerate() {
        crate::poll()?;
        joint(&mut model, &points, &format!("joints[{k}] ({})", j.name), j)?;
    }
    forces(&mut model, &points, spec)?;
    model.check_nodes()?;
    model.check_rates()?;
    if let Some(tip) = &spec.tip {
        if !model.nodes.iter().any(|n| &n.name == tip) {
            return Err(
                SceneError::new("tip", format!("'{tip}' is no body or node of the scene")).into(),
            );
        }
    }
    Ok(SpatialScene {
        name: spec.name.clone(),
        analysis: match spec.analysis {
            AnalysisSpec::Dynamic => Analysis::Dynamic,
            AnalysisSpec::Static => Analysis::Static,
        },
        model,
        options: spec.simulation,
        tip: spec.tip.clone(),
        beams,
        design: Design {
            interpolation,
            mass,
            x_min,
            variables: variables.names,
        },
    })
}

/// A frame at `position` with the axes of `orientation` (identity if none).
fn frame(path: &str, position: &[f64; 3], orientation: Option<&OrientationSpec>) -> Result<Frame> {
    let x = vector(&format!("{path}.position"), *position)?;
    let r = orientation.map_or(Ok(UnitQuaternion::identity()), |o| {
        rotation(&format!("{path}.orientation"), o)
    })?;
    Ok(Frame::new(x, r))
}

/// The sections by name.
fn sections(
    specs: &BTreeMap<String, SpatialSectionSpec>,
) -> Result<BTreeMap<String, (Section, [f64; 2])>> {
    specs
        .iter()
        .map(|(name, s)| {
            let section = section(&format!("sections.{name}"), s)?;
            Ok((name.clone(), (section, [s.E, s.rho])))
        })
        .collect()
}

/// A section from its material and shape, the keys of other shapes refused.
fn section(path: &str, s: &SpatialSectionSpec) -> Result<Section> {
    let e = positive(&format!("{path}.E"), s.E)?;
    let rho = positive(&format!("{path}.rho"), s.rho)?;
    if !(s.nu.is_finite() && s.nu > -1.0 && s.nu < 0.5) {
        return Err(SceneError::new(
            format!("{path}.nu"),
            format!("{}: Poisson's ratio lies in (−1, 0.5)", short(s.nu)),
        ));
    }
    let dims = [
        ("diameter", s.diameter),
        ("outer", s.outer),
        ("inner", s.inner),
        ("width", s.width),
        ("height", s.height),
    ];
    let (shape, keys): (_, &[&str]) = match s.shape {
        ShapeSpec::Circle => (Shape::SolidCircle { d: 0.0 }, &["diameter"]),
        ShapeSpec::Tube => (
            Shape::HollowCircle {
                outer: 0.0,
                inner: 0.0,
            },
            &["outer", "inner"],
        ),
        ShapeSpec::Rectangle => (Shape::Rectangle { b: 0.0, h: 0.0 }, &["width", "height"]),
    };
    let mut given = [0.0; 2];
    for (name, value) in dims {
        match (keys.iter().position(|k| *k == name), value) {
            (Some(i), Some(v)) => given[i] = positive(&format!("{path}.{name}"), v)?,
            (Some(_), None) => {
                return Err(SceneError::new(
                    path,
                    format!("a {:?} section needs `{}`", s.shape, keys.join("` and `"))
                        .to_lowercase(),
                ))
            }
            (None, Some(_)) => {
                return Err(SceneError::new(
                    format!("{path}.{name}"),
                    format!("is not a dimension of a {:?} section", s.shape).to_lowercase(),
                ))
            }
            (None, None) => {}
        }
    }
    let shape = match shape {
        Shape::SolidCircle { .. } => Shape::SolidCircle { d: given[0] },
        Shape::HollowCircle { .. } => Shape::HollowCircle {
            outer: given[0],
            inner: given[1],
        },
        Shape::Rectangle { .. } => Shape::Rectangle {
            b: given[0],
            h: given[1],
        },
    };
    let geometry = shape.geometry(s.nu).ok_or_else(|| {
        SceneError::new(
            path,
            "the tube's inner diameter must be less than its outer",
        )
    })?;
    let [alpha, beta] = s.rayleigh.unwrap_or_default();
    let (alpha, beta) = (
        non_negative(&format!("{path}.rayleigh[0]"), alpha)?,
        non_negative(&format!("{path}.rayleigh[1]"), beta)?,
    );
    Ok(Section::new(&geometry, e, e / (2.0 * (1.0 + s.nu)), rho)
        .with_rayleigh(alpha, beta)
        .with_shape(shape))
}

/// A rigid body with its rates (its angular velocity given in the inertial frame).
fn body(model: &mut SpatialModel, path: &str, b: &SpatialBodySpec) -> Result<()> {
    let frame = frame(path, &b.position, b.orientation.as_ref())?;
    let [i11, i22, i33] = b.inertia;
    let [i12, i13, i23] = b.products;
    let inertia = Matrix3::new(i11, i12, i13, i12, i22, i23, i13, i23, i33);
    let k = model.add_body(&b.name, frame, b.mass, inertia)?;
    for (name, p) in &b.points {
        vector(&format!("{path}.points.{name}"), *p)?;
    }
    let omega = frame.rotation().transpose()
        * vector(&format!("{path}.angular_velocity"), b.angular_velocity)?;
    model.set_rates(k, vector(&format!("{path}.velocity"), b.velocity)?, omega)
}

/// A node's index by name.
fn node(model: &SpatialModel, path: &str, name: &str) -> Result<usize> {
    model
        .node_named(name)
        .ok_or_else(|| SceneError::new(path, format!("no node or body called '{name}'")))
}

/// Every entry of the scene's `splits` names a frame beam, with between 1 and
/// [`MAX_SPLIT`] elements.
fn check_splits(
    splits: &BTreeMap<String, usize>,
    beams: &[(String, &SpatialBeamSpec)],
) -> Result<()> {
    let named: std::collections::HashMap<&str, &SpatialBeamSpec> =
        beams.iter().map(|(_, b)| (b.name.as_str(), *b)).collect();
    for (name, &split) in splits {
        let path = format!("splits.{name}");
        match named.get(name.as_str()) {
            None => {
                let what = "no beam is called so (a ground structure's bars are NAME/barK)";
                return Err(SceneError::new(path, what));
            }
            Some(b) if b.kind == KindSpec::Truss => {
                return Err(SceneError::new(path, "a truss bar is one element"));
            }
            Some(_) if split == 0 || split > MAX_SPLIT => {
                let what = format!("{split}: between 1 and {MAX_SPLIT} elements");
                return Err(SceneError::new(path, what));
            }
            Some(_) => {}
        }
    }
    Ok(())
}

/// A beam in `split` elements (a truss bar in one), its inner nodes on the chord with the
/// first end's axes and rates interpolated between the ends'.
fn beam(
    model: &mut SpatialModel,
    path: &str,
    b: &SpatialBeamSpec,
    sections: &BTreeMap<String, (Section, [f64; 2])>,
) -> Result<BeamElements> {
    let (section, material) = sections.get(&b.section).ok_or_else(|| {
        SceneError::new(
            format!("{path}.section"),
            format!("no section called '{}'", b.section),
        )
    })?;
    let ends = [
        node(model, &format!("{path}.nodes[0]"), &b.nodes[0])?,
        node(model, &format!("{path}.nodes[1]"), &b.nodes[1])?,
    ];
    if b.split == 0 || b.split > MAX_SPLIT || model.nodes.len() + b.split > MAX_NODES {
        return Err(SceneError::new(
            format!("{path}.split"),
            format!(
                "{}: between 1 and {MAX_SPLIT} elements (at most {MAX_NODES} nodes in all)",
                b.split
            ),
        ));
    }
    if b.kind == KindSpec::Truss {
        if b.split != 1 || b.up.is_some() {
            return Err(SceneError::new(
                path,
                "a truss bar is one element with no section axes: no `split` or `up`",
            ));
        }
        let k = model.add_truss(&b.name, ends[0], ends[1], section)?;
        return Ok(BeamElements {
            truss: true,
            elements: vec![k],
            material: *material,
            section: *section,
            variable: None,
        });
    }
    let [a, z] = [&model.nodes[ends[0]], &model.nodes[ends[1]]];
    let (xa, xz) = (a.frame.x, z.frame.x);
    let up = match b.up {
        Some(up) => vector(&format!("{path}.up"), up)?,
        None if (xz - xa).cross(&Vector3::z()).norm() > 1e-6 * (xz - xa).norm() => Vector3::z(),
        None => Vector3::y(),
    };
    let (va, vz) = (a.velocity, z.velocity);
    let (ra, rz) = (a.frame.r, z.frame.r);
    let spin = |r: UnitQuaternion<f64>, v: [f64; 6]| r * Vector3::new(v[3], v[4], v[5]);
    let (wa, wz) = (spin(ra, va), spin(rz, vz));
    let mut nodes = vec![ends[0]];
    for k in 1..b.split {
        let s = k as f64 / b.split as f64;
        let n = model.add_node(
            &format!("{}[{k}]", b.name),
            Frame::new(xa + (xz - xa) * s, ra),
        )?;
        let v = Vector3::from_fn(|i, _| va[i] + (vz[i] - va[i]) * s);
        model.set_node_rates(n, v, ra.inverse() * (wa + (wz - wa) * s))?;
        nodes.push(n);
    }
    nodes.push(ends[1]);
    let elements = nodes
        .windows(2)
        .enumerate()
        .map(|(k, pair)| {
            let name = if b.split == 1 {
                b.name.clone()
            } else {
                format!("{}/{}", b.name, k + 1)
            };
            model.add_beam(&name, pair[0], pair[1], section, up)
        })
        .collect::<Result<Vec<_>>>()?;
    for &e in &elements {
        model.beams[e].set_bar_length((xz - xa).norm());
    }
    Ok(BeamElements {
        truss: false,
        elements,
        material: *material,
        section: *section,
        variable: None,
    })
}

/// Bodies' named points, by body.
type Points<'s> = BTreeMap<&'s str, &'s BTreeMap<String, [f64; 3]>>;

/// An anchor by name: a body's centre of mass or point (`BODY.POINT`), a node's origin, or
/// the ground at `ground` (where the other anchor is) or at a given point.
fn anchor(
    model: &SpatialModel,
    points: &Points,
    path: &str,
    a: &AnchorSpec,
    ground: Option<Vector3<f64>>,
) -> Result<Anchor> {
    let name = match a {
        AnchorSpec::Ground(p) => return Ok(Anchor::Ground(vector(path, *p)?)),
        AnchorSpec::Named(name) => name,
    };
    if name == "ground" {
        return ground
            .map(Anchor::Ground)
            .ok_or_else(|| SceneError::new(path, "the ground needs a point here: give [x, y, z]"));
    }
    let body = |n: &str| model.bodies.iter().position(|b| b.name == n);
    if let Some(body) = body(name) {
        return Ok(Anchor::Body {
            body,
            point: Vector3::zeros(),
        });
    }
    if let Some(node) = model.node_named(name) {
        return Ok(Anchor::Node {
            node,
            point: Vector3::zeros(),
        });
    }
    let missing = || {
        SceneError::new(
            path,
            format!("'{name}' is no body, body's point or node of the scene"),
        )
    };
    let (owner, point) = name.rsplit_once('.').ok_or_else(missing)?;
    let body = body(owner).ok_or_else(missing)?;
    let point = (points.get(owner).and_then(|p| p.get(point)))
        .ok_or_else(|| SceneError::new(path, format!("body '{owner}' has no point '{point}'")))?;
    Ok(Anchor::Body {
        body,
        point: Vector3::from(*point),
    })
}

/// Where an anchor is in the initial configuration.
fn location(model: &SpatialModel, a: &Anchor) -> Vector3<f64> {
    let at = |node: usize, point: &Vector3<f64>| {
        let f = &model.nodes[node].frame;
        f.x + f.r * point
    };
    match a {
        Anchor::Ground(p) => *p,
        Anchor::Body { body, point } => at(model.bodies[*body].node, point),
        Anchor::Node { node, point } => at(*node, point),
    }
}

/// Anchors `a` and `b` of an entry: `"ground"` on one side stands where the other is.
fn anchors(
    model: &SpatialModel,
    points: &Points,
    path: &str,
    [a, b]: [&AnchorSpec; 2],
) -> Result<[Anchor; 2]> {
    let is_ground = |s: &AnchorSpec| matches!(s, AnchorSpec::Named(n) if n == "ground");
    let (pa, pb) = (format!("{path}.a"), format!("{path}.b"));
    if is_ground(a) && is_ground(b) {
        return Err(SceneError::new(path, "both anchors are the ground"));
    }
    if is_ground(a) {
        let b = anchor(model, points, &pb, b, None)?;
        let at = location(model, &b);
        Ok([anchor(model, points, &pa, a, Some(at))?, b])
    } else {
        let a = anchor(model, points, &pa, a, None)?;
        let at = location(model, &a);
        Ok([a, anchor(model, points, &pb, b, Some(at))?])
    }
}

/// A joint's kind with its axes; the axes of other kinds refused.
fn kind(path: &str, j: &SpatialJointSpec) -> Result<JointKind> {
    let axis = || {
        let a = j.axis.ok_or_else(|| {
            SceneError::new(
                path,
                format!("a {:?} joint needs an `axis`", j.kind).to_lowercase(),
            )
        })?;
        vector(&format!("{path}.axis"), a)
    };
    let refuse = |key: &str, given: bool| {
        if given {
            Err(SceneError::new(
                format!("{path}.{key}"),
                format!("a {:?} joint has no `{key}`", j.kind).to_lowercase(),
            ))
        } else {
            Ok(())
        }
    };
    let hinged = matches!(
        j.kind,
        JointKindSpec::Revolute | JointKindSpec::Cylindrical | JointKindSpec::Prismatic
    );
    refuse("axis", !hinged && j.axis.is_some())?;
    refuse(
        "axes",
        j.kind != JointKindSpec::Universal && j.axes.is_some(),
    )?;
    Ok(match j.kind {
        JointKindSpec::Spherical => JointKind::Spherical,
        JointKindSpec::Weld => JointKind::Weld,
        JointKindSpec::Revolute => JointKind::Revolute { axis: axis()? },
        JointKindSpec::Cylindrical => JointKind::Cylindrical { axis: axis()? },
        JointKindSpec::Prismatic => JointKind::Prismatic { axis: axis()? },
        JointKindSpec::Universal => {
            let [a, b] = j.axes.ok_or_else(|| {
                SceneError::new(
                    path,
                    "a universal joint needs its two `axes`, on a and on b",
                )
            })?;
            JointKind::Universal {
                axis_a: vector(&format!("{path}.axes[0]"), a)?,
                axis_b: vector(&format!("{path}.axes[1]"), b)?,
            }
        }
    })
}

/// A joint and its drive.
fn joint(
    model: &mut SpatialModel,
    points: &Points,
    path: &str,
    j: &SpatialJointSpec,
) -> Result<()> {
    let kind = kind(path, j)?;
    let [a, b] = anchors(model, points, path, [&j.a, &j.b])?;
    let k = model.add_joint(&j.name, kind, a, b)?;
    if let Some(law) = &j.drive {
        if law.in_degrees() && j.kind == JointKindSpec::Prismatic {
            return Err(SceneError::new(
                format!("{path}.drive"),
                "a prismatic joint's travel is in metres, not degrees",
            ));
        }
        model.add_drive(k, drive(&format!("{path}.drive"), law)?)?;
    }
    Ok(())
}

/// Springs, motors and loads.
/// The joint called `name`, for the entry at `path`.
fn joint_named(model: &SpatialModel, path: &str, name: &str) -> Result<usize> {
    (model.joints.iter().position(|j| j.name == name)).ok_or_else(|| {
        SceneError::new(format!("{path}.joint"), format!("no joint called '{name}'"))
    })
}

fn forces(model: &mut SpatialModel, points: &Points, spec: &SpatialSceneSpec) -> Result<()> {
    for (k, s) in spec.springs.iter().enumerate() {
        let path = format!("springs[{k}] ({})", s.name);
        match (&s.joint, &s.a, &s.b, s.length, s.rest) {
            (Some(j), None, None, None, rest) => {
                let joint = joint_named(model, &path, j)?;
                model.add_torsion(&s.name, joint, s.k, s.c, rest)?;
            }
            (None, Some(a), b, length, None) => {
                let ground = AnchorSpec::default();
                let [a, b] = anchors(model, points, &path, [a, b.as_ref().unwrap_or(&ground)])?;
                model.add_spring(&s.name, a, b, s.k, s.c, length)?;
            }
            _ => {
                return Err(SceneError::new(
                    path,
                    "a spring joins `a` and `b` (a `length` at rest) or turns with a `joint` \
                     (a `rest` angle), not both",
                ))
            }
        }
    }
    for (k, m) in spec.motors.iter().enumerate() {
        let path = format!("motors[{k}] ({})", m.name);
        let joint = joint_named(model, &path, &m.joint)?;
        let table = time(&path, m.table.as_ref())?;
        model.add_motor(&m.name, joint, m.torque, table)?;
    }
    for (k, l) in spec.loads.iter().enumerate() {
        let path = format!("loads[{k}] ({})", l.name);
        let at = anchor(model, points, &format!("{path}.at"), &l.at, None)?;
        let (force, moment) = (
            vector(&format!("{path}.force"), l.force)?,
            vector(&format!("{path}.moment"), l.moment)?,
        );
        let table = time(&path, l.table.as_ref())?;
        model.add_load(&l.name, at, force, moment, table, l.follower)?;
    }
    Ok(())
}
