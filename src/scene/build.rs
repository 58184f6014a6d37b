//! Building a [`Model`] from a [`SceneSpec`], validating every entry on the way.
//!
//! Each error names the entry at fault (`sections.al.E`, `joints[1] (elbow)`, …): non-finite
//! or non-physical values, missing or duplicate nodes, zero-length bars, hinges between
//! distant nodes, and at the end the mechanism itself — redundant joints (over-constrained),
//! frames not connected to the ground (unconstrained), and for a static scene any rigid-body
//! mode left free.

use std::collections::{BTreeMap, HashMap};

use nalgebra::Vector2;

use super::ground_structure;
use super::spec::*;
use crate::constraint::{Joint, JointKind};
use crate::element::Beam;
use crate::error::SceneError;
use crate::interpolation::Interpolation;
use crate::load::{NodalLoad, TimeFunction};
use crate::model::{size_of, Analysis, Bar, Design, Element, Model, Node, PointMass};
use crate::motion::{Motion, Table, Trapezoidal};
use crate::rigid::{redundant_rows, Clusters};
use crate::section::Section;
use crate::settings::RunOptions;

type Result<T> = std::result::Result<T, SceneError>;

fn finite(path: &str, v: f64) -> Result<f64> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(SceneError::new(path, format!("must be finite, got {v}")))
    }
}

fn positive(path: &str, v: f64) -> Result<f64> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(SceneError::new(
            path,
            format!("must be positive and finite, got {v}"),
        ))
    }
}

fn non_negative(path: &str, v: f64) -> Result<f64> {
    if v.is_finite() && v >= 0.0 {
        Ok(v)
    } else {
        Err(SceneError::new(
            path,
            format!("must be non-negative and finite, got {v}"),
        ))
    }
}

/// Strictly increasing finite samples, at least two.
fn samples(path: &str, t: &[f64], values: &[f64], what: &str) -> Result<()> {
    if t.len() < 2 || t.len() != values.len() {
        return Err(SceneError::new(
            path,
            format!(
                "needs at least two samples and as many {what} as times ({} vs {})",
                values.len(),
                t.len()
            ),
        ));
    }
    for (k, (&ti, &vi)) in t.iter().zip(values).enumerate() {
        finite(&format!("{path}.t[{k}]"), ti)?;
        finite(&format!("{path}.{what}[{k}]"), vi)?;
    }
    if let Some(k) = t.windows(2).position(|w| w[1] <= w[0]) {
        return Err(SceneError::new(
            format!("{path}.t[{}]", k + 1),
            "times must be strictly increasing",
        ));
    }
    Ok(())
}

fn section(path: &str, s: &SectionSpec) -> Result<Section> {
    let e = positive(&format!("{path}.E"), s.E)?;
    let rho = positive(&format!("{path}.rho"), s.rho)?;
    let (g, nu) = match (s.G, s.nu) {
        (Some(g), None) => {
            let g = positive(&format!("{path}.G"), g)?;
            (g, e / (2.0 * g) - 1.0)
        }
        (None, Some(nu)) => (e / (2.0 * (1.0 + nu)), nu),
        _ => return Err(SceneError::new(path, "give exactly one of G and nu")),
    };
    if !(nu > -1.0 && nu <= 0.5) {
        return Err(SceneError::new(
            path,
            format!("Poisson's ratio must lie in (-1, 0.5], got {nu}"),
        ));
    }
    let (area, inertia, kappa) = match (s.diameter, s.A, s.I, s.kappa) {
        (Some(d), None, None, None) => {
            Section::solid_circle(positive(&format!("{path}.diameter"), d)?, nu)
        }
        (None, Some(a), Some(i), Some(k)) => (
            positive(&format!("{path}.A"), a)?,
            positive(&format!("{path}.I"), i)?,
            positive(&format!("{path}.kappa"), k)?,
        ),
        _ => {
            return Err(SceneError::new(
                path,
                "give either `diameter` (solid circle) or all of `A`, `I`, `kappa`",
            ))
        }
    };
    Ok(Section::new(e, g, area, inertia, kappa, rho))
}

