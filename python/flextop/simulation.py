"""Running a scene: :class:`Simulation` and its :class:`Results`.

``Simulation(scene).run(x)`` integrates a dynamic scene with generalized-α (paper
Algorithm 1) or solves a static one, for the design ``x`` (one density per design
variable, ``None`` for full density). The engine releases the GIL while it runs.
"""

from __future__ import annotations

import copy
import json
import math
import os
import threading
import warnings
from collections import OrderedDict
from concurrent.futures import Executor
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path
from typing import Any, Iterable, Iterator, Mapping, Sequence, Union

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from . import _core, execution, export, modal, responses, saved, tolerance
from .accuracy import preset, split_by
from .errors import (DesignError, MechanismWarning, PlausibilityWarning, SceneError, SettingsError, SettingsWarning,
                     SimulationError)
from .scene import Scene
from .tolerance import Discretization, ErrorEstimate


DesignLike = Union[float, Sequence[float], "npt.NDArray[np.floating]", None]
"""A design: one density for every variable, a vector of one per variable, or ``None``
(full density). Strings and complex numbers are refused (:class:`DesignError`)."""

ENERGY_CREATED = 0.05
"""Share of the largest energy or work of a run that its kinetic plus strain energy may
exceed the work done on it before :class:`PlausibilityWarning` (generalized-α only
dissipates; the trapezoidal work differs by O(h²): 7e-4 at the arm's coarsest step)."""


ENERGY_ROUND_OFF = 1e-15
"""Energy and work (J) below which a run's book is round-off (a mechanism at rest on its
supports): no warning there."""


def _warn_if_energy_created(res: Results) -> None:
    e = res.energies
    energy, work = e["kinetic"] + e["strain"], e["drive_work"] + e["external_work"] + e["damping_work"]
    scale = max(np.abs(work).max(initial=0.0), np.abs(energy).max(initial=0.0))
    excess = energy - energy[0] - work  # at least the initial state: never empty
    k = int(np.argmax(excess))
    if excess[k] > ENERGY_CREATED * scale > ENERGY_ROUND_OFF:
        warnings.warn(PlausibilityWarning(
            f"the run created energy: at t = {res.time[k]:.4g} s kinetic plus strain energy is {energy[k]:.4g} J "
            f"({energy[0]:.4g} J at the start), the work done "
            f"{work[k]:.4g} J ({excess[k] / scale:.1%} of the largest); use a smaller step h"), stacklevel=3)


def _warn_if_over_constrained(mechanism: dict[str, Any]) -> None:
    """A :class:`MechanismWarning` naming the joints that over-constrain the rigid mechanism."""
    if mechanism["redundant_rows"]:
        names = ", ".join(f"'{n}'" for n in mechanism["over_constraining"])
        warnings.warn(f"the joints {names} over-constrain the rigid mechanism ({mechanism['redundant_rows']} redundant row(s)): "
                      "the flexible model runs, but the rigid motion (and the tip deflection, Eq. 40) exists only where "
                      "the redundant constraints agree", MechanismWarning, stacklevel=3)


def _warn_if_step_shortened(asked: float | None, used: float) -> None:
    """A :class:`SettingsWarning` when the step used is more than 1 % below the one asked
    for (shortened so that a whole number of steps ends at ``t_end``)."""
    if asked and used < 0.99 * asked:
        warnings.warn(f"h = {asked:g} s was shortened to {used:.6g} s so that a whole number of steps ends at t_end",
                      SettingsWarning, stacklevel=4)


def _warn_if_implausible_static(res: StaticResults) -> None:
    compliance = res.response("compliance")
    if compliance < 0:
        warnings.warn(PlausibilityWarning(
            f"negative compliance F^T u = {compliance:.4g} J under dead loads: the equilibrium found is on another branch; "
            "use more load steps"), stacklevel=3)


def _as_spec(scene: Scene | dict | str | os.PathLike) -> dict:
    if isinstance(scene, Scene):
        return scene.to_dict()
    if isinstance(scene, dict):
        return scene
    return Scene.from_toml(Path(scene)).to_dict()


@dataclass(frozen=True)
class Joint:
    """A joint of the scene: its ``kind`` (``"clamp"``, ``"pin"``, ``"hinge"``, ``"weld"``,
    ``"prismatic"``), node indices (a rigid body's own node for its points; a slider's
    carrier first), the ``range`` of its constraint rows in ``lam`` (the drive row last)
    and whether a motion law drives it."""

    name: str
    kind: str
    nodes: tuple[int, ...]
    rows: range
    driven: bool


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
    ``discretization`` and, per name, the estimated relative ``errors`` of the values and
    ``gradient_errors`` of the gradients (2-norm). A run with ``local_tol`` holds its
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

    def parameter_gradient(self, response: str, parameter: str) -> float:
        """``∂f/∂p`` of one response with respect to one scene parameter."""
        if self.parameter_gradients is None or parameter not in self.parameters:
            raise SettingsError(f"parameter {parameter!r}: not among those asked for ({', '.join(self.parameters) or 'none'})")
        if response not in self.names:
            raise SettingsError(f"response {response!r}: not among {', '.join(self.names)}")
        return float(self.parameter_gradients[self.names.index(response), self.parameters.index(parameter)])

    def __iter__(self) -> Iterator[np.ndarray]:
        return iter((self.values, self.gradients))

    def __getitem__(self, index: int) -> np.ndarray:
        return (self.values, self.gradients)[index]

    def __len__(self) -> int:
        return 2

    def __repr__(self) -> str:
        pairs = ", ".join(f"{n}={v:.6g}" for n, v in zip(self.names, self.values))
        return f"Sensitivities({pairs}; method={self.method!r})"


