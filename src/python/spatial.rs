//! The spatial engine as Python sees it: a built spatial scene, its motion, its static
//! equilibrium, its natural modes and the exact gradients of its responses. Each run takes
//! settings as a dict (the keys of [`crate::settings::RunOptions`]), releases the GIL and
//! hears Ctrl-C, and returns numpy arrays in a dict.

use std::sync::Arc;

use pyo3::prelude::*;
use pyo3::types::PyDict;

use super::convert::{matrix, run_options, scene_value, spatial_scene_spec, vector};
use super::signals::{abandonable, detached, heard, reporting};
use crate::error::{Error, SettingsError};
use crate::mechanism::model::Analysis;
use crate::scene::spatial::names::Named;
use crate::scene::spatial::{build_spatial, parse_spatial_toml, SpatialScene};
use crate::spatial::element::Element;
use crate::spatial::integrator::simulate_spatial;
use crate::spatial::modal::natural_modes_spatial;
use crate::spatial::modal_rates::omega_squared_rates;
use crate::spatial::rigid::rigid_trajectories;
use crate::spatial::sensitivity::{sensitivities, static_sensitivities, time_errors};
use crate::spatial::shares::beam_shares;
use crate::spatial::statics::solve_static_spatial;

/// A built and validated spatial scene.
#[pyclass(name = "SpatialModel", module = "flextop._core", frozen)]
pub struct PySpatialModel {
    scene: Arc<SpatialScene>,
}

impl PySpatialModel {
    /// The scene `spec` reads, built on a thread of its own, Ctrl-C heard.
    fn built(
        py: Python<'_>,
        spec: impl FnOnce() -> Result<crate::scene::spatial::SpatialSceneSpec, Error> + Send + 'static,
    ) -> PyResult<Self> {
        let scene = abandonable(py, move || build_spatial(&spec()?))?;
        Ok(Self {
            scene: Arc::new(scene),
        })
    }

    /// A list of `(rows, cols)` entries as a numpy matrix.
    fn rows<'py>(py: Python<'py>, rows: Vec<Vec<f64>>, cols: usize) -> PyResult<Bound<'py, PyAny>> {
        let n = rows.len();
        matrix(py, rows.concat(), n, cols)
    }
}

#[pymethods]
impl PySpatialModel {
    /// Builds a spatial scene from a dict, read with Ctrl-C heard.
    #[staticmethod]
    fn from_dict(py: Python<'_>, spec: &Bound<'_, PyAny>) -> PyResult<Self> {
        let value = heard(None, || scene_value(spec))?;
        Self::built(py, move || spatial_scene_spec(value))
    }

    /// Builds a spatial scene from TOML text.
    #[staticmethod]
    fn from_toml(py: Python<'_>, text: &str) -> PyResult<Self> {
        let text = text.to_owned();
        Self::built(py, move || Ok(parse_spatial_toml(&text)?))
    }

    #[getter]
    fn name(&self) -> String {
        self.scene.name.clone()
    }