fn motion(path: &str, m: &MotionSpec) -> Result<Motion> {
    Ok(match m {
        MotionSpec::Trapezoidal {
            start,
            end,
            acceleration,
            speed,
            t_start,
        } => Motion::Trapezoidal(Trapezoidal::new(
            finite(&format!("{path}.start"), *start)?,
            finite(&format!("{path}.end"), *end)?,
            positive(&format!("{path}.acceleration"), *acceleration)?,
            positive(&format!("{path}.speed"), *speed)?,
            non_negative(&format!("{path}.t_start"), *t_start)?,
        )),
        MotionSpec::Table {
            t,
            theta,
            start_velocity,
            end_velocity,
        } => {
            samples(path, t, theta, "theta")?;
            let v0 = finite(&format!("{path}.start_velocity"), *start_velocity)?;
            let v1 = finite(&format!("{path}.end_velocity"), *end_velocity)?;
            Motion::Table(Table::new(t.clone(), theta.clone(), [v0, v1]))
        }
    })
}

/// Mesh under construction.
#[derive(Default)]
struct Mesh {
    nodes: Vec<Node>,
    index: HashMap<String, usize>,
    elements: Vec<Element>,
    bars: Vec<Bar>,
    /// Scene path of each bar, for messages.
    bar_paths: Vec<String>,
    components: Vec<String>,
    variables: Vec<String>,
    groups: HashMap<String, usize>,
}

/// What a new bar is made of and where it belongs.
struct BarSpec<'a> {
    path: String,
    name: String,
    ends: [usize; 2],
    section: &'a Section,
    split: usize,
    component: usize,
    variable: Option<usize>,
}

impl Mesh {
    fn add_node(&mut self, path: &str, name: &str, x: f64, y: f64) -> Result<usize> {
        finite(&format!("{path}.x"), x)?;
        finite(&format!("{path}.y"), y)?;
        if self.index.contains_key(name) {
            return Err(SceneError::new(
                path,
                format!("duplicate node name '{name}'"),
            ));
        }
        self.index.insert(name.to_string(), self.nodes.len());
        self.nodes.push(Node {
            name: name.to_string(),
            position: Vector2::new(x, y),
        });
        Ok(self.nodes.len() - 1)
    }

    fn node(&self, path: &str, name: &str) -> Result<usize> {
        self.index
            .get(name)
            .copied()
            .ok_or_else(|| SceneError::new(path, format!("unknown node '{name}'")))
    }

    fn component(&mut self, name: &str) -> usize {
        self.components
            .iter()
            .position(|c| c == name)
            .unwrap_or_else(|| {
                self.components.push(name.to_string());
                self.components.len() - 1
            })
    }

    fn variable(&mut self, name: &str) -> usize {
        self.variables.push(name.to_string());
        self.variables.len() - 1
    }

    /// A straight bar split into `split` elements, interior nodes named `NAME:k` (its length
    /// is checked by [`Mesh::check_lengths`] once the whole mesh is known).
    fn add_bar(&mut self, b: BarSpec) -> Result<()> {
        let [a, z] = b.ends;
        let (xa, xz) = (self.nodes[a].position, self.nodes[z].position);
        let length = (xz - xa).norm();
        if b.split == 0 {
            return Err(SceneError::new(
                format!("{}.split", b.path),
                "must be at least 1",
            ));
        }
        let mut chain = vec![a];
        for k in 1..b.split {
            let p = xa + (xz - xa) * (k as f64 / b.split as f64);
            chain.push(self.add_node(&b.path, &format!("{}:{k}", b.name), p.x, p.y)?);
        }
        chain.push(z);
        let first = self.elements.len();
        let bar = self.bars.len();
        for w in chain.windows(2) {
            let beam = Beam::new(
                self.nodes[w[0]].position,
                self.nodes[w[1]].position,
                *b.section,
            );
            self.elements.push(Element {
                beam,
                nodes: [w[0], w[1]],
                bar,
            });
        }
        let volume = b.section.area * length;
        self.bars.push(Bar {
            name: b.name,
            component: b.component,
            variable: b.variable,
            elements: first..self.elements.len(),
            volume,
        });
        self.bar_paths.push(b.path);
        Ok(())
    }

    /// Every bar has a finite length above 1e-9 of the model's size and above the round-off
    /// of its end coordinates (1e-12 of their magnitude).
    fn check_lengths(&self, size: f64) -> Result<()> {
        if !size.is_finite() {
            return Err(SceneError::new(
                "nodes",
                format!("the scene spans {size} m: coordinates too large to compute with"),
            ));
        }
        for (bar, path) in self.bars.iter().zip(&self.bar_paths) {
            let (a, z) = (
                self.elements[bar.elements.start].nodes[0],
                self.elements[bar.elements.end - 1].nodes[1],
            );
            let (xa, xz) = (self.nodes[a].position, self.nodes[z].position);
            let length = (xz - xa).norm();
            let too_short = length.partial_cmp(&(1e-9 * size).max(1e-12 * (xa.norm() + xz.norm())))
                != Some(std::cmp::Ordering::Greater);
            if too_short {
                let (na, nz) = (&self.nodes[a].name, &self.nodes[z].name);
                return Err(SceneError::new(path, format!("zero-length bar: nodes '{na}' and '{nz}' coincide ({length:.1e} m apart in a scene of {size:.3} m)")));
            }
        }
        Ok(())
    }

