//! Python bindings: the `flextop._core` extension module (thin wrappers only).
//!
//! Scenes arrive as Python dicts (converted with `pythonize`, unknown keys rejected with
//! their path) or TOML text; results leave as dicts of numpy arrays. Long computations
//! release the GIL. Engine errors are raised as the classes of `flextop.errors`.

use std::sync::Arc;

use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::element::MassKind;
use crate::error::{Error, SceneError, SettingsError};
use crate::model::{Analysis, Model};
use crate::options::RunOptions;
use crate::rigid::Clusters;
use crate::scene::{self, SceneSpec};
use crate::sensitivity::{self, parse_responses, Memory, Method};
use crate::simulation::simulate;
use crate::statics::solve_static;

impl From<Error> for PyErr {
    /// The matching class of `flextop.errors`, so Python code can catch `SceneError`,
    /// `DesignError`, `SettingsError` (all `ValueError`) or `SimulationError` (`RuntimeError`).
    fn from(e: Error) -> PyErr {
        let class = match e {
            Error::Scene(_) => "SceneError",
            Error::Design(_) => "DesignError",
            Error::Settings(_) => "SettingsError",
            Error::Solve(_) => "SimulationError",
        };
        let msg = e.to_string();
        Python::attach(|py| {
            match py
                .import("flextop.errors")
                .and_then(|m| m.getattr(class))
                .and_then(|c| c.call1((msg.clone(),)))
            {
                Ok(instance) => PyErr::from_value(instance),
                Err(_) => pyo3::exceptions::PyRuntimeError::new_err(msg),
            }
        })
    }
}

fn scene_error(path: String, message: String) -> PyErr {
    Error::Scene(SceneError::new(
        if path == "." { "scene".into() } else { path },
        message,
    ))
    .into()
}

/// A joint as Python sees it: `(name, kind, node indices, first row, row count, driven)`.
type JointInfo = (String, &'static str, Vec<usize>, usize, usize, bool);

/// A built and validated mechanism.
#[pyclass(name = "Model", module = "flextop._core", frozen)]
struct PyModel {
    model: Arc<Model>,
}

/// Run options from a settings dict; unknown keys and wrong values name the setting.
fn run_options(settings: Option<&Bound<'_, PyAny>>) -> PyResult<RunOptions> {
    let Some(settings) = settings else {
        return Ok(RunOptions::default());
    };
    let mut de = pythonize::Depythonizer::from_object(settings);
    serde_path_to_error::deserialize(&mut de).map_err(|e| {
        let path = e.path().to_string();
        Error::Settings(SettingsError::new(
            if path == "." { "settings".into() } else { path },
            e.into_inner().to_string(),
        ))
        .into()
    })
}

fn design_vector(x: Option<PyReadonlyArray1<'_, f64>>) -> PyResult<Option<Vec<f64>>> {
    x.map(|a| Ok(a.as_slice()?.to_vec())).transpose()
}

/// A row-major `(rows, cols)` numpy array from a flat vector.
fn matrix<'py>(py: Python<'py>, data: Vec<f64>, cols: usize) -> PyResult<Bound<'py, PyAny>> {
    let rows = data.len().checked_div(cols).unwrap_or(0);
    Ok(PyArray1::from_vec(py, data)
        .reshape([rows, cols])?
        .into_any())
}

#[pymethods]
impl PyModel {
    /// Builds a model from a scene dict.
    #[staticmethod]
    fn from_dict(spec: &Bound<'_, PyAny>) -> PyResult<Self> {
        let mut de = pythonize::Depythonizer::from_object(spec);
        let spec: SceneSpec = serde_path_to_error::deserialize(&mut de)
            .map_err(|e| scene_error(e.path().to_string(), e.into_inner().to_string()))?;
        Ok(Self {
            model: Arc::new(scene::build(&spec).map_err(Error::from)?),
        })
    }