    #[getter]
    fn analysis(&self) -> &'static str {
        match self.scene.analysis {
            Analysis::Dynamic => "dynamic",
            Analysis::Static => "static",
        }
    }

    /// The design variables' names: each beam's or design group's.
    #[getter]
    fn variables(&self) -> Vec<String> {
        self.scene.design.variables.clone()
    }

    /// The lower bound on the densities.
    #[getter]
    fn x_min(&self) -> f64 {
        self.scene.design.x_min
    }

    /// The material volume (m³) of each design variable at full density, and of the fixed
    /// beams.
    #[getter]
    fn volumes(&self) -> (Vec<f64>, f64) {
        self.scene.volumes()
    }

    /// The mass (kg) of each design variable's elements at design `x` (full density by
    /// default), its derivative to the variable, and the fixed beams' mass.
    #[pyo3(signature = (x=None))]
    fn masses(&self, x: Option<Vec<f64>>) -> PyResult<(Vec<f64>, Vec<f64>, f64)> {
        let x = x.unwrap_or_else(|| vec![1.0; self.scene.n_variables()]);
        Ok(self.scene.masses(&x).map_err(Error::from)?)
    }

    /// Each beam's lowest clamped–clamped bending frequency (Hz) at design `x` (full density
    /// by default), in the order of `beams`; infinite for a truss bar.
    #[pyo3(signature = (x=None))]
    fn beam_frequencies(&self, x: Option<Vec<f64>>) -> PyResult<Vec<f64>> {
        Ok(self
            .scene
            .beam_frequencies(x.as_deref())
            .map_err(Error::from)?)
    }

    /// Each beam's mass (kg) at design `x` (full density by default), in the order of `beams`.
    #[pyo3(signature = (x=None))]
    fn beam_masses(&self, x: Option<Vec<f64>>) -> PyResult<Vec<f64>> {
        Ok(self.scene.beam_masses(x.as_deref()).map_err(Error::from)?)
    }

    #[getter]
    fn tip(&self) -> Option<String> {
        self.scene.tip.clone()
    }

    /// Names of the nodes, bodies' included (seven numbers each in `q`, six in `v`).
    #[getter]
    fn node_names(&self) -> Vec<String> {
        self.scene
            .model
            .nodes
            .iter()
            .map(|n| n.name.clone())
            .collect()
    }

    /// The node each body sits on, by the body's name.
    #[getter]
    fn body_nodes(&self) -> Vec<(String, usize)> {
        let bodies = self.scene.model.bodies.iter();
        bodies.map(|b| (b.name.clone(), b.node)).collect()
    }

    /// Each joint's name and its rows in `λ` (start, end).
    #[getter]
    fn joint_rows(&self) -> Vec<(String, usize, usize)> {
        let m = &self.scene.model;
        let rows = |k| m.joint_rows(k).map_or((0, 0), |r| (r.start, r.end));
        (m.joints.iter().enumerate())
            .map(|(k, j)| (j.name.clone(), rows(k).0, rows(k).1))
            .collect()
    }

    /// Each scene beam's name and its elements' end nodes.
    #[getter]
    fn beams(&self) -> Vec<(String, Vec<[usize; 2]>)> {
        let m = &self.scene.model;
        let ends = |b: &crate::scene::spatial::BeamElements| {
            b.elements
                .iter()
                .map(|&e| {
                    if b.truss {
                        m.trusses[e].nodes()
                    } else {
                        m.beams[e].nodes()
                    }
                })
                .collect()
        };
        (self.scene.beams.iter())
            .map(|(name, b)| (name.clone(), ends(b)))
            .collect()
    }

    /// The initial configuration: seven numbers per node (position, unit quaternion `w, x, y, z`).
    #[getter]
    fn initial_q(&self) -> Vec<f64> {
        self.scene.model.initial_configuration()
    }

    /// Each scene beam's design variable (in the order of `beams`); `None` where it is fixed.
    #[getter]
    fn beam_variables(&self) -> Vec<Option<usize>> {
        self.scene.beams.values().map(|b| b.variable).collect()
    }

    /// The scene's `[simulation]` defaults as a dict.
    fn options<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let o = &self.scene.options;
        let d = PyDict::new(py);
        for (key, value) in [
            ("t_end", o.t_end),
            ("h", o.h),
            ("rho_inf", o.rho_inf),
            ("tol", o.tol),
        ] {
            if let Some(v) = value {
                d.set_item(key, v)?;
            }
        }
        Ok(d)
    }

    /// The motion: `time`, `q`, `v` (velocities `(u̇, Ω)`), `lam`, and the `kinetic`,
    /// `potential` (gravity, springs, dead loads and strains) and `strain` energies (J)
    /// at each time. `progress`, if given, is called with the time reached (s).
    #[pyo3(signature = (settings=None, progress=None, x=None))]
    fn simulate<'py>(
        &self,
        py: Python<'py>,
        settings: Option<&Bound<'py, PyAny>>,
        progress: Option<Py<PyAny>>,
        x: Option<Vec<f64>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let scene = Arc::clone(&self.scene);
        let settings = run_options(settings)?
            .dynamic(&scene.options)
            .map_err(Error::from)?;
        let design = x.clone();
        let states = reporting(py, progress, move || {
            settings.validate()?;
            let model = scene.model_at(x.as_deref())?;
            simulate_spatial(&model, &settings, &settings.grid())
        })?;
        // The energies of the mechanism at the design it ran at.
        let model = self
            .scene
            .model_at(design.as_deref())
            .map_err(Error::from)?;
        let m = &*model;
        let d = PyDict::new(py);
        let column = |f: &dyn Fn(&crate::solver::alpha::State) -> f64| {
            vector(py, states.iter().map(f).collect())
        };
        d.set_item("time", column(&|s| s.t))?;
        d.set_item("kinetic", column(&|s| m.kinetic_energy(&s.qdot)))?;
        d.set_item("potential", column(&|s| m.potential_energy(&s.q)))?;
        d.set_item("strain", column(&|s| m.strain_energy(&s.q)))?;
        let n = states.len();
        let flat = |f: &dyn Fn(&crate::solver::alpha::State) -> &Vec<f64>| {
            states
                .iter()
                .flat_map(|s| f(s).iter().copied())
                .collect::<Vec<_>>()
        };
        d.set_item("q", matrix(py, flat(&|s| &s.q), n, m.n_q())?)?;
        d.set_item("v", matrix(py, flat(&|s| &s.qdot), n, m.n_v())?)?;
        d.set_item("lam", matrix(py, flat(&|s| &s.lam), n, m.n_rows())?)?;
        Ok(d)
    }

    /// The rigid trajectory of node `node` (paper Eq. 40's `r_rigid`: the mechanism with each
    /// link one rigid body on its joints and drives, [`crate::spatial::rigid`]) on the grid
    /// `settings` give a run: one position per state, `(n_t, 3)` (m).
    #[pyo3(signature = (node, settings=None))]
    fn rigid_trajectory<'py>(
        &self,
        py: Python<'py>,
        node: usize,
        settings: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let scene = Arc::clone(&self.scene);
        let settings = run_options(settings)?
            .dynamic(&scene.options)
            .map_err(Error::from)?;
        if node >= scene.model.nodes.len() {
            return Err(Error::from(SettingsError::new(
                "node",
                format!("no node {node} (the scene has {})", scene.model.nodes.len()),
            ))
            .into());
        }
        let path = detached(py, move || {
            settings.validate()?;
            let grid = settings.grid();
            Ok(rigid_trajectories(&scene.model, &settings, &grid, &[node])?.remove(0))
        })?;
        let n = path.len();
        matrix(
            py,
            path.iter().flat_map(|p| p.iter().copied()).collect(),
            n,
            3,
        )
    }

    /// The static equilibrium at the loads of `t_end` (0 by default): `q`, `lam`, Newton
    /// `iterations` and `load_steps`, the `strain` energy (J).
    #[pyo3(signature = (settings=None, x=None))]
    fn solve_static<'py>(
        &self,
        py: Python<'py>,
        settings: Option<&Bound<'py, PyAny>>,
        x: Option<Vec<f64>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let scene = Arc::clone(&self.scene);
        let settings = run_options(settings)?
            .statics(&scene.options)
            .map_err(Error::from)?;
        let design = x.clone();
        let eq = detached(py, move || {
            let model = scene.model_at(x.as_deref())?;
            solve_static_spatial(&model, &settings)
        })?;
        let model = self
            .scene
            .model_at(design.as_deref())
            .map_err(Error::from)?;
        let d = PyDict::new(py);
        d.set_item("strain", model.strain_energy(&eq.q))?;
        d.set_item("q", vector(py, eq.q))?;
        d.set_item("lam", vector(py, eq.lambda))?;
        d.set_item("iterations", eq.iterations)?;
        d.set_item("load_steps", eq.load_steps)?;
        Ok(d)
    }

    /// The natural modes about configuration `q` with multipliers `lam` at time `t` (without
    /// them, at rest: the initial configuration, the loads, motors and gravity taken away,
    /// [`crate::spatial::model::SpatialModel::at_rest`]): every
    /// one without `count`, the lowest `count` (shift-invert Lanczos, any size) with it —
    /// `omega_squared` (rad²/s², ascending), the `frequencies` (Hz; `None` where the state is
    /// unstable), mass-normalized `shapes` (one row each, six numbers per node) and, for a
    /// count, the Sturm `bound` (rad²/s²) and the count `below` it (`None` without).
    #[pyo3(signature = (q=None, lam=None, t=0.0, x=None, count=None, parameters=None))]
    #[allow(clippy::too_many_arguments)]
    fn natural_modes<'py>(
        &self,
        py: Python<'py>,
        q: Option<Vec<f64>>,
        lam: Option<Vec<f64>>,
        t: f64,
        x: Option<Vec<f64>>,
        count: Option<usize>,
        parameters: Option<Vec<String>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let scene = Arc::clone(&self.scene);
        let (modes, rates) = detached(py, move || {
            let mut model = scene.model_at(x.as_deref())?;
            let (q, lam) = match (q, lam) {
                (Some(q), Some(lam)) => (q, lam),
                (None, None) => {
                    model = std::borrow::Cow::Owned(model.at_rest());
                    (model.initial_configuration(), vec![0.0; model.n_rows()])
                }
                _ => {
                    return Err(Error::from(SettingsError::new(
                        "natural_modes",
                        "give both q and lam (a configuration), or neither (at rest)",
                    )))
                }
            };
            let modes = natural_modes_spatial(&model, &q, &lam, t, count)?;
            let rates = match parameters {
                None => None,
                Some(names) => {
                    let (named, ps) = scene.named_and_densities(&names, x.as_deref())?;
                    let rates =
                        omega_squared_rates(&model, &q, &modes.omega_squared, &modes.shapes, &ps)?;
                    Some(combined(&named, &rates))
                }
            };
            Ok::<_, Error>((modes, rates))
        })?;
        let d = PyDict::new(py);
        let n_v = self.scene.model.n_v();
        let n_p = rates.as_ref().and_then(|r| r.first()).map_or(0, Vec::len);
        let rates = rates.map(|r| Self::rows(py, r, n_p)).transpose()?;
        d.set_item("omega_squared_rates", rates)?;
        let frequencies = modes.frequencies().map(|f| vector(py, f));
        d.set_item("frequencies", frequencies)?;
        d.set_item("shapes", Self::rows(py, modes.shapes, n_v)?)?;
        d.set_item("omega_squared", vector(py, modes.omega_squared))?;
        d.set_item("bound", modes.sturm.map(|s| s.bound))?;
        d.set_item("below", modes.sturm.map(|s| s.below))?;
        Ok(d)
    }

    /// Responses by name and their exact gradients to parameters by name
    /// ([`crate::scene::spatial::names`]) and to the design's densities (after them), at
    /// design `x` (full density by default), over the motion or, with `equilibrium`, at the
    /// static equilibrium: `values`, `gradient` (one row per response) and `peaks` (a stress
    /// mean's peak, `None` for the others).
    #[pyo3(signature = (responses, parameters, settings=None, equilibrium=false, x=None))]
    fn sensitivities<'py>(
        &self,
        py: Python<'py>,
        responses: Vec<String>,
        parameters: Vec<String>,
        settings: Option<&Bound<'py, PyAny>>,
        equilibrium: bool,
        x: Option<Vec<f64>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let scene = Arc::clone(&self.scene);
        let options = run_options(settings)?;
        let method = options.sensitivity(&scene.options).method;
        let found = detached(py, move || {
            let rs = (responses.iter())
                .map(|r| scene.response(r))
                .collect::<Result<Vec<_>, _>>()?;
            let (named, ps) = scene.named_and_densities(&parameters, x.as_deref())?;
            let model = scene.model_at(x.as_deref())?;
            let g = if equilibrium {
                let settings = options.statics(&scene.options)?;
                static_sensitivities(&model, &settings, &rs, &ps, method)?
            } else {
                let settings = options.dynamic(&scene.options)?;
                settings.validate()?;
                sensitivities(&model, &settings, &settings.grid(), &rs, &ps, method)?
            };
            Ok::<_, Error>((g.values, combined(&named, &g.gradient), g.peaks))
        })?;
        let (values, gradient, peaks) = found;
        let d = PyDict::new(py);
        let n_p = gradient.first().map_or(0, Vec::len);
        d.set_item("values", vector(py, values))?;
        d.set_item("gradient", Self::rows(py, gradient, n_p)?)?;
        d.set_item("peaks", peaks)?;
        Ok(d)
    }

    /// The responses' `values` of the motion at design `x` and their time `errors`
    /// `f(h) − f` to leading order in the step, from the run and one adjoint sweep
    /// ([`crate::spatial::sensitivity::time_errors`]).
    #[pyo3(signature = (responses, settings=None, x=None))]
    fn time_errors<'py>(
        &self,
        py: Python<'py>,
        responses: Vec<String>,
        settings: Option<&Bound<'py, PyAny>>,
        x: Option<Vec<f64>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let scene = Arc::clone(&self.scene);
        let options = run_options(settings)?;
        let (values, errors) = detached(py, move || {
            let rs = (responses.iter())
                .map(|r| scene.response(r))
                .collect::<Result<Vec<_>, _>>()?;
            let model = scene.model_at(x.as_deref())?;
            let settings = options.dynamic(&scene.options)?;
            settings.validate()?;
            time_errors(&model, &settings, &settings.grid(), &rs)
        })?;
        let d = PyDict::new(py);
        d.set_item("values", vector(py, values))?;
        d.set_item("errors", vector(py, errors))?;
        Ok(d)
    }

    /// Each scene beam's share of the change of `responses` from this scene's run at design
    /// `x` to the run of `fine` — this scene with every frame beam's elements split in two,
    /// `fine_responses` the same responses named there — on the same steps
    /// ([`crate::spatial::shares`]): `values`, `fine_values`, `shares` and `first_order` (one
    /// row per response, one column per scene beam in the order of `beams`).
    #[pyo3(signature = (fine, responses, fine_responses, settings=None, x=None))]
    fn beam_shares<'py>(
        &self,
        py: Python<'py>,
        fine: &PySpatialModel,
        responses: Vec<String>,
        fine_responses: Vec<String>,
        settings: Option<&Bound<'py, PyAny>>,
        x: Option<Vec<f64>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let (scene, fine) = (Arc::clone(&self.scene), Arc::clone(&fine.scene));
        let options = run_options(settings)?;
        let out = detached(py, move || {
            let named = |s: &SpatialScene, names: &[String]| {
                (names.iter())
                    .map(|r| s.response(r))
                    .collect::<Result<Vec<_>, _>>()
            };
            let (rs, fs) = (named(&scene, &responses)?, named(&fine, &fine_responses)?);
            let settings = options.dynamic(&scene.options)?;
            settings.validate()?;
            let beams = scene.split_beams(&fine)?;
            let models = (scene.model_at(x.as_deref())?, fine.model_at(x.as_deref())?);
            let grid = settings.grid();
            beam_shares((&models.0, &models.1), &beams, &settings, &grid, &rs, &fs)
        })?;
        let (n_r, n_b) = (out.values.len(), self.scene.beams.len());
        let d = PyDict::new(py);
        d.set_item("values", vector(py, out.values))?;
        d.set_item("fine_values", vector(py, out.fine_values))?;
        d.set_item("shares", matrix(py, out.shares, n_r, n_b)?)?;
        d.set_item("first_order", matrix(py, out.first_order, n_r, n_b)?)?;
        Ok(d)
    }
}

/// Gradients to the engine's parameters combined into those to the named ones (each named
/// one a sum of engine parameters times factors, in order).
fn combined(named: &[Named], gradient: &[Vec<f64>]) -> Vec<Vec<f64>> {
    (gradient.iter())
        .map(|row| {
            let mut parts = row.iter();
            (named.iter())
                .map(|n| n.iter().zip(&mut parts).map(|((_, f), d)| f * d).sum())
                .collect()
        })
        .collect()
}