    fn ground_structure(
        &mut self,
        path: &str,
        g: &GroundStructureSpec,
        sections: &BTreeMap<String, Section>,
    ) -> Result<()> {
        if g.nx < 2 || g.ny < 1 {
            return Err(SceneError::new(
                path,
                format!("needs nx >= 2 and ny >= 1, got {} × {}", g.nx, g.ny),
            ));
        }
        let length = positive(&format!("{path}.length"), g.length)?;
        let height = if g.ny > 1 {
            positive(&format!("{path}.height"), g.height)?
        } else {
            non_negative(&format!("{path}.height"), g.height)?
        };
        let angle = finite(&format!("{path}.angle"), g.angle)?;
        let origin = match &g.origin {
            PointSpec::Coordinates([x, y]) => Vector2::new(
                finite(&format!("{path}.origin[0]"), *x)?,
                finite(&format!("{path}.origin[1]"), *y)?,
            ),
            PointSpec::Node(n) => self.nodes[self.node(&format!("{path}.origin"), n)?].position,
        };
        let section = sections.get(&g.section).ok_or_else(|| {
            SceneError::new(
                format!("{path}.section"),
                format!("unknown section '{}'", g.section),
            )
        })?;
        let (c, s) = (angle.cos(), angle.sin());
        let first = self.nodes.len();
        for k in 0..g.nx * g.ny {
            let (i, j) = ground_structure::grid_position(k, g.ny);
            let [lx, ly] = ground_structure::local_coordinates(i, j, g.nx, g.ny, length, height);
            let p = origin + Vector2::new(c * lx - s * ly, s * lx + c * ly);
            self.add_node(path, &format!("{}[{i},{j}]", g.name), p.x, p.y)?;
        }
        let component = self.component(&g.name);
        for (k, (i, j)) in ground_structure::bars(g.nx, g.ny).into_iter().enumerate() {
            let name = format!("{}/bar{k}", g.name);
            let variable = (!g.fixed).then(|| self.variable(&name));
            let ends = [first + i, first + j];
            self.add_bar(BarSpec {
                path: format!("{path}/bar{k}"),
                name,
                ends,
                section,
                split: g.split,
                component,
                variable,
            })?;
        }
        Ok(())
    }

    fn beam(
        &mut self,
        path: &str,
        k: usize,
        b: &BeamSpec,
        sections: &BTreeMap<String, Section>,
    ) -> Result<()> {
        let name = b.name.clone().unwrap_or_else(|| format!("beams[{k}]"));
        let ends = [
            self.node(&format!("{path}.nodes[0]"), &b.nodes[0])?,
            self.node(&format!("{path}.nodes[1]"), &b.nodes[1])?,
        ];
        let section = sections.get(&b.section).ok_or_else(|| {
            SceneError::new(
                format!("{path}.section"),
                format!("unknown section '{}'", b.section),
            )
        })?;
        let component = self.component(b.component.as_deref().unwrap_or("frame"));
        let variable = match (&b.group, b.fixed) {
            (Some(_), true) => {
                return Err(SceneError::new(
                    path,
                    "a fixed beam cannot belong to a design group",
                ))
            }
            (_, true) => None,
            (Some(g), false) => Some(match self.groups.get(g) {
                Some(&v) => v,
                None => {
                    let v = self.variable(g);
                    self.groups.insert(g.clone(), v);
                    v
                }
            }),
            (None, false) => Some(self.variable(&name)),
        };
        self.add_bar(BarSpec {
            path: path.to_string(),
            name,
            ends,
            section,
            split: b.split,
            component,
            variable,
        })
    }
}

