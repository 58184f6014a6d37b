//! The spatial engine as Python sees it: a built spatial scene, its motion, its static
//! equilibrium, its natural modes and the exact gradients of its responses. Each run takes
//! settings as a dict (the keys of [`crate::settings::RunOptions`]), releases the GIL and
//! hears Ctrl-C, and returns numpy arrays in a dict.

use std::sync::Arc;

use pyo3::prelude::*;
use pyo3::types::PyDict;

use super::convert::{scene_value, spatial_scene_spec};
use super::signals::{abandonable, heard};
use super::spatial_runs;
use crate::error::Error;
use crate::mechanism::model::Analysis;
use crate::scene::spatial::{build_spatial, parse_spatial_toml, SpatialScene};
use crate::spatial::element::Element;

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

    /// Each scene beam's reach from its axis, for drawing it (in the order of `beams`, m):
    /// a frame beam's section's ([`crate::spatial::section::Section::outer_radius`]), a truss
    /// bar's the radius of the circle of its area.
    #[getter]
    fn beam_radii(&self) -> Vec<f64> {
        let m = &self.scene.model;
        let radius = |b: &crate::scene::spatial::BeamElements| match b.elements.first() {
            Some(&e) if b.truss => (m.trusses[e].area / std::f64::consts::PI).sqrt(),
            Some(&e) => m.beams[e].section.outer_radius(),
            None => 0.0,
        };
        self.scene.beams.values().map(radius).collect()
    }

    /// Each joint's name, kind and anchors: per side (A, B) its node (`None`: the ground)
    /// and its point, in the node's frame from its origin (the ground's in space, m).
    #[getter]
    #[allow(clippy::type_complexity)] // the tuple Python receives
    fn joint_anchors(&self) -> Vec<(String, &'static str, [Option<usize>; 2], [[f64; 3]; 2])> {
        let point = |v: &nalgebra::Vector3<f64>| [v.x, v.y, v.z];
        (self.scene.model.joints.iter())
            .map(|j| {
                let arms = [point(&j.pair.arms[0]), point(&j.pair.arms[1])];
                (j.name.clone(), j.kind.name(), j.pair.nodes, arms)
            })
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
        spatial_runs::simulate(py, &self.scene, settings, progress, x)
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
        spatial_runs::rigid_trajectory(py, &self.scene, node, settings)
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
        spatial_runs::solve_static(py, &self.scene, settings, x)
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
        spatial_runs::natural_modes(py, &self.scene, (q, lam, t), x, count, parameters)
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
        spatial_runs::sensitivities(
            py,
            &self.scene,
            responses,
            parameters,
            settings,
            equilibrium,
            x,
        )
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
        spatial_runs::time_errors(py, &self.scene, responses, settings, x)
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
        spatial_runs::beam_shares(
            py,
            &self.scene,
            &fine.scene,
            responses,
            fine_responses,
            settings,
            x,
        )
    }
}
