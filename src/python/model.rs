//! The built mechanism as Python sees it: construction from a dict or TOML text, and its
//! description (sizes, names, bars, elements, joints).

use std::sync::Arc;

use pyo3::prelude::*;
use pyo3::types::PyDict;

use numpy::PyReadonlyArray1;

use super::convert::{design, matrix, scene_spec, scene_value, vector};
use super::signals::{abandonable, heard};
use crate::error::Error;
use crate::mechanism::model::{Analysis, Densities, Model};
use crate::scene;

/// A built and validated mechanism.
#[pyclass(name = "Model", module = "flextop._core", frozen)]
pub struct PyModel {
    pub(super) model: Arc<Model>,
}

impl PyModel {
    /// The element scalings of design `x` (every bar solid if `None`), checked.
    fn at(&self, x: Option<PyReadonlyArray1<'_, f64>>) -> PyResult<Densities> {
        Ok(self
            .model
            .densities(design(x)?.as_deref())
            .map_err(Error::from)?)
    }

    /// The model of the scene `spec` reads, read and built on a thread of its own, the GIL
    /// released and Ctrl-C heard ([`abandonable`]).
    fn built(
        py: Python<'_>,
        spec: impl FnOnce() -> Result<scene::SceneSpec, Error> + Send + 'static,
    ) -> PyResult<Self> {
        let model = abandonable(py, move || scene::build(&spec()?))?;
        Ok(Self {
            model: Arc::new(model),
        })
    }
}

#[pymethods]
impl PyModel {
    /// Builds a model from a scene dict, read with Ctrl-C heard.
    #[staticmethod]
    fn from_dict(py: Python<'_>, spec: &Bound<'_, PyAny>) -> PyResult<Self> {
        let value = heard(None, || scene_value(spec))?;
        Self::built(py, move || scene_spec(value))
    }

    /// Builds a model from TOML text.
    #[staticmethod]
    fn from_toml(py: Python<'_>, text: &str) -> PyResult<Self> {
        let text = text.to_owned();
        Self::built(py, move || Ok(scene::parse_toml(&text)?))
    }

    #[getter]
    fn name(&self) -> String {
        self.model.name.clone()
    }