fn joint(path: &str, j: &JointSpec, mesh: &Mesh, size: f64) -> Result<Joint> {
    let (name, kind, drive) = match j {
        JointSpec::Clamp { name, node } => (
            name,
            JointKind::Clamp {
                node: mesh.node(&format!("{path}.node"), node)?,
            },
            None,
        ),
        JointSpec::Pin { name, node, drive } => (
            name,
            JointKind::Pin {
                node: mesh.node(&format!("{path}.node"), node)?,
            },
            drive.as_ref(),
        ),
        JointSpec::Hinge { name, nodes, drive } => {
            let a = mesh.node(&format!("{path}.nodes[0]"), &nodes[0])?;
            let b = mesh.node(&format!("{path}.nodes[1]"), &nodes[1])?;
            let gap = (mesh.nodes[a].position - mesh.nodes[b].position).norm();
            if a == b {
                return Err(SceneError::new(
                    format!("{path} ({name})"),
                    "a hinge needs two distinct nodes",
                ));
            }
            if gap > 1e-9 * size {
                return Err(SceneError::new(
                    format!("{path} ({name})"),
                    format!(
                        "hinge nodes '{}' and '{}' are {gap:.3e} m apart; they must coincide",
                        nodes[0], nodes[1]
                    ),
                ));
            }
            (name, JointKind::Hinge { nodes: [a, b] }, drive.as_ref())
        }
    };
    let drive = drive
        .map(|d| motion(&format!("{path}.drive"), d))
        .transpose()?;
    if let Some(rate) = drive
        .as_ref()
        .map(|m| m.at(0.0).velocity)
        .filter(|v| v.abs() > 0.0)
    {
        return Err(SceneError::new(format!("{path}.drive"), format!("moves at t = 0 (θ̇ = {rate} rad/s), but scenes start at rest: start the motion from rest")));
    }
    Ok(Joint {
        name: name.clone(),
        kind,
        drive,
    })
}

fn design(d: &DesignSpec) -> Result<(Interpolation, f64)> {
    let x_min = d.x_min;
    if !(x_min > 0.0 && x_min < 1.0) {
        return Err(SceneError::new(
            "design.x_min",
            format!("must lie in (0, 1), got {x_min}"),
        ));
    }
    let law = match (d.interpolation, d.p, d.q) {
        (InterpolationSpec::Simp, p, None) => {
            let p = p.unwrap_or(3.0);
            if !(p.is_finite() && p >= 1.0) {
                return Err(SceneError::new(
                    "design.p",
                    format!("SIMP exponent must be finite and >= 1, got {p}"),
                ));
            }
            Interpolation::Simp { p }
        }
        (InterpolationSpec::Ramp, None, q) => Interpolation::Ramp {
            q: non_negative("design.q", q.unwrap_or(8.0))?,
        },
        (InterpolationSpec::Simp, _, Some(_)) => {
            return Err(SceneError::new(
                "design.q",
                "`q` is the RAMP parameter; SIMP takes `p`",
            ))
        }
        (InterpolationSpec::Ramp, Some(_), _) => {
            return Err(SceneError::new(
                "design.p",
                "`p` is the SIMP exponent; RAMP takes `q`",
            ))
        }
    };
    Ok((law, x_min))
}

/// The scene's default run settings, checked like the scene's other values.
fn defaults(s: &RunOptions) -> Result<RunOptions> {
    for (name, value) in [("t_end", s.t_end), ("h", s.h), ("tol", s.tol)] {
        if let Some(v) = value {
            positive(&format!("simulation.{name}"), v)?;
        }
    }
    if let Some(r) = s.rho_inf {
        if !(0.0..=1.0).contains(&r) {
            return Err(SceneError::new(
                "simulation.rho_inf",
                format!("must lie in [0, 1], got {r}"),
            ));
        }
    }
    for (name, value) in [("load_steps", s.load_steps), ("max_iter", s.max_iter)] {
        if value == Some(0) {
            return Err(SceneError::new(
                format!("simulation.{name}"),
                "must be at least 1",
            ));
        }
    }
    Ok(*s)
}