class Simulation:
    """A validated scene, ready to run for any design.

    Parameters
    ----------
    scene:
        A :class:`Scene`, a scene dict, or the path of a TOML scene file.
    accuracy:
        ``"fast"``, ``"balanced"`` or ``"accurate"``: a named ``rtol`` (3e-2, 1e-2, 3e-3;
        :mod:`flextop.accuracy`).
    rtol, atol:
        A tolerance on the responses (relative, and absolute in their units): runs without
        an explicit ``h`` then choose the elements per bar and the step so that the
        estimated error of every response asked for is at most ``rtol·|f| + atol``
        (:mod:`flextop.tolerance`). Each run may also pass its own.

    Raises
    ------
    SceneError
        If the scene cannot be built; the message names the entry.
    SettingsError
        If ``rtol`` is not in (0, 1), ``atol`` is negative, ``accuracy`` is not a preset's
        name, or both ``accuracy`` and ``rtol`` are given.
    """

    def __init__(self, scene: Scene | dict | str | os.PathLike, *, accuracy: str | None = None, rtol: float | None = None,
                 atol: float = 0.0) -> None:
        spec = _as_spec(scene)
        try:
            self.spec = copy.deepcopy(spec)
        except RecursionError:
            raise SceneError("scene: nested too deeply to be a scene") from None
        self.accuracy = accuracy
        if accuracy is not None:
            if rtol is not None:
                raise SettingsError("give accuracy (a named tolerance) or rtol, not both")
            rtol = preset(accuracy)
        if rtol is not None:
            tolerance.check_tolerance(rtol, atol)
        self.rtol, self.atol = rtol, atol
        self._levels: dict[int, Simulation] = {1: self}
        self.model = _core.Model.from_dict(spec)
        raw = self.model.bars()
        self.bars = Bars(tuple(raw["name"]), np.asarray(raw["nodes"], dtype=int), np.asarray(raw["variable"], dtype=int),
                         np.asarray(raw["component"], dtype=int), np.asarray(raw["volume"]))
        self.joints = tuple(Joint(j["name"], j["kind"], tuple(j["nodes"]), range(*j["rows"]), j["driven"]) for j in self.model.joints())
        if self.analysis == "dynamic":  # a static structure may well be indeterminate
            _warn_if_over_constrained(self.mechanism)

    def bar_densities(self, x: DesignLike = None) -> np.ndarray:
        """The density of every bar for design ``x`` (``None``: full density); bars that are
        not designed (variable −1) are at 1."""
        xv = self._design(x)
        variable = np.asarray(self.bars.variable, dtype=int)
        if xv is None:
            return np.ones(variable.size)
        return np.where(variable >= 0, xv[np.maximum(variable, 0)] if xv.size else 1.0, 1.0)

    @cached_property
    def mechanism(self) -> dict[str, Any]:
        """The rigid mechanism behind the flexible one: ``frames`` (rigid clusters),
        ``mobility`` (rigid-body modes the joints leave free), ``redundant_rows`` and the
        ``over_constraining`` joints' names when the joints over-constrain it."""
        return dict(self.model.mechanism())

    @property
    def options(self) -> dict[str, Any]:
        """The keyword arguments that rebuild this Simulation from its scene: ``accuracy``,
        or ``rtol``, and ``atol``."""
        return {"accuracy": self.accuracy, "rtol": None if self.accuracy else self.rtol, "atol": self.atol}

    # -- description --------------------------------------------------------------------

    @property
    def analysis(self) -> str:
        """``"dynamic"`` or ``"static"``."""
        return self.model.analysis

    @property
    def n_design(self) -> int:
        """Number of design variables."""
        return self.model.n_design

    @property
    def x_min(self) -> float:
        """Lower bound on densities."""
        return self.model.x_min

    @property
    def node_names(self) -> list[str]:
        return self.model.node_names

    @property
    def variable_names(self) -> list[str]:
        return self.model.variable_names

    @property
    def components(self) -> list[str]:
        return self.model.components

    @property
    def tip(self) -> int | None:
        """Index of the scene's tip node."""
        return self.model.tip

    def node(self, name: str) -> int:
        """Index of the node called ``name``."""
        try:
            return self.model.node_names.index(name)
        except ValueError:
            raise KeyError(f"no node named {name!r}") from None

    # -- runs ---------------------------------------------------------------------------

    def run(self, x: DesignLike = None, *, rtol: float | None = None, atol: float | None = None, responses: Sequence[str] | str | None = None,
            local_tol: float | None = None, t_end: float | None = None, h: float | None = None, rho_inf: float | None = None,
            tol: float | None = None, max_iter: int | None = None, newton: str | None = None, mass: str | None = None,
            load_steps: int | None = None) -> Results | StaticResults:
        """Runs the scene for design ``x`` (``None``: every bar at full density).

        Dynamic scenes integrate to ``t_end`` with step ``h`` — at most ``t_end``, and
        shortened, if needed, so that a whole number of steps ends exactly at ``t_end``;
        ``results.raw["h"]`` is the step used — and spectral radius ``rho_inf`` (defaults from the scene's ``[simulation]``
        table, ``rho_inf`` 0.8);
        ``tol`` is the relative Newton tolerance (1e-10), ``max_iter`` the iterations per
        step (20), ``newton`` ``"full"`` (a new iteration matrix every iteration) or
        ``"modified"`` (the step's first kept while the residual falls tenfold per
        iteration: the same solution to ``tol``, 12–26 % faster on the arm's designs
        measured, BENCHMARKS.md), ``mass``
        ``"consistent"`` or ``"lumped"``. Static scenes solve the
        equilibrium with ``load_steps`` initial load increments.

        With a tolerance (``rtol`` here or on the :class:`Simulation`) and no ``h``, the
        elements per bar and the step are chosen so that the estimated error of
        ``responses`` (default: ``tip_deflection`` if the scene has a tip, else
        ``compliance``) is at most ``rtol·|f| + atol``; the results then come from the
        refined scene and tell their ``discretization``.

        With ``local_tol`` instead, the steps vary: local error control of generalized-α
        (the position error of each step against ``local_tol`` times the model's size, and
        ``local_tol`` rad), starting from ``h``, ending exactly at every kink of the motion
        laws and at ``t_end``; ``results.steps`` holds them. On the reference scenes it
        needs as many steps as uniform steps for the same error of d, or more (x = 0.4 arm;
        BENCHMARKS.md); it is meant for motions whose difficulty varies in time.

        Raises ``DesignError``, ``SettingsError``, ``SimulationError`` (with the time,
        residual and iteration count of a failed Newton step) or ``ToleranceError``.
        """
        xv = self._design(x)
        given = {"t_end": t_end, "tol": tol, "max_iter": max_iter, "newton": newton}
        given |= {"load_steps": load_steps} if self.analysis == "static" else {"h": h, "rho_inf": rho_inf, "mass": mass}
        settings = self._settings(**given)
        if local_tol is not None:
            if rtol is not None or self.analysis == "static":
                raise SettingsError("local_tol applies to a dynamic run without rtol")
            return self._fixed(xv, settings, local_tol=local_tol)
        wanted = self._tolerance(rtol, atol, h)
        if wanted is None:
            return self._fixed(xv, settings)
        names = [responses] if isinstance(responses, str) else list(responses or [self._default_response()])
        return self._to_tolerance(xv, names, wanted, settings, None)

    def simulate(self, x: DesignLike = None, **options: Any) -> Results:
        """:meth:`run` of a dynamic scene, typed as its :class:`Results` (``options`` as in
        :meth:`run`); a static scene is a :class:`SettingsError`."""
        if self.analysis != "dynamic":
            raise SettingsError(f"{self.spec.get('name') or 'the scene'} is static: use equilibrium(), or run()")
        res = self.run(x, **options)
        assert isinstance(res, Results)
        return res

    def equilibrium(self, x: DesignLike = None, **options: Any) -> StaticResults:
        """:meth:`run` of a static scene, typed as its :class:`StaticResults`; a dynamic
        scene is a :class:`SettingsError`."""
        if self.analysis != "static":
            raise SettingsError(f"{self.spec.get('name') or 'the scene'} is dynamic: use simulate(), or run()")
        res = self.run(x, **options)
        assert isinstance(res, StaticResults)
        return res

    def _fixed(self, xv: np.ndarray | None, settings: dict[str, Any], *, local_tol: float | None = None,
               steps: np.ndarray | None = None, guide: np.ndarray | None = None) -> Results | StaticResults:
        """One run on the scene as it is: uniform steps, the given ``steps``, or steps chosen
        to ``local_tol``; Newton starts each step from ``guide`` (a nearby run's ``q`` at
        the same times) when given."""
        if self.analysis == "static":
            static = StaticResults(self, _core.solve_static(self.model, xv, settings), xv, settings)
            _warn_if_implausible_static(static)
            return static
        raw = _core.simulate(self.model, xv, settings, local_tol, None if steps is None else [float(h) for h in steps], guide)
        res = Results(self, raw, xv, settings)
        _warn_if_energy_created(res)
        if steps is None and local_tol is None:
            _warn_if_step_shortened(settings.get("h") or self.spec.get("simulation", {}).get("h"), raw["h"])
        return res

    def _settings(self, **given: Any) -> dict[str, Any]:
        """The run settings given explicitly."""
        return {k: v for k, v in given.items() if v is not None}

    def run_with_sensitivities(self, x: DesignLike, responses: Sequence[str] | str = ("tip_deflection",), *,
                               method: str = "auto", memory: str = "auto", rtol: float | None = None, atol: float | None = None,
                               start: Discretization | None = None, hold_gradients: bool = True, local_tol: float | None = None,
                               parameters: Sequence[str] = (), **settings: Any) -> Sensitivities:
        """Responses ``f`` (shape ``(n_r,)``) and their exact gradients ``df/dx``
        (``(n_r, n_design)``) for design ``x``, as a :class:`Sensitivities` that unpacks as
        ``f, dfdx``.

        Responses, by name (``flextop.responses.KINDS``, read from the engine):

{responses}

        Means over the motion stay below the peak, which the result holds in ``peaks``.
        Time integrals use the trapezoidal rule on the step times, and the gradients are
        those of that discrete value.

        ``parameters`` names scene parameters whose gradients come too, by the same direct
        or adjoint sweep, in ``parameter_gradients``: ``"k:SPRING"``, ``"c:SPRING"``,
        ``"length:SPRING"`` (between points) or ``"rest:SPRING"`` (on a joint),
        ``"mass:BODY"`` / ``"inertia:BODY"`` (a rigid body's, or a point mass's by its node),
        ``"torque:MOTOR"``, ``"kp:MOTOR"``, ``"kd:MOTOR"``, ``"E:SECTION"``,
        ``"rho:SECTION"``, ``"diameter:SECTION"``, ``"alpha:SECTION"``, ``"beta:SECTION"``
        (Rayleigh damping), a trapezoidal drive's ``"end:JOINT"``, ``"acceleration:JOINT"``
        and ``"speed:JOINT"``, and ``"arm_x:BODY.POINT"`` / ``"arm_y:BODY.POINT"`` for a
        point held to the ground by its joints, in the body's frame (the pin moves with it). Their gradients are exact for the grid that ran; a run to a tolerance does
        not estimate their error.

        ``method``: ``"direct"`` (Algorithm 2; cost grows with the number of variables),
        ``"adjoint"`` (cost independent of it) or ``"auto"`` (adjoint when there are fewer
        responses than variables). ``memory`` (adjoint): ``"store"`` keeps every step's
        state, ``"checkpoints"`` keeps full states every ⌈√N⌉ steps and replays segments
        backwards (memory O(√N), one more forward sweep), ``"auto"`` checkpoints past 512 MiB.
        ``settings`` are those of :meth:`run`. The result tells the method used and the
        seconds spent in the simulation and in the sensitivity analysis.

        With a tolerance (``rtol``, as in :meth:`run`) the discretization is chosen for
        every response named, starting from ``start`` (default: the scene's own), and the
        gradients are exact for the grid that ran; the result carries the
        ``discretization`` and the estimated relative ``errors`` of the values. The gradients
        are held to ``5·rtol`` in the relative 2-norm (``tolerance.GRADIENT_FACTOR``), and
        their estimated errors are in ``gradient_errors``; every companion run then computes
        gradients too. With ``hold_gradients=False`` the discretization is chosen on the
        values alone (companions run without gradients) and the gradients are the exact
        derivatives of those values on the grid accepted, their error not estimated. With ``local_tol`` (as in :meth:`run`) the steps are chosen by local
        error control, then frozen: the gradients are exact for the steps that ran, which
        the result holds in ``steps``.
        """
        names = [responses] if isinstance(responses, str) else list(responses)
        xv = self._design(x)
        if xv is None:
            raise DesignError("run_with_sensitivities needs a design vector x")
        asked = [parameters] if isinstance(parameters, str) else [str(p) for p in parameters]
        gradients: dict[str, Any] = {"method": method, "memory": memory, "parameters": asked}
        if local_tol is not None:
            if rtol is not None or self.analysis == "static":
                raise SettingsError("local_tol applies to a dynamic run without rtol")
            steps = self._fixed(xv, self._settings(**settings), local_tol=local_tol).steps
            return self._sensitivities(xv, names, self._settings(**gradients, **settings), steps)
        wanted = self._tolerance(rtol, atol, settings.get("h"))
        if wanted is None:
            return self._sensitivities(xv, names, self._settings(**gradients, **settings))
        return self._to_tolerance(xv, names, wanted, self._settings(**settings), gradients, start, hold_gradients)

    def map(self, designs: Iterable[DesignLike], responses: Sequence[str] | str | None = None, *, gradients: bool = True,
            executor: Executor | None = None, chunksize: int = 1, **options: Any) -> list[Sensitivities]:
        """``responses`` (default: the tip deflection, or the compliance) at each of
        ``designs``, in their order, for parameter studies and multi-starts: with exact
        gradients (``options`` as in :meth:`run_with_sensitivities`) or, with
        ``gradients=False``, values only (``options`` as in :meth:`run`; ``gradients`` of
        each result ``None``). The runs go to ``executor`` (any
        :class:`concurrent.futures.Executor`, a Dask client's ``get_executor()``; ``None``:
        here, in turn), each as the scene and one design (:mod:`flextop.execution`),
        ``chunksize`` runs to a task; the results are the same bits whatever the executor.
        A run that fails raises its error with ``design K:`` in front."""
        names = (responses,) if isinstance(responses, str) else tuple(responses or (self._default_response(),))
        vectors = self._designs(designs)
        remember(self)
        tasks = [(f"design {k}", Task(self.spec, x, names, gradients, options, self.options)) for k, x in enumerate(vectors)]
        return execution.run_all(perform, tasks, executor, chunksize=chunksize)

    def _sensitivities(self, xv: np.ndarray, names: list[str], settings: dict[str, Any], steps: np.ndarray | None = None) -> Sensitivities:
        grid = None if steps is None else [float(h) for h in steps]
        settings = dict(settings)
        parameters = settings.pop("parameters", [])
        out = _core.run_with_sensitivities(self.model, xv, names, settings, grid, parameters)
        timings = {"simulation": out["simulation_seconds"], "gradients": out["gradient_seconds"]}
        peaks = {n: p for n, p in zip(names, out["peaks"]) if p is not None}
        return Sensitivities(tuple(names), out["values"], out["gradients"], out["method"], timings, steps=steps, peaks=peaks,
                             parameters=tuple(parameters), parameter_gradients=out["parameter_gradients"])

    # -- runs to a tolerance ------------------------------------------------------------

    def _tolerance(self, rtol: float | None, atol: float | None, h: float | None) -> tuple[float, float] | None:
        """The tolerance a run is made to, or ``None`` for a fixed-step run: an explicit
        ``h`` wins over the Simulation's tolerance, and cannot be given with a run's own."""
        if h is not None and rtol is not None:
            raise SettingsError("give h (a fixed step) or rtol (steps chosen to meet it), not both")
        if h is not None or (rtol is None and self.rtol is None):
            return None
        rtol = self.rtol if rtol is None else rtol
        atol = self.atol if atol is None else atol
        tolerance.check_tolerance(rtol, atol)
        return rtol, atol

    def _default_response(self) -> str:
        return "tip_deflection" if self.tip is not None and self.analysis == "dynamic" else "compliance"

    def _first(self, settings: dict[str, Any]) -> Discretization:
        """The scene's own discretization: its elements per bar and step (16 steps if the
        scene gives none)."""
        if self.analysis == "static":
            return Discretization(1, 0)
        t_end = self._t_end(settings)
        h = self.spec.get("simulation", {}).get("h") or t_end / 16
        if not (isinstance(h, (int, float)) and math.isfinite(h) and 0 < h <= t_end):
            raise SettingsError(f"simulation.h: must be a step in (0, t_end], got {h!r}")
        return tolerance.start(math.ceil(t_end / h - 1e-9))

    def _t_end(self, settings: dict[str, Any]) -> float:
        t_end = settings.get("t_end") or self.spec.get("simulation", {}).get("t_end")
        if t_end is None:
            raise SettingsError("t_end: give it in the scene's [simulation] table or to the run")
        if not (isinstance(t_end, (int, float)) and math.isfinite(t_end) and t_end > 0):
            raise SettingsError(f"t_end: must be a positive number of seconds, got {t_end!r}")
        return float(t_end)

    def _level(self, refinement: int) -> Simulation:
        """This scene with ``refinement`` times its elements per bar."""
        if refinement not in self._levels:
            self._levels[refinement] = Simulation(split_by(self.spec, refinement))
        return self._levels[refinement]

    def _companion(self, refinement: int, xv: np.ndarray | None, settings: dict[str, Any], plain: dict[str, Any],
                   coarse: _Run | None, steps: np.ndarray | None = None) -> Results | StaticResults:
        """A companion run of step doubling at ``refinement`` with ``settings``, each step's
        Newton started from the states of ``coarse`` (a run at half the refinement on the
        same steps) carried over, each element's middle node on its cubic shape. Where that
        fails, the run with ``plain`` settings and no guide decides: a guide or a kept
        matrix that led Newton astray must not pass for a model that cannot run."""
        level = self._level(refinement)
        guide = None if coarse is None else _core.prolong(self._level(refinement // 2).model, level.model, coarse.q)
        try:
            return level._fixed(xv, settings, steps=steps, guide=guide)
        except SimulationError:
            if guide is None and plain == settings:
                raise
            return level._fixed(xv, plain, steps=steps)

    def _to_tolerance(self, xv: np.ndarray | None, names: list[str], wanted: tuple[float, float], settings: dict[str, Any],
                      gradients: dict[str, str] | None, first: Discretization | None = None, hold_gradients: bool = True) -> Any:
        """Runs until :func:`tolerance.resolve` accepts a candidate; returns the candidate's
        results (or sensitivities) with its estimate and companions attached. With
        ``gradients`` but not ``hold_gradients``, candidates are judged on forward runs and
        the sensitivities are computed once, on the grid accepted. Companion runs stop
        Newton at :func:`tolerance.companion_newton_tol` (unless the run's ``tol`` is
        given), and reuse any run made at their discretization; a candidate reuses only a
        candidate's run."""
        t_end = None if self.analysis == "static" else self._t_end(settings)
        runs: dict[tuple[Discretization, bool], Any] = {}
        judged = gradients if hold_gradients else None
        loose = {"tol": tolerance.companion_newton_tol(wanted[0]), "newton": "modified"}
        loose = {k: v for k, v in loose.items() if k not in settings}

        def run(d: Discretization, gradients: dict[str, str] | None, companion: bool = False) -> Any:
            level = self._level(d.refinement)
            at = {**settings, **({"h": t_end / d.steps, "t_end": t_end} if d.steps else {}), **(loose if companion else {})}
            if gradients:
                return level._sensitivities(xv, names, {**at, **gradients})
            if not companion:
                return level._fixed(xv, at)
            coarse = made(Discretization(d.refinement // 2, d.steps)) if d.steps and d.refinement % 2 == 0 else None
            plain = {k: v for k, v in at.items() if k != "newton" or "newton" in settings}
            return self._companion(d.refinement, xv, at, plain, coarse)

        def made(d: Discretization, companion: bool = True) -> Any:
            return runs.get((d, False)) or (runs.get((d, True)) if companion else None)

        def values(d: Discretization, companion: bool) -> list[np.ndarray]:
            out = made(d, companion)
            if out is None:
                out = runs[(d, companion)] = run(d, judged, companion)
            if isinstance(out, Sensitivities):
                return [*out.values[:, None], *out.gradients]
            return [np.array([out.response(n)]) for n in names]

        d, est = tolerance.resolve(values, first or self._first(settings), tolerance.tolerance_of(names, *wanted, judged is not None))
        relative = est.relative
        errors = dict(zip(names, map(float, relative)))
        if gradients:
            out = runs[(d, False)] if hold_gradients else run(d, gradients)
            return replace(out, discretization=d, errors=errors, gradient_errors=dict(zip(names, map(float, relative[len(names):]))))
        out = runs[(d, False)]
        out.discretization, out.errors = d, errors
        out.companions = (made(d.half_steps), made(d.quarter_steps), made(d.split)) if d.steps else (None, None, made(d.split))
        return out

    def as_built(self, x: DesignLike, threshold: float | None = None) -> tuple[Simulation, np.ndarray]:
        """The design ``x`` as it would be built: its void bars removed.

        Bars of ground structures whose density is at most ``threshold`` (default: at
        ``x_min``) are left out of the scene, with the grid nodes only they touched; the
        rest keep their names, densities and the scene's material law. Returns the new
        :class:`Simulation` (same tolerance) and its design vector, so that a final
        design can be judged without void bars, e.g. on a refined discretization. Raises
        ``SceneError`` if what remains is not a mechanism (a joint's node was removed, a
        frame falls apart).
        """
        xv = self._design(x)
        if xv is None:
            raise DesignError(f"as_built needs a design vector of {self.n_design} densities")
        limit = self.x_min * (1.0 + 1e-9) if threshold is None else float(threshold)
        void = {name for name, v in zip(self.bars.name, self.bars.variable) if v >= 0 and xv[v] <= limit}
        spec = copy.deepcopy(self.spec)
        for g in spec.get("ground_structures", []):
            prefix = f"{g['name']}/bar"
            omit = set(g.get("omit", [])) | {int(n[len(prefix):]) for n in void if n.startswith(prefix) and n[len(prefix):].isdigit()}
            g["omit"] = sorted(omit)
        built = Simulation(spec, rtol=self.rtol, atol=self.atol)
        index = {name: k for k, name in enumerate(self.variable_names)}
        return built, np.array([xv[index[name]] for name in built.variable_names])

    def _designs(self, designs: Iterable[DesignLike]) -> list[np.ndarray | None]:
        """Each of ``designs`` as :meth:`_design` makes it; a bad one is named by its index."""
        out = []
        for k, x in enumerate(designs):
            try:
                out.append(self._design(x))
            except DesignError as error:
                raise DesignError(f"design {k}: {error}") from None
        return out

    def _design(self, x: Any) -> np.ndarray | None:
        """``x`` as a vector of floats: a number means every variable; strings, complex
        numbers, arrays of more than one dimension and vectors of another length are refused
        with a DesignError (values outside ``[x_min, 1]`` by the engine)."""
        if x is None:
            return None
        xv = np.asarray(x)
        if xv.dtype.kind not in "biuf":
            raise DesignError(f"the design must be real numbers, got {type(x).__name__} of {xv.dtype}")
        if xv.ndim > 1:
            raise DesignError(f"the design must be one number or a vector of {self.n_design}, got an array of shape {xv.shape}")
        xv = xv.astype(float)
        if xv.ndim == 0:
            return np.full(self.n_design, float(xv))
        if xv.shape != (self.n_design,):
            raise DesignError(f"the design has {xv.size} entries; the scene has {self.n_design} design variables")
        return np.ascontiguousarray(xv)

    def linearize(self, x: Any = None, q: Any = None, *, mass: str | None = None) -> tuple[sp.csc_matrix, sp.csc_matrix, sp.csc_matrix]:
        """Mass ``M``, tangent stiffness ``K_t(q)`` (at the reference state by default) and
        constraint Jacobian ``G = Φ_q`` as scipy sparse matrices."""
        qv = None if q is None else np.ascontiguousarray(q, dtype=float)
        raw = _core.linearize(self.model, self._design(x), qv, self._settings(mass=mass))
        return tuple(sp.csc_matrix((m["data"], m["indices"], m["indptr"]), shape=m["shape"]) for m in (raw[k] for k in ("M", "K", "G")))

    def modes(self, n: int = 6, x: Any = None, *, rtol: float | None = 1e-3, mass: str | None = None) -> modal.Modes:
        """The ``n`` lowest natural modes of the structure at rest with its drives locked:
        frequencies (Hz), their exact design gradients, error estimates and the Sturm
        proof that none was skipped (:class:`flextop.modal.Modes`). With ``rtol`` they
        meet that relative tolerance against the converged structure (bars refined for the
        eigen-analysis, whatever this scene's elements per bar); ``rtol=None`` gives the
        modes of the model as meshed."""
        levels = lambda r: (self if r == 1 else self._level(r)).model  # noqa: E731
        return modal.natural_modes(levels, n, self._design(x), rtol, self._settings(mass=mass))

    def natural_frequencies(self, n: int = 3, x: Any = None, *, rtol: float | None = 1e-3, mass: str | None = None) -> np.ndarray:
        """The ``n`` lowest natural frequencies (Hz) of the structure at rest with its drives
        locked, to ``rtol`` against the converged structure (see :meth:`modes`)."""
        return self.modes(n, x, rtol=rtol, mass=mass).frequencies

    def rigid_positions(self, times: Any) -> np.ndarray:
        """Positions (m) of every node at ``times`` when every frame is rigid and the joints
        follow their drives, shape ``(len(times), n_nodes, 2)``."""
        return _core.rigid_positions(self.model, [float(t) for t in np.atleast_1d(times)])

    def rigid_trajectory(self, node: int | str, times: Any) -> np.ndarray:
        """Position (m) of ``node`` at ``times`` when every frame is rigid and the joints
        follow their drives: the ``r_rigid`` of paper Eq. 40."""
        index = self.node(node) if isinstance(node, str) else int(node)
        if not 0 <= index < len(self.node_names):
            raise IndexError(f"node index {index} out of range")
        return self.rigid_positions(times)[:, index]

Simulation.run_with_sensitivities.__doc__ = (Simulation.run_with_sensitivities.__doc__ or "").replace(
    "{responses}", responses.describe(indent=" " * 8))

CACHED_SCENES = 64
"""Scenes whose :class:`Simulation` a process keeps for its tasks, the least recently used
dropped first."""

_simulations: OrderedDict[str, Simulation] = OrderedDict()
_simulations_lock = threading.Lock()


@dataclass(frozen=True)
class Task:
    """One run in plain data, for :func:`perform` in any process: ``responses`` of
    ``scene`` (a scene dict) at design ``x``, with gradients (``options`` of
    :meth:`Simulation.run_with_sensitivities`) or without (``options`` of
    :meth:`Simulation.run`); ``simulation`` holds the Simulation's own ``accuracy``,
    ``rtol`` and ``atol``."""

    scene: dict
    x: np.ndarray | None
    responses: tuple[str, ...]
    gradients: bool = True
    options: dict[str, Any] = field(default_factory=dict)
    simulation: dict[str, Any] = field(default_factory=dict)


def perform(task: Task) -> Sensitivities:
    """Runs ``task`` on this process's :class:`Simulation` of its scene, built on first use."""
    sim = _cached(task.scene, task.simulation)
    if task.gradients:
        return sim.run_with_sensitivities(task.x, task.responses, **task.options)
    res = sim.run(task.x, responses=task.responses, **task.options)
    values = np.array([res.response(name) for name in task.responses])
    return Sensitivities(task.responses, values, None, "none", {}, res.discretization, dict(res.errors))


def _key(scene: dict, options: dict[str, Any]) -> str:
    return json.dumps([scene, options], sort_keys=True, default=float)


def _cached(scene: dict, options: dict[str, Any], sim: Simulation | None = None) -> Simulation:
    """This process's Simulation of ``scene`` and ``options`` (``sim`` itself if given),
    kept for the next task; safe from several threads."""
    key = _key(scene, options)
    with _simulations_lock:
        if sim is not None:
            _simulations[key] = sim
        found = _simulations.get(key)
    if found is None:
        found = Simulation(scene, **options)
    with _simulations_lock:
        found = _simulations.setdefault(key, found)
        _simulations.move_to_end(key)
        while len(_simulations) > CACHED_SCENES:
            _simulations.popitem(last=False)
    return found


def remember(sim: Simulation) -> None:
    """Lets this process's tasks on ``sim``'s scene and options run on ``sim`` itself."""
    _cached(sim.spec, sim.options, sim)


@dataclass(repr=False)
class _Run:
    """What dynamic and static results share: the run's data and its joint loads."""

    simulation: Simulation = field(repr=False)
    raw: Mapping[str, Any] = field(repr=False)
    x: np.ndarray | None = None
    settings: dict = field(default_factory=dict, repr=False)
    discretization: Discretization | None = None
    """For a run made to a tolerance: the refinement of the scene and the steps that met it."""
    errors: dict[str, float] = field(default_factory=dict)
    """For a run made to a tolerance: the estimated relative error of each response it met."""
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
        """Everything this result holds, to ``path`` (``.npz``; :mod:`flextop.saved`), for
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
    def reactions(self) -> dict[str, np.ndarray]:
        """Per joint, the force (and, for a drive row, torque) it applies on the structure:
        ``−λ`` of its constraint rows."""
        return {j.name: -self.lam[..., j.rows.start:j.rows.stop] for j in self.simulation.joints}

    def _value_and_peak(self, name: str) -> tuple[float, float | None]:
        """The value of response ``name`` on this run's states and its peak (an aggregate's
        largest point value; ``None`` for other responses). A static result is one state
        whose loads act at its ``raw["time"]``; a dynamic one has a state per time."""
        time = np.atleast_1d(self.raw["time"])
        times, load_time = (np.zeros(1), float(time[0])) if self.simulation.analysis == "static" else (time, 0.0)
        qdot = getattr(self, "qdot", None)
        kind = self.settings.get("mass") or self.simulation.spec.get("simulation", {}).get("mass")
        mass = {"mass": kind} if kind else None
        out = _core.evaluate_responses(self.simulation.model, self.x, np.atleast_2d(self.q), np.atleast_2d(self.lam),
                                       list(map(float, times)), load_time, [name],
                                       None if qdot is None else np.atleast_2d(qdot), mass)
        return float(out["values"][0]), out["peaks"][0]

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

    def error_estimate(self, name: str) -> float:
        """The estimated relative error of response ``name`` (any name of
        :meth:`Simulation.run_with_sensitivities`) against the converged discretization, by
        step doubling in time and space (:mod:`flextop.tolerance`). A run made to a
        tolerance has its companion runs already; for any other run they are made on the
        first call: its steps merged in pairs and in fours, and twice the elements per bar
        on the steps merged in pairs (a static scene: twice the elements per bar only)."""
        half, quarter, split = self._companions()
        value = lambda run: None if run is None else [np.array([run.response(name)])]  # noqa: E731
        est = tolerance.estimate(value(self), value(half), value(quarter), value(split))
        return float(est.relative[0])

    def _companions(self) -> tuple[_Run | None, _Run | None, _Run]:
        if self.companions is None:
            steps, half, quarter = None, None, None
            if isinstance(self, Results):
                steps = self.steps
                if len(steps) < 4:
                    raise SettingsError("an error estimate needs a run of at least 4 steps")
                half, quarter = (self.simulation._fixed(self.x, self.settings, steps=_merged(steps, k)) for k in (2, 4))
            split_steps = None if steps is None else _merged(steps, 2)
            split = self.simulation._companion(2, self.x, self.settings, self.settings, half, split_steps)
            self.companions = (half, quarter, split)
        return self.companions


def _merged(steps: np.ndarray, k: int) -> np.ndarray:
    """The steps summed in consecutive groups of ``k`` (the last group may be shorter)."""
    return np.add.reduceat(steps, np.arange(0, len(steps), k))


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
        (:mod:`flextop.export`)."""
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
                raise ValueError("the scene has no tip; name a node")
            return self.simulation.tip
        return self.simulation.node(node) if isinstance(node, str) else int(node)


@dataclass(repr=False)
class StaticResults(_Run):
    """A static equilibrium."""

    def to_vtk(self, path: str | os.PathLike) -> Path:
        """The deformed structure for ParaView as one ``.vtu`` file (:mod:`flextop.export`)."""
        return export.write_state(self, path)

    @property
    def positions(self) -> np.ndarray:
        """Node positions, shape ``(n_nodes, 2)``."""
        return self.simulation.model.reference_positions + self.q.reshape(-1, 3)[:, :2]

    @property
    def newton(self) -> dict[str, Any]:
        return {"total": self.raw["iterations"], "load_steps": self.raw["load_steps"]}

    def displacement(self, node: int | str) -> np.ndarray:
        """Displacement ``(u, v, φ)`` of ``node``."""
        index = self.simulation.node(node) if isinstance(node, str) else int(node)
        return self.q[3 * index:3 * index + 3]


def load(path: str | os.PathLike) -> Results | StaticResults:
    """The results saved at ``path`` by ``results.save(path)``, on the Simulation of their
    saved scene and options."""
    meta, raw, x = saved.read(path)
    sim = Simulation(meta["scene"], **meta["simulation"])
    kind = Results if meta["kind"] == "dynamic" else StaticResults
    d = meta["discretization"]
    return kind(sim, raw, x, meta["settings"], None if d is None else Discretization(*d), meta["errors"])