    /// Builds a model from TOML text.
    #[staticmethod]
    fn from_toml(text: &str) -> PyResult<Self> {
        let spec = scene::parse_toml(text).map_err(Error::from)?;
        Ok(Self {
            model: Arc::new(scene::build(&spec).map_err(Error::from)?),
        })
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
    fn n_variables(&self) -> usize {
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
        matrix(py, self.model.reference_positions(), 2)
    }

    /// Bars as a dict of arrays: end `nodes` (n, 2), `variable` (−1 if fixed), `component`,
    /// full-density `volume` (m³), `name`.
    fn bars<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let m = &self.model;
        let d = PyDict::new(py);
        let ends: Vec<f64> = m
            .bars
            .iter()
            .flat_map(|b| {
                [
                    m.elements[b.elements.start].nodes[0] as f64,
                    m.elements[b.elements.end - 1].nodes[1] as f64,
                ]
            })
            .collect();
        d.set_item("nodes", matrix(py, ends, 2)?)?;
        d.set_item(
            "variable",
            m.bars
                .iter()
                .map(|b| b.variable.map_or(-1, |v| v as i64))
                .collect::<Vec<_>>(),
        )?;
        d.set_item(
            "component",
            m.bars.iter().map(|b| b.component).collect::<Vec<_>>(),
        )?;
        d.set_item(
            "volume",
            PyArray1::from_vec(py, m.bars.iter().map(|b| b.volume).collect()),
        )?;
        d.set_item(
            "name",
            m.bars.iter().map(|b| b.name.clone()).collect::<Vec<_>>(),
        )?;
        Ok(d)
    }

