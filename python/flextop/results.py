"""What a run gives back: :class:`Results` of a dynamic run, :class:`StaticResults` of a
static one, :class:`Sensitivities` (responses and their exact gradients), and the
description of the scene they refer to (:class:`Joint`, :class:`Bars`).

A result holds the :class:`~flextop.simulation.Simulation` that made it and reads the scene
through it; this module does not import the simulation. Error estimates come from
:mod:`flextop.discretization`, which makes the companion runs they compare with.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any, Iterator, Mapping, Sequence

import numpy as np

from . import _core
from .discretization import tolerance
from .discretization.refinement import companions_of
from .discretization.tolerance import Discretization
from .errors import SettingsError
from .io import export, saved


@dataclass(frozen=True)
class Joint:
    """A joint of the scene: its ``kind`` (``"clamp"``, ``"pin"``, ``"hinge"``, ``"weld"``,
    ``"prismatic"``, ``"roller"``), node indices (a rigid body's own node for its points; a slider's
    carrier first), the ``range`` of its constraint rows in ``lam`` (the drive row last),
    whether a motion law drives it and when a trapezoidal law stops accelerating, starts
    braking and has done its motion (s; ``None`` for a table or no drive)."""

    name: str
    kind: str
    nodes: tuple[int, ...]
    rows: range
    driven: bool
    drive_phases: tuple[float, float, float] | None = None


@dataclass(frozen=True, eq=False)
class Bars:
    """The scene's bars, one entry per bar in each array: ``name``, end ``nodes``
    ``(n_bars, 2)``, design ``variable`` (−1 for a bar of fixed full density), ``component``
    index into :attr:`Simulation.components`, full-density ``volume`` (m³)."""

    name: tuple[str, ...]
    nodes: np.ndarray
    variable: np.ndarray
    component: np.ndarray
    volume: np.ndarray

    def __len__(self) -> int:
        return len(self.name)


@dataclass(frozen=True, eq=False)
class Sensitivities:
    """Responses and their exact gradients from :meth:`Simulation.run_with_sensitivities`.

    Unpacks as ``f, dfdx = ...``. ``values`` has shape ``(n_r,)``, ``gradients``
    ``(n_r, n_design)``, in the order of ``names``; ``method`` is the method used
    (``"direct"`` or ``"adjoint"``; values only, from :meth:`Simulation.map` with
    ``gradients=False``: ``"none"`` and ``gradients`` ``None``) and ``timings`` the seconds spent in the simulation and
    in the sensitivity analysis. A run made to a tolerance also carries its
    ``discretization`` (where ``discretization.extrapolated``, values and gradients are
    Richardson's extrapolation in the step from its grid and half its steps, and so are the
    ``peaks``) and, per name, the estimated relative ``errors`` of the values and
    ``gradient_errors`` of the gradients (2-norm), and per peak-limited response (a drive's
    torque, a stress) ``peak_errors``: peaks are held to the same tolerance as values. A run with ``local_tol`` holds its
    ``steps``. ``peaks`` holds, per stress or buckling response, the largest point value over
    the motion, beside the mean in ``values`` (runs with gradients only). With scene
    ``parameters`` named, ``parameter_gradients`` has shape ``(n_r, n_parameters)``;
    :meth:`parameter_gradient` reads one.
    """

    names: tuple[str, ...]
    values: np.ndarray
    gradients: np.ndarray | None
    method: str
    timings: dict[str, float]
    discretization: Discretization | None = None
    errors: dict[str, float] = field(default_factory=dict)
    gradient_errors: dict[str, float] = field(default_factory=dict)
    steps: np.ndarray | None = field(default=None, repr=False)
    peaks: dict[str, float] = field(default_factory=dict)
    parameters: tuple[str, ...] = ()
    parameter_gradients: np.ndarray | None = None
    peak_errors: dict[str, float] = field(default_factory=dict)
    time_errors: np.ndarray | None = field(default=None, repr=False)
    """Per response, ``f(h) − f`` to leading order in the step, estimated by the adjoint
    sweep that made the gradients (as :meth:`Simulation.time_errors`); ``None`` where no
    adjoint sweep of a motion made them, or the values are extrapolated."""

    def parameter_gradient(self, response: str, parameter: str) -> float:
        """``∂f/∂p`` of one response with respect to one scene parameter."""
        if self.parameter_gradients is None or parameter not in self.parameters:
            raise SettingsError(f"parameter {parameter!r}: not among those asked for ({', '.join(self.parameters) or 'none'})")
        if response not in self.names:
            raise SettingsError(f"response {response!r}: not among {', '.join(self.names)}")
        return float(self.parameter_gradients[self.names.index(response), self.parameters.index(parameter)])

    def save(self, path: str | os.PathLike) -> Path:
        """Everything these sensitivities hold, to ``path`` (``.npz``), for
        :func:`flextop.load` to give back bit for bit."""
        return saved.write_sensitivities(self, path)

    def __iter__(self) -> Iterator[np.ndarray]:
        return iter((self.values, self.gradients))

    def __getitem__(self, index: int) -> np.ndarray:
        return (self.values, self.gradients)[index]

    def __len__(self) -> int:
        return 2

    def __repr__(self) -> str:
        pairs = ", ".join(f"{n}={v:.6g}" for n, v in zip(self.names, self.values))
        return f"Sensitivities({pairs}; method={self.method!r})"


@dataclass(repr=False)
class _Run:
    """What dynamic and static results share: the run's data and its joint loads."""

    simulation: Any = field(repr=False)
    """The :class:`~flextop.simulation.Simulation` that made it."""
    raw: Mapping[str, Any] = field(repr=False)
    x: np.ndarray | None = None
    settings: dict = field(default_factory=dict, repr=False)
    discretization: Discretization | None = None
    """For a run made to a tolerance: the refinement of the scene and the steps that met it."""
    errors: dict[str, float] = field(default_factory=dict)
    """For a run made to a tolerance: the estimated relative error of each response it met."""
    peak_errors: dict[str, float] = field(default_factory=dict)
    """For a run made to a tolerance: the estimated relative error of the peak of each
    peak-limited response it met (a drive's torque, a stress), held to the same tolerance."""
    companions: tuple[_Run | None, _Run | None, _Run] | None = field(default=None, repr=False)
    """The runs the estimate compares with: half and a quarter of the steps (``None`` for
    statics), and twice the elements per bar on half the steps."""

    @property
    def q(self) -> np.ndarray:
        """Solved coordinates ``q``: displacements and rotations from the reference
        configuration, three per node (``(u, v, φ)``)."""
        return self.raw["q"]

    @property
    def lam(self) -> np.ndarray:
        """Lagrange multipliers ``λ``, one per constraint row."""
        return self.raw["lam"]

    def save(self, path: str | os.PathLike) -> Path:
        """Everything this result holds, to ``path`` (``.npz``; :mod:`flextop.io.saved`), for
        :func:`flextop.load` to give back bit for bit."""
        return saved.write(self, path)

    def __repr__(self) -> str:
        x = ("full density" if self.x is None else "no design variables" if np.size(self.x) == 0
             else f"x in [{np.min(self.x):.3g}, {np.max(self.x):.3g}] ({np.size(self.x)} values)")
        tolerance = f", {self.discretization}" if self.discretization is not None else ""
        return f"{type(self).__name__}({self.simulation.spec.get('name') or 'scene'}: {self._summary()}; {x}{tolerance})"

    def _summary(self) -> str:
        return f"{self.raw['iterations']} Newton iterations"

    @cached_property
    def section_forces(self) -> np.ndarray:
        """Per state and element: the axial force ``N`` (N, tension positive) and the end
        moments ``M₁``, ``M₂`` (N m) in the element's chord frame, with the design's
        stiffness; shape ``(n_states, n_elements, 3)`` (one state for a static result)."""
        q = np.ascontiguousarray(np.atleast_2d(self.q), dtype=float)
        return _core.section_forces(self.simulation.model, self.x, q)

    @cached_property
    def cell_fields(self) -> np.ndarray:
        """Per state and continuum cell: the von Mises stress (Pa; the volume mean over the
        cell's Gauss points of the stress its material carries, ``s(x)`` times the solid's
        at the cell's strain) and the strain energy (J); shape ``(n_states, n_cells, 2)``."""
        q = np.ascontiguousarray(np.atleast_2d(self.q), dtype=float)
        return _core.cell_fields(self.simulation.model, self.x, q)

    @cached_property
    def reactions(self) -> dict[str, np.ndarray]:
        """Per joint, the force (and, for a drive row, torque) it applies on the structure:
        ``−λ`` of its constraint rows."""
        return {j.name: -self.lam[..., j.rows.start:j.rows.stop] for j in self.simulation.joints}

    def _value_and_peak(self, name: str) -> tuple[float, float | None]:
        """The value of response ``name`` on this run's states and its peak (an aggregate's
        largest point value; ``None`` for other responses)."""
        values, peaks = self.values_and_peaks([name])
        return float(values[0]), peaks[0]

    def values_and_peaks(self, names: Sequence[str]) -> tuple[np.ndarray, list[float | None]]:
        """The values of responses ``names`` on this run's states, in one pass, and their
        peaks (an aggregate's largest point value; ``None`` for other responses). A static
        result is one state whose loads act at its ``raw["time"]``; a dynamic one has a
        state per time."""
        time = np.atleast_1d(self.raw["time"])
        times, load_time = (np.zeros(1), float(time[0])) if self.simulation.analysis == "static" else (time, 0.0)
        qdot = getattr(self, "qdot", None)
        kind = self.settings.get("mass") or self.simulation.spec.get("simulation", {}).get("mass")
        given = {"mass": kind, "analysis": self.settings.get("analysis")}
        mass = {k: v for k, v in given.items() if v is not None} or None
        out = _core.evaluate_responses(self.simulation.model, self.x, np.atleast_2d(self.q), np.atleast_2d(self.lam),
                                       list(map(float, times)), load_time, list(names),
                                       None if qdot is None else np.atleast_2d(qdot), mass)
        return np.asarray(out["values"], dtype=float), list(out["peaks"])

    def peak(self, name: str) -> float:
        """The largest point value of an aggregate response (``"stress"``, ``"shear"``,
        ``"buckling"``, …) over this run's states, beside the mean :meth:`response` gives;
        a ``SettingsError`` for a response that is not an aggregate."""
        value = self._value_and_peak(name)[1]
        if value is None:
            raise SettingsError(f"response '{name}' is not an aggregate: it has no peak")
        return float(value)

    def response(self, name: str) -> float:
        """Value of a response of :meth:`Simulation.run_with_sensitivities` (e.g.
        ``"compliance"``; for a static scene ``Fᵀu``) on this run — the same discrete value
        the gradients refer to."""
        return self._value_and_peak(name)[0]

    def error_estimate(self, name: str, *, absolute: bool = False) -> float:
        """The estimated relative error of response ``name`` (any name of
        :meth:`Simulation.run_with_sensitivities`) against the converged discretization, by
        step doubling in time and space (:mod:`flextop.discretization.tolerance`); with
        ``absolute``, the error in the response's own units. A run made to a
        tolerance has its companion runs already; for any other run they are made on the
        first call: its steps merged in pairs and in fours, and twice the elements per bar
        on the steps merged in pairs (a static scene: twice the elements per bar only).
        A response of value 0 with a nonzero estimated error has no relative error: a
        ``SettingsError`` gives the absolute one."""
        half, quarter, split = companions_of(self)
        value = lambda run: None if run is None else [np.array([run.response(name)])]  # noqa: E731
        est = tolerance.estimate(value(self), value(half), value(quarter), value(split))
        if absolute:
            return float(est.total[0])
        if est.size[0] == 0.0 and est.total[0] > 0.0:
            raise SettingsError(f"response '{name}' is 0 on this run, so it has no relative error; its estimated "
                                f"absolute error is {est.total[0]:.3g} (error_estimate('{name}', absolute=True))")
        return float(est.relative[0])