    #[getter]
    fn analysis(&self) -> &'static str {
        match self.model.analysis {
            Analysis::Dynamic => "dynamic",
            Analysis::Static => "static",
        }
    }

    #[getter]
    fn n_dofs(&self) -> usize {
        self.model.n_dofs()
    }

    #[getter]
    fn n_constraints(&self) -> usize {
        self.model.n_constraints()
    }

    #[getter]
    fn n_design(&self) -> usize {
        self.model.n_variables()
    }

    #[getter]
    fn x_min(&self) -> f64 {
        self.model.design.x_min
    }

    #[getter]
    fn tip(&self) -> Option<usize> {
        self.model.tip
    }

    #[getter]
    fn node_names(&self) -> Vec<String> {
        self.model.nodes.iter().map(|n| n.name.clone()).collect()
    }

    #[getter]
    fn variable_names(&self) -> Vec<String> {
        self.model.design.variables.clone()
    }

    #[getter]
    fn components(&self) -> Vec<String> {
        self.model.components.clone()
    }

    /// Reference positions, shape `(n_nodes, 2)`.
    #[getter]
    fn reference_positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        matrix(
            py,
            self.model.reference_positions(),
            self.model.nodes.len(),
            2,
        )
    }

    /// Bars as a dict of arrays: `name`, end `nodes` (n, 2), design `variable` (−1 if
    /// fixed), `component` index, full-density `volume` (m³), number of `elements`.
    fn bars<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let m = &self.model;
        let d = PyDict::new(py);
        let end = |b: &crate::mechanism::model::Bar, k: usize| {
            let e = if k == 0 {
                b.elements.start
            } else {
                b.elements.end - 1
            };
            m.elements[e].nodes[k] as f64
        };
        let ends = m.bars.iter().flat_map(|b| [end(b, 0), end(b, 1)]).collect();
        d.set_item(
            "name",
            m.bars.iter().map(|b| b.name.clone()).collect::<Vec<_>>(),
        )?;
        d.set_item("nodes", matrix(py, ends, m.bars.len(), 2)?)?;
        let variable = |b: &crate::mechanism::model::Bar| b.variable.map_or(-1, |v| v as i64);
        d.set_item("variable", m.bars.iter().map(variable).collect::<Vec<_>>())?;
        d.set_item(
            "component",
            m.bars.iter().map(|b| b.component).collect::<Vec<_>>(),
        )?;
        d.set_item(
            "volume",
            vector(py, m.bars.iter().map(|b| b.volume).collect()),
        )?;
        d.set_item(
            "elements",
            m.bars.iter().map(|b| b.elements.len()).collect::<Vec<_>>(),
        )?;
        d.set_item(
            "kind",
            m.bars.iter().map(|b| b.kind.name()).collect::<Vec<_>>(),
        )?;
        Ok(d)
    }

    /// Each bar's lowest clamped–clamped bending frequency (Hz) at design `x` (every bar
    /// solid if `None`): the a-priori indicator of where a bar needs more elements.
    #[pyo3(signature = (x=None))]
    fn bar_frequencies<'py>(
        &self,
        py: Python<'py>,
        x: Option<PyReadonlyArray1<'py, f64>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        Ok(vector(py, self.model.bar_frequencies(&self.at(x)?)))
    }

    /// Checks design `x` as a run does (its length, every density finite and in
    /// `[x_min, 1]`): a `DesignError` naming the first variable that is not.
    fn check_design(&self, x: PyReadonlyArray1<'_, f64>) -> PyResult<()> {
        self.at(Some(x)).map(drop)
    }

    /// Each bar's mass (kg) at design `x` (every bar solid if `None`).
    #[pyo3(signature = (x=None))]
    fn bar_masses<'py>(
        &self,
        py: Python<'py>,
        x: Option<PyReadonlyArray1<'py, f64>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        Ok(vector(py, self.model.bar_masses(&self.at(x)?)))
    }

    /// Elements as end-node pairs `nodes` (n_elements, 2) and the `bar` of each.
    fn elements<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let m = &self.model;
        let d = PyDict::new(py);
        let ends = m
            .elements
            .iter()
            .flat_map(|e| e.nodes.map(|n| n as f64))
            .collect();
        d.set_item("nodes", matrix(py, ends, m.elements.len(), 2)?)?;
        d.set_item("bar", m.elements.iter().map(|e| e.bar).collect::<Vec<_>>())?;
        Ok(d)
    }

    /// Cells of the continuum members: corner `nodes` (n_cells, 4), reference `centre`
    /// (n_cells, 2), full-density `volume` (m³), design `variable` (−1 if fixed), the
    /// `member` of each, and the members' `members` names.
    fn cells<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let m = &self.model;
        let d = PyDict::new(py);
        let n = m.cells.len();
        let corners = m
            .cells
            .iter()
            .flat_map(|c| c.nodes.map(|k| k as f64))
            .collect();
        let centres = m
            .cells
            .iter()
            .flat_map(|c| {
                let p = c
                    .nodes
                    .iter()
                    .map(|&k| m.nodes[k].position)
                    .sum::<nalgebra::Vector2<f64>>()
                    / 4.0;
                [p.x, p.y]
            })
            .collect();
        d.set_item("nodes", matrix(py, corners, n, 4)?)?;
        d.set_item("centre", matrix(py, centres, n, 2)?)?;
        let volumes: Vec<f64> = m.cells.iter().map(|c| c.kernel.volume()).collect();
        d.set_item("volume", vector(py, volumes))?;
        let variables: Vec<i64> = m
            .cells
            .iter()
            .map(|c| c.variable.map_or(-1, |v| v as i64))
            .collect();
        d.set_item("variable", variables)?;
        d.set_item(
            "member",
            m.cells.iter().map(|c| c.member).collect::<Vec<_>>(),
        )?;
        let names: Vec<&str> = m.members.iter().map(|k| k.name.as_str()).collect();
        d.set_item("members", names)?;
        Ok(d)
    }

    /// The rigid mechanism: `frames` (rigid clusters), `mobility` (free rigid-body modes
    /// the joints leave at the reference), `redundant_rows`, the `repeated_rows` among them
    /// and the names of the `over_constraining` joints
    /// ([`crate::mechanism::rigid::OverConstraint`]).
    fn mechanism<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let m = &self.model;
        let model = Arc::clone(m);
        let (frames, mobility, over) = abandonable(py, move || {
            let clusters = crate::mechanism::rigid::Clusters::of(&model);
            let over = clusters.over_constraint(&model)?;
            Ok((clusters.len(), clusters.free_modes(&model, &[])?, over))
        })?;
        let d = PyDict::new(py);
        d.set_item("frames", frames)?;
        d.set_item("mobility", mobility)?;
        d.set_item("redundant_rows", over.as_ref().map_or(0, |o| o.redundant))?;
        d.set_item("repeated_rows", over.as_ref().map_or(0, |o| o.repeated))?;
        let names: Vec<&str> = over
            .iter()
            .flat_map(|o| o.joints.iter().map(|&j| m.joints[j].name.as_str()))
            .collect();
        d.set_item("over_constraining", names)?;
        Ok(d)
    }

    /// Joints, each a dict: `name`, `kind`, node indices `nodes`, constraint `rows` as
    /// `(first, end)` (the drive row last) and `driven`; Ctrl-C heard between joints.
    fn joints<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        let m = &self.model;
        m.joints
            .iter()
            .enumerate()
            .map(|(j, joint)| {
                py.check_signals()?;
                let d = PyDict::new(py);
                let rows = m.joint_rows(j);
                d.set_item("name", &joint.name)?;
                d.set_item("kind", joint.kind.name())?;
                d.set_item("nodes", joint.nodes())?;
                d.set_item("rows", (rows.start, rows.end))?;
                d.set_item("driven", joint.drive.is_some())?;
                d.set_item(
                    "drive_phases",
                    joint.drive.as_ref().and_then(|law| law.phases()),
                )?;
                Ok(d)
            })
            .collect()
    }
}