    /// Elements as end-node pairs, shape `(n_elements, 2)`, and the bar of each.
    fn elements<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let m = &self.model;
        let d = PyDict::new(py);
        d.set_item(
            "nodes",
            matrix(
                py,
                m.elements
                    .iter()
                    .flat_map(|e| [e.nodes[0] as f64, e.nodes[1] as f64])
                    .collect(),
                2,
            )?,
        )?;
        d.set_item("bar", m.elements.iter().map(|e| e.bar).collect::<Vec<_>>())?;
        Ok(d)
    }

    /// Joints: list of `(name, kind, node indices, first row, row count, driven)`.
    fn joints(&self) -> Vec<JointInfo> {
        let m = &self.model;
        m.joints
            .iter()
            .enumerate()
            .map(|(j, joint)| {
                let first = m
                    .rows
                    .iter()
                    .position(|r| r.joint == j)
                    .unwrap_or(m.rows.len());
                let count = m.rows.iter().filter(|r| r.joint == j).count();
                let kind = match joint.kind {
                    crate::constraint::JointKind::Clamp { .. } => "clamp",
                    crate::constraint::JointKind::Pin { .. } => "pin",
                    crate::constraint::JointKind::Hinge { .. } => "hinge",
                };
                (
                    joint.name.clone(),
                    kind,
                    joint.nodes(),
                    first,
                    count,
                    joint.drive.is_some(),
                )
            })
            .collect()
    }

    /// Time integration (dynamic scenes) with run `settings` (dict: `t_end`, `h`,
    /// `rho_inf`, `tol`, `max_iter`, `mass`). Returns a dict of numpy arrays.
    #[pyo3(signature = (x=None, settings=None))]
    fn simulate<'py>(
        &self,
        py: Python<'py>,
        x: Option<PyReadonlyArray1<'py, f64>>,
        settings: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let settings = run_options(settings)?
            .dynamic(&self.model.defaults)
            .map_err(Error::from)?;
        let x = design_vector(x)?;
        let model = Arc::clone(&self.model);
        let traj = py.detach(move || simulate(&model, x.as_deref(), &settings))?;
        let d = PyDict::new(py);
        let (n_q, n_c) = (traj.n_q, traj.n_c);
        d.set_item("time", PyArray1::from_vec(py, traj.time))?;
        d.set_item("q", matrix(py, traj.q, n_q)?)?;
        d.set_item("qdot", matrix(py, traj.v, n_q)?)?;
        d.set_item("qddot", matrix(py, traj.acc, n_q)?)?;
        d.set_item("lam", matrix(py, traj.lambda, n_c)?)?;
        d.set_item("iterations", traj.iterations)?;
        d.set_item("kinetic", PyArray1::from_vec(py, traj.kinetic))?;
        d.set_item("strain", PyArray1::from_vec(py, traj.strain))?;
        d.set_item("drive_work", PyArray1::from_vec(py, traj.drive_work))?;
        d.set_item("external_work", PyArray1::from_vec(py, traj.external_work))?;
        d.set_item("h", settings.step())?;
        d.set_item("rho_inf", settings.rho_inf)?;
        Ok(d)
    }

    /// Static equilibrium (any scene) with run `settings` (dict: `t_end`, `tol`,
    /// `max_iter`, `load_steps`). Returns a dict with `u`, `lambda`, Newton statistics.
    #[pyo3(signature = (x=None, settings=None))]
    fn solve_static<'py>(
        &self,
        py: Python<'py>,
        x: Option<PyReadonlyArray1<'py, f64>>,
        settings: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let settings = run_options(settings)?
            .statics(&self.model.defaults)
            .map_err(Error::from)?;
        let x = design_vector(x)?;
        let model = Arc::clone(&self.model);
        let sol = py.detach(move || -> Result<_, Error> {
            let densities = model.densities(x.as_deref())?;
            Ok(solve_static(&model, densities, &settings)?)
        })?;
        let d = PyDict::new(py);
        d.set_item("q", PyArray1::from_vec(py, sol.q))?;
        d.set_item("lam", PyArray1::from_vec(py, sol.lambda))?;
        d.set_item("iterations", sol.iterations)?;
        d.set_item("load_steps", sol.load_steps)?;
        d.set_item("time", settings.time)?;
        Ok(d)
    }

    /// Responses and their gradients for run `settings` (dict, as [`PyModel::simulate`] or
    /// [`PyModel::solve_static`]): a dict of `values` (n_r,), `gradients` (n_r, n_x), the
    /// `method` used, `simulation_seconds` and `gradient_seconds`.
    #[pyo3(signature = (x, responses, method="auto", memory="auto", settings=None))]
    fn run_with_sensitivities<'py>(
        &self,
        py: Python<'py>,
        x: PyReadonlyArray1<'py, f64>,
        responses: Vec<String>,
        method: &str,
        memory: &str,
        settings: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let method = match method {
            "auto" => Method::Auto,
            "direct" => Method::Direct,
            "adjoint" => Method::Adjoint,
            other => {
                return Err(Error::Settings(SettingsError::new(
                    "method",
                    format!("must be 'auto', 'direct' or 'adjoint', got '{other}'"),
                ))
                .into())
            }
        };
        let memory = match memory {
            "auto" => Memory::default(),
            "store" => Memory::StoreAll,
            "checkpoints" => Memory::Checkpoints,
            other => {
                return Err(Error::Settings(SettingsError::new(
                    "memory",
                    format!("must be 'auto', 'store' or 'checkpoints', got '{other}'"),
                ))
                .into())
            }
        };
        let model = Arc::clone(&self.model);
        let parsed = parse_responses(&model, &responses).map_err(Error::from)?;
        let options = run_options(settings)?;
        let x = x.as_slice()?.to_vec();
        let result = match model.analysis {
            Analysis::Dynamic => {
                let settings = options.dynamic(&model.defaults).map_err(Error::from)?;
                py.detach(move || {
                    sensitivity::dynamic(&model, &x, &settings, &parsed, method, memory)
                })?
            }
            Analysis::Static => {
                let settings = options.statics(&model.defaults).map_err(Error::from)?;
                py.detach(move || sensitivity::equilibrium(&model, &x, &settings, &parsed, method))?
            }
        };
        let n_x = self.model.n_variables();
        let used = if result.method == Method::Direct {
            "direct"
        } else {
            "adjoint"
        };
        let d = PyDict::new(py);
        d.set_item("values", PyArray1::from_vec(py, result.values))?;
        d.set_item("gradients", matrix(py, result.gradients, n_x)?)?;
        d.set_item("method", used)?;
        d.set_item("simulation_seconds", result.timings.simulation)?;
        d.set_item("gradient_seconds", result.timings.gradients)?;
        Ok(d)
    }

    /// Values of `responses` on recorded coordinates `u` (shape `(n_states, n_dofs)`, steps
    /// of `h`; a static state's loads act at `load_time`) for design `x`.
    #[pyo3(signature = (x, u, h, load_time, responses))]
    fn evaluate_responses<'py>(
        &self,
        py: Python<'py>,
        x: Option<PyReadonlyArray1<'py, f64>>,
        u: numpy::PyReadonlyArray2<'py, f64>,
        h: f64,
        load_time: f64,
        responses: Vec<String>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let parsed = parse_responses(&self.model, &responses).map_err(Error::from)?;
        let u = u.as_slice()?.to_vec();
        let x = design_vector(x)?;
        let model = Arc::clone(&self.model);
        let values = py.detach(move || {
            sensitivity::evaluate(&model, x.as_deref(), &u, h, load_time, &parsed)
        })?;
        Ok(PyArray1::from_vec(py, values).into_any())
    }

    /// Mass `M`, tangent stiffness `K_t(u)` and constraint Jacobian `Φ_q` as CSC triplets
    /// `(data, indices, indptr, shape)` for `scipy.sparse.csc_matrix`.
    #[pyo3(signature = (x=None, u=None, settings=None))]
    fn linearize<'py>(
        &self,
        py: Python<'py>,
        x: Option<PyReadonlyArray1<'py, f64>>,
        u: Option<PyReadonlyArray1<'py, f64>>,
        settings: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let mass = run_options(settings)?.mass.unwrap_or(MassKind::Consistent);
        let m = &self.model;
        let densities = m
            .densities(design_vector(x)?.as_deref())
            .map_err(Error::from)?;
        let n = m.n_dofs();
        let u = match u {
            Some(u) => u.as_slice()?.to_vec(),
            None => vec![0.0; n],
        };
        if u.len() != n {
            return Err(Error::Settings(SettingsError::new(
                "u",
                format!("has {} entries, the model has {n} DOFs", u.len()),
            ))
            .into());
        }
        let asm = crate::assembly::Assembler::new(m, densities, mass);
        let mut values = vec![0.0; asm.pattern.nnz()];
        let block = |values: &[f64], rows: std::ops::Range<usize>, cols: std::ops::Range<usize>| {
            let p = &asm.pattern;
            let (mut data, mut indices, mut indptr) = (Vec::new(), Vec::new(), vec![0usize]);
            for j in cols {
                for idx in p.col_ptr[j]..p.col_ptr[j + 1] {
                    let i = p.row_idx[idx];
                    if rows.contains(&i) && values[idx] != 0.0 {
                        data.push(values[idx]);
                        indices.push(i - rows.start);
                    }
                }
                indptr.push(data.len());
            }
            (data, indices, indptr)
        };
        let d = PyDict::new(py);
        asm.start_iteration_matrix(1.0, 0.0, &mut values);
        d.set_item("M", (block(&values, 0..n, 0..n), (n, n)))?;
        asm.start_iteration_matrix(0.0, 0.0, &mut values);
        asm.internal_forces(&u, &mut vec![0.0; n], Some(&mut values));
        d.set_item("K", (block(&values, 0..n, 0..n), (n, n)))?;
        let n_c = m.n_constraints();
        asm.start_iteration_matrix(0.0, 1.0, &mut values);
        d.set_item("G", (block(&values, n..n + n_c, 0..n), (n_c, n)))?;
        Ok(d)
    }

    /// Positions of every node at `times` when every frame is rigid, shape
    /// `(len, n_nodes, 2)`.
    fn rigid_positions<'py>(
        &self,
        py: Python<'py>,
        times: Vec<f64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let model = Arc::clone(&self.model);
        let (len, n) = (times.len(), model.nodes.len());
        let flat = py.detach(move || -> Result<Vec<f64>, Error> {
            let clusters = Clusters::of(&model);
            let motion = clusters.rigid_motion(&model, &times)?;
            Ok(motion
                .iter()
                .flat_map(|rho| {
                    (0..model.nodes.len())
                        .flat_map(|k| clusters.position(&model, rho, k))
                        .collect::<Vec<_>>()
                })
                .collect())
        })?;
        Ok(PyArray1::from_vec(py, flat)
            .reshape([len, n, 2])?
            .into_any())
    }
}

/// The extension module.
#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyModel>()
}