/// Builds and validates the model of `spec`.
///
/// # Errors
/// A [`SceneError`] naming the first entry at fault.
pub fn build(spec: &SceneSpec) -> Result<Model> {
    let sections = spec
        .sections
        .iter()
        .map(|(k, s)| Ok((k.clone(), section(&format!("sections.{k}"), s)?)))
        .collect::<Result<BTreeMap<_, _>>>()?;
    let mut mesh = Mesh::default();
    for (k, n) in spec.nodes.iter().enumerate() {
        mesh.add_node(&format!("nodes[{k}] ({})", n.name), &n.name, n.x, n.y)?;
    }
    for (k, g) in spec.ground_structures.iter().enumerate() {
        mesh.ground_structure(
            &format!("ground_structures[{k}] ({})", g.name),
            g,
            &sections,
        )?;
    }
    for (k, b) in spec.beams.iter().enumerate() {
        mesh.beam(&format!("beams[{k}]"), k, b, &sections)?;
    }
    if mesh.elements.is_empty() {
        return Err(SceneError::new("scene", "has no beams"));
    }
    let size = size_of(&mesh.nodes);
    mesh.check_lengths(size)?;
    let joints = spec
        .joints
        .iter()
        .enumerate()
        .map(|(k, j)| joint(&format!("joints[{k}]"), j, &mesh, size))
        .collect::<Result<Vec<_>>>()?;
    let rows = joints
        .iter()
        .enumerate()
        .flat_map(|(k, j)| j.rows(k))
        .collect::<Vec<_>>();
    let point_masses = spec
        .point_masses
        .iter()
        .enumerate()
        .map(|(k, p)| {
            let path = format!("point_masses[{k}]");
            Ok(PointMass {
                node: mesh.node(&format!("{path}.node"), &p.node)?,
                mass: positive(&format!("{path}.mass"), p.mass)?,
                inertia: non_negative(&format!("{path}.inertia"), p.inertia)?,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    let loads = spec
        .loads
        .iter()
        .enumerate()
        .map(|(k, l)| {
            let path = format!("loads[{k}]");
            let value = [
                finite(&format!("{path}.force[0]"), l.force[0])?,
                finite(&format!("{path}.force[1]"), l.force[1])?,
                finite(&format!("{path}.moment"), l.moment)?,
            ];
            let time = match &l.table {
                None => TimeFunction::Constant,
                Some(t) => {
                    samples(&format!("{path}.table"), &t.t, &t.scale, "scale")?;
                    TimeFunction::Table {
                        t: t.t.clone(),
                        value: t.scale.clone(),
                    }
                }
            };
            Ok(NodalLoad {
                node: mesh.node(&format!("{path}.node"), &l.node)?,
                value,
                time,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    let gravity = match spec.gravity {
        Some([gx, gy]) => Vector2::new(finite("gravity[0]", gx)?, finite("gravity[1]", gy)?),
        None => Vector2::zeros(),
    };
    let (interpolation, x_min) = design(&spec.design)?;
    let tip = spec.tip.as_ref().map(|t| mesh.node("tip", t)).transpose()?;
    let model = Model {
        name: spec.name.clone(),
        analysis: match spec.analysis {
            AnalysisSpec::Dynamic => Analysis::Dynamic,
            AnalysisSpec::Static => Analysis::Static,
        },
        nodes: mesh.nodes,
        elements: mesh.elements,
        bars: mesh.bars,
        components: mesh.components,
        point_masses,
        joints,
        rows,
        loads,
        gravity,
        design: Design {
            interpolation,
            x_min,
            variables: mesh.variables,
        },
        tip,
        defaults: defaults(&spec.simulation)?,
    };
    check_mechanism(&model)?;
    Ok(model)
}

/// Every node on a beam; no redundant joint; every frame grounded; statics without free modes.
fn check_mechanism(model: &Model) -> Result<()> {
    let mut attached = vec![false; model.nodes.len()];
    model
        .elements
        .iter()
        .flat_map(|e| e.nodes)
        .for_each(|n| attached[n] = true);
    if let Some(n) = attached.iter().position(|a| !a) {
        return Err(SceneError::new(
            format!("node '{}'", model.nodes[n].name),
            "is not attached to any beam",
        ));
    }
    if let Some(&r) = redundant_rows(&model.rows).first() {
        let j = model.rows[r].joint;
        return Err(SceneError::new(
            format!("joints[{j}] ({})", model.joints[j].name),
            "over-constrained: this joint repeats a constraint already imposed by earlier joints",
        ));
    }
    let clusters = Clusters::of(model);
    if let Some(&c) = clusters.floating(model).first() {
        let node = &model.nodes[clusters.anchor[c]].name;
        return Err(SceneError::new("joints", format!("unconstrained: the frame containing node '{node}' is not connected to the ground by any joint")));
    }
    if model.analysis == Analysis::Static {
        let free = clusters.mobility(model);
        if free > 0 {
            return Err(SceneError::new("joints", format!("unconstrained: the static scene is a mechanism with {free} free rigid-body mode(s); clamp or drive its joints")));
        }
    }
    Ok(())
}