@dataclass(repr=False)
class Results(_Run):
    """Time histories of a dynamic run (one row per time ``t_n``): ``q``, ``qdot``,
    ``qddot``, ``lam``, as the engine and saved files name them.

    ``q`` holds the solved coordinates — displacements and rotations from the reference
    configuration, three per node; :attr:`coordinates` the absolute nodal coordinates
    ``(x, y, φ)`` of the paper.
    """

    def _summary(self) -> str:
        return f"{len(self.time) - 1} steps to t = {self.time[-1]:.6g} s"

    def to_xarray(self) -> Any:
        """The time histories as an ``xarray.Dataset``: ``q`` (displacements and rotation
        from the reference), ``qdot``, ``qddot`` over ``(time, node, coordinate)``
        (coordinates ``x``, ``y``, ``phi``: the components), ``lam`` over ``(time,
        multiplier)`` (``JOINT:ROW``), the energies and step sizes over time, the design
        ``x`` over ``variable``; the scene's name, ``h`` and ``rho_inf`` as attributes."""
        try:
            import xarray as xr
        except ImportError:
            raise SettingsError("to_xarray needs xarray: pip install xarray") from None
        sim, n = self.simulation, len(self.time)
        nodal = ("time", "node", "coordinate")
        data = {k: (nodal, np.asarray(self.raw[k]).reshape(n, -1, 3)) for k in ("q", "qdot", "qddot")}
        data |= {"lam": (("time", "multiplier"), self.raw["lam"]), "steps": ("time", self.raw["steps"])}
        data |= {k: ("time", v) for k, v in self.energies.items()}
        attrs = {"scene": sim.spec.get("name") or "", "h": self.raw["h"], "rho_inf": self.raw["rho_inf"]}
        if self.x is not None:
            data["x"] = ("variable", self.x)
        coords = {"time": self.time, "node": sim.node_names, "coordinate": ["x", "y", "phi"],
                  "multiplier": saved.multiplier_names(sim), "variable": sim.variable_names}
        return xr.Dataset(data, coords=coords, attrs=attrs)

    def to_vtk(self, path: str | os.PathLike, *, every: int | None = None) -> Path:
        """The motion for ParaView: a ``.pvd`` index at ``path`` and a ``.vtu`` file per
        step (every ``every``-th, default about 100 frames, and the last) beside it
        (:mod:`flextop.io.export`)."""
        return export.write_motion(self, path, every=every)

    @property
    def time(self) -> np.ndarray:
        return self.raw["time"]

    @property
    def coordinates(self) -> np.ndarray:
        """Absolute nodal coordinates ``(x, y, φ)`` per node: ``q`` plus the reference."""
        ref = np.zeros(self.q.shape[1])
        ref.reshape(-1, 3)[:, :2] = self.simulation.model.reference_positions
        return self.q + ref

    @property
    def steps(self) -> np.ndarray:
        """The step sizes ``hₙ = tₙ₊₁ − tₙ`` that ran (s)."""
        return self.raw["steps"][1:]

    @property
    def qdot(self) -> np.ndarray:
        """Velocities ``q̇``."""
        return self.raw["qdot"]

    @property
    def qddot(self) -> np.ndarray:
        """Accelerations ``q̈``."""
        return self.raw["qddot"]

    @cached_property
    def positions(self) -> np.ndarray:
        """Node positions, shape ``(n_times, n_nodes, 2)``."""
        return self.coordinates.reshape(len(self.time), -1, 3)[:, :, :2]

    @cached_property
    def rotations(self) -> np.ndarray:
        """Node rotations from the reference, shape ``(n_times, n_nodes)``."""
        return self.q.reshape(len(self.time), -1, 3)[:, :, 2]

    @cached_property
    def motor_torques(self) -> dict[str, np.ndarray]:
        """Per driven joint, the motor torque applied on the driven node (N m): its drive row,
        the last of its reactions."""
        return {j.name: self.reactions[j.name][..., -1] for j in self.simulation.joints if j.driven}

    @property
    def energies(self) -> dict[str, np.ndarray]:
        """Kinetic and strain energy (springs and servos' springs included), the work of the
        drives, of external loads, gravity and motors (a servo's feed), and of the dampers
        (negative: what they dissipated) (J). From an equilibrium start the strain energy
        starts at the equilibrium's; the balance is on the changes."""
        names = ("kinetic", "strain", "drive_work", "external_work", "damping_work")
        return {k: self.raw.get(k, np.zeros_like(self.raw["kinetic"])) for k in names}

    @property
    def newton(self) -> dict[str, Any]:
        """Newton statistics: ``iterations`` per step, ``total``, ``max``, ``mean``."""
        its = np.asarray(self.raw["iterations"][1:])
        return {"iterations": its, "total": int(its.sum()), "max": int(its.max(initial=0)), "mean": float(its.mean()) if its.size else 0.0}

    def tip_error(self, node: int | str | None = None) -> np.ndarray:
        """``e(t) = r(t) − r_rigid(t)`` of ``node`` (the scene's tip by default), ``(n, 2)``."""
        index = self._node(node)
        return self.positions[:, index] - self.simulation.rigid_trajectory(index, self.time)

    def tip_deflection(self, node: int | str | None = None) -> float:
        """Mean squared tip deflection ``d = (1/t_f) ∫ |e|² dt`` (paper Eq. 40, m²), by the
        trapezoidal rule on the step times."""
        if node is None:
            return self.response("tip_deflection")
        name = self.simulation.node_names[node] if isinstance(node, int) else node
        return self.response(f"tip_deflection:{name}")

    def _node(self, node: int | str | None) -> int:
        if node is None:
            if self.simulation.tip is None:
                raise SettingsError("the scene has no `tip`: name a node, e.g. tip_error(\"NODE\")")
            return self.simulation.tip
        return self.simulation.node(node) if isinstance(node, str) else int(node)


@dataclass(repr=False)
class StaticResults(_Run):
    """A static equilibrium."""

    def to_vtk(self, path: str | os.PathLike) -> Path:
        """The deformed structure for ParaView as one ``.vtu`` file (:mod:`flextop.io.export`)."""
        return export.write_state(self, path)

    @property
    def positions(self) -> np.ndarray:
        """Node positions, shape ``(n_nodes, 2)``."""
        return self.simulation.model.reference_positions + self.q.reshape(-1, 3)[:, :2]

    @property
    def newton(self) -> dict[str, Any]:
        return {"total": self.raw["iterations"], "load_steps": self.raw["load_steps"]}

    @property
    def analysis(self) -> str:
        """The static problem solved: ``"linear"`` or ``"nonlinear"`` (the run's setting, or the scene's)."""
        return str(self.settings.get("analysis") or self.simulation.spec.get("simulation", {}).get("analysis", "nonlinear"))

    def displacement(self, node: int | str) -> np.ndarray:
        """Displacement ``(u, v, φ)`` of ``node``."""
        index = self.simulation.node(node) if isinstance(node, str) else int(node)
        return self.q[3 * index:3 * index + 3]