/// Every kind of response either engine computes, as `(name, syntax, doc, peak, unit,
/// planar, spatial)`: what the Python side documents, labels and checks names against
/// (`peak`: a limit on it bounds its peak; `planar`: a planar scene offers it; `spatial`:
/// how a spatial scene writes it, where one does).
#[pyfunction]
pub fn response_kinds() -> Vec<Described> {
    crate::response::Response::kinds()
        .iter()
        .map(|k| {
            (
                k.name,
                k.syntax,
                k.doc,
                k.peak,
                k.unit,
                k.planar(),
                k.spatial,
            )
        })
        .collect()
}

/// A response kind for Python: name, planar syntax, documentation, whether a limit bounds
/// its peak, unit, whether a planar scene offers it, its syntax on a spatial scene.
type Described = (
    &'static str,
    &'static str,
    &'static str,
    bool,
    &'static str,
    bool,
    Option<&'static str>,
);

/// The named limits on a model's size ([`crate::limits`]) by name: what the example
/// scenes' builders check their counts against before they allocate anything.
#[pyfunction]
pub fn size_limits() -> Vec<(&'static str, usize)> {
    use crate::limits::{MAX_ELEMENTS, MAX_GRID_NODES, MAX_NODES, MAX_SPLIT};
    vec![
        ("grid_nodes", MAX_GRID_NODES),
        ("split", MAX_SPLIT),
        ("nodes", MAX_NODES),
        ("elements", MAX_ELEMENTS),
        ("steps", crate::settings::MAX_STEPS),
    ]
}
